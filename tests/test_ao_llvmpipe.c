/* test_ao_llvmpipe.c: our SAO, MIP pyramid and blur against the same shaders run by Mesa's llvmpipe
 * (the peer in ../shared/tools/llvmpipe-peer, README section 5). The peer is built into the build
 * tree (never copied into the repository), run on the Stanford bunny, and its CSZ buffer and
 * uniforms are fed to our kernel. When the peer cannot be built or run (no EGL/GL development
 * packages, no llvmpipe, no mesh), the test prints why and exits with 77, which ctest reports as
 * skipped (SKIP_RETURN_CODE in tests/CMakeLists.txt).
 *
 * The numbers this test prints are the ones recorded in docs/ao/sao.md. */
#include "ao/ao.h"
#include "core/obs.h"
#include "test.h"

#include <fcntl.h>
#include <math.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;

#define SKIP_CODE 77

/* Skip (exit 77). Under CI=true only the absence of the peer's source is a skip (the peer lives
 * outside this repository, in ../shared; the project's own SAO port, tests/gl/test_gl_sao.c,
 * runs everywhere); a peer that is present but cannot be built or run fails the test there. */
static void skip(const char *fmt, const char *arg)
{
    const char *ci = getenv("CI");
    const int fail = ci && !strcmp(ci, "true") && strncmp(fmt, "no peer source", 14) != 0;
    printf(fail ? "FAIL under CI=true: " : "llvmpipe unavailable, skipping: ");
    printf(fmt, arg);
    printf("\n");
    fflush(stdout);
    exit(fail ? 1 : SKIP_CODE);
}

/* Run argv (argv[0] = program path), output to log; returns the exit code or -1. */
static int run(char *const *argv, const char *log)
{
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    pid_t pid;
    int rc = posix_spawnp(&pid, argv[0], &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0)
        return -1;
    int status;
    if (waitpid(pid, &status, 0) < 0 || !WIFEXITED(status))
        return -1;
    return WEXITSTATUS(status);
}

static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = malloc((size_t)n + 1);
    size_t got = fread(b, 1, (size_t)n, f);
    fclose(f);
    b[got] = '\0';
    if (len)
        *len = got;
    return b;
}

/* "key": number, or the idx-th number of "key": [ ... ] */
static int json_num(const char *js, const char *key, int idx, double *out)
{
    char pat[80];
    snprintf(pat, sizeof pat, "\"%s\":", key);
    const char *p = strstr(js, pat);
    if (!p)
        return 0;
    p += strlen(pat);
    while (*p == ' ')
        p++;
    if (*p == '[') {
        p++;
        for (int i = 0; i < idx; i++) {
            p = strchr(p, ',');
            if (!p)
                return 0;
            p++;
        }
    }
    char *end;
    *out = strtod(p, &end);
    return end != p;
}

typedef struct peer_dump {
    int W, H;
    float *csz, *ao, *ao_mip, *ao_blur; /* GL row order */
    double proj_info[4], proj_scale, radius, bias, intensity, epsilon, edge_k;
    int taps, turns, max_mip;
} peer_dump;

static float *load_f32(const char *prefix, const char *name, size_t n)
{
    char path[4200];
    snprintf(path, sizeof path, "%s_%s.f32", prefix, name);
    size_t len = 0;
    char *b = slurp(path, &len);
    if (!b || len != n * sizeof(float)) {
        free(b);
        return NULL;
    }
    return (float *)b;
}

static const char *peer_binary(void)
{
    static char bin[4200];
    char src[2048], dir[2048], log[4200];
    snprintf(src, sizeof src, "%s/../shared/tools/llvmpipe-peer/peer.c", test_source_dir());
    if (access(src, R_OK) != 0)
        skip("no peer source at %s", src);
    snprintf(dir, sizeof dir, "%s/llvmpipe-peer", test_binary_dir());
    mkdir(dir, 0777);
    snprintf(bin, sizeof bin, "%s/peer", dir);
    snprintf(log, sizeof log, "%s/build.log", dir);
    struct stat sb, ss;
    if (stat(bin, &sb) == 0 && stat(src, &ss) == 0 && sb.st_mtime >= ss.st_mtime)
        return bin;
    /* the peer's Makefile line, with the output in the build tree */
    char *argv[] = {"cc", "-O2", "-Wall", "-Wextra", "-std=c11", "-D_GNU_SOURCE", "-o", bin, src,
                    "-lEGL", "-lOpenGL", "-lz", "-lm", NULL};
    if (run(argv, log) != 0)
        skip("the peer does not build (EGL/OpenGL dev packages missing? scripts/setup.sh --dev); see %s", log);
    return bin;
}

