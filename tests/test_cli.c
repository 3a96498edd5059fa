/* test_cli.c: the obscura command end to end: outputs, sidecars, exit codes, refusals that
 * leave no files, and determinism across thread counts and instruction sets. */
#include "core/obs.h"
#include "io/io.h"
#include "test.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Run the CLI; stdout and stderr go to <tag>.stdout / <tag>.stderr in the test directory. */
static int run_cli(const char *const *args, const char *tag)
{
    char out[4200], err[4200];
    snprintf(out, sizeof out, "%s/%s.stdout", test_tmpdir(), tag);
    snprintf(err, sizeof err, "%s/%s.stderr", test_tmpdir(), tag);
    return test_spawn(OBS_CLI_PATH, args, out, err);
}

static char *slurp(const char *path, size_t *len) { return test_slurp(path, len); }

static int file_contains(const char *path, const char *needle)
{
    char *b = slurp(path, NULL);
    int r = b && strstr(b, needle) != NULL;
    free(b);
    return r;
}

static int same_bytes(const char *a, const char *b)
{
    size_t la = 0, lb = 0;
    char *x = slurp(a, &la), *y = slurp(b, &lb);
    int r = x && y && la == lb && memcmp(x, y, la) == 0;
    free(x);
    free(y);
    return r;
}

static int exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0;
}

/* No file in dir except our captured stdout/stderr. */
static int dir_has_no_outputs(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return 1;
    struct dirent *e;
    int clean = 1;
    while ((e = readdir(d)) != NULL) {
        const char *n = e->d_name;
        size_t l = strlen(n);
        if (!strcmp(n, ".") || !strcmp(n, ".."))
            continue;
        if ((l > 7 && !strcmp(n + l - 7, ".stdout")) || (l > 7 && !strcmp(n + l - 7, ".stderr")))
            continue;
        fprintf(stderr, "unexpected file %s\n", n);
        clean = 0;
    }
    closedir(d);
    return clean;
}

static const char *scene(const char *name) { return test_path(test_data_dir(), name); }
static const char *tmp(const char *name) { return test_path(test_tmpdir(), name); }
static const char *errf(const char *tag)
{
    static char b[4200];
    snprintf(b, sizeof b, "%s/%s.stderr", test_tmpdir(), tag);
    return b;
}
static const char *outf(const char *tag)
{
    static char b[4200];
    snprintf(b, sizeof b, "%s/%s.stdout", test_tmpdir(), tag);
    return b;
}

TEST(cli_help_and_version_exit_zero)
{
    const char *a1[] = {"--help", NULL};
    CHECK_EQ_INT(run_cli(a1, "help"), 0);
    CHECK(file_contains(outf("help"), "exit codes"));
    const char *a2[] = {"--version", NULL};
    CHECK_EQ_INT(run_cli(a2, "version"), 0);
    CHECK(file_contains(outf("version"), OBS_VERSION_STRING));
    const char *a3[] = {"gbuffer", "--help", NULL};
    CHECK_EQ_INT(run_cli(a3, "ghelp"), 0);
    CHECK(file_contains(outf("ghelp"), "--depth"));
}

TEST(cli_bad_command_lines_are_usage_errors)
{
    const char *a1[] = {"frobnicate", NULL};
    CHECK_EQ_INT(run_cli(a1, "a1"), 2);
    CHECK(file_contains(errf("a1"), "unknown command"));
    const char *a2[] = {"--bogus", NULL};
    CHECK_EQ_INT(run_cli(a2, "a2"), 2);
    const char *a3[] = {"gbuffer", scene("plane.glb"), "--size", "12xq", NULL};
    CHECK_EQ_INT(run_cli(a3, "a3"), 2);
    CHECK(file_contains(errf("a3"), "--size"));
    const char *a4[] = {"--threads", "-3", "gbuffer", scene("plane.glb"), NULL};
    CHECK_EQ_INT(run_cli(a4, "a4"), 2);
    const char *a5[] = {"gbuffer", NULL};
    CHECK_EQ_INT(run_cli(a5, "a5"), 2);
    const char *a6[] = {"gbuffer", scene("plane.glb"), "--depth", "sideways", NULL};
    CHECK_EQ_INT(run_cli(a6, "a6"), 2);
    CHECK(dir_has_no_outputs(test_tmpdir()));
}

