/* test_ao_input.c: AO inputs: validation, our G-buffer, external G-buffers from EXR in every depth
 * convention with intrinsics from metadata or JSON, and normals reconstructed from depth. */
#include "ao/ao.h"
#include "core/obs.h"
#include "io/io.h"
#include "raster/raster.h"
#include "ao_test_util.h"
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A sphere of radius 1 at (0, 0, -4) above a ground quad at y = -1.2 (clipped by the far plane). */
static void scene_sphere_ground(obs_scene *s) { tu_sphere_over_ground(s, 32, 16, 0.05f, -1.2f, 30.0f, -60.0f); }

/* Write what `obscura gbuffer --keep-guard` writes (channels Z, Zndc, N.*; its metadata). */
static obs_status write_gbuffer_exr(obs_context *ctx, const char *path, const rast_gbuffer *gb, const obs_camera *cam,
                                    int with_metadata)
{
    const rast_view_constants *vc = &gb->constants;
    io_channel ch[5] = {
        {"Z", IO_PIXEL_FLOAT, &gb->depth, NULL},     {"Zndc", IO_PIXEL_FLOAT, &gb->ndc_depth, NULL},
        {"N.X", IO_PIXEL_FLOAT, &gb->normal[0], NULL}, {"N.Y", IO_PIXEL_FLOAT, &gb->normal[1], NULL},
        {"N.Z", IO_PIXEL_FLOAT, &gb->normal[2], NULL},
    };
    float fxyc[4] = {(float)vc->fx, (float)vc->fy, (float)vc->cx, (float)vc->cy};
    float window[4] = {(float)vc->inner_x0, (float)vc->inner_y0, (float)(gb->width - 2 * gb->guard),
                       (float)(gb->height - 2 * gb->guard)};
    io_attr at[6];
    memset(at, 0, sizeof at);
    int na = 0;
    strcpy(at[na].name, "obscura:pixel_model_fx_fy_cx_cy"); at[na].type = IO_ATTR_FLOATS; at[na].v = fxyc; at[na].n = 4; na++;
    strcpy(at[na].name, "obscura:znear"); at[na].type = IO_ATTR_FLOAT; at[na].f = cam->znear; na++;
    strcpy(at[na].name, "obscura:zfar"); at[na].type = IO_ATTR_FLOAT; at[na].f = cam->zfar; na++;
    strcpy(at[na].name, "obscura:depth_convention"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)rast_depth_convention_name(gb->depth_convention); na++;
    strcpy(at[na].name, "obscura:projection_type"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)(cam->projection == OBS_PROJECTION_PERSPECTIVE ? "perspective" : "orthographic"); na++;
    strcpy(at[na].name, "obscura:inner_window_x_y_w_h"); at[na].type = IO_ATTR_FLOATS; at[na].v = window; at[na].n = 4; na++;
    return io_exr_write(ctx, path, ch, 5, at, with_metadata ? na : 0);
}

/* The worst |recovered - rasterized| / d over the image, divided by the allowed relative error:
 * 1e-6, or for a standard / zero-to-one depth buffer the float32 quantisation of 1 - n/d near 1
 * (2^-24 d/n, with margin), which exceeds 1e-6 beyond ~16 near distances (the reason for
 * reversed-Z). Returns <= 1 when every pixel is within its bound. */
static double max_rel_depth_error(const rast_gbuffer *gb, const obs_image_f32 *d, int64_t *bg_mismatch,
                                  int ndc_standard, double znear)
{
    double worst = 0.0;
    *bg_mismatch = 0;
    for (int y = 0; y < gb->height; y++)
        for (int x = 0; x < gb->width; x++) {
            float a = obs_image_f32_row(&gb->depth, y)[x], b = obs_image_f32_row(d, y)[x];
            if (!(a < INFINITY) || !(b < INFINITY)) {
                *bg_mismatch += (a < INFINITY) != (b < INFINITY);
                continue;
            }
            double allowed = 1e-6;
            if (ndc_standard)
                allowed = fmax(allowed, 1.5 * ldexp(1.0, -24) * (double)a / znear);
            double e = fabs((double)b - (double)a) / (double)a / allowed;
            worst = e > worst ? e : worst;
        }
    return worst;
}

