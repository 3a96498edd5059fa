/* sss_maps_internal.h: shared pieces of the scattering-map passes (sss_maps.c, sss_combine.c) and
 * the hooks tests/test_sss_maps.c uses to check the samplers. Not installed. */
#ifndef SSS_MAPS_INTERNAL_H
#define SSS_MAPS_INTERNAL_H

#include "sss.h"

#include <math.h>

/* ---- The per-texel random stream (docs/sss/maps.md, "Randomness": the exact recipe) ---------
 * Seeded with TEA [Wheeler94], 16 rounds, the key constants of Dal Corso's
 * ss_aincludes_random.glinc (the OptiX SDK's tea<16>), then advanced by the LCG
 * state = 1664525 state + 1013904223 (mod 2^32) (Numerical Recipes' constants, as the same
 * file's lcg()). A float is the TOP 24 bits of the new state times 2^-24 (the shader masks the
 * LOW 24 bits, which have short periods: a deviation, documented). uint32 operations only. */
static inline uint32_t sss_i_tea16(uint32_t v0, uint32_t v1)
{
    uint32_t s0 = 0;
    for (int n = 0; n < 16; n++) {
        s0 += 0x9e3779b9u;
        v0 += ((v1 << 4) + 0xa341316cu) ^ (v1 + s0) ^ ((v1 >> 5) + 0xc8013ea4u);
        v1 += ((v0 << 4) + 0xad90777du) ^ (v0 + s0) ^ ((v0 >> 5) + 0x7e95761eu);
    }
    return v0;
}
/* The stream of texel `texel` (y * size + x), layer k, frame f of `frames`, seed:
 * state0 = tea16(tea16(texel, k * frames + f), seed_lo ^ seed_hi). */
static inline uint32_t sss_i_stream_seed(uint32_t texel, uint32_t layer_frame, uint64_t seed)
{
    return sss_i_tea16(sss_i_tea16(texel, layer_frame), (uint32_t)seed ^ (uint32_t)(seed >> 32));
}
static inline float sss_i_rand(uint32_t *state)
{
    *state = 1664525u * *state + 1013904223u;
    return (float)(*state >> 8) * (1.0f / 16777216.0f);
}

/* One Russian-roulette candidate ([DalCorso14] final shader, sss.md 3.4): three draws, in this
 * order: rho = R sqrt(z1), phi = 2 pi z2, zeta = z3; the disk offset is (rho cos phi, rho sin phi)
 * in the light-map plane (x right, y up). The caller accepts when zeta < exp(-sigma* |x_o - x_i|). */
static inline void sss_i_rr_candidate(uint32_t *state, double R, double *ox, double *oy, double *zeta)
{
    double u1 = sss_i_rand(state), u2 = sss_i_rand(state);
    *zeta = sss_i_rand(state);
    double rho = R * sqrt(u1), phi = 2.0 * OBS_PI * u2;
    *ox = rho * cos(phi);
    *oy = rho * sin(phi);
}

/* ---- The N-of-M candidate set: M Halton (2,3) points on the disk of radius 1 ----------------
 * [DalCorso14] method.tex "planeHaltonCircleRejectionExponential" with the final code's
 * area-uniform mapping (miscellaneous.cpp haltonPointCircle): rho = sqrt(Phi_2(j)),
 * phi = 2 pi Phi_3(j), j = 1..M. Kept sorted by rho (ties by j) so that the nearest accepted
 * points come first. */
typedef struct sss_i_halton_disk {
    int M;
    float *rho;    /* M, ascending */
    float *phi;    /* M */
} sss_i_halton_disk;
obs_status sss_i_halton_disk_make(obs_context *ctx, int M, sss_i_halton_disk *out);
void sss_i_halton_disk_free(sss_i_halton_disk *h);
/* Visit the candidates in order of rho, drawing one zeta per visited candidate from *state, and
 * accept candidate j when exp(-sigma_r * rho_j) > zeta (sigma_r = sigma* R: rho is on the unit
 * disk); stop after `keep` acceptances (keep <= 0: visit all M). Writes accepted indices into
 * idx (room for M) and returns how many. */
int sss_i_nofm_accept(const sss_i_halton_disk *h, uint32_t *state, double sigma_r, int keep, int *idx, int *visited);

/* The receiver's depth in a map as a plane over pixel positions:
 * depth(x, y) = d0 + gx (x - px0) + gy (y - py0). */
typedef struct sss_i_depth_plane {
    double px0, py0, d0, gx, gy;
} sss_i_depth_plane;
/* A map sees x_o only when n_o . w_d > this (cos 87 degrees): at grazing angles the texel's
 * radiance belongs to a sliver of surface and the depth plane is ill-conditioned. */
#define SSS_I_MIN_FACING 0.05
/* The visibility of a point whose (shrunk) projection is at pixel position (px, py) in map layer
 * gb (sss_combine.c): PRODUCT5 in {0, 1}, PCF3X3 in {0, 1/9, .., 1}. bias in depth units. */
double sss_i_visibility(const rast_gbuffer *gb, sss_visibility mode, double px, double py,
                        const sss_i_depth_plane *pl, double bias);

/* ---- Geometry helpers -------------------------------------------------------------------- */
/* Projection of a world point into a view's full image: continuous pixel coordinates (pixel
 * centre x + 0.5, row 0 top), linear depth, and pixels per world unit in the view plane at
 * that depth. Returns 0 behind a perspective eye. Uses the view constants only (the inverse of
 * rast_pixel_ray's model). */
int sss_i_project(const rast_view_constants *vc, const double p[3], double *px, double *py, double *depth,
                  double *px_per_unit);
/* World position of pixel position (px, py) at linear depth `depth` (rast_pixel_ray's model;
 * the view matrix is rigid, so view -> world is R^T (p - t), in double). */
void sss_i_pixel_world(const rast_view_constants *vc, double px, double py, double depth, double out[3]);
/* View-space normal -> world (R^T n), normalised; zero stays zero. */
void sss_i_normal_world(const rast_view_constants *vc, const float nv[3], double out[3]);
/* The material constants of a G-buffer material id, or NULL when opaque. */
const sss_constants *sss_i_material(const sss_scene_materials *mats, uint32_t material_id);
/* Scene framing: centre and radius of the bounds' bounding sphere. INVALID_ARGUMENT when empty. */
obs_status sss_i_scene_sphere(obs_context *ctx, const obs_scene *scene, double c[3], double *radius);

#endif
