/* test_cli_render.c: `obscura render` end to end (docs/render.md, docs/cli.md): the dry run's
 * plan, the three files of a render and their names, several scenes and cameras in one call, and
 * refusals (bad flags, a bad "obscura_render" key in a scene) that name the problem and write
 * nothing. The sizes are tiny: seconds even under the sanitizers. */
#include "core/obs.h"
#include "io/io.h"
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static int rc_exists(const char *dir, const char *name)
{
    struct stat st;
    return stat(test_path(dir, name), &st) == 0;
}

static const char *rc_scene(const char *name) { return test_path(test_data_dir(), name); }

/* Small and quick: a tiny image, small shadow maps. */
#define RC_SMALL "--size", "64x48", "--shadow-map-size", "128"

/* The lines of <tmpdir>/<tag>.stdout that contain both a and b. */
static int rc_stdout_lines_with(const char *tag, const char *a, const char *b)
{
    char name[256];
    snprintf(name, sizeof name, "%s.stdout", tag);
    char *out = test_slurp(test_path(test_tmpdir(), name), NULL);
    int n = 0;
    for (char *line = out ? strtok(out, "\n") : NULL; line; line = strtok(NULL, "\n"))
        if (strstr(line, a) && (!b || strstr(line, b)))
            n++;
    free(out);
    return n;
}

TEST(cli_render_dry_run_of_an_opaque_scene_plans_no_sss_or_volume_pass_and_writes_nothing)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s/plan", test_tmpdir());
    const char *a[] = {"render", rc_scene("sphere_on_plane.glb"), "--camera", "default", RC_SMALL, "--dry-run", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a, "dry"), 0);
    /* The plan lists the G-buffer as planned; no SSS or volume pass is planned (at most culled). */
    CHECK(rc_stdout_lines_with("dry", "gbuffer", "planned") >= 1);
    CHECK_EQ_INT(rc_stdout_lines_with("dry", "sss", "planned"), 0);
    CHECK_EQ_INT(rc_stdout_lines_with("dry", "light_volume", "planned"), 0);
    CHECK_EQ_INT(rc_stdout_lines_with("dry", "raycast", "planned"), 0);
    CHECK(!rc_exists(test_tmpdir(), "plan"));
    /* The default scene plans every effect. */
    const char *b[] = {"render", rc_scene("cornell_hybrid.glb"), RC_SMALL, "--dry-run", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(b, "dry2"), 0);
    CHECK(rc_stdout_lines_with("dry2", "sss", "planned") >= 1);
    CHECK(rc_stdout_lines_with("dry2", "ao", "planned") >= 1);
    CHECK(rc_stdout_lines_with("dry2", "light_volume", "planned") >= 1);
    /* AO off: no AO pass planned. */
    const char *c[] = {"render", rc_scene("sphere_on_plane.glb"), "--camera", "0", RC_SMALL, "--ao", "none", "--dry-run", NULL};
    CHECK_EQ_INT(test_cli_run(c, "dry3"), 0);
    CHECK_EQ_INT(rc_stdout_lines_with("dry3", " ao ", "planned"), 0);
    CHECK(!rc_exists(test_tmpdir(), "plan"));
}

