/* render_passes_surface.c: the camera G-buffer, the shadow maps, direct light, AO, ambient and the
 * composition (docs/render.md, "Passes").
 *
 * Units (docs/render.md, "Light units"): radiance in the lights' units, as the SSS module's
 * (sss.h): a directional light gives irradiance E = colour x intensity (lux), a point light
 * E = colour x intensity / d^2 (candela; glTF KHR_lights_punctual; range ignored). Opaque meshes
 * are Lambertian with albedo = the material's base colour (glTF's default 1 without a material):
 *   direct  L = albedo / pi x E x max(0, n.l) x shadow        (the Lambert BRDF albedo/pi)
 *   ambient L = ambient x albedo x AO                         (uniform ambient radiance: the
 *                                                              pi of the cosine integral cancels)
 * Translucent meshes get neither term: their light is the SSS radiance (sss_combine), which is
 * already the whole exitant radiance of the scattering-map model. */
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------------
 * Predicates shared with the graph
 * ---------------------------------------------------------------------------------------------- */

static unsigned reads_text(char *text, size_t size, const char *s, unsigned mask)
{
    snprintf(text, size, "%s", s);
    return mask;
}

/* ------------------------------------------------------------------------------------------------
 * gbuffer
 * ---------------------------------------------------------------------------------------------- */

static unsigned gbuffer_reads(const render_job *j, char *t, size_t n)
{
    (void)j;
    return reads_text(t, n, "geometry,materials,camera", 0);
}
static int gbuffer_wanted(const render_job *j, char *r, size_t n)
{
    (void)j;
    snprintf(r, n, "every layer starts from the camera's depth, normals, ids and base colour");
    return 1;
}

typedef struct flip_job {
    render_job *j;
} flip_job;

/* Face the normals toward the viewer, as the rasterizer's face_forward does (raster.h), and fill
 * the albedo and the opaque / translucent masks. One row per task. */
static void gbuffer_row(void *user, int64_t y, int thread)
{
    (void)thread;
    render_job *j = ((flip_job *)user)->j;
    const rast_gbuffer *gb = &j->gb;
    const rast_view_constants *vc = &gb->constants;
    const obs_scene *scene = j->scene;
    const float *depth = obs_image_f32_row(&gb->depth, (int)y);
    const uint32_t *mat = obs_image_u32_row(&gb->material_id, (int)y);
    for (int x = 0; x < gb->width; x++) {
        float n[3], fn[3], alb[3] = {0, 0, 0}, op = 0, tr = 0;
        for (int c = 0; c < 3; c++) {
            n[c] = obs_image_f32_row(&gb->normal[c], (int)y)[x];
            fn[c] = obs_image_f32_row(&gb->face_normal[c], (int)y)[x];
        }
        if (isfinite(depth[x]) && depth[x] > 0) {
            double dx = 0, dy = 0, dz = -1;
            if (vc->projection_type == OBS_PROJECTION_PERSPECTIVE) {
                dx = ((double)x + 0.5 - vc->cx) / vc->fx;
                dy = -((double)y + 0.5 - vc->cy) / vc->fy;
            }
            if (dx * fn[0] + dy * fn[1] + dz * fn[2] > 0)
                for (int c = 0; c < 3; c++) {
                    n[c] = -n[c];
                    fn[c] = -fn[c];
                }
            const uint32_t m = mat[x];
            const int translucent = m != RAST_ID_NONE && m < j->sss.mats.count && j->sss.mats.translucent[m];
            if (m != RAST_ID_NONE && m < scene->material_count)
                for (int c = 0; c < 3; c++)
                    alb[c] = scene->materials[m].base_color[c];
            else
                alb[0] = alb[1] = alb[2] = 1.0f; /* glTF's default base colour */
            tr = translucent ? 1.0f : 0.0f;
            op = 1.0f - tr;
        }
        for (int c = 0; c < 3; c++) {
            obs_image_f32_row(&j->nff[c], (int)y)[x] = n[c];
            obs_image_f32_row(&j->fnff[c], (int)y)[x] = fn[c];
            obs_image_f32_row(&j->f->albedo[c], (int)y)[x] = alb[c];
        }
        obs_image_f32_row(&j->mask_opaque, (int)y)[x] = op;
        obs_image_f32_row(&j->mask_translucent, (int)y)[x] = tr;
    }
}

