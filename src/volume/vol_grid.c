/* vol_grid.c: scalar volumes (vol.h section 1): allocation under the context's limits, range,
 * bounds, trilinear sampling, type names. Conventions: docs/volume.md, "Volumes and loaders". */
#include "vol.h"

#include <math.h>
#include <stdint.h>
#include <string.h>
#include <strings.h>

/* ---- Type names -------------------------------------------------------------------------------- */

static const char *const vol_type_names[VOL_TYPE_COUNT] = {"u8", "u16", "i16", "f32"};

const char *vol_type_name(vol_type t)
{
    if ((int)t < 0 || t >= VOL_TYPE_COUNT)
        return "unknown";
    return vol_type_names[t];
}

int vol_type_from_name(const char *name, vol_type *out)
{
    /* The short names first, then the spellings NRRD, NIfTI and C use for the same types. */
    static const struct {
        const char *name;
        vol_type type;
    } aliases[] = {
        {"u8", VOL_TYPE_U8},     {"uint8", VOL_TYPE_U8},    {"uchar", VOL_TYPE_U8},
        {"unsigned char", VOL_TYPE_U8},                     {"uint8_t", VOL_TYPE_U8},
        {"u16", VOL_TYPE_U16},   {"uint16", VOL_TYPE_U16},  {"ushort", VOL_TYPE_U16},
        {"unsigned short", VOL_TYPE_U16},                   {"uint16_t", VOL_TYPE_U16},
        {"i16", VOL_TYPE_I16},   {"int16", VOL_TYPE_I16},   {"short", VOL_TYPE_I16},
        {"signed short", VOL_TYPE_I16},                     {"int16_t", VOL_TYPE_I16},
        {"f32", VOL_TYPE_F32},   {"float", VOL_TYPE_F32},   {"float32", VOL_TYPE_F32},
    };
    if (!name || !out)
        return 0;
    for (size_t i = 0; i < sizeof aliases / sizeof aliases[0]; i++) {
        if (strcasecmp(name, aliases[i].name) == 0) {
            *out = aliases[i].type;
            return 1;
        }
    }
    return 0;
}

/* ---- Allocation -------------------------------------------------------------------------------- */

obs_status vol_grid_alloc(obs_context *ctx, int nx, int ny, int nz, const double spacing[3], vol_grid *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_grid_alloc: out is NULL");
    memset(out, 0, sizeof *out);
    if (nx < 1 || ny < 1 || nz < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "volume dimensions %dx%dx%d: each side must be >= 1", nx,
                         ny, nz);
    if (!spacing)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_grid_alloc: spacing is NULL");
    for (int a = 0; a < 3; a++) {
        if (!isfinite(spacing[a]) || !(spacing[a] > 0.0))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "volume spacing (%g, %g, %g): each component must be finite and > 0", spacing[0],
                             spacing[1], spacing[2]);
    }

    /* Limits, before allocating: nx*ny fits int64 (< 2^62); the product with nz is checked for
     * overflow by obs_mul_size, and any overflow is over every limit anyway. */
    obs_limits deflim = obs_limits_default();
    const obs_limits *lim = ctx ? obs_context_limits(ctx) : &deflim;
    size_t voxels, bytes;
    int fits = obs_mul_size((size_t)nx, (size_t)ny, &voxels) && obs_mul_size(voxels, (size_t)nz, &voxels);
    if (!fits || voxels > (size_t)INT64_MAX || (int64_t)voxels > lim->max_voxels)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "volume %dx%dx%d has %.6g voxels, over the limit of %lld (raise it with --max-voxels)", nx,
                         ny, nz, (double)nx * (double)ny * (double)nz, (long long)lim->max_voxels);
    if (!obs_mul_size(voxels, sizeof(float), &bytes) || bytes > (size_t)INT64_MAX ||
        (int64_t)bytes > lim->max_memory_bytes)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "volume %dx%dx%d needs %.6g bytes, over the limit of %lld (raise it with --max-memory)", nx,
                         ny, nz, 4.0 * (double)nx * (double)ny * (double)nz, (long long)lim->max_memory_bytes);

    float *data = (float *)obs_aligned_alloc(bytes);
    if (!data)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "cannot allocate %zu bytes for a %dx%dx%d volume", bytes, nx,
                         ny, nz);
    memset(data, 0, bytes);
    out->nx = nx;
    out->ny = ny;
    out->nz = nz;
    for (int a = 0; a < 3; a++) {
        out->spacing[a] = spacing[a];
        out->origin[a] = 0.0;
    }
    out->data = data;
    out->source_type = VOL_TYPE_F32;
    out->value_min = 0.0f;
    out->value_max = 0.0f;
    return OBS_STATUS_OK;
}

