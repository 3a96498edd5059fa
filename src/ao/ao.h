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
 *     buffers produce the same numbers. Where the reference is HLSL with D3D's convention (rows
 *     from the top: XeGTAO, UE4, the classic HBAO SDK shader), its pixel (x, y) is our (x, y), no
 *     flip. Each technique's page says which convention it uses.
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
    const char *depth_channel;      /* NULL: "Z" if present, else "Zndc", else "depth", else "R", else
                                       the image's only channel when it has exactly one (logged) */
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
    int64_t renormalized_normal_pixels; /* surface pixels whose normal was not of length [0.5, 2]:
                                       renormalised (finite, nonzero) or set to 0 (no normal) */
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
 * when the build and the CPU have it, the AO pass's cos/sin on AVX-512F where the CPU also has
 * that (the environment's OBS_ISA=scalar forces the scalar path, OBS_ISA=avx2 at most AVX2); all
 * paths give the same bytes (docs/ao/sao.md, "Speed"). The call keeps its planes in ctx for the
 * next call with ctx (freed by obs_context_destroy or obs_context_scratch_release).
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

/* Crytek SSAO [Kajalin09] (Vladimir Kajalin, "Screen-Space Ambient Occlusion", ShaderX7 §6.1,
 * CryEngine 2): 8 cube-corner offsets per round, each scaled by a growing offsetScale, rotated per
 * pixel by a matrix built from a 4x4 tiled rotation texture, a depth-buffer visibility test with
 * the "range check" lerp(dS > S.z ? 1 : 0, 0.5, saturate((dP - dS)/dS)), A = acc / N, output
 * saturate(A^2 + A). A flat open plane gives A = 1/2, i.e. 0.75. docs/ao/crytek.md. */

#define AO_CRYTEK_DEFAULT_RADIUS 0.5f       /* m, > 0: the world-space ball radius (space "world"); our
                                               choice (the original is screen-space and has none):
                                               XeGTAO's default Radius, the truth module's default */
#define AO_CRYTEK_DEFAULT_SAMPLES 16        /* N in {4, 8, 16, ..., 256}; ShaderX7 "nSamplesNum = 16" */
#define AO_CRYTEK_DEFAULT_OFFSET_SCALE 0.01f /* > 0, UV units; ShaderX7 "float offsetScale = 0.01"
                                               (the compute port 11093304203 uses 0.001) */
#define AO_CRYTEK_DEFAULT_DEPTH_SCALE 2.0f  /* ShaderX7 "vRotatedOffset.z * fSceneDepthP * 2" (space
                                               "screen" only; fixed, not a parameter) */
#define AO_CRYTEK_MAX_SAMPLES 256
#define AO_CRYTEK_ROT_TILE 4                /* the rotation texture is 4x4, tiled over the screen */

typedef enum ao_crytek_space {
    AO_CRYTEK_SPACE_WORLD = 0,      /* default: the taps fill a world-space ball of radius r (metres)
                                       at every pixel (our mapping, docs/ao/crytek.md) */
    AO_CRYTEK_SPACE_SCREEN,         /* the original: offsets in UV units scaled by offset_scale,
                                       depth offset o.z * dP * 2 (radius grows with depth) */
    AO_CRYTEK_SPACE_COUNT
} ao_crytek_space;

typedef enum ao_crytek_sky {
    AO_CRYTEK_SKY_VISIBLE = 0,      /* default: a tap on background adds 1 (the ReShade copies'
                                       fSSAODepthClip branch; what the original gives when the sky
                                       is cleared to the far plane) */
    AO_CRYTEK_SKY_SKIP,             /* the compute port (11093304203): the tap adds nothing, but A is
                                       still acc / N (so sky darkens) */
    AO_CRYTEK_SKY_COUNT
} ao_crytek_sky;

typedef enum ao_crytek_filter {
    AO_CRYTEK_FILTER_LINEAR = 0,    /* default: bilinear depth fetch (the HLSL effect copy 18810930753:
                                       g_SceneDepthSampler MinFilter = MagFilter = Linear); a footprint
                                       touching background falls back to the nearest texel */
    AO_CRYTEK_FILTER_NEAREST,       /* the texel containing S.xy (the compute port's integer fetch) */
    AO_CRYTEK_FILTER_COUNT
} ao_crytek_filter;

typedef enum ao_crytek_output {
    AO_CRYTEK_OUTPUT_REMAP = 0,     /* default: saturate(A^2 + A), the original's output */
    AO_CRYTEK_OUTPUT_ACCESSIBILITY, /* A = acc / N itself (the quantity the "vol" truth estimates) */
    AO_CRYTEK_OUTPUT_COUNT
} ao_crytek_output;

typedef struct ao_crytek_params {
    ao_crytek_space space;
    float radius;           /* world: ball radius, metres */
    float offset_scale;     /* the initial offsetScale (UV units in space "screen"; in "world" only
                               the ratios of the tap radii matter, which do not depend on it) */
    int samples;            /* N: 4, or a multiple of 8 up to AO_CRYTEK_MAX_SAMPLES (N/8 rounds of the
                               8 corners; 4 = the two antipodal pairs of corners with y = z) */
    ao_crytek_sky sky;
    ao_crytek_filter filter;
    ao_crytek_output output;
    int blur;               /* 1: the seed thesis' 21-tap separable Gaussian (ao_blur_gaussian21) */
} ao_crytek_params;

/* Defaults (AO_CRYTEK_DEFAULT_*): space world, r = 0.5 m, N = 16, sky visible, remapped output,
 * blur on (the seed thesis blurs every technique's AO). */
ao_crytek_params ao_crytek_params_default(void);

/* Named presets. Returns 1 and fills *out, or 0 for an unknown name.
 *   "default": ao_crytek_params_default().
 *   "kajalin": the ShaderX7 listing exactly: space screen, offsetScale 0.01, N = 16, no blur (the
 *              listing is the AO pass alone). Every depth quantity of the original is a ratio, so
 *              the result does not depend on the far plane the copies normalise depth by.
 *   "compute-port": the DirectCompute copy (11093304203): as "kajalin" with offsetScale 0.001 and
 *              sky taps skipped. */
int ao_crytek_params_preset(const char *name, ao_crytek_params *out);
const char *const *ao_crytek_preset_names(void);   /* NULL-terminated */

/* Returns OK or INVALID_ARGUMENT naming the field and its range. */
obs_status ao_crytek_params_validate(obs_context *ctx, const ao_crytek_params *p);

/* Resolved params as one line ("space=world radius=0.5 ..."); snprintf semantics. */
int ao_crytek_params_to_string(const ao_crytek_params *p, char *buf, size_t size);

/* The rotation texture: 16 unit vectors vRotation, texel (i, j) at index 4 j + i, where i = x_gl % 4
 * and j = y_gl % 4 (GL pixel coordinates; row j = 0 is the bottom row of a GL texture upload, so a
 * port uploads this array as a 4x4 RGB32F texture with GL_REPEAT / GL_NEAREST and fetches texel
 * ivec2(gl_FragCoord.xy) & 3). Generator (docs/ao/crytek.md): texel (i, j) holds vector
 * k = bayer4[j][i] (the 4x4 Bayer matrix {0 8 2 10 / 12 4 14 6 / 3 11 1 9 / 15 7 13 5}) of the
 * golden-angle spiral over the upper hemisphere, z_k = 1 - (k + 1/2)/16, phi_k = k pi (3 - sqrt 5),
 * r_k = (sqrt(1 - z_k^2) cos phi_k, sqrt(1 - z_k^2) sin phi_k, z_k), evaluated in double and rounded
 * to float. z > 0 keeps h = 1/(1 + z) <= 1, far from the matrix's singularity at z = -1. */
extern const float ao_crytek_rotation[AO_CRYTEK_ROT_TILE * AO_CRYTEK_ROT_TILE][3];

/* The rotation matrix of ao.md 1.1 / ShaderX7 for vector r, h = 1/(1 + r.z), float, row-major
 * m[3 i + j] = rotMat._m(i)(j):
 *   [h ry^2 + rz, -h ry rx, -rx;  -h ry rx, h rx^2 + rz, -ry;  rx, ry, rz]
 * (for a unit r: the smallest rotation taking +z to r, applied as the row vector v * M). */
void ao_crytek_rotation_matrix(const float r[3], float m[9]);

/* The constant block a shader port needs, field for field (float32). */
typedef struct ao_crytek_constants {
    int full_width, full_height;    /* the GL pixel grid the pattern lives on */
    int orthographic;               /* the input's projection (world space only) */
    int space, sky, filter, output, blur; /* the enums above; blur 0/1 */
    int num_samples;                /* N */
    float inv_size[2];              /* 1/W, 1/H: uv = (vec2(p) + 0.5) * inv_size */
    float size[2];                  /* W, H: nearest texel clamp(floor(S.xy * size), 0, size - 1);
                                       linear: GL_LINEAR at S.xy * size - 0.5, CLAMP_TO_EDGE */
    float offset_scale;             /* the initial offsetScale */
    float offset_scale_step;        /* 1.0f + 2.4f / float(N) */
    float inv_corner;               /* normalize(+-1, +-1, +-1) = +-1/sqrt(3), correctly rounded */
    float kxy[2];                   /* S.xy = uv + R.xy * kxy (screen: 1; world, perspective: divided
                                       by dP per pixel; world: (r / s_N) (fx/W, fy/H)) */
    float kz;                       /* S.z = dP + R.z * kz (screen: 2, times dP per pixel; world: r / s_N m) */
    float ray[4];                   /* world, perspective: pixel ray slopes a = ray.xy + p * ray.zw
                                       (p in GL pixels): uv' = uv + kxy (R.xy - a R.z) / S.z */
    float num_samples_f;            /* float(N): A = acc / float(N) */
    float offsets[AO_CRYTEK_MAX_SAMPLES][3];  /* vOffset_t = normalize(corner_t) * (offsetScale *= step) */
    float rot_mat[AO_CRYTEK_ROT_TILE * AO_CRYTEK_ROT_TILE][9]; /* ao_crytek_rotation_matrix per texel */
} ao_crytek_constants;

/* The pure params -> constants step (in gives the buffer size and the pixel model). Params are
 * assumed validated. */
void ao_crytek_constants_from_params(const ao_crytek_params *p, const ao_input *in, ao_crytek_constants *k);

/* Crytek SSAO over the input's window. out (required) and out_raw (optional) are w x h planes in
 * our row order: out gets the blurred AO when params->blur, else the raw AO; out_raw the AO before
 * the blur. With the blur, the AO pass runs over the window plus the blur's 10 px reach (inside the
 * buffer), so the result equals a GPU running both passes over the whole buffer and cropping.
 * stats may be NULL. Returns OK, INVALID_ARGUMENT (input, params, plane sizes), OUT_OF_MEMORY,
 * LIMIT_EXCEEDED. */
obs_status ao_crytek_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_crytek_params *params,
                             obs_image_f32 *out, obs_image_f32 *out_raw, ao_stats *stats);

