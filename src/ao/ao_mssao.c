/* ao_mssao.c: Multi-resolution screen-space ambient occlusion [Hoang12] (Hoang & Low, VRCAI 2010;
 * The Visual Computer 28(3):289-304, 2012), exact to Hoang's original code: main.cpp (the host:
 * LEVEL_COUNT, dMax, rMax, the per-level r, the Poisson disk), shaders/downsample.frag (the median
 * rule), aoFirst.frag (coarsest level), ao.frag (middle levels), aoLast.frag (finest level and the
 * combine) and blur.frag (the per-level blur). ../shared/reference/ao.md 1.4, verification.md 3,
 * docs/ao/mssao.md.
 *
 * Everything here works in the shader's pixel grid: GL window coordinates, y UP (row 0 of every
 * level plane is the BOTTOM row). gl_FragCoord of texel (i, j) is (i + 0.5, j + 0.5); the shaders
 * read GL_TEXTURE_RECTANGLE textures with NEAREST filtering and CLAMP_TO_EDGE, i.e. the texel
 * floor(coord) clamped to the texture. Arithmetic is float32 in the shaders' operation order (the
 * build uses -ffp-contract=off). Remaining differences from a GPU (pow as repeated squaring,
 * normalize as v * (1 / sqrt), the zero-length tap, the all-zero upsampling weights, denormals)
 * are listed in docs/ao/mssao.md, "Differences from the reference".
 */
#include "ao.h"
#include "ao_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* [Hoang12] main.cpp SetupAOPrograms: "GLfloat poissonDisk[] = { ... }" (16 (x, y) pairs). */
const float ao_mssao_poisson_disk[2 * AO_MSSAO_POISSON_COUNT] = {
    -0.6116678f, 0.04548655f, -0.26605980f, -0.6445347f, -0.4798763f, 0.78557830f, -0.19723210f, -0.1348270f,
    -0.7351842f, -0.58396650f, -0.35353550f, 0.3798947f, 0.1423388f, 0.39469180f, -0.01819171f, 0.8008046f,
    0.3313283f, -0.04656135f, 0.58593510f, 0.4467109f, 0.8577477f, 0.11188750f, 0.03690137f, -0.9906120f,
    0.4768903f, -0.84335800f, 0.13749180f, -0.4746810f, 0.7814927f, -0.48938420f, 0.38269190f, 0.8695006f,
};

/* ================================================================================================
 * Parameters, presets, constants
 * ============================================================================================== */

ao_mssao_params ao_mssao_params_default(void)
{
    ao_mssao_params p;
    memset(&p, 0, sizeof p);
    p.d_max = AO_MSSAO_DEFAULT_D_MAX;
    p.r_max = AO_MSSAO_DEFAULT_R_MAX;
    p.levels = AO_MSSAO_DEFAULT_LEVELS;
    p.d_threshold = AO_MSSAO_DEFAULT_D_THRESHOLD;
    p.samples = AO_MSSAO_DEFAULT_SAMPLES;
    p.downsample = AO_MSSAO_DOWNSAMPLE_HOANG;
    p.normals = AO_MSSAO_NORMALS_AUTO;
    p.level_blur = 1;   /* main.cpp RenderAO: "if (size < RESOLUTION) Blur(size, index)" */
    p.blur = 0;         /* Hoang has no final spatial blur (only a temporal filter, not reproduced) */
    return p;
}

static const char *const preset_names[] = {"default", "hoang", "thesis", "kool", NULL};

const char *const *ao_mssao_preset_names(void) { return preset_names; }

int ao_mssao_params_preset(const char *name, ao_mssao_params *out)
{
    if (!name || !out)
        return 0;
    ao_mssao_params p = ao_mssao_params_default();
    if (!strcmp(name, "default") || !strcmp(name, "hoang")) {
        /* main.cpp as published */
    } else if (!strcmp(name, "thesis")) {
        /* ssao-thesis-2017 Tabla 3: "Multi Scale AO 2 (m) 16 (muestras)"; 5.2: "Blur Multi Scale AO" */
        p.d_max = 2.0f;
        p.samples = 16;
        p.blur = 1;
    } else if (!strcmp(name, "kool")) {
        /* fabmax/kool GbufferDownsamplingPass: bubble sort by depth, dRange < uMedianThresh (1) */
        p.downsample = AO_MSSAO_DOWNSAMPLE_SORTED;
    } else {
        return 0;
    }
    *out = p;
    return 1;
}

