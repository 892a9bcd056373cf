#include <brdf/material/colour.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace brdf::material {
namespace {

std::size_t index_of(ColorSpace space) {
    switch (space) {
    case ColorSpace::Rec709:
        return 0;
    case ColorSpace::AcesCg:
        return 1;
    case ColorSpace::Rec2020:
        return 2;
    }
    throw NumericalError("internal error: unknown ColorSpace");
}

// ITU-R BT.709-6 item 1.3-1.4 (the sRGB primaries of IEC 61966-2-1), D65 as BT.709 rounds it.
const Chromaticities rec709_chromaticities{{0.64, 0.33}, {0.30, 0.60}, {0.15, 0.06}, {0.3127, 0.3290}};
// ACES AP1 (ACES S-2014-004 "ACEScg", table 1), ACES white point (SMPTE ST 2065-1).
const Chromaticities acescg_chromaticities{
    {0.713, 0.293}, {0.165, 0.830}, {0.128, 0.044}, {0.32168, 0.33767}};
// ITU-R BT.2020-2 table 3, D65.
const Chromaticities rec2020_chromaticities{
    {0.708, 0.292}, {0.170, 0.797}, {0.131, 0.046}, {0.3127, 0.3290}};

Tristimulus compute_table_white() {
    // The sums of SpectralSet::integrate for R = 1 (every hat function sums to 1), written out here
    // because SpectralSet's weights are built from these matrices.
    const CieTables& cie = cie_tables();
    Tristimulus sum{0.0, 0.0, 0.0};
    for (std::size_t i = 0; i < cie.wavelength_nm.size(); ++i) {
        const double l = cie.wavelength_nm[i];
        if (l < visible_min_nm || l > visible_max_nm) continue;
        sum[0] += cie.xbar[i] * cie.d65[i];
        sum[1] += cie.ybar[i] * cie.d65[i];
        sum[2] += cie.zbar[i] * cie.d65[i];
    }
    return {sum[0] / sum[1], 1.0, sum[2] / sum[1]};
}

struct SpaceMatrices {
    Matrix3 xyz_to_rgb, rgb_to_xyz, rgb_to_rec709;
    Rgb luminance;
};

SpaceMatrices make_matrices(ColorSpace space) {
    const Tristimulus& white = table_white();
    SpaceMatrices m;
    if (space == ColorSpace::Rec709) {
        // spectrum.h: the IEC matrix, then each channel scaled so that the tables' white is (1, 1, 1).
        const Rgb raw = xyz_to_linear_rec709(white);
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) m.xyz_to_rgb[r][c] = xyz_to_rec709_matrix[r][c] / raw[r];
    } else {
        const Chromaticities& ch = chromaticities(space);
        const Matrix3 adapt = bradford_adaptation(white, xyz_of_white(ch.white));
        m.xyz_to_rgb = multiply(inverse(normalised_primary_matrix(ch)), adapt);
    }
    m.rgb_to_xyz = inverse(m.xyz_to_rgb);
    m.luminance = m.rgb_to_xyz[1];
    return m;
}

const SpaceMatrices& matrices(ColorSpace space) {
    static const std::array<SpaceMatrices, 3> all = [] {
        std::array<SpaceMatrices, 3> out;
        for (ColorSpace s : all_color_spaces) out[index_of(s)] = make_matrices(s);
        const Matrix3& to_rec709 = out[index_of(ColorSpace::Rec709)].xyz_to_rgb;
        for (ColorSpace s : all_color_spaces)
            out[index_of(s)].rgb_to_rec709 = multiply(to_rec709, out[index_of(s)].rgb_to_xyz);
        return out;
    }();
    return all[index_of(space)];
}

// CIE 15:2018 eq. 8.3: f(t) of L*a*b*.
double lab_f(double t) {
    constexpr double delta = 6.0 / 29.0;
    return t > delta * delta * delta ? std::cbrt(t) : t / (3.0 * delta * delta) + 4.0 / 29.0;
}

// A number for a warning: 3 significant digits.
std::string short_number(double v) {
    std::ostringstream os;
    os.precision(3);
    os << v;
    return os.str();
}