/* As ao_crytek_compute with an explicit constant block (k->full_width/height must match). */
obs_status ao_crytek_compute_constants(obs_context *ctx, obs_pool *pool, const ao_input *in,
                                       const ao_crytek_constants *k, obs_image_f32 *out, obs_image_f32 *out_raw,
                                       ao_stats *stats);

/* The instruction set of the AO pass: AUTO (AVX2 where the CPU and build have it, unless the
 * environment sets OBS_ISA=scalar), the scalar reference, or AVX2 (8 pixels of a row per vector).
 * Every ISA gives the same bytes (docs/ao/crytek.md, "Speed"). */
typedef enum ao_crytek_isa {
    AO_CRYTEK_ISA_AUTO = 0,
    AO_CRYTEK_ISA_SCALAR,
    AO_CRYTEK_ISA_AVX2,
    AO_CRYTEK_ISA_COUNT
} ao_crytek_isa;

/* 1 if this CPU and build can run isa (AUTO and SCALAR always), else 0. */
int ao_crytek_isa_available(ao_crytek_isa isa);

/* As ao_crytek_compute_constants on a chosen ISA. Returns as ao_crytek_compute_constants, and
 * UNSUPPORTED_ISA when isa is not available (ao_crytek_isa_available). */
obs_status ao_crytek_compute_constants_isa(obs_context *ctx, obs_pool *pool, const ao_input *in,
                                           const ao_crytek_constants *k, ao_crytek_isa isa, obs_image_f32 *out,
                                           obs_image_f32 *out_raw, ao_stats *stats);

/* (end of Crytek SSAO) */


/* ================================================================================================
 * Alchemy AO (src/ao/ao_alchemy.c)
 *
 * The Alchemy screen-space ambient obscurance algorithm [McGuire11] (McGuire, Osman, Bukowski,
 * Hennessy, HPG 2011): per pixel, s taps on a screen-space disk of the projected world radius r,
 * placed on SAO's HPG12 spiral with its per-pixel hash (ao_sao_spin, GL pixel coordinates; SAO_AO.pix
 * credits the hash to the Alchemy paper; the HPG11 paper's own pattern is not verified), and
 *   A = max(0, 1 - (2 sigma / s) * sum_i max(0, v_i.n + z_C beta) / (v_i.v_i + epsilon))^k
 * with v_i = Q_i - C (camera space, z_C < 0), taps with v_i.v_i >= r^2 skipped (as SAO_AO.pix's
 * falloff A, "From the HPG12 paper"; optional), n the pixel's unit normal (the G-buffer's when the
 * input has normals, else ao_normals_from_depth). docs/ao/alchemy.md has every detail.
 * ============================================================================================== */

/* Defaults: the paper's and its authors' HPG11 talk values ([McGuire11], talk "Equation" slide,
 * ../shared/reference/verification.md section 1), the spiral of the SAO HPG12 shader. */
#define AO_ALCHEMY_DEFAULT_RADIUS 0.5f      /* r, m, > 0; secondary design note "r = 0.5 m" [U] */
#define AO_ALCHEMY_DEFAULT_BIAS 1e-4f       /* beta, >= 0 (scaled by z_C); talk: "e.g., 10^-4" */
#define AO_ALCHEMY_DEFAULT_INTENSITY 1.0f   /* sigma, >= 0, artistic; talk: "e.g., 1.0" */
#define AO_ALCHEMY_DEFAULT_CONTRAST 1.0f    /* k, > 0, artistic; talk: "e.g., 1.0" */
#define AO_ALCHEMY_DEFAULT_EPSILON 1e-5f    /* epsilon, m^2, > 0; talk: "e.g., 10^-5" */
#define AO_ALCHEMY_DEFAULT_SAMPLES 12       /* s in [1, AO_ALCHEMY_MAX_SAMPLES]; paper Fig. 1 "12 samples" */
#define AO_ALCHEMY_DEFAULT_SPIRAL_TURNS 7   /* tau >= 1; HPG12 SAO_AO.pix NUM_SPIRAL_TURNS (the paper's
                                               own value was not verified) */
#define AO_ALCHEMY_MAX_SAMPLES 1024

typedef enum ao_alchemy_normals {
    AO_ALCHEMY_NORMALS_AUTO = 0,    /* default: the G-buffer's when the input has them (the paper reads
                                       a normal buffer), else ao_normals_from_depth */
    AO_ALCHEMY_NORMALS_GBUFFER,     /* the G-buffer's; INVALID_ARGUMENT when the input has none */
    AO_ALCHEMY_NORMALS_DEPTH,       /* always ao_normals_from_depth */
    AO_ALCHEMY_NORMALS_COUNT
} ao_alchemy_normals;

typedef struct ao_alchemy_params {
    float radius;           /* r: world-space radius of the sample disk, metres */
    float bias;             /* beta: the shadow bias, multiplied by the pixel's z_C (so in m/m) */
    float intensity;        /* sigma */
    float contrast;         /* k */
    float epsilon;          /* m^2 */
    int samples;            /* s */
    int spiral_turns;       /* tau */
    ao_alchemy_normals normals;
    int range_check;        /* 1 (default): only taps with v.v < r^2 count (as SAO_AO.pix falloff A,
                               "From the HPG12 paper"); 0: every tap in the disk (as printed) */
    int blur;               /* 1: the seed's 21-tap Gaussian (ao_blur_gaussian21) after the AO pass */
} ao_alchemy_params;

/* The paper's defaults (AO_ALCHEMY_DEFAULT_*), blur on. */
ao_alchemy_params ao_alchemy_params_default(void);

/* Named presets. Returns 1 and fills *out, or 0 for an unknown name.
 *   "default", "hpg11": ao_alchemy_params_default() (the paper's and talk's values).
 *   "thesis": the seed thesis' Table 3 (ssao-thesis-2017): r = 1 m, 16 samples; the rest default.
 *   "port": the third-party AlchemyHPG11 GLSL ports ("From paper AlchemyHPG11 and improvements
 *           SAOHPG12"): sigma 1, k 1.5, beta 0.002, epsilon 1e-5, tau 7, 16 samples, r 1 m. */
int ao_alchemy_params_preset(const char *name, ao_alchemy_params *out);
/* The preset names, NULL-terminated. */
const char *const *ao_alchemy_preset_names(void);

/* Check params. Returns OK or INVALID_ARGUMENT naming the field and its range. */
obs_status ao_alchemy_params_validate(obs_context *ctx, const ao_alchemy_params *p);

/* Resolved params as one line of text. snprintf semantics. */
int ao_alchemy_params_to_string(const ao_alchemy_params *p, char *buf, size_t size);

/* The shader's constant block (uniforms), float32. */
typedef struct ao_alchemy_constants {
    int full_width, full_height;    /* the buffer the shader runs over (GL pixel grid) */
    int orthographic;               /* 0: perspective; 1: orthographic */
    int normals_from_gbuffer;       /* 1: the G-buffer's normals; 0: ao_normals_from_depth */
    /* csPos(s, z) = vec3((vec2(s) + 0.5) * projInfo.xy + projInfo.zw, 1) * z (perspective; z < 0),
     * s in GL pixel coordinates, as ao_sao_constants.proj_info (orthographic: xy not times z). */
    float proj_info[4];
    float proj_scale;               /* pixels per metre at 1 m: fy */
    float radius, radius2, bias, intensity, contrast, epsilon;
    int range_check;                /* 1: taps count only when v.v < radius2 */
    int num_samples, num_spiral_turns;
    float inv_num_samples;          /* 1.0 / float(s) */
    float turns_angle;              /* float(tau) * 6.28 (the HPG12 spiral's constant) */
    float intensity_scale;          /* (2.0 * sigma) / float(s) */
    int blur;
} ao_alchemy_constants;

/* The pure params -> constants step. in gives the buffer size and the pixel model; normals_from_gbuffer
 * resolves AUTO against in. Params are assumed validated. */
ao_alchemy_constants ao_alchemy_constants_from_params(const ao_alchemy_params *p, const ao_input *in);

typedef struct ao_alchemy_stats {
    int64_t pixels_computed;        /* pixels the AO pass ran on (window plus blur reach) */
    int64_t pixels_background;      /* of those: background (visibility 1) */
    int64_t pixels_degenerate_normal; /* of those: zero or non-finite normal (visibility 1) */
    double seconds_normals, seconds_ao, seconds_blur;
} ao_alchemy_stats;

/* Alchemy AO over the input's window. out (required) and out_raw (optional) are w x h planes. The
 * AO pass runs over the window plus the blur's reach (AO_GAUSS21_RADIUS px each side, inside the
 * buffer) when params->blur, so that the result equals a GPU running both passes over the whole
 * buffer and cropping. stats may be NULL.
 * Returns: OK; INVALID_ARGUMENT (input, params, planes, GBUFFER normals without normals);
 * OUT_OF_MEMORY; LIMIT_EXCEEDED. */
obs_status ao_alchemy_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_alchemy_params *params,
                              obs_image_f32 *out, obs_image_f32 *out_raw, ao_alchemy_stats *stats);

/* The building block (also the kernel of every mssao-seed level): the raw (unblurred) Alchemy AO over
 * the rectangle rect = {x, y, w, h} of the full buffer (our row order) into out (w x h). normals: the
 * unit view-space normal planes to use (full buffer size, our row order; the G-buffer's or
 * ao_normals_from_depth's), required. counts (may be NULL) receives {background, degenerate normal}.
 * Returns OK or INVALID_ARGUMENT. */
obs_status ao_alchemy_raw(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_alchemy_constants *k,
                          const obs_image_f32 *const normals[3], const int rect[4], obs_image_f32 *out,
                          int64_t counts[2]);

/* The instruction set of the AO pass. Every ISA gives the same bits (the AVX2 path evaluates the
 * scalar path's float and double operations, in the same order, eight pixels per vector; tested). */
typedef enum ao_alchemy_isa {
    AO_ALCHEMY_ISA_AUTO = 0,        /* AVX512, else AVX2, when the CPU and the build have it, unless OBS_ISA says */
    AO_ALCHEMY_ISA_SCALAR,          /* the reference path, always compiled */
    AO_ALCHEMY_ISA_AVX2,            /* OBS_HAVE_AVX2 builds on AVX2 CPUs */
    AO_ALCHEMY_ISA_AVX512,          /* AVX2 with the taps' cos/sin on 8 doubles per register (AVX-512F; GCC
                                       x86-64 builds); AUTO's first choice unless OBS_ISA=avx2 or scalar */
    AO_ALCHEMY_ISA_COUNT
} ao_alchemy_isa;

/* 1 if isa can run here (AUTO and SCALAR always). */
int ao_alchemy_isa_available(ao_alchemy_isa isa);

/* ao_alchemy_raw on a chosen ISA (ao_alchemy_raw is AUTO). Returns as ao_alchemy_raw, and
 * UNSUPPORTED_ISA where isa cannot run here. */
