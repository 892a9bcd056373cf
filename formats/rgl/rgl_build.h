#pragma once
// Building the RGL parameterisation from an isotropic BRDF model, the way Dupuy and Jakob ("An
// Adaptive Parameterization for Efficient Material Acquisition and Rendering", SIGGRAPH Asia 2018)
// build it from measurements:
//
//  1. NDF from the retro-reflection (as the paper does, with the power iteration of Dupuy et al.,
//     "Extracting microfacet-based BRDF parameters from arbitrary materials with power
//     iterations", EGSR 2015). A
//     microfacet BRDF seen back along the light, wo = wi = w, has h = w, F = F(0) and G2 = G1(w) =
//     cos(theta) / sigma(w), so f(w, w) = F(0) D(w) / (4 sigma(w) cos(theta)), i.e.
//         D(w) = (4 / F(0)) f(w, w) cos(theta) sigma_D(w),  sigma_D(w) = int D(m) <w.m> dm,
//     an eigenproblem in D solved by power iteration, normalised so that int D(m) cos(theta_m) dm
//     = sigma_D(normal) = 1. We take f(w, w) from the model directly (its back-scattering), as the
//     luminance of the channels, and evaluate every integral on the file's own interpolant of D
//     (piecewise linear in u_theta = sqrt(theta / (pi/2))), with the azimuthal integral in closed
//     form. A floor of 1e-4 of the peak keeps D > 0 where the model has no back-scattering.
//  2. sigma(w) of that D on its grid (the same integral).
//  3. Per incidence theta_i: the visible-normal density D(m) <wi.m> / sigma(wi) on a grid of m in
//     (u_theta, u_phi - u_phi_i) with the Jacobian of that grid (2 pi^2 u_theta sin(theta_m)): the
//     paper's warp from the unit square to microfacet normals (renderers normalise it; ours
//     integrates to 1).
//  4. The BRDF samples: each node s of the n x n sample grid is mapped through the warp exactly as
//     the renderers map it (formats/rgl/rgl_warp.h) to m, wo = reflect(wi, m), and stores
//         f(wi, wo) cos(theta_o) * 4 sigma(wi) / D(m)     (jacobian = 1)
//     with D and sigma the interpolants the renderer will multiply back, so that the file is exact
//     at every node up to float rounding; between nodes the renderer interpolates. Nodes whose wo
//     falls at or below the horizon hold 0, the limit of f cos(theta_o) there (and no negative
//     values: pbrt-v4 clamps them, and our outputs hold none).
//  5. The luminance warp (sampling only): the renderers draw s from it, then wo through the warp,
//     so it holds Y(f cos(theta_o)) over the warp's own pdf of wo at each node, which makes their
//     pdf proportional to the BRDF's luminance (for the visible-normal warp that pdf is close to
//     D / (4 sigma), and this is the luminance of the samples, as in the paper).
//
// Our files are isotropic: one phi_i (0), ndf and sigma with two identical azimuth rows (the
// renderers' interpolants need two), theta_i uniform in angle.

#include <formats/halfdiff.h>
#include <formats/rgl/rgl_bsdf.h>

#include <array>
#include <functional>
#include <string>
#include <vector>

namespace brdf::formats {

/// The BRDF in 1/sr for each channel: `values` has one entry per channel (each wavelength of
/// RglOptions::wavelengths_nm, or R, G, B). wi (towards the light) and wo (towards the viewer) are
/// unit vectors pointing away from the surface, z up, both strictly above the horizon. The model
/// must be isotropic (a function of theta_i, theta_o and phi_o - phi_i only). Called from the
/// calling thread only.
using RglBrdfCallback =
    std::function<void(const Vec3& wi, const Vec3& wo, std::vector<double>& values)>;

struct RglOptions {
    /// Wavelengths in nm, increasing, for a spectral file (field "spectra"; Mitsuba's spectral
    /// variants and pbrt-v4); empty for an RGB file (field "rgb"; Mitsuba's RGB variants only).
    std::vector<double> wavelengths_nm;
    /// Luminance weight of each channel, used for the NDF's retro-reflection and the luminance
    /// warp. Empty: Rec.709 Y (0.2126, 0.7152, 0.0722) for RGB, the CIE 1931 y-bar of each
    /// wavelength (the fit of Wyman, Sloan and Shirley 2013) times its trapezoid width for spectral
    /// (equal weights if that is ~0, e.g. all in the infrared).
    std::vector<double> luminance_weights;
    /// Incidence angles, uniform from 0 to max_theta_i_deg; >= 2.
    int theta_i_count = 16;
    /// Last incidence angle in degrees, (0, 90]; the renderers clamp beyond it.
    double max_theta_i_deg = 89.5;
    /// n of the n x n BRDF sample (and luminance) grid per incidence; >= 2.
    int sample_resolution = 32;
    /// Nodes of the visible-normal warp per incidence, in theta_m and in phi_m; >= 2.
    int vndf_theta_resolution = 64;
    int vndf_phi_resolution = 64;
    /// Nodes in theta of the ndf and sigma grids; >= 2.
    int ndf_resolution = 128;
    int sigma_resolution = 64;
    /// Stored as the file's `description` (our provenance: see rgl_description).
    std::string description;
};

/// `{"generator": GENERATOR, "spec": SPEC}` with SPEC embedded as JSON when it is a JSON object
/// (our material specs are), else as a string; without "spec" when it is empty.
std::string rgl_description(const std::string& generator, const std::string& spec_json);

/// Builds the parameterisation and samples of `brdf` (see above). Throws InputError for options
/// out of range, NumericalError naming the channel, incidence and directions when the callback
/// returns the wrong number of values, a negative or non-finite value.
RglBsdf make_rgl_bsdf(const RglBrdfCallback& brdf, const RglOptions& options);

/// The RGB file of a spectral one, for Mitsuba 3's RGB variants: its `measured` takes a file with
/// "wavelengths" as spectral and refuses it in an RGB variant, and pbrt-v4 needs "spectra" and
/// "wavelengths", so no single file serves both (docs/formats.md). The same theta_i, phi_i, ndf,
/// sigma, vndf, luminance, description and jacobian, and at every sample node
///     rgb[c] = max(0, sum_l weights[l][c] spectra[l]),
/// which is exact where the spectral file is: the samples are linear in the BRDF and the factor the
/// renderer multiplies back (ndf / (4 sigma)) is the same for every channel. The luminance grid
/// (sampling only) stays the CIE luminance of the spectral samples. Throws InputError when `spectral`
/// is not spectral or the weights are not one per wavelength, finite.
RglBsdf rgl_rgb_from_spectral(const RglBsdf& spectral, const std::vector<std::array<double, 3>>& weights);

} // namespace brdf::formats
