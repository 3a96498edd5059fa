/* off.c: the OFF reader (off.h). */
#include "off.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct off_cursor {
    const char *p, *end;
    int line;
} off_cursor;

static void skip_space(off_cursor *c)
{
    while (c->p < c->end) {
        if (*c->p == '#') {
            while (c->p < c->end && *c->p != '\n')
                c->p++;
        } else if (*c->p == '\n') {
            c->line++;
            c->p++;
        } else if (*c->p == ' ' || *c->p == '\t' || *c->p == '\r') {
            c->p++;
        } else {
            return;
        }
    }
}

/* Skip to the start of the next line (ignoring extra columns). */
static void next_line(off_cursor *c)
{
    while (c->p < c->end && *c->p != '\n')
        c->p++;
}

static int read_double(off_cursor *c, double *v)
{
    skip_space(c);
    if (c->p >= c->end)
        return 0;
    char *e;
    errno = 0;
    double d = strtod(c->p, &e);
    if (e == c->p || errno == ERANGE || (e < c->end && !strchr(" \t\r\n#", *e)))
        return 0;
    c->p = e;
    *v = d;
    return 1;
}

static int read_count(off_cursor *c, long long *v)
{
    skip_space(c);
    if (c->p >= c->end)
        return 0;
    char *e;
    errno = 0;
    long long x = strtoll(c->p, &e, 10);
    if (e == c->p || errno == ERANGE || (e < c->end && !strchr(" \t\r\n#", *e)))
        return 0;
    c->p = e;
    *v = x;
    return 1;
}

obs_status off_parse(obs_context *ctx, const char *name, const char *text, size_t len, float **positions,
                     uint32_t *nv_out, uint32_t **indices, uint32_t *nt_out)
{
    *positions = NULL;
    *indices = NULL;
    off_cursor c = {text, text + len, 1};
    skip_space(&c);
    if ((size_t)(c.end - c.p) < 3 || strncmp(c.p, "OFF", 3) != 0)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: not an OFF file (no 'OFF' header)", name, c.line);
    c.p += 3;
    long long nv, nf, ne;
    if (!read_count(&c, &nv) || !read_count(&c, &nf) || !read_count(&c, &ne))
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: expected three counts after 'OFF'", name, c.line);
    if (nv < 3 || nf < 1 || ne < 0)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: bad counts %lld vertices, %lld faces, %lld edges", name,
                         c.line, nv, nf, ne);
    const obs_limits *lim = obs_context_limits(ctx);
    size_t rest = (size_t)(c.end - c.p);
    /* The smallest vertex line is "0 0 0\n" (6 bytes), the smallest face "3 0 1 2\n" (8). */
    if ((unsigned long long)nv > rest / 6 || (unsigned long long)nf > rest / 8)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                         "%s:%d: %lld vertices and %lld faces cannot fit in the remaining %zu bytes", name, c.line, nv,
                         nf, rest);
    if (nv > lim->max_vertices)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: %lld vertices, over the limit of %lld (--max-vertices)",
                         name, nv, (long long)lim->max_vertices);
    float *pos = (float *)malloc((size_t)nv * 3 * sizeof(float));
    size_t cap = (size_t)nf * 2 + 16, nt = 0;
    uint32_t *idx = (uint32_t *)malloc(cap * 3 * sizeof(uint32_t));
    if (!pos || !idx) {
        free(pos);
        free(idx);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", name);
    }
    obs_status st = OBS_STATUS_OK;
    for (long long v = 0; v < nv && st == OBS_STATUS_OK; v++) {
        for (int k = 0; k < 3; k++) {
            double d;
            if (!read_double(&c, &d) || !isfinite(d) || fabs(d) > 3.0e38) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: vertex %lld: expected three finite numbers", name,
                               c.line, v);
                break;
            }
            pos[3 * v + k] = (float)d;
        }
        next_line(&c);
    }
    for (long long f = 0; f < nf && st == OBS_STATUS_OK; f++) {
        long long n, first, prev;
        if (!read_count(&c, &n) || n < 3 || n > 1000000) {
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: face %lld: expected a vertex count >= 3", name, c.line, f);
            break;
        }
        long long ids[2];
        for (int k = 0; k < 2 && st == OBS_STATUS_OK; k++)
            if (!read_count(&c, &ids[k]) || ids[k] < 0 || ids[k] >= nv)
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: face %lld: index missing or out of [0, %lld)", name,
                               c.line, f, nv);
        first = ids[0];
        prev = ids[1];
        for (long long k = 2; k < n && st == OBS_STATUS_OK; k++) { /* fan triangulation */
            long long cur;
            if (!read_count(&c, &cur) || cur < 0 || cur >= nv) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s:%d: face %lld: index missing or out of [0, %lld)", name,
                               c.line, f, nv);
                break;
            }
            if (nt == cap) {
                if ((long long)nt >= lim->max_triangles) {
                    st = obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: over %lld triangles (--max-triangles)", name,
                                   (long long)lim->max_triangles);
                    break;
                }
                uint32_t *ni = (uint32_t *)realloc(idx, cap * 2 * 3 * sizeof(uint32_t));
                if (!ni) {
                    st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", name);
                    break;
                }
                idx = ni;
                cap *= 2;
            }
            idx[3 * nt] = (uint32_t)first;
            idx[3 * nt + 1] = (uint32_t)prev;
            idx[3 * nt + 2] = (uint32_t)cur;
            nt++;
            prev = cur;
        }
        next_line(&c);
    }
    if (st == OBS_STATUS_OK && (long long)nt > lim->max_triangles)
        st = obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: %zu triangles, over the limit (--max-triangles)", name, nt);
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