obs_status ao_alchemy_raw_isa(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_alchemy_constants *k,
                              const obs_image_f32 *const normals[3], const int rect[4], obs_image_f32 *out,
                              int64_t counts[2], ao_alchemy_isa isa);

/* The constant block as one JSON object (the uniforms a shader port needs). snprintf semantics. */
int ao_alchemy_constants_to_json(const ao_alchemy_constants *k, char *buf, size_t size);

/* The tap of sample i of the pixel at GL coordinates (x_gl, y_gl) with screen-space disk radius
 * disk_px: the integer offset (ivec2(ssR * (cos, sin))) added to the pixel, before the clamp to the
 * buffer. Exposed for validation (the sample pattern). */
void ao_alchemy_tap_offset(const ao_alchemy_constants *k, int x_gl, int y_gl, float disk_px, int i, int offset[2]);

/* (end of Alchemy AO) */


/* ================================================================================================
 * HBAO (src/ao/ao_hbao.c)
 *
 * Horizon-Based Ambient Occlusion [Bavoil08] (Bavoil, Sainz, Dimitrov, SIGGRAPH 2008 talk;
 * ShaderX7), two variants, each exact to its reference shader (docs/ao/hbao.md):
 *   - CLASSIC: the NVIDIA DX10 SDK sample HorizonBasedAOEngine.fx, HORIZON_BASED_AO_PS with
 *     qualityMode 1 (AccumulatedHorizonOcclusion: horizon angle, angle bias, W(r) = 1 - att r^2);
 *   - PLUS: HBAO+'s per-tap form as nvpro-samples/gl_ssao hbao.frag.glsl computes it on its
 *     non-deinterleaved path (AO_DEINTERLEAVED 0): saturate(N.V/|V| - NDotVBias) *
 *     saturate(1 - |V|^2/R^2), out = saturate(1 - 2 AO (1/(1-bias))/(dirs steps))^PowExponent.
 * and the HBAO+-style separable cross-bilateral blur (HBAOPlus Blur_Common.hlsl, gl_ssao
 * bilateralblur.frag.glsl), public so that other methods can use it.
 * ============================================================================================== */

/* Defaults (CLASSIC: the DX10 SDK sample's HorizonBasedAOEngine constructor, verification.md 2;
 * PLUS: HBAO+ GFSDK_SSAO.h / gl_ssao, ao.md 1.6). */
#define AO_HBAO_DEFAULT_RADIUS 1.0f          /* R (m) > 0; SDK: m_RadiusMultiplier 1.0 x the app's
                                                m_AORadius (scene-dependent, not in the sample);
                                                HBAO+ GFSDK_SSAO_Parameters Radius(1.f) */
#define AO_HBAO_DEFAULT_DIRECTIONS_CLASSIC 16 /* [1, 32]; SDK m_NumDirs 16 (UpdateDirs clamps to 32) */
#define AO_HBAO_DEFAULT_STEPS_CLASSIC 8      /* [1, 32]; SDK m_NumSteps 8 */
#define AO_HBAO_DEFAULT_DIRECTIONS_PLUS 8    /* [1, 32]; gl_ssao NUM_DIRECTIONS 8, HBAO+ SharedDefines.h */
#define AO_HBAO_DEFAULT_STEPS_PLUS 4         /* [1, 32]; gl_ssao NUM_STEPS 4, HBAO+ STEP_COUNT_4 */
#define AO_HBAO_DEFAULT_ANGLE_BIAS_DEG 30.0f /* [0, 89] degrees; SDK m_AngleBias 30 (slider 0..60) */
#define AO_HBAO_DEFAULT_ATTENUATION 1.0f     /* >= 0; SDK m_Attenuation 1.0 (slider 0..1): W = 1 - att r^2 */
#define AO_HBAO_DEFAULT_CONTRAST 1.4f        /* >= 0, artistic; SDK m_Contrast 1.4; the shader gets
                                                g_Contrast = contrast / (1 - sin(angle bias)) */
#define AO_HBAO_DEFAULT_NDOTV_BIAS 0.1f      /* [0, 1); gl_ssao Tweak bias 0.1, HBAO+ Bias(0.1f) */
#define AO_HBAO_DEFAULT_POW_EXPONENT 2.0f    /* >= 0; HBAO+ PowerExponent(2.f) (gl_ssao intensity 1.5) */
#define AO_HBAO_DEFAULT_BLUR_RADIUS 4        /* KERNEL_RADIUS [1, 16]; HBAO+ GFSDK_SSAO_BLUR_RADIUS_4
                                                (gl_ssao 3) */
#define AO_HBAO_DEFAULT_BLUR_SHARPNESS 16.0f /* >= 0, per metre; HBAO+ Blur.Sharpness(16.f) (gl_ssao 40) */
#define AO_HBAO_MAX_DIRECTIONS 32
#define AO_HBAO_MAX_STEPS 32
#define AO_HBAO_MAX_BLUR_RADIUS 16
#define AO_HBAO_NOISE_SIZE 4                 /* gl_ssao's random texture is 4 x 4 (AO_RANDOMTEX_SIZE;
                                                ao.md 1.6) */
#define AO_HBAO_NOISE_SIZE_SDK 64            /* the DX10 SDK sample's is 64 x 64 (HorizonBasedAOEngine.cpp
                                                UpdateDirs; the .fx reads it at pos & 63) */

typedef enum ao_hbao_variant {
    AO_HBAO_VARIANT_CLASSIC = 0,    /* default: DX10 SDK HorizonBasedAOEngine.fx, quality mode 1 */
    AO_HBAO_VARIANT_PLUS,           /* HBAO+ per-tap form, gl_ssao hbao.frag.glsl (non-deinterleaved) */
    AO_HBAO_VARIANT_COUNT
} ao_hbao_variant;

typedef enum ao_hbao_normals {
    AO_HBAO_NORMALS_DEPTH = 0,      /* default: the reference's own reconstruction from depth (MinDiff
                                       neighbours: CLASSIC's dPdu/dPdv tangent basis, PLUS's
                                       ReconstructNormal) */
    AO_HBAO_NORMALS_GBUFFER,        /* the input's normals: CLASSIC's useNormal path (neighbours
                                       projected onto the tangent plane); PLUS: N = the G-buffer's */
    AO_HBAO_NORMALS_COUNT
} ao_hbao_normals;

/* The random (jitter) texture. */
typedef enum ao_hbao_noise {
    AO_HBAO_NOISE_AUTO = 0,         /* default: the variant's reference: SDK for CLASSIC, GL_SSAO for PLUS */
    AO_HBAO_NOISE_SDK,              /* 64 x 64, the DX10 SDK sample's UpdateDirs (ao_hbao_noise_texture_sdk) */
    AO_HBAO_NOISE_GL_SSAO,          /* 4 x 4, gl_ssao's Sample::initMisc (ao_hbao_noise_texture) */
    AO_HBAO_NOISE_COUNT
} ao_hbao_noise;

typedef struct ao_hbao_params {
    ao_hbao_variant variant;
    float radius;           /* R: world-space radius of influence, metres */
    int directions;         /* N_d; 0 = the variant's default (16 CLASSIC, 8 PLUS) */
    int steps;              /* N_s per direction; 0 = the variant's default (8 CLASSIC, 4 PLUS) */
    float angle_bias_deg;   /* CLASSIC: angle bias (degrees) added to the tangent angle */
    float attenuation;      /* CLASSIC: W(r) = 1 - attenuation r^2, r = |S - P| / R */
    float contrast;         /* CLASSIC: m_Contrast; AO = 1 - ao / N_d * contrast / (1 - sin(bias)) */
    float ndotv_bias;       /* PLUS: NDotVBias */
    float pow_exponent;     /* PLUS: PowExponent */
    float small_scale_ao;   /* PLUS: 0 = gl_ssao's form (every step weighs 1, the default); > 0 = HBAO+
                               CoarseAO_PS: the first step weighs 2 * small_scale_ao, the others 1
                               (LargeScaleAO 1), and RadiusPixels < 1 gives 1 */
    ao_hbao_normals normals;
    ao_hbao_noise noise;    /* the random texture; AUTO = the variant's reference (hbao.md) */
    int blur;               /* 1: ao_hbao_blur after the AO pass */
    int blur_radius;        /* KERNEL_RADIUS: taps 1..R each side, point-sampled */
    float blur_sharpness;   /* per metre of linear depth */
    float blur_sigma;       /* pixels; 0 = HBAO+'s (KERNEL_RADIUS + 1) / 2 (gl_ssao: KERNEL_RADIUS / 2) */
    int blur_depth_slope;   /* 1: HBAO+ USE_DEPTH_SLOPE (offset the centre depth along the slope) */
} ao_hbao_params;

/* CLASSIC with the SDK defaults, blur on (radius 4, sharpness 16, depth slope on). */
ao_hbao_params ao_hbao_params_default(void);

/* Named presets. Returns 1 and fills *out, or 0 for an unknown name.
 *   "default", "sdk": ao_hbao_params_default() (the DX10 SDK sample's constructor values).
 *   "plus": PLUS with HBAO+'s GFSDK_SSAO_Parameters defaults: R 1 m, bias 0.1, PowerExponent 2,
 *           8 directions x 4 steps, blur radius 4, sharpness 16, depth slope on, gl_ssao's
 *           unsplit sum (small_scale_ao 0).
 *   "hbaoplus": "plus" with HBAO+'s SmallScaleAO(1.f) split (small_scale_ao 1).
 *   "gl-ssao": PLUS with gl_ssao's Tweak defaults: R 2 m, bias 0.1, intensity (PowExponent) 1.5,
 *           bilateralblur.frag.glsl: radius 3, sigma 1.5, sharpness 40, no depth slope. */
int ao_hbao_params_preset(const char *name, ao_hbao_params *out);
const char *const *ao_hbao_preset_names(void);

/* Check params. Returns OK or INVALID_ARGUMENT naming the field and its range. */
obs_status ao_hbao_params_validate(obs_context *ctx, const ao_hbao_params *p);

/* Resolved params as one line of text. snprintf semantics. */
int ao_hbao_params_to_string(const ao_hbao_params *p, char *buf, size_t size);

/* The shader's constant block (the DX10 sample's cb0/cb1, gl_ssao's HBAOData), float32.
 * uv is the shader's texture coordinate of the full buffer: CLASSIC: D3D (x right, y DOWN,
 * uv = ((x + 0.5)/W, (y + 0.5)/H) with our row y); PLUS: GL (y UP, uv.y = (y_gl + 0.5)/H).
 * View position of uv at linear depth z (> 0, the reference's eye_z): perspective
 * (uv * uv_to_view.xy + uv_to_view.zw) * z, orthographic the same without "* z" (PLUS's projOrtho;
 * an extension for CLASSIC), with x right, y UP, z = depth INTO the screen (the references'
 * eye space). */
