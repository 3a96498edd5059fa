/* ao.h: the public header of obscura's screen-space ambient occlusion module (prefix ao_).
 *
 * Every kernel reads an ao_input (a G-buffer view: linear depth, optional view-space normals, and
 * the camera's pixel model) and writes visibility (1 = unoccluded) into one float plane.
 *
 * Conventions (docs/conventions.md, docs/ao/README.md, docs/ao/<technique>.md):
 *   - Images are row-major with row 0 at the TOP; pixel (x, y) has its centre at (x+0.5, y+0.5).
 *     Reference shaders are written against OpenGL's gl_FragCoord, whose y grows UPWARDS. Every
 *     kernel takes its per-pixel pattern (hash, noise, tap offsets, 2x2 derivative quads, MIP
 *     texel grids) in the shader's own pixel coordinates: x_gl = x, y_gl = H - 1 - y (H = the
 *     FULL buffer height, guard band included). That is what makes a GPU port given the same
 *     buffers produce the same numbers. Each technique's page says so.
 *   - View space: right-handed, -Z forward, +Y up, metres; linear depth d = -z_view > 0.
 *     Background: a depth that is not finite and > 0 (+inf, as our rasterizer writes, but also
 *     NaN, 0 or negative values from an external G-buffer) is background and gets visibility 1.
 *   - Position reconstruction from depth uses the rasterizer's pixel model exactly:
 *     perspective P(x, y) = d * ((x+0.5-cx)/fx, -(y+0.5-cy)/fy, -1); orthographic
 *     P(x, y) = ((x+0.5-cx)/fx, -(y+0.5-cy)/fy, -d).
 *   - All kernel arithmetic is float32 in the reference shader's operation order; the project
 *     builds with -ffp-contract=off, so no FMA is formed behind our back.
 *
 * Each technique has: *_params (human units) with *_params_default() naming every default's
 * source, a pure *_constants_from_params() that mirrors the reference shader's constant block,
 * and *_compute(ctx, pool, input, params, ...). Output is identical for any thread count.
 *
 * Ownership: an ao_input borrows its planes. ao_external owns its planes (free with
 * ao_external_free). Output planes are allocated by the caller (obs_image_f32_alloc).
 */
#ifndef AO_H
#define AO_H

#include "../core/obs.h"
#include "../raster/raster.h"

