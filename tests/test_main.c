/* test_main.c: registry and runner for the TEST() harness. */
#include "test.h"

#include <dirent.h>
#include <errno.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define MAX_TESTS 1024

static struct { const char *name; test_fn fn; const char *file; } g_tests[MAX_TESTS];
static int g_count;
static int g_failed;
static char g_tmp[8192];

void test_register(const char *name, test_fn fn, const char *file)
{
    if (g_count < MAX_TESTS) {
        g_tests[g_count].name = name;
        g_tests[g_count].fn = fn;
        g_tests[g_count].file = file;
        g_count++;
    }
}

void test_fail_at(const char *file, int line, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "%s:%d: FAIL: ", file, line);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    g_failed = 1;
}

int test_failed(void) { return g_failed; }

const char *test_data_dir(void) { return OBS_TEST_DATA_DIR; }
const char *test_source_dir(void) { return OBS_TEST_SOURCE_DIR; }
const char *test_binary_dir(void) { return OBS_TEST_BINARY_DIR; }

const char *test_path(const char *dir, const char *name)
{
    static char bufs[8][4096];
    static int next;
    char *b = bufs[next++ & 7];
    snprintf(b, sizeof bufs[0], "%s/%s", dir, name);
    return b;
}

static void remove_tree(const char *path)
{
    DIR *d = opendir(path);
    if (!d) {
        unlink(path);
        return;
    }
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        char p[4096];
        snprintf(p, sizeof p, "%s/%s", path, e->d_name);
        struct stat st;
        if (lstat(p, &st) == 0 && S_ISDIR(st.st_mode))
            remove_tree(p);
        else
            unlink(p);
    }
    closedir(d);
    rmdir(path);
}

const char *test_tmpdir(void) { return g_tmp; }

int main(int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "--list")) {
        for (int i = 0; i < g_count; i++)
            printf("%s\n", g_tests[i].name);
        return argc < 2 ? 2 : 0;
    }
    for (int i = 0; i < g_count; i++) {
        if (strcmp(g_tests[i].name, argv[1]) != 0)
            continue;
        char base[4096];
        snprintf(base, sizeof base, "%s/test-tmp", OBS_TEST_BINARY_DIR);
        mkdir(base, 0777);
        snprintf(g_tmp, sizeof g_tmp, "%s/%s", base, g_tests[i].name);
        remove_tree(g_tmp);
        if (mkdir(g_tmp, 0777) != 0) {
            fprintf(stderr, "cannot create %s: %s\n", g_tmp, strerror(errno));
            return 1;
        }
        g_tests[i].fn();
        if (g_failed) {
            fprintf(stderr, "%s: FAILED (%s)\n", g_tests[i].name, g_tests[i].file);
            return 1;
        }
        printf("%s: passed\n", g_tests[i].name);
        return 0;
    }
    fprintf(stderr, "no test named %s\n", argv[1]);
    return 2;
}
