// Batched per-Fourier-order solvers of Ambartsumian's equation for CPU-type devices: each work-item
// solves order problems serially, one after another (local size 1, no barriers, no local memory).
// A direct port of the C++ references solve_fixed_point, solve_doubling and solve_fast
// (src/brdf/rte/order_solver.cpp) and LuFactor (src/brdf/core/linalg.cpp), operation for operation:
// every product element summed in k order skipping zero a_ik (rows in pairs and columns in blocks
// of 16 and 32, in registers), LU with the same pivot search and the same skipped zero multipliers,
// the same elementwise passes. The products' terms are fused multiply-adds (fma: one rounding, on
// every device, as the host's BLAS does), everything else with FP_CONTRACT OFF as the reference
// writes it: results agree with the reference to rounding, with the same iteration counts
// (tests/rte/cl_solver_test.cpp: 1e-11 asserted).
// The step limit, the method switch, its early give-up and the element formulas come from
// shared/ambartsumian_rules.h, as the reference's do.
//
// The same task, input, output, workspace and status layouts as kernels/ambartsumian.cl
// (shared/ambartsumian_layout.h), so the host code (src/brdf/rte/cl_solver.cpp) is shared, but for
// the workspace: one slot per work-item, not per task (ambartsumian_solve_serial below). On a CPU
// device the work-groups (about one per core) spread over the cores and each inner j loop vectorises;
// the cooperative kernel's hundreds of barrier passes per problem cost far more than they gain there.

#pragma OPENCL FP_CONTRACT OFF

#include "shared/ambartsumian_layout.h"
#include "shared/ambartsumian_rules.h"
#include "shared/ambartsumian_setup.h"

typedef __global double* gptr;
typedef __global const double* gcptr;

// c (ld ldc) = a (ld lda) b (ld ldb), all n x n: brdf::operator* (i-k-j, zero a_ik skipped).
// Two rows of c and 32 of their columns stay in registers through the k loop: four independent
// sums, where one row's 16 columns waited on the latency of each add (a CPU device ran the loop at
// one add per latency); each b load serves both rows. Each element is 0 + a_i0 b_0j + a_i1 b_1j +
// ... in k order with the zero a_ik skipped, each term fused into the sum (fma): a multiply and an
// add were twice the instructions of the loop, where the solves of a gloss finish (48 streams)
// spend most of their time: its `compute` 0.826 -> 0.792 s (medians of 7 alternating runs).
// MAT_MUL_WIDE 0 (the host's build option where the device's native double vectors are narrower
// than eight) leaves the 32-column blocks out: their four double16 sums are 16 of AVX2's 16
// registers, and spilled they cost a gloss finish's solves more than the blocks save. Each element
// is the same sum either way.
#ifndef MAT_MUL_WIDE
#define MAT_MUL_WIDE 1
#endif
static void mat_mul(gptr restrict c, int ldc, gcptr restrict a, int lda, gcptr restrict b, int ldb, int n) {
    const int blocked = n - n % 16;
    for (int i = 0; i < n; i += 2) {
        const int pair = i + 1 < n;
        gcptr restrict a0 = a + i * lda;
        gcptr restrict a1 = a + (pair ? i + 1 : i) * lda; // an odd last row is computed twice, kept once
        gptr restrict c0 = c + i * ldc;
        gptr restrict c1 = c + (i + 1) * ldc;
        int j0 = 0;
        for (; MAT_MUL_WIDE && j0 + 32 <= blocked; j0 += 32) {
            double16 s00 = (double16)(0.0), s01 = (double16)(0.0), s10 = (double16)(0.0), s11 = (double16)(0.0);
            for (int k = 0; k < n; ++k) {
                const double x0 = a0[k], x1 = a1[k];
                const double16 b0 = vload16(0, b + k * ldb + j0), b1 = vload16(0, b + k * ldb + j0 + 16);
                if (x0 != 0.0) {
                    s00 = fma((double16)(x0), b0, s00);
                    s01 = fma((double16)(x0), b1, s01);
                }
                if (x1 != 0.0) {
                    s10 = fma((double16)(x1), b0, s10);
                    s11 = fma((double16)(x1), b1, s11);
                }
            }
            vstore16(s00, 0, c0 + j0);
            vstore16(s01, 0, c0 + j0 + 16);
            if (pair) {
                vstore16(s10, 0, c1 + j0);
                vstore16(s11, 0, c1 + j0 + 16);
            }
        }
        for (; j0 < blocked; j0 += 16) {
            double16 s0 = (double16)(0.0), s1 = (double16)(0.0);
            for (int k = 0; k < n; ++k) {
                const double x0 = a0[k], x1 = a1[k];
                const double16 bk = vload16(0, b + k * ldb + j0);
                if (x0 != 0.0) s0 = fma((double16)(x0), bk, s0);
                if (x1 != 0.0) s1 = fma((double16)(x1), bk, s1);
            }
            vstore16(s0, 0, c0 + j0);
            if (pair) vstore16(s1, 0, c1 + j0);
        }
        if (blocked == n) continue;
        for (int r = 0; r <= pair; ++r) {
            gptr restrict ci = c + (i + r) * ldc;
            gcptr restrict ai = a + (i + r) * lda;
            for (int j = blocked; j < n; ++j) ci[j] = 0.0;
            for (int k = 0; k < n; ++k) {
                const double aik = ai[k];
                if (aik == 0.0) continue;
                gcptr restrict bk = b + k * ldb;
                for (int j = blocked; j < n; ++j) ci[j] = fma(aik, bk[j], ci[j]);
            }
        }
    }
}