#ifdef __cplusplus
extern "C" {
#endif

struct io_image; /* src/io/io.h: an image read from a file (only its fields are used here) */

/* ================================================================================================
 * Input
 * ============================================================================================== */

/* A G-buffer view for AO. Planes are borrowed, never owned. The kernels compute the window
 * [x0, x0+w) x [y0, y0+h) of the full buffer (the inner window of a guard band) and may read
 * every pixel of the full buffer. */
typedef struct ao_input {
    int width, height;              /* full buffer size */
    int x0, y0, w, h;               /* window to compute; the output plane is w x h */
    const obs_image_f32 *depth;     /* linear depth, +inf = background; required */
    const obs_image_f32 *normal[3]; /* view-space unit normals; all NULL = none (kernels that need
                                       normals reconstruct them from depth) */
    double fx, fy, cx, cy;          /* pixel model of the full buffer (rast_view_constants) */
    obs_projection projection;
    double znear, zfar;             /* zfar may be +inf; 0 and +inf when unknown */
} ao_input;

/* Check an input: sizes, window inside the buffer, planes present and of the buffer's size,
 * normals all three or none, finite intrinsics with fx, fy > 0.
 * Returns OK or INVALID_ARGUMENT with a message. Pixel values are not inspected (any depth that
 * is not finite and > 0 is background, see above). */
obs_status ao_input_validate(obs_context *ctx, const ao_input *in);

/* The view-space position of full-buffer pixel (x, y) at linear depth d (see above). */
static inline obs_vec3 ao_position(const ao_input *in, int x, int y, float d)
{
    float ax = (float)(((double)x + 0.5 - in->cx) / in->fx), ay = (float)(-((double)y + 0.5 - in->cy) / in->fy);
    if (in->projection == OBS_PROJECTION_PERSPECTIVE)
        return obs_v3(ax * d, ay * d, -d);
    return obs_v3(ax, ay, -d);
}

/* An input over our own G-buffer: the window is the inner image (the guard band is read, not
 * computed), intrinsics from gb->constants, normals = gb->normal when use_normals and present.
 * The input points into gb, which must outlive it.
 * Returns OK or INVALID_ARGUMENT (NULLs, no depth plane). */
obs_status ao_input_from_gbuffer(obs_context *ctx, const rast_gbuffer *gb, int use_normals, ao_input *out);

/* View-space unit normals reconstructed from depth (for blends and for kernels that need normals
 * when the G-buffer has none): at each pixel, of the two one-sided differences along x and along
 * y, the one with the smaller depth step is used (HBAO's MinDiff rule, [Bavoil08], which avoids
 * straddling silhouettes), and n = normalize(cross(dx, dy)) facing the camera. Background and
 * pixels without a usable neighbour get the zero vector. out[0..2] must be allocated at the full
 * buffer size. Returns OK or INVALID_ARGUMENT. */
obs_status ao_normals_from_depth(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 out[3]);

/* ---- External G-buffers (EXR from a GPU engineer, or our own `obscura gbuffer` output) ---- */

typedef enum ao_depth_kind {
    AO_DEPTH_KIND_AUTO = 0,         /* "Z" is linear; other channels: the file's obscura:depth_convention */
    AO_DEPTH_KIND_LINEAR,           /* linear view depth -z_view, metres */
    AO_DEPTH_KIND_NDC_GL,           /* depth-buffer value, glDepthRange(0,1) of NDC z in [-1,1] */
    AO_DEPTH_KIND_NDC_ZERO_TO_ONE,  /* depth-buffer value, GL_ZERO_TO_ONE / D3D */
    AO_DEPTH_KIND_NDC_REVERSED_Z,   /* depth-buffer value, reversed-Z (near 1, far 0; infinite far n/d) */
    AO_DEPTH_KIND_COUNT
} ao_depth_kind;

/* Camera intrinsics of an external G-buffer (the written image, not the full guard-band buffer,
 * unless the file holds the full buffer). Fields left at their "unknown" value are taken from the
 * image's metadata. */
typedef struct ao_intrinsics {
    double fx, fy, cx, cy;          /* pixel model; fx <= 0 = unknown */
    int projection;                 /* obs_projection, or -1 = unknown */
    double znear, zfar;             /* znear < 0 = unknown; zfar may be +inf; NaN = unknown */
    int depth_kind;                 /* ao_depth_kind; AO_DEPTH_KIND_AUTO = unknown */
    int window[4];                  /* x0, y0, w, h of the inner window; w <= 0 = unknown */
} ao_intrinsics;

/* All fields "unknown". */
ao_intrinsics ao_intrinsics_unknown(void);

/* Parse intrinsics from JSON text: the first occurrences of the keys "fx", "fy", "cx", "cy"
 * (numbers), "projection" or "projection_type" ("perspective" / "orthographic"), "znear",
 * "zfar" (number or "infinity"), "depth_convention" or "depth_kind" ("linear", "gl",
 * "zero-to-one", "reversed-z"), and "inner_window" ([x, y, w, h]), at any nesting depth. Both a
 * flat file and the sidecar `obscura gbuffer` writes are accepted. Keys not present stay unknown.
 * Returns OK, PARSE_ERROR (malformed value for a known key) or INVALID_ARGUMENT (NULLs). */
obs_status ao_intrinsics_parse_json(obs_context *ctx, const char *text, ao_intrinsics *out);

typedef enum ao_external_normals {
    AO_EXTERNAL_NORMALS_AUTO = 0,   /* use N.X, N.Y, N.Z when present */
    AO_EXTERNAL_NORMALS_NONE,       /* ignore them */
    AO_EXTERNAL_NORMALS_REQUIRE,    /* NOT_FOUND when absent */
    AO_EXTERNAL_NORMALS_COUNT
} ao_external_normals;

typedef struct ao_external_options {
    const char *depth_channel;      /* NULL: "Z" if present, else "Zndc", else "depth", else "R" */
    ao_depth_kind depth_kind;       /* AO_DEPTH_KIND_AUTO: see the enum */
    ao_external_normals normals;    /* default AUTO */
    const char *normal_prefix;      /* NULL = "N" (channels N.X, N.Y, N.Z) */
    const ao_intrinsics *intrinsics;/* NULL = all from the metadata; known fields override it */
} ao_external_options;

ao_external_options ao_external_options_default(void);

/* An owned G-buffer read from an image, and the ao_input over it (whose planes point into this
 * struct: do not copy or move it after ao_external_from_image). */
typedef struct ao_external {
    obs_image_f32 depth;            /* linear depth, +inf = background */
    obs_image_f32 normal[3];        /* data NULL when absent */
    ao_input input;
    ao_depth_kind depth_kind;       /* the kind used (never AUTO) */
    char depth_channel[64];         /* the channel read */
    int64_t background_pixels;      /* depth +inf (linear) or the clear value (NDC) */
    int64_t invalid_depth_pixels;   /* NaN, -inf, <= 0, or NDC values that map to no positive depth:
                                       set to +inf (background) and counted */
} ao_external;

/* Build an external G-buffer from an image read with io_image_read.
 * Intrinsics: options->intrinsics' known fields, else the metadata `obscura gbuffer` writes
 * (obscura:pixel_model_fx_fy_cx_cy, obscura:projection_type, obscura:znear, obscura:zfar,
 * obscura:depth_convention, obscura:inner_window_x_y_w_h), else fx, fy, cx, cy from the GL
 * matrix obscura:projection (column-major). The window is the inner window when known, else the
 * whole image. NDC depth is converted with rast_linear_from_ndc_depth (in double), which needs
 * znear, zfar and the projection type.
 * Returns: OK; INVALID_ARGUMENT (NULLs, bad option values, non-finite or non-positive fx/fy, a
 * window outside the image); NOT_FOUND (no depth channel, a required normal channel or a needed
 * intrinsic absent: the message names it); INVALID_DEPTH_RANGE (znear/zfar unusable for the NDC
 * conversion); UNSUPPORTED (a uint depth channel); OUT_OF_MEMORY; LIMIT_EXCEEDED. */
obs_status ao_external_from_image(obs_context *ctx, const struct io_image *im, const ao_external_options *opt,
                                  ao_external *out);
void ao_external_free(ao_external *e);   /* NULL-safe */

/* ================================================================================================
 * The method registry: one descriptor per technique. The CLI (`obscura ao --list`, the parameter
 * flags), the study (issue 5: the sample, radius and blur axes, the matched ground truth), the
 * benchmarks and the generic tests (flat plane, thread counts, hard cases) all work through it, so
 * a technique is added by writing its file and one line in ao_methods.c.
 * ============================================================================================== */

typedef enum ao_param_type {
    AO_PARAM_FLOAT = 0,             /* a float field */
    AO_PARAM_INT,                   /* an int field */
    AO_PARAM_BOOL,                  /* an int field, 0 or 1: flags --NAME and --no-NAME */
    AO_PARAM_ENUM,                  /* an enum field (int-sized; each method static-asserts it):
                                       --NAME CHOICE; when choice 0 is "none", --no-NAME sets 0 */
    AO_PARAM_TYPE_COUNT
} ao_param_type;

/* One parameter of a technique's *_params struct, as the CLI and the study see it. */
typedef struct ao_param_desc {
    const char *name;               /* flag name without "--", e.g. "radius" */
    ao_param_type type;
    size_t offset;                  /* offsetof(params struct, field) */
    double min, max;                /* inclusive range the CLI accepts (FLOAT, INT); the method's
                                       validate step is still the authority */
    const char *const *choices;     /* ENUM: names by value, NULL-terminated; else NULL */
    const char *help;               /* one line: meaning and unit */
} ao_param_desc;

/* What every kernel reports. Methods with more detail keep their own stats struct beside it. */
typedef struct ao_stats {
    int64_t pixels_computed;        /* pixels the AO pass ran on (window plus blur reach) */
    int64_t pixels_background;      /* of those: background (visibility 1) */
    double seconds_prepare;         /* depth conversion, MIP pyramids, normals, noise */
    double seconds_kernel;          /* the AO pass(es) */
    double seconds_blur;            /* the post-process (0 without) */
} ao_stats;

/* Largest sizeof of any technique's params struct (the CLI keeps one on the stack). */
#define AO_PARAMS_MAX_SIZE 1024

typedef struct ao_method {
    const char *name;               /* "sao": --method NAME */
    const char *title;              /* one line: technique and reference key */
    const char *doc;                /* its page: "docs/ao/sao.md" */
    size_t params_size;             /* sizeof its params struct, <= AO_PARAMS_MAX_SIZE */
    void (*params_default)(void *p);
    int (*params_preset)(const char *name, void *p); /* 1 and *p filled, or 0 for an unknown name */
    const char *const *preset_names;                 /* NULL-terminated (may be empty) */
    const ao_param_desc *params;                     /* the flags, in --list order */
    int param_count;
    /* Optional: called once after the CLI applied its flags; given[i] != 0 when params[i] was set
     * on the command line (SAO: --samples without --turns takes the table's spiral turns). */
    void (*params_adjust)(void *p, const unsigned char *given);
    obs_status (*params_validate)(obs_context *ctx, const void *p);   /* OK or INVALID_ARGUMENT */
    int (*params_to_string)(const void *p, char *buf, size_t size);  /* snprintf semantics */
    /* The study's axes (issue 5): samples per pixel (GTAO maps n to slices x steps and says how in
     * its page), world-space radius in metres, and the technique's reference blur on or off. */
    void (*set_samples)(void *p, int n);
    void (*set_radius)(void *p, float r);
    void (*set_blur)(void *p, int on);
    float (*get_radius)(const void *p);
    /* The matched ground truth for these params: a truth_ao estimator name
     * (truth_ao_estimator_from_name), run with radius get_radius(p). docs/truth.md and
     * ../shared/reference/ao.md section 2. */
    const char *(*truth_estimator)(const void *p);
    /* The documented visibility on an open flat plane with the default params (1 for most; 0.75
     * for Crytek SSAO), and the tolerance the flat-plane test holds it to. */
    float flat_value, flat_tolerance;
    /* Optional: the resolved constant block as one JSON object (text), for the sidecar, so that a
     * shader port can be fed the same uniforms. snprintf semantics. NULL when the method has none. */
    int (*constants_to_json)(const void *p, const ao_input *in, char *buf, size_t size);
    /* Run the technique over in's window. out (w x h) gets the final AO (after the blur when the
     * params ask for one); out_raw (may be NULL) the AO before it. stats may be NULL.
     * Returns OK, INVALID_ARGUMENT, OUT_OF_MEMORY, LIMIT_EXCEEDED. */
    obs_status (*compute)(obs_context *ctx, obs_pool *pool, const ao_input *in, const void *p,
                          obs_image_f32 *out, obs_image_f32 *out_raw, ao_stats *stats);
} ao_method;

/* Every registered method, in a fixed order, NULL-terminated. */
const ao_method *const *ao_methods(void);
/* The method called name, or NULL. */
const ao_method *ao_method_find(const char *name);
/* The descriptor of a method's parameter called name, or NULL. */
const ao_param_desc *ao_method_param(const ao_method *m, const char *name);

/* ================================================================================================
 * The final blend (issue 4, item 3): AO multiplied into a simply shaded image
 * ============================================================================================== */

/* The blend's light: view-space direction toward the light, normalize(0.35, 0.6, 0.72) (upper
 * right, behind the viewer), and the ambient share. Our choice (the seed thesis blends AO into its
 * forward-shaded scenes; a fixed Lambert-plus-ambient image is the neutral stand-in). */
#define AO_BLEND_LIGHT_X 0.35f
#define AO_BLEND_LIGHT_Y 0.6f
#define AO_BLEND_LIGHT_Z 0.72f
#define AO_BLEND_AMBIENT 0.25f      /* shade = AO * (ambient + (1 - ambient) * max(0, n.l)) */

/* out(x, y) = AO * (AO_BLEND_AMBIENT + (1 - AO_BLEND_AMBIENT) max(0, n.l)) over in's window, with
 * n the normal planes (full buffer size, view space; the G-buffer's, or ao_normals_from_depth);
 * background pixels get 0. ao and out are w x h (they may alias). Linear values in [0, 1].
 * Returns OK or INVALID_ARGUMENT (sizes, NULLs). */
obs_status ao_blend_lambert(obs_context *ctx, obs_pool *pool, const ao_input *in, const obs_image_f32 *ao,
                            const obs_image_f32 *const normal[3], obs_image_f32 *out);

/* ================================================================================================
 * SAO: Scalable Ambient Obscurance [McGuire12] (McGuire, Mara, Luebke, HPG 2012), as the HPG12
 * reference shader (SAO_AO.pix) computes it and as the llvmpipe peer
 * (../shared/tools/llvmpipe-peer, README section 5) runs it. docs/ao/sao.md has every detail.
 * ============================================================================================== */

/* Defaults: the llvmpipe peer's (README section 3/5), which are the HPG12 shader's constants and
 * "SAO's own defaults for a metre-scale scene". */
#define AO_SAO_DEFAULT_RADIUS 1.0f          /* r, world units (m), > 0; peer --radius; HPG12 demo */
#define AO_SAO_DEFAULT_BIAS 0.01f           /* world units (m); peer --bias; HPG12 comment "e.g., 0.01m" */
#define AO_SAO_DEFAULT_INTENSITY 1.0f       /* >= 0, artistic; peer --intensity; G3D default 1.0 */
#define AO_SAO_DEFAULT_EPSILON 0.01f        /* > 0; HPG12 SAO_AO.pix "const float epsilon = 0.01" */
#define AO_SAO_DEFAULT_SAMPLES 11           /* N in [1, AO_SAO_MAX_SAMPLES]; HPG12 NUM_SAMPLES */
#define AO_SAO_DEFAULT_SPIRAL_TURNS 7       /* tau >= 1; HPG12 NUM_SPIRAL_TURNS ("tuned for 9 samples") */
#define AO_SAO_DEFAULT_MAX_MIP_LEVEL 5      /* [0, AO_SAO_MAX_MIP]; peer and later G3D MAX_MIP_LEVEL
                                               (AmbientOcclusion_constants.glsl); HPG12 used 4 */
#define AO_SAO_DEFAULT_LOG_MAX_OFFSET 3     /* [0, 30]; HPG12 LOG_MAX_OFFSET ("< 3: flashing") */
#define AO_SAO_DEFAULT_BLUR_STRIDE 2        /* [1, 64] px; HPG12 SAO_blur.pix SCALE */
#define AO_SAO_DEFAULT_EDGE_SHARPNESS 1.0f  /* >= 0; HPG12 EDGE_SHARPNESS */
#define AO_SAO_DEFAULT_BLUR_KEY_FAR 300.0f  /* m, > 0: the blur key is z / this; peer edgeK = 2000/300 */
#define AO_SAO_BLUR_RADIUS 4                /* taps each side; HPG12 SAO_blur.pix R (fixed: the
                                               Gaussian table below is for R = 4) */
