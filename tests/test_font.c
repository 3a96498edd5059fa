/* test_font.c: the embedded bitmap font (src/core/obs_font.h) and the labels it writes into the
 * study's image grids (study_ao_i_grid_*, src/study/study_ao_report.c). */
#include "core/obs.h"
#include "core/obs_font.h"
#include "study/study_ao_internal.h"
#include "test.h"

#include <stdio.h>
#include <string.h>

/* 'A' as the font's source draws it (font8x8_basic.h, U+0041: 0C 1E 33 33 3F 33 33 00), written
 * out by hand, left to right, so the bit order is checked independently of the table. */
static const char *const glyph_A[8] = {"..##....", ".####...", "##..##..", "##..##..",
                                       "######..", "##..##..", "##..##..", "........"};

TEST(font_glyph_renders_its_known_bitmap_at_each_scale)
{
    obs_context *ctx = obs_context_create();
    const unsigned char *a = obs_font_glyph('A');
    static const unsigned char want[8] = {0x0C, 0x1E, 0x33, 0x33, 0x3F, 0x33, 0x33, 0x00};
    CHECK(memcmp(a, want, 8) == 0);
    for (int scale = 1; scale <= 3; scale++) {
        obs_image_f32 im = {0};
        CHECK_OK(obs_image_f32_alloc(ctx, 12 * scale, 10 * scale, &im), ctx);
        obs_image_f32_fill(&im, 0.5f);
        const float ink = 1.0f;
        /* drawn at (1, 1) * scale: the glyph's pixels become scale x scale blocks; the rest is untouched */
        const int end = obs_font_draw(&im, 1, scale, scale, scale, &ink, "A");
        CHECK_EQ_INT(end, scale + 8 * scale);
        int bad = 0;
        for (int y = 0; y < im.height; y++)
            for (int x = 0; x < im.width; x++) {
                const int gx = x / scale - 1, gy = y / scale - 1;
                const int on = gx >= 0 && gx < 8 && gy >= 0 && gy < 8 && glyph_A[gy][gx] == '#';
                bad += obs_image_f32_row(&im, y)[x] != (on ? 1.0f : 0.5f);
            }
        CHECK_MSG(bad == 0, "scale %d: %d pixels differ from the bitmap", scale, bad);
        obs_image_f32_free(&im);
    }
    obs_context_destroy(ctx);
}

TEST(font_clips_to_the_image_and_maps_unknown_characters_to_a_question_mark)
{
    obs_context *ctx = obs_context_create();
    CHECK(obs_font_glyph(0x7F) == obs_font_glyph('?') && obs_font_glyph(-1) == obs_font_glyph('?') &&
          obs_font_glyph(0xE9) == obs_font_glyph('?') && obs_font_glyph(' ') != obs_font_glyph('?'));
    for (int i = 0; i < 8; i++)
        CHECK(obs_font_glyph(' ')[i] == 0);
    CHECK_EQ_INT(obs_font_text_width("abc", 2), 48);
    CHECK_EQ_INT(obs_font_text_width(NULL, 2), 0);
    CHECK_EQ_INT(obs_font_fit_scale("abc", 48, 5), 2);
    CHECK_EQ_INT(obs_font_fit_scale("abc", 10, 5), 1);
    obs_image_f32 im = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 16, 16, &im), ctx);
    const float ink = 1.0f;
    /* partly and wholly outside: no write outside the plane (ASan would see it), the visible part drawn */
    obs_font_draw(&im, 1, -20, -4, 3, &ink, "HH");
    obs_font_draw(&im, 1, 12, 12, 4, &ink, "W");
    obs_font_draw(&im, 1, 100, 100, 1, &ink, "x");
    obs_font_fill_rect(&im, 1, -5, -5, 3, 3, &ink);
    double sum = 0.0;
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 16; x++)
            sum += obs_image_f32_row(&im, y)[x];
    CHECK(sum > 0.0);
    obs_image_f32_free(&im);
    obs_context_destroy(ctx);
}

/* Is any pixel of rgb in the rectangle exactly black (the labels' ink)? */
static int has_ink(const obs_image_f32 rgb[3], int x0, int y0, int w, int h)
{
    for (int y = y0; y < y0 + h; y++)
        for (int x = x0; x < x0 + w; x++)
            if (obs_image_f32_row(&rgb[0], y)[x] == 0.0f && obs_image_f32_row(&rgb[1], y)[x] == 0.0f &&
                obs_image_f32_row(&rgb[2], y)[x] == 0.0f)
                return 1;
    return 0;
}

