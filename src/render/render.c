/* render.c: the session (pool, cache, options), the job a frame's passes share, planning and
 * running a frame, the reference's per-layer errors (docs/render.md). */
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

const char *render_pass_state_name(render_pass_state s)
{
    static const char *const n[RENDER_PASS_STATE_COUNT] = {"planned", "ran", "memory", "disk", "culled"};
    return (unsigned)s < RENDER_PASS_STATE_COUNT ? n[s] : "?";
}

render_options render_options_default(void)
{
    render_options o;
    memset(&o, 0, sizeof o);
    return o;
}

/* The memory cache's default budget (ours): half the machine's physical memory, 1 GiB when
 * sysconf cannot say. */
static uint64_t default_cache_memory(void)
{
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0)
        return (uint64_t)1 << 30;
    return (uint64_t)pages * (uint64_t)page / 2u;
}

render_session *render_session_create(obs_context *ctx, const render_options *opt)
{
    render_options o = opt ? *opt : render_options_default();
    if (o.threads < 0 || o.threads > 4096) {
        obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "render: threads %d out of [0, 4096]", o.threads);
        return NULL;
    }
    render_session *s = (render_session *)calloc(1, sizeof *s);
    if (!s) {
        obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "render: out of memory for the session");
        return NULL;
    }
    s->ctx = ctx;
    if (o.cache_dir) {
        if (strlen(o.cache_dir) >= sizeof s->cache_dir - 80) {
            free(s);
            obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "render: cache directory path too long");
            return NULL;
        }
        snprintf(s->cache_dir, sizeof s->cache_dir, "%s", o.cache_dir);
        o.cache_dir = s->cache_dir;
    }
    s->opt = o;
    s->pool = obs_pool_create(o.threads);
    s->cache = render_cache_create(o.cache_dir, o.cache_memory ? o.cache_memory : default_cache_memory());
    if (!s->pool || !s->cache) {
        render_session_destroy(s);
        obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "render: cannot start the thread pool or the cache");
        return NULL;
    }
    return s;
}

void render_session_destroy(render_session *s)
{
    if (!s)
        return;
    render_cache_destroy(s->cache);
    sss_maps_workspace_free(s->sss_ws);
    obs_pool_destroy(s->pool);
    free(s);
}

void render_session_cache_stats(const render_session *s, render_cache_stats *out)
{
    memset(out, 0, sizeof *out);
    if (s)
        render_cache_get_stats(s->cache, out);
}

void render_frame_free(render_frame *f)
{
    if (!f)
        return;
    obs_image_f32 *planes[] = {f->beauty, f->direct, f->ambient, f->sss, f->normal, f->albedo, f->ref_beauty,
                               f->ref_ambient, f->ref_sss};
    for (size_t i = 0; i < sizeof planes / sizeof planes[0]; i++)
        render_planes_free(3, planes[i]);
    render_planes_free(4, f->volume);
    render_planes_free(4, f->ref_volume);
    obs_image_f32_free(&f->ao);
    obs_image_f32_free(&f->ref_ao);
    obs_image_f32_free(&f->depth);
    memset(f, 0, sizeof *f);
}

/* ------------------------------------------------------------------------------------------------
 * Helpers shared by the passes
 * ---------------------------------------------------------------------------------------------- */

obs_status render_planes_alloc(obs_context *ctx, int n, int w, int h, obs_image_f32 *out)
{
    for (int i = 0; i < n; i++) {
        obs_status st = obs_image_f32_alloc(ctx, w, h, &out[i]);
        if (st != OBS_STATUS_OK) {
            render_planes_free(i, out);
            return st;
        }
    }
    return OBS_STATUS_OK;
}

void render_planes_free(int n, obs_image_f32 *p)
{
    for (int i = 0; i < n; i++)
        obs_image_f32_free(&p[i]);
}

