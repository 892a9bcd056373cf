#pragma once
// Spectral sampling and colour: which vacuum wavelengths the service solves, and the weights that
// turn the solved spectral values into linear Rec.709 RGB (D65 white), so that
//     rgb_c = sum_j w_c(lambda_j) R(lambda_j)        c = r, g, b
// for a spectral reflectance (or BRDF value) R known at the solved wavelengths lambda_j.
//
// Integration rule (every set except "rgb"): R between the solved wavelengths is the piecewise-
// linear interpolant of the R(lambda_j), held constant beyond the first and last wavelength. The
// CIE tristimulus values of the reflected D65 light are the CIE 15 sums over the 5 nm tables
// (data/cie, CIE 1931 2-degree observer, illuminant D65) from 380 to 780 nm:
//     X = K sum_i xbar(l_i) S(l_i) R(l_i),   K = 1 / sum_i ybar(l_i) S(l_i)   (Y of white = 1)
// and R(l_i) = sum_j h_j(l_i) R(lambda_j) with the hat functions h_j of the interpolant, so the XYZ
// weight of lambda_j is K sum_i (xbar, ybar, zbar)(l_i) S(l_i) h_j(l_i). Linear Rec.709 follows
// with the IEC 61966-2-1 (sRGB) matrix M; each RGB channel is then scaled by s_c (within 3e-4 of 1)
// so that R = 1 everywhere gives exactly (1, 1, 1): the 5 nm tables' white point (x = 0.31272,
// y = 0.32903) differs from the rounded Rec.709 white (0.3127, 0.3290) that M is built on, and a
// white reflector must stay white. Since the hat functions sum to 1, every channel's weights sum to
// 1 for every set.
//
// Other colour spaces (ColorSpace, colour.h): the same XYZ weights through that space's matrix
// (adaptation included), white-preserving too: R = 1 gives (1, 1, 1) in the space's own white.
// The Rec.709 weights above are computed exactly as before (bit for bit).
//
// "rgb": three wavelengths, the dominant wavelengths of the Rec.709 primaries about the D65 white
// on the CIE 1931 locus (611.46, 549.09, 464.26 nm: tests/reference/material/spectral_weights.py),
// rounded to 611, 549 and 464 nm, with identity weights: r = R(611), g = R(549), b = R(464). Fast
// and white-preserving, but not colorimetric (a narrow-band sample of each channel). In another
// space its weights are the Rec.709 identity converted by that space's matrix from Rec.709.

#include <brdf/material/colour_space.h>

#include <array>
#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace brdf::material {

using Tristimulus = std::array<double, 3>; ///< CIE 1931 X, Y, Z
using Rgb = std::array<double, 3>; ///< linear r, g, b: Rec.709 (D65 white = 1, 1, 1) unless a ColorSpace says otherwise

struct Chromaticity {
    double x = 0.0;
    double y = 0.0;
};

/// The CIE tables embedded from data/cie on the observer's 5 nm grid (360-830 nm).
struct CieTables {
    std::vector<double> wavelength_nm;    ///< 360, 365, ..., 830
    std::vector<double> xbar, ybar, zbar; ///< CIE 1931 2-degree colour-matching functions
    std::vector<double> d65;              ///< illuminant D65 relative power (100 at 560 nm)
};

/// The CIE tables, parsed once on first use (thread-safe). FormatError if the embedded files are
/// malformed (which a test rules out).
const CieTables& cie_tables();

/// Integration limits of the colour pipeline (nm).
inline constexpr double visible_min_nm = 380.0;
inline constexpr double visible_max_nm = 780.0;

/// Limits of explicit wavelength lists: each in [200, 2500] nm, at most 1000 of them.
inline constexpr double explicit_min_nm = 200.0;
inline constexpr double explicit_max_nm = 2500.0;
inline constexpr std::size_t max_explicit_wavelengths = 1000;

/// The wavelengths of the "rgb" set, ascending: blue, green, red (nm).
inline constexpr std::array<double, 3> rgb_wavelengths_nm = {464.0, 549.0, 611.0};

/// IEC 61966-2-1 (sRGB) matrix from CIE XYZ to linear Rec.709 RGB, rows r, g, b.
inline constexpr std::array<std::array<double, 3>, 3> xyz_to_rec709_matrix = {{
    {3.2406, -1.5372, -0.4986},
    {-0.9689, 1.8758, 0.0415},
    {0.0557, -0.2040, 1.0570},
}};

/// x = X / (X + Y + Z), y = Y / (X + Y + Z).
Chromaticity chromaticity(const Tristimulus& xyz);

