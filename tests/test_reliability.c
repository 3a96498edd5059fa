/* test_reliability.c: issue 6's guarantees that are not one module's business (docs/reliability.md):
 *   - no partial output: a run killed with SIGKILL at any moment leaves no truncated file under a
 *     final name (only io_temp_path's "*.tmp.<pid>.<n>" names may remain);
 *   - every resource-limit refusal of every command exits 4, names the flag that raises the
 *     limit, and writes nothing;
 *   - the fixes for fuzzing findings, as unit tests: JSON strings that are not UTF-8, EXR headers
 *     that declare more bytes than the file has, and the clipper's precision across huge depth
 *     ranges. */
#include "core/obs.h"
#include "io/io.h"
#include "raster/raster.h"
#include "scene_util.h"
#include "test.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

/* ---- running the command -------------------------------------------------------------------- */

/* Start the CLI without waiting (test_spawn waits): a NULL-terminated argument list (argv[0]
 * excluded); stdout and stderr go to <tmpdir>/<tag>.stdout/.stderr. Returns the pid, or -1. */
static pid_t start_cli(const char *const *args, const char *tag)
{
    const char *argv[64];
    int n = 0;
    argv[n++] = OBS_CLI_PATH;
    for (int i = 0; args[i] && n < 63; i++)
        argv[n++] = args[i];
    argv[n] = NULL;
    char out[4200], err[4200];
    snprintf(out, sizeof out, "%s/%s.stdout", test_tmpdir(), tag);
    snprintf(err, sizeof err, "%s/%s.stderr", test_tmpdir(), tag);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, out, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&fa, 2, err, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid;
    int rc = posix_spawn(&pid, OBS_CLI_PATH, &fa, NULL, (char *const *)argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    return rc == 0 ? pid : -1;
}

static int run_cli(const char *const *args, const char *tag)
{
    char out[4200], err[4200];
    snprintf(out, sizeof out, "%s/%s.stdout", test_tmpdir(), tag);
    snprintf(err, sizeof err, "%s/%s.stderr", test_tmpdir(), tag);
    return test_spawn(OBS_CLI_PATH, args, out, err);
}

static int file_contains(const char *path, const char *needle)
{
    char *b = test_slurp(path, NULL);
    int r = b && strstr(b, needle) != NULL;
    free(b);
    return r;
}

static int exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0;
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Number of entries in dir (0 when it does not exist); those named like io_temp_path's
 * temporaries are counted in *tmp. */
static int count_entries(const char *dir, int *tmp)
{
    DIR *d = opendir(dir);
    if (tmp)
        *tmp = 0;
    if (!d)
        return 0;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        n++;
        if (tmp && strstr(e->d_name, ".tmp."))
            (*tmp)++;
    }
    closedir(d);
    return n;
}

static const char *tmp(const char *name) { return test_path(test_tmpdir(), name); }
static const char *scene(const char *name) { return test_path(test_data_dir(), name); }
static const char *errf(const char *tag)
{
    static char b[4200];
    snprintf(b, sizeof b, "%s/%s.stderr", test_tmpdir(), tag);
    return b;
}

/* ---- no partial output ---------------------------------------------------------------------- */

static int same_file(const char *a, const char *b)
{
    size_t la = 0, lb = 0;
    char *x = test_slurp(a, &la), *y = test_slurp(b, &lb);
    int r = x && y && la == lb && memcmp(x, y, la) == 0;
    free(x);
    free(y);
    return r;
}

/* A complete sidecar: one JSON object, braces balanced outside strings, ending "}\n". */
static int complete_json(const char *path)
{
    size_t n = 0;
    char *b = test_slurp(path, &n);
    if (!b)
        return 0;
    int depth = 0, in_str = 0, esc = 0, ok = n >= 3 && b[0] == '{' && b[n - 2] == '}' && b[n - 1] == '\n';
    for (size_t i = 0; ok && i < n; i++) {
        char c = b[i];
        if (in_str) {
            if (esc)
                esc = 0;
            else if (c == '\\')
                esc = 1;
            else if (c == '"')
                in_str = 0;
        } else if (c == '"') {
            in_str = 1;
        } else if (c == '{' || c == '[') {
            depth++;
        } else if (c == '}' || c == ']') {
            if (--depth < 0)
                ok = 0;
        }
    }
    free(b);
    return ok && depth == 0 && !in_str;
}