// What keeps the colour when `space` cannot: the wider spaces (AP1's triangle contains BT.2020's,
// which contains BT.709's) and the spectral output.
std::string_view wider_advice(ColorSpace space) {
    switch (space) {
    case ColorSpace::Rec709:
        return "a wider colour space (\"colorspace\": \"acescg\" or \"rec2020\") or the spectral "
               "output (\"spectral_exr\") keeps the colour";
    case ColorSpace::Rec2020:
        return "a wider colour space (\"colorspace\": \"acescg\") or the spectral output "
               "(\"spectral_exr\") keeps the colour";
    case ColorSpace::AcesCg:
        return "the spectral output (\"spectral_exr\") keeps the colour";
    }
    return "";
}

[[noreturn]] void internal(const std::string& what) {
    throw NumericalError(cat("internal error: gamut fit ", what));
}

// Per probe (or reflectance) i: the colour V_i = sum_k w_k f_ki, its luminance Y_i, and the size
// of the terms summed, sum_k sum_c |w_kc f_ki|: the scale of the rounding error of V_i and Y_i.
struct ProbeColours {
    std::vector<Rgb> colour;
    std::vector<double> luminance;
    std::vector<double> magnitude;
};

ProbeColours probe_colours(std::span<const Rgb> weights, std::span<const double> values,
                           std::size_t count, const Rgb& lum) {
    ProbeColours out{std::vector<Rgb>(count, Rgb{0.0, 0.0, 0.0}), std::vector<double>(count, 0.0),
                     std::vector<double>(count, 0.0)};
    for (std::size_t k = 0; k < weights.size(); ++k) {
        const Rgb& w = weights[k];
        const double y = lum[0] * w[0] + lum[1] * w[1] + lum[2] * w[2];
        const double size = std::abs(w[0]) + std::abs(w[1]) + std::abs(w[2]);
        for (std::size_t i = 0; i < count; ++i) {
            const double f = values[k * count + i];
            for (int c = 0; c < 3; ++c) out.colour[i][c] += w[c] * f;
            out.luminance[i] += y * f;
            out.magnitude[i] += size * std::abs(f);
        }
    }
    return out;
}

// Rounding of a sum whose terms have total size `magnitude` (a few hundred terms: well inside 1e-12).
double rounding(double magnitude) {
    return 1e-12 * magnitude;
}

// What a value may stray outside its range without being colour: rounding, or the solve's error.
double slack(const GamutFitInput& in, double magnitude) {
    return std::max(rounding(magnitude), in.value_error * magnitude);
}

void check_input(const GamutFitInput& in) {
    const std::size_t n = in.weights.size();
    if (in.brdf.size() != n * in.probe_count)
        internal(cat("input for ", in.material, ": ", in.brdf.size(), " BRDF values for ", n,
                     " samples x ", in.probe_count, " probes"));
    if (in.reflectance.size() != n * in.reflectance_count)
        internal(cat("input for ", in.material, ": ", in.reflectance.size(), " reflectances for ", n,
                     " samples x ", in.reflectance_count));
    if (!(in.min_scale > 0.0 && in.min_scale <= 1.0))
        internal(cat("input for ", in.material, ": min_scale ", in.min_scale, " outside (0, 1]"));
    if (!(in.value_error >= 0.0 && in.value_error < 1e-2))
        internal(
            cat("input for ", in.material, ": value_error ", in.value_error, " outside [0, 0.01)"));
    for (const Rgb& w : in.weights)
        for (double v : w)
            if (!std::isfinite(v)) throw NumericalError(cat(in.material, ": a colour weight is not finite"));
    for (double v : in.brdf)
        if (!std::isfinite(v)) throw NumericalError(cat(in.material, ": a probed BRDF value is not finite"));
    for (double v : in.reflectance)
        if (!std::isfinite(v)) throw NumericalError(cat(in.material, ": a reflectance is not finite"));
}

} // namespace

std::string_view to_string(ColorSpace space) {
    switch (space) {
    case ColorSpace::Rec709:
        return "rec709";
    case ColorSpace::AcesCg:
        return "acescg";
    case ColorSpace::Rec2020:
        return "rec2020";
    }
    return "unknown";
}

std::optional<ColorSpace> color_space_from_string(std::string_view name) {
    for (ColorSpace s : all_color_spaces)
        if (to_string(s) == name) return s;
    return std::nullopt;
}

std::string_view long_name(ColorSpace space) {
    switch (space) {
    case ColorSpace::Rec709:
        return "linear Rec.709 (sRGB primaries), D65";
    case ColorSpace::AcesCg:
        return "linear ACEScg (ACES AP1 primaries), ACES white";
    case ColorSpace::Rec2020:
        return "linear Rec.2020 (ITU-R BT.2020 primaries), D65";
    }
    return "unknown";
}

