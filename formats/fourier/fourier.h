#pragma once
// Fourier BSDF files: pbrt-v3's `Material "fourier"` (FourierBSDFTable::Read, FourierBSDF::f in
// src/core/reflection.cpp; PBR book 3rd ed., section 8.6 "Fourier basis BSDFs"), the "SCATFUN"
// version 1 format of layerlab and Mitsuba (Jakob et al., "A Comprehensive Framework for Rendering
// Layered Materials", SIGGRAPH 2014). docs/formats.md, "Fourier BSDF", describes the file and the
// conventions in full.
//
// An isotropic BSDF as a function of mu_i = cos(-wi) (the light's propagation direction), mu_o =
// cos(wo), both in [-1, 1], and the azimuth phi' between -wi and wo:
//     f(mu_i, mu_o, phi') |mu_i| = sum_{k < m} a_k(mu_i, mu_o) cos(k phi')        (PBR eq. 8.21)
// with a_k tabulated on nodes mu[] x mu[] and interpolated by Catmull-Rom splines in mu_i and mu_o.
// Reflection from above is the quadrant mu_i < 0 < mu_o; phi' = 0 is the mirror side. In our
// conventions (docs/design.md: phi = phi_o - phi_i, 0 with the viewer on the light's side) a
// BRDF f = sum_m b_m cos(m phi) is stored as a_m = (-1)^m cos(theta_i) b_m at (-cos theta_i,
// cos theta_o).
//
// Little-endian file: a 64-byte header, float32 mu[n], float32 cdf[n * n], int32 (offset,
// length)[n * n], float32 coefficients[nCoeffs], then nMetadataBytes of metadata that pbrt-v3
// ignores (our provenance goes there, as JSON).

#include <formats/halfdiff.h>
#include <formats/table.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace brdf::formats {

/// The first 8 bytes of every file: "SCATFUN" and the version byte 1.
inline constexpr std::array<char, 8> fourier_magic{'S', 'C', 'A', 'T', 'F', 'U', 'N', '\x01'};
inline constexpr std::size_t fourier_header_size = 64;
/// Header flag 0x01: the file holds a BSDF (pbrt-v3 requires exactly this flag).
inline constexpr std::uint32_t fourier_flag_bsdf = 0x01;
/// Header flag 0x02: harmonic extrapolation (Mitsuba only; pbrt-v3 refuses it, and so do we).
inline constexpr std::uint32_t fourier_flag_extrapolated = 0x02;

/// pbrt-v3's luminance and green reconstruction: Y = 0.212671 R + 0.715160 G + 0.072169 B and
/// G = 1.39829 Y - 0.100913 B - 0.297375 R (reflection.cpp; layerlab's storage.cpp writes Y so).
inline constexpr std::array<double, 3> fourier_luminance_weights{0.212671, 0.715160, 0.072169};

/// The content of a Fourier BSDF file.
struct FourierBsdf {
    /// One series: `length` coefficients per channel, channel c at coefficients[offset + c *
    /// length + k], k < length. length 0: the pair is black (pbrt-v3 never reads its offset).
    struct Series {
        std::uint32_t offset = 0;
        std::uint32_t length = 0;
    };

    /// Node cosines, non-decreasing, in [-1, 1]. pbrt-v3 evaluates nothing outside [mu.front(),
    /// mu.back()], so files run from -1 to 1. A value may repeat: layerlab (and we) store 0 twice,
    /// so that the spline does not blend reflection (mu_o > 0) into transmission (mu_o < 0).
    std::vector<float> mu;
    /// 1 (Y) or 3 (Y, R, B in pbrt-v3's order; G is reconstructed).
    int channels = 3;
    /// mMax: the length of the longest series.
    std::uint32_t max_order = 0;
    /// eta(bottom) / eta(top); pbrt-v3 uses it only to scale transmission. 1 for our
    /// reflection-only tables.
    float eta = 1.0f;
    /// Beckmann-equivalent roughness of the top and bottom interface (layerlab's header; pbrt-v3
    /// ignores it).
    std::array<float, 2> alpha{0.0f, 0.0f};
    /// Per node pair, index o * mu.size() + i: o the outgoing node, i the incident node (pbrt-v3's
    /// FourierBSDFTable::GetAk).
    std::vector<Series> series;
    /// nCoeffs values; see Series.
    std::vector<float> coefficients;
    /// cdf[o * n + i] = integral of a_0 of the first channel (Y) over mu_i from mu[0] to mu[i] at
    /// mu_o = mu[o], by the Catmull-Rom spline (PBR book's IntegrateCatmullRom): what pbrt-v3
    /// samples mu_i with (FourierBSDF::Sample_f, Pdf).
    std::vector<float> cdf;
    /// The metadata block, verbatim (layerlab writes JSON describing its layers; we write
    /// fourier_provenance_metadata()).
    std::string metadata;

