/* metrics.h: the public header of obscura's image-comparison module (prefix met_).
 *
 * Pure computation on float planes (no file I/O, no OpenImageIO): error measures between a
 * reference image A and a test image B over the valid pixels, SSIM, and the calibrated fit of a
 * screen-space AO technique's artistic knobs (gain and power). docs/compare.md gives every
 * definition with its formula and source.
 *
 * Sign convention: the error at a pixel is e = test - reference (B - A), so a positive mean bias
 * means the test image is brighter (less occluded) than the reference.
 *
 * Valid pixels: a pixel enters the measures when the mask (if any) says so -- a mask value m is
 * "valid" when m != 0 and m is not NaN -- and both values are finite. What happens to a
 * non-finite value at a pixel the mask allows is chosen by met_params.ignore_nonfinite.
 *
 * Determinism: every sum is accumulated in double, row-major inside fixed strips of
 * MET_STRIP_ROWS rows, and the strips' partial sums are added in strip order. The decomposition
 * never depends on the number of threads, so the results are bit-identical for any pool (or
 * none) and over repeated runs.
 *
 * Threading: functions take an optional obs_pool (NULL = run on the caller's thread). They are
 * re-entrant; the pool must not be in use by another call at the same time (obs_pool_run is not
 * re-entrant).
 */
#ifndef MET_METRICS_H
#define MET_METRICS_H

#include "../core/obs.h"

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Rows per work unit; fixed so that the summation order never depends on the thread count. */
#define MET_STRIP_ROWS 64

/* SSIM constants of Wang, Bovik, Sheikh & Simoncelli, IEEE TIP 13(4), 2004, section III-C. */
#define MET_SSIM_WINDOW 11        /* window side, pixels */
#define MET_SSIM_RADIUS 5         /* (MET_SSIM_WINDOW - 1) / 2 */
#define MET_SSIM_SIGMA 1.5        /* Gaussian standard deviation, pixels */
#define MET_SSIM_K1 0.01
#define MET_SSIM_K2 0.03

/* Search range of the calibrated fit's power p (see met_fit_gain_power). */
#define MET_FIT_POWER_MIN 0.1
#define MET_FIT_POWER_MAX 10.0

/* Parameters. Start from met_params_default() and change what you need. */
typedef struct met_params {
    double peak;             /* PSNR peak value; > 0, finite. Default 1.0 (AO visibility in [0,1]) */
    double threshold;        /* over_threshold counts pixels with |e| > threshold; >= 0, finite.
                                Default 0.05 */
    double dynamic_range;    /* SSIM's L (C1 = (K1 L)^2, C2 = (K2 L)^2); > 0, finite. Default 1.0 */
    int ignore_nonfinite;    /* 0 (default): a NaN or +-Inf in either image at a pixel the mask
                                allows is an error (OBS_STATUS_INVALID_ARGUMENT).
                                1: such pixels are skipped and counted in met_result.nonfinite */
    int compute_ssim;        /* 1 (default): compute SSIM; 0: leave met_result.ssim NaN */
} met_params;

met_params met_params_default(void);

/* Which input held the first non-finite value (met_result.first_nonfinite_input). */
enum { MET_INPUT_NONE = -1, MET_INPUT_REFERENCE = 0, MET_INPUT_TEST = 1 };

/* The measures over the valid pixels. A measure that is undefined because no pixel is valid is
 * NaN (and psnr is NaN too); psnr is +INFINITY when the valid pixels are identical (mse == 0). */
