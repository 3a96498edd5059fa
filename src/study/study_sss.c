/* study_sss.c: the SSS study (study_sss.h): options, frames, the references and their cache, one
 * point (run and error functions), the sweep. The report is study_sss_report.c. docs/study.md,
 * "Subsurface scattering". */
#include "study_sss_internal.h"
#include "../io/io.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef OBS_STUDY_DATA_DIR
#define OBS_STUDY_DATA_DIR "build/data"
#endif

/* ================================================================================================
 * Options
 * ============================================================================================== */

study_sss_options study_sss_options_default(void)
{
    study_sss_options o;
    memset(&o, 0, sizeof o);
    o.out_dir = "out/study-sss";
    o.data_dir = OBS_STUDY_DATA_DIR;
    o.scenes = STUDY_SSS_DEFAULT_SCENES;
    o.lights = STUDY_SSS_DEFAULT_LIGHTS;
    o.resolutions = STUDY_SSS_DEFAULT_RESOLUTIONS;
    o.samplers = STUDY_SSS_DEFAULT_SAMPLERS;
    o.Ks = STUDY_SSS_DEFAULT_KS;
    o.Ns = STUDY_SSS_DEFAULT_NS;
    o.map_sizes = STUDY_SSS_DEFAULT_MAP_SIZES;
    o.runs = STUDY_SSS_DEFAULT_RUNS;
    o.ref_samples = STUDY_SSS_DEFAULT_REF_SAMPLES;
    o.seed_points = 1;
    return o;
}

study_sss_options study_sss_options_quick(void)
{
    study_sss_options o = study_sss_options_default();
    o.scenes = STUDY_SSS_QUICK_SCENES;
    o.lights = STUDY_SSS_QUICK_LIGHTS;
    o.resolutions = STUDY_SSS_QUICK_RESOLUTIONS;
    o.Ks = STUDY_SSS_QUICK_KS;
    o.Ns = STUDY_SSS_QUICK_NS;
    o.map_sizes = STUDY_SSS_QUICK_MAP_SIZES;
    o.runs = STUDY_SSS_QUICK_RUNS;
    o.ref_samples = STUDY_SSS_QUICK_REF_SAMPLES;
    o.seed_points = 0;
    o.quick = 1;
    return o;
}

truth_sss_params study_sss_truth_params(const study_sss_options *o, truth_sss_estimator e)
{
    truth_sss_params p = truth_sss_params_default();
    p.estimator = e;
    p.model = SSS_MODEL_DIRECTIONAL;                  /* the maps' BSSRDF (study_sss_map_params) */
    p.min_samples = p.max_samples = o->ref_samples;   /* a fixed count: no adaptive stop (docs/study.md) */
    p.batch = 64;
    p.replicates = 8;                                 /* as the AO study's ground truth */
    p.seed = 0;
    return p;
}

sss_params study_sss_map_params(sss_sampler sampler, int K, int N, int map_size)
{
    sss_params p = sss_params_default();
    p.model = SSS_MODEL_DIRECTIONAL;
    p.sampler = sampler;
    p.visibility = SSS_VISIBILITY_PRODUCT5;
    p.K = K;
    p.N = N;
    p.map_size = map_size;
    p.light_map_size = SSS_DEFAULT_LIGHT_MAP_SIZE;
    p.frames = 1;
    p.gamma = 1.0;
    p.specular = 0;
    p.seed = 0;
    return p;
}

/* ---- the results table ------------------------------------------------------------------------ */

#define REF_COLS(p)                                                                                              \
    p "_status", p "_rmse", p "_rmse_nc", p "_rel_rmse", p "_rel_rmse_nc", p "_mean_ratio", p "_noise_rms",     \
        p "_mean", p "_gain", p "_cal_rmse_nc", p "_skill_nc", p "_pixels", p "_seconds"

const char *const study_sss_columns[] = {
    /* key */
    "scene", "light", "width", "height", "sampler", "K", "N", "map_size",
    /* what was run */
    "params", "status", "light_dir", "material",
    /* time, ms (median, min, max over the runs) */
    "lightmaps_ms", "lightmaps_ms_min", "lightmaps_ms_max", "maps_ms", "maps_ms_min", "maps_ms_max",
    "camera_gbuffer_ms", "combine_ms", "combine_ms_min", "combine_ms_max", "rebuilt_ms", "fixed_ms", "runs",
    "threads", "bssrdf_evaluations", "disk_candidates", "translucent_pixels", "covered_pixels",
    /* error against the brute-force BSSRDF integral (the method's) and the random walk (the model's) */
    REF_COLS("bf"), REF_COLS("rw"),
};
const int study_sss_column_count = (int)(sizeof study_sss_columns / sizeof study_sss_columns[0]);
_Static_assert(sizeof study_sss_columns / sizeof study_sss_columns[0] <= STUDY_MAX_COLUMNS, "columns");

const study_table *study_sss_table(const study_sss *s) { return &s->table; }

/* ---- open, close --------------------------------------------------------------------------------- */

static obs_status check_int_axis(obs_context *ctx, const study_axis *a, const char *name, long long lo, long long hi)
{
    long long v;
    for (int i = 0; i < a->n; i++)
        if (!obs_parse_int(a->v[i], lo, hi, &v))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study sss: %s: '%s' is not an integer in [%lld, %lld]",
                             name, a->v[i], lo, hi);
    return OBS_STATUS_OK;
}