#define AO_SAO_MAX_SAMPLES 1024
#define AO_SAO_MAX_MIP 15
#define AO_SAO_TURNS_FROM_TABLE 0           /* spiral_turns value: McGuire's minimum-discrepancy
                                               table for the sample count (ao_sao_turns_for_samples) */

typedef enum ao_sao_normals {
    AO_SAO_NORMALS_FROM_DEPTH = 0,  /* default: normalize(cross(dFdxFine(C), dFdyFine(C))) in GL 2x2
                                       quads, as the reference */
    AO_SAO_NORMALS_GBUFFER,         /* the input's normals (normalised); an option, not the reference */
    AO_SAO_NORMALS_COUNT
} ao_sao_normals;

typedef enum ao_sao_variant {
    AO_SAO_VARIANT_HPG12 = 0,       /* default: falloff B, A = max(0, 1 - sum * intensity * 5/(r^6 N)) */
    AO_SAO_VARIANT_G3D_HQ,          /* later G3D AmbientOcclusion_AO.pix with HIGH_QUALITY 1 (docs/ao/sao.md) */
    AO_SAO_VARIANT_COUNT
} ao_sao_variant;

typedef struct ao_sao_params {
    ao_sao_variant variant;
    float radius;           /* r: world-space radius, metres */
    float bias;             /* metres */
    float intensity;        /* artistic scale (HPG12) or exponent (G3D HQ) */
    float epsilon;          /* HPG12 0.01; the G3D HQ variant uses 0.001 */
    int samples;            /* N = NUM_SAMPLES */
    int spiral_turns;       /* NUM_SPIRAL_TURNS, or AO_SAO_TURNS_FROM_TABLE */
    int max_mip_level;      /* MAX_MIP_LEVEL; 0 = taps read level 0 only (the peer's `sao` stage) */
    int log_max_offset;     /* LOG_MAX_OFFSET */
    ao_sao_normals normals;
    int blur;               /* 1: the separable bilateral blur (two passes) after the AO pass */
    int blur_stride;        /* SCALE: taps every this many pixels */
    float edge_sharpness;   /* EDGE_SHARPNESS */
    float blur_key_far;     /* |FAR_PLANE_Z| of the blur key: edgeK = edge_sharpness * 2000 / this */
} ao_sao_params;

