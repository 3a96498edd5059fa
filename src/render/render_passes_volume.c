/* render_passes_volume.c: the scene's volume (vol.h): loading (memory cache only: a reload is
 * cheap), the light volume of [Ropinski10] (cached in memory and on disk) and the ray cast per view,
 * stopped at the meshes' depth. The eye pass (vol_lv_params.eye_pass) depends on the camera: the
 * raycast pass runs it on a copy of the cached light volume (docs/render.md). */
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../io/io.h"

int render_job_has_volume(const render_job *j) { return j->st->volume.enabled != 0; }

static unsigned load_reads(const render_job *j, char *t, size_t n)
{
    (void)j;
    snprintf(t, n, "volume.source,volume.transfer,volume.box");
    return 0;
}
static int load_wanted(const render_job *j, char *r, size_t n)
{
    if (!render_job_has_volume(j)) {
        snprintf(r, n, "no volume in the scene");
        return 0;
    }
    snprintf(r, n, "volume '%s' with transfer function '%s'", j->st->volume.source, j->st->volume.transfer);
    return 1;
}

/* A path relative to the scene file's directory (absolute paths and scenes without a file: as is). */
static void resolve_path(const render_job *j, const char *rel, char *out, size_t n)
{
    const char *src = j->scene->source;
    const char *slash = strrchr(src, '/');
    if (rel[0] == '/' || !slash)
        snprintf(out, n, "%s", rel);
    else
        snprintf(out, n, "%.*s/%s", (int)(slash - src), src, rel);
}

static int is_json(const char *s)
{
    size_t n = strlen(s);
    return n > 5 && !strcmp(s + n - 5, ".json");
}

static int load_key(render_job *j, render_key *out)
{
    const render_volume_settings *v = &j->st->volume;
    char path[1200];
    render_hash h;
    render_hash_init(&h, "volume");
    if (strncmp(v->source, "synth:", 6) != 0) {
        resolve_path(j, v->source, path, sizeof path);
        render_hash_str(&h, path);
    } else {
        render_hash_str(&h, v->source);
    }
    if (is_json(v->transfer)) {
        resolve_path(j, v->transfer, path, sizeof path);
        render_hash_str(&h, path);
    } else {
        render_hash_str(&h, v->transfer);
    }
    render_hash_i(&h, v->has_box);
    for (int a = 0; a < 3; a++) {
        render_hash_d(&h, v->has_box ? v->box_lo[a] : 0);
        render_hash_d(&h, v->has_box ? v->box_hi[a] : 0);
    }
    *out = render_hash_final(&h);
    return 1;
}

static void vol_free(void *p)
{
    render_volume_data *v = (render_volume_data *)p;
    vol_rc_prepared_free(v->rc); /* before the grid and TF it points to */
    v->rc = NULL;
    vol_grid_free(&v->grid);
    vol_tf_free(&v->tf);
}
static uint64_t vol_bytes(const void *p)
{
    const render_volume_data *v = (const render_volume_data *)p;
    return 4u * (uint64_t)v->grid.nx * (uint64_t)v->grid.ny * (uint64_t)v->grid.nz;
}
const render_product_ops render_ops_volume = {"volume", vol_free, NULL, NULL, sizeof(render_volume_data), vol_bytes};

static obs_status load_grid(render_job *j, vol_grid *g)
{
    const char *src = j->st->volume.source;
    if (!strncmp(src, "synth:", 6)) {
        char name[64];
        int n = 32;
        const char *colon = strchr(src + 6, ':');
        size_t len = colon ? (size_t)(colon - (src + 6)) : strlen(src + 6);
        if (len >= sizeof name)
            len = sizeof name - 1;
        memcpy(name, src + 6, len);
        name[len] = '\0';
        if (colon) {
            long long ll;
            if (!obs_parse_int(colon + 1, 4, 4096, &ll))
                return obs_error(j->ctx, OBS_STATUS_INVALID_ARGUMENT,
                                 "volume '%s': the size after the name must be an integer in [4, 4096]", src);
            n = (int)ll;
        }
        return vol_synth(j->ctx, name, n, g);
    }
    char path[1200];
    resolve_path(j, src, path, sizeof path);
    FILE *f = fopen(path, "rb");
    if (!f)
        return obs_error(j->ctx, OBS_STATUS_NOT_FOUND, "volume file '%s' (from the scene's volume.source '%s') does not exist",
                         path, src);
    fclose(f);
    io_volume_options vo = io_volume_options_default();
    return io_volume_load(j->ctx, path, &vo, g);
}