obs_status ao_mssao_params_validate(obs_context *ctx, const ao_mssao_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: params is NULL");
    if (!isfinite(p->d_max) || !(p->d_max > 0.0f) || !(p->d_max <= 1e6f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: d_max must be in (0, 1e6] m (got %g)",
                         (double)p->d_max);
    if (!isfinite(p->r_max) || !(p->r_max > 0.0f) || !(p->r_max <= 64.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: r_max must be in (0, 64] pixels (got %g)",
                         (double)p->r_max);
    if (p->levels < 1 || p->levels > AO_MSSAO_MAX_LEVELS)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: levels must be in [1, %d] (got %d)",
                         AO_MSSAO_MAX_LEVELS, p->levels);
    if (!isfinite(p->d_threshold) || !(p->d_threshold >= 0.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: d_threshold must be finite and >= 0 m (got %g)",
                         (double)p->d_threshold);
    if (p->samples < 1 || p->samples > AO_MSSAO_MAX_SAMPLES)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: samples must be in [1, %d] (got %d)",
                         AO_MSSAO_MAX_SAMPLES, p->samples);
    if ((int)p->downsample < 0 || p->downsample >= AO_MSSAO_DOWNSAMPLE_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: downsample must be hoang or sorted (got %d)",
                         (int)p->downsample);
    if ((int)p->normals < 0 || p->normals >= AO_MSSAO_NORMALS_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: normals must be auto or depth (got %d)",
                         (int)p->normals);
    if (p->level_blur != 0 && p->level_blur != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: level_blur must be 0 or 1 (got %d)", p->level_blur);
    if (p->blur != 0 && p->blur != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: blur must be 0 or 1 (got %d)", p->blur);
    return OBS_STATUS_OK;
}

static const char *const downsample_names[] = {"hoang", "sorted", NULL};
static const char *const normals_names[] = {"auto", "depth", NULL};

int ao_mssao_params_to_string(const ao_mssao_params *p, char *buf, size_t size)
{
    const int ds = (int)p->downsample, nm = (int)p->normals;
    return snprintf(buf, size,
                    "d_max=%.9g r_max=%.9g levels=%d d_threshold=%.9g samples=%d downsample=%s normals=%s "
                    "level_blur=%d blur=%d",
                    (double)p->d_max, (double)p->r_max, p->levels, (double)p->d_threshold, p->samples,
                    ds >= 0 && ds < AO_MSSAO_DOWNSAMPLE_COUNT ? downsample_names[ds] : "?",
                    nm >= 0 && nm < AO_MSSAO_NORMALS_COUNT ? normals_names[nm] : "?", p->level_blur, p->blur);
}

void ao_mssao_taps(int n, float *taps)
{
    const float *D = ao_mssao_poisson_disk;
    const int N = AO_MSSAO_POISSON_COUNT;
    if (n < 1)
        return;
    if (n > AO_MSSAO_MAX_SAMPLES)
        n = AO_MSSAO_MAX_SAMPLES;
    const int first = n < N ? n : N;
    for (int k = 0; k < first; k++) {
        const int i = k * N / first; /* floor(k * 16 / n): an even spread over Hoang's order */
        taps[2 * k] = D[2 * i];
        taps[2 * k + 1] = D[2 * i + 1];
    }
    const int extra = n - first;   /* our extension beyond Hoang's 16: the disk rotated by +90 deg */
    for (int k = 0; k < extra; k++) {
        const int i = k * N / extra;
        taps[2 * (N + k)] = -D[2 * i + 1];
        taps[2 * (N + k) + 1] = D[2 * i];
    }
}

ao_mssao_constants ao_mssao_constants_from_params(const ao_mssao_params *p, const ao_input *in)
{
    ao_mssao_constants K;
    memset(&K, 0, sizeof K);
    K.full_width = in->width;
    K.full_height = in->height;
    K.levels = p->levels;
    int w = in->width, h = in->height;
    double scale = 1.0;
    for (int l = 0; l < p->levels; l++) {
        /* Level sizes: ceil halving (main.cpp halves RESOLUTION = 800 exactly; for odd sizes the
         * coarse texel of the last column / row has children outside the finer level, read clamped
         * to its edge as texture2DRect with CLAMP_TO_EDGE does). A 1x1 level stays 1x1. */
        K.level_width[l] = w;
        K.level_height[l] = h;
        /* main.cpp: r = size * dMax / (2 * tan(fov/2)); size / (2 tan(fov/2)) = fy / 2^l */
        K.r[l] = (float)(in->fy * scale * (double)p->d_max);
        w = (w + 1) / 2;
        h = (h + 1) / 2;
        scale *= 0.5;
    }
    K.orthographic = in->projection == OBS_PROJECTION_ORTHOGRAPHIC;
    K.d_max = p->d_max;
    K.d_max2 = p->d_max * p->d_max;  /* ao*.frag: (dMax * dMax), float */
    K.r_max = p->r_max;
    K.d_threshold = p->d_threshold;
    K.samples = p->samples;
    ao_mssao_taps(p->samples, K.taps);
    K.downsample = (int)p->downsample;
    K.level_blur = p->level_blur;
    K.blur = p->blur;
    return K;
}

/* ================================================================================================
 * Levels
 * ============================================================================================== */

static void level_free(ao_mssao_level *L)
{
    for (int c = 0; c < 3; c++) {
        obs_image_f32_free(&L->pos[c]);
        obs_image_f32_free(&L->normal[c]);
        obs_image_f32_free(&L->ao[c]);
        obs_image_f32_free(&L->ao_blur[c]);
    }
    obs_image_f32_free(&L->valid);
    obs_image_f32_free(&L->own);
}

void ao_mssao_levels_free(ao_mssao_levels *lv)
{
    if (!lv)
        return;
    for (int l = 0; l < AO_MSSAO_MAX_LEVELS; l++)
        level_free(&lv->level[l]);
    obs_image_f32_free(&lv->visibility);
    memset(lv, 0, sizeof *lv);
}

/* Allocate the planes of one level: gbuf, position z and the normals (what the blur and the
 * upsampling read); full (the kept levels), also position x, y, the validity and own (the packed
 * texels hold x, y, z, w for the kernels); ao, the AO planes; blur, the blurred ones. */
/* A zeroed plane: the workspace's when ws is set (ao_i_ws_plane; then the workspace owns it), else a
 * fresh one (ao_mssao_compute_levels, whose planes go to the caller). */
static obs_status ms_plane(obs_context *ctx, ao_i_ws *ws, int w, int h, obs_image_f32 *out)
{
    return ws ? ao_i_ws_plane(ctx, ws, w, h, out) : obs_image_f32_alloc(ctx, w, h, out);
}

static obs_status level_alloc(obs_context *ctx, ao_i_ws *ws, ao_mssao_level *L, int w, int h, int gbuf, int full,
                              int ao, int blur)
{
    obs_status st = OBS_STATUS_OK;
    L->width = w;
    L->height = h;
    for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++) {
        if (full || (gbuf && c == 2))
            st = ms_plane(ctx, ws, w, h, &L->pos[c]);
        if (st == OBS_STATUS_OK && (gbuf || full))
            st = ms_plane(ctx, ws, w, h, &L->normal[c]);
        if (st == OBS_STATUS_OK && ao)
            st = ms_plane(ctx, ws, w, h, &L->ao[c]);
        if (st == OBS_STATUS_OK && blur)
            st = ms_plane(ctx, ws, w, h, &L->ao_blur[c]);
    }
    if (st == OBS_STATUS_OK && full)
        st = ms_plane(ctx, ws, w, h, &L->valid);
    if (st == OBS_STATUS_OK && ao && full)
        st = ms_plane(ctx, ws, w, h, &L->own);
    return st;
}

static inline int clampi(int v, int lo, int hi) { return v < lo ? lo : v > hi ? hi : v; }

/* Speed: the build has no fast-math and targets baseline x86-64, so fminf, fmaxf and floorf are libm
 * calls. These inline forms return exactly what glibc's x86-64 fminf / fmaxf return (minss / maxss
 * with the NaN operand dropped; on equal operands, signed zeros included, the second one), and
 * ifloor is (int)floorf(x) for |x| < 2^31 (every caller's range). docs/ao/mssao.md, "Speed". */
static inline float ms_fminf(float a, float b) { return (a < b || b != b) ? a : b; }
static inline float ms_fmaxf(float a, float b) { return (a > b || b != b) ? a : b; }
static inline int ifloor(float x)
{
    const int t = (int)x;
    return (float)t > x ? t - 1 : t;
}
static inline float at(const obs_image_f32 *im, int x, int y) { return obs_image_f32_row(im, y)[x]; }
static inline float pow8(float x)
{
    /* pow(x, 8.0) as x^2^2^2 (a GPU evaluates exp2(8 log2 x); docs: "Differences") */
    const float x2 = x * x, x4 = x2 * x2;
    return x4 * x4;
}

obs_status ao_mssao_level_visibility(obs_context *ctx, const ao_mssao_levels *lv, int l, ao_mssao_level_view view,
                                     obs_image_f32 *out)
{
    if (!lv || !out || !out->data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: level_visibility: NULL levels or output");
    if (l < 0 || l >= lv->count)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: level_visibility: level %d not in [0, %d)", l,
                         lv->count);
    if ((int)view < 0 || view >= AO_MSSAO_LEVEL_VIEW_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: level_visibility: view %d unknown", (int)view);
    const ao_mssao_level *L = &lv->level[l];
    if (!L->own.data || out->width != L->width || out->height != L->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: level_visibility: output must be %dx%d (level %d)",
                         L->width, L->height, l);
    for (int y = 0; y < L->height; y++) {
        const int j = L->height - 1 - y;
        float *o = obs_image_f32_row(out, y);
        for (int i = 0; i < L->width; i++) {
            float v;
            if (!(at(&L->valid, i, j) > 0.0f))
                v = 1.0f;
            else if (view == AO_MSSAO_LEVEL_OWN)
                v = 1.0f - at(&L->own, i, j);
            else
                v = (1.0f - at(&L->ao[0], i, j)) * (1.0f - at(&L->ao[1], i, j) / at(&L->ao[2], i, j));
            o[i] = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
        }
    }
    return OBS_STATUS_OK;
}

/* ---- Level 0 G-buffer (GL rows): positions from depth, normals, validity ----
 *
 * Speed: unless the levels are kept, level 0 has no planes. Its positions and validity are in its
 * packed texels, and its normals are read from the input's (or the reconstructed) normal planes,
 * our row order, through nrm0_fix, which gives what the G-buffer holds: */

/* Level 0's normal of a texel from the source normal n: zero on the background (w = 0, Hoang's
 * cleared G-buffer) and where n is not finite (the pixel then occludes nothing itself). */
static inline void nrm0_fix(float n[3], int surface)
{
    if (!surface || !(isfinite(n[0]) && isfinite(n[1]) && isfinite(n[2])))
        n[0] = n[1] = n[2] = 0.0f;
}

typedef struct g0_job {
    const ao_input *in;
    const obs_image_f32 *nrm;   /* 3 planes, our row order, full buffer */
    ao_mssao_level *L;          /* pos and valid planes only when kept (else NULL data) */
    float *pk;                  /* level 0's packed (x, y, z, w), GL rows */
} g0_job;

static void g0_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const g0_job *J = (const g0_job *)user;
    const ao_input *in = J->in;
    const int j = (int)task, y = in->height - 1 - j; /* GL row j is our row H - 1 - j */
    const float *drow = obs_image_f32_row(in->depth, y);
    const float *nr[3] = {obs_image_f32_row(&J->nrm[0], y), obs_image_f32_row(&J->nrm[1], y),
                          obs_image_f32_row(&J->nrm[2], y)};
    const int planes = J->L->valid.data != NULL;
    float *P[3] = {NULL, NULL, NULL}, *N[3] = {NULL, NULL, NULL}, *V = planes ? obs_image_f32_row(&J->L->valid, j) : NULL;
    for (int c = 0; c < 3 && planes; c++) {
        P[c] = obs_image_f32_row(&J->L->pos[c], j);
        N[c] = obs_image_f32_row(&J->L->normal[c], j);
    }
    float *Q = J->pk + 4 * (size_t)j * (size_t)in->width;
    for (int x = 0; x < in->width; x++) {
        const float d = drow[x];
        const obs_vec3 p = ao_position(in, x, y, d);
        /* DIFF (docs/ao/mssao.md): a pixel whose view-space position is beyond 1e18 m in any component
         * is background. Differences and squared distances of such positions overflow float (inf -
         * inf = NaN in normalize(q - p); found by fuzz_gbuffer, F13, with depths of 3.4e38); below
         * 1e18 every |v|^2 stays under 1.2e37. A GPU would give NaN or inf there. */
        if (!(isfinite(d) && d > 0.0f) || !(fabsf(p.x) <= 1e18f && fabsf(p.y) <= 1e18f && fabsf(p.z) <= 1e18f)) {
            /* Background: Hoang's G-buffer is cleared to (0, 0, 0, 0) (glClearColor 0, 0, 0, 0) */
            Q[4 * x] = Q[4 * x + 1] = Q[4 * x + 2] = Q[4 * x + 3] = 0.0f;
            if (planes)
                P[0][x] = P[1][x] = P[2][x] = N[0][x] = N[1][x] = N[2][x] = V[x] = 0.0f;
            continue;
        }
        /* normTex.w: the geometry pass writes 1 where it draws */
        Q[4 * x] = p.x;
        Q[4 * x + 1] = p.y;
        Q[4 * x + 2] = p.z;
        Q[4 * x + 3] = 1.0f;
        if (planes) {
            float n[3] = {nr[0][x], nr[1][x], nr[2][x]};
            nrm0_fix(n, 1);
            P[0][x] = p.x;
            P[1][x] = p.y;
            P[2][x] = p.z;
            N[0][x] = n[0];
            N[1][x] = n[1];
            N[2][x] = n[2];
            V[x] = 1.0f;
        }
    }
}

/* ---- Downsampling (downsample.frag), level l from level l-1 ---- */

typedef struct ds_job {
    const ao_mssao_level *F;    /* finer */
    ao_mssao_level *C;          /* coarser */
    float *cpk;                 /* the coarser level's packed texels, written here */
    const float *fpk;           /* the finer level's packed (x, y, z, w) */
    const obs_image_f32 *fnrm;  /* level 0 as the finer level: its source normals (our rows), else NULL */
    int rule;
    float thr;
    int avx2;
} ds_job;

#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
__attribute__((target("avx2"))) static void ds_hoang8(const ds_job *J, const float *const src[4][7],
                                                      float *const dst[7], float *Q, int i);
#endif

static void ds_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const ds_job *J = (const ds_job *)user;
    const ao_mssao_level *F = J->F;
    ao_mssao_level *C = J->C;
    const int j = (int)task;
    /* downsample.frag: xy2 = 2 gl_FragCoord; children at xy2 + (-0.5, 0.5), (0.5, 0.5), (0.5, -0.5),
     * (-0.5, -0.5), i.e. texels (2i, 2j+1), (2i+1, 2j+1), (2i+1, 2j), (2i, 2j), clamped. */
    const int cy[4] = {clampi(2 * j + 1, 0, F->height - 1), clampi(2 * j + 1, 0, F->height - 1),
                       clampi(2 * j, 0, F->height - 1), clampi(2 * j, 0, F->height - 1)};
    /* the 7 planes' child rows, once per row */
    const float *src[4][7];  /* pos xyz and w from the packed level (element step 4), normals from planes */
    float *dst[7];
    for (int k = 0; k < 4; k++) {
        const float *q = J->fpk + 4 * (size_t)cy[k] * (size_t)F->width;
        for (int c = 0; c < 3; c++) {
            src[k][c] = q + c;
            src[k][3 + c] = J->fnrm ? obs_image_f32_row(&J->fnrm[c], F->height - 1 - cy[k])
                                    : obs_image_f32_row(&F->normal[c], cy[k]);
        }
        src[k][6] = q + 3;
    }
    const int full = C->valid.data != NULL;
    for (int c = 0; c < 3; c++) {
        dst[c] = full || c == 2 ? obs_image_f32_row(&C->pos[c], j) : NULL;
        dst[3 + c] = obs_image_f32_row(&C->normal[c], j);
    }
    dst[6] = full ? obs_image_f32_row(&C->valid, j) : NULL;
    float *Q = J->cpk + 4 * (size_t)j * (size_t)C->width;
    int i = 0;
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
    if (J->avx2 && J->rule == AO_MSSAO_DOWNSAMPLE_HOANG)
        for (; i + 8 <= C->width && 2 * i + 16 <= F->width; i += 8)
            ds_hoang8(J, (const float *const(*)[7])src, dst, Q, i);
#endif
    for (; i < C->width; i++) {
        const int cx[4] = {clampi(2 * i, 0, F->width - 1), clampi(2 * i + 1, 0, F->width - 1),
                           clampi(2 * i + 1, 0, F->width - 1), clampi(2 * i, 0, F->width - 1)};
        float v[4][7]; /* pos xyz, normal xyz, w */
        for (int k = 0; k < 4; k++) {
            for (int c = 0; c < 3; c++) {
                v[k][c] = src[k][c][4 * cx[k]];
                v[k][3 + c] = src[k][3 + c][cx[k]];
            }
            v[k][6] = src[k][6][4 * cx[k]];
            if (J->fnrm)
                nrm0_fix(&v[k][3], v[k][6] > 0.0f);
        }
        int a, b, avg;
        if (J->rule == AO_MSSAO_DOWNSAMPLE_HOANG) {
            /* downsample.frag: min and max z, the last index wins a tie */
            const float maxZ = ms_fmaxf(ms_fmaxf(v[0][2], v[1][2]), ms_fmaxf(v[2][2], v[3][2]));
            const float minZ = ms_fminf(ms_fminf(v[0][2], v[1][2]), ms_fminf(v[2][2], v[3][2]));
            int minPos = 0, maxPos = 0;
            for (int k = 0; k < 4; k++) {
                if (v[k][2] == minZ)
                    minPos = k;
                if (v[k][2] == maxZ)
                    maxPos = k;
            }
            /* d = distance(pos[minPos].xyz, pos[maxPos].xyz) */
            const float dx = v[minPos][0] - v[maxPos][0], dy = v[minPos][1] - v[maxPos][1],
                        dz = v[minPos][2] - v[maxPos][2];
            const float d = sqrtf(dx * dx + dy * dy + dz * dz);
            int med[2] = {0, 0}, idx = 0;
            for (int k = 0; k < 4 && idx < 2; k++)
                if (k != minPos && k != maxPos)
                    med[idx++] = k;
            a = med[0];
            b = med[1];
            avg = d < J->thr; /* "if (d < 1.0)" */
        } else {
            /* fabmax/kool: bubble sort by linear depth (-z), "if (dnArray[j].z lt dnArray[i].z) swap" */
            int ord[4] = {0, 1, 2, 3};
            for (int p = 0; p < 3; p++)
                for (int q = p + 1; q < 4; q++)
                    if (-v[ord[q]][2] < -v[ord[p]][2]) {
                        const int t = ord[p];
                        ord[p] = ord[q];
                        ord[q] = t;
                    }
            const float dRange = (-v[ord[3]][2]) - (-v[ord[0]][2]);
            a = ord[1];
            b = ord[2];
            avg = dRange < J->thr; /* "if (dRange lt medianThresh)" */
        }
        float o[7];
        for (int c = 0; c < 7; c++)
            o[c] = avg ? (v[a][c] + v[b][c]) / 2.0f : v[a][c]; /* "(pos[median.x] + pos[median.y]) / 2.0" */
        for (int c = 0; c < 7; c++)
            if (dst[c])
                dst[c][i] = o[c];
        Q[4 * i] = o[0];
        Q[4 * i + 1] = o[1];
        Q[4 * i + 2] = o[2];
        Q[4 * i + 3] = o[6];
    }
}

/* ---- The per-sample term (ComputeOcclusion in ao*.frag) ---- */

/* Each level's taps read one interleaved (x, y, z, w) texel (the posTex.xyz and normTex.w the
 * shader fetches): one cache line per tap. g0_row and ds_row write them; the x, y and w planes exist
 * only when the levels are kept. */
typedef struct packed_level {
    const float *t;             /* width * height * 4 floats, GL rows */
    int width, height;
} packed_level;

static inline void occlusion_tap(const packed_level *L, int tx, int ty, const float p[3], const float n[3],
                                 float d_max2, float *occ, float *cnt)
{
    tx = clampi(tx, 0, L->width - 1);
    ty = clampi(ty, 0, L->height - 1);
    const float *q = L->t + 4 * ((size_t)ty * (size_t)L->width + (size_t)tx);
    const float v0 = q[0] - p[0], v1 = q[1] - p[1], v2 = q[2] - p[2];
    const float vv = v0 * v0 + v1 * v1 + v2 * v2;
    const float d = sqrtf(vv);                           /* distance(p.xyz, samplePos.xyz) */
    float t = ms_fminf(1.0f, (d * d) / d_max2);             /* min(1.0, (d * d) / (dMax * dMax)) */
    t = 1.0f - t;                                         /* rho = 1 - min(1, d^2 / dMax^2) */
    float cosTheta = 0.0f;
    if (vv > 0.0f) {
        /* normalize(samplePos.xyz - p.xyz); a zero vector (the tap is the pixel itself) gives NaN
         * on a GPU, which max(., 0.0) turns into 0 under IEEE maxNum: we take 0 explicitly */
        const float inv = 1.0f / d;
        const float c = n[0] * (v0 * inv) + n[1] * (v1 * inv) + n[2] * (v2 * inv);
        cosTheta = ms_fmaxf(c, 0.0f);
    }
    *occ += t * cosTheta * q[3]; /* occlusion += t * cosTheta * sampleNorm.w */
    *cnt += 1.0f;
}

/* ---- Bilateral upsampling (Upsample() in ao.frag / aoLast.frag) ---- */

/* The upsampled (maxAO, sumAO, count) of the coarser level C at fine texel (i, j) with position z
 * pz and normal n. Returns 1 when the bilateral weights all underflowed and bilinear was used. */
static inline int upsample(const ao_mssao_level *C, const obs_image_f32 *cao, int i, int j, float pz,
                           const float n[3], float out[3])
{
    const float fcx = (float)i + 0.5f, fcy = (float)j + 0.5f;
    static const float off[4][2] = {{-1.0f, 1.0f}, {1.0f, 1.0f}, {-1.0f, -1.0f}, {1.0f, -1.0f}};
    float wsum = 0.0f, acc[3] = {0.0f, 0.0f, 0.0f}, bl[4], vals[4][3];
    for (int k = 0; k < 4; k++) {
        /* loResCoord = floor((gl_FragCoord.xy + off) / 2.0) + vec2(0.5, 0.5) */
        const int fx = ifloor((fcx + off[k][0]) / 2.0f), fy = ifloor((fcy + off[k][1]) / 2.0f);
        const float lx = (float)fx + 0.5f, ly = (float)fy + 0.5f;   /* floor(lx) = fx */
        const int tx = clampi(fx, 0, C->width - 1), ty = clampi(fy, 0, C->height - 1);
        const float ln0 = at(&C->normal[0], tx, ty), ln1 = at(&C->normal[1], tx, ty), ln2 = at(&C->normal[2], tx, ty);
        const float lz = at(&C->pos[2], tx, ty);
        for (int c = 0; c < 3; c++)
            vals[k][c] = at(&cao[c], tx, ty);
        const float nw = pow8((ln0 * n[0] + ln1 * n[1] + ln2 * n[2] + 1.1f) / 2.1f); /* ((n_lo.n + 1.1)/2.1)^8 */
        const float dw8 = pow8(1.0f / (1.0f + fabsf(pz - lz) * 0.2f));
        const float dw = dw8 * dw8;                                                /* (1/(1 + 0.2|dz|))^16 */
        /* (9/16) / (|(x - 2 lx)(y - 2 ly)| * 4): 9/16, 3/16, 3/16, 1/16 */
        bl[k] = (9.0f / 16.0f) / (fabsf((fcx - lx * 2.0f) * (fcy - ly * 2.0f)) * 4.0f);
        const float w = nw * dw * (9.0f / 16.0f) / (fabsf((fcx - lx * 2.0f) * (fcy - ly * 2.0f)) * 4.0f);
        wsum += w;
        for (int c = 0; c < 3; c++)
            acc[c] += vals[k][c] * w;
    }
    if (wsum > 0.0f) {
        for (int c = 0; c < 3; c++)
            out[c] = acc[c] / wsum; /* combinedAO /= totalWeight */
        return 0;
    }
    /* All four weights underflowed (|dz| of thousands of metres): the shader divides 0 by 0. Our
     * deviation: the plain bilinear weights (docs, "Differences from the reference"). */
    wsum = 0.0f;
    acc[0] = acc[1] = acc[2] = 0.0f;
    for (int k = 0; k < 4; k++) {
        wsum += bl[k];
        for (int c = 0; c < 3; c++)
            acc[c] += vals[k][c] * bl[k];
    }
    for (int c = 0; c < 3; c++)
        out[c] = acc[c] / wsum;
    return 1;
}

/* ---- The AVX2 vocabulary (docs/ao/mssao.md, "Speed") ----
 *
 * The AVX2 paths run 8 horizontally adjacent texels of one row, lane k = texel i + k, and do per lane
 * the scalar code's float operations in its order (no FMA: -ffp-contract=off, and no FMA target), so
 * their results are bit-identical to it (tested: test_ao_mssao.c, "avx2_matches_scalar"). The mins
 * and maxes map exactly: _mm256_min_ps(a, b) is (a < b ? a : b) = ms_fminf(a, b) for b not NaN, and
 * _mm256_max_ps(c, 0) is ms_fmaxf(c, 0). The upsampling and the per-pixel tails stay scalar. */
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
#define MS_AVX2 1
#include <immintrin.h>
#define MS_TARGET __attribute__((target("avx2")))

/* 8 texels (x, y, z, w) of a packed level at float offsets idx[0..7] -> 4 vectors, lane k = idx[k] */
MS_TARGET static inline void ms_load8x4(const float *t, const int *idx, __m256 *X, __m256 *Y, __m256 *Z,
                                        __m256 *W)
{
    const __m256 r0 = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(t + idx[0])), _mm_loadu_ps(t + idx[4]), 1);
    const __m256 r1 = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(t + idx[1])), _mm_loadu_ps(t + idx[5]), 1);
    const __m256 r2 = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(t + idx[2])), _mm_loadu_ps(t + idx[6]), 1);
    const __m256 r3 = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(t + idx[3])), _mm_loadu_ps(t + idx[7]), 1);
    const __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpackhi_ps(r0, r1); /* x0 x1 y0 y1, z0 z1 w0 w1 */
    const __m256 t2 = _mm256_unpacklo_ps(r2, r3), t3 = _mm256_unpackhi_ps(r2, r3);
    *X = _mm256_shuffle_ps(t0, t2, 0x44);
    *Y = _mm256_shuffle_ps(t0, t2, 0xEE);
    *Z = _mm256_shuffle_ps(t1, t3, 0x44);
    *W = _mm256_shuffle_ps(t1, t3, 0xEE);
}

