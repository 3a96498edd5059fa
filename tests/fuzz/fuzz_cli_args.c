/* fuzz_cli_args.c: the obscura command's argument parsing, end to end, in-process.
 *
 * How: src/cli/main.c's main() is cli_main() plus a two-line main() compiled out with
 * OBS_CLI_NO_MAIN, so this target runs the real command (every subcommand's parser, and the work
 * behind the arguments that parse) without spawning a process. The input is a list of arguments
 * separated by '\n' or '\0'. The target
 *   - runs in a private directory (under $TMPDIR, else /dev/shm, else /tmp) holding small valid
 *     inputs, rewritten before every run: s.glb (a scene with two cameras, a light and a
 *     material), a.exr and b.exr (G-buffer-like EXRs with float, half and uint channels and
 *     metadata), p.png (a grey PNG), i.json (camera intrinsics for `ao --gbuffer`);
 *   - turns every '/' in an argument into '_', so everything the command writes stays in that
 *     directory (the working directory is switched to it for the call and back afterwards), and
 *     every ".tmp." into "_tmp.", so that only io_temp_path makes such names;
 *   - keeps each run small: the global flags --threads 1, --max-pixels 4096, --max-memory 256 MiB,
 *     --max-triangles/--max-vertices 100000 come first; the same flags given by the input are
 *     clamped to those values (malformed values pass unchanged, they are what the parser must
 *     refuse); `truth` runs get --max-samples 64 --min-samples 16 appended.
 * Invariants: the exit code is one of docs/cli.md's (0..6); no temporary file (io_temp_path's
 * "<path>.tmp.<pid>.<n>") is left behind, whatever the outcome; a usage error (2) or a limit
 * refusal (4) writes nothing.
 *
 * libFuzzer: pass an absolute -artifact_prefix (tests/fuzz/run.sh does): a crash happens while
 * the working directory is the private one. */
#include "fuzz.h"

#include "cli/cli.h"
#include "io/io.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define MAX_ARGS 48
#define MAX_ARG_LEN 256

typedef struct fixture {
    const char *name;
    unsigned char *bytes;
    size_t len;
} fixture;

#define FIXTURES 5
static fixture g_fix[FIXTURES] = {
    {"s.glb", NULL, 0}, {"a.exr", NULL, 0}, {"b.exr", NULL, 0}, {"p.png", NULL, 0}, {"i.json", NULL, 0}};
/* camera intrinsics for `ao --gbuffer a.exr --intrinsics i.json` (the AO module's JSON reader) */
static const char g_intrinsics[] =
    "{\"fx\": 20.5, \"fy\": 20.5, \"cx\": 8, \"cy\": 6, \"projection\": \"perspective\", \"znear\": 0.1, "
    "\"zfar\": 100, \"depth_kind\": \"linear\", \"inner_window\": [0, 0, 16, 12]}\n";
static char g_dir[4096];
static int g_ready;

static unsigned char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)n + 1);
    size_t got = b ? fread(b, 1, (size_t)n, f) : 0;
    fclose(f);
    if (!b || got != (size_t)n) {
        free(b);
        return NULL;
    }
    *len = got;
    return b;
}

/* Remove everything in dir (files only are expected; directories are removed recursively). */
static void clear_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        char p[8192];
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        struct stat st;
        if (lstat(p, &st) == 0 && S_ISDIR(st.st_mode)) {
            clear_dir(p);
            rmdir(p);
        } else {
            unlink(p);
        }
    }
    closedir(d);
}

/* The scene: a 4x4 floor and a unit box on it, cameras "default" (perspective) and "top"
 * (orthographic), a point light, a material with extras. */