TEST(cli_gbuffer_writes_exr_pngs_and_sidecar)
{
    const char *a[] = {"gbuffer", scene("sphere_on_plane.glb"), "-o", tmp("out/sp"), "--size", "160x90", NULL};
    CHECK_EQ_INT(run_cli(a, "run"), 0);
    CHECK(exists(tmp("out/sp.exr")) && exists(tmp("out/sp_normal.png")) && exists(tmp("out/sp_depth.png")));
    CHECK(file_contains(tmp("out/sp.json"), "\"version\""));
    CHECK(file_contains(tmp("out/sp.json"), "\"depth_convention\""));
    CHECK(file_contains(tmp("out/sp.json"), "\"pixels_covered\""));
    obs_context *ctx = obs_context_create();
    io_image im;
    CHECK_OK(io_image_read(ctx, tmp("out/sp.exr"), &im), ctx);
    CHECK(im.width == 160 && im.height == 90);
    const char *want[] = {"Z", "Zndc", "N.X", "N.Y", "N.Z", "Ng.X", "Ng.Y", "Ng.Z", "primid", "instid", "matid"};
    for (int k = 0; k < 11; k++)
        CHECK_MSG(io_image_find_channel(&im, want[k]) >= 0, "channel %s missing", want[k]);
    CHECK(im.types[io_image_find_channel(&im, "primid")] == IO_PIXEL_UINT);
    CHECK(io_image_find_attr(&im, "worldToCamera") != NULL);
    CHECK(io_image_find_attr(&im, "obscura:depth_convention") != NULL);
    /* the centre pixel sees geometry; a finite depth there, and unit normals */
    int z = io_image_find_channel(&im, "Z"), nz = io_image_find_channel(&im, "N.Z");
    float d = obs_image_f32_row(&im.f32[z], 45)[80];
    CHECK(isfinite(d) && d > 0.0f);
    float n0 = obs_image_f32_row(&im.f32[io_image_find_channel(&im, "N.X")], 45)[80];
    float n1 = obs_image_f32_row(&im.f32[io_image_find_channel(&im, "N.Y")], 45)[80];
    float n2 = obs_image_f32_row(&im.f32[nz], 45)[80];
    CHECK_NEAR(n0 * n0 + n1 * n1 + n2 * n2, 1.0, 1e-5);
    io_image_free(&im);
    obs_context_destroy(ctx);
}

TEST(cli_gbuffer_bytes_identical_for_1_2_8_threads_and_both_isas)
{
    const char *t1[] = {"--threads", "1", "gbuffer", scene("dragon_plane.glb"), "-o", tmp("t1"), "--size", "320x180", NULL};
    const char *t2[] = {"--threads", "2", "gbuffer", scene("dragon_plane.glb"), "-o", tmp("t2"), "--size", "320x180", NULL};
    const char *t8[] = {"--threads", "8", "gbuffer", scene("dragon_plane.glb"), "-o", tmp("t8"), "--size", "320x180", NULL};
    const char *sc[] = {"--threads", "2", "gbuffer", scene("dragon_plane.glb"), "-o", tmp("sc"), "--size", "320x180",
                        "--isa", "scalar", NULL};
    CHECK_EQ_INT(run_cli(t1, "t1"), 0);
    CHECK_EQ_INT(run_cli(t2, "t2"), 0);
    CHECK_EQ_INT(run_cli(t8, "t8"), 0);
    CHECK_EQ_INT(run_cli(sc, "sc"), 0);
    CHECK(same_bytes(tmp("t1.exr"), tmp("t2.exr")));
    CHECK(same_bytes(tmp("t1.exr"), tmp("t8.exr")));
    CHECK(same_bytes(tmp("t1.exr"), tmp("sc.exr")));
    CHECK(same_bytes(tmp("t1_normal.png"), tmp("t8_normal.png")));
}

