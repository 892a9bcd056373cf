// Delta-M (Wiscombe 1977, J. Atmos. Sci. 34, 1408, eqs. 5-7; docs/physics.md section 3): with chi_l =
// beta_l / (2l + 1) and L the first order dropped,
//   f = chi_L,  chi'_l = (chi_l - f) / (1 - f) for l < L,  omega' = (1 - f) omega / (1 - f omega).
// The scaled moments and f against that formula for Henyey-Greenstein (chi_l = g^l) and a two-lobe
// mixture, the documented exceptions (a series shorter than L; no forward peak), and the purpose of
// it all: a solve with delta-M (and the exact single scattering added back, Nakajima and Tanaka
// 1988) agrees with a solve at enough streams that nothing is truncated.

#include "rte_test_support.h"

#include <brdf/core/error.h>
#include <brdf/rte/phase.h>
#include <brdf/rte/reflection.h>

#include <gtest/gtest.h>
#include <test_support.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace {

using namespace brdf;
using namespace brdf::rte;

// The formula, written out independently of rte::delta_m.
void expect_wiscombe(const Medium& medium, int first_dropped, const DeltaM& got) {
    const auto chi = [&](int l) { return medium.beta[l] / (2.0 * l + 1.0); };
    const double f = chi(first_dropped);
    EXPECT_REL_NEAR(got.f, f, 1e-14);
    EXPECT_REL_NEAR(got.scaled.omega, (1.0 - f) * medium.omega / (1.0 - f * medium.omega), 1e-14);
    ASSERT_EQ(static_cast<int>(got.scaled.beta.size()), first_dropped);
    for (int l = 0; l < first_dropped; ++l) {
        SCOPED_TRACE(l);
        EXPECT_NEAR(got.scaled.beta[l], (2.0 * l + 1.0) * (chi(l) - f) / (1.0 - f), 1e-13 * (2.0 * l + 1.0));
    }
    EXPECT_EQ(got.scaled.beta[0], 1.0);
}

TEST(DeltaM, HenyeyGreensteinMomentsAndFractionAreWiscombes) {
    for (double g : {0.3, 0.8, 0.95})
        for (double omega : {0.5, 0.99, 1.0})
            for (int first_dropped : {4, 16, 32}) {
                SCOPED_TRACE(testing::Message() << "g " << g << " omega " << omega << " L " << first_dropped);
                const Medium medium{omega, test::hg_beta(g, 200)};
                const DeltaM d = delta_m(medium, first_dropped);
                expect_wiscombe(medium, first_dropped, d);
                // HG in closed form: f = g^L, chi'_l = (g^l - g^L) / (1 - g^L).
                EXPECT_REL_NEAR(d.f, std::pow(g, first_dropped), 1e-12);
                EXPECT_REL_NEAR(d.scaled.beta[1], 3.0 * (g - d.f) / (1.0 - d.f), 1e-12);
            }
}

TEST(DeltaM, TwoLobeMixtureMomentsAreWiscombes) {
    // 0.8 HG(0.9) + 0.2 HG(-0.4): forward peaked overall (beta_1 > 0) with an alternating part.
    std::vector<double> beta(120);
    for (int l = 0; l < 120; ++l) beta[l] = (2.0 * l + 1.0) * (0.8 * std::pow(0.9, l) + 0.2 * std::pow(-0.4, l));
    for (int first_dropped : {8, 20, 41}) {
        SCOPED_TRACE(first_dropped);
        const Medium medium{0.97, beta};
        expect_wiscombe(medium, first_dropped, delta_m(medium, first_dropped));
    }
}

TEST(DeltaM, ShortSeriesIsUnchanged) {
    const Medium medium{0.9, test::hg_beta(0.7, 10)};
    for (int first_dropped : {10, 11, 40}) {
        const DeltaM d = delta_m(medium, first_dropped);
        EXPECT_EQ(d.f, 0.0);
        EXPECT_EQ(d.scaled.omega, medium.omega);
        EXPECT_EQ(d.scaled.beta, medium.beta);
    }
}

TEST(DeltaM, BackwardPeakedIsTruncatedNotScaled) {
    // No forward peak to remove (beta_1 < 0): plain truncation, f = 0 (rte/phase.cpp says why).
    const Medium medium{0.95, test::hg_beta(-0.9, 200)};
    const DeltaM d = delta_m(medium, 16);
    EXPECT_EQ(d.f, 0.0);
    EXPECT_EQ(d.scaled.omega, medium.omega);
    ASSERT_EQ(d.scaled.beta.size(), 16u);
    for (int l = 0; l < 16; ++l) EXPECT_REL_NEAR(d.scaled.beta[l], medium.beta[l], 1e-15);
}

TEST(DeltaM, RefusesATruncationOrderBelowOne) {
    EXPECT_THROW(delta_m(Medium{0.5, test::hg_beta(0.5, 10)}, 0), InputError);
}

