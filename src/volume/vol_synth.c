/* vol_synth.c: synthetic volumes generated in code (vol.h section 1; docs/volume.md, "Synthetic
 * volumes"): bucky, slab, sphere, hollow box. Each is a pure function of (name, n): no randomness.
 * Spacing 1, and the grid centred on the world origin (origin = -(n-1)/2 on each axis). */
#include "vol.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define VOL_SYNTH_DEFAULT_N 32 /* n = 0 asks for it; the seed thesis' bucky is 32^3 (vol.h) */
#define VOL_SYNTH_MIN_N 4      /* the slab's z range [n/4, 3n/4) and the box's 2-voxel shell need n >= 4 */

/* The 60 vertices of a truncated icosahedron with edge length 2: the even (here: cyclic)
 * permutations of (0, +-1, +-3 phi), (+-1, +-(2 + phi), +-2 phi) and (+-phi, +-2, +-phi^3), with
 * phi the golden ratio (the standard construction; circumradius sqrt(9 phi + 10) ~ 4.956) [R].
 * Returns the count written (60). */
static int vol_synth_truncated_icosahedron(double v[60][3])
{
    const double phi = 0.5 * (1.0 + sqrt(5.0));
    const double base[3][3] = {{0.0, 1.0, 3.0 * phi}, {1.0, 2.0 + phi, 2.0 * phi}, {phi, 2.0, phi * phi * phi}};
    int n = 0;
    for (int b = 0; b < 3; b++) {
        for (int s = 0; s < 8; s++) {
            double p[3];
            int dup = 0;
            for (int a = 0; a < 3; a++) {
                p[a] = (s >> a & 1) ? -base[b][a] : base[b][a];
                if (base[b][a] == 0.0 && (s >> a & 1))
                    dup = 1; /* -0 is +0: that sign combination repeats another */
            }
            if (dup)
                continue;
            for (int r = 0; r < 3; r++) { /* the three cyclic permutations */
                v[n][0] = p[r % 3];
                v[n][1] = p[(r + 1) % 3];
                v[n][2] = p[(r + 2) % 3];
                n++;
            }
        }
    }
    return n;
}

obs_status vol_synth(obs_context *ctx, const char *name, int n, vol_grid *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_synth: out is NULL");
    memset(out, 0, sizeof *out);
    enum { BUCKY, SLAB, SPHERE, BOX, NONE } kind = NONE;
    if (name && strcmp(name, "bucky") == 0)
        kind = BUCKY;
    else if (name && strcmp(name, "slab") == 0)
        kind = SLAB;
    else if (name && strcmp(name, "sphere") == 0)
        kind = SPHERE;
    else if (name && strcmp(name, "box") == 0)
        kind = BOX;
    if (kind == NONE)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "unknown synthetic volume '%s' (known: bucky, slab, sphere, box)", name ? name : "(null)");
    if (n == 0)
        n = VOL_SYNTH_DEFAULT_N;
    if (n < VOL_SYNTH_MIN_N)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "synthetic volume '%s': size %d is below %d", name, n,
                         VOL_SYNTH_MIN_N);
    const double sp[3] = {1.0, 1.0, 1.0};
    obs_status st = vol_grid_alloc(ctx, n, n, n, sp, out);
    if (st != OBS_STATUS_OK)
        return st;
    const double c = 0.5 * (double)(n - 1); /* the grid's centre in voxel coordinates */
    for (int a = 0; a < 3; a++)
        out->origin[a] = -c;
    snprintf(out->source, sizeof out->source, "synthetic:%s:%d", name, n);
    out->source_type = kind == BUCKY ? VOL_TYPE_U8 : VOL_TYPE_F32;
    float *d = out->data;
    const size_t nn = (size_t)n;

    switch (kind) {
    case BUCKY: {
        /* 60 Gaussian blobs on a truncated icosahedron scaled to a circumradius of 0.35 n, each of
         * standard deviation a quarter of the scaled edge (so neighbouring blobs, 4 sigma apart,
         * keep separate maxima); value = 255 * sum of the blobs, clamped to [0, 255] [R]. */
        double v[60][3];
        int nv = vol_synth_truncated_icosahedron(v);
        const double phi = 0.5 * (1.0 + sqrt(5.0));
        const double scale = 0.35 * (double)n / sqrt(9.0 * phi + 10.0);
        const double sigma = 0.25 * 2.0 * scale;
        const double inv2s2 = 1.0 / (2.0 * sigma * sigma);
        const double cutoff2 = 36.0 * sigma * sigma; /* beyond 6 sigma a blob adds < 1.6e-8 of 255 */
        for (int k = 0; k < n; k++)
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    double sum = 0.0;
                    for (int b = 0; b < nv; b++) { /* fixed order: the result never depends on threads */
                        double dx = i - c - scale * v[b][0], dy = j - c - scale * v[b][1], dz = k - c - scale * v[b][2];
                        double r2 = dx * dx + dy * dy + dz * dz;
                        if (r2 < cutoff2)
                            sum += exp(-r2 * inv2s2);
                    }
                    double val = 255.0 * sum;
                    d[((size_t)k * nn + (size_t)j) * nn + (size_t)i] = (float)(val > 255.0 ? 255.0 : val);
                }
        break;
    }
    case SLAB:
        /* Value 1 for z in [n/4, 3n/4) (integer division), 0 elsewhere. */
        for (int k = n / 4; k < 3 * n / 4; k++)
            for (size_t q = 0; q < nn * nn; q++)
                d[(size_t)k * nn * nn + q] = 1.0f;
        break;
    case SPHERE: {
        /* Radius R = 0.4 n about the centre; value clamp(R + 0.5 - r, 0, 1): a linear edge one
         * voxel wide, 0.5 exactly at r = R. */
        const double R = 0.4 * (double)n;
        for (int k = 0; k < n; k++)
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    double dx = i - c, dy = j - c, dz = k - c;
                    double e = R + 0.5 - sqrt(dx * dx + dy * dy + dz * dz);
                    d[((size_t)k * nn + (size_t)j) * nn + (size_t)i] = (float)(e < 0.0 ? 0.0 : e > 1.0 ? 1.0 : e);
                }
        break;
    }
    case BOX:
        /* Value 1 within 2 voxels of any face (a shell 2 voxels thick), 0 inside. */
        for (int k = 0; k < n; k++)
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    int m = i;
                    const int e[5] = {n - 1 - i, j, n - 1 - j, k, n - 1 - k};
                    for (int q = 0; q < 5; q++)
                        m = e[q] < m ? e[q] : m;
                    d[((size_t)k * nn + (size_t)j) * nn + (size_t)i] = m < 2 ? 1.0f : 0.0f;
                }
        break;
    case NONE:
        break;
    }
    vol_grid_update_range(out);
    return OBS_STATUS_OK;
}
