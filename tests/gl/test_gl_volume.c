/* test_gl_volume.c: our light volume (vol_light_volume_build, src/volume/vol_light.c) against the
 * project's GLSL port of the propagation (glsl_volume.c), run slice by slice into 3D textures on
 * Mesa's llvmpipe, on the synthetic bucky and sphere at 32^3: directional lights along each axis
 * and one oblique, a point light outside and one inside, scales 1 and 2, blend on and off.
 * The figures are in docs/volume/light.md, "GLSL port". */
#include "gl/glsl_volume.h"
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE
typedef struct gv_diff {
    double max_abs;  /* over l and c, every voxel */
    size_t unequal;  /* values not bit-identical */
    size_t n;
} gv_diff;

static gv_diff lv_diff(const vol_light_volume *a, const vol_light_volume *b)
{
    gv_diff d = {0.0, 0, 0};
    const size_t n = (size_t)a->nx * a->ny * a->nz;
    const float *pa[4] = {a->l, a->c[0], a->c[1], a->c[2]}, *pb[4] = {b->l, b->c[0], b->c[1], b->c[2]};
    for (int c = 0; c < 4; c++)
        for (size_t i = 0; i < n; i++) {
            const double x = pa[c][i], y = pb[c][i];
            const double e = (x == x && y == y) ? fabs(x - y) : INFINITY;
            d.max_abs = e > d.max_abs ? e : d.max_abs;
            d.unequal += memcmp(&pa[c][i], &pb[c][i], sizeof(float)) != 0;
            d.n++;
        }
    return d;
}

typedef struct gv_case {
    const char *synth;     /* "bucky" or "sphere" */
    int point;             /* 0 directional (v = travel direction), 1 point (v = position, in voxels from the centre) */
    double v[3];
    int scale, blend;
    double cone;
} gv_case;

/* The sphere's TF: 0 clear, 1 an orange absorber (alpha 0.3 per voxel). */
static int sphere_tf(obs_context *ctx, vol_tf *tf)
{
    const char *js = "{\"name\": \"sphere-orange\", \"points\": [[0, 1, 1, 1, 0], [1, 0.9, 0.6, 0.3, 0.3]]}";
    return vol_tf_parse_json(ctx, js, "sphere_tf", tf) == OBS_STATUS_OK;
}

/* Bounds (measured, then rounded up; docs/volume/light.md, "GLSL port"): float rounding of
 * values in [0, 1]. Ours against the port's per-tap form: the per-tap path (OBS_LV_PER_TAP=1); ours by
 * default (directional lights take the gathered-kernel path: the cone's sums in another order). */
#define GV_TOL_PER_TAP 1e-6
#define GV_TOL_DEFAULT 1e-5

