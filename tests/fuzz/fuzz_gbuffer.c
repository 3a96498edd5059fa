/* fuzz_gbuffer.c: the external G-buffer path of `obscura ao --gbuffer` (issue 4, item 4), end to
 * end: intrinsics JSON (ao_intrinsics_parse_json), an EXR or PNG (io_image_read_memory), the
 * G-buffer built from it and its metadata (ao_external_from_image, every depth kind and normals
 * mode), and then EVERY registered AO method with its default parameters, and the final blend, on
 * it. Hostile depth values, lying intrinsics and odd sizes must give a clear refusal or finite
 * visibility in [0, 1], never a crash or a sanitizer report.
 *
 * Input layout: byte 0 = options (bits 0-2: depth kind, 0 = auto; bits 3-4: normals mode; bit 5:
 * use the JSON part), bytes 1-2 = the JSON part's length L
 * (little endian), then L bytes of intrinsics JSON, then the image file.
 *
 * Invariants:
 *   - ao_intrinsics_parse_json: OK leaves every known field either unknown or finite/valid;
 *   - ao_external_from_image: failure says why and leaves nothing to free; success gives an input
 *     that ao_input_validate accepts, depth > 0 or +inf everywhere (unusable values counted);
 *   - every method on an image of at most 64x64 pixels returns OK, or INVALID_ARGUMENT /
 *     LIMIT_EXCEEDED with a message, and when OK, out and out_raw are finite and in [0, 1];
 *   - ao_blend_lambert gives values in [0, 1].
 *
 * Size bound (issue 13): the methods run on images of at most 64x64 pixels, and the image itself
 * is bounded too, so the target keeps hundreds of executions a second under the sanitizers: an
 * image whose EXR data window (first part's header) or PNG IHDR size has more than 64x64 pixels
 * is skipped before decoding (units with a 983,064 x 1 data window and a 24 x 16 display window
 * took ~29 s each), and the context's max_image_pixels is 64*64*16 values, which io_image's own
 * header check applies to any data window this scan misses. */
#include "fuzz.h"

#include "ao/ao.h"
#include "io/io.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* With OBS_FUZZ_DUMP=FILE in the environment, a broken invariant first writes the G-buffer the
 * methods saw (sizes, window, intrinsics as doubles, depth and normals as floats) to FILE: an
 * external image's pixels can come from OpenEXR's decompressor uninitialised (docs/reliability.md,
 * L2), so the input file alone may not reproduce the values. */
static const ao_input *g_dump_input;
static void dump_input(void)
{
    const char *path = getenv("OBS_FUZZ_DUMP");
    const ao_input *in = g_dump_input;
    if (!path || !in)
        return;
    FILE *f = fopen(path, "wb");
    if (!f)
        return;
    const int hdr[8] = {in->width, in->height, in->x0, in->y0, in->w, in->h, (int)in->projection, in->normal[0] != NULL};
    const double k[6] = {in->fx, in->fy, in->cx, in->cy, in->znear, in->zfar};
    fwrite(hdr, sizeof hdr, 1, f);
    fwrite(k, sizeof k, 1, f);
    for (int c = 0; c < (in->normal[0] ? 4 : 1); c++) {
        const obs_image_f32 *p = c == 0 ? in->depth : in->normal[c - 1];
        for (int y = 0; y < in->height; y++)
            fwrite(obs_image_f32_row(p, y), sizeof(float), (size_t)in->width, f);
    }
    fclose(f);
}

static void check_unit_plane(const obs_image_f32 *a, const char *method, const char *what)
{
    for (int y = 0; y < a->height; y++)
        for (int x = 0; x < a->width; x++) {
            const float v = obs_image_f32_row(a, y)[x];
            if (!(v >= 0.0f && v <= 1.0f)) {
                fprintf(stderr, "obscura fuzz: %s: pixel (%d,%d) of %dx%d = %.9g\n", method, x, y, a->width,
                        a->height, (double)v);
                dump_input();
                fuzz_require(0, what);
            }
        }
}

