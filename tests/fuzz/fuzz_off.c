/* fuzz_off.c: OFF text through off_parse (src/tools/off.c, the data generator's mesh reader).
 *
 * Invariants checked on every input:
 *   - failure returns no arrays and says why (naming the file);
 *   - success gives at least 3 vertices and 1 triangle, counts within the context's limits,
 *     finite positions, and every index below the vertex count; every element is read. */
#include "fuzz.h"

#include "tools/off.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int obs_fuzz_off(const uint8_t *data, size_t size)
{
    /* off_parse takes NUL-terminated text (strtod must stop at the end) */
    char *text = malloc(size + 1);
    if (!text)
        return 0;
    if (size)
        memcpy(text, data, size);
    text[size] = '\0';
    obs_context *ctx = fuzz_context();
    float *pos = (float *)(uintptr_t)1; /* poison: off_parse must reset them */
    uint32_t *idx = (uint32_t *)(uintptr_t)1;
    uint32_t nv = 0, nt = 0;
    obs_status st = off_parse(ctx, "fuzz.off", text, size, &pos, &nv, &idx, &nt);
    if (st != OBS_STATUS_OK) {
        fuzz_require(pos == NULL && idx == NULL, "a failed parse returns no arrays");
        fuzz_require(strstr(obs_context_last_error(ctx), "fuzz.off") != NULL, "a failed parse names the file");
    } else {
        const obs_limits *lim = obs_context_limits(ctx);
        fuzz_require(pos != NULL && idx != NULL && nv >= 3 && nt >= 1, "a parsed mesh is not empty");
        fuzz_require((int64_t)nv <= lim->max_vertices && (int64_t)nt <= lim->max_triangles,
                     "a parsed mesh is within the limits");
        for (uint64_t i = 0; i < 3ull * nv; i++)
            fuzz_require(isfinite(pos[i]), "positions are finite");
        for (uint64_t i = 0; i < 3ull * nt; i++)
            fuzz_require(idx[i] < nv, "every index is below the vertex count");
        free(pos);
        free(idx);
    }
    obs_context_destroy(ctx);
    free(text);
    return 0;
}
