/* vol_eye.c: the eye-direction pass of the light volume, a RECONSTRUCTION.
 *
 * [Ropinski10]'s summary speaks of "a two-pass algorithm to compute incoming and outgoing light"
 * (../shared/reference/volume.md 1.1), but how the second (outgoing, towards the eye) pass is
 * computed and combined is unverified: in the Voreen snapshot the camera volume is allocated and
 * its creation call is commented out, and the camera can only be chosen INSTEAD of the light
 * ("Change direction: Lightsource / Camera", volume.md 1.3 and 1.8). We take volume.md 1.8's [R]
 * scheme and say so in docs/volume/light.md, "Eye pass":
 *
 *   - run the same slice-by-slice propagation a second time, seeded from the volume face that
 *     most faces the camera (volume.md 1.3 with the camera position, as Voreen's camera option),
 *     with light travelling from the camera into the volume: for an orthographic camera a
 *     directional "light" along the view direction, for a perspective one a point "light" at the
 *     camera position (which may be inside the volume: the light volume's seed slices handle it);
 *   - keep only the cone-blurred chromaticity c (outgoing scattering blurs toward the eye); the
 *     eye volume's l is set to 1 (the transmittance towards the eye is what the ray caster
 *     already composites front to back, so a second copy of it would count it twice);
 *   - at render time the light pass's chromaticity is modulated by it, voxel by voxel:
 *     c_lit(x) = c_light(x) * c_eye(x) (vol_light_volume_modulate).
 *
 * The propagation itself is vol_light_volume_build (public API), with the same params p (scale,
 * cone angle, blend_second, kappa), so the eye volume has the light volume's layout exactly. */
#include "vol.h"

#include <math.h>
#include <string.h>

/* The "light from the eye" for a camera: directional along the view direction (orthographic),
 * a point at the eye (perspective). glTF camera: looks down its local -Z (glTF 2.0, 3.10). */
static obs_status eye_light_from_camera(obs_context *ctx, const obs_camera *cam, vol_light *L)
{
    memset(L, 0, sizeof *L);
    L->color[0] = L->color[1] = L->color[2] = 1.0f; /* unused by the build: c is a ratio */
    const float *m = cam->world.m;                  /* column-major: column 2 = local +Z, 3 = position */
    for (int i = 0; i < 16; i++)
        if (!isfinite(m[i]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "eye volume: the camera's world matrix is not finite");
    if (cam->projection == OBS_PROJECTION_ORTHOGRAPHIC) {
        double d[3] = {-(double)m[8], -(double)m[9], -(double)m[10]};
        double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(n > 0.0))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "eye volume: the camera has no view direction");
        L->type = OBS_LIGHT_DIRECTIONAL;
        for (int c = 0; c < 3; c++)
            L->direction[c] = d[c] / n;
    } else if (cam->projection == OBS_PROJECTION_PERSPECTIVE) {
        L->type = OBS_LIGHT_POINT;
        for (int c = 0; c < 3; c++)
            L->position[c] = (double)m[12 + c];
    } else {
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "eye volume: unknown camera projection %d",
                         (int)cam->projection);
    }
    return OBS_STATUS_OK;
}

obs_status vol_eye_volume_build(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                const obs_camera *camera, const vol_lv_params *p, vol_light_volume *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_eye_volume_build: out is NULL");
    memset(out, 0, sizeof *out);
    if (!camera)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_eye_volume_build: camera is NULL");
    vol_light L;
    obs_status st = eye_light_from_camera(ctx, camera, &L);
    if (st != OBS_STATUS_OK)
        return st;
    /* The same propagation, faces chosen for the camera (volume.md 1.3), blend as p says. */
    st = vol_light_volume_build(ctx, pool, g, tf, &L, p, out);
    if (st != OBS_STATUS_OK)
        return st;
    /* Keep only the chromaticity (volume.md 1.8 [R]); l = 1 so that the eye volume carries no
     * second transmittance (see the top of this file). */
    const size_t voxels = (size_t)out->nx * (size_t)out->ny * (size_t)out->nz;
    for (size_t i = 0; i < voxels; i++)
        out->l[i] = 1.0f;
    return OBS_STATUS_OK;
}

obs_status vol_light_volume_modulate(obs_context *ctx, const vol_light_volume *eye, vol_light_volume *lv)
{
    if (!eye || !lv)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_light_volume_modulate: a volume is NULL");
    if (!eye->c[0] || !eye->c[1] || !eye->c[2] || !lv->c[0] || !lv->c[1] || !lv->c[2])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_light_volume_modulate: a volume is empty");
    int same = eye->nx == lv->nx && eye->ny == lv->ny && eye->nz == lv->nz && eye->scale == lv->scale;
    for (int c = 0; c < 3; c++)
        same = same && eye->spacing[c] == lv->spacing[c] && eye->origin[c] == lv->origin[c];
    if (!same)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "vol_light_volume_modulate: the eye volume (%dx%dx%d, scale %d) and the light volume "
                         "(%dx%dx%d, scale %d) differ in layout (size, scale, spacing or origin); build both with "
                         "the same grid and params",
                         eye->nx, eye->ny, eye->nz, eye->scale, lv->nx, lv->ny, lv->nz, lv->scale);
    const size_t voxels = (size_t)lv->nx * (size_t)lv->ny * (size_t)lv->nz;
    /* c_lit = c_light * c_eye (volume.md 1.8 [R]: "modulate the light-pass chromaticity by it"). */
    for (int c = 0; c < 3; c++)
        for (size_t i = 0; i < voxels; i++)
            lv->c[c][i] *= eye->c[c][i];
    return OBS_STATUS_OK;
}
