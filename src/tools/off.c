/* off.c: the OFF reader (off.h).
 *
 * Grammar (Geomview's OFF, as CGAL writes it; '#' starts a comment that runs to the end of the
 * line, anywhere):
 *   "OFF" [nv nf ne]            the header keyword, a whole token; the counts may follow on the
 *   nv nf ne                    same line or on the next non-blank line (ne is read and ignored),
 *                               alone on their line
 *   x y z [extra numbers]       nv vertex records, one per line; extra columns (colours) must be
 *                               numbers and are ignored
 *   n i0 .. i{n-1} [colour]     nf face records, one per line, n >= 3; fan-triangulated
 *                               (i0 i1 i2), (i0 i2 i3), ...; a colour must be numbers
 * Blank and comment lines may appear between records; nothing but blanks and comments may follow
 * the last face. A record never continues onto the next line, so a short line is an error on
 * that line instead of silently borrowing numbers from the next record. */
#include "off.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The largest polygon accepted: far above any real mesh, small enough to bound a face's work. */
#define OFF_MAX_POLYGON 1000000

typedef struct off_cursor {
    const char *p, *end;
    int line;
} off_cursor;

/* Skip blanks, newlines and comments (between records). */
static void skip_space(off_cursor *c)
{
    while (c->p < c->end) {
        if (*c->p == '#') {
            while (c->p < c->end && *c->p != '\n')
                c->p++;
        } else if (*c->p == '\n') {
            c->line++;
            c->p++;
        } else if (*c->p == ' ' || *c->p == '\t' || *c->p == '\r' || *c->p == '\f' || *c->p == '\v') {
            c->p++;
        } else {
            return;
        }
    }
}

/* Skip blanks within the current line; returns 1 if a token follows on this line. */
static int skip_inline(off_cursor *c)
{
    while (c->p < c->end && (*c->p == ' ' || *c->p == '\t' || *c->p == '\r' || *c->p == '\f' || *c->p == '\v'))
        c->p++;
    return c->p < c->end && *c->p != '\n' && *c->p != '#';
}

static int token_end(const off_cursor *c, const char *e)
{
    return e >= c->end || strchr(" \t\r\f\v\n#", *e) != NULL;
}

/* A number token on the current line (first = 1: the first token of a record, which may come
 * after blank and comment lines). */
static int read_double(off_cursor *c, int first, double *v)
{
    if (first)
        skip_space(c);
    if (!skip_inline(c))
        return 0;
    char *e;
    errno = 0;
    double d = strtod(c->p, &e);
    if (e == c->p || e > c->end || errno == ERANGE || !token_end(c, e))
        return 0;
    c->p = e;
    *v = d;
    return 1;
}

static int read_int(off_cursor *c, int first, long long *v)
{
    if (first)
        skip_space(c);
    if (!skip_inline(c))
        return 0;
    char *e;
    errno = 0;
    long long x = strtoll(c->p, &e, 10);
    if (e == c->p || e > c->end || errno == ERANGE || !token_end(c, e))
        return 0;
    c->p = e;
    *v = x;
    return 1;
}

/* The rest of a record's line: a comment, and numbers (colours) where extra_numbers is set. */
static int end_record(off_cursor *c, int extra_numbers)
{
    double ignored;
    while (skip_inline(c))
        if (!extra_numbers || !read_double(c, 0, &ignored))
            return 0;
    while (c->p < c->end && *c->p != '\n') /* a comment */
        c->p++;
    return 1;
}