static obs_status gbuffer_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    rast_params rp = rast_params_default();
    rp.width = j->W;
    rp.height = j->H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_FACE_NORMAL | RAST_OUT_PRIM_ID |
                 RAST_OUT_INSTANCE_ID | RAST_OUT_MATERIAL_ID;
    rp.face_forward = 0; /* sss_combine and truth_sss want the outward normals; faced below */
    obs_status st = rast_gbuffer_alloc(j->ctx, &rp, &j->gb);
    rast_view view = {j->cam};
    if (st == OBS_STATUS_OK)
        st = rast_render(j->ctx, j->pool, j->scene, &view, 1, &rp, &j->gb, NULL);
    if (st == OBS_STATUS_OK) st = render_planes_alloc(j->ctx, 3, j->W, j->H, j->nff);
    if (st == OBS_STATUS_OK) st = render_planes_alloc(j->ctx, 3, j->W, j->H, j->fnff);
    if (st == OBS_STATUS_OK) st = render_planes_alloc(j->ctx, 3, j->W, j->H, j->f->albedo);
    if (st == OBS_STATUS_OK) st = render_planes_alloc(j->ctx, 1, j->W, j->H, &j->mask_opaque);
    if (st == OBS_STATUS_OK) st = render_planes_alloc(j->ctx, 1, j->W, j->H, &j->mask_translucent);
    if (st == OBS_STATUS_OK) st = render_planes_alloc(j->ctx, 1, j->W, j->H, &j->f->depth);
    if (st == OBS_STATUS_OK) st = render_planes_alloc(j->ctx, 3, j->W, j->H, j->f->normal);
    if (st != OBS_STATUS_OK)
        return st;
    flip_job fj = {j};
    obs_pool_run(j->pool, j->H, gbuffer_row, &fj);
    j->gb_ff = j->gb;
    for (int c = 0; c < 3; c++) {
        j->gb_ff.normal[c] = j->nff[c];
        j->gb_ff.face_normal[c] = j->fnff[c];
    }
    for (int y = 0; y < j->H; y++) {
        memcpy(obs_image_f32_row(&j->f->depth, y), obs_image_f32_row(&j->gb.depth, y), sizeof(float) * (size_t)j->W);
        for (int c = 0; c < 3; c++)
            memcpy(obs_image_f32_row(&j->f->normal[c], y), obs_image_f32_row(&j->nff[c], y),
                   sizeof(float) * (size_t)j->W);
    }
    *state = RENDER_PASS_RAN;
    *bytes = (uint64_t)j->W * (uint64_t)j->H * 4u * 20u;
    return OBS_STATUS_OK;
}

const render_pass render_pass_gbuffer = {"gbuffer", RES_GBUFFER, 1, 0, gbuffer_reads, gbuffer_wanted, NULL, gbuffer_run};

/* ------------------------------------------------------------------------------------------------
 * shadow_maps: one depth map per light ([Williams78] shadow mapping). A directional light: one orthographic map framing the
 * scene's bounding sphere along the light. A point light: a cube of six 90-degree perspective
 * maps at the light (it may be inside the scene, as in a Cornell box).
 * ---------------------------------------------------------------------------------------------- */

static int has_direct(const render_job *j) { return j->any_opaque && j->light_count > 0; }

static unsigned shadow_reads(const render_job *j, char *t, size_t n)
{
    (void)j;
    return reads_text(t, n, "geometry,lights", 0);
}
static int shadow_wanted(const render_job *j, char *r, size_t n)
{
    if (!has_direct(j)) {
        snprintf(r, n, "%s", j->light_count == 0 ? "no directional or point light in the scene"
                                                 : "no opaque mesh in the scene");
        return 0;
    }
    if (!j->st->shadows) {
        snprintf(r, n, "shadows off");
        return 0;
    }
    snprintf(r, n, "%d light(s) shadow the direct light (%d^2 per map)", j->light_count, j->st->shadow_map_size);
    return 1;
}
static int shadow_key(render_job *j, render_key *out)
{
    render_hash h;
    render_hash_init(&h, "shadow_maps");
    render_hash_geometry(&h, j->scene);
    render_hash_lights(&h, j);
    render_hash_i(&h, j->st->shadow_map_size);
    *out = render_hash_final(&h);
    return 1;
}

