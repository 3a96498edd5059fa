/* replay.c: obscura_fuzz_replay TARGET PATH...: run every file under each PATH (a file, or a
 * directory searched recursively; missing paths are skipped) through the fuzz target's entry
 * function, in sorted order. ctest runs it over tests/fuzz/corpus/<target> and
 * tests/fuzz/regressions/<target> in every build, so a crash found once stays fixed even
 * without libFuzzer; under OBS_SANITIZE=ON the replays run with ASan and UBSan.
 * Exit status: 0 when every input ran (a crash or a broken invariant aborts), 1 when no input
 * was found, 2 on bad usage. */
#include "fuzz.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

typedef int (*entry_fn)(const uint8_t *, size_t);

static const struct { const char *name; entry_fn fn; } targets[] = {
    {"gltf", obs_fuzz_gltf}, {"exr", obs_fuzz_exr}, {"off", obs_fuzz_off},
    {"cli_args", obs_fuzz_cli_args}, {"json", obs_fuzz_json}, {"gbuffer", obs_fuzz_gbuffer},
    {"render_settings", obs_fuzz_render_settings},
};

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

static int run_file(entry_fn fn, const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "replay: cannot open %s\n", path);
        return 0;
    }
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    /* an exact-size heap copy, as libFuzzer gives, so that ASan sees reads past the end */
    uint8_t *buf = malloc(n > 0 ? (size_t)n : 1);
    size_t got = buf && n > 0 ? fread(buf, 1, (size_t)n, f) : 0;
    fclose(f);
    if (!buf || got != (size_t)(n > 0 ? n : 0)) {
        free(buf);
        fprintf(stderr, "replay: cannot read %s\n", path);
        return 0;
    }
    fprintf(stderr, "replay: %s (%ld bytes)\n", path, n);
    fn(buf, got);
    free(buf);
    return 1;
}

/* Returns the number of files run under path. */
static int run_path(entry_fn fn, const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return 0;
    if (!S_ISDIR(st.st_mode))
        return run_file(fn, path);
    DIR *d = opendir(path);
    if (!d)
        return 0;
    char **names = NULL;
    size_t count = 0, cap = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.' || !strcmp(e->d_name, "README.md"))
            continue;
        if (count == cap) {
            cap = cap ? 2 * cap : 64;
            names = realloc(names, cap * sizeof *names);
        }
        size_t len = strlen(path) + strlen(e->d_name) + 2;
        names[count] = malloc(len);
        snprintf(names[count], len, "%s/%s", path, e->d_name);
        count++;
    }
    closedir(d);
    if (count)
        qsort(names, count, sizeof *names, cmp_str);
    int ran = 0;
    for (size_t k = 0; k < count; k++) {
        ran += run_path(fn, names[k]);
        free(names[k]);
    }
    free(names);
    return ran;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: obscura_fuzz_replay TARGET PATH...\n");
        return 2;
    }
    entry_fn fn = NULL;
    for (size_t k = 0; k < sizeof targets / sizeof targets[0]; k++)
        if (!strcmp(argv[1], targets[k].name))
            fn = targets[k].fn;
    if (!fn) {
        fprintf(stderr, "replay: unknown target '%s'\n", argv[1]);
        return 2;
    }
    int ran = 0;
    for (int i = 2; i < argc; i++)
        ran += run_path(fn, argv[i]);
    if (ran == 0) {
        fprintf(stderr, "replay: %s: no input found (a wrong path?)\n", argv[1]);
        return 1;
    }
    fprintf(stderr, "replay: %s: %d inputs ran without a crash or a broken invariant\n", argv[1], ran);
    return 0;
}