static obs_status load_tf(render_job *j, vol_tf *tf)
{
    const char *t = j->st->volume.transfer;
    if (!is_json(t))
        return vol_tf_preset(j->ctx, t, tf);
    char path[1200], *text = NULL;
    size_t len;
    resolve_path(j, t, path, sizeof path);
    obs_status st = io_read_file(j->ctx, path, (size_t)1 << 20, &text, &len);
    if (st == OBS_STATUS_OK)
        st = vol_tf_parse_json(j->ctx, text, path, tf);
    free(text);
    return st;
}

/* has_box: the grid's bounds [lo, hi] (voxel hull + half a voxel) mapped onto [box_lo, box_hi]. */
static void map_box(const render_volume_settings *v, vol_grid *g)
{
    double lo[3], hi[3];
    vol_grid_bounds(g, lo, hi);
    for (int a = 0; a < 3; a++) {
        const double s = (v->box_hi[a] - v->box_lo[a]) / (hi[a] - lo[a]);
        g->spacing[a] *= s;
        g->origin[a] = v->box_lo[a] + 0.5 * g->spacing[a];
    }
}

static obs_status load_build(render_job *j, void *p)
{
    render_volume_data *v = (render_volume_data *)p;
    obs_status st = load_grid(j, &v->grid);
    if (st == OBS_STATUS_OK)
        st = load_tf(j, &v->tf);
    if (st == OBS_STATUS_OK && j->st->volume.has_box)
        map_box(&j->st->volume, &v->grid);
    return st;
}
static obs_status load_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    return render_cached(j, RES_VOLUME_GRID, &render_ops_volume, load_build, (void **)&j->vol, state, bytes);
}
const render_pass render_pass_volume_load = {"volume_load", RES_VOLUME_GRID, 0, 0, load_reads, load_wanted, load_key,
                                             load_run};

/* ---- light_volume ------------------------------------------------------------------------- */

static int lv_needed(const render_job *j) { return j->st->volume.rc.shading == VOL_SHADING_LIGHT_VOLUME; }

static unsigned lv_reads(const render_job *j, char *t, size_t n)
{
    if (j->st->volume.mesh_shadows) { /* the meshes outside the box shadow it through the shadow maps */
        snprintf(t, n, "volume_grid,transfer_function,light,volume.lv,geometry,shadow_maps");
        return RES_VOLUME_GRID | RES_SHADOW_MAPS;
    }
    snprintf(t, n, "volume_grid,transfer_function,light,volume.lv");
    return RES_VOLUME_GRID;
}

/* The render light (j->lights) that lights the volume, -1 when none. */
static int lv_render_light(const render_job *j)
{
    if (j->volume_light < 0)
        return -1;
    for (int i = 0; i < j->light_count; i++)
        if (j->lights[i].node == j->scene->lights[j->volume_light].node)
            return i;
    return -1;
}

/* Meshes outside the volume's box shadow it (ours, docs/render.md "Meshes shadow the volume"):
 * the light entering the box at x is seen through the light's shadow map (render_shadow_lookup:
 * 3x3 PCF, one texel of bias, no normal offset: x is on the box, not on a surface). */
typedef struct lv_entry_ctx { const render_shadow_map *sm; const obs_light *L; } lv_entry_ctx;
static float lv_entry(void *user, const double x[3])
{
    const lv_entry_ctx *e = (const lv_entry_ctx *)user;
    return render_shadow_lookup(e->sm, e->L, obs_v3((float)x[0], (float)x[1], (float)x[2]), obs_v3(0, 0, 0));
}
/* 1 when the volume's light has a shadow map this frame (shadow_maps live: its key is valid). */
static int lv_has_entry(const render_job *j)
{
    return j->st->volume.mesh_shadows && j->key_valid[1] /* RES_SHADOW_MAPS */ && lv_render_light(j) >= 0;
}
static int lv_wanted(const render_job *j, char *r, size_t n)
{
    if (!render_job_has_volume(j)) {
        snprintf(r, n, "no volume in the scene");
        return 0;
    }
    if (!lv_needed(j)) {
        snprintf(r, n, "the ray cast's shading (%s) reads no light volume", vol_shading_name(j->st->volume.rc.shading));
        return 0;
    }
    if (j->volume_light < 0) {
        snprintf(r, n, "no directional or point light for the volume (unlit: emission-absorption)");
        return 0;
    }
    snprintf(r, n, "light '%s' through the volume (scale %d, cone %g deg)%s", j->scene->lights[j->volume_light].name,
             j->st->volume.lv.scale, j->st->volume.lv.cone_angle_deg,
             j->st->volume.mesh_shadows ? ", with mesh_shadows (the meshes in its box shadow it)" : "");
    return 1;
}