typedef struct ao_hbao_constants {
    int full_width, full_height;
    int variant, orthographic, normals_from_gbuffer;
    int num_dirs, num_steps;        /* g_NumDir, g_NumSteps / NUM_DIRECTIONS, NUM_STEPS */
    int noise;                      /* the resolved random texture: AO_HBAO_NOISE_SDK or _GL_SSAO */
    int noise_size;                 /* its width and height: 64 (SDK) or 4 (gl_ssao) */
    float uv_to_view[4];            /* CLASSIC (W/fx, -H/fy, -cx/fx, cy/fy); PLUS = gl_ssao projInfo
                                       (W/fx, H/fy, -cx/fx, -(H - cy)/fy) */
    float resolution[2], inv_resolution[2];   /* g_Resolution, g_InvResolution / InvFullResolution */
    /* CLASSIC (cb1) */
    float focal_len[2];             /* g_FocalLen = (2 fx / W, 2 fy / H) (1/tan(fov/2) when centred) */
    float R, inv_R, sqr_R;          /* g_R, g_inv_R, g_sqr_R */
    float angle_bias, tan_angle_bias; /* g_AngleBias (radians), g_TanAngleBias */
    float attenuation;              /* g_Attenuation */
    float contrast;                 /* g_Contrast = m_Contrast / (1 - sin(g_AngleBias)) */
    float dirs[AO_HBAO_MAX_DIRECTIONS][2]; /* cb0 g_Dirs[d] = (cosf, sinf)(inc * d), inc = 2 pi_f / N_d in
                                       float (UpdateDirs) */
    /* PLUS (HBAOData) */
    float radius_to_screen;         /* RadiusToScreen = R * 0.5 / tan(fovy/2) * H = R fy (HBAO+) */
    float R2, neg_inv_R2;           /* R2, NegInvR2 = -1 / R2 */
    float ndotv_bias;               /* NDotVBias */
    float ao_multiplier;            /* AOMultiplier = 1 / (1 - NDotVBias) */
    float pow_exponent;             /* PowExponent */
    float small_scale_amount;       /* 0: gl_ssao form; else HBAO+ fSmallScaleAOAmount = Small * 2 / (1 - bias) */
    float large_scale_amount;       /* HBAO+ fLargeScaleAOAmount = 1 / (1 - bias) (LargeScaleAO 1) */
    float alpha;                    /* Alpha = 2.0 * M_PI / NUM_DIRECTIONS (M_PI = 3.14159265f) */
    float plus_dirs[AO_HBAO_MAX_DIRECTIONS][2]; /* (cos, sin)(Alpha * d), the loop-invariant values a
                                       compiler folds when it unrolls the direction loop */
    /* the blur */
    int blur, blur_radius, blur_depth_slope;
    float blur_sharpness;           /* g_Sharpness */
    float blur_falloff;             /* BlurFalloff = 1 / (2 sigma^2) */
} ao_hbao_constants;

/* The pure params -> constants step. Params are assumed validated. */
ao_hbao_constants ao_hbao_constants_from_params(const ao_hbao_params *p, const ao_input *in);

/* The 4 x 4 random texture of gl_ssao, (cos(alpha), sin(alpha), jitter, 0) per texel, for num_dirs
 * directions, exactly as gl_ssao's Sample::initMisc: MT19937 (Matsumoto-Nishimura,
 * init_genrand(0)), per texel i = 0..15 in order: r1 = float(genrand_int32() * 2^-32), r2 = the
 * same; alpha = 2.f * pi_f * r1 / float(num_dirs) in float; (cosf, sinf)(alpha) correctly rounded;
 * stored as RGBA16_SNORM: c = (short)(32768 * v) truncated (clamped to 32767), decoded
 * v' = c / 32767 (GL's SNORM rule; the value we use). Texel i has texture coordinates
 * (i % 4, i / 4) in upload order (GL: row i/4 from the BOTTOM; D3D: from the TOP). shorts (may be
 * NULL) gets the 64 int16 to upload; texels the decoded floats. num_dirs in [1, 32]. */
void ao_hbao_noise_texture(int num_dirs, int16_t shorts[AO_HBAO_NOISE_SIZE * AO_HBAO_NOISE_SIZE * 4],
                           float texels[AO_HBAO_NOISE_SIZE * AO_HBAO_NOISE_SIZE][4]);

/* The 64 x 64 random texture of the DX10 SDK sample (HorizonBasedAOEngine.cpp UpdateDirs, read in
 * full for hbao.md): MTRand seeded with 0 (init_genrand(0)), then for texel i = 0 .. 4095 in order
 *   float angle = 2.0f*D3DX_PI * rng.randExc() / (float)m_NumDirs;   (double arithmetic, rounded
 *                                                                     to float once)
 *   f[4i] = (short)(SCALE*cos(angle)); f[4i+1] = (short)(SCALE*sin(angle));   (cosf/sinf of the float
 *                                                                     angle; SCALE = 1 << 15)
 *   f[4i+2] = (short)(SCALE*rng.randExc());                           (double: genrand >> 17)
 *   f[4i+3] = 0;
 * randExc = genrand_int32() * 2^-32 in double, D3DX_PI = 3.141592654f; truncation toward zero,
 * 32768 * 1.0 clamped to 32767 (not reached for N_d 1 .. 32). Uploaded as
 * DXGI_FORMAT_R16G16B16A16_SNORM with a pitch of 64 texels: texel i is (i % 64, i / 64), row 0 at
 * the TOP (D3D); decoded c / 32767 (D3D10 SNORM, -32768 -> -1). shorts (may be NULL) gets the
 * 16384 int16, texels the decoded floats. num_dirs in [1, 32]. */
void ao_hbao_noise_texture_sdk(int num_dirs, int16_t shorts[AO_HBAO_NOISE_SIZE_SDK * AO_HBAO_NOISE_SIZE_SDK * 4],
                               float texels[AO_HBAO_NOISE_SIZE_SDK * AO_HBAO_NOISE_SIZE_SDK][4]);

/* The texel index a pixel reads, in the variant's own pixel coordinates, for the resolved texture
 * of size n = k->noise_size: CLASSIC tRandom.Load(int3(SV_Position.x & 63, SV_Position.y & 63))
 * (n = 64; & 3 with gl_ssao's) with D3D y (our row y); PLUS texture(texRandom, gl_FragCoord.xy / n)
 * (REPEAT, NEAREST) with GL y (y_gl = H - 1 - y). Returns (iy & (n-1)) * n + (ix & (n-1)). */
int ao_hbao_noise_index(const ao_hbao_constants *k, int x, int y);

typedef struct ao_hbao_stats {
    int64_t pixels_computed;        /* AO-pass pixels (window plus blur reach) */
    int64_t pixels_background;      /* of those: background (visibility 1) */
    int64_t pixels_small_radius;    /* CLASSIC: projected radius < 1 px ("numSteps < 1": visibility 1) */
    int64_t pixels_degenerate_normal; /* no usable normal: PLUS from depth, or a G-buffer's (visibility 1) */
    double seconds_prepare, seconds_ao, seconds_blur;
} ao_hbao_stats;

/* HBAO over the input's window. out (required) and out_raw (optional) are w x h planes (our row
 * order); out gets the blurred AO when params->blur, else the raw AO. The AO pass runs over the
 * window plus the blur's reach (blur_radius pixels each side, inside the buffer), so that the
 * result equals a GPU running both passes over the whole buffer and cropping. Values in [0, 1].
 * Returns: OK; INVALID_ARGUMENT (input, params, plane sizes, normals = GBUFFER without normals);
 * The call keeps its planes in ctx for the next call with ctx (no fresh pages per call; freed by
 * obs_context_destroy or obs_context_scratch_release).
 * OUT_OF_MEMORY. */
obs_status ao_hbao_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_hbao_params *params,
                           obs_image_f32 *out, obs_image_f32 *out_raw, ao_hbao_stats *stats);

/* The HBAO+-style separable cross-bilateral blur, usable by any method. Planes in our row order:
 * ao and depth (linear depth d > 0, background = not finite or <= 0) of the full buffer size; the
 * result is written for the window [x0, x0 + out->width) x [y0, y0 + out->height), which reads ao
 * and depth up to radius pixels outside it (clamped to the buffer, as CLAMP_TO_EDGE). Horizontal
 * pass (+x taps first, then -x), then vertical (+y_gl = UP first, then down), per pass:
 *   out = (ao_c + sum_r w_r ao_r) / (1 + sum_r w_r),  r = 1..radius each side,
 *   w_r = exp2(-r^2 / (2 sigma^2) - ((z_r - slope * r - z_c) * sharpness)^2),
 * slope = z_(+-1) - z_c per side when depth_slope (HBAO+ ProcessRadius1), else 0. sigma 0 means
 * (radius + 1) / 2. Background centres pass their AO through; background taps get weight 0.
 * Returns OK, INVALID_ARGUMENT (sizes, NULLs, aliasing, ranges), OUT_OF_MEMORY. */
obs_status ao_hbao_blur(obs_context *ctx, obs_pool *pool, const obs_image_f32 *ao, const obs_image_f32 *depth,
                        int x0, int y0, int radius, float sigma, float sharpness, int depth_slope, obs_image_f32 *out);

/* 1 when ao_hbao_compute and ao_hbao_blur run their AVX2 loops (8 pixels per lane group): the build
 * has AVX2 (OBS_HAVE_AVX2), the CPU has it and OBS_ISA is not "scalar" (read at each call). Both
 * paths give the same bits (tests/test_ao_hbao.c, hbao_avx2_paths_give_the_scalar_bits). */
int ao_hbao_simd_available(void);

/* (end of HBAO) */


/* ================================================================================================
 * UE4 AO (src/ao/ao_ue4.c)
 *
 * Unreal Engine 4's screen-space AO [Mittring12] ("The Technology Behind the Elemental Demo",
 * SIGGRAPH 2012) as PostProcessAmbientOcclusion.usf computes it (UE 4.11/4.12 era, Copyright
 * 1998-2016; read in JimmieKJ/unrealTournament @ 89cfe56, with the constant setup of
 * PostProcessAmbientOcclusion.h/.cpp and the random texture of SystemTextures.cpp): the
 * full-resolution pass and UE's multi-resolution chain (levels 2, the default as at quality 50, and 3:
 * AO setup levels and MipBlend with the upsampled coarser AO). docs/ao/ue4.md has every detail.
 *
 * The kernel runs in UE's scene units (1 unit = 1 cm): depths are multiplied by
 * AO_UE4_UNITS_PER_METRE, so the shader's unit-bearing constants (FlatSurfaceBias 5, the anti-halo
 * distance 80, the O1 normal scale 0.08 * 1000) act as they do in a metre-scale UE scene. Params are
 * in metres.
 * ============================================================================================== */

