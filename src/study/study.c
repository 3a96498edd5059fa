/* study.c: the generic study machinery (study.h). */
#include "study.h"
#include "../io/io.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ================================================================================================
 * A growable text buffer (CSV, JSON and SVG are built in memory, then written atomically)
 * ============================================================================================== */

typedef struct sbuf {
    char *p;
    size_t n, cap;
    int failed;
} sbuf;

static void sb_printf(sbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void sb_printf(sbuf *b, const char *fmt, ...)
{
    if (b->failed)
        return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        size_t room = b->cap - b->n;
        int k = vsnprintf(b->p ? b->p + b->n : NULL, b->p ? room : 0, fmt, ap);
        va_end(ap);
        if (k < 0) {
            b->failed = 1;
            return;
        }
        if (b->p && (size_t)k < room) {
            b->n += (size_t)k;
            return;
        }
        size_t cap = b->cap ? b->cap * 2 : 4096;
        while (cap < b->n + (size_t)k + 1)
            cap *= 2;
        char *q = (char *)realloc(b->p, cap);
        if (!q) {
            b->failed = 1;
            return;
        }
        b->p = q;
        b->cap = cap;
    }
}

static obs_status sb_write(obs_context *ctx, sbuf *b, const char *path)
{
    obs_status st;
    if (b->failed)
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory while formatting", path);
    else
        st = io_write_file_atomic(ctx, path, b->p ? b->p : "", b->n);
    free(b->p);
    memset(b, 0, sizeof *b);
    return st;
}

static char *dup_str(const char *s)
{
    size_t n = strlen(s ? s : "");
    char *d = (char *)malloc(n + 1);
    if (d)
        memcpy(d, s ? s : "", n + 1);
    return d;
}

/* ================================================================================================
 * The table
 * ============================================================================================== */

obs_status study_table_init(obs_context *ctx, study_table *t, const char *const *names, int columns, int key_columns)
{
    if (!t)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study table: NULL");
    memset(t, 0, sizeof *t);
    if (!names || columns < 1 || columns > STUDY_MAX_COLUMNS || key_columns < 1 || key_columns > columns)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study table: %d columns (key %d): need 1..%d", columns,
                         key_columns, STUDY_MAX_COLUMNS);
    for (int i = 0; i < columns; i++) {
        if (!names[i] || !names[i][0] || strpbrk(names[i], ",\"\n\r"))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study table: column %d has an unusable name", i);
        for (int k = 0; k < i; k++)
            if (!strcmp(names[k], names[i]))
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study table: column %s twice", names[i]);
    }
    for (int i = 0; i < columns; i++) {
        t->names[i] = dup_str(names[i]);
        if (!t->names[i]) {
            study_table_free(t);
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study table: out of memory");
        }
    }
    t->columns = columns;
    t->key_columns = key_columns;
    return OBS_STATUS_OK;
}

void study_table_free(study_table *t)
{
    if (!t)
        return;
    for (int i = 0; i < t->columns; i++)
        free(t->names[i]);
    for (int64_t i = 0; i < t->rows * t->columns; i++)
        free(t->cells[i]);
    free(t->cells);
    memset(t, 0, sizeof *t);
}

int study_table_column(const study_table *t, const char *name)
{
    for (int i = 0; t && name && i < t->columns; i++)
        if (!strcmp(t->names[i], name))
            return i;
    return -1;
}

int64_t study_table_find(const study_table *t, const char *const *key)
{
    for (int64_t r = 0; t && key && r < t->rows; r++) {
        int k = 0;
        while (k < t->key_columns && !strcmp(t->cells[r * t->columns + k], key[k] ? key[k] : ""))
            k++;
        if (k == t->key_columns)
            return r;
    }
    return -1;
}

obs_status study_table_append(obs_context *ctx, study_table *t, const char *const *values)
{
    if (!t || !values || t->columns < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study table: NULL or uninitialised");
    if (t->rows >= STUDY_MAX_ROWS)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "study table: more than %d rows", STUDY_MAX_ROWS);
    if (t->rows == t->capacity) {
        int64_t cap = t->capacity ? 2 * t->capacity : 64;
        char **c = (char **)realloc(t->cells, sizeof(char *) * (size_t)(cap * t->columns));
        if (!c)
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study table: out of memory");
        t->cells = c;
        t->capacity = cap;
    }
    char **row = t->cells + t->rows * t->columns;
    for (int i = 0; i < t->columns; i++) {
        row[i] = dup_str(values[i]);
        if (!row[i]) {
            for (int k = 0; k < i; k++)
                free(row[k]);
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study table: out of memory");
        }
    }
    t->rows++;
    return OBS_STATUS_OK;
}