/* Run the peer on the bunny at W x H; fill d. Skips when the peer cannot run on llvmpipe. */
static void peer_run(int W, int H, const char *extra, const char *tag, peer_dump *d)
{
    const char *bin = peer_binary();
    char mesh[2048], prefix[2048], log[4200], ws[16], hs[16];
    snprintf(mesh, sizeof mesh, "%s/data/cache/bunny00.off", test_source_dir());
    if (access(mesh, R_OK) != 0)
        skip("no bunny mesh at %s (scripts/setup.sh extracts it)", mesh);
    snprintf(prefix, sizeof prefix, "%s/%s", test_tmpdir(), tag);
    snprintf(log, sizeof log, "%s/%s.log", test_tmpdir(), tag);
    snprintf(ws, sizeof ws, "%d", W);
    snprintf(hs, sizeof hs, "%d", H);
    char *argv[32] = {(char *)bin, mesh, "--w", ws, "--h", hs, "--frames", "1", "--warmup", "0", "--out", prefix};
    char extra_buf[256];
    snprintf(extra_buf, sizeof extra_buf, "%s", extra);
    int na = 12;
    for (char *t = strtok(extra_buf, " "); t && na < 31; t = strtok(NULL, " "))
        argv[na++] = t;
    argv[na] = NULL;
    if (run(argv, log) != 0)
        skip("the peer did not run (no llvmpipe / EGL surfaceless?); see %s", log);
    char *out = slurp(log, NULL);
    if (!out || !strstr(out, "GL_RENDERER: llvmpipe")) {
        free(out);
        skip("the peer's renderer is not llvmpipe; see %s", log);
    }
    free(out);
    char jp[4200];
    snprintf(jp, sizeof jp, "%s.json", prefix);
    char *js = slurp(jp, NULL);
    if (!js)
        skip("the peer wrote no sidecar; see %s", log);
    double v;
    memset(d, 0, sizeof *d);
    int ok = json_num(js, "width", 0, &v) && (d->W = (int)v) > 0;
    ok = ok && json_num(js, "height", 0, &v) && (d->H = (int)v) > 0;
    for (int i = 0; ok && i < 4; i++)
        ok = json_num(js, "projInfo", i, &d->proj_info[i]);
    ok = ok && json_num(js, "projScale", 0, &d->proj_scale) && json_num(js, "radius", 0, &d->radius) &&
         json_num(js, "bias", 0, &d->bias) && json_num(js, "intensity", 0, &d->intensity) &&
         json_num(js, "epsilon", 0, &d->epsilon) && json_num(js, "blur_edgeK", 0, &d->edge_k);
    ok = ok && json_num(js, "taps", 0, &v) && (d->taps = (int)v) > 0;
    ok = ok && json_num(js, "spiral_turns", 0, &v) && (d->turns = (int)v) > 0;
    ok = ok && json_num(js, "max_mip_level", 0, &v) && (d->max_mip = (int)v) > 0;
    free(js);
    if (!ok)
        skip("the peer's sidecar lacks a field this test reads (%s)", jp);
    size_t n = (size_t)d->W * d->H;
    d->csz = load_f32(prefix, "csz", n);
    d->ao = load_f32(prefix, "ao", n);
    d->ao_mip = load_f32(prefix, "ao_mip", n);
    d->ao_blur = load_f32(prefix, "ao_blur", n);
    if (!d->csz || !d->ao || !d->ao_mip || !d->ao_blur)
        skip("the peer's dumps are missing or short (%s_*.f32)", prefix);
}

static void peer_free(peer_dump *d)
{
    free(d->csz);
    free(d->ao);
    free(d->ao_mip);
    free(d->ao_blur);
}

/* Our input from the peer's CSZ: linear depth = -csz (exact), background (0) = +inf, rows flipped
 * to our order; the pixel model from projInfo (the constants below use projInfo itself). */
typedef struct our_input {
    obs_image_f32 depth;
    ao_input in;
} our_input;

static int make_input(obs_context *ctx, const peer_dump *d, our_input *o)
{
    memset(o, 0, sizeof *o);
    if (obs_image_f32_alloc(ctx, d->W, d->H, &o->depth) != OBS_STATUS_OK)
        return 0;
    for (int y = 0; y < d->H; y++)
        for (int x = 0; x < d->W; x++) {
            float z = d->csz[(size_t)(d->H - 1 - y) * d->W + x];
            obs_image_f32_row(&o->depth, y)[x] = z == 0.0f ? INFINITY : -z;
        }
    ao_input *in = &o->in;
    in->width = in->w = d->W;
    in->height = in->h = d->H;
    in->depth = &o->depth;
    in->fx = -1.0 / d->proj_info[0];
    in->fy = -1.0 / d->proj_info[1];
    in->cx = d->proj_info[2] * in->fx;
    in->cy = d->H - d->proj_info[3] * in->fy;
    in->projection = OBS_PROJECTION_PERSPECTIVE;
    in->znear = 0.0;
    in->zfar = INFINITY;
    return 1;
}

