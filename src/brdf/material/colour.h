#pragma once
// RGB colour spaces, chromatic adaptation and the gamut fit (docs/colour.md).
//
// The colour pipeline's XYZ is that of spectrum.h: CIE 1931 2-degree observer, D65 from the 5 nm
// tables, Y of a perfect white = 1. Its white, table_white(), is x = 0.312721, y = 0.329031 (the
// tables' own D65, not the rounded 0.3127, 0.3290 the spaces are defined on). Each space gets one
// matrix from that XYZ to its linear RGB, built so that table_white() gives exactly (1, 1, 1):
//   rec709   diag(s) M_IEC: the IEC 61966-2-1 matrix and the per-channel white balance s of
//            spectrum.h (unchanged: the service's Rec.709 numbers stay bit for bit)
//   acescg   NPM_AP1^-1 B(table white -> ACES white): ACES AP1 primaries (SMPTE ST 2065-1 /
//            ACES S-2014-004), white x = 0.32168, y = 0.33767
//   rec2020  NPM_2020^-1 B(table white -> D65): ITU-R BT.2020 primaries, D65
// NPM is the normalised primary matrix of SMPTE RP 177-1993 section 3.3, derived here from the
// chromaticities. B is the von Kries transform in the Bradford cone space (Lam 1985; ICC.1:2010
// Annex E.3), the chromatic adaptation of the ACES reference implementation (calculate_cat_matrix
// in the ACES CTL library defaults to the Bradford cone response; the OCIO ACES configs use it).
// colour-science's default is CAT02: its functions are called with "Bradford" in the reference
// script (tests/reference/material/colour_reference.py).
//
// The gamut fit (fit_into_gamut) brings a material's colour inside a space by moving every colour
// weight towards its own luminance by one factor s, w' = Y(w) + s (w - Y(w)): linear, so the BRDF
// keeps its angular shape and reciprocity, and exact in luminance, which it checks.

#include <brdf/material/colour_space.h>
#include <brdf/material/spectrum.h>

