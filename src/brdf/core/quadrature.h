#pragma once
// Gauss-Legendre quadrature (and the Chebyshev-Lobatto nodes and Lagrange weights of interpolation
// in a parameter). Nodes by Newton's method on P_n from Tricomi's asymptotic initial guess
// (Abramowitz and Stegun 22.16.6; Press et al., Numerical Recipes 3rd ed., section 4.6), weights
// 2 / ((1 - x^2) P_n'(x)^2). Exact for polynomials of degree <= 2n - 1. Rules are cached: the Mie
// moments and the solver ask for the same sizes over and over.

#include <memory>
#include <span>
#include <vector>

namespace brdf {

struct Quadrature {
    std::vector<double> x; ///< nodes, ascending
    std::vector<double> w; ///< weights, positive
    std::size_t size() const { return x.size(); }
};

/// n-point Gauss-Legendre rule on [-1, 1]; n in [1, 200000]. Thread-safe, cached.
std::shared_ptr<const Quadrature> gauss_legendre(int n);

/// n-point Gauss-Legendre rule mapped affinely to [a, b].
Quadrature gauss_legendre(int n, double a, double b);

/// n >= 2 Chebyshev-Lobatto points on [a, b], ascending, a and b exactly: the nodes of polynomial
/// interpolation of a smooth function in a parameter (the binder index of a material's wavelengths).
std::vector<double> chebyshev_lobatto(int n, double a, double b);

/// The Lagrange basis of distinct `nodes` at x: l_j(x) = prod_{i != j} (x - x_i) / (x_j - x_i), so
/// that sum_j l_j(x) f(x_j) is the interpolating polynomial's value.
std::vector<double> lagrange_weights(std::span<const double> nodes, double x);

} // namespace brdf
