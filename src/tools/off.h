/* off.h: a robust reader for OFF triangle meshes (Geomview's Object File Format), used by the
 * scene generator to convert the Stanford bunny, the Chinese dragon and the armadillo. */
#ifndef OBS_TOOLS_OFF_H
#define OBS_TOOLS_OFF_H

#include "core/obs.h"

/* Parse OFF text (NUL-terminated, `len` bytes): "OFF", counts (vertices, faces, edges), vertex
 * lines of 3 coordinates (extra columns such as colours are ignored), face lines "n i0 .. i{n-1}"
 * fan-triangulated. '#' starts a comment. Counts are checked against the remaining text before
 * any allocation (a vertex needs at least 6 bytes, a face at least 8), against
 * max_vertices / max_triangles, and every index against the vertex count.
 * On success fills positions (3*nv floats) and indices (3*nt), malloc'd, owned by the caller.
 * Errors name `name` and the line: PARSE_ERROR, LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status off_parse(obs_context *ctx, const char *name, const char *text, size_t len, float **positions,
                     uint32_t *nv, uint32_t **indices, uint32_t *nt);

#endif