/* The peer's / HPG12 defaults (AO_SAO_DEFAULT_*), blur on. */
ao_sao_params ao_sao_params_default(void);

/* Named presets. Returns 1 and fills *out, or 0 for an unknown name.
 *   "default", "peer": ao_sao_params_default().
 *   "hpg12": the HPG12 shader's constants: as the default, with MAX_MIP_LEVEL 4.
 *   "thesis": the seed thesis' Table 3 (ssao-thesis-2017): r = 10 m, 8 samples, turns from the table (3).
 *   "g3d": G3D's AmbientOcclusionSettings (GLG3D.lib, 2014-12-30): r = 0.75 m, bias 0.023,
 *          intensity 1, 19 samples (turns 7 from the table), blur stride 2, radius 4, HPG12 estimator.
 *   "g3d-hq": the same settings with the later G3D HIGH_QUALITY estimator (epsilon 0.001). */
int ao_sao_params_preset(const char *name, ao_sao_params *out);
/* The preset names, NULL-terminated. */
const char *const *ao_sao_preset_names(void);

/* McGuire's minimum-discrepancy spiral turns for n samples (G3D AmbientOcclusionSettings::
 * numSpiralTurns, minDiscrepancyArray[100]; 5779 for n >= 100). n < 1 gives 1. */