static int axis_has(const study_axis *a, int v)
{
    for (int i = 0; i < a->n; i++)
        if (atoi(a->v[i]) == v)
            return 1;
    return 0;
}

/* The (K, N, map size) combinations of a frame: the grid, then the seed's Table 5.3 points
 * (K = 4, 8, 16 cameras with 12, 24, 48 samples: "M = 12, 24, 48", at 512 maps: our light
 * G-buffer's size) that are not in it. */
static obs_status build_combos(obs_context *ctx, study_sss *s)
{
    const int max = s->samplers.n * (s->Ks.n * s->Ns.n * s->map_sizes.n + 3);
    s->combos = (study_sss_i_combo *)calloc((size_t)max, sizeof *s->combos);
    if (!s->combos)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory");
    for (int a = 0; a < s->samplers.n; a++) {
        sss_sampler smp = SSS_SAMPLER_RUSSIAN_ROULETTE;
        sss_sampler_from_name(s->samplers.v[a], &smp);
        const char *sp = sss_sampler_name(smp); /* the canonical name is the key (a static string) */
        for (int m = 0; m < s->map_sizes.n; m++)
            for (int k = 0; k < s->Ks.n; k++)
                for (int n = 0; n < s->Ns.n; n++)
                    s->combos[s->ncombos++] =
                        (study_sss_i_combo){sp, atoi(s->Ks.v[k]), atoi(s->Ns.v[n]), atoi(s->map_sizes.v[m]), 0};
        if (s->o.seed_points)
            for (int i = 0; i < 3; i++) {
                const int K = 4 << i, N = 12 << i, M = 512;
                if (!(axis_has(&s->Ks, K) && axis_has(&s->Ns, N) && axis_has(&s->map_sizes, M)))
                    s->combos[s->ncombos++] = (study_sss_i_combo){sp, K, N, M, 1};
            }
    }
    return OBS_STATUS_OK;
}

obs_status study_sss_open(obs_context *ctx, const study_sss_options *o, study_sss **out)
{
    *out = NULL;
    if (!o || !o->out_dir || !o->data_dir)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study sss: no options, out_dir or data_dir");
    study_sss *s = (study_sss *)calloc(1, sizeof *s);
    if (!s)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory");
    s->o = *o;
    obs_status st = study_axis_parse(ctx, "scenes", o->scenes, &s->scenes);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "lights", o->lights, &s->lights);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "resolutions", o->resolutions, &s->resolutions);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "samplers", o->samplers, &s->samplers);
    for (int i = 0; st == OBS_STATUS_OK && i < s->samplers.n; i++)
        if (!sss_sampler_from_name(s->samplers.v[i], NULL))
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study sss: unknown sampler '%s'", s->samplers.v[i]);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "K", o->Ks, &s->Ks);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "N", o->Ns, &s->Ns);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "map sizes", o->map_sizes, &s->map_sizes);
    for (int i = 0; st == OBS_STATUS_OK && i < s->lights.n; i++)
        if (strcmp(s->lights.v[i], "front") && strcmp(s->lights.v[i], "behind"))
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study sss: light '%s' is not front or behind",
                           s->lights.v[i]);
    for (int i = 0; st == OBS_STATUS_OK && i < s->resolutions.n; i++) {
        int w, h;
        if (!obs_parse_size(s->resolutions.v[i], RAST_MAX_DIM, &w, &h))
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study sss: resolution '%s' is not WxH",
                           s->resolutions.v[i]);
    }
    if (st == OBS_STATUS_OK)
        st = check_int_axis(ctx, &s->Ks, "K", 1, 256);
    if (st == OBS_STATUS_OK)
        st = check_int_axis(ctx, &s->Ns, "N", 1, 65536);
    if (st == OBS_STATUS_OK)
        st = check_int_axis(ctx, &s->map_sizes, "map size", 16, 4096);
    if (st == OBS_STATUS_OK && (o->runs < 1 || o->runs > 64))
        st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study sss: runs %d is not in [1, 64]", o->runs);
    if (st == OBS_STATUS_OK && (o->ref_samples < 64 || o->ref_samples > (1 << 20) || o->ref_samples % 64))
        st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                       "study sss: reference samples %lld is not a multiple of 64 in [64, 1048576]", o->ref_samples);
    if (st == OBS_STATUS_OK)
        st = build_combos(ctx, s);
    if (st == OBS_STATUS_OK)
        st = study_table_init(ctx, &s->table, study_sss_columns, study_sss_column_count, STUDY_SSS_KEY_COLUMNS);
    snprintf(s->csv, sizeof s->csv, "%s/results.csv", o->out_dir);
    snprintf(s->json, sizeof s->json, "%s/results.json", o->out_dir);
    int64_t read = 0;
    if (st == OBS_STATUS_OK)
        st = study_table_read_csv(ctx, &s->table, s->csv, &read);
    if (st == OBS_STATUS_OK && read && o->log)
        fprintf(o->log, "obscura: study sss: resuming: %lld points in %s\n", (long long)read, s->csv);
    if (st != OBS_STATUS_OK) {
        study_sss_close(s);
        return st;
    }
    s->last_save = obs_time_now();
    *out = s;
    return OBS_STATUS_OK;
}

