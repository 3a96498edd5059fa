/* test_truth_ao.c: the ray-traced AO ground truth (src/truth/truth_ao.c, docs/truth.md).
 *
 * Analytic cases (issue 3, item 6), each through the whole pipeline (rasterized G-buffer, then
 * Embree), with the exact value derived in the comment and, where a closed form needs an
 * idealisation (infinite planes), an independent quadrature of the finite scene as well:
 *   - an open plane: visibility exactly 1 (any self-hit is a bug);
 *   - a point under a sphere: cosine occlusion sin^2(alpha), uniform 1 - cos(alpha);
 *   - a point in the inside corner of a floor and a wall;
 *   - a point inside a closed box: visibility exactly 0;
 * then the 1/sqrt(N) convergence, thread-count determinism, the obscurance estimators against a
 * quadrature, parameter refusals, and the CLI. */
#include "io/io.h"
#include "raster/raster.h"
#include "scene_util.h"
#include "test.h"
#include "truth/truth.h"
#include "truth/truth_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

/* ---- scene building ------------------------------------------------------------------------- */

typedef struct mesh_b {
    float *pos;
    uint32_t *idx;
    uint32_t nv, nt, cap_v, cap_t;
} mesh_b;

static uint32_t mb_vertex(mesh_b *m, double x, double y, double z)
{
    if (m->nv == m->cap_v) {
        m->cap_v = m->cap_v ? 2 * m->cap_v : 1024;
        m->pos = (float *)realloc(m->pos, sizeof(float) * 3 * m->cap_v);
    }
    m->pos[3 * m->nv] = (float)x;
    m->pos[3 * m->nv + 1] = (float)y;
    m->pos[3 * m->nv + 2] = (float)z;
    return m->nv++;
}

static void mb_tri(mesh_b *m, uint32_t a, uint32_t b, uint32_t c)
{
    if (m->nt == m->cap_t) {
        m->cap_t = m->cap_t ? 2 * m->cap_t : 1024;
        m->idx = (uint32_t *)realloc(m->idx, sizeof(uint32_t) * 3 * m->cap_t);
    }
    m->idx[3 * m->nt] = a;
    m->idx[3 * m->nt + 1] = b;
    m->idx[3 * m->nt + 2] = c;
    m->nt++;
}

/* A grid quad: corner o, edges u and v, n x n cells. */
static void mb_quad(mesh_b *m, const double o[3], const double u[3], const double v[3], int n)
{
    uint32_t first = m->nv;
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            double s = (double)i / n, t = (double)j / n;
            mb_vertex(m, o[0] + s * u[0] + t * v[0], o[1] + s * u[1] + t * v[1], o[2] + s * u[2] + t * v[2]);
        }
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            uint32_t a = first + (uint32_t)(j * (n + 1) + i), b = a + 1, c = a + (uint32_t)(n + 1), d = c + 1;
            mb_tri(m, a, b, d);
            mb_tri(m, a, d, c);
        }
}

/* A horizontal (y = y0) plane centred at (cx, cz), half-size h, n x n cells. */
static void mb_floor(mesh_b *m, double cx, double y0, double cz, double h, int n)
{
    double o[3] = {cx - h, y0, cz + h}, u[3] = {2 * h, 0, 0}, v[3] = {0, 0, -2 * h};
    mb_quad(m, o, u, v, n);
}

/* A UV sphere (slices x stacks), vertices on the sphere. */
static void mb_sphere(mesh_b *m, double cx, double cy, double cz, double R, int slices, int stacks)
{
    uint32_t first = m->nv;
    for (int j = 0; j <= stacks; j++)
        for (int i = 0; i <= slices; i++) {
            double th = OBS_PI * j / stacks, ph = 2 * OBS_PI * (i % slices) / slices;
            mb_vertex(m, cx + R * sin(th) * cos(ph), cy + R * cos(th), cz - R * sin(th) * sin(ph));
        }
    for (int j = 0; j < stacks; j++)
        for (int i = 0; i < slices; i++) {
            uint32_t a = first + (uint32_t)(j * (slices + 1) + i), b = a + 1, c = a + (uint32_t)(slices + 1), d = c + 1;
            mb_tri(m, a, c, b);
            mb_tri(m, b, c, d);
        }
}

static void mb_to_scene(mesh_b *m, obs_scene *s)
{
    tu_scene_one_mesh(s, m->pos, m->nv, NULL, m->idx, m->nt);
    free(m->pos);
    free(m->idx);
    memset(m, 0, sizeof *m);
}

/* ---- running the pipeline ------------------------------------------------------------------- */

typedef struct ao_run {
    obs_context *ctx;
    obs_scene scene;
    truth_scene *ts;
    obs_camera cam;
    rast_gbuffer gb;
    rast_params rp;
} ao_run;

/* Rasterize the G-buffer for a camera at eye looking at target, and build the Embree scene. */
static int run_setup(ao_run *R, obs_vec3 eye, obs_vec3 target, int W, int H)
{
    R->ctx = obs_context_create();
    R->cam = obs_camera_look_at(eye, target, obs_v3(0, 1, 0), 0.6f, 0.01f, 1e5f);
    R->rp = rast_params_default();
    R->rp.width = W;
    R->rp.height = H;
    if (rast_gbuffer_alloc(R->ctx, &R->rp, &R->gb) != OBS_STATUS_OK)
        return 0;
    rast_view v = {R->cam};
    if (rast_render(R->ctx, NULL, &R->scene, &v, 1, &R->rp, &R->gb, NULL) != OBS_STATUS_OK)
        return 0;
    return truth_scene_create(R->ctx, &R->scene, TRUTH_BUILD_MEDIUM, &R->ts) == OBS_STATUS_OK;
}

static void run_free(ao_run *R)
{
    truth_scene_destroy(R->ts);
    rast_gbuffer_free(&R->gb);
    obs_scene_free(&R->scene);
    obs_context_destroy(R->ctx);
}

static obs_status run_ao(ao_run *R, obs_pool *pool, const truth_ao_params *p, truth_ao_result *res)
{
    return truth_ao_render(R->ctx, pool, R->ts, &R->scene, &R->cam, &R->gb, p, res);
}

static float px(const obs_image_f32 *im, int x, int y) { return obs_image_f32_row(im, y)[x]; }

/* Converged single-pixel runs take a few million samples: raise the context's sample limit. */
static void allow_samples(obs_context *ctx, int64_t n)
{
    obs_limits lim = *obs_context_limits(ctx);
    lim.max_samples = n;
    obs_context_set_limits(ctx, &lim);
}

/* ---- open plane ----------------------------------------------------------------------------- */

/* The samples at which a pixel whose outcomes all agree stops: the first multiple of the batch,
 * from min_samples on, whose floor is within the target (704 for the defaults). */
static int64_t agreeing_stop(const truth_ao_params *p)
{
    int64_t n = p->min_samples;
    while (n < p->max_samples && truth_ao_error_floor(n) > p->target_error)
        n += p->batch;
    return n;
}

/* Every surface pixel sees only sky: every single ray must be unoccluded, so the mean is exactly
 * 1, the replicates agree and the error bar is the floor: the pixel stops at the first count
 * whose floor is within the target (704 samples), never before. Three planes stress
 * the self-intersection offset: a fine grid near the origin, the same grid moved to large
 * coordinates and tilted, and one huge two-triangle quad (Embree's plane test works on
 * v0 - origin, so a large triangle is the hard case). Both origins, both normals. */
static void check_open_plane_on(ao_run *Rp, const char *what, const char *layout)
{
    ao_run R = *Rp;
    static const truth_ao_estimator est[] = {TRUTH_AO_COS, TRUTH_AO_UNIF, TRUTH_AO_OBS_SAO_B};
    static const float radii[] = {1.0f, INFINITY};
    for (int e = 0; e < 3; e++)
        for (int ri = 0; ri < 2; ri++)
            for (int org = 0; org < 2; org++)
                for (int nrm = 0; nrm < 2; nrm++) {
                    if (est[e] == TRUTH_AO_OBS_SAO_B && isinf(radii[ri]))
                        continue;
                    truth_ao_params p = truth_ao_params_default();
                    p.estimator = est[e];
                    p.radius = radii[ri];
                    p.origin = (truth_ao_origin)org;
                    p.normal = (truth_ao_normal)nrm;
                    p.seed = 7;
                    truth_ao_result res;
                    CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
                    int64_t surface = 0;
                    for (int y = 0; y < res.height; y++)
                        for (int x = 0; x < res.width; x++) {
                            if (px(&res.count, x, y) == 0.0f)
                                continue;
                            surface++;
                            CHECK_MSG(px(&res.mean, x, y) == 1.0f &&
                                          px(&res.std_error, x, y) == (float)truth_ao_error_floor(agreeing_stop(&p)),
                                      "%s (%s scene), %s, r=%g, origin %d, normal %d: pixel (%d,%d) mean %.9g se %g (a self-hit)",
                                      what, layout, truth_ao_estimator_name(est[e]), (double)radii[ri], org, nrm, x, y,
                                      (double)px(&res.mean, x, y), (double)px(&res.std_error, x, y));
                            CHECK_EQ_INT(px(&res.count, x, y), agreeing_stop(&p));
                        }
                    CHECK_MSG(surface > 600, "%s: only %lld surface pixels", what, (long long)surface);
                    CHECK_EQ_INT(res.stats.pixels_surface, surface);
                    CHECK_EQ_INT(res.stats.pixels_converged, surface);
                    CHECK_EQ_INT(agreeing_stop(&p), 704);
                    CHECK_EQ_INT(res.stats.rays, (uint64_t)surface * 704);
                    truth_ao_result_free(&res);
                }
}


static void check_open_plane(const char *what, mesh_b *mb, const obs_mat4 *world, obs_vec3 eye, obs_vec3 target)
{
    ao_run R;
    memset(&R, 0, sizeof R);
    mb_to_scene(mb, &R.scene);
    R.scene.instances[0].world = *world;
    obs_scene_update_bounds(&R.scene);
    CHECK_MSG(run_setup(&R, eye, target, 40, 30), "%s: setup failed: %s", what, obs_context_last_error(R.ctx));
    check_open_plane_on(&R, what, "flat");
    /* the same checks on the two-level scene (the default is flat) */
    truth_scene_destroy(R.ts);
    truth_scene_options so = truth_scene_options_default();
    so.layout = TRUTH_SCENE_INSTANCED;
    CHECK_OK(truth_scene_create_ex(R.ctx, &R.scene, &so, &R.ts), R.ctx);
    check_open_plane_on(&R, what, "two-level");
    run_free(&R);
}

TEST(truth_open_plane_has_visibility_one)
{
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 20, 40);
    obs_mat4 id = obs_mat4_identity();
    check_open_plane("grid plane", &mb, &id, obs_v3(3, 5, 8), obs_v3(0.3f, 0, -0.2f));
    if (test_failed())
        return;
    /* the same grid at (1000, -300, 2500), tilted by 30 degrees about x then 20 about z */
    mb_floor(&mb, 0, 0, 0, 20, 40);
    double a = 30 * OBS_PI / 180, b = 20 * OBS_PI / 180;
    obs_mat4 rx = obs_mat4_from_quat((obs_vec4){(float)sin(a / 2), 0, 0, (float)cos(a / 2)});
    obs_mat4 rz = obs_mat4_from_quat((obs_vec4){0, 0, (float)sin(b / 2), (float)cos(b / 2)});
    obs_mat4 w = obs_mat4_mul(obs_mat4_translation(obs_v3(1000, -300, 2500)), obs_mat4_mul(rz, rx));
    check_open_plane("far tilted plane", &mb, &w, obs_mat4_mul_point(w, obs_v3(3, 5, 8)),
                     obs_mat4_mul_point(w, obs_v3(0.3f, 0, -0.2f)));
    if (test_failed())
        return;
    /* one quad of 20 km, two triangles */
    mb_floor(&mb, 0, 0, 0, 10000, 1);
    check_open_plane("huge quad", &mb, &id, obs_v3(3, 5, 8), obs_v3(0.3f, 0, -0.2f));
}

/* VOL on a lone plane: the ball's points in front of the plane are seen from the eye, those
 * behind are not: exactly half of the ball, so V = 1/2 (ao.md 1.1: "flat = 0.5"). */
TEST(truth_vol_of_open_plane_is_one_half)
{
    ao_run R;
    memset(&R, 0, sizeof R);
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 20, 40);
    mb_to_scene(&mb, &R.scene);
    CHECK_MSG(run_setup(&R, obs_v3(3, 5, 8), obs_v3(0.3f, 0, -0.2f), 12, 9), "setup: %s", obs_context_last_error(R.ctx));
    truth_ao_params p = truth_ao_params_default();
    p.estimator = TRUTH_AO_VOL;
    p.radius = 0.5f;
    p.target_error = 0.002;
    p.max_samples = 1 << 16;
    truth_ao_result res;
    CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
    int n = 0;
    for (int y = 0; y < res.height; y++)
        for (int x = 0; x < res.width; x++) {
            float c = px(&res.count, x, y), m = px(&res.mean, x, y), se = px(&res.std_error, x, y);
            CHECK(c > 0);
            CHECK_MSG(fabs(m - 0.5) <= 3 * se + 1e-6, "pixel (%d,%d): %.6f +- %.2g, want 0.5", x, y, m, se);
            CHECK(se <= 0.002);
            n++;
        }
    CHECK_EQ_INT(n, 12 * 9);
    truth_ao_result_free(&res);
    /* the same through an orthographic camera: segments start on the view plane */
    obs_camera oc = R.cam;
    oc.projection = OBS_PROJECTION_ORTHOGRAPHIC;
    oc.xmag = 2.0f;
    oc.ymag = 1.5f;
    oc.znear = 0.0f;
    oc.zfar = 100.0f;
    R.cam = oc;
    rast_view v = {oc};
    CHECK_OK(rast_render(R.ctx, NULL, &R.scene, &v, 1, &R.rp, &R.gb, NULL), R.ctx);
    CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
    n = 0;
    for (int y = 0; y < res.height; y++)
        for (int x = 0; x < res.width; x++) {
            float m = px(&res.mean, x, y), se = px(&res.std_error, x, y);
            CHECK(px(&res.count, x, y) > 0);
            CHECK_MSG(fabs(m - 0.5) <= 3 * se + 1e-6, "orthographic pixel (%d,%d): %.6f +- %.2g, want 0.5", x, y, m, se);
            n++;
        }
    CHECK_EQ_INT(n, 12 * 9);
    truth_ao_result_free(&res);
    run_free(&R);
}