void vol_grid_free(vol_grid *g)
{
    if (!g)
        return;
    obs_aligned_free(g->data);
    memset(g, 0, sizeof *g);
}

void vol_grid_update_range(vol_grid *g)
{
    if (!g || !g->data)
        return;
    size_t n = (size_t)g->nx * (size_t)g->ny * (size_t)g->nz;
    float lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        float v = g->data[i];
        if (!isfinite(v))
            continue;
        if (v < lo)
            lo = v;
        if (v > hi)
            hi = v;
    }
    if (lo > hi) /* no finite value at all */
        lo = hi = 0.0f;
    g->value_min = lo;
    g->value_max = hi;
}

void vol_grid_bounds(const vol_grid *g, double lo[3], double hi[3])
{
    const int n[3] = {g->nx, g->ny, g->nz};
    for (int a = 0; a < 3; a++) {
        lo[a] = g->origin[a] - 0.5 * g->spacing[a];
        hi[a] = g->origin[a] + ((double)n[a] - 0.5) * g->spacing[a];
    }
}

/* ---- Trilinear sampling ------------------------------------------------------------------------ */

/* Split a continuous voxel coordinate into a base index and a fraction, clamped so that
 * [i0, i0+1] stays inside [0, n-1]; at the last voxel i1 = i0 and the fraction is 0. NaN maps to 0. */
static inline void vol_split(double c, int n, int *i0, int *i1, float *t)
{
    if (!(c > 0.0)) { /* also NaN */
        *i0 = *i1 = 0;
        *t = 0.0f;
        return;
    }
    if (c >= (double)(n - 1)) {
        *i0 = *i1 = n - 1;
        *t = 0.0f;
        return;
    }
    double f = floor(c);
    *i0 = (int)f;
    *i1 = *i0 + 1;
    *t = (float)(c - f);
}

float vol_grid_sample(const vol_grid *g, double i, double j, double k)
{
    int x0, x1, y0, y1, z0, z1;
    float tx, ty, tz;
    vol_split(i, g->nx, &x0, &x1, &tx);
    vol_split(j, g->ny, &y0, &y1, &ty);
    vol_split(k, g->nz, &z0, &z1, &tz);
    const size_t sx = 1, sy = (size_t)g->nx, sz = (size_t)g->nx * (size_t)g->ny;
    const float *d = g->data;
    /* Trilinear interpolation as three nested lerps a*(1-t) + b*t: exact at voxel centres (t = 0
     * gives a bit for bit), linear along each axis between them. */
    float c000 = d[x0 * sx + y0 * sy + z0 * sz], c100 = d[x1 * sx + y0 * sy + z0 * sz];
    float c010 = d[x0 * sx + y1 * sy + z0 * sz], c110 = d[x1 * sx + y1 * sy + z0 * sz];
    float c001 = d[x0 * sx + y0 * sy + z1 * sz], c101 = d[x1 * sx + y0 * sy + z1 * sz];
    float c011 = d[x0 * sx + y1 * sy + z1 * sz], c111 = d[x1 * sx + y1 * sy + z1 * sz];
    float ux = 1.0f - tx, uy = 1.0f - ty, uz = 1.0f - tz;
    float c00 = c000 * ux + c100 * tx, c10 = c010 * ux + c110 * tx;
    float c01 = c001 * ux + c101 * tx, c11 = c011 * ux + c111 * tx;
    float c0 = c00 * uy + c10 * ty, c1 = c01 * uy + c11 * ty;
    return c0 * uz + c1 * tz;
}