/* The scene light as the volume module sees it (vol.h: colour x intensity; the ray caster has no
 * distance falloff, so a point light's colour is divided by its squared distance to the volume's
 * centre: ours, docs/render.md). */
void render_volume_light(render_job *j)
{
    memset(&j->vlight, 0, sizeof j->vlight);
    if (j->volume_light < 0 || !j->vol)
        return;
    const obs_light *L = &j->scene->lights[j->volume_light];
    float s = L->intensity;
    j->vlight.type = L->type;
    if (L->type == OBS_LIGHT_DIRECTIONAL) {
        obs_vec3 d = obs_v3_normalize(L->direction);
        j->vlight.direction[0] = d.x, j->vlight.direction[1] = d.y, j->vlight.direction[2] = d.z;
    } else {
        double lo[3], hi[3], d2 = 0;
        vol_grid_bounds(&j->vol->grid, lo, hi);
        const double p[3] = {L->position.x, L->position.y, L->position.z};
        for (int a = 0; a < 3; a++) {
            j->vlight.position[a] = p[a];
            d2 += (0.5 * (lo[a] + hi[a]) - p[a]) * (0.5 * (lo[a] + hi[a]) - p[a]);
        }
        if (d2 > 0)
            s = (float)(s / d2);
    }
    j->vlight.color[0] = L->color.x * s, j->vlight.color[1] = L->color.y * s, j->vlight.color[2] = L->color.z * s;
}

/* Meshes shadow the volume (ours: docs/render.md "Meshes shadow the volume"): every instance,
 * opaque or translucent (a translucent mesh's medium is optically thick: it blocks the volume's
 * light as an opaque one does), whose world bounds meet the volume's bounds; the others cannot
 * cover a voxel (each instance's parity is its own: vol_occupancy_voxelize). A mask over the
 * instances (NULL when none is selected); *count the number selected. */
static unsigned char *lv_mesh_select(const render_job *j, int *count)
{
    *count = 0;
    if (!j->st->volume.mesh_shadows || !j->vol || j->scene->instance_count == 0)
        return NULL;
    double lo[3], hi[3];
    vol_grid_bounds(&j->vol->grid, lo, hi);
    unsigned char *sel = (unsigned char *)calloc(j->scene->instance_count, 1);
    if (!sel)
        return NULL;
    for (uint32_t i = 0; i < j->scene->instance_count; i++) {
        const obs_instance *in = &j->scene->instances[i];
        if (in->mesh >= j->scene->mesh_count)
            continue;
        const obs_mesh *m = &j->scene->meshes[in->mesh];
        double blo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, bhi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
        for (uint32_t v = 0; v < m->vertex_count; v++) {
            const obs_vec3 w =
                obs_mat4_mul_point(in->world, obs_v3(m->positions[3 * v], m->positions[3 * v + 1], m->positions[3 * v + 2]));
            const double x[3] = {w.x, w.y, w.z};
            for (int a = 0; a < 3; a++) {
                blo[a] = x[a] < blo[a] ? x[a] : blo[a];
                bhi[a] = x[a] > bhi[a] ? x[a] : bhi[a];
            }
        }
        int meet = m->triangle_count > 0;
        for (int a = 0; a < 3; a++)
            meet &= blo[a] <= hi[a] && bhi[a] >= lo[a];
        sel[i] = (unsigned char)meet;
        *count += meet;
    }
    if (*count == 0) {
        free(sel);
        return NULL;
    }
    return sel;
}

/* The grid's content, the transfer function, the light and the params. Needs the grid loaded:
 * 0 (key unknown) before volume_load ran. */
