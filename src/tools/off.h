/* off.h: a robust reader for OFF triangle meshes (Geomview's Object File Format), used by the
 * scene generator to convert the Stanford bunny, the Chinese dragon and the armadillo. */
#ifndef OBS_TOOLS_OFF_H
#define OBS_TOOLS_OFF_H

#include "core/obs.h"

/* Parse OFF text (NUL-terminated, `len` bytes): the keyword "OFF", counts (vertices, faces,
 * edges), one vertex per line (3 coordinates; extra numeric columns such as colours are
 * ignored), one face per line "n i0 .. i{n-1} [colour]" (n >= 3, fan-triangulated). '#' starts a
 * comment anywhere. A record must fit on its line, and nothing but blanks and comments may follow
 * the last face (off.c has the grammar). Counts are checked against the remaining text before
 * any allocation (a vertex needs at least 6 bytes, a face at least 8), against the context's
 * max_vertices / max_triangles, and every index against the vertex count.
 * On success fills positions (3*nv floats) and indices (3*nt), malloc'd, owned by the caller.
 * On failure both pointers are NULL and the message names `name` and, for content errors, the
 * line. Returns: OK; INVALID_ARGUMENT (NULL text or counts); PARSE_ERROR (malformed or
 * truncated content, including counts that cannot fit in the text); LIMIT_EXCEEDED;
 * OUT_OF_MEMORY. */
obs_status off_parse(obs_context *ctx, const char *name, const char *text, size_t len, float **positions,
                     uint32_t *nv, uint32_t **indices, uint32_t *nt);

#endif
