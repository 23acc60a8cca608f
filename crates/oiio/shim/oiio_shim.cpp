// oiio_shim.cpp: the C ABI of oiio_shim.h over OpenImageIO.
//
// Every entry point catches every C++ exception and turns it into an error
// status with a message; OpenImageIO's own errors (geterror()) are reported
// the same way.

#include "oiio_shim.h"

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstring>
#include <vector>
#include <exception>
#include <memory>
#include <string>

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

struct plsr_oiio_input {
    std::unique_ptr<ImageInput> in;
};

struct plsr_oiio_output {
    std::unique_ptr<ImageOutput> out;
};

namespace {

void set_error(char *err, size_t err_len, const std::string &message) {
    if (err == nullptr || err_len == 0)
        return;
    std::string m = message.empty() ? std::string("unknown OpenImageIO error") : message;
    // Trim trailing newlines OIIO tends to leave.
    while (!m.empty() && (m.back() == '\n' || m.back() == '\r'))
        m.pop_back();
    size_t n = m.size() < err_len - 1 ? m.size() : err_len - 1;
    std::memcpy(err, m.data(), n);
    err[n] = '\0';
}

bool type_of(int type, TypeDesc *out) {
    switch (type) {
    case PLSR_OIIO_U8: *out = TypeDesc::UINT8; return true;
    case PLSR_OIIO_U16: *out = TypeDesc::UINT16; return true;
    case PLSR_OIIO_HALF: *out = TypeDesc::HALF; return true;
    case PLSR_OIIO_F32: *out = TypeDesc::FLOAT; return true;
    default: return false;
    }
}

int code_of(TypeDesc t) {
    switch (t.basetype) {
    case TypeDesc::UINT8: return PLSR_OIIO_U8;
    case TypeDesc::UINT16: return PLSR_OIIO_U16;
    case TypeDesc::HALF: return PLSR_OIIO_HALF;
    case TypeDesc::FLOAT: return PLSR_OIIO_F32;
    default: return PLSR_OIIO_OTHER;
    }
}

// Both the global error and a per-object one may hold the message; take what
// there is (reading clears them, which is what we want).
std::string global_error() { return OIIO::geterror(); }

}  // namespace

extern "C" int plsr_oiio_open(const char *path, plsr_oiio_input **out, plsr_oiio_spec *spec,
                              char *err, size_t err_len) {
    try {
        if (path == nullptr || out == nullptr || spec == nullptr) {
            set_error(err, err_len, "null argument");
            return PLSR_OIIO_ERROR;
        }
        *out = nullptr;
        // Camera raw files (LibRaw) are read as linear data with sRGB
        // primaries: the camera's black level subtracted, scaled to its
        // white level, its as-shot white balance applied, highlights
        // clipped, no automatic brightening. Other formats ignore these.
        ImageSpec config;
        config.attribute("raw:ColorSpace", "sRGB-linear");
        config.attribute("raw:use_camera_wb", 1);
        config.attribute("raw:auto_bright", 0);
        config.attribute("raw:adjust_maximum_thr", 0.0f);
        config.attribute("raw:HighlightMode", 0);
        auto in = ImageInput::open(path, &config);
        if (!in) {
            set_error(err, err_len, global_error());
            return PLSR_OIIO_ERROR;
        }
        const ImageSpec &s = in->spec();
        if (s.width <= 0 || s.height <= 0 || s.nchannels <= 0 || s.depth > 1) {
            set_error(err, err_len, "unsupported image layout (empty, or a volume)");
            return PLSR_OIIO_ERROR;
        }
        spec->width = s.width;
        spec->height = s.height;
        spec->channels = s.nchannels;
        spec->format = code_of(s.format);
        int bits = s.get_int_attribute("oiio:BitsPerSample", 0);
        spec->bits = bits > 0 ? bits : int(s.format.size() * 8);
        auto *h = new plsr_oiio_input;
        h->in = std::move(in);
        *out = h;
        return PLSR_OIIO_OK;
    } catch (const std::exception &e) {
        set_error(err, err_len, e.what());
    } catch (...) {
        set_error(err, err_len, "unknown C++ exception in OpenImageIO");
    }
    return PLSR_OIIO_ERROR;
}

