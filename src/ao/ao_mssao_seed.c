/* ao_mssao_seed.c: the seed thesis' multi-resolution Alchemy AO (ssao-thesis-2017 section 4.2.2.3,
 * "Multi-Scale Ambient Occlusion": Figura 30 the level loop, Figura 33 the blend, Tablas 3, 24, 25).
 *
 * The thesis does not run Hoang & Low's MSSAO kernel: it runs its Alchemy AO shader at five
 * resolutions (full, 1/2, 1/4, 1/8, 1/16; Figura 30 re-renders the G-buffer at each viewport
 * RTT_WIDTH / pow(2, i)), blurs each level with its 21-tap Gaussian at that level's resolution
 * ("cinco diferentes texturas con su respectivo blur"), and mixes the five textures in the final
 * shader with per-level intensities, mixText = sum_i tex_i * intensidadTex_i (Figura 33), blended
 * over the scene with GL_SRC_ALPHA / GL_ONE_MINUS_SRC_ALPHA.
 *
 * Here, per level l (docs/ao/mssao-seed.md, every choice the thesis leaves open):
 *   1. the G-buffer at W >> l x H >> l: depth (and normals) point-sampled at the full pixel whose
 *      square holds the level pixel's centre (GL coordinates), the pixel model scaled as glViewport
 *      maps the same frustum onto the smaller viewport (we have no scene to re-render);
 *   2. Alchemy AO (ao_alchemy_raw, the same params at every level) over the whole level (level 0:
 *      the window plus the blur's reach), then ao_blur_gaussian21 at the level's resolution;
 *   3. the level sampled at each window pixel with GL_LINEAR / CLAMP_TO_EDGE (texture(tex, vUV)),
 *   4. V = max(0, 1 - sum_l I_l (1 - A_l)): the textures hold obscurance 1 - A as alpha (our reading
 *      of Figuras 32-33; the UNORM target saturates the sum at 1).
 */
#include "ao.h"
#include "ao_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ================================================================================================
 * Parameters
 * ============================================================================================== */

/* ssao-thesis-2017 Tabla 25 "Multi-Scale AO intensidades por texturas": 1920x1080 1,0; 960x540 0,5;
 * 480x270 0,3; 240x137 0,3; 120x68 0,3. */
static const float thesis_intensity[AO_MSSAO_SEED_LEVELS] = {1.0f, 0.5f, 0.3f, 0.3f, 0.3f};

ao_mssao_seed_params ao_mssao_seed_params_default(void)
{
    ao_mssao_seed_params p;
    memset(&p, 0, sizeof p);
    p.alchemy = ao_alchemy_params_default();
    p.alchemy.radius = AO_MSSAO_SEED_DEFAULT_RADIUS;   /* Tabla 3 */
    p.alchemy.samples = AO_MSSAO_SEED_DEFAULT_SAMPLES; /* Tabla 3 */
    p.alchemy.blur = 1;                                /* each level's Gaussian */
    memcpy(p.level_intensity, thesis_intensity, sizeof thesis_intensity);
    return p;
}

static const char *const preset_names[] = {"default", "thesis", "full-intensity", "level0", "level1",
                                           "level2", "level3", "level4", NULL};

const char *const *ao_mssao_seed_preset_names(void) { return preset_names; }

int ao_mssao_seed_params_preset(const char *name, ao_mssao_seed_params *out)
{
    if (!name || !out)
        return 0;
    ao_mssao_seed_params p = ao_mssao_seed_params_default();
    if (!strcmp(name, "default") || !strcmp(name, "thesis")) {
        /* Tablas 3 and 25 */
    } else if (!strcmp(name, "full-intensity")) {
        /* Figura 86: "combinarlas a su máxima intensidad" */
        for (int l = 0; l < AO_MSSAO_SEED_LEVELS; l++)
            p.level_intensity[l] = 1.0f;
    } else if (!strncmp(name, "level", 5) && name[5] >= '0' && name[5] < '0' + AO_MSSAO_SEED_LEVELS && !name[6]) {
        /* Figura 85: each texture alone */
        for (int l = 0; l < AO_MSSAO_SEED_LEVELS; l++)
            p.level_intensity[l] = l == name[5] - '0' ? 1.0f : 0.0f;
    } else {
        return 0;
    }
    *out = p;
    return 1;
}