static void run_methods(obs_context *ctx, const ao_input *in)
{
    g_dump_input = in;
    obs_image_f32 out = {0}, raw = {0}, blend = {0};
    if (obs_image_f32_alloc(ctx, in->w, in->h, &out) != OBS_STATUS_OK ||
        obs_image_f32_alloc(ctx, in->w, in->h, &raw) != OBS_STATUS_OK ||
        obs_image_f32_alloc(ctx, in->w, in->h, &blend) != OBS_STATUS_OK) {
        obs_image_f32_free(&out);
        obs_image_f32_free(&raw);
        return;
    }
    unsigned char params[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
    for (const ao_method *const *mp = ao_methods(); *mp; mp++) {
        const ao_method *m = *mp;
        m->params_default(params);
        obs_context_clear_error(ctx);
        obs_status st = m->compute(ctx, NULL, in, params, &out, &raw, NULL);
        if (st != OBS_STATUS_OK) {
            fuzz_require(st == OBS_STATUS_INVALID_ARGUMENT || st == OBS_STATUS_LIMIT_EXCEEDED ||
                             st == OBS_STATUS_OUT_OF_MEMORY,
                         "an AO method refuses a G-buffer only with INVALID_ARGUMENT or a limit");
            fuzz_require(obs_context_last_error(ctx)[0] != '\0', "an AO method's refusal says why");
            continue;
        }
        check_unit_plane(&out, m->name, "AO is finite and in [0, 1] on any G-buffer");
        check_unit_plane(&raw, m->name, "raw AO is finite and in [0, 1] on any G-buffer");
    }
    /* the blend with reconstructed normals (the CLI's path when the file has none) */
    obs_image_f32 n[3] = {{0}, {0}, {0}};
    int ok = 1;
    for (int c = 0; c < 3; c++)
        ok = ok && obs_image_f32_alloc(ctx, in->width, in->height, &n[c]) == OBS_STATUS_OK;
    if (ok && ao_normals_from_depth(ctx, NULL, in, n) == OBS_STATUS_OK) {
        const obs_image_f32 *np[3] = {&n[0], &n[1], &n[2]};
        if (ao_blend_lambert(ctx, NULL, in, &out, np, &blend) == OBS_STATUS_OK)
            check_unit_plane(&blend, "blend", "the blend is in [0, 1]");
    }
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&n[c]);
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    obs_image_f32_free(&blend);
}

#define FUZZ_GBUFFER_MAX_PIXELS (64 * 64)

static uint32_t le32(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }
static uint32_t be32(const uint8_t *p) { return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3]; }

/* Whether the image's declared size is over FUZZ_GBUFFER_MAX_PIXELS: the EXR dataWindow (box2i) of
 * the first header, or the PNG IHDR width x height. Anything this scan cannot read (no magic,
 * a header cut short) is left to the reader. */
static int image_too_large(const uint8_t *d, size_t n)
{
    if (n >= 24 && !memcmp(d, "\x89PNG\r\n\x1a\n", 8) && !memcmp(d + 12, "IHDR", 4))
        return (uint64_t)be32(d + 16) * be32(d + 20) > FUZZ_GBUFFER_MAX_PIXELS;
    if (n < 8 || le32(d) != 20000630u) /* the EXR magic number */
        return 0;
    size_t pos = 8;
    while (pos < n && d[pos]) {
        const uint8_t *name = d + pos, *nz = memchr(name, 0, n - pos);
        if (!nz)
            return 0;
        size_t tpos = (size_t)(nz - d) + 1;
        const uint8_t *tz = tpos < n ? memchr(d + tpos, 0, n - tpos) : NULL;
        if (!tz || (size_t)(tz - d) + 5 > n)
            return 0;
        size_t vpos = (size_t)(tz - d) + 5;
        uint32_t len = le32(tz + 1);
        if (len > n - vpos)
            return 0;
        if (!strcmp((const char *)name, "dataWindow") && !strcmp((const char *)d + tpos, "box2i") && len == 16) {
            int64_t w = (int64_t)(int32_t)le32(d + vpos + 8) - (int32_t)le32(d + vpos) + 1;
            int64_t h = (int64_t)(int32_t)le32(d + vpos + 12) - (int32_t)le32(d + vpos + 4) + 1;
            return w > 0 && h > 0 && w * h > FUZZ_GBUFFER_MAX_PIXELS;
        }
        pos = vpos + len;
    }
    return 0;
}

