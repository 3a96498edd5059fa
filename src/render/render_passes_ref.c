/* render_passes_ref.c: --reference, the same frame with the references in place of the
 * approximations (docs/render.md, "Reference"):
 *   ref_scene   the Embree scene (view-independent; cached in memory only)
 *   ref_ao      truth_ao_render with the AO method's matched estimator and radius
 *   ref_ambient ambient x albedo x ref_ao
 *   ref_sss     truth_sss_render (settings.ref_sss: the brute force by default)
 *   ref_volume  the volume's Monte Carlo single-scattering reference (truth_volume_mc_render:
 *               delta tracking, ratio-tracked shadow rays, g = 0, which is the ray caster's
 *               light-volume model with the exact transmittance and chromaticity 1), each ray
 *               stopped at the camera G-buffer's depth as the ray cast is. The light volume's
 *               cone-blurred chromaticity c has no ground truth (docs/volume/truth.md), so the
 *               volume layer's error includes it.
 *   ref_compose beauty composed the same way from direct (shared), ref_ambient, ref_sss, ref_volume.
 * The direct light is shared: both sides use the shadow-mapped Lambert term. */
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int ref_has_sss(const render_job *j) { return j->any_translucent && j->light_count > 0; }
static int ref_has_volume(const render_job *j)
{
    return render_job_has_volume(j) && j->st->volume.rc.shading == VOL_SHADING_LIGHT_VOLUME && j->volume_light >= 0;
}

/* ---- ref_scene --------------------------------------------------------------------------------- */

static unsigned scene_reads(const render_job *j, char *t, size_t n)
{
    (void)j;
    snprintf(t, n, "geometry");
    return 0;
}
static int scene_wanted(const render_job *j, char *r, size_t n)
{
    const int vol = ref_has_volume(j) && j->st->volume.mesh_shadows && j->scene->instance_count > 0;
    if (!(j->st->ao && j->any_opaque) && !ref_has_sss(j) && !vol) {
        snprintf(r, n, "no reference traces rays (no AO, no SSS, no mesh-shadowed volume)");
        return 0;
    }
    snprintf(r, n, "the Embree scene the AO, SSS and volume references trace");
    return 1;
}
static int scene_key(render_job *j, render_key *out)
{
    render_hash h;
    render_hash_init(&h, "ref_scene");
    render_hash_geometry(&h, j->scene);
    *out = render_hash_final(&h);
    return 1;
}
static void ts_free(void *p)
{
    render_truth_scene *t = (render_truth_scene *)p;
    truth_scene_destroy(t->ts);
    t->ts = NULL;
}
static uint64_t ts_bytes(const void *p)
{
    (void)p;
    return 0;
}
const render_product_ops render_ops_truth_scene = {"ref_scene", ts_free, NULL, NULL, sizeof(render_truth_scene),
                                                   ts_bytes};
static obs_status scene_build(render_job *j, void *p)
{
    return truth_scene_create(j->ctx, j->scene, TRUTH_BUILD_MEDIUM, &((render_truth_scene *)p)->ts);
}
static obs_status scene_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    return render_cached(j, RES_REF_SCENE, &render_ops_truth_scene, scene_build, (void **)&j->truth, state, bytes);
}
const render_pass render_pass_ref_scene = {"ref_scene", RES_REF_SCENE, 0, 1, scene_reads, scene_wanted, scene_key,
                                           scene_run};

/* ---- ref_ao -------------------------------------------------------------------------------------- */

