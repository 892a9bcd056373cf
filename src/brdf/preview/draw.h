#pragma once
// Drawing on a preview Image (linear RGB): anti-aliased lines and a tiny built-in 5x7 bitmap font
// (digits, upper-case letters, a little punctuation, the degree sign and theta; lower case is drawn
// as upper case). Enough for axes and legends without a font library.

#include <brdf/preview/image.h>

#include <string_view>

namespace brdf::preview::draw {

/// Blends `colour` over the pixel with weight `alpha` in [0, 1]; outside the image does nothing.
void blend(Image& image, int x, int y, const Rgb& colour, double alpha);
void fill_rect(Image& image, int x0, int y0, int x1, int y1, const Rgb& colour);
/// A segment `width` pixels wide with a one-pixel anti-aliased edge; coordinates in pixels (pixel
/// centres at +0.5).
void line(Image& image, double x0, double y0, double x1, double y1, double width, const Rgb& colour);
/// A dashed segment: dashes and gaps of `dash` pixels.
void dashed_line(Image& image, double x0, double y0, double x1, double y1, double width, double dash,
                 const Rgb& colour);

/// Width and height in pixels of `text` drawn at `scale` (each font pixel a scale x scale block).
int text_width(std::string_view text, int scale);
inline int text_height(int scale) { return 7 * scale; }
/// Draws UTF-8 `text` with its top-left corner at (x, y). Characters without a glyph show as '?'.
void text(Image& image, int x, int y, std::string_view text, int scale, const Rgb& colour);

} // namespace brdf::preview::draw