uint64_t render_planes_bytes(int n, const obs_image_f32 *p)
{
    uint64_t b = 0;
    for (int i = 0; i < n; i++)
        if (p[i].data)
            b += 4u * (uint64_t)p[i].stride * (uint64_t)p[i].height;
    return b;
}

void render_hash_geometry(render_hash *h, const obs_scene *scene)
{
    render_hash_u64(h, scene->instance_count);
    for (uint32_t i = 0; i < scene->instance_count; i++) {
        const obs_instance *in = &scene->instances[i];
        const obs_mesh *m = &scene->meshes[in->mesh];
        render_hash_u64(h, in->mesh);
        render_hash_u64(h, in->node);
        render_hash_bytes(h, in->world.m, sizeof in->world.m);
        render_hash_u64(h, m->vertex_count);
        render_hash_u64(h, m->triangle_count);
        render_hash_i(h, m->material);
        render_hash_bytes(h, m->positions, sizeof(float) * 3 * (size_t)m->vertex_count);
        render_hash_i(h, m->normals != NULL);
        if (m->normals)
            render_hash_bytes(h, m->normals, sizeof(float) * 3 * (size_t)m->vertex_count);
        render_hash_bytes(h, m->indices, sizeof(uint32_t) * 3 * (size_t)m->triangle_count);
    }
}

void render_hash_lights(render_hash *h, const render_job *j)
{
    render_hash_i(h, j->light_count);
    for (int i = 0; i < j->light_count; i++) {
        const obs_light *L = &j->lights[i];
        render_hash_i(h, L->type);
        /* range is not read (ignored, docs/render.md); the position of a directional light is not
           read either, but a light's node placing it is cheap to over-key */
        const float v[] = {L->color.x, L->color.y, L->color.z, L->intensity, L->position.x,
                           L->position.y, L->position.z, L->direction.x, L->direction.y, L->direction.z};
        for (size_t k = 0; k < sizeof v / sizeof v[0]; k++)
            render_hash_d(h, v[k]);
    }
}

void render_hash_materials(render_hash *h, const render_job *j)
{
    const sss_scene_setup *s = &j->sss;
    render_hash_u64(h, s->mats.count);
    for (uint32_t i = 0; i < s->mats.count; i++) {
        render_hash_i(h, s->translucent[i]);
        if (!s->translucent[i])
            continue;
        const sss_material *m = &s->constants[i].material;
        for (int c = 0; c < 3; c++)
            render_hash_d(h, m->sigma_s[c]), render_hash_d(h, m->sigma_a[c]);
        render_hash_d(h, m->g);
        render_hash_d(h, m->eta);
        render_hash_d(h, s->constants[i].mm_per_unit);
    }
}

void render_hash_sss_params(render_hash *h, const sss_params *p)
{
    render_hash_i(h, p->model), render_hash_i(h, p->K), render_hash_i(h, p->N), render_hash_i(h, p->M);
    render_hash_i(h, p->map_size), render_hash_i(h, p->light_map_size), render_hash_i(h, p->frames);
    render_hash_d(h, p->spread_q), render_hash_d(h, p->disk_radius), render_hash_i(h, p->sampler);
    render_hash_i(h, p->visibility), render_hash_d(h, p->shadow_bias), render_hash_d(h, p->shrink_eps);
    render_hash_d(h, p->gamma), render_hash_i(h, p->specular), render_hash_d(h, p->specular_exponent);
    render_hash_u64(h, p->seed), render_hash_i(h, p->isa);
}

render_pass_record *render_job_record(render_job *j, const char *name)
{
    for (int i = 0; i < j->f->pass_count; i++)
        if (!strcmp(j->f->passes[i].name, name))
            return &j->f->passes[i];
    return NULL;
}

static int res_index(unsigned bit)
{
    for (int i = 0; i < RES_COUNT_BITS; i++)
        if (bit == (1u << i))
            return i;
    return 0;
}

