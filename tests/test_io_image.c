/* test_io_image.c: EXR and PNG through io_image.cpp, the sRGB transfer function, and atomic
 * file output / bounded file input (io_file.c). */
#include "core/obs.h"
#include "io/io.h"
#include "test.h"

#include <dirent.h>
#include <errno.h>
#include <float.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- helpers ------------------------------------------------------------------------------ */

static uint32_t f2u(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}

static float u2f(uint32_t u)
{
    float f;
    memcpy(&f, &u, 4);
    return f;
}

/* Number of entries in dir (except . and ..) whose name contains `needle` (NULL: all). */
static int count_entries(const char *dir, const char *needle)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        if (!needle || strstr(e->d_name, needle))
            n++;
    }
    closedir(d);
    return n;
}

static int file_exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0;
}

static int write_raw(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    size_t w = fwrite(data, 1, len, f);
    return fclose(f) == 0 && w == len;
}

/* Search a byte buffer for a 4-byte PNG chunk type. */
static int has_bytes(const char *buf, size_t len, const char *tag)
{
    size_t n = strlen(tag);
    for (size_t i = 0; i + n <= len; i++)
        if (!memcmp(buf + i, tag, n))
            return 1;
    return 0;
}

static double srgb_ref(double x)
{
    return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

/* ---- EXR ---------------------------------------------------------------------------------- */

TEST(exr_round_trip_preserves_float_half_and_uint_channels)
{
    obs_context *ctx = obs_context_create();
    CHECK(ctx);
    enum { W = 37, H = 23 };
    obs_image_f32 z, nx, ny, nz;
    obs_image_u32 prim;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &z), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &nx), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ny), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &nz), ctx);
    CHECK_OK(obs_image_u32_alloc(ctx, W, H, &prim), ctx);

    /* Special float values first, then a spread of ordinary ones. */
    const float specials[] = {NAN, INFINITY, -INFINITY, -0.0f, 0.0f, 1e-40f /* denormal */,
                              FLT_TRUE_MIN, -FLT_TRUE_MIN, FLT_MIN, FLT_MAX, -FLT_MAX,
                              u2f(0x7fc12345u) /* NaN with payload */, 1.0f / 3.0f, 16777217.0f};
    const int nspecial = (int)(sizeof specials / sizeof specials[0]);
    const uint32_t uspecial[] = {0u, 1u, 16777216u, 16777217u, 0x7fffffffu, 0x80000000u, 0xfffffffeu, 0xffffffffu};
    const int nuspecial = (int)(sizeof uspecial / sizeof uspecial[0]);
    for (int y = 0; y < H; y++) {
        for (int x = 0; x < W; x++) {
            int i = y * W + x;
            obs_image_f32_row(&z, y)[x] = i < nspecial ? specials[i] : (float)(i * 0.731) - 200.0f;
            obs_image_f32_row(&nx, y)[x] = sinf((float)i * 0.1f);
            obs_image_f32_row(&ny, y)[x] = cosf((float)i * 0.07f);
            obs_image_f32_row(&nz, y)[x] = i == 0 ? 65504.0f : (i == 1 ? 1e-6f : (float)(x - y) / 64.0f);
            obs_image_u32_row(&prim, y)[x] = i < nuspecial ? uspecial[i] : 16777216u + (uint32_t)i * 2654435761u;
        }
    }
    io_channel ch[5] = {
        {"Z", IO_PIXEL_FLOAT, &z, NULL},     {"N.X", IO_PIXEL_HALF, &nx, NULL}, {"N.Y", IO_PIXEL_HALF, &ny, NULL},
        {"N.Z", IO_PIXEL_HALF, &nz, NULL},   {"primid", IO_PIXEL_UINT, NULL, &prim},
    };
    const char *path = test_path(test_tmpdir(), "gbuf.exr");
    CHECK_OK(io_exr_write(ctx, path, ch, 5, NULL, 0), ctx);
    CHECK_EQ_INT(count_entries(test_tmpdir(), ".tmp."), 0);

    io_image im;
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    CHECK_EQ_INT(im.width, W);
    CHECK_EQ_INT(im.height, H);
    CHECK_EQ_INT(im.channel_count, 5);
    int cz = io_image_find_channel(&im, "Z"), cx = io_image_find_channel(&im, "N.X"),
        cy = io_image_find_channel(&im, "N.Y"), czz = io_image_find_channel(&im, "N.Z"),
        cp = io_image_find_channel(&im, "primid");
    CHECK(cz >= 0 && cx >= 0 && cy >= 0 && czz >= 0 && cp >= 0);
    CHECK(io_image_find_channel(&im, "N") == -1);
    CHECK(im.types[cz] == IO_PIXEL_FLOAT && im.types[cx] == IO_PIXEL_FLOAT && im.types[cp] == IO_PIXEL_UINT);
    CHECK(im.f32[cz].data && !im.u32[cz].data);
    CHECK(im.u32[cp].data && !im.f32[cp].data);

    for (int y = 0; y < H; y++) {
        for (int x = 0; x < W; x++) {
            uint32_t a = f2u(obs_image_f32_row(&z, y)[x]), b = f2u(obs_image_f32_row(&im.f32[cz], y)[x]);
            CHECK_MSG(a == b, "Z at (%d,%d): %08x written, %08x read", x, y, a, b);
            uint32_t ua = obs_image_u32_row(&prim, y)[x], ub = obs_image_u32_row(&im.u32[cp], y)[x];
            CHECK_MSG(ua == ub, "primid at (%d,%d): %u written, %u read", x, y, ua, ub);
            const obs_image_f32 *src[3] = {&nx, &ny, &nz};
            int idx[3] = {cx, cy, czz};
            for (int k = 0; k < 3; k++) {
                float v = obs_image_f32_row(src[k], y)[x], r = obs_image_f32_row(&im.f32[idx[k]], y)[x];
                /* Half: 11 significant bits (relative error <= 2^-11), subnormals below 2^-14
                 * have an absolute step of 2^-24. */
                double tol = fabs(v) * (1.0 / 2048.0) + ldexp(1.0, -25);
                CHECK_MSG(fabs((double)v - r) <= tol, "%s at (%d,%d): %.9g written, %.9g read", im.names[idx[k]], x, y,
                          v, r);
            }
        }
    }
    /* The half channels really are half in the file: sin(0.1) is not a half value. */
    CHECK(obs_image_f32_row(&im.f32[cx], 0)[1] != obs_image_f32_row(&nx, 0)[1]);

    io_image_free(&im);
    CHECK(im.channel_count == 0 && im.names == NULL);
    io_image_free(&im); /* idempotent */
    obs_image_f32_free(&z);
    obs_image_f32_free(&nx);
    obs_image_f32_free(&ny);
    obs_image_f32_free(&nz);
    obs_image_u32_free(&prim);
    obs_context_destroy(ctx);
}

