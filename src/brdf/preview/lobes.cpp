#include <brdf/preview/lobes.h>

#include "draw.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

namespace brdf::preview {
namespace {

constexpr double pi = std::numbers::pi;

std::string format_number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

/// A 1-2-5 step that puts about four rings under `top`.
double nice_step(double top) {
    const double raw = top / 4.0;
    const double decade = std::pow(10.0, std::floor(std::log10(raw)));
    for (double m : {1.0, 2.0, 5.0})
        if (m * decade >= raw) return m * decade;
    return 10.0 * decade;
}

double channel_value(const Rgb& v, LobeChannel channel) {
    switch (channel) {
    case LobeChannel::Luminance: return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]; // Rec.709 Y
    case LobeChannel::Red: return v[0];
    case LobeChannel::Green: return v[1];
    case LobeChannel::Blue: return v[2];
    }
    return v[1];
}

} // namespace

LobeChannel parse_lobe_channel(const std::string& name) {
    if (name == "luminance") return LobeChannel::Luminance;
    if (name == "red") return LobeChannel::Red;
    if (name == "green") return LobeChannel::Green;
    if (name == "blue") return LobeChannel::Blue;
    throw InputError(cat("channel: expected luminance, red, green or blue (got '", name, "')"));
}

Rgb lobe_colour(std::size_t index) {
    // Distinct on white paper (linear values of a Tableau-like palette).
    static const Rgb palette[] = {{0.01, 0.20, 0.60}, {0.85, 0.20, 0.02}, {0.05, 0.45, 0.05}, {0.60, 0.02, 0.45},
                                  {0.80, 0.55, 0.00}, {0.00, 0.45, 0.50}, {0.30, 0.30, 0.30}, {0.55, 0.15, 0.05}};
    return palette[index % std::size(palette)];
}