obs_status ao_mssao_seed_params_validate(obs_context *ctx, const ao_mssao_seed_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao-seed: NULL params");
    obs_status st = ao_alchemy_params_validate(ctx, &p->alchemy);
    if (st != OBS_STATUS_OK)
        return st;
    for (int l = 0; l < AO_MSSAO_SEED_LEVELS; l++)
        if (!(p->level_intensity[l] >= 0.0f) || !(p->level_intensity[l] <= 1e6f))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "mssao-seed: level%d-intensity %g must be in [0, 1e6]", l, (double)p->level_intensity[l]);
    return OBS_STATUS_OK;
}

int ao_mssao_seed_params_to_string(const ao_mssao_seed_params *p, char *buf, size_t size)
{
    char a[512];
    ao_alchemy_params_to_string(&p->alchemy, a, sizeof a);
    return snprintf(buf, size, "%s levels=%d level_intensity=%.9g,%.9g,%.9g,%.9g,%.9g", a, AO_MSSAO_SEED_LEVELS,
                    (double)p->level_intensity[0], (double)p->level_intensity[1], (double)p->level_intensity[2],
                    (double)p->level_intensity[3], (double)p->level_intensity[4]);
}

/* ================================================================================================
 * Levels
 * ============================================================================================== */

void ao_mssao_seed_level_size(int W, int H, int l, int *w, int *h)
{
    /* Figura 30: glViewport(0, 0, RTT_WIDTH/(pow(2,i)), RTT_HEIGHT/(pow(2,i))), GLsizei truncation */
    int a = W >> l, b = H >> l;
    *w = a < 1 ? 1 : a;
    *h = b < 1 ? 1 : b;
}

void ao_mssao_seed_level_source(int W, int H, int l, int x, int y, int *sx, int *sy)
{
    int w, h;
    ao_mssao_seed_level_size(W, H, l, &w, &h);
    /* GL coordinates: level pixel (i, j) has its centre at ((i + 0.5) W / w, (j + 0.5) H / h) of the
     * full buffer; the full pixel holding it is the floor (exact in integers: (2i + 1) W / 2w). */
    const int j = h - 1 - y;
    int64_t fx = ((int64_t)(2 * x + 1) * W) / (2 * (int64_t)w), fy = ((int64_t)(2 * j + 1) * H) / (2 * (int64_t)h);
    fx = fx > W - 1 ? W - 1 : fx;
    fy = fy > H - 1 ? H - 1 : fy;
    *sx = (int)fx;
    *sy = H - 1 - (int)fy;
}

typedef struct level_buf {
    int w, h;
    obs_image_f32 depth, normal[3];
    ao_input in;
} level_buf;

typedef struct down_job {
    const ao_input *in;
    level_buf *L;
    int l;
    const int *sx; /* ao_mssao_seed_level_source's column for each level column (it depends on x alone) */
} down_job;

static void down_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const down_job *J = (const down_job *)user;
    const int y = (int)task, w = J->L->w;
    int sx0, sy;
    ao_mssao_seed_level_source(J->in->width, J->in->height, J->l, 0, y, &sx0, &sy); /* sy: y alone */
    const int *sx = J->sx;
    const float *drow = obs_image_f32_row(J->in->depth, sy);
    float *d = obs_image_f32_row(&J->L->depth, y);
    for (int x = 0; x < w; x++)
        d[x] = drow[sx[x]];
    if (J->in->normal[0])
        for (int a = 0; a < 3; a++) {
            const float *nrow = obs_image_f32_row(J->in->normal[a], sy);
            float *n = obs_image_f32_row(&J->L->normal[a], y);
            for (int x = 0; x < w; x++)
                n[x] = nrow[sx[x]];
        }
}

