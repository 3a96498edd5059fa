/* sss_combine.c: pass 3 of the scattering-map pipeline [DalCorso17] / [DalCorso14]: for one camera
 * G-buffer, the visibility-weighted mean of the K scattering maps, times T21, plus an optional
 * specular term, then ^(1/gamma) (sss.md 3.6; ss_array_combination.frag). docs/sss/maps.md. */
#include "sss_maps_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* One binary shadow tap of map layer gb at continuous pixel position (px, py): the texel
 * containing (px, py), clamped to the edge (GL_CLAMP_TO_EDGE), is lit when the receiver's depth
 * at that texel's centre, minus the bias, is <= the stored depth (GL_LEQUAL; empty texels hold
 * +inf and pass, as a depth buffer cleared to far). The receiver's depth at the texel centre
 * comes from its tangent plane (receiver-plane depth, [Isidoro06]), not the constant depth of
 * x_o that a GL shadow sampler compares: a deviation (docs/sss/maps.md, "Visibility"): with a
 * constant depth, taps 1.5 texels away fail on any surface tilted more than bias / 1.5 texels. */
static double shadow_tap(const rast_gbuffer *gb, double px, double py, const sss_i_depth_plane *pl, double bias)
{
    int ix = (int)floor(px), iy = (int)floor(py);
    if (ix < 0)
        ix = 0;
    if (iy < 0)
        iy = 0;
    if (ix >= gb->width)
        ix = gb->width - 1;
    if (iy >= gb->height)
        iy = gb->height - 1;
    double d = pl->d0 + pl->gx * (ix + 0.5 - pl->px0) + pl->gy * (iy + 0.5 - pl->py0);
    return d - bias <= (double)obs_image_f32_row(&gb->depth, iy)[ix] ? 1.0 : 0.0;
}

double sss_i_visibility(const rast_gbuffer *gb, sss_visibility mode, double px, double py,
                        const sss_i_depth_plane *pl, double bias)
{
    if (mode == SSS_VISIBILITY_PRODUCT5) {
        /* [DalCorso14] ss_array_combination.frag (sss.md 3.6): the PRODUCT of 5 taps, the centre and
         * a rotated grid at +-0.5 texel x (1, 3) (reconstruction of the offsets' signs:
         * (0.5, 1.5), (-1.5, 0.5), (-0.5, -1.5), (1.5, -0.5)). Any shadowed tap gives 0. */
        static const double off[5][2] = {{0, 0}, {0.5, 1.5}, {-1.5, 0.5}, {-0.5, -1.5}, {1.5, -0.5}};
        double v = 1.0;
        for (int t = 0; t < 5 && v > 0.0; t++)
            v *= shadow_tap(gb, px + off[t][0], py + off[t][1], pl, bias);
        return v;
    }
    /* 3x3 percentage-closer filtering: the mean of 9 binary taps one texel apart (the brief's
     * variant; [UNVERIFIED] for the paper, sss.md 3.6) */
    double v = 0.0;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++)
            v += shadow_tap(gb, px + dx, py + dy, pl, bias);
    return v / 9.0;
}

typedef struct combine_job {
    const sss_scene_materials *mats;
    const sss_maps *maps;
    const sss_light_map *lights;
    int light_count;
    const rast_gbuffer *gb;
    const obs_camera *camera;
    const sss_params *p;
    obs_image_f32 *out;
    obs_image_f32 *count;
    obs_tiling tiling;
    double eps_world;    /* shrink distance, world units */
    double bias_world;   /* shadow bias, world units */
    sss_i_combine_map *cm; /* K */
    int use_avx2;          /* the AVX2 map loop (PRODUCT5 only) */
} combine_job;

/* shadow_tap with the map's constants: (int) truncation then the clamp equals floor then the
 * clamp (a position in (-1, 0) truncates to 0, one <= -1 to a negative index, both clamp to 0) */