static unsigned rao_reads(const render_job *j, char *t, size_t n)
{
    (void)j;
    snprintf(t, n, "gbuffer,ref_scene,camera");
    return RES_GBUFFER | RES_REF_SCENE;
}
static int rao_wanted(const render_job *j, char *r, size_t n)
{
    if (!j->st->ao) {
        snprintf(r, n, "AO off");
        return 0;
    }
    if (!j->any_opaque) {
        snprintf(r, n, "no opaque mesh in the scene");
        return 0;
    }
    const ao_method *m = j->st->ao;
    snprintf(r, n, "ray-traced AO, estimator %s, radius %g (matched to %s)", m->truth_estimator(j->st->ao_params),
             (double)m->get_radius(j->st->ao_params), m->name);
    return 1;
}
static obs_status rao_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    const ao_method *m = j->st->ao;
    truth_ao_params p = j->st->ref_ao;
    if (!truth_ao_estimator_from_name(m->truth_estimator(j->st->ao_params), &p.estimator))
        return obs_error(j->ctx, OBS_STATUS_INTERNAL, "ref_ao: AO method %s names an unknown estimator", m->name);
    p.radius = m->get_radius(j->st->ao_params);
    p.seed ^= j->st->seed;
    truth_ao_result res;
    memset(&res, 0, sizeof res);
    obs_status st = truth_ao_render(j->ctx, j->pool, j->truth->ts, j->scene, &j->cam, &j->gb_ff, &p, &res);
    if (st == OBS_STATUS_OK) {
        j->f->ref_ao = res.mean;
        res.mean.data = NULL;
    }
    truth_ao_result_free(&res);
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(1, &j->f->ref_ao);
    return st;
}
const render_pass render_pass_ref_ao = {"ref_ao", RES_REF_AO, 1, 1, rao_reads, rao_wanted, NULL, rao_run};

/* ---- ref_ambient --------------------------------------------------------------------------------- */

static unsigned ramb_reads(const render_job *j, char *t, size_t n)
{
    if (j->st->ao) {
        snprintf(t, n, "gbuffer,ref_ao,ambient");
        return RES_GBUFFER | RES_REF_AO;
    }
    snprintf(t, n, "gbuffer,ambient");
    return RES_GBUFFER;
}
static int ramb_wanted(const render_job *j, char *r, size_t n)
{
    if (!j->any_opaque) {
        snprintf(r, n, "no opaque mesh in the scene");
        return 0;
    }
    snprintf(r, n, "ambient x albedo x the ray-traced AO");
    return 1;
}
static obs_status ramb_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    obs_status st = render_ambient_fill(j, j->f->ref_ao.data ? &j->f->ref_ao : NULL, j->f->ref_ambient);
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(3, j->f->ref_ambient);
    return st;
}
const render_pass render_pass_ref_ambient = {"ref_ambient", RES_REF_AMBIENT, 1, 1, ramb_reads, ramb_wanted, NULL,
                                             ramb_run};

/* ---- ref_sss ------------------------------------------------------------------------------------- */

static unsigned rsss_reads(const render_job *j, char *t, size_t n)
{
    (void)j;
    snprintf(t, n, "gbuffer,ref_scene,materials,lights,camera");
    return RES_GBUFFER | RES_REF_SCENE;
}
static int rsss_wanted(const render_job *j, char *r, size_t n)
{
    if (!ref_has_sss(j)) {
        snprintf(r, n, "%s", j->any_translucent ? "no directional or point light" : "no translucent material in the scene");
        return 0;
    }
    snprintf(r, n, "SSS ground truth (%s)", truth_sss_estimator_name(j->st->ref_sss.estimator));
    return 1;
}
static obs_status rsss_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    truth_sss_params p = j->st->ref_sss;
    p.seed ^= j->st->seed;
    p.model = j->sss_p.model;
    truth_sss_result res;
    memset(&res, 0, sizeof res);
    obs_status st = truth_sss_render(j->ctx, j->pool, j->truth->ts, j->scene, &j->sss.mats, &j->cam, &j->gb, &p, &res);
    if (st == OBS_STATUS_OK)
        for (int c = 0; c < 3; c++) {
            j->f->ref_sss[c] = res.radiance[c];
            res.radiance[c].data = NULL;
        }
    truth_sss_result_free(&res);
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(3, j->f->ref_sss);
    return st;
}
const render_pass render_pass_ref_sss = {"ref_sss", RES_REF_SSS, 1, 1, rsss_reads, rsss_wanted, NULL, rsss_run};

/* ---- ref_volume ---------------------------------------------------------------------------------- */

static unsigned rvol_reads(const render_job *j, char *t, size_t n)
{
    if (j->st->volume.mesh_shadows) { /* the meshes on the shadow rays, as the light volume sees them */
        snprintf(t, n, "volume_grid,gbuffer,light,camera,ref_scene");
        return RES_VOLUME_GRID | RES_GBUFFER | RES_REF_SCENE;
    }
    snprintf(t, n, "volume_grid,gbuffer,light,camera");
    return RES_VOLUME_GRID | RES_GBUFFER;
}