/* texels i..i+7 of row j of a packed level */
MS_TARGET static inline void ms_load8x4_row(const packed_level *T, int i, int j, __m256 *X, __m256 *Y, __m256 *Z, __m256 *W)
{
    const int b = 4 * (j * T->width + i);
    const int idx[8] = {b, b + 4, b + 8, b + 12, b + 16, b + 20, b + 24, b + 28};
    ms_load8x4(T->t, idx, X, Y, Z, W);
}

/* occlusion_tap for 8 lanes at texel offsets idx (already * 4), accumulated where active */
MS_TARGET static inline void ms_tap8(const float *t, const int *idx, const __m256 p[3], const __m256 n[3], __m256 d_max2,
                                     __m256 active, __m256 *occ, __m256 *cnt)
{
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
    __m256 X, Y, Z, W;
    ms_load8x4(t, idx, &X, &Y, &Z, &W);
    const __m256 v0 = _mm256_sub_ps(X, p[0]), v1 = _mm256_sub_ps(Y, p[1]), v2 = _mm256_sub_ps(Z, p[2]);
    const __m256 vv = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(v0, v0), _mm256_mul_ps(v1, v1)), _mm256_mul_ps(v2, v2));
    const __m256 d = _mm256_sqrt_ps(vv);
    const __m256 tt = _mm256_sub_ps(one, _mm256_min_ps(_mm256_div_ps(_mm256_mul_ps(d, d), d_max2), one));
    const __m256 inv = _mm256_div_ps(one, d);
    const __m256 c = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(n[0], _mm256_mul_ps(v0, inv)),
                                                 _mm256_mul_ps(n[1], _mm256_mul_ps(v1, inv))),
                                   _mm256_mul_ps(n[2], _mm256_mul_ps(v2, inv)));
    const __m256 cosTheta = _mm256_and_ps(_mm256_max_ps(c, zero), _mm256_cmp_ps(vv, zero, _CMP_GT_OQ));
    const __m256 term = _mm256_mul_ps(_mm256_mul_ps(tt, cosTheta), W);
    *occ = _mm256_blendv_ps(*occ, _mm256_add_ps(*occ, term), active);
    *cnt = _mm256_blendv_ps(*cnt, _mm256_add_ps(*cnt, one), active);
}

MS_TARGET static inline __m256 ms_pow8(__m256 x)
{
    const __m256 x2 = _mm256_mul_ps(x, x), x4 = _mm256_mul_ps(x2, x2);
    return _mm256_mul_ps(x4, x4);
}

MS_TARGET static inline __m256 ms_range_max(const ao_mssao_constants *K, float r, __m256 pz)
{
    const __m256 rMax = _mm256_set1_ps(K->r_max);
    if (K->orthographic)
        return _mm256_set1_ps(ms_fminf(r, K->r_max));
    const __m256 az = _mm256_andnot_ps(_mm256_set1_ps(-0.0f), pz); /* fabsf */
    return _mm256_min_ps(_mm256_div_ps(_mm256_set1_ps(r), az), rMax);
}
#endif

/* Whether this run may take the AVX2 paths: the build and the CPU have AVX2, OBS_ISA is not
 * "scalar", and level 0's packed float offsets fit an int. */
static int ms_use_avx2(int w, int h)
{
#if defined(MS_AVX2)
    const char *env = getenv("OBS_ISA");
    if (env && !strcmp(env, "scalar"))
        return 0;
    if ((double)w * (double)h * 4.0 >= 2147483647.0)
        return 0;
    return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
    (void)w;
    (void)h;
    return 0;
#endif
}

/* ---- Coarse and middle levels (aoFirst.frag, ao.frag) ---- */

typedef struct ao_job {
    const ao_mssao_constants *K;
    int l;
    ao_mssao_level *L;
    const packed_level *T;            /* L's packed taps */
    const ao_mssao_level *C;          /* coarser level, NULL for the coarsest */
    const obs_image_f32 *cao;         /* its (blurred) AO planes */
    int64_t *fallback;                /* per row */
    int avx2, up8;                    /* the AVX2 taps; the AVX2 upsampling (ms_up8_ok) */
} ao_job;

static inline void coarse_load(const ao_job *J, int i, int j, float p[3], float n[3])
{
    const float *q = J->T->t + 4 * ((size_t)j * (size_t)J->T->width + (size_t)i);
    for (int c = 0; c < 3; c++) {
        p[c] = q[c];
        n[c] = at(&J->L->normal[c], i, j);
    }
}

