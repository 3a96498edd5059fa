/* fuzz_json.c: the io_json writer driven by a byte program (objects, arrays, keys, strings of
 * arbitrary bytes, doubles and floats of every bit pattern, ints, raw values, misuse), checked
 * against an independent model:
 *   - the model predicts which calls are misuse (a key in an array, none in an object, a second
 *     top-level value, a mismatched end, nesting over 64); the writer's `failed` must agree;
 *   - when the document is complete, its text must be one valid JSON text under a strict
 *     RFC 8259 parser written here (UTF-8 strings included, RFC 3629), and the parsed values must
 *     be the ones written: keys and strings byte for byte (bytes that are not UTF-8 become
 *     U+FFFD), ints exactly, floats exactly (%.9g round-trips a float), doubles to 9 significant
 *     digits, non-finite numbers as null. */
#include "fuzz.h"

#include "io/io.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- events: what the model expects and what the parser finds --------------------------------- */

typedef struct ev {
    char t;          /* { } [ ] K(key) S(string) N(number) T F Z(null) */
    char want;       /* for expected numbers: 'd' double, 'f' float, 'i' int */
    double d;
    float f;
    int64_t i;
    size_t off, len; /* payload in the pool: key/string bytes (decoded), number text */
} ev;

typedef struct evlist {
    ev *v;
    size_t n, cap;
    char *pool;
    size_t plen, pcap;
} evlist;

static void ev_free(evlist *l)
{
    free(l->v);
    free(l->pool);
    memset(l, 0, sizeof *l);
}

static ev *ev_push(evlist *l, char t)
{
    if (l->n == l->cap) {
        l->cap = l->cap ? 2 * l->cap : 64;
        l->v = realloc(l->v, l->cap * sizeof(ev));
        fuzz_require(l->v != NULL, "allocation");
    }
    ev *e = &l->v[l->n++];
    memset(e, 0, sizeof *e);
    e->t = t;
    e->off = l->plen;
    return e;
}

/* The payload of an event (never a NULL pointer, even for an empty pool). */
static const char *payload(const evlist *l, const ev *e) { return l->pool ? l->pool + e->off : ""; }

static void pool_put(evlist *l, ev *e, const char *s, size_t n)
{
    if (n == 0)
        return;
    if (l->plen + n > l->pcap) {
        while (l->plen + n > l->pcap)
            l->pcap = l->pcap ? 2 * l->pcap : 256;
        l->pool = realloc(l->pool, l->pcap);
        fuzz_require(l->pool != NULL, "allocation");
    }
    memcpy(l->pool + l->plen, s, n);
    l->plen += n;
    e->len += n;
}

/* ---- UTF-8 (RFC 3629; Unicode 15, table 3-7) ------------------------------------------------ */

/* Length of the valid UTF-8 sequence at s (n bytes left), or 0. */
static size_t utf8_seq(const unsigned char *s, size_t n)
{
    unsigned char c = s[0];
    if (c < 0x80)
        return 1;
    size_t len;
    unsigned char lo = 0x80, hi = 0xBF;
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
    if (n < len || s[1] < lo || s[1] > hi)
        return 0;
    for (size_t k = 2; k < len; k++)
        if (s[k] < 0x80 || s[k] > 0xBF)
            return 0;
    return len;
}

/* The model of what a written string reads back as: valid sequences as they are, every other
 * byte as U+FFFD. */
static void expect_text(evlist *l, ev *e, const char *s)
{
    const unsigned char *p = (const unsigned char *)s;
    size_t n = strlen(s);
    for (size_t i = 0; i < n;) {
        size_t k = utf8_seq(p + i, n - i);
        if (k) {
            pool_put(l, e, (const char *)p + i, k);
            i += k;
        } else {
            pool_put(l, e, "\xEF\xBF\xBD", 3);
            i++;
        }
    }
}

/* ---- a strict RFC 8259 parser producing events -------------------------------------------- */

typedef struct parser {
    const char *p, *end;
    int depth;
    evlist *out;
} parser;

static void ws(parser *ps)
{
    while (ps->p < ps->end && (*ps->p == ' ' || *ps->p == '\t' || *ps->p == '\n' || *ps->p == '\r'))
        ps->p++;
}

