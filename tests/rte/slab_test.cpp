// The finite slab (rte/slab.h) against an independent doubling code written here from the thin-layer
// propagator, and its invariants: reciprocity, energy at albedo 1, the thin and thick limits, and the
// agreement of the off-stream evaluations (rows, beams) with the streams' own values.

#include "rte_test_support.h"

#include <brdf/rte/order_solver.h>
#include <brdf/rte/slab.h>
#include <brdf/rte/streams.h>
#include <test_support.h>

#include <cmath>

namespace brdf::test {
namespace {

using rte::OrderProblem;
using rte::SlabOrder;

// Doubling from a thin layer whose propagator exp(H tau0) is summed as a Taylor series (|H tau0| < 0.05):
// the discrete-ordinates generator H = [[M^-1 A, M^-1 B], [-M^-1 B, -M^-1 A]] of the same equations,
// so the two codes share nothing but the equations. Returns R^m, T^m (direct included).
struct Doubled {
    Matrix r, t;
};
Doubled doubling_reference(const OrderProblem& p, double tau) {
    const int n = p.streams.size();
    const auto& mu = p.streams.mu;
    const auto& w = p.streams.w;
    double mu_min = 1.0;
    for (double m : mu) mu_min = std::min(mu_min, m);
    int steps = 0;
    double tau0 = tau;
    while (tau0 > 0.02 * mu_min) {
        tau0 *= 0.5;
        ++steps;
    }
    Matrix h(2 * n, 2 * n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double a = (i == j ? 1.0 : 0.0) - 0.5 * p.omega * p.p_plus(i, j) * w[j];
            const double b = -0.5 * p.omega * p.p_minus(i, j) * w[j];
            h(i, j) = a / mu[i];
            h(i, n + j) = b / mu[i];
            h(n + i, j) = -b / mu[i];
            h(n + i, n + j) = -a / mu[i];
        }
    Matrix phi = Matrix::identity(2 * n), term = Matrix::identity(2 * n);
    for (int k = 1; k <= 30; ++k) {
        term = term * h;
        term *= tau0 / k;
        phi += term;
    }
    // [I+(tau0); I-(tau0)] = Phi [I+(0); I-(0)] with I-(0) = F, I+(tau0) = 0.
    Matrix p11(n, n), p12(n, n), p21(n, n), p22(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            p11(i, j) = phi(i, j), p12(i, j) = phi(i, n + j), p21(i, j) = phi(n + i, j), p22(i, j) = phi(n + i, n + j);
        }
    Matrix r = solve(p11, p12);
    r *= -1.0;
    Matrix t = p22 + p21 * r;
    for (int s = 0; s < steps; ++s) { // symmetric layer: R2 = R + T (I - R R)^-1 R T, T2 = T (I - R R)^-1 T
        const Matrix g = inverse(Matrix::identity(n) - r * r);
        const Matrix tg = t * g;
        r = r + tg * r * t;
        t = tg * t;
    }
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            r(i, j) /= 2.0 * w[j] * mu[j];
            t(i, j) /= 2.0 * w[j] * mu[j];
        }
    return {r, t};
}

OrderProblem problem(double omega, const std::vector<double>& beta, int m, int streams) {
    return rte::make_order_problem(beta, omega, m, rte::gauss_streams(streams));
}

double rel_diff(const Matrix& a, const Matrix& b) { return max_abs_diff(a, b) / std::max(1e-300, max_abs(b)); }

TEST(Slab, MatchesIndependentDoubling) {
    for (double omega : {0.5, 0.9, 0.999, 1.0})
        for (double tau : {0.01, 0.3, 2.0, 10.0})
            for (int m : {0, 1, 3}) {
                const OrderProblem p = problem(omega, hg_beta(0.6, 24), m, 12);
                const SlabOrder slab(p, tau);
                const Doubled ref = doubling_reference(p, tau);
                // T is a difference of two operators of the size of R + T (slab.cpp), so its error is
                // absolute, ~1e-16 of the larger of the two: judge both on that common scale.
                const double scale = std::max(max_abs(ref.r), max_abs(ref.t));
                EXPECT_LE(max_abs_diff(slab.reflection(), ref.r) / scale, 1e-10) << "omega " << omega << " tau " << tau << " m " << m;
                EXPECT_LE(max_abs_diff(slab.transmission(), ref.t) / scale, 1e-10) << "omega " << omega << " tau " << tau << " m " << m;
            }
}

TEST(Slab, IsReciprocal) {
    const SlabOrder slab(problem(0.95, hg_beta(0.8, 40), 2, 16), 1.7);
    const Matrix& r = slab.reflection();
    const Matrix& t = slab.transmission();
    EXPECT_LE(max_abs_diff(r, transpose(r)), 1e-12 * max_abs(r));
    EXPECT_LE(max_abs_diff(t, transpose(t)), 1e-12 * max_abs(t));
}

TEST(Slab, ConservesEnergyAtAlbedoOne) {
    // Every input stream's light is reflected or transmitted: sum_i q_i (R + T)(i, j) = 1.
    for (double tau : {1e-3, 0.5, 5.0, 200.0}) {
        const OrderProblem p = problem(1.0, hg_beta(0.7, 32), 0, 16);
        const SlabOrder slab(p, tau);
        for (int j = 0; j < 16; ++j) {
            double flux = 0.0;
            for (int i = 0; i < 16; ++i)
                flux += 2.0 * p.streams.w[i] * p.streams.mu[i] * (slab.reflection()(i, j) + slab.transmission()(i, j));
            EXPECT_NEAR(flux, 1.0, 1e-12) << "tau " << tau << " stream " << j;
        }
    }
}

TEST(Slab, ZeroThicknessIsTheIdentity) {
    const OrderProblem p = problem(0.9, hg_beta(0.5, 20), 0, 8);
    const SlabOrder slab(p, 0.0);
    EXPECT_LE(max_abs(slab.reflection()), 1e-14);
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j)
            EXPECT_NEAR(slab.transmission()(i, j) * 2.0 * p.streams.w[j] * p.streams.mu[j], i == j ? 1.0 : 0.0, 1e-13);
}