obs_status study_table_set(obs_context *ctx, study_table *t, int64_t row, int column, const char *value)
{
    if (!t || row < 0 || row >= t->rows || column < 0 || column >= t->columns)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study table: cell (%lld, %d) out of range", (long long)row,
                         column);
    char *c = dup_str(value);
    if (!c)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study table: out of memory");
    free(t->cells[row * t->columns + column]);
    t->cells[row * t->columns + column] = c;
    return OBS_STATUS_OK;
}

const char *study_table_get(const study_table *t, int64_t row, int column)
{
    if (!t || row < 0 || row >= t->rows || column < 0 || column >= t->columns)
        return "";
    return t->cells[row * t->columns + column];
}

double study_table_num(const study_table *t, int64_t row, int column)
{
    const char *s = study_table_get(t, row, column);
    char *end;
    if (!s[0])
        return NAN;
    double v = strtod(s, &end);
    return *end == '\0' ? v : NAN;
}

static void csv_cell(sbuf *b, const char *s)
{
    if (!strpbrk(s, ",\"\n\r")) {
        sb_printf(b, "%s", s);
        return;
    }
    sb_printf(b, "\"");
    for (const char *p = s; *p; p++)
        sb_printf(b, *p == '"' ? "\"\"" : "%c", *p);
    sb_printf(b, "\"");
}

obs_status study_table_write_csv(obs_context *ctx, const study_table *t, const char *path)
{
    sbuf b = {0};
    for (int i = 0; i < t->columns; i++) {
        csv_cell(&b, t->names[i]);
        sb_printf(&b, i + 1 < t->columns ? "," : "\n");
    }
    for (int64_t r = 0; r < t->rows; r++)
        for (int i = 0; i < t->columns; i++) {
            csv_cell(&b, t->cells[r * t->columns + i]);
            sb_printf(&b, i + 1 < t->columns ? "," : "\n");
        }
    return sb_write(ctx, &b, path);
}

/* Parse one CSV record starting at *p (RFC 4180); cells are written NUL-terminated into out
 * (which must hold the record's length + 1); starts[] receives each cell. Returns the number of
 * cells, or -1 for a malformed record (an unterminated quote, a quote inside a bare cell). */
static int csv_record(const char **p, char *out, char **starts, int max_cells)
{
    const char *s = *p;
    int n = 0;
    for (;;) {
        if (n == max_cells)
            return -1;
        starts[n++] = out;
        if (*s == '"') {
            s++;
            for (;;) {
                if (*s == '\0')
                    return -1;
                if (*s == '"') {
                    if (s[1] == '"') {
                        *out++ = '"';
                        s += 2;
                        continue;
                    }
                    s++;
                    break;
                }
                *out++ = *s++;
            }
        } else {
            while (*s && *s != ',' && *s != '\n' && *s != '\r') {
                if (*s == '"')
                    return -1;
                *out++ = *s++;
            }
        }
        *out++ = '\0';
        if (*s == ',') {
            s++;
            continue;
        }
        if (*s == '\r')
            s++;
        if (*s == '\n')
            s++;
        else if (*s != '\0')
            return -1;
        *p = s;
        return n;
    }
}

obs_status study_table_read_csv(obs_context *ctx, study_table *t, const char *path, int64_t *rows_read)
{
    if (rows_read)
        *rows_read = 0;
    if (access(path, F_OK) != 0)
        return OBS_STATUS_OK;
    char *text = NULL;
    size_t len = 0;
    obs_status st = io_read_file(ctx, path, (size_t)1 << 30, &text, &len);
    if (st != OBS_STATUS_OK)
        return st;
    char *buf = (char *)malloc(len + 1);
    if (!buf) {
        free(text);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", path);
    }
    char *cells[STUDY_MAX_COLUMNS + 1];
    const char *p = text;
    int line = 1;
    int n = csv_record(&p, buf, cells, STUDY_MAX_COLUMNS + 1);
    /* a table written before columns were appended to this study's list is read with the new
     * trailing cells empty: its header must be a prefix of ours, from the key columns on */
    const int file_columns = n;
    if (n < t->key_columns || n > t->columns)
        st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: line 1: %d columns, expected %d (another study's table?)",
                       path, n, t->columns);
    for (int i = 0; st == OBS_STATUS_OK && i < n; i++)
        if (strcmp(cells[i], t->names[i]) != 0)
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: line 1: column %d is '%s', expected '%s'", path, i + 1,
                           cells[i], t->names[i]);
    while (st == OBS_STATUS_OK && *p) {
        line++;
        n = csv_record(&p, buf, cells, STUDY_MAX_COLUMNS + 1);
        if (n != file_columns) {
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: line %d: %s", path, line,
                           n < 0 ? "malformed record" : "wrong number of cells");
            break;
        }
        for (int i = n; i < t->columns; i++)
            cells[i] = (char *)"";
        st = study_table_append(ctx, t, (const char *const *)cells);
        if (st == OBS_STATUS_OK && rows_read)
            (*rows_read)++;
    }
    free(buf);
    free(text);
    return st;
}

