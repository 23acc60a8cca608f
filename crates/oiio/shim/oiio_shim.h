/*
 * oiio_shim.h: the C ABI between plsr (Rust) and OpenImageIO (C++).
 *
 * Every function returns PLSR_OIIO_OK (0) on success or PLSR_OIIO_ERROR (1)
 * on failure; on failure a NUL-terminated message (OpenImageIO's geterror()
 * text, or the text of a caught C++ exception) is written to `err`, at most
 * `err_len` bytes including the NUL. No C++ exception ever leaves a function
 * of this header.
 *
 * Pixel types (the `type` arguments): PLSR_OIIO_U8, PLSR_OIIO_U16,
 * PLSR_OIIO_HALF, PLSR_OIIO_F32. Buffers are interleaved channels,
 * rows top to bottom, tightly packed.
 */
#ifndef PLSR_OIIO_SHIM_H
#define PLSR_OIIO_SHIM_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#define PLSR_OIIO_OK 0
#define PLSR_OIIO_ERROR 1

#define PLSR_OIIO_U8 0
#define PLSR_OIIO_U16 1
#define PLSR_OIIO_HALF 2
#define PLSR_OIIO_F32 3
#define PLSR_OIIO_OTHER 4

/* An open image being read (one subimage, MIP level 0). */
typedef struct plsr_oiio_input plsr_oiio_input;
/* An image being written. */
typedef struct plsr_oiio_output plsr_oiio_output;

/* What an open image holds. */
typedef struct plsr_oiio_spec {
    int width;
    int height;
    int channels;
    /* PLSR_OIIO_U8 / U16 / HALF / F32 / OTHER: the file's pixel type. */
    int format;
    /* Bits per sample as the file states it (oiio:BitsPerSample), else the
     * size of `format` in bits. */
    int bits;
} plsr_oiio_spec;

/* One header attribute to write: kind 0 = float, 1 = int, 2 = string. */
typedef struct plsr_oiio_attr {
    const char *name;
    int kind;
    float f;
    int i;
    const char *s;
} plsr_oiio_attr;

int plsr_oiio_open(const char *path, plsr_oiio_input **out, plsr_oiio_spec *spec,
                   char *err, size_t err_len);
/* Reads a metadata attribute as a float. Returns 1 and fills *value when the
 * attribute exists and is numeric, 0 otherwise. Never fails. */
int plsr_oiio_get_float(const plsr_oiio_input *in, const char *name, float *value);
/* Reads a metadata attribute as a string into buf (NUL-terminated, truncated
 * to buf_len). Returns 1 when the attribute exists, 0 otherwise. */
int plsr_oiio_get_string(const plsr_oiio_input *in, const char *name, char *buf,
                         size_t buf_len);
/* Reads rows [ybegin, yend) of all channels, converted to `type`, into
 * `data`, which holds `data_len` bytes (at least
 * (yend-ybegin) * width * channels * sizeof(type)). */
int plsr_oiio_read_rows(plsr_oiio_input *in, int ybegin, int yend, int type,
                        void *data, size_t data_len, char *err, size_t err_len);
void plsr_oiio_close(plsr_oiio_input *in);

/* Creates `path` (format chosen by its extension) of the given size and
 * channels, stored as `type`, with the given header attributes. */
int plsr_oiio_create(const char *path, int width, int height, int channels, int type,
                     const plsr_oiio_attr *attrs, size_t n_attrs,
                     plsr_oiio_output **out, char *err, size_t err_len);
/* Writes rows [ybegin, yend) given as `type` (converted to the file's type). */
int plsr_oiio_write_rows(plsr_oiio_output *out, int ybegin, int yend, int type,
                         const void *data, size_t data_len, char *err, size_t err_len);
/* Closes the file and frees `out` (also on failure). */
int plsr_oiio_finish(plsr_oiio_output *out, char *err, size_t err_len);
/* Closes and frees `out` without reporting errors (the caller deletes the file). */
void plsr_oiio_abort(plsr_oiio_output *out);

#ifdef __cplusplus
}
#endif

#endif
