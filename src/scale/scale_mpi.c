/* scale_mpi.c: the MPI adapter (built with OBS_WITH_MPI; docs/scale.md). Only the thread that
 * called scale_mpi_init talks to MPI (MPI_THREAD_FUNNELED); the worker pools never do. */
#include "scale.h"

#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct scale_comm {
    int rank, size;
};

enum { TAG_STATS = 1701, TAG_PIXELS = 1702 };
#define MSG_LEN 512
/* MPI counts are int: pixel payloads go in chunks of at most 2^26 floats (256 MiB). */
#define CHUNK_FLOATS ((int64_t)1 << 26)

int scale_mpi_built(void) { return 1; }

obs_status scale_mpi_init(obs_context *ctx, int *argc, char ***argv, scale_comm **out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_mpi_init: NULL argument");
    *out = NULL;
    scale_comm *c = (scale_comm *)calloc(1, sizeof *c);
    if (!c)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "scale_mpi_init: out of memory");
    int provided = 0;
    if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        free(c);
        return obs_error(ctx, OBS_STATUS_INTERNAL, "MPI_Init_thread failed");
    }
    if (provided < MPI_THREAD_FUNNELED) {
        MPI_Finalize();
        free(c);
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "the MPI library does not provide MPI_THREAD_FUNNELED");
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &c->rank);
    MPI_Comm_size(MPI_COMM_WORLD, &c->size);
    *out = c;
    return OBS_STATUS_OK;
}

int scale_comm_rank(const scale_comm *c) { return c ? c->rank : 0; }
int scale_comm_size(const scale_comm *c) { return c ? c->size : 1; }

void scale_mpi_abort(scale_comm *c, int code)
{
    if (c)
        MPI_Abort(MPI_COMM_WORLD, code);
}

void scale_mpi_finalize(scale_comm *c)
{
    if (!c)
        return;
    MPI_Finalize();
    free(c);
}

obs_status scale_mpi_agree(obs_context *ctx, scale_comm *c, obs_status local)
{
    if (!c)
        return local;
    int mine = (int)local;
    int *all = (int *)malloc(sizeof(int) * (size_t)c->size);
    char msg[MSG_LEN];
    if (!all) /* cannot take part: end the job rather than hang the others */
        MPI_Abort(MPI_COMM_WORLD, 6);
    MPI_Allgather(&mine, 1, MPI_INT, all, 1, MPI_INT, MPI_COMM_WORLD);
    int first = -1, failed = 0;
    for (int r = 0; r < c->size; r++)
        if (all[r] != OBS_STATUS_OK) {
            failed++;
            if (first < 0)
                first = r;
        }
    if (first < 0) {
        free(all);
        return OBS_STATUS_OK;
    }
    /* the lowest failing rank's message, to everyone */
    memset(msg, 0, sizeof msg);
    if (c->rank == first)
        snprintf(msg, sizeof msg, "%s", obs_context_last_error(ctx));
    MPI_Bcast(msg, MSG_LEN, MPI_CHAR, first, MPI_COMM_WORLD);
    const obs_status st = (obs_status)all[first];
    free(all);
    obs_context_clear_error(ctx);
    if (failed > 1)
        return obs_error(ctx, st, "rank %d of %d failed (and %d other ranks): %s", first, c->size, failed - 1, msg);
    return obs_error(ctx, st, "rank %d of %d failed: %s", first, c->size, msg);
}

