/* sss_maps.c: passes 1 and 2 of the scattering-map pipeline of [DalCorso17] as its precursor
 * thesis [DalCorso14] does it (../shared/reference/sss.md section 3; docs/sss/maps.md):
 *   pass 1  sss_light_map_render: the scene seen from a light (positions, normals, ids);
 *   pass 2  sss_maps_build: K orthographic views from Halton directions; every texel on a
 *           translucent surface gathers T12 S_d L from disk samples of every light map.
 * Nothing here depends on a camera. Randomness is a function of (texel, layer, frame, seed) only
 * (the recipe is in sss_maps_internal.h and docs/sss/maps.md), so the maps are the same bytes for
 * any thread count. */
#include "sss_maps_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------------
 * Geometry helpers
 * ---------------------------------------------------------------------------------------------- */

int sss_i_project(const rast_view_constants *vc, const double p[3], double *px, double *py, double *depth,
                  double *px_per_unit)
{
    const float *m = vc->view.m;
    double v[3];
    for (int r = 0; r < 3; r++)
        v[r] = (double)m[r] * p[0] + (double)m[4 + r] * p[1] + (double)m[8 + r] * p[2] + (double)m[12 + r];
    double d = -v[2];
    if (vc->projection_type == OBS_PROJECTION_PERSPECTIVE) {
        if (!(d > 0.0))
            return 0;
        /* the inverse of rast_pixel_ray's dir_view = ((px - cx)/fx, -(py - cy)/fy, -1) */
        *px = vc->cx + vc->fx * v[0] / d;
        *py = vc->cy - vc->fy * v[1] / d;
        *px_per_unit = vc->fx / d;
    } else {
        /* org_view = ((px - cx)/fx, -(py - cy)/fy, 0) */
        *px = vc->cx + vc->fx * v[0];
        *py = vc->cy - vc->fy * v[1];
        *px_per_unit = vc->fx;
    }
    *depth = d;
    return 1;
}

void sss_i_pixel_world(const rast_view_constants *vc, double px, double py, double depth, double out[3])
{
    double ax = (px - vc->cx) / vc->fx, ay = -(py - vc->cy) / vc->fy;
    double q[3];
    if (vc->projection_type == OBS_PROJECTION_PERSPECTIVE) {
        q[0] = ax * depth;
        q[1] = ay * depth;
    } else {
        q[0] = ax;
        q[1] = ay;
    }
    q[2] = -depth;
    const float *m = vc->view.m;
    for (int r = 0; r < 3; r++)
        q[r] -= (double)m[12 + r];
    for (int c = 0; c < 3; c++)
        out[c] = (double)m[c * 4 + 0] * q[0] + (double)m[c * 4 + 1] * q[1] + (double)m[c * 4 + 2] * q[2];
}

void sss_i_normal_world(const rast_view_constants *vc, const float nv[3], double out[3])
{
    const float *m = vc->view.m;
    double l2 = 0.0;
    for (int c = 0; c < 3; c++) {
        out[c] = (double)m[c * 4 + 0] * nv[0] + (double)m[c * 4 + 1] * nv[1] + (double)m[c * 4 + 2] * nv[2];
        l2 += out[c] * out[c];
    }
    if (l2 > 0.0) {
        double inv = 1.0 / sqrt(l2);
        for (int c = 0; c < 3; c++)
            out[c] *= inv;
    }
}

const sss_constants *sss_i_material(const sss_scene_materials *mats, uint32_t material_id)
{
    if (!mats)
        return NULL;
    if (material_id == RAST_ID_NONE)
        return mats->none;
    if (material_id >= mats->count || !mats->constants || !mats->translucent || !mats->translucent[material_id])
        return NULL;
    return &mats->constants[material_id];
}

