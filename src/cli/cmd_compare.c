/* cmd_compare.c: `obscura compare A B`: error measures of a test image B against a reference A,
 * with thresholds that set the exit status (docs/compare.md). */
#include "cli.h"
#include "metrics/metrics.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *compare_help =
    "usage: obscura compare REFERENCE TEST [options]\n"
    "Compares TEST (B) against REFERENCE (A), channel by channel, over the valid pixels; the error is\n"
    "B - A. Images are EXR (or anything OpenImageIO reads, e.g. PNG). See docs/compare.md.\n"
    "channels:\n"
    "  --channel NAME          compare channel NAME of both images (repeatable)\n"
    "  --channel-a NAME        reference channel, paired in order with --channel-b (repeatable)\n"
    "  --channel-b NAME        test channel\n"
    "                          default: every float channel present in both under the same name\n"
    "                          (id channels primid, instid, matid excluded)\n"
    "valid pixels:\n"
    "  --mask FILE[:CHANNEL]   valid where the mask channel is nonzero (float; NaN = invalid) or is not\n"
    "                          4294967295 (uint id channels); default channel: the only one, else\n"
    "                          'mask', else 'A'. Without --mask: valid where every input's Z channel\n"
    "                          (if any) is finite (G-buffer background Z = inf).\n"
    "  --ignore-nonfinite      skip (and count) pixels where a compared value is NaN or +-Inf; by\n"
    "                          default such a value at a valid pixel is an error (exit 3)\n"
    "measures:\n"
    "  --peak X                PSNR peak value (default 1)\n"
    "  --threshold X           count pixels with |B - A| > X (default 0.05)\n"
    "  --dynamic-range L       SSIM dynamic range L (default 1)\n"
    "  --calibrated            fit B' = clamp01(1 - g (1 - B^p)) to A (least squares) and report g, p\n"
    "                          and the measures of B'; thresholds then apply to B'\n"
    "outputs:\n"
    "  --json FILE             write every measure, count and parameter as JSON\n"
    "  --heatmap FILE.png      |B - A| (max over channels) through the 'inferno' colour map, invalid\n"
    "                          pixels grey\n"
    "  --heatmap-max X         |error| shown at the top of the colour map (default 0.1)\n"
    "  --quiet                 no table on stdout\n"
    "thresholds (exit 1 when any is violated in any channel, 0 when all hold):\n"
    "  --max-rmse X  --max-abs X  --max-bias X (on |bias|)  --min-psnr X  --min-ssim X\n"
    "  --max-over-threshold F  (fraction of valid pixels over --threshold)\n"
    "exit codes: 0 within thresholds, 1 outside, 2 usage, 3 bad input (missing file, size mismatch,\n"
    "missing channel, NaN, no valid pixel), 4 resource limit, 5 cannot write an output.\n";

#define MAX_PAIRS 64

typedef struct chan_pair {
    const char *name_a, *name_b;
    int ia, ib;
    met_result raw, cal;
    met_fit fit;
    obs_image_f32 calibrated;   /* the calibrated test plane (--calibrated) */
} chan_pair;

typedef struct thresholds {
    double max_rmse, max_abs, max_bias, min_psnr, min_ssim, max_over;
    int has_max_rmse, has_max_abs, has_max_bias, has_min_psnr, has_min_ssim, has_max_over;
} thresholds;


static int is_id_name(const char *n) { return !strcmp(n, "primid") || !strcmp(n, "instid") || !strcmp(n, "matid"); }

/* "R, G, B (uint: primid)" */
static void list_channels(const io_image *im, char *buf, size_t size)
{
    size_t len = 0;
    buf[0] = '\0';
    for (int c = 0; c < im->channel_count && len + 1 < size; c++) {
        int n = snprintf(buf + len, size - len, "%s%s%s", c ? ", " : "", im->names[c],
                         im->types[c] == IO_PIXEL_UINT ? " (uint)" : "");
        if (n < 0)
            break;
        len += (size_t)n;
    }
    if (im->channel_count == 0)
        snprintf(buf, size, "(none)");
}