TEST(ao_input_from_exr_round_trips)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    scene_sphere_ground(&s);
    /* near 1, far 12: depths within 12 near-plane distances, so a float32 depth-buffer value
     * (spacing 2^-24 near 1) pins the linear depth to ~4e-7 relative in every convention. */
    static const struct { rast_depth_convention conv; int infinite; const char *name; } cases[] = {
        {RAST_DEPTH_GL_STANDARD, 0, "gl"},
        {RAST_DEPTH_ZERO_TO_ONE, 0, "zero-to-one"},
        {RAST_DEPTH_REVERSED_Z, 0, "reversed-z"},
        {RAST_DEPTH_REVERSED_Z, 1, "reversed-z, infinite far"},
        {RAST_DEPTH_ZERO_TO_ONE, 1, "zero-to-one, infinite far"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        obs_camera cam = obs_camera_look_at(obs_v3(0.2f, 0.5f, 0.0f), obs_v3(0.0f, -0.4f, -4.0f), obs_v3(0, 1, 0),
                                            0.9f, 1.0f, cases[c].infinite ? INFINITY : 12.0f);
        rast_params p = rast_params_default();
        p.width = 72;
        p.height = 45;
        p.guard = 5;
        p.depth_convention = cases[c].conv;
        rast_gbuffer gb;
        CHECK_OK(rast_gbuffer_alloc(ctx, &p, &gb), ctx);
        rast_view v = {cam};
        CHECK_OK(rast_render(ctx, NULL, &s, &v, 1, &p, &gb, NULL), ctx);
        const char *path = test_path(test_tmpdir(), "gb.exr");
        CHECK_OK(write_gbuffer_exr(ctx, path, &gb, &cam, 1), ctx);
        io_image im;
        CHECK_OK(io_image_read(ctx, path, &im), ctx);
        for (int which = 0; which < 2; which++) {
            ao_external_options o = ao_external_options_default();
            o.depth_channel = which ? "Zndc" : NULL; /* NULL: Z is found first */
            ao_external e;
            CHECK_OK(ao_external_from_image(ctx, &im, &o, &e), ctx);
            CHECK_EQ_INT(e.depth_kind, which == 0 ? AO_DEPTH_KIND_LINEAR
                                       : cases[c].conv == RAST_DEPTH_GL_STANDARD ? AO_DEPTH_KIND_NDC_GL
                                       : cases[c].conv == RAST_DEPTH_ZERO_TO_ONE ? AO_DEPTH_KIND_NDC_ZERO_TO_ONE
                                                                                  : AO_DEPTH_KIND_NDC_REVERSED_Z);
            int64_t bgm;
            int standard = which == 1 && cases[c].conv != RAST_DEPTH_REVERSED_Z;
            double err = max_rel_depth_error(&gb, &e.depth, &bgm, standard, 1.0);
            CHECK_MSG(err <= 1.0 && bgm == 0,
                      "%s, channel %s: depth error %.3g times its bound, %lld background mismatches", cases[c].name,
                      e.depth_channel, err, (long long)bgm);
            CHECK_EQ_INT(e.invalid_depth_pixels, 0);
            CHECK(e.background_pixels > 0);
            /* the window is the inner image, the intrinsics are the rasterizer's (as floats) */
            const ao_input *in = &e.input;
            CHECK_EQ_INT(in->width, 82);
            CHECK_EQ_INT(in->height, 55);
            CHECK_EQ_INT(in->x0, 5);
            CHECK_EQ_INT(in->y0, 5);
            CHECK_EQ_INT(in->w, 72);
            CHECK_EQ_INT(in->h, 45);
            CHECK_NEAR(in->fx, gb.constants.fx, 1e-4);
            CHECK_NEAR(in->cy, gb.constants.cy, 1e-6);
            CHECK(in->normal[0] && in->normal[2]);
            CHECK(cases[c].infinite ? isinf(in->zfar) : in->zfar == 12.0);
            ao_external_free(&e);
        }
        /* the same without metadata, the intrinsics from JSON (flat keys) */
        CHECK_OK(write_gbuffer_exr(ctx, path, &gb, &cam, 0), ctx);
        io_image im2;
        CHECK_OK(io_image_read(ctx, path, &im2), ctx);
        char json[1024];
        const char *kinds[] = {"gl", "zero-to-one", "reversed-z"};
        snprintf(json, sizeof json,
                 "{\"fx\": %.17g, \"fy\": %.17g, \"cx\": %.17g, \"cy\": %.17g, \"projection\": \"perspective\",\n"
                 " \"znear\": 1, \"zfar\": %s, \"depth_kind\": \"%s\", \"inner_window\": [5, 5, 72, 45]}",
                 gb.constants.fx, gb.constants.fy, gb.constants.cx, gb.constants.cy,
                 cases[c].infinite ? "\"infinity\"" : "12", kinds[cases[c].conv]);
        ao_intrinsics k;
        CHECK_OK(ao_intrinsics_parse_json(ctx, json, &k), ctx);
        ao_external_options o = ao_external_options_default();
        o.depth_channel = "Zndc";
        o.intrinsics = &k;
        ao_external e;
        CHECK_OK(ao_external_from_image(ctx, &im2, &o, &e), ctx);
        int64_t bgm;
        double err = max_rel_depth_error(&gb, &e.depth, &bgm, cases[c].conv != RAST_DEPTH_REVERSED_Z, 1.0);
        CHECK_MSG(err <= 1.0 && bgm == 0, "%s via JSON: depth error %.3g times its bound", cases[c].name, err);
        CHECK_EQ_INT(e.input.x0, 5);
        CHECK(e.input.fx == gb.constants.fx);
        ao_external_free(&e);
        /* without metadata or JSON, an NDC channel is refused with a message, not guessed */
        o.intrinsics = NULL;
        CHECK(ao_external_from_image(ctx, &im2, &o, &e) == OBS_STATUS_NOT_FOUND);
        io_image_free(&im2);
        io_image_free(&im);
        rast_gbuffer_free(&gb);
    }
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(ao_input_validation_and_external_errors)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 d = {0}, n = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 8, 6, &d), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 8, 6, &n), ctx);
    ao_input in;
    memset(&in, 0, sizeof in);
    in.width = in.w = 8;
    in.height = in.h = 6;
    in.depth = &d;
    in.fx = in.fy = 10.0;
    in.cx = 4.0;
    in.cy = 3.0;
    in.zfar = INFINITY;
    CHECK_OK(ao_input_validate(ctx, &in), ctx);
    ao_input b = in;
    b.x0 = 1; /* window past the right edge */
    CHECK(ao_input_validate(ctx, &b) == OBS_STATUS_INVALID_ARGUMENT);
    b = in;
    b.depth = NULL;
    CHECK(ao_input_validate(ctx, &b) == OBS_STATUS_INVALID_ARGUMENT);
    b = in;
    b.normal[0] = &n;
    b.normal[1] = &n; /* two of three */
    CHECK(ao_input_validate(ctx, &b) == OBS_STATUS_INVALID_ARGUMENT);
    b = in;
    b.fx = 0.0;
    CHECK(ao_input_validate(ctx, &b) == OBS_STATUS_INVALID_ARGUMENT);
    b = in;
    b.cy = NAN;
    CHECK(ao_input_validate(ctx, &b) == OBS_STATUS_INVALID_ARGUMENT);
    b = in;
    b.width = 9; /* plane size mismatch */
    b.w = 9;
    CHECK(ao_input_validate(ctx, &b) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(ao_input_validate(ctx, NULL) == OBS_STATUS_INVALID_ARGUMENT);

    /* external: no depth channel; uint depth; normals required but absent */
    obs_image_u32 u = {0};
    CHECK_OK(obs_image_u32_alloc(ctx, 8, 6, &u), ctx);
    io_channel ch[2] = {{"albedo", IO_PIXEL_FLOAT, &d, NULL}, {"depth", IO_PIXEL_UINT, NULL, &u}};
    const char *path = test_path(test_tmpdir(), "bad.exr");
    /* two float channels, neither named as depth (a single channel would be taken as depth) */
    io_channel two[2] = {{"albedo", IO_PIXEL_FLOAT, &d, NULL}, {"rough", IO_PIXEL_FLOAT, &d, NULL}};
    CHECK_OK(io_exr_write(ctx, path, two, 2, NULL, 0), ctx);
    io_image im;
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    ao_external e;
    obs_context_clear_error(ctx);
    CHECK(ao_external_from_image(ctx, &im, NULL, &e) == OBS_STATUS_NOT_FOUND);
    CHECK(strstr(obs_context_last_error(ctx), "albedo") != NULL); /* the message lists what is there */
    io_image_free(&im);
    CHECK_OK(io_exr_write(ctx, path, ch, 2, NULL, 0), ctx);
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    obs_context_clear_error(ctx);
    CHECK(ao_external_from_image(ctx, &im, NULL, &e) == OBS_STATUS_UNSUPPORTED);
    io_image_free(&im);
    /* a linear Z without intrinsics: NOT_FOUND; with them but normals required: NOT_FOUND */
    io_channel zc = {"Z", IO_PIXEL_FLOAT, &d, NULL};
    CHECK_OK(io_exr_write(ctx, path, &zc, 1, NULL, 0), ctx);
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    CHECK(ao_external_from_image(ctx, &im, NULL, &e) == OBS_STATUS_NOT_FOUND);
    ao_intrinsics k = ao_intrinsics_unknown();
    k.fx = k.fy = 10.0;
    k.cx = 4.0;
    k.cy = 3.0;
    ao_external_options o = ao_external_options_default();
    o.intrinsics = &k;
    obs_image_f32_fill(&d, 2.0f);
    CHECK_OK(ao_external_from_image(ctx, &im, &o, &e), ctx); /* the file's values: 0 = invalid depth */
    CHECK_EQ_INT(e.invalid_depth_pixels, 48);
    ao_external_free(&e);
    o.normals = AO_EXTERNAL_NORMALS_REQUIRE;
    CHECK(ao_external_from_image(ctx, &im, &o, &e) == OBS_STATUS_NOT_FOUND);
    o.normals = AO_EXTERNAL_NORMALS_AUTO;
    o.depth_kind = AO_DEPTH_KIND_NDC_GL; /* NDC without znear / zfar */
    CHECK(ao_external_from_image(ctx, &im, &o, &e) == OBS_STATUS_NOT_FOUND);
    k.znear = 2.0;
    k.zfar = 1.0; /* far < near */
    CHECK(ao_external_from_image(ctx, &im, &o, &e) == OBS_STATUS_INVALID_DEPTH_RANGE);
    io_image_free(&im);

    /* JSON: our gbuffer sidecar's layout (nested objects), and malformed values */
    const char *sidecar = "{\"camera\": {\"name\": \"c\", \"projection\": \"perspective\", \"znear\": 0.1, "
                          "\"zfar\": \"infinity\"}, \"params\": {\"depth_convention\": \"reversed_z\"}, "
                          "\"constants\": {\"fx\": 100.5, \"fy\": 99.25, \"cx\": 64, \"cy\": 36, "
                          "\"projection_gl_column_major\": [1, 0]}}";
    CHECK_OK(ao_intrinsics_parse_json(ctx, sidecar, &k), ctx);
    CHECK(k.fx == 100.5 && k.fy == 99.25 && k.cx == 64.0 && k.cy == 36.0);
    CHECK(k.projection == OBS_PROJECTION_PERSPECTIVE && k.znear == 0.1 && isinf(k.zfar));
    CHECK_EQ_INT(k.depth_kind, AO_DEPTH_KIND_NDC_REVERSED_Z);
    CHECK(ao_intrinsics_parse_json(ctx, "{\"fx\": \"wide\"}", &k) == OBS_STATUS_PARSE_ERROR);
    CHECK(ao_intrinsics_parse_json(ctx, "{\"projection\": \"fisheye\"}", &k) == OBS_STATUS_PARSE_ERROR);
    CHECK(ao_intrinsics_parse_json(ctx, "{\"depth_kind\": \"log\"}", &k) == OBS_STATUS_PARSE_ERROR);
    CHECK_OK(ao_intrinsics_parse_json(ctx, "{}", &k), ctx);
    CHECK(!(k.fx > 0.0) && k.projection == -1);
    obs_image_u32_free(&u);
    obs_image_f32_free(&n);
    obs_image_f32_free(&d);
    obs_context_destroy(ctx);
}