/* The grid taps of texel (i, j): occlusion and sampleCount */
typedef struct cnt_memo {
    float rangeMax, cnt;          /* the last zero-normal texel's rangeMax and its sampleCount */
} cnt_memo;

static inline void coarse_taps(const ao_job *J, int i, int j, const float p[3], const float n[3], float *occ_out,
                               float *cnt_out, cnt_memo *memo)
{
    const ao_mssao_constants *K = J->K;
    const float r = K->r[J->l], rMax = K->r_max, d_max2 = K->d_max2;
    /* rangeMax = min(r / abs(p.z), rMax); background p.z = 0 gives r / 0 = inf -> rMax */
    const float rangeMax = K->orthographic ? ms_fminf(r, rMax) : ms_fminf(r / fabsf(p[2]), rMax);
    float occ = 0.0f, cnt = 0.0001f; /* aoFirst.frag / ao.frag: "float sampleCount = 0.0001" */
    if (n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f) {
        /* Speed: a zero normal (the background, cleared to 0) makes every tap's cosTheta
         * max(0 or NaN, 0) = +0 and its term t * (+0) * w = +0 (t in [0, 1], w in [0, 1]), so
         * occlusion stays +0: only sampleCount is accumulated, in the shader's order. It is a
         * function of rangeMax alone, which is rMax on the whole background: memoised per row. */
        if (rangeMax == memo->rangeMax) {
            *occ_out = 0.0f;
            *cnt_out = memo->cnt;
            return;
        }
        for (float x = 1.0f; x <= rangeMax; x += 2.0f)
            for (float y = 1.0f; y <= rangeMax; y += 2.0f) {
                cnt += 1.0f;
                cnt += 1.0f;
                cnt += 1.0f;
                cnt += 1.0f;
            }
        memo->rangeMax = rangeMax;
        memo->cnt = cnt;
    } else {
        for (float x = 1.0f; x <= rangeMax; x += 2.0f)
            for (float y = 1.0f; y <= rangeMax; y += 2.0f) {
                const int ix = (int)x, iy = (int)y;
                occlusion_tap(J->T, i + ix, j + iy, p, n, d_max2, &occ, &cnt);
                occlusion_tap(J->T, i - ix, j + iy, p, n, d_max2, &occ, &cnt);
                occlusion_tap(J->T, i - ix, j - iy, p, n, d_max2, &occ, &cnt);
                occlusion_tap(J->T, i + ix, j - iy, p, n, d_max2, &occ, &cnt);
            }
    }
    *occ_out = occ;
    *cnt_out = cnt;
}

/* The rest of texel (i, j) once its taps are summed: upsampling and the outputs. Returns the
 * upsampling fallback flag. */
static inline int coarse_finish(const ao_job *J, int i, int j, const float p[3], const float n[3], float occ, float cnt)
{
    ao_mssao_level *L = J->L;
    const float own = occ / cnt;
    float o[3];
    int fb = 0;
    if (!J->C) {
        /* aoFirst.frag: AO = vec4(occlusion / sampleCount, occlusion, sampleCount, 0) */
        o[0] = own;
        o[1] = occ;
        o[2] = cnt;
    } else {
        /* ao.frag: (max(upsample.x, occlusion / sampleCount), upsample.y + occlusion, upsample.z + sampleCount) */
        float up[3];
        fb = upsample(J->C, J->cao, i, j, p[2], n, up);
        o[0] = ms_fmaxf(up[0], own);
        o[1] = up[1] + occ;
        o[2] = up[2] + cnt;
    }
    if (L->own.data)
        obs_image_f32_row(&L->own, j)[i] = own;
    for (int c = 0; c < 3; c++)
        obs_image_f32_row(&L->ao[c], j)[i] = o[c];
    return fb;
}

#if defined(MS_AVX2)
/* coarse_taps for texels i..i+7 (all inside the row). Returns 0 when all 8 normals are zero (the
 * scalar shortcut is then cheaper), else 1 with occ and cnt filled. */
MS_TARGET static int coarse_taps8(const ao_job *J, int i, int j, float *occ_out, float *cnt_out)
{
    const ao_mssao_constants *K = J->K;
    const ao_mssao_level *L = J->L;
    const packed_level *T = J->T;
    __m256 p[3], n[3], w;
    ms_load8x4_row(T, i, j, &p[0], &p[1], &p[2], &w);
    for (int c = 0; c < 3; c++)
        n[c] = _mm256_loadu_ps(obs_image_f32_row(&L->normal[c], j) + i);
    const __m256 zero = _mm256_setzero_ps();
    const __m256 nz = _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(n[0], zero, _CMP_EQ_OQ), _mm256_cmp_ps(n[1], zero, _CMP_EQ_OQ)),
                                    _mm256_cmp_ps(n[2], zero, _CMP_EQ_OQ));
    if (_mm256_movemask_ps(nz) == 0xFF)
        return 0;
    const __m256 rm = ms_range_max(K, K->r[J->l], p[2]);
    float rml[8];
    _mm256_storeu_ps(rml, rm);
    float maxr = rml[0];
    for (int k = 1; k < 8; k++)
        maxr = rml[k] > maxr ? rml[k] : maxr;
    const __m256 d_max2 = _mm256_set1_ps(K->d_max2);
    __m256 occ = zero, cnt = _mm256_set1_ps(0.0001f);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const __m256i base = _mm256_add_epi32(_mm256_set1_epi32(i), lane);
    const __m256i xmax = _mm256_set1_epi32(T->width - 1), izero = _mm256_setzero_si256();
    for (float x = 1.0f; x <= maxr; x += 2.0f) {
        const __m256 ax = _mm256_cmp_ps(_mm256_set1_ps(x), rm, _CMP_LE_OQ);
        const int ix = (int)x;
        /* the 4 taps' columns (clamped), * 4 */
        const __m256i cp = _mm256_slli_epi32(_mm256_min_epi32(_mm256_max_epi32(_mm256_add_epi32(base, _mm256_set1_epi32(ix)), izero), xmax), 2);
        const __m256i cm = _mm256_slli_epi32(_mm256_min_epi32(_mm256_max_epi32(_mm256_sub_epi32(base, _mm256_set1_epi32(ix)), izero), xmax), 2);
        for (float y = 1.0f; y <= maxr; y += 2.0f) {
            const __m256 act = _mm256_and_ps(ax, _mm256_cmp_ps(_mm256_set1_ps(y), rm, _CMP_LE_OQ));
            if (_mm256_movemask_ps(act) == 0)
                continue;
            const int iy = (int)y;
            const __m256i rp = _mm256_set1_epi32(4 * clampi(j + iy, 0, T->height - 1) * T->width);
            const __m256i rn = _mm256_set1_epi32(4 * clampi(j - iy, 0, T->height - 1) * T->width);
            int idx[4][8];
            _mm256_storeu_si256((__m256i *)idx[0], _mm256_add_epi32(rp, cp));   /* (i + x, j + y) */
            _mm256_storeu_si256((__m256i *)idx[1], _mm256_add_epi32(rp, cm));   /* (i - x, j + y) */
            _mm256_storeu_si256((__m256i *)idx[2], _mm256_add_epi32(rn, cm));   /* (i - x, j - y) */
            _mm256_storeu_si256((__m256i *)idx[3], _mm256_add_epi32(rn, cp));   /* (i + x, j - y) */
            for (int q = 0; q < 4; q++)
                ms_tap8(T->t, idx[q], p, n, d_max2, act, &occ, &cnt);
        }
    }
    _mm256_storeu_ps(occ_out, occ);
    _mm256_storeu_ps(cnt_out, cnt);
    return 1;
}
#endif

/* ---- The per-level blur (blur.frag): 3x3 cross-bilateral ---- */

typedef struct blur_job {
    ao_mssao_level *L;
    int avx2;
} blur_job;

static inline void blur_pixel(ao_mssao_level *L, int i, int j)
{
    const float n0 = at(&L->normal[0], i, j), n1 = at(&L->normal[1], i, j), n2 = at(&L->normal[2], i, j);
    const float pz = at(&L->pos[2], i, j);
    float ss[3] = {0.0f, 0.0f, 0.0f}, weight = 0.0f;
    for (int di = -1; di <= 1; di++)      /* for (float i = -1.0; i <= 1.0; i += 1.0) */
        for (int dj = -1; dj <= 1; dj++) { /*   for (float j = -1.0; j <= 1.0; j += 1.0) */
            const int tx = clampi(i + di, 0, L->width - 1), ty = clampi(j + dj, 0, L->height - 1);
            const float nw = pow8((at(&L->normal[0], tx, ty) * n0 + at(&L->normal[1], tx, ty) * n1 +
                                   at(&L->normal[2], tx, ty) * n2 + 1.2f) / 2.2f); /* ((n.n' + 1.2)/2.2)^8 */
            const float dw8 = pow8(1.0f / (1.0f + fabsf(pz - at(&L->pos[2], tx, ty)) * 0.2f));
            const float dw = dw8 * dw8;
            const float gw = 1.0f / (((float)abs(di) + 1.0f) * ((float)abs(dj) + 1.0f)); /* 1/((|i|+1)(|j|+1)) */
            weight += nw * dw * gw;
            for (int c = 0; c < 3; c++)
                ss[c] += at(&L->ao[c], tx, ty) * nw * dw * gw;
        }
    /* the centre tap has weight nw * 1 * 1 > 0, so weight > 0 */
    for (int c = 0; c < 3; c++)
        obs_image_f32_row(&L->ao_blur[c], j)[i] = ss[c] / weight;
}

#if defined(MS_AVX2)
/* blur_pixel for texels i..i+7, all with both horizontal neighbours inside the row (1 <= i, i + 8 < width) */
MS_TARGET static void blur8(ao_mssao_level *L, int i, int j)
{
    const __m256 n0 = _mm256_loadu_ps(obs_image_f32_row(&L->normal[0], j) + i);
    const __m256 n1 = _mm256_loadu_ps(obs_image_f32_row(&L->normal[1], j) + i);
    const __m256 n2 = _mm256_loadu_ps(obs_image_f32_row(&L->normal[2], j) + i);
    const __m256 pz = _mm256_loadu_ps(obs_image_f32_row(&L->pos[2], j) + i);
    const __m256 one = _mm256_set1_ps(1.0f), sgn = _mm256_set1_ps(-0.0f);
    __m256 ss[3] = {_mm256_setzero_ps(), _mm256_setzero_ps(), _mm256_setzero_ps()}, weight = _mm256_setzero_ps();
    for (int di = -1; di <= 1; di++)
        for (int dj = -1; dj <= 1; dj++) {
            const int tx = i + di, ty = clampi(j + dj, 0, L->height - 1);
            const __m256 m0 = _mm256_loadu_ps(obs_image_f32_row(&L->normal[0], ty) + tx);
            const __m256 m1 = _mm256_loadu_ps(obs_image_f32_row(&L->normal[1], ty) + tx);
            const __m256 m2 = _mm256_loadu_ps(obs_image_f32_row(&L->normal[2], ty) + tx);
            const __m256 z = _mm256_loadu_ps(obs_image_f32_row(&L->pos[2], ty) + tx);
            const __m256 dot = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(m0, n0), _mm256_mul_ps(m1, n1)),
                                                           _mm256_mul_ps(m2, n2)),
                                             _mm256_set1_ps(1.2f));
            const __m256 nw = ms_pow8(_mm256_div_ps(dot, _mm256_set1_ps(2.2f)));
            const __m256 adz = _mm256_andnot_ps(sgn, _mm256_sub_ps(pz, z));
            const __m256 dw8 = ms_pow8(_mm256_div_ps(one, _mm256_add_ps(one, _mm256_mul_ps(adz, _mm256_set1_ps(0.2f)))));
            const __m256 dw = _mm256_mul_ps(dw8, dw8);
            const __m256 gw = _mm256_set1_ps(1.0f / (((float)abs(di) + 1.0f) * ((float)abs(dj) + 1.0f)));
            weight = _mm256_add_ps(weight, _mm256_mul_ps(_mm256_mul_ps(nw, dw), gw));
            for (int c = 0; c < 3; c++) {
                const __m256 a = _mm256_loadu_ps(obs_image_f32_row(&L->ao[c], ty) + tx);
                ss[c] = _mm256_add_ps(ss[c], _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(a, nw), dw), gw));
            }
        }
    for (int c = 0; c < 3; c++)
        _mm256_storeu_ps(obs_image_f32_row(&L->ao_blur[c], j) + i, _mm256_div_ps(ss[c], weight));
}
#endif

