/* io_json.c: a small JSON writer (io.h, "JSON writer").
 *
 * Output is RFC 8259 JSON, one member or element per line with two spaces of indent per level;
 * io_json_floats puts its numbers on one line ("v": [1, 2, 3]) so that matrices stay readable.
 *
 * need_comma[d] describes the container open at depth d+1 (depth counts open containers):
 *   bit 0: it already holds a member/element (a comma is due before the next one);
 *   bit 1: it is an array (else an object).
 * Misuse that would produce invalid JSON (a member without a key inside an object, a key inside
 * an array or at the top level, a second top-level value, a mismatched end, nesting deeper than
 * 64) sets `failed`; io_json_write then refuses the document with INVALID_ARGUMENT.
 * At depth 0 (no container open) len > 0 means the single top-level value was already written.
 */
#include "io.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define JSON_MAX_DEPTH 64
#define JSON_HAS_ITEMS 1
#define JSON_IS_ARRAY 2

void io_json_init(io_json *j)
{
    if (!j)
        return;
    memset(j, 0, sizeof *j);
}

void io_json_free(io_json *j)
{
    if (!j)
        return;
    free(j->buf);
    memset(j, 0, sizeof *j);
}

static int json_reserve(io_json *j, size_t extra)
{
    if (j->failed)
        return 0;
    size_t need;
    if (!obs_add_size(j->len, extra, &need) || !obs_add_size(need, 1, &need)) {
        j->failed = 1;
        return 0;
    }
    if (need <= j->cap)
        return 1;
    size_t cap = j->cap ? j->cap : 256;
    while (cap < need) {
        if (cap > SIZE_MAX / 2) {
            cap = need;
            break;
        }
        cap *= 2;
    }
    char *nb = realloc(j->buf, cap);
    if (!nb) {
        j->failed = 1;
        return 0;
    }
    j->buf = nb;
    j->cap = cap;
    return 1;
}

static void json_put(io_json *j, const char *s, size_t n)
{
    if (!json_reserve(j, n))
        return;
    memcpy(j->buf + j->len, s, n);
    j->len += n;
    j->buf[j->len] = '\0';
}

static void json_puts(io_json *j, const char *s) { json_put(j, s, strlen(s)); }

static void json_putc(io_json *j, char c) { json_put(j, &c, 1); }

static void json_newline_indent(io_json *j, int depth)
{
    json_putc(j, '\n');
    for (int i = 0; i < depth; i++)
        json_put(j, "  ", 2);
}

/* Length of the well-formed UTF-8 sequence (RFC 3629; Unicode table 3-7: no overlong forms, no
 * surrogates, nothing above U+10FFFF) starting at the non-ASCII byte p[0], or 0. p is
 * NUL-terminated, so a truncated sequence stops at a byte that is not a continuation. */
static size_t utf8_sequence(const unsigned char *p)
{
    unsigned char c = p[0], lo = 0x80, hi = 0xBF;
    size_t len;
    if (c >= 0xC2 && c <= 0xDF)
        len = 2;
    else if (c == 0xE0)
        len = 3, lo = 0xA0;
    else if ((c >= 0xE1 && c <= 0xEC) || c == 0xEE || c == 0xEF)
        len = 3;
    else if (c == 0xED)
        len = 3, hi = 0x9F;
    else if (c == 0xF0)
        len = 4, lo = 0x90;
    else if (c >= 0xF1 && c <= 0xF3)
        len = 4;
    else if (c == 0xF4)
        len = 4, hi = 0x8F;
    else
        return 0;
    if (p[1] < lo || p[1] > hi)
        return 0;
    for (size_t k = 2; k < len; k++)
        if (p[k] < 0x80 || p[k] > 0xBF)
            return 0;
    return len;
}

int io_json_utf8_valid(const char *s)
{
    const unsigned char *p = (const unsigned char *)s;
    while (*p) {
        if (*p < 0x80) {
            p++;
            continue;
        }
        size_t n = utf8_sequence(p);
        if (!n)
            return 0;
        p += n;
    }
    return 1;
}

/* A quoted, escaped JSON string (RFC 8259 section 7). Well-formed UTF-8 passes through; any
 * other byte >= 0x80 (e.g. a Latin-1 file name in argv) becomes U+FFFD, because JSON text must
 * be UTF-8 (RFC 8259 section 8.1) and strict readers refuse anything else. */
static void json_quoted(io_json *j, const char *s)
{
    static const char hex[] = "0123456789abcdef";
    json_putc(j, '"');
    const unsigned char *p = (const unsigned char *)s;
    const unsigned char *run = p;
    for (; *p; p++) {
        unsigned char c = *p;
        const char *esc = NULL;
        char ubuf[7];
        switch (c) {
        case '"': esc = "\\\""; break;
        case '\\': esc = "\\\\"; break;
        case '\b': esc = "\\b"; break;
        case '\f': esc = "\\f"; break;
        case '\n': esc = "\\n"; break;
        case '\r': esc = "\\r"; break;
        case '\t': esc = "\\t"; break;
        default:
            if (c >= 0x80) {
                size_t n = utf8_sequence(p);
                if (n) {
                    p += n - 1; /* the whole sequence stays in the run */
                    continue;
                }
                esc = "\xEF\xBF\xBD"; /* U+FFFD REPLACEMENT CHARACTER */
            } else if (c < 0x20) {
                ubuf[0] = '\\';
                ubuf[1] = 'u';
                ubuf[2] = '0';
                ubuf[3] = '0';
                ubuf[4] = hex[c >> 4];
                ubuf[5] = hex[c & 15];
                ubuf[6] = '\0';
                esc = ubuf;
            }
            break;
        }
        if (esc) {
            json_put(j, (const char *)run, (size_t)(p - run));
            json_puts(j, esc);
            run = p + 1;
        }
    }
    json_put(j, (const char *)run, (size_t)(p - run));
    json_putc(j, '"');
}