static void run_case(glh *g, const gv_case *cs, double *worst_tap, double *worst_def)
{
    obs_context *ctx = obs_context_create();
    vol_grid grid;
    CHECK_OK(vol_synth(ctx, cs->synth, 32, &grid), ctx);
    vol_tf tf;
    if (!strcmp(cs->synth, "bucky"))
        CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    else
        CHECK(sphere_tf(ctx, &tf));
    vol_light L;
    memset(&L, 0, sizeof L);
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    if (cs->point) {
        L.type = OBS_LIGHT_POINT;
        double lo[3], hi[3];
        vol_grid_bounds(&grid, lo, hi);
        for (int c = 0; c < 3; c++)
            L.position[c] = 0.5 * (lo[c] + hi[c]) + cs->v[c] * grid.spacing[c];
    } else {
        L.type = OBS_LIGHT_DIRECTIONAL;
        double n = sqrt(cs->v[0] * cs->v[0] + cs->v[1] * cs->v[1] + cs->v[2] * cs->v[2]);
        for (int c = 0; c < 3; c++)
            L.direction[c] = cs->v[c] / n;
    }
    vol_lv_params p = vol_lv_params_default();
    p.scale = cs->scale;
    p.blend_second = cs->blend;
    p.cone_angle_deg = cs->cone;
    vol_light_volume ours, tap, gl;
    unsetenv("OBS_ISA");
    CHECK_OK(vol_light_volume_build(ctx, NULL, &grid, &tf, &L, &p, &ours), ctx);
    setenv("OBS_LV_PER_TAP", "1", 1); /* the per-tap reference path (vol_light.c) */
    CHECK_OK(vol_light_volume_build(ctx, NULL, &grid, &tf, &L, &p, &tap), ctx);
    unsetenv("OBS_LV_PER_TAP");
    glsl_volume r;
    const int built = glsl_volume_build(g, ctx, &grid, &tf, &L, &p, &r);
    CHECK_MSG(built, "%s: the port was not built", cs->synth);
    if (built) {
        double t0 = obs_time_now();
        CHECK_OK(glsl_volume_read(g, &r, ctx, &gl), ctx);
        const double t_gl = obs_time_now() - t0;
        CHECK_EQ_INT(gl.nx, ours.nx);
        CHECK_EQ_INT(gl.ny, ours.ny);
        CHECK_EQ_INT(gl.nz, ours.nz);
        CHECK_EQ_INT(gl.face0, ours.face0);
        CHECK_EQ_INT(gl.face1, ours.face1);
        CHECK(gl.blend_weight == ours.blend_weight);
        if (gl.nx == ours.nx && gl.ny == ours.ny && gl.nz == ours.nz) {
            const gv_diff dt = lv_diff(&tap, &gl), dd = lv_diff(&ours, &gl);
            printf("  %s, %s (%g, %g, %g), scale %d, blend %d (faces %d, %d, w %.4f), cone %g: %dx%dx%d, llvmpipe "
                   "%.0f ms (first run, with compile); |per-tap - GLSL| max %.3g, %zu of %zu values not bit-identical; "
                   "|default - GLSL| max %.3g (%zu)\n",
                   cs->synth, cs->point ? "point" : "directional", cs->v[0], cs->v[1], cs->v[2], cs->scale, cs->blend,
                   ours.face0, ours.face1, (double)ours.blend_weight, cs->cone, gl.nx, gl.ny, gl.nz, 1e3 * t_gl,
                   dt.max_abs, dt.unequal, dt.n, dd.max_abs, dd.unequal);
            fflush(stdout);
            CHECK_MSG(dt.max_abs <= GV_TOL_PER_TAP, "per-tap: max |ours - llvmpipe| %.3g > %g", dt.max_abs,
                      GV_TOL_PER_TAP);
            CHECK_MSG(dd.max_abs <= GV_TOL_DEFAULT, "default: max |ours - llvmpipe| %.3g > %g", dd.max_abs,
                      GV_TOL_DEFAULT);
            *worst_tap = fmax(*worst_tap, dt.max_abs);
            *worst_def = fmax(*worst_def, dd.max_abs);
            /* the case is not trivial: some light is absorbed */
            size_t shadowed = 0;
            for (size_t i = 0; i < (size_t)gl.nx * gl.ny * gl.nz; i++)
                shadowed += gl.l[i] < 0.9f;
            CHECK_MSG(shadowed > 100, "only %zu shadowed voxels", shadowed);
        }
        vol_light_volume_free(&gl);
    }
    glsl_volume_free(g, &r);
    vol_light_volume_free(&ours);
    vol_light_volume_free(&tap);
    vol_tf_free(&tf);
    vol_grid_free(&grid);
    obs_context_destroy(ctx);
}
#endif

TEST(gl_volume_light_volume_matches_its_glsl_port_on_llvmpipe_directional)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    const gv_case cases[] = {
        {"bucky", 0, {-1, 0, 0}, 1, 1, 45.0},     /* along -x: light enters by +x */
        {"bucky", 0, {0, 1, 0}, 1, 0, 45.0},      /* along +y */
        {"sphere", 0, {0, 0, -1}, 1, 1, 45.0},    /* along -z */
        {"bucky", 0, {0.3, -0.5, 0.8}, 1, 1, 45.0}, /* oblique, blended */
        {"bucky", 0, {0.3, -0.5, 0.8}, 1, 0, 45.0},
        {"sphere", 0, {-0.6, 0.45, 0.3}, 2, 1, 45.0},
        {"bucky", 0, {0.5, 0.2, -0.7}, 2, 0, 70.0}, /* a wide cone: R = 2..3 rings */
    };
    double wt = 0.0, wd = 0.0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&g, &cases[i], &wt, &wd);
    printf("  worst: per-tap %.3g, default %.3g\n", wt, wd);
    glh_close(&g);
#endif
}

TEST(gl_volume_light_volume_matches_its_glsl_port_on_llvmpipe_point)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    const gv_case cases[] = {
        {"bucky", 1, {-40, 12, 50}, 1, 1, 45.0},  /* outside, in voxels from the centre */
        {"sphere", 1, {30, -45, 8}, 1, 0, 45.0},
        {"bucky", 1, {-40, 12, 50}, 2, 1, 45.0},
        {"bucky", 1, {3.3, -2.2, 5.1}, 1, 1, 45.0}, /* inside: seed slices */
        {"sphere", 1, {-4.4, 1.7, 0.6}, 2, 0, 30.0},
    };
    double wt = 0.0, wd = 0.0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&g, &cases[i], &wt, &wd);
    printf("  worst: per-tap %.3g, default %.3g\n", wt, wd);
    glh_close(&g);
#endif
}
