#pragma once
// Comparison model: the dipole diffusion BRDF plus single scattering of Jensen, Marschner, Levoy and
// Hanrahan 2001 ("A Practical Model for Subsurface Light Transport", SIGGRAPH 2001, section 2.4 and
// eqs. (5)-(7); docs/physics.md section 5). It is the baseline the seed paper compares against: cheap, but
// biased in both directions (diffusion overestimates or underestimates the multiple scattering
// depending on albedo and angles) and it loses the angular structure of the multiple scattering.
// Keep it as a comparison model only; the service's default is the exact solve.
//
//   alpha' = omega (1 - g) / (1 - omega g)                         reduced albedo (similarity relation)
//   F_dr   = -1.440/eta^2 + 0.710/eta + 0.668 + 0.0636 eta           diffuse Fresnel reflectance
//                                                                  (Egan and Hilgeman 1979 fit; 0 at eta = 1)
//   A      = (1 + F_dr) / (1 - F_dr)
//   R_d    = (alpha'/2) [1 + exp(-(4/3) A sqrt(3 (1 - alpha')))] exp(-sqrt(3 (1 - alpha')))
//   f_d    = F_t(eta, theta_i) R_d F_t(eta, theta_o) / pi          (1/sr)
//   f_ss   = F_t(eta, theta_i) F_t(eta, theta_o) / eta^2 * omega p(cos T) / (4 pi (u_i + u_o))
// The single-scattering term (Jensen et al. eq. 7 after Hanrahan and Krueger 1993) uses the full
// phase function p = sum beta_l P_l at the refracted cosines u_i, u_o inside the medium, with the
// radiance factor 1/eta^2 of crossing the interface: it is exactly the single scattering of the
// exact model (rte::Reflection::single_scattering with its transmission factor), so that the two
// models differ only in the multiple scattering. eta = 1 means no interface (F_t = 1, F_dr = 0: the
// fit's 0.0026 at eta = 1 is its own error, not internal reflection).
//
// Angles: cosines in air, phi in the graphics convention of docs/design.md (0 on the light's side).

#include <brdf/rte/interface.h>

#include <vector>

namespace brdf::rte {

/// Reduced albedo alpha' = omega (1 - g) / (1 - omega g).
double dipole_reduced_albedo(double omega, double g);
/// Diffuse Fresnel reflectance F_dr(eta) (the polynomial fit above); 0 for eta == 1.
double dipole_fresnel_dr(double eta);
/// Total diffuse reflectance R_d(alpha', eta) of the dipole (Jensen et al. 2001, eq. 6 integrated).
double dipole_rd(double reduced_albedo, double eta);

class Dipole {
public:
    /// omega: single-scattering albedo in [0, 1]; g: asymmetry parameter (|g| < 1); eta: binder index
    /// (>= 1, 1 = no interface); beta: the full phase function's Legendre coefficients, beta_0 = 1.
    Dipole(double omega, double g, double eta, std::vector<double> beta);

    /// BRDF (1/sr) of the diffuse part (diffusion + single scattering), no mirror reflection.
    double brdf(double mu_i, double mu_o, double phi) const;
    double diffusion_brdf(double mu_i, double mu_o) const;
    double single_scattering_brdf(double mu_i, double mu_o, double phi) const;
    /// Directional-hemispherical reflectance of brdf() (numerical quadrature over the hemisphere).
    double albedo(double mu_i) const;
    /// The interface's mirror reflectance (0 without one).
    double mirror(double mu_i) const;

    double reduced_albedo() const { return m_alpha; }
    double rd() const { return m_rd; }

private:
    double transmission(double mu_air) const; ///< F_t = 1 - Fresnel reflectance from air
    double m_omega, m_g;
    Interface m_interface;
    std::vector<double> m_beta;
    double m_alpha, m_rd;
};

} // namespace brdf::rte