TEST(exr_round_trip_preserves_metadata)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 z;
    CHECK_OK(obs_image_f32_alloc(ctx, 5, 3, &z), ctx);
    obs_image_f32_fill(&z, 2.5f);
    io_channel ch = {"Z", IO_PIXEL_FLOAT, &z, NULL};

    /* A world-to-camera matrix with a translation and no symmetry: column-major obs_mat4. */
    obs_mat4 m = obs_mat4_look_at(obs_v3(1.0f, 2.0f, 3.0f), obs_v3(0.1f, -0.2f, 0.3f), obs_v3(0, 1, 0));
    float weights[5] = {0.1f, -2.0f, 3.0e10f, 1e-30f, 0.0f};
    io_attr attrs[5];
    memset(attrs, 0, sizeof attrs);
    strcpy(attrs[0].name, "obscura:camera");
    attrs[0].type = IO_ATTR_STRING;
    attrs[0].s = "main camera \xc3\xa9 \"quoted\"";
    strcpy(attrs[1].name, "obscura:samples");
    attrs[1].type = IO_ATTR_INT;
    attrs[1].i = -123456789;
    strcpy(attrs[2].name, "obscura:near");
    attrs[2].type = IO_ATTR_FLOAT;
    attrs[2].f = 0.1f;
    strcpy(attrs[3].name, "worldToCamera");
    attrs[3].type = IO_ATTR_MATRIX44;
    attrs[3].v = m.m;
    attrs[3].n = 16;
    strcpy(attrs[4].name, "obscura:weights");
    attrs[4].type = IO_ATTR_FLOATS;
    attrs[4].v = weights;
    attrs[4].n = 5;

    const char *path = test_path(test_tmpdir(), "meta.exr");
    CHECK_OK(io_exr_write(ctx, path, &ch, 1, attrs, 5), ctx);

    io_image im;
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    const io_attr *a = io_image_find_attr(&im, "obscura:camera");
    CHECK(a && a->type == IO_ATTR_STRING && a->s);
    CHECK_MSG(!strcmp(a->s, attrs[0].s), "string read back as '%s'", a->s);
    a = io_image_find_attr(&im, "obscura:samples");
    CHECK(a && a->type == IO_ATTR_INT);
    CHECK_EQ_INT(a->i, -123456789);
    a = io_image_find_attr(&im, "obscura:near");
    CHECK(a && a->type == IO_ATTR_FLOAT);
    CHECK(f2u(a->f) == f2u(0.1f));
    a = io_image_find_attr(&im, "worldToCamera");
    CHECK_MSG(a && a->type == IO_ATTR_MATRIX44 && a->n == 16 && a->v, "worldToCamera missing or type %d n %d",
              a ? (int)a->type : -1, a ? a->n : -1);
    for (int k = 0; k < 16; k++)
        CHECK_MSG(f2u(a->v[k]) == f2u(m.m[k]), "matrix element %d: %.9g != %.9g", k, a->v[k], m.m[k]);
    a = io_image_find_attr(&im, "obscura:weights");
    CHECK_MSG(a && a->type == IO_ATTR_FLOATS && a->n == 5 && a->v, "weights missing or type %d n %d",
              a ? (int)a->type : -1, a ? a->n : -1);
    for (int k = 0; k < 5; k++)
        CHECK(f2u(a->v[k]) == f2u(weights[k]));
    /* Compression is ZIP, as documented. */
    a = io_image_find_attr(&im, "compression");
    CHECK(a && a->type == IO_ATTR_STRING && a->s);
    CHECK_MSG(strstr(a->s, "zip") != NULL, "compression is '%s'", a->s);
    CHECK(io_image_find_attr(&im, "obscura:absent") == NULL);
    /* No wall-clock time stamp: the same image and metadata give the same bytes. */
    a = io_image_find_attr(&im, "DateTime");
    CHECK_MSG(!a || (a->type == IO_ATTR_STRING && a->s && !a->s[0]), "DateTime: %s", a && a->s ? a->s : "?");
    {
        const char *path2 = test_path(test_tmpdir(), "meta2.exr");
        CHECK_OK(io_exr_write(ctx, path2, &ch, 1, attrs, 5), ctx);
        char *d1, *d2;
        size_t l1, l2;
        CHECK_OK(io_read_file(ctx, path, 1 << 20, &d1, &l1), ctx);
        CHECK_OK(io_read_file(ctx, path2, 1 << 20, &d2, &l2), ctx);
        int same = l1 == l2 && !memcmp(d1, d2, l1);
        free(d1);
        free(d2);
        CHECK_MSG(same, "two writes of the same image differ");
    }

    /* The file really holds the matrix the way Imath reads it (row-vector form: translation in
     * the last row); oiiotool, when installed, prints the 16 values in file order. */
    io_image_free(&im);
    obs_image_f32_free(&z);
    obs_context_destroy(ctx);
}