typedef struct met_result {
    int64_t pixels;          /* width * height */
    int64_t valid;           /* pixels that entered the measures */
    int64_t masked;          /* pixels the mask excluded (mask value 0 or NaN) */
    int64_t nonfinite;       /* mask-allowed pixels skipped for a non-finite value (ignore_nonfinite) */
    /* The first (row-major) mask-allowed pixel with a non-finite value in either image, whether
     * or not it was skipped; input MET_INPUT_NONE and x = y = -1 when there is none. When both
     * images are non-finite at that pixel, the reference is named. */
    int first_nonfinite_x, first_nonfinite_y, first_nonfinite_input;
    float first_nonfinite_value;

    double mse;              /* mean of e^2 */
    double rmse;             /* sqrt(mse) */
    double mae;              /* mean of |e| */
    double bias;             /* mean of e = mean(test - reference) */
    double max_abs;          /* max |e| ... */
    int max_x, max_y;        /* ... at its first pixel in row-major order (-1, -1 when none valid) */
    double psnr;             /* 10 log10(peak^2 / mse), dB */
    int64_t over_count;      /* pixels with |e| > threshold */
    double over_fraction;    /* over_count / valid */
    double ref_mean, test_mean;
    double ref_var;          /* the reference's variance over the valid pixels, (1/n) sum (a - ref_mean)^2:
                                the MSE of the best constant image (met_skill_of) */

    double ssim;             /* mean SSIM over the SSIM pixels (see met_ssim) */
    int64_t ssim_pixels;     /* valid centre pixels whose window holds >= half its weight valid */
} met_result;

/* Compare test against reference over the pixels mask allows (mask NULL: every pixel).
 * Preconditions: ctx may be NULL; ref, test (and mask when not NULL) have data, width and
 * height >= 1 and the same size; strides >= width; p NULL means met_params_default().
 * Returns: OK (out filled; out->valid may be 0, then the measures are NaN);
 * INVALID_ARGUMENT for a NULL or empty plane, a size mismatch, a parameter out of its range, or
 * -- when p->ignore_nonfinite is 0 -- a non-finite value at a mask-allowed pixel (the message
 * names the input, the value and the pixel; out->first_nonfinite_* are set, the measures are NaN);
 * OUT_OF_MEMORY; LIMIT_EXCEEDED (scratch over ctx's max_memory_bytes). */
obs_status met_compare(obs_context *ctx, obs_pool *pool, const obs_image_f32 *ref, const obs_image_f32 *test,
                       const obs_image_f32 *mask, const met_params *p, met_result *out);

/* Mean SSIM only (the same definition and validity rules as met_compare), with an optional
 * per-pixel map. Definition (Wang et al. 2004, eq. 13), per pixel with local weighted statistics:
 *   SSIM = ((2 mu_x mu_y + C1)(2 sigma_xy + C2)) / ((mu_x^2 + mu_y^2 + C1)(sigma_x^2 + sigma_y^2 + C2))
 * over an 11x11 Gaussian window (sigma 1.5, weights summing to 1) centred on the pixel.
 * Deviations from the paper (no mask, MATLAB 'valid' filtering) are documented in docs/compare.md:
 * the window weights are renormalised over the valid pixels inside the image; a valid centre
 * pixel counts when its window's valid weight is at least half its in-image weight.
 * map: NULL, or a plane of the same size that receives the SSIM of each counted pixel and NaN
 * elsewhere. Preconditions and returns as met_compare (out_ssim receives NaN when no pixel
 * counts; out_count may be NULL). */
obs_status met_ssim(obs_context *ctx, obs_pool *pool, const obs_image_f32 *ref, const obs_image_f32 *test,
                    const obs_image_f32 *mask, const met_params *p, double *out_ssim, int64_t *out_count,
                    obs_image_f32 *map);

/* The calibrated fit: the result of fitting
 *     calibrated(v) = clamp01(1 - gain * (1 - clamp01(v)^power))
 * of the test visibility v to the reference r by least squares over the valid pixels: UE4's
 * final blend "1 - (1 - ao^Power) * Intensity" with gain = Intensity (docs/compare.md). */
typedef struct met_fit {
    double gain;             /* g >= 0 */
    double power;            /* p in [MET_FIT_POWER_MIN, MET_FIT_POWER_MAX] */
    double sse;              /* the fit's objective at (g, p): sum over valid pixels of
                                ((1 - r) - g (1 - clamp01(v)^p))^2 (model without the outer clamp) */
    double fit_rmse;         /* sqrt(sse / count) */
    int64_t count;           /* valid pixels used */
    int power_at_bound;      /* 1 when p ended within 1e-6 (relative) of a bound of the range */
    int evaluations;         /* objective evaluations used (for diagnostics) */
} met_fit;

