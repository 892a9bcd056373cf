// Counting and locating sharp Mie resonances (src/brdf/mie/resonance.h) against brute force.

#include <brdf/mie/mie.h>
#include <brdf/mie/resonance.h>

#include "test_support.h"

#include <cmath>
#include <functional>
#include <vector>

namespace brdf::mie {
namespace {

// All resonances of order n between x1 and x2: bisect until each interval holds one and no pole,
// then locate it (as the ensemble does).
std::vector<Resonance> find_all(double m, int n, bool electric, double x1, double x2) {
    std::vector<Resonance> out;
    std::function<void(double, double)> isolate = [&](double a, double b) {
        ModeSample sa, sb;
        sample_modes(m, a, n, sa);
        sample_modes(m, b, n, sb);
        const int count = count_resonances(sa, sb, n, electric);
        if (count <= 0) return;
        if (count == 1 && sa.zeros[n] == sb.zeros[n]) {
            if (auto r = locate_resonance(m, n, electric, a, b)) out.push_back(*r);
            return;
        }
        isolate(a, 0.5 * (a + b));
        isolate(0.5 * (a + b), b);
    };
    isolate(x1, x2);
    return out;
}

// Brute force: local maxima of |a_n|^2 (or |b_n|^2) above 0.99 on a grid of step h.
std::vector<double> scan_peaks(double m, int n, bool electric, double x1, double x2, double h) {
    std::vector<double> peaks;
    double prev2 = 0.0, prev = 0.0;
    for (double x = x1; x <= x2; x += h) {
        const Coefficients c = coefficients({m, 0.0}, x);
        const double v = n <= c.size() ? std::norm(electric ? c.a[n - 1] : c.b[n - 1]) : 0.0;
        if (prev > 0.99 && prev >= prev2 && prev > v) peaks.push_back(x - h);
        prev2 = prev;
        prev = v;
    }
    return peaks;
}

// For m = 2 and orders 15, 16 on [8, 17] (widths from 0.1 down to ~1e-4, all resolvable by a scan
// with step 1e-5), the counted and located resonances are exactly the peaks of the brute-force scan,
// at |a_n| = 1 to 1e-9, with the half width of |a_n|^2 = 1 / (1 + T^2) right to 5% for the sharp
// ones (for broad ones the Lorentzian picture is only approximate).
TEST(Resonance, CountsAndLocatesEveryResonanceOfAnOrder) {
    const double m = 2.0;
    for (int n = 15; n <= 16; ++n)
        for (const bool electric : {true, false}) {
            SCOPED_TRACE(testing::Message() << (electric ? "a_" : "b_") << n);
            const double lo = std::max(8.0, (n + 0.5) / m + 1e-3), hi = std::min(17.0, n + 0.5 - 0.05);
            if (!(hi > lo)) continue;
            ASSERT_TRUE(countable(m, n, lo, hi));
            const std::vector<Resonance> found = find_all(m, n, electric, lo, hi);
            const std::vector<double> peaks = scan_peaks(m, n, electric, lo, hi, 1e-5);
            ASSERT_EQ(found.size(), peaks.size());
            for (std::size_t i = 0; i < found.size(); ++i) {
                const Resonance& r = found[i];
                EXPECT_NEAR(r.x, peaks[i], 2e-5);
                const Coefficients c = coefficients({m, 0.0}, r.x);
                EXPECT_NEAR(std::norm(electric ? c.a[n - 1] : c.b[n - 1]), 1.0, 1e-9);
                if (r.hwhm < 1e-3) {
                    const Coefficients half = coefficients({m, 0.0}, r.x + r.hwhm);
                    EXPECT_NEAR(std::norm(electric ? half.a[n - 1] : half.b[n - 1]), 0.5, 0.025);
                }
            }
        }
}

// A very sharp one: b_30 of m = 2 near x = 17.94, half width ~2e-5, found from samples 1 apart.
TEST(Resonance, FindsSharpResonancesBetweenDistantSamples) {
    const std::vector<Resonance> found = find_all(2.0, 26, false, 17.5, 18.5);
    ASSERT_EQ(found.size(), 1u);
    EXPECT_NEAR(found[0].x, 17.93676, 1e-4);
    EXPECT_LT(found[0].hwhm, 1e-4);
    const Coefficients c = coefficients({2.0, 0.0}, found[0].x);
    EXPECT_NEAR(std::norm(c.b[25]), 1.0, 1e-9);
}

// Absorption damps a resonance: Im T > 0, peak |a_n|^2 = 1 / (1 + Im T)^2.
TEST(Resonance, DampingOfAnAbsorbingSphere) {
    const std::vector<Resonance> found = find_all(2.0, 26, false, 17.5, 18.5);
    ASSERT_EQ(found.size(), 1u);
    EXPECT_EQ(resonance_damping({2.0, 0.0}, found[0]), 0.0);
    const double damping = resonance_damping({2.0, 1e-4}, found[0]);
    EXPECT_GT(damping, 0.0);
    const Coefficients c = coefficients({2.0, 1e-4}, found[0].x);
    EXPECT_NEAR(std::norm(c.b[25]), 1.0 / ((1.0 + damping) * (1.0 + damping)), 1e-3);
}

TEST(Resonance, CountableOnlyBetweenTheTurningPoints) {
    EXPECT_TRUE(countable(2.0, 20, 12.0, 13.0));
    EXPECT_FALSE(countable(2.0, 20, 12.0, 21.0)); // x2 above n + 1/2
    EXPECT_FALSE(countable(2.0, 20, 9.0, 10.0));  // m x2 below n + 1/2: no interior oscillation
    EXPECT_FALSE(countable(2.0, 20, 13.0, 12.0));
}

} // namespace
} // namespace brdf::mie