void study_sss_close(study_sss *s)
{
    if (!s)
        return;
    study_axis_free(&s->scenes);
    study_axis_free(&s->lights);
    study_axis_free(&s->resolutions);
    study_axis_free(&s->samplers);
    study_axis_free(&s->Ks);
    study_axis_free(&s->Ns);
    study_axis_free(&s->map_sizes);
    study_table_free(&s->table);
    free(s->combos);
    free(s);
}

/* ---- the plan ------------------------------------------------------------------------------------ */

/* The cost model (docs/study.md, "SSS: cost"), measured on the shared 2-core development machine
 * (2026-12-02, the reduced study, 2 threads, other jobs running): the maps pass costs about
 * STUDY_SSS_NS_PER_MAP_CANDIDATE ns per disk candidate, and draws N candidates per covered texel
 * and layer, a covered texel being about STUDY_SSS_MAP_COVER of a map (the bunny: 0.2); the
 * brute-force reference about STUDY_SSS_NS_PER_REF_CANDIDATE per candidate and the random walk
 * STUDY_SSS_RW_FACTOR times that (cream: 9, marble: 2), on about STUDY_SSS_PIXEL_COVER of the
 * pixels (0.18 to 0.25 at the mkdata cameras). */
#define STUDY_SSS_NS_PER_MAP_CANDIDATE 270.0
#define STUDY_SSS_MAP_COVER 0.2
#define STUDY_SSS_NS_PER_REF_CANDIDATE 600.0
#define STUDY_SSS_RW_FACTOR 7.0
#define STUDY_SSS_PIXEL_COVER 0.25
study_sss_plan study_sss_plan_of(const study_sss *s)
{
    study_sss_plan p;
    memset(&p, 0, sizeof p);
    p.scenes = s->scenes.n;
    p.lights = s->lights.n;
    p.resolutions = s->resolutions.n;
    p.Ks = s->Ks.n;
    p.Ns = s->Ns.n;
    p.map_sizes = s->map_sizes.n;
    p.runs = s->o.runs;
    const int64_t frames = (int64_t)p.scenes * p.lights * p.resolutions;
    p.points = frames * s->ncombos;
    double evals = 0.0;
    for (int i = 0; i < s->ncombos; i++)
        evals += (double)s->combos[i].K * s->combos[i].N * STUDY_SSS_MAP_COVER * s->combos[i].map_size *
                 s->combos[i].map_size;
    p.sweep_min = (double)frames * evals * p.runs * STUDY_SSS_NS_PER_MAP_CANDIDATE * 1e-9 / 60.0;
    double px = 0.0;
    for (int r = 0; r < s->resolutions.n; r++) {
        int w = 0, h = 0;
        obs_parse_size(s->resolutions.v[r], RAST_MAX_DIM, &w, &h);
        px += STUDY_SSS_PIXEL_COVER * w * h;
    }
    p.ref_min = (double)p.scenes * p.lights * px * (double)s->o.ref_samples * (1.0 + STUDY_SSS_RW_FACTOR) *
                STUDY_SSS_NS_PER_REF_CANDIDATE * 1e-9 / 60.0;
    return p;
}

/* ================================================================================================
 * Frames: scene, material, light, camera G-buffer
 * ============================================================================================== */

void study_sss_i_frame_free(study_sss_i_frame *f)
{
    truth_scene_destroy(f->ts);
    rast_gbuffer_free(&f->gb);
    sss_scene_setup_free(&f->setup);
    obs_image_f32_free(&f->mask);
    obs_scene_free(&f->scene);
    memset(f, 0, sizeof *f);
}

/* FNV-1a, 64 bits: the reference cache's content key. */
static uint64_t fnv(uint64_t h, const void *data, size_t n)
{
    const unsigned char *b = (const unsigned char *)data;
    for (size_t i = 0; i < n; i++) {
        h ^= b[i];
        h *= 1099511628211ull;
    }
    return h;
}
#define FNV0 14695981039346656037ull

static obs_status file_hash(obs_context *ctx, const char *path, uint64_t *out)
{
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return obs_error(ctx, OBS_STATUS_NOT_FOUND, "study sss: cannot open %s (build the data target)", path);
    uint64_t h = FNV0;
    unsigned char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, fp)) > 0)
        h = fnv(h, buf, n);
    fclose(fp);
    *out = h;
    return OBS_STATUS_OK;
}

/* Half the smallest reduced mean free path (as `obscura truth sss`: the random walk's patch
 * radius, about 0.3% bias on the point-lit slab, docs/sss/truth.md "Patch bias"). */
static double patch_radius_of(const sss_scene_setup *s)
{
    double mfp = INFINITY;
    for (uint32_t m = 0; m < s->mats.count; m++)
        for (int c = 0; s->mats.translucent[m] && c < 3; c++)
            if (s->mats.constants[m].ch[c].sigma_t_p > 0.0)
                mfp = fmin(mfp, 1.0 / s->mats.constants[m].ch[c].sigma_t_p);
    return isfinite(mfp) ? 0.5 * mfp : 0.05;
}

