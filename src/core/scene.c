/* scene.c: scene ownership, validation, bounds, and camera helpers (glTF 2.0 conventions). */
#include "obs.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void obs_scene_init(obs_scene *s)
{
    memset(s, 0, sizeof *s);
    s->bounds.lo = obs_v3(INFINITY, INFINITY, INFINITY);
    s->bounds.hi = obs_v3(-INFINITY, -INFINITY, -INFINITY);
}

void obs_scene_free(obs_scene *s)
{
    if (!s)
        return;
    for (uint32_t i = 0; i < s->mesh_count; i++) {
        free(s->meshes[i].positions);
        free(s->meshes[i].normals);
        free(s->meshes[i].indices);
    }
    for (uint32_t i = 0; i < s->material_count; i++)
        free(s->materials[i].extras_json);
    free(s->meshes);
    free(s->instances);
    free(s->cameras);
    free(s->lights);
    free(s->materials);
    free(s->extras_json);
    obs_scene_init(s);
}

uint64_t obs_scene_triangle_count(const obs_scene *s)
{
    uint64_t n = 0;
    for (uint32_t i = 0; i < s->instance_count; i++)
        if (s->instances[i].mesh < s->mesh_count)
            n += s->meshes[s->instances[i].mesh].triangle_count;
    return n;
}

obs_status obs_scene_validate(obs_context *ctx, const obs_scene *s)
{
    const char *src = s->source[0] ? s->source : "scene";
    const obs_limits *lim = obs_context_limits(ctx);
    uint64_t verts = 0, tris = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const obs_mesh *mesh = &s->meshes[m];
        verts += mesh->vertex_count;
        tris += mesh->triangle_count;
        if (mesh->triangle_count && (!mesh->indices || !mesh->positions))
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: mesh %u (%s) has triangles but no data", src, m,
                             mesh->name);
        uint64_t n = (uint64_t)mesh->triangle_count * 3;
        for (uint64_t i = 0; i < n; i++)
            if (mesh->indices[i] >= mesh->vertex_count)
                return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                                 "%s: mesh %u (%s): index %llu is %u, not below the vertex count %u", src, m,
                                 mesh->name, (unsigned long long)i, mesh->indices[i], mesh->vertex_count);
        if (mesh->material >= (int32_t)s->material_count || mesh->material < -1)
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: mesh %u (%s): material %d out of range", src, m,
                             mesh->name, mesh->material);
    }
    if ((int64_t)verts > lim->max_vertices)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "%s: %llu vertices, over the limit of %lld (raise it with --max-vertices)", src,
                         (unsigned long long)verts, (long long)lim->max_vertices);
    uint64_t inst_tris = obs_scene_triangle_count(s);
    if ((int64_t)tris > lim->max_triangles || (int64_t)inst_tris > lim->max_triangles)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "%s: %llu triangles, over the limit of %lld (raise it with --max-triangles)", src,
                         (unsigned long long)(inst_tris > tris ? inst_tris : tris), (long long)lim->max_triangles);
    for (uint32_t i = 0; i < s->instance_count; i++) {
        if (s->instances[i].mesh >= s->mesh_count)
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: instance %u refers to mesh %u of %u", src, i,
                             s->instances[i].mesh, s->mesh_count);
        if (!obs_mat4_is_finite(s->instances[i].world))
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: instance %u (node %u) has a non-finite transform",
                             src, i, s->instances[i].node);
    }
    for (uint32_t c = 0; c < s->camera_count; c++) {
        const obs_camera *cam = &s->cameras[c];
        if (!obs_mat4_is_finite(cam->view) || !obs_mat4_is_finite(cam->world))
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: camera %u (%s) has a non-finite transform", src, c,
                             cam->name);
    }
    return OBS_STATUS_OK;
}