/* Level l's G-buffer and its ao_input (the whole level is its window). */
/* Planes from the workspace ws (the workspace owns them). */
static obs_status level_make(obs_context *ctx, obs_pool *pool, ao_i_ws *ws, const ao_input *in, int l, level_buf *L)
{
    memset(L, 0, sizeof *L);
    ao_mssao_seed_level_size(in->width, in->height, l, &L->w, &L->h);
    /* unzeroed: down_row writes every pixel of the level's planes */
    obs_status st = ao_i_ws_plane_unzeroed(ctx, ws, L->w, L->h, &L->depth);
    for (int a = 0; a < 3 && st == OBS_STATUS_OK && in->normal[0]; a++)
        st = ao_i_ws_plane_unzeroed(ctx, ws, L->w, L->h, &L->normal[a]);
    if (st != OBS_STATUS_OK)
        return st;
    /* the source column of each level column, once per level (ao_mssao_seed_level_source's x
     * depends on x alone, its y on y alone) */
    int *src_x = (int *)ao_i_ws_buf(ws, sizeof(int) * (size_t)L->w, 0);
    if (!src_x)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "mssao-seed: out of memory");
    for (int x = 0; x < L->w; x++) {
        int sy;
        ao_mssao_seed_level_source(in->width, in->height, l, x, 0, &src_x[x], &sy);
    }
    down_job J = {in, L, l, src_x};
    obs_pool_run(pool, L->h, down_row, &J);
    ao_input *li = &L->in;
    *li = *in;
    li->width = li->w = L->w;
    li->height = li->h = L->h;
    li->x0 = li->y0 = 0;
    li->depth = &L->depth;
    for (int a = 0; a < 3; a++)
        li->normal[a] = in->normal[0] ? &L->normal[a] : NULL;
    /* glViewport maps the same frustum onto w x h: the pixel model scales by w / W and h / H */
    const double sx = (double)L->w / in->width, sy = (double)L->h / in->height;
    li->fx = in->fx * sx;
    li->cx = in->cx * sx;
    li->fy = in->fy * sy;
    li->cy = in->cy * sy;
    return OBS_STATUS_OK;
}

/* One level's AO: raw over rect (level coordinates) and, with the blur, blurred; both rect-sized,
 * from the workspace ws, as every plane here. */
static obs_status level_ao(obs_context *ctx, obs_pool *pool, ao_i_ws *ws, const ao_input *li,
                           const ao_alchemy_params *ap, const int rect[4], obs_image_f32 *raw, obs_image_f32 *blurred,
                           int64_t counts[2], double *t_ao, double *t_blur)
{
    const ao_alchemy_constants k = ao_alchemy_constants_from_params(ap, li);
    obs_image_f32 rec[3];
    memset(rec, 0, sizeof rec);
    const obs_image_f32 *nrm[3] = {li->normal[0], li->normal[1], li->normal[2]};
    obs_status st = OBS_STATUS_OK;
    double t0 = obs_time_now();
    if (!k.normals_from_gbuffer) {
        for (int a = 0; a < 3 && st == OBS_STATUS_OK; a++)
            st = ao_i_ws_plane(ctx, ws, li->width, li->height, &rec[a]);
        if (st == OBS_STATUS_OK)
            st = ao_normals_from_depth(ctx, pool, li, rec);
        for (int a = 0; a < 3; a++)
            nrm[a] = &rec[a];
    }
    if (st == OBS_STATUS_OK) /* unzeroed: ao_alchemy_raw writes every pixel of rect */
        st = ao_i_ws_plane_unzeroed(ctx, ws, rect[2], rect[3], raw);
    if (st == OBS_STATUS_OK)
        st = ao_alchemy_raw(ctx, pool, li, &k, nrm, rect, raw, counts);
    double t1 = obs_time_now();
    if (st == OBS_STATUS_OK && ap->blur) {
        st = ao_i_ws_plane(ctx, ws, rect[2], rect[3], blurred);
        if (st == OBS_STATUS_OK)
            st = ao_i_blur_gaussian21_ws(ctx, pool, ws, raw, blurred);
    }
    double t2 = obs_time_now();
    *t_ao += t1 - t0;
    *t_blur += t2 - t1;
    return st; /* rec[] are the workspace's */
}

/* ================================================================================================
 * Upsampling and the blend
 * ============================================================================================== */

/* One axis of texture(tex, vUV) with GL_LINEAR and CLAMP_TO_EDGE on an n-texel level axis, for the
 * full buffer's fragment centre g of N: texel coordinate u = (g + 0.5) / N * n - 0.5, the two texels
 * around it (clamped) and the weight of the second. Columns are tabulated once per call and rows
 * once per row: the same float operations as per pixel, so the same bits. */
typedef struct lin_tap {
    int i0, i1;
    float a;
} lin_tap;

static lin_tap lin_axis(int g, int N, int n)
{
    const float u = ((float)g + 0.5f) / (float)N * (float)n - 0.5f;
    const float fu = floorf(u);
    lin_tap t;
    t.a = u - fu;
    t.i0 = (int)fu;
    t.i1 = t.i0 + 1;
    t.i0 = t.i0 < 0 ? 0 : t.i0 > n - 1 ? n - 1 : t.i0;
    t.i1 = t.i1 < 0 ? 0 : t.i1 > n - 1 ? n - 1 : t.i1;
    return t;
}