/// M xyz with the IEC 61966-2-1 matrix (no white-balance scaling).
Rgb xyz_to_linear_rec709(const Tristimulus& xyz);

/// Every problem of an explicit wavelength list, one message each starting with `path`, e.g.
/// "wavelengths_nm[2]: 550 nm is not greater than wavelengths_nm[1] = 600 nm (list the wavelengths
/// in increasing order, without repeats)". Checks: not empty; each finite and within
/// [explicit_min_nm, explicit_max_nm]; strictly increasing as given (a list out of order is an
/// error rather than silently sorted: it is likely a typo). The count limit is not checked here.
std::vector<std::string> wavelength_list_problems(std::span<const double> wavelengths_nm,
                                                  std::string_view path = "wavelengths_nm");

/// The wavelengths to solve and their colour weights (see the file comment).
class SpectralSet {
  public:
    enum class Kind {
        Visible,        ///< "visible": 380, 390, ..., 780 nm (41 wavelengths), integrated
        RgbWavelengths, ///< "rgb": 464, 549, 611 nm, identity weights
        Explicit,       ///< {"wavelengths_nm": [...]}: the given wavelengths, integrated
    };

    /// The "visible" set: 380 to 780 nm in 10 nm steps.
    static SpectralSet visible();
    /// The "rgb" set.
    static SpectralSet rgb();
    /// A user list (nm). Throws LimitError for more than max_explicit_wavelengths, else
    /// InputError listing wavelength_list_problems(wavelengths_nm, path).
    static SpectralSet from_wavelengths(std::span<const double> wavelengths_nm,
                                        std::string_view path = "wavelengths_nm");
    /// Integration weights for any strictly increasing list of positive wavelengths, without the
    /// explicit-list limits (a helper for tests and for converting measured spectra). Throws
    /// InputError for an empty or non-increasing list.
    static SpectralSet integrating(std::span<const double> wavelengths_nm);

    Kind kind() const { return m_kind; }
    /// "visible", "rgb" or "wavelengths".
    std::string_view name() const;
    std::size_t size() const { return m_wavelengths.size(); }

    /// The wavelengths to solve, nm, strictly increasing.
    std::span<const double> wavelengths_nm() const { return m_wavelengths; }
    /// w_c(lambda_j) in linear Rec.709, one Rgb per wavelength; every channel sums to 1.
    std::span<const Rgb> rgb_weights() const { return m_rgb; }
    /// The same in `space` (colour.h): every channel sums to 1 (to rounding) there too.
    /// rgb_weights(ColorSpace::Rec709) is rgb_weights().
    std::span<const Rgb> rgb_weights(ColorSpace space) const;
    /// The CIE XYZ weights (Y of white = 1) before the RGB conversion. For the rgb set, which has
    /// no colorimetric meaning, M^-1 applied to the identity weights.
    std::span<const Tristimulus> xyz_weights() const { return m_xyz; }
    /// The per-channel scale s_c applied after M (1, 1, 1 for the rgb set).
    const Rgb& white_balance() const { return m_balance; }

    /// sum_j w(lambda_j) values[j]; values.size() must equal size() (InputError otherwise).
    Rgb to_rgb(std::span<const double> values) const;
    /// sum_j rgb_weights(space)[j] values[j].
    Rgb to_rgb(std::span<const double> values, ColorSpace space) const;
    /// sum_j xyz_weights[j] values[j].
    Tristimulus to_xyz(std::span<const double> values) const;

  private:
    SpectralSet() = default;
    static SpectralSet integrate(std::vector<double> wavelengths, Kind kind);
    void add_other_spaces(); // m_acescg, m_rec2020 from m_xyz, or from m_rgb for the rgb set

    Kind m_kind = Kind::Visible;
    std::vector<double> m_wavelengths;
    std::vector<Rgb> m_rgb;
    std::vector<Tristimulus> m_xyz;
    Rgb m_balance{1.0, 1.0, 1.0};
    std::vector<Rgb> m_acescg, m_rec2020;
};

/// XYZ (Y of white = 1, D65) of a reflectance given at strictly increasing wavelengths, by the same
/// rule as SpectralSet (piecewise linear, constant beyond the ends).
Tristimulus reflectance_to_xyz(std::span<const double> wavelengths_nm,
                               std::span<const double> reflectance);
/// Linear Rec.709 of the same, white-balanced like SpectralSet (R = 1 gives 1, 1, 1).
Rgb reflectance_to_rgb(std::span<const double> wavelengths_nm, std::span<const double> reflectance);
/// The same in `space`.
Rgb reflectance_to_rgb(std::span<const double> wavelengths_nm, std::span<const double> reflectance,
                       ColorSpace space);

} // namespace brdf::material
