/* sss.h: the public header of obscura's subsurface scattering (prefix sss_).
 *
 * Three layers, each usable on its own:
 *   1. Materials: Jensen et al. 2001's twelve measured materials as presets, user materials, and
 *      the pure material -> constants step (double precision, per colour channel).
 *   2. BSSRDFs: the standard dipole [Jensen01] (with the corrected eq. 4) and the directional
 *      dipole [Frisvad14], each as a scalar double-precision reference and as a float batch
 *      evaluation (scalar and AVX2 paths) that is tested against it.
 *   3. The scattering-map pipeline of [DalCorso17] (as its precursor thesis [DalCorso14] and the
 *      seed thesis describe it): light G-buffers -> K scattering maps -> combination per view.
 *      Each stage is a pass with a stated input and output; the maps do not depend on the view.
 *
 * Conventions (docs/sss.md has the full page; ../shared/reference/sss.md the facts):
 *   - Optical coefficients are per millimetre (as Jensen's table). A scene gives its scale in
 *     millimetres per scene unit (mm_per_unit); the constants step converts every coefficient to
 *     per scene unit, so distances inside the kernels are scene units and S_d is per unit^2.
 *   - w_i is the unit direction from x_i TOWARDS the light; n_i, n_o are unit outward normals.
 *   - eta = n_inside / n_outside.
 *   - RGB channels 0, 1, 2 are Jensen's R, G, B.
 *   - Radiance units are the light's (obs_light colour x intensity): a directional light of
 *     irradiance E (lux) on a surface facing it gives E, a point light E = I / d^2.
 */
#ifndef SSS_H
#define SSS_H

#include "../core/obs.h"
#include "../raster/raster.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------------------------------------
 * 1. Materials
 * ---------------------------------------------------------------------------------------------- */

/* A homogeneous translucent material. Coefficients per mm, per RGB channel.
 * Jensen's table gives the reduced scattering coefficient sigma_s' directly (g unknown): a preset
 * has sigma_s = sigma_s' and g = 0, as pbrt-v3 does (sss.md section 2). */
typedef struct sss_material {
    char name[OBS_NAME_MAX];
    double sigma_s[3];   /* scattering coefficient, mm^-1, >= 0, finite */
    double sigma_a[3];   /* absorption coefficient, mm^-1, >= 0, finite */
    double g;            /* Henyey-Greenstein mean cosine, (-1, 1) */
    double eta;          /* relative index of refraction n_inside/n_outside, > 0, finite */
} sss_material;

/* The presets: Jensen et al. 2001, Fig. 5(b) (as in sss.md section 2, checked against pbrt-v3's
 * SubsurfaceParameterTable): Apple, Chicken1, Chicken2, Cream, Ketchup, Marble, Potato, Skimmilk,
 * Skin1, Skin2, Spectralon, Wholemilk. data/materials/jensen2001.json holds the same table as a
 * documented file (a test checks they agree). */
#define SSS_PRESET_COUNT 12
int sss_preset_count(void);
/* Preset i (0..count-1), or NULL. */
const sss_material *sss_preset(int i);
/* Jensen's measured total diffuse reflectance R_d of preset i, per channel (the table's last
 * columns), for the energy tests. Returns 0 if i is out of range. */
int sss_preset_measured_rd(int i, double rd[3]);

/* Find a preset by name, case-insensitive ("cream", "Skin1").
 * Returns OK or NOT_FOUND (the message lists the names). */
obs_status sss_material_find(obs_context *ctx, const char *name, sss_material *out);

/* Check a material: finite, sigma_s >= 0, sigma_a >= 0, sigma_t > 0 per channel, eta > 0,
 * -1 < g < 1. `where` (a file or flag name, may be NULL) prefixes the message.
 * Returns OK or INVALID_ARGUMENT naming the field and channel. */
obs_status sss_material_validate(obs_context *ctx, const sss_material *m, const char *where);