int ao_sao_turns_for_samples(int n);

/* Check params. Returns OK or INVALID_ARGUMENT naming the field and its range. */
obs_status ao_sao_params_validate(obs_context *ctx, const ao_sao_params *p);

/* Resolved params as one line of text ("variant=hpg12 radius=1 ..."). Returns the length that
 * was needed (snprintf semantics). */
int ao_sao_params_to_string(const ao_sao_params *p, char *buf, size_t size);

/* The shader's constant block, field for field (the peer's uniforms and #defines, float32). */
typedef struct ao_sao_constants {
    int full_width, full_height;    /* the buffer the shader runs over (GL pixel grid) */
    int orthographic;               /* 0: perspective (the reference); 1: our orthographic extension */
    int variant;                    /* ao_sao_variant */
    int normals_from_gbuffer;       /* 0: reconstructed (reference); 1: the G-buffer's */
    /* csPos(s, z) = vec3((vec2(s) + 0.5) * projInfo.xy + projInfo.zw, 1) * z  (perspective),
     * with s in GL pixel coordinates: projInfo = (-1/fx, -1/fy, cx/fx, (H-cy)/fy), which is the
     * peer's (-2/(W P00), -2/(H P11), 1/P00, 1/P11) for a centred frustum. Orthographic:
     * vec3((vec2(s) + 0.5) * projInfo.xy + projInfo.zw, z) with (1/fx, 1/fy, -cx/fx, -(H-cy)/fy). */
    float proj_info[4];
    float proj_scale;               /* pixels per metre at 1 m: H P11 / 2 = fy (orthographic: fy) */
    float radius, radius2, inv_radius2, bias, intensity, epsilon;
    int num_samples, num_spiral_turns;
    float inv_num_samples;          /* 1.0 / float(NUM_SAMPLES), rounded once (GLSL constant folding) */
    float turns_angle;              /* float(NUM_SPIRAL_TURNS) * 6.28, in float */
    float final_scale;              /* HPG12: 5.0 / (r2 * r2 * r2 * float(N)); G3D HQ: 3.0 / float(N) */
    int max_mip;                    /* maxMip uniform: 0 = level 0 only */
    int log_max_offset;
    int blur, blur_radius, blur_stride;
    float edge_k;                   /* blur edgeK = edge_sharpness * 2000 / blur_key_far */
} ao_sao_constants;