TEST(exr_channels_are_found_by_name_not_position)
{
    obs_context *ctx = obs_context_create();
    enum { W = 4, H = 3 };
    /* Written in an order that is not alphabetical; EXR sorts channels by name. */
    const char *names[5] = {"zeta", "primid", "B", "alpha", "N.Y"};
    obs_image_f32 f[5];
    obs_image_u32 u;
    io_channel ch[5];
    for (int c = 0; c < 5; c++) {
        if (c == 1) {
            CHECK_OK(obs_image_u32_alloc(ctx, W, H, &u), ctx);
            obs_image_u32_fill(&u, 4000000001u);
            ch[c] = (io_channel){names[c], IO_PIXEL_UINT, NULL, &u};
            f[c].data = NULL;
        } else {
            CHECK_OK(obs_image_f32_alloc(ctx, W, H, &f[c]), ctx);
            obs_image_f32_fill(&f[c], (float)(c + 1) * 10.0f);
            ch[c] = (io_channel){names[c], c == 4 ? IO_PIXEL_HALF : IO_PIXEL_FLOAT, &f[c], NULL};
        }
    }
    const char *path = test_path(test_tmpdir(), "order.exr");
    CHECK_OK(io_exr_write(ctx, path, ch, 5, NULL, 0), ctx);
    io_image im;
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    CHECK_EQ_INT(im.channel_count, 5);
    for (int c = 0; c < 5; c++) {
        int k = io_image_find_channel(&im, names[c]);
        CHECK_MSG(k >= 0, "channel %s not found", names[c]);
        if (c == 1) {
            CHECK(im.types[k] == IO_PIXEL_UINT);
            CHECK(obs_image_u32_row(&im.u32[k], H - 1)[W - 1] == 4000000001u);
        } else {
            CHECK(im.types[k] == IO_PIXEL_FLOAT);
            CHECK_MSG(obs_image_f32_row(&im.f32[k], H - 1)[W - 1] == (float)(c + 1) * 10.0f, "channel %s: %g", names[c],
                      obs_image_f32_row(&im.f32[k], H - 1)[W - 1]);
        }
    }
    io_image_free(&im);
    for (int c = 0; c < 5; c++)
        if (c != 1)
            obs_image_f32_free(&f[c]);
    obs_image_u32_free(&u);
    obs_context_destroy(ctx);
}