static void shadow_maps_free(void *p)
{
    render_shadow_maps *s = (render_shadow_maps *)p;
    for (int i = 0; s->maps && i < s->count; i++)
        render_planes_free(6, s->maps[i].depth);
    free(s->maps);
    memset(s, 0, sizeof *s);
}
static uint64_t shadow_maps_bytes(const void *p)
{
    const render_shadow_maps *s = (const render_shadow_maps *)p;
    uint64_t b = 0;
    for (int i = 0; i < s->count; i++)
        b += render_planes_bytes(6, s->maps[i].depth);
    return b;
}
const render_product_ops render_ops_shadow_maps = {"shadow_maps", shadow_maps_free, NULL, NULL,
                                                    sizeof(render_shadow_maps), shadow_maps_bytes};

static void scene_sphere(const obs_scene *s, obs_vec3 *c, float *r)
{
    *c = obs_v3_scale(obs_v3_add(s->bounds.lo, s->bounds.hi), 0.5f);
    *r = 0.5f * obs_v3_length(obs_v3_sub(s->bounds.hi, s->bounds.lo));
    if (!(*r > 0))
        *r = 1.0f;
}

static obs_status shadow_map_build(render_job *j, const obs_light *L, render_shadow_map *sm)
{
    const int size = j->st->shadow_map_size;
    obs_vec3 c;
    float R;
    scene_sphere(j->scene, &c, &R);
    rast_params rp = rast_params_default();
    rp.width = rp.height = size;
    rp.outputs = RAST_OUT_DEPTH;
    rast_view views[6];
    if (L->type == OBS_LIGHT_DIRECTIONAL) {
        obs_vec3 d = obs_v3_normalize(L->direction);
        obs_vec3 up = fabsf(d.y) > 0.9f ? obs_v3(0, 0, 1) : obs_v3(0, 1, 0);
        obs_camera cam = obs_camera_look_at(obs_v3_sub(c, obs_v3_scale(d, 2.0f * R)), c, up, 1.0f, 0.5f * R, 3.5f * R);
        cam.projection = OBS_PROJECTION_ORTHOGRAPHIC;
        cam.xmag = cam.ymag = 1.02f * R;
        cam.aspect = 1.0f;
        sm->faces = 1;
        views[0].camera = cam;
    } else {
        static const float dirs[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        static const float ups[6][3] = {{0, 1, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}};
        const float zn = fmaxf(1e-4f * R, 1e-6f);
        sm->faces = 6;
        for (int f = 0; f < 6; f++) {
            obs_vec3 t = obs_v3_add(L->position, obs_v3(dirs[f][0], dirs[f][1], dirs[f][2]));
            obs_camera cam = obs_camera_look_at(L->position, t, obs_v3(ups[f][0], ups[f][1], ups[f][2]),
                                                (float)(0.5 * OBS_PI), zn, INFINITY);
            cam.aspect = 1.0f;
            views[f].camera = cam;
        }
    }
    rast_gbuffer gbs[6];
    memset(gbs, 0, sizeof gbs);
    obs_status st = OBS_STATUS_OK;
    for (int f = 0; f < sm->faces && st == OBS_STATUS_OK; f++)
        st = rast_gbuffer_alloc(j->ctx, &rp, &gbs[f]);
    if (st == OBS_STATUS_OK)
        st = rast_render(j->ctx, j->pool, j->scene, views, sm->faces, &rp, gbs, NULL);
    for (int f = 0; f < sm->faces; f++) {
        if (st == OBS_STATUS_OK) {
            sm->cam[f] = views[f].camera;
            sm->vc[f] = gbs[f].constants;
            sm->depth[f] = gbs[f].depth;
            gbs[f].depth.data = NULL;
        }
        rast_gbuffer_free(&gbs[f]);
    }
    sm->texel_world = 1.0 / sm->vc[0].fx;
    return st;
}

static obs_status shadow_build(render_job *j, void *p)
{
    render_shadow_maps *s = (render_shadow_maps *)p;
    s->maps = (render_shadow_map *)calloc((size_t)j->light_count, sizeof *s->maps);
    if (!s->maps)
        return obs_error(j->ctx, OBS_STATUS_OUT_OF_MEMORY, "render: out of memory for the shadow maps");
    s->count = j->light_count;
    obs_status st = OBS_STATUS_OK;
    for (int i = 0; i < j->light_count && st == OBS_STATUS_OK; i++)
        st = shadow_map_build(j, &j->lights[i], &s->maps[i]);
    return st;
}

static obs_status shadow_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    return render_cached(j, RES_SHADOW_MAPS, &render_ops_shadow_maps, shadow_build, (void **)&j->shadow, state, bytes);
}

