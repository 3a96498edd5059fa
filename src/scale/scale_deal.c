/* scale_deal.c: dealing an image's tasks over ranks by estimated cost (docs/scale.md, "Balance").
 * Plain C, no MPI: the adapter (scale_mpi.c) and the tests call it. */
#include "scale.h"

#include "../raster/raster.h"

#include <math.h>
#include <stdlib.h>

obs_status scale_ao_task_costs(obs_context *ctx, const rast_gbuffer *gb, int tile, double *cost, int64_t ntasks)
{
    if (!gb || !cost)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_ao_task_costs: NULL argument");
    if (!(gb->outputs & RAST_OUT_DEPTH) || !gb->depth.data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_ao_task_costs: the G-buffer has no depth plane");
    const int W = gb->width - 2 * gb->guard, H = gb->height - 2 * gb->guard;
    if (truth_ao_task_count(W, H, tile) != ntasks)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_ao_task_costs: %lld tasks given, the %dx%d image has %lld",
                         (long long)ntasks, W, H, (long long)truth_ao_task_count(W, H, tile));
    for (int64_t t = 0; t < ntasks; t++) {
        int x0, y0, x1, y1;
        truth_ao_task_rect(W, H, tile, t, &x0, &y0, &x1, &y1);
        int64_t surface = 0, all = (int64_t)(x1 - x0) * (y1 - y0);
        for (int y = y0; y < y1; y++) {
            const float *d = obs_image_f32_row(&gb->depth, y + gb->guard) + gb->guard;
            for (int x = x0; x < x1; x++)
                surface += d[x] > 0.0f && isfinite(d[x]); /* truth_ao's surface test (ao_tile) */
        }
        cost[t] = (double)surface + SCALE_BACKGROUND_COST * (double)(all - surface);
    }
    return OBS_STATUS_OK;
}

obs_status scale_sss_task_costs(obs_context *ctx, const rast_gbuffer *gb, const obs_scene *scene,
                                const sss_scene_materials *mats, int tile, double *cost, int64_t ntasks)
{
    if (!gb || !scene || !mats || !cost)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_sss_task_costs: NULL argument");
    if (!gb->depth.data || !gb->instance_id.data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "scale_sss_task_costs: the G-buffer has no depth or instance id plane");
    const int W = gb->width - 2 * gb->guard, H = gb->height - 2 * gb->guard;
    if (truth_sss_task_count(W, H, tile) != ntasks)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_sss_task_costs: %lld tasks given, the %dx%d image has %lld",
                         (long long)ntasks, W, H, (long long)truth_sss_task_count(W, H, tile));
    /* per instance: 1 when truth_sss estimates its pixels (a translucent material; truth_sss.c's
     * inst_material: a mesh without material takes mats->none) */
    unsigned char *lit = (unsigned char *)calloc(scene->instance_count ? scene->instance_count : 1, 1);
    if (!lit)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "scale_sss_task_costs: out of memory");
    for (uint32_t i = 0; i < scene->instance_count; i++) {
        const uint32_t m = scene->instances[i].mesh;
        if (m >= scene->mesh_count)
            continue;
        const int mat = scene->meshes[m].material;
        lit[i] = mat < 0 ? mats->none != NULL
                         : (uint32_t)mat < mats->count && mats->translucent && mats->translucent[mat];
    }
    for (int64_t t = 0; t < ntasks; t++) {
        int x0, y0, x1, y1;
        truth_sss_task_rect(W, H, tile, t, &x0, &y0, &x1, &y1);
        int64_t surface = 0, all = (int64_t)(x1 - x0) * (y1 - y0);
        for (int y = y0; y < y1; y++) {
            const float *d = obs_image_f32_row(&gb->depth, y + gb->guard) + gb->guard;
            const uint32_t *id = obs_image_u32_row(&gb->instance_id, y + gb->guard) + gb->guard;
            for (int x = x0; x < x1; x++)
                surface += isfinite(d[x]) && id[x] < scene->instance_count && lit[id[x]];
        }
        cost[t] = (double)surface + SCALE_BACKGROUND_COST * (double)(all - surface);
    }
    free(lit);
    return OBS_STATUS_OK;
}

obs_status scale_deal_tasks(obs_context *ctx, const double *cost, int64_t ntasks, int nranks, int *owner)
{
    if ((!cost || !owner) && ntasks > 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_deal_tasks: NULL argument");
    if (nranks < 1 || ntasks < 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_deal_tasks: %d ranks, %lld tasks", nranks,
                         (long long)ntasks);
    for (int64_t t = 0; t < ntasks; t++)
        if (!(cost[t] >= 0.0) || !isfinite(cost[t]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_deal_tasks: task %lld has cost %g", (long long)t,
                             cost[t]);
    double *load = (double *)calloc((size_t)nranks, sizeof(double));
    if (!load)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "scale_deal_tasks: out of memory");
    /* Greedy in index order (list scheduling, [Graham66]): each task to the least-loaded rank.
     * Linear in nranks per task: a 4K image has ~30 k tasks; at 1000 ranks that is 3e7 compares,
     * well under a second. */
    for (int64_t t = 0; t < ntasks; t++) {
        int best = 0;
        for (int r = 1; r < nranks; r++)
            if (load[r] < load[best])
                best = r;
        owner[t] = best;
        load[best] += cost[t];
    }
    free(load);
    return OBS_STATUS_OK;
}

double scale_imbalance(const double *v, int n)
{
    if (!v || n < 1)
        return 0.0;
    double sum = 0.0, mx = v[0];
    for (int i = 0; i < n; i++) {
        sum += v[i];
        mx = v[i] > mx ? v[i] : mx;
    }
    const double mean = sum / n;
    return mean > 0.0 ? mx / mean - 1.0 : 0.0;
}

int64_t scale_ao_rank_pixels(int width, int height, int tile, const int *owner, int64_t ntasks, int rank)
{
    int64_t n = 0;
    for (int64_t t = 0; t < ntasks; t++)
        if (owner[t] == rank) {
            int x0, y0, x1, y1;
            truth_ao_task_rect(width, height, tile, t, &x0, &y0, &x1, &y1);
            n += (int64_t)(x1 - x0) * (y1 - y0);
        }
    return n;
}