static inline int tap_fast(const sss_i_combine_map *c, double px, double py, double d0, double px0, double py0, double gx,
                           double gy, double bias)
{
    int ix = (int)px, iy = (int)py;
    ix = ix < 0 ? 0 : ix >= c->W ? c->W - 1 : ix;
    iy = iy < 0 ? 0 : iy >= c->H ? c->H - 1 : iy;
    double d = d0 + gx * (ix + 0.5 - px0) + gy * (iy + 0.5 - py0);
    return d - bias <= (double)c->depth[(ptrdiff_t)iy * c->dstride + ix];
}

/* The map loop of one pixel, scalar: acc = sum_k V_k R_k, sumv = sum_k V_k, seen = #{k: V_k > 0} in
 * the order k = 0..K-1 (sss_combine_avx2.c does 4 pixels at once with the same operations). */
static void pixel_maps_scalar(const combine_job *j, const double xo[3], const double no[3], double acc[3], double *sumv_,
                              int *seen_)
{
    const sss_maps *m = j->maps;
    const sss_params *p = j->p;
    double sumv = 0.0;
    int seen = 0;
    acc[0] = acc[1] = acc[2] = 0.0;
    const int product5 = p->visibility == SSS_VISIBILITY_PRODUCT5;
    for (int k = 0; k < m->K; k++) {
        const sss_i_combine_map *c = &j->cm[k];
        /* a point that faces away from direction k (or grazes it) is not seen by map k
         * (tested first: it does not depend on the shrink) */
        const double nvz = (c->r2[0] * no[0] + c->r2[1] * no[1]) + c->r2[2] * no[2];
        if (!(nvz > SSS_I_MIN_FACING))
            continue;
        const double *wd = c->wd;
        const double nd = no[0] * wd[0] + no[1] * wd[1] + no[2] * wd[2];
        /* shrink along the tangent plane of direction k: x_o - eps_c (n_o - w_d (n_o.w_d))
         * ([DalCorso14] ss_array_combination.frag, sss.md 3.6) */
        double xs[3];
        for (int a = 0; a < 3; a++)
            xs[a] = xo[a] - j->eps_world * (no[a] - wd[a] * nd);
        /* sss_i_project of xs (orthographic maps) */
        const double px = c->cx + c->fx * (((c->r0[0] * xs[0] + c->r0[1] * xs[1]) + c->r0[2] * xs[2]) + c->r0[3]);
        const double py = c->cy - c->fy * (((c->r1[0] * xs[0] + c->r1[1] * xs[1]) + c->r1[2] * xs[2]) + c->r1[3]);
        if (px < 0.0 || py < 0.0 || px >= c->W || py >= c->H)
            continue;
        /* the receiver plane through the UNshrunk x_o (the maps are orthographic):
         * depth(px, py) = d0 + gx (px - px0) + gy (py - py0) from n_o in view space */
        const double nvx = (c->r0[0] * no[0] + c->r0[1] * no[1]) + c->r0[2] * no[2];
        const double nvy = (c->r1[0] * no[0] + c->r1[1] * no[1]) + c->r1[2] * no[2];
        const double px0 = c->cx + c->fx * (((c->r0[0] * xo[0] + c->r0[1] * xo[1]) + c->r0[2] * xo[2]) + c->r0[3]);
        const double py0 = c->cy - c->fy * (((c->r1[0] * xo[0] + c->r1[1] * xo[1]) + c->r1[2] * xo[2]) + c->r1[3]);
        const double d0 = -((((c->r2[0] * xo[0] + c->r2[1] * xo[1]) + c->r2[2] * xo[2]) + c->r2[3]));
        /* view z - z0 = -(nx dx + ny dy) / nz, dx = dpx / fx, dy = -dpy / fy, depth = -z */
        const double gx = nvx / (nvz * c->fx);
        const double gy = -nvy / (nvz * c->fy);
        double v;
        if (product5) {
            /* sss_i_visibility's PRODUCT5: the centre and the rotated grid, any shadowed
             * tap gives 0 */
            const double bias = j->bias_world;
            if (!tap_fast(c, px, py, d0, px0, py0, gx, gy, bias) ||
                !tap_fast(c, px + 0.5, py + 1.5, d0, px0, py0, gx, gy, bias) ||
                !tap_fast(c, px + -1.5, py + 0.5, d0, px0, py0, gx, gy, bias) ||
                !tap_fast(c, px + -0.5, py + -1.5, d0, px0, py0, gx, gy, bias) ||
                !tap_fast(c, px + 1.5, py + -0.5, d0, px0, py0, gx, gy, bias))
                continue;
            v = 1.0;
        } else {
            sss_i_depth_plane pl = {px0, py0, d0, gx, gy};
            v = sss_i_visibility(&m->views[k], p->visibility, px, py, &pl, j->bias_world);
            if (!(v > 0.0))
                continue;
        }
        /* bilinear3 (GL_LINEAR with clamp to edge, [DalCorso14] samples the map array with linear filtering;
         * texel centres at (i + 0.5, j + 0.5)); u >= -0.5, so floor is the truncation
         * minus one below 0 */
        const double u = px - 0.5, vv = py - 0.5;
        double fu = (double)(int)u, fv = (double)(int)vv;
        if (fu > u)
            fu -= 1.0;
        if (fv > vv)
            fv -= 1.0;
        const double a = u - fu, b = vv - fv;
        const int x0 = (int)fu, y0 = (int)fv;
        const int xa = x0 < 0 ? 0 : x0 >= c->W ? c->W - 1 : x0, xb = x0 + 1 >= c->W ? c->W - 1 : x0 + 1;
        const int ya = y0 < 0 ? 0 : y0 >= c->H ? c->H - 1 : y0, yb = y0 + 1 >= c->H ? c->H - 1 : y0 + 1;
        for (int ch = 0; ch < 3; ch++) {
            const float *r0 = c->rad[ch] + (ptrdiff_t)ya * c->rstride, *r1 = c->rad[ch] + (ptrdiff_t)yb * c->rstride;
            const double top = (1.0 - a) * r0[xa] + a * r0[xb];
            const double bot = (1.0 - a) * r1[xa] + a * r1[xb];
            acc[ch] += v * ((1.0 - b) * top + b * bot);
        }
        sumv += v;
        seen++;
    }
    *sumv_ = sumv;
    *seen_ = seen;
}