static ao_sao_constants peer_constants(const peer_dump *d, const ao_input *in, int max_mip, int blur)
{
    ao_sao_params p = ao_sao_params_default();
    p.radius = (float)d->radius;
    p.bias = (float)d->bias;
    p.intensity = (float)d->intensity;
    p.epsilon = (float)d->epsilon;
    p.samples = d->taps;
    p.spiral_turns = d->turns;
    p.max_mip_level = max_mip;
    p.blur = blur;
    ao_sao_constants k = ao_sao_constants_from_params(&p, in);
    /* the peer's exact uniforms */
    for (int i = 0; i < 4; i++)
        k.proj_info[i] = (float)d->proj_info[i];
    k.proj_scale = (float)d->proj_scale;
    k.edge_k = (float)d->edge_k;
    return k;
}

static int cmp_f(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

typedef struct diff_stats {
    double median, p99, max, frac_1e3;
    int64_t n, nan, bg_mismatch;
} diff_stats;

/* |ours - peer| over object pixels (csz != 0); ours in our row order (w = W window). */
static diff_stats compare(const peer_dump *d, const obs_image_f32 *ours, const float *peer)
{
    diff_stats s;
    memset(&s, 0, sizeof s);
    size_t n = (size_t)d->W * d->H, k = 0;
    float *diffs = malloc(n * sizeof(float));
    for (int gy = 0; gy < d->H; gy++)
        for (int x = 0; x < d->W; x++) {
            float a = obs_image_f32_row(ours, d->H - 1 - gy)[x], b = peer[(size_t)gy * d->W + x];
            if (a != a)
                s.nan++;
            if (d->csz[(size_t)gy * d->W + x] == 0.0f) {
                if (a != b)
                    s.bg_mismatch++;
                continue;
            }
            diffs[k++] = fabsf(a - b);
        }
    qsort(diffs, k, sizeof(float), cmp_f);
    s.n = (int64_t)k;
    if (k) {
        s.median = diffs[k / 2];
        s.p99 = diffs[(size_t)(k * 0.99)];
        s.max = diffs[k - 1];
        size_t over = 0;
        for (size_t i = 0; i < k; i++)
            over += diffs[i] > 1e-3f;
        s.frac_1e3 = (double)over / (double)k;
    }
    free(diffs);
    return s;
}

static void report(const char *name, const diff_stats *s)
{
    printf("llvmpipe %-22s n=%lld  median %.2e  p99 %.2e  max %.2e  frac>1e-3 %.5f  nan %lld  bg mismatches %lld\n",
           name, (long long)s->n, s->median, s->p99, s->max, s->frac_1e3, (long long)s->nan,
           (long long)s->bg_mismatch);
}

/* The bounds: the peer README's own re-derivation reaches median <= 8e-7, p99 <= 5e-5; the
 * issue asks for ~1e-4. Rare pixels whose tap lands on a neighbouring texel (cos/sin and log2
 * of the GPU against libm, see docs/ao/sao.md) may differ by more: we bound their share. */
static int within(const diff_stats *s, double median, double p99, double frac)
{
    return s->n > 1000 && s->nan == 0 && s->bg_mismatch == 0 && s->median <= median && s->p99 <= p99 &&
           s->frac_1e3 <= frac;
}

static void compare_size(int W, int H, const char *extra, const char *tag)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    peer_dump d;
    peer_run(W, H, extra, tag, &d);
    printf("llvmpipe peer run %s: %dx%d (peer options '%s'), taps %d, turns %d, r %g, projScale %.9g\n", tag, d.W, d.H,
           extra, d.taps, d.turns, d.radius, d.proj_scale);
    our_input o;
    CHECK(make_input(ctx, &d, &o));
    CHECK_OK(ao_input_validate(ctx, &o.in), ctx);
    obs_image_f32 raw = {0}, fin = {0}, gl_blur = {0}, peer_ao = {0}, peer_csz = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, d.W, d.H, &raw), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, d.W, d.H, &fin), ctx);

    /* 1. SAO without the MIP chain (the peer's `sao` stage), no blur */
    ao_sao_constants k = peer_constants(&d, &o.in, 0, 0);
    CHECK_OK(ao_sao_compute_constants(ctx, pool, &o.in, &k, &raw, NULL, NULL), ctx);
    diff_stats s_ao = compare(&d, &raw, d.ao);
    report("ao (level 0)", &s_ao);

    /* 2. SAO with the rotated-grid MIP chain (the peer's `sao_mip`) */
    k = peer_constants(&d, &o.in, d.max_mip, 0);
    CHECK_OK(ao_sao_compute_constants(ctx, pool, &o.in, &k, &raw, NULL, NULL), ctx);
    diff_stats s_mip = compare(&d, &raw, d.ao_mip);
    report("ao_mip (MIP 0..5)", &s_mip);
    /* control: how much the MIP chain changes the peer's own result (the comparison above must be
     * able to tell them apart) */
    obs_image_f32 peer_ao_ours_order = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, d.W, d.H, &peer_ao_ours_order), ctx);
    for (int y = 0; y < d.H; y++)
        memcpy(obs_image_f32_row(&peer_ao_ours_order, d.H - 1 - y), d.ao + (size_t)y * d.W, sizeof(float) * d.W);
    diff_stats s_ctl = compare(&d, &peer_ao_ours_order, d.ao_mip);
    report("control: peer ao vs ao_mip", &s_ctl);
    obs_image_f32_free(&peer_ao_ours_order);

    /* 3. The blur alone, on the peer's own `ao` and CSZ (GL order, as dumped) */
    CHECK_OK(obs_image_f32_alloc(ctx, d.W, d.H, &peer_ao), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, d.W, d.H, &peer_csz), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, d.W, d.H, &gl_blur), ctx);
    for (int y = 0; y < d.H; y++) {
        memcpy(obs_image_f32_row(&peer_ao, y), d.ao + (size_t)y * d.W, sizeof(float) * d.W);
        memcpy(obs_image_f32_row(&peer_csz, y), d.csz + (size_t)y * d.W, sizeof(float) * d.W);
    }
    CHECK_OK(ao_sao_blur_gl(ctx, pool, &peer_ao, &peer_csz, 2, (float)d.edge_k, &gl_blur), ctx);
    obs_image_f32 flipped = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, d.W, d.H, &flipped), ctx);
    for (int y = 0; y < d.H; y++)
        memcpy(obs_image_f32_row(&flipped, d.H - 1 - y), obs_image_f32_row(&gl_blur, y), sizeof(float) * d.W);
    diff_stats s_blur_only = compare(&d, &flipped, d.ao_blur);
    report("ao_blur (blur only)", &s_blur_only);

    /* 4. Our whole pipeline: SAO (level 0) then our blur, against the peer's ao_blur */
    k = peer_constants(&d, &o.in, 0, 1);
    CHECK_OK(ao_sao_compute_constants(ctx, pool, &o.in, &k, &fin, &raw, NULL), ctx);
    diff_stats s_blur = compare(&d, &fin, d.ao_blur);
    report("ao_blur (end to end)", &s_blur);

    CHECK_MSG(within(&s_ao, 1e-6, 1e-5, 0.001), "%s: ao differs from llvmpipe beyond the bounds", tag);
    CHECK_MSG(within(&s_mip, 1e-6, 1e-5, 0.001), "%s: ao_mip differs from llvmpipe beyond the bounds", tag);
    CHECK_MSG(within(&s_blur_only, 1e-6, 1e-5, 0.0) && s_blur_only.max <= 1e-5,
              "%s: the blur differs from llvmpipe beyond the bounds", tag);
    CHECK_MSG(within(&s_blur, 1e-6, 1e-5, 0.001), "%s: ao_blur differs from llvmpipe beyond the bounds", tag);
    if (s_ctl.frac_1e3 > 0.01) /* where the MIP chain matters, the test must see it */
        CHECK_MSG(s_ctl.frac_1e3 > 100.0 * s_mip.frac_1e3 + 0.005,
                  "%s: the comparison cannot tell the MIP chain apart", tag);

    obs_image_f32_free(&flipped);
    obs_image_f32_free(&gl_blur);
    obs_image_f32_free(&peer_csz);
    obs_image_f32_free(&peer_ao);
    obs_image_f32_free(&fin);
    obs_image_f32_free(&raw);
    obs_image_f32_free(&o.depth);
    peer_free(&d);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

TEST(ao_sao_matches_llvmpipe_peer)
{
    /* the peer's defaults */
    compare_size(640, 360, "", "bunny640x360");
    if (test_failed())
        return;
    /* odd sizes, the bunny cut by every border (taps clamp, derivative quads and MIP texels meet
     * the last row and column), a larger radius reaching MIP level 4, other taps and turns */
    compare_size(321, 181, "--dist 0.45 --radius 6 --taps 8 --turns 3", "bunny321x181_close");
    if (test_failed())
        return;
    compare_size(480, 270, "--radius 12 --taps 19 --turns 7 --bias 0.05 --rx 30 --ry 120", "bunny480x270_wide");
}
