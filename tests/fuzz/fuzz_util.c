/* fuzz_util.c: helpers shared by the fuzz targets (fuzz.h). */
#include "fuzz.h"

#include <stdio.h>
#include <stdlib.h>

static void silent_log(void *user, obs_log_level level, const char *message)
{
    (void)user;
    (void)level;
    (void)message;
}

obs_context *fuzz_context(void)
{
    obs_context *ctx = obs_context_create();
    if (!ctx)
        abort();
    obs_context_set_log_callback(ctx, silent_log, NULL);
    obs_limits lim = obs_limits_default();
    lim.max_image_pixels = (int64_t)1 << 22;   /* 4 M values */
    lim.max_triangles = (int64_t)1 << 20;
    lim.max_vertices = (int64_t)1 << 20;
    lim.max_memory_bytes = (int64_t)256 << 20; /* 256 MiB per allocation group */
    obs_context_set_limits(ctx, &lim);
    return ctx;
}

void fuzz_require(int cond, const char *what)
{
    if (cond)
        return;
    fprintf(stderr, "obscura fuzz: invariant broken: %s\n", what);
    fflush(stderr);
    abort();
}