/* Parse the documented material schema (docs/sss.md, "Materials in glTF"), the value of a glTF
 * material's extras member "obscura_sss" given as JSON text:
 *   {"preset": "cream"}                                                     or
 *   {"sigma_s_prime": [r,g,b], "sigma_a": [r,g,b], "eta": 1.3}               or
 *   {"sigma_s": [r,g,b], "g": 0.8, "sigma_a": [r,g,b], "eta": 1.3}
 * with an optional "name". Unknown keys are an error. `extras_json` is the whole extras object;
 * *found is set to 0 (and OK returned) when it has no "obscura_sss" member.
 * Returns OK, PARSE_ERROR or INVALID_ARGUMENT (messages name `where`). */
obs_status sss_material_from_extras(obs_context *ctx, const char *extras_json, const char *where,
                                    sss_material *out, int *found);

/* ------------------------------------------------------------------------------------------------
 * 2. BSSRDF constants and evaluation
 * ---------------------------------------------------------------------------------------------- */

typedef enum sss_model {
    SSS_MODEL_DIRECTIONAL = 0, /* [Frisvad14] directional dipole (default: what the seed uses) */
    SSS_MODEL_STANDARD,        /* [Jensen01] standard dipole, corrected eq. 4 */
    SSS_MODEL_COUNT
} sss_model;
const char *sss_model_name(sss_model m);                   /* "directional", "standard" */
int sss_model_from_name(const char *name, sss_model *out); /* 1 if known */

/* Derived constants of one channel, in scene units (coefficients per unit, lengths in units).
 * Computed once in double (the 3C2 fit cancels catastrophically in float, sss.md 1.3). */
typedef struct sss_channel {
    double sigma_a, sigma_s, sigma_t;         /* sigma_t unreduced (back-lit d_r only) */
    double sigma_s_p, sigma_t_p, alpha_p;     /* reduced: sigma_s' = sigma_s (1-g) */
    double D;                                 /* 1/(3 sigma_t') */
    double sigma_tr;                          /* sqrt(sigma_a / D) */
    /* directional dipole [Frisvad14] */
    double d_e;                               /* 2.131 D / sqrt(alpha') */
    double two_a_de;                          /* 2 A d_e: virtual source offset */
    double backlit_d2;                        /* 1/(3 sigma_t)^2 */
    /* standard dipole [Jensen01] */
    double z_r, z_v;                          /* 1/sigma_t', z_r + 4 A_J D */
} sss_channel;

typedef struct sss_constants {
    sss_material material;     /* as given (mm^-1) */
    double mm_per_unit;        /* scene scale */
    double eta;
    double two_c1, three_c2;   /* d'Eon-Irving fits at eta (2C1, 3C2) */
    double c_phi, c_e;         /* C_phi(eta) = (1-2C1)/4, C_E(eta) = (1-3C2)/2 */
    double a_dir;              /* (1 - C_E) / (2 C_phi) */
    double norm_dir;           /* 1/(4 C_phi(1/eta)) */
    double f_dr, a_jensen;     /* Jensen's F_dr(eta) and A = (1+F_dr)/(1-F_dr) */
    double min_sigma_tr;       /* min over channels, per unit; floored (see docs) for sampling */
    sss_channel ch[3];
} sss_constants;

/* The pure params-to-constants step. mm_per_unit > 0 and finite.
 * Guards (sss.md 1.3): sigma_a is floored at SSS_SIGMA_A_FLOOR so that sigma_tr > 0 (Spectralon);
 * alpha' = 0 (sigma_s = 0) gives a channel whose S_d is 0; eta = 1 exactly uses the exact values
 * 2C1 = 3C2 = 0 (A = 1) instead of either branch of the fits.
 * Returns OK or INVALID_ARGUMENT (via sss_material_validate). */
obs_status sss_constants_make(obs_context *ctx, const sss_material *m, double mm_per_unit, sss_constants *out);
#define SSS_SIGMA_A_FLOOR 1e-8 /* mm^-1; ray_engine's clamp (sss.md 1.3), keeps sigma_tr > 0 */

