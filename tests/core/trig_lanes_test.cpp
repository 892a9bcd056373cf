#include <brdf/core/trig_lanes.h>

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace brdf {
namespace {

// |a - b| in units of the last place of b.
double ulps(double a, double b) {
    const double ulp = std::nextafter(std::abs(b), INFINITY) - std::abs(b);
    return std::abs(a - b) / ulp;
}

TEST(TrigLanes, QuarterTurnSinCosIsWithinOneUlpOfLibm) {
    constexpr double half_pi = 0.5 * std::numbers::pi;
    std::vector<double> x{0.0, 1e-300, 1e-8, std::nextafter(0.0, -1.0), 0.25 * std::numbers::pi, std::nextafter(0.25 * std::numbers::pi, 1.0),
                          std::nextafter(0.25 * std::numbers::pi, 0.0), half_pi, std::nextafter(half_pi, 0.0),
                          std::nextafter(half_pi, 2.0)};
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> angle(0.0, half_pi);
    for (int k = 0; k < 200000; ++k) x.push_back(angle(rng));
    std::vector<double> s(x.size()), c(x.size());
    quarter_turn_sincos(x, s.data(), c.data());
    double worst_sin = 0.0, worst_cos = 0.0;
    for (std::size_t k = 0; k < x.size(); ++k) {
        worst_sin = std::max(worst_sin, ulps(s[k], std::sin(x[k])));
        worst_cos = std::max(worst_cos, ulps(c[k], std::cos(x[k])));
    }
    EXPECT_LE(worst_sin, 1.0);
    EXPECT_LE(worst_cos, 1.0);
    EXPECT_EQ(s[0], 0.0);
    EXPECT_EQ(c[0], 1.0);
    EXPECT_EQ(s[1], 1e-300);
}

// Odd lengths reach the clones' remainder loops: every element is written.
TEST(TrigLanes, EveryLengthIsComputedToTheEnd) {
    for (std::size_t n = 0; n < 20; ++n) {
        std::vector<double> x(n), s(n, NAN), c(n, NAN);
        for (std::size_t k = 0; k < n; ++k) x[k] = 0.07 * static_cast<double>(k + 1);
        quarter_turn_sincos(x, s.data(), c.data());
        for (std::size_t k = 0; k < n; ++k) {
            EXPECT_NEAR(s[k], std::sin(x[k]), 1e-15) << n << " " << k;
            EXPECT_NEAR(c[k], std::cos(x[k]), 1e-15) << n << " " << k;
        }
    }
}

} // namespace
} // namespace brdf