/* Fit (gain, power) as above. For each p the optimal g is closed-form linear least squares,
 * g(p) = max(0, S_ro / S_oo) with o = 1 - v^p, r' = 1 - r; p is searched on u = ln p over
 * [ln 0.1, ln 10]: first a 21-point grid, then Brent's minimiser (Brent 1973, ch. 5) on the
 * bracket around the best grid point, to |du| <= 1e-9. Entirely deterministic.
 * When no pixel has occlusion (S_oo = 0 for every p), g = 1 and p = 1.
 * Preconditions and validity rules as met_compare (the same mask, the same non-finite policy).
 * Returns: OK (out->count may be 0: then gain = power = 1, sse = 0, fit_rmse NaN);
 * INVALID_ARGUMENT; OUT_OF_MEMORY; LIMIT_EXCEEDED. */
obs_status met_fit_gain_power(obs_context *ctx, obs_pool *pool, const obs_image_f32 *ref,
                              const obs_image_f32 *test, const obs_image_f32 *mask, const met_params *p,
                              met_fit *out);

/* 1 when power lies within 1e-6 (relative) of MET_FIT_POWER_MIN or MET_FIT_POWER_MAX: the rule of
 * met_fit.power_at_bound, for a power read back from a table. */
int met_fit_power_at_bound(double power);

/* How much better than a flat image a test is: the flat baseline and the MSE skill score.
 *
 * The fit above can turn an uninformative test into a near-constant image whose calibrated RMSE is
 * the reference's own standard deviation (a constant test calibrates to exactly the reference's
 * mean). So a calibrated RMSE is read beside
 *   baseline_rmse = sqrt(Var(r))                the RMSE of the best constant image (r's mean)
 *   skill         = 1 - MSE / Var(r)            [Murphy88], the MSE skill score with the sample
 *                                               climatology (the reference's mean) as its standard
 * 1 for a perfect test, 0 for one no better than a flat image, negative for worse (an inverted
 * image). Both over the same valid pixels as the MSE.
 *
 * noise_var corrects for a noisy reference r_hat = r + n (n independent of r and of the test):
 * both the MSE and Var(r_hat) are inflated by the mean noise variance, so both are reduced by it
 * (clamped at 0): rmse = sqrt(max(0, mse - noise_var)), baseline_rmse = sqrt(max(0, ref_var -
 * noise_var)), skill = 1 - max(0, mse - noise_var) / max(0, ref_var - noise_var). Pass 0 for an
 * exact reference. skill is NaN when the (corrected) variance is 0 (a flat reference: no image
 * can beat a flat one), and everything is NaN for a negative or non-finite mse or ref_var. */
typedef struct met_skill {
    double rmse;             /* sqrt(max(0, mse - noise_var)) */
    double baseline_rmse;    /* sqrt(max(0, ref_var - noise_var)) */
    double skill;            /* 1 - rmse^2 / baseline_rmse^2 */
} met_skill;

met_skill met_skill_of(double mse, double ref_var, double noise_var);

/* out(x, y) = clamp01(1 - gain (1 - clamp01(test(x, y))^power)) for every pixel; a NaN test
 * value stays NaN (so met_compare's non-finite policy still applies). out may alias test.
 * Preconditions: same sizes, gain >= 0 finite, power > 0 finite. Returns OK or INVALID_ARGUMENT. */
obs_status met_apply_gain_power(obs_context *ctx, const obs_image_f32 *test, double gain, double power,
                                obs_image_f32 *out);

/* The 1-D Gaussian of the SSIM window: w[k] = exp(-(k-5)^2 / (2 * 1.5^2)) / sum, k = 0..10. The
 * 2-D window is w[i] * w[j] (circular-symmetric; sums to 1). */
void met_ssim_weights(double w[MET_SSIM_WINDOW]);

/* The heat-map colour map: matplotlib's "inferno" (N. Smith and S. van der Walt, 2015, CC0),
 * 33 entries of its 256-entry table linearly interpolated. t is clamped to [0, 1] (NaN -> 0).
 * Returns sRGB-encoded components in [0, 1] (decode them before io_png_write with IO_PNG_SRGB). */
void met_colormap_inferno(double t, float srgb[3]);

/* 1 when a mask value marks a valid pixel (m != 0 and not NaN). */
static inline int met_mask_valid(float m) { return m != 0.0f && m == m; }

#ifdef __cplusplus
}
#endif

#endif /* MET_METRICS_H */