/* d'Eon & Irving 2011 polynomial fits, both branches (eta < 1 and eta >= 1), in double. */
double sss_fresnel_two_c1(double eta);
double sss_fresnel_three_c2(double eta);
/* Unpolarised dielectric Fresnel reflectance for a ray arriving from OUTSIDE at cos_i = n.w
 * (w towards the outside), relative IOR eta; 1 on total internal reflection (eta < 1). */
double sss_fresnel_reflectance(double cos_i, double eta);
/* Jensen 2001's diffuse Fresnel reflectance fit F_dr(eta) (with 0.0636 eta, not the thesis' typo). */
double sss_fresnel_dr(double eta);
/* Closed-form total diffuse reflectance of the standard dipole [Jensen01] eq. (after 5). */
double sss_stddipole_total_rd(double alpha_p, double eta);

/* Scalar double reference of S_d for one channel (no Fresnel transmission; clamped to >= 0).
 * xi, ni: incidence point and unit normal; wi: unit direction towards the light;
 * xo, no: exit point and unit normal. Never NaN or Inf for finite unit inputs (the guards of
 * sss.md 1.3 are documented at each line). */
double sss_sd(const sss_constants *c, sss_model model, int channel, const double xi[3], const double ni[3],
              const double wi[3], const double xo[3], const double no[3]);
/* The standard dipole's radial profile R_d(r) (per unit^2), [Jensen01] eq. 4 corrected. */
double sss_stddipole_rd(const sss_constants *c, int channel, double r);

/* Float batch evaluation, the kernel of the scattering maps. For one exit point (xo, no) and n
 * incidence samples given as structure-of-arrays, out[c][k] = T12(eta, ni.wi) * S_d(channel c)
 * when with_t12, else S_d. Lanes are samples. The AVX2 path and the scalar float path give
 * identical bits; both agree with sss_sd within the bound tested in tests/test_sss_bssrdf.c. */
typedef enum sss_isa {
    SSS_ISA_AUTO = 0,  /* AVX2 when built and supported, unless OBS_ISA=scalar */
    SSS_ISA_SCALAR,
    SSS_ISA_AVX2,
    SSS_ISA_COUNT
} sss_isa;
int sss_isa_available(sss_isa isa);
const char *sss_isa_name(sss_isa isa);

/* The float constants a GPU uniform block would carry, derived from sss_constants. */
typedef struct sss_gpu_constants {
    float sigma_tr[4], D[4], d_e[4], two_a_de[4], backlit_d2[4], z_r[4], z_v[4], alpha_p[4];
    float c_phi, c_e, norm_dir, eta;
    float inv_eta, model, pad0, pad1;         /* model: 0 directional, 1 standard */
} sss_gpu_constants;
void sss_gpu_constants_make(const sss_constants *c, sss_model model, sss_gpu_constants *out);

typedef struct sss_batch {
    int n;
    const float *xi[3], *ni[3], *wi[3];   /* SoA inputs, n each */
    float *out[3];                        /* SoA outputs, n each */
} sss_batch;
/* Returns OK, INVALID_ARGUMENT (NULLs, n < 0), UNSUPPORTED_ISA. ctx may be NULL. */
obs_status sss_eval_batch(obs_context *ctx, const sss_gpu_constants *g, const float xo[3], const float no[3],
                          const sss_batch *b, int with_t12, sss_isa isa);

/* ------------------------------------------------------------------------------------------------
 * 3. The scattering-map pipeline [DalCorso17] / [DalCorso14]
 * ---------------------------------------------------------------------------------------------- */

/* Which material each scene material slot has. Slots with translucent[i] == 0 are opaque (not
 * lit by SSS; they still cast shadows in the light G-buffer). Meshes without a material
 * (material == -1) use `none` when it is not NULL, else they are opaque. */
typedef struct sss_scene_materials {
    uint32_t count;                    /* = scene->material_count */
    const sss_constants *constants;    /* count entries */
    const uint8_t *translucent;        /* count entries */
    const sss_constants *none;         /* for material -1, or NULL */
} sss_scene_materials;