typedef struct blend_job {
    const ao_input *in;
    const obs_image_f32 *lev[AO_MSSAO_SEED_LEVELS]; /* level l's plane: level 0 over rect0, others whole */
    int rect0[4];
    float I[AO_MSSAO_SEED_LEVELS];
    obs_image_f32 *out;
    const lin_tap *col[AO_MSSAO_SEED_LEVELS];       /* levels 1..: lin_axis of window column i */
    /* the same columns split into arrays (the AVX2 row's loads): texel i0, i1 and weight a */
    const int32_t *col_i0[AO_MSSAO_SEED_LEVELS], *col_i1[AO_MSSAO_SEED_LEVELS];
    const float *col_a[AO_MSSAO_SEED_LEVELS];
} blend_job;

/* texture(tex, vUV) with GL_LINEAR and CLAMP_TO_EDGE on a w x h level (our row order), vUV the full
 * buffer's fragment centre: bilinear of the four texels lin_axis picks in x (cu) and y (cv, GL). */
static inline float sample_linear(const obs_image_f32 *T, lin_tap cu, lin_tap cv)
{
    const int h = T->height;
    const float au = cu.a, av = cv.a;
    const float *r0 = obs_image_f32_row(T, h - 1 - cv.i0), *r1 = obs_image_f32_row(T, h - 1 - cv.i1);
    const float a = r0[cu.i0] * (1.0f - au) + r0[cu.i1] * au;
    const float b = r1[cu.i0] * (1.0f - au) + r1[cu.i1] * au;
    return a * (1.0f - av) + b * av;
}

/* One window pixel i of a row: depth d, level 0's texel l0i, cv the row half of each level's lookup. */
static inline float blend_pixel(const blend_job *J, int i, float d, float l0i, const lin_tap *cv)
{
    if (!(d > 0.0f && d < INFINITY)) /* background keeps 1 (documented) */
        return 1.0f;
    /* level 0 is at the full resolution: texel centres coincide, GL_LINEAR returns the texel */
    float occ = J->I[0] * (1.0f - l0i);
    for (int l = 1; l < AO_MSSAO_SEED_LEVELS; l++)
        occ += J->I[l] * (1.0f - sample_linear(J->lev[l], J->col[l][i], cv[l]));
    /* V = 1 - min(1, sum_l I_l (1 - A_l)) */
    const float V = 1.0f - occ;
    return V > 0.0f ? (V < 1.0f ? V : 1.0f) : 0.0f;
}

static void blend_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const blend_job *J = (const blend_job *)user;
    const ao_input *in = J->in;
    const int y = in->y0 + (int)task, gy = in->height - 1 - y;
    float *o = obs_image_f32_row(J->out, (int)task);
    const float *l0 = obs_image_f32_row(J->lev[0], y - J->rect0[1]) + (in->x0 - J->rect0[0]);
    const float *drow = obs_image_f32_row(in->depth, y) + in->x0;
    lin_tap cv[AO_MSSAO_SEED_LEVELS];
    for (int l = 1; l < AO_MSSAO_SEED_LEVELS; l++)
        cv[l] = lin_axis(gy, in->height, J->lev[l]->height);
    for (int i = 0; i < in->w; i++)
        o[i] = blend_pixel(J, i, drow[i], l0[i], cv);
}

#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#define SEED_AVX2 __attribute__((target("avx2")))
/* blend_row on eight window pixels per vector: per lane the scalar row's float operations in its
 * order (sample_linear's two lerps and the lerp between them, then occ += I_l (1 - A_l) level by
 * level; no FMA: -ffp-contract=off and separate mul/add), so the same bits
 * (tests/test_ao_mssao_seed.c, mssao_seed_simd_and_scalar_paths_are_bit_identical). The texels
 * are gathered with the columns' i0, i1 from the two rows cv picks. */