obs_status render_cached(render_job *j, unsigned res, const render_product_ops *ops,
                         obs_status (*build)(render_job *j, void *p), void **out, render_pass_state *state,
                         uint64_t *bytes)
{
    render_cache *c = j->session->cache;
    const int ri = res_index(res);
    if (!j->key_valid[ri])
        return obs_error(j->ctx, OBS_STATUS_INTERNAL, "render: %s has no key", ops->kind);
    const render_key k = j->key[ri];
    void *p = render_cache_find(c, k, ops);
    if (p) {
        render_cache_count(c, 1, 0, 0);
        *state = RENDER_PASS_CACHED_MEMORY;
    } else if ((p = render_cache_load(c, j->ctx, k, ops)) != NULL) {
        render_cache_count(c, 0, 1, 0);
        *state = RENDER_PASS_CACHED_DISK;
    } else {
        render_cache_count(c, 0, 0, 1);
        p = calloc(1, ops->size);
        if (!p)
            return obs_error(j->ctx, OBS_STATUS_OUT_OF_MEMORY, "render: out of memory for %s", ops->kind);
        obs_status st = build(j, p);
        if (st != OBS_STATUS_OK) {
            ops->free_fn(p);
            free(p);
            return st;
        }
        p = render_cache_put(c, j->ctx, k, ops, p, ops->bytes(p));
        if (!p)
            return obs_error(j->ctx, OBS_STATUS_OUT_OF_MEMORY, "render: out of memory for the cache");
        *state = RENDER_PASS_RAN;
    }
    *out = p;
    *bytes = ops->bytes(p);
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * Views
 * ---------------------------------------------------------------------------------------------- */

int render_view_count(const obs_scene *scene, const render_settings *st)
{
    if (st->camera_count > 0)
        return st->camera_count;
    return scene->camera_count > 0 ? (int)scene->camera_count : 1;
}

static obs_status pick_camera(obs_context *ctx, const obs_scene *scene, const render_settings *st, int slot,
                              obs_camera *cam, int *index)
{
    const int views = render_view_count(scene, st);
    if (slot < 0 || slot >= views)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "render: view %d out of range (the scene renders %d view(s))",
                         slot, views);
    int ci = st->camera_count > 0 ? st->cameras[slot] : (scene->camera_count > 0 ? slot : -1);
    if (ci >= (int)scene->camera_count || ci < -1 || (st->camera_count > 0 && ci < 0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "render: camera index %d out of range: scene '%s' has %u camera(s)", ci, scene->source,
                         scene->camera_count);
    *index = ci;
    if (ci >= 0) {
        *cam = scene->cameras[ci];
    } else {
        /* as cli_pick_camera: a camera framing the bounds with a 45-degree field of view */
        *cam = obs_camera_frame_bounds(scene->bounds, (float)(45.0 * OBS_PI / 180.0));
        snprintf(cam->name, sizeof cam->name, "framing");
    }
    return OBS_STATUS_OK;
}

/* Size: settings.width x height; 0 x 0: RENDER_DEFAULT_WIDTH wide at the camera's aspect (as
 * cli_size_from_camera), 1920 x 1080 when the camera has none; one side 0: from the other. */
static obs_status pick_size(obs_context *ctx, const render_settings *st, const obs_camera *cam, int *W, int *H)
{
    const double aspect = cam->projection == OBS_PROJECTION_PERSPECTIVE && cam->aspect > 0 ? cam->aspect : 0.0;
    int w = st->width, h = st->height;
    if (w <= 0 && h <= 0) {
        w = RENDER_DEFAULT_WIDTH;
        h = aspect > 0 ? (int)lround(RENDER_DEFAULT_WIDTH / aspect) : 1080;
    } else if (h <= 0) {
        h = (int)lround(w / (aspect > 0 ? aspect : 16.0 / 9.0));
    } else if (w <= 0) {
        w = (int)lround(h * (aspect > 0 ? aspect : 16.0 / 9.0));
    }
    if (h < 1) h = 1;
    if (w < 1) w = 1;
    if (w > RAST_MAX_DIM || h > RAST_MAX_DIM)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "render: image size %dx%d over %d per side", w, h, RAST_MAX_DIM);
    *W = w;
    *H = h;
    return OBS_STATUS_OK;
}