const Chromaticities& chromaticities(ColorSpace space) {
    switch (space) {
    case ColorSpace::Rec709:
        return rec709_chromaticities;
    case ColorSpace::AcesCg:
        return acescg_chromaticities;
    case ColorSpace::Rec2020:
        return rec2020_chromaticities;
    }
    throw NumericalError("internal error: unknown ColorSpace");
}

Matrix3 multiply(const Matrix3& a, const Matrix3& b) {
    Matrix3 out{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) out[i][j] += a[i][k] * b[k][j];
    return out;
}

std::array<double, 3> apply_matrix(const Matrix3& m, const std::array<double, 3>& v) {
    std::array<double, 3> out{};
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) out[i] += m[i][k] * v[k];
    return out;
}

Matrix3 inverse(const Matrix3& m) {
    Matrix3 adj{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            // cofactor of m[j][i]
            const int r1 = (j + 1) % 3, r2 = (j + 2) % 3, c1 = (i + 1) % 3, c2 = (i + 2) % 3;
            adj[i][j] = m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1];
        }
    const double det = m[0][0] * adj[0][0] + m[0][1] * adj[1][0] + m[0][2] * adj[2][0];
    double size = 0.0;
    for (const auto& row : m)
        for (double v : row) size = std::max(size, std::abs(v));
    if (!(std::abs(det) > 1e-12 * size * size * size))
        throw NumericalError(cat("singular 3x3 matrix (determinant ", det, ")"));
    for (auto& row : adj)
        for (double& v : row) v /= det;
    return adj;
}

Tristimulus xyz_of_white(Chromaticity white) {
    return {white.x / white.y, 1.0, (1.0 - white.x - white.y) / white.y};
}

Matrix3 normalised_primary_matrix(const Chromaticities& c) {
    // SMPTE RP 177-1993 eqs. 3.3.1-3.3.6: P holds the primaries' (x, y, z) as columns; the
    // luminances C of the primaries solve P C = W, the white's XYZ with Y = 1; NPM = P diag(C).
    const Chromaticity p[3] = {c.red, c.green, c.blue};
    Matrix3 primaries{};
    for (int j = 0; j < 3; ++j) {
        primaries[0][j] = p[j].x;
        primaries[1][j] = p[j].y;
        primaries[2][j] = 1.0 - p[j].x - p[j].y;
    }
    const std::array<double, 3> scale = apply_matrix(inverse(primaries), xyz_of_white(c.white));
    Matrix3 npm{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) npm[i][j] = primaries[i][j] * scale[j];
    return npm;
}

Matrix3 bradford_adaptation(const Tristimulus& source_white, const Tristimulus& destination_white) {
    const std::array<double, 3> rs = apply_matrix(bradford_cone_response, source_white);
    const std::array<double, 3> rd = apply_matrix(bradford_cone_response, destination_white);
    Matrix3 gain{};
    for (int i = 0; i < 3; ++i) gain[i][i] = rd[i] / rs[i];
    return multiply(inverse(bradford_cone_response), multiply(gain, bradford_cone_response));
}

const Tristimulus& table_white() {
    static const Tristimulus white = compute_table_white();
    return white;
}

const Matrix3& xyz_to_rgb_matrix(ColorSpace space) {
    return matrices(space).xyz_to_rgb;
}

const Matrix3& rgb_to_xyz_matrix(ColorSpace space) {
    return matrices(space).rgb_to_xyz;
}

const Matrix3& rgb_to_rec709_matrix(ColorSpace space) {
    return matrices(space).rgb_to_rec709;
}

const Rgb& luminance_coefficients(ColorSpace space) {
    return matrices(space).luminance;
}

Rgb xyz_to_rgb(const Tristimulus& xyz, ColorSpace space) {
    return apply_matrix(xyz_to_rgb_matrix(space), xyz);
}

Tristimulus rgb_to_xyz(const Rgb& rgb, ColorSpace space) {
    return apply_matrix(rgb_to_xyz_matrix(space), rgb);
}

double luminance(const Rgb& rgb, ColorSpace space) {
    const Rgb& l = luminance_coefficients(space);
    return l[0] * rgb[0] + l[1] * rgb[1] + l[2] * rgb[2];
}