TEST(cli_gbuffer_missing_or_corrupt_scene_is_input_error_and_writes_nothing)
{
    const char *a[] = {"gbuffer", tmp("nope.glb"), "-o", tmp("x"), NULL};
    CHECK_EQ_INT(run_cli(a, "missing"), 3);
    CHECK(file_contains(errf("missing"), "nope.glb"));
    /* a truncated copy of a real scene */
    size_t len;
    char *glb = slurp(scene("plane.glb"), &len);
    CHECK(glb != NULL && len > 100);
    FILE *f = fopen(tmp("cut.glb"), "wb");
    fwrite(glb, 1, len / 2, f);
    fclose(f);
    free(glb);
    const char *b[] = {"gbuffer", tmp("cut.glb"), "-o", tmp("y"), NULL};
    CHECK_EQ_INT(run_cli(b, "cut"), 3);
    CHECK(file_contains(errf("cut"), "cut.glb"));
    unlink(tmp("cut.glb"));
    CHECK(dir_has_no_outputs(test_tmpdir()));
}

TEST(cli_gbuffer_limit_refusal_names_the_flag_and_writes_nothing)
{
    const char *a[] = {"--max-pixels", "1000", "gbuffer", scene("plane.glb"), "-o", tmp("big"), "--size", "64x64", NULL};
    CHECK_EQ_INT(run_cli(a, "pix"), 4);
    CHECK(file_contains(errf("pix"), "--max-pixels"));
    const char *b[] = {"gbuffer", scene("dragon_plane.glb"), "--max-triangles", "100", "-o", tmp("tri"), NULL};
    CHECK_EQ_INT(run_cli(b, "tri"), 4);
    CHECK(file_contains(errf("tri"), "--max-triangles"));
    CHECK(dir_has_no_outputs(test_tmpdir()));
}

TEST(cli_gbuffer_unwritable_output_is_output_error)
{
    /* a path whose parent is a regular file cannot be created */
    FILE *f = fopen(tmp("blocker"), "w");
    fputs("x", f);
    fclose(f);
    const char *a[] = {"gbuffer", scene("plane.glb"), "-o", tmp("blocker/out"), "--size", "32x32", NULL};
    int rc = run_cli(a, "unwritable");
    CHECK_MSG(rc == 5 || rc == 3, "exit %d", rc);
    CHECK(file_contains(errf("unwritable"), "blocker"));
}

TEST(cli_gbuffer_reversed_z_with_infinite_far_stores_near_over_depth)
{
    const char *a[] = {"gbuffer", scene("sphere_on_plane.glb"), "-o", tmp("rz"), "--size", "96x64", "--depth",
                       "reversed-z", "--infinite-far", NULL};
    CHECK_EQ_INT(run_cli(a, "rz"), 0);
    obs_context *ctx = obs_context_create();
    io_image im;
    CHECK_OK(io_image_read(ctx, tmp("rz.exr"), &im), ctx);
    const io_attr *zn = io_image_find_attr(&im, "obscura:znear");
    CHECK(zn != NULL);
    int z = io_image_find_channel(&im, "Z"), d = io_image_find_channel(&im, "Zndc");
    int hits = 0;
    for (int y = 0; y < im.height; y++)
        for (int x = 0; x < im.width; x++) {
            float lin = obs_image_f32_row(&im.f32[z], y)[x], v = obs_image_f32_row(&im.f32[d], y)[x];
            if (!isfinite(lin)) {
                CHECK(v == 0.0f);
                continue;
            }
            CHECK_NEAR(v, zn->f / lin, 1e-6 * (zn->f / lin) + 1e-12);
            hits++;
        }
    CHECK(hits > 100);
    io_image_free(&im);
    obs_context_destroy(ctx);
}