static void job_free(render_job *j)
{
    rast_gbuffer_free(&j->gb);
    render_planes_free(3, j->nff);
    render_planes_free(3, j->fnff);
    obs_image_f32_free(&j->mask_opaque);
    obs_image_f32_free(&j->mask_translucent);
    sss_scene_setup_free(&j->sss);
    free(j->sss_scene.instances);
    free(j->lights);
    memset(j, 0, sizeof *j);
}

static obs_status job_init(render_session *s, const obs_scene *scene, const render_settings *st, int slot,
                           render_frame *out, render_job *j)
{
    memset(j, 0, sizeof *j);
    memset(out, 0, sizeof *out);
    j->session = s;
    j->ctx = s->ctx;
    j->pool = s->pool;
    j->scene = scene;
    j->st = st;
    j->f = out;
    j->volume_light = -1;
    obs_status r = pick_camera(s->ctx, scene, st, slot, &j->cam, &out->camera);
    if (r == OBS_STATUS_OK)
        r = pick_size(s->ctx, st, &j->cam, &j->W, &j->H);
    if (r != OBS_STATUS_OK)
        return r;
    if (j->cam.aspect == 0.0f)
        j->cam.aspect = (float)j->W / (float)j->H;
    out->width = j->W;
    out->height = j->H;
    out->cam = j->cam;
    /* lights: directional and point (spot lights are not supported by the SSS and volume passes) */
    j->lights = (obs_light *)calloc(scene->light_count ? scene->light_count : 1, sizeof *j->lights);
    if (!j->lights)
        return obs_error(s->ctx, OBS_STATUS_OUT_OF_MEMORY, "render: out of memory");
    for (uint32_t i = 0; i < scene->light_count; i++) {
        if (scene->lights[i].type == OBS_LIGHT_SPOT) {
            j->spot_lights++;
            continue;
        }
        j->lights[j->light_count++] = scene->lights[i];
        if (j->volume_light < 0)
            j->volume_light = (int)i;
    }
    if (st->volume.light >= 0) {
        if (st->volume.light >= (int)scene->light_count)
            return obs_error(s->ctx, OBS_STATUS_INVALID_ARGUMENT, "render: volume light %d out of range: scene '%s' has %u light(s)",
                             st->volume.light, scene->source, scene->light_count);
        if (scene->lights[st->volume.light].type == OBS_LIGHT_SPOT)
            return obs_error(s->ctx, OBS_STATUS_UNSUPPORTED, "render: volume light %d ('%s') is a spot light (unsupported)",
                             st->volume.light, scene->lights[st->volume.light].name);
        j->volume_light = st->volume.light;
    }
    r = sss_scene_setup_make(s->ctx, scene, NULL, st->mm_per_unit, &j->sss);
    if (r != OBS_STATUS_OK)
        return r;
    j->any_translucent = sss_scene_setup_any_translucent(&j->sss, scene);
    for (uint32_t i = 0; i < scene->instance_count && !j->any_opaque; i++) {
        int32_t m = scene->meshes[scene->instances[i].mesh].material;
        j->any_opaque = !(m >= 0 && (uint32_t)m < j->sss.mats.count && j->sss.mats.translucent[m]);
    }
    /* The SSS products see the translucent instances only (docs/render.md, "SSS"): the maps frame
       them tightly, a point light in the room (outside the objects' bounding sphere, which
       sss_light_map_render requires) works, and a change to an opaque mesh keeps the maps. The
       price: opaque meshes cast no shadow into the scattering maps (the reference, ref_sss, traces
       the full scene, so --reference measures it). */
    j->sss_scene = *scene;
    j->sss_scene.instances = (obs_instance *)calloc(scene->instance_count ? scene->instance_count : 1,
                                                    sizeof(obs_instance));
    if (!j->sss_scene.instances)
        return obs_error(s->ctx, OBS_STATUS_OUT_OF_MEMORY, "render: out of memory");
    j->sss_scene.instance_count = 0;
    for (uint32_t i = 0; i < scene->instance_count; i++) {
        int32_t m = scene->meshes[scene->instances[i].mesh].material;
        if (m >= 0 && (uint32_t)m < j->sss.mats.count && j->sss.mats.translucent[m])
            j->sss_scene.instances[j->sss_scene.instance_count++] = scene->instances[i];
    }
    obs_scene_update_bounds(&j->sss_scene);
    j->sss_p = st->sss;
    j->sss_p.seed ^= st->seed; /* the session seed reaches the SSS samplers */
    return OBS_STATUS_OK;
}