/* The pure params -> constants step (mirrors the peer's uniform setup). in gives the buffer size
 * and the pixel model. Params are assumed validated. */
ao_sao_constants ao_sao_constants_from_params(const ao_sao_params *p, const ao_input *in);

/* The per-pixel rotation, in GL pixel coordinates, exactly as GLSL computes
 *   float((3 * x ^ y + x * y) * 10) = float(((3x) ^ (y + x*y)) * 10)
 * with 32-bit two's-complement int arithmetic (wrap-around on overflow, as GLSL int does), then
 * int -> float rounding to nearest. */
float ao_sao_spin(int x_gl, int y_gl);

typedef struct ao_sao_stats {
    int64_t pixels_computed;        /* window (plus blur margin) pixels the AO pass ran on */
    int64_t pixels_background;      /* of those: background (visibility 1) */
    int64_t pixels_degenerate_normal; /* of those: zero or non-finite normal (visibility 1) */
    int64_t pixels_below_min_radius;  /* G3D HQ: disk radius <= 3 px (visibility 1) */
    double seconds_csz, seconds_mip, seconds_ao, seconds_blur;
} ao_sao_stats;

/* SAO over the input's window. out (required) and out_raw (optional, may be NULL) are w x h
 * planes (our row order). out receives the blurred AO when params->blur, else the raw AO; out_raw
 * the AO before the blur. The AO pass runs over the window plus the blur's reach (stride * R
 * pixels each side, inside the buffer), so that the result equals a GPU running both passes
 * over the whole buffer and cropping. stats may be NULL. The AO pass and the blur run on AVX2
 * when the build and the CPU have it (the environment's OBS_ISA=scalar forces the scalar path);
 * both paths give the same bytes (docs/ao/sao.md, "Speed").
 * Returns: OK; INVALID_ARGUMENT (input, params, plane sizes, or normals = GBUFFER without
 * normals); OUT_OF_MEMORY; LIMIT_EXCEEDED. */
