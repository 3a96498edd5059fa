/* sss_scene.c: which of a scene's materials are translucent, and their constants (sss.h, part 4).
 * The schema of a material's extras is docs/sss.md, "Materials in glTF". */
#include "sss.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void sss_scene_setup_free(sss_scene_setup *s)
{
    if (!s)
        return;
    free(s->constants);
    free(s->translucent);
    memset(s, 0, sizeof *s);
}

obs_status sss_scene_setup_make(obs_context *ctx, const obs_scene *scene, const sss_material *override,
                                double mm_per_unit, sss_scene_setup *out)
{
    if (!scene || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_scene_setup_make: NULL argument");
    memset(out, 0, sizeof *out);
    if (!(mm_per_unit > 0.0) || !isfinite(mm_per_unit))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "scene scale: %g mm per scene unit must be finite and > 0", mm_per_unit);
    const char *src = scene->source[0] ? scene->source : "scene";
    uint32_t n = scene->material_count;
    if (n) {
        out->constants = (sss_constants *)calloc(n, sizeof *out->constants);
        out->translucent = (uint8_t *)calloc(n, 1);
        if (!out->constants || !out->translucent) {
            sss_scene_setup_free(out);
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory for %u materials", src, n);
        }
    }
    obs_status st = OBS_STATUS_OK;
    if (override) {
        st = sss_constants_make(ctx, override, mm_per_unit, &out->none_constants);
        for (uint32_t i = 0; i < n && st == OBS_STATUS_OK; i++) {
            out->constants[i] = out->none_constants;
            out->translucent[i] = 1;
        }
        out->translucent_slots = n;
        out->uses_override = 1;
    } else {
        for (uint32_t i = 0; i < n && st == OBS_STATUS_OK; i++) {
            const obs_material *mat = &scene->materials[i];
            if (!mat->extras_json)
                continue;
            char where[OBS_NAME_MAX + 600];
            snprintf(where, sizeof where, "%s: material %u (%s)", src, i, mat->name[0] ? mat->name : "unnamed");
            sss_material m;
            int found = 0;
            st = sss_material_from_extras(ctx, mat->extras_json, where, &m, &found);
            if (st == OBS_STATUS_OK && found) {
                st = sss_constants_make(ctx, &m, mm_per_unit, &out->constants[i]);
                out->translucent[i] = 1;
                out->translucent_slots++;
            }
        }
    }
    if (st != OBS_STATUS_OK) {
        sss_scene_setup_free(out);
        return st;
    }
    out->mats.count = n;
    out->mats.constants = out->constants;
    out->mats.translucent = out->translucent;
    out->mats.none = override ? &out->none_constants : NULL;
    return OBS_STATUS_OK;
}

int sss_scene_setup_any_translucent(const sss_scene_setup *s, const obs_scene *scene)
{
    if (!s || !scene)
        return 0;
    for (uint32_t i = 0; i < scene->instance_count; i++) {
        const obs_instance *in = &scene->instances[i];
        if (in->mesh >= scene->mesh_count)
            continue;
        const obs_mesh *m = &scene->meshes[in->mesh];
        if (m->triangle_count == 0)
            continue;
        if (m->material < 0) {
            if (s->mats.none)
                return 1;
        } else if ((uint32_t)m->material < s->mats.count && s->mats.translucent[m->material]) {
            return 1;
        }
    }
    return 0;
}