static void blur_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const blur_job *B = (const blur_job *)user;
    ao_mssao_level *L = B->L;
    const int j = (int)task;
    int i = 0;
#if defined(MS_AVX2)
    if (B->avx2 && L->width >= 10) {
        blur_pixel(L, 0, j);
        for (i = 1; i + 8 < L->width; i += 8)
            blur8(L, i, j);
    }
#endif
    for (; i < L->width; i++)
        blur_pixel(L, i, j);
}

/* ---- Level 0 (aoLast.frag) ---- */

typedef struct last_job {
    const ao_mssao_constants *K;
    const ao_mssao_level *L;          /* level 0 G-buffer */
    const packed_level *T;            /* its packed taps */
    ao_mssao_level *Lout;             /* NULL, or level 0 with own/ao planes to fill (whole buffer) */
    const ao_mssao_level *C;          /* level 1, or NULL with 1 level */
    const obs_image_f32 *cao;
    int rx0, ry0;                     /* region origin, OUR row order */
    obs_image_f32 *vis;               /* region-sized, our row order */
    obs_image_f32 *vis_gl;            /* NULL, or the full-buffer visibility in GL rows */
    int64_t (*counts)[2];             /* per row: background, fallback */
    int avx2, up8;
    const obs_image_f32 *nrm;         /* level 0's source normals (our rows), read through nrm0_fix */
} last_job;

/* Level 0's position from its packed texel (level 0 has no position planes unless kept) */
static inline void last_load(const last_job *J, int i, int j, float p[3], float n[3])
{
    const float *q = J->T->t + 4 * ((size_t)j * (size_t)J->T->width + (size_t)i);
    const int y = J->K->full_height - 1 - j;
    for (int c = 0; c < 3; c++) {
        p[c] = q[c];
        n[c] = obs_image_f32_row(&J->nrm[c], y)[i];
    }
    nrm0_fix(n, 1);
}

/* The Poisson taps of a surface texel (i, j): occlusion (sampleCount is K->samples) */
static inline float last_taps(const last_job *J, int i, int j, const float p[3], const float n[3])
{
    const ao_mssao_constants *K = J->K;
    const float r = K->r[0], rMax = K->r_max, d_max2 = K->d_max2;
    const float rangeMax = K->orthographic ? ms_fminf(r, rMax) : ms_fminf(r / fabsf(p[2]), rMax);
    const float fcx = (float)i + 0.5f, fcy = (float)j + 0.5f;
    float occ = 0.0f, cnt = 0.0f; /* aoLast.frag: "float sampleCount = 0.0" */
    for (int k = 0; k < K->samples; k++) {
        /* gl_FragCoord.xy + vec2(poissonDisk[i], poissonDisk[i + 1]) * rangeMax, NEAREST */
        const float sx = fcx + K->taps[2 * k] * rangeMax, sy = fcy + K->taps[2 * k + 1] * rangeMax;
        occlusion_tap(J->T, ifloor(sx), ifloor(sy), p, n, d_max2, &occ, &cnt);
    }
    return occ;
}

/* Texel (i, j) (region column xr) given its summed taps: upsampling, combine, outputs. */
static inline void last_finish(const last_job *J, int i, int j, int xr, const float p[3], const float n[3], int surface,
                               float occ, float *vrow, int64_t *bg, int64_t *fb)
{
    float vis = 1.0f, o[3] = {0.0f, 0.0f, 0.0f}, own = 0.0f;
    if (surface) {
        const float cnt = (float)J->K->samples; /* 0 + 1 + ... + 1, exact */
        own = occ / cnt;
        float aoMax, aoAverage;
        if (J->C) {
            float up[3];
            *fb += upsample(J->C, J->cao, i, j, p[2], n, up);
            aoMax = ms_fmaxf(up[0], own);                 /* max(upsample.x, occlusion / sampleCount) */
            aoAverage = (up[1] + occ) / (up[2] + cnt);    /* (upsample.y + occlusion) / (upsample.z + sampleCount) */
            o[0] = aoMax;
            o[1] = up[1] + occ;
            o[2] = up[2] + cnt;
        } else {
            aoMax = aoAverage = own; /* one level: nothing to upsample (main.cpp's LEVEL_COUNT 1 reads a missing level) */
            o[0] = own;
            o[1] = occ;
            o[2] = cnt;
        }
        vis = (1.0f - aoMax) * (1.0f - aoAverage); /* currentFrameAO = (1 - aoMax) * (1 - aoAverage) */
        /* in [0, 1] up to the rounding of normals of length 1 + ulps; clamp that away */
        vis = vis < 0.0f ? 0.0f : vis > 1.0f ? 1.0f : vis;
    } else {
        (*bg)++; /* background (w = 0): visibility 1, as every obscura kernel (ao.h) */
    }
    vrow[xr] = vis;
    if (J->Lout) {
        obs_image_f32_row(&J->Lout->own, j)[i] = own;
        for (int c = 0; c < 3; c++)
            obs_image_f32_row(&J->Lout->ao[c], j)[i] = o[c];
    }
    if (J->vis_gl)
        obs_image_f32_row(J->vis_gl, j)[i] = vis;
}

#if defined(MS_AVX2)
/* last_load's normals (nrm0_fix on surface texels) for texels i..i+7 */
MS_TARGET static inline void ms_nrm0_load8(const last_job *J, int i, int j, __m256 n[3])
{
    const int y = J->K->full_height - 1 - j;
    const __m256 zero = _mm256_setzero_ps();
    __m256 finite = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    for (int c = 0; c < 3; c++) {
        n[c] = _mm256_loadu_ps(obs_image_f32_row(&J->nrm[c], y) + i);
        finite = _mm256_and_ps(finite, _mm256_cmp_ps(_mm256_sub_ps(n[c], n[c]), zero, _CMP_EQ_OQ)); /* x - x = 0 */
    }
    for (int c = 0; c < 3; c++)
        n[c] = _mm256_and_ps(n[c], finite);
}

/* last_taps for texels i..i+7 (lanes whose valid w <= 0 compute values that are not used) */
MS_TARGET static void last_taps8(const last_job *J, int i, int j, float *occ_out)
{
    const ao_mssao_constants *K = J->K;
    const packed_level *T = J->T;
    __m256 p[3], n[3], w;
    ms_load8x4_row(T, i, j, &p[0], &p[1], &p[2], &w);
    ms_nrm0_load8(J, i, j, n);
    const __m256 rm = ms_range_max(K, K->r[0], p[2]);
    const __m256 fcx = _mm256_add_ps(_mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(i), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7))),
                                     _mm256_set1_ps(0.5f));
    const __m256 fcy = _mm256_set1_ps((float)j + 0.5f);
    const __m256 d_max2 = _mm256_set1_ps(K->d_max2);
    const __m256i xmax = _mm256_set1_epi32(T->width - 1), ymax = _mm256_set1_epi32(T->height - 1);
    const __m256i izero = _mm256_setzero_si256(), wv = _mm256_set1_epi32(T->width);
    const __m256 all = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    __m256 occ = _mm256_setzero_ps(), cnt = _mm256_setzero_ps();
    for (int k = 0; k < K->samples; k++) {
        const __m256 sx = _mm256_add_ps(fcx, _mm256_mul_ps(_mm256_set1_ps(K->taps[2 * k]), rm));
        const __m256 sy = _mm256_add_ps(fcy, _mm256_mul_ps(_mm256_set1_ps(K->taps[2 * k + 1]), rm));
        __m256i tx = _mm256_cvttps_epi32(_mm256_floor_ps(sx)), ty = _mm256_cvttps_epi32(_mm256_floor_ps(sy));
        tx = _mm256_min_epi32(_mm256_max_epi32(tx, izero), xmax);
        ty = _mm256_min_epi32(_mm256_max_epi32(ty, izero), ymax);
        int idx[8];
        _mm256_storeu_si256((__m256i *)idx, _mm256_slli_epi32(_mm256_add_epi32(_mm256_mullo_epi32(ty, wv), tx), 2));
        ms_tap8(T->t, idx, p, n, d_max2, all, &occ, &cnt);
    }
    _mm256_storeu_ps(occ_out, occ);
}
#endif

#if defined(MS_AVX2)
/* upsample() for fine texels i..i+7 of row j, lane-wise in its operation order; pz and n are the
 * fine texels' z and normals. All 7 coarse planes must share one stride (ms_up8_ok). Returns the
 * lanes that took the bilinear fallback as a bit mask. */
