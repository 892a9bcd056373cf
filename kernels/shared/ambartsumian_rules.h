#pragma once
// The rules and constants of the per-order solvers of Ambartsumian's equation, once for the C++
// reference (src/brdf/rte/order_solver.cpp) and both kernels (kernels/ambartsumian.cl,
// kernels/ambartsumian_serial.cl). Plain C that OpenCL C 1.2 and C++ both compile: scalars in,
// scalars out, each expression in the reference's arithmetic order, so that with FP_CONTRACT off
// the kernels reproduce the reference to the ulp. Host code includes this as
// <shared/ambartsumian_rules.h>, kernels as "shared/ambartsumian_rules.h".
//
// The equation (docs/physics.md section 3; src/brdf/rte/order_solver.h) is the nonsymmetric
// algebraic Riccati equation X C X - X D - A X + B = 0 with, for streams mu_i, weights w_i, albedo
// om and the phase components P+_ij = p^m(mu_i, mu_j), P-_ij = p^m(-mu_i, mu_j):
//   B = (om/4) M^-1 P- M^-1,  C = om W P- W,  D = M^-1 - (om/2) W P+ M^-1,  A = D^T.

/// Structure-preserving doubling stops after this many steps whatever the tolerance: it converges
/// quadratically (9-17 steps at 1e-13), so 100 steps without convergence means it never will.
#define AMB_DOUBLING_STEPS 100

/// Method::Fast: an order whose albedo (OrderProblem::order_albedo, om max_{l >= m} |beta_l| / (2l
/// + 1), the largest eigenvalue of its scattering operator) is above this goes straight to
/// doubling. The fixed point contracts at about that rate, so such an order needs more sweeps than
/// the capped first try allows at any iteration tolerance the service uses (<= 1e-8): O(1/sqrt(1 -
/// om)) at m = 0 (docs/physics.md section 3); measured on HG g 0.3-0.99, albedo 0.9-1, 16-64
/// streams, every order above 0.80 needed more than 30 sweeps (the highest that finished: 0.78).
#define AMB_FAST_DOUBLING_ALBEDO 0.85

/// The eigenvalue eta the conservative rank-one shift moves the critical zero eigenvalue to (Guo,
/// Iannazzo and Meini 2007, SIAM J. Matrix Anal. Appl. 29, 1083; any eta > 0 keeps X).
#define AMB_CONSERVATIVE_SHIFT 1.0

/// Method::Fast goes straight to doubling for an order of this order albedo (else: fixed point
/// first). The host decides it per task (AmbTask::doubling_first), the C++ reference per problem.
static inline int amb_fast_starts_with_doubling(double order_albedo) {
    return order_albedo > AMB_FAST_DOUBLING_ALBEDO;
}

/// Method::Fast: the fixed point's first try gives up before its cap from this sweep on when its
/// own convergence says it cannot reach the tolerance by the cap (amb_fast_gives_up).
#define AMB_FAST_RATE_SWEEP 4

/// Method::Fast's fixed point after sweep `sweep` of at most `cap`, whose changes were `change`,
/// `previous` and `before` (sweeps sweep, sweep - 1, sweep - 2), with the convergence threshold
/// `target`: 1 to give up now. The change falls geometrically, by q per sweep; even at the faster
/// of the last two ratios it stays above `target` through the cap, so the remaining sweeps would be
/// spent for nothing before doubling (m = 1..15 of a silica matting agent: 30 sweeps, a third of
/// their solve). q^k by repeated products, not a logarithm: the kernels decide exactly as the
/// reference does. Not contracting yet (q >= 1): no decision.
static inline int amb_fast_gives_up(int sweep, int cap, double change, double previous, double before, double target) {
    if (sweep < AMB_FAST_RATE_SWEEP || !(previous > 0.0) || !(before > 0.0)) return 0;
    const double q1 = change / previous, q2 = previous / before;
    const double q = q1 < q2 ? q1 : q2;
    if (!(q < 1.0)) return 0;
    double projected = change;
    for (int k = sweep; k < cap; ++k) projected *= q;
    return projected > target;
}

/// Order m at albedo om is the critical (conservative) case: m = 0, om = 1, where doubling needs
/// the rank-one shift.
static inline int amb_conservative(int m, double om) { return m == 0 && om >= 1.0; }

/// B_ij = (om/4) P-_ij / (mu_i mu_j): the single-scattering term.
static inline double amb_riccati_b(double om, double p_minus_ij, double mu_i, double mu_j) {
    return 0.25 * om * p_minus_ij / (mu_i * mu_j);
}

/// C_ij = om w_i P-_ij w_j.
static inline double amb_riccati_c(double om, double w_i, double p_minus_ij, double w_j) {
    return om * w_i * p_minus_ij * w_j;
}

/// D_ij = delta_ij / mu_i - (om/2) w_i P+_ij / mu_j. A_ij = D_ji is amb_riccati_d with (i, j)
/// swapped: amb_riccati_d(j == i, om, mu_j, mu_i, w_j, P+_ji).
static inline double amb_riccati_d(int diagonal, double om, double mu_i, double mu_j, double w_i, double p_plus_ij) {
    return (diagonal ? 1.0 / mu_i : 0.0) - 0.5 * om * w_i * p_plus_ij / mu_j;
}

/// The fixed point's (om/2) M^-1 P+ W, element (i, j): the left product of the sweep.
static inline double amb_fixed_point_left(double om, double p_plus_ij, double w_j, double mu_i) {
    return 0.5 * om * p_plus_ij * w_j / mu_i;
}

/// The fixed point's (om/2) W P+ M^-1, element (i, j): the right product of the sweep.
static inline double amb_fixed_point_right(double om, double w_i, double p_plus_ij, double mu_j) {
    return 0.5 * om * w_i * p_plus_ij / mu_j;
}

/// The fixed point divides element (i, j) of each sweep by 1/mu_i + 1/mu_j (the diagonal part of
/// X D + A X moved to the left).
static inline double amb_fixed_point_divisor(double mu_i, double mu_j) { return 1.0 / mu_i + 1.0 / mu_j; }

/// Element i of the conservation null vector's first half, v1 = 2 W mu (sum_j w_j (P+ + P-)_ij = 2
/// at om = 1, m = 0); the shift is normalised by e . v1 = sum_i of these, summed in increasing i.
static inline double amb_shift_vector(double w_i, double mu_i) { return 2.0 * w_i * mu_i; }

/// What the shift adds to D_ij (every j): eta v1_i / (e . v1).
static inline double amb_shift_d(double w_i, double mu_i, double ev1) {
    return AMB_CONSERVATIVE_SHIFT * amb_shift_vector(w_i, mu_i) / ev1;
}

/// What the shift adds to B_ij (every i, j): eta / (e . v1).
static inline double amb_shift_b(double ev1) { return AMB_CONSERVATIVE_SHIFT / ev1; }
