/* test_determinism.c: the determinism suite (issue 6, item 5). Every command that renders runs with
 * 1, 2 and 8 threads through the CLI, and every file it writes is compared byte for byte: EXR and PNG
 * files whole, JSON sidecars with the lines that legitimately differ removed (timings, the thread
 * count, the ISA used, and argv/paths that name the run's own output directory). The AO methods are all taken from
 * the registry, so a new technique is covered the moment it is registered. The SIMD and scalar paths
 * (OBS_ISA=scalar) are compared the same way where the project promises identical bytes (the
 * rasterizer and the AO kernels). `study` is left out: its tables are timings by design; its AO
 * images come from the same kernels tested here. */
#include "ao/ao.h"
#include "test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char *cli_path(void) { return OBS_CLI_PATH; }

/* Run `obscura --threads T ARGS...`, where an argument "@SUFFIX" becomes DIR/outSUFFIX, and
 * `-o DIR/out` is appended when no argument starts with '@'. Returns the exit code. */
static int run_threads(int threads, const char *const *args, const char *dir, const char *isa_env)
{
    const char *argv[40];
    char tbuf[16], out[8][1100];
    int n = 0, nout = 0;
    snprintf(tbuf, sizeof tbuf, "%d", threads);
    argv[n++] = "--threads";
    argv[n++] = tbuf;
    for (int i = 0; args[i] && n < 36; i++) {
        if (args[i][0] == '@' && nout < 8) {
            snprintf(out[nout], sizeof out[nout], "%s/out%s", dir, args[i] + 1);
            argv[n++] = out[nout++];
        } else {
            argv[n++] = args[i];
        }
    }
    if (!nout) {
        snprintf(out[0], sizeof out[0], "%s/out", dir);
        argv[n++] = "-o";
        argv[n++] = out[0];
    }
    argv[n] = NULL;
    mkdir(dir, 0777);
    if (isa_env)
        setenv("OBS_ISA", isa_env, 1);
    char err[1100];
    snprintf(err, sizeof err, "%s/stderr.txt", dir);
    int rc = test_spawn(cli_path(), argv, NULL, err);
    if (isa_env)
        unsetenv("OBS_ISA");
    return rc;
}

/* A JSON sidecar without the lines that may differ between runs. */
static char *json_stable(const char *path, const char *dir)
{
    char *t = test_slurp(path, NULL);
    if (!t)
        return NULL;
    char *o = malloc(strlen(t) + 1);
    size_t k = 0;
    for (char *line = t; *line;) {
        char *e = strchr(line, '\n');
        size_t len = e ? (size_t)(e - line + 1) : strlen(line);
        char save = line[len - (e ? 1 : 0)];
        line[len - (e ? 1 : 0)] = 0;
        int drop = strstr(line, "seconds") || strstr(line, "\"threads\"") || strstr(line, "mrays") ||
                   strstr(line, "rays_per_second") || strstr(line, "\"isa_used\"") || strstr(line, dir);
        line[len - (e ? 1 : 0)] = save;
        if (!drop) {
            memcpy(o + k, line, len);
            k += len;
        }
        line += len;
    }
    o[k] = 0;
    free(t);
    return o;
}

/* Compare DIR_A/out* and DIR_B/out* for the given suffixes. */
static int same_outputs(const char *a, const char *b, const char *const *suffixes, char *why, size_t whylen)
{
    for (int i = 0; suffixes[i]; i++) {
        char pa[1100], pb[1100];
        snprintf(pa, sizeof pa, "%s/out%s", a, suffixes[i]);
        snprintf(pb, sizeof pb, "%s/out%s", b, suffixes[i]);
        size_t la = 0, lb = 0;
        char *x, *y;
        if (strstr(suffixes[i], ".json")) {
            x = json_stable(pa, a);
            y = json_stable(pb, b);
            la = x ? strlen(x) : 0;
            lb = y ? strlen(y) : 0;
        } else {
            x = test_slurp(pa, &la);
            y = test_slurp(pb, &lb);
        }
        int same = x && y && la == lb && !memcmp(x, y, la);
        if (!same)
            snprintf(why, whylen, "out%s differs between %s and %s (%s)", suffixes[i], a, b,
                     !x || !y ? "missing" : la != lb ? "sizes differ" : "bytes differ");
        free(x);
        free(y);
        if (!same)
            return 0;
    }
    return 1;
}