static SEED_AVX2 void blend_row_avx2(void *user, int64_t task, int thread)
{
    (void)thread;
    const blend_job *J = (const blend_job *)user;
    const ao_input *in = J->in;
    const int y = in->y0 + (int)task, gy = in->height - 1 - y;
    float *o = obs_image_f32_row(J->out, (int)task);
    const float *l0 = obs_image_f32_row(J->lev[0], y - J->rect0[1]) + (in->x0 - J->rect0[0]);
    const float *drow = obs_image_f32_row(in->depth, y) + in->x0;
    const float *r0[AO_MSSAO_SEED_LEVELS], *r1[AO_MSSAO_SEED_LEVELS];
    float av[AO_MSSAO_SEED_LEVELS];
    lin_tap cv[AO_MSSAO_SEED_LEVELS];
    for (int l = 1; l < AO_MSSAO_SEED_LEVELS; l++) {
        cv[l] = lin_axis(gy, in->height, J->lev[l]->height);
        const int h = J->lev[l]->height;
        r0[l] = obs_image_f32_row(J->lev[l], h - 1 - cv[l].i0);
        r1[l] = obs_image_f32_row(J->lev[l], h - 1 - cv[l].i1);
        av[l] = cv[l].a;
    }
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps(), inf = _mm256_set1_ps(INFINITY);
    int i = 0;
    for (; i + 8 <= in->w; i += 8) {
        const __m256 d = _mm256_loadu_ps(drow + i);
        const __m256 surf = _mm256_and_ps(_mm256_cmp_ps(d, zero, _CMP_GT_OQ), _mm256_cmp_ps(d, inf, _CMP_LT_OQ));
        if (!_mm256_movemask_ps(surf)) { /* background keeps 1 */
            _mm256_storeu_ps(o + i, one);
            continue;
        }
        __m256 occ = _mm256_mul_ps(_mm256_set1_ps(J->I[0]), _mm256_sub_ps(one, _mm256_loadu_ps(l0 + i)));
        for (int l = 1; l < AO_MSSAO_SEED_LEVELS; l++) {
            const __m256i c0 = _mm256_loadu_si256((const __m256i *)(J->col_i0[l] + i));
            const __m256i c1 = _mm256_loadu_si256((const __m256i *)(J->col_i1[l] + i));
            const __m256 au = _mm256_loadu_ps(J->col_a[l] + i), nau = _mm256_sub_ps(one, au);
            const __m256 av8 = _mm256_set1_ps(av[l]), nav = _mm256_set1_ps(1.0f - av[l]);
            const __m256 a = _mm256_add_ps(_mm256_mul_ps(_mm256_i32gather_ps(r0[l], c0, 4), nau),
                                           _mm256_mul_ps(_mm256_i32gather_ps(r0[l], c1, 4), au));
            const __m256 b = _mm256_add_ps(_mm256_mul_ps(_mm256_i32gather_ps(r1[l], c0, 4), nau),
                                           _mm256_mul_ps(_mm256_i32gather_ps(r1[l], c1, 4), au));
            const __m256 A = _mm256_add_ps(_mm256_mul_ps(a, nav), _mm256_mul_ps(b, av8));
            occ = _mm256_add_ps(occ, _mm256_mul_ps(_mm256_set1_ps(J->I[l]), _mm256_sub_ps(one, A)));
        }
        /* V > 0 ? (V < 1 ? V : 1) : 0, i.e. (V > 0) & MINPS(V, 1) (MINPS(V, 1) = V < 1 ? V : 1) */
        const __m256 V = _mm256_sub_ps(one, occ);
        const __m256 v = _mm256_and_ps(_mm256_cmp_ps(V, zero, _CMP_GT_OQ), _mm256_min_ps(V, one));
        _mm256_storeu_ps(o + i, _mm256_blendv_ps(one, v, surf));
    }
    for (; i < in->w; i++) /* the row's last pixels: the scalar row's code */
        o[i] = blend_pixel(J, i, drow[i], l0[i], cv);
}
#undef SEED_AVX2
#define SEED_HAVE_AVX2 1
#endif

/* The blend's row function: the AVX2 row where the build and the CPU have it, unless OBS_ISA=scalar
 * (as every AO kernel's AUTO). Both give the same bits. */
static void (*blend_row_fn(void))(void *, int64_t, int)
{
#if defined(SEED_HAVE_AVX2)
    const char *env = getenv("OBS_ISA");
    if (!(env && !strcmp(env, "scalar")) && __builtin_cpu_supports("avx2"))
        return blend_row_avx2;
#endif
    return blend_row;
}

/* ================================================================================================
 * The whole pass
 * ============================================================================================== */

static const char seed_workspace_key; /* its address names our slot in the context */