static int write_scene(obs_context *ctx, const char *path)
{
    static const float pos[] = {-2, 0, -2, 2, 0, -2, 2, 0, 2, -2, 0, 2, /* floor */
                                -0.5f, 0, -0.5f, 0.5f, 0, -0.5f, 0.5f, 1, -0.5f, -0.5f, 1, -0.5f,
                                -0.5f, 0, 0.5f, 0.5f, 0, 0.5f, 0.5f, 1, 0.5f, -0.5f, 1, 0.5f};
    static const uint32_t idx[] = {0, 2, 1, 0, 3, 2,                                     /* floor, up */
                                   4, 6, 5, 4, 7, 6, 8, 9, 10, 8, 10, 11, 4, 5, 9, 4, 9, 8, /* box */
                                   7, 10, 6, 7, 11, 10, 4, 8, 11, 4, 11, 7, 5, 6, 10, 5, 10, 9};
    obs_mesh mesh;
    memset(&mesh, 0, sizeof mesh);
    strcpy(mesh.name, "floor_and_box");
    mesh.vertex_count = 12;
    mesh.triangle_count = 14;
    mesh.positions = (float *)pos;
    mesh.indices = (uint32_t *)idx;
    mesh.material = 0;
    obs_instance inst;
    memset(&inst, 0, sizeof inst);
    inst.world = obs_mat4_identity();
    obs_camera cams[2];
    cams[0] = obs_camera_look_at(obs_v3(0, 2, 5), obs_v3(0, 0.5f, 0), obs_v3(0, 1, 0), 0.8f, 0.1f, 100.0f);
    strcpy(cams[0].name, "default");
    cams[1] = obs_camera_look_at(obs_v3(0, 5, 0.001f), obs_v3(0, 0, 0), obs_v3(0, 1, 0), 0.8f, 0.5f, 10.0f);
    cams[1].projection = OBS_PROJECTION_ORTHOGRAPHIC;
    cams[1].xmag = cams[1].ymag = 2.5f;
    strcpy(cams[1].name, "top");
    obs_light light;
    memset(&light, 0, sizeof light);
    strcpy(light.name, "lamp");
    light.type = OBS_LIGHT_POINT;
    light.color = obs_v3(1, 1, 1);
    light.intensity = 10.0f;
    light.position = obs_v3(1, 3, 1);
    light.direction = obs_v3(0, 0, -1);
    obs_material mat;
    memset(&mat, 0, sizeof mat);
    strcpy(mat.name, "grey");
    mat.base_color[0] = mat.base_color[1] = mat.base_color[2] = 0.5f;
    mat.base_color[3] = 1.0f;
    mat.roughness = 0.5f;
    mat.extras_json = (char *)"{\"albedo\":0.5}";
    obs_scene s;
    obs_scene_init(&s);
    s.meshes = &mesh;
    s.mesh_count = 1;
    s.instances = &inst;
    s.instance_count = 1;
    s.cameras = cams;
    s.camera_count = 2;
    s.lights = &light;
    s.light_count = 1;
    s.materials = &mat;
    s.material_count = 1;
    obs_scene_update_bounds(&s);
    return io_glb_write(ctx, path, &s) == OBS_STATUS_OK; /* s's arrays are ours: no obs_scene_free */
}

/* 16x12 G-buffer-like EXR: Z (float, background inf), N.X/N.Y/N.Z (half), primid (uint),
 * AO.mean (float), and camera metadata; `shift` perturbs the values (b.exr). */
static int write_exr(obs_context *ctx, const char *path, float shift)
{
    enum { W = 16, H = 12 };
    obs_image_f32 z, n[3], ao;
    obs_image_u32 prim;
    int ok = obs_image_f32_alloc(ctx, W, H, &z) == OBS_STATUS_OK && obs_image_f32_alloc(ctx, W, H, &ao) == OBS_STATUS_OK &&
             obs_image_u32_alloc(ctx, W, H, &prim) == OBS_STATUS_OK;
    for (int k = 0; k < 3; k++)
        ok = ok && obs_image_f32_alloc(ctx, W, H, &n[k]) == OBS_STATUS_OK;
    if (!ok)
        return 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int bg = y < 2;
            obs_image_f32_row(&z, y)[x] = bg ? INFINITY : 2.0f + 0.1f * (float)x + shift * (float)((x * 7 + y) % 5);
            obs_image_f32_row(&ao, y)[x] = bg ? 1.0f : 0.5f + 0.02f * (float)(x - y) + shift;
            obs_image_f32_row(&n[0], y)[x] = 0.0f;
            obs_image_f32_row(&n[1], y)[x] = 1.0f;
            obs_image_f32_row(&n[2], y)[x] = shift;
            obs_image_u32_row(&prim, y)[x] = bg ? 0xFFFFFFFFu : (uint32_t)(x / 4 + y);
        }
    io_channel ch[6] = {{"Z", IO_PIXEL_FLOAT, &z, NULL},      {"N.X", IO_PIXEL_HALF, &n[0], NULL},
                        {"N.Y", IO_PIXEL_HALF, &n[1], NULL},  {"N.Z", IO_PIXEL_HALF, &n[2], NULL},
                        {"AO.mean", IO_PIXEL_FLOAT, &ao, NULL}, {"primid", IO_PIXEL_UINT, NULL, &prim}};
    obs_mat4 view = obs_mat4_identity();
    io_attr at[3];
    memset(at, 0, sizeof at);
    strcpy(at[0].name, "worldToCamera");
    at[0].type = IO_ATTR_MATRIX44;
    at[0].v = view.m;
    strcpy(at[1].name, "obscura:conventions");
    at[1].type = IO_ATTR_STRING;
    at[1].s = (char *)"fuzz fixture";
    strcpy(at[2].name, "obscura:radius");
    at[2].type = IO_ATTR_FLOAT;
    at[2].f = 0.5f;
    ok = io_exr_write(ctx, path, ch, 6, at, 3) == OBS_STATUS_OK;
    obs_image_f32_free(&z);
    obs_image_f32_free(&ao);
    obs_image_u32_free(&prim);
    for (int k = 0; k < 3; k++)
        obs_image_f32_free(&n[k]);
    return ok;
}