static int lv_key(render_job *j, render_key *out)
{
    if (!j->vol)
        return 0;
    render_volume_light(j);
    const vol_grid *g = &j->vol->grid;
    const vol_tf *tf = &j->vol->tf;
    const vol_lv_params *p = &j->st->volume.lv;
    render_hash h;
    render_hash_init(&h, "light_volume");
    render_hash_i(&h, g->nx), render_hash_i(&h, g->ny), render_hash_i(&h, g->nz);
    for (int a = 0; a < 3; a++)
        render_hash_d(&h, g->spacing[a]), render_hash_d(&h, g->origin[a]);
    render_hash_bytes(&h, g->data, sizeof(float) * (size_t)g->nx * (size_t)g->ny * (size_t)g->nz);
    render_hash_i(&h, tf->count);
    render_hash_d(&h, tf->ref_step);
    for (int i = 0; i < tf->count; i++) {
        render_hash_d(&h, tf->points[i].value);
        for (int c = 0; c < 4; c++)
            render_hash_d(&h, tf->points[i].rgba[c]);
    }
    const vol_light *L = &j->vlight;
    render_hash_i(&h, L->type);
    for (int a = 0; a < 3; a++) {
        render_hash_d(&h, L->direction[a]);
        render_hash_d(&h, L->position[a]);
        render_hash_d(&h, L->color[a]);
    }
    render_hash_i(&h, p->scale);
    render_hash_d(&h, p->cone_angle_deg);
    render_hash_i(&h, p->blend_second);
    render_hash_d(&h, p->kappa);
    /* the meshes it voxelizes: their geometry and transforms (render_hash_geometry's fields) */
    render_hash_i(&h, j->st->volume.mesh_shadows);
    if (j->st->volume.mesh_shadows) {
        render_hash_str(&h, "occupancy parity v1");
        render_hash_i(&h, VOL_OCC_DEFAULT_SUBCOLUMNS);
        int count;
        unsigned char *sel = lv_mesh_select(j, &count);
        render_hash_i(&h, count);
        for (uint32_t i = 0; sel && i < j->scene->instance_count; i++) {
            if (!sel[i])
                continue;
            const obs_instance *in = &j->scene->instances[i];
            const obs_mesh *m = &j->scene->meshes[in->mesh];
            render_hash_u64(&h, i);
            render_hash_bytes(&h, in->world.m, sizeof in->world.m);
            render_hash_u64(&h, m->vertex_count);
            render_hash_u64(&h, m->triangle_count);
            render_hash_bytes(&h, m->positions, sizeof(float) * 3 * (size_t)m->vertex_count);
            render_hash_bytes(&h, m->indices, sizeof(uint32_t) * 3 * (size_t)m->triangle_count);
        }
        free(sel);
        /* and the meshes outside it, through the volume light's shadow map */
        render_hash_i(&h, lv_has_entry(j));
        if (lv_has_entry(j)) {
            render_hash_str(&h, "entry through the shadow map v1");
            render_hash_u64(&h, j->key[1].k[0]);
            render_hash_u64(&h, j->key[1].k[1]);
            render_hash_i(&h, lv_render_light(j));
        }
    }
    *out = render_hash_final(&h);
    return 1;
}

