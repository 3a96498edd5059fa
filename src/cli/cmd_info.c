/* cmd_info.c: `obscura info FILE`: what a scene or an image holds. */
#include "cli.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

static int has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n >= e && !strcasecmp(path + n - e, ext);
}

static int info_scene(obs_context *ctx, const char *path)
{
    obs_scene s;
    obs_status st = cli_load_scene(ctx, path, &s);
    if (st != OBS_STATUS_OK)
        return cli_fail(ctx, st);
    uint64_t verts = 0;
    for (uint32_t m = 0; m < s.mesh_count; m++)
        verts += s.meshes[m].vertex_count;
    printf("scene: %s\n", path);
    printf("meshes: %u (%llu vertices)\n", s.mesh_count, (unsigned long long)verts);
    for (uint32_t m = 0; m < s.mesh_count; m++)
        printf("  mesh %u '%s': %u vertices, %u triangles, normals %s, material %d\n", m, s.meshes[m].name,
               s.meshes[m].vertex_count, s.meshes[m].triangle_count, s.meshes[m].normals ? "yes" : "no",
               s.meshes[m].material);
    printf("instances: %u (%llu triangles drawn)\n", s.instance_count,
           (unsigned long long)obs_scene_triangle_count(&s));
    printf("cameras: %u\n", s.camera_count);
    for (uint32_t c = 0; c < s.camera_count; c++) {
        const obs_camera *cam = &s.cameras[c];
        obs_vec3 eye = obs_mat4_mul_point(cam->world, obs_v3(0, 0, 0));
        if (cam->projection == OBS_PROJECTION_PERSPECTIVE)
            printf("  camera %u '%s': perspective, yfov %.4g deg, aspect %g, near %g, far %g, eye (%g, %g, %g)\n", c,
                   cam->name, cam->yfov * 180.0 / OBS_PI, cam->aspect, cam->znear, cam->zfar, eye.x, eye.y, eye.z);
        else
            printf("  camera %u '%s': orthographic, xmag %g, ymag %g, near %g, far %g, eye (%g, %g, %g)\n", c,
                   cam->name, cam->xmag, cam->ymag, cam->znear, cam->zfar, eye.x, eye.y, eye.z);
    }
    static const char *lt[] = {"directional", "point", "spot"};
    printf("lights: %u\n", s.light_count);
    for (uint32_t l = 0; l < s.light_count; l++) {
        const obs_light *L = &s.lights[l];
        printf("  light %u '%s': %s, intensity %g, colour (%g, %g, %g), position (%g, %g, %g), direction (%g, %g, %g)\n",
               l, L->name, L->type < OBS_LIGHT_COUNT ? lt[L->type] : "?", L->intensity, L->color.x, L->color.y,
               L->color.z, L->position.x, L->position.y, L->position.z, L->direction.x, L->direction.y, L->direction.z);
    }
    printf("materials: %u\n", s.material_count);
    for (uint32_t m = 0; m < s.material_count; m++)
        printf("  material %u '%s': base colour (%g, %g, %g, %g)%s%s\n", m, s.materials[m].name,
               s.materials[m].base_color[0], s.materials[m].base_color[1], s.materials[m].base_color[2],
               s.materials[m].base_color[3], s.materials[m].extras_json ? ", extras " : "",
               s.materials[m].extras_json ? s.materials[m].extras_json : "");
    printf("bounds: (%g, %g, %g) .. (%g, %g, %g)\n", s.bounds.lo.x, s.bounds.lo.y, s.bounds.lo.z, s.bounds.hi.x,
           s.bounds.hi.y, s.bounds.hi.z);
    obs_scene_free(&s);
    return CLI_EXIT_OK;
}

static int info_image(obs_context *ctx, const char *path)
{
    io_image im;
    obs_status st = io_image_read(ctx, path, &im);
    if (st != OBS_STATUS_OK)
        return cli_fail(ctx, st);
    printf("image: %s\n", path);
    printf("size: %dx%d, %d channels\n", im.width, im.height, im.channel_count);
    for (int c = 0; c < im.channel_count; c++) {
        double lo = INFINITY, hi = -INFINITY;
        long long nonfinite = 0;
        for (int y = 0; y < im.height; y++)
            for (int x = 0; x < im.width; x++) {
                double v = im.types[c] == IO_PIXEL_UINT ? (double)obs_image_u32_row(&im.u32[c], y)[x]
                                                        : (double)obs_image_f32_row(&im.f32[c], y)[x];
                if (!isfinite(v)) {
                    nonfinite++;
                    continue;
                }
                lo = v < lo ? v : lo;
                hi = v > hi ? v : hi;
            }
        printf("  channel '%s' (%s): min %g, max %g, non-finite %lld\n", im.names[c],
               im.types[c] == IO_PIXEL_UINT ? "uint" : "float", lo, hi, nonfinite);
    }
    printf("attributes: %d\n", im.attr_count);
    for (int a = 0; a < im.attr_count; a++) {
        const io_attr *at = &im.attrs[a];
        printf("  %s = ", at->name);
        switch (at->type) {
        case IO_ATTR_STRING: printf("\"%s\"\n", at->s ? at->s : ""); break;
        case IO_ATTR_FLOAT: printf("%g\n", at->f); break;
        case IO_ATTR_INT: printf("%lld\n", (long long)at->i); break;
        default:
            printf("[");
            for (int k = 0; k < at->n && at->v; k++)
                printf("%s%g", k ? ", " : "", at->v[k]);
            printf("]\n");
        }
    }
    io_image_free(&im);
    return CLI_EXIT_OK;
}

int cmd_info(cli_globals *g, int argc, char **argv)
{
    const char *path = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            printf("usage: obscura info FILE   (a .gltf/.glb scene, or an image OpenImageIO reads)\n");
            return CLI_EXIT_OK;
        }
        int r = cli_limit_flag(g, argc, argv, &i);
        if (r < 0) return CLI_EXIT_USAGE;
        if (r > 0) continue;
        if (argv[i][0] == '-')
            return cli_usage_error("info: unknown option '%s'", argv[i]);
        if (path)
            return cli_usage_error("info: more than one file given");
        path = argv[i];
    }
    if (!path)
        return cli_usage_error("info: no file given");
    obs_context *ctx = obs_context_create();
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    obs_context_set_limits(ctx, &g->limits);
    int code = (has_ext(path, ".gltf") || has_ext(path, ".glb")) ? info_scene(ctx, path) : info_image(ctx, path);
    obs_context_destroy(ctx);
    return code;
}