static void json_string(sbuf *b, const char *s)
{
    sb_printf(b, "\"");
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p == '"' || *p == '\\')
            sb_printf(b, "\\%c", *p);
        else if (*p < 0x20)
            sb_printf(b, "\\u%04x", *p);
        else
            sb_printf(b, "%c", *p);
    }
    sb_printf(b, "\"");
}

obs_status study_table_write_json(obs_context *ctx, const study_table *t, const char *path)
{
    sbuf b = {0};
    sb_printf(&b, "{\n  \"columns\": [");
    for (int i = 0; i < t->columns; i++) {
        json_string(&b, t->names[i]);
        sb_printf(&b, i + 1 < t->columns ? ", " : "],\n  \"key_columns\": %d,\n  \"rows\": [", t->key_columns);
    }
    for (int64_t r = 0; r < t->rows; r++) {
        sb_printf(&b, r ? ",\n    {" : "\n    {");
        for (int i = 0; i < t->columns; i++) {
            const char *s = t->cells[r * t->columns + i];
            char *end;
            double v = s[0] ? strtod(s, &end) : NAN;
            json_string(&b, t->names[i]);
            sb_printf(&b, ": ");
            if (s[0] && *end == '\0' && isfinite(v))
                sb_printf(&b, "%s", s);
            else
                json_string(&b, s);
            if (i + 1 < t->columns)
                sb_printf(&b, ", ");
        }
        sb_printf(&b, "}");
    }
    sb_printf(&b, "\n  ]\n}\n");
    return sb_write(ctx, &b, path);
}

/* ================================================================================================
 * Statistics and the Pareto front
 * ============================================================================================== */

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

study_stats study_stats_of(double *v, int n)
{
    study_stats s = {NAN, NAN, NAN, n};
    if (n <= 0)
        return s;
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    s.min = v[0];
    s.max = v[n - 1];
    s.median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    return s;
}

typedef struct pidx {
    double c, e;
    int i;
} pidx;

static int cmp_pidx(const void *a, const void *b)
{
    const pidx *x = (const pidx *)a, *y = (const pidx *)b;
    if (x->c != y->c)
        return (x->c > y->c) - (x->c < y->c);
    if (x->e != y->e)
        return (x->e > y->e) - (x->e < y->e);
    return x->i - y->i;
}

int study_pareto_front(const double *cost, const double *err, int n, unsigned char *on_front)
{
    if (n <= 0)
        return 0;
    pidx *v = (pidx *)malloc(sizeof(pidx) * (size_t)n);
    int m = 0, count = 0;
    for (int i = 0; i < n; i++) {
        on_front[i] = 0;
        if (v && !isnan(cost[i]) && !isnan(err[i]))
            v[m++] = (pidx){cost[i], err[i], i};
    }
    if (!v)
        return 0;
    /* Sweep by increasing cost (ties: increasing error): a point is on the front when its error
     * is strictly below every error seen at a smaller-or-equal cost. Exact duplicates are both
     * kept (neither dominates the other). */
    qsort(v, (size_t)m, sizeof *v, cmp_pidx);
    double best = INFINITY;
    for (int k = 0; k < m; k++) {
        if (v[k].e < best || (k > 0 && v[k].c == v[k - 1].c && v[k].e == v[k - 1].e && on_front[v[k - 1].i])) {
            on_front[v[k].i] = 1;
            count++;
            best = v[k].e < best ? v[k].e : best;
        }
    }
    free(v);
    return count;
}

/* ================================================================================================
 * Progress
 * ============================================================================================== */

void study_progress_begin(study_progress *p, FILE *out, int64_t total)
{
    memset(p, 0, sizeof *p);
    p->out = out;
    p->total = total;
    p->t0 = obs_time_now();
    p->last_print = -1.0;
    p->is_tty = out && isatty(fileno(out));
}

