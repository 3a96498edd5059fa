/* test_io_json.c: the io_json writer: RFC 8259 escaping, numbers, nesting, atomic output. */
#include "core/obs.h"
#include "io/io.h"
#include "test.h"

#include <dirent.h>
#include <locale.h>
#include <stdlib.h>
#include <string.h>

/* ---- a tiny RFC 8259 checker: returns 1 when s is exactly one valid JSON text ------------ */

typedef struct jp { const char *p; int depth; } jp;

static void jp_ws(jp *j)
{
    while (*j->p == ' ' || *j->p == '\t' || *j->p == '\n' || *j->p == '\r')
        j->p++;
}

static int jp_value(jp *j);

static int jp_string(jp *j)
{
    if (*j->p != '"')
        return 0;
    j->p++;
    for (;;) {
        unsigned char c = (unsigned char)*j->p;
        if (c == '\0' || c < 0x20)
            return 0;
        j->p++;
        if (c == '"')
            return 1;
        if (c == '\\') {
            char e = *j->p++;
            if (e == 'u') {
                for (int k = 0; k < 4; k++, j->p++) {
                    char h = *j->p;
                    if (!((h >= '0' && h <= '9') || (h >= 'a' && h <= 'f') || (h >= 'A' && h <= 'F')))
                        return 0;
                }
            } else if (!strchr("\"\\/bfnrt", e) || e == '\0') {
                return 0;
            }
        }
    }
}

static int jp_digits(jp *j)
{
    int n = 0;
    while (*j->p >= '0' && *j->p <= '9')
        j->p++, n++;
    return n;
}

static int jp_number(jp *j)
{
    if (*j->p == '-')
        j->p++;
    if (*j->p == '0')
        j->p++;
    else if (!jp_digits(j))
        return 0;
    if (*j->p == '.') {
        j->p++;
        if (!jp_digits(j))
            return 0;
    }
    if (*j->p == 'e' || *j->p == 'E') {
        j->p++;
        if (*j->p == '+' || *j->p == '-')
            j->p++;
        if (!jp_digits(j))
            return 0;
    }
    return 1;
}

static int jp_container(jp *j, char close, int is_object)
{
    j->p++;
    if (++j->depth > 1000)
        return 0;
    jp_ws(j);
    if (*j->p == close) {
        j->p++;
        j->depth--;
        return 1;
    }
    for (;;) {
        jp_ws(j);
        if (is_object) {
            if (!jp_string(j))
                return 0;
            jp_ws(j);
            if (*j->p++ != ':')
                return 0;
        }
        if (!jp_value(j))
            return 0;
        jp_ws(j);
        if (*j->p == ',') {
            j->p++;
            continue;
        }
        if (*j->p == close) {
            j->p++;
            j->depth--;
            return 1;
        }
        return 0;
    }
}

static int jp_value(jp *j)
{
    jp_ws(j);
    switch (*j->p) {
    case '{': return jp_container(j, '}', 1);
    case '[': return jp_container(j, ']', 0);
    case '"': return jp_string(j);
    case 't': return strncmp(j->p, "true", 4) == 0 ? (j->p += 4, 1) : 0;
    case 'f': return strncmp(j->p, "false", 5) == 0 ? (j->p += 5, 1) : 0;
    case 'n': return strncmp(j->p, "null", 4) == 0 ? (j->p += 4, 1) : 0;
    default: return jp_number(j);
    }
}

static int json_valid(const char *s)
{
    jp j = {s, 0};
    if (!jp_value(&j))
        return 0;
    jp_ws(&j);
    return *j.p == '\0';
}

static int count_tmp(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strstr(e->d_name, ".tmp."))
            n++;
    closedir(d);
    return n;
}

/* ---- tests -------------------------------------------------------------------------------- */

TEST(json_escapes_strings_per_rfc8259)
{
    io_json j;
    io_json_init(&j);
    io_json_begin_object(&j, NULL);
    io_json_string(&j, "s", "q\"b\\s/n\nt\tr\rb\bf\fc\x01\x1f\x7f");
    io_json_string(&j, "utf8", "caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80");
    io_json_string(&j, "k\"ey\n", "v");
    io_json_string(&j, "null", NULL);
    io_json_string(&j, "empty", "");
    io_json_end_object(&j);
    CHECK(!j.failed);
    const char *expect = "{\n"
                         "  \"s\": \"q\\\"b\\\\s/n\\nt\\tr\\rb\\bf\\fc\\u0001\\u001f\x7f\",\n"
                         "  \"utf8\": \"caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80\",\n"
                         "  \"k\\\"ey\\n\": \"v\",\n"
                         "  \"null\": null,\n"
                         "  \"empty\": \"\"\n"
                         "}";
    CHECK_MSG(!strcmp(j.buf, expect), "got:\n%s\nexpected:\n%s", j.buf, expect);
    CHECK(json_valid(j.buf));
    CHECK_EQ_INT(j.len, strlen(expect));
    io_json_free(&j);
    CHECK(j.buf == NULL && j.len == 0);
}