double chroma_ab(const Tristimulus& xyz) {
    // CIE 15:2018 eqs. 8.1-8.6: a* = 500 (f(X/Xn) - f(Y/Yn)), b* = 200 (f(Y/Yn) - f(Z/Zn)).
    const Tristimulus& n = table_white();
    const double fx = lab_f(xyz[0] / n[0]), fy = lab_f(xyz[1] / n[1]), fz = lab_f(xyz[2] / n[2]);
    return std::hypot(500.0 * (fx - fy), 200.0 * (fy - fz));
}

GamutFit fit_into_gamut(const GamutFitInput& in) {
    check_input(in);
    const Rgb& lum = luminance_coefficients(in.space);
    const ProbeColours probes = probe_colours(in.weights, in.brdf, in.probe_count, lum);
    const ProbeColours refl = probe_colours(in.weights, in.reflectance, in.reflectance_count, lum);

    // Each channel is v(s) = Y + s (V - Y): a lower bound 0 caps s where V < 0, an upper bound 1
    // (of a reflectance) where V > 1. A bound the luminance itself breaks (Y < 0, or Y > 1 for a
    // reflectance) no s can meet: that value is clipped. Values within rounding (or the solve's
    // error) of the bound are not colour: left to the caller's clamp. Each cap is taken 1e-10
    // (relative) inside the exact root so that the bound holds after rounding too.
    constexpr double inside = 1.0 - 1e-10;
    double s = 1.0;
    bool luminance_out_of_range = false;
    const auto bound = [&](const ProbeColours& pc, bool upper) {
        for (std::size_t i = 0; i < pc.colour.size(); ++i) {
            const double y = pc.luminance[i], tol = slack(in, pc.magnitude[i]);
            const double error = in.value_error * pc.magnitude[i];
            if (y < -tol || (upper && y > 1.0 + tol)) {
                luminance_out_of_range = true;
                continue;
            }
            for (int c = 0; c < 3; ++c) {
                const double v = pc.colour[i][c];
                if (v < -error && y > tol) s = std::min(s, inside * y / (y - v));
                if (upper && v > 1.0 + error && y < 1.0 - tol)
                    s = std::min(s, inside * (1.0 - y) / (v - y));
            }
        }
    };
    bound(probes, false);
    bound(refl, true);

    GamutFit fit;
    fit.clipped = luminance_out_of_range || s < in.min_scale;
    fit.scale = std::max(s, in.min_scale);
    if (fit.scale == 1.0) {
        fit.weights = in.weights;
    } else {
        fit.weights.reserve(in.weights.size());
        for (const Rgb& w : in.weights) {
            const double y = lum[0] * w[0] + lum[1] * w[1] + lum[2] * w[2];
            fit.weights.push_back({y + fit.scale * (w[0] - y), y + fit.scale * (w[1] - y),
                                   y + fit.scale * (w[2] - y)});
        }
    }
    if (fit.clipped) {
        const ProbeColours after = probe_colours(fit.weights, in.brdf, in.probe_count, lum);
        const ProbeColours after_refl =
            probe_colours(fit.weights, in.reflectance, in.reflectance_count, lum);
        for (std::size_t i = 0; i < after.colour.size(); ++i)
            for (double x : after.colour[i])
                if (x < -slack(in, after.magnitude[i])) {
                    ++fit.values_out_of_range;
                    fit.lowest_value = std::min(fit.lowest_value, x);
                }
        for (std::size_t i = 0; i < after_refl.colour.size(); ++i)
            for (double x : after_refl.colour[i]) {
                const double tol = slack(in, after_refl.magnitude[i]);
                if (x < -tol) {
                    ++fit.values_out_of_range;
                    fit.lowest_value = std::min(fit.lowest_value, x);
                } else if (x > 1.0 + tol) {
                    ++fit.values_out_of_range;
                    fit.highest_reflectance = std::max(fit.highest_reflectance, x);
                }
            }
    }
    if (fit.scale < 1.0 || fit.clipped) {
        std::string what = cat(in.material, ": colour outside the ", to_string(in.space), " gamut (",
                               long_name(in.space), "): chroma scaled by ", short_number(fit.scale),
                               " about the luminance (luminance kept)");
        if (fit.clipped) {
            what += cat("; still out of range: ",
                        luminance_out_of_range ? std::string("the luminance itself is")
                                               : cat("it would need ", short_number(std::max(s, 0.0)),
                                                     ", below the floor ", short_number(in.min_scale)),
                        "; ", fit.values_out_of_range, fit.values_out_of_range == 1 ? " value" : " values",
                        " clipped");
            if (fit.lowest_value < 0.0)
                what += cat(" (negative channels to 0, lowest ", short_number(fit.lowest_value), ")");
            if (fit.highest_reflectance > 1.0)
                what += cat(" (reflectance above 1: up to ", short_number(fit.highest_reflectance), ")");
        }
        fit.warning = cat(what, "; ", wider_advice(in.space));
    }
    check_gamut_fit(in, fit);
    return fit;
}