TEST(reliability_sigkill_at_any_moment_leaves_no_truncated_output)
{
    /* A write-heavy run (a 1024x1024 G-buffer of the dragon: about 8 MB of EXR, two PNGs and a
     * sidecar), first to completion for reference bytes and its duration T, then killed with
     * SIGKILL at 12 moments spread over T. Every file under a final name must be complete and
     * identical to the reference (the output is deterministic); nothing else may exist but
     * io_temp_path's temporaries. */
    const char *names[] = {"out.exr", "out_normal.png", "out_depth.png"};
    mkdir(tmp("ref"), 0777);
    const char *ref_args[] = {"--quiet", "--threads", "2", "gbuffer", scene("dragon_plane.glb"), "--size", "1024x1024",
                              "-o", tmp("ref/out"), NULL};
    double t0 = now();
    CHECK_EQ_INT(run_cli(ref_args, "ref"), 0);
    double T = now() - t0;
    for (int k = 0; k < 3; k++)
        CHECK(exists(test_path(tmp("ref"), names[k])));
    CHECK(complete_json(tmp("ref/out.json")));

    int killed = 0, interrupted_writes = 0, partial_sets = 0;
    const int runs = 12;
    for (int r = 0; r < runs; r++) {
        char dir[64], prefix[4200], tag[32];
        snprintf(dir, sizeof dir, "k%02d", r);
        snprintf(tag, sizeof tag, "kill%02d", r);
        mkdir(tmp(dir), 0777);
        snprintf(prefix, sizeof prefix, "%s/out", tmp(dir));
        const char *args[] = {"--quiet", "--threads", "2", "gbuffer", scene("dragon_plane.glb"), "--size", "1024x1024",
                              "-o", prefix, NULL};
        pid_t pid = start_cli(args, tag);
        CHECK(pid > 0);
        double delay = T * (0.03 + 0.97 * r / (runs - 1)); /* from just after the start to the very end */
        struct timespec ts = {(time_t)delay, (long)((delay - (double)(time_t)delay) * 1e9)};
        nanosleep(&ts, NULL);
        kill(pid, SIGKILL);
        int status;
        CHECK(waitpid(pid, &status, 0) == pid);
        if (WIFSIGNALED(status))
            killed++;
        else
            CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 0, "run %d exited with %d", r, WEXITSTATUS(status));
        int temps = 0, entries = count_entries(tmp(dir), &temps), finals = 0;
        for (int k = 0; k < 3; k++) {
            char p[4300], q[4300];
            snprintf(p, sizeof p, "%s/%s", tmp(dir), names[k]);
            snprintf(q, sizeof q, "%s/%s", tmp("ref"), names[k]);
            if (exists(p)) {
                finals++;
                CHECK_MSG(same_file(p, q), "run %d (killed after %.3f s of %.3f s): %s is not the complete file", r,
                          delay, T, names[k]);
            }
        }
        char js[4300];
        snprintf(js, sizeof js, "%s/out.json", tmp(dir));
        if (exists(js)) {
            finals++;
            CHECK_MSG(complete_json(js), "run %d: out.json is not a complete document", r);
        }
        CHECK_MSG(entries == finals + temps, "run %d: %d entries, %d final files, %d temporaries", r, entries, finals,
                  temps);
        interrupted_writes += temps > 0;
        partial_sets += finals > 0 && finals < 4;
    }
    CHECK_MSG(killed > 0, "no run was killed: the reference took only %.3f s", T);
    fprintf(stderr, "reference run %.3f s; %d of %d runs killed, %d interrupted a write (temporary left), %d left "
            "some but not all outputs\n", T, killed, runs, interrupted_writes, partial_sets);
}

/* ---- limit refusals ------------------------------------------------------------------------- */