    std::size_t nodes() const { return mu.size(); }
    const Series& at(std::size_t o, std::size_t i) const { return series[o * mu.size() + i]; }
    /// The coefficients a_k, k < length, of one channel of pair (o, i).
    std::span<const float> coefficients_of(std::size_t o, std::size_t i, int channel) const;
};

/// What our metadata JSON says; fields are empty when absent (any foreign file).
struct FourierProvenance {
    std::string spec;       ///< the material spec JSON text
    std::string generator;  ///< name and version of the program
    std::string colorspace; ///< "rec709", "acescg" or "rec2020": the RGB the coefficients are in
    bool ours = false;      ///< the metadata is our JSON object
};

/// The metadata block we write: a JSON object {"brdf.generator", "brdf.spec", "brdf.colorspace",
/// "brdf.units": "1/sr", "brdf.convention"}.
std::string fourier_provenance_metadata(const std::string& spec, const std::string& generator,
                                        const std::string& colorspace);
/// Parses our metadata; anything else (layerlab's JSON, text, nothing) gives ours = false.
FourierProvenance fourier_provenance(const FourierBsdf& bsdf);

/// Checks what a writer and the evaluator rely on (the same checks read_fourier_bsdf makes on a
/// file): at least 2 nodes, non-decreasing within [-1, 1], mu.front() < mu.back(); channels 1 or
/// 3; n * n series and cdf values; every series inside `coefficients` and no longer than
/// max_order, max_order the longest; every float finite; eta finite and > 0. Throws FormatError
/// starting with `what`.
void check_fourier_bsdf(const FourierBsdf& bsdf, const std::string& what);

/// Reads a Fourier BSDF file. Checks, in this order and before allocating anything that the file
/// size does not bound: a readable regular file (IoError); the 64-byte header; the magic and
/// version; flags (exactly 0x01: harmonic extrapolation is refused, as pbrt-v3 does), channels 1 or
/// 3, one basis and no textured parameters (what pbrt-v3 reads); the exact file size the counts
/// imply; then check_fourier_bsdf. Every fault is one FormatError line starting with the path,
/// e.g. "paint.bsdf: truncated (207354 bytes expected from the header: 58 nodes, 41502
/// coefficients, 682 metadata bytes; 1200 found)".
FourierBsdf read_fourier_bsdf(const std::filesystem::path& path);

/// Writes atomically (temporary file in the same folder, fsync, rename) after check_fourier_bsdf
/// (NumericalError for non-finite values, FormatError for the rest). IoError naming the path when
/// the file cannot be written; the temporary file is then removed.
void write_fourier_bsdf(const std::filesystem::path& path, const FourierBsdf& bsdf);

/// pbrt-v3's FourierBSDF::f in its own variables: mu_i = cos(-wi), mu_o = cos(wo), cos_phi the
/// cosine of the azimuth between -wi and wo. RGB (for 1 channel, Y in all three), 1/sr, clamped at
/// 0 as pbrt-v3 clamps. 0 outside the nodes, and for |mu_i| < 1e-12 (pbrt-v3 returns 0 at mu_i
/// == 0 only; closer to the horizon than that its 1/|mu_i| amplifies rounding). `radiance`: the
/// transport mode's eta^2 scaling of transmission (mu_i mu_o > 0); reflection is never scaled.
Rgb evaluate_pbrt(const FourierBsdf& bsdf, double mu_i, double mu_o, double cos_phi,
                  bool radiance = true);

