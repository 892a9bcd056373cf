#include "draw.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace brdf::preview::draw {
namespace {

using Glyph = std::array<std::uint8_t, 7>; // 7 rows, 5 bits each, bit 4 = leftmost column

struct GlyphEntry {
    char32_t code;
    Glyph rows;
};

// A classic 5x7 dot-matrix font (after the HD44780 character generator's shapes).
constexpr GlyphEntry glyphs[] = {
    {U' ', {0, 0, 0, 0, 0, 0, 0}},
    {U'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}},
    {U'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {U'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}},
    {U'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
    {U'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}},
    {U'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
    {U'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}},
    {U'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {U'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}},
    {U'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
    {U'A', {0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11}},
    {U'B', {0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E}},
    {U'C', {0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E}},
    {U'D', {0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C}},
    {U'E', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F}},
    {U'F', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10}},
    {U'G', {0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F}},
    {U'H', {0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11}},
    {U'I', {0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {U'J', {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C}},
    {U'K', {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11}},
    {U'L', {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F}},
    {U'M', {0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11}},
    {U'N', {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11}},
    {U'O', {0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}},
    {U'P', {0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10}},
    {U'Q', {0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D}},
    {U'R', {0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11}},
    {U'S', {0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E}},
    {U'T', {0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04}},
    {U'U', {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}},
    {U'V', {0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04}},
    {U'W', {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A}},
    {U'X', {0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11}},
    {U'Y', {0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04}},
    {U'Z', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F}},
    {U'-', {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00}},
    {U'+', {0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00}},
    {U'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C}},
    {U',', {0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08}},
    {U':', {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00}},
    {U'/', {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00}},
    {U'(', {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}},
    {U')', {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08}},
    {U'=', {0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00}},
    {U'_', {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F}},
    {U'?', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04}},
    {U'\u00B0', {0x0C, 0x12, 0x12, 0x0C, 0x00, 0x00, 0x00}}, // degree sign
    {U'\u03B8', {0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x0E}}, // theta
    {U'\u03C6', {0x04, 0x0E, 0x15, 0x15, 0x15, 0x0E, 0x04}}, // phi
};

const Glyph& glyph(char32_t c) {
    if (c >= U'a' && c <= U'z') c = c - U'a' + U'A';
    for (const GlyphEntry& g : glyphs)
        if (g.code == c) return g.rows;
    for (const GlyphEntry& g : glyphs)
        if (g.code == U'?') return g.rows;
    return glyphs[0].rows;
}

/// Decodes UTF-8 one code point at a time (invalid bytes come out as '?').
template <typename Visit> void for_each_code_point(std::string_view s, const Visit& visit) {
    for (std::size_t k = 0; k < s.size();) {
        const auto b = static_cast<unsigned char>(s[k]);
        int extra = b < 0x80 ? 0 : (b >> 5) == 0x6 ? 1 : (b >> 4) == 0xE ? 2 : (b >> 3) == 0x1E ? 3 : -1;
        if (extra < 0 || k + static_cast<std::size_t>(extra) >= s.size()) { // bad lead byte or truncated
            visit(U'?');
            ++k;
            continue;
        }
        char32_t c = extra == 0 ? b : (b & (0x3F >> extra));
        for (int e = 1; e <= extra; ++e) c = (c << 6) | (static_cast<unsigned char>(s[k + e]) & 0x3F);
        visit(c);
        k += extra + 1;
    }
}

} // namespace

void blend(Image& image, int x, int y, const Rgb& colour, double alpha) {
    if (x < 0 || y < 0 || x >= image.width || y >= image.height || alpha <= 0.0) return;
    alpha = std::min(alpha, 1.0);
    float* p = image.at(x, y);
    for (int c = 0; c < 3; ++c) p[c] = static_cast<float>(p[c] * (1.0 - alpha) + colour[c] * alpha);
}

void fill_rect(Image& image, int x0, int y0, int x1, int y1, const Rgb& colour) {
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) blend(image, x, y, colour, 1.0);
}

void line(Image& image, double x0, double y0, double x1, double y1, double width, const Rgb& colour) {
    const double half = 0.5 * width;
    const int xa = static_cast<int>(std::floor(std::min(x0, x1) - half - 1.0));
    const int xb = static_cast<int>(std::ceil(std::max(x0, x1) + half + 1.0));
    const int ya = static_cast<int>(std::floor(std::min(y0, y1) - half - 1.0));
    const int yb = static_cast<int>(std::ceil(std::max(y0, y1) + half + 1.0));
    const double dx = x1 - x0, dy = y1 - y0, len2 = dx * dx + dy * dy;
    for (int y = std::max(ya, 0); y <= std::min(yb, image.height - 1); ++y)
        for (int x = std::max(xa, 0); x <= std::min(xb, image.width - 1); ++x) {
            const double px = x + 0.5, py = y + 0.5;
            const double t = len2 > 0.0 ? std::clamp(((px - x0) * dx + (py - y0) * dy) / len2, 0.0, 1.0) : 0.0;
            const double ex = px - (x0 + t * dx), ey = py - (y0 + t * dy);
            const double coverage = std::clamp(half + 0.5 - std::sqrt(ex * ex + ey * ey), 0.0, 1.0);
            blend(image, x, y, colour, coverage);
        }
}

void dashed_line(Image& image, double x0, double y0, double x1, double y1, double width, double dash,
                 const Rgb& colour) {
    const double len = std::hypot(x1 - x0, y1 - y0);
    if (len <= 0.0 || dash <= 0.0) return;
    for (double s = 0.0; s < len; s += 2.0 * dash) {
        const double e = std::min(len, s + dash);
        line(image, x0 + (x1 - x0) * s / len, y0 + (y1 - y0) * s / len, x0 + (x1 - x0) * e / len,
             y0 + (y1 - y0) * e / len, width, colour);
    }
}

int text_width(std::string_view s, int scale) {
    int n = 0;
    for_each_code_point(s, [&](char32_t) { ++n; });
    return n == 0 ? 0 : (6 * n - 1) * scale;
}

void text(Image& image, int x, int y, std::string_view s, int scale, const Rgb& colour) {
    int pen = x;
    for_each_code_point(s, [&](char32_t c) {
        const Glyph& g = glyph(c);
        for (int row = 0; row < 7; ++row)
            for (int col = 0; col < 5; ++col)
                if (g[row] & (0x10 >> col))
                    for (int a = 0; a < scale; ++a)
                        for (int b = 0; b < scale; ++b) blend(image, pen + col * scale + b, y + row * scale + a, colour, 1.0);
        pen += 6 * scale;
    });
}

} // namespace brdf::preview::draw