static void lv_free(void *p)
{
    render_light_volumes *w = (render_light_volumes *)p;
    vol_light_volume_free(&w->own);
    vol_light_volume_free(&w->mesh);
}
static uint64_t lv_bytes(const void *p)
{
    const render_light_volumes *w = (const render_light_volumes *)p;
    uint64_t b = 16u * (uint64_t)w->own.nx * (uint64_t)w->own.ny * (uint64_t)w->own.nz;
    if (w->mesh.l)
        b += 16u * (uint64_t)w->mesh.nx * (uint64_t)w->mesh.ny * (uint64_t)w->mesh.nz;
    return b;
}
typedef struct lv_head {
    int32_t nx, ny, nz, scale, face0, face1;
    float blend_weight, pad;
    double spacing[3], origin[3];
} lv_head;
static int lv_save_one(const vol_light_volume *lv, render_blobs *out)
{
    lv_head hd;
    memset(&hd, 0, sizeof hd);
    hd.nx = lv->nx, hd.ny = lv->ny, hd.nz = lv->nz, hd.scale = lv->scale, hd.face0 = lv->face0, hd.face1 = lv->face1;
    hd.blend_weight = lv->blend_weight;
    memcpy(hd.spacing, lv->spacing, sizeof hd.spacing);
    memcpy(hd.origin, lv->origin, sizeof hd.origin);
    const uint64_t nv = (uint64_t)lv->nx * (uint64_t)lv->ny * (uint64_t)lv->nz;
    int ok = render_blobs_add_copy(out, &hd, sizeof hd) && render_blobs_add_copy(out, lv->l, 4 * nv);
    for (int c = 0; ok && c < 3; c++)
        ok = render_blobs_add_copy(out, lv->c[c], 4 * nv);
    return ok;
}
/* own, then an int32 (1: the meshes' one follows), then the meshes' one */
static obs_status lv_save(obs_context *ctx, const void *p, render_blobs *out)
{
    const render_light_volumes *w = (const render_light_volumes *)p;
    const int32_t has = w->mesh.l != NULL;
    int ok = lv_save_one(&w->own, out) && render_blobs_add_copy(out, &has, sizeof has) && (!has || lv_save_one(&w->mesh, out));
    return ok ? OBS_STATUS_OK : obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "render cache: out of memory");
}
static obs_status lv_load_one(render_reader *r, vol_light_volume *lv)
{
    const lv_head *hd = (const lv_head *)render_reader_take(r, sizeof(lv_head));
    if (!hd || hd->nx < 1 || hd->ny < 1 || hd->nz < 1)
        return OBS_STATUS_PARSE_ERROR;
    const uint64_t nv = (uint64_t)hd->nx * (uint64_t)hd->ny * (uint64_t)hd->nz;
    float *mem = (float *)obs_aligned_alloc((size_t)(16 * nv)); /* one block, as vol_light_volume_build */
    if (!mem)
        return OBS_STATUS_OUT_OF_MEMORY;
    lv->l = mem;
    for (int c = 0; c < 3; c++)
        lv->c[c] = mem + (size_t)(c + 1) * (size_t)nv;
    lv->nx = hd->nx, lv->ny = hd->ny, lv->nz = hd->nz, lv->scale = hd->scale;
    lv->face0 = hd->face0, lv->face1 = hd->face1, lv->blend_weight = hd->blend_weight;
    memcpy(lv->spacing, hd->spacing, sizeof lv->spacing);
    memcpy(lv->origin, hd->origin, sizeof lv->origin);
    for (int c = 0; c < 4; c++) {
        const void *src = render_reader_take(r, 4 * nv);
        if (!src)
            return OBS_STATUS_PARSE_ERROR;
        memcpy(c == 0 ? lv->l : lv->c[c - 1], src, (size_t)(4 * nv));
    }
    return OBS_STATUS_OK;
}
static obs_status lv_load(obs_context *ctx, render_reader *r, void *p)
{
    (void)ctx;
    render_light_volumes *w = (render_light_volumes *)p;
    obs_status st = lv_load_one(r, &w->own);
    if (st != OBS_STATUS_OK)
        return st;
    const int32_t *has = (const int32_t *)render_reader_take(r, sizeof(int32_t));
    if (!has || (*has != 0 && *has != 1))
        return OBS_STATUS_PARSE_ERROR;
    return *has ? lv_load_one(r, &w->mesh) : OBS_STATUS_OK;
}
const render_product_ops render_ops_light_volume = {"light_volume", lv_free, lv_save, lv_load,
                                                    sizeof(render_light_volumes), lv_bytes};

/* The volume's own light volume, and, when meshes meet the volume's box (volume.mesh_shadows), the
 * one the meshes shadow: their occupancy (vol_occupancy_voxelize, the light volume's layout) as
 * extra extinction (vol_light_volume_build_ex; ref_step 0: a voxel of occupancy f transmits about
 * 1 - f). The meshes sample the own one (direct: mesh-to-mesh shadows are the shadow maps'; a
 * surface inside the box must not shadow itself); the ray cast samples the meshes' one. */