void check_gamut_fit(const GamutFitInput& in, const GamutFit& fit) {
    check_input(in);
    if (fit.weights.size() != in.weights.size())
        internal(cat("for ", in.material, ": ", fit.weights.size(), " weights for ", in.weights.size(),
                     " samples"));
    if (!(fit.scale >= in.min_scale && fit.scale <= 1.0))
        internal(cat("for ", in.material, ": chroma scale ", fit.scale, " outside [", in.min_scale, ", 1]"));
    // Independent of the fit: the luminance of every probe before and after, by the space's own
    // coefficients.
    const Rgb& lum = luminance_coefficients(in.space);
    const auto compare = [&](std::span<const double> values, std::size_t count, std::string_view kind,
                             bool upper) {
        const ProbeColours before = probe_colours(in.weights, values, count, lum);
        const ProbeColours after = probe_colours(fit.weights, values, count, lum);
        for (std::size_t i = 0; i < count; ++i) {
            // 1e-10 of the terms' size: far above rounding (1e-16 per term), far below any real
            // change: with non-negative BRDF values a probe's luminance is at least 4e-3 of that
            // size (the smallest Y / |w|_1 of a "visible" weight, at 380 nm), so a change of 3e-8
            // of the luminance is caught.
            if (!(std::abs(after.luminance[i] - before.luminance[i]) <= 1e-10 * before.magnitude[i]))
                internal(cat("changed the luminance of ", in.material, " (", kind, " ", i, ": ",
                             before.luminance[i], " -> ", after.luminance[i], ")"));
            if (fit.clipped) continue;
            const double tol =
                std::max(10.0 * rounding(after.magnitude[i]), slack(in, after.magnitude[i]));
            for (int c = 0; c < 3; ++c) {
                const double v = after.colour[i][c];
                if (v < -tol || (upper && v > 1.0 + tol))
                    internal(cat("left ", in.material, " out of range without clipping (", kind, " ", i,
                                 " channel ", c, ": ", v, ")"));
            }
        }
    };
    compare(in.brdf, in.probe_count, "probe", false);
    compare(in.reflectance, in.reflectance_count, "reflectance", true);
}

Rgb clip_negative(const Rgb& rgb) {
    return {std::max(rgb[0], 0.0), std::max(rgb[1], 0.0), std::max(rgb[2], 0.0)};
}

ReflectanceColour reflectance_colour(const SpectralSet& set, std::span<const double> reflectance,
                                     ColorSpace space) {
    ReflectanceColour out;
    out.rgb = set.to_rgb(reflectance, space); // InputError on a size mismatch
    out.chroma_spectral = chroma_ab(rgb_to_xyz(out.rgb, space));
    GamutFitInput in;
    in.material = "reflectance";
    in.space = space;
    const auto w = set.rgb_weights(space);
    in.weights.assign(w.begin(), w.end());
    in.probe_count = 1;
    in.brdf.assign(reflectance.begin(), reflectance.end());
    in.reflectance_count = 1;
    in.reflectance.assign(reflectance.begin(), reflectance.end());
    const GamutFit fit = fit_into_gamut(in);
    out.gamut_scale = fit.scale;
    out.clipped = fit.clipped;
    Rgb fitted{0.0, 0.0, 0.0};
    for (std::size_t k = 0; k < fit.weights.size(); ++k)
        for (int c = 0; c < 3; ++c) fitted[c] += fit.weights[k][c] * reflectance[k];
    out.fitted = fit.clipped ? clip_negative(fitted) : fitted;
    out.chroma = chroma_ab(rgb_to_xyz(out.fitted, space));
    return out;
}

} // namespace brdf::material
