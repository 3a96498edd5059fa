/* ao_blend.c: the final blend of issue 4, item 3: AO multiplied into a Lambert-plus-ambient image. */
#include "ao.h"

#include <math.h>

typedef struct blend_job {
    const ao_input *in;
    const obs_image_f32 *ao, *const *n;
    obs_image_f32 *out;
    float l[3];
} blend_job;

static void blend_rows(void *user, int64_t y, int thread)
{
    (void)thread;
    const blend_job *j = (const blend_job *)user;
    const ao_input *in = j->in;
    const int fy = in->y0 + (int)y;
    const float *d = obs_image_f32_row(in->depth, fy) + in->x0;
    const float *nx = obs_image_f32_row(j->n[0], fy) + in->x0, *ny = obs_image_f32_row(j->n[1], fy) + in->x0,
                *nz = obs_image_f32_row(j->n[2], fy) + in->x0;
    const float *a = obs_image_f32_row(j->ao, (int)y);
    float *o = obs_image_f32_row(j->out, (int)y);
    for (int x = 0; x < in->w; x++) {
        const int bg = !(d[x] > 0.0f && d[x] < INFINITY);
        float ndl = nx[x] * j->l[0] + ny[x] * j->l[1] + nz[x] * j->l[2];
        ndl = ndl > 0.0f ? ndl : 0.0f; /* also maps a NaN normal to 0 */
        o[x] = bg ? 0.0f : a[x] * (AO_BLEND_AMBIENT + (1.0f - AO_BLEND_AMBIENT) * ndl);
    }
}

obs_status ao_blend_lambert(obs_context *ctx, obs_pool *pool, const ao_input *in, const obs_image_f32 *ao,
                            const obs_image_f32 *const normal[3], obs_image_f32 *out)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    if (!ao || !out || !normal || !ao->data || !out->data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_blend_lambert: NULL plane");
    if (ao->width != in->w || ao->height != in->h || out->width != in->w || out->height != in->h)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_blend_lambert: AO and output must be %dx%d", in->w,
                         in->h);
    for (int c = 0; c < 3; c++)
        if (!normal[c] || !normal[c]->data || normal[c]->width != in->width || normal[c]->height != in->height)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_blend_lambert: normal plane %d must be %dx%d", c,
                             in->width, in->height);
    blend_job j = {in, ao, normal, out, {AO_BLEND_LIGHT_X, AO_BLEND_LIGHT_Y, AO_BLEND_LIGHT_Z}};
    const float il = 1.0f / sqrtf(j.l[0] * j.l[0] + j.l[1] * j.l[1] + j.l[2] * j.l[2]);
    for (int c = 0; c < 3; c++)
        j.l[c] *= il;
    obs_pool_run(pool, in->h, blend_rows, &j);
    return OBS_STATUS_OK;
}
