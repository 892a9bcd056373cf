#pragma once
// RGL BSDF files (`NAME.rgl.bsdf`): the adaptive parameterisation of Dupuy and Jakob, "An Adaptive
// Parameterization for Efficient Material Acquisition and Rendering" (SIGGRAPH Asia 2018), stored
// in a tensor file (formats/rgl/tensor_file.h) as the RGL material database distributes it and as
// Mitsuba 3's `measured` BSDF and pbrt-v4's `measured` BxDF read it.
//
// Fields (all float32 but `description` and `jacobian`; the u coordinates below are those of the
// renderers: u_theta = sqrt(theta / (pi/2)), u_phi = (phi + pi) / (2 pi), grids span [0, 1] with
// nodes at k / (n - 1)):
//   theta_i      [T]                incidence zenith angles, radians, increasing
//   phi_i        [P]                incidence azimuths, radians; P <= 2 means isotropic (then the
//                                   microfacet azimuth is relative to phi_i)
//   ndf          [nphi, ntheta]     microfacet normal distribution D(m) (1/sr) on the (u_theta,
//                                   u_phi) grid of m
//   sigma        [nphi, ntheta]     projected microfacet area sigma(w) = int D(m) <w.m> dm on the
//                                   grid of w
//   vndf         [P, T, nphi, ntheta]    visible-normal density per incidence on the u grid of m
//                                   (the warp of section 5; normalised by the reader)
//   luminance    [P, T, n, n]       luminance of the BRDF samples per incidence (for sampling)
//   spectra      [P, T, L, n, n]    BRDF samples on the warped n x n grid, per wavelength, with
//   wavelengths  [L]                  the wavelengths in nm (spectral files), or
//   rgb          [P, T, 3, n, n]    the same per R, G, B channel (RGB files; Mitsuba only: pbrt-v4
//                                   reads spectral files only)
//   description  [bytes]            free text (our provenance)
//   jacobian     [1] uint8          1: a sample s stores f(wi, wo) cos(theta_o) / p(wo) with
//                                   p(wo) = D(m) / (4 sigma(wi)), which the renderer multiplies back
//                                   (pbrt-v4 always does); 0: it stores f(wi, wo) cos(theta_o)
//
// Grid index order is row-major with the last index fastest, so a BRDF sample is
// values[((p * T + t) * L + l) * n * n + y * n + x] for sample coordinates (x, y) / (n - 1).

#include <formats/rgl/tensor_file.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace brdf::formats {

/// A float32 array with its shape (row-major, last index fastest).
struct RglArray {
    std::vector<std::size_t> shape;
    std::vector<float> values;

    std::size_t size() const;
};

struct RglBsdf {
    std::vector<float> theta_i; ///< radians, increasing
    std::vector<float> phi_i;   ///< radians, increasing; one value for our isotropic files
    RglArray ndf;               ///< [nphi, ntheta]
    RglArray sigma;             ///< [nphi, ntheta]
    RglArray vndf;              ///< [P, T, nphi, ntheta]
    RglArray luminance;         ///< [P, T, n, n]
    RglArray values;            ///< [P, T, channels, n, n]: field "spectra" or "rgb"
    /// Wavelengths of the channels of `values` in nm, increasing; empty for an RGB file.
    std::vector<float> wavelengths;
    std::string description;
    bool jacobian = true;

    bool spectral() const { return !wavelengths.empty(); }
    /// As Mitsuba and pbrt-v4 decide it: at most two incidence azimuths.
    bool isotropic() const { return phi_i.size() <= 2; }
    /// Number of channels of `values` (wavelengths, or 3).
    std::size_t channels() const { return spectral() ? wavelengths.size() : 3; }
    /// Side n of the n x n sample grid.
    std::size_t sample_resolution() const { return values.shape.size() == 5 ? values.shape[4] : 0; }
};

/// The first structural or numerical fault of `bsdf` as Mitsuba 3 and pbrt-v4 would meet it, or an
/// empty string. Checks the shapes Mitsuba's `measured` checks (and pbrt-v4's: the same), and
/// beyond them what would make those readers fail or produce NaN: grids of at least 2 x 2 (their
/// interpolants need it), non-empty increasing finite theta_i, phi_i and wavelengths, finite
/// values everywhere, ndf, vndf and luminance >= 0, sigma > 0 (it divides), no vndf or luminance
/// row of zeros (inverting a warp divides by each row's integral) and no such grid too small to
/// normalise in float, and largest sample x largest ndf / (4 x smallest sigma) within float range.
/// BRDF samples may be negative (measured noise; pbrt-v4 clamps them, Mitsuba does not).
std::string rgl_bsdf_fault(const RglBsdf& bsdf);

/// Reads an RGL BSDF file: read_tensor_file (every size and offset checked first), then the fields
/// above. Extra fields are ignored. A spectral file ("wavelengths" present) needs "spectra", an RGB
/// file "rgb". Each fault is one FormatError line naming the path and the field, e.g.
///   "paint.rgl.bsdf: field 'vndf': shape [1, 8, 32, 32] does not match theta_i (9 values)".
/// Throws IoError, FormatError or LimitError.
RglBsdf read_rgl_bsdf(const std::filesystem::path& path);

/// The tensor fields of `bsdf`, in the order theta_i, phi_i, ndf, sigma, vndf, luminance, spectra +
/// wavelengths (or rgb), description, jacobian; unchecked (write_rgl_bsdf checks first).
TensorFile rgl_tensor_fields(const RglBsdf& bsdf);

/// Writes `bsdf` atomically as a tensor file with the fields of rgl_tensor_fields. Throws
/// NumericalError naming the path and the fault (rgl_bsdf_fault, or a negative BRDF sample: our
/// files hold none) before any file is created; IoError if it cannot be written.
void write_rgl_bsdf(const std::filesystem::path& path, const RglBsdf& bsdf);

} // namespace brdf::formats