/* ---- a point under a sphere ------------------------------------------------------------------- */

/* A point p on the floor, a sphere of radius R centred at p + h n. The sphere subtends a cap of
 * half-angle alpha, sin(alpha) = R/h, around n. With r = infinity:
 *   cosine-weighted: O = (1/pi) Int_cap cos(theta) dw = 2 Int_0^alpha cos sin dtheta = sin^2(alpha);
 *   uniform:         O = (1/2pi) Int_cap dw = 1 - cos(alpha).
 * The sphere is a 256 x 128 UV sphere with its vertices on the true sphere: its faces lie
 * between radius R cos^2(pi/256) and R, so the exact occlusion of the mesh is within
 * 2 (1 - cos^2(pi/256)) sin^2(alpha) < 1e-4 of the formula (tess_tol below). */
#define CAP_H 2.0
#define CAP_R 1.0
static const double k_px = 0.013, k_pz = 0.021; /* p, off the grid's vertices */

static int cap_setup(ao_run *R)
{
    memset(R, 0, sizeof *R);
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 50, 20);
    mb_sphere(&mb, k_px, CAP_H, k_pz, CAP_R, 256, 128);
    mb_to_scene(&mb, &R->scene);
    /* a 1x1 image: its pixel centre ray is the look-at ray, so the pixel's point is p */
    return run_setup(R, obs_v3(8, 1, 0.5f), obs_v3((float)k_px, 0, (float)k_pz), 1, 1);
}

static const double tess_tol = 1e-4;

TEST(truth_point_under_sphere_matches_cap_formula)
{
    ao_run R;
    CHECK_MSG(cap_setup(&R), "setup: %s", obs_context_last_error(R.ctx));
    allow_samples(R.ctx, (int64_t)1 << 22);
    double s = CAP_R / CAP_H, c = sqrt(1 - s * s);
    struct { truth_ao_estimator e; double want; } cases[] = {{TRUTH_AO_COS, 1 - s * s}, {TRUTH_AO_UNIF, c}};
    for (int k = 0; k < 2; k++)
        for (int org = 0; org < 2; org++) {
            truth_ao_params p = truth_ao_params_default();
            p.estimator = cases[k].e;
            p.radius = INFINITY;
            p.origin = (truth_ao_origin)org;
            p.target_error = 3e-4; /* so that 3 standard errors are under 1e-3 */
            p.min_samples = 1024;
            p.max_samples = (int64_t)1 << 22;
            truth_ao_result res;
            CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
            double m = px(&res.mean, 0, 0), se = px(&res.std_error, 0, 0);
            printf("%s (origin %d): V = %.6f +- %.2g (%g samples), exact %.6f, diff %.2g\n",
                   truth_ao_estimator_name(cases[k].e), org, m, se, (double)px(&res.count, 0, 0), cases[k].want,
                   m - cases[k].want);
            CHECK(se <= 3e-4 && se > 0);
            CHECK_MSG(fabs(m - cases[k].want) <= 3 * se + tess_tol, "%.6f vs %.6f: over 3 standard errors (%.2g)", m,
                      cases[k].want, se);
            CHECK(fabs(m - cases[k].want) <= 1e-3);
            truth_ao_result_free(&res);
        }
    run_free(&R);
}

/* ---- the inside corner of a floor and a wall -------------------------------------------------- */

/* p on the floor (normal +y) at distance a from a wall, the plane x = a, rising from the floor.
 * A direction w (theta from the normal) reaches the wall plane at distance a / w_x when w_x > 0.
 *
 * (i) finite radius r, a wall taller than r: occluded iff w_x > c = a/r.
 *   cosine: project the cosine-distributed directions to the unit disk (Malley): uniform in the
 *   disk with x = w_x, so O = area{x > c}/pi = (acos c - c sqrt(1 - c^2)) / pi;
 *   uniform: w_x of a uniform hemisphere direction is uniform in [-1, 1] (Archimedes), so
 *   O = (1 - c)/2. At c = 0 (a point on the corner line) both give 1/2.
 * (ii) r = infinity, a wall of height H, infinitely long: occluded iff w_x > 0 and the elevation
 *   in the xy-plane is below atan(H/a). The geometry is 2-D, so the cosine-weighted fraction is
 *   the 2-D form factor (1/2) Int cos(phi) dphi over phi in [atan(a/H), pi/2] from the normal:
 *   O = (1 - a/sqrt(a^2 + H^2)) / 2.
 * The scene's wall is finite (+-L along z); an independent quadrature of the finite rectangle
 * (midpoint rule in theta, phi) checks both closed forms and bounds the finite-size error. */
static double corner_quadrature(double a, double H, double L, double r, int cosine)
{
    const int nt = 1500, np = 3000;
    double sum = 0;
    for (int i = 0; i < nt; i++) {
        double th = (i + 0.5) * (OBS_PI / 2) / nt, st = sin(th), ct = cos(th);
        double w = cosine ? ct * st : st;
        for (int j = 0; j < np; j++) {
            double ph = (j + 0.5) * 2 * OBS_PI / np;
            double wx = st * cos(ph), wz = st * sin(ph), wy = ct;
            if (wx <= 0)
                continue;
            double t = a / wx;
            if (t >= r)
                continue;
            double y = t * wy, z = t * wz;
            if (y <= H && fabs(z) <= L)
                sum += w;
        }
    }
    double dA = (OBS_PI / 2 / nt) * (2 * OBS_PI / np);
    return sum * dA / (cosine ? OBS_PI : 2 * OBS_PI);
}

static int corner_setup(ao_run *R, double a, double H, double L)
{
    memset(R, 0, sizeof *R);
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 1000, 10);
    double o[3] = {a, 0, -L}, u[3] = {0, 0, 2 * L}, v[3] = {0, H, 0};
    mb_quad(&mb, o, u, v, 8);
    mb_to_scene(&mb, &R->scene);
    return run_setup(R, obs_v3(-3, 2, 1), obs_v3(0, 0, 0), 1, 1);
}

TEST(truth_inside_corner_of_two_planes)
{
    struct {
        double a, H, L, r;
        truth_ao_estimator e;
    } cases[] = {
        {0.3, 5, 50, 1.0, TRUTH_AO_COS},
        {0.3, 5, 50, 1.0, TRUTH_AO_UNIF},
        {0.05, 5, 50, 0.5, TRUTH_AO_COS},
        {1.0, 2, 500, INFINITY, TRUTH_AO_COS},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        double a = cases[k].a, H = cases[k].H, L = cases[k].L, r = cases[k].r;
        int cosine = cases[k].e == TRUTH_AO_COS;
        double closed;
        if (isinf(r))
            closed = 0.5 * (1 - a / sqrt(a * a + H * H));
        else {
            double c = a / r;
            closed = cosine ? (acos(c) - c * sqrt(1 - c * c)) / OBS_PI : (1 - c) / 2;
        }
        double quad = corner_quadrature(a, H, L, r, cosine);
        printf("corner a=%g H=%g r=%g %s: closed form O = %.6f, quadrature %.6f\n", a, H, r,
               truth_ao_estimator_name(cases[k].e), closed, quad);
        CHECK_MSG(fabs(quad - closed) < 3e-4, "quadrature %.6f vs closed form %.6f", quad, closed);
        ao_run R;
        CHECK_MSG(corner_setup(&R, a, H, L), "setup: %s", obs_context_last_error(R.ctx));
        allow_samples(R.ctx, (int64_t)1 << 22);
        truth_ao_params p = truth_ao_params_default();
        p.estimator = cases[k].e;
        p.radius = (float)r;
        p.target_error = 3e-4;
        p.min_samples = 1024;
        p.max_samples = (int64_t)1 << 22;
        truth_ao_result res;
        CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
        double m = px(&res.mean, 0, 0), se = px(&res.std_error, 0, 0);
        printf("  estimate V = %.6f +- %.2g (%g samples), 1 - O = %.6f\n", m, se, (double)px(&res.count, 0, 0), 1 - closed);
        CHECK(se > 0 && se <= 3e-4);
        CHECK_MSG(fabs(m - (1 - quad)) <= 3 * se + 3e-4, "V %.6f vs quadrature %.6f (se %.2g)", m, 1 - quad, se);
        CHECK_MSG(fabs(m - (1 - closed)) <= 3 * se + 1e-5 || fabs(m - (1 - closed)) <= 1e-3,
                  "V %.6f vs closed form %.6f (se %.2g)", m, 1 - closed, se);
        CHECK(fabs(m - (1 - closed)) <= 1e-3);
        truth_ao_result_free(&res);
        run_free(&R);
    }
}

/* ---- a closed box ------------------------------------------------------------------------------ */

/* A point inside a closed box sees walls in every direction: with r = infinity every ray is
 * occluded, V = 0 exactly (a leak through an edge or a missed wall would show). */