/* Everything before a value: the comma, newline and indent, and the key inside objects.
 * Returns 0 (and sets failed) on misuse. */
static int json_prefix(io_json *j, const char *key)
{
    if (j->failed)
        return 0;
    if (j->depth == 0) {
        if (key || j->len > 0) { /* a key at the top level, or a second top-level value */
            j->failed = 1;
            return 0;
        }
        return 1;
    }
    int *state = &j->need_comma[j->depth - 1];
    int is_array = (*state & JSON_IS_ARRAY) != 0;
    if (is_array ? key != NULL : key == NULL) {
        j->failed = 1;
        return 0;
    }
    if (*state & JSON_HAS_ITEMS)
        json_putc(j, ',');
    *state |= JSON_HAS_ITEMS;
    json_newline_indent(j, j->depth);
    if (key) {
        json_quoted(j, key);
        json_put(j, ": ", 2);
    }
    return !j->failed;
}

static void json_begin(io_json *j, const char *key, int is_array)
{
    if (!j || !json_prefix(j, key))
        return;
    if (j->depth >= JSON_MAX_DEPTH) {
        j->failed = 1;
        return;
    }
    json_putc(j, is_array ? '[' : '{');
    j->need_comma[j->depth] = is_array ? JSON_IS_ARRAY : 0;
    j->depth++;
}

static void json_end(io_json *j, int is_array)
{
    if (!j || j->failed)
        return;
    if (j->depth == 0 || ((j->need_comma[j->depth - 1] & JSON_IS_ARRAY) != 0) != (is_array != 0)) {
        j->failed = 1;
        return;
    }
    int had_items = (j->need_comma[j->depth - 1] & JSON_HAS_ITEMS) != 0;
    j->depth--;
    if (had_items)
        json_newline_indent(j, j->depth);
    json_putc(j, is_array ? ']' : '}');
}

void io_json_raw(io_json *j, const char *key, const char *raw)
{
    if (!j || !raw || !raw[0]) {
        if (j)
            j->failed = 1;
        return;
    }
    if (!json_prefix(j, key))
        return;
    json_puts(j, raw);
}

void io_json_begin_object(io_json *j, const char *key) { json_begin(j, key, 0); }
void io_json_end_object(io_json *j) { json_end(j, 0); }
void io_json_begin_array(io_json *j, const char *key) { json_begin(j, key, 1); }
void io_json_end_array(io_json *j) { json_end(j, 1); }

void io_json_string(io_json *j, const char *key, const char *value)
{
    if (!j || !json_prefix(j, key))
        return;
    if (value)
        json_quoted(j, value);
    else
        json_put(j, "null", 4);
}

/* %.9g (enough to round-trip a float), with '.' as the decimal separator whatever the locale. */
static void json_put_number(io_json *j, double value)
{
    if (!isfinite(value)) {
        json_put(j, "null", 4);
        return;
    }
    char b[64];
    int n = snprintf(b, sizeof b, "%.9g", value);
    if (n < 0 || (size_t)n >= sizeof b) {
        j->failed = 1;
        return;
    }
    for (int i = 0; i < n; i++)
        if (b[i] == ',')
            b[i] = '.';
    json_put(j, b, (size_t)n);
}

void io_json_number(io_json *j, const char *key, double value)
{
    if (!j || !json_prefix(j, key))
        return;
    json_put_number(j, value);
}

void io_json_int(io_json *j, const char *key, int64_t value)
{
    if (!j || !json_prefix(j, key))
        return;
    char b[32];
    int n = snprintf(b, sizeof b, "%" PRId64, value);
    json_put(j, b, (size_t)n);
}

void io_json_bool(io_json *j, const char *key, int value)
{
    if (!j || !json_prefix(j, key))
        return;
    json_puts(j, value ? "true" : "false");
}

void io_json_null(io_json *j, const char *key)
{
    if (!j || !json_prefix(j, key))
        return;
    json_put(j, "null", 4);
}

void io_json_floats(io_json *j, const char *key, const float *v, int n)
{
    if (!j || !json_prefix(j, key))
        return;
    if (n < 0 || (n > 0 && !v)) {
        j->failed = 1;
        return;
    }
    json_putc(j, '[');
    for (int i = 0; i < n; i++) {
        if (i)
            json_put(j, ", ", 2);
        json_put_number(j, (double)v[i]);
    }
    json_putc(j, ']');
}

obs_status io_json_write(obs_context *ctx, const io_json *j, const char *path)
{
    if (!j || !path)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_json_write: NULL argument");
    if (j->failed)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "cannot write '%s': the JSON document is invalid (allocation failure, nesting over %d, "
                         "or a misplaced key or end)",
                         path, JSON_MAX_DEPTH);
    if (j->depth != 0 || j->len == 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "cannot write '%s': the JSON document is %s", path,
                         j->len == 0 ? "empty" : "unfinished (an object or array is still open)");
    char *out = malloc(j->len + 1);
    if (!out)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "cannot allocate %zu bytes to write '%s'", j->len + 1, path);
    memcpy(out, j->buf, j->len);
    out[j->len] = '\n';
    obs_status st = io_write_file_atomic(ctx, path, out, j->len + 1);
    free(out);
    return st;
}