#define AO_UE4_UNITS_PER_METRE 100.0f       /* UE scene units per metre (UE: 1 uu = 1 cm) */
/* Defaults: FPostProcessSettings (Engine/Classes/Engine/Scene.h, UE4) converted cm -> m. */
#define AO_UE4_DEFAULT_RADIUS 2.0f          /* m, > 0; AmbientOcclusionRadius 200 (uu) */
#define AO_UE4_DEFAULT_RADIUS_IN_WS 0       /* AmbientOcclusionRadiusInWS false (view-space radius) */
#define AO_UE4_DEFAULT_POWER 2.0f           /* > 0; AmbientOcclusionPower 2.0 */
#define AO_UE4_DEFAULT_INTENSITY 0.5f       /* [0, 1]; AmbientOcclusionIntensity .5 */
#define AO_UE4_DEFAULT_BIAS 3.0f            /* >= 0, per mille of depth; AmbientOcclusionBias 3.0 (/1000 in C++) */
#define AO_UE4_DEFAULT_DISTANCE 0.8f        /* m, > 0; AmbientOcclusionDistance_DEPRECATED 80 (anti-halo, no-normal path) */
#define AO_UE4_DEFAULT_FADE_DISTANCE 80.0f  /* m, >= 0; AmbientOcclusionFadeDistance 8000 */
#define AO_UE4_DEFAULT_FADE_RADIUS 50.0f    /* m, >= 0.01 (C++ max(1 uu, .)); AmbientOcclusionFadeRadius 5000 */
#define AO_UE4_DEFAULT_MIP_SCALE 1.7f       /* AmbientOcclusionMipScale 1.7 (radius factor per level) */
#define AO_UE4_DEFAULT_SAMPLE_SET 1         /* USE_SAMPLESET at SHADER_QUALITY 2 (AmbientOcclusionQuality 50) */
#define AO_UE4_DEFAULT_STEPS 2              /* SAMPLE_STEPS at SHADER_QUALITY 2 */
#define AO_UE4_DEFAULT_QUAD_BLUR 2          /* QUAD_MESSAGE_PASSING_BLUR at SHADER_QUALITY 2 */
#define AO_UE4_FLAT_SURFACE_BIAS 5.0f       /* uu; WedgeNoNormal "FlatSurfaceBias = 5.0f" */
#define AO_UE4_CONTRAST_TWEAK 0.9f          /* acosApproxNormAngle "ContrastTweak = 0.9f" */
#define AO_UE4_MAX_STEPS 8
#define AO_UE4_MAX_LEVELS 3                 /* r.AmbientOcclusionLevels range (min(., 3) in the C++) */
#define AO_UE4_DEFAULT_MIP_BLEND 0.6f       /* AmbientOcclusionMipBlend 0.6 (levels > 1) */
#define AO_UE4_MAX_DEPTH_M 1.0e5f           /* depths (and background taps) are clamped to 100 km */

typedef enum ao_ue4_normals {
    AO_UE4_NORMALS_NONE = 0,        /* SSAO_NORMAL_MODE 0: WedgeNoNormal (angle between the pair) */
    AO_UE4_NORMALS_GBUFFER,         /* 1: the G-buffer's normals (default); reconstructed from depth
                                       (mode 2) when the input has none */
    AO_UE4_NORMALS_DEPTH,           /* 2: reconstructed from depth (ao_normals_from_depth) */
    AO_UE4_NORMALS_COUNT
} ao_ue4_normals;

typedef enum ao_ue4_variant {
    AO_UE4_VARIANT_CLASSIC = 0,     /* "classic-reconstruction": OPTIMIZATION_O1 0, saturate(dot(D, n)/|D|)
                                       with halo weights. UE never ran it (the shader defines
                                       OPTIMIZATION_O1 1; in the 2016 text its InvHaloSize zeroes every
                                       weight): our reconstruction, with our InvHaloSize (docs/ao/ue4.md,
                                       difference 2) */
    AO_UE4_VARIANT_O1,              /* "o1", the default: OPTIMIZATION_O1 1 (what UE 4.9+ compiles):
                                       saturate(dot(D, n * 0.08 * lerp(z, 1000, ws))/dot(D, D)), weight 1 */
    AO_UE4_VARIANT_COUNT
} ao_ue4_variant;

#define AO_UE4_DEFAULT_VARIANT AO_UE4_VARIANT_O1 /* PostProcessAmbientOcclusion.usf "#define OPTIMIZATION_O1 1" (UE 4.9+) */
#define AO_UE4_DEFAULT_LEVELS 2             /* [1, 3]; r.AmbientOcclusionLevels -1 -> ComputeAmbientOcclusionPassCount
                                               1 + (q > 70) + (q > 35) at AmbientOcclusionQuality q = 50 */

typedef struct ao_ue4_params {
    ao_ue4_variant variant;
    ao_ue4_normals normals;
    float radius;           /* AmbientOcclusionRadius in metres (UE value / 100) */
    int radius_in_ws;       /* 0: AORadiusInShader = radius*100/400/4 scaled by depth (constant
                               screen size); 1: world-space radius*100/4 uu (= radius/4 m) */
    float power;            /* AmbientOcclusionPower */
    float intensity;        /* AmbientOcclusionIntensity */
    float bias;             /* AmbientOcclusionBias (per mille of depth, along the normal) */
    float distance;         /* AmbientOcclusionDistance (m): the no-normal path's anti-halo depth */
    float fade_distance;    /* AmbientOcclusionFadeDistance (m) */
    float fade_radius;      /* AmbientOcclusionFadeRadius (m) */
    int sample_set;         /* USE_SAMPLESET: 0 (1 point), 1 (3), 2 (5), 3 (6) */
    int steps;              /* SAMPLE_STEPS, [1, AO_UE4_MAX_STEPS] */
    int quad_blur;          /* QUAD_MESSAGE_PASSING_BLUR 0..3 (the 2x2 ddx/ddy blur) */
    int blur;               /* 1: the seed thesis' 21-tap Gaussian (ao_blur_gaussian21) afterwards */
    int levels;             /* resolution levels, [1, AO_UE4_MAX_LEVELS]: 1 = the full-resolution pass
                               alone; 2 (default, AO_UE4_DEFAULT_LEVELS), 3 = UE's multi-resolution chain
                               (AO setup levels at 1/2, 1/4, each blended with the upsampled coarser
                               one by MipBlend; simplified: docs/ao/ue4.md, difference 3) */
    float mip_blend;        /* AmbientOcclusionMipBlend, [0, 1] (levels > 1) */
    float mip_scale;        /* AmbientOcclusionMipScale, radius factor per level, (0, 16] (levels > 1) */
} ao_ue4_params;

/* UE4's defaults (AO_UE4_DEFAULT_*), what UE 4.9+ runs at AmbientOcclusionQuality 50: set 1, 2 steps,
 * quad blur 2, 2 levels, OPTIMIZATION_O1 1, G-buffer normals, Gaussian blur off. */
ao_ue4_params ao_ue4_params_default(void);

/* Presets: "default" = "ue4" (ao_ue4_params_default(): UE 4.9+ at quality 50, O1, 2 levels);
 * "ue4-o1" and "ue4-multires" (the same as "ue4", names kept from before the default was O1 with
 * 2 levels); "ue4-one-level" (the full-resolution pass alone, as a one-pass shader port runs it);
 * "classic-reconstruction" (our reconstruction of the OPTIMIZATION_O1 0 branch UE never ran, one
 * level: the default before issue 12); "thesis" (ssao-thesis-2017 Table 3: r = 0.05, 8 samples; read
 * as the shader radius AORadiusInShader = 0.05 in view-space mode, i.e. radius 0.8 m; 8 samples ->
 * set 1 x 2 steps, Gaussian blur on: docs/ao/ue4.md); "quality-0" .. "quality-4" (SHADER_QUALITY
 * 0..4 with the levels of a representative AmbientOcclusionQuality: 1, 1, 2, 2, 3). */
int ao_ue4_params_preset(const char *name, ao_ue4_params *out);
const char *const *ao_ue4_preset_names(void);

/* The study's samples-per-pixel n -> (sample_set, steps): the lowest UE4 quality level whose taps
 * (2 x points x steps) are >= n: n <= 6 -> (1, 1) [6 taps], <= 12 -> (1, 2), <= 18 -> (1, 3),
 * <= 36 -> (3, 3); above, set 3 with ceil(n / 12) steps (at most AO_UE4_MAX_STEPS). */
void ao_ue4_samples_to_set(int n, int *sample_set, int *steps);

obs_status ao_ue4_params_validate(obs_context *ctx, const ao_ue4_params *p);
int ao_ue4_params_to_string(const ao_ue4_params *p, char *buf, size_t size);

/* The points of sample set s (OcclusionSamplesOffsets, float expressions as in the shader); returns
 * the count (1, 3, 5, 6), 0 for an unknown set. xy must hold 2 x 6 floats. */
int ao_ue4_sample_set(int s, float xy[12]);

/* The 4x4 SSAORandomization texture (SystemTextures.cpp): texel (x % 4, y % 4), y counted from the
 * TOP of the full buffer (D3D rows, our row order), is rgba[(x % 4) + 4 (y % 4)], B8G8R8A8 UNORM with
 * R = Q(c), G = Q(s), B = Q(-s), A = Q(c), c/s = cos/sin(w/16 pi) * lenm(w), w = Reorder[index],
 * Q(v) = (int)((v * 0.5 + 0.5) * 255.999). The shader reads RandomVec = .rg * 2 - 1. */
void ao_ue4_random_texture(unsigned char rgba[16][4]);

/* ScreenSpaceAOParams as the C++ sets it for the full-resolution pass (UE units), plus the
 * projection terms the shader takes from the view, the sample set and the flags. */
typedef struct ao_ue4_constants {
    int full_width, full_height;
    float power, bias_over_1000, inv_distance, intensity;      /* [0] .x .y .z .w */
    float viewport_uv_to_random_uv[2], ao_radius_in_shader, ratio; /* [1] */
    float scale_factor, inv_threshold, scale_radius_in_ws, mip_blend; /* [2] (full-resolution pass) */
    float temporal_offset[2], static_fraction, inv_tan_half_fov; /* [3] (temporal offset 0: no TAA) */
    float fade_mul, fade_add;                                    /* [4] .x .y */
    float fov_fix[2];               /* (P00, P11) = (2 fx / W, 2 fy / H) */
    float screen_scale[2];          /* NDC per pixel: (2 / W, -2 / H); NDC measured from (cx, cy) */
    float units_per_metre;          /* AO_UE4_UNITS_PER_METRE */
    float max_depth;                /* AO_UE4_MAX_DEPTH_M in uu */
    int orthographic;               /* our extension: CS position (ScreenPos * units_per_metre, z) */
    int variant, normal_mode, sample_set, sample_count, steps, quad_blur, blur;
    int levels;
    float mip_scale;                /* AmbientOcclusionMipScale (levels > 1) */
    float samples[12];              /* OcclusionSamplesOffsets */
} ao_ue4_constants;

/* Pure params -> constants (mirrors FScreenSpaceAOandSSRShaderParameters::Set at ScaleToFullRes 1).
 * normal_mode is the effective SSAO_NORMAL_MODE (GBUFFER without input normals -> 2). */
ao_ue4_constants ao_ue4_constants_from_params(const ao_ue4_params *p, const ao_input *in);