/* Find a float channel; prints the error and returns -1 when absent or not float. */
static int find_float_channel(const io_image *im, const char *path, const char *role, const char *name)
{
    char list[2048];
    int i = io_image_find_channel(im, name);
    if (i < 0) {
        list_channels(im, list, sizeof list);
        fprintf(stderr, "obscura: error: %s image %s has no channel '%s'; its channels are: %s\n", role, path, name, list);
        return -1;
    }
    if (im->types[i] == IO_PIXEL_UINT) {
        fprintf(stderr, "obscura: error: channel '%s' of %s image %s is an integer (id) channel; compare handles float "
                        "channels only\n", name, role, path);
        return -1;
    }
    return i;
}

/* JSON number where +-inf becomes the string "inf" / "-inf" and NaN becomes null. */
static void json_num(io_json *j, const char *key, double v)
{
    if (isinf(v))
        io_json_string(j, key, v > 0 ? "inf" : "-inf");
    else
        io_json_number(j, key, v);
}

static void json_result(io_json *j, const met_result *r)
{
    io_json_int(j, "valid_pixels", r->valid);
    io_json_int(j, "masked_pixels", r->masked);
    io_json_int(j, "nonfinite_pixels", r->nonfinite);
    json_num(j, "rmse", r->rmse);
    json_num(j, "mse", r->mse);
    json_num(j, "mae", r->mae);
    json_num(j, "bias", r->bias);
    json_num(j, "max_abs", r->max_abs);
    io_json_int(j, "max_abs_x", r->max_x);
    io_json_int(j, "max_abs_y", r->max_y);
    json_num(j, "psnr", r->psnr);
    json_num(j, "ssim", r->ssim);
    io_json_int(j, "ssim_pixels", r->ssim_pixels);
    io_json_int(j, "over_threshold_count", r->over_count);
    json_num(j, "over_threshold_fraction", r->over_fraction);
    json_num(j, "reference_mean", r->ref_mean);
    json_num(j, "test_mean", r->test_mean);
}

static void print_row(const char *label, const met_result *r)
{
    char at[32], psnr[16];
    snprintf(at, sizeof at, "(%d, %d)", r->max_x, r->max_y);
    if (isinf(r->psnr))
        snprintf(psnr, sizeof psnr, "inf");
    else
        snprintf(psnr, sizeof psnr, "%.2f", r->psnr);
    printf("%-28s %9lld %10.6f %10.6f %10.6f %10.6f %-12s %7s %8.5f %8.5f\n", label, (long long)r->valid, r->rmse,
           r->mae, r->bias, r->max_abs, at, psnr, r->ssim, r->over_fraction);
}

/* Check the thresholds against r; print each violation; return the number violated. */
static int check_thresholds(const thresholds *t, const char *label, const met_result *r)
{
    int bad = 0;
#define VIOLATION(fmt, ...) (fprintf(stderr, "obscura: compare: %s: " fmt "\n", label, __VA_ARGS__), bad++)
    if (t->has_max_rmse && !(r->rmse <= t->max_rmse))
        VIOLATION("rmse %.6g > --max-rmse %.6g", r->rmse, t->max_rmse);
    if (t->has_max_abs && !(r->max_abs <= t->max_abs))
        VIOLATION("max |error| %.6g at (%d, %d) > --max-abs %.6g", r->max_abs, r->max_x, r->max_y, t->max_abs);
    if (t->has_max_bias && !(fabs(r->bias) <= t->max_bias))
        VIOLATION("|bias| %.6g > --max-bias %.6g", fabs(r->bias), t->max_bias);
    if (t->has_min_psnr && !(r->psnr >= t->min_psnr))
        VIOLATION("psnr %.6g dB < --min-psnr %.6g", r->psnr, t->min_psnr);
    if (t->has_min_ssim && !(r->ssim >= t->min_ssim)) {
        if (r->ssim != r->ssim)
            VIOLATION("ssim is undefined (no valid pixel has half its window valid), --min-ssim %.6g", t->min_ssim);
        else
            VIOLATION("ssim %.6g < --min-ssim %.6g", r->ssim, t->min_ssim);
    }
    if (t->has_max_over && !(r->over_fraction <= t->max_over))
        VIOLATION("fraction over threshold %.6g > --max-over-threshold %.6g", r->over_fraction, t->max_over);
#undef VIOLATION
    return bad;
}