obs_status study_sss_i_frame_render(obs_context *ctx, obs_pool *pool, const study_sss *s, const char *scene_name,
                                    const char *light, int W, int H, study_sss_i_frame *f)
{
    memset(f, 0, sizeof *f);
    obs_scene_init(&f->scene);
    f->width = W;
    f->height = H;
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.glb", s->o.data_dir, scene_name);
    obs_status st = file_hash(ctx, path, &f->file_hash);
    io_gltf_options opt = io_gltf_options_default();
    if (st == OBS_STATUS_OK)
        st = io_gltf_load(ctx, path, &opt, &f->scene);
    if (st != OBS_STATUS_OK)
        return st;
    /* the camera: "default" (every SSS scene of mkdata has one), else the first */
    if (f->scene.camera_count == 0)
        return obs_error(ctx, OBS_STATUS_NOT_FOUND, "%s: no camera", path);
    f->cam = f->scene.cameras[0];
    for (uint32_t c = 0; c < f->scene.camera_count; c++)
        if (!strcmp(f->scene.cameras[c].name, "default"))
            f->cam = f->scene.cameras[c];
    /* the materials: the scene's own ("obscura_sss" in the glTF extras) */
    st = sss_scene_setup_make(ctx, &f->scene, NULL, SSS_DEFAULT_MM_PER_UNIT, &f->setup);
    if (st == OBS_STATUS_OK && !sss_scene_setup_any_translucent(&f->setup, &f->scene))
        st = obs_error(ctx, OBS_STATUS_NOT_FOUND, "%s: no material carries \"obscura_sss\"", path);
    if (st != OBS_STATUS_OK)
        return st;
    for (uint32_t m = 0; m < f->setup.mats.count && !f->material[0]; m++)
        if (f->setup.mats.translucent[m])
            snprintf(f->material, sizeof f->material, "%.63s", f->setup.mats.constants[m].material.name);
    /* The light: "front" is the scene's first directional light (its key light), "behind" the same
     * light travelling the opposite way, so that the side lit by "front" is the one in shadow.
     * Either replaces the scene's lights (as cli_sss_prepare does: the passes and the references
     * read scene->lights). */
    const obs_light *key = NULL;
    for (uint32_t l = 0; l < f->scene.light_count && !key; l++)
        if (f->scene.lights[l].type == OBS_LIGHT_DIRECTIONAL)
            key = &f->scene.lights[l];
    if (!key)
        return obs_error(ctx, OBS_STATUS_NOT_FOUND, "%s: no directional light to call 'front'", path);
    obs_light L = *key;
    if (!strcmp(light, "behind")) {
        L.direction = (obs_vec3){-L.direction.x, -L.direction.y, -L.direction.z};
        snprintf(L.name, sizeof L.name, "behind (-%.40s)", key->name);
    }
    f->scene.lights[0] = L;
    f->scene.light_count = 1;
    f->light = L;
    /* the camera's G-buffer: what the combination reads and what the references read */
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_MATERIAL_ID | RAST_OUT_INSTANCE_ID | RAST_OUT_PRIM_ID;
    rp.face_forward = 0;
    f->rp = rp;
    st = rast_gbuffer_alloc(ctx, &rp, &f->gb);
    rast_view view = {f->cam};
    if (st == OBS_STATUS_OK)
        st = rast_render(ctx, pool, &f->scene, &view, 1, &rp, &f->gb, NULL);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, W, H, &f->mask);
    f->patch_radius = patch_radius_of(&f->setup);
    return st;
}

/* ================================================================================================
 * The references and their cache
 * ============================================================================================== */

void study_sss_i_ref_free(study_sss_i_ref *r)
{
    for (int c = 0; c < 3; c++) {
        obs_image_f32_free(&r->rgb[c]);
        obs_image_f32_free(&r->se[c]);
    }
    obs_image_f32_free(&r->count);
    memset(r, 0, sizeof *r);
}

static truth_sss_params frame_truth_params(const study_sss *s, const study_sss_i_frame *f, truth_sss_estimator e)
{
    truth_sss_params p = study_sss_truth_params(&s->o, e);
    p.patch_radius = f->patch_radius;
    return p;
}

/* The cache key: every input that decides a reference's pixels. */
static uint64_t ref_key(const study_sss_i_frame *f, const truth_sss_params *p)
{
    uint64_t h = fnv(FNV0, &f->file_hash, sizeof f->file_hash);
    for (uint32_t m = 0; m < f->setup.mats.count; m++) {
        const sss_material *mt = &f->setup.mats.constants[m].material;
        const double v[9] = {mt->sigma_s[0], mt->sigma_s[1], mt->sigma_s[2], mt->sigma_a[0], mt->sigma_a[1],
                             mt->sigma_a[2], mt->g, mt->eta, f->setup.mats.translucent[m]};
        h = fnv(h, v, sizeof v);
    }
    const double lv[8] = {f->light.type, f->light.direction.x, f->light.direction.y, f->light.direction.z,
                          f->light.color.x, f->light.color.y, f->light.color.z, f->light.intensity};
    h = fnv(h, lv, sizeof lv);
    h = fnv(h, f->cam.world.m, sizeof f->cam.world.m);
    const double cv[7] = {f->cam.projection, f->cam.yfov, f->cam.aspect, f->cam.xmag, f->cam.ymag, f->cam.znear, f->cam.zfar};
    h = fnv(h, cv, sizeof cv);
    const double pv[13] = {f->width, f->height, p->estimator, p->model, (double)p->min_samples, (double)p->max_samples,
                           p->batch, p->replicates, p->sigma_star, p->patch_radius, p->max_bounces, p->offset_ulps,
                           (double)p->seed};
    h = fnv(h, pv, sizeof pv);
    return fnv(h, "study_sss_ref_v1", 16);
}