/* Keys of the view-independent passes that can be known now (light_volume needs its grid: known at
 * plan time only when the grid is already in this session's memory cache). */
static void job_keys(render_job *j, const int live[], int count, const render_pass *const *ps)
{
    for (int i = 0; i < count; i++) {
        if (ps[i] == &render_pass_light_volume && live[i] && !j->vol) {
            const int vi = res_index(RES_VOLUME_GRID);
            if (j->key_valid[vi])
                j->vol = (render_volume_data *)render_cache_find(j->session->cache, j->key[vi], &render_ops_volume);
        }
        if (!live[i] || ps[i]->view_dependent || !ps[i]->key)
            continue;
        const int ri = res_index(ps[i]->writes);
        j->key_valid[ri] = ps[i]->key(j, &j->key[ri]);
        render_pass_record *rec = render_job_record(j, ps[i]->name);
        if (rec && j->key_valid[ri])
            render_key_hex(j->key[ri], rec->key);
    }
}

obs_status render_plan(render_session *s, const obs_scene *scene, const render_settings *st, int camera_slot,
                       render_frame *out)
{
    if (!s || !scene || !st || !out)
        return obs_error(s ? s->ctx : NULL, OBS_STATUS_INVALID_ARGUMENT, "render_plan: NULL argument");
    render_job j;
    int live[RENDER_MAX_PASSES], order[RENDER_MAX_PASSES], count;
    const render_pass *const *ps = render_passes(&count);
    obs_status r = job_init(s, scene, st, camera_slot, out, &j);
    if (r == OBS_STATUS_OK)
        r = render_graph_compile(&j, live, order);
    if (r == OBS_STATUS_OK)
        job_keys(&j, live, count, ps);
    job_free(&j);
    return r;
}

/* ------------------------------------------------------------------------------------------------
 * Reference errors
 * ---------------------------------------------------------------------------------------------- */

/* RMSE, MAE, bias (mean of approx - ref) and PSNR (peak = the largest reference value, at least 1
 * for AO) over the pixels of mask (1 plane) and n channels. */
static void layer_error(render_frame *f, const char *name, const obs_image_f32 *a, const obs_image_f32 *r, int n,
                        const obs_image_f32 *mask, const obs_image_f32 *alpha_a, const obs_image_f32 *alpha_r)
{
    if (f->error_count >= RENDER_MAX_LAYER_ERRORS || !a[0].data || !r[0].data)
        return;
    double se = 0, ae = 0, b = 0, peak = 0;
    int64_t px = 0;
    for (int y = 0; y < f->height; y++)
        for (int x = 0; x < f->width; x++) {
            int in = mask && obs_image_f32_row(mask, y)[x] > 0;
            if (alpha_a && (obs_image_f32_row(alpha_a, y)[x] > 0 || obs_image_f32_row(alpha_r, y)[x] > 0))
                in = 1;
            if (!in)
                continue;
            px++;
            for (int c = 0; c < n; c++) {
                double va = obs_image_f32_row(&a[c], y)[x], vr = obs_image_f32_row(&r[c], y)[x], d = va - vr;
                se += d * d;
                ae += fabs(d);
                b += d;
                if (vr > peak)
                    peak = vr;
            }
        }
    render_layer_error *e = &f->errors[f->error_count++];
    memset(e, 0, sizeof *e);
    snprintf(e->layer, sizeof e->layer, "%s", name);
    e->pixels = px;
    const double m = px > 0 ? (double)px * n : 1.0;
    e->rmse = sqrt(se / m);
    e->mae = ae / m;
    e->bias = b / m;
    if (!strcmp(name, "ao") && peak < 1.0)
        peak = 1.0;
    e->psnr = se > 0 ? 10.0 * log10(peak * peak / (se / m)) : INFINITY;
}