TEST(study_grid_labels_write_the_bands_and_leave_the_images_unchanged)
{
    obs_context *ctx = obs_context_create();
    const char *labels[3] = {"sao: 16 samples, radius 0.125 m, blur on\n20.48 ms at 1920x1080, calibrated RMSE 0.025",
                             "gtao: 4 samples, radius 0.125 m, blur on\n56.66 ms at 1920x1080, calibrated RMSE 0.031",
                             "mssao: 16 samples, radius 0.125 m, blur off\nnot measured at 1920x1080"};
    study_ao_i_grid g;
    study_ao_i_grid_layout(&g, 480, 270, 3, labels);
    CHECK_EQ_INT(g.scale, 2);
    CHECK_EQ_INT(g.width, 3 * 480 + 2 * g.gap);
    CHECK(g.title_h >= 8 * g.scale && g.label_h >= 2 * 8 * g.scale);
    /* a 4K grid's text is scaled up; a line too long for the grid brings the scale down */
    study_ao_i_grid g4;
    study_ao_i_grid_layout(&g4, 3840, 2160, 3, labels);
    CHECK_EQ_INT(g4.scale, 12);
    const char *wide[1] = {
        "a label far too long to be written at the scale the width alone would give it, so it shrinks"};
    study_ao_i_grid gw;
    study_ao_i_grid_layout(&gw, 480, 270, 1, wide);
    CHECK(gw.scale == 1);

    obs_image_f32 rgb[3] = {{0}, {0}, {0}}, before[3] = {{0}, {0}, {0}};
    for (int c = 0; c < 3; c++) {
        CHECK_OK(obs_image_f32_alloc(ctx, g.width, g.height, &rgb[c]), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, g.width, g.height, &before[c]), ctx);
        /* a pattern with no exact black, in the cells, gaps and bands alike */
        for (int y = 0; y < g.height; y++)
            for (int x = 0; x < g.width; x++)
                obs_image_f32_row(&rgb[c], y)[x] = obs_image_f32_row(&before[c], y)[x] =
                    0.1f + 0.8f * (float)((x * 7 + y * 13 + c * 5) % 97) / 97.0f;
    }
    study_ao_i_grid_draw_labels(&g, rgb, labels);
    /* the cells are unchanged, pixel for pixel */
    int changed = 0;
    for (int r = 0; r < 3; r++)
        for (int col = 0; col < 3; col++) {
            int x0, y0;
            study_ao_i_grid_cell_origin(&g, r, col, &x0, &y0);
            CHECK(x0 + 480 <= g.width && y0 + 270 <= g.height);
            for (int c = 0; c < 3; c++)
                for (int y = y0; y < y0 + 270; y++)
                    changed += memcmp(obs_image_f32_row(&rgb[c], y) + x0, obs_image_f32_row(&before[c], y) + x0,
                                      480 * sizeof(float)) != 0;
        }
    CHECK_MSG(changed == 0, "%d cell rows changed", changed);
    /* the title band: a title over each column, and the error column's colour bar */
    for (int col = 0; col < 3; col++)
        CHECK_MSG(has_ink(rgb, col * (480 + g.gap), 0, 480, g.title_h), "no title over column %d", col);
    /* the first title starts with 'A', drawn at (2s, 2s) with its known bitmap, black on the band */
    int bad = 0;
    for (int gy = 0; gy < 8; gy++)
        for (int gx = 0; gx < 8; gx++) {
            const float v = obs_image_f32_row(&rgb[0], 2 * g.scale + gy * g.scale)[2 * g.scale + gx * g.scale];
            bad += v != (glyph_A[gy][gx] == '#' ? 0.0f : 0.85f);
        }
    CHECK_MSG(bad == 0, "%d pixels of the title's 'A' differ", bad);
    /* each row's label band: ink on both lines, directly above the row's cells */
    for (int r = 0; r < 3; r++) {
        int x0, y0;
        study_ao_i_grid_cell_origin(&g, r, 0, &x0, &y0);
        const int top = y0 - g.label_h, line = 8 * g.scale + g.scale;
        CHECK_MSG(has_ink(rgb, 0, top, g.width, line), "row %d: no first line", r);
        CHECK_MSG(has_ink(rgb, 0, top + line, g.width, g.label_h - line), "row %d: no second line", r);
    }
    for (int c = 0; c < 3; c++) {
        obs_image_f32_free(&rgb[c]);
        obs_image_f32_free(&before[c]);
    }
    obs_context_destroy(ctx);
}