TEST(reliability_every_limit_refusal_names_its_flag_and_writes_nothing)
{
    /* inputs: an EXR and a PNG from a small G-buffer */
    mkdir(tmp("in"), 0777);
    const char *mk[] = {"--quiet", "gbuffer", scene("plane.glb"), "--size", "64x48", "-o", tmp("in/g"), NULL};
    CHECK_EQ_INT(run_cli(mk, "mk"), 0);
    int before = count_entries(tmp("in"), NULL);
    /* test_path's buffers rotate: keep our own copies of every path in the table */
    char o[4200], exr[4200], png[4200], cj[4200], hp[4200], plane[4200], box[4200], dragon[4200];
    snprintf(o, sizeof o, "%s", tmp("out/x"));
    snprintf(exr, sizeof exr, "%s", tmp("in/g.exr"));
    snprintf(png, sizeof png, "%s", tmp("in/g_normal.png"));
    snprintf(cj, sizeof cj, "%s", tmp("out/c.json"));
    snprintf(hp, sizeof hp, "%s", tmp("out/h.png"));
    snprintf(plane, sizeof plane, "%s", scene("plane.glb"));
    snprintf(box, sizeof box, "%s", scene("closed_box.glb"));
    snprintf(dragon, sizeof dragon, "%s", scene("dragon_plane.glb"));
    struct {
        const char *flag;
        const char *args[16];
    } cases[] = {
        /* gbuffer: image size, scene size, memory (the file itself, the G-buffer) */
        {"--max-pixels", {"--max-pixels", "1000", "gbuffer", plane, "--size", "64x64", "-o", o}},
        {"--max-pixels", {"gbuffer", plane, "--size", "30x30", "--guard", "8", "--max-pixels", "1000", "-o", o}},
        {"--max-triangles", {"gbuffer", dragon, "--max-triangles", "100", "-o", o}},
        {"--max-vertices", {"gbuffer", plane, "--max-vertices", "10", "--size", "8x8", "-o", o}},
        {"--max-memory", {"gbuffer", plane, "--max-memory", "1000", "--size", "8x8", "-o", o}},
        {"--max-memory", {"--max-memory", "100000", "gbuffer", plane, "--size", "256x256", "-o", o}},
        /* truth ao */
        {"--max-pixels", {"truth", "ao", box, "--size", "64x64", "--max-pixels", "1000", "-o", o}},
        {"--max-triangles", {"truth", "ao", dragon, "--size", "8x8", "--max-triangles", "100", "-o", o}},
        {"--max-vertices", {"truth", "ao", plane, "--size", "8x8", "--max-vertices", "10", "-o", o}},
        {"--max-memory", {"truth", "ao", plane, "--size", "64x64", "--max-memory", "100000", "-o", o}},
        /* info: scenes and images */
        {"--max-triangles", {"info", dragon, "--max-triangles", "100"}},
        {"--max-memory", {"info", plane, "--max-memory", "100"}},
        {"--max-pixels", {"info", exr, "--max-pixels", "100"}},
        {"--max-memory", {"info", exr, "--max-memory", "1000"}},
        {"--max-pixels", {"info", png, "--max-pixels", "100"}},
        /* compare */
        {"--max-pixels", {"compare", exr, exr, "--max-pixels", "100", "--json", cj}},
        {"--max-memory", {"compare", exr, exr, "--max-memory", "10000", "--heatmap", hp}},
        {"--max-pixels", {"--max-pixels", "100", "compare", png, png}},
        /* the samples-per-pixel limit (obs_limits.max_samples, F7): its default, and lowered
         * before and after the command */
        {"--max-spp", {"truth", "ao", box, "--size", "8x8", "--max-samples", "2000000", "-o", o}},
        {"--max-spp", {"--max-spp", "1024", "truth", "ao", box, "--size", "8x8", "--max-samples", "2048", "-o", o}},
        {"--max-spp", {"truth", "ao", box, "--size", "8x8", "--max-samples", "128", "--max-spp", "64", "-o", o}},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char tag[32];
        snprintf(tag, sizeof tag, "case%02zu", c);
        int code = run_cli(cases[c].args, tag);
        char *err = test_slurp(errf(tag), NULL);
        CHECK_MSG(code == 4, "case %zu (%s %s): exit %d, stderr: %s", c, cases[c].args[0], cases[c].args[1], code,
                  err ? err : "");
        CHECK_MSG(err && strstr(err, cases[c].flag), "case %zu: the refusal does not name %s: %s", c, cases[c].flag,
                  err ? err : "");
        free(err);
        CHECK_MSG(count_entries(tmp("out"), NULL) == 0, "case %zu wrote into out/", c);
    }
    CHECK_EQ_INT(count_entries(tmp("in"), NULL), before);
}

/* F7 (docs/reliability.md): --max-spp is the limit on samples per pixel (obs_limits.max_samples,
 * default 2^20); truth ao's --max-samples is the request checked against it. Raising the limit
 * lets a request over the default run; the same request at the default limit is refused. */