/* After the map loop: T21, the optional specular, gamma; writes the pixel. */
static void pixel_finish(const combine_job *j, int x, int y, const sss_constants *mc, const double xo[3],
                         const double no[3], const double wo[3], const double acc[3], double sumv, int seen)
{
    const sss_params *p = j->p;
    float *o[3];
    for (int c = 0; c < 3; c++)
        o[c] = obs_image_f32_row(&j->out[c], y) + x;
    if (j->count)
        obs_image_f32_row(j->count, y)[x] = (float)seen;
    double L[3] = {0, 0, 0};
    double cos_o = no[0] * wo[0] + no[1] * wo[1] + no[2] * wo[2];
    double T21 = 1.0 - sss_fresnel_reflectance(fmin(1.0, fmax(0.0, cos_o)), mc->eta);
    T21 = fmin(1.0, fmax(0.0, T21)); /* clamped to [0, 1] as fresnel_T in the shader */
    if (sumv > 0.0)
        for (int c = 0; c < 3; c++)
            L[c] = T21 * acc[c] / sumv; /* L = T21 sum_k V_k R_k / sum_k V_k (sss.md 3.6) */
    if (p->specular) {
        /* Blinn-Phong from each light, weight (1 - T21) (the thesis adds (1 - T) L_env(reflected)
         * from an environment map; a punctual-light lobe is our substitute: a deviation),
         * shadowed by a one-tap test against the light map */
        for (int l = 0; l < j->light_count; l++) {
            const sss_light_map *lm = &j->lights[l];
            const obs_light *Lt = &lm->light;
            double wl[3], E = 1.0;
            if (Lt->type == OBS_LIGHT_POINT) {
                double d2 = 0.0;
                wl[0] = Lt->position.x - xo[0];
                wl[1] = Lt->position.y - xo[1];
                wl[2] = Lt->position.z - xo[2];
                d2 = wl[0] * wl[0] + wl[1] * wl[1] + wl[2] * wl[2];
                E = 1.0 / d2;
                double il = 1.0 / sqrt(d2);
                for (int a = 0; a < 3; a++)
                    wl[a] *= il;
            } else {
                double il = 1.0 / sqrt((double)Lt->direction.x * Lt->direction.x +
                                       (double)Lt->direction.y * Lt->direction.y +
                                       (double)Lt->direction.z * Lt->direction.z);
                wl[0] = -Lt->direction.x * il;
                wl[1] = -Lt->direction.y * il;
                wl[2] = -Lt->direction.z * il;
            }
            double ndl = no[0] * wl[0] + no[1] * wl[1] + no[2] * wl[2];
            if (!(ndl > 0.0))
                continue;
            double lpx, lpy, ld, lppu;
            if (!sss_i_project(&lm->gb.constants, xo, &lpx, &lpy, &ld, &lppu))
                continue;
            /* one tap, constant depth, bias = shadow_bias x depth range + a slope-scaled
             * term of one texel (tan of the light's incidence angle / texel) */
            double lbias = p->shadow_bias * (lm->gb.constants.zfar - lm->gb.constants.znear) +
                           sqrt(fmax(0.0, 1.0 - ndl * ndl)) / fmax(ndl, 0.05) / lppu;
            sss_i_depth_plane lpl = {lpx, lpy, ld, 0.0, 0.0};
            if (lpx < 0 || lpy < 0 || lpx >= lm->gb.width || lpy >= lm->gb.height ||
                !shadow_tap(&lm->gb, lpx, lpy, &lpl, lbias))
                continue;
            double h[3] = {wl[0] + wo[0], wl[1] + wo[1], wl[2] + wo[2]};
            double hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
            if (!(hl > 0.0))
                continue;
            double ndh = (no[0] * h[0] + no[1] * h[1] + no[2] * h[2]) / hl;
            if (!(ndh > 0.0))
                continue;
            double s = (1.0 - T21) * pow(ndh, p->specular_exponent) * ndl * E * Lt->intensity;
            L[0] += s * Lt->color.x;
            L[1] += s * Lt->color.y;
            L[2] += s * Lt->color.z;
        }
    }
    for (int c = 0; c < 3; c++) {
        double v = L[c];
        if (p->gamma != 1.0 && v > 0.0)
            v = pow(v, 1.0 / p->gamma); /* L^(1/gamma) (sss.md 3.6) */
        o[c][0] = (float)v;
    }
}