TEST(ao_normals_from_depth_recover_planes_and_skip_silhouettes)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    scene_sphere_ground(&s);
    obs_camera cam = obs_camera_look_at(obs_v3(0.2f, 0.5f, 0.0f), obs_v3(0.0f, -0.4f, -4.0f), obs_v3(0, 1, 0), 0.9f,
                                        0.5f, 30.0f);
    rast_params p = rast_params_default();
    p.width = 96;
    p.height = 64;
    p.outputs = RAST_OUT_DEPTH | RAST_OUT_FACE_NORMAL | RAST_OUT_PRIM_ID;
    rast_gbuffer gb;
    CHECK_OK(rast_gbuffer_alloc(ctx, &p, &gb), ctx);
    rast_view v = {cam};
    CHECK_OK(rast_render(ctx, NULL, &s, &v, 1, &p, &gb, NULL), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 0, &in), ctx);
    CHECK(in.normal[0] == NULL);
    obs_image_f32 n[3] = {{0}};
    for (int c = 0; c < 3; c++)
        CHECK_OK(obs_image_f32_alloc(ctx, 96, 64, &n[c]), ctx);
    CHECK_OK(ao_normals_from_depth(ctx, NULL, &in, n), ctx);
    /* On the ground (the last two triangles): the face normal, to float precision, even next to
     * the sphere's silhouette (MinDiff takes the side on the ground). */
    const uint32_t ground0 = s.meshes[0].triangle_count - 2;
    int checked = 0;
    double worst = 0.0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 96; x++) {
            float d = obs_image_f32_row(&gb.depth, y)[x];
            float nx = obs_image_f32_row(&n[0], y)[x], ny = obs_image_f32_row(&n[1], y)[x], nz = obs_image_f32_row(&n[2], y)[x];
            if (!(d < INFINITY)) {
                CHECK(nx == 0.0f && ny == 0.0f && nz == 0.0f);
                continue;
            }
            CHECK(nz >= 0.0f); /* faces the camera */
            /* interior ground pixels: the pixel and its 4 neighbours on the ground (at a grazing
             * angle a sphere pixel next door can be nearer in depth than the next ground row, and
             * MinDiff then takes it: that is the rule's known limit, not tested here) */
            int interior = x > 0 && y > 0 && x < 95 && y < 63;
            for (int k = 0; interior && k < 5; k++) {
                static const int off[5][2] = {{0, 0}, {1, 0}, {-1, 0}, {0, 1}, {0, -1}};
                int xx = x + off[k][0], yy = y + off[k][1];
                interior = obs_image_f32_row(&gb.depth, yy)[xx] < INFINITY &&
                           obs_image_u32_row(&gb.prim_id, yy)[xx] >= ground0;
            }
            if (!interior)
                continue;
            double dot = nx * obs_image_f32_row(&gb.face_normal[0], y)[x] + ny * obs_image_f32_row(&gb.face_normal[1], y)[x] +
                         nz * obs_image_f32_row(&gb.face_normal[2], y)[x];
            worst = fmax(worst, 1.0 - dot);
            checked++;
        }
    CHECK(checked > 500);
    CHECK_MSG(worst < 1e-4, "ground normal off by 1 - cos = %.3g", worst);
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&n[c]);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* fuzz_gbuffer's findings F11 and F12 as direct cases: non-finite intrinsics are refused by the
 * JSON parser (only zfar may be infinite), and external normals that are not unit length are
 * renormalised or become "no normal", counted, on surface pixels only. */