extern "C" int plsr_oiio_get_float(const plsr_oiio_input *in, const char *name, float *value) {
    try {
        if (in == nullptr || name == nullptr || value == nullptr)
            return 0;
        const ImageSpec &s = in->in->spec();
        const OIIO::ParamValue *p = s.find_attribute(name);
        if (p == nullptr)
            return 0;
        float v = s.get_float_attribute(name, NAN);
        if (std::isnan(v))
            return 0;
        *value = v;
        return 1;
    } catch (...) {
        return 0;
    }
}

extern "C" int plsr_oiio_get_string(const plsr_oiio_input *in, const char *name, char *buf,
                                    size_t buf_len) {
    try {
        if (in == nullptr || name == nullptr || buf == nullptr || buf_len == 0)
            return 0;
        const ImageSpec &s = in->in->spec();
        const OIIO::ParamValue *p = s.find_attribute(name);
        if (p == nullptr)
            return 0;
        std::string v = s.get_string_attribute(name);
        size_t n = v.size() < buf_len - 1 ? v.size() : buf_len - 1;
        std::memcpy(buf, v.data(), n);
        buf[n] = '\0';
        return 1;
    } catch (...) {
        return 0;
    }
}

extern "C" int plsr_oiio_read_rows(plsr_oiio_input *in, int ybegin, int yend, int type,
                                   void *data, size_t data_len, char *err, size_t err_len) {
    try {
        if (in == nullptr || data == nullptr) {
            set_error(err, err_len, "null argument");
            return PLSR_OIIO_ERROR;
        }
        TypeDesc t;
        if (!type_of(type, &t)) {
            set_error(err, err_len, "unknown pixel type");
            return PLSR_OIIO_ERROR;
        }
        const ImageSpec &s = in->in->spec();
        if (ybegin < 0 || yend > s.height || ybegin > yend) {
            set_error(err, err_len, "row range outside the image");
            return PLSR_OIIO_ERROR;
        }
        size_t need = size_t(yend - ybegin) * size_t(s.width) * size_t(s.nchannels) * t.size();
        if (data_len < need) {
            set_error(err, err_len, "buffer too small for the requested rows");
            return PLSR_OIIO_ERROR;
        }
        if (ybegin == yend)
            return PLSR_OIIO_OK;
        bool ok;
        if (s.tile_width > 0 && s.tile_height > 0) {
            // A tiled file (OpenImageIO 2.4's read_scanlines divides by zero
            // on some): read the rows of tiles that cover the range, then
            // copy the rows asked for.
            int th = s.tile_height;
            int y0 = ybegin - ybegin % th;
            int y1 = ((yend + th - 1) / th) * th;
            if (y1 > s.height)
                y1 = s.height;
            size_t row = size_t(s.width) * size_t(s.nchannels) * t.size();
            std::vector<unsigned char> buf(size_t(y1 - y0) * row);
            int z1 = s.z + (s.depth > 0 ? s.depth : 1);
            ok = in->in->read_tiles(in->in->current_subimage(), in->in->current_miplevel(), s.x,
                                    s.x + s.width, s.y + y0, s.y + y1, s.z, z1, 0, s.nchannels, t,
                                    buf.data());
            if (ok)
                std::memcpy(data, buf.data() + size_t(ybegin - y0) * row,
                            size_t(yend - ybegin) * row);
        } else {
            ok = in->in->read_scanlines(in->in->current_subimage(), in->in->current_miplevel(),
                                        s.y + ybegin, s.y + yend, s.z, 0, s.nchannels, t, data);
        }
        if (!ok) {
            std::string m = in->in->geterror();
            if (m.empty())
                m = global_error();
            set_error(err, err_len, m);
            return PLSR_OIIO_ERROR;
        }
        return PLSR_OIIO_OK;
    } catch (const std::exception &e) {
        set_error(err, err_len, e.what());
    } catch (...) {
        set_error(err, err_len, "unknown C++ exception in OpenImageIO");
    }
    return PLSR_OIIO_ERROR;
}

extern "C" void plsr_oiio_close(plsr_oiio_input *in) {
    try {
        if (in != nullptr) {
            in->in->close();
            delete in;
        }
    } catch (...) {
    }
}