void study_sss_i_ref_path(const study_sss *s, const char *scene, const char *light, const study_sss_i_frame *f,
                          truth_sss_estimator e, char *path, size_t size)
{
    const truth_sss_params p = frame_truth_params(s, f, e);
    snprintf(path, size, "%s/ref/%s_%s_%dx%d_%s_n%lld_%016llx", s->o.out_dir, scene, light, f->width, f->height,
             e == TRUTH_SSS_BRUTE_FORCE ? "bf" : "rw", (long long)p.max_samples,
             (unsigned long long)ref_key(f, &p));
}

static const char *chan_names[7] = {"R", "G", "B", "SE.R", "SE.G", "SE.B", "count"};

/* Load or compute one reference. A reference the truth module refuses (the random walk on an
 * open mesh) is returned with r->missing set and its reason, and OK: the reason is also cached
 * (PATH.missing), so that a resumed study reports it without trying again. */
obs_status study_sss_i_ref_get(obs_context *ctx, obs_pool *pool, const study_sss *s, const char *scene,
                               const char *light, study_sss_i_frame *f, truth_sss_estimator e, study_sss_i_ref *r)
{
    memset(r, 0, sizeof *r);
    char base[4400], path[4500];
    study_sss_i_ref_path(s, scene, light, f, e, base, sizeof base);
    snprintf(path, sizeof path, "%s.missing", base);
    FILE *fp = fopen(path, "r");
    if (fp) {
        size_t n = fread(r->reason, 1, sizeof r->reason - 1, fp);
        r->reason[n] = '\0';
        fclose(fp);
        r->missing = 1;
        return OBS_STATUS_OK;
    }
    snprintf(path, sizeof path, "%s.exr", base);
    io_image im;
    if (io_image_read(ctx, path, &im) == OBS_STATUS_OK) {
        int idx[7], ok = im.width == f->width && im.height == f->height;
        for (int c = 0; c < 7 && ok; c++)
            ok = (idx[c] = io_image_find_channel(&im, chan_names[c])) >= 0;
        if (ok) {
            for (int c = 0; c < 3; c++) {
                r->rgb[c] = im.f32[idx[c]];
                r->se[c] = im.f32[idx[3 + c]];
                memset(&im.f32[idx[c]], 0, sizeof im.f32[0]);
                memset(&im.f32[idx[3 + c]], 0, sizeof im.f32[0]);
            }
            r->count = im.f32[idx[6]];
            memset(&im.f32[idx[6]], 0, sizeof im.f32[0]);
            r->cached = 1;
            io_image_free(&im);
            return OBS_STATUS_OK;
        }
        io_image_free(&im);
    }
    obs_context_clear_error(ctx);
    obs_status st = OBS_STATUS_OK;
    if (!f->ts)
        st = truth_scene_create(ctx, &f->scene, TRUTH_BUILD_MEDIUM, &f->ts);
    if (st != OBS_STATUS_OK)
        return st;
    const truth_sss_params p = frame_truth_params(s, f, e);
    truth_sss_result res;
    const double t0 = obs_time_now();
    st = truth_sss_render(ctx, pool, f->ts, &f->scene, &f->setup.mats, &f->cam, &f->gb, &p, &res);
    r->seconds = obs_time_now() - t0;
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/ref", s->o.out_dir);
    if (st == OBS_STATUS_INVALID_ARGUMENT || st == OBS_STATUS_UNSUPPORTED) {
        /* refused (an open mesh for the random walk): a missing reference, with its reason */
        snprintf(r->reason, sizeof r->reason, "%s", obs_context_last_error(ctx));
        obs_context_clear_error(ctx);
        r->missing = 1;
        st = io_make_dirs(ctx, dir);
        snprintf(path, sizeof path, "%s.missing", base);
        fp = st == OBS_STATUS_OK ? fopen(path, "w") : NULL;
        if (fp) {
            fputs(r->reason, fp);
            fclose(fp);
        }
        if (s->o.log)
            fprintf(s->o.log, "obscura: study sss: %s %s: no %s reference: %s\n", scene, light,
                    truth_sss_estimator_name(e), r->reason);
        return st;
    }
    if (st != OBS_STATUS_OK)
        return st;
    for (int c = 0; c < 3; c++) {
        r->rgb[c] = res.radiance[c];
        r->se[c] = res.std_error[c];
        memset(&res.radiance[c], 0, sizeof res.radiance[c]);
        memset(&res.std_error[c], 0, sizeof res.std_error[c]);
    }
    r->count = res.count;
    memset(&res.count, 0, sizeof res.count);
    truth_sss_result_free(&res);
    if (s->o.log)
        fprintf(s->o.log, "obscura: study sss: %s %s %dx%d: %s reference in %.1f s\n", scene, light, f->width,
                f->height, truth_sss_estimator_name(e), r->seconds);
    st = io_make_dirs(ctx, dir);
    if (st == OBS_STATUS_OK) {
        io_channel ch[7];
        for (int c = 0; c < 3; c++) {
            ch[c] = (io_channel){chan_names[c], IO_PIXEL_FLOAT, &r->rgb[c], NULL};
            ch[3 + c] = (io_channel){chan_names[3 + c], IO_PIXEL_FLOAT, &r->se[c], NULL};
        }
        ch[6] = (io_channel){chan_names[6], IO_PIXEL_FLOAT, &r->count, NULL};
        st = io_exr_write(ctx, path, ch, 7, NULL, 0);
    }
    return st;
}