TEST(json_non_finite_numbers_become_null)
{
    io_json j;
    io_json_init(&j);
    io_json_begin_array(&j, NULL);
    io_json_number(&j, NULL, NAN);
    io_json_number(&j, NULL, INFINITY);
    io_json_number(&j, NULL, -INFINITY);
    io_json_number(&j, NULL, 0.1f);
    io_json_number(&j, NULL, -0.0);
    io_json_number(&j, NULL, 1e30);
    io_json_number(&j, NULL, 16777217.0);
    io_json_int(&j, NULL, INT64_MIN);
    float v[4] = {1.0f, NAN, 2.5f, -INFINITY};
    io_json_floats(&j, NULL, v, 4);
    io_json_floats(&j, NULL, v, 0);
    io_json_end_array(&j);
    CHECK(!j.failed);
    const char *expect = "[\n  null,\n  null,\n  null,\n  0.100000001,\n  -0,\n  1e+30,\n  16777217,\n"
                         "  -9223372036854775808,\n  [1, null, 2.5, null],\n  []\n]";
    CHECK_MSG(!strcmp(j.buf, expect), "got:\n%s\nexpected:\n%s", j.buf, expect);
    CHECK(json_valid(j.buf));
    io_json_free(&j);

    /* A locale with a decimal comma must not leak into the output. */
    const char *locales[] = {"de_DE.UTF-8", "de_DE.utf8", "fr_FR.UTF-8", "fr_FR.utf8", "ru_RU.UTF-8", "C.UTF-8"};
    const char *used = NULL;
    for (size_t i = 0; i < sizeof locales / sizeof locales[0] && !used; i++)
        if (setlocale(LC_NUMERIC, locales[i]))
            used = locales[i];
    io_json_init(&j);
    io_json_floats(&j, NULL, (const float[]){1.5f, -0.25f}, 2);
    setlocale(LC_NUMERIC, "C");
    CHECK_MSG(!strcmp(j.buf, "[1.5, -0.25]"), "under locale %s: %s", used ? used : "C", j.buf);
    /* Say which locale was exercised: machines with only C/POSIX locales cannot test the comma
     * (LOCPATH pointing at a localedef-compiled de_DE.UTF-8 can). */
    printf("numbers checked under LC_NUMERIC=%s\n", used ? used : "C");
    io_json_free(&j);
}

