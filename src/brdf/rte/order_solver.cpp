#include <brdf/rte/order_solver.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/rte/phase.h>

#include <algorithm>
#include <cmath>

namespace brdf::rte {
namespace {

bool finite(const Matrix& x) {
    return std::all_of(x.data().begin(), x.data().end(), [](double v) { return std::isfinite(v); });
}

// [P Q] as one n x 2n matrix, so one LU solve serves both right-hand sides of a doubling step.
Matrix side_by_side(const Matrix& p, const Matrix& q) {
    Matrix out(p.rows(), p.cols() + q.cols());
    for (int i = 0; i < p.rows(); ++i) {
        std::copy(p.row(i).begin(), p.row(i).end(), out.row(i).begin());
        std::copy(q.row(i).begin(), q.row(i).end(), out.row(i).begin() + p.cols());
    }
    return out;
}

Matrix columns(const Matrix& m, int first, int count) {
    Matrix out(m.rows(), count);
    for (int i = 0; i < m.rows(); ++i)
        std::copy_n(m.row(i).begin() + first, count, out.row(i).begin());
    return out;
}

} // namespace

std::string_view to_string(Method method) {
    switch (method) {
    case Method::FixedPoint: return "fixed-point";
    case Method::Doubling: return "doubling";
    case Method::Fast: return "fast";
    }
    return "?";
}

bool OrderProblem::conservative() const { return amb_conservative(m, omega) != 0; }

OrderProblem make_order_problem(std::span<const double> beta, double omega, int m, const Streams& streams) {
    PhasePair p = phase_components(beta, m, streams.mu, streams.mu);
    double largest = 0.0; // max |chi_l| over l >= m
    for (std::size_t l = static_cast<std::size_t>(m); l < beta.size(); ++l)
        largest = std::max(largest, std::abs(beta[l]) / (2.0 * static_cast<double>(l) + 1.0));
    return OrderProblem{m, omega, streams, std::move(p.plus), std::move(p.minus), omega * largest};
}

RiccatiMatrices riccati_matrices(const OrderProblem& pr) {
    const int n = pr.streams.size();
    const auto& mu = pr.streams.mu;
    const auto& w = pr.streams.w;
    const double om = pr.omega;
    RiccatiMatrices r{Matrix(n, n), Matrix(n, n), Matrix(n, n), Matrix(n, n)};
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            r.b(i, j) = amb_riccati_b(om, pr.p_minus(i, j), mu[i], mu[j]);
            r.c(i, j) = amb_riccati_c(om, w[i], pr.p_minus(i, j), w[j]);
            r.d(i, j) = amb_riccati_d(i == j, om, mu[i], mu[j], w[i], pr.p_plus(i, j));
        }
    }
    r.a = transpose(r.d);
    return r;
}

double riccati_residual(const RiccatiMatrices& r, const Matrix& x) {
    const Matrix xcx = x * r.c * x;
    const Matrix xd = x * r.d;
    const Matrix ax = r.a * x;
    const Matrix res = xcx - xd - ax + r.b;
    const double scale = std::max({max_abs(xcx), max_abs(xd), max_abs(ax), max_abs(r.b)});
    return scale > 0.0 ? max_abs(res) / scale : 0.0;
}