/* ================================================================================================
 * The error function
 * ============================================================================================== */

/* Luminance weights (ITU-R BT.709, as truth_sss_params.target_rel_error). */
static double lum(double r, double g, double b) { return 0.2126 * r + 0.7152 * g + 0.0722 * b; }

study_sss_i_err study_sss_i_error(const obs_image_f32 ours[3], const study_sss_i_ref *r)
{
    study_sss_i_err e;
    memset(&e, 0, sizeof e);
    const int W = r->count.width, H = r->count.height;
    double so = 0, sr = 0, sr2 = 0, sd2 = 0, sn2 = 0, soo = 0, sor = 0;
    int64_t n = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            if (!(obs_image_f32_row(&r->count, y)[x] > 0.0f))
                continue;
            const double yo = lum(obs_image_f32_row(&ours[0], y)[x], obs_image_f32_row(&ours[1], y)[x],
                                  obs_image_f32_row(&ours[2], y)[x]);
            const double yr = lum(obs_image_f32_row(&r->rgb[0], y)[x], obs_image_f32_row(&r->rgb[1], y)[x],
                                  obs_image_f32_row(&r->rgb[2], y)[x]);
            /* The reference's standard error of Y: the channels come from the same candidates, so
             * they are correlated; sum_c w_c se_c bounds sqrt(Var Y) from above (Cauchy-Schwarz),
             * so the noise taken out is at most over-estimated (docs/study.md). */
            const double sy = lum(obs_image_f32_row(&r->se[0], y)[x], obs_image_f32_row(&r->se[1], y)[x],
                                  obs_image_f32_row(&r->se[2], y)[x]);
            so += yo;
            sr += yr;
            sr2 += yr * yr;
            sd2 += (yo - yr) * (yo - yr);
            sn2 += sy * sy;
            soo += yo * yo;
            sor += yo * yr;
            n++;
        }
    e.pixels = n;
    if (!n) {
        e.rmse = e.rmse_nc = e.rel_rmse = e.rel_rmse_nc = e.mean_ratio = e.mean = e.gain = NAN;
        e.noise_rms = e.score.cal_rmse_nc = e.score.cal_skill_nc = NAN;
        return e;
    }
    const double mean_r = sr / n, var_r = fmax(0.0, sr2 / n - mean_r * mean_r);
    const double mse = sd2 / n;
    /* the calibrated error: the best single gain a (an albedo scale), least squares */
    const double a = soo > 0.0 ? sor / soo : 0.0;
    const double cal_mse = fmax(0.0, (a * a * soo - 2.0 * a * sor + sr2) / n);
    e.noise_rms = sqrt(sn2 / n);
    e.score = study_score_of(mse, cal_mse, var_r, e.noise_rms, 0);
    e.rmse = e.score.rmse;
    e.rmse_nc = e.score.rmse_nc;
    e.mean = mean_r;
    e.rel_rmse = mean_r > 0.0 ? e.rmse / mean_r : NAN;
    e.rel_rmse_nc = mean_r > 0.0 ? e.rmse_nc / mean_r : NAN;
    e.mean_ratio = sr > 0.0 ? so / sr : NAN;
    e.gain = a;
    return e;
}

/* ================================================================================================
 * The run function
 * ============================================================================================== */

obs_status study_sss_i_run_point(obs_context *ctx, obs_pool *pool, study_sss_i_frame *f, const sss_params *p,
                                 int runs, obs_image_f32 out[3], study_sss_i_times *t)
{
    memset(t, 0, sizeof *t);
    double tl[64], tm[64], tg[64], tc[64];
    if (runs > 64)
        runs = 64;
    obs_status st = sss_params_validate(ctx, p);
    rast_view view = {f->cam};
    const int nl = (int)f->scene.light_count;
    for (int r = 0; r < runs && st == OBS_STATUS_OK; r++) {
        sss_light_map lm[4];
        sss_maps maps;
        memset(lm, 0, sizeof lm);
        memset(&maps, 0, sizeof maps);
        for (int c = 0; c < 3; c++)
            obs_image_f32_free(&out[c]);
        double t0 = obs_time_now();
        for (int l = 0; l < nl && st == OBS_STATUS_OK; l++)
            st = sss_light_map_render(ctx, pool, &f->scene, &f->scene.lights[l], p, &lm[l]);
        double t1 = obs_time_now();
        if (st == OBS_STATUS_OK)
            st = sss_maps_build(ctx, pool, &f->scene, &f->setup.mats, lm, nl, p, &maps);
        double t2 = obs_time_now();
        if (st == OBS_STATUS_OK)
            st = rast_render(ctx, pool, &f->scene, &view, 1, &f->rp, &f->gb, NULL);
        double t3 = obs_time_now();
        if (st == OBS_STATUS_OK)
            st = sss_combine(ctx, pool, &f->scene, &f->setup.mats, &maps, lm, nl, &f->gb, &f->cam, p, out, NULL);
        double t4 = obs_time_now();
        tl[r] = 1e3 * (t1 - t0);
        tm[r] = 1e3 * (t2 - t1);
        tg[r] = 1e3 * (t3 - t2);
        tc[r] = 1e3 * (t4 - t3);
        t->bssrdf_evaluations = maps.samples_evaluated;
        t->candidates = maps.candidates;
        sss_maps_free(&maps);
        for (int l = 0; l < nl; l++)
            sss_light_map_free(&lm[l]);
    }
    if (st != OBS_STATUS_OK)
        return st;
    double rb[64], fx[64];
    for (int r = 0; r < runs; r++) {
        rb[r] = tl[r] + tm[r] + tg[r] + tc[r];
        fx[r] = tg[r] + tc[r];
    }
    t->lightmaps = study_stats_of(tl, runs);
    t->maps = study_stats_of(tm, runs);
    t->gbuffer = study_stats_of(tg, runs);
    t->combine = study_stats_of(tc, runs);
    t->rebuilt = study_stats_of(rb, runs);
    t->fixed = study_stats_of(fx, runs);
    return OBS_STATUS_OK;
}