// a (n x n) += b (ld ldb)
static void mat_add(gptr a, gcptr b, int ldb, int n) {
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) a[i * n + j] += b[i * ldb + j];
}

static void mat_identity(gptr a, int n) {
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) a[i * n + j] = i == j ? 1.0 : 0.0;
}

// a = I - a (n x n), element by element as the reference: 1 - a_ii, 0 - a_ij.
static void identity_minus(gptr a, int n) {
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) a[i * n + j] = (i == j ? 1.0 : 0.0) - a[i * n + j];
}

// out (ld ldo) = a (n x n)
static void mat_copy(gptr out, int ldo, gcptr a, int n) {
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) out[i * ldo + j] = a[i * n + j];
}

// The reductions below run sixteen lanes at a time (a scalar fmax chain cost a tenth of a solve):
// the largest of a set is the same in any order, and fmax skips a NaN whatever its place.
static double lane_max(double16 m) {
    const double8 h = fmax(m.lo, m.hi);
    const double4 q = fmax(h.lo, h.hi);
    const double2 p = fmax(q.lo, q.hi);
    return fmax(p.lo, p.hi);
}

// max |a_q| (0 for none)
static double max_abs_of(gcptr a, int n2) {
    double16 m = (double16)(0.0);
    int q = 0;
    for (; q + 16 <= n2; q += 16) m = fmax(m, fabs(vload16(0, a + q)));
    double r = lane_max(m);
    for (; q < n2; ++q) r = fmax(r, fabs(a[q]));
    return r;
}

// max |a_q - b_q|: the change of an iteration
static double max_abs_diff_of(gcptr a, gcptr b, int n2) {
    double16 m = (double16)(0.0);
    int q = 0;
    for (; q + 16 <= n2; q += 16) m = fmax(m, fabs(vload16(0, a + q) - vload16(0, b + q)));
    double r = lane_max(m);
    for (; q < n2; ++q) r = fmax(r, fabs(a[q] - b[q]));
    return r;
}

// 0 x a_q is 0 for every finite a_q and NaN for an infinity or a NaN: one sum says whether all are finite.
static int all_finite(gcptr a, int n2) {
    double16 s = (double16)(0.0);
    int q = 0;
    for (; q + 16 <= n2; q += 16) s += 0.0 * vload16(0, a + q);
    double r = 0.0;
    for (; q < n2; ++q) r += 0.0 * a[q];
    return isfinite(r) && all(isfinite(s));
}