static obs_status lv_build(render_job *j, void *p)
{
    render_light_volumes *w = (render_light_volumes *)p;
    render_volume_light(j);
    vol_lv_params lp = j->st->volume.lv;
    lp.eye_pass = 0; /* the light's product: the eye pass runs per view, in the raycast pass */
    obs_status st = vol_light_volume_build(j->ctx, j->pool, &j->vol->grid, &j->vol->tf, &j->vlight, &lp, &w->own);
    int count = 0;
    unsigned char *sel = st == OBS_STATUS_OK ? lv_mesh_select(j, &count) : NULL;
    lv_entry_ctx ec = {NULL, NULL};
    if (st == OBS_STATUS_OK && lv_has_entry(j) && j->shadow) {
        const int li = lv_render_light(j);
        if (li < j->shadow->count) {
            ec.sm = &j->shadow->maps[li];
            ec.L = &j->lights[li];
        }
    }
    vol_occluder oc;
    memset(&oc, 0, sizeof oc);
    oc.ref_step = 0.0;
    if (ec.sm) {
        oc.entry = lv_entry;
        oc.entry_user = &ec;
    }
    if (!sel) {
        if (st == OBS_STATUS_OK && oc.entry) /* the meshes outside the box alone */
            st = vol_light_volume_build_ex(j->ctx, j->pool, &j->vol->grid, &j->vol->tf, &j->vlight, &lp, &oc,
                                           &w->mesh);
        return st;
    }
    vol_occ_mesh *meshes = (vol_occ_mesh *)malloc(sizeof(vol_occ_mesh) * (size_t)count);
    vol_occupancy occ;
    memset(&occ, 0, sizeof occ);
    if (!meshes) {
        free(sel);
        return obs_error(j->ctx, OBS_STATUS_OUT_OF_MEMORY, "light_volume: out of memory");
    }
    int k = 0;
    for (uint32_t i = 0; i < j->scene->instance_count; i++)
        if (sel[i]) {
            meshes[k].mesh = &j->scene->meshes[j->scene->instances[i].mesh];
            meshes[k].world = j->scene->instances[i].world;
            k++;
        }
    const double t0 = obs_time_now();
    st = vol_occupancy_alloc(j->ctx, &j->vol->grid, lp.scale, &occ);
    if (st == OBS_STATUS_OK)
        st = vol_occupancy_voxelize(j->ctx, j->pool, meshes, count, VOL_OCC_DEFAULT_SUBCOLUMNS, &occ);
    w->voxelize_ms = 1e3 * (obs_time_now() - t0);
    w->mesh_instances = count;
    int any = 0;
    const size_t nv = (size_t)occ.nx * (size_t)occ.ny * (size_t)occ.nz;
    for (size_t i = 0; st == OBS_STATUS_OK && i < nv && !any; i++)
        any = occ.f[i] > 0.0f;
    if (st == OBS_STATUS_OK && (any || oc.entry)) { /* neither: the own one serves the ray cast too */
        oc.occupancy = any ? &occ : NULL;
        st = vol_light_volume_build_ex(j->ctx, j->pool, &j->vol->grid, &j->vol->tf, &j->vlight, &lp, &oc, &w->mesh);
    }
    vol_occupancy_free(&occ);
    free(meshes);
    free(sel);
    return st;
}
static obs_status lv_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    void *p = NULL;
    obs_status st = render_cached(j, RES_LIGHT_VOLUME, &render_ops_light_volume, lv_build, &p, state, bytes);
    if (st != OBS_STATUS_OK)
        return st;
    render_light_volumes *w = (render_light_volumes *)p;
    j->lv = &w->own;
    j->lv_rc = w->mesh.l ? &w->mesh : &w->own;
    return OBS_STATUS_OK;
}
const render_pass render_pass_light_volume = {"light_volume", RES_LIGHT_VOLUME, 0, 0, lv_reads, lv_wanted, lv_key,
                                              lv_run};

/* ---- raycast ------------------------------------------------------------------------------- */

