/* The light volume's fast paths keep its bytes (docs/volume/light.md, step 10 and "Cost"):
 * the AVX-512F span, the AVX2 forms and the scalar forms give the same bytes; the guarded vector
 * exp and log1p of vol_light_avx2.c give libm's floats bit for bit (their double evaluations stay
 * within a few ulps of libm's, far inside the guard's 2^16 ulps); the slice's edge voxels on the
 * kernel path stay within the kernel path's bound of the per-tap path. No timings. */
#include "test.h"
#include "volume_test_util.h"

#include "core/obs.h"
#include "volume/vol.h"
#include "volume/vol_light_internal.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* |a - b| in ulps of b (doubles of one sign, b normal). */
static double ulps(double a, double b)
{
    return fabs(a - b) / (nextafter(fabs(b), INFINITY) - fabs(b));
}

static uint64_t lcg(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return *s >> 11;
}

TEST(volume_light_guarded_exp_gives_libm_floats)
{
    /* Arguments as the span makes them (-0.5 (sigma + sigma_p) ds <= 0): uniform in [-100, 0],
     * small ones down to 1e-300, the range ends, +-0, NaN; 2^20 values. */
    const int n = 1 << 20;
    double *x = (double *)malloc((size_t)n * sizeof(double)), *y = (double *)malloc((size_t)n * sizeof(double));
    float *f = (float *)malloc((size_t)n * sizeof(float));
    CHECK(x && y && f);
    if (!x || !y || !f) {
        free(x), free(y), free(f);
        return;
    }
    uint64_t s = 12345;
    for (int i = 0; i < n; i++) {
        const double u = (double)lcg(&s) / 9007199254740992.0; /* [0, 1) */
        x[i] = i % 4 == 3 ? -pow(10.0, -300.0 * u) : -100.0 * u;
    }
    const double special[] = {0.0, -0.0, -87.0, -87.0000001, -86.9999999, -1e-300, -745.2, NAN, -0.5, -1.0};
    for (int k = 0; k < (int)(sizeof special / sizeof special[0]); k++)
        x[k] = special[k];
    if (!vol_i_lv_exp_test_avx2(x, n, y, f)) {
        printf("built without AVX2: nothing to compare\n");
        free(x), free(y), free(f);
        return;
    }
    int differ = 0, near = 0;
    double worst = 0.0;
    for (int i = 0; i < n; i++) {
        const float ref = (float)exp(x[i]);
        differ += memcmp(&ref, &f[i], sizeof ref) != 0;
        if (x[i] >= -87.0 && x[i] <= 0.0) {
            worst = fmax(worst, ulps(y[i], exp(x[i])));
            near += (float)y[i] != ref; /* what the guard is for: 0 expected here too */
        }
    }
    printf("guarded exp: %d of %d floats differ from libm's; the unguarded double is within %.2f ulps of libm's, "
           "its float differs in %d\n", differ, n, worst, near);
    CHECK_EQ_INT(differ, 0);
    CHECK(worst <= 16.0); /* the guard assumes 2^15 */
    free(x), free(y), free(f);
}

TEST(volume_light_guarded_log1p_within_a_few_ulps_of_libm)
{
    /* lv_log4's log(1 - a) against libm's log1p(-a), a every float-spaced alpha the TF can give
     * in [2^-20, 1 - 2^-24] (the vector path's range): 2^20 values, log-uniform and uniform. */
    const int n = 1 << 20;
    double *a = (double *)malloc((size_t)n * sizeof(double)), *y = (double *)malloc((size_t)n * sizeof(double));
    CHECK(a && y);
    if (!a || !y) {
        free(a), free(y);
        return;
    }
    uint64_t s = 777;
    for (int i = 0; i < n; i++) {
        const double u = (double)lcg(&s) / 9007199254740992.0;
        float af = i & 1 ? (float)pow(2.0, -20.0 * u) : (float)u;
        if (af < 0x1p-20f)
            af = 0x1p-20f;
        if (af > 1.0f - 0x1p-24f)
            af = 1.0f - 0x1p-24f;
        a[i] = af;
    }
    if (!vol_i_lv_log1p_test_avx2(a, n, y)) {
        printf("built without AVX2: nothing to compare\n");
        free(a), free(y);
        return;
    }
    double worst = 0.0;
    for (int i = 0; i < n; i++)
        worst = fmax(worst, ulps(y[i], log1p(-a[i])));
    printf("log(1 - a) within %.2f ulps of libm's log1p(-a)\n", worst);
    CHECK(worst <= 16.0);
    free(a), free(y);
}

