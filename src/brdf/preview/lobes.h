#pragma once
// In-plane BRDF lobes in polar form, as in the seed paper's figures 1b, 1d and 2: the plane of
// incidence, the light coming in from the upper left at theta_i, the outgoing direction swept from
// -90 degrees (grazing on the light's side, phi = 0, "retro") through the normal to +90 degrees
// (grazing on the mirror side, phi = 180), the distance from the origin the BRDF value (linear, or
// log10 over a few decades). Axes with rings, angle ticks and labels, a legend with one colour per
// curve, and the incidence direction of each curve marked by a dashed ray with an arrow head.

#include <brdf/preview/image.h>
#include <brdf/preview/render.h>

#include <optional>
#include <string>
#include <vector>

namespace brdf::preview {

struct LobeCurve {
    std::string label;        ///< legend text (drawn upper case)
    BrdfFunction brdf;        ///< 1/sr, docs/design.md angles
    double theta_i_deg = 30.0; ///< incidence zenith angle, [0, 90)
    std::optional<Rgb> colour; ///< linear RGB; default: the palette colour of its position
};

enum class LobeChannel { Luminance, Red, Green, Blue };

/// "luminance", "red", "green", "blue" (InputError otherwise).
LobeChannel parse_lobe_channel(const std::string& name);

struct LobeOptions {
    int width = 800;           ///< pixels, [200, 8192]; the height follows from the legend
    bool log_scale = false;    ///< radius = log10 of the BRDF over `decades` decades
    double decades = 3.0;      ///< with log_scale, > 0
    int samples = 361;         ///< outgoing angles from -90 to 90 degrees, >= 3
    LobeChannel channel = LobeChannel::Luminance; ///< Rec.709 luminance or one channel
    std::string title = "BRDF (1/SR) IN THE PLANE OF INCIDENCE";
    Rgb background{1.0, 1.0, 1.0};
};

/// The palette colour (linear RGB) of curve `index`.
Rgb lobe_colour(std::size_t index);

/// The plot as a linear RGB image meant to be written with ToneCurve::Clamp (white paper stays
/// white). InputError for no curves or options out of range.
Image plot_lobes(const std::vector<LobeCurve>& curves, const LobeOptions& options);

} // namespace brdf::preview