MS_TARGET static int ms_upsample8(const ao_mssao_level *C, const obs_image_f32 *cao, int i, int j, __m256 pz,
                                  const __m256 n[3], __m256 out[3])
{
    static const float off[4][2] = {{-1.0f, 1.0f}, {1.0f, 1.0f}, {-1.0f, -1.0f}, {1.0f, -1.0f}};
    const __m256 fcx = _mm256_add_ps(_mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(i), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7))),
                                     _mm256_set1_ps(0.5f));
    const float fcy = (float)j + 0.5f;
    const __m256 half = _mm256_set1_ps(0.5f), sgn = _mm256_set1_ps(-0.0f), one = _mm256_set1_ps(1.0f);
    const __m256i xmax = _mm256_set1_epi32(C->width - 1), izero = _mm256_setzero_si256();
    const int stride = (int)C->normal[0].stride;
    __m256 wsum = _mm256_setzero_ps(), acc[3] = {_mm256_setzero_ps(), _mm256_setzero_ps(), _mm256_setzero_ps()};
    __m256 dens[4], vals[4][3];
    for (int k = 0; k < 4; k++) {
        /* loResCoord = floor((gl_FragCoord.xy + off) / 2.0) + vec2(0.5, 0.5) */
        const __m256 fx = _mm256_floor_ps(_mm256_div_ps(_mm256_add_ps(fcx, _mm256_set1_ps(off[k][0])), _mm256_set1_ps(2.0f)));
        const int fy = ifloor((fcy + off[k][1]) / 2.0f);
        const __m256 lx = _mm256_add_ps(fx, half);
        const float ly = (float)fy + 0.5f;
        const __m256i tx = _mm256_min_epi32(_mm256_max_epi32(_mm256_cvttps_epi32(fx), izero), xmax);
        const int ty = clampi(fy, 0, C->height - 1);
        /* The lanes' coarse columns are non-decreasing and span at most 5: one row load from the
         * first lane's column and a permute when the 8 floats lie inside the row's allocation
         * (stride >= width), else gathers. */
        __m256 ln0, ln1, ln2, lz;
        const int b = _mm256_cvtsi256_si32(tx);
        if (b + 8 <= stride) {
            const __m256i perm = _mm256_sub_epi32(tx, _mm256_set1_epi32(b));
            const ptrdiff_t o = (ptrdiff_t)ty * stride + b;
            ln0 = _mm256_permutevar8x32_ps(_mm256_loadu_ps(C->normal[0].data + o), perm);
            ln1 = _mm256_permutevar8x32_ps(_mm256_loadu_ps(C->normal[1].data + o), perm);
            ln2 = _mm256_permutevar8x32_ps(_mm256_loadu_ps(C->normal[2].data + o), perm);
            lz = _mm256_permutevar8x32_ps(_mm256_loadu_ps(C->pos[2].data + o), perm);
            for (int c = 0; c < 3; c++)
                vals[k][c] = _mm256_permutevar8x32_ps(_mm256_loadu_ps(cao[c].data + o), perm);
        } else {
            const __m256i idx = _mm256_add_epi32(tx, _mm256_set1_epi32(ty * stride));
            ln0 = _mm256_i32gather_ps(C->normal[0].data, idx, 4);
            ln1 = _mm256_i32gather_ps(C->normal[1].data, idx, 4);
            ln2 = _mm256_i32gather_ps(C->normal[2].data, idx, 4);
            lz = _mm256_i32gather_ps(C->pos[2].data, idx, 4);
            for (int c = 0; c < 3; c++)
                vals[k][c] = _mm256_i32gather_ps(cao[c].data, idx, 4);
        }
        const __m256 dot = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ln0, n[0]), _mm256_mul_ps(ln1, n[1])),
                                                       _mm256_mul_ps(ln2, n[2])),
                                         _mm256_set1_ps(1.1f));
        const __m256 nw = ms_pow8(_mm256_div_ps(dot, _mm256_set1_ps(2.1f)));
        const __m256 adz = _mm256_andnot_ps(sgn, _mm256_sub_ps(pz, lz));
        const __m256 dw8 = ms_pow8(_mm256_div_ps(one, _mm256_add_ps(one, _mm256_mul_ps(adz, _mm256_set1_ps(0.2f)))));
        const __m256 dw = _mm256_mul_ps(dw8, dw8);
        const __m256 den = _mm256_mul_ps(_mm256_andnot_ps(sgn, _mm256_mul_ps(_mm256_sub_ps(fcx, _mm256_mul_ps(lx, _mm256_set1_ps(2.0f))),
                                                                           _mm256_set1_ps(fcy - ly * 2.0f))),
                                         _mm256_set1_ps(4.0f));
        dens[k] = den;
        const __m256 w = _mm256_div_ps(_mm256_mul_ps(_mm256_mul_ps(nw, dw), _mm256_set1_ps(9.0f / 16.0f)), den);
        wsum = _mm256_add_ps(wsum, w);
        for (int c = 0; c < 3; c++)
            acc[c] = _mm256_add_ps(acc[c], _mm256_mul_ps(vals[k][c], w));
    }
    const __m256 ok = _mm256_cmp_ps(wsum, _mm256_setzero_ps(), _CMP_GT_OQ);
    for (int c = 0; c < 3; c++)
        out[c] = _mm256_div_ps(acc[c], wsum);
    const int fb = ~_mm256_movemask_ps(ok) & 0xFF;
    if (fb) {
        /* all four weights underflowed in some lane: the plain bilinear weights there */
        __m256 bsum = _mm256_setzero_ps(), bacc[3] = {_mm256_setzero_ps(), _mm256_setzero_ps(), _mm256_setzero_ps()};
        for (int k = 0; k < 4; k++) {
            const __m256 bl = _mm256_div_ps(_mm256_set1_ps(9.0f / 16.0f), dens[k]);
            bsum = _mm256_add_ps(bsum, bl);
            for (int c = 0; c < 3; c++)
                bacc[c] = _mm256_add_ps(bacc[c], _mm256_mul_ps(vals[k][c], bl));
        }
        for (int c = 0; c < 3; c++)
            out[c] = _mm256_blendv_ps(_mm256_div_ps(bacc[c], bsum), out[c], ok);
    }
    return fb;
}

/* ms_fmaxf(a, b) lane-wise: (a > b || b is NaN) ? a : b */
MS_TARGET static inline __m256 ms_fmax8(__m256 a, __m256 b)
{
    const __m256 m = _mm256_or_ps(_mm256_cmp_ps(a, b, _CMP_GT_OQ), _mm256_cmp_ps(b, b, _CMP_UNORD_Q));
    return _mm256_blendv_ps(b, a, m);
}

/* coarse_finish for texels i..i+7 */
MS_TARGET static int coarse_finish8(const ao_job *J, int i, int j, const float *occ8, const float *cnt8)
{
    ao_mssao_level *L = J->L;
    const __m256 occ = _mm256_loadu_ps(occ8), cnt = _mm256_loadu_ps(cnt8);
    const __m256 own = _mm256_div_ps(occ, cnt);
    __m256 o[3];
    int fb = 0;
    if (!J->C) {
        o[0] = own;
        o[1] = occ;
        o[2] = cnt;
    } else {
        __m256 n[3], up[3];
        for (int c = 0; c < 3; c++)
            n[c] = _mm256_loadu_ps(obs_image_f32_row(&L->normal[c], j) + i);
        const __m256 pz = _mm256_loadu_ps(obs_image_f32_row(&L->pos[2], j) + i);
        fb = __builtin_popcount((unsigned)ms_upsample8(J->C, J->cao, i, j, pz, n, up));
        o[0] = ms_fmax8(up[0], own);
        o[1] = _mm256_add_ps(up[1], occ);
        o[2] = _mm256_add_ps(up[2], cnt);
    }
    if (L->own.data)
        _mm256_storeu_ps(obs_image_f32_row(&L->own, j) + i, own);
    for (int c = 0; c < 3; c++)
        _mm256_storeu_ps(obs_image_f32_row(&L->ao[c], j) + i, o[c]);
    return fb;
}

/* last_finish for texels i..i+7 (region columns xr..xr+7), surface lanes from the valid plane */
MS_TARGET static void last_finish8(const last_job *J, int i, int j, int xr, const float *occ8, float *vrow, int64_t *bg,
                                   int64_t *fb)
{
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
    __m256 px, py, pz, pw;
    ms_load8x4_row(J->T, i, j, &px, &py, &pz, &pw);
    const __m256 surf = _mm256_cmp_ps(pw, zero, _CMP_GT_OQ);
    const int sm = _mm256_movemask_ps(surf);
    const __m256 occ = _mm256_loadu_ps(occ8), cnt = _mm256_set1_ps((float)J->K->samples);
    const __m256 own = _mm256_div_ps(occ, cnt);
    __m256 o[3], aoMax, aoAverage;
    if (J->C) {
        __m256 n[3], up[3];
        ms_nrm0_load8(J, i, j, n);
        *fb += __builtin_popcount((unsigned)(ms_upsample8(J->C, J->cao, i, j, pz, n, up) & sm));
        aoMax = ms_fmax8(up[0], own);
        o[1] = _mm256_add_ps(up[1], occ);
        o[2] = _mm256_add_ps(up[2], cnt);
        aoAverage = _mm256_div_ps(o[1], o[2]);
        o[0] = aoMax;
    } else {
        aoMax = aoAverage = o[0] = own;
        o[1] = occ;
        o[2] = cnt;
    }
    __m256 vis = _mm256_mul_ps(_mm256_sub_ps(one, aoMax), _mm256_sub_ps(one, aoAverage));
    /* vis < 0 ? 0 : vis > 1 ? 1 : vis */
    vis = _mm256_blendv_ps(vis, one, _mm256_cmp_ps(vis, one, _CMP_GT_OQ));
    vis = _mm256_blendv_ps(vis, zero, _mm256_cmp_ps(vis, zero, _CMP_LT_OQ));
    vis = _mm256_blendv_ps(one, vis, surf);
    *bg += 8 - __builtin_popcount((unsigned)sm);
    _mm256_storeu_ps(vrow + xr, vis);
    if (J->Lout) {
        _mm256_storeu_ps(obs_image_f32_row(&J->Lout->own, j) + i, _mm256_and_ps(own, surf));
        for (int c = 0; c < 3; c++)
            _mm256_storeu_ps(obs_image_f32_row(&J->Lout->ao[c], j) + i, _mm256_and_ps(o[c], surf));
    }
    if (J->vis_gl)
        _mm256_storeu_ps(obs_image_f32_row(J->vis_gl, j) + i, vis);
}
#endif

#if defined(MS_AVX2)
/* ms_fminf(a, b) lane-wise: (a < b || b is NaN) ? a : b */
MS_TARGET static inline __m256 ms_fmin8(__m256 a, __m256 b)
{
    const __m256 m = _mm256_or_ps(_mm256_cmp_ps(a, b, _CMP_LT_OQ), _mm256_cmp_ps(b, b, _CMP_UNORD_Q));
    return _mm256_blendv_ps(b, a, m);
}

/* lane-wise arr[pos] for pos in 0..3 */
MS_TARGET static inline __m256 ms_sel4(__m256i pos, const __m256 arr[4])
{
    __m256 r = arr[0];
    for (int k = 1; k < 4; k++)
        r = _mm256_blendv_ps(r, arr[k], _mm256_castsi256_ps(_mm256_cmpeq_epi32(pos, _mm256_set1_epi32(k))));
    return r;
}

/* ds_row's Hoang rule for coarse texels i..i+7, all children inside the finer row (2i + 16 <= width) */
MS_TARGET static void ds_hoang8(const ds_job *J, const float *const src[4][7], float *const dst[7], float *Q, int i)
{
    __m256 v[7][4]; /* channel (pos xyz, normal xyz, w), child */
    for (int k = 0; k < 4; k++) {
        const int par = k == 1 || k == 2; /* children [1], [2] are in the odd column 2i + 1 */
        int idx[8];
        for (int m = 0; m < 8; m++)
            idx[m] = 4 * (2 * (i + m) + par);
        ms_load8x4(src[k][0], idx, &v[0][k], &v[1][k], &v[2][k], &v[6][k]);
        __m256 finite = _mm256_cmp_ps(v[6][k], _mm256_setzero_ps(), _CMP_GT_OQ);
        for (int c = 0; c < 3; c++) {
            const float *s = src[k][3 + c] + 2 * i;
            const __m256 lo = _mm256_loadu_ps(s), hi = _mm256_loadu_ps(s + 8);
            const __m256 sh = par ? _mm256_shuffle_ps(lo, hi, 0xDD) : _mm256_shuffle_ps(lo, hi, 0x88); /* l0 l2 h0 h2 | l4 l6 h4 h6 */
            v[3 + c][k] = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(sh), 0xD8));
            finite = _mm256_and_ps(finite, _mm256_cmp_ps(_mm256_sub_ps(v[3 + c][k], v[3 + c][k]), _mm256_setzero_ps(), _CMP_EQ_OQ));
        }
        if (J->fnrm) /* nrm0_fix */
            for (int c = 0; c < 3; c++)
                v[3 + c][k] = _mm256_and_ps(v[3 + c][k], finite);
    }
    /* downsample.frag: min and max z, the last index wins a tie */
    const __m256 *z = v[2];
    const __m256 maxZ = ms_fmax8(ms_fmax8(z[0], z[1]), ms_fmax8(z[2], z[3]));
    const __m256 minZ = ms_fmin8(ms_fmin8(z[0], z[1]), ms_fmin8(z[2], z[3]));
    __m256i minPos = _mm256_setzero_si256(), maxPos = _mm256_setzero_si256();
    for (int k = 0; k < 4; k++) {
        const __m256i kk = _mm256_set1_epi32(k);
        minPos = _mm256_castps_si256(_mm256_blendv_ps(_mm256_castsi256_ps(minPos), _mm256_castsi256_ps(kk),
                                                      _mm256_cmp_ps(z[k], minZ, _CMP_EQ_OQ)));
        maxPos = _mm256_castps_si256(_mm256_blendv_ps(_mm256_castsi256_ps(maxPos), _mm256_castsi256_ps(kk),
                                                      _mm256_cmp_ps(z[k], maxZ, _CMP_EQ_OQ)));
    }
    /* d = distance(pos[minPos].xyz, pos[maxPos].xyz) */
    const __m256 dx = _mm256_sub_ps(ms_sel4(minPos, v[0]), ms_sel4(maxPos, v[0]));
    const __m256 dy = _mm256_sub_ps(ms_sel4(minPos, v[1]), ms_sel4(maxPos, v[1]));
    const __m256 dz = _mm256_sub_ps(ms_sel4(minPos, v[2]), ms_sel4(maxPos, v[2]));
    const __m256 d = _mm256_sqrt_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz)));
    /* the first two indices that are neither minPos nor maxPos */
    __m256i a = _mm256_setzero_si256(), b = _mm256_setzero_si256(), found = _mm256_setzero_si256();
    for (int k = 0; k < 4; k++) {
        const __m256i kk = _mm256_set1_epi32(k);
        const __m256i ok = _mm256_andnot_si256(_mm256_or_si256(_mm256_cmpeq_epi32(minPos, kk), _mm256_cmpeq_epi32(maxPos, kk)),
                                               _mm256_set1_epi32(-1));
        const __m256i first = _mm256_and_si256(ok, _mm256_cmpeq_epi32(found, _mm256_setzero_si256()));
        const __m256i second = _mm256_and_si256(ok, _mm256_cmpeq_epi32(found, _mm256_set1_epi32(1)));
        a = _mm256_blendv_epi8(a, kk, first);
        b = _mm256_blendv_epi8(b, kk, second);
        found = _mm256_sub_epi32(found, ok);
    }
    const __m256 avg = _mm256_cmp_ps(d, _mm256_set1_ps(J->thr), _CMP_LT_OQ); /* "if (d < 1.0)" */
    float o[7][8];
    for (int c = 0; c < 7; c++) {
        const __m256 va = ms_sel4(a, v[c]), vb = ms_sel4(b, v[c]);
        const __m256 r = _mm256_blendv_ps(va, _mm256_div_ps(_mm256_add_ps(va, vb), _mm256_set1_ps(2.0f)), avg);
        _mm256_storeu_ps(o[c], r);
        if (dst[c])
            _mm256_storeu_ps(dst[c] + i, r);
    }
    for (int m = 0; m < 8; m++) {
        Q[4 * (i + m)] = o[0][m];
        Q[4 * (i + m) + 1] = o[1][m];
        Q[4 * (i + m) + 2] = o[2][m];
        Q[4 * (i + m) + 3] = o[6][m];
    }
}
#endif