obs_status ao_mssao_seed_compute(obs_context *ctx, obs_pool *pool, const ao_input *in,
                                 const ao_mssao_seed_params *params, obs_image_f32 *out, obs_image_f32 *out_raw,
                                 ao_mssao_seed_stats *stats)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    st = ao_mssao_seed_params_validate(ctx, params);
    if (st != OBS_STATUS_OK)
        return st;
    if (!out || !out->data || out->width != in->w || out->height != in->h ||
        (out_raw && (!out_raw->data || out_raw->width != in->w || out_raw->height != in->h)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "mssao-seed: output planes must be %dx%d (the window)",
                         in->w, in->h);
    if (params->alchemy.normals == AO_ALCHEMY_NORMALS_GBUFFER && !in->normal[0])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "mssao-seed: normals from the G-buffer were asked for, but the input has none");
    if (stats)
        memset(stats, 0, sizeof *stats);
    const ao_alchemy_params *ap = &params->alchemy;
    level_buf L[AO_MSSAO_SEED_LEVELS];
    memset(L, 0, sizeof L);
    obs_image_f32 raw[AO_MSSAO_SEED_LEVELS], blr[AO_MSSAO_SEED_LEVELS];
    memset(raw, 0, sizeof raw);
    memset(blr, 0, sizeof blr);
    int64_t bg = 0, computed = 0;
    double t_prep = 0.0, t_ao = 0.0, t_blur = 0.0;

    /* ---- Level 0: the input itself, over the window plus the blur's reach ---- */
    int rect0[4];
    ao_blur_reach(in, ap->blur ? AO_GAUSS21_RADIUS : 0, rect0);
    int64_t c[2] = {0, 0};
    /* Every plane and buffer of the call comes from the workspace kept in the context between calls
     * (ao_i_ws_*: zeroed as fresh planes, or unzeroed where every pixel is written before it is read;
     * without a fresh plane's page faults) */
    ao_i_ws *ws = ao_i_ws_take(ctx, &seed_workspace_key);
    if (!ws)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "mssao-seed: out of memory");
    st = level_ao(ctx, pool, ws, in, ap, rect0, &raw[0], &blr[0], c, &t_ao, &t_blur);
    bg += c[0];
    computed += (int64_t)rect0[2] * rect0[3];
    /* ---- Levels 1..4: the point-sampled G-buffer, the whole level ---- */
    for (int l = 1; l < AO_MSSAO_SEED_LEVELS && st == OBS_STATUS_OK; l++) {
        double t0 = obs_time_now();
        st = level_make(ctx, pool, ws, in, l, &L[l]);
        t_prep += obs_time_now() - t0;
        if (st != OBS_STATUS_OK)
            break;
        const int rect[4] = {0, 0, L[l].w, L[l].h};
        st = level_ao(ctx, pool, ws, &L[l].in, ap, rect, &raw[l], &blr[l], c, &t_ao, &t_blur);
        bg += c[0];
        computed += (int64_t)L[l].w * L[l].h;
    }
    /* ---- Blend (Figura 33), of the blurred levels into out and of the raw ones into out_raw ---- */
    double t0 = obs_time_now();
    if (st == OBS_STATUS_OK) {
        blend_job J;
        memset(&J, 0, sizeof J);
        J.in = in;
        memcpy(J.rect0, rect0, sizeof rect0);
        memcpy(J.I, params->level_intensity, sizeof J.I);
        /* the column half of every level's bilinear lookup, once per call (same bits as per pixel) */
        const size_t nc = (size_t)in->w * (AO_MSSAO_SEED_LEVELS - 1);
        lin_tap *cols = (lin_tap *)ao_i_ws_buf(ws, sizeof(lin_tap) * nc, 0);
        int32_t *ci0 = (int32_t *)ao_i_ws_buf(ws, sizeof(int32_t) * nc, 0);
        int32_t *ci1 = (int32_t *)ao_i_ws_buf(ws, sizeof(int32_t) * nc, 0);
        float *ca = (float *)ao_i_ws_buf(ws, sizeof(float) * nc, 0);
        if (!cols || !ci0 || !ci1 || !ca) {
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "mssao-seed: out of memory");
            cols = NULL;
        }
        for (int l = 1; l < AO_MSSAO_SEED_LEVELS && cols; l++) {
            const size_t off = (size_t)(l - 1) * in->w;
            lin_tap *c = cols + off;
            for (int i = 0; i < in->w; i++) {
                c[i] = lin_axis(in->x0 + i, in->width, raw[l].width);
                ci0[off + i] = c[i].i0;
                ci1[off + i] = c[i].i1;
                ca[off + i] = c[i].a;
            }
            J.col[l] = c;
            J.col_i0[l] = ci0 + off;
            J.col_i1[l] = ci1 + off;
            J.col_a[l] = ca + off;
        }
        void (*row_fn)(void *, int64_t, int) = blend_row_fn();
        for (int pass = 0; pass < 2 && cols; pass++) {
            obs_image_f32 *dst = pass == 0 ? out : out_raw;
            if (!dst)
                continue;
            if (pass == 1 && !ap->blur) { /* the same levels as pass 0's: the same bytes, copied */
                for (int r = 0; r < in->h; r++)
                    memcpy(obs_image_f32_row(dst, r), obs_image_f32_row(out, r), sizeof(float) * (size_t)in->w);
                continue;
            }
            for (int l = 0; l < AO_MSSAO_SEED_LEVELS; l++)
                J.lev[l] = pass == 0 && ap->blur ? &blr[l] : &raw[l];
            J.out = dst;
            obs_pool_run(pool, in->h, row_fn, &J);
        }
    }
    if (stats && st == OBS_STATUS_OK) {
        stats->pixels_computed = computed;
        stats->pixels_background = bg;
        stats->seconds_prepare = t_prep;
        stats->seconds_ao = t_ao;
        stats->seconds_blur = t_blur;
        stats->seconds_blend = obs_time_now() - t0;
    }
    ao_i_ws_put(ctx, &seed_workspace_key, ws); /* raw, blr, L and cols are its */
    return st;
}

