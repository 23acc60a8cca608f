// plsr.hpp: a header-only C++17 wrapper over the C ABI (plsr.h).
//
// RAII handles (move-only) that free themselves, and errors as exceptions:
// every failing call throws plsr::Error carrying the result code and
// plsr_last_error()'s message. Nothing here allocates beyond std::string and
// std::vector; the library owns what the handles point to.
#ifndef PLSR_HPP
#define PLSR_HPP

#include "plsr.h"

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace plsr {

/// A failed call: the C result code and the library's message.
class Error : public std::runtime_error {
public:
    Error(plsr_result code, const std::string &message)
        : std::runtime_error(message), code_(code) {}
    /// The C result code (PLSR_ERR_*).
    plsr_result code() const noexcept { return code_; }

private:
    plsr_result code_;
};

/// Throws plsr::Error unless `r` is PLSR_OK.
inline void check(plsr_result r) {
    if (r != PLSR_OK) {
        throw Error(r, plsr_last_error());
    }
}

/// The library version.
inline std::string version() { return plsr_version(); }

using Vec3 = std::array<float, 3>;

namespace detail {
/// A move-only owner of a C handle, freed by `Free`.
template <typename T, plsr_result (*Free)(T *)>
class Handle {
public:
    Handle() = default;
    explicit Handle(T *p) : p_(p) {}
    Handle(const Handle &) = delete;
    Handle &operator=(const Handle &) = delete;
    Handle(Handle &&o) noexcept : p_(std::exchange(o.p_, nullptr)) {}
    Handle &operator=(Handle &&o) noexcept {
        if (this != &o) {
            reset();
            p_ = std::exchange(o.p_, nullptr);
        }
        return *this;
    }
    ~Handle() { reset(); }
    T *get() const noexcept { return p_; }

private:
    void reset() noexcept {
        if (p_) {
            Free(p_);  // never throws: a C call
            p_ = nullptr;
        }
    }
    T *p_ = nullptr;
};
}  // namespace detail

/// A rendered image.
class Image {
public:
    explicit Image(plsr_image *p) : h_(p) {
        check(plsr_image_size(p, &width_, &height_));
    }
    uint32_t width() const noexcept { return width_; }
    uint32_t height() const noexcept { return height_; }
    /// RGBA floats, width·height·4, valid while the Image lives.
    const float *rgba() const { return plsr_image_rgba(h_.get()); }
    void save_exr(const std::string &path) const {
        check(plsr_image_save_exr(h_.get(), path.c_str()));
    }
    void save_png(const std::string &path, float exposure_ev = 0.0f, bool filmic = false) const {
        check(plsr_image_save_png(h_.get(), path.c_str(), exposure_ev, filmic ? 1u : 0u));
    }
    /// This image denoised, guided by its albedo and normal layers
    /// (`prefilter`: the guides cleaned first); its EXR keeps the noisy
    /// colour as noisy.R/G/B.
    Image denoised(bool prefilter = false, uint32_t threads = 0) const {
        plsr_image *img = nullptr;
        check(plsr_image_denoise(h_.get(), prefilter ? 1u : 0u, threads, &img));
        return Image(img);
    }
    const plsr_image *get() const noexcept { return h_.get(); }

private:
    detail::Handle<plsr_image, plsr_image_free> h_;
    uint32_t width_ = 0, height_ = 0;
};

/// Denoises a host's float RGB buffers (width·height·3 each; `albedo` and
/// `normal` may be null, `normal` only with `albedo`); `output` may be
/// `color`. See plsr_denoise.
inline void denoise(uint32_t width, uint32_t height, const float *color, const float *albedo,
                    const float *normal, float *output,
                    plsr_denoise_settings settings = {1, 0, 0}, uint32_t threads = 0) {
    check(plsr_denoise(width, height, color, albedo, normal, &settings, threads, output));
}

/// A scene ready to render; may be rendered from several threads at once.
class Scene {
public:
    explicit Scene(plsr_scene *p) : h_(p) {}
    /// Loads a scene file.
    static Scene load(const std::string &path) {
        plsr_scene *p = nullptr;
        check(plsr_scene_load(path.c_str(), &p));
        return Scene(p);
    }
    /// Renders with `threads` threads (0: all cores).
    Image render(uint32_t threads = 0, plsr_progress_fn progress = nullptr,
                 void *user_data = nullptr) const {
        plsr_image *img = nullptr;
        check(plsr_render(h_.get(), threads, progress, user_data, &img));
        return Image(img);
    }
    /// Renders as `render` does, then denoises the image (see
    /// Image::denoised).
    Image render_denoised(uint32_t threads = 0, bool prefilter = false,
                          plsr_progress_fn progress = nullptr, void *user_data = nullptr) const {
        plsr_image *img = nullptr;
        check(plsr_render_denoised(h_.get(), nullptr, prefilter ? 1u : 0u, threads, progress,
                                   user_data, &img));
        return Image(img);
    }
    /// Composites the scene's virtual objects into a camera frame of
    /// width·height interleaved 8-bit RGB values (the camera's size); the
    /// result holds the composite (linear RGB) and the matte (alpha).
    /// `exposure` 0 fits it; `*exposure_used` (optional) receives it.
    Image composite(const uint8_t *frame_rgb, uint32_t width, uint32_t height,
                    plsr_composite_settings settings = {0, 0, 0.0f, 0, 0},
                    float *exposure_used = nullptr) const {
        plsr_image *img = nullptr;
        check(plsr_composite(h_.get(), frame_rgb, width, height, &settings, &img, exposure_used));
        return Image(img);
    }
    const plsr_scene *get() const noexcept { return h_.get(); }

private:
    detail::Handle<plsr_scene, plsr_scene_free> h_;
};

/// Builds a scene in code.
class SceneBuilder {
public:
    SceneBuilder() {
        plsr_scene_builder *p = nullptr;
        check(plsr_scene_builder_new(&p));
        h_ = detail::Handle<plsr_scene_builder, plsr_scene_builder_free>(p);
    }
    /// Adds a Lambertian material; returns its index.
    uint32_t add_diffuse(const std::string &name, Vec3 reflectance) {
        uint32_t i = 0;
        check(plsr_scene_builder_add_diffuse(h_.get(), name.c_str(), reflectance.data(), &i));
        return i;
    }
    /// Adds a principled material; returns its index.
    uint32_t add_principled(const std::string &name, const plsr_principled &p) {
        uint32_t i = 0;
        check(plsr_scene_builder_add_principled(h_.get(), name.c_str(), &p, &i));
        return i;
    }
    /// Adds a triangle mesh (xyz per vertex, 3 indices per triangle);
    /// returns its object id.
    uint32_t add_mesh(const std::vector<float> &positions, const std::vector<uint32_t> &indices,
                      uint32_t material, const Vec3 *emission = nullptr) {
        uint32_t id = 0;
        check(plsr_scene_builder_add_mesh(h_.get(), positions.data(), positions.size() / 3,
                                          indices.data(), indices.size() / 3, material,
                                          emission ? emission->data() : nullptr, &id));
        return id;
    }
    void add_point_light(Vec3 position, Vec3 intensity) {
        check(plsr_scene_builder_add_point_light(h_.get(), position.data(), intensity.data()));
    }
    /// Adds a parametric light source, tessellated into `nf` quads (0: 32).
    void add_pls(const plsr_pls_params &p, uint32_t nf = 0) {
        check(plsr_scene_builder_add_pls(h_.get(), &p, nf));
    }
    void set_environment(const std::string &path, Vec3 up, Vec3 forward, float scale = 1.0f) {
        check(plsr_scene_builder_set_environment(h_.get(), path.c_str(), up.data(),
                                                 forward.data(), scale));
    }
    void set_camera(Vec3 position, Vec3 look_at, Vec3 up, float vfov_deg, uint32_t width,
                    uint32_t height) {
        check(plsr_scene_builder_set_camera(h_.get(), position.data(), look_at.data(), up.data(),
                                            vfov_deg, width, height));
    }
    /// A calibrated camera: `to_world` row-major (OpenCV axes), intrinsics
    /// {fx, fy, cx, cy, skew} in pixels, `distortion` 0 none, 1
    /// Brown–Conrady, 2 fisheye, with its coefficients in OpenCV's order.
    void set_calibrated_camera(const std::array<float, 16> &to_world,
                               const std::array<double, 5> &intrinsics, uint32_t distortion,
                               const std::vector<double> &coefficients, uint32_t width,
                               uint32_t height) {
        check(plsr_scene_builder_set_calibrated_camera(
            h_.get(), to_world.data(), intrinsics.data(), distortion, coefficients.data(),
            coefficients.size(), width, height));
    }
    void set_render(uint32_t spp, uint32_t max_depth, uint64_t seed) {
        check(plsr_scene_builder_set_render(h_.get(), spp, max_depth, seed));
    }
    Scene build() const {
        plsr_scene *p = nullptr;
        check(plsr_scene_builder_build(h_.get(), &p));
        return Scene(p);
    }

private:
    detail::Handle<plsr_scene_builder, plsr_scene_builder_free> h_;
};

}  // namespace plsr

#endif  // PLSR_HPP