static int write_png(obs_context *ctx, const char *path)
{
    obs_image_f32 g;
    if (obs_image_f32_alloc(ctx, 16, 12, &g) != OBS_STATUS_OK)
        return 0;
    for (int y = 0; y < 12; y++)
        for (int x = 0; x < 16; x++)
            obs_image_f32_row(&g, y)[x] = (float)((x + y) % 3) * 0.5f;
    int ok = io_png_write(ctx, path, &g, 1, IO_PNG_LINEAR) == OBS_STATUS_OK;
    obs_image_f32_free(&g);
    return ok;
}

static void setup(void)
{
    const char *base = getenv("TMPDIR");
    struct stat st;
    if (!base || !base[0])
        base = stat("/dev/shm", &st) == 0 && S_ISDIR(st.st_mode) && access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    snprintf(g_dir, sizeof g_dir, "%s/obscura-fuzz-cli-XXXXXX", base);
    fuzz_require(mkdtemp(g_dir) != NULL, "cannot create the fuzz directory");
    obs_context *ctx = fuzz_context();
    char path[8192];
    snprintf(path, sizeof path, "%s/%s", g_dir, g_fix[0].name);
    fuzz_require(write_scene(ctx, path), "cannot write the fixture scene");
    snprintf(path, sizeof path, "%s/%s", g_dir, g_fix[1].name);
    fuzz_require(write_exr(ctx, path, 0.0f), "cannot write the fixture a.exr");
    snprintf(path, sizeof path, "%s/%s", g_dir, g_fix[2].name);
    fuzz_require(write_exr(ctx, path, 0.01f), "cannot write the fixture b.exr");
    snprintf(path, sizeof path, "%s/%s", g_dir, g_fix[3].name);
    fuzz_require(write_png(ctx, path), "cannot write the fixture p.png");
    obs_context_destroy(ctx);
    for (int k = 0; k < 4; k++) {
        snprintf(path, sizeof path, "%s/%s", g_dir, g_fix[k].name);
        g_fix[k].bytes = slurp(path, &g_fix[k].len);
        fuzz_require(g_fix[k].bytes != NULL, "cannot read a fixture back");
    }
    g_fix[4].len = sizeof g_intrinsics - 1;
    g_fix[4].bytes = malloc(g_fix[4].len);
    fuzz_require(g_fix[4].bytes != NULL, "allocation");
    memcpy(g_fix[4].bytes, g_intrinsics, g_fix[4].len);
    /* the command's tables and help go to stdout: not wanted in the fuzzer's output */
    int devnull = open("/dev/null", O_WRONLY);
    if (devnull >= 0) {
        fflush(stdout);
        dup2(devnull, 1);
        close(devnull);
    }
    g_ready = 1;
}

static void restore_fixtures(void)
{
    clear_dir(g_dir);
    for (int k = 0; k < FIXTURES; k++) {
        char path[8192];
        snprintf(path, sizeof path, "%s/%s", g_dir, g_fix[k].name);
        FILE *f = fopen(path, "wb");
        fuzz_require(f != NULL, "cannot restore a fixture");
        fuzz_require(fwrite(g_fix[k].bytes, 1, g_fix[k].len, f) == g_fix[k].len, "cannot restore a fixture");
        fclose(f);
    }
}

/* Whether a name is one of this process's io_temp_path names: it ends in ".tmp.<pid>.<n>". (The
 * arguments cannot contain ".tmp.", so only io_temp_path makes such an ending; an output prefix
 * ending in ".tmp" gives "x.tmp.exr", which is not one.) */
static int is_temporary(const char *name)
{
    char mark[48];
    int m = snprintf(mark, sizeof mark, ".tmp.%ld.", (long)getpid());
    const char *p = NULL;
    for (const char *q = strstr(name, mark); q; q = strstr(q + 1, mark))
        p = q;
    if (!p)
        return 0;
    p += m;
    if (!*p)
        return 0;
    for (; *p; p++)
        if (*p < '0' || *p > '9')
            return 0;
    return 1;
}