static int hex4(parser *ps, unsigned *v)
{
    if (ps->end - ps->p < 4)
        return 0;
    *v = 0;
    for (int k = 0; k < 4; k++) {
        char h = *ps->p++;
        unsigned d = h >= '0' && h <= '9' ? (unsigned)(h - '0')
                   : h >= 'a' && h <= 'f' ? (unsigned)(h - 'a' + 10)
                   : h >= 'A' && h <= 'F' ? (unsigned)(h - 'A' + 10)
                                          : 16u;
        if (d > 15)
            return 0;
        *v = *v * 16 + d;
    }
    return 1;
}

static void put_utf8(evlist *l, ev *e, unsigned cp)
{
    char b[4];
    size_t n;
    if (cp < 0x80)
        b[0] = (char)cp, n = 1;
    else if (cp < 0x800)
        b[0] = (char)(0xC0 | cp >> 6), b[1] = (char)(0x80 | (cp & 63)), n = 2;
    else if (cp < 0x10000)
        b[0] = (char)(0xE0 | cp >> 12), b[1] = (char)(0x80 | (cp >> 6 & 63)), b[2] = (char)(0x80 | (cp & 63)), n = 3;
    else
        b[0] = (char)(0xF0 | cp >> 18), b[1] = (char)(0x80 | (cp >> 12 & 63)), b[2] = (char)(0x80 | (cp >> 6 & 63)),
        b[3] = (char)(0x80 | (cp & 63)), n = 4;
    pool_put(l, e, b, n);
}

static int string_ev(parser *ps, char t)
{
    if (ps->p >= ps->end || *ps->p != '"')
        return 0;
    ps->p++;
    ev *e = ev_push(ps->out, t);
    size_t idx = (size_t)(e - ps->out->v);
    for (;;) {
        e = &ps->out->v[idx];
        if (ps->p >= ps->end)
            return 0;
        unsigned char c = (unsigned char)*ps->p;
        if (c < 0x20)
            return 0; /* control characters must be escaped */
        if (c == '"') {
            ps->p++;
            return 1;
        }
        if (c == '\\') {
            ps->p++;
            if (ps->p >= ps->end)
                return 0;
            char x = *ps->p++;
            unsigned cp;
            switch (x) {
            case '"': pool_put(ps->out, e, "\"", 1); break;
            case '\\': pool_put(ps->out, e, "\\", 1); break;
            case '/': pool_put(ps->out, e, "/", 1); break;
            case 'b': pool_put(ps->out, e, "\b", 1); break;
            case 'f': pool_put(ps->out, e, "\f", 1); break;
            case 'n': pool_put(ps->out, e, "\n", 1); break;
            case 'r': pool_put(ps->out, e, "\r", 1); break;
            case 't': pool_put(ps->out, e, "\t", 1); break;
            case 'u':
                if (!hex4(ps, &cp))
                    return 0;
                if (cp >= 0xD800 && cp <= 0xDBFF) { /* a surrogate pair */
                    unsigned lo;
                    if (ps->end - ps->p < 6 || ps->p[0] != '\\' || ps->p[1] != 'u')
                        return 0;
                    ps->p += 2;
                    if (!hex4(ps, &lo) || lo < 0xDC00 || lo > 0xDFFF)
                        return 0;
                    cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
                } else if (cp >= 0xDC00 && cp <= 0xDFFF) {
                    return 0;
                }
                put_utf8(ps->out, e, cp);
                break;
            default: return 0;
            }
            continue;
        }
        size_t k = utf8_seq((const unsigned char *)ps->p, (size_t)(ps->end - ps->p));
        if (!k)
            return 0; /* RFC 8259 section 8.1: JSON text is UTF-8 */
        pool_put(ps->out, e, ps->p, k);
        ps->p += k;
    }
}

static int digits(parser *ps)
{
    int n = 0;
    while (ps->p < ps->end && *ps->p >= '0' && *ps->p <= '9')
        ps->p++, n++;
    return n;
}