static void reference_errors(render_job *j)
{
    render_frame *f = j->f;
    obs_image_f32 surface;
    if (obs_image_f32_alloc(j->ctx, j->W, j->H, &surface) != OBS_STATUS_OK)
        return;
    for (int y = 0; y < j->H; y++)
        for (int x = 0; x < j->W; x++) {
            float d = obs_image_f32_row(&j->gb.depth, y)[x];
            obs_image_f32_row(&surface, y)[x] = isfinite(d) && d > 0 ? 1.0f : 0.0f;
        }
    const obs_image_f32 *va = f->volume[3].data ? &f->volume[3] : NULL;
    const obs_image_f32 *vr = f->ref_volume[3].data ? &f->ref_volume[3] : va;
    layer_error(f, "beauty", f->beauty, f->ref_beauty, 3, &surface, va, vr);
    layer_error(f, "ao", &f->ao, &f->ref_ao, 1, &j->mask_opaque, NULL, NULL);
    layer_error(f, "ambient", f->ambient, f->ref_ambient, 3, &j->mask_opaque, NULL, NULL);
    layer_error(f, "sss", f->sss, f->ref_sss, 3, &j->mask_translucent, NULL, NULL);
    if (f->ref_volume[3].data)
        layer_error(f, "volume", f->volume, f->ref_volume, 4, NULL, &f->volume[3], &f->ref_volume[3]);
    obs_image_f32_free(&surface);
    f->has_reference = 1;
}

/* Drop the layers not asked for (the passes may have made them as inputs of others). */
static void prune_layers(render_frame *f, const render_settings *st)
{
    const unsigned o = f->outputs;
    if (!(o & RENDER_OUT_BEAUTY)) render_planes_free(3, f->beauty);
    if (!(o & RENDER_OUT_DIRECT)) render_planes_free(3, f->direct);
    if (!(o & RENDER_OUT_AMBIENT)) render_planes_free(3, f->ambient);
    if (!(o & RENDER_OUT_AO)) obs_image_f32_free(&f->ao);
    if (!(o & RENDER_OUT_SSS)) render_planes_free(3, f->sss);
    if (!(o & RENDER_OUT_VOLUME)) render_planes_free(4, f->volume);
    if (!(o & RENDER_OUT_DEPTH)) obs_image_f32_free(&f->depth);
    if (!(o & RENDER_OUT_NORMAL)) render_planes_free(3, f->normal);
    if (!(o & RENDER_OUT_ALBEDO)) render_planes_free(3, f->albedo);
    if (!st->reference || !(st->outputs & RENDER_OUT_BEAUTY)) render_planes_free(3, f->ref_beauty);
    if (!st->reference || !(st->outputs & RENDER_OUT_AMBIENT)) render_planes_free(3, f->ref_ambient);
    if (!st->reference || !(st->outputs & RENDER_OUT_AO)) obs_image_f32_free(&f->ref_ao);
    if (!st->reference || !(st->outputs & RENDER_OUT_SSS)) render_planes_free(3, f->ref_sss);
    if (!st->reference || !(st->outputs & RENDER_OUT_VOLUME)) render_planes_free(4, f->ref_volume);
}

