#pragma once
// Legendre polynomials and normalised associated Legendre functions, the building blocks of the
// Fourier decomposition of a phase function (docs/physics.md section 3; Mishchenko et al. 1999, JQSRT 63,
// 409, eq. 10):
//   p^m(mu, mu') = sum_{l >= m} beta_l Pbar_l^m(mu) Pbar_l^m(mu'),
//   Pbar_l^m = sqrt((l - m)! / (l + m)!) P_l^m   (no Condon-Shortley phase: it cancels in products).
// The normalised functions stay O(1) for every l and m, so the upward recurrence in l is stable for
// l in the thousands where P_l^m itself overflows.

#include <span>
#include <vector>

namespace brdf {

/// Pbar_l^m(x) for l = m .. lmax into out[l - m] (out.size() >= lmax - m + 1); x in [-1, 1], m >= 0.
void normalized_legendre(int m, int lmax, double x, std::span<double> out);

/// The same, returned as a vector of lmax - m + 1 values.
std::vector<double> normalized_legendre(int m, int lmax, double x);

/// The same at every x[k], into out[k * (lmax - m + 1) + l - m] (a row per point, as a row-major
/// matrix holds them; out.size() >= x.size() * (lmax - m + 1)); each point's values are bit for bit
/// those of the single-point function (which is this with one point). The recurrence's square roots
/// once per degree, and the points' recurrences side by side, where one point's chain of divisions
/// waits on the one before.
void normalized_legendre(int m, int lmax, std::span<const double> x, std::span<double> out);

/// Pbar_l^m(x) / (1 - x^2)^(power/2), 0 <= power <= m, laid out as the one above: without `power`
/// of the factor sin^m that every Pbar_l^m carries. With power = m the rest is a polynomial in x;
/// with power = m mod 2 it is a polynomial in x times sin^(m - power), a polynomial in 1 - x^2,
/// so analytic in sin^2 (rte::Reflection's order grid interpolates in sin^2).
void normalized_legendre_over_sine(int m, int lmax, std::span<const double> x,
                                   std::span<double> out, int power);

/// Legendre polynomials P_l(x), l = 0 .. lmax, into out (out.size() >= lmax + 1).
void legendre_polynomials(int lmax, double x, std::span<double> out);

/// sum_l beta_l P_l(x): a phase function from its Legendre coefficients (Clenshaw summation).
double legendre_series(std::span<const double> beta, double x);

/// The same at every x[k] into out[k] (out.size() >= x.size()), bit for bit the scalar sums: the
/// recurrence's coefficients once per degree for a block of points instead of two divisions per
/// degree and point (a Mie phase function at size parameter 1000 has thousands of degrees).
void legendre_series(std::span<const double> beta, std::span<const double> x, std::span<double> out);

} // namespace brdf