TEST(Slab, ThickLimitIsTheHalfSpace) {
    for (int m : {0, 1, 4}) {
        const OrderProblem p = problem(0.9, hg_beta(0.5, 30), m, 12);
        const SlabOrder slab(p, 500.0);
        const auto x = rte::solve_order(p, rte::Method::Doubling);
        EXPECT_LE(rel_diff(slab.reflection(), x.x), 1e-11) << "m " << m;
        // exp(-k tau) underflows; what is left is the rounding of T = (P - Q) / 2 (slab.cpp).
        EXPECT_LE(max_abs(slab.transmission()), 1e-12 * max_abs(x.x)) << "m " << m;
    }
}

TEST(Slab, RowsAtTheStreamsAreTheStreamsValues) {
    const OrderProblem p = problem(0.97, hg_beta(0.6, 30), 1, 10);
    const SlabOrder slab(p, 1.3);
    const std::vector<double> beta = hg_beta(0.6, 30);
    const rte::SlabRows rows = slab.rows(beta, p.streams.mu);
    Matrix diffuse = slab.transmission();
    for (int j = 0; j < 10; ++j)
        diffuse(j, j) -= std::exp(-1.3 / p.streams.mu[j]) / (2.0 * p.streams.w[j] * p.streams.mu[j]);
    EXPECT_LE(rel_diff(rows.r, slab.reflection()), 1e-11);
    EXPECT_LE(rel_diff(rows.t, diffuse), 1e-11);
}

TEST(Slab, BeamsAreReciprocalToRows) {
    // A beam from u_b seen at the streams equals light from the streams seen at u_b (R and T are
    // symmetric), and the off-stream block is symmetric; the block at the streams equals the matrices.
    const std::vector<double> beta = hg_beta(0.5, 30);
    for (double omega : {0.8, 1.0})
        for (double tau : {0.05, 1.0, 8.0}) {
            const OrderProblem p = problem(omega, beta, 0, 12);
            const SlabOrder slab(p, tau);
            const std::vector<double> u{0.003, 0.05, 0.31, 0.5, 0.77, 1.0};
            const rte::SlabRows rows = slab.rows(beta, u);
            const SlabOrder::Beams beams = slab.beams(beta, u);
            EXPECT_LE(rel_diff(beams.r_columns, transpose(rows.r)), 1e-10) << omega << " " << tau;
            EXPECT_LE(rel_diff(beams.t_columns, transpose(rows.t)), 1e-10) << omega << " " << tau;
            EXPECT_LE(rel_diff(beams.block.r, transpose(beams.block.r)), 1e-10) << omega << " " << tau;
            EXPECT_LE(rel_diff(beams.block.t, transpose(beams.block.t)), 1e-10) << omega << " " << tau;
            const SlabOrder::Beams at_streams = slab.beams(beta, p.streams.mu);
            EXPECT_LE(rel_diff(at_streams.block.r, slab.reflection()), 1e-10) << omega << " " << tau;
        }
}

TEST(Slab, OffStreamValuesConvergeWithTheStreams) {
    // Off the streams the evaluation is exact for the discrete problem; against a solve with four
    // times the streams it must agree to the quadrature error (isotropic, a moderate film).
    const std::vector<double> beta{1.0};
    const std::vector<double> u{0.02, 0.2, 0.6, 0.95};
    const OrderProblem coarse = problem(0.99, beta, 0, 16), fine = problem(0.99, beta, 0, 64);
    const SlabOrder a(coarse, 2.0), b(fine, 2.0);
    const SlabOrder::Beams ba = a.beams(beta, u), bb = b.beams(beta, u);
    EXPECT_LE(rel_diff(ba.block.r, bb.block.r), 1e-5);
    EXPECT_LE(rel_diff(ba.block.t, bb.block.t), 1e-5);
}

} // namespace
} // namespace brdf::test