obs_status sss_i_scene_sphere(obs_context *ctx, const obs_scene *scene, double c[3], double *radius)
{
    const obs_aabb *b = &scene->bounds;
    if (!(b->lo.x <= b->hi.x && b->lo.y <= b->hi.y && b->lo.z <= b->hi.z))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss: the scene's bounds are empty");
    double lo[3] = {b->lo.x, b->lo.y, b->lo.z}, hi[3] = {b->hi.x, b->hi.y, b->hi.z}, d2 = 0.0;
    for (int a = 0; a < 3; a++) {
        c[a] = 0.5 * (lo[a] + hi[a]);
        d2 += (hi[a] - lo[a]) * (hi[a] - lo[a]);
    }
    *radius = 0.5 * sqrt(d2);
    if (!(*radius > 0.0 && isfinite(*radius)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss: the scene's bounds have no extent");
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * Halton directions and the N-of-M candidate disk
 * ---------------------------------------------------------------------------------------------- */

void sss_halton_directions(int K, double *dirs)
{
    /* [DalCorso14] miscellaneous.cpp haltonPointSphere, sss.md 3.2: k = 1..K,
     * phi = 2 pi Phi_2(k), cos theta = 2 (1 - Phi_3(k)) - 1 [Halton60]. The polar axis is +Z
     * (our choice; the thesis' axis convention does not change the set's uniformity). */
    for (int k = 1; k <= K; k++) {
        double phi = 2.0 * OBS_PI * obs_radical_inverse(2, (uint64_t)k);
        double ct = 2.0 * (1.0 - obs_radical_inverse(3, (uint64_t)k)) - 1.0;
        double st = sqrt(fmax(0.0, 1.0 - ct * ct));
        double *d = dirs + 3 * (k - 1);
        d[0] = st * cos(phi);
        d[1] = st * sin(phi);
        d[2] = ct;
    }
}

typedef struct rho_idx {
    float rho;
    int j;
} rho_idx;

static int cmp_rho(const void *a, const void *b)
{
    const rho_idx *x = (const rho_idx *)a, *y = (const rho_idx *)b;
    if (x->rho != y->rho)
        return x->rho < y->rho ? -1 : 1;
    return x->j < y->j ? -1 : (x->j > y->j);
}

obs_status sss_i_halton_disk_make(obs_context *ctx, int M, sss_i_halton_disk *out)
{
    memset(out, 0, sizeof *out);
    rho_idx *tmp = (rho_idx *)malloc(sizeof(rho_idx) * (size_t)(M > 0 ? M : 1));
    out->rho = (float *)malloc(sizeof(float) * (size_t)(M > 0 ? M : 1));
    out->phi = (float *)malloc(sizeof(float) * (size_t)(M > 0 ? M : 1));
    if (!tmp || !out->rho || !out->phi) {
        free(tmp);
        sss_i_halton_disk_free(out);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "sss: out of memory for %d disk candidates", M);
    }
    /* [DalCorso14] miscellaneous.cpp haltonPointCircle (area-uniform): rho = sqrt(Phi_2(j)),
     * phi = 2 pi Phi_3(j), j = 1..M [Halton60]. */
    for (int j = 0; j < M; j++) {
        tmp[j].rho = (float)sqrt(obs_radical_inverse(2, (uint64_t)(j + 1)));
        tmp[j].j = j;
    }
    qsort(tmp, (size_t)M, sizeof(rho_idx), cmp_rho);
    for (int i = 0; i < M; i++) {
        out->rho[i] = tmp[i].rho;
        out->phi[i] = (float)(2.0 * OBS_PI * obs_radical_inverse(3, (uint64_t)(tmp[i].j + 1)));
    }
    out->M = M;
    free(tmp);
    return OBS_STATUS_OK;
}

void sss_i_halton_disk_free(sss_i_halton_disk *h)
{
    if (!h)
        return;
    free(h->rho);
    free(h->phi);
    memset(h, 0, sizeof *h);
}

/* ------------------------------------------------------------------------------------------------
 * The exponential sampler (sss_maps_internal.h has the recipe)
 * ---------------------------------------------------------------------------------------------- */

void sss_i_exp_disk_make(double sigma, double R, int N, sss_i_exp_disk *d)
{
    memset(d, 0, sizeof *d);
    d->sigma = (float)sigma;
    d->R = (float)R;
    d->T = d->sigma * d->R;
    const double T = sigma * R, q = (1.0 + T) * exp(-T);
    d->q = (float)q;
    d->Z = (float)(1.0 - q);
    /* 1 / (N p(x)), p(x) = sigma^2 e^{-sigma rho} / (2 pi Z): the e^{sigma rho} factor per sample */
    d->w0 = (float)(2.0 * OBS_PI * (1.0 - q) / ((double)N * sigma * sigma));
    /* the LCG of sss_i_rand composed k times: a_k = a^k, c_k = c (a^{k-1} + ... + 1) (mod 2^32) */
    uint32_t a = 1, c = 0;
    for (int k = 0; k < 24; k++) {
        a = 1664525u * a;
        c = 1664525u * c + 1013904223u;
        d->jump_a[k] = a;
        d->jump_c[k] = c;
    }
    for (int j = 0; j < 8; j++) {
        for (int q = 0; q < 2; q++) {
            d->lane2_a[q][j] = d->jump_a[2 * j + q];
            d->lane2_c[q][j] = d->jump_c[2 * j + q];
        }
        for (int q = 0; q < 3; q++) {
            d->lane3_a[q][j] = d->jump_a[3 * j + q];
            d->lane3_c[q][j] = d->jump_c[3 * j + q];
        }
    }
}

void sss_i_exp_samples_scalar(uint32_t *state, int n, const sss_i_exp_disk *d, float *ox, float *oy, float *w)
{
    for (int i = 0; i < n; i++) {
        const float u1 = sss_i_rand(state), u2 = sss_i_rand(state);
        sss_i_exp_sample(u1, u2, d, &ox[i], &oy[i], &w[i]);
    }
}

void sss_i_exp_samples(uint32_t *state, int n, const sss_i_exp_disk *d, float *ox, float *oy, float *w, int use_avx2)
{
    int done = 0;
#if defined(OBS_HAVE_AVX2)
    if (use_avx2 && n >= 8) {
        sss_i_exp_samples_avx2(state, n / 8, d, ox, oy, w);
        done = n / 8 * 8;
    }
#else
    (void)use_avx2;
#endif
    sss_i_exp_samples_scalar(state, n - done, d, ox + done, oy + done, w + done);
}

int sss_i_rr_prefilter_off = 0;
int sss_i_maps_cull_back = 0;

void sss_i_pack_lut_make(int32_t lut[256 * 8])
{
    /* entry m: the indices of m's set bits in increasing order, then zeros */
    for (int m = 0; m < 256; m++) {
        int q = 0;
        for (int b = 0; b < 8; b++)
            if (m >> b & 1)
                lut[8 * m + q++] = b;
        while (q < 8)
            lut[8 * m + q++] = 0;
    }
}

void sss_i_rr_table_make(double sigma, double R, double m, uint32_t *zmax)
{
    for (int b = 0; b < SSS_I_RR_BINS; b++) {
        const double arg = sigma * (R * sqrt((double)b / SSS_I_RR_BINS) - m);
        const double pb = arg <= 0.0 ? 2.0 : (1.0 + 1e-4) * exp(-arg);
        const double z = ceil(pb * 16777216.0);
        zmax[b] = z >= 16777217.0 ? 16777217u : (uint32_t)z;
    }
}

int sss_i_rr_prefilter(uint32_t *state, int N, const sss_i_rr_filter *f, float *u1, float *u2, float *zeta,
                       int use_avx2)
{
    int n = 0, done = 0;
#if defined(OBS_HAVE_AVX2)
    if (use_avx2 && N >= 8) {
        n = sss_i_rr_prefilter_avx2(state, N / 8, f, u1, u2, zeta);
        done = N / 8 * 8;
    }
#else
    (void)use_avx2;
#endif
    for (int i = done; i < N; i++) {
        const uint32_t s1 = 1664525u * *state + 1013904223u;
        const float a = sss_i_rand(state), b = sss_i_rand(state), z = sss_i_rand(state);
        if ((*state >> 8) >= f->zmax[s1 >> 22])
            continue;
        u1[n] = a;
        u2[n] = b;
        zeta[n] = z;
        n++;
    }
    return n;
}

int sss_i_nofm_accept(const sss_i_halton_disk *h, uint32_t *state, double sigma_r, int keep, int *idx, int *visited)
{
    /* [DalCorso14] method.tex, planeHaltonCircleRejectionExponential: accept when
     * exp(-sigma* r) > zeta. Visiting in order of rho and stopping after `keep` acceptances gives
     * the same set as "accept among all M, then keep the N nearest" (the zetas of the unvisited
     * candidates are never looked at). */
    int n = 0, v = 0;
    for (int i = 0; i < h->M; i++) {
        float zeta = sss_i_rand(state);
        v++;
        if (exp(-sigma_r * (double)h->rho[i]) > (double)zeta) {
            idx[n++] = i;
            if (keep > 0 && n >= keep)
                break;
        }
    }
    if (visited)
        *visited = v;
    return n;
}

int sss_i_nofm_accept_tab(const sss_i_halton_disk *h, uint32_t *state, const double *p, int keep, int *idx,
                          int *visited)
{
    int n = 0, v = 0;
    for (int i = 0; i < h->M; i++) {
        float zeta = sss_i_rand(state);
        v++;
        if (p[i] > (double)zeta) {
            idx[n++] = i;
            if (keep > 0 && n >= keep)
                break;
        }
    }
    if (visited)
        *visited = v;
    return n;
}

/* ------------------------------------------------------------------------------------------------
 * Pass 1: the light G-buffer
 * ---------------------------------------------------------------------------------------------- */

void sss_light_map_free(sss_light_map *lm)
{
    if (!lm)
        return;
    rast_gbuffer_free(&lm->gb);
    for (int c = 0; c < 3; c++) {
        obs_image_f32_free(&lm->position[c]);
        obs_image_f32_free(&lm->wnormal[c]);
    }
    memset(lm, 0, sizeof *lm);
}

/* An orthographic camera looking at c from direction `towards` (unit, from c to the eye), framing
 * the sphere (c, rad): xmag = ymag = 1.01 rad (1% margin so the silhouette never touches the
 * border), near 0 at the eye 2 rad away, far 4 rad. */
static obs_camera ortho_camera(const double c[3], const double towards[3], double rad)
{
    obs_vec3 eye = obs_v3((float)(c[0] + 2.0 * rad * towards[0]), (float)(c[1] + 2.0 * rad * towards[1]),
                          (float)(c[2] + 2.0 * rad * towards[2]));
    obs_vec3 up = fabs(towards[1]) < 0.99 ? obs_v3(0, 1, 0) : obs_v3(1, 0, 0);
    obs_camera cam = obs_camera_look_at(eye, obs_v3((float)c[0], (float)c[1], (float)c[2]), up, 1.0f, 0.0f,
                                        (float)(4.0 * rad));
    cam.projection = OBS_PROJECTION_ORTHOGRAPHIC;
    cam.xmag = cam.ymag = (float)(1.01 * rad);
    cam.znear = 0.0f;
    cam.zfar = (float)(4.0 * rad);
    return cam;
}

static rast_params gbuffer_params(int size)
{
    rast_params rp = rast_params_default();
    rp.width = rp.height = size;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_INSTANCE_ID | RAST_OUT_MATERIAL_ID;
    /* outward normals: a back face keeps its orientation (no gl_FrontFacing flip) */
    rp.face_forward = 0;
    return rp;
}

obs_status sss_light_map_render(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const obs_light *light,
                                const sss_params *p, sss_light_map *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_light_map_render: NULL output");
    memset(out, 0, sizeof *out);
    if (!scene || !light || !p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_light_map_render: NULL argument");
    obs_status st = sss_params_validate(ctx, p);
    if (st != OBS_STATUS_OK)
        return st;
    double c[3], rad;
    if ((st = sss_i_scene_sphere(ctx, scene, c, &rad)) != OBS_STATUS_OK)
        return st;
    obs_camera cam;
    const int size = p->light_map_size;
    double world_per_texel;
    if (light->type == OBS_LIGHT_DIRECTIONAL) {
        /* [DalCorso14] implementation.tex: an orthographic light camera framing the object */
        double d[3] = {light->direction.x, light->direction.y, light->direction.z};
        double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(l > 0.0 && isfinite(l)))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss: light '%s' has no direction", light->name);
        double towards[3] = {-d[0] / l, -d[1] / l, -d[2] / l};
        cam = ortho_camera(c, towards, rad);
        world_per_texel = 2.0 * cam.xmag / size;
    } else if (light->type == OBS_LIGHT_POINT) {
        /* a perspective camera at the light looking at the bounds' centre, its field of view
         * covering the bounding sphere (1% margin) */
        double pl[3] = {light->position.x, light->position.y, light->position.z};
        double dist = sqrt((pl[0] - c[0]) * (pl[0] - c[0]) + (pl[1] - c[1]) * (pl[1] - c[1]) +
                           (pl[2] - c[2]) * (pl[2] - c[2]));
        if (!(dist > 1.02 * rad) || !isfinite(dist))
            return obs_error(ctx, OBS_STATUS_UNSUPPORTED,
                             "sss: point light '%s' is inside the scene's bounding sphere (distance %g, radius %g); "
                             "a light map needs it outside",
                             light->name, dist, rad);
        double half = asin(1.01 * rad / dist);
        obs_vec3 dir = obs_v3((float)((c[0] - pl[0]) / dist), (float)((c[1] - pl[1]) / dist),
                              (float)((c[2] - pl[2]) / dist));
        obs_vec3 up = fabsf(dir.y) < 0.99f ? obs_v3(0, 1, 0) : obs_v3(1, 0, 0);
        cam = obs_camera_look_at(light->position, obs_v3((float)c[0], (float)c[1], (float)c[2]), up,
                                 (float)(2.0 * half), (float)(0.5 * (dist - rad)), (float)(dist + 1.5 * rad));
        world_per_texel = 2.0 * dist * tan(half) / size; /* at the bounds' centre */
    } else {
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "sss: light '%s': only directional and point lights have light maps",
                         light->name);
    }
    rast_params rp = gbuffer_params(size);
    /* not zeroed: rast_render writes every element (rast_gbuffer_alloc_uninit) */
    if ((st = rast_gbuffer_alloc_uninit(ctx, &rp, &out->gb)) != OBS_STATUS_OK)
        goto fail;
    rast_view view;
    view.camera = cam;
    if ((st = rast_render(ctx, pool, scene, &view, 1, &rp, &out->gb, NULL)) != OBS_STATUS_OK)
        goto fail;
    for (int a = 0; a < 3; a++) {
        /* not zeroed: the loop below writes every texel of both */
        if ((st = obs_image_f32_alloc_uninit(ctx, size, size, &out->position[a])) != OBS_STATUS_OK ||
            (st = obs_image_f32_alloc_uninit(ctx, size, size, &out->wnormal[a])) != OBS_STATUS_OK)
            goto fail;
    }
    const rast_view_constants *vc = &out->gb.constants;
    for (int y = 0; y < size; y++) {
        const float *dr = obs_image_f32_row(&out->gb.depth, y);
        for (int x = 0; x < size; x++) {
            double pw[3] = {NAN, NAN, NAN}, nw[3] = {0, 0, 0};
            if (dr[x] < INFINITY) {
                float nv[3] = {obs_image_f32_row(&out->gb.normal[0], y)[x], obs_image_f32_row(&out->gb.normal[1], y)[x],
                               obs_image_f32_row(&out->gb.normal[2], y)[x]};
                sss_i_pixel_world(vc, x + 0.5, y + 0.5, dr[x], pw);
                sss_i_normal_world(vc, nv, nw);
            }
            for (int a = 0; a < 3; a++) {
                obs_image_f32_row(&out->position[a], y)[x] = (float)pw[a];
                obs_image_f32_row(&out->wnormal[a], y)[x] = (float)nw[a];
            }
        }
    }
    out->light = *light;
    out->world_per_texel = world_per_texel;
    return OBS_STATUS_OK;
fail:
    sss_light_map_free(out);
    return st;
}

/* ------------------------------------------------------------------------------------------------
 * Pass 2: the scattering maps
 * ---------------------------------------------------------------------------------------------- */

void sss_maps_free(sss_maps *m)
{
    if (!m)
        return;
    if (m->views)
        for (int k = 0; k < m->K; k++)
            rast_gbuffer_free(&m->views[k]);
    if (m->radiance)
        for (int i = 0; i < 3 * m->K; i++)
            obs_image_f32_free(&m->radiance[i]);
    free(m->views);
    free(m->radiance);
    free(m->dirs);
    memset(m, 0, sizeof *m);
}

typedef struct light_info {
    const sss_light_map *lm;
    int point;
    double to_light[3];   /* directional: unit, towards the light */
    double pos[3];        /* point: position */
    double radiance[3];   /* colour x intensity */
    sss_i_view_geo geo;   /* the light map's view constants in double (x_o's projection) */
    uint32_t *pack;       /* exponential sampler, directional, AVX2: the light map interleaved
                             (sss_i_fetch_in.pack), or NULL */
    int rr_prefilter;     /* Russian roulette: the pre-filter applies to this light (tables made,
                             directional, orthographic with square texels); set once per build */
    int index;            /* l: this light's table in mat_info.rr_zmax */
} light_info;

typedef struct mat_info {
    const sss_constants *c; /* NULL: opaque */
    sss_gpu_constants g;
    double sigma_star;      /* min sigma_tr / q, per scene unit */
    sss_i_exp_disk ed;      /* the exponential sampler's constants (sigma*, R, N) */
    double *nofm_p;         /* N-of-M: exp(-sigma* R rho_j), M entries */
    const uint32_t *rr_zmax;/* Russian roulette: this material's pre-filter tables, one per light
                               (light l at rr_zmax + l SSS_I_RR_BINS), or NULL */
} mat_info;

typedef struct scratch {
    uint32_t seeds[40];     /* one row of a 32-texel tile, rounded up to 8 */
    float *buf;             /* xi[3], ni[3], wi[3], out[3], ox, oy, w: 15 N floats */
    float *pl[15];          /* the 15 planes of buf, plane i at buf + i np (set per build) */
    double *w;              /* N */
    int *idx;               /* M */
} scratch;

typedef struct build_job {
    const sss_params *p;
    sss_maps *maps;
    obs_tiling tiling;
    int64_t tiles;
    const light_info *lights;
    int light_count;
    const mat_info *mats;   /* count + 1: the last is `none` */
    uint32_t mat_count;
    double R, area;
    const sss_i_halton_disk *hd;
    double *hd_cos, *hd_sin; /* N-of-M: cos and sin of the Halton phi_j */
    scratch *scr;           /* one per thread */
    uint64_t *evaluated, *candidates; /* one per task */
    uint8_t *failed;        /* one per task */
    int use_avx2;           /* the exponential sampler's sample generation; batch padding */
    int np;                 /* N rounded up to a multiple of 8: the scratch arrays' length */
    int32_t pack_lut[256 * 8]; /* left-pack permutations (sss_i_pack_lut_make) */
    uint32_t *rr_zmax;      /* Russian roulette: the pre-filter's tables, (count + 1) x lights x 1024, or NULL */
} build_job;

static const mat_info *job_material(const build_job *j, uint32_t id)
{
    if (id == RAST_ID_NONE)
        return j->mats[j->mat_count].c ? &j->mats[j->mat_count] : NULL;
    if (id >= j->mat_count || !j->mats[id].c)
        return NULL;
    return &j->mats[id];
}

/* Gather for one texel and one light: append accepted samples to the SoA scratch; returns the
 * number of samples, adds to *cand the candidates drawn. */
static int gather_light(const build_job *j, const light_info *li, const double xo[3], uint32_t inst_o,
                        const mat_info *mi, uint32_t *state, double theta, scratch *s, uint64_t *cand)
{
    const sss_params *p = j->p;
    const sss_light_map *lm = li->lm;
    const int N = p->N, size = lm->gb.width;
    double pcx, pcy, dl, ppu;
    float **xi = s->pl, **ni = s->pl + 3, **wi = s->pl + 6;
    /* the disk's centre: the light-space projection of x_o ([DalCorso14] "circle_center =
     * (L x_o).xy", sss.md 3.2); for a point light the disk lies in the plane perpendicular to
     * the light's axis at x_o's depth, scaled by fx / depth */
    if (!sss_i_geo_project(&li->geo, xo, &pcx, &pcy, &dl, &ppu)) /* = sss_i_project, same bits */
        return 0;
    int n = 0;
    const double R = j->R;
    /* one candidate: disk offset (ox, oy) in world units in the light-map plane */
#define SSS_FETCH(ox, oy, ...)                                                                         \
    do {                                                                                               \
        double tx_ = pcx + (ox) * ppu, ty_ = pcy - (oy) * ppu;                                         \
        if (tx_ >= 0.0 && ty_ >= 0.0 && tx_ < size && ty_ < size) {                                    \
            int ix_ = (int)tx_, iy_ = (int)ty_; /* nearest texel (docs/sss/maps.md) */                \
            float px_ = obs_image_f32_row(&lm->position[0], iy_)[ix_];                                 \
            if (px_ == px_ && obs_image_u32_row(&lm->gb.instance_id, iy_)[ix_] == inst_o) {            \
                double x_i[3] = {px_, obs_image_f32_row(&lm->position[1], iy_)[ix_],                   \
                                 obs_image_f32_row(&lm->position[2], iy_)[ix_]};                       \
                __VA_ARGS__                                                                            \
            }                                                                                          \
        }                                                                                              \
    } while (0)
#define SSS_PUSH(weight)                                                                               \
    do {                                                                                               \
        double w_ = (weight), wl_[3];                                                                  \
        if (li->point) {                                                                               \
            double dx_ = li->pos[0] - x_i[0], dy_ = li->pos[1] - x_i[1], dz_ = li->pos[2] - x_i[2];     \
            double d2_ = dx_ * dx_ + dy_ * dy_ + dz_ * dz_, il_ = 1.0 / sqrt(d2_);                     \
            w_ /= d2_; /* point light: E = I / |x_p - x_i|^2 ([DalCorso14] eq. inter2 variant) */       \
            wl_[0] = dx_ * il_;                                                                        \
            wl_[1] = dy_ * il_;                                                                        \
            wl_[2] = dz_ * il_;                                                                        \
        } else {                                                                                       \
            wl_[0] = li->to_light[0];                                                                  \
            wl_[1] = li->to_light[1];                                                                  \
            wl_[2] = li->to_light[2];                                                                  \
        }                                                                                              \
        for (int a_ = 0; a_ < 3; a_++) {                                                               \
            xi[a_][n] = (float)x_i[a_];                                                                \
            ni[a_][n] = obs_image_f32_row(&lm->wnormal[a_], iy_)[ix_];                                 \
            wi[a_][n] = (float)wl_[a_];                                                                \
        }                                                                                              \
        s->w[n] = w_;                                                                                  \
        n++;                                                                                           \
    } while (0)

    if (p->sampler == SSS_SAMPLER_EXPONENTIAL) {
        /* ours (docs/sss/maps.md "Samplers"): N samples of the density e^{-sigma* rho} on the disk,
         * weight 1/(N pdf), drawn SoA (sss_i_exp_samples), then fetched and packed in order */
        float *sox = s->pl[12], *soy = s->pl[13], *sw = s->pl[14];
        sss_i_exp_samples(state, N, &mi->ed, sox, soy, sw, j->use_avx2);
        *cand += (uint64_t)N;
        const float fcx = (float)pcx, fcy = (float)pcy, fppu = (float)ppu, fsize = (float)size;
        const float *P0 = lm->position[0].data, *P1 = lm->position[1].data, *P2 = lm->position[2].data;
        const float *W0 = lm->wnormal[0].data, *W1 = lm->wnormal[1].data, *W2 = lm->wnormal[2].data;
        const uint32_t *IID = lm->gb.instance_id.data;
        const ptrdiff_t pst = lm->position[0].stride, ist = lm->gb.instance_id.stride;
        /* The near field (docs/sss/maps.md "Samplers"): the 3 x 3 light-map texels around x_o's
         * projection are integrated exactly (each texel's value times its area 1/ppu^2, appended
         * after the samples) and samples that land in them count 0. Unbiased: the integrand is
         * constant over a texel (nearest fetch). Only when the block lies inside the disk. */
        const int block = R * ppu >= 3.0 && fcx > -4.0f && fcy > -4.0f && fcx < fsize + 4.0f && fcy < fsize + 4.0f;
        const int bx = block ? (int)floorf(fcx) - 1 : 0, by = block ? (int)floorf(fcy) - 1 : 0;
#define SSS_IN_BLOCK(ix, iy) (block && (unsigned)((ix) - bx) < 3u && (unsigned)((iy) - by) < 3u)
        if (!li->point) {
            const float l0 = (float)li->to_light[0], l1 = (float)li->to_light[1], l2 = (float)li->to_light[2];
            int i = 0;
#if defined(OBS_HAVE_AVX2)
            if (j->use_avx2) {
                /* the loop below, 8 samples per vector (gathers, left-packed by a table) */
                sss_i_fetch_in in = {{P0, P1, P2}, {W0, W1, W2}, IID, pst, ist, fcx, fcy, fppu, fsize, inst_o, {l0, l1, l2}, bx, by, block,
                                     li->pack, size};
                n = sss_i_exp_fetch_dir_avx2(&in, N / 8, sox, soy, sw, j->pack_lut, xi, ni, wi, s->w, n);
                i = N / 8 * 8;
            }
#endif
            for (; i < N; i++) {
                const float tx = fcx + sox[i] * fppu, ty = fcy - soy[i] * fppu;
                if (!(tx >= 0.0f && ty >= 0.0f && tx < fsize && ty < fsize))
                    continue;
                const int ix = (int)tx, iy = (int)ty; /* nearest texel (docs/sss/maps.md) */
                if (SSS_IN_BLOCK(ix, iy))
                    continue;
                const ptrdiff_t o = (ptrdiff_t)iy * pst + ix;
                const float px = P0[o];
                if (px != px || IID[(ptrdiff_t)iy * ist + ix] != inst_o)
                    continue;
                xi[0][n] = px;
                xi[1][n] = P1[o];
                xi[2][n] = P2[o];
                ni[0][n] = W0[o];
                ni[1][n] = W1[o];
                ni[2][n] = W2[o];
                wi[0][n] = l0;
                wi[1][n] = l1;
                wi[2][n] = l2;
                s->w[n] = (double)sw[i];
                n++;
            }
        } else {
            for (int i = 0; i < N; i++) {
                const float tx = fcx + sox[i] * fppu, ty = fcy - soy[i] * fppu;
                if (!(tx >= 0.0f && ty >= 0.0f && tx < fsize && ty < fsize))
                    continue;
                const int ix = (int)tx, iy = (int)ty;
                if (SSS_IN_BLOCK(ix, iy))
                    continue;
                const ptrdiff_t o = (ptrdiff_t)iy * pst + ix;
                const float px = P0[o];
                if (px != px || IID[(ptrdiff_t)iy * ist + ix] != inst_o)
                    continue;
                const double x_i[3] = {px, P1[o], P2[o]};
                double dx = li->pos[0] - x_i[0], dy = li->pos[1] - x_i[1], dz = li->pos[2] - x_i[2];
                double d2 = dx * dx + dy * dy + dz * dz, il = 1.0 / sqrt(d2);
                for (int a = 0; a < 3; a++)
                    xi[a][n] = (float)x_i[a];
                ni[0][n] = W0[o];
                ni[1][n] = W1[o];
                ni[2][n] = W2[o];
                wi[0][n] = (float)(dx * il);
                wi[1][n] = (float)(dy * il);
                wi[2][n] = (float)(dz * il);
                /* point light: E = I / |x_p - x_i|^2 ([DalCorso14] eq. inter2 variant) */
                s->w[n] = (double)sw[i] / d2;
                n++;
            }
        }
        /* the block, row by row: weight = texel area in the disk plane, 1/ppu^2 */
        const double wgt0 = 1.0 / (ppu * ppu);
        const int ix0 = bx < 0 ? 0 : bx, ix1 = bx + 3 > size ? size : bx + 3;
        const int iy0 = by < 0 ? 0 : by, iy1 = by + 3 > size ? size : by + 3;
#if defined(OBS_HAVE_AVX2)
        if (block && !li->point && j->use_avx2 && bx >= 0 && by >= 0 && bx + 3 <= size && by + 3 <= size) {
            /* the whole block inside the map: the loop below as one gathered, left-packed vector
             * of 8 texels and the ninth alone (sss_maps_avx2.c; the same values, in order) */
            const sss_i_fetch_in in = {{P0, P1, P2}, {W0, W1, W2}, IID, pst, ist, fcx, fcy, fppu, fsize, inst_o,
                                       {(float)li->to_light[0], (float)li->to_light[1], (float)li->to_light[2]}, bx, by, block,
                                       li->pack, size};
            n = sss_i_exp_block_dir_avx2(&in, wgt0, j->pack_lut, xi, ni, wi, s->w, n);
        } else
#endif
        if (block && !li->point) {
            /* directional: the loop below with its invariants hoisted (the light's direction as
             * float once, local output pointers that alias nothing, so nothing is reloaded after
             * the double store of the weight); the same values appended in the same order */
            const float l0 = (float)li->to_light[0], l1 = (float)li->to_light[1], l2 = (float)li->to_light[2];
            float *restrict X0 = xi[0], *restrict X1 = xi[1], *restrict X2 = xi[2];
            float *restrict N0 = ni[0], *restrict N1 = ni[1], *restrict N2 = ni[2];
            float *restrict L0 = wi[0], *restrict L1 = wi[1], *restrict L2 = wi[2];
            double *restrict SW = s->w;
            for (int iy = iy0; iy < iy1; iy++) {
                const ptrdiff_t ro = (ptrdiff_t)iy * pst, ri = (ptrdiff_t)iy * ist;
                for (int ix = ix0; ix < ix1; ix++) {
                    const ptrdiff_t o = ro + ix;
                    const float px = P0[o];
                    if (px != px || IID[ri + ix] != inst_o)
                        continue;
                    X0[n] = px;
                    X1[n] = P1[o];
                    X2[n] = P2[o];
                    N0[n] = W0[o];
                    N1[n] = W1[o];
                    N2[n] = W2[o];
                    L0[n] = l0;
                    L1[n] = l1;
                    L2[n] = l2;
                    SW[n] = wgt0;
                    n++;
                }
            }
        }
        for (int iy = iy0; block && li->point && iy < iy1; iy++)
            for (int ix = ix0; ix < ix1; ix++) {
                const ptrdiff_t o = (ptrdiff_t)iy * pst + ix;
                const float px = P0[o];
                if (px != px || IID[(ptrdiff_t)iy * ist + ix] != inst_o)
                    continue;
                xi[0][n] = px;
                xi[1][n] = P1[o];
                xi[2][n] = P2[o];
                ni[0][n] = W0[o];
                ni[1][n] = W1[o];
                ni[2][n] = W2[o];
                double dx = li->pos[0] - px, dy = li->pos[1] - P1[o], dz = li->pos[2] - P2[o];
                double d2 = dx * dx + dy * dy + dz * dz, il = 1.0 / sqrt(d2);
                wi[0][n] = (float)(dx * il);
                wi[1][n] = (float)(dy * il);
                wi[2][n] = (float)(dz * il);
                s->w[n] = wgt0 / d2;
                n++;
            }
#undef SSS_IN_BLOCK
    } else if (p->sampler == SSS_SAMPLER_RUSSIAN_ROULETTE) {
        /* [DalCorso14] final shader (#define RUSSIAN_ROULETTE, sss.md 3.4): rho = R sqrt(z1),
         * phi = 2 pi z2, accept if z3 < exp(-sigma* |x_o - x_i|) (3D distance), weight
         * disk_area / (N p) (sss.md 3.5: the unbiased Russian-roulette form). Three draws per
         * candidate, always, so the stream position never depends on the geometry. */
#define SSS_RR_TEST                                                                                    \
    {                                                                                                  \
        double dx = xo[0] - x_i[0], dy = xo[1] - x_i[1], dz = xo[2] - x_i[2];                          \
        double pa = exp(-mi->sigma_star * sqrt(dx * dx + dy * dy + dz * dz));                          \
        if (zeta < pa)                                                                                 \
            SSS_PUSH(j->area / ((double)N * pa));                                                      \
    }
        if (li->rr_prefilter) { /* tables made, directional, orthographic, square texels (maps_fill) */
            /* The pre-filter (sss_maps_internal.h; no bit changes): only candidates that may pass
             * the exact test below get their cos, sin, fetch and exp. Margin: half a texel
             * diagonal (0.7072 texel, as 0.75) plus float rounding of rho, positions and the view
             * matrix (1e-4 R + 1e-5 (|x_o|_inf + R)). */
            sss_i_rr_filter f;
            f.zmax = mi->rr_zmax + (size_t)li->index * SSS_I_RR_BINS; /* = rr_zmax[(material, light)] */
            f.jd = &mi->ed;
            float *fu1 = s->pl[12], *fu2 = s->pl[13], *fz = s->pl[14];
            int nc;
#if defined(OBS_HAVE_AVX2)
            if (j->use_avx2 && (N & 7) == 0) /* whole groups: sss_i_rr_prefilter's AVX2 part alone */
                nc = sss_i_rr_prefilter_avx2(state, N / 8, &f, fu1, fu2, fz);
            else
#endif
                nc = sss_i_rr_prefilter(state, N, &f, fu1, fu2, fz, j->use_avx2);
            for (int q = 0; q < nc; q++) {
                double ox, oy, zeta = fz[q];
                sss_i_rr_offset(R, fu1[q], fu2[q], &ox, &oy);
                SSS_FETCH(ox, oy, SSS_RR_TEST);
            }
        } else {
            for (int i = 0; i < N; i++) {
                double ox, oy, zeta;
                sss_i_rr_candidate(state, R, &ox, &oy, &zeta);
                SSS_FETCH(ox, oy, SSS_RR_TEST);
            }
        }
#undef SSS_RR_TEST
        *cand += (uint64_t)N;
    } else {
        /* [DalCorso14] method.tex (the thesis text): M Halton points, exponential rejection
         * exp(-sigma* rho) > zeta, the N accepted nearest to x_o, weight A_c / N (biased:
         * docs/sss/maps.md measures it), pattern rotated per texel and frame by theta. */
        int visited = 0;
        /* exp(-sigma* R rho_j) and cos, sin of phi_j come from tables made once per build (the same
         * expressions, so the same bits; docs/sss/maps.md "Cost") */
        int na = sss_i_nofm_accept_tab(j->hd, state, mi->nofm_p, N, s->idx, &visited);
        double ct = cos(theta), st = sin(theta);
        for (int q = 0; q < na; q++) {
            int i = s->idx[q];
            double rho = R * j->hd->rho[i];
            double ox0 = rho * j->hd_cos[i], oy0 = rho * j->hd_sin[i];
            double ox = ct * ox0 - st * oy0, oy = st * ox0 + ct * oy0;
            SSS_FETCH(ox, oy, { SSS_PUSH(j->area / (double)N); });
        }
        *cand += (uint64_t)visited;
    }
#undef SSS_FETCH
#undef SSS_PUSH
    return n;
}

static void build_task(void *user, int64_t task, int thread)
{
    build_job *j = (build_job *)user;
    const sss_params *p = j->p;
    sss_maps *m = j->maps;
    const int k = (int)(task / j->tiles);
    int x0, y0, x1, y1;
    obs_tiling_rect(&j->tiling, task % j->tiles, &x0, &y0, &x1, &y1);
    const rast_gbuffer *gb = &m->views[k];
    sss_i_view_geo vg; /* the view's constants in double, once per task (same bits as the helpers) */
    sss_i_view_geo_make(&gb->constants, &vg);
    scratch *s = &j->scr[thread];
    uint64_t evaluated = 0, cand = 0;
    /* the streams' seeds of a row, 8 texels per vector (one frame, AVX2): the same values as
     * sss_i_stream_seed per texel */
#if defined(OBS_HAVE_AVX2)
    const int row_seeds = p->frames == 1 && j->use_avx2;
#else
    const int row_seeds = 0; /* built without the AVX2 files: per-texel seeds (the same values) */
    (void)row_seeds;
#endif
    for (int y = y0; y < y1; y++) {
        /* row_seeds: the seeds of a block of 8 texels are made when its first covered texel is
         * met (blocks with none are skipped) */
        int seeded = -1; /* the block of s->seeds made last in this row */
        (void)seeded;
        /* Every texel of the tile is written, 0 off the object and on opaque surfaces: the radiance
         * planes are allocated uninitialised (obs_image_f32_alloc_uninit) and a rebuild
         * (sss_maps_rebuild) writes over the previous maps, so nothing may be left unwritten
         * (test sss_maps_rebuild_leaves_no_texel_unwritten, with OBS_POISON_UNINIT=1). */
        const float *drow = obs_image_f32_row(&gb->depth, y);
        float *orow[3];
        for (int c = 0; c < 3; c++)
            orow[c] = obs_image_f32_row(&m->radiance[3 * k + c], y);
        for (int x = x0; x < x1; x++) {
            const float depth = drow[x];
            float *out[3];
            for (int c = 0; c < 3; c++) {
                out[c] = orow[c] + x;
                out[c][0] = 0.0f;
            }
            if (!(depth < INFINITY))
                continue;
            const mat_info *mi = job_material(j, obs_image_u32_row(&gb->material_id, y)[x]);
            if (!mi)
                continue; /* opaque: no subsurface radiance */
            uint32_t inst = obs_image_u32_row(&gb->instance_id, y)[x];
            double xo[3], no[3];
            float nv[3] = {obs_image_f32_row(&gb->normal[0], y)[x], obs_image_f32_row(&gb->normal[1], y)[x],
                           obs_image_f32_row(&gb->normal[2], y)[x]};
            sss_i_geo_pixel_world(&vg, x + 0.5, y + 0.5, depth, xo);
            sss_i_geo_normal_world(&vg, nv, no);
            float xof[3] = {(float)xo[0], (float)xo[1], (float)xo[2]};
            float nof[3] = {(float)no[0], (float)no[1], (float)no[2]};
            double acc[3] = {0, 0, 0};
            for (int f = 0; f < p->frames; f++) {
                uint32_t state;
#if defined(OBS_HAVE_AVX2)
                if (row_seeds) {
                    const int blk = (x - x0) >> 3;
                    if (blk != seeded) {
                        sss_i_stream_seeds_avx2((uint32_t)(y * m->size + x0 + 8 * blk), 8, (uint32_t)k, p->seed,
                                                s->seeds + 8 * blk);
                        seeded = blk;
                    }
                    state = s->seeds[x - x0];
                } else
#endif
                    state = sss_i_stream_seed((uint32_t)(y * m->size + x), (uint32_t)(k * p->frames + f), p->seed);
                double theta = 0.0;
                if (p->sampler == SSS_SAMPLER_NEAREST_N_OF_M) /* theta = 2 pi (r + t/T), [DalCorso14] method.tex */
                    theta = 2.0 * OBS_PI * ((double)sss_i_rand(&state) + (double)f / p->frames);
                for (int l = 0; l < j->light_count; l++) {
                    const light_info *li = &j->lights[l];
                    int n = gather_light(j, li, xo, inst, mi, &state, theta, s, &cand);
                    if (n == 0)
                        continue;
                    sss_batch b;
                    b.n = n;
                    for (int a = 0; a < 3; a++) {
                        b.xi[a] = s->pl[a];
                        b.ni[a] = s->pl[3 + a];
                        b.wi[a] = s->pl[6 + a];
                        b.out[a] = s->pl[9 + a];
                    }
                    /* With AVX2, round up to whole vectors: the lanes past n hold whatever earlier
                     * batches left there (finite samples, or the zeros the scratch is allocated
                     * with) and their outputs are not summed; every lane is independent, so the n
                     * real outputs are the scalar path's bits, and the tail does not run on the
                     * (8x slower) scalar path. */
                    if (j->use_avx2 && (n & 7))
                        b.n = (n + 7) & ~7;
                    /* T12 S_d per sample ([DalCorso14] eq. inter2: L_d A_c/N sum S e^{sigma r}):
                     * sss_eval_batch's two paths, called directly (the arguments are checked
                     * once, in sss_maps_build; the ISA is resolved once, not per call) */
#if defined(OBS_HAVE_AVX2)
                    if (j->use_avx2) {
                        sss_i_eval_avx2(&mi->g, xof, nof, &b, 1, 0, b.n / 8);
                        sss_i_eval_scalar(&mi->g, xof, nof, &b, 1, b.n / 8 * 8, b.n);
                    } else
#endif
                        sss_i_eval_scalar(&mi->g, xof, nof, &b, 1, 0, b.n);
                    evaluated += (uint64_t)n;
                    if (p->sampler == SSS_SAMPLER_EXPONENTIAL) {
                        /* four interleaved partial sums (sample q into q mod 4), then
                         * (s0 + s1) + (s2 + s3): a fixed order that the compiler can vectorise */
                        const int n4 = n & ~3;
#if defined(OBS_HAVE_AVX2)
                        if (j->use_avx2) {
                            double sums[3];
                            const float *const outs[3] = {b.out[0], b.out[1], b.out[2]};
                            sss_i_wsum3_avx2(s->w, outs, n, sums);
                            for (int c = 0; c < 3; c++)
                                acc[c] += li->radiance[c] * sums[c];
                            continue;
                        }
#endif
                        for (int c = 0; c < 3; c++) {
                            const float *o = b.out[c];
                            double a0 = 0.0, a1 = 0.0, a2 = 0.0, a3 = 0.0;
                            for (int q = 0; q < n4; q += 4) {
                                a0 += s->w[q] * (double)o[q];
                                a1 += s->w[q + 1] * (double)o[q + 1];
                                a2 += s->w[q + 2] * (double)o[q + 2];
                                a3 += s->w[q + 3] * (double)o[q + 3];
                            }
                            if (n4 < n)
                                a0 += s->w[n4] * (double)o[n4];
                            if (n4 + 1 < n)
                                a1 += s->w[n4 + 1] * (double)o[n4 + 1];
                            if (n4 + 2 < n)
                                a2 += s->w[n4 + 2] * (double)o[n4 + 2];
                            acc[c] += li->radiance[c] * ((a0 + a1) + (a2 + a3));
                        }
                    } else {
                        /* sequential (the order the rr and N-of-M maps were pinned with) */
                        for (int c = 0; c < 3; c++) {
                            double sum = 0.0;
                            for (int q = 0; q < n; q++)
                                sum += s->w[q] * (double)b.out[c][q];
                            acc[c] += li->radiance[c] * sum;
                        }
                    }
                }
            }
            /* progressive accumulation over frames, divided by the frame count
             * ([DalCorso14] sss.md 3.3: R^{t,k} = R^{t-1,k} + R^{t,k}, / t in the combination) */
            for (int c = 0; c < 3; c++) /* acc / 1 is acc: the division only when it can change a bit */
                out[c][0] = (float)(p->frames == 1 ? acc[c] : acc[c] / p->frames);
        }
    }
    j->evaluated[task] = evaluated;
    j->candidates[task] = cand;
}

/* ------------------------------------------------------------------------------------------------
 * The workspace: everything a build allocates besides the maps themselves, kept between rebuilds
 * (sss.h, sss_maps_rebuild). Every buffer grows only; a rebuild of the same configuration finds
 * them all large enough and allocates nothing.
 * ---------------------------------------------------------------------------------------------- */

struct sss_maps_workspace {
    scratch *scr;              /* per thread */
    int scr_threads, scr_np, scr_idx;
    mat_info *mi;              /* mats->count + 1 */
    size_t mi_cap;
    light_info *li;            /* light_count */
    size_t li_cap;
    uint32_t **pack;           /* per light: the exponential sampler's interleaved light map */
    size_t *pack_cap;          /* elements of pack[l] */
    size_t pack_lights;        /* entries of pack and pack_cap */
    rast_view *views;          /* K */
    size_t views_cap;
    uint64_t *evaluated, *candidates; /* K x tiles */
    uint8_t *failed;
    size_t tasks_cap, cand_cap, failed_cap;
    uint32_t *rr_zmax;         /* (count + 1) x lights x SSS_I_RR_BINS */
    size_t rr_cap;
    double *nofm_p;            /* (count + 1) x M */
    size_t nofm_cap;
    sss_i_halton_disk hd;      /* N-of-M candidates, made for hd.M (0: not made) */
    double *hd_cos, *hd_sin;   /* hd.M */
    rast_workspace *rast;      /* the rasterizer's scratch (rast_render_ws) */
};

sss_maps_workspace *sss_maps_workspace_create(void)
{
    sss_maps_workspace *ws = (sss_maps_workspace *)calloc(1, sizeof *ws);
    if (!ws)
        return NULL;
    ws->rast = rast_workspace_create();
    if (!ws->rast) {
        free(ws);
        return NULL;
    }
    return ws;
}

static void ws_free_scratch(sss_maps_workspace *ws)
{
    for (int t = 0; ws->scr && t < ws->scr_threads; t++) {
        free(ws->scr[t].buf);
        free(ws->scr[t].w);
        free(ws->scr[t].idx);
    }
    free(ws->scr);
    ws->scr = NULL;
    ws->scr_threads = ws->scr_np = ws->scr_idx = 0;
}

void sss_maps_workspace_free(sss_maps_workspace *ws)
{
    if (!ws)
        return;
    ws_free_scratch(ws);
    free(ws->mi);
    free(ws->li);
    for (size_t l = 0; l < ws->pack_lights; l++)
        free(ws->pack[l]);
    free(ws->pack);
    free(ws->pack_cap);
    free(ws->views);
    free(ws->evaluated);
    free(ws->candidates);
    free(ws->failed);
    free(ws->rr_zmax);
    free(ws->nofm_p);
    sss_i_halton_disk_free(&ws->hd);
    free(ws->hd_cos);
    free(ws->hd_sin);
    rast_workspace_destroy(ws->rast);
    free(ws);
}

/* *p holds at least `need` elements of `elem` bytes (contents not kept); returns 0 when out of memory. */
static int ws_grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap && *p)
        return 1;
    free(*p);
    *p = malloc(elem * (need > 0 ? need : 1));
    *cap = *p ? need : 0;
    return *p != NULL;
}

