/* io_image.c: the C side of io.h's images. The sRGB transfer functions and the io_image helpers
 * are here; EXR and PNG reading and writing go through the image module (OpenImageIO), loaded
 * with dlopen the first time they are needed (io_image_module.h says why; docs/io.md, "The image
 * module").
 *
 * Where the module is looked for, in order:
 *   1. $OBSCURA_IMAGE_MODULE, when set (and then only there: a wrong path is an error naming it);
 *   2. the build tree's module (OBS_IMAGE_MODULE_BUILD_PATH, set by CMake), when that file exists;
 *   3. the installed module (OBS_IMAGE_MODULE_INSTALL_PATH, <libdir>/obscura/).
 * The module is loaded once per process (pthread_once) and never unloaded. */
#define _GNU_SOURCE
#include "io_image_module.h"

#include <dlfcn.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifndef OBS_IMAGE_MODULE_BUILD_PATH
#define OBS_IMAGE_MODULE_BUILD_PATH ""
#endif
#ifndef OBS_IMAGE_MODULE_INSTALL_PATH
#define OBS_IMAGE_MODULE_INSTALL_PATH ""
#endif

float io_srgb_encode(float linear)
{
    /* IEC 61966-2-1:1999, the sRGB "gamma" (OETF), evaluated in double and rounded once. */
    double x = linear;
    if (isnan(x))
        return linear;
    if (x <= 0.0031308)
        return (float)(12.92 * x);
    return (float)(1.055 * pow(x, 1.0 / 2.4) - 0.055);
}

float io_srgb_decode(float encoded)
{
    double v = encoded;
    if (isnan(v))
        return encoded;
    if (v <= 0.04045)
        return (float)(v / 12.92);
    return (float)pow((v + 0.055) / 1.055, 2.4);
}

void io_image_free(io_image *im)
{
    if (!im)
        return;
    if (im->f32)
        for (int c = 0; c < im->channel_count; c++)
            obs_image_f32_free(&im->f32[c]);
    if (im->u32)
        for (int c = 0; c < im->channel_count; c++)
            obs_image_u32_free(&im->u32[c]);
    free(im->f32);
    free(im->u32);
    free(im->names);
    free(im->types);
    if (im->attrs) {
        for (int i = 0; i < im->attr_count; i++) {
            free(im->attrs[i].s);
            free(im->attrs[i].v);
        }
        free(im->attrs);
    }
    memset(im, 0, sizeof *im);
}

int io_image_find_channel(const io_image *im, const char *name)
{
    if (!im || !name || !im->names)
        return -1;
    for (int c = 0; c < im->channel_count; c++)
        if (strcmp(im->names[c], name) == 0)
            return c;
    return -1;
}

const io_attr *io_image_find_attr(const io_image *im, const char *name)
{
    if (!im || !name || !im->attrs)
        return NULL;
    for (int i = 0; i < im->attr_count; i++)
        if (strcmp(im->attrs[i].name, name) == 0)
            return &im->attrs[i];
    return NULL;
}

/* ---- the image module ------------------------------------------------------------------------ */

static const io_image_host k_host = {
    IO_IMAGE_MODULE_ABI, obs_error,          obs_log,         obs_mul_size,   obs_limits_default,
    obs_context_limits,  obs_image_f32_alloc, obs_image_u32_alloc, obs_image_f32_free, obs_image_u32_free,
    io_temp_path,        io_commit_temp,     io_image_free,   io_srgb_encode,
};

static pthread_once_t g_once = PTHREAD_ONCE_INIT;
static const io_image_module *g_module;
static char g_why[1536]; /* why no module loaded: one "PATH: reason" per candidate tried */

static void why_append(const char *path, const char *reason)
{
    size_t n = strlen(g_why);
    if (!reason)
        reason = "unknown error";
    if (strncmp(reason, path, strlen(path)) == 0) /* dlerror() already names the file */
        snprintf(g_why + n, sizeof g_why - n, "%s%s", n ? "; " : "", reason);
    else
        snprintf(g_why + n, sizeof g_why - n, "%s%s: %s", n ? "; " : "", path, reason);
}