// LuFactor(lu): in place, pivots to piv. Returns -1, or the column of a zero / non-finite pivot.
static int lu_factor(gptr lu, int n, int* piv) {
    for (int k = 0; k < n; ++k) {
        int p = k;
        for (int i = k + 1; i < n; ++i)
            if (fabs(lu[i * n + k]) > fabs(lu[p * n + k])) p = i;
        const double pivot = lu[p * n + k];
        if (pivot == 0.0 || !isfinite(pivot)) return k;
        piv[k] = p;
        if (p != k)
            for (int j = 0; j < n; ++j) {
                const double tmp = lu[k * n + j];
                lu[k * n + j] = lu[p * n + j];
                lu[p * n + j] = tmp;
            }
        gcptr rk = lu + k * n;
        for (int i = k + 1; i < n; ++i) {
            gptr ri = lu + i * n;
            const double f = (ri[k] /= pivot);
            if (f == 0.0) continue;
            for (int j = k + 1; j < n; ++j) ri[j] -= f * rk[j];
        }
    }
    return -1;
}

// LuFactor::solve: (LU) X = B in place, B n x cols with leading dimension ldb. Sixteen columns of
// row i stay in registers through each elimination loop (instead of a load and a store per
// multiply-add); every element is still updated in the reference's k order, zero factors skipped.
static void lu_solve(gcptr lu, int n, const int* piv, gptr b, int ldb, int cols) {
    for (int k = 0; k < n; ++k) {
        const int p = piv[k];
        if (p != k)
            for (int j = 0; j < cols; ++j) {
                const double tmp = b[k * ldb + j];
                b[k * ldb + j] = b[p * ldb + j];
                b[p * ldb + j] = tmp;
            }
    }
    const int blocked = cols - cols % 16;
    for (int i = 0; i < n; ++i) { // forward: L has a unit diagonal
        gptr bi = b + i * ldb;
        for (int j0 = 0; j0 < blocked; j0 += 16) {
            double16 v = vload16(0, bi + j0);
            for (int k = 0; k < i; ++k) {
                const double l = lu[i * n + k];
                if (l != 0.0) v -= l * vload16(0, b + k * ldb + j0);
            }
            vstore16(v, 0, bi + j0);
        }
        for (int k = 0; k < i; ++k) {
            const double l = lu[i * n + k];
            if (l == 0.0) continue;
            gcptr bk = b + k * ldb;
            for (int j = blocked; j < cols; ++j) bi[j] -= l * bk[j];
        }
    }
    for (int i = n - 1; i >= 0; --i) { // backward
        gptr bi = b + i * ldb;
        const double d = lu[i * n + i];
        for (int j0 = 0; j0 < blocked; j0 += 16) {
            double16 v = vload16(0, bi + j0);
            for (int k = i + 1; k < n; ++k) {
                const double u = lu[i * n + k];
                if (u != 0.0) v -= u * vload16(0, b + k * ldb + j0);
            }
            vstore16(v / d, 0, bi + j0);
        }
        for (int k = i + 1; k < n; ++k) {
            const double u = lu[i * n + k];
            if (u == 0.0) continue;
            gcptr bk = b + k * ldb;
            for (int j = blocked; j < cols; ++j) bi[j] -= u * bk[j];
        }
        for (int j = blocked; j < cols; ++j) bi[j] /= d;
    }
}

// Half of an SDA step: Z = [E, G R] (n x 2n) solved with I - G H in place, R = F (or E^T in the
// symmetric form); the other half swaps the roles, [F, H E] with I - H G. -1, or the column of a
// zero pivot.
static int sda_solve(gptr z, gptr lu, int* piv, gcptr e, gcptr g, gcptr h, gcptr r, int n) {
    mat_copy(z, 2 * n, e, n);
    mat_mul(z + n, 2 * n, g, n, r, n, n);
    mat_mul(lu, n, g, n, h, n, n);
    identity_minus(lu, n);
    const int bad = lu_factor(lu, n, piv);
    if (bad < 0) lu_solve(lu, n, piv, z, 2 * n, 2 * n);
    return bad;
}