void study_progress_step(study_progress *p, int measured, const char *label)
{
    p->done++;
    if (!measured)
        p->skipped++;
    if (!p->out)
        return;
    const double now = obs_time_now();
    const int last = p->done >= p->total;
    if (p->is_tty) {
        if (!last && now - p->last_print < 0.2)
            return;
    } else {
        int64_t step = p->total / 20 > 0 ? p->total / 20 : 1;
        if (!last && p->done % step != 0)
            return;
    }
    p->last_print = now;
    const double frac = p->total > 0 ? (double)p->done / (double)p->total : 1.0;
    const int64_t measured_n = p->done - p->skipped;
    const double per = measured_n > 0 ? (now - p->t0) / (double)measured_n : 0.0;
    const double eta = per * (double)(p->total - p->done);
    char bar[31];
    int fill = (int)(frac * 30.0);
    for (int i = 0; i < 30; i++)
        bar[i] = i < fill ? '#' : '.';
    bar[30] = '\0';
    fprintf(p->out, "%s[%s] %5.1f%% %lld/%lld (%lld resumed) ETA %.0f s  %-40.40s%s", p->is_tty ? "\r" : "", bar,
            100.0 * frac, (long long)p->done, (long long)p->total, (long long)p->skipped, eta, label ? label : "",
            p->is_tty ? "" : "\n");
    fflush(p->out);
}

void study_progress_end(study_progress *p)
{
    if (p->out && p->is_tty)
        fprintf(p->out, "\n");
}

/* ================================================================================================
 * SVG scatter plots
 * ============================================================================================== */

/* Colour-blind-safe palette (Okabe and Ito 2008), then greys; markers cycle too. */
static const char *const palette[16] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9",
                                        "#F0E442", "#000000", "#7F7F7F", "#8C564B", "#1F77B4", "#FF7F0E",
                                        "#2CA02C", "#D62728", "#9467BD", "#17BECF"};

static void svg_marker(sbuf *b, int kind, double x, double y, const char *colour)
{
    switch (kind % 4) {
    case 0:
        sb_printf(b, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"3.5\" fill=\"%s\" fill-opacity=\"0.75\"/>\n", x, y, colour);
        break;
    case 1:
        sb_printf(b, "<rect x=\"%.1f\" y=\"%.1f\" width=\"6.5\" height=\"6.5\" fill=\"%s\" fill-opacity=\"0.75\"/>\n",
                  x - 3.25, y - 3.25, colour);
        break;
    case 2:
        sb_printf(b, "<path d=\"M%.1f %.1fL%.1f %.1fL%.1f %.1fZ\" fill=\"%s\" fill-opacity=\"0.75\"/>\n", x, y - 4.2,
                  x + 4.0, y + 3.2, x - 4.0, y + 3.2, colour);
        break;
    default:
        sb_printf(b, "<path d=\"M%.1f %.1fL%.1f %.1fL%.1f %.1fL%.1f %.1fZ\" fill=\"%s\" fill-opacity=\"0.75\"/>\n", x,
                  y - 4.5, x + 4.5, y, x, y + 4.5, x - 4.5, y, colour);
    }
}

typedef struct axis {
    double lo, hi;
    int log;
} axis;

static double ax_t(const axis *a, double v)
{
    return a->log ? (log10(v) - a->lo) / (a->hi - a->lo) : (v - a->lo) / (a->hi - a->lo);
}

static void axis_fit(axis *a, double mn, double mx, int log_scale)
{
    a->log = log_scale;
    if (log_scale) {
        a->lo = floor(log10(mn));
        a->hi = ceil(log10(mx));
        if (a->hi <= a->lo)
            a->hi = a->lo + 1.0;
    } else {
        double span = mx - mn;
        if (!(span > 0.0))
            span = fabs(mx) > 0.0 ? fabs(mx) : 1.0;
        double step = pow(10.0, floor(log10(span / 5.0)));
        if (span / step > 10.0)
            step *= 2.0;
        a->lo = floor(mn / step) * step;
        a->hi = ceil(mx / step) * step;
        if (a->hi <= a->lo)
            a->hi = a->lo + step;
    }
}