TEST(truth_point_inside_closed_box_has_visibility_zero)
{
    ao_run R;
    memset(&R, 0, sizeof R);
    mesh_b mb = {0};
    static const double P[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                   {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
    for (int i = 0; i < 8; i++)
        mb_vertex(&mb, P[i][0], P[i][1], P[i][2]);
    static const uint32_t F[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                                      {3, 6, 2}, {3, 7, 6}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};
    for (int f = 0; f < 12; f++)
        mb_tri(&mb, F[f][0], F[f][1], F[f][2]);
    mb_to_scene(&mb, &R.scene);
    CHECK_MSG(run_setup(&R, obs_v3(0.2f, 0.3f, 0.5f), obs_v3(-0.5f, -1, -0.4f), 24, 18), "setup: %s",
              obs_context_last_error(R.ctx));
    for (int org = 0; org < 2; org++) {
        truth_ao_params p = truth_ao_params_default();
        p.radius = INFINITY;
        p.origin = (truth_ao_origin)org;
        truth_ao_result res;
        CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
        CHECK_EQ_INT(res.stats.pixels_surface, 24 * 18);
        for (int y = 0; y < res.height; y++)
            for (int x = 0; x < res.width; x++) {
                CHECK_MSG(px(&res.mean, x, y) == 0.0f, "pixel (%d,%d): mean %g", x, y, (double)px(&res.mean, x, y));
                CHECK(px(&res.std_error, x, y) == (float)truth_ao_error_floor(704));
                CHECK_EQ_INT(px(&res.count, x, y), agreeing_stop(&p));
            }
        truth_ao_result_free(&res);
    }
    run_free(&R);
}

/* ---- convergence and error bars ------------------------------------------------------------------ */

static double slope(const double *x, const double *y, int n)
{
    double mx = 0, my = 0;
    for (int i = 0; i < n; i++) {
        mx += log(x[i]) / n;
        my += log(y[i]) / n;
    }
    double sxy = 0, sxx = 0;
    for (int i = 0; i < n; i++) {
        sxy += (log(x[i]) - mx) * (log(y[i]) - my);
        sxx += (log(x[i]) - mx) * (log(x[i]) - mx);
    }
    return sxy / sxx;
}

/* The sphere straight above p maps, through Malley's projection and the concentric map, to the
 * centred square [1/4, 3/4]^2 of the unit square: a union of dyadic boxes of area 2^-4. Each
 * replicate's first 2^k points (k >= 4) of the (0,2)-sequence form a (0,k,2)-net, and Owen
 * scrambling keeps it one (as a digital XOR shift would), so exactly a quarter of them fall in the
 * square: with N = 8 replicates x 2^k samples the estimate is exact, 3/4, for every seed (but for
 * samples on the tessellated silhouette). An additive (Cranley-Patterson) shift breaks the dyadic
 * boxes: 199 of 200 shifts did, with errors of order 1/N. */
TEST(truth_scrambling_keeps_the_sequence_stratified)
{
    ao_run R;
    CHECK_MSG(cap_setup(&R), "setup: %s", obs_context_last_error(R.ctx));
    double s = CAP_R / CAP_H, want = 1 - s * s;
    const int N[2] = {128, 512};
    for (int k = 0; k < 2; k++) {
        int exact = 0;
        double worst = 0;
        for (int seed = 0; seed < 64; seed++) {
            truth_ao_params p = truth_ao_params_default();
            p.radius = INFINITY;
            p.seed = (uint64_t)seed * 7919u + 1;
            p.min_samples = p.max_samples = N[k];
            truth_ao_result res;
            CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
            double d = fabs(px(&res.mean, 0, 0) - want);
            exact += d == 0.0;
            worst = d > worst ? d : worst;
            truth_ao_result_free(&res);
        }
        printf("N = %d: %d of 64 seeds exact, worst error %.3g\n", N[k], exact, worst);
        CHECK_MSG(exact >= 62 && worst <= 1.0 / N[k], "N = %d: %d of 64 seeds exact, worst %.3g", N[k], exact, worst);
    }
    run_free(&R);
}

/* The Owen scramble's SSE2 path (4 lanes, emulated 32-bit multiplies, bit reversal by masks)
 * equals its scalar form for every value, seed and length, including the tail past a multiple of
 * 4; and it is a nested scramble: values sharing their k leading bits map to outputs sharing
 * their k leading bits, for every k, so nets stay nets. */
TEST(truth_owen_scramble_simd_equals_scalar_and_is_nested)
{
    enum { N = 4099 };
    static uint32_t v[N], seed[N], out[N];
    uint64_t x = 0x9E3779B97F4A7C15ull;
    for (int k = 0; k < N; k++) {
        x = x * 6364136223846793005ull + 1442695040888963407ull;
        v[k] = (uint32_t)(x >> 32);
        seed[k] = (uint32_t)x;
    }
    v[0] = 0, seed[0] = 0, v[1] = 0xFFFFFFFFu, seed[1] = 0xFFFFFFFFu;
    for (int n = 0; n <= 9; n++) {
        truth_i_owen_scramble(v, seed, n, out);
        for (int k = 0; k < n; k++)
            CHECK(out[k] == truth_i_owen_scramble1(v[k], seed[k]));
    }
    truth_i_owen_scramble(v, seed, N, out);
    int bad = 0;
    for (int k = 0; k < N; k++)
        bad += out[k] != truth_i_owen_scramble1(v[k], seed[k]);
    CHECK_EQ_INT(bad, 0);
    CHECK(truth_i_owen_scramble1(0, 0) == 0);
    /* nested: the inputs are bit-reversed coordinates, so "leading" bits of a coordinate are the
     * low bits of v; two coordinates agreeing in their top k bits agree after scrambling */
    for (int k = 0; k < 2000; k++) {
        uint32_t a = v[k], s0 = seed[7];
        for (int bits = 1; bits < 32; bits += 5) {
            uint32_t b = (a & ((1u << bits) - 1u)) | (v[k + 1] & ~((1u << bits) - 1u)); /* same low bits */
            uint32_t oa = truth_i_owen_scramble1(a, s0), ob = truth_i_owen_scramble1(b, s0);
            CHECK((oa >> (32 - bits)) == (ob >> (32 - bits)));
        }
    }
}

/* An oblique sphere: centre at distance D from p, at angle theta from the normal, entirely above
 * the horizon. Its cosine-weighted occlusion is the differential-area-to-sphere form factor,
 * (R/D)^2 cos(theta) (e.g. Howell's catalogue of configuration factors, B-15): the circle's
 * image in the disk is an off-centre ellipse, aligned with no dyadic box. */
#define OBL_D 2.0
#define OBL_THETA (40.0 * OBS_PI / 180.0)
static int oblique_setup(ao_run *R)
{
    memset(R, 0, sizeof *R);
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 50, 20);
    mb_sphere(&mb, k_px + OBL_D * sin(OBL_THETA), OBL_D * cos(OBL_THETA), k_pz, CAP_R, 256, 128);
    mb_to_scene(&mb, &R->scene);
    return run_setup(R, obs_v3(-6, 1, 0.5f), obs_v3((float)k_px, 0, (float)k_pz), 1, 1);
}

/* Fixed sample counts N = 64 .. 4096, 128 seeds each, on the oblique sphere. The error bar is
 * calibrated: the actual RMS error against the form factor is within [0.5, 1.25] of the RMS
 * reported error bar at every N (the old i.i.d. formula was 3-14x too large on the centred cap,
 * docs/truth.md), and it falls
 * faster than N^-1/2 (slope <= -0.6: the replicates keep their stratification). */
TEST(truth_error_bars_track_the_actual_error_as_n_grows)
{
    ao_run R;
    CHECK_MSG(oblique_setup(&R), "setup: %s", obs_context_last_error(R.ctx));
    const double want = 1.0 - (CAP_R / OBL_D) * (CAP_R / OBL_D) * cos(OBL_THETA);
    double N[4] = {64, 256, 1024, 4096}, rms[4], rse[4];
    const int seeds = 128;
    for (int k = 0; k < 4; k++) {
        double e2 = 0, se2 = 0;
        for (int seed = 0; seed < seeds; seed++) {
            truth_ao_params p = truth_ao_params_default();
            p.radius = INFINITY;
            p.seed = (uint64_t)seed * 7919u + 1;
            p.min_samples = p.max_samples = (int64_t)N[k];
            truth_ao_result res;
            CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
            CHECK_EQ_INT(px(&res.count, 0, 0), N[k]);
            double d = px(&res.mean, 0, 0) - want, se = px(&res.std_error, 0, 0);
            CHECK(se >= truth_ao_error_floor((int64_t)N[k]) * (1 - 1e-6));
            e2 += d * d / seeds;
            se2 += se * se / seeds;
            truth_ao_result_free(&res);
        }
        rms[k] = sqrt(e2);
        rse[k] = sqrt(se2);
        printf("N = %5.0f: RMS error %.6f, RMS error bar %.6f (floor %.6f), ratio %.2f\n", N[k], rms[k], rse[k],
               truth_ao_error_floor((int64_t)N[k]), rms[k] / rse[k]);
        CHECK_MSG(rms[k] >= 0.5 * rse[k] && rms[k] <= 1.25 * rse[k], "N = %.0f: RMS error %.6f vs error bar %.6f", N[k],
                  rms[k], rse[k]);
    }
    double s_rms = slope(N, rms, 4);
    printf("slope of the RMS error: %.3f\n", s_rms);
    CHECK_MSG(s_rms <= -0.6 && s_rms >= -1.6, "RMS error slope %.3f", s_rms);
    run_free(&R);
}

/* The scene: a sphere of radius 1, centre 2 above a large plane, seen from 10 units
 * above. A visible ground point at horizontal distance x from the sphere's foot has the cosine
 * occlusion h R^2 / d^3, d = sqrt(x^2 + h^2) (the form factor above with cos(theta) = h/d). */
typedef struct ground_px {
    double x, want; /* distance from the foot, exact visibility */
    float v, se, n;
} ground_px;

static int ground_setup(ao_run *R, int W)
{
    memset(R, 0, sizeof *R);
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 60, 24);
    mb_sphere(&mb, 0, 2, 0, 1, 256, 128);
    mb_to_scene(&mb, &R->scene);
    R->ctx = obs_context_create();
    R->cam = obs_camera_look_at(obs_v3(0.01f, 10, 0.02f), obs_v3(0, 0, 0), obs_v3(0, 0, -1), 1.2f, 0.01f, 1e5f);
    R->rp = rast_params_default();
    R->rp.width = R->rp.height = W;
    if (rast_gbuffer_alloc(R->ctx, &R->rp, &R->gb) != OBS_STATUS_OK)
        return 0;
    rast_view v = {R->cam};
    if (rast_render(R->ctx, NULL, &R->scene, &v, 1, &R->rp, &R->gb, NULL) != OBS_STATUS_OK)
        return 0;
    return truth_scene_create(R->ctx, &R->scene, TRUTH_BUILD_MEDIUM, &R->ts) == OBS_STATUS_OK;
}

/* The ground pixels whose foot distance is in [x0, x1), with their estimates and exact values. */
static int ground_pixels(const ao_run *R, const truth_ao_result *res, double x0, double x1, ground_px *out, int max)
{
    int n = 0;
    for (int y = 0; y < res->height; y++)
        for (int x = 0; x < res->width; x++) {
            if (px(&res->count, x, y) == 0.0f)
                continue;
            obs_dvec3 o, d;
            rast_pixel_ray(&R->gb.constants, &R->cam, x + 0.5, y + 0.5, &o, &d);
            double t = obs_image_f32_row(&R->gb.depth, y)[x];
            double X = o.x + t * d.x, Y = o.y + t * d.y, Z = o.z + t * d.z;
            if (fabs(Y) > 1e-4)
                continue; /* the sphere */
            double r = sqrt(X * X + Z * Z), dd = sqrt(r * r + 4.0);
            if (r < x0 || r >= x1 || n >= max)
                continue;
            out[n].x = r;
            out[n].want = 1.0 - 2.0 / (dd * dd * dd);
            out[n].v = px(&res->mean, x, y);
            out[n].se = px(&res->std_error, x, y);
            out[n].n = px(&res->count, x, y);
            n++;
        }
    return n;
}

/* Rare occlusion (1.2-2.4%, ground points 4 to 5 units from the foot).
 * With the default stopping rule: no pixel may stop on identical outcomes (the old rule stopped a
 * third of them at V = 1: mean bias +0.003 with a reported error of 0.001), every pixel takes at
 * least the 704 samples at which floor(n) first reaches the target 0.002, at most 4% are off by
 * more than 3 error bars, and the mean bias is under a tenth of the target (adaptive stopping on a
 * noisy error bar keeps a small bias, about -1.3e-4 here: docs/truth.md, "Limits").
 * With a fixed count (min = max = 1024) the estimate is exactly unbiased: the mean error over the
 * pixels is within 3 of its own standard errors, sqrt(sum se^2) / n. */
TEST(truth_rare_occlusion_is_unbiased)
{
    ao_run R;
    CHECK_MSG(ground_setup(&R, 160), "setup: %s", obs_context_last_error(R.ctx));
    for (int fixed = 0; fixed < 2; fixed++) {
        truth_ao_params p = truth_ao_params_default();
        p.radius = INFINITY;
        p.seed = 3;
        if (fixed)
            p.min_samples = p.max_samples = 1024;
        truth_ao_result res;
        CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
        static ground_px g[160 * 160];
        int n = ground_pixels(&R, &res, 4.0, 5.0, g, 160 * 160);
        CHECK_MSG(n > 2000, "only %d ground pixels 4 to 5 units from the foot", n);
        double bias = 0, se2 = 0, minn = 1e30;
        int ones = 0, over3 = 0;
        for (int i = 0; i < n; i++) {
            double e = g[i].v - g[i].want;
            bias += e / n;
            se2 += (double)g[i].se * g[i].se;
            ones += g[i].v == 1.0f;
            over3 += fabs(e) > 3 * g[i].se;
            minn = g[i].n < minn ? g[i].n : minn;
        }
        double se_mean = sqrt(se2) / n;
        printf("%s: %d pixels, mean bias %.2e (its standard error %.2e), %d at exactly 1, %.2f%% over 3 error bars, "
               "fewest samples %.0f\n", fixed ? "1024 samples" : "default stopping", n, bias, se_mean, ones,
               100.0 * over3 / n, minn);
        CHECK_MSG(ones == 0, "%d pixels stopped at visibility exactly 1", ones);
        CHECK_MSG(over3 <= 0.04 * n, "%d of %d pixels over 3 error bars", over3, n);
        if (fixed) {
            CHECK_MSG(fabs(bias) <= 3 * se_mean, "mean bias %.3g over 3 standard errors %.3g", bias, se_mean);
        } else {
            CHECK_MSG(fabs(bias) <= 0.1 * p.target_error, "mean bias %.3g over a tenth of the target", bias);
            CHECK(minn >= 704); /* floor(n) <= 0.002 first at n = 704 */
        }
        truth_ao_result_free(&res);
    }
    run_free(&R);
}

/* Calibration over many pixels against the exact values (every visible ground point, occlusion
 * 0.8% to 17%), at fixed N, for the cosine estimator alone and as one output of a multi-output
 * set: the share of pixels off by more than 2 and 3 error bars is near what a t-distribution with
 * R - 1 = 7 degrees of freedom gives (8.6% and 2.0%; the floor only makes it smaller): at most 12%
 * and 4%, and at least 1% over 2 (the bars are not inflated); and the RMS of error / bar is in
 * [0.6, 1.3]. */
TEST(truth_error_bars_are_calibrated_over_many_pixels)
{
    ao_run R;
    CHECK_MSG(ground_setup(&R, 96), "setup: %s", obs_context_last_error(R.ctx));
    for (int multi = 0; multi < 2; multi++)
        for (int k = 0; k < 2; k++) {
            const int64_t N = k ? 1024 : 256;
            truth_ao_params p = truth_ao_params_default();
            p.radius = INFINITY;
            p.seed = 11;
            p.min_samples = p.max_samples = N;
            truth_ao_result res[2];
            if (multi) {
                truth_ao_output o[2] = {{TRUTH_AO_OBS_SAO_B, 0.5f}, {TRUTH_AO_COS, INFINITY}};
                CHECK_OK(truth_ao_render_multi(R.ctx, NULL, R.ts, &R.scene, &R.cam, &R.gb, &p, o, 2, res), R.ctx);
            } else {
                CHECK_OK(run_ao(&R, NULL, &p, &res[1]), R.ctx);
            }
            static ground_px g[96 * 96];
            int n = ground_pixels(&R, &res[1], 0.0, 1e9, g, 96 * 96);
            CHECK_MSG(n > 5000, "only %d ground pixels", n);
            int over2 = 0, over3 = 0;
            double z2 = 0;
            for (int i = 0; i < n; i++) {
                double z = fabs(g[i].v - g[i].want) / g[i].se;
                over2 += z > 2;
                over3 += z > 3;
                z2 += z * z / n;
            }
            printf("%s N = %lld: %d pixels, %.2f%% over 2 error bars, %.2f%% over 3, RMS(error / bar) %.3f\n",
                   multi ? "multi" : "single", (long long)N, n, 100.0 * over2 / n, 100.0 * over3 / n, sqrt(z2));
            CHECK_MSG(over2 <= 0.12 * n && over2 >= 0.01 * n, "%d of %d over 2 error bars", over2, n);
            CHECK_MSG(over3 <= 0.04 * n, "%d of %d over 3 error bars", over3, n);
            CHECK_MSG(sqrt(z2) >= 0.6 && sqrt(z2) <= 1.3, "RMS(error / bar) %.3f", sqrt(z2));
            truth_ao_result_free(&res[1]);
            if (multi)
                truth_ao_result_free(&res[0]);
        }
    run_free(&R);
}

