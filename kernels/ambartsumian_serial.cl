// Batched per-Fourier-order solvers of Ambartsumian's equation for CPU-type devices: ONE work-item
// solves ONE order problem serially (local size 1, no barriers, no local memory). A direct port of
// the C++ references solve_fixed_point, solve_doubling and solve_fast (src/brdf/rte/order_solver.cpp)
// and LuFactor (src/brdf/core/linalg.cpp), loop for loop: products in i-k-j order skipping zero
// a_ik, LU with the same pivot search and the same skipped zero multipliers, the same elementwise
// passes. With FP_CONTRACT OFF every operation is the reference's, so results agree bit for bit
// with a host build that does not contract either (and iteration counts exactly).
//
// The same task, input, output, workspace and status layouts as kernels/ambartsumian.cl
// (shared/ambartsumian_layout.h), so the host code (src/brdf/rte/cl_solver.cpp) is shared. On a CPU
// device the work-groups (one per problem) spread over the cores and each inner j loop vectorises;
// the cooperative kernel's hundreds of barrier passes per problem cost far more than they gain there.

#pragma OPENCL FP_CONTRACT OFF

#include "shared/ambartsumian_layout.h"
#include "shared/ambartsumian_setup.h"

#define DOUBLING_STEPS 100

typedef __global double* gptr;
typedef __global const double* gcptr;

// c (ld ldc) = a (ld lda) b (ld ldb), all n x n: brdf::operator* (i-k-j, zero a_ik skipped).
static void mat_mul(gptr restrict c, int ldc, gcptr restrict a, int lda, gcptr restrict b, int ldb, int n) {
    for (int i = 0; i < n; ++i) {
        gptr restrict ci = c + i * ldc;
        for (int j = 0; j < n; ++j) ci[j] = 0.0;
        for (int k = 0; k < n; ++k) {
            const double aik = a[i * lda + k];
            if (aik == 0.0) continue;
            gcptr restrict bk = b + k * ldb;
            for (int j = 0; j < n; ++j) ci[j] += aik * bk[j];
        }
    }
}

// a (n x n) += b (ld ldb)
static void mat_add(gptr a, gcptr b, int ldb, int n) {
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) a[i * n + j] += b[i * ldb + j];
}

static void mat_identity(gptr a, int n) {
    for (int q = 0; q < n * n; ++q) a[q] = (q / n == q % n) ? 1.0 : 0.0;
}

// out (ld ldo) = a (n x n)
static void mat_copy(gptr out, int ldo, gcptr a, int n) {
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) out[i * ldo + j] = a[i * n + j];
}

static double max_abs_of(gcptr a, int n2) {
    double m = 0.0;
    for (int q = 0; q < n2; ++q) m = fmax(m, fabs(a[q]));
    return m;
}

static int all_finite(gcptr a, int n2) {
    for (int q = 0; q < n2; ++q)
        if (!isfinite(a[q])) return 0;
    return 1;
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

// LuFactor::solve: (LU) X = B in place, B n x cols with leading dimension ldb.
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
    for (int i = 0; i < n; ++i) { // forward: L has a unit diagonal
        gptr bi = b + i * ldb;
        for (int k = 0; k < i; ++k) {
            const double l = lu[i * n + k];
            if (l == 0.0) continue;
            gcptr bk = b + k * ldb;
            for (int j = 0; j < cols; ++j) bi[j] -= l * bk[j];
        }
    }
    for (int i = n - 1; i >= 0; --i) { // backward
        gptr bi = b + i * ldb;
        for (int k = i + 1; k < n; ++k) {
            const double u = lu[i * n + k];
            if (u == 0.0) continue;
            gcptr bk = b + k * ldb;
            for (int j = 0; j < cols; ++j) bi[j] -= u * bk[j];
        }
        const double d = lu[i * n + i];
        for (int j = 0; j < cols; ++j) bi[j] /= d;
    }
}