/* The per-thread scratch: buf zeroed when (re)allocated (the batches' pad lanes, see build_task:
 * afterwards they hold finite samples of earlier batches, which is all the pad lanes need). */
static int ws_scratch(sss_maps_workspace *ws, int threads, int np, int nidx)
{
    if (ws->scr && threads <= ws->scr_threads && np <= ws->scr_np && nidx <= ws->scr_idx)
        return 1;
    ws_free_scratch(ws);
    ws->scr = (scratch *)calloc((size_t)threads, sizeof(scratch));
    if (!ws->scr)
        return 0;
    ws->scr_threads = threads;
    for (int t = 0; t < threads; t++) {
        ws->scr[t].buf = (float *)calloc(15 * (size_t)np, sizeof(float));
        ws->scr[t].w = (double *)malloc(sizeof(double) * (size_t)np);
        ws->scr[t].idx = (int *)malloc(sizeof(int) * (size_t)nidx);
        if (!ws->scr[t].buf || !ws->scr[t].w || !ws->scr[t].idx) {
            ws_free_scratch(ws);
            return 0;
        }
    }
    ws->scr_np = np;
    ws->scr_idx = nidx;
    return 1;
}

/* The checks common to a build and a rebuild; on OK, the scene's framing sphere in c, *rad. */
static obs_status maps_check(obs_context *ctx, const char *fn, const obs_scene *scene, const sss_scene_materials *mats,
                             const sss_light_map *lights, int light_count, const sss_params *p, double c[3],
                             double *rad)
{
    if (!scene || !mats || !p || light_count < 0 || (light_count > 0 && !lights))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: NULL argument or negative light count", fn);
    obs_status st = sss_params_validate(ctx, p);
    if (st != OBS_STATUS_OK)
        return st;
    if (p->isa != SSS_ISA_AUTO && !sss_isa_available(p->isa))
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED_ISA, "sss: ISA %s is not available", sss_isa_name(p->isa));
    if (mats->count > 0 && (!mats->constants || !mats->translucent))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: materials without constants", fn);
    for (int l = 0; l < light_count; l++)
        if (!lights[l].position[0].data || !lights[l].gb.instance_id.data)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: light map %d is not rendered", fn, l);
    return sss_i_scene_sphere(ctx, scene, c, rad);
}