TEST(json_nesting_and_commas_are_valid)
{
    io_json j;
    io_json_init(&j);
    io_json_begin_object(&j, NULL);
    io_json_string(&j, "name", "x");
    io_json_begin_array(&j, "list");
    io_json_int(&j, NULL, 1);
    io_json_begin_object(&j, NULL);
    io_json_bool(&j, "ok", 1);
    io_json_bool(&j, "no", 0);
    io_json_end_object(&j);
    io_json_begin_array(&j, NULL);
    io_json_end_array(&j);
    io_json_end_array(&j);
    io_json_begin_object(&j, "empty");
    io_json_end_object(&j);
    io_json_floats(&j, "m", (const float[]){1.0f, 2.5f}, 2);
    io_json_null(&j, "n");
    io_json_end_object(&j);
    CHECK(!j.failed);
    CHECK_EQ_INT(j.depth, 0);
    const char *expect = "{\n"
                         "  \"name\": \"x\",\n"
                         "  \"list\": [\n"
                         "    1,\n"
                         "    {\n"
                         "      \"ok\": true,\n"
                         "      \"no\": false\n"
                         "    },\n"
                         "    []\n"
                         "  ],\n"
                         "  \"empty\": {},\n"
                         "  \"m\": [1, 2.5],\n"
                         "  \"n\": null\n"
                         "}";
    CHECK_MSG(!strcmp(j.buf, expect), "got:\n%s\nexpected:\n%s", j.buf, expect);
    CHECK(json_valid(j.buf));
    io_json_free(&j);

    /* 64 levels are fine, the 65th sets failed. */
    io_json_init(&j);
    for (int d = 0; d < 64; d++)
        io_json_begin_array(&j, NULL);
    io_json_int(&j, NULL, 7);
    for (int d = 0; d < 64; d++)
        io_json_end_array(&j);
    CHECK(!j.failed);
    CHECK(json_valid(j.buf));
    io_json_free(&j);
    io_json_init(&j);
    for (int d = 0; d < 65; d++)
        io_json_begin_object(&j, d ? "k" : NULL);
    CHECK(j.failed);
    obs_context *ctx = obs_context_create();
    CHECK(io_json_write(ctx, &j, test_path(test_tmpdir(), "deep.json")) == OBS_STATUS_INVALID_ARGUMENT);
    io_json_free(&j);

    /* Misuse that would give invalid JSON sets failed instead. */
    io_json_init(&j);
    io_json_begin_object(&j, NULL);
    io_json_int(&j, NULL, 1); /* a member without a key */
    CHECK(j.failed);
    io_json_free(&j);
    io_json_init(&j);
    io_json_begin_array(&j, NULL);
    io_json_end_object(&j); /* mismatched end */
    CHECK(j.failed);
    io_json_free(&j);
    io_json_init(&j);
    io_json_int(&j, NULL, 1);
    io_json_int(&j, NULL, 2); /* two top-level values */
    CHECK(j.failed);
    io_json_free(&j);
    io_json_init(&j);
    io_json_begin_object(&j, NULL); /* never closed */
    CHECK(!j.failed);
    CHECK(io_json_write(ctx, &j, test_path(test_tmpdir(), "open.json")) == OBS_STATUS_INVALID_ARGUMENT);
    io_json_free(&j);

    /* A large document (buffer growth). */
    io_json_init(&j);
    io_json_begin_array(&j, NULL);
    for (int i = 0; i < 20000; i++)
        io_json_string(&j, NULL, "some text \"with\" escapes\n");
    io_json_end_array(&j);
    CHECK(!j.failed);
    CHECK(json_valid(j.buf));
    io_json_free(&j);
    obs_context_destroy(ctx);
}

TEST(json_write_is_atomic_and_complete)
{
    obs_context *ctx = obs_context_create();
    const char *path = test_path(test_tmpdir(), "side.json");
    io_json j;
    io_json_init(&j);
    io_json_begin_object(&j, NULL);
    io_json_string(&j, "version", "first");
    io_json_begin_array(&j, "values");
    for (int i = 0; i < 1000; i++)
        io_json_int(&j, NULL, i);
    io_json_end_array(&j);
    io_json_end_object(&j);
    CHECK_OK(io_json_write(ctx, &j, path), ctx);
    char *data;
    size_t len;
    CHECK_OK(io_read_file(ctx, path, 1 << 20, &data, &len), ctx);
    CHECK_EQ_INT(len, j.len + 1);
    CHECK(!memcmp(data, j.buf, j.len) && data[j.len] == '\n');
    CHECK(json_valid(data));
    free(data);
    io_json_free(&j);

    /* A second, shorter document replaces the first completely. */
    io_json_init(&j);
    io_json_begin_object(&j, NULL);
    io_json_string(&j, "version", "second");
    io_json_end_object(&j);
    CHECK_OK(io_json_write(ctx, &j, path), ctx);
    CHECK_OK(io_read_file(ctx, path, 1 << 20, &data, &len), ctx);
    CHECK(!strcmp(data, "{\n  \"version\": \"second\"\n}\n"));
    free(data);
    CHECK_EQ_INT(count_tmp(test_tmpdir()), 0);

    /* Failure leaves the old file and nothing else. */
    char bad[4096];
    snprintf(bad, sizeof bad, "%s/missing/side.json", test_tmpdir());
    CHECK(io_json_write(ctx, &j, bad) == OBS_STATUS_IO_ERROR);
    CHECK(strstr(obs_context_last_error(ctx), "missing/side.json") != NULL);
    CHECK_OK(io_read_file(ctx, path, 1 << 20, &data, &len), ctx);
    CHECK(strstr(data, "second") != NULL);
    free(data);
    CHECK_EQ_INT(count_tmp(test_tmpdir()), 0);
    io_json_free(&j);

    /* An empty document is refused. */
    io_json_init(&j);
    CHECK(io_json_write(ctx, &j, path) == OBS_STATUS_INVALID_ARGUMENT);
    io_json_free(&j);
    obs_context_destroy(ctx);
}