static void svg_ticks(sbuf *b, const axis *a, int horizontal, double x0, double y0, double len)
{
    if (a->log) {
        for (double e = a->lo; e <= a->hi + 1e-9; e += 1.0)
            for (int m = 1; m <= 9; m++) {
                double v = pow(10.0, e) * m;
                double t = ax_t(a, v);
                if (t < -1e-9 || t > 1.0 + 1e-9)
                    continue;
                double p = horizontal ? x0 + t * len : y0 - t * len;
                int major = m == 1;
                if (horizontal) {
                    sb_printf(b, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#000\"/>\n", p, y0, p,
                              y0 + (major ? 6 : 3));
                    if (major || m == 2 || m == 5)
                        sb_printf(b, "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\" font-size=\"12\">%g</text>\n", p,
                                  y0 + 20, v);
                } else {
                    sb_printf(b, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#000\"/>\n", x0, p,
                              x0 - (major ? 6 : 3), p);
                    if (major || m == 2 || m == 5)
                        sb_printf(b, "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\" font-size=\"12\">%g</text>\n",
                                  x0 - 9, p + 4, v);
                }
            }
    } else {
        double span = a->hi - a->lo, step = pow(10.0, floor(log10(span / 5.0)));
        if (span / step > 10.0)
            step *= 2.0;
        for (double v = a->lo; v <= a->hi + 1e-9 * span; v += step) {
            double t = ax_t(a, v), p = horizontal ? x0 + t * len : y0 - t * len;
            if (horizontal) {
                sb_printf(b, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#000\"/>\n", p, y0, p, y0 + 6);
                sb_printf(b, "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\" font-size=\"12\">%g</text>\n", p, y0 + 20,
                          fabs(v) < 1e-12 * span ? 0.0 : v);
            } else {
                sb_printf(b, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#000\"/>\n", x0, p, x0 - 6, p);
                sb_printf(b, "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\" font-size=\"12\">%g</text>\n", x0 - 9, p + 4,
                          fabs(v) < 1e-12 * span ? 0.0 : v);
            }
        }
    }
}

static void svg_text(sbuf *b, const char *s)
{
    for (const char *p = s ? s : ""; *p; p++) {
        if (*p == '<')
            sb_printf(b, "&lt;");
        else if (*p == '>')
            sb_printf(b, "&gt;");
        else if (*p == '&')
            sb_printf(b, "&amp;");
        else
            sb_printf(b, "%c", *p);
    }
}

static int usable(const study_plot *pl, double x, double y)
{
    return isfinite(x) && isfinite(y) && (!pl->log_x || x > 0.0) && (!pl->log_y || y > 0.0);
}

obs_status study_svg_scatter(obs_context *ctx, const char *path, const study_plot *plot, const study_series *series,
                             int series_count)
{
    if (!plot || !series || series_count < 1 || series_count > 16)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: a plot needs 1..16 series", path ? path : "plot");
    const int W = plot->width > 0 ? plot->width : 900, H = plot->height > 0 ? plot->height : 560;
    const double L = 80, R = 210, T = 40, B = 60; /* margins: the legend sits at the right */
    const double pw = W - L - R, ph = H - T - B;
    double xmn = INFINITY, xmx = -INFINITY, ymn = INFINITY, ymx = -INFINITY;
    int64_t total = 0, left_out = 0;
    for (int s = 0; s < series_count; s++)
        for (int i = 0; i < series[s].n; i++) {
            double x = series[s].x[i], y = series[s].y[i];
            if (!usable(plot, x, y)) {
                left_out++;
                continue;
            }
            total++;
            xmn = x < xmn ? x : xmn;
            xmx = x > xmx ? x : xmx;
            ymn = y < ymn ? y : ymn;
            ymx = y > ymx ? y : ymx;
        }
    if (total == 0) {
        xmn = ymn = plot->log_x ? 1.0 : 0.0;
        xmx = ymx = 10.0;
    }
    axis ax, ay;
    axis_fit(&ax, xmn, xmx, plot->log_x);
    axis_fit(&ay, plot->log_y ? ymn : (ymn > 0.0 ? 0.0 : ymn), ymx, plot->log_y);
    sbuf b = {0};
    sb_printf(&b,
              "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" "
              "height=\"%d\" viewBox=\"0 0 %d %d\" font-family=\"DejaVu Sans, Arial, sans-serif\">\n"
              "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n",
              W, H, W, H);
    sb_printf(&b, "<text x=\"%.1f\" y=\"24\" text-anchor=\"middle\" font-size=\"16\" font-weight=\"bold\">", L + pw / 2);
    svg_text(&b, plot->title);
    sb_printf(&b, "</text>\n<rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\" fill=\"none\" stroke=\"#000\"/>\n",
              L, T, pw, ph);
    svg_ticks(&b, &ax, 1, L, T + ph, pw);
    svg_ticks(&b, &ay, 0, L, T + ph, ph);
    sb_printf(&b, "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\" font-size=\"14\">", L + pw / 2, (double)H - 14);
    svg_text(&b, plot->x_label);
    sb_printf(&b, "</text>\n<text x=\"18\" y=\"%.1f\" text-anchor=\"middle\" font-size=\"14\" transform=\"rotate(-90 18 %.1f)\">",
              T + ph / 2, T + ph / 2);
    svg_text(&b, plot->y_label);
    sb_printf(&b, "</text>\n");
    /* points */
    for (int s = 0; s < series_count; s++)
        for (int i = 0; i < series[s].n; i++) {
            double x = series[s].x[i], y = series[s].y[i];
            if (!usable(plot, x, y))
                continue;
            svg_marker(&b, s, L + ax_t(&ax, x) * pw, T + ph - ax_t(&ay, y) * ph, palette[s]);
        }
    /* the Pareto front of all series together, as a staircase */
    int front_n = 0;
    if (plot->pareto && total > 0) {
        double *xs = (double *)malloc(sizeof(double) * (size_t)total), *ys = (double *)malloc(sizeof(double) * (size_t)total);
        unsigned char *on = (unsigned char *)malloc((size_t)total);
        if (xs && ys && on) {
            int64_t k = 0;
            for (int s = 0; s < series_count; s++)
                for (int i = 0; i < series[s].n; i++)
                    if (usable(plot, series[s].x[i], series[s].y[i])) {
                        xs[k] = series[s].x[i];
                        ys[k] = series[s].y[i];
                        k++;
                    }
            front_n = study_pareto_front(xs, ys, (int)total, on);
            /* order the front by cost */
            pidx *f = (pidx *)malloc(sizeof(pidx) * (size_t)(front_n > 0 ? front_n : 1));
            if (f) {
                int m = 0;
                for (int64_t i = 0; i < total; i++)
                    if (on[i])
                        f[m++] = (pidx){xs[i], ys[i], (int)i};
                qsort(f, (size_t)m, sizeof *f, cmp_pidx);
                sb_printf(&b, "<path d=\"");
                for (int i = 0; i < m; i++) {
                    double px = L + ax_t(&ax, f[i].c) * pw, py = T + ph - ax_t(&ay, f[i].e) * ph;
                    if (i == 0)
                        sb_printf(&b, "M%.1f %.1f", px, py);
                    else
                        sb_printf(&b, "H%.1fV%.1f", px, py);
                }
                sb_printf(&b, "\" fill=\"none\" stroke=\"#000\" stroke-width=\"1.5\" stroke-dasharray=\"5 3\"/>\n");
                for (int i = 0; i < m; i++)
                    sb_printf(&b, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"6\" fill=\"none\" stroke=\"#000\"/>\n",
                              L + ax_t(&ax, f[i].c) * pw, T + ph - ax_t(&ay, f[i].e) * ph);
                free(f);
            }
        }
        free(xs);
        free(ys);
        free(on);
    }
    /* legend */
    double ly = T + 10;
    for (int s = 0; s < series_count; s++, ly += 20) {
        svg_marker(&b, s, L + pw + 22, ly, palette[s]);
        sb_printf(&b, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"13\">", L + pw + 34, ly + 4);
        svg_text(&b, series[s].name);
        sb_printf(&b, "</text>\n");
    }
    if (plot->pareto) {
        sb_printf(&b, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#000\" stroke-width=\"1.5\" "
                      "stroke-dasharray=\"5 3\"/>\n<text x=\"%.1f\" y=\"%.1f\" font-size=\"13\">Pareto front (%d)</text>\n",
                  L + pw + 12, ly, L + pw + 30, ly, L + pw + 34, ly + 4, front_n);
        ly += 20;
    }
    if (left_out)
        sb_printf(&b, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"11\" fill=\"#555\">%lld points not drawable</text>\n",
                  L + pw + 12, ly + 4, (long long)left_out);
    sb_printf(&b, "</svg>\n");
    return sb_write(ctx, &b, path);
}

/* ================================================================================================
 * Axes
 * ============================================================================================== */

void study_axis_free(study_axis *a)
{
    if (!a)
        return;
    free(a->buf);
    memset(a, 0, sizeof *a);
}

obs_status study_axis_parse(obs_context *ctx, const char *name, const char *list, study_axis *out)
{
    memset(out, 0, sizeof *out);
    if (!list || !*list)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study: the %s list is empty", name);
    out->buf = dup_str(list);
    if (!out->buf)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study: out of memory");
    char *save = NULL;
    for (char *tok = strtok_r(out->buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        if (out->n == STUDY_AXIS_MAX) {
            study_axis_free(out);
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study: the %s list has more than %d values", name,
                             STUDY_AXIS_MAX);
        }
        out->v[out->n++] = tok;
    }
    if (out->n == 0) {
        study_axis_free(out);
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study: the %s list is empty", name);
    }
    return OBS_STATUS_OK;
}

/* ================================================================================================
 * Scores against a noisy ground truth
 * ============================================================================================== */

double study_replicate_noise_rms(const obs_image_f32 *g0, const obs_image_f32 *g1, const obs_image_f32 *mask)
{
    /* [L'Ecuyer & Lemieux 2002, section 3]: E[(g0 - g1)^2] = 2 Var(g0) for two independent
     * randomisations of the same estimator */
    double s2 = 0.0;
    int64_t n = 0;
    for (int y = 0; y < g0->height; y++)
        for (int x = 0; x < g0->width; x++)
            if (!mask || obs_image_f32_row(mask, y)[x] != 0.0f) {
                double d = (double)obs_image_f32_row(g0, y)[x] - obs_image_f32_row(g1, y)[x];
                s2 += d * d;
                n++;
            }
    return n ? sqrt(s2 / (2.0 * (double)n)) : 0.0;
}

double study_noise_corrected(double rmse, double noise_rms)
{
    double d = rmse * rmse - noise_rms * noise_rms;
    return d > 0.0 ? sqrt(d) : 0.0;
}

study_score study_score_of(double raw_mse, double cal_mse, double ref_var, double noise_rms, int fit_at_bound)
{
    study_score s;
    const double nv = noise_rms * noise_rms;
    s.rmse = sqrt(raw_mse);
    s.rmse_nc = study_noise_corrected(s.rmse, noise_rms);
    s.cal_rmse = sqrt(cal_mse);
    s.cal_rmse_nc = study_noise_corrected(s.cal_rmse, noise_rms);
    /* [Murphy88]: the best constant image has MSE Var(truth); skill 1 - MSE / Var (met_skill_of) */
    const met_skill k = met_skill_of(cal_mse, ref_var, 0.0), knc = met_skill_of(cal_mse, ref_var, nv);
    s.baseline_rmse = k.baseline_rmse;
    s.baseline_rmse_nc = knc.baseline_rmse;
    s.cal_skill = k.skill;
    s.cal_skill_nc = knc.skill;
    s.fit_at_bound = fit_at_bound;
    return s;
}

int study_score_informative(double cal_skill)
{
    return cal_skill > STUDY_SKILL_MIN;
}

/* ================================================================================================
 * Shards, hashes, locks and manifests (docs/scale.md)
 * ============================================================================================== */

int study_shard_parse(const char *s, int *k, int *n)
{
    if (!s)
        return 0;
    char *end;
    errno = 0;
    long a = strtol(s, &end, 10);
    if (end == s || *end != '/' || errno)
        return 0;
    const char *t = end + 1;
    long b = strtol(t, &end, 10);
    if (end == t || *end || errno || b < 1 || b > 1000000 || a < 1 || a > b)
        return 0;
    *k = (int)a;
    *n = (int)b;
    return 1;
}

int study_shard_from_env(int *k, int *n)
{
    const char *id = getenv("SLURM_ARRAY_TASK_ID"), *count = getenv("SLURM_ARRAY_TASK_COUNT");
    const char *mn = getenv("SLURM_ARRAY_TASK_MIN");
    if (!id || !count)
        return 0;
    long long i, c, m = 0;
    if (!obs_parse_int(id, 0, 1 << 30, &i) || !obs_parse_int(count, 1, 1000000, &c) ||
        (mn && !obs_parse_int(mn, 0, 1 << 30, &m)))
        return 0;
    if (i - m + 1 < 1 || i - m + 1 > c)
        return 0;
    *k = (int)(i - m + 1);
    *n = (int)c;
    return 1;
}

uint64_t study_hash_bytes(uint64_t h, const void *data, size_t len)
{
    const unsigned char *p = (const unsigned char *)data;
    for (size_t i = 0; i < len; i++)
        h = (h ^ p[i]) * 0x100000001b3ull; /* [FNV] FNV-1a */
    return h;
}

uint64_t study_hash_string(uint64_t h, const char *s) { return study_hash_bytes(h, s, strlen(s) + 1); }

obs_status study_hash_file(obs_context *ctx, uint64_t h, const char *path, uint64_t *out)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot open %s: %s", path, strerror(errno));
    unsigned char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        h = study_hash_bytes(h, buf, n);
    int bad = ferror(f);
    fclose(f);
    if (bad)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot read %s", path);
    *out = h;
    return OBS_STATUS_OK;
}

#include <fcntl.h>
#include <signal.h>
#include <time.h>

obs_status study_lock_acquire(obs_context *ctx, const char *path, double timeout_s, study_lock *lock, int *waited)
{
    memset(lock, 0, sizeof *lock);
    if (waited)
        *waited = 0;
    if (strlen(path) >= sizeof lock->path)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "lock path too long: %s", path);
    snprintf(lock->path, sizeof lock->path, "%s", path);
    char host[256] = "";
    gethostname(host, sizeof host - 1);
    const double t0 = obs_time_now();
    for (unsigned tries = 0;; tries++) {
        int fd = open(path, O_WRONLY | O_CREAT | O_EXCL, 0644);
        if (fd >= 0) {
            char text[320];
            int len = snprintf(text, sizeof text, "%s %ld\n", host, (long)getpid());
            ssize_t w = write(fd, text, (size_t)len);
            close(fd);
            if (w != len) {
                unlink(path);
                return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write the lock %s", path);
            }
            lock->held = 1;
            return OBS_STATUS_OK;
        }
        if (errno != EEXIST)
            return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot create the lock %s: %s", path, strerror(errno));
        if (waited)
            *waited = 1;
        /* a holder on this host that is gone left a stale lock */
        FILE *f = fopen(path, "r");
        if (f) {
            char owner[256] = "";
            long pid = 0;
            if (fscanf(f, "%255s %ld", owner, &pid) == 2 && !strcmp(owner, host) && pid > 0 &&
                kill((pid_t)pid, 0) != 0 && errno == ESRCH)
                unlink(path);
            fclose(f);
        }
        if (obs_time_now() - t0 > timeout_s)
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "waited %.0f s for the lock %s (remove it if its holder is gone)",
                             timeout_s, path);
        struct timespec ts = {0, (long)(50 + (tries % 8) * 7) * 1000000L};
        nanosleep(&ts, NULL);
    }
}

