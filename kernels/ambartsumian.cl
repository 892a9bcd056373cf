// Batched per-Fourier-order solvers of Ambartsumian's equation (docs/physics.md section 3): one work-group
// per order problem, the same algorithms and the same arithmetic order as the C++ references in
// src/brdf/rte/order_solver.cpp (fixed point, structure-preserving doubling with the conservative
// rank-one shift, and the fast switch between them) and src/brdf/core/linalg.cpp (LU with partial
// pivoting). Every matrix element is summed over k in increasing order, as the reference does, so the
// two agree to a few ulp per operation. The step limit, the method switch and every element formula
// of the equation's matrices are the reference's own, from shared/ambartsumian_rules.h.
//
// Structure: the kernel is a small interpreter with a single barrier. Each pass of its main loop first
// runs the (private, identical on every work-item) control logic, which picks the next operation
// (a matrix product, one LU column step, a triangular solve, an elementwise pass...), then all
// work-items execute that operation on their share of elements, then everyone meets at the one
// barrier. Decisions read only values written before the previous barrier (local partial
// reductions), so they are uniform, every work-item reaches every barrier, and PoCL's work-group
// compiler sees one barrier in one loop instead of hundreds (which took it minutes to compile).

#pragma OPENCL FP_CONTRACT OFF

#include "shared/ambartsumian_layout.h"
#include "shared/ambartsumian_rules.h"
#include "shared/ambartsumian_setup.h"


// Operations (what all work-items do between two barriers).
#define OP_NONE 0
#define OP_GEMM 1        // out = f(A B) by mode
#define OP_COPY 2        // out (ld ldo) = a (n x n)
#define OP_IDENTITY 3    // out = I
#define OP_SETUP_FP 4    // fixed point's left, right, c, b; X = 0
#define OP_SETUP_DB 5    // doubling's A_g, B, C, D_g (shifted when conservative)
#define OP_EF 6          // E = I - 2g V^-1, F = I - 2g W^-1 (symmetric: E = I - 2g W^-T alone)
#define OP_SWEEP 7       // one fixed-point sweep into nx, with partial reductions
#define OP_DIFF 8        // partial reductions of H1 - H
#define OP_LU_PIVOT 9    // partial pivot search in column k
#define OP_LU_SWAP 10    // swap rows k and p
#define OP_LU_SCALE 11   // a_ik /= pivot
#define OP_LU_UPDATE 12  // trailing update
#define OP_SOLVE 13      // (LU) X = B, columns in parallel
#define OP_TRANSPOSE 14  // out = a^T (n x n)

#define MODE_PLAIN 0     // out = A B
#define MODE_ADD 1       // out = base + A B
#define MODE_SCALE 2     // out = s (A B)
#define MODE_EYE_MINUS 3 // out = I - A B
#define MODE_SUB 4       // out = base - A B

// Control states.
#define S_START 0
#define S_FP_SETUP 1
#define S_FP_LOOP 2
#define S_FP_SWEEP 3
#define S_FP_DECIDE 4
#define S_FP_DONE 5
#define S_DB_SETUP 10   // then S_DB_SETUP + 1 .. S_DB_SETUP + 23: the set-up sequence
#define S_DB_STEP 40    // then S_DB_STEP + 1 .. S_DB_STEP + 15: one doubling step
#define S_DB_DECIDE 60
#define S_DB_SYMMETRIC_STEP 90 // + 1 .. + 10: the rest of a symmetric SDA step, after S_DB_STEP
#define S_LU_PIVOT 70
#define S_LU_CHECK 71
#define S_LU_SCALE 72
#define S_LU_UPDATE 73
#define S_OUTPUT 80
#define S_FINISHED 81