TEST(cli_render_writes_the_layered_exr_the_png_and_the_sidecar)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s/out", test_tmpdir());
    const char *a[] = {"render", rc_scene("sphere_on_plane.glb"), "--camera", "default", RC_SMALL, "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a, "run"), 0);
    CHECK(rc_exists(dir, "sphere_on_plane.exr"));
    CHECK(rc_exists(dir, "sphere_on_plane.png"));
    CHECK(rc_exists(dir, "sphere_on_plane.json"));
    /* It says where they are, with the pass log. */
    CHECK(rc_stdout_lines_with("run", "sphere_on_plane.png", NULL) >= 1);
    CHECK(rc_stdout_lines_with("run", "sphere_on_plane.exr", NULL) >= 1);
    CHECK(rc_stdout_lines_with("run", "gbuffer", "ran") >= 1);
    obs_context *ctx = obs_context_create();
    io_image im;
    memset(&im, 0, sizeof im);
    CHECK_OK(io_image_read(ctx, test_path(dir, "sphere_on_plane.exr"), &im), ctx);
    CHECK_EQ_INT(im.width, 64);
    CHECK_EQ_INT(im.height, 48);
    int r = io_image_find_channel(&im, "beauty.R");
    CHECK(r >= 0);
    if (r >= 0) {
        /* The beauty image: finite, >= 0, and lit somewhere (the sphere and the ground). */
        int64_t bad = 0, lit = 0;
        for (int y = 0; y < im.height; y++)
            for (int x = 0; x < im.width; x++) {
                float v = obs_image_f32_row(&im.f32[r], y)[x];
                bad += !(isfinite(v) && v >= 0.0f);
                lit += v > 0.0f;
            }
        CHECK_EQ_INT(bad, 0);
        CHECK(lit > 100);
    }
    /* An opaque scene has no SSS layer. */
    CHECK(io_image_find_channel(&im, "sss.R") < 0);
    io_image_free(&im);
    char *js = test_slurp(test_path(dir, "sphere_on_plane.json"), NULL);
    CHECK(js && strstr(js, "\"settings\"") && strstr(js, "gbuffer"));
    free(js);
    obs_context_destroy(ctx);
}

TEST(cli_render_several_scenes_and_cameras_in_one_call_name_their_files)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s/batch", test_tmpdir());
    /* sphere_on_plane.glb has two cameras (default, view2): both render, with the camera in the name;
     * plane.glb has one: no suffix. */
    const char *a[] = {"render", rc_scene("sphere_on_plane.glb"), rc_scene("plane.glb"), RC_SMALL, "--ao", "none",
                       "--outputs", "beauty,depth", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a, "batch"), 0);
    static const char *const files[] = {
        "sphere_on_plane_default.exr", "sphere_on_plane_default.png", "sphere_on_plane_default.json",
        "sphere_on_plane_view2.exr",   "sphere_on_plane_view2.png",   "sphere_on_plane_view2.json",
        "plane.exr",                   "plane.png",                   "plane.json"};
    for (size_t k = 0; k < sizeof files / sizeof files[0]; k++)
        CHECK_MSG(rc_exists(dir, files[k]), "missing %s", files[k]);
    /* --camera picks one by name in each scene that has it. */
    const char *b[] = {"render", rc_scene("sphere_on_plane.glb"), RC_SMALL, "--camera", "view2", "--camera", "default",
                       "--outputs", "depth", "-o", test_path(test_tmpdir(), "two"), NULL};
    CHECK_EQ_INT(test_cli_run(b, "two"), 0);
    CHECK(rc_exists(test_path(test_tmpdir(), "two"), "sphere_on_plane_view2.exr"));
    CHECK(rc_exists(test_path(test_tmpdir(), "two"), "sphere_on_plane_default.exr"));
    /* The same camera twice: the second view does not overwrite the first. */
    const char *c[] = {"render", rc_scene("sphere_on_plane.glb"), RC_SMALL, "--camera", "view2", "--camera", "1",
                       "--outputs", "depth", "-o", test_path(test_tmpdir(), "same"), NULL};
    CHECK_EQ_INT(test_cli_run(c, "same"), 0);
    CHECK(rc_exists(test_path(test_tmpdir(), "same"), "sphere_on_plane_view2_0.exr"));
    CHECK(rc_exists(test_path(test_tmpdir(), "same"), "sphere_on_plane_view2_1.exr"));
}