TEST(cli_info_describes_scenes_and_images)
{
    const char *a[] = {"info", scene("cornell_box.glb"), NULL};
    CHECK_EQ_INT(run_cli(a, "scene"), 0);
    CHECK(file_contains(outf("scene"), "cameras:"));
    CHECK(file_contains(outf("scene"), "lights: 1"));
    const char *g[] = {"gbuffer", scene("plane.glb"), "-o", tmp("p"), "--size", "40x30", NULL};
    CHECK_EQ_INT(run_cli(g, "g"), 0);
    const char *b[] = {"info", tmp("p.exr"), NULL};
    CHECK_EQ_INT(run_cli(b, "img"), 0);
    CHECK(file_contains(outf("img"), "channel 'Z'"));
    CHECK(file_contains(outf("img"), "worldToCamera"));
    const char *c[] = {"info", tmp("none.exr"), NULL};
    CHECK_EQ_INT(run_cli(c, "none"), 3);
    CHECK(file_contains(errf("none"), "none.exr"));
}

TEST(cli_output_ending_in_exr_names_the_exr_and_a_bare_prefix_still_works)
{
    /* gbuffer, ao and truth: "-o dir/x.exr" writes dir/x.exr and its siblings beside it (never
     * x.exr.exr); "-o dir/y" writes dir/y.exr as before; "-o dir/z.EXR" writes dir/z.EXR as typed */
    struct {
        const char *tag;
        const char *args[16];
        const char *siblings[4];
    } cmds[] = {
        {"gbuffer", {"gbuffer", scene("plane.glb"), "--size", "32x24", "-o", NULL}, {"_normal.png", "_depth.png", ".json", NULL}},
        {"ao", {"ao", "--method", "sao", "--scene", scene("plane.glb"), "--size", "32x24", "-o", NULL}, {".png", "_blend.png", ".json", NULL}},
        {"truth", {"truth", "ao", scene("plane.glb"), "--size", "16x12", "--max-samples", "16", "--min-samples", "16", "-o", NULL},
         {".png", ".json", NULL}},
    };
    for (int c = 0; c < 3; c++) {
        int n = 0;
        while (cmds[c].args[n])
            n++;
        /* the argument, the stem of the siblings, the EXR's path */
        const char *forms[3][3] = {{"named.exr", "named", "named.exr"}, {"bare", "bare", "bare.exr"},
                                   {"upper.EXR", "upper", "upper.EXR"}};
        for (int f = 0; f < 3; f++) {
            char arg[4200], stem[4200], tag[64], p[4300];
            snprintf(arg, sizeof arg, "%s/%s/%s", test_tmpdir(), cmds[c].tag, forms[f][0]);
            snprintf(stem, sizeof stem, "%s/%s/%s", test_tmpdir(), cmds[c].tag, forms[f][1]);
            cmds[c].args[n] = arg;
            cmds[c].args[n + 1] = NULL;
            snprintf(tag, sizeof tag, "%s_%d", cmds[c].tag, f);
            int rc = run_cli(cmds[c].args, tag);
            CHECK_MSG(rc == 0, "%s -o %s: exit %d", cmds[c].tag, forms[f][0], rc);
            snprintf(p, sizeof p, "%s/%s/%s", test_tmpdir(), cmds[c].tag, forms[f][2]);
            CHECK_MSG(exists(p), "%s: %s missing", cmds[c].tag, p);
            snprintf(p, sizeof p, "%s.exr.exr", stem);
            CHECK_MSG(!exists(p), "%s: %s written", cmds[c].tag, p);
            snprintf(p, sizeof p, "%s.EXR.exr", stem);
            CHECK_MSG(!exists(p), "%s: %s written", cmds[c].tag, p);
            for (int s = 0; cmds[c].siblings[s]; s++) {
                snprintf(p, sizeof p, "%s%s", stem, cmds[c].siblings[s]);
                CHECK_MSG(exists(p), "%s: %s missing", cmds[c].tag, p);
            }
            cmds[c].args[n] = NULL;
        }
    }
}