Image plot_lobes(const std::vector<LobeCurve>& curves, const LobeOptions& o) {
    if (curves.empty()) throw InputError("lobes: no curves to plot");
    if (o.width < 200 || o.width > 8192) throw InputError(cat("lobes: width must be in [200, 8192] (got ", o.width, ")"));
    if (o.samples < 3 || o.samples > 100000) throw InputError(cat("lobes: samples must be in [3, 100000] (got ", o.samples, ")"));
    if (o.log_scale && !(o.decades > 0.0 && o.decades <= 30.0))
        throw InputError(cat("lobes: decades must be in (0, 30] (got ", o.decades, ")"));
    for (const LobeCurve& c : curves)
        if (!(c.theta_i_deg >= 0.0 && c.theta_i_deg < 90.0))
            throw InputError(cat("lobes: incidence angle must be in [0, 90) degrees (got ", c.theta_i_deg, ")"));

    // Sample every curve: signed outgoing angle s, negative on the light's side (phi = 0).
    std::vector<std::vector<double>> values(curves.size());
    double vmax = 0.0;
    for (std::size_t k = 0; k < curves.size(); ++k) {
        const double ti = curves[k].theta_i_deg * pi / 180.0;
        for (int j = 0; j < o.samples; ++j) {
            const double s = -0.5 * pi + pi * j / (o.samples - 1);
            const double to = std::min(std::abs(s), 0.5 * pi * (1.0 - 1e-6)); // grazing: just above the horizon
            const double v = channel_value(curves[k].brdf(ti, to, s < 0.0 ? 0.0 : pi), o.channel);
            if (!std::isfinite(v))
                throw NumericalError(cat("lobes: ", curves[k].label, ": BRDF is not finite at theta_o ", s * 180.0 / pi, " degrees"));
            values[k].push_back(std::max(0.0, v));
            vmax = std::max(vmax, v);
        }
    }

    // Scale: linear rings at a 1-2-5 step, or one ring per decade.
    std::vector<std::pair<double, std::string>> rings; // radius fraction, label
    double top = 1.0, step = 0.25, log_top = 0.0;
    if (!o.log_scale) {
        if (vmax <= 0.0) vmax = 1.0;
        step = nice_step(vmax);
        top = std::ceil(vmax / step - 1e-9) * step;
        for (double v = step; v <= top * (1.0 + 1e-9); v += step) rings.push_back({v / top, format_number(v)});
    } else {
        log_top = std::ceil(std::log10(vmax > 0.0 ? vmax : 1.0) - 1e-9);
        const int n = static_cast<int>(std::ceil(o.decades));
        for (int d = 0; d < n; ++d) {
            const double frac = 1.0 - d / o.decades;
            rings.push_back({frac, format_number(std::pow(10.0, log_top - d))});
        }
    }
    const auto radius_fraction = [&](double v) {
        if (!o.log_scale) return std::min(v / top, 1.05);
        if (v <= 0.0) return 0.0;
        return std::clamp((std::log10(v) - (log_top - o.decades)) / o.decades, 0.0, 1.05);
    };

    // Layout: title, the half disc, its angle labels, then the legend rows.
    const int scale = o.width >= 600 ? 2 : 1;
    const int line_height = draw::text_height(scale) + 6 * scale;
    const int pad = 12 * scale;
    const double R = 0.5 * o.width - 2.0 * pad - 4.0 * draw::text_width("-90", scale) / 3.0;
    const int top_y = pad + line_height + draw::text_height(scale) + pad; // title, then room for "0" label
    const double cx = 0.5 * o.width, cy = top_y + R;
    const int legend_y = static_cast<int>(cy) + pad + 2 * line_height;
    const int height = legend_y + static_cast<int>(curves.size()) * line_height + pad;
    Image image(o.width, height, o.background);
    const Rgb ink{0.0, 0.0, 0.0}, grid{0.75, 0.75, 0.75}, faint{0.88, 0.88, 0.88};
    const double lw = 1.0 * scale;

    const auto point = [&](double frac, double s) {
        return std::pair{cx + frac * R * std::sin(s), cy - frac * R * std::cos(s)};
    };
    const auto arc = [&](double frac, const Rgb& colour, double width) {
        const int n = 180;
        for (int j = 0; j < n; ++j) {
            const auto [x0, y0] = point(frac, -0.5 * pi + pi * j / n);
            const auto [x1, y1] = point(frac, -0.5 * pi + pi * (j + 1) / n);
            draw::line(image, x0, y0, x1, y1, width, colour);
        }
    };

    // Rings and radial grid lines every 30 degrees.
    for (const auto& [frac, label] : rings) arc(frac, frac >= 1.0 - 1e-9 ? grid : faint, lw);
    for (int deg = -60; deg <= 60; deg += 30) {
        const auto [x, y] = point(1.0, deg * pi / 180.0);
        draw::line(image, cx, cy, x, y, lw, faint);
    }
    arc(1.0, ink, lw);
    // Angle ticks every 10 degrees, labels every 30.
    for (int deg = -90; deg <= 90; deg += 10) {
        const double s = deg * pi / 180.0;
        const double len = (deg % 30 == 0 ? 8.0 : 4.0) * scale;
        const auto [x0, y0] = point(1.0, s);
        const auto [x1, y1] = point(1.0 + len / R, s);
        draw::line(image, x0, y0, x1, y1, lw, ink);
        if (deg % 30 == 0) {
            const std::string label = cat(deg, "\u00B0");
            const auto [lx, ly] = point(1.0 + (len + 6.0 * scale) / R, s);
            const int w = draw::text_width(label, scale), h = draw::text_height(scale);
            // Anchor the label on the side facing away from the centre.
            const double ax = 0.5 * (1.0 + std::sin(s)), ay = 0.5 * (1.0 + std::cos(s));
            draw::text(image, static_cast<int>(lx - (1.0 - ax) * w), static_cast<int>(ly - ay * h), label, scale, ink);
        }
    }
    // The surface and the normal.
    draw::line(image, cx - R - 10.0 * scale, cy, cx + R + 10.0 * scale, cy, 2.0 * lw, ink);
    draw::line(image, cx, cy, cx, cy - R, lw, grid);
    // Ring values along the normal.
    for (const auto& [frac, label] : rings)
        draw::text(image, static_cast<int>(cx) + 3 * scale, static_cast<int>(cy - frac * R) + 2 * scale, label, scale,
                   {0.35, 0.35, 0.35});
    // Side captions under the surface.
    const int caption_y = static_cast<int>(cy) + pad;
    draw::text(image, static_cast<int>(cx - R), caption_y, "RETRO (\u03C6=0)", scale, ink);
    const std::string mirror = "MIRROR (\u03C6=180)";
    draw::text(image, static_cast<int>(cx + R) - draw::text_width(mirror, scale), caption_y, mirror, scale, ink);
    const std::string axis = o.log_scale ? cat("LOG10, ", format_number(o.decades), " DECADES") : "LINEAR";
    draw::text(image, static_cast<int>(cx) - draw::text_width(axis, scale) / 2, caption_y, axis, scale, {0.35, 0.35, 0.35});
    // Title.
    draw::text(image, static_cast<int>(cx) - draw::text_width(o.title, scale) / 2, pad, o.title, scale, ink);

    // Curves, then incidence markers on top, then the legend.
    // Earlier curves are drawn wider, so a curve that coincides with a later one (a spec and its
    // table) still shows as a coloured rim around it.
    const double widest = curves.size() > 1 ? 1.5 : 0.0;
    for (std::size_t k = 0; k < curves.size(); ++k) {
        const Rgb colour = curves[k].colour.value_or(lobe_colour(k));
        const double width = 2.0 * lw * (1.0 + widest * (curves.size() - 1 - k) / std::max<double>(1.0, curves.size() - 1));
        std::pair<double, double> prev{};
        for (int j = 0; j < o.samples; ++j) {
            const double s = -0.5 * pi + pi * j / (o.samples - 1);
            const auto p = point(radius_fraction(values[k][j]), s);
            if (j > 0) draw::line(image, prev.first, prev.second, p.first, p.second, width, colour);
            prev = p;
        }
    }
    for (std::size_t k = 0; k < curves.size(); ++k) {
        const Rgb colour = curves[k].colour.value_or(lobe_colour(k));
        const double s = -curves[k].theta_i_deg * pi / 180.0; // the light is on the retro side
        const auto [x0, y0] = point(1.08, s);
        const auto [x1, y1] = point(0.0, s);
        draw::dashed_line(image, x0, y0, x1, y1, lw, 6.0 * scale, colour);
        // Arrow head pointing at the origin, just inside the outer ring.
        const auto [hx, hy] = point(0.9, s);
        const double ux = std::sin(s), uy = -std::cos(s); // outward unit vector in image coordinates
        const double size = 9.0 * scale;
        for (int side : {-1, 1}) {
            const double bx = hx + size * (ux * 0.94 + side * -uy * 0.34), by = hy + size * (uy * 0.94 + side * ux * 0.34);
            draw::line(image, hx, hy, bx, by, 2.0 * lw, colour);
        }
    }
    for (std::size_t k = 0; k < curves.size(); ++k) {
        const Rgb colour = curves[k].colour.value_or(lobe_colour(k));
        const int y = legend_y + static_cast<int>(k) * line_height;
        const int x = pad;
        draw::fill_rect(image, x, y + draw::text_height(scale) / 2 - scale, x + 24 * scale, y + draw::text_height(scale) / 2 + scale,
                        colour);
        draw::text(image, x + 30 * scale, y, cat(curves[k].label, "  \u03B8I=", format_number(curves[k].theta_i_deg), "\u00B0"),
                   scale, colour);
    }
    return image;
}

} // namespace brdf::preview