/* The maps' own storage for p: K directions, K view G-buffers and 3K radiance planes, none of them
 * zeroed (rast_render_ws writes every G-buffer element, build_task every radiance texel). */
static obs_status maps_alloc(obs_context *ctx, const sss_params *p, sss_maps *out)
{
    const int K = p->K, size = p->map_size;
    out->K = K;
    out->size = size;
    out->dirs = (double *)malloc(sizeof(double) * 3 * (size_t)K);
    out->views = (rast_gbuffer *)calloc((size_t)K, sizeof(rast_gbuffer));
    out->radiance = (obs_image_f32 *)calloc(3 * (size_t)K, sizeof(obs_image_f32));
    if (!out->dirs || !out->views || !out->radiance)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "sss_maps_build: out of memory");
    rast_params rp = gbuffer_params(size);
    obs_status st;
    for (int k = 0; k < K; k++)
        if ((st = rast_gbuffer_alloc_uninit(ctx, &rp, &out->views[k])) != OBS_STATUS_OK)
            return st;
    for (int i = 0; i < 3 * K; i++)
        if ((st = obs_image_f32_alloc_uninit(ctx, size, size, &out->radiance[i])) != OBS_STATUS_OK)
            return st;
    return OBS_STATUS_OK;
}

#define WS_OOM(ctx) obs_error((ctx), OBS_STATUS_OUT_OF_MEMORY, "sss_maps_build: out of memory")