/* Whether the AVX2 upsampling may read level C: its 7 planes share one stride and its offsets fit an int */
static int ms_up8_ok(const ao_mssao_level *C, const obs_image_f32 *cao)
{
    if (!C)
        return 1;
    const ptrdiff_t s = C->normal[0].stride;
    if (C->normal[1].stride != s || C->normal[2].stride != s || C->pos[2].stride != s)
        return 0;
    for (int c = 0; c < 3; c++)
        if (cao[c].stride != s)
            return 0;
    return (double)s * (double)C->height < 2147483647.0;
}

static void ao_coarse_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const ao_job *J = (const ao_job *)user;
    ao_mssao_level *L = J->L;
    const int j = (int)task;
    int64_t fb = 0;
    int i = 0;
    float p[3], n[3], occ, cnt;
    cnt_memo memo = {-1.0f, 0.0f}; /* rangeMax >= 0 never equals -1 */
#if defined(MS_AVX2)
    if (J->avx2)
        for (; i + 8 <= L->width; i += 8) {
            float occ8[8], cnt8[8];
            if (!coarse_taps8(J, i, j, occ8, cnt8))
                for (int k = 0; k < 8; k++) {
                    coarse_load(J, i + k, j, p, n);
                    coarse_taps(J, i + k, j, p, n, &occ8[k], &cnt8[k], &memo);
                }
            if (J->up8) {
                fb += coarse_finish8(J, i, j, occ8, cnt8);
            } else {
                for (int k = 0; k < 8; k++) {
                    coarse_load(J, i + k, j, p, n);
                    fb += coarse_finish(J, i + k, j, p, n, occ8[k], cnt8[k]);
                }
            }
        }
#endif
    for (; i < L->width; i++) {
        coarse_load(J, i, j, p, n);
        coarse_taps(J, i, j, p, n, &occ, &cnt, &memo);
        fb += coarse_finish(J, i, j, p, n, occ, cnt);
    }
    J->fallback[task] = fb;
}

static void last_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const last_job *J = (const last_job *)user;
    const ao_mssao_constants *K = J->K;
    const int y = J->ry0 + (int)task, j = K->full_height - 1 - y;
    float *vrow = obs_image_f32_row(J->vis, (int)task);
    const float *V = J->T->t + 4 * (size_t)j * (size_t)J->T->width + 3; /* V[4 i]: valid w of texel i */
    int64_t bg = 0, fb = 0;
    float p[3] = {0.0f, 0.0f, 0.0f}, n[3] = {0.0f, 0.0f, 0.0f};
    int xr = 0;
#if defined(MS_AVX2)
    if (J->avx2)
        for (; xr + 8 <= J->vis->width; xr += 8) {
            const int i0 = J->rx0 + xr;
            int any = 0;
            for (int k = 0; k < 8; k++)
                any |= V[4 * (i0 + k)] > 0.0f;
            float occ8[8] = {0};
            if (any)
                last_taps8(J, i0, j, occ8);
            if (J->up8) {
                last_finish8(J, i0, j, xr, occ8, vrow, &bg, &fb);
                continue;
            }
            for (int k = 0; k < 8; k++) {
                const int i = i0 + k, surface = V[4 * i] > 0.0f;
                if (surface)
                    last_load(J, i, j, p, n);
                last_finish(J, i, j, xr + k, p, n, surface, occ8[k], vrow, &bg, &fb);
            }
        }
#endif
    for (; xr < J->vis->width; xr++) {
        const int i = J->rx0 + xr, surface = V[4 * i] > 0.0f;
        float occ = 0.0f;
        if (surface) {
            last_load(J, i, j, p, n);
            occ = last_taps(J, i, j, p, n);
        }
        last_finish(J, i, j, xr, p, n, surface, occ, vrow, &bg, &fb);
    }
    J->counts[task][0] = bg;
    J->counts[task][1] = fb;
}

/* ================================================================================================
 * The pipeline
 * ============================================================================================== */

static int64_t sum_rows(const int64_t *a, int n)
{
    int64_t s = 0;
    for (int i = 0; i < n; i++)
        s += a[i];
    return s;
}

/* Run MSSAO. Level 0 over the region [rx0, rx0+rw) x [ry0, ry0+rh) (our row order) into vis
 * (rw x rh). keep: keep every level's planes (and fill level 0's AO planes and vis_gl). ws: the
 * workspace every plane and buffer comes from (then lv's planes are the workspace's: never free
 * them), or NULL for fresh ones. */
static obs_status mssao_run(obs_context *ctx, obs_pool *pool, ao_i_ws *ws, const ao_input *in,
                            const ao_mssao_params *P, const ao_mssao_constants *K, int rx0, int ry0,
                            obs_image_f32 *vis, ao_mssao_levels *lv, ao_mssao_stats *stats)
{
    const int W = in->width, H = in->height, NL = K->levels;
    const int avx2 = ms_use_avx2(W, H);
    obs_status st = OBS_STATUS_OK;
    obs_image_f32 nrm[3] = {{0}};
    int own_nrm = 0;
    int64_t *rows = NULL;
    int64_t(*counts)[2] = NULL;
    int64_t fallback = 0;
    float *pk[AO_MSSAO_MAX_LEVELS] = {NULL};
    packed_level T[AO_MSSAO_MAX_LEVELS];
    memset(T, 0, sizeof T);

    /* ---- 1. Normals: the G-buffer's, else reconstructed from depth ---- */
    double t0 = obs_time_now();
    if (in->normal[0] && P->normals == AO_MSSAO_NORMALS_AUTO) {
        for (int c = 0; c < 3; c++)
            nrm[c] = *in->normal[c];
    } else {
        own_nrm = 1;
        for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++)
            st = ms_plane(ctx, ws, W, H, &nrm[c]);
        if (st == OBS_STATUS_OK)
            st = ao_normals_from_depth(ctx, pool, in, nrm);
    }
    const int maxh = H > 0 ? H : 1;
    if (st == OBS_STATUS_OK) {
        rows = ws ? (int64_t *)ao_i_ws_buf(ws, (size_t)maxh * sizeof *rows, 1)
                  : (int64_t *)calloc((size_t)maxh, sizeof *rows);
        counts = ws ? (int64_t(*)[2])ao_i_ws_buf(ws, (size_t)vis->height * sizeof *counts, 1)
                    : (int64_t(*)[2])calloc((size_t)vis->height, sizeof *counts);
        if (!rows || !counts)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "mssao: out of memory");
    }

    /* ---- 2. Level 0 G-buffer and the downsampled pyramid ---- */
    for (int l = 0; l < NL && st == OBS_STATUS_OK; l++) {
        double ta = obs_time_now();
        ao_mssao_level *L = &lv->level[l];
        /* Speed: level 0's positions and validity live only in its packed texels (g0_row writes
         * them there), unless every plane is kept: 4 full-size planes fewer to allocate and fill. */
        const int keep = lv->count < 0;
        st = level_alloc(ctx, ws, L, K->level_width[l], K->level_height[l], l > 0 || keep, keep, l > 0 || keep,
                         l > 0 && K->level_blur);
        if (st != OBS_STATUS_OK)
            break;
        const size_t pk_bytes = sizeof(float) * 4 * (size_t)L->width * (size_t)L->height;
        pk[l] = ws ? (float *)ao_i_ws_buf(ws, pk_bytes, 0) : (float *)obs_aligned_alloc(pk_bytes);
        if (!pk[l]) {
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "mssao: out of memory");
            break;
        }
        if (l == 0) {
            g0_job J = {in, nrm, L, pk[0]};
            obs_pool_run(pool, H, g0_row, &J);
        } else {
            ds_job J = {&lv->level[l - 1], L, pk[l], pk[l - 1], l == 1 ? nrm : NULL, K->downsample, K->d_threshold, avx2};
            obs_pool_run(pool, L->height, ds_row, &J);
        }
        T[l].t = pk[l];
        T[l].width = L->width;
        T[l].height = L->height;
        if (stats)
            stats->seconds_level[l] += obs_time_now() - ta;
    }
    double t1 = obs_time_now();

    /* ---- 3. AO coarse to fine, blurring each coarse level (main.cpp Display / RenderAO) ---- */
    for (int l = NL - 1; l >= 1 && st == OBS_STATUS_OK; l--) {
        double ta = obs_time_now();
        ao_mssao_level *L = &lv->level[l];
        const ao_mssao_level *C = l + 1 < NL ? &lv->level[l + 1] : NULL;
        const obs_image_f32 *cao = C ? (K->level_blur ? C->ao_blur : C->ao) : NULL;
        ao_job J = {K, l, L, &T[l], C, cao, rows, avx2, avx2 && ms_up8_ok(C, cao)};
        obs_pool_run(pool, L->height, ao_coarse_row, &J);
        fallback += sum_rows(rows, L->height);
        if (K->level_blur) {
            blur_job B = {L, avx2};
            obs_pool_run(pool, L->height, blur_row, &B);
        }
        if (stats)
            stats->seconds_level[l] += obs_time_now() - ta;
    }
    if (st == OBS_STATUS_OK) {
        double ta = obs_time_now();
        const ao_mssao_level *C = NL > 1 ? &lv->level[1] : NULL;
        last_job J = {K,
                      &lv->level[0],
                      &T[0],
                      lv->count < 0 ? &lv->level[0] : NULL,
                      C,
                      C ? (K->level_blur ? C->ao_blur : C->ao) : NULL,
                      rx0,
                      ry0,
                      vis,
                      lv->count < 0 ? &lv->visibility : NULL,
                      counts,
                      avx2,
                      avx2 && ms_up8_ok(C, C ? (K->level_blur ? C->ao_blur : C->ao) : NULL),
                      nrm};
        obs_pool_run(pool, vis->height, last_row, &J);
        int64_t bg = 0;
        for (int r = 0; r < vis->height; r++) {
            bg += counts[r][0];
            fallback += counts[r][1];
        }
        if (stats) {
            stats->seconds_level[0] += obs_time_now() - ta;
            stats->pixels_computed = (int64_t)vis->width * vis->height;
            stats->pixels_background = bg;
            stats->pixels_upsample_fallback = fallback;
            stats->levels = NL;
        }
    }
    double t2 = obs_time_now();
    if (stats) {
        stats->seconds_prepare = t1 - t0;
        stats->seconds_kernel = t2 - t1;
    }
    if (!ws) { /* else they are the workspace's */
        free(rows);
        free(counts);
        for (int l = 0; l < AO_MSSAO_MAX_LEVELS; l++)
            obs_aligned_free(pk[l]);
        if (own_nrm)
            for (int c = 0; c < 3; c++)
                obs_image_f32_free(&nrm[c]);
    }
    return st;
}