/* ---- determinism -------------------------------------------------------------------------------- */

static int planes_equal(const truth_ao_result *a, const truth_ao_result *b)
{
    if (a->width != b->width || a->height != b->height)
        return 0;
    for (int y = 0; y < a->height; y++) {
        size_t n = sizeof(float) * (size_t)a->width;
        if (memcmp(obs_image_f32_row(&a->mean, y), obs_image_f32_row(&b->mean, y), n) ||
            memcmp(obs_image_f32_row(&a->std_error, y), obs_image_f32_row(&b->std_error, y), n) ||
            memcmp(obs_image_f32_row(&a->count, y), obs_image_f32_row(&b->count, y), n))
            return 0;
    }
    return a->stats.rays == b->stats.rays && a->stats.pixels_converged == b->stats.pixels_converged;
}

/* A lone floor of n x n quads, 8x8 pixels seen from eye: for the refusal tests. */
static int floor_setup(ao_run *R, int n, obs_vec3 eye)
{
    memset(R, 0, sizeof *R);
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 5, n);
    mb_to_scene(&mb, &R->scene);
    return run_setup(R, eye, obs_v3(0, 0, 0), 8, 8);
}

/* A floor with two balls, seen obliquely: occlusion of every degree, for the determinism tests. */
static int two_balls_setup(ao_run *R, int W, int H)
{
    memset(R, 0, sizeof *R);
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 5, 16);
    mb_sphere(&mb, 0, 0.5, 0, 0.5, 32, 16);
    mb_sphere(&mb, 0.8, 0.3, 0.4, 0.3, 24, 12);
    mb_to_scene(&mb, &R->scene);
    return run_setup(R, obs_v3(1.5f, 1.5f, 2.5f), obs_v3(0.2f, 0.3f, 0), W, H);
}

TEST(truth_output_identical_for_1_2_and_8_threads)
{
    ao_run R;
    CHECK_MSG(two_balls_setup(&R, 37, 29), "setup: %s", obs_context_last_error(R.ctx));
    static const truth_ao_estimator est[] = {TRUTH_AO_COS, TRUTH_AO_OBS_SAO_B, TRUTH_AO_VOL};
    for (int e = 0; e < 3; e++) {
        truth_ao_params p = truth_ao_params_default();
        p.estimator = est[e];
        p.radius = 0.6f;
        p.target_error = 0.03; /* adaptive: pixels stop at different rounds */
        p.max_samples = 512;
        p.seed = 12345;
        truth_ao_result res[3];
        int threads[3] = {1, 2, 8};
        for (int t = 0; t < 3; t++) {
            obs_pool *pool = obs_pool_create(threads[t]);
            CHECK_OK(run_ao(&R, pool, &p, &res[t]), R.ctx);
            obs_pool_destroy(pool);
        }
        int64_t c64 = 0, cmax = 0, cmid = 0;
        for (int y = 0; y < res[0].height; y++)
            for (int x = 0; x < res[0].width; x++) {
                float c = px(&res[0].count, x, y);
                c64 += c == 64;
                cmax += c == 512;
                cmid += c > 64 && c < 512;
            }
        printf("%s: %lld pixels stopped at 64 samples, %lld between, %lld at 512\n", truth_ao_estimator_name(est[e]),
               (long long)c64, (long long)cmid, (long long)cmax);
        CHECK(cmid > 0);
        CHECK_MSG(planes_equal(&res[0], &res[1]), "%s: 1 and 2 threads differ", truth_ao_estimator_name(est[e]));
        CHECK_MSG(planes_equal(&res[0], &res[2]), "%s: 1 and 8 threads differ", truth_ao_estimator_name(est[e]));
        /* a different seed gives a different (but close) image */
        truth_ao_result other;
        p.seed = 54321;
        CHECK_OK(run_ao(&R, NULL, &p, &other), R.ctx);
        CHECK(!planes_equal(&res[0], &other));
        for (int t = 0; t < 3; t++)
            truth_ao_result_free(&res[t]);
        truth_ao_result_free(&other);
    }
    run_free(&R);
}

/* The AVX2 forms of the per-pixel sampling (truth_ao_avx2.c) against their SSE2 references in
 * truth_ao.c, bit for bit: the replicate seeds (8-lane Philox against obs_rng_u32x4_n_scalar), the
 * 8-lane Owen scramble, and one pixel's rays (scramble, directions, basis, stores) for every
 * B = 8 .. 64 in steps of 8 with each rays-per-replicate m that divides it (R = B/m in [2, 32]),
 * cosine and uniform, occlusion and hit records, random bases and extreme coordinates; then whole
 * renders with OBS_ISA=scalar and without give the same planes. Skipped (with a line) where the
 * build or the CPU lacks AVX2. */
TEST(truth_avx2_rays_and_seeds_equal_the_sse2_reference)
{
#if defined(OBS_HAVE_AVX2)
    if (!truth_i_avx2_active()) {
        printf("skipped: this CPU has no AVX2 (or OBS_ISA=scalar is set)\n");
        return;
    }
    uint64_t x = 0x2545F4914F6CDD1Dull;
#define NEXT() (x = x * 6364136223846793005ull + 1442695040888963407ull, (uint32_t)(x >> 32))
    for (int it = 0; it < 200; it++) {
        /* one NEXT() per statement: two in one expression modify x unsequenced (clang -Wunsequenced) */
        const uint64_t p_hi = NEXT(), p_lo = NEXT(), s_hi = NEXT(), s_lo = NEXT();
        uint64_t pixel = (p_hi << 32 | p_lo) >> (it % 40), seed = s_hi << 32 | s_lo;
        if (it == 0)
            pixel = seed = 0;
        const int R = 2 + it % (TRUTH_AO_MAX_REPLICATES - 1);
        uint32_t shift[TRUTH_AO_MAX_REPLICATES][2];
        uint64_t shift3[TRUTH_AO_MAX_REPLICATES];
        uint32_t ref[TRUTH_AO_MAX_REPLICATES][4];
        truth_i_seeds_avx2(pixel, R, seed, shift, shift3);
        obs_rng_u32x4_n_scalar(pixel, 0, R, 0, seed, ref);
        for (int r = 0; r < R; r++) {
            CHECK(shift[r][0] == ref[r][0] && shift[r][1] == ref[r][1]);
            CHECK(shift3[r] == ((uint64_t)ref[r][3] << 32 | ref[r][2]));
        }
    }
    {
        enum { N = 1003 };
        static uint32_t v[N], sd[N], out[N];
        for (int k = 0; k < N; k++)
            v[k] = NEXT(), sd[k] = NEXT();
        v[0] = 0, sd[0] = 0, v[1] = 0xFFFFFFFFu, sd[1] = 0xFFFFFFFFu;
        truth_i_owen_scramble_avx2(v, sd, N, out);
        int bad = 0;
        for (int k = 0; k < N; k++)
            bad += out[k] != truth_i_owen_scramble1(v[k], sd[k]);
        CHECK_EQ_INT(bad, 0);
    }
    /* three pixels' records, traced in the order 2, 0, 1 */
    struct { float frame[12]; uint32_t shift[TRUTH_AO_MAX_REPLICATES][2]; } rec[3];
    const int order[3] = {2, 0, 1};
    static RTCRayHit ra[3 * 64], rb[3 * 64];
    int cases = 0, bad = 0;
    for (int B = 8; B <= 64; B += 8)
        for (int m = 1; m <= B / 2; m++) {
            if (B % m || B / m > TRUTH_AO_MAX_REPLICATES)
                continue;
            for (int variant = 0; variant < 4; variant++) {
                uint32_t base0[64], base1[64], v0[64], v1[64];
                for (int i = 0; i < m; i++)
                    base0[i] = NEXT(), base1[i] = NEXT();
                base0[0] = variant == 1 ? 0xFFFFFFFFu : 0u; /* the extreme cells of [0, 1) */
                base1[0] = variant == 2 ? 0x80000000u : base1[0];
                for (int k = 0; k < B; k++)
                    v0[k] = base0[k % m], v1[k] = base1[k % m];
                for (int q = 0; q < 3; q++) {
                    for (int r = 0; r < B / m; r++)
                        rec[q].shift[r][0] = NEXT(), rec[q].shift[r][1] = NEXT();
                    if (variant == 3)
                        rec[q].shift[0][0] = rec[q].shift[0][1] = 0u;
                    /* an origin, a random unit normal and its Duff basis */
                    float *fr = rec[q].frame, *t = fr + 3, *b = fr + 6, *n = fr + 9;
                    for (int c = 0; c < 3; c++)
                        fr[c] = (float)NEXT() / 65536.0f - 30000.0f;
                    double nx = (double)NEXT() / 4294967296.0 - 0.5, ny = (double)NEXT() / 4294967296.0 - 0.5,
                           nz = (double)NEXT() / 4294967296.0 - 0.5, l = sqrt(nx * nx + ny * ny + nz * nz) + 1e-9;
                    n[0] = (float)(nx / l), n[1] = (float)(ny / l), n[2] = (float)(nz / l);
                    float sg = n[2] < 0.0f ? -1.0f : 1.0f, aa = -1.0f / (sg + n[2]), bb = n[0] * n[1] * aa;
                    t[0] = 1.0f + sg * n[0] * n[0] * aa, t[1] = sg * bb, t[2] = -sg * n[0];
                    b[0] = bb, b[1] = sg + n[1] * n[1] * aa, b[2] = -n[1];
                }
                for (int hit = 0; hit < 2; hit++)
                    for (int cosine = 0; cosine < 2; cosine++) {
                        const truth_i_hemi_in in = {v0, v1, 0.25f + (float)variant, B, m, cosine, hit,
                                                    (const char *)rec, sizeof rec[0], 0,
                                                    (size_t)((const char *)rec[0].shift - (const char *)&rec[0]), order, 3};
                        memset(ra, 0xA5, sizeof ra);
                        memset(rb, 0xA5, sizeof rb);
                        truth_i_hemisphere_rays_avx2(&in, ra);
                        CHECK(truth_i_hemisphere_rays_sse2(&in, rb));
                        const size_t bytes = 3 * (size_t)B * (hit ? sizeof(RTCRayHit) : sizeof(RTCRay));
                        bad += memcmp(ra, rb, bytes) != 0;
                        cases++;
                    }
            }
        }
    printf("%d ray cases (B, m, cosine/uniform, occlusion/hit), %d differ\n", cases, bad);
    CHECK_EQ_INT(bad, 0);
#undef NEXT
    /* whole renders: the AVX2 forms against OBS_ISA=scalar (the SSE2 references) */
    ao_run Rn;
    CHECK_MSG(two_balls_setup(&Rn, 37, 29), "setup: %s", obs_context_last_error(Rn.ctx));
    static const struct { truth_ao_estimator e; int batch, replicates; } cfg[] = {
        {TRUTH_AO_COS, 16, 8}, {TRUTH_AO_UNIF, 16, 16}, {TRUTH_AO_OBS_SAO_B, 16, 8}, {TRUTH_AO_OBS_HBAO, 24, 8},
        {TRUTH_AO_COS, 32, 4}, {TRUTH_AO_VOL, 16, 8}};
    for (size_t c = 0; c < sizeof cfg / sizeof cfg[0]; c++) {
        truth_ao_params p = truth_ao_params_default();
        p.estimator = cfg[c].e;
        p.radius = 0.6f;
        p.batch = cfg[c].batch;
        p.replicates = cfg[c].replicates;
        p.min_samples = 2 * p.batch;
        p.max_samples = 16 * p.batch;
        p.target_error = 0.03;
        p.seed = 777 + c;
        truth_ao_result a, s;
        CHECK_OK(run_ao(&Rn, NULL, &p, &a), Rn.ctx);
        setenv("OBS_ISA", "scalar", 1);
        CHECK_OK(run_ao(&Rn, NULL, &p, &s), Rn.ctx);
        unsetenv("OBS_ISA");
        CHECK_MSG(planes_equal(&a, &s), "%s, batch %d, %d replicates: AVX2 and scalar planes differ",
                  truth_ao_estimator_name(cfg[c].e), cfg[c].batch, cfg[c].replicates);
        truth_ao_result_free(&a);
        truth_ao_result_free(&s);
    }
    run_free(&Rn);
#else
    printf("skipped: built without the AVX2 paths (OBS_ENABLE_SIMD=OFF)\n");
#endif
}

/* truth_ao_render_multi: one ray set, several (estimator, radius) outputs. With a fixed sample
 * count (min = max, target 0) every output must equal, value for value, the single-output run of
 * its own estimator and radius: the directions depend on pixel, sample and seed only, and the
 * closest hit within r_max is the closest within r when t <= r. Binary outputs (COS, UNIF) are
 * traced by rtcOccluded1M alone and by rtcIntersect1M in the shared set; both report a hit at
 * t <= r for the same rays, so they must agree too. Adaptive: every output meets the target or
 * the pixel is at max, and one output alone is bit-identical to truth_ao_render. */