const render_pass render_pass_shadow_maps = {"shadow_maps", RES_SHADOW_MAPS, 0, 0, shadow_reads, shadow_wanted,
                                             shadow_key, shadow_run};

/* The fraction of a 3x3 texel neighbourhood that sees world point p (percentage-closer filtering
 * [Reeves87]). Acne is kept off by a normal offset [Holbert11]: p is moved 1.5 texels (the texel's
 * world size at p) along its normal n before the lookup, and the comparison has a bias of one
 * texel (our constants, tuned on the Cornell box). */
float render_shadow_lookup(const render_shadow_map *sm, const obs_light *L, obs_vec3 p, obs_vec3 n)
{
    int f = 0;
    if (sm->faces == 6) {
        obs_vec3 v = obs_v3_sub(p, L->position);
        float ax = fabsf(v.x), ay = fabsf(v.y), az = fabsf(v.z);
        if (ax >= ay && ax >= az) f = v.x >= 0 ? 0 : 1;
        else if (ay >= az) f = v.y >= 0 ? 2 : 3;
        else f = v.z >= 0 ? 4 : 5;
    }
    const rast_view_constants *vc = &sm->vc[f];
    obs_vec3 q = obs_mat4_mul_point(sm->cam[f].view, p);
    double d = -(double)q.z;
    if (!(d > 0))
        return 1.0f;
    const double texel = sm->faces == 6 ? d / vc->fx : 1.0 / vc->fx;
    q = obs_mat4_mul_point(sm->cam[f].view, obs_v3_add(p, obs_v3_scale(n, (float)(1.5 * texel))));
    d = -(double)q.z;
    if (!(d > 0))
        return 1.0f;
    double px, py;
    if (sm->faces == 6) {
        px = vc->cx + vc->fx * q.x / d;
        py = vc->cy - vc->fy * q.y / d;
    } else {
        px = vc->cx + vc->fx * q.x;
        py = vc->cy - vc->fy * q.y;
    }
    const double bias = texel;
    const int ix = (int)floor(px), iy = (int)floor(py);
    const obs_image_f32 *m = &sm->depth[f];
    int lit = 0;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            int x = ix + dx, y = iy + dy;
            if (x < 0 || y < 0 || x >= m->width || y >= m->height) {
                lit++;
                continue;
            }
            float z = obs_image_f32_row(m, y)[x];
            if (!(d - bias > (double)z))
                lit++;
        }
    return (float)lit / 9.0f;
}

/* ------------------------------------------------------------------------------------------------
 * direct
 * ---------------------------------------------------------------------------------------------- */

/* Whether the volume shadows the meshes: a volume lit by one of the scene's lights, with its light
 * volume built (light-volume shading). The hybrid scene: "meshes receive shadows from the
 * volume: the light volume is sampled at their surface points". */
static int volume_shadows_meshes(const render_job *j)
{
    return j->st->volume.enabled && j->volume_light >= 0 &&
           j->st->volume.rc.shading == VOL_SHADING_LIGHT_VOLUME;
}

static unsigned direct_reads(const render_job *j, char *t, size_t n)
{
    const int vs = volume_shadows_meshes(j);
    if (j->st->shadows)
        return reads_text(t, n, vs ? "gbuffer,shadow_maps,light_volume,lights" : "gbuffer,shadow_maps,lights",
                          RES_GBUFFER | RES_SHADOW_MAPS | (vs ? RES_LIGHT_VOLUME : 0u));
    return reads_text(t, n, vs ? "gbuffer,light_volume,lights" : "gbuffer,lights",
                      RES_GBUFFER | (vs ? RES_LIGHT_VOLUME : 0u));
}

/* The volume's transmittance from the light to the surface point p (world), from the light volume:
 * l is the transmittance from the light to each point of the volume's box, so for p inside the box
 * it is l(p), and for p outside it is l at the point where the segment from p toward the light
 * first enters the box (beyond it, toward p, there is no more volume); 1 when the segment misses
 * the box. dir: unit, toward the light; tmax: the distance to a point light (INFINITY: directional). */