TEST(cli_render_bad_flags_are_usage_errors_that_name_the_problem)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s/never", test_tmpdir());
    const char *a1[] = {"render", rc_scene("sphere_on_plane.glb"), "--size", "0x10", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a1, "a1"), 2);
    CHECK(test_cli_stderr_has("a1", "--size"));
    const char *a2[] = {"render", rc_scene("sphere_on_plane.glb"), "--outputs", "beauty,bloom", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a2, "a2"), 2);
    CHECK(test_cli_stderr_has("a2", "bloom"));
    const char *a3[] = {"render", rc_scene("sphere_on_plane.glb"), "--ao", "ssdo", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a3, "a3"), 2);
    CHECK(test_cli_stderr_has("a3", "ssdo"));
    const char *a4[] = {"render", rc_scene("sphere_on_plane.glb"), "--set", "sss.KK=3", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a4, "a4"), 2);
    CHECK(test_cli_stderr_has("a4", "obscura_render.sss.KK: unknown key"));
    const char *a5[] = {"render", rc_scene("sphere_on_plane.glb"), "--ao-param", "radius=-1", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a5, "a5"), 2);
    CHECK(test_cli_stderr_has("a5", "obscura_render.ao.radius"));
    const char *a6[] = {"render", rc_scene("sphere_on_plane.glb"), "--frobnicate", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a6, "a6"), 2);
    CHECK(test_cli_stderr_has("a6", "--frobnicate"));
    const char *a11[] = {"render", rc_scene("sphere_on_plane.glb"), "--cache-memory", "0", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a11, "a11"), 2);
    CHECK(test_cli_stderr_has("a11", "--cache-memory"));
    const char *a7[] = {"render", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a7, "a7"), 2);
    const char *a8[] = {"render", rc_scene("sphere_on_plane.glb"), "--ao", "none", "--ao-param", "radius=1", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a8, "a8"), 2);
    /* A camera the scene does not have: an input error, naming it and the scene's cameras. */
    const char *a9[] = {"render", rc_scene("sphere_on_plane.glb"), "--camera", "nope", "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a9, "a9"), 3);
    CHECK(test_cli_stderr_has("a9", "nope") && test_cli_stderr_has("a9", "view2"));
    /* A missing scene. */
    const char *a10[] = {"render", test_path(test_tmpdir(), "missing.glb"), "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a10, "a10"), 3);
    CHECK(!rc_exists(test_tmpdir(), "never"));
}

TEST(cli_render_scene_with_a_bad_obscura_render_key_is_refused_naming_the_key)
{
    /* sphere_on_plane.glb with extras that misspell a key. */
    obs_context *ctx = obs_context_create();
    obs_scene sc;
    obs_scene_init(&sc);
    io_gltf_options opt = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, rc_scene("sphere_on_plane.glb"), &opt, &sc), ctx);
    sc.extras_json = strdup("{\"obscura_render\":{\"sss\":{\"KK\":4}}}");
    const char *path = test_path(test_tmpdir(), "bad_settings.glb");
    char scene_path[4200];
    snprintf(scene_path, sizeof scene_path, "%s", path);
    CHECK_OK(io_glb_write(ctx, scene_path, &sc), ctx);
    obs_scene_free(&sc);
    char dir[4096];
    snprintf(dir, sizeof dir, "%s/never", test_tmpdir());
    const char *a[] = {"render", scene_path, "-o", dir, NULL};
    CHECK_EQ_INT(test_cli_run(a, "bad"), 3);
    CHECK(test_cli_stderr_has("bad", "bad_settings.glb") && test_cli_stderr_has("bad", "obscura_render.sss.KK") &&
          test_cli_stderr_has("bad", "unknown key"));
    /* The dry run refuses it too. */
    const char *b[] = {"render", scene_path, "--dry-run", NULL};
    CHECK_EQ_INT(test_cli_run(b, "bad2"), 3);
    CHECK(!rc_exists(test_tmpdir(), "never"));
    obs_context_destroy(ctx);
}

TEST(cli_render_help_lists_the_flags)
{
    const char *a[] = {"render", "--help", NULL};
    CHECK_EQ_INT(test_cli_run(a, "help"), 0);
    CHECK(rc_stdout_lines_with("help", "--dry-run", NULL) >= 1);
    CHECK(rc_stdout_lines_with("help", "--reference", NULL) >= 1);
    CHECK(rc_stdout_lines_with("help", "--cache", NULL) >= 1);
    CHECK(rc_stdout_lines_with("help", "obscura_render", NULL) >= 1);
    const char *b[] = {"--help", NULL};
    CHECK_EQ_INT(test_cli_run(b, "mainhelp"), 0);
    CHECK(rc_stdout_lines_with("mainhelp", "render SCENE", NULL) >= 1);
}