/* ================================================================================================
 * The sweep
 * ============================================================================================== */

static void fmt(char *buf, double v) { snprintf(buf, 32, "%.9g", v); }

static obs_status save_table(obs_context *ctx, study_sss *s)
{
    s->last_save = obs_time_now();
    s->dirty = 0;
    obs_status st = io_make_dirs(ctx, s->o.out_dir);
    if (st == OBS_STATUS_OK)
        st = study_table_write_csv(ctx, &s->table, s->csv);
    if (st == OBS_STATUS_OK)
        st = study_table_write_json(ctx, &s->table, s->json);
    return st;
}

static void ref_cells(char cells[][64], const char **row, int c0, const study_sss_i_ref *r, const study_sss_i_err *e,
                      char *status, size_t status_size)
{
    if (r->missing) {
        snprintf(status, status_size, "missing: %s", r->reason);
        row[c0] = status;
        return;
    }
    row[c0] = "ok";
    const double v[12] = {e->rmse, e->rmse_nc, e->rel_rmse, e->rel_rmse_nc, e->mean_ratio, e->noise_rms, e->mean,
                          e->gain, e->score.cal_rmse_nc, e->score.cal_skill_nc, (double)e->pixels,
                          r->cached ? NAN : r->seconds};
    for (int k = 0; k < 12; k++)
        if (!isnan(v[k]))
            fmt(cells[c0 + 1 + k], v[k]);
}

static obs_status measure_point(obs_context *ctx, obs_pool *pool, study_sss *s, const char *const *key,
                                const study_sss_i_combo *cb, study_sss_i_frame *f, const study_sss_i_ref refs[2])
{
    enum { NCOL = sizeof study_sss_columns / sizeof study_sss_columns[0] };
    char cells[NCOL][64];
    const char *row[NCOL];
    for (int c = 0; c < NCOL; c++) {
        cells[c][0] = '\0';
        row[c] = cells[c];
    }
    for (int c = 0; c < STUDY_SSS_KEY_COLUMNS; c++)
        row[c] = key[c];
    sss_sampler smp = SSS_SAMPLER_RUSSIAN_ROULETTE;
    sss_sampler_from_name(cb->sampler, &smp);
    const sss_params p = study_sss_map_params(smp, cb->K, cb->N, cb->map_size);
    char params[512], status[600], bfs[600], rws[600];
    snprintf(params, sizeof params,
             "model=%s sampler=%s visibility=%s light_map_size=%d frames=%d q=%g disk_radius=%g seed=%llu "
             "ref_samples=%lld%s",
             sss_model_name(p.model), sss_sampler_name(p.sampler), sss_visibility_name(p.visibility), p.light_map_size,
             p.frames, p.spread_q, p.disk_radius, (unsigned long long)p.seed, s->o.ref_samples,
             cb->seed ? " seed_table=5.3" : "");
    row[8] = params;
    snprintf(cells[10], 64, "%.4f %.4f %.4f", f->light.direction.x, f->light.direction.y, f->light.direction.z);
    row[11] = f->material;
    obs_image_f32 out[3] = {{0}};
    study_sss_i_times t;
    obs_status st = OBS_STATUS_OK;
    obs_status ps = study_sss_i_run_point(ctx, pool, f, &p, s->o.runs, out, &t);
    if (ps == OBS_STATUS_OUT_OF_MEMORY || ps == OBS_STATUS_IO_ERROR) {
        st = ps;
    } else if (ps != OBS_STATUS_OK) {
        snprintf(status, sizeof status, "failed: %s", obs_context_last_error(ctx));
        row[9] = status;
        obs_context_clear_error(ctx);
    } else {
        row[9] = "ok";
        int64_t tp = 0, cov = 0;
        const obs_image_f32 *mask = !refs[0].missing ? &refs[0].count : !refs[1].missing ? &refs[1].count : NULL;
        for (int y = 0; mask && y < f->height; y++)
            for (int x = 0; x < f->width; x++)
                if (obs_image_f32_row(mask, y)[x] > 0.0f) {
                    tp++;
                    cov += obs_image_f32_row(&out[0], y)[x] + obs_image_f32_row(&out[1], y)[x] +
                               obs_image_f32_row(&out[2], y)[x] > 0.0f;
                }
        const double v[] = {t.lightmaps.median, t.lightmaps.min, t.lightmaps.max, t.maps.median, t.maps.min,
                            t.maps.max, t.gbuffer.median, t.combine.median, t.combine.min, t.combine.max,
                            t.rebuilt.median, t.fixed.median, s->o.runs, obs_pool_threads(pool),
                            (double)t.bssrdf_evaluations, (double)t.candidates, (double)tp, (double)cov};
        for (size_t k = 0; k < sizeof v / sizeof v[0]; k++)
            fmt(cells[12 + k], v[k]);
        const int c_bf = study_table_column(&s->table, "bf_status"), c_rw = study_table_column(&s->table, "rw_status");
        study_sss_i_err e0 = refs[0].missing ? (study_sss_i_err){0} : study_sss_i_error(out, &refs[0]);
        study_sss_i_err e1 = refs[1].missing ? (study_sss_i_err){0} : study_sss_i_error(out, &refs[1]);
        ref_cells(cells, row, c_bf, &refs[0], &e0, bfs, sizeof bfs);
        ref_cells(cells, row, c_rw, &refs[1], &e1, rws, sizeof rws);
    }
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&out[c]);
    if (st == OBS_STATUS_OK)
        st = study_table_append(ctx, &s->table, row);
    s->dirty = 1;
    return st;
}

