/* bench_scene.h: the benchmarks' scene: a mesh framed exactly as the llvmpipe peer
 * (../shared/tools/llvmpipe-peer) frames its OFF mesh, so that both render the same pixels: the
 * mesh is centred on its bounding-box centre and scaled so that the farthest vertex is at radius
 * 10; the camera sits at (0, 0, dist) looking down -Z with fovy 45 degrees, dist = 10 / sin(fovy/2),
 * near = max(dist - 11, 0.5), far = dist + 11. */
#ifndef OBS_BENCH_SCENE_H
#define OBS_BENCH_SCENE_H

#include "core/obs.h"

/* Load MESH (glTF/GLB) and frame it. Returns 0, or 3 with the error printed to stderr. */
int bench_load_framed(obs_context *ctx, const char *mesh, obs_scene *out_scene, obs_camera *out_cam);

#endif