TEST(exr_write_to_missing_directory_is_io_error_and_leaves_no_file)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 z;
    CHECK_OK(obs_image_f32_alloc(ctx, 8, 8, &z), ctx);
    io_channel ch = {"Z", IO_PIXEL_FLOAT, &z, NULL};
    char path[4096];
    snprintf(path, sizeof path, "%s/no/such/dir/x.exr", test_tmpdir());
    obs_status st = io_exr_write(ctx, path, &ch, 1, NULL, 0);
    CHECK_MSG(st == OBS_STATUS_IO_ERROR, "status %s: %s", obs_status_string(st), obs_context_last_error(ctx));
    CHECK_MSG(strstr(obs_context_last_error(ctx), "x.exr") != NULL, "message: %s", obs_context_last_error(ctx));
    CHECK(!file_exists(path));
    CHECK_EQ_INT(count_entries(test_tmpdir(), NULL), 0);

    /* Invalid arguments are refused before anything is created. */
    obs_context_clear_error(ctx);
    CHECK(io_exr_write(ctx, test_path(test_tmpdir(), "y.exr"), &ch, 0, NULL, 0) == OBS_STATUS_INVALID_ARGUMENT);
    io_channel bad = {"Z", IO_PIXEL_UINT, &z, NULL};
    CHECK(io_exr_write(ctx, test_path(test_tmpdir(), "y.exr"), &bad, 1, NULL, 0) == OBS_STATUS_INVALID_ARGUMENT);
    io_channel dup[2] = {ch, ch};
    CHECK(io_exr_write(ctx, test_path(test_tmpdir(), "y.exr"), dup, 2, NULL, 0) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(count_entries(test_tmpdir(), NULL), 0);
    obs_image_f32_free(&z);
    obs_context_destroy(ctx);
}

TEST(image_read_missing_file_is_io_error)
{
    obs_context *ctx = obs_context_create();
    const char *path = test_path(test_tmpdir(), "missing-file-42.exr");
    io_image im;
    memset(&im, 0x5a, sizeof im);
    obs_status st = io_image_read(ctx, path, &im);
    CHECK_MSG(st == OBS_STATUS_IO_ERROR, "status %s", obs_status_string(st));
    CHECK_MSG(strstr(obs_context_last_error(ctx), "missing-file-42.exr") != NULL, "message: %s",
              obs_context_last_error(ctx));
    CHECK(im.channel_count == 0 && im.names == NULL && im.f32 == NULL && im.attrs == NULL);
    io_image_free(&im);
    obs_context_destroy(ctx);
}

TEST(image_read_garbage_file_is_error)
{
    obs_context *ctx = obs_context_create();
    unsigned char buf[4096];
    uint32_t s = 12345u;
    for (size_t i = 0; i < sizeof buf; i++) {
        s = s * 1664525u + 1013904223u;
        buf[i] = (unsigned char)(s >> 24);
    }
    const char *path = test_path(test_tmpdir(), "x.exr");
    CHECK(write_raw(path, buf, sizeof buf));
    io_image im;
    obs_status st = io_image_read(ctx, path, &im);
    CHECK_MSG(st != OBS_STATUS_OK, "random bytes read as an image");
    CHECK_MSG(st == OBS_STATUS_PARSE_ERROR, "status %s: %s", obs_status_string(st), obs_context_last_error(ctx));
    CHECK_MSG(strstr(obs_context_last_error(ctx), "x.exr") != NULL, "message: %s", obs_context_last_error(ctx));
    CHECK(im.channel_count == 0 && im.names == NULL);

    /* The EXR magic number and version followed by garbage: the EXR parser must fail cleanly. */
    buf[0] = 0x76, buf[1] = 0x2f, buf[2] = 0x31, buf[3] = 0x01, buf[4] = 2, buf[5] = buf[6] = buf[7] = 0;
    const char *path2 = test_path(test_tmpdir(), "y.exr");
    CHECK(write_raw(path2, buf, sizeof buf));
    obs_context_clear_error(ctx);
    st = io_image_read(ctx, path2, &im);
    CHECK_MSG(st != OBS_STATUS_OK, "EXR magic + random bytes read as an image");
    CHECK_MSG(strstr(obs_context_last_error(ctx), "y.exr") != NULL, "message: %s", obs_context_last_error(ctx));

    /* A valid EXR truncated in the middle of its pixel data. */
    obs_image_f32 z;
    CHECK_OK(obs_image_f32_alloc(ctx, 64, 64, &z), ctx);
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++)
            obs_image_f32_row(&z, y)[x] = (float)(x * 131 + y * 7919 % 1000);
    io_channel ch = {"Z", IO_PIXEL_FLOAT, &z, NULL};
    const char *path3 = test_path(test_tmpdir(), "trunc.exr");
    obs_context_clear_error(ctx);
    CHECK_OK(io_exr_write(ctx, path3, &ch, 1, NULL, 0), ctx);
    char *data;
    size_t len;
    CHECK_OK(io_read_file(ctx, path3, 1 << 24, &data, &len), ctx);
    CHECK(len > 600);
    CHECK(write_raw(path3, data, len / 2 + 100));
    free(data);
    obs_context_clear_error(ctx);
    st = io_image_read(ctx, path3, &im);
    CHECK_MSG(st != OBS_STATUS_OK, "a truncated EXR read as OK");
    CHECK_MSG(strstr(obs_context_last_error(ctx), "trunc.exr") != NULL, "message: %s", obs_context_last_error(ctx));
    CHECK(im.channel_count == 0 && im.names == NULL);
    obs_image_f32_free(&z);
    obs_context_destroy(ctx);
}