/// One work-group per task: tasks[get_group_id(0)] solved by its method; X to output, the outcome
/// to status. Local size: a power of two <= AMB_MAX_WG.
__kernel void ambartsumian_solve(__global const AmbTask* tasks, __global const double* input,
                                 __global double* output, __global double* workspace,
                                 __global AmbStatus* status) {
    __local int piv[AMB_MAX_N];
    __local double part_a[AMB_MAX_WG]; // reductions: max change / pivot |value|
    __local double part_b[AMB_MAX_WG]; // reductions: max scale / pivot signed value
    __local int part_i[AMB_MAX_WG];    // reductions: non-finite flag / pivot row
    const int group = (int)get_group_id(0);
    const int lid = (int)get_local_id(0);
    const int lsz = (int)get_local_size(0);
    const AmbTask task = tasks[group];
    const int n = task.n;
    const int n2 = n * n;
    const double om = task.omega;
    __global const double* mu = input + task.input_offset;
    __global const double* w = mu + n;
    __global const double* phase_plus = w + n;
    __global const double* phase_minus = phase_plus + n2;
    __global double* x_out = output + task.output_offset;
    __global double* ws = workspace + task.workspace_offset;
    const double g = task.gamma;
    const double g2 = 2.0 * g;
    const int conservative = amb_conservative(task.m, om);
    // Unshifted, the equation is symmetric: F_k = E_k^T is never formed (solve_doubling).
    const int symmetric = !conservative;

    // Workspace slots (n x n each). The Riccati B and C (slots 5, 6) serve the fixed point and the
    // doubling set-up alike.
    __global double* riccati_b = ws + 5 * n2;
    __global double* riccati_c = ws + 6 * n2;
    // Fixed point: the iterate and the next one, the sweep's constant products.
    __global double* x = ws;
    __global double* nx = ws + n2;
    __global double* sweep_left = ws + 3 * n2;
    __global double* sweep_right = ws + 4 * n2;
    // Doubling: the SDA iterates E_k, F_k, G_k, H_k and the next ones (Guo, Lin and Xu
    // 2006); the set-up matrices live in slots 4..11 until the first step.
    __global double* e_k = ws;
    __global double* f_k = ws + n2;
    __global double* g_k = ws + 2 * n2;
    __global double* h_k = ws + 3 * n2;
    __global double* e_next = ws + 4 * n2;
    __global double* f_next = ws + 5 * n2;
    __global double* g_next = ws + 6 * n2;
    __global double* h_next = ws + 7 * n2;
    __global double* z = ws + 8 * n2;  // n x 2n
    __global double* y = ws + 10 * n2; // n x 2n
    __global double* lu = ws + 12 * n2;
    __global double* t = ws + 13 * n2;
    __global double* t2 = ws + 14 * n2;
    __global double* a_gamma = ws + 4 * n2; // A + g I
    __global double* d_gamma = ws + 7 * n2; // D + g I
    __global double* dinv = ws + 8 * n2;
    __global double* ainv = ws + 9 * n2;
    __global double* winv = ws + 10 * n2;
    __global double* vinv = ws + 11 * n2;

    const double ev1 = amb_shift_norm(conservative, n, mu, w);

    // Outcome and control state (private, identical on every work-item).
    int iterations = 0, converged = 0, error = AMB_OK, detail = 0;
    int state = S_START, it = 0, sweeps = 0, cap = 0;
    double previous = 0.0, before = 0.0; // the fixed point's changes of the last two sweeps
    int lu_k = 0, lu_ret = 0, lu_p = 0;
    double pivot = 1.0;
    __global double* result = x;

    while (state != S_FINISHED) {
        // ---- control: choose the next operation ----
        int op = OP_NONE, mode = MODE_PLAIN, ldo = n, ldb = n, cols = n;
        double s = 0.0;
        __global double* out = 0;
        __global const double* base = 0;
        __global const double* a = 0;
        __global const double* b = 0;
        while (op == OP_NONE && state != S_FINISHED) {
            switch (state) {
            case S_START:
                if (task.method == AMB_FIXED_POINT) {
                    cap = task.max_iterations;
                    state = S_FP_SETUP;
                } else if (task.method == AMB_FAST && !task.doubling_first) {
                    cap = task.fast_sweeps;
                    state = S_FP_SETUP;
                } else {
                    state = S_DB_SETUP;
                }
                break;
            // -- fixed point (solve_fixed_point) --
            case S_FP_SETUP:
                op = OP_SETUP_FP;
                it = 0;
                state = S_FP_LOOP;
                break;
            case S_FP_LOOP:
                ++it;
                if (it > cap) {
                    state = S_FP_DONE;
                    break;
                }
                // right + C X; the first sweep starts from X = 0 and needs no products (OP_SWEEP)
                if (it > 1) op = OP_GEMM, mode = MODE_ADD, out = t, base = sweep_right, a = riccati_c, b = x;
                state = S_FP_SWEEP;
                break;
            case S_FP_SWEEP:
                op = OP_SWEEP;
                state = S_FP_DECIDE;
                break;
            case S_FP_DECIDE: {
                double change = 0.0, scale = 0.0;
                int bad = 0;
                for (int q = 0; q < lsz; ++q) {
                    change = fmax(change, part_a[q]);
                    scale = fmax(scale, part_b[q]);
                    bad |= part_i[q];
                }
                __global double* sw = x;
                x = nx, nx = sw;
                if (bad) {
                    error = AMB_FIXED_POINT_DIVERGED;
                    iterations = it;
                    state = S_FINISHED;
                } else if (change <= task.tolerance * scale) {
                    converged = 1;
                    state = S_FP_DONE;
                } else if (task.method == AMB_FAST &&
                           amb_fast_gives_up(it, cap, change, previous, before, task.tolerance * scale)) {
                    state = S_FP_DONE;
                } else {
                    before = previous, previous = change;
                    state = S_FP_LOOP;
                }
                break;
            }
            case S_FP_DONE:
                iterations = min(it, cap);
                if (task.method == AMB_FAST && !converged) {
                    sweeps = iterations; // solve_fast: switch to doubling
                    state = S_DB_SETUP;
                } else {
                    result = x;
                    state = S_OUTPUT;
                }
                break;
            // -- doubling (solve_doubling): Cayley-transformed start --
            case S_DB_SETUP + 0: op = OP_SETUP_DB; state = S_DB_SETUP + 1; break;
            case S_DB_SETUP + 1: op = OP_COPY, out = lu, a = d_gamma; state = S_DB_SETUP + 2; break;
            case S_DB_SETUP + 2: lu_ret = S_DB_SETUP + 3; lu_k = 0; state = S_LU_PIVOT; break;
            case S_DB_SETUP + 3: op = OP_IDENTITY, out = dinv; state = S_DB_SETUP + 4; break;
            case S_DB_SETUP + 4: op = OP_SOLVE, out = dinv; state = S_DB_SETUP + 5; break;
            case S_DB_SETUP + 5: // A_g^-1 and V^-1 only for the general (shifted) start
                if (symmetric) state = S_DB_SETUP + 9;
                else op = OP_COPY, out = lu, a = a_gamma, state = S_DB_SETUP + 6;
                break;
            case S_DB_SETUP + 6: lu_ret = S_DB_SETUP + 7; lu_k = 0; state = S_LU_PIVOT; break;
            case S_DB_SETUP + 7: op = OP_IDENTITY, out = ainv; state = S_DB_SETUP + 8; break;
            case S_DB_SETUP + 8: op = OP_SOLVE, out = ainv; state = S_DB_SETUP + 9; break;
            case S_DB_SETUP + 9: op = OP_GEMM, out = t, a = riccati_b, b = dinv; state = S_DB_SETUP + 10; break;
            case S_DB_SETUP + 10: // A_g - B D_g^-1 C
                op = OP_GEMM, mode = MODE_SUB, out = lu, base = a_gamma, a = t, b = riccati_c;
                state = S_DB_SETUP + 11;
                break;
            case S_DB_SETUP + 11: lu_ret = S_DB_SETUP + 12; lu_k = 0; state = S_LU_PIVOT; break;
            case S_DB_SETUP + 12: op = OP_IDENTITY, out = winv; state = S_DB_SETUP + 13; break;
            case S_DB_SETUP + 13: op = OP_SOLVE, out = winv; state = S_DB_SETUP + 14; break;
            case S_DB_SETUP + 14:
                if (symmetric) state = S_DB_SETUP + 19;
                else op = OP_GEMM, out = t, a = riccati_c, b = ainv, state = S_DB_SETUP + 15;
                break;
            case S_DB_SETUP + 15: // D_g - C A_g^-1 B
                op = OP_GEMM, mode = MODE_SUB, out = lu, base = d_gamma, a = t, b = riccati_b;
                state = S_DB_SETUP + 16;
                break;
            case S_DB_SETUP + 16: lu_ret = S_DB_SETUP + 17; lu_k = 0; state = S_LU_PIVOT; break;
            case S_DB_SETUP + 17: op = OP_IDENTITY, out = vinv; state = S_DB_SETUP + 18; break;
            case S_DB_SETUP + 18: op = OP_SOLVE, out = vinv; state = S_DB_SETUP + 19; break;
            case S_DB_SETUP + 19: op = OP_EF; state = S_DB_SETUP + 20; break;
            case S_DB_SETUP + 20: op = OP_GEMM, out = t, a = dinv, b = riccati_c; state = S_DB_SETUP + 21; break;
            case S_DB_SETUP + 21: // G0 = 2g (D_g^-1 C W^-1)
                op = OP_GEMM, mode = MODE_SCALE, s = g2, out = g_k, a = t, b = winv;
                state = S_DB_SETUP + 22;
                break;
            case S_DB_SETUP + 22: op = OP_GEMM, out = t, a = winv, b = riccati_b; state = S_DB_SETUP + 23; break;
            case S_DB_SETUP + 23: // H0 = 2g (W^-1 B D_g^-1)
                op = OP_GEMM, mode = MODE_SCALE, s = g2, out = h_k, a = t, b = dinv;
                it = 0;
                state = S_DB_STEP;
                break;
            // -- one doubling step --
            case S_DB_STEP + 0:
                ++it;
                if (it > AMB_DOUBLING_STEPS) {
                    iterations = AMB_DOUBLING_STEPS + sweeps;
                    result = h_k;
                    state = S_OUTPUT;
                    break;
                }
                if (symmetric) {
                    op = OP_TRANSPOSE, out = t, a = e_k; // t = E^T
                    state = S_DB_SYMMETRIC_STEP + 1;
                } else {
                    op = OP_COPY, out = z, ldo = 2 * n, a = e_k; // Z = [E, .]
                    state = S_DB_STEP + 1;
                }
                break;
            case S_DB_STEP + 1: // Z = [E, G F]
                op = OP_GEMM, out = z + n, ldo = 2 * n, a = g_k, b = f_k;
                state = S_DB_STEP + 2;
                break;
            case S_DB_STEP + 2: op = OP_GEMM, mode = MODE_EYE_MINUS, out = lu, a = g_k, b = h_k; state = S_DB_STEP + 3; break;
            case S_DB_STEP + 3: lu_ret = S_DB_STEP + 4; lu_k = 0; state = S_LU_PIVOT; break;
            case S_DB_STEP + 4: op = OP_SOLVE, out = z, ldo = 2 * n, cols = 2 * n; state = S_DB_STEP + 5; break;
            case S_DB_STEP + 5: op = OP_COPY, out = y, ldo = 2 * n, a = f_k; state = S_DB_STEP + 6; break;
            case S_DB_STEP + 6: // Y = [F, H E]
                op = OP_GEMM, out = y + n, ldo = 2 * n, a = h_k, b = e_k;
                state = S_DB_STEP + 7;
                break;
            case S_DB_STEP + 7: op = OP_GEMM, mode = MODE_EYE_MINUS, out = lu, a = h_k, b = g_k; state = S_DB_STEP + 8; break;
            case S_DB_STEP + 8: lu_ret = S_DB_STEP + 9; lu_k = 0; state = S_LU_PIVOT; break;
            case S_DB_STEP + 9: op = OP_SOLVE, out = y, ldo = 2 * n, cols = 2 * n; state = S_DB_STEP + 10; break;
            case S_DB_STEP + 10: op = OP_GEMM, out = e_next, a = e_k, b = z, ldb = 2 * n; state = S_DB_STEP + 11; break;
            case S_DB_STEP + 11:
                op = OP_GEMM, mode = MODE_ADD, out = g_next, base = g_k, a = e_k, b = z + n, ldb = 2 * n;
                state = S_DB_STEP + 12;
                break;
            case S_DB_STEP + 12: op = OP_GEMM, out = f_next, a = f_k, b = y, ldb = 2 * n; state = S_DB_STEP + 13; break;
            case S_DB_STEP + 13:
                op = OP_GEMM, mode = MODE_ADD, out = h_next, base = h_k, a = f_k, b = y + n, ldb = 2 * n;
                state = S_DB_STEP + 14;
                break;
            case S_DB_STEP + 14: op = OP_DIFF; state = S_DB_DECIDE; break;
            case S_DB_DECIDE: {
                double change = 0.0, scale = 0.0;
                int bad = 0;
                for (int q = 0; q < lsz; ++q) {
                    change = fmax(change, part_a[q]);
                    scale = fmax(scale, part_b[q]);
                    bad |= part_i[q];
                }
                __global double* sw;
                sw = e_k, e_k = e_next, e_next = sw;
                sw = f_k, f_k = f_next, f_next = sw;
                sw = g_k, g_k = g_next, g_next = sw;
                sw = h_k, h_k = h_next, h_next = sw;
                if (bad) {
                    error = AMB_DOUBLING_DIVERGED;
                    iterations = it + sweeps;
                    state = S_FINISHED;
                } else if (change <= task.tolerance * scale) {
                    converged = 1;
                    iterations = it + sweeps;
                    result = h_k;
                    state = S_OUTPUT;
                } else {
                    state = S_DB_STEP;
                }
                break;
            }
            // -- the rest of a symmetric SDA step (S_DB_STEP + 0 took t = E^T): Z = [E, G E^T] solved with
            // I - G H, H_k+1 = H + (E^T H) Z_1 --
            case S_DB_SYMMETRIC_STEP + 1: op = OP_COPY, out = z, ldo = 2 * n, a = e_k; state = S_DB_SYMMETRIC_STEP + 2; break;
            case S_DB_SYMMETRIC_STEP + 2: // Z = [E, G E^T]
                op = OP_GEMM, out = z + n, ldo = 2 * n, a = g_k, b = t;
                state = S_DB_SYMMETRIC_STEP + 3;
                break;
            case S_DB_SYMMETRIC_STEP + 3:
                op = OP_GEMM, mode = MODE_EYE_MINUS, out = lu, a = g_k, b = h_k;
                state = S_DB_SYMMETRIC_STEP + 4;
                break;
            case S_DB_SYMMETRIC_STEP + 4: lu_ret = S_DB_SYMMETRIC_STEP + 5; lu_k = 0; state = S_LU_PIVOT; break;
            case S_DB_SYMMETRIC_STEP + 5:
                op = OP_SOLVE, out = z, ldo = 2 * n, cols = 2 * n;
                state = S_DB_SYMMETRIC_STEP + 6;
                break;
            case S_DB_SYMMETRIC_STEP + 6:
                op = OP_GEMM, out = e_next, a = e_k, b = z, ldb = 2 * n;
                state = S_DB_SYMMETRIC_STEP + 7;
                break;
            case S_DB_SYMMETRIC_STEP + 7:
                op = OP_GEMM, mode = MODE_ADD, out = g_next, base = g_k, a = e_k, b = z + n, ldb = 2 * n;
                state = S_DB_SYMMETRIC_STEP + 8;
                break;
            case S_DB_SYMMETRIC_STEP + 8: op = OP_GEMM, out = t2, a = t, b = h_k; state = S_DB_SYMMETRIC_STEP + 9; break;
            case S_DB_SYMMETRIC_STEP + 9:
                op = OP_GEMM, mode = MODE_ADD, out = h_next, base = h_k, a = t2, b = z, ldb = 2 * n;
                state = S_DB_SYMMETRIC_STEP + 10;
                break;
            case S_DB_SYMMETRIC_STEP + 10: op = OP_DIFF; state = S_DB_DECIDE; break;
            // -- LU of `lu` with partial pivoting (LuFactor), column lu_k; returns to lu_ret --
            case S_LU_PIVOT:
                op = OP_LU_PIVOT;
                state = S_LU_CHECK;
                break;
            case S_LU_CHECK: {
                // The first row of largest |a_ik| (item 0's partial holds row k, which wins ties and,
                // if NaN, everything: as the reference's strict > from p = k).
                double bv = part_a[0], sv = part_b[0];
                int bi = part_i[0];
                for (int q = 1; q < lsz; ++q) {
                    const int oi = part_i[q];
                    const double ov = part_a[q];
                    if (oi >= 0 && (bi < 0 || ov > bv || (ov == bv && oi < bi))) {
                        bv = ov, sv = part_b[q], bi = oi;
                    }
                }
                lu_p = bi;
                pivot = sv;
                if (pivot == 0.0 || !isfinite(pivot)) {
                    error = AMB_SINGULAR;
                    detail = lu_k;
                    state = S_FINISHED;
                    break;
                }
                op = OP_LU_SWAP;
                state = S_LU_SCALE;
                break;
            }
            case S_LU_SCALE: op = OP_LU_SCALE; state = S_LU_UPDATE; break;
            case S_LU_UPDATE:
                if (lu_k + 1 < n) {
                    op = OP_LU_UPDATE;
                    ++lu_k;
                    state = S_LU_PIVOT;
                } else {
                    state = lu_ret; // the last column has no trailing part
                }
                break;
            case S_OUTPUT:
                op = OP_COPY, out = x_out, a = result;
                state = S_FINISHED;
                break;
            default:
                error = -1;
                state = S_FINISHED;
                break;
            }
        }

        // ---- execute the operation: every work-item its share ----
        if (op == OP_GEMM) {
            const int total = n * n; // every product here is n x n (column blocks via ld)
            for (int q = lid; q < total; q += lsz) {
                const int i = q / n, j = q % n;
                double acc = 0.0;
                for (int k = 0; k < n; ++k) acc += a[i * n + k] * b[k * ldb + j];
                double r = acc;
                if (mode == MODE_ADD) r = base[i * n + j] + acc;
                else if (mode == MODE_SCALE) r = s * acc;
                else if (mode == MODE_EYE_MINUS) r = (i == j ? 1.0 : 0.0) - acc;
                else if (mode == MODE_SUB) r = base[i * n + j] - acc;
                out[i * ldo + j] = r;
            }
        } else if (op == OP_COPY) {
            for (int q = lid; q < n2; q += lsz) out[(q / n) * ldo + q % n] = a[q];
        } else if (op == OP_TRANSPOSE) {
            for (int q = lid; q < n2; q += lsz) out[q] = a[(q % n) * n + q / n];
        } else if (op == OP_IDENTITY) {
            for (int q = lid; q < n2; q += lsz) out[q] = (q / n == q % n) ? 1.0 : 0.0;
        } else if (op == OP_SETUP_FP) {
            for (int q = lid; q < n2; q += lsz)
                amb_fixed_point_element(q / n, q % n, n, om, mu, w, phase_plus, phase_minus, sweep_left, sweep_right,
                                        riccati_b, riccati_c, x);
        } else if (op == OP_SETUP_DB) {
            for (int q = lid; q < n2; q += lsz) {
                const int i = q / n, j = q % n;
                amb_doubling_element(i, j, n, om, g, conservative, ev1, mu, w, phase_plus, phase_minus, riccati_b,
                                     riccati_c, a_gamma, d_gamma);
            }
        } else if (op == OP_EF) {
            for (int q = lid; q < n2; q += lsz) {
                const double eye = (q / n == q % n) ? 1.0 : 0.0;
                if (symmetric) {
                    e_k[q] = eye - g2 * winv[(q % n) * n + q / n];
                } else {
                    e_k[q] = eye - g2 * vinv[q];
                    f_k[q] = eye - g2 * winv[q];
                }
            }
        } else if (op == OP_SWEEP) {
            double c0 = 0.0, s0 = 0.0;
            int bad = 0;
            for (int q = lid; q < n2; q += lsz) {
                const int i = q / n, j = q % n;
                // (B + left X) + X (right + C X), t = right + C X: three products a sweep
                // (the first from X = 0: B alone, as solve_fixed_point)
                double lx = 0.0, xt = 0.0;
                for (int k = 0; it > 1 && k < n; ++k) lx += sweep_left[i * n + k] * x[k * n + j];
                for (int k = 0; it > 1 && k < n; ++k) xt += x[i * n + k] * t[k * n + j];
                double v = (riccati_b[q] + lx) + xt;
                v /= amb_fixed_point_divisor(mu[i], mu[j]);
                nx[q] = v;
                c0 = fmax(c0, fabs(v - x[q]));
                s0 = fmax(s0, fabs(v));
                bad |= !isfinite(v);
            }
            part_a[lid] = c0, part_b[lid] = s0, part_i[lid] = bad;
        } else if (op == OP_DIFF) {
            double c0 = 0.0, s0 = 0.0;
            int bad = 0;
            for (int q = lid; q < n2; q += lsz) {
                c0 = fmax(c0, fabs(h_next[q] - h_k[q]));
                s0 = fmax(s0, fabs(h_next[q]));
                bad |= !isfinite(h_next[q]);
            }
            part_a[lid] = c0, part_b[lid] = s0, part_i[lid] = bad;
        } else if (op == OP_LU_PIVOT) {
            const int k = lu_k;
            double bv = -1.0, sv = 0.0;
            int bi = -1;
            if (lid == 0) {
                sv = lu[k * n + k];
                bv = fabs(sv);
                bi = k;
            }
            for (int i = k + lid; i < n; i += lsz) {
                if (i == k) continue;
                const double v = lu[i * n + k];
                if (fabs(v) > bv) { // rows with NaN never win
                    bv = fabs(v), sv = v, bi = i;
                }
            }
            part_a[lid] = bv, part_b[lid] = sv, part_i[lid] = bi;
        } else if (op == OP_LU_SWAP) {
            const int k = lu_k, p = lu_p;
            if (lid == 0) piv[k] = p;
            if (p != k) {
                for (int j = lid; j < n; j += lsz) {
                    const double tmp = lu[k * n + j];
                    lu[k * n + j] = lu[p * n + j];
                    lu[p * n + j] = tmp;
                }
            }
        } else if (op == OP_LU_SCALE) {
            for (int i = lu_k + 1 + lid; i < n; i += lsz) lu[i * n + lu_k] /= pivot;
        } else if (op == OP_LU_UPDATE) {
            const int k = lu_k - 1; // already advanced by the control
            const int rest = n - k - 1;
            for (int q = lid; q < rest * rest; q += lsz) {
                const int i = k + 1 + q / rest, j = k + 1 + q % rest;
                lu[i * n + j] -= lu[i * n + k] * lu[k * n + j];
            }
        } else if (op == OP_SOLVE) {
            // (LU) X = B for B = out (n x cols, leading dimension ldo): each work-item whole columns.
            for (int j = lid; j < cols; j += lsz) {
                for (int k = 0; k < n; ++k) {
                    const int p = piv[k];
                    if (p != k) {
                        const double tmp = out[k * ldo + j];
                        out[k * ldo + j] = out[p * ldo + j];
                        out[p * ldo + j] = tmp;
                    }
                }
                for (int i = 0; i < n; ++i) {
                    double v = out[i * ldo + j];
                    for (int k = 0; k < i; ++k) v -= lu[i * n + k] * out[k * ldo + j];
                    out[i * ldo + j] = v;
                }
                for (int i = n - 1; i >= 0; --i) {
                    double v = out[i * ldo + j];
                    for (int k = i + 1; k < n; ++k) v -= lu[i * n + k] * out[k * ldo + j];
                    out[i * ldo + j] = v / lu[i * n + i];
                }
            }
        }
        barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
    }

    if (lid == 0) {
        status[group].iterations = iterations;
        status[group].converged = converged;
        status[group].error = error;
        status[group].detail = detail;
    }
}