typedef enum sss_sampler {
    SSS_SAMPLER_RUSSIAN_ROULETTE = 0, /* unbiased: uniform candidates on the disk, accepted with
                                         p = exp(-sigma* r), weight disk_area/(candidates p)
                                         (the thesis' final shader, sss.md 3.5) */
    SSS_SAMPLER_NEAREST_N_OF_M,       /* the thesis text: M Halton points with exponential
                                         rejection, keep the N nearest to x_o, weight A_c/N
                                         (biased; docs/sss.md measures it) */
    SSS_SAMPLER_EXPONENTIAL,          /* the default. Unbiased importance sampling of the same
                                         density: rho by inversion of the CDF of
                                         rho e^{-sigma* rho} on [0, R], phi uniform, weight
                                         1/(N pdf); every one of the N samples counts,
                                         except that the 3 x 3 light-map texels around x_o are
                                         integrated exactly instead (their samples count 0).
                                         DEVIATION: the shipped shader is rr with 1000 frames
                                         (CONVERGENCE_FRAMES); a one-call CPU reference needs an
                                         estimator that converges in one call; `--sampler rr
                                         --frames 1000` is the shipped configuration
                                         (docs/sss/maps.md "Samplers") */
    SSS_SAMPLER_COUNT
} sss_sampler;
/* Names: "russian-roulette", "nearest-n-of-m", "exponential" (case-insensitive). */
const char *sss_sampler_name(sss_sampler s);
int sss_sampler_from_name(const char *name, sss_sampler *out);

typedef enum sss_visibility {
    SSS_VISIBILITY_PRODUCT5 = 0, /* the thesis' final combination shader: product of 5 shadow taps
                                    (centre + 4 rotated-grid taps, sss.md 3.6) */
    SSS_VISIBILITY_PCF3X3,       /* 3x3 percentage-closer average */
    SSS_VISIBILITY_COUNT
} sss_visibility;
const char *sss_visibility_name(sss_visibility v);
int sss_visibility_from_name(const char *name, sss_visibility *out);

/* Defaults name their source (sss.md section 3.7, the thesis' final code, unless said).
 * The default sampler is SSS_SAMPLER_EXPONENTIAL (ours, a DEVIATION: the shipped shader is rr
 * with 1000 frames, CONVERGENCE_FRAMES = 1000; a one-call CPU reference needs an estimator that
 * converges in one call; `--sampler rr --frames 1000` is the shipped configuration). */
#define SSS_DEFAULT_K 16                 /* LAYERS = 16 (TranslucentMaterials.cpp) */
#define SSS_DEFAULT_N 48                 /* samples per texel per frame; the bar (bunny, K=16, N=48) */
#define SSS_DEFAULT_M 1000               /* candidate points of the N-of-M variant (thesis results chapter) */
#define SSS_DEFAULT_MAP_SIZE 512         /* ARRAY_TEXTURE_SIZE = 512 */
#define SSS_DEFAULT_LIGHT_MAP_SIZE 512   /* GBUFFER_SIZE = 512 */
#define SSS_DEFAULT_SPREAD_Q 1.0         /* q: sigma* = min sigma_tr / q (thesis: q = 1) */
#define SSS_DEFAULT_SHADOW_BIAS 1e-3     /* in units of the map's depth range; reconstruction (thesis uses a GL bias, value not given) */
#define SSS_DEFAULT_SHRINK_EPS 0.002     /* eps_c ~ 2/1024 in map texture units (ss_array_combination.frag) */
#define SSS_DEFAULT_GAMMA 1.0            /* the final shader has the gamma line commented out; thesis figures use 1.8 */

