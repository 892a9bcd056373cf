#pragma once
// Device code shared by both order-solver kernels (ambartsumian.cl, ambartsumian_serial.cl): the
// element-wise set-up of the doubling start, as riccati_matrices and the conservative shift of
// src/brdf/rte/order_solver.cpp build it. Host code does not include this file.

/// Element (i, j) of B, C, A + g I and D + g I for order problem (mu, w, P+, P-) at albedo om. With
/// `conservative` (m = 0, om = 1) the rank-one shift along the conservation null vector (eta = 1,
/// ev1 = sum_k 2 w_k mu_k) is added to D and B.
static inline void amb_doubling_element(int i, int j, int n, double om, double g, int conservative, double ev1,
                                        __global const double* mu, __global const double* w,
                                        __global const double* pp, __global const double* pm, __global double* bb,
                                        __global double* cc, __global double* ag, __global double* dg) {
    const int q = i * n + j;
    double bij = 0.25 * om * pm[q] / (mu[i] * mu[j]);
    double dij = (i == j ? 1.0 / mu[i] : 0.0) - 0.5 * om * w[i] * pp[q] / mu[j];
    const double aij = (i == j ? 1.0 / mu[j] : 0.0) - 0.5 * om * w[j] * pp[j * n + i] / mu[i];
    if (conservative) {
        dij += 1.0 * (2.0 * w[i] * mu[i]) / ev1;
        bij += 1.0 / ev1;
    }
    bb[q] = bij;
    cc[q] = om * w[i] * pm[q] * w[j];
    ag[q] = aij + (i == j ? g * 1.0 : g * 0.0);
    dg[q] = dij + (i == j ? g * 1.0 : g * 0.0);
}
