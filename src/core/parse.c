/* parse.c: numbers from text, for the command line and the studies' option lists (obs.h). */
#include "obs.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

int obs_parse_int(const char *s, long long lo, long long hi, long long *out)
{
    if (!s || !*s)
        return 0;
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (errno || *end || v < lo || v > hi)
        return 0;
    *out = v;
    return 1;
}

int obs_parse_double(const char *s, double *out)
{
    if (!s || !*s)
        return 0;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || *end || v != v)
        return 0;
    *out = v;
    return 1;
}

int obs_parse_size(const char *s, int max, int *w, int *h)
{
    const char *x = s ? strchr(s, 'x') : NULL;
    if (!x || x == s)
        return 0;
    char buf[32];
    size_t n = (size_t)(x - s);
    if (n >= sizeof buf)
        return 0;
    memcpy(buf, s, n);
    buf[n] = '\0';
    long long a, b;
    if (!obs_parse_int(buf, 1, max, &a) || !obs_parse_int(x + 1, 1, max, &b))
        return 0;
    *w = (int)a;
    *h = (int)b;
    return 1;
}