static int number_ev(parser *ps)
{
    const char *start = ps->p;
    if (ps->p < ps->end && *ps->p == '-')
        ps->p++;
    if (ps->p < ps->end && *ps->p == '0')
        ps->p++;
    else if (!digits(ps))
        return 0;
    if (ps->p < ps->end && *ps->p == '.') {
        ps->p++;
        if (!digits(ps))
            return 0;
    }
    if (ps->p < ps->end && (*ps->p == 'e' || *ps->p == 'E')) {
        ps->p++;
        if (ps->p < ps->end && (*ps->p == '+' || *ps->p == '-'))
            ps->p++;
        if (!digits(ps))
            return 0;
    }
    ev *e = ev_push(ps->out, 'N');
    pool_put(ps->out, e, start, (size_t)(ps->p - start));
    return 1;
}

static int literal(parser *ps, const char *word, char t)
{
    size_t n = strlen(word);
    if ((size_t)(ps->end - ps->p) < n || memcmp(ps->p, word, n) != 0)
        return 0;
    ps->p += n;
    ev_push(ps->out, t);
    return 1;
}

static int value(parser *ps);

static int container(parser *ps, int is_object)
{
    char close = is_object ? '}' : ']';
    ev_push(ps->out, is_object ? '{' : '[');
    ps->p++;
    if (++ps->depth > 200)
        return 0;
    ws(ps);
    if (ps->p < ps->end && *ps->p == close) {
        ps->p++;
        ps->depth--;
        ev_push(ps->out, close);
        return 1;
    }
    for (;;) {
        ws(ps);
        if (is_object) {
            if (!string_ev(ps, 'K'))
                return 0;
            ws(ps);
            if (ps->p >= ps->end || *ps->p++ != ':')
                return 0;
        }
        if (!value(ps))
            return 0;
        ws(ps);
        if (ps->p >= ps->end)
            return 0;
        if (*ps->p == ',') {
            ps->p++;
            continue;
        }
        if (*ps->p == close) {
            ps->p++;
            ps->depth--;
            ev_push(ps->out, close);
            return 1;
        }
        return 0;
    }
}

static int value(parser *ps)
{
    ws(ps);
    if (ps->p >= ps->end)
        return 0;
    switch (*ps->p) {
    case '{': return container(ps, 1);
    case '[': return container(ps, 0);
    case '"': return string_ev(ps, 'S');
    case 't': return literal(ps, "true", 'T');
    case 'f': return literal(ps, "false", 'F');
    case 'n': return literal(ps, "null", 'Z');
    default: return number_ev(ps);
    }
}

/* One JSON text, nothing but whitespace around it. */
static int parse_json(const char *s, size_t n, evlist *out)
{
    parser ps = {s, s + n, 0, out};
    if (!value(&ps))
        return 0;
    ws(&ps);
    return ps.p == ps.end;
}

/* ---- the byte program ------------------------------------------------------------------- */

typedef struct prog {
    const uint8_t *p;
    size_t n;
} prog;

static int take(prog *g, uint8_t *b)
{
    if (!g->n)
        return 0;
    *b = *g->p++;
    g->n--;
    return 1;
}

static void take_bytes(prog *g, void *dst, size_t n)
{
    memset(dst, 0, n);
    size_t k = n < g->n ? n : g->n;
    memcpy(dst, g->p, k);
    g->p += k;
    g->n -= k;
}

/* A C string of up to 47 arbitrary non-NUL bytes (NUL maps to 0x01) into buf[48]. */
static void take_string(prog *g, char buf[48])
{
    uint8_t len = 0;
    take(g, &len);
    len %= 48;
    size_t k = 0;
    for (; k < len && g->n; k++) {
        uint8_t c;
        take(g, &c);
        buf[k] = c ? (char)c : 1;
    }
    buf[k] = '\0';
}

static const char *const raw_values[] = {
    "{}", "[]", "0", "-1.5e-7", "true", "null", "\"r\\u00e9\\n\"", "[1,2,{\"a\":null,\"b\":[]}]",
    "{\"k\":[true,false,\"\\ud83d\\ude00\"]}",
};

static const double special_numbers[] = {
    0.0, -0.0, 1.0, -1.0, 0.1, 1e-300, 4.9406564584124654e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
    -1.7976931348623157e308, 3.4028234663852886e38, 1.401298464324817e-45, 16777217.0, 9007199254740993.0,
    NAN, INFINITY, -INFINITY, 123456789.0, 1e21, 1e-7,
};