/* ================================================================================================
 * The registry descriptor
 * ============================================================================================== */

_Static_assert(sizeof(ao_mssao_seed_params) <= AO_PARAMS_MAX_SIZE, "AO_PARAMS_MAX_SIZE");

static const char *const normals_names[] = {"auto", "gbuffer", "depth", NULL};

#define MS_F(field) offsetof(ao_mssao_seed_params, field)
static const ao_param_desc mssao_seed_param_descs[] = {
    {"radius", AO_PARAM_FLOAT, MS_F(alchemy.radius), 1e-6, 1e6, NULL, "Alchemy radius r at every level (m)"},
    {"bias", AO_PARAM_FLOAT, MS_F(alchemy.bias), 0, 1e30, NULL, "Alchemy shadow bias beta (term z_C beta)"},
    {"intensity", AO_PARAM_FLOAT, MS_F(alchemy.intensity), 0, 1e30, NULL, "Alchemy intensity sigma"},
    {"contrast", AO_PARAM_FLOAT, MS_F(alchemy.contrast), 1e-30, 1e30, NULL, "Alchemy contrast k"},
    {"epsilon", AO_PARAM_FLOAT, MS_F(alchemy.epsilon), 1e-30, 1e30, NULL, "Alchemy epsilon (m^2)"},
    {"samples", AO_PARAM_INT, MS_F(alchemy.samples), 1, AO_ALCHEMY_MAX_SAMPLES, NULL, "Alchemy taps s per level"},
    {"turns", AO_PARAM_INT, MS_F(alchemy.spiral_turns), 1, 1000000, NULL, "Alchemy spiral turns tau"},
    {"normals", AO_PARAM_ENUM, MS_F(alchemy.normals), 0, 0, normals_names,
     "auto: the G-buffer's (point-sampled per level) if present, else from each level's depth"},
    {"range-check", AO_PARAM_BOOL, MS_F(alchemy.range_check), 0, 1, NULL,
     "Alchemy: count only taps with |v| < r (SAO's falloff A)"},
    {"blur", AO_PARAM_BOOL, MS_F(alchemy.blur), 0, 1, NULL, "each level's 21-tap Gaussian at its own resolution"},
    {"level0-intensity", AO_PARAM_FLOAT, MS_F(level_intensity[0]), 0, 1e6, NULL, "I_0, full resolution"},
    {"level1-intensity", AO_PARAM_FLOAT, MS_F(level_intensity[1]), 0, 1e6, NULL, "I_1, 1/2 resolution"},
    {"level2-intensity", AO_PARAM_FLOAT, MS_F(level_intensity[2]), 0, 1e6, NULL, "I_2, 1/4 resolution"},
    {"level3-intensity", AO_PARAM_FLOAT, MS_F(level_intensity[3]), 0, 1e6, NULL, "I_3, 1/8 resolution"},
    {"level4-intensity", AO_PARAM_FLOAT, MS_F(level_intensity[4]), 0, 1e6, NULL, "I_4, 1/16 resolution"},
};
#undef MS_F