/* Before the map loop: whether pixel (x, y) (depth < inf) is a translucent surface, its material,
 * x_o, n_o, w_o. The output planes are allocated zeroed (obs_image_f32_alloc), so pixels that
 * are not written keep 0. */
static const sss_constants *pixel_setup(const combine_job *j, int x, int y, float depth, double xo[3], double no[3],
                                        double wo[3])
{
    const rast_gbuffer *gb = j->gb;
    const sss_constants *mc = sss_i_material(j->mats, obs_image_u32_row(&gb->material_id, y)[x]);
    if (!mc)
        return NULL;
    /* x_o from the camera's exact pixel ray and linear depth (perspective dir has view z = -1,
     * orthographic dir is unit: x_o = origin + depth dir in both) */
    obs_dvec3 org, dir;
    rast_pixel_ray(&gb->constants, j->camera, x + 0.5, y + 0.5, &org, &dir);
    xo[0] = org.x + depth * dir.x;
    xo[1] = org.y + depth * dir.y;
    xo[2] = org.z + depth * dir.z;
    float nv[3] = {obs_image_f32_row(&gb->normal[0], y)[x], obs_image_f32_row(&gb->normal[1], y)[x],
                   obs_image_f32_row(&gb->normal[2], y)[x]};
    sss_i_normal_world(&gb->constants, nv, no);
    double dl = sqrt(dir.x * dir.x + dir.y * dir.y + dir.z * dir.z);
    wo[0] = -dir.x / dl; /* towards the camera */
    wo[1] = -dir.y / dl;
    wo[2] = -dir.z / dl;
    return mc;
}