static int same_values(const truth_ao_result *a, const truth_ao_result *b, double *max_diff)
{
    *max_diff = 0.0;
    if (a->width != b->width || a->height != b->height)
        return 0;
    for (int y = 0; y < a->height; y++)
        for (int x = 0; x < a->width; x++) {
            double d = fabs((double)px(&a->mean, x, y) - px(&b->mean, x, y));
            d = fmax(d, fabs((double)px(&a->std_error, x, y) - px(&b->std_error, x, y)));
            d = fmax(d, fabs((double)px(&a->count, x, y) - px(&b->count, x, y)));
            *max_diff = fmax(*max_diff, d);
        }
    return *max_diff == 0.0;
}

TEST(truth_multi_output_equals_each_single_run)
{
    ao_run R;
    CHECK_MSG(two_balls_setup(&R, 41, 31), "setup: %s", obs_context_last_error(R.ctx));
    static const truth_ao_output cos_family[] = {
        {TRUTH_AO_COS, 0.3f}, {TRUTH_AO_OBS_SAO_B, 0.3f}, {TRUTH_AO_COS, 0.9f}, {TRUTH_AO_OBS_MSSAO, 0.6f},
        {TRUTH_AO_OBS_SAO_LINEAR, 0.9f}, {TRUTH_AO_OBS_SAO_B, 0.9f}, {TRUTH_AO_COS, INFINITY}};
    static const truth_ao_output unif_family[] = {{TRUTH_AO_UNIF, 0.25f}, {TRUTH_AO_OBS_HBAO, 0.25f},
                                                  {TRUTH_AO_OBS_HBAO, 0.7f}, {TRUTH_AO_UNIF, 0.7f}};
    const struct { const truth_ao_output *o; int n; } fam[] = {{cos_family, 7}, {unif_family, 4}};
    obs_pool *pool = obs_pool_create(2);
    for (int f = 0; f < 2; f++) {
        truth_ao_params p = truth_ao_params_default();
        p.min_samples = p.max_samples = 128; /* fixed count: the same rays in both */
        p.target_error = 0.0;
        p.seed = 77;
        truth_ao_result multi[TRUTH_AO_MAX_OUTPUTS];
        CHECK_OK(truth_ao_render_multi(R.ctx, pool, R.ts, &R.scene, &R.cam, &R.gb, &p, fam[f].o, fam[f].n, multi), R.ctx);
        for (int j = 0; j < fam[f].n; j++) {
            truth_ao_params q = p;
            q.estimator = fam[f].o[j].estimator;
            q.radius = fam[f].o[j].radius;
            truth_ao_result one;
            CHECK_OK(run_ao(&R, pool, &q, &one), R.ctx);
            double md;
            CHECK_MSG(same_values(&multi[j], &one, &md), "output %d (%s, r %g): max difference %g from its single run", j,
                      truth_ao_estimator_name(q.estimator), (double)q.radius, md);
            truth_ao_result_free(&one);
        }
        /* the ray set is traced once: its ray count is one output's, not the sum */
        truth_ao_params q = p;
        q.estimator = fam[f].o[0].estimator;
        q.radius = fam[f].o[0].radius;
        truth_ao_result one;
        CHECK_OK(run_ao(&R, pool, &q, &one), R.ctx);
        CHECK(multi[0].stats.rays == one.stats.rays);
        truth_ao_result_free(&one);
        for (int j = 0; j < fam[f].n; j++)
            truth_ao_result_free(&multi[j]);
    }
    /* adaptive: a pixel stops only when every output is within the target, or at max */
    {
        truth_ao_params p = truth_ao_params_default();
        p.target_error = 0.02;
        p.max_samples = 1024;
        truth_ao_result multi[TRUTH_AO_MAX_OUTPUTS];
        CHECK_OK(truth_ao_render_multi(R.ctx, NULL, R.ts, &R.scene, &R.cam, &R.gb, &p, cos_family, 7, multi), R.ctx);
        int64_t early = 0;
        for (int y = 0; y < multi[0].height; y++)
            for (int x = 0; x < multi[0].width; x++) {
                float c = px(&multi[0].count, x, y);
                if (c == 0.0f || c >= 1024.0f)
                    continue;
                early++;
                for (int j = 0; j < 7; j++) {
                    CHECK(px(&multi[j].count, x, y) == c);
                    CHECK_MSG(px(&multi[j].std_error, x, y) <= 0.02f, "pixel %d,%d output %d stopped at se %g", x, y, j,
                              (double)px(&multi[j].std_error, x, y));
                }
            }
        CHECK(early > 0);
        /* 1 and 2 threads: the same bits */
        truth_ao_result m2[TRUTH_AO_MAX_OUTPUTS];
        CHECK_OK(truth_ao_render_multi(R.ctx, pool, R.ts, &R.scene, &R.cam, &R.gb, &p, cos_family, 7, m2), R.ctx);
        for (int j = 0; j < 7; j++) {
            CHECK(planes_equal(&multi[j], &m2[j]));
            truth_ao_result_free(&multi[j]);
            truth_ao_result_free(&m2[j]);
        }
        /* one output alone is truth_ao_render, bit for bit (VOL included) */
        static const truth_ao_output singles[] = {{TRUTH_AO_COS, 0.4f}, {TRUTH_AO_OBS_HBAO, 0.4f}, {TRUTH_AO_VOL, 0.4f}};
        for (int k = 0; k < 3; k++) {
            truth_ao_result a, b;
            truth_ao_params q = p;
            q.estimator = singles[k].estimator;
            q.radius = singles[k].radius;
            CHECK_OK(truth_ao_render_multi(R.ctx, pool, R.ts, &R.scene, &R.cam, &R.gb, &p, &singles[k], 1, &a), R.ctx);
            CHECK_OK(run_ao(&R, pool, &q, &b), R.ctx);
            CHECK_MSG(planes_equal(&a, &b), "%s alone differs from truth_ao_render", truth_ao_estimator_name(q.estimator));
            truth_ao_result_free(&a);
            truth_ao_result_free(&b);
        }
    }
    obs_pool_destroy(pool);
    run_free(&R);
}

/* The outputs' order does not matter: {cos inf, obs-sao 0.5} and {obs-sao 0.5, cos inf} are both
 * accepted (the shared rays once took the first output's estimator and the largest radius, and
 * refused the second order), give the same planes per output, each equal to its single run at a
 * fixed count; with adaptive stopping each output's statistics are its own: pixels_converged counts
 * its pixels within the target and max_std_error is its plane's maximum. */
TEST(truth_multi_output_accepts_its_outputs_in_any_order)
{
    ao_run R;
    CHECK_MSG(two_balls_setup(&R, 33, 25), "setup: %s", obs_context_last_error(R.ctx));
    const truth_ao_output ab[2] = {{TRUTH_AO_COS, INFINITY}, {TRUTH_AO_OBS_SAO_B, 0.5f}};
    const truth_ao_output ba[2] = {{TRUTH_AO_OBS_SAO_B, 0.5f}, {TRUTH_AO_COS, INFINITY}};
    const truth_ao_output ub[2] = {{TRUTH_AO_OBS_HBAO, 0.5f}, {TRUTH_AO_UNIF, INFINITY}};
    for (int adaptive = 0; adaptive < 2; adaptive++) {
        truth_ao_params p = truth_ao_params_default();
        p.seed = 5;
        if (adaptive) {
            p.target_error = 0.01;
            p.max_samples = 2048;
        } else {
            p.min_samples = p.max_samples = 256;
        }
        truth_ao_result x[2], y[2], u[2];
        CHECK_OK(truth_ao_render_multi(R.ctx, NULL, R.ts, &R.scene, &R.cam, &R.gb, &p, ab, 2, x), R.ctx);
        CHECK_OK(truth_ao_render_multi(R.ctx, NULL, R.ts, &R.scene, &R.cam, &R.gb, &p, ba, 2, y), R.ctx);
        CHECK_OK(truth_ao_render_multi(R.ctx, NULL, R.ts, &R.scene, &R.cam, &R.gb, &p, ub, 2, u), R.ctx);
        CHECK(planes_equal(&x[0], &y[1]) && planes_equal(&x[1], &y[0]));
        for (int j = 0; j < 2 && !adaptive; j++) {
            truth_ao_params q = p;
            q.estimator = ab[j].estimator;
            q.radius = ab[j].radius;
            truth_ao_result one;
            CHECK_OK(run_ao(&R, NULL, &q, &one), R.ctx);
            double md;
            CHECK_MSG(same_values(&x[j], &one, &md), "output %d: max difference %g from its single run", j, md);
            truth_ao_result_free(&one);
        }
        const truth_ao_result *all[4] = {&x[0], &x[1], &u[0], &u[1]};
        for (int k = 0; k < 4 && adaptive; k++) {
            const truth_ao_result *r = all[k];
            int64_t conv = 0;
            double mx = 0;
            for (int yy = 0; yy < r->height; yy++)
                for (int xx = 0; xx < r->width; xx++) {
                    if (px(&r->count, xx, yy) == 0.0f)
                        continue;
                    double se = px(&r->std_error, xx, yy);
                    conv += se <= p.target_error;
                    mx = se > mx ? se : mx;
                }
            CHECK_EQ_INT(r->stats.pixels_converged, conv);
            CHECK_MSG(fabs(r->stats.max_std_error - mx) <= 1e-6 * mx, "output %d: max_std_error %g, plane %g", k,
                      r->stats.max_std_error, mx);
        }
        if (adaptive) /* the binary and the falloff outputs do not converge alike */
            CHECK(x[0].stats.pixels_converged != x[1].stats.pixels_converged ||
                  x[0].stats.max_std_error != x[1].stats.max_std_error);
        for (int j = 0; j < 2; j++) {
            truth_ao_result_free(&x[j]);
            truth_ao_result_free(&y[j]);
            truth_ao_result_free(&u[j]);
        }
    }
    run_free(&R);
}

TEST(truth_multi_output_refuses_outputs_that_cannot_share_rays)
{
    ao_run R;
    CHECK_MSG(floor_setup(&R, 4, obs_v3(0, 2, 2)), "setup: %s", obs_context_last_error(R.ctx));
    truth_ao_params p = truth_ao_params_default();
    p.max_samples = 64;
    truth_ao_result out[TRUTH_AO_MAX_OUTPUTS + 1];
    const truth_ao_output mixed[] = {{TRUTH_AO_COS, 0.5f}, {TRUTH_AO_UNIF, 0.5f}};
    const truth_ao_output vol[] = {{TRUTH_AO_VOL, 0.5f}, {TRUTH_AO_VOL, 0.2f}};
    const truth_ao_output inf_obs[] = {{TRUTH_AO_COS, 0.5f}, {TRUTH_AO_OBS_SAO_B, INFINITY}};
    const truth_ao_output bad_est[] = {{TRUTH_AO_COS, 0.5f}, {(truth_ao_estimator)99, 0.5f}};
    truth_ao_output many[TRUTH_AO_MAX_OUTPUTS + 1];
    for (int j = 0; j <= TRUTH_AO_MAX_OUTPUTS; j++)
        many[j] = (truth_ao_output){TRUTH_AO_COS, 0.1f * (float)(j + 1)};
    const struct { const truth_ao_output *o; int n; const char *what; } bad[] = {
        {mixed, 2, "share"}, {vol, 2, "share"}, {inf_obs, 2, "radius"}, {bad_est, 2, "out of range"},
        {many, TRUTH_AO_MAX_OUTPUTS + 1, "outputs"}, {many, 0, "outputs"}, {NULL, 1, "NULL"}};
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        obs_context_clear_error(R.ctx);
        obs_status st = truth_ao_render_multi(R.ctx, NULL, R.ts, &R.scene, &R.cam, &R.gb, &p, bad[k].o, bad[k].n, out);
        CHECK_MSG(st == OBS_STATUS_INVALID_ARGUMENT, "case %zu: status %d", k, (int)st);
        CHECK_MSG(strstr(obs_context_last_error(R.ctx), bad[k].what) != NULL, "case %zu: message '%s'", k,
                  obs_context_last_error(R.ctx));
    }
    /* the full 16 are accepted */
    CHECK_OK(truth_ao_render_multi(R.ctx, NULL, R.ts, &R.scene, &R.cam, &R.gb, &p, many, TRUTH_AO_MAX_OUTPUTS, out), R.ctx);
    for (int j = 0; j < TRUTH_AO_MAX_OUTPUTS; j++) {
        CHECK(out[j].width == 8 && px(&out[j].count, 4, 4) >= 64.0f);
        truth_ao_result_free(&out[j]);
    }
    run_free(&R);
}

/* A G-buffer rendered with a guard band gives the same inner pixels (the same rays, see
 * docs/conventions.md), so the ground truth of its inner image is the same, bit for bit; the
 * tile size does not matter either. */