TEST(ao_external_refuses_nonfinite_intrinsics_and_repairs_non_unit_normals)
{
    obs_context *ctx = obs_context_create();
    ao_intrinsics k;
    obs_context_clear_error(ctx);
    CHECK(ao_intrinsics_parse_json(ctx, "{\"fx\": \"infinity\"}", &k) == OBS_STATUS_PARSE_ERROR);
    CHECK(strstr(obs_context_last_error(ctx), "\"fx\"") != NULL);
    CHECK(ao_intrinsics_parse_json(ctx, "{\"cy\": nan}", &k) == OBS_STATUS_PARSE_ERROR);
    CHECK(ao_intrinsics_parse_json(ctx, "{\"zfar\": nan}", &k) == OBS_STATUS_PARSE_ERROR);
    CHECK_OK(ao_intrinsics_parse_json(ctx, "{\"zfar\": \"infinity\", \"fx\": 5}", &k), ctx);
    CHECK(isinf(k.zfar) && k.fx == 5.0);

    const int W = 6, H = 1;
    obs_image_f32 z = {0}, nx = {0}, ny = {0}, nz = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &z), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &nx), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ny), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &nz), ctx);
    /* unit; 0.9 long (kept as is); 1e36 long; NaN; zero; and a huge normal on background */
    const float n3[6][3] = {{0, 0, 1}, {0, 0.9f, 0}, {5e36f, 0, 0}, {NAN, 0, 0}, {0, 0, 0}, {1e30f, 0, 0}};
    for (int x = 0; x < W; x++) {
        obs_image_f32_row(&z, 0)[x] = x == 5 ? INFINITY : 2.0f;
        obs_image_f32_row(&nx, 0)[x] = n3[x][0];
        obs_image_f32_row(&ny, 0)[x] = n3[x][1];
        obs_image_f32_row(&nz, 0)[x] = n3[x][2];
    }
    io_channel ch[4] = {{"Z", IO_PIXEL_FLOAT, &z, NULL}, {"N.X", IO_PIXEL_FLOAT, &nx, NULL},
                        {"N.Y", IO_PIXEL_FLOAT, &ny, NULL}, {"N.Z", IO_PIXEL_FLOAT, &nz, NULL}};
    const char *path = test_path(test_tmpdir(), "normals.exr");
    CHECK_OK(io_exr_write(ctx, path, ch, 4, NULL, 0), ctx);
    io_image im;
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    k = ao_intrinsics_unknown();
    k.fx = k.fy = 10.0;
    k.cx = 3.0;
    k.cy = 0.5;
    ao_external_options o = ao_external_options_default();
    o.intrinsics = &k;
    ao_external e;
    CHECK_OK(ao_external_from_image(ctx, &im, &o, &e), ctx);
    CHECK_EQ_INT(e.renormalized_normal_pixels, 3);
    const float *ex = obs_image_f32_row(&e.normal[0], 0), *ey = obs_image_f32_row(&e.normal[1], 0),
                *ez = obs_image_f32_row(&e.normal[2], 0);
    CHECK(ex[0] == 0.0f && ey[0] == 0.0f && ez[0] == 1.0f);
    CHECK(ey[1] == 0.9f);                               /* within [0.5, 2]: the file's value */
    CHECK(ex[2] == 1.0f && ey[2] == 0.0f && ez[2] == 0.0f); /* renormalised */
    for (int x = 3; x < 6; x++)                          /* NaN, zero, background: no normal */
        CHECK(ex[x] == 0.0f && ey[x] == 0.0f && ez[x] == 0.0f);
    ao_external_free(&e);
    io_image_free(&im);
    obs_image_f32_free(&z);
    obs_image_f32_free(&nx);
    obs_image_f32_free(&ny);
    obs_image_f32_free(&nz);
    obs_context_destroy(ctx);
}