obs_status ao_sao_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_sao_params *params,
                          obs_image_f32 *out, obs_image_f32 *out_raw, ao_sao_stats *stats);

/* As ao_sao_compute with an explicit constant block (to feed another renderer's exact uniforms,
 * e.g. the llvmpipe peer's projInfo and projScale). k->full_width/height must match the input. */
obs_status ao_sao_compute_constants(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_sao_constants *k,
                                    obs_image_f32 *out, obs_image_f32 *out_raw, ao_sao_stats *stats);

/* ---- Building blocks, exposed for validation. All planes here are in GL row order (row 0 =
 * the BOTTOM row), full buffer size, as the shader's textures are. ---- */

/* SAO's camera-space z buffer (reconstructCSZ): csz = -depth for a finite depth > 0, else 0
 * (the background sentinel). out must be a width x height plane; row r of out is input row
 * height - 1 - r. Returns OK or INVALID_ARGUMENT. */
obs_status ao_sao_csz_from_input(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out);

/* The depth MIP pyramid by rotated-grid subsampling (AmbientOcclusion_minify.pix):
 * level l has size max(1, size_0 >> l) and z_l(p) = z_{l-1}(clamp(2p + (p.y & 1, p.x & 1), 0,
 * size_{l-1} - 1)), p in GL coordinates. levels[0] is set to a view of *level0 (not owned);
 * levels[1..max_level] are allocated here: free them with ao_sao_mip_free.
 * Returns OK, INVALID_ARGUMENT (max_level outside [0, AO_SAO_MAX_MIP]), OUT_OF_MEMORY,
 * LIMIT_EXCEEDED. */
obs_status ao_sao_mip_build(obs_context *ctx, obs_pool *pool, const obs_image_f32 *level0, int max_level,
                            obs_image_f32 *levels);
void ao_sao_mip_free(obs_image_f32 *levels, int max_level);

