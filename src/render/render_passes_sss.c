/* render_passes_sss.c: subsurface scattering through the scattering maps of [DalCorso17]
 * (sss.h section 3): the light G-buffers and the K maps are view-independent products (cached in
 * memory and on disk); the combination runs per view. One maps product covers every translucent
 * mesh of the scene (sss_maps_build gathers them together), so its key holds every translucent
 * material: a change to any of them rebuilds the maps (docs/render.md, "Keys"). The light G-buffers
 * and the maps are built from j->sss_scene, the translucent instances alone (render.c says why). */
#include "render_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int has_sss(const render_job *j, char *r, size_t n)
{
    if (!j->any_translucent) {
        snprintf(r, n, "no translucent material in the scene");
        return 0;
    }
    if (j->light_count == 0) {
        snprintf(r, n, "no directional or point light to light the translucent meshes");
        return 0;
    }
    return 1;
}

/* ---- sss_light_maps ---------------------------------------------------------------------- */

static unsigned lm_reads(const render_job *j, char *t, size_t n)
{
    (void)j;
    snprintf(t, n, "geometry,lights,sss.light_map_size");
    return 0;
}
static int lm_wanted(const render_job *j, char *r, size_t n)
{
    if (!has_sss(j, r, n))
        return 0;
    snprintf(r, n, "%d light G-buffer(s) of %d^2 for the scattering maps", j->light_count, j->sss_p.light_map_size);
    return 1;
}
static int lm_key(render_job *j, render_key *out)
{
    render_hash h;
    render_hash_init(&h, "sss_light_maps");
    render_hash_geometry(&h, &j->sss_scene); /* the translucent instances only */
    render_hash_lights(&h, j);
    render_hash_i(&h, j->sss_p.light_map_size);
    *out = render_hash_final(&h);
    return 1;
}

static void lm_free(void *p)
{
    render_sss_light_maps *s = (render_sss_light_maps *)p;
    for (int i = 0; s->lm && i < s->count; i++)
        sss_light_map_free(&s->lm[i]);
    free(s->lm);
    memset(s, 0, sizeof *s);
}
static uint64_t gb_bytes(const rast_gbuffer *gb)
{
    uint64_t b = render_planes_bytes(1, &gb->depth) + render_planes_bytes(1, &gb->ndc_depth) +
                 render_planes_bytes(3, gb->normal) + render_planes_bytes(3, gb->face_normal);
    const obs_image_u32 *u[3] = {&gb->prim_id, &gb->instance_id, &gb->material_id};
    for (int i = 0; i < 3; i++)
        if (u[i]->data)
            b += 4u * (uint64_t)u[i]->stride * (uint64_t)u[i]->height;
    return b;
}
static uint64_t lm_bytes(const void *p)
{
    const render_sss_light_maps *s = (const render_sss_light_maps *)p;
    uint64_t b = 0;
    for (int i = 0; i < s->count; i++)
        b += gb_bytes(&s->lm[i].gb) + render_planes_bytes(3, s->lm[i].position) + render_planes_bytes(3, s->lm[i].wnormal);
    return b;
}

typedef struct lm_head { obs_light light; double world_per_texel; } lm_head;

static obs_status lm_save(obs_context *ctx, const void *p, render_blobs *out)
{
    const render_sss_light_maps *s = (const render_sss_light_maps *)p;
    int32_t n = s->count;
    int ok = render_blobs_add_copy(out, &n, sizeof n);
    for (int i = 0; ok && i < s->count; i++) {
        lm_head hd;
        memset(&hd, 0, sizeof hd);
        hd.light = s->lm[i].light;
        hd.world_per_texel = s->lm[i].world_per_texel;
        ok = render_blobs_add_copy(out, &hd, sizeof hd) && render_blobs_add_gbuffer(out, &s->lm[i].gb);
        for (int c = 0; ok && c < 3; c++)
            ok = render_blobs_add_plane(out, &s->lm[i].position[c]) && render_blobs_add_plane(out, &s->lm[i].wnormal[c]);
    }
    return ok ? OBS_STATUS_OK : obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "render cache: out of memory");
}
static obs_status lm_load(obs_context *ctx, render_reader *r, void *p)
{
    render_sss_light_maps *s = (render_sss_light_maps *)p;
    const int32_t *n = (const int32_t *)render_reader_take(r, sizeof(int32_t));
    if (!n || *n < 0 || *n > 4096)
        return OBS_STATUS_PARSE_ERROR;
    s->lm = (sss_light_map *)calloc((size_t)(*n ? *n : 1), sizeof *s->lm);
    if (!s->lm)
        return OBS_STATUS_OUT_OF_MEMORY;
    s->count = *n;
    obs_status st = OBS_STATUS_OK;
    for (int i = 0; i < s->count && st == OBS_STATUS_OK; i++) {
        const lm_head *hd = (const lm_head *)render_reader_take(r, sizeof(lm_head));
        if (!hd)
            return OBS_STATUS_PARSE_ERROR;
        s->lm[i].light = hd->light;
        s->lm[i].world_per_texel = hd->world_per_texel;
        st = render_reader_gbuffer(ctx, r, &s->lm[i].gb);
        for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++) {
            st = render_reader_plane(ctx, r, 0, 0, &s->lm[i].position[c]);
            if (st == OBS_STATUS_OK)
                st = render_reader_plane(ctx, r, 0, 0, &s->lm[i].wnormal[c]);
        }
    }
    return st;
}
const render_product_ops render_ops_sss_light_maps = {"sss_light_maps", lm_free, lm_save, lm_load,
                                                       sizeof(render_sss_light_maps), lm_bytes};

