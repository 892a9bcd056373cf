#pragma once
// Device code shared by both order-solver kernels (ambartsumian.cl, ambartsumian_serial.cl): the
// element-wise set-up of the fixed point and of the doubling start, from the formulas of
// shared/ambartsumian_rules.h, as solve_fixed_point and solve_doubling of
// src/brdf/rte/order_solver.cpp build them. Host code does not include this file (__global).

#include "shared/ambartsumian_rules.h"

/// Element q = (i, j) of the fixed point's matrices for the problem (mu, w, P+, P-) at albedo om:
/// the sweep's left (om/2) M^-1 P+ W and right (om/2) W P+ M^-1 products and the Riccati B and C;
/// the iterate X starts at 0.
static inline void amb_fixed_point_element(int i, int j, int n, double om, __global const double* mu,
                                           __global const double* w, __global const double* phase_plus,
                                           __global const double* phase_minus, __global double* sweep_left,
                                           __global double* sweep_right, __global double* riccati_b,
                                           __global double* riccati_c, __global double* x) {
    const int q = i * n + j;
    sweep_left[q] = amb_fixed_point_left(om, phase_plus[q], w[j], mu[i]);
    sweep_right[q] = amb_fixed_point_right(om, w[i], phase_plus[q], mu[j]);
    riccati_c[q] = amb_riccati_c(om, w[i], phase_minus[q], w[j]);
    riccati_b[q] = amb_riccati_b(om, phase_minus[q], mu[i], mu[j]);
    x[q] = 0.0;
}

/// Element (i, j) of B, C, A_g = A + g I and D_g = D + g I (Guo, Lin and Xu 2006, Numer. Math. 103,
/// 393, eqs. 2.6-2.8: the matrices of the Cayley-transformed start) for order problem
/// (mu, w, P+, P-) at albedo om. With `conservative` (m = 0, om = 1) the rank-one shift along the
/// conservation null vector is added to D and B (not to A, which is the unshifted D^T).
static inline void amb_doubling_element(int i, int j, int n, double om, double g, int conservative, double ev1,
                                        __global const double* mu, __global const double* w,
                                        __global const double* phase_plus, __global const double* phase_minus,
                                        __global double* riccati_b, __global double* riccati_c,
                                        __global double* a_gamma, __global double* d_gamma) {
    const int q = i * n + j;
    double bij = amb_riccati_b(om, phase_minus[q], mu[i], mu[j]);
    double dij = amb_riccati_d(i == j, om, mu[i], mu[j], w[i], phase_plus[q]);
    const double aij = amb_riccati_d(j == i, om, mu[j], mu[i], w[j], phase_plus[j * n + i]);
    if (conservative) {
        dij += amb_shift_d(w[i], mu[i], ev1);
        bij += amb_shift_b(ev1);
    }
    riccati_b[q] = bij;
    riccati_c[q] = amb_riccati_c(om, w[i], phase_minus[q], w[j]);
    a_gamma[q] = aij + (i == j ? g * 1.0 : g * 0.0);
    d_gamma[q] = dij + (i == j ? g * 1.0 : g * 0.0);
}

/// e . v1 of the conservative shift (0 when not conservative), summed in increasing i as the
/// reference does.
static inline double amb_shift_norm(int conservative, int n, __global const double* mu, __global const double* w) {
    double ev1 = 0.0;
    if (conservative)
        for (int i = 0; i < n; ++i) ev1 += amb_shift_vector(w[i], mu[i]);
    return ev1;
}