static void combine_task(void *user, int64_t task, int thread)
{
    (void)thread;
    const combine_job *j = (const combine_job *)user;
    int x0, y0, x1, y1;
    obs_tiling_rect(&j->tiling, task, &x0, &y0, &x1, &y1);
    for (int y = y0; y < y1; y++) {
        const float *drow = obs_image_f32_row(&j->gb->depth, y);
#if defined(OBS_HAVE_AVX2)
        if (j->use_avx2) {
            /* 4 translucent pixels of the row at a time through the AVX2 map loop */
            int lx[4], n = 0;
            const sss_constants *lmc[4];
            double xo[3][4], no[3][4], wo[4][3], acc[3][4], sumv[4];
            int seen[4];
            for (int x = x0; x <= x1; x++) {
                if (x < x1) {
                    if (!(drow[x] < INFINITY))
                        continue;
                    double a[3], b[3];
                    const sss_constants *mc = pixel_setup(j, x, y, drow[x], a, b, wo[n]);
                    if (!mc)
                        continue;
                    for (int c = 0; c < 3; c++) {
                        xo[c][n] = a[c];
                        no[c][n] = b[c];
                    }
                    lx[n] = x;
                    lmc[n] = mc;
                    n++;
                }
                if (n == 4 || (x == x1 && n > 0)) {
                    for (int q = n; q < 4; q++) /* pad with copies of lane 0 (not written back) */
                        for (int c = 0; c < 3; c++) {
                            xo[c][q] = xo[c][0];
                            no[c][q] = no[c][0];
                        }
                    sss_i_combine_maps_avx2(j->cm, j->maps->K, j->eps_world, j->bias_world, xo, no, acc, sumv, seen);
                    for (int q = 0; q < n; q++) {
                        const double xq[3] = {xo[0][q], xo[1][q], xo[2][q]}, nq[3] = {no[0][q], no[1][q], no[2][q]};
                        const double aq[3] = {acc[0][q], acc[1][q], acc[2][q]};
                        pixel_finish(j, lx[q], y, lmc[q], xq, nq, wo[q], aq, sumv[q], seen[q]);
                    }
                    n = 0;
                }
            }
            continue;
        }
#endif
        for (int x = x0; x < x1; x++) {
            double xo[3], no[3], wo[3], acc[3], sumv;
            int seen;
            if (!(drow[x] < INFINITY))
                continue;
            const sss_constants *mc = pixel_setup(j, x, y, drow[x], xo, no, wo);
            if (!mc)
                continue;
            pixel_maps_scalar(j, xo, no, acc, &sumv, &seen);
            pixel_finish(j, x, y, mc, xo, no, wo, acc, sumv, seen);
        }
    }
}