TEST(reliability_max_spp_flag_raises_the_samples_per_pixel_limit)
{
    char box[4200], o[4200];
    snprintf(box, sizeof box, "%s", scene("closed_box.glb"));
    snprintf(o, sizeof o, "%s", tmp("spp/x"));
    mkdir(tmp("spp"), 0777);
    /* over the default: refused, naming the flag and the limit, nothing written */
    const char *refused[] = {"truth", "ao", box, "--size", "4x4", "--min-samples", "16", "--max-samples", "2000000",
                             "--target-error", "0.5", "-o", o, NULL};
    CHECK_EQ_INT(run_cli(refused, "spp_refused"), 4);
    CHECK(file_contains(errf("spp_refused"), "--max-spp"));
    CHECK(file_contains(errf("spp_refused"), "max_samples"));
    CHECK_EQ_INT(count_entries(tmp("spp"), NULL), 0);
    /* the same request with the limit raised (a global flag, before the command): it runs; an
     * error bar target of 0.5 stops every pixel after its first 16 samples */
    const char *raised[] = {"--quiet", "--max-spp", "2097152", "truth", "ao", box, "--size", "4x4", "--min-samples",
                            "16", "--max-samples", "2000000", "--target-error", "0.5", "-o", o, NULL};
    CHECK_EQ_INT(run_cli(raised, "spp_raised"), 0);
    CHECK(count_entries(tmp("spp"), NULL) > 0);
    CHECK(file_contains(tmp("spp/x.json"), "\"max_samples\": 2000000"));
    /* a bad value is a usage error naming the flag */
    const char *bad[] = {"--max-spp", "0", "truth", "ao", box, "-o", o, NULL};
    CHECK_EQ_INT(run_cli(bad, "spp_bad"), 2);
    CHECK(file_contains(errf("spp_bad"), "--max-spp"));
}

/* ---- JSON strings that are not UTF-8 (fuzz_json finding) ------------------------------------ */

TEST(json_strings_that_are_not_utf8_get_replacement_characters)
{
    static const struct { const char *in, *out; } cases[] = {
        {"caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80", "caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80"}, /* valid: kept */
        {"caf\xe9", "caf\xef\xbf\xbd"},                                    /* Latin-1 */
        {"\xff\xfe", "\xef\xbf\xbd\xef\xbf\xbd"},                          /* never valid */
        {"\xc0\xaf", "\xef\xbf\xbd\xef\xbf\xbd"},                          /* overlong '/' */
        {"\xed\xa0\x80", "\xef\xbf\xbd\xef\xbf\xbd\xef\xbf\xbd"},          /* a UTF-16 surrogate */
        {"\xf4\x90\x80\x80", "\xef\xbf\xbd\xef\xbf\xbd\xef\xbf\xbd\xef\xbf\xbd"}, /* above U+10FFFF */
        {"\xe2\x82", "\xef\xbf\xbd\xef\xbf\xbd"},                          /* truncated at the end */
        {"a\xe2\x82z", "a\xef\xbf\xbd\xef\xbf\xbdz"},                      /* truncated inside */
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        io_json j;
        io_json_init(&j);
        io_json_begin_object(&j, NULL);
        io_json_string(&j, cases[c].in, cases[c].in); /* keys too */
        io_json_end_object(&j);
        CHECK(!j.failed);
        char want[256];
        snprintf(want, sizeof want, "{\n  \"%s\": \"%s\"\n}", cases[c].out, cases[c].out);
        CHECK_MSG(strcmp(j.buf, want) == 0, "case %zu: got %s", c, j.buf);
        io_json_free(&j);
    }
    /* end to end: a Latin-1 output prefix lands in the sidecar's argv as U+FFFD */
    char prefix[4200];
    snprintf(prefix, sizeof prefix, "%s/caf\xe9", test_tmpdir());
    const char *a[] = {"--quiet", "gbuffer", scene("plane.glb"), "--size", "8x8", "-o", prefix, NULL};
    CHECK_EQ_INT(run_cli(a, "latin1"), 0);
    char js[4300];
    snprintf(js, sizeof js, "%s.json", prefix);
    CHECK(file_contains(js, "caf\xef\xbf\xbd\""));
    CHECK(!file_contains(js, "caf\xe9"));
}

/* ---- EXR headers that lie about their size (fuzz_exr finding) ------------------------------- */