void study_lock_release(study_lock *lock)
{
    if (!lock || !lock->held)
        return;
    unlink(lock->path);
    lock->held = 0;
}

obs_status study_manifest_write(obs_context *ctx, const char *dir, const study_manifest *m)
{
    io_json j;
    io_json_init(&j);
    io_json_begin_object(&j, NULL);
    io_json_string(&j, "generator", "obscura");
    io_json_string(&j, "study", m->study);
    io_json_string(&j, "version", m->version);
    io_json_string(&j, "config_hash", m->config_hash);
    io_json_string(&j, "config", m->config);
    io_json_int(&j, "shard", m->shard);
    io_json_int(&j, "shards", m->shards);
    io_json_end_object(&j);
    char path[4200];
    snprintf(path, sizeof path, "%s/manifest.json", dir);
    obs_status st = io_json_write(ctx, &j, path);
    io_json_free(&j);
    return st;
}

/* The string value of "key": "..." in text (our own writer's output: no escapes in these values). */
static int manifest_string(const char *text, const char *key, char *out, size_t size)
{
    char pat[64];
    snprintf(pat, sizeof pat, "\"%s\": \"", key);
    const char *p = strstr(text, pat);
    if (!p)
        return 0;
    p += strlen(pat);
    const char *e = strchr(p, '"');
    if (!e || (size_t)(e - p) >= size)
        return 0;
    memcpy(out, p, (size_t)(e - p));
    out[e - p] = 0;
    return 1;
}