obs_status off_parse(obs_context *ctx, const char *name, const char *text, size_t len, float **positions,
                     uint32_t *nv_out, uint32_t **indices, uint32_t *nt_out)
{
    *positions = NULL;
    *indices = NULL;
    if (!name)
        name = "<off>";
    if (!text || !nv_out || !nt_out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: off_parse: NULL argument", name);
    if (memchr(text, '\0', len) != NULL)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: contains a NUL byte (binary data, not OFF text)", name);
    off_cursor c = {text, text + len, 1};

    /* Header: the keyword as a whole token, then three counts. */
    skip_space(&c);
    if ((size_t)(c.end - c.p) < 3 || strncmp(c.p, "OFF", 3) != 0 || !token_end(&c, c.p + 3))
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: not an OFF file (no 'OFF' header)", name, c.line);
    c.p += 3;
    long long nv, nf, ne;
    if (!read_int(&c, 1, &nv) || !read_int(&c, 0, &nf) || !read_int(&c, 0, &ne))
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                         "%s:%d: expected three integer counts (vertices faces edges) after 'OFF'", name, c.line);
    if (!end_record(&c, 0))
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                         "%s:%d: unexpected text after the three counts (one record per line)", name, c.line);
    if (nv < 3 || nf < 1 || ne < 0)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: bad counts %lld vertices, %lld faces, %lld edges", name,
                         c.line, nv, nf, ne);

    /* Counts against the text before any allocation: the smallest vertex record is "0 0 0\n"
     * (6 bytes), the smallest face "3 0 1 2\n" (8), the last one possibly without its newline. */
    const obs_limits *lim = obs_context_limits(ctx);
    const unsigned long long rest = (unsigned long long)(c.end - c.p);
    if ((unsigned long long)nv > rest / 6 || (unsigned long long)nf > rest / 8 ||
        6ull * (unsigned long long)nv + 8ull * (unsigned long long)nf > rest + 1)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                         "%s:%d: %lld vertices and %lld faces cannot fit in the remaining %llu bytes (truncated file "
                         "or corrupt counts)",
                         name, c.line, nv, nf, rest);
    if (nv > lim->max_vertices || nv > (long long)UINT32_MAX)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: %lld vertices, over the limit of %lld (--max-vertices)",
                         name, nv, (long long)lim->max_vertices);
    if (nf > lim->max_triangles)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "%s: %lld faces, over the triangle limit of %lld (--max-triangles)", name, nf,
                         (long long)lim->max_triangles);

    /* Sizes are bounded by the text length above (nv <= len/6, nf <= len/8), so these products
     * cannot overflow; the index array starts at one triangle per face and grows for polygons. */
    float *pos = (float *)malloc((size_t)nv * 3 * sizeof(float));
    size_t cap = (size_t)nf, nt = 0;
    uint32_t *idx = (uint32_t *)malloc(cap * 3 * sizeof(uint32_t));
    if (!pos || !idx) {
        free(pos);
        free(idx);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory for %lld vertices and %lld faces", name, nv,
                         nf);
    }

    obs_status st = OBS_STATUS_OK;
    /* Vertex records. */
    for (long long v = 0; v < nv && st == OBS_STATUS_OK; v++) {
        skip_space(&c);
        if (c.p >= c.end) {
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: the file ends after %lld of %lld vertices", name,
                           c.line, v, nv);
            break;
        }
        for (int k = 0; k < 3; k++) {
            double d;
            if (!read_double(&c, 0, &d) || !isfinite(d) || fabs(d) > 3.0e38) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                               "%s:%d: vertex %lld: expected three finite numbers on the line", name, c.line, v);
                break;
            }
            pos[3 * v + k] = (float)d;
        }
        if (st == OBS_STATUS_OK && !end_record(&c, 1))
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: vertex %lld: unexpected text after the coordinates",
                           name, c.line, v);
    }
    /* Face records, fan-triangulated. */
    for (long long f = 0; f < nf && st == OBS_STATUS_OK; f++) {
        skip_space(&c);
        if (c.p >= c.end) {
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: the file ends after %lld of %lld faces", name, c.line,
                           f, nf);
            break;
        }
        long long n, first = 0, prev = 0;
        if (!read_int(&c, 0, &n) || n < 3 || n > OFF_MAX_POLYGON) {
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                           "%s:%d: face %lld: expected a vertex count in [3, %d] at the start of the line", name,
                           c.line, f, OFF_MAX_POLYGON);
            break;
        }
        for (long long k = 0; k < n && st == OBS_STATUS_OK; k++) {
            long long cur;
            if (!read_int(&c, 0, &cur) || cur < 0 || cur >= nv) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                               "%s:%d: face %lld: index %lld of %lld missing, not an integer or out of [0, %lld)", name,
                               c.line, f, k, n, nv);
                break;
            }
            if (k == 0) {
                first = cur;
            } else if (k >= 2) {
                if (nt == cap) {
                    if ((long long)nt >= lim->max_triangles) {
                        st = obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s:%d: over %lld triangles (--max-triangles)",
                                       name, c.line, (long long)lim->max_triangles);
                        break;
                    }
                    size_t ncap, bytes;
                    uint32_t *ni = NULL;
                    if (obs_mul_size(cap, 2, &ncap) && obs_mul_size(ncap, 3 * sizeof(uint32_t), &bytes))
                        ni = (uint32_t *)realloc(idx, bytes);
                    if (!ni) {
                        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory for %zu triangles", name,
                                       2 * cap);
                        break;
                    }
                    idx = ni;
                    cap = ncap;
                }
                idx[3 * nt] = (uint32_t)first;
                idx[3 * nt + 1] = (uint32_t)prev;
                idx[3 * nt + 2] = (uint32_t)cur;
                nt++;
            }
            prev = cur;
        }
        if (st == OBS_STATUS_OK && !end_record(&c, 1))
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                           "%s:%d: face %lld: unexpected text after its %lld indices (a colour must be numbers)", name,
                           c.line, f, n);
    }
    if (st == OBS_STATUS_OK) {
        skip_space(&c);
        if (c.p < c.end)
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: unexpected content after the last face", name, c.line);
    }
    if (st == OBS_STATUS_OK && (long long)nt > lim->max_triangles)
        st = obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: %zu triangles, over the limit of %lld (--max-triangles)",
                       name, nt, (long long)lim->max_triangles);
    if (st != OBS_STATUS_OK) {
        free(pos);
        free(idx);
        return st;
    }
    *positions = pos;
    *indices = idx;
    *nv_out = (uint32_t)nv;
    *nt_out = (uint32_t)nt;
    return OBS_STATUS_OK;
}