static unsigned rc_reads(const render_job *j, char *t, size_t n)
{
    if (lv_needed(j) && j->volume_light >= 0) {
        snprintf(t, n, "volume_grid,light_volume,gbuffer,camera");
        return RES_VOLUME_GRID | RES_LIGHT_VOLUME | RES_GBUFFER;
    }
    snprintf(t, n, "volume_grid,gbuffer,camera");
    return RES_VOLUME_GRID | RES_GBUFFER;
}
static int rc_wanted(const render_job *j, char *r, size_t n)
{
    if (!render_job_has_volume(j)) {
        snprintf(r, n, "no volume in the scene");
        return 0;
    }
    const int eye = j->st->volume.lv.eye_pass && j->st->volume.rc.shading == VOL_SHADING_LIGHT_VOLUME &&
                    j->volume_light >= 0;
    snprintf(r, n, "ray cast (%s%s), stopped at the meshes' depth",
             lv_needed(j) && j->volume_light < 0 ? "ea: no light" : vol_shading_name(j->st->volume.rc.shading),
             eye ? ", with the eye pass" : "");
    return 1;
}

/* The ray caster's parameters for this job: light-volume shading falls back to emission-absorption
 * when no light lights the volume. */
vol_rc_params render_volume_rc_params(const render_job *j)
{
    vol_rc_params rp = j->st->volume.rc;
    if (rp.shading == VOL_SHADING_LIGHT_VOLUME && j->volume_light < 0)
        rp.shading = VOL_SHADING_EMISSION_ABSORPTION;
    return rp;
}

/* The eye pass (vol.h vol_eye_volume_build, a reconstruction: docs/volume/light.md "Eye pass"):
 * it depends on the camera, so it runs here, in the view pass, on a copy of the cached light volume
 * (the cached product stays the light's alone). */
static obs_status rc_eye_modulated(render_job *j, vol_light_volume *out)
{
    const vol_light_volume *lv = j->lv_rc;
    const size_t nv = (size_t)lv->nx * (size_t)lv->ny * (size_t)lv->nz;
    vol_light_volume eye;
    memset(&eye, 0, sizeof eye);
    memset(out, 0, sizeof *out);
    obs_status st = vol_eye_volume_build(j->ctx, j->pool, &j->vol->grid, &j->vol->tf, &j->cam, &j->st->volume.lv, &eye);
    if (st != OBS_STATUS_OK)
        return st;
    *out = *lv;
    float *mem = (float *)obs_aligned_alloc(16 * nv); /* one block: l, then c[0..2], as vol_light_volume_build */
    if (!mem) {
        vol_light_volume_free(&eye);
        memset(out, 0, sizeof *out);
        return obs_error(j->ctx, OBS_STATUS_OUT_OF_MEMORY, "raycast: cannot copy the light volume for the eye pass");
    }
    out->l = mem;
    memcpy(out->l, lv->l, 4 * nv);
    for (int c = 0; c < 3; c++) {
        out->c[c] = mem + (size_t)(c + 1) * nv;
        memcpy(out->c[c], lv->c[c], 4 * nv);
    }
    st = vol_light_volume_modulate(j->ctx, &eye, out);
    vol_light_volume_free(&eye);
    return st;
}

static obs_status rc_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    render_volume_light(j);
    vol_rc_params rp = render_volume_rc_params(j);
    const vol_light_volume *lv = j->lv_rc; /* with the meshes' shadows (lv_build) */
    vol_light_volume modulated;
    memset(&modulated, 0, sizeof modulated);
    const int eye = rp.shading == VOL_SHADING_LIGHT_VOLUME && j->lv_rc && j->st->volume.lv.eye_pass;
    obs_status st = OBS_STATUS_OK;
    if (eye) {
        st = rc_eye_modulated(j, &modulated);
        lv = &modulated;
    }
    render_volume_data *v = j->vol;
    if (st == OBS_STATUS_OK && (!v->rc || v->rc_brick != rp.brick)) { /* once per volume (and brick) */
        vol_rc_prepared_free(v->rc);
        v->rc = NULL;
        st = vol_rc_prepare(j->ctx, j->pool, &v->grid, &v->tf, &rp, &v->rc);
        v->rc_brick = rp.brick;
    }
    if (st == OBS_STATUS_OK)
        st = vol_raycast_prepared(j->ctx, j->pool, v->rc, &j->vlight, lv, &j->cam, j->W, j->H, &j->gb.depth, &rp,
                                  j->f->volume);
    if (eye)
        vol_light_volume_free(&modulated);
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(4, j->f->volume);
    return st;
}
const render_pass render_pass_raycast = {"raycast", RES_VOLUME, 1, 0, rc_reads, rc_wanted, NULL, rc_run};