/* The model's view of the writer: container kinds, whether the top value was written, and
 * whether a misuse happened. */
typedef struct model {
    char kind[64]; /* 'a' array, 'o' object */
    int depth;
    int top_done;
    int failed;
} model;

/* Before a value: 1 when the writer must accept a value with this key here. */
static int model_prefix(model *m, const char *key)
{
    if (m->failed)
        return 0;
    if (m->depth == 0) {
        if (key || m->top_done) {
            m->failed = 1;
            return 0;
        }
        m->top_done = 1;
        return 1;
    }
    int is_array = m->kind[m->depth - 1] == 'a';
    if (is_array ? key != NULL : key == NULL) {
        m->failed = 1;
        return 0;
    }
    return 1;
}

static void expect_key(evlist *x, const char *key)
{
    if (key) {
        ev *e = ev_push(x, 'K');
        expect_text(x, e, key);
    }
}

static void expect_number(evlist *x, char want, double d, float f, int64_t i)
{
    if ((want == 'd' && !isfinite(d)) || (want == 'f' && !isfinite(f))) {
        ev_push(x, 'Z');
        return;
    }
    ev *e = ev_push(x, 'N');
    e->want = want;
    e->d = d;
    e->f = f;
    e->i = i;
}

static int number_matches(const ev *want, const char *text, size_t len)
{
    char buf[64];
    if (len >= sizeof buf)
        return 0;
    memcpy(buf, text, len);
    buf[len] = '\0';
    if (want->want == 'i')
        return strtoll(buf, NULL, 10) == want->i && strchr(buf, '.') == NULL && strchr(buf, 'e') == NULL;
    double v = strtod(buf, NULL);
    if (want->want == 'f')
        return (float)v == want->f;
    if (isinf(v))
        return fabs(want->d) > 1.7976931e308; /* %.9g may round DBL_MAX's neighbours up */
    return fabs(v - want->d) <= fabs(want->d) * 1e-8 + 1e-320;
}

static int same_events(const evlist *want, const evlist *got)
{
    if (want->n != got->n)
        return 0;
    for (size_t k = 0; k < want->n; k++) {
        const ev *a = &want->v[k], *b = &got->v[k];
        if (a->t != b->t)
            return 0;
        if (a->t == 'K' || a->t == 'S') {
            if (a->len != b->len || memcmp(payload(want, a), payload(got, b), a->len) != 0)
                return 0;
        } else if (a->t == 'N' && a->want) {
            if (!number_matches(a, payload(got, b), b->len))
                return 0;
        } else if (a->t == 'N') { /* from a raw value: the same text */
            if (a->len != b->len || memcmp(payload(want, a), payload(got, b), a->len) != 0)
                return 0;
        }
    }
    return 1;
}

