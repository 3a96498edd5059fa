/* bench_scene.h: the benchmarks' scene: a mesh framed exactly as the llvmpipe peer
 * (../shared/tools/llvmpipe-peer) frames its OFF mesh, so that both render the same pixels: the
 * mesh is centred on its bounding-box centre and scaled so that the farthest vertex is at radius
 * 10; the camera sits at (0, 0, dist) looking down -Z with fovy 45 degrees, dist = 10 / sin(fovy/2),
 * near = max(dist - 11, 0.5), far = dist + 11. Below it, the cost-growth fit that obscura_bench_sss
 * and obscura_bench_volume print (header-only). */
#ifndef OBS_BENCH_SCENE_H
#define OBS_BENCH_SCENE_H

#include "core/obs.h"

#include <math.h>
#include <stdio.h>

/* Load MESH (glTF/GLB) and frame it. Returns 0, or 3 with the error printed to stderr. */
int bench_load_framed(obs_context *ctx, const char *mesh, obs_scene *out_scene, obs_camera *out_cam);

/* ------------------------------------------------------------------------------------------------
 * Cost growth (obscura_bench_sss --sweep, obscura_bench_volume --growth; docs/results/cost-growth.md).
 * Header-only so that each benchmark takes it without a library: the ordinary least-squares line
 * t = a + b x through the points (x_i, t_i), its coefficient of determination
 * R^2 = 1 - sum (t_i - a - b x_i)^2 / sum (t_i - mean t)^2, and each point's relative residual
 * (t_i - (a + b x_i)) / (a + b x_i). Centred sums (x - mean x), so texel counts of 10^6 lose
 * nothing to cancellation. Not tested: benchmark code, not the library's.
 * ---------------------------------------------------------------------------------------------- */

typedef struct bench_point {
    double param;   /* the swept parameter as the user names it (K, N, map side, n, image width) */
    double x;       /* the fit's abscissa (K, N, texels, voxels, pixels, n) */
    double ms;      /* median of the timed repetitions */
    double ms_min, ms_max;
    double units;   /* the work units of this point (texel-samples, voxels, pixels): ns per unit = ms 1e6 / units */
} bench_point;

typedef struct bench_fit {
    double a, b, r2;
} bench_fit;

static inline bench_fit bench_fit_line(const bench_point *pt, int n)
{
    bench_fit f = {0.0, 0.0, 1.0};
    if (n < 1)
        return f;
    double mx = 0.0, my = 0.0;
    for (int i = 0; i < n; i++) {
        mx += pt[i].x;
        my += pt[i].ms;
    }
    mx /= n;
    my /= n;
    double sxx = 0.0, sxy = 0.0, syy = 0.0;
    for (int i = 0; i < n; i++) {
        const double dx = pt[i].x - mx, dy = pt[i].ms - my;
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    f.b = sxx > 0.0 ? sxy / sxx : 0.0;
    f.a = my - f.b * mx;
    double sr = 0.0;
    for (int i = 0; i < n; i++) {
        const double e = pt[i].ms - (f.a + f.b * pt[i].x);
        sr += e * e;
    }
    f.r2 = syy > 0.0 ? 1.0 - sr / syy : 1.0;
    return f;
}

/* Prints the table of N points and the fit: a header naming TAG (e.g. "sss sampler=exponential
 * axis=K"), one row per point (PNAME, x as XNAME, median, min, max, ns per UNAME, the fitted ms and
 * the relative residual), then one machine-readable line
 *   FIT TAG x=XNAME intercept_ms=a slope_ms=b r2=R2 max_abs_residual_pct=M ns_per_UNAME_first=.. last=..
 * (slope_ms: milliseconds per unit of x). Returns the fit. */
static inline bench_fit bench_growth_print(const char *tag, const char *pname, const char *xname, const char *uname,
                                           const bench_point *pt, int n)
{
    bench_fit f = bench_fit_line(pt, n);
    double worst = 0.0;
    printf("GROWTH %s: t = a + b x with x = %s; per-unit cost = t / (%s)\n", tag, xname, uname);
    printf("  %10s %12s %11s %10s %10s %16s %10s %9s\n", pname, xname, "median ms", "min ms", "max ms", "ns per unit",
           "fit ms", "residual");
    for (int i = 0; i < n; i++) {
        const double fit = f.a + f.b * pt[i].x;
        const double res = fit != 0.0 ? (pt[i].ms - fit) / fit : 0.0;
        worst = fabs(res) > worst ? fabs(res) : worst;
        printf("  %10.0f %12.0f %11.2f %10.2f %10.2f %16.4g %10.2f %+8.1f%%\n", pt[i].param, pt[i].x, pt[i].ms,
               pt[i].ms_min, pt[i].ms_max, pt[i].units > 0.0 ? pt[i].ms * 1e6 / pt[i].units : 0.0, fit, 100.0 * res);
    }
    printf("FIT %s x=%s intercept_ms=%.3f slope_ms=%.6g r2=%.5f max_abs_residual_pct=%.2f points=%d\n", tag, xname, f.a,
           f.b, f.r2, 100.0 * worst, n);
    fflush(stdout);
    return f;
}

#endif