/* One candidate: NULL, with the reason appended to g_why, unless it loads and has our ABI. */
static const io_image_module *try_module(const char *path)
{
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        why_append(path, dlerror());
        return NULL;
    }
    io_image_module_entry_fn entry;
    void *sym = dlsym(h, IO_IMAGE_MODULE_ENTRY);
    memcpy(&entry, &sym, sizeof entry); /* object pointer to function pointer (POSIX dlsym) */
    const io_image_module *m = entry ? entry(&k_host) : NULL;
    if (!m || m->abi != IO_IMAGE_MODULE_ABI) {
        why_append(path, entry ? "built for another version of obscura (ABI mismatch)"
                               : "not an obscura image module (no " IO_IMAGE_MODULE_ENTRY ")");
        dlclose(h);
        return NULL;
    }
    return m; /* never unloaded: OpenImageIO keeps threads and static state */
}

static void load_module(void)
{
    const char *env = getenv("OBSCURA_IMAGE_MODULE");
    if (env && env[0]) {
        g_module = try_module(env);
        return;
    }
    const char *candidates[2] = {OBS_IMAGE_MODULE_BUILD_PATH, OBS_IMAGE_MODULE_INSTALL_PATH};
    for (int i = 0; i < 2 && !g_module; i++) {
        if (!candidates[i][0])
            continue;
        if (i == 0 && access(candidates[i], F_OK) != 0)
            continue; /* no build tree (an installed copy): not worth a message */
        g_module = try_module(candidates[i]);
    }
    if (!g_module && !g_why[0])
        why_append("(none)", "no module path was configured at build time; set OBSCURA_IMAGE_MODULE");
}

/* The loaded module, or NULL with IO_ERROR recorded on ctx naming `what` and why. */
static const io_image_module *module(obs_context *ctx, const char *what)
{
    pthread_once(&g_once, load_module);
    if (!g_module)
        obs_error(ctx, OBS_STATUS_IO_ERROR,
                  "cannot read or write '%s': the image module (OpenImageIO) could not be loaded: %s "
                  "(set OBSCURA_IMAGE_MODULE to the path of obscura_image_oiio.so)",
                  what ? what : "(null)", g_why);
    return g_module;
}

int io_image_module_loaded(void)
{
    return g_module != NULL;
}

obs_status io_image_module_load(obs_context *ctx)
{
    return module(ctx, "(no image: io_image_module_load)") ? OBS_STATUS_OK : OBS_STATUS_IO_ERROR;
}

obs_status io_exr_write(obs_context *ctx, const char *path, const io_channel *channels, int channel_count,
                        const io_attr *attrs, int attr_count)
{
    const io_image_module *m = module(ctx, path);
    return m ? m->exr_write(ctx, path, channels, channel_count, attrs, attr_count) : OBS_STATUS_IO_ERROR;
}

obs_status io_png_write(obs_context *ctx, const char *path, const obs_image_f32 *planes, int plane_count,
                        io_png_encoding encoding)
{
    const io_image_module *m = module(ctx, path);
    return m ? m->png_write(ctx, path, planes, plane_count, encoding) : OBS_STATUS_IO_ERROR;
}

obs_status io_image_read(obs_context *ctx, const char *path, io_image *out)
{
    if (out)
        memset(out, 0, sizeof *out);
    const io_image_module *m = module(ctx, path);
    return m ? m->image_read(ctx, path, out) : OBS_STATUS_IO_ERROR;
}

obs_status io_image_read_memory(obs_context *ctx, const char *name, const void *data, size_t len, io_image *out)
{
    if (out)
        memset(out, 0, sizeof *out);
    const io_image_module *m = module(ctx, name && name[0] ? name : "<memory>");
    return m ? m->image_read_memory(ctx, name, data, len, out) : OBS_STATUS_IO_ERROR;
}