OrderSolution solve_fixed_point(const OrderProblem& pr, const SolveControl& control) {
    // The seed paper's iteration: (1/mu_i + 1/mu_j) X_ij = [B + (w/2) M^-1 P+ W X + (w/2) X W P+ M^-1
    // + w X W P- W X]_ij, from X = 0. Each sweep is a few matrix products.
    const int n = pr.streams.size();
    const auto& mu = pr.streams.mu;
    const auto& w = pr.streams.w;
    const double om = pr.omega;
    Matrix left(n, n), right(n, n), c(n, n), b(n, n);
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            left(i, j) = amb_fixed_point_left(om, pr.p_plus(i, j), w[j], mu[i]);
            right(i, j) = amb_fixed_point_right(om, w[i], pr.p_plus(i, j), mu[j]);
            c(i, j) = amb_riccati_c(om, w[i], pr.p_minus(i, j), w[j]);
            b(i, j) = amb_riccati_b(om, pr.p_minus(i, j), mu[i], mu[j]);
        }
    }
    Matrix divisor(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) divisor(i, j) = amb_fixed_point_divisor(mu[i], mu[j]);
    OrderSolution s;
    s.x = Matrix(n, n);
    Matrix next(n, n), inner(n, n);
    double previous = 0.0, before = 0.0; // the changes of the last two sweeps
    for (s.iterations = 1; s.iterations <= control.max_iterations; ++s.iterations) {
        // next = B + left X + X (right + C X); X right + X C X as X (right + C X): three products a
        // sweep, not four. Summed into the two buffers by gemm's beta = 1, the same additions in
        // the same order as the expression's, without its five new matrices a sweep.
        // The first sweep starts from X = 0, where the products vanish: it is B alone (the single
        // scattering), without three products of zeros (a third of the work of the many orders that
        // converge in three sweeps: HG g 0.5 at 64 streams has 12 of its 24).
        next = b;
        if (s.iterations > 1) {
            gemm(left, false, s.x, false, next, 1.0, 1.0);
            inner = right;
            gemm(c, false, s.x, false, inner, 1.0, 1.0);
            gemm(s.x, false, inner, false, next, 1.0, 1.0);
        }
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) next(i, j) /= divisor(i, j);
        const double change = max_abs_diff(next, s.x);
        std::swap(s.x, next);
        if (!finite(s.x)) throw NumericalError(cat("fixed-point iteration diverged at order ", pr.m));
        const double target = control.tolerance * max_abs(s.x);
        if (change <= target) {
            s.converged = true;
            break;
        }
        if (control.give_up_when_slow &&
            amb_fast_gives_up(s.iterations, control.max_iterations, change, previous, before, target))
            break;
        before = previous, previous = change;
    }
    s.iterations = std::min(s.iterations, control.max_iterations);
    s.residual = riccati_residual(riccati_matrices(pr), s.x);
    return s;
}

double doubling_gamma(const OrderProblem& pr) {
    const auto& mu = pr.streams.mu;
    if (mu.empty()) return 1.0;
    const double mu_min = *std::min_element(mu.begin(), mu.end());
    const double lambda_min =
        pr.m == 0 && !pr.conservative() ? std::min(1.0, std::sqrt(3.0 * (1.0 - pr.omega))) : 1.0;
    return std::max(1.0, std::sqrt(lambda_min / mu_min));
}