// E_k+1 = E Z_1 and G_k+1 = G + E Z_2 from the solved Z (or F_k+1, H_k+1 from F, H and Y).
static void sda_update(gptr e_next, gptr g_next, gcptr e, gcptr g, gcptr z, int n) {
    mat_mul(e_next, n, e, n, z, 2 * n, n);
    mat_mul(g_next, n, e, n, z + n, 2 * n, n);
    for (int q = 0; q < n * n; ++q) g_next[q] = g[q] + g_next[q];
}

/// tasks[id] solved by its method in the workspace `ws`; X to output, the outcome to status.
static void solve_task(__global const AmbTask* tasks, __global const double* input, __global double* output,
                       gptr ws, __global AmbStatus* status, int id) {
    const AmbTask task = tasks[id];
    const int n = task.n;
    const int n2 = n * n;
    const double om = task.omega;
    gcptr mu = input + task.input_offset;
    gcptr w = mu + n;
    gcptr phase_plus = w + n;
    gcptr phase_minus = phase_plus + n2;
    gptr x_out = output + task.output_offset;
    const double g = task.gamma;
    int piv[AMB_MAX_N];

    int iterations = 0, converged = 0, error = AMB_OK, detail = 0;
    int sweeps = 0;
    int run_doubling = 1;
    gcptr result = ws;

    // ---- fixed point (solve_fixed_point; solve_fast's capped first attempt) ----
    int cap = -1;
    if (task.method == AMB_FIXED_POINT) cap = task.max_iterations;
    else if (task.method == AMB_FAST && !task.doubling_first) cap = task.fast_sweeps;
    if (cap >= 0) {
        gptr x = ws;
        gptr nx = ws + n2;
        gptr xt = ws + 2 * n2;
        gptr sweep_left = ws + 3 * n2;
        gptr sweep_right = ws + 4 * n2;
        gptr riccati_b = ws + 5 * n2;
        gptr riccati_c = ws + 6 * n2;
        gptr t = ws + 7 * n2;
        gptr divisor = ws + 9 * n2; // once per problem, not two divisions per element per sweep
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                amb_fixed_point_element(i, j, n, om, mu, w, phase_plus, phase_minus, sweep_left, sweep_right,
                                        riccati_b, riccati_c, x);
                divisor[i * n + j] = amb_fixed_point_divisor(mu[i], mu[j]);
            }
        int it;
        double previous = 0.0, before = 0.0; // the changes of the last two sweeps
        for (it = 1; it <= cap; ++it) {
            // next = (B + left X) + X (right + C X): three products a sweep, as solve_fixed_point
            // (the first from X = 0: B alone, as solve_fixed_point)
            if (it == 1) {
                for (int q = 0; q < n2; ++q) nx[q] = riccati_b[q];
            } else {
                mat_mul(nx, n, sweep_left, n, x, n, n);
                for (int q = 0; q < n2; ++q) nx[q] = riccati_b[q] + nx[q];
                mat_mul(t, n, riccati_c, n, x, n, n);
                mat_add(t, sweep_right, n, n);
                mat_mul(xt, n, x, n, t, n, n);
                mat_add(nx, xt, n, n);
            }
            for (int q = 0; q < n2; ++q) nx[q] /= divisor[q];
            const double change = max_abs_diff_of(nx, x, n2);
            gptr sw = x;
            x = nx, nx = sw;
            if (!all_finite(x, n2)) {
                error = AMB_FIXED_POINT_DIVERGED;
                break;
            }
            const double target = task.tolerance * max_abs_of(x, n2);
            if (change <= target) {
                converged = 1;
                break;
            }
            if (task.method == AMB_FAST && amb_fast_gives_up(it, cap, change, previous, before, target)) break;
            before = previous, previous = change;
        }
        iterations = min(it, cap);
        result = x;
        if (error != AMB_OK || converged || task.method != AMB_FAST) run_doubling = 0;
        else sweeps = iterations; // solve_fast: switch to doubling
    }

    // ---- doubling (solve_doubling): the SDA iterates E_k, F_k, G_k, H_k and the next ones (Guo,
    // Lin and Xu 2006) ----
    if (run_doubling) {
        gptr e_k = ws;
        gptr f_k = ws + n2;
        gptr g_k = ws + 2 * n2;
        gptr h_k = ws + 3 * n2;
        gptr e_next = ws + 4 * n2;
        gptr f_next = ws + 5 * n2;
        gptr g_next = ws + 6 * n2;
        gptr h_next = ws + 7 * n2;
        gptr z = ws + 8 * n2;  // n x 2n
        gptr y = ws + 10 * n2; // n x 2n
        gptr lu = ws + 12 * n2;
        gptr t = ws + 13 * n2;
        gptr t2 = ws + 14 * n2;
        // The set-up's matrices (slots 4..11) until the first step overwrites them.
        gptr a_gamma = ws + 4 * n2; // A + g I
        gptr riccati_b = ws + 5 * n2;
        gptr riccati_c = ws + 6 * n2;
        gptr d_gamma = ws + 7 * n2; // D + g I
        gptr dinv = ws + 8 * n2;
        gptr ainv = ws + 9 * n2;
        gptr winv = ws + 10 * n2;
        gptr vinv = ws + 11 * n2;
        const int conservative = amb_conservative(task.m, om);
        const double ev1 = amb_shift_norm(conservative, n, mu, w);
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j)
                amb_doubling_element(i, j, n, om, g, conservative, ev1, mu, w, phase_plus, phase_minus, riccati_b,
                                     riccati_c, a_gamma, d_gamma);
        // dinv = D_g^-1, then winv = (A_g - (B D_g^-1) C)^-1; unshifted (symmetric), E0 = I - 2g W^-T and no
        // F; shifted, ainv = A_g^-1, vinv = (D_g - (C A_g^-1) B)^-1, E0 = I - 2g V^-1 and F0 = I - 2g W^-1.
        const int symmetric = !conservative;
        mat_copy(lu, n, d_gamma, n);
        int bad = lu_factor(lu, n, piv);
        if (bad < 0) {
            mat_identity(dinv, n);
            lu_solve(lu, n, piv, dinv, n, n);
            mat_mul(t, n, riccati_b, n, dinv, n, n);
            mat_mul(t2, n, t, n, riccati_c, n, n);
            for (int q = 0; q < n2; ++q) lu[q] = a_gamma[q] - t2[q];
            bad = lu_factor(lu, n, piv);
        }
        if (bad < 0) {
            mat_identity(winv, n);
            lu_solve(lu, n, piv, winv, n, n);
            if (!symmetric) {
                mat_copy(lu, n, a_gamma, n);
                bad = lu_factor(lu, n, piv);
            }
        }
        if (bad < 0 && !symmetric) {
            mat_identity(ainv, n);
            lu_solve(lu, n, piv, ainv, n, n);
            mat_mul(t, n, riccati_c, n, ainv, n, n);
            mat_mul(t2, n, t, n, riccati_b, n, n);
            for (int q = 0; q < n2; ++q) lu[q] = d_gamma[q] - t2[q];
            bad = lu_factor(lu, n, piv);
            if (bad < 0) {
                mat_identity(vinv, n);
                lu_solve(lu, n, piv, vinv, n, n);
            }
        }
        if (bad >= 0) {
            error = AMB_SINGULAR;
            detail = bad;
        } else {
            const double g2 = 2.0 * g;
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    const int q = i * n + j;
                    const double eye = i == j ? 1.0 : 0.0;
                    if (symmetric) {
                        e_k[q] = eye - g2 * winv[j * n + i];
                    } else {
                        e_k[q] = eye - g2 * vinv[q];
                        f_k[q] = eye - g2 * winv[q];
                    }
                }
            mat_mul(t, n, dinv, n, riccati_c, n, n); // G0 = 2g ((D_g^-1 C) W^-1)
            mat_mul(g_k, n, t, n, winv, n, n);
            for (int q = 0; q < n2; ++q) g_k[q] = g2 * g_k[q];
            mat_mul(t, n, winv, n, riccati_b, n, n); // H0 = 2g ((W^-1 B) D_g^-1)
            mat_mul(h_k, n, t, n, dinv, n, n);
            for (int q = 0; q < n2; ++q) h_k[q] = g2 * h_k[q];

            int it;
            for (it = 1; it <= AMB_DOUBLING_STEPS; ++it) {
                if (symmetric) {
                    // Z = [E, G E^T] solved with I - G H; H_k+1 = H + (E^T H) Z_1 (solve_doubling).
                    gptr et = t, eth = t2;
                    for (int i = 0; i < n; ++i)
                        for (int j = 0; j < n; ++j) et[i * n + j] = e_k[j * n + i];
                    bad = sda_solve(z, lu, piv, e_k, g_k, h_k, et, n);
                    if (bad >= 0) break;
                    sda_update(e_next, g_next, e_k, g_k, z, n);
                    mat_mul(eth, n, et, n, h_k, n, n);
                    mat_mul(h_next, n, eth, n, z, 2 * n, n);
                    for (int q = 0; q < n2; ++q) h_next[q] = h_k[q] + h_next[q];
                } else {
                    // Z = [E, G F], solved with I - G H; Y = [F, H E], solved with I - H G.
                    bad = sda_solve(z, lu, piv, e_k, g_k, h_k, f_k, n);
                    if (bad >= 0) break;
                    bad = sda_solve(y, lu, piv, f_k, h_k, g_k, e_k, n);
                    if (bad >= 0) break;
                    sda_update(e_next, g_next, e_k, g_k, z, n);
                    sda_update(f_next, h_next, f_k, h_k, y, n);
                }
                const double change = max_abs_diff_of(h_next, h_k, n2);
                gptr sw;
                sw = e_k, e_k = e_next, e_next = sw;
                sw = f_k, f_k = f_next, f_next = sw;
                sw = g_k, g_k = g_next, g_next = sw;
                sw = h_k, h_k = h_next, h_next = sw;
                if (!all_finite(h_k, n2)) {
                    error = AMB_DOUBLING_DIVERGED;
                    break;
                }
                if (change <= task.tolerance * max_abs_of(h_k, n2)) {
                    converged = 1;
                    break;
                }
            }
            if (bad >= 0) {
                error = AMB_SINGULAR;
                detail = bad;
            }
            iterations = min(it, AMB_DOUBLING_STEPS) + sweeps;
            result = h_k;
        }
    }

    if (error == AMB_OK)
        for (int q = 0; q < n2; ++q) x_out[q] = result[q];
    status[id].iterations = iterations;
    status[id].converged = converged;
    status[id].error = error;
    status[id].detail = detail;
}

/// A few work-items (local size 1, about one per core), each taking the next unsolved task from the
/// counter `next` until all `count` are done, in its own workspace slot of `slot_doubles` (the
/// largest task's AMB_WORKSPACE_MATRICES n x n). A slot is reused task after task, so it stays in
/// the core's cache and its pages are touched once, where one slot per task (what the cooperative
/// kernel's layout gives, tasks[].workspace_offset) faulted in hundreds of MB per batch; the atomic
/// counter balances tasks of unequal cost (order 0 against the high orders). Each task is solved
/// as before, whatever slot or order it is taken in: the results do not change.
__kernel void ambartsumian_solve_serial(__global const AmbTask* tasks, __global const double* input,
                                        __global double* output, __global double* workspace,
                                        __global AmbStatus* status, __global int* next, int count,
                                        long slot_doubles) {
    gptr ws = workspace + (long)get_global_id(0) * slot_doubles;
    for (int id = atomic_inc(next); id < count; id = atomic_inc(next)) solve_task(tasks, input, output, ws, status, id);
}