/* volume.mesh_shadows in the reference: a shadow ray from a scattering point towards the light is
 * blocked by any mesh (the exact counterpart of the light volume's occupancy and entry test;
 * docs/render.md "Meshes shadow the volume"): one Embree ray, hit or not. */
static double rvol_visibility(void *user, const double x[3], const double w[3], double dist)
{
    const truth_scene *ts = (const truth_scene *)user;
    truth_hit h;
    truth_intersect1(ts, obs_v3((float)x[0], (float)x[1], (float)x[2]), obs_v3((float)w[0], (float)w[1], (float)w[2]),
                     0.0f, isinf(dist) ? INFINITY : (float)dist, &h);
    return h.instance == 0xFFFFFFFFu ? 1.0 : 0.0;
}
static int rvol_wanted(const render_job *j, char *r, size_t n)
{
    if (!render_job_has_volume(j)) {
        snprintf(r, n, "no volume in the scene");
        return 0;
    }
    if (!ref_has_volume(j)) {
        snprintf(r, n, "the volume is not lit through a light volume: nothing to check");
        return 0;
    }
    snprintf(r, n, "Monte Carlo single scattering (delta tracking, ratio-tracked shadow rays, %d samples per "
             "pixel), stopped at the meshes' depth", j->st->ref_volume_samples);
    return 1;
}
static obs_status rvol_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    render_volume_light(j);
    truth_volume_mc_params mp = truth_volume_mc_params_default();
    mp.samples = j->st->ref_volume_samples;
    mp.kappa = j->st->volume.lv.kappa;
    mp.seed = j->st->seed;
    mp.depth_limit = &j->gb.depth; /* the ray stops at the meshes, as the ray cast does */
    if (j->st->volume.mesh_shadows && j->truth && j->truth->ts) {
        mp.visibility = rvol_visibility;
        mp.visibility_user = j->truth->ts;
    }
    truth_volume_image im;
    memset(&im, 0, sizeof im);
    obs_status st = truth_volume_mc_render(j->ctx, j->pool, &j->vol->grid, &j->vol->tf, &j->vlight, &j->cam, j->W,
                                           j->H, &mp, &im);
    if (st == OBS_STATUS_OK) {
        /* The frame owns its planes: take the RGBA planes over, free the error bars. */
        for (int c = 0; c < 4; c++) {
            j->f->ref_volume[c] = im.rgba[c];
            memset(&im.rgba[c], 0, sizeof im.rgba[c]);
        }
    }
    truth_volume_image_free(&im);
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(4, j->f->ref_volume);
    return st;
}
const render_pass render_pass_ref_volume = {"ref_volume", RES_REF_VOLUME, 1, 1, rvol_reads, rvol_wanted, NULL,
                                            rvol_run};

/* ---- ref_compose --------------------------------------------------------------------------------- */

static unsigned rcomp_reads(const render_job *j, char *t, size_t n)
{
    unsigned m = 0;
    char d[224];
    t[0] = '\0';
    if (render_pass_direct.wanted(j, d, sizeof d)) m |= RES_DIRECT;
    if (ramb_wanted(j, d, sizeof d)) m |= RES_REF_AMBIENT;
    if (rsss_wanted(j, d, sizeof d)) m |= RES_REF_SSS;
    if (rvol_wanted(j, d, sizeof d)) m |= RES_REF_VOLUME;
    else if (render_pass_raycast.wanted(j, d, sizeof d)) m |= RES_VOLUME;
    for (int i = 0; i < RES_COUNT_BITS; i++)
        if (m & (1u << i)) {
            size_t l = strlen(t);
            snprintf(t + l, n - l, "%s%s", l ? "," : "", render_resource_name(1u << i));
        }
    return m;
}
static int rcomp_wanted(const render_job *j, char *r, size_t n)
{
    (void)j;
    snprintf(r, n, "the reference beauty, composed as beauty");
    return 1;
}
static obs_status rcomp_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    render_frame *f = j->f;
    obs_status st = render_compose(j, f->direct, f->ref_ambient, f->ref_sss, f->ref_volume[0].data ? f->ref_volume : f->volume,
                                   f->ref_beauty);
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(3, f->ref_beauty);
    return st;
}
const render_pass render_pass_ref_compose = {"ref_compose", RES_REF_BEAUTY, 1, 1, rcomp_reads, rcomp_wanted, NULL,
                                             rcomp_run};
