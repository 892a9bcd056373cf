// Hansen and Travis (1974) size distributions: the published power-law range, moments against
// direct integration, the tail truncation criterion, and parameter validation.

#include <brdf/core/error.h>
#include <brdf/core/quadrature.h>
#include <brdf/mie/size_distribution.h>

#include "mie_test_support.h"
#include "test_support.h"

#include <cmath>
#include <functional>
#include <numbers>

namespace brdf::mie {
namespace {

constexpr double pi = std::numbers::pi;

// int_a^b f dr by composite 32-point Gauss-Legendre on `panels` pieces, geometric in r so that
// distributions spanning decades are resolved: far more than these smooth integrands need.
double integrate(const std::function<double(double)>& f, double a, double b, int panels = 400) {
    const auto rule = gauss_legendre(32);
    double sum = 0.0;
    const double ratio = std::pow(b / a, 1.0 / panels);
    double lo = a;
    for (int p = 0; p < panels; ++p) {
        const double hi = p + 1 == panels ? b : lo * ratio;
        const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
        for (std::size_t i = 0; i < rule->size(); ++i) sum += half * rule->w[i] * f(mid + half * rule->x[i]);
        lo = hi;
    }
    return sum;
}

// Mishchenko's spher.f reference run (docs/physics.md section 2): r_eff = 0.6, v_eff = 0.2 gives
// r1 = 0.245830, r2 = 1.194170 (six digits).
TEST(SizeDistribution, PowerLawRangeMatchesMishchenko) {
    const SizeDistribution d = power_law(0.6, 0.2);
    EXPECT_EQ(d.kind(), DistributionKind::PowerLaw);
    EXPECT_NEAR(d.r_min_um(), 0.245830, 5e-7);
    EXPECT_NEAR(d.r_max_um(), 1.194170, 5e-7);
    // The defining relations hold to rounding.
    EXPECT_REL_NEAR(d.r_min_um() + d.r_max_um(), 2.0 * 0.6 * 1.2, 1e-15);
    EXPECT_REL_NEAR((d.r_max_um() - d.r_min_um()) / std::log(d.r_max_um() / d.r_min_um()), 0.6,
                    1e-13);
}

// For each distribution the effective radius and variance recomputed from the number density over
// the integration range (H&T's definitions), the mean volume and area, and the normalisation of the
// cross-section and volume weighted densities agree with the closed forms. The truncated tails are
// 5e-9 each (size_distribution.h), so the moments agree to ~1e-8; v_eff involves r^4 n, whose tail
// beyond r_max is not bounded by the criterion and is larger (1.3e-6 for sigma_g = 2.5).
void check_moments(const SizeDistribution& d, double tol, double v_tol) {
    SCOPED_TRACE(d.describe());
    const double a = d.r_min_um(), b = d.r_max_um();
    const auto n = [&](double r) { return d.number_density(r); };
    const double m2 = integrate([&](double r) { return r * r * n(r); }, a, b);
    const double m3 = integrate([&](double r) { return r * r * r * n(r); }, a, b);
    const double r_eff = m3 / m2;
    const double v_eff =
        integrate([&](double r) { return (r - r_eff) * (r - r_eff) * r * r * n(r); }, a, b) /
        (r_eff * r_eff * m2);
    EXPECT_REL_NEAR(r_eff, d.r_eff_um(), tol);
    EXPECT_REL_NEAR(v_eff, d.v_eff(), v_tol);
    EXPECT_REL_NEAR(pi * m2, d.mean_area_um2(), tol);
    EXPECT_REL_NEAR(4.0 / 3.0 * pi * m3, d.mean_volume_um3(), tol);
}

TEST(SizeDistribution, MomentsMatchClosedForms) {
    check_moments(power_law(0.4, 0.3), 1e-12, 1e-11);
    check_moments(power_law(0.6, 0.2), 1e-12, 1e-11);
    check_moments(power_law(1.0, 1e-4), 1e-12, 1e-8);
    check_moments(power_law(0.2, 2.0), 1e-12, 1e-11);
    check_moments(gamma(0.4, 0.1), 2e-8, 1e-6);
    check_moments(gamma(0.4, 0.45), 2e-8, 1e-6);
    check_moments(gamma(1.0, 1e-3), 2e-8, 1e-6);
    check_moments(gamma(1.0, 1e-5), 2e-8, 1e-6);
    check_moments(lognormal(0.2, 1.5), 2e-8, 1e-6);
    check_moments(lognormal(0.2, 2.5), 2e-8, 2e-6);
    check_moments(lognormal(0.2, 1.01), 2e-8, 1e-6);
}

// The power law's number density is normalised over its support; gamma and log-normal over (0, inf),
// so that averages are per particle of the whole distribution.
TEST(SizeDistribution, NumberDensityIsNormalised) {
    const SizeDistribution p = power_law(0.4, 0.3);
    EXPECT_REL_NEAR(integrate([&](double r) { return p.number_density(r); }, p.r_min_um(),
                              p.r_max_um()),
                    1.0, 1e-13);
    EXPECT_EQ(p.number_density(0.5 * p.r_min_um()), 0.0);
    EXPECT_EQ(p.number_density(2.0 * p.r_max_um()), 0.0);
    const SizeDistribution g = gamma(0.4, 0.1); // shape 8: negligible number below r_min
    EXPECT_REL_NEAR(integrate([&](double r) { return g.number_density(r); }, 1e-6, 20.0), 1.0, 1e-9);
    const SizeDistribution l = lognormal(0.3, 1.6);
    EXPECT_REL_NEAR(integrate([&](double r) { return l.number_density(r); }, 1e-4, 1e3), 1.0, 1e-9);
}

// The truncation criterion: below r_min the cross-section-weighted tail, above r_max the
// volume-weighted tail, each 5e-9 (size_distribution.h).
TEST(SizeDistribution, TailsBeyondTheRangeAreBelowTheCriterion) {
    for (const SizeDistribution& d :
         {gamma(0.4, 0.1), gamma(0.4, 0.45), gamma(2.0, 1e-3), lognormal(0.2, 1.5),
          lognormal(0.2, 2.9)}) {
        SCOPED_TRACE(d.describe());
        const auto n = [&](double r) { return d.number_density(r); };
        const double m2 = d.mean_area_um2() / pi, m3 = d.mean_volume_um3() / (4.0 / 3.0 * pi);
        const double low = integrate([&](double r) { return r * r * n(r); }, 1e-12 * d.r_min_um(),
                                     d.r_min_um()) / m2;
        const double high = integrate([&](double r) { return r * r * r * n(r); }, d.r_max_um(),
                                      1e3 * d.r_max_um()) / m3;
        EXPECT_NEAR(low, tail_fraction, 0.05 * tail_fraction);
        EXPECT_NEAR(high, tail_fraction, 0.05 * tail_fraction);
    }
}

TEST(SizeDistribution, LognormalEffectiveRadiusAndVariance) {
    // H&T: r_eff = r_g exp(2.5 ln^2 sigma_g), v_eff = exp(ln^2 sigma_g) - 1.
    const SizeDistribution d = lognormal(0.25, 1.7);
    const double s2 = std::log(1.7) * std::log(1.7);
    EXPECT_REL_NEAR(d.r_eff_um(), 0.25 * std::exp(2.5 * s2), 1e-15);
    EXPECT_REL_NEAR(d.v_eff(), std::exp(s2) - 1.0, 1e-15);
}

TEST(SizeDistribution, MonodisperseIsOneRadius) {
    const SizeDistribution d = monodisperse(0.3);
    EXPECT_EQ(d.r_min_um(), 0.3);
    EXPECT_EQ(d.r_max_um(), 0.3);
    EXPECT_REL_NEAR(d.mean_volume_um3(), 4.0 / 3.0 * pi * 0.027, 1e-15);
    EXPECT_REL_NEAR(d.mean_area_um2(), pi * 0.09, 1e-15);
    EXPECT_EQ(d.describe(), "monodisperse(radius = 0.3 um)");
}

TEST(SizeDistribution, RejectsInvalidParametersWithClearMessages) {
    using test::expect_error_mentions;
    const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
    expect_error_mentions<InputError>([] { monodisperse(-0.2); }, "monodisperse: radius_um: must be > 0 (got -0.2)");
    expect_error_mentions<InputError>([] { monodisperse(0.0); }, "radius_um");
    expect_error_mentions<InputError>([&] { monodisperse(nan); }, "nan");
    expect_error_mentions<InputError>([&] { power_law(inf, 0.2); }, "r_eff_um");
    expect_error_mentions<InputError>([] { power_law(0.4, 0.0); }, "v_eff: must be in");
    expect_error_mentions<InputError>([] { power_law(0.4, 2.5); }, "(got 2.5)");
    expect_error_mentions<InputError>([&] { power_law(0.4, nan); }, "v_eff");
    expect_error_mentions<InputError>([] { gamma(0.4, 0.5); }, "not normalisable");
    expect_error_mentions<InputError>([] { gamma(0.4, -0.1); }, "got -0.1");
    expect_error_mentions<InputError>([] { gamma(-1.0, 0.1); }, "gamma: r_eff_um");
    expect_error_mentions<InputError>([] { lognormal(0.2, 1.0); }, "sigma_g: must be in (1, 3]");
    expect_error_mentions<InputError>([] { lognormal(0.2, 0.5); }, "(got 0.5)");
    expect_error_mentions<InputError>([] { lognormal(0.2, 3.5); }, "sigma_g");
    expect_error_mentions<InputError>([] { lognormal(0.2, 1.0001); }, "use monodisperse");
    expect_error_mentions<InputError>([] { lognormal(0.0, 1.5); }, "r_g_um");
}

// The spec parser reports these under each parameter's JSON path, and the constructors throw the same
// words: one source for the ranges.
TEST(SizeDistribution, ParameterProblemsNameTheSpecKeys) {
    const auto texts = [](DistributionKind kind, double p1, double p2) {
        std::vector<std::string> out;
        for (const ParameterProblem& p : parameter_problems(kind, p1, p2)) out.push_back(p.text());
        return out;
    };
    using V = std::vector<std::string>;
    EXPECT_EQ(texts(DistributionKind::Monodisperse, 0.25, 0.0), V{});
    EXPECT_EQ(texts(DistributionKind::PowerLaw, 0.4, 0.3), V{});
    EXPECT_EQ(texts(DistributionKind::Gamma, 0.4, 0.1), V{});
    EXPECT_EQ(texts(DistributionKind::Lognormal, 0.2, 1.5), V{});
    // Monodisperse ignores the second parameter.
    EXPECT_EQ(texts(DistributionKind::Monodisperse, 0.25, -7.0), V{});

    EXPECT_EQ(texts(DistributionKind::Monodisperse, 0.0, 0.0), V{"radius_um: must be > 0 (got 0)"});
    EXPECT_EQ(texts(DistributionKind::Monodisperse, std::nan(""), 0.0),
              V{"radius_um: must be a finite number > 0 (got nan)"});
    EXPECT_EQ(texts(DistributionKind::PowerLaw, -0.2, 3.0),
              (V{"r_eff_um: must be > 0 (got -0.2)", "v_eff: must be in [1e-06, 2] (got 3)"}));
    EXPECT_EQ(texts(DistributionKind::Gamma, 0.4, 0.6),
              V{"v_eff: must be in [1e-06, 0.5) for the gamma distribution (it is not normalisable "
                "at 0.5) (got 0.6)"});
    EXPECT_EQ(texts(DistributionKind::Gamma, 0.4, 0.0),
              V{"v_eff: must be in [1e-06, 0.5) for the gamma distribution (it is not normalisable "
                "at 0.5) (got 0)"});
    EXPECT_EQ(texts(DistributionKind::Lognormal, 0.2, 5.0), V{"sigma_g: must be in (1, 3] (got 5)"});
    EXPECT_EQ(texts(DistributionKind::Lognormal, 0.2, 1.0001),
              V{"sigma_g: is narrower than v_eff = 1e-06 (sigma_g >= 1.001); use monodisperse (got "
                "1.0001)"});
    // The boundaries: v_eff = 2 and sigma_g = 3 are allowed, 0.5 for gamma is not.
    EXPECT_EQ(texts(DistributionKind::PowerLaw, 0.4, 2.0), V{});
    EXPECT_EQ(texts(DistributionKind::Lognormal, 0.2, 3.0), V{});
    EXPECT_EQ(texts(DistributionKind::Gamma, 0.4, 0.5).size(), 1u);

    const auto problems = parameter_problems(DistributionKind::Lognormal, -1.0, 0.5);
    ASSERT_EQ(problems.size(), 2u);
    EXPECT_EQ(problems[0].key, "r_g_um");
    EXPECT_EQ(problems[1].key, "sigma_g");
    EXPECT_EQ(problems[1].fault, "must be in (1, 3] (got 0.5)");

    EXPECT_STREQ(parameter1_key(DistributionKind::Monodisperse), "radius_um");
    EXPECT_STREQ(parameter2_key(DistributionKind::Monodisperse), "");
    EXPECT_STREQ(parameter1_key(DistributionKind::Gamma), "r_eff_um");
    EXPECT_STREQ(parameter2_key(DistributionKind::PowerLaw), "v_eff");
    EXPECT_STREQ(parameter1_key(DistributionKind::Lognormal), "r_g_um");
    EXPECT_STREQ(parameter2_key(DistributionKind::Lognormal), "sigma_g");
}

TEST(SizeDistribution, ConstructorsThrowTheProblemsText) {
    try {
        lognormal(-1.0, 0.5);
        ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()),
                  "lognormal: r_g_um: must be > 0 (got -1); sigma_g: must be in (1, 3] (got 0.5)");
    }
    try {
        gamma(0.4, 0.6);
        ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()),
                  "gamma: v_eff: must be in [1e-06, 0.5) for the gamma distribution (it is not "
                  "normalisable at 0.5) (got 0.6)");
    }
}

} // namespace
} // namespace brdf::mie