int obs_fuzz_json(const uint8_t *data, size_t size)
{
    prog g = {data, size};
    io_json j;
    io_json_init(&j);
    model m;
    memset(&m, 0, sizeof m);
    evlist want;
    memset(&want, 0, sizeof want);
    uint8_t op;
    int ops = 0;
    while (take(&g, &op) && ops++ < 4096) {
        char keybuf[48];
        const char *key = NULL;
        if (op & 0x80) {
            take_string(&g, keybuf);
            key = keybuf;
        }
        switch (op & 0x0F) {
        case 0:
        case 1: { /* begin object / array */
            int is_array = (op & 0x0F) == 1;
            int ok = model_prefix(&m, key);
            if (ok && m.depth >= 64) {
                m.failed = 1;
                ok = 0;
            }
            if (ok) {
                expect_key(&want, key);
                ev_push(&want, is_array ? '[' : '{');
                m.kind[m.depth++] = is_array ? 'a' : 'o';
            }
            if (is_array)
                io_json_begin_array(&j, key);
            else
                io_json_begin_object(&j, key);
            break;
        }
        case 2:
        case 3: { /* end object / array */
            int is_array = (op & 0x0F) == 3;
            if (!m.failed) {
                if (m.depth == 0 || (m.kind[m.depth - 1] == 'a') != is_array) {
                    m.failed = 1;
                } else {
                    m.depth--;
                    ev_push(&want, is_array ? ']' : '}');
                }
            }
            if (is_array)
                io_json_end_array(&j);
            else
                io_json_end_object(&j);
            break;
        }
        case 4: { /* a string, or NULL (null) */
            char val[48];
            take_string(&g, val);
            int is_null = (op & 0x40) != 0;
            if (model_prefix(&m, key)) {
                expect_key(&want, key);
                if (is_null)
                    ev_push(&want, 'Z');
                else
                    expect_text(&want, ev_push(&want, 'S'), val);
            }
            io_json_string(&j, key, is_null ? NULL : val);
            break;
        }
        case 5: { /* any double bit pattern */
            double d;
            take_bytes(&g, &d, sizeof d);
            if (model_prefix(&m, key)) {
                expect_key(&want, key);
                expect_number(&want, 'd', d, 0.0f, 0);
            }
            io_json_number(&j, key, d);
            break;
        }
        case 6: { /* int64 */
            int64_t v;
            take_bytes(&g, &v, sizeof v);
            if (model_prefix(&m, key)) {
                expect_key(&want, key);
                expect_number(&want, 'i', 0.0, 0.0f, v);
            }
            io_json_int(&j, key, v);
            break;
        }
        case 7:
        case 8: { /* bool, null */
            if (model_prefix(&m, key)) {
                expect_key(&want, key);
                ev_push(&want, (op & 0x0F) == 8 ? 'Z' : (op & 0x40) ? 'T' : 'F');
            }
            if ((op & 0x0F) == 8)
                io_json_null(&j, key);
            else
                io_json_bool(&j, key, (op & 0x40) != 0);
            break;
        }
        case 9: { /* a float array of any bit patterns */
            uint8_t n = 0;
            take(&g, &n);
            n %= 20;
            float v[20];
            take_bytes(&g, v, (size_t)n * sizeof(float));
            if (model_prefix(&m, key)) {
                expect_key(&want, key);
                ev_push(&want, '[');
                for (int k = 0; k < n; k++)
                    expect_number(&want, 'f', 0.0, v[k], 0);
                ev_push(&want, ']');
            }
            io_json_floats(&j, key, n ? v : NULL, n);
            break;
        }
        case 10: { /* a raw, already serialised value */
            uint8_t which = 0;
            take(&g, &which);
            const char *raw = raw_values[which % (sizeof raw_values / sizeof raw_values[0])];
            if (model_prefix(&m, key)) {
                expect_key(&want, key);
                evlist sub;
                memset(&sub, 0, sizeof sub);
                fuzz_require(parse_json(raw, strlen(raw), &sub), "the raw snippets are valid JSON");
                for (size_t k = 0; k < sub.n; k++) {
                    ev *e = ev_push(&want, sub.v[k].t);
                    pool_put(&want, e, payload(&sub, &sub.v[k]), sub.v[k].len);
                }
                ev_free(&sub);
            }
            io_json_raw(&j, key, raw);
            break;
        }
        case 11: { /* a special double */
            uint8_t which = 0;
            take(&g, &which);
            double d = special_numbers[which % (sizeof special_numbers / sizeof special_numbers[0])];
            if (model_prefix(&m, key)) {
                expect_key(&want, key);
                expect_number(&want, 'd', d, 0.0f, 0);
            }
            io_json_number(&j, key, d);
            break;
        }
        default: break; /* no call: lets the fuzzer skip bytes */
        }
        fuzz_require(m.failed == (j.failed != 0), "the writer refuses exactly the misuse the model predicts");
        fuzz_require(m.depth == j.depth || m.failed, "the writer's depth follows the model");
    }
    if (!m.failed && m.depth == 0 && m.top_done) {
        fuzz_require(j.len > 0 && j.buf != NULL && strlen(j.buf) == j.len, "a complete document has text");
        evlist got;
        memset(&got, 0, sizeof got);
        fuzz_require(parse_json(j.buf, j.len, &got), "a complete document is one valid JSON text (RFC 8259)");
        fuzz_require(same_events(&want, &got), "the document holds exactly the values written");
        ev_free(&got);
    }
    ev_free(&want);
    io_json_free(&j);
    return 0;
}