/* Write plane z of a G-buffer EXR as a one-channel PFM ("Pf", little-endian, rows bottom to top). */
static int write_pfm_from_exr(const char *exr, const char *pfm)
{
    obs_context *ctx = obs_context_create();
    io_image im;
    int ok = 0;
    if (io_image_read(ctx, exr, &im) == OBS_STATUS_OK) {
        int z = io_image_find_channel(&im, "Z");
        FILE *f = fopen(pfm, "wb");
        if (z >= 0 && f) {
            fprintf(f, "Pf\n%d %d\n-1.0\n", im.width, im.height);
            for (int y = im.height - 1; y >= 0; y--)
                fwrite(obs_image_f32_row(&im.f32[z], y), sizeof(float), (size_t)im.width, f);
            ok = 1;
        }
        if (f)
            ok = fclose(f) == 0 && ok;
        io_image_free(&im);
    }
    obs_context_destroy(ctx);
    return ok;
}

TEST(cli_ao_gbuffer_one_channel_image_is_used_as_depth_and_logged)
{
    /* a GPU engineer's depth buffer as a one-channel PFM (read as channel 'Y'): used as depth,
     * the log says so, and SAO's AO equals the one computed from the EXR's Z channel */
    const char *g[] = {"gbuffer", scene("sphere_on_plane.glb"), "-o", tmp("g.exr"), "--size", "64x48", NULL};
    CHECK_EQ_INT(run_cli(g, "g"), 0);
    CHECK(write_pfm_from_exr(tmp("g.exr"), tmp("depth.pfm")));
    const char *a[] = {"ao", "--method", "sao", "--gbuffer", tmp("depth.pfm"), "--intrinsics", tmp("g.json"),
                       "--depth-kind", "linear", "-o", tmp("from_pfm.exr"), NULL};
    int rc = run_cli(a, "pfm");
    CHECK_MSG(rc == 0, "exit %d", rc);
    CHECK(file_contains(errf("pfm"), "only channel 'Y' is used as depth"));
    const char *b[] = {"ao", "--method", "sao", "--gbuffer", tmp("g.exr"), "-o", tmp("from_exr.exr"), NULL};
    CHECK_EQ_INT(run_cli(b, "exr"), 0);
    CHECK(!file_contains(errf("exr"), "used as depth"));
    obs_context *ctx = obs_context_create();
    io_image p, e;
    CHECK_OK(io_image_read(ctx, tmp("from_pfm.exr"), &p), ctx);
    CHECK_OK(io_image_read(ctx, tmp("from_exr.exr"), &e), ctx);
    int cp = io_image_find_channel(&p, "AO"), ce = io_image_find_channel(&e, "AO");
    CHECK(cp >= 0 && ce >= 0 && p.width == e.width && p.height == e.height);
    int64_t differ = 0, valid = 0;
    for (int y = 0; y < p.height && cp >= 0 && ce >= 0; y++)
        for (int x = 0; x < p.width; x++) {
            float u = obs_image_f32_row(&p.f32[cp], y)[x], v = obs_image_f32_row(&e.f32[ce], y)[x];
            differ += !(u == v || (isnan(u) && isnan(v)));
            valid += isfinite(v) && v < 1.0f;
        }
    CHECK_MSG(differ == 0, "%lld pixels differ", (long long)differ);
    CHECK(valid > 100); /* some occlusion, so the comparison means something */
    io_image_free(&p);
    io_image_free(&e);
    obs_context_destroy(ctx);
}