typedef struct sss_params {
    sss_model model;          /* default SSS_MODEL_DIRECTIONAL */
    int K;                    /* scattering-map directions, 1..256 */
    int N;                    /* samples per texel and light (all count for exponential; candidates
                                 for Russian roulette; accepted for N-of-M) */
    int M;                    /* candidates for SSS_SAMPLER_NEAREST_N_OF_M */
    int map_size;             /* scattering-map side, 16..4096 */
    int light_map_size;       /* light G-buffer side, 16..4096 */
    int frames;               /* progressive frames accumulated, >= 1; default 1 */
    double spread_q;          /* > 0 */
    double disk_radius;       /* world units; 0 = half the diagonal of the lit mesh's bounds (default) */
    sss_sampler sampler;      /* default SSS_SAMPLER_EXPONENTIAL (a deviation, see above) */
    sss_visibility visibility;/* default SSS_VISIBILITY_PRODUCT5 */
    double shadow_bias;
    double shrink_eps;
    double gamma;             /* output = L^(1/gamma); 1 = linear */
    int specular;             /* add Blinn-Phong specular from the light (default 0) */
    double specular_exponent; /* default 64 */
    uint64_t seed;            /* default 0 */
    sss_isa isa;              /* default SSS_ISA_AUTO */
} sss_params;
sss_params sss_params_default(void);
/* Range checks of the above. Returns OK or INVALID_ARGUMENT naming the field. */
obs_status sss_params_validate(obs_context *ctx, const sss_params *p);

/* K scattering-map directions: Halton points on the sphere, bases (2, 3), k = 1..K
 * (phi = 2 pi Phi_2(k), cos theta = 2 (1 - Phi_3(k)) - 1; miscellaneous.cpp haltonPointSphere).
 * dirs has 3*K entries, unit vectors pointing from the object's centre towards the camera. */
void sss_halton_directions(int K, double *dirs);

/* Pass 1, the light G-buffer: the scene rendered from one light (orthographic for a directional
 * light, framing the scene bounds; perspective for a point light looking at the bounds' centre).
 * Owns its planes. */
typedef struct sss_light_map {
    obs_light light;
    rast_gbuffer gb;                /* depth, normals, instance and material ids */
    obs_image_f32 position[3];      /* world-space position of each texel; NaN where empty */
    obs_image_f32 wnormal[3];       /* world-space unit normal (outward, not face-forwarded) */
    double world_per_texel;         /* orthographic: texel side in world units */
} sss_light_map;
obs_status sss_light_map_render(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const obs_light *light,
                                const sss_params *p, sss_light_map *out);
void sss_light_map_free(sss_light_map *lm);   /* NULL-safe */

/* Pass 2, the scattering maps: K orthographic views (Halton directions) of the scene; each texel
 * on a translucent surface gathers, from every light map, the radiance scattered to it
 * (T12 S_d L weighted by the sampler). Depends on geometry, materials, lights and params only:
 * never on the camera. Owns its planes. */
typedef struct sss_maps {
    int K, size;
    double *dirs;                   /* 3*K */
    rast_gbuffer *views;            /* K layers: depth (for visibility), normals, ids */
    obs_image_f32 *radiance;        /* 3*K planes: layer k channel c at [3*k + c]; 0 off-object */
    uint64_t samples_evaluated;     /* BSSRDF evaluations (for the cost model) */
    uint64_t candidates;            /* disk candidates drawn */
} sss_maps;
obs_status sss_maps_build(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const sss_scene_materials *mats,
                          const sss_light_map *lights, int light_count, const sss_params *p, sss_maps *out);
void sss_maps_free(sss_maps *m);   /* NULL-safe */

/* ---- Rebuilding into the same memory (docs/sss/maps.md "Fourth round: rebuild and speed"). The
 * GPU implementation keeps its framebuffers and texture arrays from frame to frame; the CPU's
 * equivalent: when the scene changes (a light, a material, the geometry) the maps are written
 * into the storage of the previous ones, and the build's temporaries live in a workspace. A fresh
 * build's 3K radiance planes and K view G-buffers are about 60 MiB at K = 16, 512^2, which the
 * kernel must hand over page by page (page faults) on first touch. */

/* Everything sss_maps_build allocates besides the maps themselves: the rasterizer's scratch
 * (rast_workspace), per-thread sample buffers, the per-material and per-light tables (the
 * Russian-roulette pre-filter's bounds, the exponential sampler's interleaved light maps, the
 * N-of-M candidate set), the per-task counters. Grows on demand, never shrinks. Opaque; not
 * shared by concurrent rebuilds. */