/* Files in the directory beyond the fixtures: 0 none, else 1 (and temporary ones in *tmp). */
static int scan_outputs(int *tmp)
{
    DIR *d = opendir(g_dir);
    fuzz_require(d != NULL, "the fuzz directory is readable");
    int extra = 0;
    *tmp = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        const char *n = e->d_name;
        if (!strcmp(n, ".") || !strcmp(n, ".."))
            continue;
        if (is_temporary(n))
            *tmp = 1;
        int fixture = 0;
        for (int k = 0; k < FIXTURES; k++)
            fixture |= !strcmp(n, g_fix[k].name);
        if (!fixture)
            extra = 1;
    }
    closedir(d);
    return extra;
}

/* Clamp the value after a resource flag to the target's cap (an integer over the cap only). */
static void clamp_value(char *v, long long cap)
{
    char *end;
    errno = 0;
    long long x = strtoll(v, &end, 10);
    if (end != v && *end == '\0' && !errno && x > cap)
        snprintf(v, MAX_ARG_LEN, "%lld", cap);
    else if (end != v && *end == '\0' && errno == ERANGE)
        snprintf(v, MAX_ARG_LEN, "%lld", cap);
}

int obs_fuzz_cli_args(const uint8_t *data, size_t size)
{
    if (!g_ready)
        setup();
    static char args[MAX_ARGS][MAX_ARG_LEN];
    int n = 0;
    size_t i = 0;
    while (i <= size && n < MAX_ARGS) {
        size_t k = 0;
        while (i < size && data[i] != '\n' && data[i] != '\0') {
            if (k < MAX_ARG_LEN - 1)
                args[n][k++] = data[i] == '/' ? '_' : (char)data[i];
            i++;
        }
        args[n][k] = '\0';
        for (char *t = strstr(args[n], ".tmp."); t; t = strstr(t, ".tmp."))
            *t = '_'; /* only io_temp_path makes names with ".tmp." in them */
        n++;
        i++;
    }
    if (n > 0 && size > 0 && args[n - 1][0] == '\0' && (data[size - 1] == '\n' || data[size - 1] == '\0'))
        n--; /* a trailing separator ends the list, it adds no empty argument */

    static const struct { const char *flag; long long cap; } caps[] = {
        {"--threads", 2},         {"--max-pixels", 4096},     {"--max-memory", 256ll << 20},
        {"--max-triangles", 100000}, {"--max-vertices", 100000}, {"--max-samples", 64},
        {"--min-samples", 64},
    };
    int truth = 0;
    for (int a = 0; a < n; a++) {
        truth |= !strcmp(args[a], "truth");
        for (size_t c = 0; c < sizeof caps / sizeof caps[0]; c++)
            if (!strcmp(args[a], caps[c].flag) && a + 1 < n)
                clamp_value(args[a + 1], caps[c].cap);
        if (!strcmp(args[a], "--threads") && a + 1 < n && !strcmp(args[a + 1], "0"))
            strcpy(args[a + 1], "1"); /* 0 means every CPU of the machine */
    }

    char *argv[MAX_ARGS + 16];
    int argc = 0;
    static char fixed[][24] = {"obscura", "--threads", "1", "--max-pixels", "4096", "--max-memory", "268435456",
                               "--max-triangles", "100000", "--max-vertices", "100000"};
    for (size_t k = 0; k < sizeof fixed / sizeof fixed[0]; k++)
        argv[argc++] = fixed[k];
    for (int a = 0; a < n; a++)
        argv[argc++] = args[a];
    static char tail[][16] = {"--max-samples", "64", "--min-samples", "16"};
    if (truth)
        for (int k = 0; k < 4; k++)
            argv[argc++] = tail[k];
    argv[argc] = NULL;

    restore_fixtures();
    int here = open(".", O_RDONLY | O_DIRECTORY);
    fuzz_require(here >= 0 && chdir(g_dir) == 0, "cannot enter the fuzz directory");
    int code = cli_main(argc, argv);
    fflush(stdout);
    fuzz_require(fchdir(here) == 0, "cannot return to the working directory");
    close(here);

    fuzz_require(code >= 0 && code <= 6, "the exit code is one of docs/cli.md's");
    int tmp = 0;
    int extra = scan_outputs(&tmp);
    fuzz_require(!tmp, "no temporary file is left behind");
    if (code == CLI_EXIT_USAGE || code == CLI_EXIT_LIMIT)
        fuzz_require(!extra, "a usage error or a limit refusal writes nothing");
    return 0;
}