/* ---- EXR data window != display window (issue 13, item 5) ---------------------------------- */

static uint32_t dw_le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static void dw_put32(unsigned char *p, int32_t v)
{
    uint32_t u = (uint32_t)v;
    p[0] = (unsigned char)u, p[1] = (unsigned char)(u >> 8), p[2] = (unsigned char)(u >> 16), p[3] = (unsigned char)(u >> 24);
}

/* Rewrite an EXR written by io_exr_write (one part, scanlines) so that its data window is
 * (x0, y0)..(x0+w-1, y0+h-1) and its display window (0, 0)..(dw-1, dh-1): the two box2i
 * attributes, and each chunk's first scanline (shifted by y0; chunks of `lines` rows). */
static int dw_rewrite(unsigned char *b, size_t n, int x0, int y0, int w, int h, int dw, int dh)
{
    size_t pos = 8;
    int found = 0;
    while (pos < n && b[pos]) {
        const char *name = (const char *)b + pos;
        size_t tpos = pos + strlen(name) + 1;
        const char *type = (const char *)b + tpos;
        size_t spos = tpos + strlen(type) + 1, vpos = spos + 4;
        uint32_t len = dw_le32(b + spos);
        if (!strcmp(type, "box2i") && (!strcmp(name, "dataWindow") || !strcmp(name, "displayWindow"))) {
            int data = !strcmp(name, "dataWindow");
            dw_put32(b + vpos, data ? x0 : 0);
            dw_put32(b + vpos + 4, data ? y0 : 0);
            dw_put32(b + vpos + 8, data ? x0 + w - 1 : dw - 1);
            dw_put32(b + vpos + 12, data ? y0 + h - 1 : dh - 1);
            found++;
        }
        pos = vpos + len;
    }
    if (found != 2 || pos + 1 + 8 > n)
        return 0;
    /* the offset table follows the header's terminating 0; each chunk starts with its first y */
    const int lines = 16; /* io_exr_write writes ZIP: 16 scanlines per chunk */
    size_t table = pos + 1;
    for (int c = 0; c < (h + lines - 1) / lines; c++) {
        uint64_t off = 0;
        for (int k = 7; k >= 0; k--)
            off = off << 8 | b[table + 8 * (size_t)c + (size_t)k];
        if (off + 4 > n)
            return 0;
        dw_put32(b + off, (int32_t)dw_le32(b + off) + y0);
    }
    return 1;
}