/* Pass 2 into allocated maps `out` (K, size of p) with the temporaries of ws: the K views
 * rendered, then every radiance texel written. */
static obs_status maps_fill(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const sss_scene_materials *mats,
                            const sss_light_map *lights, int light_count, const sss_params *p, const double c[3],
                            double rad, sss_maps_workspace *ws, sss_maps *out)
{
    const int K = p->K, size = p->map_size;
    obs_status st = OBS_STATUS_OK;
    build_job job;
    memset(&job, 0, sizeof job);
    int threads = pool ? obs_pool_threads(pool) : 1;
    if (threads < 1)
        threads = 1;
    out->samples_evaluated = 0;
    out->candidates = 0;

    if (!ws_grow((void **)&ws->views, &ws->views_cap, (size_t)K, sizeof(rast_view)) ||
        !ws_grow((void **)&ws->mi, &ws->mi_cap, (size_t)mats->count + 1, sizeof(mat_info)) ||
        !ws_grow((void **)&ws->li, &ws->li_cap, (size_t)(light_count > 0 ? light_count : 1), sizeof(light_info)))
        return WS_OOM(ctx);
    rast_view *views = ws->views;
    mat_info *mi = ws->mi;
    light_info *li = ws->li;
    memset(views, 0, sizeof(rast_view) * (size_t)K);
    memset(mi, 0, sizeof(mat_info) * ((size_t)mats->count + 1));
    memset(li, 0, sizeof(light_info) * (size_t)(light_count > 0 ? light_count : 1));

    /* K directions [DalCorso14] haltonPointSphere; orthographic views looking at the bounds'
     * centre (sss.md 3.2) */
    sss_halton_directions(K, out->dirs);
    for (int k = 0; k < K; k++)
        views[k].camera = ortho_camera(c, out->dirs + 3 * k, rad);
    rast_params rp = gbuffer_params(size);
    if (sss_i_maps_cull_back)
        rp.cull = RAST_CULL_BACK; /* test hook only (sss_maps_internal.h): not bit-identical in general */
    /* one layered render, as the thesis' geometry shader with gl_Layer */
    if ((st = rast_render_ws(ctx, pool, ws->rast, scene, views, K, &rp, out->views, NULL)) != OBS_STATUS_OK)
        return st;

    for (uint32_t i = 0; i <= mats->count; i++) {
        const sss_constants *cc = (i < mats->count) ? ((mats->translucent[i]) ? &mats->constants[i] : NULL) : mats->none;
        if (!cc)
            continue;
        mi[i].c = cc;
        sss_gpu_constants_make(cc, p->model, &mi[i].g);
        mi[i].sigma_star = cc->min_sigma_tr / p->spread_q; /* sigma* = min sigma_tr / q (sss.md 3.4) */
    }
    /* disk radius: params, else half the diagonal of the bounds ([DalCorso14]: "the size of the
     * object bounding box"; sss.md 3.5) */
    job.R = p->disk_radius > 0.0 ? p->disk_radius : rad;
    job.area = OBS_PI * job.R * job.R;
    job.np = (p->N + 9 + 7) & ~7; /* + the exponential sampler's 3 x 3 near-field texels */
    sss_i_pack_lut_make(job.pack_lut);
    for (uint32_t i = 0; i <= mats->count; i++)
        if (mi[i].c)
            sss_i_exp_disk_make(mi[i].sigma_star, job.R, p->N, &mi[i].ed);
    if (p->isa == SSS_ISA_AVX2)
        job.use_avx2 = 1;
    else if (p->isa == SSS_ISA_AUTO) {
        const char *env = getenv("OBS_ISA");
        job.use_avx2 = !(env && !strcmp(env, "scalar")) && sss_isa_available(SSS_ISA_AVX2);
    }
    if ((size_t)light_count > ws->pack_lights) {
        uint32_t **np_ = (uint32_t **)realloc(ws->pack, sizeof(uint32_t *) * (size_t)light_count);
        if (!np_)
            return WS_OOM(ctx);
        ws->pack = np_;
        size_t *nc_ = (size_t *)realloc(ws->pack_cap, sizeof(size_t) * (size_t)light_count);
        if (!nc_)
            return WS_OOM(ctx);
        ws->pack_cap = nc_;
        for (size_t l = ws->pack_lights; l < (size_t)light_count; l++) {
            ws->pack[l] = NULL;
            ws->pack_cap[l] = 0;
        }
        ws->pack_lights = (size_t)light_count;
    }
    for (int l = 0; l < light_count; l++) {
        const obs_light *L = &lights[l].light;
        li[l].lm = &lights[l];
        sss_i_view_geo_make(&lights[l].gb.constants, &li[l].geo);
        li[l].point = L->type == OBS_LIGHT_POINT;
        double dl = sqrt((double)L->direction.x * L->direction.x + (double)L->direction.y * L->direction.y +
                         (double)L->direction.z * L->direction.z);
        if (dl > 0.0) {
            li[l].to_light[0] = -L->direction.x / dl;
            li[l].to_light[1] = -L->direction.y / dl;
            li[l].to_light[2] = -L->direction.z / dl;
        }
        li[l].pos[0] = L->position.x;
        li[l].pos[1] = L->position.y;
        li[l].pos[2] = L->position.z;
        li[l].radiance[0] = (double)L->color.x * L->intensity;
        li[l].radiance[1] = (double)L->color.y * L->intensity;
        li[l].radiance[2] = (double)L->color.z * L->intensity;
        if (p->sampler == SSS_SAMPLER_EXPONENTIAL && job.use_avx2 && !li[l].point) {
            /* the light map interleaved for the AVX2 fetch (sss_i_fetch_in.pack): the samples'
             * gathers of seven planes at random texels were most of the build's L1 misses */
            const int lw = lights[l].gb.width, lh = lights[l].gb.height;
            if (!ws_grow((void **)&ws->pack[l], &ws->pack_cap[l], 8 * (size_t)lw * (size_t)lh, sizeof(uint32_t)))
                return WS_OOM(ctx);
            li[l].pack = ws->pack[l];
            for (int y = 0; y < lh; y++) {
                const float *pr[3], *wr[3];
                for (int a = 0; a < 3; a++) {
                    pr[a] = obs_image_f32_row(&lights[l].position[a], y);
                    wr[a] = obs_image_f32_row(&lights[l].wnormal[a], y);
                }
                const uint32_t *ir = obs_image_u32_row(&lights[l].gb.instance_id, y);
                for (int x = 0; x < lw; x++) {
                    uint32_t *r = li[l].pack + 8 * ((size_t)y * (size_t)lw + (size_t)x);
                    for (int a = 0; a < 3; a++) {
                        memcpy(&r[a], &pr[a][x], sizeof(float));
                        memcpy(&r[3 + a], &wr[a][x], sizeof(float));
                    }
                    r[6] = ir[x];
                    r[7] = 0u;
                }
            }
        }
    }
    if (p->sampler == SSS_SAMPLER_NEAREST_N_OF_M) {
        if (ws->hd.M != p->M || !ws->hd.rho) {
            /* the candidate set depends on M only: made once per workspace and M */
            sss_i_halton_disk_free(&ws->hd);
            free(ws->hd_cos);
            free(ws->hd_sin);
            ws->hd_cos = ws->hd_sin = NULL;
            if ((st = sss_i_halton_disk_make(ctx, p->M, &ws->hd)) != OBS_STATUS_OK)
                return st;
            ws->hd_cos = (double *)malloc(sizeof(double) * (size_t)p->M);
            ws->hd_sin = (double *)malloc(sizeof(double) * (size_t)p->M);
            if (!ws->hd_cos || !ws->hd_sin) {
                sss_i_halton_disk_free(&ws->hd); /* made again next time */
                return WS_OOM(ctx);
            }
            for (int i = 0; i < p->M; i++) {
                ws->hd_cos[i] = cos((double)ws->hd.phi[i]);
                ws->hd_sin[i] = sin((double)ws->hd.phi[i]);
            }
        }
        job.hd_cos = ws->hd_cos;
        job.hd_sin = ws->hd_sin;
        if (!ws_grow((void **)&ws->nofm_p, &ws->nofm_cap, ((size_t)mats->count + 1) * (size_t)p->M, sizeof(double)))
            return WS_OOM(ctx);
        const double Rd = p->disk_radius > 0.0 ? p->disk_radius : rad;
        for (uint32_t i = 0; i <= mats->count; i++) {
            if (!mi[i].c)
                continue;
            mi[i].nofm_p = ws->nofm_p + (size_t)i * (size_t)p->M;
            const double sigma_r = mi[i].sigma_star * Rd; /* as gather_light's sigma* R */
            for (int q = 0; q < p->M; q++)
                mi[i].nofm_p[q] = exp(-sigma_r * (double)ws->hd.rho[q]);
        }
    }
    if (p->sampler == SSS_SAMPLER_RUSSIAN_ROULETTE && !sss_i_rr_prefilter_off && light_count > 0) {
        /* the pre-filter's bound tables (sss_maps_internal.h), per material and light; the margin
         * m at its largest over the scene: half a texel diagonal (0.7072 texel, as 0.75) plus
         * float rounding of rho, positions and the view matrix (1e-4 R + 1e-5 (|x_o|_inf + R),
         * |x_o|_inf <= the bounds' largest |coordinate| + their radius) */
        const obs_aabb *bb = &scene->bounds;
        const double xmax = fmax(fmax(fmax(fabs(bb->lo.x), fabs(bb->hi.x)), fmax(fabs(bb->lo.y), fabs(bb->hi.y))),
                                 fmax(fabs(bb->lo.z), fabs(bb->hi.z))) + rad;
        if (!ws_grow((void **)&ws->rr_zmax, &ws->rr_cap,
                     (size_t)SSS_I_RR_BINS * ((size_t)mats->count + 1) * (size_t)light_count, sizeof(uint32_t)))
            return WS_OOM(ctx);
        job.rr_zmax = ws->rr_zmax;
        for (uint32_t i = 0; i <= mats->count; i++)
            for (int l = 0; l < light_count; l++) {
                const double ppu = lights[l].gb.constants.fx;
                const double m = 0.75 / ppu + 1e-4 * job.R + 1e-5 * (xmax + job.R);
                uint32_t *t = job.rr_zmax + ((size_t)i * (size_t)light_count + (size_t)l) * SSS_I_RR_BINS;
                if (mi[i].c)
                    sss_i_rr_table_make(mi[i].sigma_star, job.R, m, t);
                else
                    for (int b = 0; b < SSS_I_RR_BINS; b++)
                        t[b] = 16777217u;
            }
        /* where gather_light may use them (the condition it tested per call before) */
        for (uint32_t i = 0; i <= mats->count; i++)
            mi[i].rr_zmax = job.rr_zmax + (size_t)i * (size_t)light_count * SSS_I_RR_BINS;
        for (int l = 0; l < light_count; l++) {
            li[l].index = l;
            const rast_view_constants *lvc = &lights[l].gb.constants;
            li[l].rr_prefilter = !li[l].point && lvc->projection_type == OBS_PROJECTION_ORTHOGRAPHIC &&
                                 fabs(lvc->fx - lvc->fy) <= 1e-9 * lvc->fx;
        }
    }
    if (!ws_scratch(ws, threads, job.np, p->M > p->N ? p->M : p->N))
        return WS_OOM(ctx);
    job.scr = ws->scr;
    for (int t = 0; t < threads; t++)
        for (int q = 0; q < 15; q++)
            ws->scr[t].pl[q] = ws->scr[t].buf + (size_t)q * (size_t)job.np;
    job.p = p;
    job.maps = out;
    job.tiling = obs_tiling_make(size, size, 32);
    job.tiles = obs_tiling_count(&job.tiling);
    job.lights = li;
    job.light_count = light_count;
    job.mats = mi;
    job.mat_count = mats->count;
    job.hd = &ws->hd;
    int64_t tasks = (int64_t)K * job.tiles;
    if (!ws_grow((void **)&ws->evaluated, &ws->tasks_cap, (size_t)tasks, sizeof(uint64_t)) ||
        !ws_grow((void **)&ws->candidates, &ws->cand_cap, (size_t)tasks, sizeof(uint64_t)) ||
        !ws_grow((void **)&ws->failed, &ws->failed_cap, (size_t)tasks, 1))
        return WS_OOM(ctx);
    job.evaluated = ws->evaluated;
    job.candidates = ws->candidates;
    job.failed = ws->failed;
    memset(job.evaluated, 0, sizeof(uint64_t) * (size_t)tasks);
    memset(job.candidates, 0, sizeof(uint64_t) * (size_t)tasks);
    memset(job.failed, 0, (size_t)tasks);
    obs_pool_run(pool, tasks, build_task, &job);
    for (int64_t t = 0; t < tasks; t++) {
        out->samples_evaluated += job.evaluated[t];
        out->candidates += job.candidates[t];
        if (job.failed[t] && st == OBS_STATUS_OK)
            st = obs_error(ctx, OBS_STATUS_INTERNAL, "sss_maps_build: sss_eval_batch failed");
    }
    return st;
}