/* UE4 AO over the input's window. out (w x h) receives the AO after the quad blur and, when
 * params->blur, the Gaussian; out_raw (may be NULL) the AO before the Gaussian. The AO pass runs over
 * the window plus the Gaussian's reach (10 px), aligned to 2x2 quads when the quad blur is on; the
 * coarse levels (levels > 1) over their whole planes.
 * The call keeps its planes in ctx for the next call with ctx (no fresh pages per call; freed by
 * obs_context_destroy or obs_context_scratch_release).
 * stats may be NULL. Returns OK, INVALID_ARGUMENT, OUT_OF_MEMORY, LIMIT_EXCEEDED. */
obs_status ao_ue4_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_ue4_params *params,
                          obs_image_f32 *out, obs_image_f32 *out_raw, ao_stats *stats);

/* (end of UE4 AO) */


/* ================================================================================================
 * GTAO as XeGTAO (src/ao/ao_gtao.c)
 * ============================================================================================== */

/* GTAO [Jimenez16] exactly as Intel's XeGTAO computes it (GameTechDev/XeGTAO @ a5b1686, files
 * Source/Rendering/Shaders/XeGTAO.h, XeGTAO.hlsli, vaGTAO.hlsl; Effects/vaGTAO.cpp), FP32 path
 * (XE_GTAO_FP32_DEPTHS, XE_GTAO_USE_HALF_FLOAT_PRECISION 0). docs/ao/gtao.md.
 *
 * Pixel convention: XeGTAO is D3D (uv origin top-left, y down), so its pixCoord IS our (x, y) of
 * the full buffer (row 0 at the top): unlike the GL techniques, no y flip. Its view space is
 * left-handed (+Z forward, +Y up): P_xe = (x_ours, y_ours, -z_ours) = (.., .., depth). */
#define AO_GTAO_DEFAULT_RADIUS 0.5f                   /* m, > 0; XeGTAO.h GTAOSettings::Radius */
#define AO_GTAO_DEFAULT_RADIUS_MULTIPLIER 1.457f      /* [0.3, 3]; XE_GTAO_DEFAULT_RADIUS_MULTIPLIER (auto-tuned
                                                         against the RT reference, lowest average MSE) */
#define AO_GTAO_DEFAULT_FALLOFF_RANGE 0.615f          /* (0, 1]; XE_GTAO_DEFAULT_FALLOFF_RANGE (auto-tuned) */
#define AO_GTAO_DEFAULT_SAMPLE_DISTRIBUTION_POWER 2.0f /* [1, 3]; XE_GTAO_DEFAULT_SAMPLE_DISTRIBUTION_POWER */
#define AO_GTAO_DEFAULT_THIN_OCCLUDER_COMPENSATION 0.0f /* [0, 0.7]; XE_GTAO_DEFAULT_THIN_OCCLUDER_COMPENSATION */
#define AO_GTAO_DEFAULT_FINAL_VALUE_POWER 2.2f        /* [0.5, 5]; XE_GTAO_DEFAULT_FINAL_VALUE_POWER */
#define AO_GTAO_DEFAULT_DEPTH_MIP_SAMPLING_OFFSET 3.30f /* [0, 30]; XE_GTAO_DEFAULT_DEPTH_MIP_SAMPLING_OFFSET
                                                         (the README says 3.15; the code 3.30) */
#define AO_GTAO_DEFAULT_SLICES 3                      /* QualityLevel 2 (High): vaGTAO.hlsl CSGTAOHigh (3, 3) */
#define AO_GTAO_DEFAULT_STEPS 3                       /* steps per side of a slice, CSGTAOHigh */
#define AO_GTAO_DEFAULT_DENOISE_PASSES 1              /* [0, 3]; GTAOSettings::DenoisePasses (1 = sharp) */
#define AO_GTAO_DEPTH_MIP_LEVELS 5                    /* XE_GTAO_DEPTH_MIP_LEVELS (hard-coded 5: MIP 0..4) */
#define AO_GTAO_CENTER_Z_PULL 0.99999f                /* XeGTAO_MainPass, XE_GTAO_FP32_DEPTHS (FP16: 0.99920) */
#define AO_GTAO_DEPTH_CLAMP 65504.0f                  /* XeGTAO_ClampDepth (see docs/ao/gtao.md: the #ifdef) */
#define AO_GTAO_OCCLUSION_TERM_SCALE 1.5f             /* XE_GTAO_OCCLUSION_TERM_SCALE: the working term's range */
#define AO_GTAO_DENOISE_BLUR_BETA 1.2f                /* GTAOUpdateConstants DenoiseBlurBeta (1e4 when passes = 0) */
#define AO_GTAO_HILBERT_LEVEL 6                       /* XE_HILBERT_LEVEL: 64 x 64 tile */
#define AO_GTAO_MAX_SLICES 64
#define AO_GTAO_MAX_STEPS 64

typedef enum ao_gtao_normals {
    AO_GTAO_NORMALS_AUTO = 0,       /* default: the G-buffer's when the input has them, else from depth
                                       (vaGTAO.cpp: m_generateNormals |= inputNormals == nullptr) */
    AO_GTAO_NORMALS_DEPTH,          /* XeGTAO_ComputeViewspaceNormal (edge-weighted 4 cross products) */
    AO_GTAO_NORMALS_GBUFFER,        /* the input's normals (LoadNormal: normalized) */
    AO_GTAO_NORMALS_COUNT
} ao_gtao_normals;

typedef struct ao_gtao_params {
    int slices;                     /* sliceCount (Low 1, Medium 2, High 3, Ultra 9) */
    int steps;                      /* stepsPerSlice, per side (Low/Medium 2, High/Ultra 3) */
    float radius;                   /* Radius: world-space radius of the RT reference (m) */
    float radius_multiplier;        /* RadiusMultiplier: effectRadius = radius * this */
    float falloff_range;            /* FalloffRange: fraction of effectRadius over which taps fade */
    float sample_distribution_power;/* SampleDistributionPower */
    float thin_occluder_compensation;/* ThinOccluderCompensation */
    float final_value_power;        /* FinalValuePower */
    float depth_mip_sampling_offset;/* DepthMIPSamplingOffset */
    ao_gtao_normals normals;
    int blur;                       /* 1: XeGTAO_Denoise passes after the main pass */
    int denoise_passes;             /* DenoisePasses: 0 = XeGTAO's "disabled" (one last pass with beta 1e4),
                                       1 sharp, 2 medium, 3 soft; used when blur = 1 */
    int frame_index;                /* frameCounter: NoiseIndex = frame % 64 when denoising, else 0 (TAA) */
    int gpu_packing;                /* 0 (default, the FP32 reference): float32 throughout. 1: emulate
                                       XeGTAO's storage: the AO terms in 8 bits (working term
                                       saturate(v / 1.5), denoise outputs, the final R8 value) and the
                                       normals through R11G11B10_UNORM. Depth stays FP32 */
} ao_gtao_params;

/* XeGTAO's GTAOSettings defaults (QualityLevel High, DenoisePasses 1, Radius 0.5), blur on. */
ao_gtao_params ao_gtao_params_default(void);

/* Named presets. Returns 1 and fills *out, or 0 for an unknown name.
 *   "default", "xegtao", "high": ao_gtao_params_default() (3 slices x 3 steps).
 *   "low" (1 x 2), "medium" (2 x 2), "ultra" (9 x 3): vaGTAO.hlsl CSGTAOLow/Medium/Ultra.
 *   "sharp", "soft": the default with DenoisePasses 1 / 3 ("medium-denoise": 2).
 * The seed thesis' Table 3 has no GTAO row, so there is no "thesis" preset. */
int ao_gtao_params_preset(const char *name, ao_gtao_params *out);
const char *const *ao_gtao_preset_names(void);

/* The study's sample axis: n samples per pixel = 2 * slices * steps. n = 4, 8, 18, 54 give XeGTAO's
 * Low, Medium, High, Ultra; otherwise steps = the largest of 4, 3, 2, 1 dividing ceil(n/2) and
 * slices = ceil(n/2) / steps (16 -> 2 x 4, 32 -> 4 x 4, 12 -> 2 x 3). Clamped to the MAX_ limits. */
void ao_gtao_slices_steps_for_samples(int n, int *slices, int *steps);

/* Returns OK or INVALID_ARGUMENT naming the field and its range. */
obs_status ao_gtao_params_validate(obs_context *ctx, const ao_gtao_params *p);

/* Resolved params as one line of text. snprintf semantics. */
int ao_gtao_params_to_string(const ao_gtao_params *p, char *buf, size_t size);

/* XeGTAO's GTAOConstants field for field (96 bytes, float32, same order and padding), followed by
 * the shader's compile-time choices. Filled by ao_gtao_constants_from_params as GTAOUpdateConstants
 * does for a projection with these intrinsics. */
typedef struct ao_gtao_constants {
    int viewport_size[2];           /* ViewportSize (the full buffer) */
    float viewport_pixel_size[2];   /* ViewportPixelSize = 1 / size */
    float depth_unpack_consts[2];   /* DepthUnpackConsts for a D3D [0,1] projection with in's znear/zfar
                                       (znear*zfar/(zfar-znear), zfar/(zfar-znear); infinite: znear, 1);
                                       0 when unknown. Informational: our input is linear depth */
    float camera_tan_half_fov[2];   /* CameraTanHalfFOV = (W / (2 fx), H / (2 fy)) */
    float ndc_to_view_mul[2];       /* NDCToViewMul = (W/fx, -H/fy) = (2 tanX, -2 tanY) centred */
    float ndc_to_view_add[2];       /* NDCToViewAdd = (-cx/fx, cy/fy) = (-tanX, tanY) centred */
    float ndc_to_view_mul_x_pixel_size[2]; /* NDCToViewMul * ViewportPixelSize */
    float effect_radius;            /* EffectRadius = Radius */
    float effect_falloff_range;     /* EffectFalloffRange */
    float radius_multiplier;        /* RadiusMultiplier */
    float padding0;                 /* Padding0 */
    float final_value_power;        /* FinalValuePower */
    float denoise_blur_beta;        /* DenoiseBlurBeta: 1.2, or 1e4 when DenoisePasses = 0 */
    float sample_distribution_power;/* SampleDistributionPower */
    float thin_occluder_compensation;/* ThinOccluderCompensation */
    float depth_mip_sampling_offset;/* DepthMIPSamplingOffset */
    int noise_index;                /* NoiseIndex = DenoisePasses > 0 ? frame % 64 : 0 */
    /* ---- not in the cbuffer: the entry point's arguments and our extensions ---- */
    int slice_count, steps_per_slice;
    int denoise_passes;             /* passes run: 0 (blur off), else max(1, DenoisePasses) */
    int normals_from_gbuffer;       /* 1: LoadNormal; 0: XeGTAO_ComputeViewspaceNormal */
    int orthographic;               /* 0 = XeGTAO; 1 = our orthographic extension (docs/ao/gtao.md) */
    int gpu_packing;                /* params.gpu_packing */
} ao_gtao_constants;

