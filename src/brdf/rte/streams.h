#pragma once
// Quadrature in mu for the per-order equations ("streams"). Gauss-Legendre in mu on (0, 1), as in
// DISORT's double-Gauss rule, chosen by measurement (docs/quadrature-study.md): it integrates the
// phase-function Fourier components exactly (degree <= 2N - 1), so energy is conserved to rounding at
// albedo 1, and Nystrom evaluation through the equation recovers off-node accuracy. With a smooth
// interface the rule is split at the critical cosine, where total internal reflection switches on
// (docs/physics.md section 4).

#include <span>
#include <vector>

namespace brdf::rte {

struct Streams {
    std::vector<double> mu; ///< nodes in (0, 1), ascending
    std::vector<double> w;  ///< weights, sum 1
    int size() const { return static_cast<int>(mu.size()); }
    /// Highest polynomial degree in mu integrated exactly over (0, 1).
    int exact_degree = 0;
};

/// n-point Gauss-Legendre rule on (0, 1).
Streams gauss_streams(int n);

/// Gauss-Legendre with n_below nodes on (0, split) and n_above on (split, 1); 0 < split < 1.
Streams split_gauss_streams(int n_below, int n_above, double split);

} // namespace brdf::rte