static int xfer(float *buf, int64_t n, int peer, int send)
{
    for (int64_t at = 0; at < n; at += CHUNK_FLOATS) {
        const int len = (int)(n - at < CHUNK_FLOATS ? n - at : CHUNK_FLOATS);
        const int rc = send ? MPI_Send(buf + at, len, MPI_FLOAT, peer, TAG_PIXELS, MPI_COMM_WORLD)
                            : MPI_Recv(buf + at, len, MPI_FLOAT, peer, TAG_PIXELS, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        if (rc != MPI_SUCCESS)
            return 0;
    }
    return 1;
}

/* ---- an image dealt out as tasks (ao, sss, volume image): one layout, one pack and gather ------- */

enum { MAX_PLANES = 8 };

/* A result's image layout: its planes (all width x height) and the task rectangles they are dealt
 * in (truth_ao_task_rect, truth_sss_task_rect or truth_volume_mc_task_rect of `tile`). */
typedef struct tiled_image {
    int width, height, tile, planes;
    obs_image_f32 *pl[MAX_PLANES];
    void (*rect)(int width, int height, int tile, int64_t task, int *x0, int *y0, int *x1, int *y1);
} tiled_image;

/* The floats of the tasks owned by `rank`, over all planes. */
static int64_t owned_floats(const tiled_image *im, const int *owner, int64_t ntasks, int rank)
{
    int64_t n = 0;
    for (int64_t t = 0; t < ntasks; t++)
        if (owner[t] == rank) {
            int x0, y0, x1, y1;
            im->rect(im->width, im->height, im->tile, t, &x0, &y0, &x1, &y1);
            n += (int64_t)(x1 - x0) * (y1 - y0);
        }
    return im->planes * n;
}

/* Each owned task's rectangle, plane by plane, rows in order. */
static void pack_unpack(const tiled_image *im, const int *owner, int64_t ntasks, int rank, float *buf, int unpack)
{
    size_t at = 0;
    for (int64_t t = 0; t < ntasks; t++) {
        if (owner[t] != rank)
            continue;
        int x0, y0, x1, y1;
        im->rect(im->width, im->height, im->tile, t, &x0, &y0, &x1, &y1);
        const size_t n = (size_t)(x1 - x0);
        for (int k = 0; k < im->planes; k++)
            for (int y = y0; y < y1; y++, at += n) {
                float *row = obs_image_f32_row(im->pl[k], y) + x0;
                if (unpack)
                    memcpy(row, buf + at, n * sizeof(float));
                else
                    memcpy(buf + at, row, n * sizeof(float));
            }
    }
}

/* A rank's owned pixels packed into a new buffer of *n floats (the caller frees it). */
static float *pack_owned(const tiled_image *im, const int *owner, int64_t ntasks, int rank, int64_t *n)
{
    *n = owned_floats(im, owner, ntasks, rank);
    float *buf = (float *)malloc(sizeof(float) * (size_t)(*n > 0 ? *n : 1));
    if (!buf) /* rank 0 is waiting for this rank's pixels: end the job */
        MPI_Abort(MPI_COMM_WORLD, 6);
    pack_unpack(im, owner, ntasks, rank, buf, 0);
    return buf;
}

/* On rank 0: receive rank r's owned pixels into im. Returns 0 when MPI_Recv failed. */
static int recv_owned(const tiled_image *im, const int *owner, int64_t ntasks, int r)
{
    const int64_t n = owned_floats(im, owner, ntasks, r);
    float *buf = (float *)malloc(sizeof(float) * (size_t)(n > 0 ? n : 1));
    if (!buf)
        MPI_Abort(MPI_COMM_WORLD, 6);
    if (!xfer(buf, n, r, 0)) {
        free(buf);
        return 0;
    }
    pack_unpack(im, owner, ntasks, r, buf, 1);
    free(buf);
    return 1;
}

/* per_rank before the gather: zeros, rank 0's own work, and every rank's tasks and estimates. */
static void per_rank_start(scale_rank_stats *per_rank, int ranks, const int *owner, const double *cost,
                           int64_t ntasks, uint64_t rays0, double seconds0)
{
    if (!per_rank)
        return;
    for (int r = 0; r < ranks; r++)
        memset(&per_rank[r], 0, sizeof per_rank[r]);
    per_rank[0].rays = rays0;
    per_rank[0].seconds_work = seconds0;
    for (int64_t t = 0; t < ntasks; t++) {
        per_rank[owner[t]].tasks++;
        per_rank[owner[t]].cost_estimate += cost[t];
    }
}

obs_status scale_mpi_gather_ao(obs_context *ctx, scale_comm *c, const int *owner, const double *cost, int64_t ntasks,
                               int tile, truth_ao_result *res, scale_rank_stats *per_rank)
{
    if (!c || !owner || !cost || !res)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_mpi_gather_ao: NULL argument");
    truth_ao_stats *S = &res->stats;
    const tiled_image im = {.width = res->width, .height = res->height, .tile = tile, .planes = 3,
                            .pl = {&res->mean, &res->std_error, &res->count}, .rect = truth_ao_task_rect};
    /* the counters as doubles: exact up to 2^53 */
    double mine[10] = {(double)S->rays, (double)S->primary_rays, (double)S->pixels_surface,
                       (double)S->pixels_background, (double)S->pixels_invalid, (double)S->pixels_converged,
                       (double)S->pixels_at_max, S->max_std_error, S->max_offset, S->seconds_work};
    if (c->rank != 0) {
        int64_t n;
        float *buf = pack_owned(&im, owner, ntasks, c->rank, &n);
        int ok = MPI_Send(mine, 10, MPI_DOUBLE, 0, TAG_STATS, MPI_COMM_WORLD) == MPI_SUCCESS && xfer(buf, n, 0, 1);
        free(buf);
        return ok ? OBS_STATUS_OK : obs_error(ctx, OBS_STATUS_INTERNAL, "rank %d: MPI_Send to rank 0 failed", c->rank);
    }
    per_rank_start(per_rank, c->size, owner, cost, ntasks, S->rays, S->seconds_work);
    for (int r = 1; r < c->size; r++) {
        double th[10];
        if (MPI_Recv(th, 10, MPI_DOUBLE, r, TAG_STATS, MPI_COMM_WORLD, MPI_STATUS_IGNORE) != MPI_SUCCESS)
            return obs_error(ctx, OBS_STATUS_INTERNAL, "MPI_Recv from rank %d failed", r);
        if (!recv_owned(&im, owner, ntasks, r))
            return obs_error(ctx, OBS_STATUS_INTERNAL, "MPI_Recv of rank %d's pixels failed", r);
        /* sums of the counters, maxima of the rest, as truth_ao_render combines its threads' */
        S->rays += (uint64_t)th[0];
        S->primary_rays += (uint64_t)th[1];
        S->pixels_surface += (int64_t)th[2];
        S->pixels_background += (int64_t)th[3];
        S->pixels_invalid += (int64_t)th[4];
        S->pixels_converged += (int64_t)th[5];
        S->pixels_at_max += (int64_t)th[6];
        S->max_std_error = th[7] > S->max_std_error ? th[7] : S->max_std_error;
        S->max_offset = th[8] > S->max_offset ? th[8] : S->max_offset;
        S->seconds_work = th[9] > S->seconds_work ? th[9] : S->seconds_work;
        if (per_rank) {
            per_rank[r].rays = (uint64_t)th[0];
            per_rank[r].seconds_work = th[9];
        }
    }
    return OBS_STATUS_OK;
}

/* ---- truth_sss: seven planes, tasks truth_sss_task_rect ---------------------------------------- */

enum { SSS_PLANES = 7, SSS_COUNTERS = 9 };

obs_status scale_mpi_gather_sss(obs_context *ctx, scale_comm *c, const int *owner, const double *cost, int64_t ntasks,
                                int tile, truth_sss_result *res, scale_rank_stats *per_rank)
{
    if (!c || !owner || !cost || !res)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_mpi_gather_sss: NULL argument");
    truth_sss_stats *S = &res->stats;
    tiled_image im = {.width = res->width, .height = res->height, .tile = tile, .planes = SSS_PLANES,
                      .rect = truth_sss_task_rect};
    for (int ch = 0; ch < 3; ch++) {
        im.pl[ch] = &res->radiance[ch];
        im.pl[3 + ch] = &res->std_error[ch];
    }
    im.pl[6] = &res->count;
    /* the counters as 64-bit integers (exact), the seconds apart */
    uint64_t mine[SSS_COUNTERS] = {S->candidates, S->accepted, S->rays, S->walk_events, S->walks_lost,
                                   (uint64_t)S->pixels_surface, (uint64_t)S->pixels_skipped,
                                   (uint64_t)S->pixels_converged, (uint64_t)S->pixels_at_max};
    double my_seconds = S->seconds;
    if (c->rank != 0) {
        int64_t n;
        float *buf = pack_owned(&im, owner, ntasks, c->rank, &n);
        int ok = MPI_Send(mine, SSS_COUNTERS, MPI_UINT64_T, 0, TAG_STATS, MPI_COMM_WORLD) == MPI_SUCCESS &&
                 MPI_Send(&my_seconds, 1, MPI_DOUBLE, 0, TAG_STATS, MPI_COMM_WORLD) == MPI_SUCCESS &&
                 xfer(buf, n, 0, 1);
        free(buf);
        return ok ? OBS_STATUS_OK : obs_error(ctx, OBS_STATUS_INTERNAL, "rank %d: MPI_Send to rank 0 failed", c->rank);
    }
    per_rank_start(per_rank, c->size, owner, cost, ntasks, S->rays, S->seconds);
    for (int r = 1; r < c->size; r++) {
        uint64_t th[SSS_COUNTERS];
        double secs = 0.0;
        if (MPI_Recv(th, SSS_COUNTERS, MPI_UINT64_T, r, TAG_STATS, MPI_COMM_WORLD, MPI_STATUS_IGNORE) != MPI_SUCCESS ||
            MPI_Recv(&secs, 1, MPI_DOUBLE, r, TAG_STATS, MPI_COMM_WORLD, MPI_STATUS_IGNORE) != MPI_SUCCESS)
            return obs_error(ctx, OBS_STATUS_INTERNAL, "MPI_Recv from rank %d failed", r);
        if (!recv_owned(&im, owner, ntasks, r))
            return obs_error(ctx, OBS_STATUS_INTERNAL, "MPI_Recv of rank %d's pixels failed", r);
        /* every counter is a sum over tasks (truth_sss_render adds its tasks' the same way) */
        S->candidates += th[0];
        S->accepted += th[1];
        S->rays += th[2];
        S->walk_events += th[3];
        S->walks_lost += th[4];
        S->pixels_surface += (int64_t)th[5];
        S->pixels_skipped += (int64_t)th[6];
        S->pixels_converged += (int64_t)th[7];
        S->pixels_at_max += (int64_t)th[8];
        S->seconds = secs > S->seconds ? secs : S->seconds;
        if (per_rank) {
            per_rank[r].rays = th[2];
            per_rank[r].seconds_work = secs;
        }
    }
    return OBS_STATUS_OK;
}

/* ---- truth volume: z slices of the light volume, tiles of the MC image -------------------------- */

obs_status scale_mpi_gather_volume_slices(obs_context *ctx, scale_comm *c, const int *owner, int nz,
                                          int64_t slice_floats, float *T, float *err, double seconds,
                                          double *per_rank_seconds)
{
    if (!c || (nz > 0 && (!owner || !T || !err)) || nz < 0 || slice_floats < 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_mpi_gather_volume_slices: bad argument");
    /* each rank's seconds first (tag TAG_STATS), then the slices (TAG_PIXELS) */
    if (c->rank != 0) {
        if (MPI_Send(&seconds, 1, MPI_DOUBLE, 0, TAG_STATS, MPI_COMM_WORLD) != MPI_SUCCESS)
            return obs_error(ctx, OBS_STATUS_INTERNAL, "rank %d: MPI_Send to rank 0 failed", c->rank);
    } else {
        if (per_rank_seconds)
            per_rank_seconds[0] = seconds;
        for (int r = 1; r < c->size; r++) {
            double s = 0.0;
            if (MPI_Recv(&s, 1, MPI_DOUBLE, r, TAG_STATS, MPI_COMM_WORLD, MPI_STATUS_IGNORE) != MPI_SUCCESS)
                return obs_error(ctx, OBS_STATUS_INTERNAL, "MPI_Recv from rank %d failed", r);
            if (per_rank_seconds)
                per_rank_seconds[r] = s;
        }
    }
    /* slice by slice in z order (T then err): each an MPI message of slice_floats floats, chunked */
    for (int k = 0; k < nz; k++) {
        if (owner[k] == 0)
            continue;
        float *t = T + (size_t)k * (size_t)slice_floats, *e = err + (size_t)k * (size_t)slice_floats;
        if (c->rank == owner[k]) {
            if (!xfer(t, slice_floats, 0, 1) || !xfer(e, slice_floats, 0, 1))
                return obs_error(ctx, OBS_STATUS_INTERNAL, "rank %d: MPI_Send to rank 0 failed", c->rank);
        } else if (c->rank == 0) {
            if (!xfer(t, slice_floats, owner[k], 0) || !xfer(e, slice_floats, owner[k], 0))
                return obs_error(ctx, OBS_STATUS_INTERNAL, "MPI_Recv of rank %d's slices failed", owner[k]);
        }
    }
    return OBS_STATUS_OK;
}

enum { VI_PLANES = 8, VI_COUNTERS = 4 };

obs_status scale_mpi_gather_volume_image(obs_context *ctx, scale_comm *c, const int *owner, const double *cost,
                                         int64_t ntasks, int tile, truth_volume_image *im,
                                         scale_rank_stats *per_rank)
{
    if (!c || !owner || !cost || !im)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "scale_mpi_gather_volume_image: NULL argument");
    truth_volume_mc_stats *S = &im->stats;
    tiled_image ti = {.width = im->width, .height = im->height, .tile = tile, .planes = VI_PLANES,
                      .rect = truth_volume_mc_task_rect};
    for (int q = 0; q < 4; q++) {
        ti.pl[q] = &im->rgba[q];
        ti.pl[4 + q] = &im->std_error[q];
    }
    /* the counters as 64-bit integers (exact); max_std_error and seconds apart */
    uint64_t mine[VI_COUNTERS] = {S->tentative, S->collisions, S->over_majorant, (uint64_t)S->pixels_hit};
    double mine_d[2] = {S->max_std_error, S->seconds};
    if (c->rank != 0) {
        int64_t n;
        float *buf = pack_owned(&ti, owner, ntasks, c->rank, &n);
        int ok = MPI_Send(mine, VI_COUNTERS, MPI_UINT64_T, 0, TAG_STATS, MPI_COMM_WORLD) == MPI_SUCCESS &&
                 MPI_Send(mine_d, 2, MPI_DOUBLE, 0, TAG_STATS, MPI_COMM_WORLD) == MPI_SUCCESS && xfer(buf, n, 0, 1);
        free(buf);
        return ok ? OBS_STATUS_OK : obs_error(ctx, OBS_STATUS_INTERNAL, "rank %d: MPI_Send to rank 0 failed", c->rank);
    }
    per_rank_start(per_rank, c->size, owner, cost, ntasks, S->collisions, S->seconds);
    for (int r = 1; r < c->size; r++) {
        uint64_t th[VI_COUNTERS];
        double td[2];
        if (MPI_Recv(th, VI_COUNTERS, MPI_UINT64_T, r, TAG_STATS, MPI_COMM_WORLD, MPI_STATUS_IGNORE) != MPI_SUCCESS ||
            MPI_Recv(td, 2, MPI_DOUBLE, r, TAG_STATS, MPI_COMM_WORLD, MPI_STATUS_IGNORE) != MPI_SUCCESS)
            return obs_error(ctx, OBS_STATUS_INTERNAL, "MPI_Recv from rank %d failed", r);
        if (!recv_owned(&ti, owner, ntasks, r))
            return obs_error(ctx, OBS_STATUS_INTERNAL, "MPI_Recv of rank %d's pixels failed", r);
        /* sums over tiles and a maximum, as tvi_run combines its tiles' (exact in any order) */
        S->tentative += th[0];
        S->collisions += th[1];
        S->over_majorant += th[2];
        S->pixels_hit += (int64_t)th[3];
        S->max_std_error = td[0] > S->max_std_error ? td[0] : S->max_std_error;
        S->seconds = td[1] > S->seconds ? td[1] : S->seconds;
        if (per_rank) {
            per_rank[r].rays = th[1];
            per_rank[r].seconds_work = td[1];
        }
    }
    return OBS_STATUS_OK;
}