/// One work-item per task (local size 1): tasks[get_global_id(0)] solved by its method; X to output,
/// the outcome to status.
__kernel void ambartsumian_solve_serial(__global const AmbTask* tasks, __global const double* input,
                                        __global double* output, __global double* workspace,
                                        __global AmbStatus* status) {
    const int id = (int)get_global_id(0);
    const AmbTask task = tasks[id];
    const int n = task.n;
    const int n2 = n * n;
    const double om = task.omega;
    gcptr mu = input + task.input_offset;
    gcptr w = mu + n;
    gcptr pp = w + n;
    gcptr pm = pp + n2;
    gptr x_out = output + task.output_offset;
    gptr ws = workspace + task.workspace_offset;
    const double g = task.gamma;
    int piv[AMB_MAX_N];

    double change = 0.0, scale = 0.0;
    int iterations = 0, converged = 0, error = AMB_OK, detail = 0;
    int sweeps = 0;
    int run_doubling = 1;
    gcptr result = ws;

    // ---- fixed point (solve_fixed_point; solve_fast's capped first attempt) ----
    int cap = -1;
    if (task.method == AMB_FIXED_POINT) cap = task.max_iterations;
    else if (task.method == AMB_FAST && !(task.m == 0 && om > 0.9)) cap = task.fast_sweeps;
    if (cap >= 0) {
        gptr x = ws;
        gptr nx = ws + n2;
        gptr xr = ws + 2 * n2;
        gptr left = ws + 3 * n2;
        gptr right = ws + 4 * n2;
        gptr fc = ws + 5 * n2;
        gptr fb = ws + 6 * n2;
        gptr t = ws + 7 * n2;
        gptr xcx = ws + 8 * n2;
        for (int i = 0; i < n; ++i) {
            for (int j = 0; j < n; ++j) {
                const int q = i * n + j;
                left[q] = 0.5 * om * pp[q] * w[j] / mu[i];  // (w/2) M^-1 P+ W
                right[q] = 0.5 * om * w[i] * pp[q] / mu[j]; // (w/2) W P+ M^-1
                fc[q] = om * w[i] * pm[q] * w[j];
                fb[q] = 0.25 * om * pm[q] / (mu[i] * mu[j]);
                x[q] = 0.0;
            }
        }
        int it;
        for (it = 1; it <= cap; ++it) {
            // next = ((B + left X) + X right) + (X C) X
            mat_mul(nx, n, left, n, x, n, n);
            for (int q = 0; q < n2; ++q) nx[q] = fb[q] + nx[q];
            mat_mul(xr, n, x, n, right, n, n);
            mat_add(nx, xr, n, n);
            mat_mul(t, n, x, n, fc, n, n);
            mat_mul(xcx, n, t, n, x, n, n);
            mat_add(nx, xcx, n, n);
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) nx[i * n + j] /= 1.0 / mu[i] + 1.0 / mu[j];
            double c0 = 0.0;
            for (int q = 0; q < n2; ++q) c0 = fmax(c0, fabs(nx[q] - x[q]));
            change = c0;
            gptr sw = x;
            x = nx, nx = sw;
            if (!all_finite(x, n2)) {
                error = AMB_FIXED_POINT_DIVERGED;
                break;
            }
            scale = max_abs_of(x, n2);
            if (change <= task.tolerance * scale) {
                converged = 1;
                break;
            }
        }
        iterations = min(it, cap);
        result = x;
        if (error != AMB_OK || converged || task.method != AMB_FAST) run_doubling = 0;
        else sweeps = iterations; // solve_fast: switch to doubling
    }

    // ---- doubling (solve_doubling) ----
    if (run_doubling) {
        gptr e = ws;
        gptr f = ws + n2;
        gptr gm = ws + 2 * n2;
        gptr hm = ws + 3 * n2;
        gptr e1 = ws + 4 * n2;
        gptr f1 = ws + 5 * n2;
        gptr g1 = ws + 6 * n2;
        gptr h1 = ws + 7 * n2;
        gptr z = ws + 8 * n2;  // n x 2n
        gptr y = ws + 10 * n2; // n x 2n
        gptr lu = ws + 12 * n2;
        gptr t = ws + 13 * n2;
        gptr t2 = ws + 14 * n2;
        gptr ag = ws + 4 * n2;
        gptr bb = ws + 5 * n2;
        gptr cc = ws + 6 * n2;
        gptr dg = ws + 7 * n2;
        gptr dinv = ws + 8 * n2;
        gptr ainv = ws + 9 * n2;
        gptr winv = ws + 10 * n2;
        gptr vinv = ws + 11 * n2;
        const int conservative = task.m == 0 && om >= 1.0;
        double ev1 = 0.0; // conservation shift normaliser, e . v1
        if (conservative)
            for (int i = 0; i < n; ++i) ev1 += 2.0 * w[i] * mu[i];
        for (int i = 0; i < n; ++i) {
            for (int j = 0; j < n; ++j) {
                amb_doubling_element(i, j, n, om, g, conservative, ev1, mu, w, pp, pm, bb, cc, ag, dg);
            }
        }
        int bad = -1;
        // dinv = D_g^-1, ainv = A_g^-1
        mat_copy(lu, n, dg, n);
        bad = lu_factor(lu, n, piv);
        if (bad < 0) {
            mat_identity(dinv, n);
            lu_solve(lu, n, piv, dinv, n, n);
            mat_copy(lu, n, ag, n);
            bad = lu_factor(lu, n, piv);
        }
        if (bad < 0) {
            mat_identity(ainv, n);
            lu_solve(lu, n, piv, ainv, n, n);
            // winv = (A_g - (B D_g^-1) C)^-1
            mat_mul(t, n, bb, n, dinv, n, n);
            mat_mul(t2, n, t, n, cc, n, n);
            for (int q = 0; q < n2; ++q) lu[q] = ag[q] - t2[q];
            bad = lu_factor(lu, n, piv);
        }
        if (bad < 0) {
            mat_identity(winv, n);
            lu_solve(lu, n, piv, winv, n, n);
            // vinv = (D_g - (C A_g^-1) B)^-1
            mat_mul(t, n, cc, n, ainv, n, n);
            mat_mul(t2, n, t, n, bb, n, n);
            for (int q = 0; q < n2; ++q) lu[q] = dg[q] - t2[q];
            bad = lu_factor(lu, n, piv);
        }
        if (bad >= 0) {
            error = AMB_SINGULAR;
            detail = bad;
        } else {
            mat_identity(vinv, n);
            lu_solve(lu, n, piv, vinv, n, n);
            const double g2 = 2.0 * g;
            for (int q = 0; q < n2; ++q) {
                const double eye = (q / n == q % n) ? 1.0 : 0.0;
                e[q] = eye - g2 * vinv[q];
                f[q] = eye - g2 * winv[q];
            }
            mat_mul(t, n, dinv, n, cc, n, n); // G0 = 2g ((D_g^-1 C) W^-1)
            mat_mul(gm, n, t, n, winv, n, n);
            for (int q = 0; q < n2; ++q) gm[q] = g2 * gm[q];
            mat_mul(t, n, winv, n, bb, n, n); // H0 = 2g ((W^-1 B) D_g^-1)
            mat_mul(hm, n, t, n, dinv, n, n);
            for (int q = 0; q < n2; ++q) hm[q] = g2 * hm[q];

            int it;
            for (it = 1; it <= DOUBLING_STEPS; ++it) {
                // Z = [E, G F], solved with I - G H; Y = [F, H E], solved with I - H G.
                mat_copy(z, 2 * n, e, n);
                mat_mul(z + n, 2 * n, gm, n, f, n, n);
                mat_mul(lu, n, gm, n, hm, n, n);
                for (int q = 0; q < n2; ++q) lu[q] = ((q / n == q % n) ? 1.0 : 0.0) - lu[q];
                bad = lu_factor(lu, n, piv);
                if (bad >= 0) break;
                lu_solve(lu, n, piv, z, 2 * n, 2 * n);
                mat_copy(y, 2 * n, f, n);
                mat_mul(y + n, 2 * n, hm, n, e, n, n);
                mat_mul(lu, n, hm, n, gm, n, n);
                for (int q = 0; q < n2; ++q) lu[q] = ((q / n == q % n) ? 1.0 : 0.0) - lu[q];
                bad = lu_factor(lu, n, piv);
                if (bad >= 0) break;
                lu_solve(lu, n, piv, y, 2 * n, 2 * n);
                mat_mul(e1, n, e, n, z, 2 * n, n);
                mat_mul(g1, n, e, n, z + n, 2 * n, n);
                for (int q = 0; q < n2; ++q) g1[q] = gm[q] + g1[q];
                mat_mul(f1, n, f, n, y, 2 * n, n);
                mat_mul(h1, n, f, n, y + n, 2 * n, n);
                for (int q = 0; q < n2; ++q) h1[q] = hm[q] + h1[q];
                double c0 = 0.0;
                for (int q = 0; q < n2; ++q) c0 = fmax(c0, fabs(h1[q] - hm[q]));
                change = c0;
                gptr sw;
                sw = e, e = e1, e1 = sw;
                sw = f, f = f1, f1 = sw;
                sw = gm, gm = g1, g1 = sw;
                sw = hm, hm = h1, h1 = sw;
                if (!all_finite(hm, n2)) {
                    error = AMB_DOUBLING_DIVERGED;
                    break;
                }
                scale = max_abs_of(hm, n2);
                if (change <= task.tolerance * scale) {
                    converged = 1;
                    break;
                }
            }
            if (bad >= 0) {
                error = AMB_SINGULAR;
                detail = bad;
            }
            iterations = min(it, DOUBLING_STEPS) + sweeps;
            result = hm;
        }
    }

    if (error == AMB_OK)
        for (int q = 0; q < n2; ++q) x_out[q] = result[q];
    status[id].last_change = change;
    status[id].scale = scale;
    status[id].iterations = iterations;
    status[id].converged = converged;
    status[id].error = error;
    status[id].detail = detail;
}