void obs_scene_update_bounds(obs_scene *s)
{
    obs_vec3 lo = obs_v3(INFINITY, INFINITY, INFINITY), hi = obs_v3(-INFINITY, -INFINITY, -INFINITY);
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const obs_instance *in = &s->instances[i];
        if (in->mesh >= s->mesh_count)
            continue;
        const obs_mesh *m = &s->meshes[in->mesh];
        for (uint32_t v = 0; v < m->vertex_count; v++) {
            obs_vec3 p = obs_v3(m->positions[3 * v], m->positions[3 * v + 1], m->positions[3 * v + 2]);
            if (!isfinite(p.x) || !isfinite(p.y) || !isfinite(p.z))
                continue;
            obs_vec3 w = obs_mat4_mul_point(in->world, p);
            lo.x = fminf(lo.x, w.x); lo.y = fminf(lo.y, w.y); lo.z = fminf(lo.z, w.z);
            hi.x = fmaxf(hi.x, w.x); hi.y = fmaxf(hi.y, w.y); hi.z = fmaxf(hi.z, w.z);
        }
    }
    s->bounds.lo = lo;
    s->bounds.hi = hi;
}

/* OpenGL projection (clip z in [-w, w]) per glTF 2.0 spec, "Projection Matrices" (appendix):
 * perspective finite:   P22 = (f+n)/(n-f), P23 = 2fn/(n-f); infinite: P22 = -1, P23 = -2n;
 * orthographic:         P00 = 1/xmag, P11 = 1/ymag, P22 = 2/(n-f), P23 = (f+n)/(n-f). */
obs_mat4 obs_camera_projection_gl(const obs_camera *cam, float aspect_fallback)
{
    obs_mat4 p;
    memset(&p, 0, sizeof p);
    double n = cam->znear, f = cam->zfar;
    if (cam->projection == OBS_PROJECTION_PERSPECTIVE) {
        double aspect = cam->aspect > 0.0f ? cam->aspect : aspect_fallback;
        double t = 1.0 / tan(0.5 * (double)cam->yfov);
        p.m[0] = (float)(t / aspect);
        p.m[5] = (float)t;
        p.m[11] = -1.0f;
        if (isinf(f)) {
            p.m[10] = -1.0f;
            p.m[14] = (float)(-2.0 * n);
        } else {
            p.m[10] = (float)((f + n) / (n - f));
            p.m[14] = (float)(2.0 * f * n / (n - f));
        }
    } else {
        p.m[0] = (float)(1.0 / cam->xmag);
        p.m[5] = (float)(1.0 / cam->ymag);
        p.m[10] = (float)(2.0 / (n - f));
        p.m[14] = (float)((f + n) / (n - f));
        p.m[15] = 1.0f;
    }
    return p;
}

int obs_camera_set_world(obs_camera *cam, obs_mat4 world)
{
    obs_mat4 view;
    if (!obs_mat4_inverse(world, &view))
        return 0;
    cam->world = world;
    cam->view = view;
    return 1;
}

obs_camera obs_camera_look_at(obs_vec3 eye, obs_vec3 target, obs_vec3 up, float yfov, float znear, float zfar)
{
    obs_camera c;
    memset(&c, 0, sizeof c);
    strcpy(c.name, "look_at");
    c.projection = OBS_PROJECTION_PERSPECTIVE;
    c.yfov = yfov;
    c.aspect = 0.0f;
    c.znear = znear;
    c.zfar = zfar;
    c.view = obs_mat4_look_at(eye, target, up);
    if (!obs_mat4_inverse(c.view, &c.world))
        c.world = obs_mat4_identity();
    return c;
}

obs_camera obs_camera_frame_bounds(obs_aabb b, float yfov)
{
    obs_vec3 lo = b.lo, hi = b.hi;
    if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z)) { /* empty scene: a unit box */
        lo = obs_v3(-1, -1, -1);
        hi = obs_v3(1, 1, 1);
    }
    obs_vec3 c = obs_v3_scale(obs_v3_add(lo, hi), 0.5f);
    float r = 0.5f * obs_v3_length(obs_v3_sub(hi, lo));
    if (!(r > 0.0f))
        r = 1.0f;
    float dist = 1.05f * r / sinf(0.5f * yfov);
    obs_vec3 dir = obs_v3_normalize(obs_v3(0.0f, 0.3f, 1.0f));
    obs_vec3 eye = obs_v3_add(c, obs_v3_scale(dir, dist));
    float znear = fmaxf(dist - 1.1f * r, 1e-3f * dist);
    float zfar = dist + 1.1f * r;
    obs_camera cam = obs_camera_look_at(eye, c, obs_v3(0, 1, 0), yfov, znear, zfar);
    strcpy(cam.name, "framed");
    return cam;
}
