#pragma once
// One Fourier order of Ambartsumian's nonlinear integral equation for the reflection function of a
// semi-infinite medium (docs/physics.md section 3; Ambartsumian 1943; Mishchenko et al. 1999, eq. 16).
// Discretised on the streams it is the nonsymmetric algebraic Riccati equation (NARE)
//   X C X - X D - A X + B = 0,                       X_ij = R^m(mu_i, mu_j),
//   B = (w/4) M^-1 P- M^-1,  C = w W P- W,  D = M^-1 - (w/2) W P+ M^-1,  A = D^T,
// with M = diag(mu), W = diag(weights), P+- = p^m(+-mu_i, mu_j) and w the single-scattering albedo.
// Two solvers, each the plain C++ reference of an OpenCL kernel (kernels/ambartsumian.cl):
//  - the seed paper's fixed-point iteration (Chen et al.), the baseline: O(1/sqrt(1 - w)) iterations;
//  - structure-preserving doubling (SDA; Guo, Lin and Xu 2006, Numer. Math. 103, 393), quadratically
//    convergent; at the critical case w = 1, m = 0 the zero eigenvalue pair of the Hamiltonian-like
//    matrix is split by a rank-one shift along the conservation null vector (Guo, Iannazzo and Meini
//    2007, SIAM J. Matrix Anal. Appl. 29, 1083), which keeps energy conservation exact.

#include <brdf/core/linalg.h>
#include <brdf/rte/streams.h>

#include <shared/ambartsumian_rules.h>

#include <string_view>

namespace brdf::rte {

/// Doubling steps before solve_doubling gives up (its convergence is quadratic: 9-17 steps).
/// The rules shared with the kernels live in kernels/shared/ambartsumian_rules.h.
inline constexpr int max_doubling_steps = AMB_DOUBLING_STEPS;

/// Fast (the default) runs the fixed point for orders that converge in a few sweeps (high m, or low
/// albedo) and switches to doubling when it does not converge within `fast_sweeps`; an order whose
/// order albedo is above AMB_FAST_DOUBLING_ALBEDO (0.85; m = 0 at that albedo, and the low orders
/// of a forward-peaked phase function) goes straight to doubling.
enum class Method { FixedPoint, Doubling, Fast };
std::string_view to_string(Method method);

struct OrderProblem {
    int m = 0;
    double omega = 0.0;   ///< single-scattering albedo in [0, 1] (delta-M scaled)
    Streams streams;
    Matrix p_plus;        ///< p^m(mu_i, mu_j)
    Matrix p_minus;       ///< p^m(-mu_i, mu_j)
    /// omega max_{l >= m} |beta_l| / (2l + 1): the largest eigenvalue of the order's scattering
    /// operator (the Pbar_l^m are its eigenfunctions over all directions, of eigenvalue
    /// beta_l / (2l + 1)), about the fixed point's rate of contraction
    /// (amb_fast_starts_with_doubling).
    double order_albedo = 0.0;
    /// True at w = 1, m = 0: the equation is critical and conserves energy exactly.
    bool conservative() const;
};

/// Builds the problem for order m from the (scaled) Legendre coefficients.
OrderProblem make_order_problem(std::span<const double> beta, double omega, int m, const Streams& streams);

struct RiccatiMatrices {
    Matrix a, b, c, d;
};
RiccatiMatrices riccati_matrices(const OrderProblem& problem);

struct SolveControl {
    double tolerance = 1e-13;    ///< stop when max |X_k+1 - X_k| <= tolerance * max |X_k+1|
    int max_iterations = 100000; ///< fixed point; doubling stops at max_doubling_steps whatever this says
    double gamma = 0.0;          ///< doubling's Cayley parameter; 0: doubling_gamma(problem)
    int fast_sweeps = 30;        ///< Method::Fast: fixed-point sweeps before switching to doubling
    /// solve_fixed_point stops before max_iterations once its convergence rate says it cannot get
    /// there (amb_fast_gives_up): Method::Fast's first try.
    bool give_up_when_slow = false;
};

struct OrderSolution {
    Matrix x;               ///< R^m(mu_i, mu_j)
    int iterations = 0;
    double residual = 0.0;  ///< relative NARE residual of x
    bool converged = false;
};

/// Doubling's Cayley parameter for a problem: the geometric mean of the ends of the spectrum it
/// must contract, sqrt(lambda_min / mu_min). The steps needed go as log log of the worst ratio
/// |lambda - gamma| / (lambda + gamma); the largest decay rates are about 1 / mu_min (the grazing
/// streams), the smallest about 1 (every order m >= 1, and the conservative m = 0 once shifted) or
/// sqrt(3 (1 - omega)) (m = 0 below albedo 1: the diffusion mode). Measured on HG and truncated
/// phase functions, N = 8-128, albedo 0.5-1, m = 0-39: 35 % fewer steps than gamma = 1 (64 streams:
/// 9-12 instead of 15), residuals unchanged at rounding (docs/physics.md).
double doubling_gamma(const OrderProblem& problem);

OrderSolution solve_fixed_point(const OrderProblem& problem, const SolveControl& control = {});
OrderSolution solve_doubling(const OrderProblem& problem, const SolveControl& control = {});
OrderSolution solve_fast(const OrderProblem& problem, const SolveControl& control = {});
OrderSolution solve_order(const OrderProblem& problem, Method method, const SolveControl& control = {});

/// max |X C X - X D - A X + B| / max(|X C X|, |X D|, |A X|, |B|): 0 for an exact solution.
double riccati_residual(const RiccatiMatrices& r, const Matrix& x);

} // namespace brdf::rte