TEST(image_read_refuses_over_limit)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 a, b;
    CHECK_OK(obs_image_f32_alloc(ctx, 37, 23, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 37, 23, &b), ctx);
    io_channel ch[2] = {{"A", IO_PIXEL_FLOAT, &a, NULL}, {"B", IO_PIXEL_FLOAT, &b, NULL}};
    const char *path = test_path(test_tmpdir(), "big.exr");
    CHECK_OK(io_exr_write(ctx, path, ch, 2, NULL, 0), ctx);

    obs_limits lim = *obs_context_limits(ctx);
    /* 37*23 = 851 pixels fit, but 2 channels = 1702 values do not. */
    lim.max_image_pixels = 1000;
    obs_context_set_limits(ctx, &lim);
    io_image im;
    obs_status st = io_image_read(ctx, path, &im);
    CHECK_MSG(st == OBS_STATUS_LIMIT_EXCEEDED, "status %s: %s", obs_status_string(st), obs_context_last_error(ctx));
    CHECK_MSG(strstr(obs_context_last_error(ctx), "big.exr") != NULL, "message: %s", obs_context_last_error(ctx));
    CHECK(im.channel_count == 0 && im.names == NULL);

    lim.max_image_pixels = 37 * 23 * 2;
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    io_image_free(&im);
    obs_image_f32_free(&a);
    obs_image_f32_free(&b);
    obs_context_destroy(ctx);
}

/* ---- PNG and sRGB ------------------------------------------------------------------------- */