/// The BRDF in our conventions (docs/design.md): theta_i the light's and theta_o the viewer's
/// zenith angle, phi = phi_o - phi_i (0: viewer on the light's side, pi: mirror side), radians;
/// zenith angles beyond pi/2 lie below the surface (transmission in pbrt-v3's sense). RGB in 1/sr
/// as pbrt-v3 returns it: evaluate_pbrt(bsdf, -cos theta_i, cos theta_o, cos(pi - phi)), with
/// cos_phi = 1 when either direction is vertical, as pbrt-v3's CosDPhi does.
Rgb evaluate(const FourierBsdf& bsdf, double theta_i, double theta_o, double phi);
/// The same for unit vectors pointing away from the surface (wi towards the light).
Rgb evaluate(const FourierBsdf& bsdf, const Vec3& wi, const Vec3& wo);

/// The table of the BSDF at the bin centres of the MERL layout (tabulate), for convert and diff.
/// spec, generator and colorspace come from our metadata when the file has it.
BrdfTable tabulate_fourier(const FourierBsdf& bsdf);

// --- From our model
// -------------------------------------------------------------------------------

/// The cosine series of a reflection-only BRDF at one pair of cosines, in OUR convention:
///     f(theta_i, theta_o, phi) = sum_{m < orders} b_m(mu_i, mu_o) cos(m phi),   1/sr,
/// mu_i = cos theta_i (light), mu_o = cos theta_o (viewer), phi = phi_o - phi_i (0: the viewer on
/// the light's side). Fill out[c * orders + m] for c = 0, 1, 2 (R, G, B in the table's colour
/// space). mu_i is in (0, 1], mu_o in [0, 1].
using FourierSeriesSource = std::function<void(double mu_i, double mu_o, std::span<double> out)>;

struct FourierBuildOptions {
    /// 3: Y, R, B (colour); 1: Y only (pbrt-v3 then returns grey).
    int channels = 3;
    /// Per pair and channel, the highest orders are dropped while the sum of their |a_k| stays
    /// <= truncation * |a_0| (so no phi moves by more than that, relative to the pair's mean);
    /// layerlab's rule. 0 keeps every order up to the last non-zero one.
    double truncation = 1e-6;
    float eta = 1.0f;
    std::string spec;
    std::string generator;
    std::string colorspace = "rec709";
};

/// Builds the file's content from reflection-only data. `mu`: the caller's nodes, ascending, in
/// (0, 1] (distinct after rounding to float32). The table gets the nodes pbrt-v3 needs:
///   - mu = 1 when `mu` lacks it (pbrt-v3 evaluates nothing beyond the last node: without it
///     normal incidence would be black);
///   - mu = 0 twice, as layerlab writes it: the rows mu_i = 0 are zero (the stored a_k carry the
///     factor |mu_i|), the column mu_o = +0 holds the BRDF with the viewer at the horizon, and the
///     column mu_o = -0 the zero transmission, so that the spline does not blend the two;
///   - the mirror image -mu of every node, whose pairs (transmission, reflection from below) are
///     black.
/// `b` is called for every pair of positive nodes (mu_i > 0, mu_o >= 0; never with mu_i = 0).
/// Orders 0 .. orders - 1 (orders >= 1); see FourierBuildOptions for truncation. Throws
/// InputError for bad nodes or options, NumericalError for a non-finite b, LimitError when the
/// coefficients would not fit pbrt-v3's int32 counts.
FourierBsdf make_fourier_bsdf(std::span<const double> mu, int orders, const FourierSeriesSource& b,
                              const FourierBuildOptions& options = {});

/// PBR book's IntegrateCatmullRom: cdf[0] = 0, cdf[k] = integral of the Catmull-Rom spline through
/// (x, values) from x[0] to x[k]. Returns the total. x ascending (repeated values allowed: their
/// interval has zero width).
double integrate_catmull_rom(std::span<const double> x, std::span<const double> values,
                             std::span<double> cdf);

} // namespace brdf::formats