TEST(truth_guard_band_and_tile_size_do_not_change_the_result)
{
    ao_run R;
    memset(&R, 0, sizeof R);
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 5, 16);
    mb_sphere(&mb, 0, 0.5, 0, 0.5, 32, 16);
    mb_to_scene(&mb, &R.scene);
    CHECK_MSG(run_setup(&R, obs_v3(1.5f, 1.5f, 2.5f), obs_v3(0.2f, 0.3f, 0), 33, 21), "setup: %s",
              obs_context_last_error(R.ctx));
    truth_ao_params p = truth_ao_params_default();
    p.radius = 0.6f;
    p.target_error = 0.02;
    p.max_samples = 256;
    truth_ao_result a, b, c;
    CHECK_OK(run_ao(&R, NULL, &p, &a), R.ctx);
    p.tile = 16;
    CHECK_OK(run_ao(&R, NULL, &p, &c), R.ctx);
    CHECK_MSG(planes_equal(&a, &c), "tile 8 and tile 16 differ");
    p.tile = 8;
    rast_params rp = R.rp;
    rp.guard = 5;
    rast_gbuffer gb;
    CHECK_OK(rast_gbuffer_alloc(R.ctx, &rp, &gb), R.ctx);
    rast_view v = {R.cam};
    CHECK_OK(rast_render(R.ctx, NULL, &R.scene, &v, 1, &rp, &gb, NULL), R.ctx);
    CHECK_OK(truth_ao_render(R.ctx, NULL, R.ts, &R.scene, &R.cam, &gb, &p, &b), R.ctx);
    CHECK_EQ_INT(b.width, 33);
    CHECK_EQ_INT(b.height, 21);
    CHECK_MSG(planes_equal(&a, &b), "guard band 0 and 5 differ");
    truth_ao_result_free(&a);
    truth_ao_result_free(&b);
    truth_ao_result_free(&c);
    rast_gbuffer_free(&gb);
    run_free(&R);
}

/* ---- obscurance estimators ---------------------------------------------------------------------- */

/* The sphere cap with a finite radius r: along a direction at angle theta from n (the sphere's
 * centre lies along n), the hit distance is t(theta) = h cos(theta) - sqrt(R^2 - h^2 sin^2(theta))
 * for theta < alpha. So
 *   cosine-weighted: V = 1 - 2 Int_0^alpha rho(min(t, r)) cos sin dtheta
 *   uniform:         V = 1 -   Int_0^alpha rho(min(t, r)) sin dtheta
 * with rho = 0 from r on; a composite midpoint rule with 2e5 steps is the reference. */
static double rho_of(truth_ao_estimator e, double d, double r)
{
    if (d >= r)
        return 0;
    double x = 1 - d * d / (r * r);
    return e == TRUTH_AO_OBS_SAO_B ? x * x * x : x;
}

static double cap_obscurance_quadrature(truth_ao_estimator e, double r)
{
    double alpha = asin(CAP_R / CAP_H);
    const int n = 200000;
    double sum = 0, dt = alpha / n;
    for (int i = 0; i < n; i++) {
        double th = (i + 0.5) * dt, st = sin(th), ct = cos(th);
        double t = CAP_H * ct - sqrt(fmax(0, CAP_R * CAP_R - CAP_H * CAP_H * st * st));
        double rho = rho_of(e, t, r);
        sum += e == TRUTH_AO_OBS_HBAO ? rho * st : 2 * rho * ct * st;
    }
    return 1 - sum * dt;
}

TEST(truth_obscurance_estimators_match_quadrature)
{
    ao_run R;
    CHECK_MSG(cap_setup(&R), "setup: %s", obs_context_last_error(R.ctx));
    allow_samples(R.ctx, (int64_t)1 << 22);
    static const truth_ao_estimator est[] = {TRUTH_AO_OBS_SAO_B, TRUTH_AO_OBS_SAO_LINEAR, TRUTH_AO_OBS_MSSAO,
                                             TRUTH_AO_OBS_HBAO};
    const double r = 1.5; /* the cap's hit distances run from h - R = 1 to h cos(alpha) = 1.73 */
    float linear_mean = -1;
    for (int k = 0; k < 4; k++) {
        double want = cap_obscurance_quadrature(est[k], r);
        truth_ao_params p = truth_ao_params_default();
        p.estimator = est[k];
        p.radius = (float)r;
        p.target_error = 1.5e-4;
        p.min_samples = 1024;
        p.max_samples = (int64_t)1 << 22;
        truth_ao_result res;
        CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
        double m = px(&res.mean, 0, 0), se = px(&res.std_error, 0, 0);
        printf("%s r=%g: V = %.6f +- %.2g (%g samples), quadrature %.6f\n", truth_ao_estimator_name(est[k]), r, m, se,
               (double)px(&res.count, 0, 0), want);
        /* the mesh's hit distances are longer by up to R (1 - cos^2(pi/256)) = 1.5e-4: |drho| <= 2 d/r^2 * 1.5e-4 */
        CHECK_MSG(fabs(m - want) <= 3 * se + 1.5e-4, "%s: %.6f vs %.6f (se %.2g)", truth_ao_estimator_name(est[k]), m, want, se);
        CHECK(se <= 1.5e-4 && fabs(m - want) <= 1e-3);
        /* SAO's linear falloff and MSSAO's are the same integral: the same seed gives the same bits */
        if (est[k] == TRUTH_AO_OBS_SAO_LINEAR)
            linear_mean = (float)m;
        if (est[k] == TRUTH_AO_OBS_MSSAO)
            CHECK(linear_mean == (float)m);
        truth_ao_result_free(&res);
    }
    run_free(&R);
}

/* ---- the two origins agree -------------------------------------------------------------------- */

TEST(truth_embree_origin_agrees_with_gbuffer_origin)
{
    ao_run R;
    memset(&R, 0, sizeof R);
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 5, 16);
    mb_sphere(&mb, 0, 0.5, 0, 0.5, 48, 24);
    mb_to_scene(&mb, &R.scene);
    CHECK_MSG(run_setup(&R, obs_v3(1.5f, 1.5f, 2.5f), obs_v3(0, 0.3f, 0), 24, 18), "setup: %s",
              obs_context_last_error(R.ctx));
    truth_ao_params p = truth_ao_params_default();
    p.radius = 0.5f;
    p.target_error = 0.004;
    truth_ao_result a, b;
    CHECK_OK(run_ao(&R, NULL, &p, &a), R.ctx);
    p.origin = TRUTH_AO_ORIGIN_EMBREE;
    p.seed = 99;
    CHECK_OK(run_ao(&R, NULL, &p, &b), R.ctx);
    CHECK_EQ_INT(b.stats.primary_rays, 24 * 18);
    int both = 0, far = 0;
    for (int y = 0; y < a.height; y++)
        for (int x = 0; x < a.width; x++) {
            if (px(&a.count, x, y) == 0 || px(&b.count, x, y) == 0)
                continue;
            both++;
            double d = px(&a.mean, x, y) - px(&b.mean, x, y);
            double s = sqrt(px(&a.std_error, x, y) * px(&a.std_error, x, y) + px(&b.std_error, x, y) * px(&b.std_error, x, y));
            if (fabs(d) > 4 * s + 1e-6) {
                far++;
                printf("  pixel (%d,%d): G-buffer %.4f +- %.4f (%g), Embree %.4f +- %.4f (%g)\n", x, y,
                       (double)px(&a.mean, x, y), (double)px(&a.std_error, x, y), (double)px(&a.count, x, y),
                       (double)px(&b.mean, x, y), (double)px(&b.std_error, x, y), (double)px(&b.count, x, y));
            }
        }
    printf("%d pixels with a surface in both, %d differ by more than 4 standard errors\n", both, far);
    CHECK(both > 300);
    CHECK(far <= both / 100);
    truth_ao_result_free(&a);
    truth_ao_result_free(&b);
    run_free(&R);
}

/* ---- the Embree scene's layout: flat (world-space triangles) against two-level instances -------- */

/* A scene of two meshes drawn by five instances: a floor grid once (tilted, moved far from the
 * origin), a 64 x 32 sphere three times (scaled non-uniformly, mirrored in x: det < 0, and
 * rotated), and a closed box once, around which the camera looks. Instance 0 draws mesh 0. */
static void layout_scene(obs_scene *s)
{
    mesh_b fl = {0}, sp = {0};
    mb_floor(&fl, 0, 0, 0, 6, 24);
    mb_sphere(&sp, 0, 0, 0, 1, 64, 32);
    obs_scene_init(s);
    s->meshes = (obs_mesh *)calloc(2, sizeof(obs_mesh));
    s->mesh_count = 2;
    mesh_b *mb[2] = {&fl, &sp};
    for (int m = 0; m < 2; m++) {
        obs_mesh *o = &s->meshes[m];
        snprintf(o->name, sizeof o->name, "m%d", m);
        o->vertex_count = mb[m]->nv;
        o->triangle_count = mb[m]->nt;
        o->positions = mb[m]->pos;
        o->indices = mb[m]->idx;
        o->material = -1;
    }
    double a = 25 * OBS_PI / 180;
    obs_mat4 tilt = obs_mat4_from_quat((obs_vec4){(float)sin(a / 2), 0, 0, (float)cos(a / 2)});
    obs_mat4 far = obs_mat4_mul(obs_mat4_translation(obs_v3(300, -40, 500)), tilt);
    obs_mat4 w[4] = {
        far,
        obs_mat4_mul(far, obs_mat4_mul(obs_mat4_translation(obs_v3(-1.5f, 0.9f, 0.3f)), obs_mat4_scale(obs_v3(1.2f, 0.7f, 1.0f)))),
        obs_mat4_mul(far, obs_mat4_mul(obs_mat4_translation(obs_v3(1.2f, 1.0f, -0.5f)), obs_mat4_scale(obs_v3(-1.0f, 1.0f, 1.0f)))),
        obs_mat4_mul(far, obs_mat4_mul(obs_mat4_translation(obs_v3(0.2f, 0.4f, 1.6f)),
                                       obs_mat4_mul(obs_mat4_from_quat((obs_vec4){0, 0.3826834f, 0, 0.9238795f}),
                                                    obs_mat4_scale(obs_v3(0.5f, 0.5f, 0.5f))))),
    };
    s->instances = (obs_instance *)calloc(4, sizeof(obs_instance));
    s->instance_count = 4;
    for (uint32_t i = 0; i < 4; i++) {
        s->instances[i].mesh = i == 0 ? 0 : 1;
        s->instances[i].node = i;
        s->instances[i].world = w[i];
    }
    obs_scene_update_bounds(s);
}

/* The world-space vertices (in double) of triangle prim of instance inst. */
static void tri_world(const obs_scene *s, uint32_t inst, uint32_t prim, double v[3][3])
{
    const obs_instance *in = &s->instances[inst];
    const obs_mesh *m = &s->meshes[in->mesh];
    for (int a = 0; a < 3; a++) {
        const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)prim + a]];
        for (int c = 0; c < 3; c++)
            v[a][c] = (double)in->world.m[c] * p[0] + (double)in->world.m[4 + c] * p[1] +
                      (double)in->world.m[8 + c] * p[2] + (double)in->world.m[12 + c];
    }
}

static int layout_setup(ao_run *R, truth_scene_layout layout, int64_t limit)
{
    memset(R, 0, sizeof *R);
    layout_scene(&R->scene);
    const obs_mat4 far = R->scene.instances[0].world;
    R->ctx = obs_context_create();
    R->cam = obs_camera_look_at(obs_mat4_mul_point(far, obs_v3(0.5f, 3.5f, 5.0f)), obs_mat4_mul_point(far, obs_v3(0, 0.5f, 0)),
                                obs_v3(0, 1, 0), 0.9f, 0.01f, 1e5f);
    R->rp = rast_params_default();
    R->rp.width = 48;
    R->rp.height = 36;
    R->rp.outputs |= RAST_OUT_NORMAL;
    rast_view v = {R->cam};
    if (rast_gbuffer_alloc(R->ctx, &R->rp, &R->gb) != OBS_STATUS_OK ||
        rast_render(R->ctx, NULL, &R->scene, &v, 1, &R->rp, &R->gb, NULL) != OBS_STATUS_OK)
        return 0;
    truth_scene_options o = truth_scene_options_default();
    o.layout = layout;
    o.flat_limit_bytes = limit;
    return truth_scene_create_ex(R->ctx, &R->scene, &o, &R->ts) == OBS_STATUS_OK;
}

/* Flattening changes where Embree computes (world space instead of each instance's object space)
 * and rounds the world-space vertices once: a ray can only change its verdict where it passes
 * within rounding of a triangle's edge or ends within rounding of a surface. So the estimates are
 * equal but for such rays: with a fixed count N, a pixel's mean moves by a multiple of 1/N (binary
 * estimators) or by rounding of t (falloff estimators). Checked: primary hits (same instance and
 * primitive, t and ng within 1e-5), and the visibility of every pixel under the three layouts
 * (flat, two-level, and the limit's mix: the sphere two-level, the floor flat), for cos (r = 1
 * and infinity, both origins) and obs-sao (r = 0.5). The scene sits at (300, -40, 500), where a
 * float's half ulp is 1.5e-5. Observed (2026-12-02): cos r = 1 changes 1 to 5 ray verdicts of
 * 330,496 (a pixel by 1/256), r = infinity none; obs-sao moves 176 pixels by at most 7.8e-5;
 * ng differs by up to 7.5e-4 (8% of its bound). Allowed: 1e-4 of the rays changing their
 * verdict, a falloff estimate within the rounding bound below. */