/* Parse "--flag X" as a float with a range check; returns 0 on success (after setting *out). */
static int float_arg(const char *flag, const char *v, double lo, double hi, double *out)
{
    double x;
    if (!v || !cli_parse_float(v, &x) || !(x >= lo) || !(x <= hi)) {
        cli_usage_error("compare: %s needs a number in [%g, %g]", flag, lo, hi);
        return -1;
    }
    *out = x;
    return 0;
}

int cmd_compare(cli_globals *g, int argc, char **argv)
{
    const char *path_a = NULL, *path_b = NULL, *mask_spec = NULL, *json_path = NULL, *heat_path = NULL;
    const char *chan_same[MAX_PAIRS], *chan_a[MAX_PAIRS], *chan_b[MAX_PAIRS];
    int n_same = 0, n_a = 0, n_b = 0, calibrated = 0, quiet = g->quiet;
    double heat_max = 0.1;
    met_params mp = met_params_default();
    thresholds th;
    memset(&th, 0, sizeof th);
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(compare_help, stdout);
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--channel") || !strcmp(a, "--channel-a") || !strcmp(a, "--channel-b")) {
            if (!v || !v[0])
                return cli_usage_error("compare: %s needs a channel name", a);
            const char **list = a[9] == '\0' ? chan_same : a[10] == 'a' ? chan_a : chan_b;
            int *n = a[9] == '\0' ? &n_same : a[10] == 'a' ? &n_a : &n_b;
            if (*n >= MAX_PAIRS)
                return cli_usage_error("compare: at most %d channels", MAX_PAIRS);
            list[(*n)++] = v;
            i++;
        } else if (!strcmp(a, "--mask")) {
            if (!v || !v[0])
                return cli_usage_error("compare: --mask needs FILE[:CHANNEL]");
            mask_spec = v;
            i++;
        } else if (!strcmp(a, "--json")) {
            if (!v || !v[0])
                return cli_usage_error("compare: --json needs a file name");
            json_path = v;
            i++;
        } else if (!strcmp(a, "--heatmap")) {
            if (!v || !v[0])
                return cli_usage_error("compare: --heatmap needs a file name");
            heat_path = v;
            i++;
        } else if (!strcmp(a, "--calibrated")) {
            calibrated = 1;
        } else if (!strcmp(a, "--ignore-nonfinite")) {
            mp.ignore_nonfinite = 1;
        } else if (!strcmp(a, "--quiet")) {
            quiet = 1;
        } else if (!strcmp(a, "--peak")) {
            if (float_arg(a, v, 1e-30, 1e30, &mp.peak)) return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--threshold")) {
            if (float_arg(a, v, 0.0, 1e30, &mp.threshold)) return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--dynamic-range")) {
            if (float_arg(a, v, 1e-30, 1e30, &mp.dynamic_range)) return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--heatmap-max")) {
            if (float_arg(a, v, 1e-30, 1e30, &heat_max)) return CLI_EXIT_USAGE;
            i++;
        } else if (!strcmp(a, "--max-rmse")) {
            if (float_arg(a, v, 0.0, INFINITY, &th.max_rmse)) return CLI_EXIT_USAGE;
            th.has_max_rmse = 1; i++;
        } else if (!strcmp(a, "--max-abs")) {
            if (float_arg(a, v, 0.0, INFINITY, &th.max_abs)) return CLI_EXIT_USAGE;
            th.has_max_abs = 1; i++;
        } else if (!strcmp(a, "--max-bias")) {
            if (float_arg(a, v, 0.0, INFINITY, &th.max_bias)) return CLI_EXIT_USAGE;
            th.has_max_bias = 1; i++;
        } else if (!strcmp(a, "--min-psnr")) {
            if (float_arg(a, v, -INFINITY, INFINITY, &th.min_psnr)) return CLI_EXIT_USAGE;
            th.has_min_psnr = 1; i++;
        } else if (!strcmp(a, "--min-ssim")) {
            if (float_arg(a, v, -1.0, 1.0, &th.min_ssim)) return CLI_EXIT_USAGE;
            th.has_min_ssim = 1; i++;
        } else if (!strcmp(a, "--max-over-threshold")) {
            if (float_arg(a, v, 0.0, 1.0, &th.max_over)) return CLI_EXIT_USAGE;
            th.has_max_over = 1; i++;
        } else {
            int r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            if (a[0] == '-' && a[1] != '\0') return cli_usage_error("compare: unknown option '%s'", a);
            if (!path_a) path_a = a;
            else if (!path_b) path_b = a;
            else return cli_usage_error("compare: more than two images given ('%s')", a);
        }
    }
    if (!path_a || !path_b)
        return cli_usage_error("compare: needs a reference and a test image (obscura compare A.exr B.exr)");
    if (n_a != n_b)
        return cli_usage_error("compare: %d --channel-a but %d --channel-b; they pair up in order", n_a, n_b);
    if (n_same + n_a > MAX_PAIRS)
        return cli_usage_error("compare: at most %d channels", MAX_PAIRS);
    int any_threshold = th.has_max_rmse || th.has_max_abs || th.has_max_bias || th.has_min_psnr || th.has_min_ssim ||
                        th.has_max_over;

    obs_context *ctx = cli_context(g);
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    io_image A, B, M;
    memset(&A, 0, sizeof A);
    memset(&B, 0, sizeof B);
    memset(&M, 0, sizeof M);
    chan_pair pairs[MAX_PAIRS];
    memset(pairs, 0, sizeof pairs);
    int np = 0, code = CLI_EXIT_OK;
    obs_image_f32 mask_plane = {0}, heat = {0}, rgb[3] = {{0}};
    obs_pool *pool = NULL;
    io_json j;
    io_json_init(&j);
    const char *mask_source = "none", *mask_channel = NULL;
    char mask_file[4096] = "";
    int64_t mask_excluded = 0;
    obs_status st;

    if ((st = io_image_read(ctx, path_a, &A)) != OBS_STATUS_OK || (st = io_image_read(ctx, path_b, &B)) != OBS_STATUS_OK) {
        code = cli_fail(ctx, st);
        goto done;
    }
    if (A.width != B.width || A.height != B.height) {
        fprintf(stderr, "obscura: error: size mismatch: reference %s is %dx%d, test %s is %dx%d\n", path_a, A.width,
                A.height, path_b, B.width, B.height);
        code = CLI_EXIT_INPUT;
        goto done;
    }
    const int W = A.width, H = A.height;

    /* Channel pairs. */
    for (int k = 0; k < n_same; k++) {
        pairs[np].name_a = pairs[np].name_b = chan_same[k];
        np++;
    }
    for (int k = 0; k < n_a; k++) {
        pairs[np].name_a = chan_a[k];
        pairs[np].name_b = chan_b[k];
        np++;
    }
    if (np == 0) {
        for (int c = 0; c < A.channel_count && np < MAX_PAIRS; c++) {
            if (A.types[c] == IO_PIXEL_UINT || is_id_name(A.names[c]))
                continue;
            int cb = io_image_find_channel(&B, A.names[c]);
            if (cb < 0 || B.types[cb] == IO_PIXEL_UINT)
                continue;
            pairs[np].name_a = pairs[np].name_b = A.names[c];
            np++;
        }
        if (np == 0) {
            char la[2048], lb[2048];
            list_channels(&A, la, sizeof la);
            list_channels(&B, lb, sizeof lb);
            fprintf(stderr, "obscura: error: the images have no float channel of the same name; reference %s has: %s; "
                            "test %s has: %s (pair channels with --channel-a NAME --channel-b NAME)\n",
                    path_a, la, path_b, lb);
            code = CLI_EXIT_INPUT;
            goto done;
        }
    }
    for (int k = 0; k < np; k++) {
        pairs[k].ia = find_float_channel(&A, path_a, "reference", pairs[k].name_a);
        if (pairs[k].ia >= 0)
            pairs[k].ib = find_float_channel(&B, path_b, "test", pairs[k].name_b);
        if (pairs[k].ia < 0 || pairs[k].ib < 0) {
            code = CLI_EXIT_INPUT;
            goto done;
        }
    }

    /* The mask plane: --mask, else finite Z in every input that has one, else none. */
    st = obs_image_f32_alloc(ctx, W, H, &mask_plane);
    if (st != OBS_STATUS_OK) {
        code = cli_fail(ctx, st);
        goto done;
    }
    obs_image_f32_fill(&mask_plane, 1.0f);
    if (mask_spec) {
        /* FILE[:CHANNEL]: split at the last ':' unless the whole spec names an existing file. */
        snprintf(mask_file, sizeof mask_file, "%s", mask_spec);
        char *colon = strrchr(mask_file, ':');
        if (colon && colon[1] && !strchr(colon, '/') && access(mask_spec, F_OK) != 0) {
            *colon = '\0';
            mask_channel = mask_spec + (colon - mask_file) + 1;
        }
        if ((st = io_image_read(ctx, mask_file, &M)) != OBS_STATUS_OK) {
            code = cli_fail(ctx, st);
            goto done;
        }
        if (M.width != W || M.height != H) {
            fprintf(stderr, "obscura: error: size mismatch: mask %s is %dx%d, the images are %dx%d\n", mask_file,
                    M.width, M.height, W, H);
            code = CLI_EXIT_INPUT;
            goto done;
        }
        int mc = -1;
        if (mask_channel) {
            mc = io_image_find_channel(&M, mask_channel);
        } else if (M.channel_count == 1) {
            mc = 0;
        } else {
            mc = io_image_find_channel(&M, "mask");
            if (mc < 0)
                mc = io_image_find_channel(&M, "A");
        }
        if (mc < 0) {
            char lm[2048];
            list_channels(&M, lm, sizeof lm);
            if (mask_channel)
                fprintf(stderr, "obscura: error: mask image %s has no channel '%s'; its channels are: %s\n", mask_file,
                        mask_channel, lm);
            else
                fprintf(stderr, "obscura: error: mask image %s has several channels and none named 'mask' or 'A'; "
                                "name one with --mask %s:CHANNEL (its channels are: %s)\n", mask_file, mask_file, lm);
            code = CLI_EXIT_INPUT;
            goto done;
        }
        mask_channel = M.names[mc];
        mask_source = "file";
        for (int y = 0; y < H; y++) {
            float *dst = obs_image_f32_row(&mask_plane, y);
            for (int x = 0; x < W; x++) {
                int ok = M.types[mc] == IO_PIXEL_UINT ? obs_image_u32_row(&M.u32[mc], y)[x] != RAST_ID_NONE
                                                      : met_mask_valid(obs_image_f32_row(&M.f32[mc], y)[x]);
                dst[x] = ok ? 1.0f : 0.0f;
                mask_excluded += !ok;
            }
        }
    } else {
        int za = io_image_find_channel(&A, "Z"), zb = io_image_find_channel(&B, "Z");
        if (za >= 0 && A.types[za] == IO_PIXEL_UINT) za = -1;
        if (zb >= 0 && B.types[zb] == IO_PIXEL_UINT) zb = -1;
        if (za >= 0 || zb >= 0) {
            mask_source = za >= 0 && zb >= 0 ? "Z of both images" : za >= 0 ? "Z of the reference" : "Z of the test";
            for (int y = 0; y < H; y++) {
                float *dst = obs_image_f32_row(&mask_plane, y);
                const float *ra = za >= 0 ? obs_image_f32_row(&A.f32[za], y) : NULL;
                const float *rb = zb >= 0 ? obs_image_f32_row(&B.f32[zb], y) : NULL;
                for (int x = 0; x < W; x++) {
                    int ok = (!ra || isfinite(ra[x])) && (!rb || isfinite(rb[x]));
                    dst[x] = ok ? 1.0f : 0.0f;
                    mask_excluded += !ok;
                }
            }
        }
    }

    pool = obs_pool_create(g->threads);
    if (!pool) {
        fprintf(stderr, "obscura: error: cannot start %d threads\n", g->threads);
        code = CLI_EXIT_INTERNAL;
        goto done;
    }

    /* Measures, per channel pair. */
    for (int k = 0; k < np; k++) {
        chan_pair *cp = &pairs[k];
        const obs_image_f32 *pa = &A.f32[cp->ia], *pb = &B.f32[cp->ib];
        st = met_compare(ctx, pool, pa, pb, &mask_plane, &mp, &cp->raw);
        if (st == OBS_STATUS_INVALID_ARGUMENT && cp->raw.first_nonfinite_input != MET_INPUT_NONE) {
            int in_ref = cp->raw.first_nonfinite_input == MET_INPUT_REFERENCE;
            fprintf(stderr, "obscura: error: non-finite value %g in %s image %s, channel '%s', at pixel (%d, %d) "
                            "(%lld non-finite pixels where the mask is valid); pass --ignore-nonfinite to skip them\n",
                    (double)cp->raw.first_nonfinite_value, in_ref ? "reference" : "test", in_ref ? path_a : path_b,
                    in_ref ? cp->name_a : cp->name_b, cp->raw.first_nonfinite_x, cp->raw.first_nonfinite_y,
                    (long long)cp->raw.nonfinite);
            code = CLI_EXIT_INPUT;
            goto done;
        }
        if (st != OBS_STATUS_OK) {
            code = cli_fail(ctx, st);
            goto done;
        }
        if (cp->raw.valid == 0) {
            fprintf(stderr, "obscura: error: channel '%s' vs '%s': no valid pixel to compare (%lld masked out by %s, "
                            "%lld non-finite)\n", cp->name_a, cp->name_b, (long long)cp->raw.masked,
                    mask_source, (long long)cp->raw.nonfinite);
            code = CLI_EXIT_INPUT;
            goto done;
        }
        if (calibrated) {
            st = met_fit_gain_power(ctx, pool, pa, pb, &mask_plane, &mp, &cp->fit);
            if (st == OBS_STATUS_OK)
                st = obs_image_f32_alloc(ctx, W, H, &cp->calibrated);
            if (st == OBS_STATUS_OK)
                st = met_apply_gain_power(ctx, pb, cp->fit.gain, cp->fit.power, &cp->calibrated);
            if (st == OBS_STATUS_OK)
                st = met_compare(ctx, pool, pa, &cp->calibrated, &mask_plane, &mp, &cp->cal);
            if (st != OBS_STATUS_OK) {
                code = cli_fail(ctx, st);
                goto done;
            }
        }
    }

    /* The table. */
    if (!quiet) {
        printf("reference %s, test %s: %dx%d, valid pixels by %s (%lld of %lld excluded)\n", path_a, path_b, W, H,
               mask_source, (long long)mask_excluded, (long long)W * H);
        printf("%-28s %9s %10s %10s %10s %10s %-12s %7s %8s %8s\n", "channel (reference/test)", "valid", "rmse", "mae",
               "bias", "max_abs", "at (x, y)", "psnr", "ssim", "over");
        for (int k = 0; k < np; k++) {
            char label[160];
            if (!strcmp(pairs[k].name_a, pairs[k].name_b))
                snprintf(label, sizeof label, "%s", pairs[k].name_a);
            else
                snprintf(label, sizeof label, "%s/%s", pairs[k].name_a, pairs[k].name_b);
            print_row(label, &pairs[k].raw);
            if (calibrated) {
                snprintf(label, sizeof label, "  calibrated");
                print_row(label, &pairs[k].cal);
                printf("  fit: gain %.6g, power %.6g%s, fit rmse %.6g\n", pairs[k].fit.gain, pairs[k].fit.power,
                       pairs[k].fit.power_at_bound ? " (at the search bound)" : "", pairs[k].fit.fit_rmse);
                /* [Murphy88]: the calibrated RMSE beside that of the best flat image, and the skill */
                const met_skill sk = met_skill_of(pairs[k].cal.mse, pairs[k].cal.ref_var, 0.0);
                printf("  flat baseline rmse %.6g (the reference's standard deviation), skill %.6g%s\n",
                       sk.baseline_rmse, sk.skill,
                       pairs[k].fit.power_at_bound ? " (fit at its bound: not informative)"
                       : !(sk.skill > 0.0)         ? " (no better than a flat image)"
                                                   : "");
            }
            if (pairs[k].raw.nonfinite > 0)
                printf("  %lld non-finite pixels skipped (--ignore-nonfinite)\n", (long long)pairs[k].raw.nonfinite);
        }
        printf("(error = test - reference; 'over' = fraction with |error| > %g; psnr peak %g)\n", mp.threshold, mp.peak);
    }

    /* Thresholds (on the calibrated measures with --calibrated). */
    int violated = 0;
    for (int k = 0; k < np; k++) {
        char label[160];
        snprintf(label, sizeof label, "%s%s%s%s", pairs[k].name_a, strcmp(pairs[k].name_a, pairs[k].name_b) ? "/" : "",
                 strcmp(pairs[k].name_a, pairs[k].name_b) ? pairs[k].name_b : "", calibrated ? " (calibrated)" : "");
        violated += check_thresholds(&th, label, calibrated ? &pairs[k].cal : &pairs[k].raw);
    }

    /* JSON. */
    if (json_path) {
        io_json_begin_object(&j, NULL);
        cli_json_header(&j, "compare", argc, argv);
        io_json_begin_object(&j, "reference");
        io_json_string(&j, "path", path_a);
        io_json_int(&j, "width", A.width);
        io_json_int(&j, "height", A.height);
        io_json_end_object(&j);
        io_json_begin_object(&j, "test");
        io_json_string(&j, "path", path_b);
        io_json_int(&j, "width", B.width);
        io_json_int(&j, "height", B.height);
        io_json_end_object(&j);
        io_json_begin_object(&j, "mask");
        io_json_string(&j, "source", mask_source);
        if (mask_spec) {
            io_json_string(&j, "path", mask_file);
            io_json_string(&j, "channel", mask_channel);
        }
        io_json_int(&j, "pixels", (int64_t)W * H);
        io_json_int(&j, "excluded_pixels", mask_excluded);
        io_json_end_object(&j);
        io_json_begin_object(&j, "parameters");
        io_json_string(&j, "error", "test - reference");
        io_json_number(&j, "peak", mp.peak);
        io_json_number(&j, "threshold", mp.threshold);
        io_json_number(&j, "ssim_dynamic_range", mp.dynamic_range);
        io_json_int(&j, "ssim_window", MET_SSIM_WINDOW);
        io_json_number(&j, "ssim_sigma", MET_SSIM_SIGMA);
        io_json_number(&j, "ssim_k1", MET_SSIM_K1);
        io_json_number(&j, "ssim_k2", MET_SSIM_K2);
        io_json_bool(&j, "ignore_nonfinite", mp.ignore_nonfinite);
        io_json_bool(&j, "calibrated", calibrated);
        if (calibrated)
            io_json_string(&j, "calibration_model", "clamp01(1 - gain * (1 - clamp01(test)^power))");
        io_json_number(&j, "heatmap_max", heat_max);
        io_json_string(&j, "heatmap_colormap", "inferno");
        io_json_int(&j, "threads", obs_pool_threads(pool));
        io_json_end_object(&j);
        io_json_begin_array(&j, "channels");
        for (int k = 0; k < np; k++) {
            io_json_begin_object(&j, NULL);
            io_json_string(&j, "reference_channel", pairs[k].name_a);
            io_json_string(&j, "test_channel", pairs[k].name_b);
            json_result(&j, &pairs[k].raw);
            if (calibrated) {
                io_json_begin_object(&j, "calibrated");
                io_json_number(&j, "gain", pairs[k].fit.gain);
                io_json_number(&j, "power", pairs[k].fit.power);
                io_json_bool(&j, "power_at_search_bound", pairs[k].fit.power_at_bound);
                json_num(&j, "fit_rmse_unclamped", pairs[k].fit.fit_rmse);
                io_json_int(&j, "fit_evaluations", pairs[k].fit.evaluations);
                const met_skill sk = met_skill_of(pairs[k].cal.mse, pairs[k].cal.ref_var, 0.0);
                json_num(&j, "baseline_rmse", sk.baseline_rmse);
                json_num(&j, "skill", sk.skill);
                io_json_bool(&j, "fit_at_bound", pairs[k].fit.power_at_bound);
                json_result(&j, &pairs[k].cal);
                io_json_end_object(&j);
            }
            io_json_end_object(&j);
        }
        io_json_end_array(&j);
        io_json_begin_object(&j, "thresholds");
        io_json_string(&j, "applied_to", calibrated ? "calibrated" : "raw");
        if (th.has_max_rmse) io_json_number(&j, "max_rmse", th.max_rmse);
        if (th.has_max_abs) io_json_number(&j, "max_abs", th.max_abs);
        if (th.has_max_bias) io_json_number(&j, "max_bias", th.max_bias);
        if (th.has_min_psnr) json_num(&j, "min_psnr", th.min_psnr);
        if (th.has_min_ssim) io_json_number(&j, "min_ssim", th.min_ssim);
        if (th.has_max_over) io_json_number(&j, "max_over_threshold", th.max_over);
        io_json_int(&j, "violated", violated);
        io_json_bool(&j, "passed", violated == 0);
        io_json_end_object(&j);
        io_json_end_object(&j);
        st = cli_make_parent_dirs(ctx, json_path);
        if (st == OBS_STATUS_OK)
            st = io_json_write(ctx, &j, json_path);
        if (st != OBS_STATUS_OK) {
            fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx));
            code = CLI_EXIT_OUTPUT;
            goto done;
        }
    }

    /* Heat map: max |error| over the channels at each pixel valid in any of them; grey elsewhere. */
    if (heat_path) {
        st = obs_image_f32_alloc(ctx, W, H, &heat);
        for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++)
            st = obs_image_f32_alloc(ctx, W, H, &rgb[c]);
        if (st != OBS_STATUS_OK) {
            code = cli_fail(ctx, st);
            goto done;
        }
        obs_image_f32_fill(&heat, NAN);
        for (int k = 0; k < np; k++) {
            const obs_image_f32 *pa = &A.f32[pairs[k].ia];
            const obs_image_f32 *pb = calibrated ? &pairs[k].calibrated : &B.f32[pairs[k].ib];
            for (int y = 0; y < H; y++) {
                const float *ra = obs_image_f32_row(pa, y), *rb = obs_image_f32_row(pb, y);
                const float *rm = obs_image_f32_row(&mask_plane, y);
                float *rh = obs_image_f32_row(&heat, y);
                for (int x = 0; x < W; x++) {
                    if (!met_mask_valid(rm[x]) || !isfinite(ra[x]) || !isfinite(rb[x]))
                        continue;
                    float e = fabsf(rb[x] - ra[x]);
                    if (!(rh[x] >= e))
                        rh[x] = e;
                }
            }
        }
        const float grey = io_srgb_decode(0.5f);
        for (int y = 0; y < H; y++) {
            const float *rh = obs_image_f32_row(&heat, y);
            for (int x = 0; x < W; x++) {
                float c[3];
                if (rh[x] != rh[x]) {
                    c[0] = c[1] = c[2] = grey;
                } else {
                    met_colormap_inferno((double)rh[x] / heat_max, c);
                    for (int q = 0; q < 3; q++)
                        c[q] = io_srgb_decode(c[q]);
                }
                for (int q = 0; q < 3; q++)
                    obs_image_f32_row(&rgb[q], y)[x] = c[q];
            }
        }
        st = cli_make_parent_dirs(ctx, heat_path);
        if (st == OBS_STATUS_OK)
            st = io_png_write(ctx, heat_path, rgb, 3, IO_PNG_SRGB);
        if (st != OBS_STATUS_OK) {
            fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx));
            code = CLI_EXIT_OUTPUT;
            goto done;
        }
    }

    if (any_threshold) {
        if (!quiet)
            printf("thresholds (%s): %s\n", calibrated ? "calibrated" : "raw",
                   violated ? "VIOLATED" : "all hold");
        if (violated)
            code = CLI_EXIT_THRESHOLD;
    }

done:
    for (int k = 0; k < MAX_PAIRS; k++)
        obs_image_f32_free(&pairs[k].calibrated);
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&rgb[c]);
    obs_image_f32_free(&heat);
    obs_image_f32_free(&mask_plane);
    io_json_free(&j);
    obs_pool_destroy(pool);
    io_image_free(&A);
    io_image_free(&B);
    io_image_free(&M);
    obs_context_destroy(ctx);
    return code;
}
