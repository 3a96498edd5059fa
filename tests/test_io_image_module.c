/* test_io_image_module.c: OpenImageIO lives in a module (obscura_image_oiio.so) that obscura_io
 * loads on the first image read or write (src/io/io_image_module.h, docs/io.md "The image
 * module"). Each test runs in its own process (ctest runs obscura_tests NAME). */
#define _GNU_SOURCE
#include "core/obs.h"
#include "io/io.h"
#include "test.h"

#include <dlfcn.h>
#include <stdio.h>
#include <string.h>

/* Whether OpenImageIO's library is mapped into this process (RTLD_NOLOAD: never loads it). */
static int oiio_mapped(void)
{
    void *h = dlopen("libOpenImageIO.so.2.4", RTLD_LAZY | RTLD_NOLOAD);
    if (h)
        dlclose(h);
    return h != NULL;
}

TEST(io_image_module_is_loaded_only_when_an_image_is_read_or_written)
{
    /* nothing so far has touched an image: neither the module nor OpenImageIO is in the process */
    CHECK_EQ_INT(io_image_module_loaded(), 0);
    CHECK(!oiio_mapped());
    obs_context *ctx = obs_context_create();
    /* what does not need OpenImageIO does not load it */
    CHECK(io_srgb_encode(0.5f) > 0.7f);
    CHECK_EQ_INT(io_image_find_channel(NULL, "R"), -1);
    CHECK_EQ_INT(io_image_module_loaded(), 0);
    /* the first write loads it, and the image reads back */
    obs_image_f32 g;
    CHECK_OK(obs_image_f32_alloc(ctx, 4, 3, &g), ctx);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 4; x++)
            obs_image_f32_row(&g, y)[x] = 0.25f * (float)x;
    char path[1024];
    snprintf(path, sizeof path, "%s/module.png", test_tmpdir());
    CHECK_OK(io_png_write(ctx, path, &g, 1, IO_PNG_LINEAR), ctx);
    CHECK_EQ_INT(io_image_module_loaded(), 1);
    CHECK(oiio_mapped());
    io_image im;
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    CHECK_EQ_INT(im.width, 4);
    CHECK_EQ_INT(im.height, 3);
    CHECK(im.channel_count >= 1);
    if (im.channel_count >= 1)
        CHECK_NEAR(obs_image_f32_row(&im.f32[0], 2)[3], 0.75, 1.0 / 255.0);
    io_image_free(&im);
    obs_image_f32_free(&g);
    obs_context_destroy(ctx);
}