/* The pure params -> constants step (mirrors GTAOUpdateConstants). in gives the buffer size, the
 * pixel model and whether normals are present. Params are assumed validated. */
ao_gtao_constants ao_gtao_constants_from_params(const ao_gtao_params *p, const ao_input *in);

/* ---- Building blocks, exposed for validation (coordinates are XeGTAO's pixCoord = our full-buffer
 * (x, y), row 0 at the top) ---- */

/* XeGTAO.h HilbertIndex(posX, posY) at level 6 (0 .. 4095; only the low 6 bits of x, y matter). */
uint32_t ao_gtao_hilbert_index(uint32_t x, uint32_t y);

/* vaGTAO.hlsl SpatioTemporalNoise: index = HilbertIndex(x, y) + 288 * (noise_index % 64), then
 * the R2 sequence frac(0.5 + float(index) * (0.75487766624669276005, 0.5698402909980532659114)),
 * float32. out[0] = localNoise.x (slice noise), out[1] = localNoise.y (step noise). A port may upload
 * this as a 64 x 64 RG32F texture per noise index (ao_gtao_noise_texture). */
void ao_gtao_noise(uint32_t x, uint32_t y, int noise_index, float out[2]);
/* The 64 x 64 x 2 floats of that texture (row-major, y then x, RG interleaved). */
void ao_gtao_noise_texture(int noise_index, float out[64 * 64 * 2]);

/* XeGTAO_FastSqrt (asfloat(0x1fbd1df5 + (asint(x) >> 1))) and XeGTAO_FastACos (Lagarde's
 * (-0.156583|x| + pi/2) sqrt(1 - |x|), mirrored for x < 0), bit-exact float32. Error bounds in
 * docs/ao/gtao.md, checked by the tests. */
float ao_gtao_fast_sqrt(float x);
float ao_gtao_fast_acos(float x);

/* XeGTAO_CalculateEdges(centerZ, leftZ, rightZ, topZ, bottomZ) -> edges LRTB in [0, 1], and
 * XeGTAO_PackEdges as the 8-bit integer the R8_UNORM texture stores (2 bits per edge, L high). */
void ao_gtao_calculate_edges(float center_z, float left_z, float right_z, float top_z, float bottom_z, float out[4]);
unsigned ao_gtao_pack_edges(const float edges_lrtb[4]);
/* XeGTAO_UnpackEdges of that integer. */
void ao_gtao_unpack_edges(unsigned packed, float out[4]);

/* XeGTAO_PrefilterDepths16x16: levels[0] = XeGTAO_ClampDepth(view-space depth) (background, NaN,
 * <= 0 -> 65504) and levels 1..4 by XeGTAO_DepthMIPFilter (the falloff-weighted average of the 2x2
 * children), level l of size max(1, size_{l-1} >> 1) (children clamped to the parent's edge).
 * levels[0..4] are allocated here (free with ao_gtao_mips_free). k from ao_gtao_constants_from_params.
 * Returns OK, INVALID_ARGUMENT, OUT_OF_MEMORY. */
obs_status ao_gtao_prefilter_depths(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_gtao_constants *k,
                                    obs_image_f32 levels[AO_GTAO_DEPTH_MIP_LEVELS]);
void ao_gtao_mips_free(obs_image_f32 levels[AO_GTAO_DEPTH_MIP_LEVELS]);

/* One tap of XeGTAO_MainPass at a pixel whose (pulled) view-space z is viewspace_z: the unrounded
 * offset s * omega (pixels, y down), its length, the mipLevel value, the MIP level a point-MIP
 * sampler reads (floor(mipLevel + 0.5), at most 4) and the rounded offset (round-to-nearest-even). */
typedef struct ao_gtao_tap {
    float offset[2];
    float offset_length;
    float mip_level;
    int mip;
    float rounded[2];
} ao_gtao_tap;
void ao_gtao_tap_at(const ao_gtao_constants *k, float viewspace_z, const float noise[2], int slice, int step,
                    ao_gtao_tap *out);

typedef struct ao_gtao_stats {
    int64_t pixels_computed;        /* main-pass pixels (window plus the denoiser's reach) */
    int64_t pixels_background;      /* of those: background (visibility 1) */
    int64_t pixels_degenerate_normal; /* of those: zero or non-finite normal (visibility 1) */
    double seconds_prefilter, seconds_main, seconds_denoise;
} ao_gtao_stats;

/* XeGTAO over the input's window: PrefilterDepths, MainPass (normals from depth or the G-buffer),
 * then, with params->blur, the Denoise passes. out gets the final visibility, out_raw (may be NULL)
 * the main pass's, both clamped to [0, 1] (the denoiser reads the unclamped working term in
 * [0, 1.5]). The main pass runs over the window plus one pixel per denoise pass each side (inside
 * the buffer), so the result equals a GPU run over the whole buffer, cropped. stats may be NULL.
 * Its scratch planes stay in ctx between calls (obs_context_scratch_put; freed by
 * obs_context_destroy), so repeated calls with one context allocate nothing; same bits either way.
 * Returns: OK; INVALID_ARGUMENT (input, params, plane sizes, normals = GBUFFER without normals);
 * OUT_OF_MEMORY; LIMIT_EXCEEDED (a plane over the context's limits). */
obs_status ao_gtao_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_gtao_params *params,
                           obs_image_f32 *out, obs_image_f32 *out_raw, ao_gtao_stats *stats);

/* ao_gtao_compute with the main pass as the plain per-tap port (main_pixel: noise, cos/sin of the
 * slice angle, s^power and the log2 MIP choice per tap). The oracle of ao_gtao_compute's
 * per-call tables and MIP thresholds (docs/ao/gtao.md, "Speed"): the same output bits, slower. */
obs_status ao_gtao_compute_reference(obs_context *ctx, obs_pool *pool, const ao_input *in,
                                     const ao_gtao_params *params, obs_image_f32 *out, obs_image_f32 *out_raw,
                                     ao_gtao_stats *stats);

/* The main pass's MIP choice for a tap offset of length off_len: fast = 0, min(floor(clamp(
 * log2(off_len) - mip_offset, 0, 5) + 0.5), 4) with a double log2; fast = 1, the count of the
 * per-call thresholds it reaches (what ao_gtao_compute uses). Exposed so the tests compare them. */
int ao_gtao_mip_of_length(float off_len, float mip_offset, int fast);

/* The main pass's final power, (float)pow((double)x, (double)p) bit for bit: for p = 2.2f and x in
 * [2^-126, 2) by tables and a series with a rounding test that falls back to pow near a float
 * rounding boundary (proof in ao_gtao.c), else pow. Exposed so the tests compare it with pow. */
float ao_gtao_final_power(float x, float p);

/* (end of GTAO as XeGTAO) */


/* ================================================================================================
 * MSSAO (src/ao/ao_mssao.c)
 * ============================================================================================== */

/* Multi-resolution screen-space AO [Hoang12] (Hoang & Low, "Multi-resolution screen-space ambient
 * occlusion", VRCAI 2010 / The Visual Computer 28(3):289-304, 2012), as Hoang's original code
 * computes it (main.cpp, shaders/downsample.frag, aoFirst.frag, ao.frag, aoLast.frag, blur.frag;
 * ../shared/reference/ao.md 1.4, verification.md 3). docs/ao/mssao.md has every detail.
 *
 * Pipeline: level 0 is the full buffer; level l (1 <= l < levels) has size ceil(size_{l-1} / 2) and
 * its positions and normals are downsampled from level l-1 by the median rule. AO runs coarse to
 * fine: the coarsest level with the grid kernel alone (aoFirst.frag), middle levels with the grid
 * kernel plus the bilateral upsampling of the blurred coarser level (ao.frag), level 0 with 16
 * Poisson taps plus the upsampling and the final combine (aoLast.frag). Every coarse level is
 * blurred (blur.frag) before it is upsampled. All planes here are in GL row order (row 0 = BOTTOM). */

#define AO_MSSAO_DEFAULT_D_MAX 3.0f       /* dMax, m, > 0; main.cpp "const float dMax = 3.0f; // AO radius of influence" */
#define AO_MSSAO_DEFAULT_R_MAX 5.0f       /* rMax, level pixels, > 0; main.cpp "rMax = 5.0; // maximum screen-space sampling radius" */
#define AO_MSSAO_DEFAULT_LEVELS 5         /* [1, AO_MSSAO_MAX_LEVELS]; main.cpp LEVEL_COUNT 5 */
#define AO_MSSAO_DEFAULT_D_THRESHOLD 1.0f /* m, >= 0; downsample.frag "if (d < 1.0)"; kool uMedianThresh 1 */
#define AO_MSSAO_DEFAULT_SAMPLES 16       /* level-0 Poisson taps; aoLast.frag (poissonDisk[32] = 16 taps) */
#define AO_MSSAO_MAX_LEVELS 16
#define AO_MSSAO_POISSON_COUNT 16         /* Hoang's disk: main.cpp SetupAOPrograms poissonDisk[32] */
#define AO_MSSAO_MAX_SAMPLES 32           /* 17..32: our extension (the disk rotated by 90 degrees) */

/* Hoang's Poisson disk, (x, y) pairs in GL pixel units before the scale by rangeMax (main.cpp). */
extern const float ao_mssao_poisson_disk[2 * AO_MSSAO_POISSON_COUNT];

typedef enum ao_mssao_downsample {
    AO_MSSAO_DOWNSAMPLE_HOANG = 0,  /* default: downsample.frag: the children with min and max z (last
                                       index wins ties); d = |p_max - p_min| (3-D distance); the other two
                                       in index order are the "median"; d < threshold: their average,
                                       else the first of them */
    AO_MSSAO_DOWNSAMPLE_SORTED,     /* the slides / kool: sort by z, z4 - z1 < threshold: average of the
                                       2nd and 3rd, else the 2nd */
    AO_MSSAO_DOWNSAMPLE_COUNT
} ao_mssao_downsample;

typedef enum ao_mssao_normals {
    AO_MSSAO_NORMALS_AUTO = 0,      /* default: the G-buffer's when the input has them, else from depth */
    AO_MSSAO_NORMALS_DEPTH,         /* ao_normals_from_depth even when the input has normals */
    AO_MSSAO_NORMALS_COUNT
} ao_mssao_normals;

typedef struct ao_mssao_params {
    float d_max;                    /* dMax: world-space radius of influence, metres */
    float r_max;                    /* rMax: largest sampling radius, pixels of each level */
    int levels;                     /* LEVEL_COUNT */
    float d_threshold;              /* median-rule threshold, metres */
    int samples;                    /* level-0 taps: 16 = Hoang's disk; docs/ao/mssao.md "Samples" */
    ao_mssao_downsample downsample;
    ao_mssao_normals normals;
    int level_blur;                 /* 1 (Hoang): blur.frag on each coarse level before upsampling */
    int blur;                       /* 1: a final post-blur, ao_blur_gaussian21 (the seed's); Hoang has none */
} ao_mssao_params;

/* Hoang's defaults (AO_MSSAO_DEFAULT_*), level blur on, final blur off. */
ao_mssao_params ao_mssao_params_default(void);