static void combo_key(const study_sss_i_combo *c, const char **key, char kk[3][16])
{
    key[4] = c->sampler;
    snprintf(kk[0], 16, "%d", c->K);
    snprintf(kk[1], 16, "%d", c->N);
    snprintf(kk[2], 16, "%d", c->map_size);
}

static obs_status sweep(obs_context *ctx, obs_pool *pool, study_sss *s, int truth_only)
{
    const study_sss_plan plan = study_sss_plan_of(s);
    if (s->o.log)
        fprintf(s->o.log,
                "obscura: study sss: %lld points (%d scenes x %d lights x %d resolutions x %d (sampler, K, N, map "
                "size) combinations), %d runs each, %d threads\n",
                (long long)plan.points, plan.scenes, plan.lights, plan.resolutions, s->ncombos, s->o.runs,
                obs_pool_threads(pool));
    study_progress pr;
    study_progress_begin(&pr, s->o.log, plan.points);
    obs_status st = OBS_STATUS_OK;
    for (int si = 0; si < s->scenes.n && st == OBS_STATUS_OK; si++)
        for (int li = 0; li < s->lights.n && st == OBS_STATUS_OK; li++)
            for (int ri = 0; ri < s->resolutions.n && st == OBS_STATUS_OK; ri++) {
                const char *scene = s->scenes.v[si], *light = s->lights.v[li];
                int W = 0, H = 0;
                obs_parse_size(s->resolutions.v[ri], RAST_MAX_DIM, &W, &H);
                char ws[16], hs[16];
                snprintf(ws, sizeof ws, "%d", W);
                snprintf(hs, sizeof hs, "%d", H);
                char kk[3][16];
                const char *key[STUDY_SSS_KEY_COLUMNS] = {scene, light, ws, hs, NULL, kk[0], kk[1], kk[2]};
                int64_t remaining = 0;
                for (int i = 0; i < s->ncombos; i++) {
                    combo_key(&s->combos[i], key, kk);
                    remaining += study_table_find(&s->table, key) < 0;
                }
                if (!remaining && !truth_only) {
                    for (int i = 0; i < s->ncombos; i++)
                        study_progress_step(&pr, 0, "resumed");
                    continue;
                }
                study_sss_i_frame f;
                st = study_sss_i_frame_render(ctx, pool, s, scene, light, W, H, &f);
                study_sss_i_ref refs[2];
                memset(refs, 0, sizeof refs);
                for (int e = 0; e < 2 && st == OBS_STATUS_OK; e++)
                    st = study_sss_i_ref_get(ctx, pool, s, scene, light, &f, (truth_sss_estimator)e, &refs[e]);
                for (int i = 0; i < s->ncombos && st == OBS_STATUS_OK; i++) {
                    combo_key(&s->combos[i], key, kk);
                    char label[320];
                    snprintf(label, sizeof label, "%.100s/%.16s %dx%d %.20s K=%.8s N=%.8s maps %.8s", scene, light, W,
                             H, s->combos[i].sampler, kk[0], kk[1], kk[2]);
                    if (truth_only || study_table_find(&s->table, key) >= 0) {
                        study_progress_step(&pr, 0, label);
                        continue;
                    }
                    st = measure_point(ctx, pool, s, key, &s->combos[i], &f, refs);
                    if (st == OBS_STATUS_OK && obs_time_now() - s->last_save > 5.0)
                        st = save_table(ctx, s);
                    study_progress_step(&pr, 1, label);
                }
                study_sss_i_ref_free(&refs[0]);
                study_sss_i_ref_free(&refs[1]);
                study_sss_i_frame_free(&f);
                if (st == OBS_STATUS_OK && s->dirty)
                    st = save_table(ctx, s);
            }
    study_progress_end(&pr);
    if (st == OBS_STATUS_OK || s->dirty) {
        obs_status ss = save_table(ctx, s);
        st = st == OBS_STATUS_OK ? ss : st;
    }
    return st;
}

obs_status study_sss_truth(obs_context *ctx, obs_pool *pool, study_sss *s) { return sweep(ctx, pool, s, 1); }
obs_status study_sss_sweep(obs_context *ctx, obs_pool *pool, study_sss *s) { return sweep(ctx, pool, s, 0); }