static void m_default(void *p) { *(ao_mssao_seed_params *)p = ao_mssao_seed_params_default(); }
static int m_preset(const char *name, void *p) { return ao_mssao_seed_params_preset(name, (ao_mssao_seed_params *)p); }
static obs_status m_validate(obs_context *ctx, const void *p)
{
    return ao_mssao_seed_params_validate(ctx, (const ao_mssao_seed_params *)p);
}
static int m_to_string(const void *p, char *buf, size_t size)
{
    return ao_mssao_seed_params_to_string((const ao_mssao_seed_params *)p, buf, size);
}
static void m_set_samples(void *p, int n) { ((ao_mssao_seed_params *)p)->alchemy.samples = n; }
static void m_set_radius(void *p, float r) { ((ao_mssao_seed_params *)p)->alchemy.radius = r; }
static void m_set_blur(void *p, int on) { ((ao_mssao_seed_params *)p)->alchemy.blur = on != 0; }
static float m_get_radius(const void *p) { return ((const ao_mssao_seed_params *)p)->alchemy.radius; }
static const char *m_truth(const void *p)
{
    (void)p;
    return "cos"; /* the Alchemy kernel's nearest estimator (docs/ao/alchemy.md, docs/ao/mssao-seed.md) */
}
static int m_constants_json(const void *p, const ao_input *in, char *buf, size_t size)
{
    const ao_mssao_seed_params *P = (const ao_mssao_seed_params *)p;
    size_t used = 0;
    int n = snprintf(buf, size, "{\"levels\": [");
    if (n < 0)
        return n;
    used += (size_t)n;
    for (int l = 0; l < AO_MSSAO_SEED_LEVELS; l++) {
        ao_input li = *in;
        int w, h;
        ao_mssao_seed_level_size(in->width, in->height, l, &w, &h);
        li.width = w;
        li.height = h;
        li.fx = in->fx * ((double)w / in->width);
        li.cx = in->cx * ((double)w / in->width);
        li.fy = in->fy * ((double)h / in->height);
        li.cy = in->cy * ((double)h / in->height);
        const ao_alchemy_constants K = ao_alchemy_constants_from_params(&P->alchemy, &li);
        n = snprintf(used < size ? buf + used : NULL, used < size ? size - used : 0, "%s{\"intensity\": %.9g, \"alchemy\": ",
                     l ? ", " : "", (double)P->level_intensity[l]);
        if (n < 0)
            return n;
        used += (size_t)n;
        n = ao_alchemy_constants_to_json(&K, used < size ? buf + used : NULL, used < size ? size - used : 0);
        if (n < 0)
            return n;
        used += (size_t)n;
        n = snprintf(used < size ? buf + used : NULL, used < size ? size - used : 0, "}");
        used += (size_t)n;
    }
    n = snprintf(used < size ? buf + used : NULL, used < size ? size - used : 0,
                 "], \"blend\": \"V = max(0, 1 - sum_l I_l (1 - A_l)), levels GL_LINEAR\"}");
    if (n < 0)
        return n;
    used += (size_t)n;
    return (int)used;
}
static obs_status m_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const void *p, obs_image_f32 *out,
                            obs_image_f32 *out_raw, ao_stats *stats)
{
    ao_mssao_seed_stats s;
    memset(&s, 0, sizeof s);
    obs_status st = ao_mssao_seed_compute(ctx, pool, in, (const ao_mssao_seed_params *)p, out, out_raw, &s);
    if (stats) {
        memset(stats, 0, sizeof *stats);
        stats->pixels_computed = s.pixels_computed;
        stats->pixels_background = s.pixels_background;
        stats->seconds_prepare = s.seconds_prepare;
        stats->seconds_kernel = s.seconds_ao;
        stats->seconds_blur = s.seconds_blur + s.seconds_blend;
    }
    return st;
}

const ao_method ao_i_method_mssao_seed = {
    .name = "mssao-seed",
    .title = "The seed thesis' multi-resolution Alchemy AO (5 levels, Tabla 25 blend)",
    .doc = "docs/ao/mssao-seed.md",
    .params_size = sizeof(ao_mssao_seed_params),
    .params_default = m_default,
    .params_preset = m_preset,
    .preset_names = preset_names,
    .params = mssao_seed_param_descs,
    .param_count = (int)(sizeof mssao_seed_param_descs / sizeof mssao_seed_param_descs[0]),
    .params_adjust = NULL,
    .params_validate = m_validate,
    .params_to_string = m_to_string,
    .set_samples = m_set_samples,
    .set_radius = m_set_radius,
    .set_blur = m_set_blur,
    .get_radius = m_get_radius,
    .truth_estimator = m_truth,
    .flat_value = 1.0f,
    /* every level is 1 on a plane; the Gaussian leaves 1 - 2.4e-7 per level, times sum I = 2.4 */
    .flat_tolerance = 1e-5f,
    .constants_to_json = m_constants_json,
    .compute = m_compute,
};