static float volume_transmittance(const render_job *j, obs_vec3 p, obs_vec3 dir, float tmax)
{
    const vol_light_volume *lv = j->lv;
    double lo[3], hi[3];
    vol_grid_bounds(&j->vol->grid, lo, hi);
    const double o[3] = {p.x, p.y, p.z}, d[3] = {dir.x, dir.y, dir.z};
    double t0 = 0.0, t1 = (double)tmax;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            if (o[a] < lo[a] || o[a] > hi[a])
                return 1.0f;
            continue;
        }
        double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
        if (ta > tb) {
            const double tt = ta;
            ta = tb;
            tb = tt;
        }
        if (ta > t0) t0 = ta;
        if (tb < t1) t1 = tb;
    }
    if (!(t1 >= t0))
        return 1.0f;
    const double x[3] = {o[0] + t0 * d[0], o[1] + t0 * d[1], o[2] + t0 * d[2]};
    float l, c[3];
    vol_light_volume_sample(lv, x, &l, c);
    return l;
}
static int direct_wanted(const render_job *j, char *r, size_t n)
{
    if (!has_direct(j)) {
        snprintf(r, n, "%s", j->light_count == 0 ? "no directional or point light in the scene"
                                                 : "no opaque mesh in the scene");
        return 0;
    }
    snprintf(r, n, "Lambert direct light from %d light(s) on opaque meshes%s%s", j->light_count,
             volume_shadows_meshes(j) ? ", shadowed by the volume" : "",
             j->spot_lights ? " (spot lights are not supported: left out)" : "");
    return 1;
}

/* The world position and (viewer-facing) world normal of pixel (x, y) of the camera G-buffer. */
static void pixel_world(const render_job *j, int x, int y, float d, obs_vec3 *p, obs_vec3 *nw)
{
    const rast_view_constants *vc = &j->gb.constants;
    obs_vec3 pv;
    const float ax = (float)(((double)x + 0.5 - vc->cx) / vc->fx), ay = (float)(-((double)y + 0.5 - vc->cy) / vc->fy);
    if (vc->projection_type == OBS_PROJECTION_PERSPECTIVE)
        pv = obs_v3(ax * d, ay * d, -d);
    else
        pv = obs_v3(ax, ay, -d);
    *p = obs_mat4_mul_point(j->cam.world, pv);
    obs_vec3 nv = obs_v3(obs_image_f32_row(&j->nff[0], y)[x], obs_image_f32_row(&j->nff[1], y)[x],
                         obs_image_f32_row(&j->nff[2], y)[x]);
    *nw = obs_v3_normalize(obs_mat4_mul_dir(j->cam.world, nv));
}

static void direct_row(void *user, int64_t yy, int thread)
{
    (void)thread;
    render_job *j = (render_job *)user;
    const int y = (int)yy;
    for (int x = 0; x < j->W; x++) {
        float out[3] = {0, 0, 0};
        if (obs_image_f32_row(&j->mask_opaque, y)[x] > 0) {
            obs_vec3 p, nw;
            pixel_world(j, x, y, obs_image_f32_row(&j->gb.depth, y)[x], &p, &nw);
            for (int i = 0; i < j->light_count; i++) {
                const obs_light *L = &j->lights[i];
                obs_vec3 l;
                float E = L->intensity, dist = INFINITY;
                if (L->type == OBS_LIGHT_DIRECTIONAL) {
                    l = obs_v3_scale(obs_v3_normalize(L->direction), -1.0f);
                } else {
                    obs_vec3 v = obs_v3_sub(L->position, p);
                    float d2 = obs_v3_dot(v, v);
                    if (!(d2 > 0))
                        continue;
                    dist = sqrtf(d2);
                    l = obs_v3_scale(v, 1.0f / dist);
                    E = E / d2;
                }
                const float ndl = obs_v3_dot(nw, l);
                if (!(ndl > 0))
                    continue;
                float vis = j->shadow ? render_shadow_lookup(&j->shadow->maps[i], L, p, nw) : 1.0f;
                if (j->lv && j->vol && j->volume_light >= 0 && L->node == j->scene->lights[j->volume_light].node &&
                    vis > 0.0f)
                    vis *= volume_transmittance(j, p, l, dist);
                const float s = E * ndl * vis / OBS_PI_F;
                out[0] += s * L->color.x;
                out[1] += s * L->color.y;
                out[2] += s * L->color.z;
            }
            for (int c = 0; c < 3; c++)
                out[c] *= obs_image_f32_row(&j->f->albedo[c], y)[x];
        }
        for (int c = 0; c < 3; c++)
            obs_image_f32_row(&j->f->direct[c], y)[x] = out[c];
    }
}