static int lv_same(const vol_light_volume *a, const vol_light_volume *b)
{
    if (a->nx != b->nx || a->ny != b->ny || a->nz != b->nz)
        return 0;
    const size_t bytes = (size_t)a->nx * a->ny * a->nz * sizeof(float);
    int same = memcmp(a->l, b->l, bytes) == 0;
    for (int c = 0; c < 3; c++)
        same = same && memcmp(a->c[c], b->c[c], bytes) == 0;
    return same;
}

/* Build the light volume with the default instruction set, OBS_ISA=avx2 and OBS_ISA=scalar (each
 * build checked OK) and return whether the three are byte-identical (0 if a build failed). */
static int builds_agree_across_isas(obs_context *ctx, obs_pool *pl, const vol_grid *g, const vol_tf *tf,
                                    const vol_light *L, const vol_lv_params *p)
{
    static const char *const isa[3] = {NULL, "avx2", "scalar"};
    vol_light_volume v[3];
    int built = 0;
    for (; built < 3; built++) {
        if (isa[built])
            setenv("OBS_ISA", isa[built], 1);
        else
            unsetenv("OBS_ISA");
        const obs_status st = vol_light_volume_build(ctx, pl, g, tf, L, p, &v[built]);
        if (st != OBS_STATUS_OK) { /* a failure of the test (CHECK_* would return without a value) */
            test_fail_at(__FILE__, __LINE__, "build (OBS_ISA=%s): %s", isa[built] ? isa[built] : "default",
                         obs_context_last_error(ctx));
            break;
        }
    }
    unsetenv("OBS_ISA");
    const int same = built == 3 && lv_same(&v[0], &v[1]) && lv_same(&v[0], &v[2]);
    for (int k = 0; k < built; k++)
        vol_light_volume_free(&v[k]);
    return same;
}