TEST(image_header_sizes_that_lie_are_refused_before_the_decoders_allocate)
{
    /* The fuzzer's 65 bytes: a "capDate" string attribute declaring 1,668,481,024 bytes. Through
     * OpenImageIO alone this took 1.7 GB and 4.5 s to fail; it must now fail at once (the header
     * pre-check of io_image_oiio.cpp). */
    const char *path = test_path(test_source_dir(), "tests/fuzz/regressions/exr/capdate-declares-1.6GB-in-65-bytes.exr");
    size_t len = 0;
    char *bytes = test_slurp(path, &len);
    CHECK(bytes != NULL && len == 65);
    obs_context *ctx = obs_context_create();
    io_image im;
    /* load the image module (OpenImageIO, docs/io.md) before the clock starts: its one-time
     * loading (about 1 s under ASan on a loaded machine) is not what this bound is about */
    CHECK_OK(io_image_module_load(ctx), ctx);
    double t0 = now();
    CHECK_EQ_INT(io_image_read(ctx, path, &im), OBS_STATUS_PARSE_ERROR);
    CHECK(strstr(obs_context_last_error(ctx), "'capDate'") && strstr(obs_context_last_error(ctx), "1668481024"));
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(io_image_read_memory(ctx, "lie.exr", bytes, len, &im), OBS_STATUS_PARSE_ERROR);
    CHECK(strstr(obs_context_last_error(ctx), "'capDate'") != NULL);
    /* the second finding: a channel list that runs past its declared 231 bytes, after which
     * OpenEXR read the following bytes as a string attribute of 1.6 GB (22 s, 1.7 GB) */
    obs_context_clear_error(ctx);
    const char *path2 = test_path(test_source_dir(),
                                  "tests/fuzz/regressions/exr/chlist-overrunning-its-size-then-1.6GB-string.exr");
    CHECK_EQ_INT(io_image_read(ctx, path2, &im), OBS_STATUS_PARSE_ERROR);
    CHECK(strstr(obs_context_last_error(ctx), "'channels' (chlist) does not fill its declared 231 bytes") != NULL);
    /* the third: a 144-byte PNG whose tEXt chunk declares 2,003,133,040 bytes, which libpng
     * allocated and cleared before failing (2 GB, 14 s) */
    obs_context_clear_error(ctx);
    const char *path3 = test_path(test_source_dir(),
                                  "tests/fuzz/regressions/exr/png-text-chunk-declaring-2GB-in-144-bytes.png");
    CHECK_EQ_INT(io_image_read(ctx, path3, &im), OBS_STATUS_PARSE_ERROR);
    CHECK(strstr(obs_context_last_error(ctx), "PNG chunk 'tEXt'") && strstr(obs_context_last_error(ctx), "2003133040"));
    CHECK_MSG(now() - t0 < 2.0, "the refusals took %.2f s", now() - t0);
    /* the fourth: a chunk offset of -1, which OpenImageIO's own memory reader turned into a read
     * of the byte before the buffer (ASan); the bounded reader fails it cleanly */
    obs_context_clear_error(ctx);
    size_t len4 = 0;
    char *bytes4 = test_slurp(test_path(test_source_dir(),
                                        "tests/fuzz/regressions/exr/negative-chunk-offset-reads-before-the-buffer.exr"),
                              &len4);
    CHECK(bytes4 != NULL && len4 > 0);
    char *exact = malloc(len4); /* an exact-size heap copy, so that ASan sees a read outside it */
    memcpy(exact, bytes4, len4);
    CHECK_EQ_INT(io_image_read_memory(ctx, "offsets.exr", exact, len4, &im), OBS_STATUS_PARSE_ERROR);
    CHECK(im.channel_count == 0 && im.f32 == NULL);
    free(exact);
    free(bytes4);
    CHECK(im.channel_count == 0 && im.f32 == NULL);
    free(bytes);

    /* a data window over the pixel limit is refused from the header, before any decoding */
    obs_image_f32 z;
    CHECK_OK(obs_image_f32_alloc(ctx, 40, 30, &z), ctx);
    io_channel ch = {"Z", IO_PIXEL_FLOAT, &z, NULL};
    CHECK_OK(io_exr_write(ctx, tmp("z.exr"), &ch, 1, NULL, 0), ctx);
    obs_image_f32_free(&z);
    obs_limits lim = obs_limits_default();
    lim.max_image_pixels = 1199;
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(io_image_read(ctx, tmp("z.exr"), &im), OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(strstr(obs_context_last_error(ctx), "dataWindow") && strstr(obs_context_last_error(ctx), "--max-pixels"));
    lim.max_image_pixels = 1200;
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK_OK(io_image_read(ctx, tmp("z.exr"), &im), ctx);
    io_image_free(&im);
    obs_context_destroy(ctx);
}

/* ---- clipping across a huge depth range (fuzz_gltf finding) --------------------------------- */

TEST(raster_clip_keeps_precision_across_a_huge_depth_range)
{
    /* The fuzzer's triangle, in view space (camera at the origin looking down -Z): one corner far
     * off-screen to the left at depth 10.8, one at the image centre at the same depth, one at
     * depth 1.5e29. Clipping the long edge against the left guard plane used to interpolate from
     * the far corner with t rounded to 1: the new vertex landed at z = 0 (w = 0) and its screen
     * position was NaN (undefined behaviour converting it to an integer; UBSan's report).
     * The coverage must match the exactly projected triangle, pixel centre by pixel centre.
     * In a plain build the old NaN became INT64_MIN without a trace (the broken piece lies in the
     * guard band), so the regression shows under OBS_SANITIZE (CI's sanitizer stage), as a UBSan
     * report from this test; the coverage check guards the fix's correctness. */
    const float pos[9] = {-131073.015625f, -5.96046448e-08f, -10.7703295f, -1.08422712e-19f, -5.96046448e-08f,
                          -10.7703295f, -1.08422712e-19f, 5.88492008e+28f, -1.47123004e+29f};
    const uint32_t idx[3] = {0, 1, 2};
    obs_scene s;
    tu_scene_one_mesh(&s, pos, 3, NULL, idx, 1);
    obs_camera cam = obs_camera_look_at(obs_v3(0, 0, 0), obs_v3(0, 0, -1), obs_v3(0, 1, 0), 0.785398185f, 0.1f, INFINITY);
    obs_context *ctx = obs_context_create();
    for (int isa = RAST_ISA_SCALAR; isa <= RAST_ISA_AVX2; isa++) {
        if (!rast_isa_available((rast_isa)isa))
            continue;
        rast_params p = rast_params_default();
        p.width = 24;
        p.height = 16;
        p.guard = 2;
        p.isa = (rast_isa)isa;
        rast_gbuffer gb;
        CHECK_OK(rast_gbuffer_alloc(ctx, &p, &gb), ctx);
        rast_view view = {cam};
        rast_stats st;
        CHECK_OK(rast_render(ctx, NULL, &s, &view, 1, &p, &gb, &st), ctx);
        const rast_view_constants *vc = &gb.constants;
        /* the exact projection, in double, of the float corners (all in front of the camera) */
        double sx[3], sy[3];
        for (int k = 0; k < 3; k++) {
            double w = -(double)pos[3 * k + 2];
            sx[k] = vc->cx + vc->fx * (double)pos[3 * k] / w;
            sy[k] = vc->cy - vc->fy * (double)pos[3 * k + 1] / w;
        }
        int covered = 0, checked = 0;
        for (int y = 0; y < gb.height; y++)
            for (int x = 0; x < gb.width; x++) {
                double px = x + 0.5, py = y + 0.5, e[3];
                for (int k = 0; k < 3; k++) {
                    int a = k, b = (k + 1) % 3;
                    e[k] = (sx[b] - sx[a]) * (py - sy[a]) - (sy[b] - sy[a]) * (px - sx[a]);
                    double len = hypot(sx[b] - sx[a], sy[b] - sy[a]);
                    e[k] /= len; /* signed distance in pixels */
                }
                int inside = (e[0] > 0.01 && e[1] > 0.01 && e[2] > 0.01) || (e[0] < -0.01 && e[1] < -0.01 && e[2] < -0.01);
                int outside = !((e[0] >= -0.01 && e[1] >= -0.01 && e[2] >= -0.01) ||
                                (e[0] <= 0.01 && e[1] <= 0.01 && e[2] <= 0.01));
                float d = obs_image_f32_row(&gb.depth, y)[x];
                int hit = obs_image_u32_row(&gb.instance_id, y)[x] != RAST_ID_NONE;
                CHECK_MSG(hit ? (d > 0.0f && d < INFINITY) : d == INFINITY, "%s pixel (%d, %d): depth %g, hit %d",
                          rast_isa_name((rast_isa)isa), x, y, (double)d, hit);
                if (inside || outside) {
                    checked++;
                    CHECK_MSG(hit == inside, "%s pixel (%d, %d): covered %d, the exact triangle says %d",
                              rast_isa_name((rast_isa)isa), x, y, hit, inside);
                }
                covered += hit;
            }
        CHECK_MSG(covered > 0 && checked > gb.width * gb.height / 2, "covered %d, checked %d", covered, checked);
        rast_gbuffer_free(&gb);
    }
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}