static uint64_t peak_rss(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0)
        return 0;
    return (uint64_t)ru.ru_maxrss * 1024u; /* Linux: kilobytes */
}

obs_status render_frame_run(render_session *s, const obs_scene *scene, const render_settings *st, int camera_slot,
                            render_frame *out)
{
    if (!s || !scene || !st || !out)
        return obs_error(s ? s->ctx : NULL, OBS_STATUS_INVALID_ARGUMENT, "render_frame_run: NULL argument");
    const double t_frame = obs_time_now();
    render_cache_begin_frame(s->cache, s->ctx);
    render_job j;
    int live[RENDER_MAX_PASSES], order[RENDER_MAX_PASSES], count;
    const render_pass *const *ps = render_passes(&count);
    obs_status r = job_init(s, scene, st, camera_slot, out, &j);
    if (r == OBS_STATUS_OK)
        r = render_graph_compile(&j, live, order);
    if (r == OBS_STATUS_OK)
        job_keys(&j, live, count, ps);
    int live_count = 0;
    for (int i = 0; i < out->pass_count; i++)
        live_count += out->passes[i].state == RENDER_PASS_PLANNED;
    const int views = render_view_count(scene, st);
    for (int k = 0; r == OBS_STATUS_OK && k < out->pass_count; k++) {
        render_pass_record *rec = &out->passes[k];
        if (rec->state != RENDER_PASS_PLANNED)
            continue;
        const render_pass *p = ps[order[k]];
        if (!p->view_dependent && p->key) { /* a key that needed an earlier product (light_volume) */
            const int ri = res_index(p->writes);
            if (!j.key_valid[ri] && (j.key_valid[ri] = p->key(&j, &j.key[ri])) != 0)
                render_key_hex(j.key[ri], rec->key);
        }
        const double t0 = obs_time_now();
        render_pass_state state = RENDER_PASS_RAN;
        uint64_t bytes = 0;
        r = p->run(&j, &state, &bytes);
        rec->seconds = obs_time_now() - t0;
        rec->state = state;
        rec->output_bytes = bytes;
        rec->peak_rss_bytes = peak_rss();
        if (r != OBS_STATUS_OK) {
            char msg[1024];
            snprintf(msg, sizeof msg, "%s", obs_context_last_error(s->ctx));
            obs_context_clear_error(s->ctx);
            r = obs_error(s->ctx, r, "render: pass %s failed on scene '%s': %s", p->name, scene->source, msg);
            break;
        }
        if (p->is_reference)
            out->seconds_reference += rec->seconds;
        else
            out->seconds_approx += rec->seconds;
        if (s->opt.progress)
            s->opt.progress(s->opt.progress_user, (int64_t)camera_slot * live_count + k + 1,
                            (int64_t)views * live_count);
    }
    if (r == OBS_STATUS_OK && st->reference) {
        /* the passes both sides share (G-buffer, shadow maps, direct, volume load) count on both */
        for (int k = 0; k < out->pass_count; k++) {
            const char *n = out->passes[k].name;
            if (!strcmp(n, "gbuffer") || !strcmp(n, "shadow_maps") || !strcmp(n, "direct") || !strcmp(n, "volume_load"))
                out->seconds_reference += out->passes[k].seconds;
        }
        reference_errors(&j);
    }
    if (r == OBS_STATUS_OK)
        prune_layers(out, st);
    job_free(&j);
    out->seconds = obs_time_now() - t_frame;
    if (r != OBS_STATUS_OK) {
        /* keep the pass log for the caller, drop the planes */
        render_frame keep = *out;
        memset(out, 0, sizeof *out);
        out->pass_count = keep.pass_count;
        memcpy(out->passes, keep.passes, sizeof keep.passes);
        render_frame_free(&keep);
    }
    return r;
}