TEST(volume_light_avx512_avx2_scalar_bit_for_bit)
{
    /* The default (AVX-512F span where the CPU has it), OBS_ISA=avx2 and OBS_ISA=scalar: the same
     * bytes. Dense random data (every voxel classified, most with alpha > 0) under kappa 1, 300
     * (exp arguments beyond -87: libm's lanes; one volume with NaN voxels, classified as 0) and 1e-39 (sigma_t below the normal floats:
     * libm's lanes), spans of 16 and not, the 3x3 kernel and wider ones, 1 and 2 threads. */
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    const int dims[3][3] = {{37, 29, 23}, {64, 20, 33}, {17, 40, 9}};
    vol_tf tf;
    memset(&tf, 0, sizeof tf);
    vol_tf_point pts[3] = {{0.1, {0.0f, 0.0f, 0.0f, 0.0f}}, {0.5, {0.9f, 0.6f, 0.3f, 0.2f}}, {1.0, {1.0f, 1.0f, 1.0f, 0.95f}}};
    snprintf(tf.name, sizeof tf.name, "speed");
    tf.count = 3;
    tf.points = pts;
    const vol_light Ls[5] = {vtu_dir_light(0, 0, 1), vtu_dir_light(0, 0, -1), vtu_dir_light(0.3, -0.5, 0.8),
                             vtu_dir_light(-0.7, 0.2, 0.1), vtu_dir_light(0.02, 0.05, -1)};
    const double kappas[3] = {1.0, 300.0, 1e-39};
    int cases = 0, differ = 0;
    for (int v = 0; v < 3; v++) {
        vol_grid g;
        const double sp[3] = {1.0, v == 1 ? 0.8 : 1.0, v == 2 ? 1.3 : 1.0};
        CHECK_OK(vol_grid_alloc(ctx, dims[v][0], dims[v][1], dims[v][2], sp, &g), ctx);
        const size_t n = (size_t)g.nx * g.ny * g.nz;
        uint64_t s = 99 + (uint64_t)v;
        for (size_t i = 0; i < n; i++)
            g.data[i] = v == 0 && i % 101 == 7 ? NAN : (float)((double)lcg(&s) / 9007199254740992.0);
        vol_grid_update_range(&g);
        for (int l = 0; l < 5; l++)
            for (int k = 0; k < 3; k++) {
                vol_lv_params p = vol_lv_params_default();
                p.kappa = kappas[k];
                p.blend_second = (l + k) & 1;
                p.cone_angle_deg = l == 3 ? 70.0 : 45.0;
                obs_pool *pl = (l + v) & 1 ? pool : NULL;
                const int same = builds_agree_across_isas(ctx, pl, &g, &tf, &Ls[l], &p);
                if (!same)
                    printf("differ: volume %d, light %d, kappa %g\n", v, l, kappas[k]);
                differ += !same;
                cases++;
            }
        vol_grid_free(&g);
    }
    printf("%d cases, %d differ (isa %d on this CPU)\n", cases, differ, vol_i_lv_isa());
    CHECK_EQ_INT(differ, 0);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

/* An entry transmittance that varies over the box's outside (vol.h vol_occluder.entry). */
static float entry_wave(void *user, const double x[3])
{
    (void)user;
    return (float)(0.5 + 0.4 * sin(0.7 * x[0] + 0.3 * x[1] - 0.2 * x[2]));
}

TEST(volume_light_edge_voxels_on_the_kernel_path_stay_within_its_bound)
{
    /* The slice's edge voxels read the slice buffers' border padding on the kernel path (before:
     * the per-tap path). Against the per-tap reference (OBS_LV_PER_TAP=1), the edge voxels alone
     * (a face of the volume other than the entry face) differ by float rounding only, within the
     * kernel path's bound 1e-5 (volume_light_kernel_path_matches_per_tap_path); a light along +z
     * and an oblique one through a volume that is dense at its sides, without and with an entry
     * transmittance that varies over the outside (the light entering by the side faces). */
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {1.0, 1.0, 1.0};
    CHECK_OK(vol_grid_alloc(ctx, 24, 24, 24, sp, &g), ctx);
    uint64_t s = 5;
    for (size_t i = 0; i < (size_t)24 * 24 * 24; i++)
        g.data[i] = (float)((double)lcg(&s) / 9007199254740992.0);
    vol_grid_update_range(&g);
    vol_tf tf;
    memset(&tf, 0, sizeof tf);
    vol_tf_point pts[2] = {{0.0, {0.2f, 0.5f, 0.9f, 0.0f}}, {1.0, {1.0f, 0.7f, 0.1f, 0.4f}}};
    snprintf(tf.name, sizeof tf.name, "edge");
    tf.count = 2;
    tf.points = pts;
    const vol_light Ls[2] = {vtu_dir_light(0, 0, 1), vtu_dir_light(0.3, -0.5, 0.8)};
    /* without and with an entry transmittance (the edge voxels' l then refetched, lv_span_l_entry) */
    const vol_occluder entry = {NULL, 0.0, entry_wave, NULL};
    for (int l = 0; l < 4; l++) {
        vol_lv_params p = vol_lv_params_default();
        p.blend_second = 0;
        const vol_occluder *oc = l >= 2 ? &entry : NULL;
        vol_light_volume a, t;
        unsetenv("OBS_LV_PER_TAP");
        CHECK_OK(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &Ls[l & 1], &p, oc, &a), ctx);
        setenv("OBS_LV_PER_TAP", "1", 1);
        CHECK_OK(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &Ls[l & 1], &p, oc, &t), ctx);
        unsetenv("OBS_LV_PER_TAP");
        double worst_edge = 0.0;
        size_t edge_differ = 0;
        for (int k = 1; k < 24; k++)
            for (int j = 0; j < 24; j++)
                for (int i = 0; i < 24; i++) {
                    if (!(i == 0 || j == 0 || i == 23 || j == 23))
                        continue;
                    const size_t q = ((size_t)k * 24 + j) * 24 + i;
                    double d = fabs((double)a.l[q] - t.l[q]);
                    for (int c = 0; c < 3; c++)
                        d = fmax(d, fabs((double)a.c[c][q] - t.c[c][q]));
                    worst_edge = fmax(worst_edge, d);
                    edge_differ += d > 0.0;
                }
        printf("light %d%s: edge voxels, kernel path vs per-tap: max %.3g (%zu differ)\n", l & 1,
               oc ? ", entry" : "", worst_edge, edge_differ);
        CHECK(worst_edge <= 1e-5);
        vol_light_volume_free(&a);
        vol_light_volume_free(&t);
    }
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_classification_tables_and_empty_runs_bit_for_bit)
{
    /* The AVX-512F classification picks a TF of at most 7 points by permutation (its padded tables
     * in one register) and gathers beyond that, and stores empty space 16 values at a time: TFs of
     * 1, 2, 6, 7 (the largest by permutation), 8 and 12 points, each with a leading run of +0
     * points, over data whose rows mix long empty runs (below the run's end) with values spread
     * over the whole range, rows of 37, 16 and 9 values; the default, OBS_ISA=avx2 and scalar give
     * the same bytes, 1 and 2 threads. */
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    const int dims[3][3] = {{37, 21, 13}, {16, 18, 11}, {9, 33, 12}};
    const int counts[6] = {1, 2, 6, 7, 8, 12};
    const vol_light Ls[2] = {vtu_dir_light(0, 0, 1), vtu_dir_light(0.3, -0.5, 0.8)};
    int cases = 0, differ = 0;
    for (int v = 0; v < 3; v++) {
        vol_grid g;
        const double sp[3] = {1.0, 1.0, 1.0};
        CHECK_OK(vol_grid_alloc(ctx, dims[v][0], dims[v][1], dims[v][2], sp, &g), ctx);
        const size_t n = (size_t)g.nx * g.ny * g.nz;
        uint64_t s = 7 + (uint64_t)v;
        for (size_t i = 0; i < n; i++) {
            const double r = (double)lcg(&s) / 9007199254740992.0;
            /* runs of 0..40 values at or below 0.05 (every TF's +0 run reaches 0.1), then values
             * anywhere in [0, 1] */
            g.data[i] = ((i / 23) % 3 == 0) ? (float)(0.05 * r) : (float)r;
        }
        vol_grid_update_range(&g);
        for (int t = 0; t < 6; t++) {
            vol_tf_point pts[12];
            const int np = counts[t];
            for (int q = 0; q < np; q++) {
                /* point 0 at 0.1 (+0), the others spread up to 1 */
                pts[q].value = np == 1 ? 0.5 : 0.1 + 0.9 * q / (np - 1);
                const float a = q == 0 || (q == 1 && np > 2) ? 0.0f : (float)(0.05 + 0.9 * q / np);
                pts[q].rgba[0] = q == 0 ? 0.0f : (float)q / np;
                pts[q].rgba[1] = q == 0 ? 0.0f : 1.0f - (float)q / (2 * np);
                pts[q].rgba[2] = q == 0 ? 0.0f : 0.3f;
                pts[q].rgba[3] = np == 1 ? 0.4f : a;
            }
            vol_tf tf;
            memset(&tf, 0, sizeof tf);
            snprintf(tf.name, sizeof tf.name, "tables");
            tf.count = np;
            tf.points = pts;
            for (int l = 0; l < 2; l++) {
                vol_lv_params p = vol_lv_params_default();
                p.kappa = 2.0;
                obs_pool *pl = (l + t) & 1 ? pool : NULL;
                const int same = builds_agree_across_isas(ctx, pl, &g, &tf, &Ls[l], &p);
                if (!same)
                    printf("differ: volume %d, TF of %d points, light %d\n", v, np, l);
                differ += !same;
                cases++;
            }
        }
        vol_grid_free(&g);
    }
    printf("%d cases, %d differ (isa %d on this CPU)\n", cases, differ, vol_i_lv_isa());
    CHECK_EQ_INT(differ, 0);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}