/* Named presets. Returns 1 and fills *out, or 0 for an unknown name.
 *   "default", "hoang": ao_mssao_params_default() (main.cpp's constants).
 *   "thesis": the seed thesis' Table 3 (ssao-thesis-2017): radius 2 m (= dMax), 16 samples, with the
 *             seed's final 21-tap Gaussian blur on (5.2, "Blur Multi Scale AO").
 *   "kool": fabmax/kool's downsampling rule (sorted, z range) with Hoang's other constants. */
int ao_mssao_params_preset(const char *name, ao_mssao_params *out);
const char *const *ao_mssao_preset_names(void);

/* Returns OK or INVALID_ARGUMENT naming the field and its range. */
obs_status ao_mssao_params_validate(obs_context *ctx, const ao_mssao_params *p);

/* "d_max=3 r_max=5 ..." (snprintf semantics). */
int ao_mssao_params_to_string(const ao_mssao_params *p, char *buf, size_t size);

/* The constant block (main.cpp's uniforms per level), float32. */
typedef struct ao_mssao_constants {
    int full_width, full_height;    /* level 0 = the whole buffer (GL pixel grid) */
    int levels;
    int level_width[AO_MSSAO_MAX_LEVELS], level_height[AO_MSSAO_MAX_LEVELS]; /* ceil halving, >= 1 */
    /* uniform r per level: perspective r_l = fy * dMax / 2^l (main.cpp: size * dMax / (2 tan(fov/2))
     * with size = the level's nominal height, i.e. fy / 2^l pixels per metre at 1 m), so that
     * rangeMax = min(r_l / |z|, rMax) is dMax projected into level-l pixels. Orthographic (our
     * extension): rangeMax = min(r_l, rMax) with r_l = fy * dMax / 2^l. */
    float r[AO_MSSAO_MAX_LEVELS];
    int orthographic;
    float d_max, d_max2, r_max, d_threshold;  /* d_max2 = dMax * dMax in float */
    int samples;
    float taps[2 * AO_MSSAO_MAX_SAMPLES];     /* level-0 offsets (x, y), GL pixels per unit rangeMax */
    int downsample, level_blur, blur;
} ao_mssao_constants;

/* The pure params -> constants step. Params are assumed validated. */
ao_mssao_constants ao_mssao_constants_from_params(const ao_mssao_params *p, const ao_input *in);

/* The level-0 tap set for n samples (1..AO_MSSAO_MAX_SAMPLES), n (x, y) pairs into taps:
 * n <= 16: disk indices floor(k * 16 / n), k = 0..n-1 (16 = Hoang's disk in his order);
 * n > 16: the 16, then the disk rotated by +90 degrees, (x, y) -> (-y, x), at indices
 * floor(k * 16 / (n - 16)). */
void ao_mssao_taps(int n, float *taps);

/* One level of the pyramid, GL row order, all planes level_width x level_height. */
typedef struct ao_mssao_level {
    int width, height;
    obs_image_f32 pos[3];           /* view-space position (x, y, z), z < 0; background 0 */
    obs_image_f32 normal[3];        /* normal (averaged, not renormalised, as downsample.frag) */
    obs_image_f32 valid;            /* normTex.w: 1 surface, 0 background, averages in between */
    obs_image_f32 own;              /* the level's own AO, occlusion / sampleCount */
    obs_image_f32 ao[3];            /* the pass output (maxAO, sumAO, count); level 0: the combined
                                       (aoMax, upsampled sum + occ, upsampled count + count) */
    obs_image_f32 ao_blur[3];       /* after blur.frag (levels >= 1 with level_blur; else unset) */
    double seconds;                 /* downsample + AO pass + blur of this level */
} ao_mssao_level;

typedef struct ao_mssao_levels {
    int count;
    ao_mssao_level level[AO_MSSAO_MAX_LEVELS];
    obs_image_f32 visibility;       /* level 0's final visibility (1 - aoMax)(1 - aoAvg), GL rows,
                                       background 1, before any final blur */
} ao_mssao_levels;

/* Run the pipeline over the whole buffer and keep every level (for tests, the per-level figures and
 * a shader port's intermediate images). Free with ao_mssao_levels_free.
 * Returns OK, INVALID_ARGUMENT, OUT_OF_MEMORY, LIMIT_EXCEEDED. */
obs_status ao_mssao_compute_levels(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_mssao_params *params,
                                   ao_mssao_levels *out);
void ao_mssao_levels_free(ao_mssao_levels *lv);   /* NULL-safe */

typedef enum ao_mssao_level_view {
    AO_MSSAO_LEVEL_OWN = 0,         /* 1 - occlusion / sampleCount: the level's own kernel alone */
    AO_MSSAO_LEVEL_COMBINED,        /* (1 - ao.x)(1 - ao.y / ao.z): levels coarsest..l combined, as the
                                       finest level's combine would give if l were the finest */
    AO_MSSAO_LEVEL_VIEW_COUNT
} ao_mssao_level_view;

/* Level l of lv as a visibility image in OUR row order (row 0 = top), for per-level figures (the seed
 * thesis' Figura 85 / Tabla 24). out must be level_width x level_height of level l; background
 * texels (valid == 0) get 1. Returns OK or INVALID_ARGUMENT (l out of range, sizes, NULLs). */
obs_status ao_mssao_level_visibility(obs_context *ctx, const ao_mssao_levels *lv, int l, ao_mssao_level_view view,
                                     obs_image_f32 *out);

typedef struct ao_mssao_stats {
    int64_t pixels_computed;        /* level-0 pixels (window plus final-blur reach) */
    int64_t pixels_background;      /* of those: background (visibility 1) */
    int64_t pixels_upsample_fallback; /* of those and of coarse levels: all four bilateral weights
                                       underflowed to 0, plain bilinear used (docs) */
    int levels;
    double seconds_level[AO_MSSAO_MAX_LEVELS]; /* downsample + AO + level blur, per level */
    double seconds_prepare, seconds_kernel, seconds_blur;
} ao_mssao_stats;

/* MSSAO over the input's window. out (required) and out_raw (optional) are w x h planes in our
 * row order; out gets the final-blurred AO when params->blur, else the raw AO. Coarse levels are
 * computed over the whole buffer; level 0 over the window plus the final blur's reach.
 * The call keeps its planes in ctx for the next call with ctx (no fresh pages per call; freed by
 * obs_context_destroy or obs_context_scratch_release).
 * Returns OK; INVALID_ARGUMENT; OUT_OF_MEMORY; LIMIT_EXCEEDED. */
obs_status ao_mssao_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_mssao_params *params,
                            obs_image_f32 *out, obs_image_f32 *out_raw, ao_mssao_stats *stats);

/* (end of MSSAO) */


/* ================================================================================================
 * The seed's multi-resolution Alchemy AO (src/ao/ao_mssao_seed.c)
 *
 * ssao-thesis-2017 section 4.2.2.3 ("Multi-Scale Ambient Occlusion", Figuras 30 and 33, Tablas 3,
 * 24, 25): Alchemy AO (ao_alchemy_raw) at 5 resolutions W >> l x H >> l, l = 0..4 (the G-buffer
 * point-sampled at each level's pixel centres, the pixel model scaled as glViewport does), each
 * level blurred by the seed's 21-tap Gaussian at its own resolution, upsampled bilinearly (GL_LINEAR,
 * clamp to edge) and blended: V = max(0, 1 - sum_l I_l (1 - A_l)), I = (1.0, 0.5, 0.3, 0.3, 0.3)
 * (Tabla 25). docs/ao/mssao-seed.md has every detail and every choice the thesis leaves open.
 * ============================================================================================== */

#define AO_MSSAO_SEED_LEVELS 5              /* Figura 30: LEVEL_COUNT == 5 */
#define AO_MSSAO_SEED_DEFAULT_RADIUS 2.0f   /* m; Tabla 3 "Multi Scale AO 2" */
#define AO_MSSAO_SEED_DEFAULT_SAMPLES 16    /* Tabla 3 "Multi Scale AO ... 16" */

typedef struct ao_mssao_seed_params {
    ao_alchemy_params alchemy;      /* the kernel run at every level (same r, s, ... at each);
                                       alchemy.blur = each level's Gaussian */
    float level_intensity[AO_MSSAO_SEED_LEVELS]; /* I_l, >= 0; Tabla 25 */
} ao_mssao_seed_params;

/* The thesis' values: Alchemy defaults with r = 2 m, 16 samples (Tabla 3), blur on, intensities
 * 1.0, 0.5, 0.3, 0.3, 0.3 (Tabla 25). */
ao_mssao_seed_params ao_mssao_seed_params_default(void);

/* "default", "thesis": the defaults. "full-intensity": every I_l = 1 (Figura 86, "máxima
 * intensidad"). "level0" .. "level4": one level alone (I_l = 1, the others 0; Figura 85).
 * Returns 1 and fills *out, or 0 for an unknown name. */
int ao_mssao_seed_params_preset(const char *name, ao_mssao_seed_params *out);
const char *const *ao_mssao_seed_preset_names(void);

/* Returns OK or INVALID_ARGUMENT naming the field. */
obs_status ao_mssao_seed_params_validate(obs_context *ctx, const ao_mssao_seed_params *p);
int ao_mssao_seed_params_to_string(const ao_mssao_seed_params *p, char *buf, size_t size);

/* Level l's size: max(1, W >> l) x max(1, H >> l) (Figura 30: RTT_WIDTH / pow(2, i)). */
void ao_mssao_seed_level_size(int W, int H, int l, int *w, int *h);

/* The full-buffer pixel (our row order) that level l's pixel (x, y) (its own row order) takes its
 * G-buffer values from: in GL coordinates, the full pixel whose square contains the level pixel's
 * centre, floor((i + 0.5) * W / w_l), floor((j + 0.5) * H / h_l). */
void ao_mssao_seed_level_source(int W, int H, int l, int x, int y, int *sx, int *sy);

typedef struct ao_mssao_seed_stats {
    int64_t pixels_computed;        /* all levels */
    int64_t pixels_background;
    double seconds_prepare, seconds_ao, seconds_blur, seconds_blend;
} ao_mssao_seed_stats;

/* The multi-resolution AO over in's window. out (required) gets the blend of the blurred levels
 * (of the raw levels when !params->alchemy.blur), out_raw (optional) the blend of the raw levels.
 * Level 0 is computed over the window plus the blur's reach; levels 1-4 over their whole image.
 * The call keeps its planes in ctx for the next call with ctx (no fresh pages per call; freed by
 * obs_context_destroy or obs_context_scratch_release).
 * Returns OK, INVALID_ARGUMENT, OUT_OF_MEMORY, LIMIT_EXCEEDED. */
obs_status ao_mssao_seed_compute(obs_context *ctx, obs_pool *pool, const ao_input *in,
                                 const ao_mssao_seed_params *params, obs_image_f32 *out, obs_image_f32 *out_raw,
                                 ao_mssao_seed_stats *stats);

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