obs_status sss_maps_build(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const sss_scene_materials *mats,
                          const sss_light_map *lights, int light_count, const sss_params *p, sss_maps *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_maps_build: NULL output");
    memset(out, 0, sizeof *out);
    double c[3], rad;
    obs_status st = maps_check(ctx, "sss_maps_build", scene, mats, lights, light_count, p, c, &rad);
    if (st != OBS_STATUS_OK)
        return st;
    sss_maps_workspace *ws = sss_maps_workspace_create();
    if (!ws)
        return WS_OOM(ctx);
    if ((st = maps_alloc(ctx, p, out)) == OBS_STATUS_OK)
        st = maps_fill(ctx, pool, scene, mats, lights, light_count, p, c, rad, ws, out);
    sss_maps_workspace_free(ws);
    if (st != OBS_STATUS_OK)
        sss_maps_free(out);
    return st;
}

obs_status sss_maps_rebuild(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const sss_scene_materials *mats,
                            const sss_light_map *lights, int light_count, const sss_params *p, sss_maps_workspace *ws,
                            sss_maps *maps)
{
    if (!maps)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_maps_rebuild: NULL maps");
    double c[3], rad;
    obs_status st = maps_check(ctx, "sss_maps_rebuild", scene, mats, lights, light_count, p, c, &rad);
    if (st != OBS_STATUS_OK)
        return st;
    const int empty = maps->K == 0 && maps->size == 0 && !maps->dirs && !maps->views && !maps->radiance;
    if (!empty) {
        if (!maps->dirs || !maps->views || !maps->radiance || maps->K < 1 || maps->size < 1)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "sss_maps_rebuild: the maps are neither zeroed nor built (K %d, size %d)", maps->K,
                             maps->size);
        if (maps->K != p->K || maps->size != p->map_size)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "sss_maps_rebuild: the maps hold K = %d layers of %d^2 texels but the params ask for "
                             "K = %d, map_size = %d; free them and build (sss_maps_build) for a new layout",
                             maps->K, maps->size, p->K, p->map_size);
        const rast_gbuffer *v = &maps->views[0];
        const rast_params rp = gbuffer_params(p->map_size);
        for (int k = 0; k < maps->K; k++)
            if (maps->views[k].width != v->width || maps->views[k].height != v->height ||
                (maps->views[k].outputs & rp.outputs) != rp.outputs)
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_maps_rebuild: view %d is not a maps layer", k);
        for (int i = 0; i < 3 * maps->K; i++)
            if (!maps->radiance[i].data || maps->radiance[i].width != p->map_size ||
                maps->radiance[i].height != p->map_size)
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_maps_rebuild: radiance plane %d is not %d^2",
                                 i, p->map_size);
    }
    sss_maps_workspace *tmp = NULL;
    if (!ws && !(ws = tmp = sss_maps_workspace_create()))
        return WS_OOM(ctx);
    st = empty ? maps_alloc(ctx, p, maps) : OBS_STATUS_OK;
    if (st == OBS_STATUS_OK)
        st = maps_fill(ctx, pool, scene, mats, lights, light_count, p, c, rad, ws, maps);
    sss_maps_workspace_free(tmp);
    if (st != OBS_STATUS_OK)
        sss_maps_free(maps);
    return st;
}