static obs_status lm_build(render_job *j, void *p)
{
    render_sss_light_maps *s = (render_sss_light_maps *)p;
    s->lm = (sss_light_map *)calloc((size_t)j->light_count, sizeof *s->lm);
    if (!s->lm)
        return obs_error(j->ctx, OBS_STATUS_OUT_OF_MEMORY, "render: out of memory for the light G-buffers");
    s->count = j->light_count;
    obs_status st = OBS_STATUS_OK;
    for (int i = 0; i < j->light_count && st == OBS_STATUS_OK; i++)
        st = sss_light_map_render(j->ctx, j->pool, &j->sss_scene, &j->lights[i], &j->sss_p, &s->lm[i]);
    return st;
}
static obs_status lm_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    return render_cached(j, RES_SSS_LIGHT_MAPS, &render_ops_sss_light_maps, lm_build, (void **)&j->slm, state, bytes);
}
const render_pass render_pass_sss_light_maps = {"sss_light_maps", RES_SSS_LIGHT_MAPS, 0, 0, lm_reads, lm_wanted,
                                                lm_key, lm_run};

/* ---- sss_maps ------------------------------------------------------------------------------ */

static unsigned maps_reads(const render_job *j, char *t, size_t n)
{
    (void)j;
    snprintf(t, n, "sss_light_maps,geometry,materials,sss_params");
    return RES_SSS_LIGHT_MAPS;
}
static int maps_wanted(const render_job *j, char *r, size_t n)
{
    if (!has_sss(j, r, n))
        return 0;
    snprintf(r, n, "%u translucent material(s): K=%d scattering maps of %d^2, N=%d (%s)", j->sss.translucent_slots,
             j->sss_p.K, j->sss_p.map_size, j->sss_p.N, sss_sampler_name(j->sss_p.sampler));
    return 1;
}
static int maps_key(render_job *j, render_key *out)
{
    render_key lk;
    lm_key(j, &lk);
    render_hash h;
    render_hash_init(&h, "sss_maps");
    render_hash_key(&h, lk); /* geometry, transforms, lights, light-map size */
    render_hash_materials(&h, j);
    render_hash_sss_params(&h, &j->sss_p);
    *out = render_hash_final(&h);
    return 1;
}