obs_status sss_combine(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const sss_scene_materials *mats,
                       const sss_maps *maps, const sss_light_map *lights, int light_count,
                       const rast_gbuffer *camera_gb, const obs_camera *camera, const sss_params *p,
                       obs_image_f32 out[3], obs_image_f32 *visible_count)
{
    (void)scene;
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_combine: NULL output");
    for (int c = 0; c < 3; c++)
        memset(&out[c], 0, sizeof out[c]);
    if (visible_count)
        memset(visible_count, 0, sizeof *visible_count);
    if (!mats || !maps || !camera_gb || !camera || !p || light_count < 0 || (light_count > 0 && !lights))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_combine: NULL argument");
    obs_status st = sss_params_validate(ctx, p);
    if (st != OBS_STATUS_OK)
        return st;
    if (p->isa != SSS_ISA_AUTO && !sss_isa_available(p->isa))
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED_ISA, "sss_combine: ISA %s is not available", sss_isa_name(p->isa));
    if (!maps->views || !maps->radiance || !maps->dirs || maps->K < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_combine: the maps are not built");
    if (!camera_gb->depth.data || !camera_gb->normal[0].data || !camera_gb->material_id.data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "sss_combine: the camera G-buffer needs depth, normal and material_id planes");
    const int W = camera_gb->width, H = camera_gb->height;
    for (int c = 0; c < 3; c++)
        if ((st = obs_image_f32_alloc(ctx, W, H, &out[c])) != OBS_STATUS_OK)
            goto fail;
    if (visible_count && (st = obs_image_f32_alloc(ctx, W, H, visible_count)) != OBS_STATUS_OK)
        goto fail;
    combine_job j;
    memset(&j, 0, sizeof j);
    j.mats = mats;
    j.maps = maps;
    j.lights = lights;
    j.light_count = light_count;
    j.gb = camera_gb;
    j.camera = camera;
    j.p = p;
    j.out = out;
    j.count = visible_count;
    j.tiling = obs_tiling_make(W, H, 32);
    /* eps_c is in map texture units: one unit spans the map's width 2 xmag (= size / fx) */
    const rast_view_constants *vc0 = &maps->views[0].constants;
    j.eps_world = p->shrink_eps * (double)maps->views[0].width / vc0->fx;
    /* bias in units of the map's depth range (far - near) */
    j.bias_world = p->shadow_bias * (vc0->zfar - vc0->znear);
    j.cm = (sss_i_combine_map *)malloc(sizeof(sss_i_combine_map) * (size_t)maps->K);
    if (!j.cm) {
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "sss_combine: out of memory");
        goto fail;
    }
    for (int k = 0; k < maps->K; k++) {
        const rast_gbuffer *mk = &maps->views[k];
        const rast_view_constants *vc = &mk->constants;
        sss_i_combine_map *c = &j.cm[k];
        if (vc->projection_type != OBS_PROJECTION_ORTHOGRAPHIC || !mk->depth.data || !maps->radiance[3 * k].data) {
            free(j.cm);
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_combine: map %d is not an orthographic layer", k);
            goto fail;
        }
        const float *vm = vc->view.m;
        for (int i = 0; i < 4; i++) {
            c->r0[i] = (double)vm[4 * i + 0];
            c->r1[i] = (double)vm[4 * i + 1];
            c->r2[i] = (double)vm[4 * i + 2];
        }
        c->cx = vc->cx;
        c->cy = vc->cy;
        c->fx = vc->fx;
        c->fy = vc->fy;
        for (int a = 0; a < 3; a++)
            c->wd[a] = maps->dirs[3 * k + a];
        c->W = mk->width;
        c->H = mk->height;
        c->depth = mk->depth.data;
        c->dstride = mk->depth.stride;
        for (int ch = 0; ch < 3; ch++)
            c->rad[ch] = maps->radiance[3 * k + ch].data;
        c->rstride = maps->radiance[3 * k].stride;
    }
    if (p->visibility == SSS_VISIBILITY_PRODUCT5) {
        if (p->isa == SSS_ISA_AVX2)
            j.use_avx2 = 1;
        else if (p->isa == SSS_ISA_AUTO) {
            const char *env = getenv("OBS_ISA");
            j.use_avx2 = !(env && !strcmp(env, "scalar")) && sss_isa_available(SSS_ISA_AVX2);
        }
    }
    obs_pool_run(pool, obs_tiling_count(&j.tiling), combine_task, &j);
    free(j.cm);
    return OBS_STATUS_OK;
fail:
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&out[c]);
    if (visible_count)
        obs_image_f32_free(visible_count);
    return st;
}