static obs_status direct_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    obs_status st = render_planes_alloc(j->ctx, 3, j->W, j->H, j->f->direct);
    if (st != OBS_STATUS_OK)
        return st;
    obs_pool_run(j->pool, j->H, direct_row, j);
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(3, j->f->direct);
    return OBS_STATUS_OK;
}

const render_pass render_pass_direct = {"direct", RES_DIRECT, 1, 0, direct_reads, direct_wanted, NULL, direct_run};

/* ------------------------------------------------------------------------------------------------
 * ao
 * ---------------------------------------------------------------------------------------------- */

static unsigned ao_reads(const render_job *j, char *t, size_t n)
{
    (void)j;
    return reads_text(t, n, "gbuffer,camera", RES_GBUFFER);
}
static int ao_wanted(const render_job *j, char *r, size_t n)
{
    if (!j->st->ao) {
        snprintf(r, n, "AO off");
        return 0;
    }
    if (!j->any_opaque) {
        snprintf(r, n, "no opaque mesh in the scene (AO darkens the ambient term of opaque meshes)");
        return 0;
    }
    char ps[160] = "";
    if (j->st->ao->params_to_string)
        j->st->ao->params_to_string(j->st->ao_params, ps, sizeof ps);
    snprintf(r, n, "%s on the camera G-buffer%s%s", j->st->ao->name, ps[0] ? ": " : "", ps);
    return 1;
}
static obs_status ao_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    ao_input in;
    obs_status st = ao_input_from_gbuffer(j->ctx, &j->gb_ff, 1, &in);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(j->ctx, j->W, j->H, &j->f->ao);
    ao_stats as;
    memset(&as, 0, sizeof as);
    if (st == OBS_STATUS_OK)
        st = j->st->ao->compute(j->ctx, j->pool, &in, j->st->ao_params, &j->f->ao, NULL, &as);
    if (st != OBS_STATUS_OK)
        return st;
    obs_log(j->ctx, OBS_LOG_INFO, "render: ao %s: prepare %.2f ms, kernel %.2f ms, blur %.2f ms", j->st->ao->name,
            1e3 * as.seconds_prepare, 1e3 * as.seconds_kernel, 1e3 * as.seconds_blur);
    render_pass_record *rec = NULL;
    for (int i = 0; i < j->f->pass_count; i++)
        if (!strcmp(j->f->passes[i].name, "ao"))
            rec = &j->f->passes[i];
    if (rec) {
        size_t l = strlen(rec->reason);
        snprintf(rec->reason + l, sizeof rec->reason - l, " (kernel %.1f ms, blur %.1f ms)", 1e3 * as.seconds_kernel,
                 1e3 * as.seconds_blur);
    }
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(1, &j->f->ao);
    return OBS_STATUS_OK;
}

const render_pass render_pass_ao = {"ao", RES_AO, 1, 0, ao_reads, ao_wanted, NULL, ao_run};

/* ------------------------------------------------------------------------------------------------
 * ambient
 * ---------------------------------------------------------------------------------------------- */

static unsigned ambient_reads(const render_job *j, char *t, size_t n)
{
    if (j->st->ao)
        return reads_text(t, n, "gbuffer,ao,ambient", RES_GBUFFER | RES_AO);
    return reads_text(t, n, "gbuffer,ambient", RES_GBUFFER);
}
static int ambient_wanted(const render_job *j, char *r, size_t n)
{
    if (!j->any_opaque) {
        snprintf(r, n, "no opaque mesh in the scene");
        return 0;
    }
    snprintf(r, n, "ambient (%g, %g, %g) x albedo x %s on opaque meshes", j->st->ambient[0], j->st->ambient[1],
             j->st->ambient[2], j->st->ao ? "AO" : "1 (AO off)");
    return 1;
}