/* The separable bilateral blur (SAO_blur.pix as the peer runs it) over whole images: horizontal
 * pass, then vertical, taps at stride * r for r = -R..R (R = AO_SAO_BLUR_RADIUS) clamped to the
 * image, weight (0.3 + g[|r|]) * max(0, 1 - edge_k * |z_r - z|), centre weight g[0], result
 * sum / (wsum + 1e-4); pixels with key z == 0 pass through. ao and csz (the key) in, out out
 * (may not alias ao). All the same size. Returns OK, INVALID_ARGUMENT, OUT_OF_MEMORY. */
obs_status ao_sao_blur_gl(obs_context *ctx, obs_pool *pool, const obs_image_f32 *ao, const obs_image_f32 *csz,
                          int stride, float edge_k, obs_image_f32 *out);

/* The blur's Gaussian (stddev 2) weights g[0..4], SAO_blur.pix. */
extern const float ao_sao_blur_gaussian[AO_SAO_BLUR_RADIUS + 1];

/* ================================================================================================
 * Crytek SSAO (src/ao/ao_crytek.c)
 * ============================================================================================== */

/* (end of Crytek SSAO) */


/* ================================================================================================
 * Alchemy AO (src/ao/ao_alchemy.c)
 * ============================================================================================== */

/* (end of Alchemy AO) */


/* ================================================================================================
 * HBAO (src/ao/ao_hbao.c)
 * ============================================================================================== */

/* (end of HBAO) */


/* ================================================================================================
 * UE4 AO (src/ao/ao_ue4.c)
 * ============================================================================================== */

/* (end of UE4 AO) */


/* ================================================================================================
 * GTAO as XeGTAO (src/ao/ao_gtao.c)
 * ============================================================================================== */

/* (end of GTAO as XeGTAO) */


/* ================================================================================================
 * MSSAO (src/ao/ao_mssao.c)
 * ============================================================================================== */

/* (end of MSSAO) */


/* ================================================================================================
 * The seed's multi-resolution Alchemy AO (src/ao/ao_mssao_seed.c)
 * ============================================================================================== */

/* (end of The seed's multi-resolution Alchemy AO) */


/* ================================================================================================
 * Shared post-process blurs (src/ao/ao_blur.c)
 * ============================================================================================== */

/* The seed thesis' 21-tap separable Gaussian (ssao-thesis-2017 §4.2.3, Figura 31; the kernel of
 * Movania's OpenGL Development Cookbook SSAO recipe): w_i = exp(-i^2/16) / sum_j exp(-j^2/16) for
 * i = -10..10 (sigma = 2 sqrt 2 px, normalised over the 21 taps, printed with 9 decimals; the
 * float sum of the 21 weights is 1 - 1.2e-7). docs/ao/blur.md. */
#define AO_GAUSS21_RADIUS 10
extern const float ao_gauss21_kernel[2 * AO_GAUSS21_RADIUS + 1]; /* the shader's kernel[0..20] */

/* Blur a whole plane (our row order): a horizontal pass, then a vertical one, each
 * c = sum_{i=-10..10} kernel[10 - i] * tap(i) accumulated in float from 0 in that order, the
 * vertical taps at GL row y_gl + i (our row y - i), taps clamped to the plane's edge
 * (GL_CLAMP_TO_EDGE). No depth awareness: background pixels are blurred like any other (the seed
 * blurs the whole AO texture). in and out have the same size and may not alias.
 * Returns OK, INVALID_ARGUMENT, OUT_OF_MEMORY, LIMIT_EXCEEDED. */
obs_status ao_blur_gaussian21(obs_context *ctx, obs_pool *pool, const obs_image_f32 *in, obs_image_f32 *out);

/* The rectangle {x, y, w, h} of the full buffer that a kernel must compute so that a blur reaching
 * `reach` pixels (per pass, each side) gives, over in's window, what a GPU running both passes on the
 * whole buffer and cropping gives: the window grown by reach on each side, clipped to the buffer.
 * (Clamp-to-edge at a clipped side is the buffer's own edge, so it matches too.) */
void ao_blur_reach(const ao_input *in, int reach, int rect[4]);

/* (end of Shared post-process blurs) */


#ifdef __cplusplus
}
#endif

#endif /* AO_H */