static obs_status check_call(obs_context *ctx, const ao_input *in, const ao_mssao_params *params)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    return ao_mssao_params_validate(ctx, params);
}

obs_status ao_mssao_compute_levels(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_mssao_params *params,
                                   ao_mssao_levels *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: levels output is NULL");
    memset(out, 0, sizeof *out);
    obs_status st = check_call(ctx, in, params);
    if (st != OBS_STATUS_OK)
        return st;
    const ao_mssao_constants K = ao_mssao_constants_from_params(params, in);
    obs_image_f32 vis = {0};
    st = obs_image_f32_alloc(ctx, in->width, in->height, &vis);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, in->width, in->height, &out->visibility);
    if (st == OBS_STATUS_OK) {
        out->count = -1; /* marker for mssao_run: keep everything */
        st = mssao_run(ctx, pool, NULL, in, params, &K, 0, 0, &vis, out, NULL);
        out->count = K.levels;
    }
    obs_image_f32_free(&vis);
    if (st != OBS_STATUS_OK)
        ao_mssao_levels_free(out);
    return st;
}

static const char mssao_workspace_key; /* its address names our slot in the context */

obs_status ao_mssao_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_mssao_params *params,
                            obs_image_f32 *out, obs_image_f32 *out_raw, ao_mssao_stats *stats)
{
    obs_status st = check_call(ctx, in, params);
    if (st != OBS_STATUS_OK)
        return st;
    if (!out || !out->data || out->width != in->w || out->height != in->h ||
        (out_raw && (!out_raw->data || out_raw->width != in->w || out_raw->height != in->h)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao: output planes must be %dx%d (the window)", in->w,
                         in->h);
    if (stats)
        memset(stats, 0, sizeof *stats);
    const ao_mssao_constants K = ao_mssao_constants_from_params(params, in);

    /* Level 0 over the window plus the final blur's reach (ao_blur_reach), in our row order */
    int rect[4] = {in->x0, in->y0, in->w, in->h};
    if (K.blur)
        ao_blur_reach(in, AO_GAUSS21_RADIUS, rect);
    obs_image_f32 raw = {0}, blurred = {0};
    /* Every plane and buffer of the call comes from the workspace kept in the context between calls
     * (ao_i_ws_*: zeroed as fresh planes, without a fresh plane's page faults) */
    ao_i_ws *ws = ao_i_ws_take(ctx, &mssao_workspace_key);
    ao_mssao_levels *lv = (ao_mssao_levels *)calloc(1, sizeof *lv);
    if (!lv || !ws) {
        free(lv);
        ao_i_ws_put(ctx, &mssao_workspace_key, ws);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "mssao: out of memory");
    }
    /* Speed: without the final blur the region is the window, and level 0 writes straight into out */
    obs_image_f32 *level0 = K.blur ? &raw : out;
    if (K.blur)
        st = ao_i_ws_plane(ctx, ws, rect[2], rect[3], &raw);
    if (st == OBS_STATUS_OK)
        st = mssao_run(ctx, pool, ws, in, params, &K, rect[0], rect[1], level0, lv, stats);
    free(lv); /* its planes are the workspace's */

    /* ---- 4. The optional final blur (the seed's 21-tap Gaussian), then the window ---- */
    const obs_image_f32 *final = level0;
    double t0 = obs_time_now();
    if (st == OBS_STATUS_OK && K.blur) {
        st = ao_i_ws_plane(ctx, ws, rect[2], rect[3], &blurred);
        if (st == OBS_STATUS_OK)
            st = ao_i_blur_gaussian21_ws(ctx, pool, ws, &raw, &blurred);
        final = &blurred;
    }
    if (stats)
        stats->seconds_blur = obs_time_now() - t0;
    if (st == OBS_STATUS_OK) {
        const int ox = in->x0 - rect[0], oy = in->y0 - rect[1];
        for (int y = 0; y < in->h; y++) {
            if (final != out)
                memcpy(obs_image_f32_row(out, y), obs_image_f32_row(final, y + oy) + ox, sizeof(float) * (size_t)in->w);
            if (K.blur) /* the Gaussian mixes background with its neighbours: background stays 1 (blur.md) */
                ao_i_background_to_one(in, y, obs_image_f32_row(out, y));
            if (out_raw)
                memcpy(obs_image_f32_row(out_raw, y), obs_image_f32_row(level0, y + oy) + ox,
                       sizeof(float) * (size_t)in->w);
        }
    }
    ao_i_ws_put(ctx, &mssao_workspace_key, ws); /* raw and blurred are its */
    return st;
}

/* ================================================================================================
 * The registry descriptor (ao.h, "The method registry")
 * ============================================================================================== */

_Static_assert(sizeof(ao_mssao_downsample) == sizeof(int) && sizeof(ao_mssao_normals) == sizeof(int),
               "ENUM params are int-sized");
_Static_assert(sizeof(ao_mssao_params) <= AO_PARAMS_MAX_SIZE, "AO_PARAMS_MAX_SIZE");

#define MS_F(field) offsetof(ao_mssao_params, field)
static const ao_param_desc mssao_param_descs[] = {
    {"radius", AO_PARAM_FLOAT, MS_F(d_max), 1e-6, 1e6, NULL, "dMax: world-space radius of influence (m)"},
    {"r-max", AO_PARAM_FLOAT, MS_F(r_max), 1e-6, 64, NULL, "rMax: largest sampling radius (pixels of each level)"},
    {"levels", AO_PARAM_INT, MS_F(levels), 1, AO_MSSAO_MAX_LEVELS, NULL, "resolution levels (LEVEL_COUNT)"},
    {"d-threshold", AO_PARAM_FLOAT, MS_F(d_threshold), 0, 1e30, NULL, "median-rule threshold of the downsampling (m)"},
    {"samples", AO_PARAM_INT, MS_F(samples), 1, AO_MSSAO_MAX_SAMPLES, NULL,
     "level-0 Poisson taps (16 = Hoang's disk; 17..32 add the disk rotated by 90 degrees)"},
    {"downsample", AO_PARAM_ENUM, MS_F(downsample), 0, 0, downsample_names,
     "hoang (downsample.frag) or sorted (the slides / kool) median rule"},
    {"normals", AO_PARAM_ENUM, MS_F(normals), 0, 0, normals_names,
     "auto: the G-buffer's when present, else from depth; depth: always from depth"},
    {"level-blur", AO_PARAM_BOOL, MS_F(level_blur), 0, 1, NULL, "blur.frag on each coarse level (Hoang: on)"},
    {"blur", AO_PARAM_BOOL, MS_F(blur), 0, 1, NULL, "final post-blur: the seed's 21-tap Gaussian (Hoang: off)"},
};
#undef MS_F

static void m_default(void *p) { *(ao_mssao_params *)p = ao_mssao_params_default(); }
static int m_preset(const char *name, void *p) { return ao_mssao_params_preset(name, (ao_mssao_params *)p); }
static obs_status m_validate(obs_context *ctx, const void *p)
{
    return ao_mssao_params_validate(ctx, (const ao_mssao_params *)p);
}
static int m_to_string(const void *p, char *buf, size_t size)
{
    return ao_mssao_params_to_string((const ao_mssao_params *)p, buf, size);
}
/* The study's sample axis: the level-0 Poisson taps (docs/ao/mssao.md, "Samples"). */
static void m_set_samples(void *p, int n)
{
    ((ao_mssao_params *)p)->samples = n < 1 ? 1 : n > AO_MSSAO_MAX_SAMPLES ? AO_MSSAO_MAX_SAMPLES : n;
}
static void m_set_radius(void *p, float r) { ((ao_mssao_params *)p)->d_max = r; }
static void m_set_blur(void *p, int on) { ((ao_mssao_params *)p)->blur = on != 0; }
static float m_get_radius(const void *p) { return ((const ao_mssao_params *)p)->d_max; }
static const char *m_truth(const void *p)
{
    (void)p;
    return "obs-mssao"; /* cosine-weighted obscurance, rho = 1 - d^2/dMax^2, r = dMax */
}
static int m_constants_json(const void *p, const ao_input *in, char *buf, size_t size)
{
    const ao_mssao_constants K = ao_mssao_constants_from_params((const ao_mssao_params *)p, in);
    size_t n = 0;
    int len = 0;
#define APPEND(...)                                                                                     \
    do {                                                                                                \
        int k_ = snprintf(buf ? buf + n : NULL, buf && n < size ? size - n : 0, __VA_ARGS__);           \
        if (k_ < 0)                                                                                     \
            return k_;                                                                                  \
        len += k_;                                                                                      \
        n = (size_t)len < size ? (size_t)len : size;                                                    \
    } while (0)
    APPEND("{\"LEVEL_COUNT\": %d, \"dMax\": %.9g, \"dMax2\": %.9g, \"rMax\": %.9g, \"d_threshold\": %.9g, "
           "\"downsample\": \"%s\", \"level_blur\": %d, \"final_blur\": \"%s\", \"orthographic\": %d, "
           "\"samples\": %d, \"level_size\": [",
           K.levels, (double)K.d_max, (double)K.d_max2, (double)K.r_max, (double)K.d_threshold,
           downsample_names[K.downsample], K.level_blur, K.blur ? "gaussian21" : "none", K.orthographic, K.samples);
    for (int l = 0; l < K.levels; l++)
        APPEND("%s[%d, %d]", l ? ", " : "", K.level_width[l], K.level_height[l]);
    APPEND("], \"r\": [");
    for (int l = 0; l < K.levels; l++)
        APPEND("%s%.9g", l ? ", " : "", (double)K.r[l]);
    APPEND("], \"poissonDisk\": [");
    for (int k = 0; k < 2 * K.samples; k++)
        APPEND("%s%.9g", k ? ", " : "", (double)K.taps[k]);
    APPEND("]}");
#undef APPEND
    return len;
}
static obs_status m_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const void *p, obs_image_f32 *out,
                            obs_image_f32 *out_raw, ao_stats *stats)
{
    ao_mssao_stats s;
    memset(&s, 0, sizeof s);
    obs_status st = ao_mssao_compute(ctx, pool, in, (const ao_mssao_params *)p, out, out_raw, &s);
    if (stats) {
        memset(stats, 0, sizeof *stats);
        stats->pixels_computed = s.pixels_computed;
        stats->pixels_background = s.pixels_background;
        stats->seconds_prepare = s.seconds_prepare;
        stats->seconds_kernel = s.seconds_kernel;
        stats->seconds_blur = s.seconds_blur;
    }
    return st;
}

const ao_method ao_i_method_mssao = {
    .name = "mssao",
    .title = "Multi-resolution screen-space AO [Hoang12]: Hoang's original shaders, 5 levels",
    .doc = "docs/ao/mssao.md",
    .params_size = sizeof(ao_mssao_params),
    .params_default = m_default,
    .params_preset = m_preset,
    .preset_names = preset_names,
    .params = mssao_param_descs,
    .param_count = (int)(sizeof mssao_param_descs / sizeof mssao_param_descs[0]),
    .params_adjust = NULL,
    .params_validate = m_validate,
    .params_to_string = m_to_string,
    .set_samples = m_set_samples,
    .set_radius = m_set_radius,
    .set_blur = m_set_blur,
    .get_radius = m_get_radius,
    .truth_estimator = m_truth,
    /* on a plane every tap direction lies in the plane: n.normalize(q - p) is 0 up to rounding;
     * measured worst 1 - V = 2.6e-6 (test_ao_mssao.c, planes facing and tilted 50 degrees) */
    .flat_value = 1.0f,
    .flat_tolerance = 1e-4f,
    .constants_to_json = m_constants_json,
    .compute = m_compute,
};
