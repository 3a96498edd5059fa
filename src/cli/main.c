/* main.c: the obscura command: global flags, then a subcommand. */
#include "cli.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


#ifndef OBS_GIT_REVISION
#define OBS_GIT_REVISION "unknown"
#endif

static const char *usage_text =
    "usage: obscura [global options] <command> [options]\n"
    "\n"
    "commands:\n"
    "  gbuffer SCENE   render the G-buffer of a glTF scene to EXR, PNG previews and a JSON sidecar\n"
    "  info FILE       describe a scene (.gltf/.glb) or an image (.exr, .png)\n"
    "  truth ao SCENE  ray-traced AO ground truth (Embree) per estimator: EXR mean/stderr/count, PNG, JSON\n"
    "  truth sss SCENE the SSS ground truths: brute-force BSSRDF integral and volumetric random walk\n"
    "  compare A B     compare image B with reference A (RMSE, PSNR, SSIM ...; thresholds set the exit code)\n"
    "  ao --method M   screen-space AO (ao --list: every technique) on a scene's or an external G-buffer\n"
    "  sss SCENE       subsurface scattering (Dal Corso's scattering maps, directional or standard dipole):\n"
    "                  image EXR/PNG, the maps as a layered EXR, JSON\n"
    "  volume FILE     ray cast a volume (NIfTI, NRRD, raw, synthetic), lit by Ropinski's light volume\n"
    "  truth volume F  the exact transmittance against the light volume: NRRD volumes and error statistics\n"
    "  study ao        what accuracy costs in time: sweep the AO techniques against ground truth, report\n"
    "  render SCENE... the scene-driven render: only the passes the scene calls for (AO, SSS, volume),\n"
    "                  view-independent products cached; layered EXR, beauty PNG, JSON with the pass log\n"
    "\n"
    "global options:\n"
    "  --threads N         worker threads (default: all CPUs); output is identical for any N\n"
    "  --quiet, --verbose  less or more logging on stderr\n"
    "  --max-pixels N      refuse images over N pixels (default 268435456)\n"
    "  --max-triangles N   refuse scenes over N triangles (default 268435456)\n"
    "  --max-vertices N    refuse scenes over N vertices (default 268435456)\n"
    "  --max-memory BYTES  refuse single allocations over BYTES (default 17179869184)\n"
    "  --max-spp N         refuse Monte Carlo runs over N samples per pixel (default 1048576): the\n"
    "                      limit on 'truth ao --max-samples'\n"
    "  --help              this text; 'obscura <command> --help' for a command's options\n"
    "  --version           print the version\n"
    "\n"
    "exit codes: 0 success, 1 comparison outside thresholds, 2 usage error, 3 bad input file,\n"
    "            4 resource limit, 5 cannot write output, 6 internal error or out of memory\n";

int cli_exit_for(obs_status st)
{
    switch (st) {
    case OBS_STATUS_OK: return CLI_EXIT_OK;
    case OBS_STATUS_INVALID_ARGUMENT:
    case OBS_STATUS_INVALID_DEPTH_RANGE:
    case OBS_STATUS_UNSUPPORTED_ISA: return CLI_EXIT_USAGE;
    case OBS_STATUS_PARSE_ERROR:
    case OBS_STATUS_UNSUPPORTED:
    case OBS_STATUS_NOT_FOUND: return CLI_EXIT_INPUT;
    case OBS_STATUS_IO_ERROR: return CLI_EXIT_INPUT;
    case OBS_STATUS_LIMIT_EXCEEDED: return CLI_EXIT_LIMIT;
    default: return CLI_EXIT_INTERNAL;
    }
}

int cli_fail(obs_context *ctx, obs_status st)
{
    const char *msg = obs_context_last_error(ctx);
    fprintf(stderr, "obscura: error: %s\n", msg[0] ? msg : obs_status_string(st));
    return cli_exit_for(st);
}

int cli_usage_error(const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "obscura: ");
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\n(run 'obscura --help' for usage)\n");
    return CLI_EXIT_USAGE;
}

int cli_parse_int(const char *s, long long lo, long long hi, long long *out) { return obs_parse_int(s, lo, hi, out); }

int cli_parse_float(const char *s, double *out) { return obs_parse_double(s, out); }