static const char *data(const char *name)
{
    static char buf[4][1024];
    static int k;
    k = (k + 1) & 3;
    snprintf(buf[k], sizeof buf[k], "%s/%s", test_data_dir(), name);
    return buf[k];
}

/* Run args with 1, 2 and 8 threads (and, when scalar_too, 2 threads with OBS_ISA=scalar) and
 * compare every output. */
static void check_command(const char *name, const char *const *args, const char *const *suffixes, int scalar_too)
{
    const int threads[3] = {1, 2, 8};
    char dirs[4][1024];
    for (int t = 0; t < 3; t++) {
        snprintf(dirs[t], sizeof dirs[t], "%s/%s_t%d", test_tmpdir(), name, threads[t]);
        int rc = run_threads(threads[t], args, dirs[t], NULL);
        CHECK_MSG(rc == 0, "%s with %d threads exited %d (see %s/stderr.txt)", name, threads[t], rc, dirs[t]);
    }
    char why[4096];
    CHECK_MSG(same_outputs(dirs[0], dirs[1], suffixes, why, sizeof why), "%s: %s", name, why);
    CHECK_MSG(same_outputs(dirs[0], dirs[2], suffixes, why, sizeof why), "%s: %s", name, why);
    if (scalar_too) {
        snprintf(dirs[3], sizeof dirs[3], "%s/%s_scalar", test_tmpdir(), name);
        int rc = run_threads(2, args, dirs[3], "scalar");
        CHECK_MSG(rc == 0, "%s with OBS_ISA=scalar exited %d", name, rc);
        CHECK_MSG(same_outputs(dirs[0], dirs[3], suffixes, why, sizeof why), "%s (scalar ISA): %s", name, why);
    }
}

TEST(determinism_gbuffer_and_truth_give_identical_bytes_for_1_2_8_threads)
{
    const char *g[] = {"gbuffer", data("dragon_plane.glb"), "--size", "160x90", "--guard", "4", NULL};
    const char *gs[] = {".exr", "_normal.png", "_depth.png", ".json", NULL};
    check_command("gbuffer", g, gs, 1);
    if (test_failed())
        return;
    const char *t[] = {"truth", "ao", data("sphere_on_plane.glb"), "--size", "48x32", "--estimator", "obs-sao",
                       "--radius", "0.5", "--max-samples", "128", "--min-samples", "32", NULL};
    const char *ts[] = {".exr", ".png", ".json", NULL};
    check_command("truth", t, ts, 0);
}

TEST(determinism_every_ao_method_gives_identical_bytes_for_1_2_8_threads_and_scalar)
{
    const char *suffixes[] = {".exr", ".png", "_blend.png", ".json", NULL};
    int n = 0;
    for (const ao_method *const *m = ao_methods(); *m; m++, n++) {
        /* a guard band, so the blur's reach and the window crop are part of what is compared */
        const char *a[] = {"ao", "--method", (*m)->name, "--scene", data("dragon_plane.glb"), "--size", "123x77",
                           "--guard", "6", NULL};
        char name[64];
        snprintf(name, sizeof name, "ao_%s", (*m)->name);
        check_command(name, a, suffixes, 1);
        if (test_failed())
            return;
    }
    CHECK(n >= 1);
}

TEST(determinism_compare_gives_identical_bytes_for_1_2_8_threads)
{
    /* two different AO images of one scene */
    const char *dir = test_tmpdir();
    char a[1024], b[1024];
    snprintf(a, sizeof a, "%s/ref", dir);
    snprintf(b, sizeof b, "%s/test", dir);
    const char *ra[] = {"ao", "--method", "sao", "--scene", data("sphere_on_plane.glb"), "--size", "64x48", "-o", a,
                        NULL};
    const char *rb[] = {"ao", "--method", "sao", "--scene", data("sphere_on_plane.glb"), "--size", "64x48", "--radius",
                        "0.4", "-o", b, NULL};
    CHECK_EQ_INT(test_spawn(cli_path(), ra, NULL, NULL), 0);
    CHECK_EQ_INT(test_spawn(cli_path(), rb, NULL, NULL), 0);
    char ae[1100], be[1100];
    snprintf(ae, sizeof ae, "%s.exr", a);
    snprintf(be, sizeof be, "%s.exr", b);
    const char *cc[] = {"compare", ae, be, "--channel", "AO", "--calibrated", "--json", "@.json", "--heatmap",
                        "@_heat.png", "--quiet", NULL};
    const char *cs[] = {".json", "_heat.png", NULL};
    check_command("compare", cc, cs, 0);
}
