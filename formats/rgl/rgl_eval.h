#pragma once
// Evaluation of an RGL BSDF as Mitsuba 3's `measured` BSDF evaluates it (src/bsdfs/measured.cpp,
// Measured::eval, version 3.9), in single precision like Mitsuba's scalar variants:
//
//   m = normalize(wi + wo); theta, phi of wi and m; u_m = (sqrt(theta_m / (pi/2)),
//   (phi_m [- phi_i when isotropic] + pi) / (2 pi) mod 1);
//   s = vndf^-1(u_m | phi_i, theta_i)                         (the warp of the paper's section 5)
//   value = values(s | phi_i, theta_i, channel) * [ndf(u_m) / (4 sigma(u_wi)) if jacobian]
//
// The value is f(wi, wo) cos(theta_o): Mitsuba's BSDF::eval includes the cosine of the outgoing
// direction; brdf() divides it out. Both are 0 unless wi and wo lie strictly above the horizon.
// pbrt-v4's MeasuredBxDF::f computes the same expression divided by the cosine (its f is the BRDF),
// clamping negative samples to 0 and always applying the jacobian factor.
//
// Anisotropic files (more than two phi_i) are handled with their symmetry reduction as Mitsuba does
// (reduction = rint(2 pi / (phi_i.back() - phi_i.front())); 2 or 4 mirror the directions into the
// measured azimuth range). Mitsuba 3.9 leaves the reduction of isotropic files uninitialised; for
// an isotropic file, whose samples are symmetric about the plane of incidence, the mirroring it may
// then apply changes nothing beyond float rounding, and we apply none.

#include <formats/halfdiff.h>
#include <formats/rgl/rgl_bsdf.h>
#include <formats/rgl/rgl_warp.h>

#include <string>
#include <vector>

namespace brdf::formats {

/// What our `description` says (rgl_description's JSON object): the generator and the material
/// spec (as JSON text). ours = false and both empty for anything else (the RGL database's files
/// describe the measurement in free text).
struct RglProvenance {
    std::string generator;
    std::string spec;
    bool ours = false;
};
RglProvenance rgl_provenance(const RglBsdf& bsdf);

class RglEvaluator {
  public:
    /// Builds the interpolants (as Mitsuba's loader does). `bsdf` must pass rgl_bsdf_fault
    /// (NumericalError otherwise).
    explicit RglEvaluator(RglBsdf bsdf);

    const RglBsdf& bsdf() const { return m_bsdf; }
    /// Channels of the values: the file's wavelengths, or R, G, B.
    std::size_t channels() const { return m_bsdf.channels(); }

    /// Mitsuba's BSDF::eval: f(wi, wo) cos(theta_o) per channel (each wavelength of a spectral
    /// file, or R, G, B). wi, wo: unit vectors pointing away from the surface, z up.
    std::vector<double> eval_cosine(const Vec3& wi, const Vec3& wo) const;
    /// The same at one wavelength in nm (linear between the file's wavelengths, clamped outside
    /// them, as Mitsuba's spectral variants interpolate); a channel index for an RGB file.
    double eval_cosine(const Vec3& wi, const Vec3& wo, double wavelength_nm) const;
    /// The BRDF in 1/sr: eval_cosine / cos(theta_o); 0 at or below the horizon.
    std::vector<double> brdf(const Vec3& wi, const Vec3& wo) const;

    /// What eval_cosine multiplies the interpolated sample by at (wi, wo): ndf(u_m) / (4
    /// sigma(u_wi)) for a file with the jacobian, else 1; 0 where eval_cosine is 0. The builder
    /// divides by exactly this, so that our files are exact at their nodes.
    double sample_factor(const Vec3& wi, const Vec3& wo) const;
    /// The point of the sample grid's unit square at which eval_cosine interpolates the samples
    /// (the inverse of the visible-normal warp); (-1, -1) where eval_cosine is 0.
    rgl::Point2f sample_point(const Vec3& wi, const Vec3& wo) const;

  private:
    struct Query {
        bool valid = false;
        float phi_i = 0.0f, theta_i = 0.0f;
        rgl::Point2f sample;
        float factor = 1.0f; ///< ndf / (4 sigma), or 1 without the jacobian
    };
    Query prepare(const Vec3& wi, const Vec3& wo) const;
    float value(const Query& q, float channel_param) const;

    RglBsdf m_bsdf;
    int m_reduction = 1;
    rgl::PiecewiseLinearWarp m_ndf, m_sigma, m_vndf, m_values;
    std::vector<float> m_channel_params; ///< wavelengths, or 0, 1, 2
};

} // namespace brdf::formats