int cli_parse_size(const char *s, int *w, int *h) { return obs_parse_size(s, RAST_MAX_DIM, w, h); }

int cli_limit_flag(cli_globals *g, int argc, char **argv, int *i)
{
    /* --max-spp raises obs_limits.max_samples: --max-samples is already truth ao's per-pixel
     * count (the request), this is the limit the request is checked against. */
    static const char *names[] = {"--max-pixels", "--max-triangles", "--max-vertices", "--max-memory", "--max-spp"};
    int64_t *fields[] = {&g->limits.max_image_pixels, &g->limits.max_triangles, &g->limits.max_vertices,
                         &g->limits.max_memory_bytes, &g->limits.max_samples};
    for (int k = 0; k < 5; k++) {
        if (strcmp(argv[*i], names[k]) != 0)
            continue;
        long long v;
        if (*i + 1 >= argc || !cli_parse_int(argv[*i + 1], 1, (long long)1 << 62, &v)) {
            cli_usage_error("%s needs a positive integer", names[k]);
            return -1;
        }
        *fields[k] = v;
        *i += 1;
        return 1;
    }
    return 0;
}

void cli_json_header(io_json *j, const char *command, int argc, char **argv)
{
    io_json_string(j, "generator", "obscura");
    io_json_string(j, "version", OBS_VERSION_STRING);
    io_json_string(j, "git_revision", OBS_GIT_REVISION);
    io_json_string(j, "command", command);
    io_json_begin_array(j, "argv");
    for (int i = 0; i < argc; i++)
        io_json_string(j, NULL, argv[i]);
    io_json_end_array(j);
}

int cli_main(int argc, char **argv)
{
    cli_globals g;
    memset(&g, 0, sizeof g);
    g.limits = obs_limits_default();
    int i = 1;
    for (; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-')
            break;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage_text, stdout);
            return CLI_EXIT_OK;
        }
        if (!strcmp(a, "--version")) {
            printf("obscura %s (%s)\n", OBS_VERSION_STRING, OBS_GIT_REVISION);
            return CLI_EXIT_OK;
        }
        if (!strcmp(a, "--quiet")) {
            g.quiet = 1;
            continue;
        }
        if (!strcmp(a, "--verbose")) {
            g.verbose = 1;
            continue;
        }
        if (!strcmp(a, "--threads")) {
            long long v;
            if (i + 1 >= argc || !cli_parse_int(argv[i + 1], 0, 256, &v))
                return cli_usage_error("--threads needs an integer in [0, 256]");
            g.threads = (int)v;
            i++;
            continue;
        }
        int r = cli_limit_flag(&g, argc, argv, &i);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r > 0)
            continue;
        return cli_usage_error("unknown option '%s'", a);
    }
    if (i >= argc) {
        fputs(usage_text, stderr);
        return CLI_EXIT_USAGE;
    }
    const char *cmd = argv[i];
    if (!strcmp(cmd, "gbuffer"))
        return cmd_gbuffer(&g, argc - i, argv + i);
    if (!strcmp(cmd, "info"))
        return cmd_info(&g, argc - i, argv + i);
    if (!strcmp(cmd, "truth"))
        return cmd_truth(&g, argc - i, argv + i);
    if (!strcmp(cmd, "compare"))
        return cmd_compare(&g, argc - i, argv + i);
    if (!strcmp(cmd, "ao"))
        return cmd_ao(&g, argc - i, argv + i);
    if (!strcmp(cmd, "study"))
        return cmd_study(&g, argc - i, argv + i);
    if (!strcmp(cmd, "sss"))
        return cmd_sss(&g, argc - i, argv + i);
    if (!strcmp(cmd, "volume"))
        return cmd_volume(&g, argc - i, argv + i, 0);
    if (!strcmp(cmd, "render"))
        return cmd_render(&g, argc - i, argv + i);
    if (!strcmp(cmd, "help")) {
        fputs(usage_text, stdout);
        return CLI_EXIT_OK;
    }
    return cli_usage_error("unknown command '%s'", cmd);
}

#ifndef OBS_CLI_NO_MAIN
/* The fuzz target fuzz_cli_args (tests/fuzz) compiles this file with OBS_CLI_NO_MAIN and calls
 * cli_main itself. */
int main(int argc, char **argv) { return cli_main(argc, argv); }
#endif
