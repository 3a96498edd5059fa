/* test_cli_image_module.c: the command without its image module (OBSCURA_IMAGE_MODULE pointing at
 * a missing file, or at a library that is not the module) fails with a message naming the module
 * and writes nothing; commands that touch no image never look for it. */
#include "test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static int exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0;
}

TEST(cli_without_its_image_module_fails_naming_it_and_writes_nothing)
{
    const char *dir = test_tmpdir();
    char scene[1024], prefix[1024], path[1100], err[1100];
    snprintf(scene, sizeof scene, "%s/sphere_on_plane.glb", test_data_dir());
    snprintf(prefix, sizeof prefix, "%s/nomodule/gb", dir);
    snprintf(err, sizeof err, "%s/nomodule.err", dir);
    const char *bad[] = {"/nonexistent/obscura_image_oiio.so", "libm.so.6"};
    const char *why[] = {"No such file", "not an obscura image module"};
    for (int i = 0; i < 2; i++) {
        CHECK(setenv("OBSCURA_IMAGE_MODULE", bad[i], 1) == 0);
        /* --help and a usage error never need images: they work (the module is not looked for) */
        const char *help[] = {"--help", NULL};
        CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, help, "/dev/null", NULL), 0);
        /* writing the G-buffer needs the module: an I/O error that names it, and no output file */
        const char *a[] = {"gbuffer", scene, "--size", "32x24", "-o", prefix, NULL};
        int rc = test_spawn(OBS_CLI_PATH, a, NULL, err);
        char *e = test_slurp(err, NULL);
        CHECK_MSG(rc != 0 && rc != 2, "%s: exit %d", bad[i], rc);
        CHECK_MSG(e && strstr(e, "image module") && strstr(e, bad[i]) && strstr(e, why[i]),
                  "the error does not name the module and why: %s", e ? e : "");
        free(e);
        static const char *const ext[] = {".exr", ".json", "_normal.png", "_depth.png"};
        for (int k = 0; k < 4; k++) {
            snprintf(path, sizeof path, "%s%s", prefix, ext[k]);
            CHECK_MSG(!exists(path), "%s was written without the image module", path);
        }
        /* reading an image needs it too */
        const char *c[] = {"compare", path, path, NULL};
        rc = test_spawn(OBS_CLI_PATH, c, NULL, err);
        e = test_slurp(err, NULL);
        CHECK_MSG(rc != 0 && e && strstr(e, "image module"), "compare: exit %d: %s", rc, e ? e : "");
        free(e);
    }
    /* with the module found again, the same command writes its files */
    CHECK(unsetenv("OBSCURA_IMAGE_MODULE") == 0);
    const char *a[] = {"gbuffer", scene, "--size", "32x24", "-o", prefix, NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, a, NULL, err), 0);
    snprintf(path, sizeof path, "%s.exr", prefix);
    CHECK(exists(path));
}