typedef struct sss_maps_workspace sss_maps_workspace;
sss_maps_workspace *sss_maps_workspace_create(void);   /* NULL: out of memory */
void sss_maps_workspace_free(sss_maps_workspace *ws);    /* NULL-safe */

/* sss_maps_build into `maps`, reusing its memory. maps must be zeroed (then it is allocated, as a
 * build does) or hold maps from a build or rebuild with the same K and map_size as p (the sampler,
 * N, M, model, lights, materials and the scene may all differ: they do not change the storage).
 * Then the K views are rendered into maps->views and every radiance texel is written (0 off the
 * object), with no allocation once ws has served a rebuild of the same configuration (no page
 * fault: bench obscura_bench_sss, maps_rebuild_minflt). ws NULL: a temporary workspace.
 * The output is the same bytes as sss_maps_build's for the same arguments (tests
 * sss_maps_rebuild_*). Returns sss_maps_build's codes; INVALID_ARGUMENT, maps untouched, when
 * maps holds another K or map_size (the message names both; free them and build). On any other
 * error maps is freed (zeroed), as a build leaves out. */
obs_status sss_maps_rebuild(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const sss_scene_materials *mats,
                            const sss_light_map *lights, int light_count, const sss_params *p, sss_maps_workspace *ws,
                            sss_maps *maps);

/* Pass 3, the combination for one camera view: for each pixel of the camera G-buffer (depth,
 * normals, material ids, from rast_render with the same scene) on a translucent surface, the
 * average over the maps that see it (visibility test per params) of their radiance, times the
 * exit transmission T21(eta, n_o . w_o), plus optional specular, then ^(1/gamma).
 * out: 3 planes of the camera G-buffer's full size, allocated by the call; background and opaque
 * pixels are 0. visible_count (optional, 1 plane) receives how many maps saw each pixel. */
obs_status sss_combine(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const sss_scene_materials *mats,
                       const sss_maps *maps, const sss_light_map *lights, int light_count,
                       const rast_gbuffer *camera_gb, const obs_camera *camera, const sss_params *p,
                       obs_image_f32 out[3], obs_image_f32 *visible_count);

/* ------------------------------------------------------------------------------------------------
 * 4. A scene's translucent materials (sss_scene.c)
 * ---------------------------------------------------------------------------------------------- */

/* The materials of a scene, resolved. With `override` != NULL every mesh (with or without a
 * material) is translucent with it (the CLI's --material). Otherwise a material slot is
 * translucent when its glTF extras carry "obscura_sss" (sss_material_from_extras); other slots,
 * and meshes without a material, are opaque. Owns its arrays; `mats` points into them (and into
 * the struct itself: do not copy or move a made setup). */
typedef struct sss_scene_setup {
    sss_scene_materials mats;
    sss_constants *constants;      /* material_count entries (opaque slots zeroed) */
    uint8_t *translucent;          /* material_count entries */
    sss_constants none_constants;  /* the override, for meshes without a material */
    uint32_t translucent_slots;    /* how many slots are translucent */
    int uses_override;
} sss_scene_setup;
/* Returns OK; INVALID_ARGUMENT (mm_per_unit, a bad override); PARSE_ERROR or INVALID_ARGUMENT from
 * a material's extras (the message names the scene file and the material); OUT_OF_MEMORY. */
obs_status sss_scene_setup_make(obs_context *ctx, const obs_scene *scene, const sss_material *override,
                                double mm_per_unit, sss_scene_setup *out);
void sss_scene_setup_free(sss_scene_setup *s);   /* NULL-safe */
/* Whether any instance of the scene draws a mesh that is translucent under s. */
int sss_scene_setup_any_translucent(const sss_scene_setup *s, const obs_scene *scene);
/* The default scene scale: glTF units are metres (glTF 2.0 section 3.4), so 1000 mm per unit. */
#define SSS_DEFAULT_MM_PER_UNIT 1000.0

#ifdef __cplusplus
}
#endif

#endif /* SSS_H */