#include <array>
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace brdf::material {

using Matrix3 = std::array<std::array<double, 3>, 3>; ///< row-major: m[row][column]

/// Every colour space, the default first.
inline constexpr std::array<ColorSpace, 3> all_color_spaces = {ColorSpace::Rec709, ColorSpace::AcesCg,
                                                               ColorSpace::Rec2020};

/// Primaries and white point, CIE 1931 xy: what the OpenEXR `chromaticities` attribute holds.
struct Chromaticities {
    Chromaticity red, green, blue, white;
};

/// "rec709", "acescg", "rec2020" (the spec's "colorspace" values, docs/design.md).
std::string_view to_string(ColorSpace space);
/// The inverse of to_string; nullopt for any other name (case-sensitive, like every spec value).
std::optional<ColorSpace> color_space_from_string(std::string_view name);
/// For reports and EXR headers, e.g. "linear Rec.709 (sRGB primaries), D65".
std::string_view long_name(ColorSpace space);
/// The space's defining chromaticities (ITU-R BT.709, ACES AP1 with the ACES white, ITU-R BT.2020).
const Chromaticities& chromaticities(ColorSpace space);

/// a b
Matrix3 multiply(const Matrix3& a, const Matrix3& b);
/// m v
std::array<double, 3> apply_matrix(const Matrix3& m, const std::array<double, 3>& v);
/// m^-1 (adjugate over determinant). Throws NumericalError when m is singular.
Matrix3 inverse(const Matrix3& m);

/// XYZ of the chromaticity xy with Y = 1.
Tristimulus xyz_of_white(Chromaticity white);

/// SMPTE RP 177-1993 section 3.3: the normalised primary matrix, linear RGB -> XYZ, whose white
/// (1, 1, 1) maps to xyz_of_white(c.white). Throws NumericalError for collinear primaries.
Matrix3 normalised_primary_matrix(const Chromaticities& c);

/// The Bradford cone response matrix (XYZ -> rho, gamma, beta), as in ICC.1:2010 Annex E.3.
inline constexpr Matrix3 bradford_cone_response = {{
    {0.8951, 0.2664, -0.1614},
    {-0.7502, 1.7135, 0.0367},
    {0.0389, -0.0685, 1.0296},
}};

/// Von Kries adaptation in the Bradford cone space: M^-1 diag(M d / M s) M, mapping the source
/// white's XYZ s exactly onto the destination's d.
Matrix3 bradford_adaptation(const Tristimulus& source_white, const Tristimulus& destination_white);

/// XYZ of R = 1 through the colour pipeline (spectrum.h): the tables' D65, Y = 1 (to rounding).
const Tristimulus& table_white();

/// From the pipeline's XYZ to the space's linear RGB (see the file comment): table_white() gives
/// (1, 1, 1).
const Matrix3& xyz_to_rgb_matrix(ColorSpace space);
/// Its inverse: the space's linear RGB to the pipeline's XYZ.
const Matrix3& rgb_to_xyz_matrix(ColorSpace space);
/// From the space's linear RGB to linear Rec.709 (D65), for previews and display (sRGB encoding
/// follows). Composed from the two matrices above, so white stays (1, 1, 1). Outside Rec.709's
/// gamut the result has negative channels: a preview clamps.
const Matrix3& rgb_to_rec709_matrix(ColorSpace space);
/// The luminance Y of each primary: row Y of rgb_to_xyz_matrix. Sums to 1 (Y of white). For Rec.709
/// within 1e-4 of BT.709's 0.2126, 0.7152, 0.0722 (it includes the white balance).
const Rgb& luminance_coefficients(ColorSpace space);

Rgb xyz_to_rgb(const Tristimulus& xyz, ColorSpace space);
Tristimulus rgb_to_xyz(const Rgb& rgb, ColorSpace space);
/// sum_c luminance_coefficients(space)[c] rgb[c]
double luminance(const Rgb& rgb, ColorSpace space);

/// CIE 1976 chroma C*ab = sqrt(a*^2 + b*^2) of xyz, relative to table_white() (CIE 15:2018
/// eqs. 8.1-8.6). Independent of any RGB space: it says how colourful a colour is.
double chroma_ab(const Tristimulus& xyz);

// ---------------------------------------------------------------------------------------------
// The gamut fit.

/// Below this chroma factor the fit clips instead (see fit_into_gamut).
inline constexpr double default_min_gamut_scale = 0.25;

/// What the pipeline knows of a solved material, once, after the solve. Samples are the solved
/// wavelengths (or channels), k = 0 .. weights.size() - 1.
struct GamutFitInput {
    std::string material;                   ///< the material's name, for the warning
    ColorSpace space = ColorSpace::Rec709;  ///< the space of `weights`
    std::vector<Rgb> weights;               ///< colour weight of each sample, in `space`
    std::size_t probe_count = 0;            ///< directions (pairs) at which the BRDF was probed
    /// BRDF of each sample at each probe (1/sr), row-major samples x probes:
    /// brdf[k * probe_count + p]. Every channel of sum_k weights[k] brdf[k, p] must be >= 0.
    std::vector<double> brdf;
    std::size_t reflectance_count = 0; ///< hemispherical reflectances per sample
    /// Reflectances of each sample that must stay within [0, 1] in every channel, row-major
    /// samples x reflectance_count (e.g. diffuse albedo + mirror at a few incidence angles).
    std::vector<double> reflectance;
    double min_scale = default_min_gamut_scale; ///< in (0, 1]
    /// Relative error of the values themselves (the solve's iteration tolerance; 0 for exact
    /// values): a value out of range by less than this times the size of its terms is the solve's
    /// error, not colour, and is left to the caller's clamp. A white, non-absorbing paint's
    /// diffuse albedo + mirror is 1 to about 1e-11, a channel a few 1e-12 above it: fitted, that
    /// noise set s to 0.47 (silica spheres in PMMA) and warned of a colour outside the gamut.
    double value_error = 0.0;
};

struct GamutFit {
    std::vector<Rgb> weights; ///< the fitted weights: the input's, unchanged, when scale = 1
    double scale = 1.0;       ///< the chroma factor s (1: nothing was needed)
    /// True when s alone could not bring every value into range (s would have to be below
    /// min_scale, or a luminance itself is negative or a reflectance's luminance above 1): the
    /// caller clamps what is left (clip_negative), and `warning` says so.
    bool clipped = false;
    std::size_t values_out_of_range = 0; ///< channels still outside after the scaling (clipped)
    double lowest_value = 0.0;           ///< the most negative channel left (1/sr), 0 when none
    double highest_reflectance = 0.0;    ///< the largest reflectance channel left above 1, 0 when none
    /// Empty when scale = 1 and nothing is clipped; else one line naming the material, the space,
    /// the factor, what was clipped, and what keeps the colour (a wider space, the spectral output).
    std::string warning;
};

/// The largest s in [min_scale, 1] with every probe channel >= 0 and every reflectance channel in
/// [0, 1]: each channel is linear in s (Y + s (v - Y)), so s is the smallest of the per-channel
/// bounds, found in one pass (O(samples x (probes + reflectances))), each taken 1e-10 (relative)
/// inside its root so that rounding cannot cross it. Calls check_gamut_fit before returning. Throws NumericalError ("internal error: ...") for inconsistent sizes, non-finite
/// values or a fit that check_gamut_fit rejects.
GamutFit fit_into_gamut(const GamutFitInput& input);

/// Checks a fit against its input, independently of how it was made: every probe's and every
/// reflectance's luminance unchanged (to 1e-10 of the size of the terms summed), the scale within
/// [min_scale, 1], and, when not clipped, every channel in range. Throws NumericalError ("internal
/// error: gamut fit ...") naming the first violation.
void check_gamut_fit(const GamutFitInput& input, const GamutFit& fit);

/// max(0, c) per channel: what the caller applies to values when GamutFit::clipped (no output holds
/// a negative value, docs/design.md).
Rgb clip_negative(const Rgb& rgb);

// ---------------------------------------------------------------------------------------------
// Chroma of a spectral reflectance in each space (for tests of whole materials).

struct ReflectanceColour {
    Rgb rgb{};              ///< the reflectance's colour in the space, before any fit
    double gamut_scale = 1; ///< the fit's chroma factor for this colour alone (1: in gamut)
    bool clipped = false;   ///< see GamutFit::clipped
    Rgb fitted{};           ///< after the fit (clip_negative applied when clipped)
    double chroma = 0.0;    ///< C*ab of `fitted`: the chroma the space keeps
    double chroma_spectral = 0.0; ///< C*ab of the reflectance itself (the same in every space)
};

/// The colour of a reflectance known at set.wavelengths_nm() in `space`, fitted into the space by
/// the same gamut fit (one probe: the reflectance itself, which must stay in [0, 1]). A wider
/// space keeps more chroma: for a cadmium yellow chroma(acescg) > chroma(rec709), with
/// gamut_scale 1 in acescg. Throws InputError when reflectance.size() != set.size().
ReflectanceColour reflectance_colour(const SpectralSet& set, std::span<const double> reflectance,
                                     ColorSpace space);

} // namespace brdf::material
