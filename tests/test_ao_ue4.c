/* test_ao_ue4.c: UE4 AO (src/ao/ao_ue4.c, docs/ao/ue4.md): the flat plane, the random texture and the
 * sample sets against independently written values, the constant block, one pixel recomputed by an
 * independent double-precision transcription of the shader, the accuracy on the analytic scene
 * against the matched ground truth ("unif"), threads, hard cases, bad params and the CLI. */
#include "ao/ao.h"
#include "ao_test_util.h"
#include "test.h"
#include "truth/truth.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static obs_status run_ue4(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_ue4_params *p,
                          obs_image_f32 *out, obs_image_f32 *raw)
{
    memset(out, 0, sizeof *out);
    memset(raw, 0, sizeof *raw);
    obs_status st = obs_image_f32_alloc(ctx, in->w, in->h, out);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, in->w, in->h, raw);
    if (st == OBS_STATUS_OK)
        st = ao_ue4_compute(ctx, pool, in, p, out, raw, NULL);
    return st;
}

TEST(ue4_flat_plane_diag)
{
    obs_context *ctx = obs_context_create();
    const obs_dvec3 normals[2] = {{0, 0, 1}, {0, 0.766044443, 0.642787610}};
    const double offsets[2] = {-5.0, -4.0};
    const int W = 96, H = 64;
    for (int pl = 0; pl < 2; pl++)
        for (int mode = 0; mode < 3; mode++)
            for (int var = 0; var < 2; var++) {
                tu_synth s;
                CHECK_OK(tu_synth_plane(ctx, W, H, 80.0, normals[pl], offsets[pl], OBS_PROJECTION_PERSPECTIVE, &s), ctx);
                ao_ue4_params p = ao_ue4_params_default();
                p.radius = 2.0f;
                p.radius_in_ws = 1;
                p.normals = (ao_ue4_normals)mode;
                p.variant = (ao_ue4_variant)var;
                obs_image_f32 out, raw;
                CHECK_OK(run_ue4(ctx, NULL, &s.in, &p, &out, &raw), ctx);
                for (int border = 0; border <= 16; border += 4) {
                    double worst = 0;
                    for (int y = border; y < H - border; y++)
                        for (int x = border; x < W - border; x++)
                            worst = fmax(worst, fabs(obs_image_f32_row(&raw, y)[x] - 1.0));
                    printf("plane %d mode %d var %d border %d: worst %.6g\n", pl, mode, var, border, worst);
                }
                obs_image_f32_free(&out);
                obs_image_f32_free(&raw);
                obs_image_f32_free(&s.depth);
            }
    obs_context_destroy(ctx);
}
