// Jensen et al. 2001 dipole diffusion BRDF plus single scattering; formulas and citations in dipole.h.
#include <brdf/rte/dipole.h>

#include <brdf/core/error.h>
#include <brdf/core/quadrature.h>
#include <brdf/rte/phase.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace brdf::rte {

double dipole_reduced_albedo(double omega, double g) {
    const double den = 1.0 - omega * g;
    return den > 0.0 ? omega * (1.0 - g) / den : 1.0;
}

double dipole_fresnel_dr(double eta) {
    if (eta == 1.0) return 0.0;
    return -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
}

double dipole_rd(double reduced_albedo, double eta) {
    const double fdr = dipole_fresnel_dr(eta);
    const double a = (1.0 + fdr) / (1.0 - fdr);
    const double s = std::sqrt(3.0 * std::max(0.0, 1.0 - reduced_albedo));
    return 0.5 * reduced_albedo * (1.0 + std::exp(-(4.0 / 3.0) * a * s)) * std::exp(-s);
}

Dipole::Dipole(double omega, double g, double eta, std::vector<double> beta)
    : m_omega(omega), m_g(g), m_interface{eta}, m_beta(std::move(beta)) {
    if (!(omega >= 0.0 && omega <= 1.0)) throw InputError("dipole: single-scattering albedo must be in [0, 1]");
    if (!(std::abs(g) < 1.0)) throw InputError("dipole: asymmetry parameter must satisfy |g| < 1");
    if (!(eta >= 1.0)) throw InputError("dipole: binder index must be >= 1");
    if (m_beta.empty() || std::abs(m_beta[0] - 1.0) > 1e-9) throw InputError("dipole: phase function must have beta_0 = 1");
    m_alpha = dipole_reduced_albedo(omega, g);
    m_rd = dipole_rd(m_alpha, eta);
}

double Dipole::transmission(double mu_air) const {
    return m_interface.present() ? 1.0 - m_interface.reflectance_from_air(mu_air) : 1.0;
}

double Dipole::mirror(double mu_i) const {
    return m_interface.present() ? m_interface.reflectance_from_air(std::clamp(mu_i, 0.0, 1.0)) : 0.0;
}

double Dipole::diffusion_brdf(double mu_i, double mu_o) const {
    return transmission(mu_i) * m_rd * transmission(mu_o) * std::numbers::inv_pi;
}

double Dipole::single_scattering_brdf(double mu_i, double mu_o, double phi) const {
    const double u_i = m_interface.present() ? m_interface.inside(mu_i) : mu_i;
    const double u_o = m_interface.present() ? m_interface.inside(mu_o) : mu_o;
    if (u_i + u_o <= 0.0) return 0.0;
    const double s_i = std::sqrt(std::max(0.0, 1.0 - u_i * u_i));
    const double s_o = std::sqrt(std::max(0.0, 1.0 - u_o * u_o));
    // Graphics azimuth: phi = 0 puts the viewer on the light's side (backscattering).
    const double cos_scatter = std::clamp(-u_o * u_i - s_o * s_i * std::cos(phi), -1.0, 1.0);
    const double n2 = m_interface.n * m_interface.n;
    return transmission(mu_i) * transmission(mu_o) / n2 * 0.25 * m_omega * phase_value(m_beta, cos_scatter) /
           (u_i + u_o) * std::numbers::inv_pi;
}

double Dipole::brdf(double mu_i, double mu_o, double phi) const {
    mu_i = std::clamp(mu_i, 0.0, 1.0);
    mu_o = std::clamp(mu_o, 0.0, 1.0);
    return diffusion_brdf(mu_i, mu_o) + single_scattering_brdf(mu_i, mu_o, phi);
}

double Dipole::albedo(double mu_i) const {
    // int f cos(theta_o) dOmega_o: Gauss in mu_o on (0, 1) (squared, for the 1/(u_i + u_o) end) and
    // Gauss in phi on (0, pi) (the integrand is even in phi).
    constexpr int n_mu = 64, n_phi = 64;
    const Quadrature qm = gauss_legendre(n_mu, 0.0, 1.0);
    const Quadrature qp = gauss_legendre(n_phi, 0.0, std::numbers::pi);
    const auto &t = qm.x, &wt = qm.w, &p = qp.x, &wp = qp.w;
    double sum = 0.0;
    for (int a = 0; a < n_mu; ++a) {
        const double mu_o = t[a] * t[a];
        const double jac = 2.0 * t[a] * wt[a];
        double ring = 0.0;
        for (int b = 0; b < n_phi; ++b) ring += wp[b] * single_scattering_brdf(mu_i, mu_o, p[b]);
        sum += jac * mu_o * (2.0 * ring + 2.0 * std::numbers::pi * diffusion_brdf(mu_i, mu_o));
    }
    return sum;
}

} // namespace brdf::rte
