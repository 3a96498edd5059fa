/* obs_font.h: a tiny embedded bitmap font (8x8 pixels, printable ASCII) for writing labels into
 * images, such as the study's image grids (src/study/study_ao_report.c). No dependencies, no
 * allocation: text is drawn into float planes at an integer scale, clipped to the planes.
 *
 * The glyphs are the public-domain 8x8 VGA font as collected in font8x8_basic.h (font.c says where
 * from). Each glyph is 8 rows, top first; bit i of a row is column i counted from the left. A glyph
 * occupies its whole 8x8 cell (no extra spacing): the font's glyphs leave their own blank column
 * and row, so cells are laid edge to edge. */
#ifndef OBS_FONT_H
#define OBS_FONT_H

#include "obs.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OBS_FONT_GLYPH_W 8 /* pixels per glyph cell at scale 1 (the font's cell: font.c) */
#define OBS_FONT_GLYPH_H 8

/* The 8 rows of character c's glyph (top first; bit i = column i from the left). Characters
 * outside printable ASCII (0x20..0x7E) get the glyph of '?'. */
const unsigned char *obs_font_glyph(int c);

/* Width in pixels of `text` drawn on one line at `scale` (strlen * 8 * scale; 0 for NULL). */
int obs_font_text_width(const char *text, int scale);

/* The largest integer scale in [1, max_scale] at which `text` is at most `width` pixels wide;
 * 1 when even scale 1 is wider (the text is then clipped where drawn). */
int obs_font_fit_scale(const char *text, int width, int max_scale);

/* Draw `text` on one line with the top-left corner of its first cell at (x, y): each set glyph
 * pixel becomes a scale x scale block with value colour[p] in planes[p], for each of the
 * plane_count planes (all of the same size). Unset glyph pixels are left as they are (draw a band
 * first for a background). Pixels outside the planes are skipped. Returns the x just after the
 * last cell. Preconditions: scale >= 1; planes and colour have plane_count entries. */
int obs_font_draw(obs_image_f32 *planes, int plane_count, int x, int y, int scale, const float *colour,
                  const char *text);

/* Set the rectangle [x, x+w) x [y, y+h), clipped to the planes, to colour[p] in each plane. */
void obs_font_fill_rect(obs_image_f32 *planes, int plane_count, int x, int y, int w, int h, const float *colour);

#ifdef __cplusplus
}
#endif

#endif
