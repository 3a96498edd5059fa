/* test.h: a minimal test harness. Each TEST(name) registers itself; ctest runs every test as
 * its own process (`obscura_tests name`), so a crash in one test cannot hide another.
 * Names describe the behaviour checked, e.g. TEST(raster_shared_edges_cover_each_pixel_once). */
#ifndef OBS_TEST_H
#define OBS_TEST_H

#include <math.h>
#include <stdio.h>
#include <stdint.h>

typedef void (*test_fn)(void);
void test_register(const char *name, test_fn fn, const char *file);
void test_fail_at(const char *file, int line, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
int test_failed(void);
/* A fresh, empty directory for this test's files (under the build tree). */
const char *test_tmpdir(void);
/* Path join into a static rotating buffer. */
const char *test_path(const char *dir, const char *name);
/* Run exe with args (a NULL-terminated list, argv[0] excluded), stdout and stderr redirected to
 * the given files (NULL = /dev/null). Returns the exit code, or -1 when it did not exit normally. */
int test_spawn(const char *exe, const char *const *args, const char *out_path, const char *err_path);
/* A whole file, NUL-terminated, malloc'd (NULL when unreadable); *len gets its size if non-NULL. */
char *test_slurp(const char *path, size_t *len);
/* Run the obscura command with args; stdout and stderr go to <tmpdir>/<tag>.stdout / .stderr. */
int test_cli_run(const char *const *args, const char *tag);
/* 1 when <tmpdir>/<tag>.stderr contains needle (printing the stderr when it does not). */
int test_cli_stderr_has(const char *tag, const char *needle);
/* Generated data directory (the build's data/), and the source tree. */
const char *test_data_dir(void);
const char *test_source_dir(void);
const char *test_binary_dir(void);

#define TEST(name)                                                                           \
    static void test_##name(void);                                                           \
    __attribute__((constructor)) static void test_register_##name(void)                      \
    {                                                                                        \
        test_register(#name, test_##name, __FILE__);                                         \
    }                                                                                        \
    static void test_##name(void)

#define CHECK(cond)                                                                          \
    do {                                                                                     \
        if (!(cond)) {                                                                       \
            test_fail_at(__FILE__, __LINE__, "CHECK(%s)", #cond);                            \
            return;                                                                          \
        }                                                                                    \
    } while (0)

#define CHECK_MSG(cond, ...)                                                                 \
    do {                                                                                     \
        if (!(cond)) {                                                                       \
            test_fail_at(__FILE__, __LINE__, __VA_ARGS__);                                   \
            return;                                                                          \
        }                                                                                    \
    } while (0)

#define CHECK_EQ_INT(a, b)                                                                   \
    do {                                                                                     \
        long long va_ = (long long)(a), vb_ = (long long)(b);                                \
        if (va_ != vb_) {                                                                    \
            test_fail_at(__FILE__, __LINE__, "%s == %s: %lld != %lld", #a, #b, va_, vb_);    \
            return;                                                                          \
        }                                                                                    \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                                \
    do {                                                                                     \
        double va_ = (double)(a), vb_ = (double)(b), vt_ = (double)(tol);                    \
        if (!(fabs(va_ - vb_) <= vt_)) {                                                     \
            test_fail_at(__FILE__, __LINE__, "|%s - %s| <= %s: %.9g vs %.9g (diff %.3g)",    \
                         #a, #b, #tol, va_, vb_, fabs(va_ - vb_));                           \
            return;                                                                          \
        }                                                                                    \
    } while (0)

/* CHECK that an obs_status expression is OK, printing the context's message otherwise. */
#define CHECK_OK(expr, ctx)                                                                  \
    do {                                                                                     \
        obs_status st_ = (expr);                                                             \
        if (st_ != OBS_STATUS_OK) {                                                          \
            test_fail_at(__FILE__, __LINE__, "%s -> %s: %s", #expr, obs_status_string(st_),  \
                         obs_context_last_error(ctx));                                       \
            return;                                                                          \
        }                                                                                    \
    } while (0)

#endif