extern "C" int plsr_oiio_create(const char *path, int width, int height, int channels, int type,
                                const plsr_oiio_attr *attrs, size_t n_attrs,
                                plsr_oiio_output **out, char *err, size_t err_len) {
    try {
        if (path == nullptr || out == nullptr || (attrs == nullptr && n_attrs > 0)) {
            set_error(err, err_len, "null argument");
            return PLSR_OIIO_ERROR;
        }
        *out = nullptr;
        TypeDesc t;
        if (!type_of(type, &t)) {
            set_error(err, err_len, "unknown pixel type");
            return PLSR_OIIO_ERROR;
        }
        if (width <= 0 || height <= 0 || channels <= 0) {
            set_error(err, err_len, "empty image");
            return PLSR_OIIO_ERROR;
        }
        auto o = ImageOutput::create(path);
        if (!o) {
            set_error(err, err_len, global_error());
            return PLSR_OIIO_ERROR;
        }
        ImageSpec spec(width, height, channels, t);
        for (size_t i = 0; i < n_attrs; ++i) {
            const plsr_oiio_attr &a = attrs[i];
            if (a.name == nullptr)
                continue;
            switch (a.kind) {
            case 0: spec.attribute(a.name, a.f); break;
            case 1: spec.attribute(a.name, a.i); break;
            case 2: spec.attribute(a.name, a.s == nullptr ? "" : a.s); break;
            default: break;
            }
        }
        if (!o->open(path, spec)) {
            std::string m = o->geterror();
            if (m.empty())
                m = global_error();
            set_error(err, err_len, m);
            return PLSR_OIIO_ERROR;
        }
        auto *h = new plsr_oiio_output;
        h->out = std::move(o);
        *out = h;
        return PLSR_OIIO_OK;
    } catch (const std::exception &e) {
        set_error(err, err_len, e.what());
    } catch (...) {
        set_error(err, err_len, "unknown C++ exception in OpenImageIO");
    }
    return PLSR_OIIO_ERROR;
}

extern "C" int plsr_oiio_write_rows(plsr_oiio_output *out, int ybegin, int yend, int type,
                                    const void *data, size_t data_len, char *err,
                                    size_t err_len) {
    try {
        if (out == nullptr || data == nullptr) {
            set_error(err, err_len, "null argument");
            return PLSR_OIIO_ERROR;
        }
        TypeDesc t;
        if (!type_of(type, &t)) {
            set_error(err, err_len, "unknown pixel type");
            return PLSR_OIIO_ERROR;
        }
        const ImageSpec &s = out->out->spec();
        if (ybegin < 0 || yend > s.height || ybegin > yend) {
            set_error(err, err_len, "row range outside the image");
            return PLSR_OIIO_ERROR;
        }
        size_t need = size_t(yend - ybegin) * size_t(s.width) * size_t(s.nchannels) * t.size();
        if (data_len < need) {
            set_error(err, err_len, "buffer too small for the given rows");
            return PLSR_OIIO_ERROR;
        }
        if (ybegin == yend)
            return PLSR_OIIO_OK;
        if (!out->out->write_scanlines(s.y + ybegin, s.y + yend, s.z, t, data)) {
            std::string m = out->out->geterror();
            if (m.empty())
                m = global_error();
            set_error(err, err_len, m);
            return PLSR_OIIO_ERROR;
        }
        return PLSR_OIIO_OK;
    } catch (const std::exception &e) {
        set_error(err, err_len, e.what());
    } catch (...) {
        set_error(err, err_len, "unknown C++ exception in OpenImageIO");
    }
    return PLSR_OIIO_ERROR;
}

extern "C" int plsr_oiio_finish(plsr_oiio_output *out, char *err, size_t err_len) {
    int status = PLSR_OIIO_ERROR;
    try {
        if (out == nullptr) {
            set_error(err, err_len, "null argument");
            return PLSR_OIIO_ERROR;
        }
        if (out->out->close()) {
            status = PLSR_OIIO_OK;
        } else {
            std::string m = out->out->geterror();
            if (m.empty())
                m = global_error();
            set_error(err, err_len, m);
        }
    } catch (const std::exception &e) {
        set_error(err, err_len, e.what());
    } catch (...) {
        set_error(err, err_len, "unknown C++ exception in OpenImageIO");
    }
    try {
        delete out;
    } catch (...) {
    }
    return status;
}

extern "C" void plsr_oiio_abort(plsr_oiio_output *out) {
    try {
        if (out != nullptr) {
            out->out->close();
            delete out;
        }
    } catch (...) {
    }
}
