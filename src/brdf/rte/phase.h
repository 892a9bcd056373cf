#pragma once
// Phase functions as Legendre series and their Fourier components (docs/physics.md section 3):
//   p(cos T) = sum_l beta_l P_l(cos T),  beta_0 = 1,
//   p^m(mu, mu') = sum_{l >= m} beta_l Pbar_l^m(mu) Pbar_l^m(mu').
// Delta-M truncation (Wiscombe 1977, J. Atmos. Sci. 34, 1408, eqs. 5-7) keeps the series short for
// forward-peaked phase functions; the exact single scattering is added back later (Nakajima and
// Tanaka 1988, JQSRT 40, 51: the TMS correction).

#include <brdf/core/linalg.h>

#include <span>
#include <vector>

namespace brdf::rte {

/// A scattering medium: single-scattering albedo and the phase function's Legendre coefficients.
struct Medium {
    double omega = 0.0;        ///< single-scattering albedo in [0, 1]
    std::vector<double> beta;  ///< beta_l, beta_0 = 1
};

/// Phase-function value p(cos T) from its Legendre series.
double phase_value(std::span<const double> beta, double cos_theta);
/// The same at every cosine into out (legendre_series for a block of points: the same values).
void phase_values(std::span<const double> beta, std::span<const double> cos_theta, std::span<double> out);

struct DeltaM {
    Medium scaled;   ///< omega' and beta' with beta'_l = 0 for l >= L
    double f = 0.0;  ///< the truncated forward fraction chi_L
};

/// Delta-M scaling with L the first order not kept (L = 2N for N streams). f = 0 (no change) when the
/// series is already shorter than L.
DeltaM delta_m(const Medium& medium, int first_dropped);

/// What delta-M leaves out of the single scattering, p - p_dM = sum_{l >= L} (2l + 1)(chi_l - f) P_l
/// (the term TMS adds back on a smooth top's direct paths), seen through directions spread by a
/// Gaussian of angular width sigma (each moment times exp(-l (l + 1) sigma^2 / 2), the heat kernel
/// on the sphere): its largest size relative to the equally spread phase function over the
/// scattering angles of a reflection, 90 to 180 degrees. L = first_dropped as for delta_m (f too:
/// 0 for a backward-peaked function). sigma > 0; below 2.5e-3 it is taken as 2.5e-3 (moments to
/// 4000). docs/physics.md, "Rough interface", "Which counts the check skips".
double spread_delta_m_residual(const Medium& medium, int first_dropped, double sigma);

/// psi(i, l - m) = Pbar_l^m(mu_i), l = m .. lmax, divided by (1 - mu_i^2)^(sine_power/2)
/// (normalized_legendre_over_sine).
Matrix legendre_basis(int m, int lmax, std::span<const double> mu, int sine_power = 0);

/// p^m(s * mu_rows[i], mu_cols[j]) for s = +1 and -1, from the bases of both sets.
struct PhasePair {
    Matrix plus;  ///< p^m(mu_i, mu_j)
    Matrix minus; ///< p^m(-mu_i, mu_j)
};
/// Each row divided by (1 - mu_rows[i]^2)^(rows_sine_power/2), of the sin^m that p^m carries in
/// each of its directions (legendre_basis).
PhasePair phase_components(std::span<const double> beta, int m, std::span<const double> mu_rows,
                           std::span<const double> mu_cols, int rows_sine_power = 0);

} // namespace brdf::rte