TEST(truth_flat_and_instanced_scenes_give_the_same_visibility)
{
    ao_run F, I, X;
    CHECK_MSG(layout_setup(&F, TRUTH_SCENE_FLAT, 0), "setup: %s", obs_context_last_error(F.ctx));
    CHECK_MSG(layout_setup(&I, TRUTH_SCENE_INSTANCED, 0), "setup: %s", obs_context_last_error(I.ctx));
    CHECK_MSG(layout_setup(&X, TRUTH_SCENE_AUTO, 0), "setup: %s", obs_context_last_error(X.ctx));
    truth_scene_info fi, ii, xi;
    truth_scene_get_info(F.ts, &fi);
    truth_scene_get_info(I.ts, &ii);
    truth_scene_get_info(X.ts, &xi);
    CHECK(fi.instances_flat == 4 && fi.instances_two_level == 0);
    CHECK(ii.instances_flat == 0 && ii.instances_two_level == 4);
    CHECK(xi.instances_flat == 1 && xi.instances_two_level == 3);
    /* primary rays through every pixel */
    truth_thread_init();
    int hits = 0;
    double worst_n = 0, worst_nr = 0;
    for (int y = 0; y < F.rp.height; y++)
        for (int x = 0; x < F.rp.width; x++) {
            obs_dvec3 o, d;
            rast_pixel_ray(&F.gb.constants, &F.cam, x + 0.5, y + 0.5, &o, &d);
            obs_vec3 of = obs_v3((float)o.x, (float)o.y, (float)o.z), df = obs_v3((float)d.x, (float)d.y, (float)d.z);
            truth_hit hf, hi, hx;
            truth_intersect1(F.ts, of, df, F.cam.znear, F.cam.zfar, &hf);
            truth_intersect1(I.ts, of, df, F.cam.znear, F.cam.zfar, &hi);
            truth_intersect1(X.ts, of, df, F.cam.znear, F.cam.zfar, &hx);
            const truth_hit *other[2] = {&hi, &hx};
            for (int k = 0; k < 2; k++) {
                CHECK_MSG(hf.instance == other[k]->instance && hf.prim == other[k]->prim,
                          "pixel (%d,%d): flat hits %u/%u, layout %d hits %u/%u", x, y, hf.instance, hf.prim, k,
                          other[k]->instance, other[k]->prim);
                if (hf.instance == 0xFFFFFFFFu)
                    continue;
                /* The flat triangle's world vertices are rounded once: each off by up to 1/2 ulp,
                 * under delta = 2^-24 m, m = their largest coordinate (far from the origin here).
                 * Ng = e1 x e2 then moves by at most ~2 delta (|e1| + |e2|) against |e1 x e2| =
                 * 2 area, and the hit point by ~delta / |cos| along the ray. */
                double v[3][3], m = 0;
                tri_world(&F.scene, hf.instance, hf.prim, v);
                for (int a = 0; a < 3; a++)
                    for (int c = 0; c < 3; c++)
                        m = fabs(v[a][c]) > m ? fabs(v[a][c]) : m;
                double e1[3], e2[3], e3[3], cr[3];
                for (int c = 0; c < 3; c++) {
                    e1[c] = v[1][c] - v[0][c];
                    e2[c] = v[2][c] - v[0][c];
                    e3[c] = v[2][c] - v[1][c];
                }
                cr[0] = e1[1] * e2[2] - e1[2] * e2[1];
                cr[1] = e1[2] * e2[0] - e1[0] * e2[2];
                cr[2] = e1[0] * e2[1] - e1[1] * e2[0];
                double area2 = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
                double per = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]) + sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]) +
                             sqrt(e3[0] * e3[0] + e3[1] * e3[1] + e3[2] * e3[2]);
                double delta = 0x1p-24 * m;
                double tol_n = 1e-5 + 4 * delta * per / area2;
                double dl = sqrt((double)df.x * df.x + (double)df.y * df.y + (double)df.z * df.z);
                double cosi = fabs(((double)hf.ng.x * df.x + (double)hf.ng.y * df.y + (double)hf.ng.z * df.z) / dl);
                double tol_t = 1e-5 * hf.t + 4 * delta / (dl * (cosi > 1e-3 ? cosi : 1e-3));
                double dn = fabs(hf.ng.x - other[k]->ng.x);
                dn = fabs(hf.ng.y - other[k]->ng.y) > dn ? fabs(hf.ng.y - other[k]->ng.y) : dn;
                dn = fabs(hf.ng.z - other[k]->ng.z) > dn ? fabs(hf.ng.z - other[k]->ng.z) : dn;
                CHECK_MSG(fabs(hf.t - other[k]->t) <= tol_t, "pixel (%d,%d): t %.9g vs %.9g (bound %.3g)", x, y,
                          (double)hf.t, (double)other[k]->t, tol_t);
                CHECK_MSG(dn <= tol_n, "pixel (%d,%d): ng differs by %.3g (bound %.3g)", x, y, dn, tol_n);
                worst_n = dn > worst_n ? dn : worst_n;
                worst_nr = dn / tol_n > worst_nr ? dn / tol_n : worst_nr;
            }
            hits += hf.instance != 0xFFFFFFFFu;
        }
    CHECK(hits > 1000);
    printf("primary hits: %d, same ids in all three layouts; ng worst difference %.3g (%.2f of its bound)\n", hits, worst_n,
           worst_nr);
    struct { truth_ao_estimator e; float r; truth_ao_origin org; } cases[] = {
        {TRUTH_AO_COS, 1.0f, TRUTH_AO_ORIGIN_GBUFFER}, {TRUTH_AO_COS, INFINITY, TRUTH_AO_ORIGIN_GBUFFER},
        {TRUTH_AO_COS, 1.0f, TRUTH_AO_ORIGIN_EMBREE}, {TRUTH_AO_OBS_SAO_B, 0.5f, TRUTH_AO_ORIGIN_GBUFFER}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        truth_ao_params p = truth_ao_params_default();
        p.estimator = cases[c].e;
        p.radius = cases[c].r;
        p.origin = cases[c].org;
        p.min_samples = p.max_samples = 256;
        truth_ao_result rf, ri, rx;
        CHECK_OK(run_ao(&F, NULL, &p, &rf), F.ctx);
        CHECK_OK(run_ao(&I, NULL, &p, &ri), I.ctx);
        CHECK_OK(run_ao(&X, NULL, &p, &rx), X.ctx);
        const truth_ao_result *other[2] = {&ri, &rx};
        for (int k = 0; k < 2; k++) {
            double rays_changed = 0, worst = 0;
            int pixels_differ = 0;
            for (int y = 0; y < rf.height; y++)
                for (int x = 0; x < rf.width; x++) {
                    CHECK(px(&rf.count, x, y) == px(&other[k]->count, x, y));
                    double dm = fabs((double)px(&rf.mean, x, y) - px(&other[k]->mean, x, y));
                    pixels_differ += dm > 0;
                    worst = dm > worst ? dm : worst;
                    rays_changed += dm * px(&rf.count, x, y);
                }
            printf("%s r=%g origin %d, flat vs %s: %d pixels differ, worst %.3g, %.1f ray verdicts of %llu\n",
                   truth_ao_estimator_name(cases[c].e), (double)cases[c].r, (int)cases[c].org,
                   k ? "mixed" : "instanced", pixels_differ, worst, rays_changed, (unsigned long long)rf.stats.rays);
            CHECK(rf.stats.pixels_surface > 1000 && rf.stats.rays == other[k]->stats.rays);
            if (cases[c].e == TRUTH_AO_COS)
                CHECK_MSG(rays_changed <= 1e-4 * (double)rf.stats.rays, "%.1f rays changed", rays_changed);
            else /* each ray's 1 - rho(t) moves by at most |rho'| |dt| <= (6 / r) 4 delta, delta = 2^-24 m,
                    m = 512 bounding the scene's coordinates (grazing rays aside: none changed here) */
                CHECK_MSG(worst <= 6.0 / cases[c].r * 4 * 0x1p-24 * 512, "an obscurance estimate moved by %g", worst);
        }
        truth_ao_result_free(&rf);
        truth_ao_result_free(&ri);
        truth_ao_result_free(&rx);
    }
    run_free(&F);
    run_free(&I);
    run_free(&X);
}

/* AUTO flattens a mesh while the extra copies (all but the first of a mesh, at
 * truth_scene_mesh_bytes each) fit the limit; FLAT and INSTANCED ignore it; a mesh drawn once is
 * flattened at any limit; bad options are refused. */
TEST(truth_scene_layout_follows_the_flat_memory_limit)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    layout_scene(&s);
    const int64_t extra = 2 * truth_scene_mesh_bytes(&s.meshes[1]); /* the sphere's two extra copies */
    struct { truth_scene_layout layout; int64_t limit; uint32_t flat; } cases[] = {
        {TRUTH_SCENE_AUTO, TRUTH_SCENE_FLAT_LIMIT_BYTES, 4},
        {TRUTH_SCENE_AUTO, extra, 4},
        {TRUTH_SCENE_AUTO, extra - 1, 1},
        {TRUTH_SCENE_AUTO, 0, 1},
        {TRUTH_SCENE_FLAT, 0, 4},
        {TRUTH_SCENE_INSTANCED, TRUTH_SCENE_FLAT_LIMIT_BYTES, 0},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        truth_scene_options o = truth_scene_options_default();
        o.layout = cases[c].layout;
        o.flat_limit_bytes = cases[c].limit;
        truth_scene *ts = NULL;
        CHECK_OK(truth_scene_create_ex(ctx, &s, &o, &ts), ctx);
        truth_scene_info info;
        truth_scene_get_info(ts, &info);
        CHECK_MSG(info.instances_flat == cases[c].flat && info.instances_two_level == 4 - cases[c].flat,
                  "%s, limit %lld: %u flat, %u two-level", truth_scene_layout_name(cases[c].layout),
                  (long long)cases[c].limit, info.instances_flat, info.instances_two_level);
        CHECK(info.flat_extra_bytes == (cases[c].flat == 4 ? extra : 0));
        uint64_t tris = 0;
        for (uint32_t i = 0; i < s.instance_count; i++)
            tris += cases[c].flat == 4 || i == 0 ? s.meshes[s.instances[i].mesh].triangle_count : 0;
        CHECK(info.triangles_flat == (cases[c].flat ? tris : 0));
        truth_scene_destroy(ts);
    }
    CHECK(truth_scene_options_default().layout == TRUTH_SCENE_AUTO);
    CHECK(truth_scene_options_default().flat_limit_bytes == TRUTH_SCENE_FLAT_LIMIT_BYTES);
    truth_scene_options o = truth_scene_options_default();
    truth_scene *ts = NULL;
    o.flat_limit_bytes = -1;
    CHECK(truth_scene_create_ex(ctx, &s, &o, &ts) == OBS_STATUS_INVALID_ARGUMENT && !ts);
    o = truth_scene_options_default();
    o.layout = TRUTH_SCENE_LAYOUT_COUNT;
    CHECK(truth_scene_create_ex(ctx, &s, &o, &ts) == OBS_STATUS_INVALID_ARGUMENT && !ts);
    o = truth_scene_options_default();
    o.quality = TRUTH_BUILD_COUNT;
    CHECK(truth_scene_create_ex(ctx, &s, &o, &ts) == OBS_STATUS_INVALID_ARGUMENT && !ts);
    CHECK(truth_scene_create_ex(ctx, &s, NULL, &ts) == OBS_STATUS_INVALID_ARGUMENT && !ts);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- refusals ----------------------------------------------------------------------------------- */