OrderSolution solve_doubling(const OrderProblem& pr, const SolveControl& control) {
    const int n = pr.streams.size();
    RiccatiMatrices r = riccati_matrices(pr);
    if (pr.conservative()) {
        // H = [D -C; B -A] has the right null vector v = [2 W mu; e] at w = 1, m = 0 (it encodes
        // sum_j w_j (p+ + p-)_ij = 2). H + eta v p^T with p = [e; 0] / (e . v1) moves that eigenvalue
        // from 0 to eta (AMB_CONSERVATIVE_SHIFT) and leaves the invariant subspace [I; X] alone: only
        // D and B change.
        const auto& mu = pr.streams.mu;
        const auto& w = pr.streams.w;
        double ev1 = 0.0;
        for (int i = 0; i < n; ++i) ev1 += amb_shift_vector(w[i], mu[i]);
        for (int i = 0; i < n; ++i) {
            for (int j = 0; j < n; ++j) {
                r.d(i, j) += amb_shift_d(w[i], mu[i], ev1);
                r.b(i, j) += amb_shift_b(ev1);
            }
        }
    }
    const double g = control.gamma > 0.0 ? control.gamma : doubling_gamma(pr);
    const Matrix eye = Matrix::identity(n);
    const Matrix a_g = r.a + g * eye;
    const Matrix d_g = r.d + g * eye;
    // Unshifted, A = D^T and B, C are symmetric: the equation is a symmetric (continuous-time)
    // Riccati equation, V = W^T below, and SDA keeps F_k = E_k^T with G_k, H_k symmetric at every
    // step (the SDA of Chu, Fan and Lin 2005 for such equations; by induction on the step formulas,
    // since (I - H G)^T = I - G H for symmetric G, H). So F is never formed: the set-up needs two
    // inverses instead of four and each step one LU instead of two and six products instead of
    // eight, with (I - H G)^-1 H = H (I - G H)^-1 for the H update.
    // The conservative shift changes D and B, not A, and breaks that symmetry: the general step.
    const bool symmetric = !pr.conservative();
    // Cayley-transformed start (Guo, Lin and Xu 2006, eqs. 2.6-2.8):
    //   W = A_g - B D_g^-1 C, V = D_g - C A_g^-1 B, E0 = I - 2g V^-1, F0 = I - 2g W^-1,
    //   G0 = 2g D_g^-1 C W^-1, H0 = 2g W^-1 B D_g^-1.
    const Matrix dinv = solve(d_g, eye);
    const Matrix winv = solve(a_g - r.b * dinv * r.c, eye);
    Matrix e_k, f_k;
    if (symmetric) {
        e_k = eye - 2.0 * g * transpose(winv);
    } else {
        const Matrix ainv = solve(a_g, eye);
        const Matrix vinv = solve(d_g - r.c * ainv * r.b, eye);
        e_k = eye - 2.0 * g * vinv;
        f_k = eye - 2.0 * g * winv;
    }
    Matrix g_k = 2.0 * g * (dinv * r.c * winv);
    Matrix h_k = 2.0 * g * (winv * r.b * dinv);

    OrderSolution s;
    for (s.iterations = 1; s.iterations <= max_doubling_steps; ++s.iterations) {
        // One SDA step: E_k+1 = E_k (I - G_k H_k)^-1 E_k, G_k+1 = G_k + E_k (I - G_k H_k)^-1 G_k F_k, and
        // symmetrically F_k+1, H_k+1 with (I - H_k G_k); H_k -> X.
        Matrix e_next, g_next, h_next;
        if (symmetric) {
            // Z = (I - G H)^-1 [E, G E^T]; H_k+1 = H + E^T (I - H G)^-1 H E = H + (E^T H) Z_1.
            const Matrix et = transpose(e_k);
            Matrix z = side_by_side(e_k, g_k * et);
            LuFactor(eye - g_k * h_k).solve(z);
            const Matrix z1 = columns(z, 0, n);
            e_next = e_k * z1;
            g_next = g_k + e_k * columns(z, n, n);
            h_next = h_k + (et * h_k) * z1;
        } else {
            Matrix z = side_by_side(e_k, g_k * f_k);
            LuFactor(eye - g_k * h_k).solve(z);
            Matrix y = side_by_side(f_k, h_k * e_k);
            LuFactor(eye - h_k * g_k).solve(y);
            e_next = e_k * columns(z, 0, n);
            g_next = g_k + e_k * columns(z, n, n);
            h_next = h_k + f_k * columns(y, n, n);
            f_k = f_k * columns(y, 0, n);
        }
        const double change = max_abs_diff(h_next, h_k);
        e_k = std::move(e_next), g_k = std::move(g_next), h_k = std::move(h_next);
        if (!finite(h_k)) throw NumericalError(cat("doubling diverged at order ", pr.m, ", omega ", pr.omega));
        if (change <= control.tolerance * max_abs(h_k)) {
            s.converged = true;
            break;
        }
    }
    s.iterations = std::min(s.iterations, max_doubling_steps);
    s.x = std::move(h_k);
    s.residual = riccati_residual(riccati_matrices(pr), s.x);
    return s;
}

OrderSolution solve_fast(const OrderProblem& problem, const SolveControl& control) {
    // A fixed-point sweep costs about 3 N^3, a doubling step about 11 N^3 (17 in the general form
    // of the conservative m = 0) and doubling needs 9-15 steps (doubling_gamma): the sweeps win
    // whenever they converge within about 30, which m >= 1 nearly always does (m = 1 at albedo 1
    // needs 13 to 25) unless its order albedo says it cannot (amb_fast_starts_with_doubling). A
    // try that will not makes it plain from its rate within a few sweeps (amb_fast_gives_up) and
    // stops there, not at the cap.
    int sweeps = 0;
    if (!amb_fast_starts_with_doubling(problem.order_albedo)) {
        SolveControl capped = control;
        capped.max_iterations = control.fast_sweeps;
        capped.give_up_when_slow = true;
        OrderSolution s = solve_fixed_point(problem, capped);
        if (s.converged) return s;
        sweeps = s.iterations;
    }
    OrderSolution s = solve_doubling(problem, control);
    s.iterations += sweeps;
    return s;
}

OrderSolution solve_order(const OrderProblem& problem, Method method, const SolveControl& control) {
    switch (method) {
    case Method::FixedPoint: return solve_fixed_point(problem, control);
    case Method::Doubling: return solve_doubling(problem, control);
    case Method::Fast: return solve_fast(problem, control);
    }
    throw InputError("unknown solver method");
}

} // namespace brdf::rte
