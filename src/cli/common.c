/* common.c: scene loading and camera choice shared by the subcommands. */
#include "cli.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

obs_status cli_load_scene(obs_context *ctx, const char *path, obs_scene *scene)
{
    io_gltf_options opt = io_gltf_options_default();
    return io_gltf_load(ctx, path, &opt, scene);
}

obs_status cli_pick_camera(obs_context *ctx, const obs_scene *s, const char *which, obs_camera *out)
{
    if (which && which[0]) {
        for (uint32_t c = 0; c < s->camera_count; c++)
            if (!strcmp(s->cameras[c].name, which)) {
                *out = s->cameras[c];
                return OBS_STATUS_OK;
            }
        long long idx;
        if (cli_parse_int(which, 0, (long long)s->camera_count - 1, &idx) && s->camera_count > 0) {
            *out = s->cameras[idx];
            return OBS_STATUS_OK;
        }
        return obs_error(ctx, OBS_STATUS_NOT_FOUND, "%s: no camera named or numbered '%s' (the scene has %u)",
                         s->source, which, s->camera_count);
    }
    for (uint32_t c = 0; c < s->camera_count; c++)
        if (!strcmp(s->cameras[c].name, "default")) {
            *out = s->cameras[c];
            return OBS_STATUS_OK;
        }
    if (s->camera_count > 0) {
        *out = s->cameras[0];
        return OBS_STATUS_OK;
    }
    *out = obs_camera_frame_bounds(s->bounds, (float)(45.0 * OBS_PI / 180.0));
    return OBS_STATUS_OK;
}

/* mkdir -p for the directory part of path. */
obs_status cli_make_parent_dirs(obs_context *ctx, const char *path)
{
    char buf[4096];
    size_t n = strlen(path);
    if (n >= sizeof buf)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "output path too long: %s", path);
    memcpy(buf, path, n + 1);
    char *slash = strrchr(buf, '/');
    if (!slash)
        return OBS_STATUS_OK;
    *slash = '\0';
    return io_make_dirs(ctx, buf);
}