// The spread residual (what delta-M leaves out of the single scattering, seen through a Gaussian
// spread of directions) against the difference of the phase function and delta-M's own output
// (rte::delta_m: (1 - f) p' plus f times the forward delta), both spread, computed here term by term:
// at 180 degrees (a point of its grid) and at most the largest over a grid 20 times finer.
TEST(DeltaM, SpreadResidualIsThePhaseFunctionLessDeltaMsOwnOutput) {
    const Medium medium{0.9, test::hg_beta(0.9, 400)};
    for (const auto& [first_dropped, sigma] : {std::pair{32, 0.009}, std::pair{48, 0.009}, std::pair{32, 0.045}}) {
        SCOPED_TRACE(first_dropped);
        const DeltaM d = delta_m(medium, first_dropped);
        const int terms = static_cast<int>(std::ceil(std::sqrt(80.0) / sigma)) + 1;
        std::vector<double> spread(terms), residual(terms);
        for (int l = 0; l < terms; ++l) {
            const double beta = l < static_cast<int>(medium.beta.size()) ? medium.beta[l] : 0.0;
            const double kept = l < first_dropped ? (1.0 - d.f) * d.scaled.beta[l] : 0.0;
            const double damping = std::exp(-0.5 * l * (l + 1.0) * sigma * sigma);
            spread[l] = beta * damping;
            residual[l] = (beta - kept - d.f * (2.0 * l + 1.0)) * damping;
        }
        const auto ratio = [&](double theta) {
            return std::abs(phase_value(residual, std::cos(theta))) / phase_value(spread, std::cos(theta));
        };
        double finest = 0.0;
        for (int a = 0; a <= 1800; ++a) finest = std::max(finest, ratio(0.5 * std::numbers::pi * (1.0 + a / 1800.0)));
        const double got = spread_delta_m_residual(medium, first_dropped, sigma);
        EXPECT_GE(got, ratio(std::numbers::pi) * (1.0 - 1e-9));
        EXPECT_LE(got, finest * (1.0 + 1e-9));
        EXPECT_GT(got, 0.0);
    }
}

// It falls as more moments are kept and as the spread grows (a rough top's broader lobes average the
// truncation's ringing out), and is 0 where delta-M truncates nothing.
TEST(DeltaM, SpreadResidualFallsWithStreamsAndSpread) {
    const Medium medium{1.0, test::hg_beta(0.9, 400)};
    EXPECT_GT(spread_delta_m_residual(medium, 32, 0.009), spread_delta_m_residual(medium, 48, 0.009));
    EXPECT_GT(spread_delta_m_residual(medium, 48, 0.009), spread_delta_m_residual(medium, 64, 0.009));
    EXPECT_GT(spread_delta_m_residual(medium, 32, 0.009), 10.0 * spread_delta_m_residual(medium, 32, 0.12));
    EXPECT_EQ(spread_delta_m_residual(Medium{0.9, test::hg_beta(0.7, 10)}, 10, 0.01), 0.0);
    EXPECT_THROW(spread_delta_m_residual(medium, 32, 0.0), InputError);
}

Reflection solve(const Medium& medium, int streams) {
    ReflectionSettings settings;
    settings.streams = streams;
    settings.order_tolerance = 1e-7;
    settings.method = Method::Fast;
    StackSetup setup = setup_reflection(medium, Interface{1.0}, settings);
    const auto problems = order_problems(setup);
    auto solutions = solve_orders_cpu(problems, settings.method, settings.control, 2);
    return Reflection(std::move(setup), std::move(solutions));
}

// Largest relative BRDF difference over a spread of directions, small values compared on 1e-2 of the
// largest (their relative error is noise).
double disagreement(const Reflection& a, const Reflection& ref) {
    const double mus[] = {1.0, 0.8, 0.6, 0.4, 0.25, 0.1};
    const double phis[] = {0.0, 0.5 * std::numbers::pi, 0.9 * std::numbers::pi, std::numbers::pi};
    double largest = 0.0;
    for (double mi : mus)
        for (double mo : mus)
            for (double phi : phis) largest = std::max(largest, ref.brdf(mi, mo, phi));
    double worst = 0.0;
    for (double mi : mus)
        for (double mo : mus)
            for (double phi : phis) {
                const double r = ref.brdf(mi, mo, phi);
                worst = std::max(worst, std::abs(a.brdf(mi, mo, phi) - r) / std::max(r, 1e-2 * largest));
            }
    return worst;
}

TEST(DeltaM, SolveWithDeltaMAgreesWithOneWithout) {
    // A phase function that IS a 64-term series (HG 0.9 cut there): 32 streams integrate it exactly,
    // so that solve truncates nothing (f = 0); 12 and 16 streams drop 8 % and 3.4 % of it as forward
    // peak. Tolerances: the measured worst of the albedos with headroom 1.5; without the omega'
    // scaling or with f left in the moments the difference is several percent.
    for (double omega : {0.8, 1.0}) {
        SCOPED_TRACE(omega);
        const Medium medium{omega, test::hg_beta(0.9, 64)};
        const Reflection exact = solve(medium, 32);
        ASSERT_EQ(exact.setup().layers[0].truncated.f, 0.0);
        for (const auto& [streams, tolerance] : {std::pair{12, 2e-2}, std::pair{16, 7e-3}}) {
            SCOPED_TRACE(streams);
            const Reflection scaled = solve(medium, streams);
            ASSERT_GT(scaled.setup().layers[0].truncated.f, 0.03);
            const double d = disagreement(scaled, exact);
            std::printf("omega %.2f: %d streams (f %.4f) vs 32 (no delta-M): %.2e\n", omega, streams,
                        scaled.setup().layers[0].truncated.f, d);
            EXPECT_LE(d, tolerance);
        }
    }
}

} // namespace