/* docs/ao/README.md, "External G-buffers": an EXR is read over its data window; the display window
 * and the data window's origin are ignored. So pixel (0, 0) of the image, and of the G-buffer, is
 * the data window's first pixel, its size is the data window's, and the intrinsics (fx, fy, cx,
 * cy) must describe the data window's pixels. Both a crop (8x4 at (3, 2) of a 24x16 display) and
 * an overscan (40x1 starting at x = -5, wider than the display, like the fuzz_gbuffer slow units),
 * from a file and from memory. */
TEST(ao_external_exr_is_read_over_its_data_window_not_its_display_window)
{
    obs_context *ctx = obs_context_create();
    const struct { int x0, y0, w, h; } cases[] = {{3, 2, 8, 4}, {-5, 0, 40, 1}};
    for (int c = 0; c < 2; c++) {
        const int W = cases[c].w, H = cases[c].h;
        obs_image_f32 z = {0};
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &z), ctx);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                obs_image_f32_row(&z, y)[x] = 1.0f + (float)(x + 100 * y) / 64.0f;
        io_channel ch = {"Z", IO_PIXEL_FLOAT, &z, NULL};
        const char *path = test_path(test_tmpdir(), c == 0 ? "dw_crop.exr" : "dw_overscan.exr");
        CHECK_OK(io_exr_write(ctx, path, &ch, 1, NULL, 0), ctx);
        char *data = NULL;
        size_t len = 0;
        CHECK_OK(io_read_file(ctx, path, 1 << 24, &data, &len), ctx);
        CHECK(dw_rewrite((unsigned char *)data, len, cases[c].x0, cases[c].y0, W, H, 24, 16));
        FILE *f = fopen(path, "wb");
        CHECK(f && fwrite(data, 1, len, f) == len);
        if (f)
            fclose(f);
        for (int mem = 0; mem < 2; mem++) {
            io_image im;
            obs_context_clear_error(ctx);
            if (mem)
                CHECK_OK(io_image_read_memory(ctx, "dw.exr", data, len, &im), ctx);
            else
                CHECK_OK(io_image_read(ctx, path, &im), ctx);
            CHECK_EQ_INT(im.width, W);
            CHECK_EQ_INT(im.height, H);
            CHECK_EQ_INT(im.channel_count, 1);
            int same = 1;
            for (int y = 0; y < H; y++)
                same &= memcmp(obs_image_f32_row(&im.f32[0], y), obs_image_f32_row(&z, y), sizeof(float) * W) == 0;
            CHECK_MSG(same, "case %d (%s): the pixels are not the data window's, in order", c, mem ? "memory" : "file");
            ao_intrinsics k = ao_intrinsics_unknown();
            k.fx = k.fy = 20.0;
            k.cx = 0.5 * W;
            k.cy = 0.5 * H;
            ao_external_options o = ao_external_options_default();
            o.intrinsics = &k;
            ao_external e;
            CHECK_OK(ao_external_from_image(ctx, &im, &o, &e), ctx);
            CHECK_EQ_INT(e.input.width, W);
            CHECK_EQ_INT(e.input.height, H);
            CHECK(e.input.x0 == 0 && e.input.y0 == 0 && e.input.w == W && e.input.h == H);
            CHECK(obs_image_f32_row(&e.depth, 0)[0] == 1.0f);
            CHECK(obs_image_f32_row(&e.depth, H - 1)[W - 1] == obs_image_f32_row(&z, H - 1)[W - 1]);
            ao_external_free(&e);
            io_image_free(&im);
        }
        free(data);
        obs_image_f32_free(&z);
    }
    obs_context_destroy(ctx);
}
