/* test_main.c: registry and runner for the TEST() harness. */
#include "test.h"

#include <dirent.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <errno.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Under LeakSanitizer the leak check runs when the test body returns (leak_check_now), not at
 * exit. At exit it races with threads that third-party libraries are still tearing down: the GL
 * tests keep Mesa's llvmpipe loaded (glh.c), and once in CI (2026-12-02, clang-14) LSan's
 * stop-the-world tracer crashed at exit ("Tracer caught signal 11", "LeakSanitizer has encountered
 * a fatal error", google/sanitizers#1353) after the test had passed. Checked here, while every
 * thread of ours is joined and the libraries' workers are idle, the check is the same (nothing
 * is freed between here and exit but what atexit handlers free, which is still reachable now), and
 * a second check at exit is a no-op (lsan_interface.h). docs/reliability.md. */
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(leak_sanitizer)
#define OBS_TEST_LSAN 1
#endif
#endif
#if !defined(OBS_TEST_LSAN) && defined(__SANITIZE_ADDRESS__)
#define OBS_TEST_LSAN 1
#endif
#ifdef OBS_TEST_LSAN
#include <sanitizer/lsan_interface.h>
#endif
static void leak_check_now(void)
{
    fflush(stdout);
    fflush(stderr);
#ifdef OBS_TEST_LSAN
    __lsan_do_leak_check();
#endif
}

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

extern char **environ;

int test_spawn(const char *exe, const char *const *args, const char *out_path, const char *err_path)
{
    const char *argv[128];
    int n = 0;
    argv[n++] = exe;
    for (int i = 0; args[i] && n < 127; i++)
        argv[n++] = args[i];
    argv[n] = NULL;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, out_path ? out_path : "/dev/null", O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&fa, 2, err_path ? err_path : "/dev/null", O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid;
    int rc = posix_spawn(&pid, exe, &fa, NULL, (char *const *)argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0)
        return -1;
    int status;
    if (waitpid(pid, &status, 0) != pid || !WIFEXITED(status))
        return -1;
    return WEXITSTATUS(status);
}

char *test_slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = n >= 0 ? (char *)malloc((size_t)n + 1) : NULL;
    size_t got = b ? fread(b, 1, (size_t)n, f) : 0;
    fclose(f);
    if (!b)
        return NULL;
    b[got] = '\0';
    if (len)
        *len = got;
    return b;
}

int test_cli_run(const char *const *args, const char *tag)
{
    char out[8400], err[8400];
    snprintf(out, sizeof out, "%s/%s.stdout", test_tmpdir(), tag);
    snprintf(err, sizeof err, "%s/%s.stderr", test_tmpdir(), tag);
    return test_spawn(OBS_CLI_PATH, args, out, err);
}

int test_cli_stderr_has(const char *tag, const char *needle)
{
    char path[8400];
    snprintf(path, sizeof path, "%s/%s.stderr", test_tmpdir(), tag);
    char *b = test_slurp(path, NULL);
    int r = b && strstr(b, needle) != NULL;
    if (!r)
        fprintf(stderr, "%s: stderr lacks '%s': %s\n", tag, needle, b ? b : "(none)");
    free(b);
    return r;
}

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
        leak_check_now();
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