static int manifest_int(const char *text, const char *key, int *out)
{
    char pat[64];
    snprintf(pat, sizeof pat, "\"%s\": ", key);
    const char *p = strstr(text, pat);
    if (!p)
        return 0;
    *out = atoi(p + strlen(pat));
    return 1;
}

obs_status study_manifest_read(obs_context *ctx, const char *dir, study_manifest *m)
{
    memset(m, 0, sizeof *m);
    char path[4200];
    snprintf(path, sizeof path, "%s/manifest.json", dir);
    FILE *f = fopen(path, "rb");
    if (!f)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "%s: no manifest (%s): not a study's output directory", dir,
                         strerror(errno));
    char *text = (char *)malloc(65536);
    size_t n = text ? fread(text, 1, 65535, f) : 0;
    fclose(f);
    if (!text)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory");
    text[n] = 0;
    int ok = manifest_string(text, "study", m->study, sizeof m->study) &&
             manifest_string(text, "version", m->version, sizeof m->version) &&
             manifest_string(text, "config_hash", m->config_hash, sizeof m->config_hash) &&
             manifest_string(text, "config", m->config, sizeof m->config) && manifest_int(text, "shard", &m->shard) &&
             manifest_int(text, "shards", &m->shards);
    free(text);
    if (!ok || m->shard < 1 || m->shard > m->shards)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s is not a study manifest", path);
    return OBS_STATUS_OK;
}