static void maps_free(void *p) { sss_maps_free((sss_maps *)p); }
static uint64_t maps_bytes(const void *p)
{
    const sss_maps *m = (const sss_maps *)p;
    uint64_t b = render_planes_bytes(3 * m->K, m->radiance);
    for (int k = 0; k < m->K; k++)
        b += gb_bytes(&m->views[k]);
    return b;
}
typedef struct maps_head { int32_t K, size; uint64_t samples, candidates; } maps_head;
static obs_status maps_save(obs_context *ctx, const void *p, render_blobs *out)
{
    const sss_maps *m = (const sss_maps *)p;
    maps_head hd = {m->K, m->size, m->samples_evaluated, m->candidates};
    int ok = render_blobs_add_copy(out, &hd, sizeof hd) && render_blobs_add_copy(out, m->dirs, sizeof(double) * 3 * (size_t)m->K);
    for (int k = 0; ok && k < m->K; k++)
        ok = render_blobs_add_gbuffer(out, &m->views[k]);
    for (int k = 0; ok && k < 3 * m->K; k++)
        ok = render_blobs_add_plane(out, &m->radiance[k]);
    return ok ? OBS_STATUS_OK : obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "render cache: out of memory");
}
static obs_status maps_load(obs_context *ctx, render_reader *r, void *p)
{
    sss_maps *m = (sss_maps *)p;
    const maps_head *hd = (const maps_head *)render_reader_take(r, sizeof(maps_head));
    if (!hd || hd->K < 1 || hd->K > 256)
        return OBS_STATUS_PARSE_ERROR;
    const double *dirs = (const double *)render_reader_take(r, sizeof(double) * 3 * (size_t)hd->K);
    if (!dirs)
        return OBS_STATUS_PARSE_ERROR;
    /* allocated as sss_maps_build does: malloc/calloc'd arrays freed by sss_maps_free */
    m->dirs = (double *)malloc(sizeof(double) * 3 * (size_t)hd->K);
    m->views = (rast_gbuffer *)calloc((size_t)hd->K, sizeof *m->views);
    m->radiance = (obs_image_f32 *)calloc(3 * (size_t)hd->K, sizeof *m->radiance);
    if (!m->dirs || !m->views || !m->radiance)
        return OBS_STATUS_OUT_OF_MEMORY;
    m->K = hd->K;
    m->size = hd->size;
    m->samples_evaluated = hd->samples;
    m->candidates = hd->candidates;
    memcpy(m->dirs, dirs, sizeof(double) * 3 * (size_t)hd->K);
    obs_status st = OBS_STATUS_OK;
    for (int k = 0; k < m->K && st == OBS_STATUS_OK; k++)
        st = render_reader_gbuffer(ctx, r, &m->views[k]);
    for (int k = 0; k < 3 * m->K && st == OBS_STATUS_OK; k++)
        st = render_reader_plane(ctx, r, m->size, m->size, &m->radiance[k]);
    return st;
}
const render_product_ops render_ops_sss_maps = {"sss_maps", maps_free, maps_save, maps_load, sizeof(sss_maps),
                                                maps_bytes};

/* A build (p is zeroed by the cache) through sss_maps_rebuild with the session's workspace, so that
 * the rasterizer's scratch and the per-thread buffers are reused from the last build: the same
 * bytes as sss_maps_build (tests sss_maps_rebuild_*), fewer page faults. Frames of one session
 * run one after another, so the workspace is never shared by concurrent builds. */
static obs_status maps_build(render_job *j, void *p)
{
    render_session *s = j->session;
    if (!s->sss_ws && !(s->sss_ws = sss_maps_workspace_create()))
        return obs_error(j->ctx, OBS_STATUS_OUT_OF_MEMORY, "render: out of memory (the SSS maps' workspace)");
    return sss_maps_rebuild(j->ctx, j->pool, &j->sss_scene, &j->sss.mats, j->slm->lm, j->slm->count, &j->sss_p,
                            s->sss_ws, (sss_maps *)p);
}
static obs_status maps_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    return render_cached(j, RES_SSS_MAPS, &render_ops_sss_maps, maps_build, (void **)&j->maps, state, bytes);
}
const render_pass render_pass_sss_maps = {"sss_maps", RES_SSS_MAPS, 0, 0, maps_reads, maps_wanted, maps_key, maps_run};

/* ---- sss_combine --------------------------------------------------------------------------- */

static unsigned comb_reads(const render_job *j, char *t, size_t n)
{
    (void)j;
    snprintf(t, n, "gbuffer,sss_maps,sss_light_maps,camera");
    return RES_GBUFFER | RES_SSS_MAPS | RES_SSS_LIGHT_MAPS;
}
static int comb_wanted(const render_job *j, char *r, size_t n)
{
    if (!has_sss(j, r, n))
        return 0;
    snprintf(r, n, "SSS radiance of the translucent pixels from the %d maps (%s visibility)", j->sss_p.K,
             sss_visibility_name(j->sss_p.visibility));
    return 1;
}
static obs_status comb_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    obs_status st = sss_combine(j->ctx, j->pool, &j->sss_scene, &j->sss.mats, j->maps, j->slm->lm, j->slm->count, &j->gb,
                                &j->cam, &j->sss_p, j->f->sss, NULL);
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(3, j->f->sss);
    return st;
}
const render_pass render_pass_sss_combine = {"sss_combine", RES_SSS, 1, 0, comb_reads, comb_wanted, NULL, comb_run};