/* ambient x albedo x ao (ao NULL: 1) on the opaque mask into out[3]. */
obs_status render_ambient_fill(render_job *j, const obs_image_f32 *ao, obs_image_f32 out[3])
{
    obs_status st = render_planes_alloc(j->ctx, 3, j->W, j->H, out);
    if (st != OBS_STATUS_OK)
        return st;
    for (int y = 0; y < j->H; y++)
        for (int x = 0; x < j->W; x++) {
            const float m = obs_image_f32_row(&j->mask_opaque, y)[x];
            const float a = ao ? obs_image_f32_row(ao, y)[x] : 1.0f;
            for (int c = 0; c < 3; c++)
                obs_image_f32_row(&out[c], y)[x] =
                    m > 0 ? j->st->ambient[c] * obs_image_f32_row(&j->f->albedo[c], y)[x] * a : 0.0f;
        }
    return OBS_STATUS_OK;
}

static obs_status ambient_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    obs_status st = render_ambient_fill(j, j->f->ao.data ? &j->f->ao : NULL, j->f->ambient);
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(3, j->f->ambient);
    return st;
}

const render_pass render_pass_ambient = {"ambient", RES_AMBIENT, 1, 0, ambient_reads, ambient_wanted, NULL,
                                         ambient_run};

/* ------------------------------------------------------------------------------------------------
 * compose: surface = direct + ambient (opaque) or SSS (translucent); beauty = vol.rgb + (1 - vol.a)
 * x surface (the volume is premultiplied and already stopped at the mesh depth).
 * ---------------------------------------------------------------------------------------------- */

static unsigned compose_reads(const render_job *j, char *t, size_t n)
{
    unsigned m = 0;
    char dummy[224];
    t[0] = '\0';
    if (render_pass_direct.wanted(j, dummy, sizeof dummy)) m |= RES_DIRECT;
    if (render_pass_ambient.wanted(j, dummy, sizeof dummy)) m |= RES_AMBIENT;
    if (render_pass_sss_combine.wanted(j, dummy, sizeof dummy)) m |= RES_SSS;
    if (render_pass_raycast.wanted(j, dummy, sizeof dummy)) m |= RES_VOLUME;
    for (int i = 0; i < RES_COUNT_BITS; i++)
        if (m & (1u << i)) {
            size_t l = strlen(t);
            snprintf(t + l, n - l, "%s%s", l ? "," : "", render_resource_name(1u << i));
        }
    return m;
}
static int compose_wanted(const render_job *j, char *r, size_t n)
{
    (void)j;
    snprintf(r, n, "beauty = volume + (1 - volume alpha) x (direct + ambient on opaque, SSS on translucent)");
    return 1;
}

/* Compose beauty from the given layers (any may have NULL data). */
obs_status render_compose(render_job *j, const obs_image_f32 *direct, const obs_image_f32 *ambient,
                          const obs_image_f32 *sss, const obs_image_f32 *volume, obs_image_f32 out[3])
{
    obs_status st = render_planes_alloc(j->ctx, 3, j->W, j->H, out);
    if (st != OBS_STATUS_OK)
        return st;
    for (int y = 0; y < j->H; y++)
        for (int x = 0; x < j->W; x++) {
            const float a = volume[3].data ? obs_image_f32_row(&volume[3], y)[x] : 0.0f;
            for (int c = 0; c < 3; c++) {
                float s = 0.0f;
                if (direct[c].data) s += obs_image_f32_row(&direct[c], y)[x];
                if (ambient[c].data) s += obs_image_f32_row(&ambient[c], y)[x];
                if (sss[c].data && obs_image_f32_row(&j->mask_translucent, y)[x] > 0)
                    s += obs_image_f32_row(&sss[c], y)[x];
                float v = volume[c].data ? obs_image_f32_row(&volume[c], y)[x] : 0.0f;
                obs_image_f32_row(&out[c], y)[x] = v + (1.0f - a) * s;
            }
        }
    return OBS_STATUS_OK;
}

static obs_status compose_run(render_job *j, render_pass_state *state, uint64_t *bytes)
{
    obs_status st = render_compose(j, j->f->direct, j->f->ambient, j->f->sss, j->f->volume, j->f->beauty);
    *state = RENDER_PASS_RAN;
    *bytes = render_planes_bytes(3, j->f->beauty);
    return st;
}

const render_pass render_pass_compose = {"compose", RES_BEAUTY, 1, 0, compose_reads, compose_wanted, NULL,
                                         compose_run};