int obs_fuzz_gbuffer(const uint8_t *data, size_t size)
{
    if (size < 3)
        return 0;
    const unsigned opt = data[0];
    size_t jl = (size_t)data[1] | ((size_t)data[2] << 8);
    if (jl > size - 3)
        jl = size - 3;
    const uint8_t *json = data + 3, *img = data + 3 + jl;
    const size_t img_size = size - 3 - jl;
    if (image_too_large(img, img_size))
        return 0;
    obs_context *ctx = fuzz_context();
    obs_limits lim = *obs_context_limits(ctx);
    lim.max_image_pixels = FUZZ_GBUFFER_MAX_PIXELS * 16; /* values: a 64x64 G-buffer of up to 16 channels */
    obs_context_set_limits(ctx, &lim);

    ao_intrinsics K = ao_intrinsics_unknown();
    int have_k = 0;
    if (opt & 0x20u) {
        char *text = malloc(jl + 1);
        fuzz_require(text != NULL, "malloc");
        memcpy(text, json, jl);
        text[jl] = 0;
        obs_status st = ao_intrinsics_parse_json(ctx, text, &K);
        free(text);
        if (st == OBS_STATUS_OK) {
            have_k = 1;
            fuzz_require(K.fx <= 0.0 || isfinite(K.fx), "parsed fx is finite or unknown");
            fuzz_require(K.projection == -1 || K.projection == OBS_PROJECTION_PERSPECTIVE ||
                             K.projection == OBS_PROJECTION_ORTHOGRAPHIC,
                         "parsed projection is known or unknown");
            fuzz_require(K.depth_kind >= 0 && K.depth_kind < AO_DEPTH_KIND_COUNT, "parsed depth kind is in range");
        } else {
            fuzz_require(obs_context_last_error(ctx)[0] != '\0', "a refused intrinsics file says why");
            K = ao_intrinsics_unknown();
        }
        obs_context_clear_error(ctx);
    }

    io_image im;
    if (io_image_read_memory(ctx, "fuzz.exr", img, img_size, &im) != OBS_STATUS_OK) {
        obs_context_destroy(ctx);
        return 0;
    }
    ao_external_options eo = ao_external_options_default();
    eo.depth_kind = (ao_depth_kind)((opt & 7u) % AO_DEPTH_KIND_COUNT);
    eo.normals = (ao_external_normals)(((opt >> 3) & 3u) % AO_EXTERNAL_NORMALS_COUNT);
    eo.intrinsics = have_k ? &K : NULL;
    ao_external e;
    obs_context_clear_error(ctx);
    obs_status st = ao_external_from_image(ctx, &im, &eo, &e);
    if (st != OBS_STATUS_OK) {
        fuzz_require(obs_context_last_error(ctx)[0] != '\0', "a refused G-buffer says why");
    } else {
        fuzz_require(ao_input_validate(ctx, &e.input) == OBS_STATUS_OK, "an external G-buffer is a valid input");
        for (int y = 0; y < e.depth.height; y++)
            for (int x = 0; x < e.depth.width; x++) {
                const float d = obs_image_f32_row(&e.depth, y)[x];
                fuzz_require(d > 0.0f, "external depth is > 0 or +inf (unusable values become background)");
            }
        if ((int64_t)e.input.width * e.input.height <= 64 * 64)
            run_methods(ctx, &e.input);
        ao_external_free(&e);
    }
    io_image_free(&im);
    obs_context_destroy(ctx);
    return 0;
}