TEST(truth_bad_parameters_are_refused)
{
    ao_run R;
    CHECK_MSG(floor_setup(&R, 2, obs_v3(1, 2, 3)), "setup: %s", obs_context_last_error(R.ctx));
    struct { const char *what; truth_ao_params p; obs_status want; } c[32];
    int n = 0;
#define CASE(desc, field, value, status)                                                         \
    do {                                                                                         \
        c[n].what = desc;                                                                        \
        c[n].p = truth_ao_params_default();                                                      \
        c[n].p.field = value;                                                                    \
        c[n].want = status;                                                                      \
        n++;                                                                                     \
    } while (0)
    CASE("radius 0", radius, 0.0f, OBS_STATUS_INVALID_ARGUMENT);
    CASE("radius < 0", radius, -1.0f, OBS_STATUS_INVALID_ARGUMENT);
    CASE("radius NaN", radius, NAN, OBS_STATUS_INVALID_ARGUMENT);
    CASE("target < 0", target_error, -0.001, OBS_STATUS_INVALID_ARGUMENT);
    CASE("target NaN", target_error, NAN, OBS_STATUS_INVALID_ARGUMENT);
    CASE("target inf", target_error, INFINITY, OBS_STATUS_INVALID_ARGUMENT);
    CASE("batch 1", batch, 1, OBS_STATUS_INVALID_ARGUMENT);
    CASE("batch 2048", batch, 2048, OBS_STATUS_INVALID_ARGUMENT);
    CASE("min below the batch", min_samples, 8, OBS_STATUS_INVALID_ARGUMENT);
    CASE("min 0", min_samples, 0, OBS_STATUS_INVALID_ARGUMENT);
    CASE("max over 2^31", max_samples, ((int64_t)1 << 31) + 16, OBS_STATUS_INVALID_ARGUMENT);
    CASE("min not a multiple", min_samples, 70, OBS_STATUS_INVALID_ARGUMENT);
    CASE("max < min", max_samples, 32, OBS_STATUS_INVALID_ARGUMENT);
    CASE("max not a multiple", max_samples, 4100, OBS_STATUS_INVALID_ARGUMENT);
    CASE("max over the limit", max_samples, (int64_t)1 << 21, OBS_STATUS_LIMIT_EXCEEDED);
    CASE("tile 2", tile, 2, OBS_STATUS_INVALID_ARGUMENT);
    CASE("tile 64", tile, 64, OBS_STATUS_INVALID_ARGUMENT);
    CASE("offset < 0", offset_ulps, -1.0f, OBS_STATUS_INVALID_ARGUMENT);
    CASE("offset inf", offset_ulps, INFINITY, OBS_STATUS_INVALID_ARGUMENT);
    CASE("estimator out of range", estimator, TRUTH_AO_COUNT, OBS_STATUS_INVALID_ARGUMENT);
    CASE("normal out of range", normal, TRUTH_AO_NORMAL_COUNT, OBS_STATUS_INVALID_ARGUMENT);
    CASE("origin out of range", origin, TRUTH_AO_ORIGIN_COUNT, OBS_STATUS_INVALID_ARGUMENT);
    CASE("replicates 1", replicates, 1, OBS_STATUS_INVALID_ARGUMENT);
    CASE("replicates 33", replicates, 33, OBS_STATUS_INVALID_ARGUMENT);
    CASE("replicates not dividing the batch", replicates, 3, OBS_STATUS_INVALID_ARGUMENT);
    CASE("error bar out of range", error_bar, TRUTH_AO_BAR_COUNT, OBS_STATUS_INVALID_ARGUMENT);
    /* obscurance and VOL need a finite radius */
    CASE("SAO with r = inf", estimator, TRUTH_AO_OBS_SAO_B, OBS_STATUS_INVALID_ARGUMENT);
    c[n - 1].p.radius = INFINITY;
    CASE("VOL with r = inf", estimator, TRUTH_AO_VOL, OBS_STATUS_INVALID_ARGUMENT);
    c[n - 1].p.radius = INFINITY;
#undef CASE
    for (int k = 0; k < n; k++) {
        truth_ao_result res;
        memset(&res, 0xAB, sizeof res);
        obs_context_clear_error(R.ctx);
        obs_status st = run_ao(&R, NULL, &c[k].p, &res);
        CHECK_MSG(st == c[k].want, "%s: got %s, want %s", c[k].what, obs_status_string(st), obs_status_string(c[k].want));
        CHECK_MSG(obs_context_last_error(R.ctx)[0] != '\0', "%s: no message", c[k].what);
        CHECK(res.mean.data == NULL && res.count.data == NULL && res.width == 0);
    }
    /* the limit is the context's: raising it lets the same request through */
    obs_limits lim = *obs_context_limits(R.ctx);
    lim.max_samples = (int64_t)1 << 22;
    obs_context_set_limits(R.ctx, &lim);
    truth_ao_params p = truth_ao_params_default();
    p.max_samples = (int64_t)1 << 21;
    truth_ao_result res;
    CHECK_OK(run_ao(&R, NULL, &p, &res), R.ctx);
    truth_ao_result_free(&res);
    /* NULLs */
    p = truth_ao_params_default();
    CHECK(truth_ao_render(R.ctx, NULL, NULL, &R.scene, &R.cam, &R.gb, &p, &res) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(truth_ao_render(R.ctx, NULL, R.ts, &R.scene, &R.cam, &R.gb, NULL, &res) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(truth_ao_render(R.ctx, NULL, R.ts, &R.scene, &R.cam, &R.gb, &p, NULL) == OBS_STATUS_INVALID_ARGUMENT);
    /* a G-buffer without the planes the G-buffer origin needs */
    rast_params rp = R.rp;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL;
    rast_gbuffer gb2;
    CHECK_OK(rast_gbuffer_alloc(R.ctx, &rp, &gb2), R.ctx);
    rast_view v = {R.cam};
    CHECK_OK(rast_render(R.ctx, NULL, &R.scene, &v, 1, &rp, &gb2, NULL), R.ctx);
    obs_context_clear_error(R.ctx);
    CHECK(truth_ao_render(R.ctx, NULL, R.ts, &R.scene, &R.cam, &gb2, &p, &res) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(R.ctx), "face normal") != NULL);
    /* ... which the Embree origin does not need */
    p.origin = TRUTH_AO_ORIGIN_EMBREE;
    CHECK_OK(truth_ao_render(R.ctx, NULL, R.ts, &R.scene, &R.cam, &gb2, &p, &res), R.ctx);
    truth_ao_result_free(&res);
    rast_gbuffer_free(&gb2);
    /* names round-trip */
    for (int e = 0; e < TRUTH_AO_COUNT; e++) {
        truth_ao_estimator back;
        CHECK(truth_ao_estimator_from_name(truth_ao_estimator_name((truth_ao_estimator)e), &back) && back == (truth_ao_estimator)e);
    }
    truth_ao_estimator dummy;
    CHECK(!truth_ao_estimator_from_name("ssao", &dummy));
    run_free(&R);
}

/* ---- the CLI ------------------------------------------------------------------------------------ */

/* A small glTF (external .bin) with a unit sphere resting on a plane, no camera (the CLI frames
 * the bounds). */
static int write_sphere_on_plane_gltf(const char *dir, char *path, size_t path_size)
{
    mesh_b mb = {0};
    mb_floor(&mb, 0, 0, 0, 3, 6);
    mb_sphere(&mb, 0, 1, 0, 1, 32, 16);
    char bin[4096];
    snprintf(bin, sizeof bin, "%s/scene.bin", dir);
    FILE *f = fopen(bin, "wb");
    if (!f)
        return 0;
    size_t pos_bytes = sizeof(float) * 3 * mb.nv, idx_bytes = sizeof(uint32_t) * 3 * mb.nt;
    fwrite(mb.pos, 1, pos_bytes, f);
    fwrite(mb.idx, 1, idx_bytes, f);
    fclose(f);
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t v = 0; v < mb.nv; v++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fminf(lo[c], mb.pos[3 * v + c]);
            hi[c] = fmaxf(hi[c], mb.pos[3 * v + c]);
        }
    snprintf(path, path_size, "%s/scene.gltf", dir);
    f = fopen(path, "w");
    if (!f)
        return 0;
    fprintf(f,
            "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
            "\"nodes\":[{\"mesh\":0,\"name\":\"sphere_on_plane\"}],"
            "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":4}]}],"
            "\"buffers\":[{\"uri\":\"scene.bin\",\"byteLength\":%zu}],"
            "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":%zu},"
            "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
            "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%u,\"type\":\"VEC3\","
            "\"min\":[%.9g,%.9g,%.9g],\"max\":[%.9g,%.9g,%.9g]},"
            "{\"bufferView\":1,\"componentType\":5125,\"count\":%u,\"type\":\"SCALAR\"}]}\n",
            pos_bytes + idx_bytes, pos_bytes, pos_bytes, idx_bytes, mb.nv, (double)lo[0], (double)lo[1],
            (double)lo[2], (double)hi[0], (double)hi[1], (double)hi[2], 3 * mb.nt);
    fclose(f);
    free(mb.pos);
    free(mb.idx);
    return 1;
}

static int run_cli(const char *args)
{
    char cmd[8192];
    if ((size_t)snprintf(cmd, sizeof cmd, "'%s' %s > /dev/null 2>&1", OBS_CLI_PATH, args) >= sizeof cmd)
        return -1;
    int rc = system(cmd);
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = (char *)malloc((size_t)n + 1);
    size_t got = fread(b, 1, (size_t)n, f);
    b[got] = '\0';
    fclose(f);
    return b;
}

static int file_exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 && S_ISREG(sb.st_mode);
}

/* The generated sphere_on_plane.glb (two instances, two cameras) when the data generator has run,
 * else a glTF written here. */
TEST(truth_cli_writes_exr_with_mean_stderr_count)
{
    const char *dir = test_tmpdir();
    char scene[1024];
    const char *gen = test_path(test_data_dir(), "sphere_on_plane.glb");
    if (file_exists(gen) && strlen(gen) < sizeof scene) {
        strcpy(scene, gen);
        printf("scene: %s (generated)\n", scene);
    } else {
        CHECK(write_sphere_on_plane_gltf(dir, scene, sizeof scene));
        printf("scene: %s (written by this test: no generated sphere_on_plane.glb)\n", scene);
    }
    char prefix[1024], args[4096];
    snprintf(prefix, sizeof prefix, "%s/out/ao", dir);
    snprintf(args, sizeof args, "--threads 2 truth ao '%s' --size 64x48 --radius 0.5 --estimator cos --max-samples 256 "
                                "--seed 3 -o '%s'", scene, prefix);
    CHECK_EQ_INT(run_cli(args), 0);
    obs_context *ctx = obs_context_create();
    io_image im;
    char path[1100];
    snprintf(path, sizeof path, "%s.exr", prefix);
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    CHECK_EQ_INT(im.width, 64);
    CHECK_EQ_INT(im.height, 48);
    int cm = io_image_find_channel(&im, "AO.mean"), cs = io_image_find_channel(&im, "AO.stderr"),
        cc = io_image_find_channel(&im, "AO.count"), cz = io_image_find_channel(&im, "Z");
    CHECK(cm >= 0 && cs >= 0 && cc >= 0 && cz >= 0);
    int surface = 0, occluded = 0;
    for (int y = 0; y < 48; y++)
        for (int x = 0; x < 64; x++) {
            float m = px(&im.f32[cm], x, y), s = px(&im.f32[cs], x, y), c = px(&im.f32[cc], x, y), z = px(&im.f32[cz], x, y);
            CHECK(isfinite(m) && isfinite(s) && isfinite(c));
            CHECK(m >= 0 && m <= 1 && s >= 0);
            if (isfinite(z)) {
                CHECK(c >= 64 && c <= 256);
                surface++;
                occluded += m < 0.9f;
            } else {
                CHECK(c == 0 && m == 1 && s == 0);
            }
        }
    CHECK(surface > 200);
    CHECK(occluded > 10); /* the contact of sphere and plane */
    io_image_free(&im);
    snprintf(path, sizeof path, "%s.png", prefix);
    struct stat sb;
    CHECK(stat(path, &sb) == 0 && sb.st_size > 0);
    snprintf(path, sizeof path, "%s.json", prefix);
    char *json = slurp(path);
    CHECK(json != NULL);
    CHECK(strstr(json, "\"estimator\": \"cos\"") || strstr(json, "\"estimator\":\"cos\""));
    CHECK(strstr(json, "rays") != NULL && strstr(json, "mrays_per_second") != NULL);
    free(json);
    /* the same command on 1 thread writes the same EXR bytes */
    char prefix1[1024];
    snprintf(prefix1, sizeof prefix1, "%s/out/ao1", dir);
    snprintf(args, sizeof args, "--threads 1 truth ao '%s' --size 64x48 --radius 0.5 --estimator cos --max-samples 256 "
                                "--seed 3 -o '%s'", scene, prefix1);
    CHECK_EQ_INT(run_cli(args), 0);
    snprintf(path, sizeof path, "%s.exr", prefix);
    char *e2 = slurp(path);
    snprintf(path, sizeof path, "%s.exr", prefix1);
    char *e1 = slurp(path);
    CHECK(e1 && e2);
    struct stat s1, s2;
    snprintf(path, sizeof path, "%s.exr", prefix);
    stat(path, &s2);
    snprintf(path, sizeof path, "%s.exr", prefix1);
    stat(path, &s1);
    CHECK(s1.st_size == s2.st_size && memcmp(e1, e2, (size_t)s1.st_size) == 0);
    free(e1);
    free(e2);
    /* usage errors exit 2; a missing scene exits 3; an infinite radius with an obscurance estimator is refused */
    snprintf(args, sizeof args, "truth ao '%s' --estimator nope -o '%s'", scene, prefix);
    CHECK_EQ_INT(run_cli(args), 2);
    snprintf(args, sizeof args, "truth ao '%s' --radius -1 -o '%s'", scene, prefix);
    CHECK_EQ_INT(run_cli(args), 2);
    snprintf(args, sizeof args, "truth ao '%s' --replicates 3 -o '%s'", scene, prefix); /* does not divide 16 */
    CHECK_EQ_INT(run_cli(args), 2);
    snprintf(args, sizeof args, "truth ao '%s' --replicates x -o '%s'", scene, prefix);
    CHECK_EQ_INT(run_cli(args), 2);
    snprintf(args, sizeof args, "truth ao '%s' --estimator obs-sao --radius inf -o '%s'", scene, prefix);
    CHECK_EQ_INT(run_cli(args), 2);
    snprintf(args, sizeof args, "truth ao '%s/missing.glb' -o '%s'", dir, prefix);
    CHECK_EQ_INT(run_cli(args), 3);
    snprintf(args, sizeof args, "truth nope '%s'", scene);
    CHECK_EQ_INT(run_cli(args), 2);
    /* the generated closed box, seen from inside: every AO ray is occluded, V = 0 exactly */
    const char *box = test_path(test_data_dir(), "closed_box.glb");
    if (file_exists(box)) {
        snprintf(args, sizeof args, "--threads 2 truth ao '%s' --size 32x24 --radius inf -o '%s/out/box'", box, dir);
        CHECK_EQ_INT(run_cli(args), 0);
        snprintf(path, sizeof path, "%s/out/box.exr", dir);
        CHECK_OK(io_image_read(ctx, path, &im), ctx);
        int cm2 = io_image_find_channel(&im, "AO.mean"), cc2 = io_image_find_channel(&im, "AO.count");
        CHECK(cm2 >= 0 && cc2 >= 0);
        for (int y = 0; y < im.height; y++)
            for (int x = 0; x < im.width; x++) {
                CHECK(px(&im.f32[cc2], x, y) == 704); /* the floor's first count within 0.002 */
                CHECK(px(&im.f32[cm2], x, y) == 0.0f);
            }
        io_image_free(&im);
    }
    obs_context_destroy(ctx);
}