TEST(png_srgb_encoding_matches_iec_61966)
{
    obs_context *ctx = obs_context_create();
    const float vals[] = {0.0f, 1.0f, 0.0031308f, 0.5f, 0.18f, 0.001f, 0.01f, 0.25f, 0.75f, 0.9f, 0.99f, -1.0f, 2.0f,
                          NAN, INFINITY, 1e-6f};
    /* Expected 8-bit codes from the IEC 61966-2-1 formula, computed independently in double. */
    const int n = (int)(sizeof vals / sizeof vals[0]);
    obs_image_f32 p[4];
    for (int c = 0; c < 4; c++)
        CHECK_OK(obs_image_f32_alloc(ctx, n, 2, &p[c]), ctx);
    for (int y = 0; y < 2; y++)
        for (int i = 0; i < n; i++) {
            obs_image_f32_row(&p[0], y)[i] = vals[i];
            obs_image_f32_row(&p[1], y)[i] = vals[(i + 1) % n];
            obs_image_f32_row(&p[2], y)[i] = vals[(i + 2) % n];
            obs_image_f32_row(&p[3], y)[i] = y == 0 ? 0.5f : (i == 1 ? 0.0f : 0.18f); /* alpha, incl. 0 */
        }
    const char *path = test_path(test_tmpdir(), "srgb.png");
    CHECK_OK(io_png_write(ctx, path, p, 4, IO_PNG_SRGB), ctx);
    CHECK_EQ_INT(count_entries(test_tmpdir(), ".tmp."), 0);

    io_image im;
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    CHECK_EQ_INT(im.width, n);
    CHECK_EQ_INT(im.height, 2);
    CHECK_EQ_INT(im.channel_count, 4);
    const char *names[4] = {"R", "G", "B", "A"};
    for (int c = 0; c < 4; c++) {
        int k = io_image_find_channel(&im, names[c]);
        CHECK_MSG(k >= 0, "channel %s missing", names[c]);
        for (int y = 0; y < 2; y++)
            for (int i = 0; i < n; i++) {
                double v = obs_image_f32_row(&p[c], y)[i];
                double clamped = isnan(v) ? 0.0 : (v < 0 ? 0 : (v > 1 ? 1 : v));
                double enc = c == 3 ? clamped : srgb_ref(clamped);
                int expect = (int)floor(enc * 255.0 + 0.5);
                double got = obs_image_f32_row(&im.f32[k], y)[i] * 255.0;
                int code = (int)floor(got + 0.5);
                CHECK_MSG(fabs(got - code) < 1e-3, "channel %s: %.6f is not an 8-bit code", names[c], got);
                CHECK_MSG(code == expect, "channel %s pixel (%d,%d) value %.9g: code %d, expected %d", names[c], i, y, v,
                          code, expect);
            }
    }
    /* Spot values computed by hand from the formula. */
    int kr = io_image_find_channel(&im, "R");
    const int known[5] = {0, 255, 10, 188, 118}; /* 0, 1, 0.0031308 (0.04045*255=10.31), 0.5, 0.18 */
    for (int i = 0; i < 5; i++)
        CHECK_EQ_INT((int)floor(obs_image_f32_row(&im.f32[kr], 0)[i] * 255.0 + 0.5), known[i]);
    /* Alpha 0 does not wipe the colour (no premultiplication either way). */
    CHECK_EQ_INT((int)floor(obs_image_f32_row(&im.f32[kr], 1)[1] * 255.0 + 0.5), 255);
    io_image_free(&im);

    /* The file is tagged sRGB (an sRGB chunk). */
    char *data;
    size_t len;
    CHECK_OK(io_read_file(ctx, path, 1 << 20, &data, &len), ctx);
    CHECK(len > 8 && !memcmp(data, "\x89PNG", 4));
    CHECK(has_bytes(data, len, "sRGB"));
    free(data);

    /* Grey and RGB work too; 2 planes do not. */
    CHECK_OK(io_png_write(ctx, test_path(test_tmpdir(), "grey.png"), p, 1, IO_PNG_SRGB), ctx);
    CHECK_OK(io_png_write(ctx, test_path(test_tmpdir(), "rgb.png"), p, 3, IO_PNG_SRGB), ctx);
    CHECK(io_png_write(ctx, test_path(test_tmpdir(), "two.png"), p, 2, IO_PNG_SRGB) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK_OK(io_image_read(ctx, test_path(test_tmpdir(), "grey.png"), &im), ctx);
    CHECK_EQ_INT(im.channel_count, 1);
    CHECK_EQ_INT((int)floor(obs_image_f32_row(&im.f32[0], 0)[3] * 255.0 + 0.5), 188);
    io_image_free(&im);
    for (int c = 0; c < 4; c++)
        obs_image_f32_free(&p[c]);
    obs_context_destroy(ctx);
}

TEST(png_linear_encoding_is_direct)
{
    obs_context *ctx = obs_context_create();
    const float vals[] = {0.0f, 0.5f, 0.18f, 1.0f, 0.0031308f, 1.0f / 255.0f, 0.499f / 255.0f, 0.501f / 255.0f,
                          -0.5f, 1.5f, NAN};
    const int n = (int)(sizeof vals / sizeof vals[0]);
    obs_image_f32 p[4];
    for (int c = 0; c < 4; c++)
        CHECK_OK(obs_image_f32_alloc(ctx, n, 1, &p[c]), ctx);
    for (int i = 0; i < n; i++)
        for (int c = 0; c < 4; c++)
            obs_image_f32_row(&p[c], 0)[i] = c == 3 ? 0.25f : vals[(i + c) % n];
    const char *path = test_path(test_tmpdir(), "linear.png");
    CHECK_OK(io_png_write(ctx, path, p, 4, IO_PNG_LINEAR), ctx);
    io_image im;
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    CHECK_EQ_INT(im.channel_count, 4);
    const char *names[4] = {"R", "G", "B", "A"};
    for (int c = 0; c < 4; c++) {
        int k = io_image_find_channel(&im, names[c]);
        CHECK(k >= 0);
        for (int i = 0; i < n; i++) {
            double v = obs_image_f32_row(&p[c], 0)[i];
            double clamped = isnan(v) ? 0.0 : (v < 0 ? 0 : (v > 1 ? 1 : v));
            int expect = (int)floor(clamped * 255.0 + 0.5);
            int code = (int)floor(obs_image_f32_row(&im.f32[k], 0)[i] * 255.0 + 0.5);
            CHECK_MSG(code == expect, "channel %s value %.9g: code %d, expected %d", names[c], v, code, expect);
        }
    }
    int kr = io_image_find_channel(&im, "R");
    CHECK_EQ_INT((int)floor(obs_image_f32_row(&im.f32[kr], 0)[1] * 255.0 + 0.5), 128); /* 127.5 rounds up */
    CHECK_EQ_INT((int)floor(obs_image_f32_row(&im.f32[kr], 0)[2] * 255.0 + 0.5), 46);  /* 45.9 */
    const io_attr *cs = io_image_find_attr(&im, "oiio:ColorSpace");
    CHECK_MSG(cs && cs->type == IO_ATTR_STRING && cs->s && !strcmp(cs->s, "Linear"), "colour space read back: %s",
              cs && cs->s ? cs->s : "(none)");
    io_image_free(&im);

    /* No sRGB chunk; a gAMA chunk (gamma 1.0) says linear instead. */
    char *data;
    size_t len;
    CHECK_OK(io_read_file(ctx, path, 1 << 20, &data, &len), ctx);
    CHECK(!has_bytes(data, len, "sRGB"));
    CHECK(has_bytes(data, len, "gAMA"));
    free(data);
    for (int c = 0; c < 4; c++)
        obs_image_f32_free(&p[c]);
    obs_context_destroy(ctx);
}

TEST(srgb_encode_decode_round_trip)
{
    CHECK(io_srgb_encode(0.0f) == 0.0f);
    CHECK(io_srgb_encode(1.0f) == 1.0f);
    CHECK(io_srgb_decode(0.0f) == 0.0f);
    CHECK(io_srgb_decode(1.0f) == 1.0f);
    CHECK_NEAR(io_srgb_encode(0.0031308f), 0.04045, 1e-6);
    CHECK_NEAR(io_srgb_encode(0.5f), 0.735356983, 1e-7);
    CHECK_NEAR(io_srgb_encode(0.18f), 0.461356129, 1e-7);
    CHECK_NEAR(io_srgb_decode(0.5f), 0.214041140, 1e-7);
    /* Both branches meet (almost) continuously at the threshold. */
    CHECK_NEAR(io_srgb_encode(0.0031307f), io_srgb_encode(0.0031309f), 1e-5);
    for (int i = 0; i <= 100000; i++) {
        float x = (float)i / 100000.0f;
        float e = io_srgb_encode(x);
        CHECK_NEAR(e, srgb_ref(x), 1e-7);
        CHECK_NEAR(io_srgb_decode(e), x, 2e-7 + 2e-6 * x);
        if (i > 0)
            CHECK_MSG(e >= io_srgb_encode((float)(i - 1) / 100000.0f), "encode not monotonic at %g", x);
    }
    for (int c = 0; c < 256; c++) {
        float enc = (float)c / 255.0f;
        CHECK_NEAR(io_srgb_encode(io_srgb_decode(enc)) * 255.0, c, 1e-3);
    }
    CHECK(isnan(io_srgb_encode(NAN)));
}

/* ---- atomic output and bounded input ------------------------------------------------------ */

TEST(atomic_write_replaces_whole_file_and_leaves_no_temp)
{
    obs_context *ctx = obs_context_create();
    const char *dir = test_tmpdir();
    const char *path = test_path(dir, "out.txt");
    const char *first = "the first version, which is longer than the second one\n";
    const char *second = "second\n";
    CHECK_OK(io_write_file_atomic(ctx, path, first, strlen(first)), ctx);
    CHECK_OK(io_write_file_atomic(ctx, path, second, strlen(second)), ctx);
    char *data;
    size_t len;
    CHECK_OK(io_read_file(ctx, path, 1024, &data, &len), ctx);
    CHECK_EQ_INT(len, strlen(second));
    CHECK(!memcmp(data, second, len) && data[len] == '\0');
    free(data);
    CHECK_EQ_INT(count_entries(dir, ".tmp."), 0);
    CHECK_EQ_INT(count_entries(dir, NULL), 1);

    /* An empty file is a valid write too. */
    CHECK_OK(io_write_file_atomic(ctx, path, "", 0), ctx);
    CHECK_OK(io_read_file(ctx, path, 1024, &data, &len), ctx);
    CHECK_EQ_INT(len, 0);
    free(data);

    /* Temporary names are beside the target and unique. */
    char t1[4096 + 48], t2[4096 + 48];
    CHECK_OK(io_temp_path(ctx, path, t1, sizeof t1), ctx);
    CHECK_OK(io_temp_path(ctx, path, t2, sizeof t2), ctx);
    CHECK(strncmp(t1, path, strlen(path)) == 0 && strstr(t1 + strlen(path), ".tmp.") == t1 + strlen(path));
    CHECK(strcmp(t1, t2) != 0);
    char tiny[8];
    CHECK(io_temp_path(ctx, path, tiny, sizeof tiny) == OBS_STATUS_INVALID_ARGUMENT);
    obs_context_destroy(ctx);
}

TEST(atomic_write_failure_leaves_previous_file_intact)
{
    obs_context *ctx = obs_context_create();
    const char *dir = test_tmpdir();
    const char *path = test_path(dir, "keep.txt");
    CHECK_OK(io_write_file_atomic(ctx, path, "old", 3), ctx);
    char *data;
    size_t len;

    if (geteuid() != 0) {
        /* A read-only directory: the temporary file cannot be created. (Root ignores permissions.) */
        CHECK(chmod(dir, 0555) == 0);
        obs_status st = io_write_file_atomic(ctx, path, "new content", 11);
        chmod(dir, 0755);
        CHECK_MSG(st == OBS_STATUS_IO_ERROR, "status %s", obs_status_string(st));
        CHECK_MSG(strstr(obs_context_last_error(ctx), "keep.txt") != NULL, "message: %s", obs_context_last_error(ctx));
        CHECK_OK(io_read_file(ctx, path, 1024, &data, &len), ctx);
        CHECK(len == 3 && !memcmp(data, "old", 3));
        free(data);
        obs_context_clear_error(ctx);
    }

    /* The rename fails (the target is a non-empty directory, which even root cannot replace):
     * the temporary file, already written, must be removed and the directory left alone. */
    const char *sub = test_path(dir, "target.d");
    CHECK(mkdir(sub, 0755) == 0);
    CHECK(write_raw(test_path(sub, "inside"), "x", 1));
    obs_status st = io_write_file_atomic(ctx, sub, "new content", 11);
    CHECK_MSG(st == OBS_STATUS_IO_ERROR, "status %s", obs_status_string(st));
    CHECK_MSG(strstr(obs_context_last_error(ctx), "target.d") != NULL, "message: %s", obs_context_last_error(ctx));
    CHECK_MSG(strstr(obs_context_last_error(ctx), strerror(EISDIR)) != NULL ||
                  strstr(obs_context_last_error(ctx), strerror(ENOTEMPTY)) != NULL ||
                  strstr(obs_context_last_error(ctx), strerror(EEXIST)) != NULL,
              "message lacks the errno text: %s", obs_context_last_error(ctx));
    CHECK_EQ_INT(count_entries(dir, ".tmp."), 0);
    CHECK_EQ_INT(count_entries(sub, NULL), 1);
    obs_context_clear_error(ctx);

    /* A directory that does not exist. */
    char missing[4096];
    snprintf(missing, sizeof missing, "%s/absent/keep.txt", dir);
    st = io_write_file_atomic(ctx, missing, "new", 3);
    CHECK_MSG(st == OBS_STATUS_IO_ERROR, "status %s", obs_status_string(st));
    CHECK_MSG(strstr(obs_context_last_error(ctx), "absent/keep.txt") != NULL, "message: %s",
              obs_context_last_error(ctx));
    CHECK_MSG(strstr(obs_context_last_error(ctx), strerror(ENOENT)) != NULL, "message lacks errno text: %s",
              obs_context_last_error(ctx));

    /* Through all of it the previous file is intact and no temporary file is left. */
    CHECK_OK(io_read_file(ctx, path, 1024, &data, &len), ctx);
    CHECK(len == 3 && !memcmp(data, "old", 3));
    free(data);
    CHECK_EQ_INT(count_entries(dir, ".tmp."), 0);
    CHECK(io_write_file_atomic(ctx, NULL, "x", 1) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(io_write_file_atomic(ctx, path, NULL, 1) == OBS_STATUS_INVALID_ARGUMENT);
    obs_context_destroy(ctx);
}

TEST(read_file_refuses_over_limit)
{
    obs_context *ctx = obs_context_create();
    char buf[100];
    for (int i = 0; i < 100; i++)
        buf[i] = (char)('a' + i % 26);
    const char *path = test_path(test_tmpdir(), "hundred.bin");
    CHECK_OK(io_write_file_atomic(ctx, path, buf, 100), ctx);
    char *data = (char *)1;
    size_t len = 77;
    obs_status st = io_read_file(ctx, path, 99, &data, &len);
    CHECK_MSG(st == OBS_STATUS_LIMIT_EXCEEDED, "status %s", obs_status_string(st));
    CHECK(data == NULL && len == 0);
    CHECK_MSG(strstr(obs_context_last_error(ctx), "hundred.bin") != NULL, "message: %s", obs_context_last_error(ctx));
    obs_context_clear_error(ctx);
    CHECK_OK(io_read_file(ctx, path, 100, &data, &len), ctx);
    CHECK_EQ_INT(len, 100);
    CHECK(!memcmp(data, buf, 100) && data[100] == '\0');
    free(data);

    st = io_read_file(ctx, test_path(test_tmpdir(), "nope.bin"), 100, &data, &len);
    CHECK(st == OBS_STATUS_IO_ERROR && data == NULL);
    CHECK_MSG(strstr(obs_context_last_error(ctx), "nope.bin") != NULL, "message: %s", obs_context_last_error(ctx));
    st = io_read_file(ctx, test_tmpdir(), 100, &data, &len);
    CHECK_MSG(st == OBS_STATUS_IO_ERROR && data == NULL, "reading a directory: %s", obs_status_string(st));
    obs_context_destroy(ctx);
}
