/* io_image_module.h (internal to src/io): the boundary between obscura_io and the image module.
 *
 * EXR and PNG go through OpenImageIO, which is built into a separate loadable module
 * (src/io/oiio/io_image_oiio.cpp -> obscura_image_oiio.so) that src/io/io_image.c loads with dlopen
 * the first time an image is read or written. Why: linking OpenImageIO loads about 260 shared
 * libraries and runs their static initialisers at every process start (0.3-0.5 s here), which
 * every command and every test paid even when it touched no image (docs/io.md, "The image module").
 *
 * The module links no part of obscura. The host hands it the functions it calls (io_image_host);
 * the module returns its entry points (io_image_module). Both carry IO_IMAGE_MODULE_ABI, which
 * changes whenever either struct changes; a module of another ABI is refused. */
#ifndef OBS_IO_IMAGE_MODULE_H
#define OBS_IO_IMAGE_MODULE_H

#include "io.h"

#ifdef __cplusplus
extern "C" {
#endif

#define IO_IMAGE_MODULE_ABI 1
#define IO_IMAGE_MODULE_ENTRY "obs_io_image_module_v1"

typedef struct io_image_host {
    int abi; /* IO_IMAGE_MODULE_ABI */
    obs_status (*error)(obs_context *ctx, obs_status status, const char *fmt, ...);
    void (*log)(obs_context *ctx, obs_log_level level, const char *fmt, ...);
    int (*mul_size)(size_t a, size_t b, size_t *out);
    obs_limits (*limits_default)(void);
    const obs_limits *(*context_limits)(const obs_context *ctx);
    obs_status (*image_f32_alloc)(obs_context *ctx, int width, int height, obs_image_f32 *out);
    obs_status (*image_u32_alloc)(obs_context *ctx, int width, int height, obs_image_u32 *out);
    void (*image_f32_free)(obs_image_f32 *im);
    void (*image_u32_free)(obs_image_u32 *im);
    obs_status (*temp_path)(obs_context *ctx, const char *path, char *tmp, size_t tmp_size);
    obs_status (*commit_temp)(obs_context *ctx, const char *tmp, const char *path);
    void (*image_free)(io_image *im);
    float (*srgb_encode)(float linear);
} io_image_host;

/* The module's implementations of io.h's io_exr_write, io_png_write, io_image_read and
 * io_image_read_memory, with the same contracts. */
typedef struct io_image_module {
    int abi; /* IO_IMAGE_MODULE_ABI */
    obs_status (*exr_write)(obs_context *ctx, const char *path, const io_channel *channels, int channel_count,
                            const io_attr *attrs, int attr_count);
    obs_status (*png_write)(obs_context *ctx, const char *path, const obs_image_f32 *planes, int plane_count,
                            io_png_encoding encoding);
    obs_status (*image_read)(obs_context *ctx, const char *path, io_image *out);
    obs_status (*image_read_memory)(obs_context *ctx, const char *name, const void *data, size_t len, io_image *out);
} io_image_module;

/* The module's one exported symbol, IO_IMAGE_MODULE_ENTRY: NULL when `host` is not of its ABI. */
typedef const io_image_module *(*io_image_module_entry_fn)(const io_image_host *host);

#ifdef __cplusplus
}
#endif

#endif
