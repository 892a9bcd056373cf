// The nested radius rule for large spheres without sharp resonances (ensemble.cpp): against an
// independent brute-force distribution average of matting agents (miepython), against the panel
// rule (exact series on adaptive Gauss-Kronrod panels, ~100 times more accurate than its tolerance)
// where the automatic choice switches, under doubled resolution, and the progress callback.

#include <brdf/core/error.h>
#include <brdf/mie/ensemble.h>

#include "mie_test_support.h"
#include "test_support.h"

#include <cmath>
#include <fstream>
#include <string>

namespace brdf::mie {
namespace {

using Complex = std::complex<double>;

/// Largest differences between two ensembles: cross sections relative, g and chi_l = beta_l/(2l+1)
/// absolute over every moment either has.
struct Difference {
    double cross = 0.0, g = 0.0, chi = 0.0;
    int worst_l = 0;
};

Difference difference(const Ensemble& a, const Ensemble& b) {
    Difference d;
    d.cross =
        std::max({std::abs(a.cext_um2 / b.cext_um2 - 1.0), std::abs(a.csca_um2 / b.csca_um2 - 1.0),
                  b.cabs_um2 > 0.0 ? std::abs(a.cabs_um2 / b.cabs_um2 - 1.0) : 0.0});
    d.g = std::abs(a.g - b.g);
    for (std::size_t l = 0; l < std::max(a.legendre.size(), b.legendre.size()); ++l) {
        const double x = l < a.legendre.size() ? a.legendre[l] : 0.0;
        const double y = l < b.legendre.size() ? b.legendre[l] : 0.0;
        const double chi = std::abs(x - y) / (2.0 * l + 1.0);
        if (chi > d.chi) d.chi = chi, d.worst_l = static_cast<int>(l);
    }
    return d;
}

// Matting agents, silica spheres in acrylic (m ~ 0.98), gamma distributions r_eff = 5 and 40 um,
// v_eff = 0.1, at 450, 550, 700 nm, against tests/reference/mie/mie_reference.py matting:
// miepython's series, a brute-force composite Gauss rule over 2160 radii (converged to the
// "convergence" it states) and an exact angular rule for the first 17 moments. At the tolerance
// "default" accuracy asks of Mie (1e-5, model/model.cpp) every quantity must agree within it.
TEST(NestedRule, MattingAgentsMatchBruteForceReference) {
    std::ifstream in(test::source_dir() / "tests/reference/mie/matting_reference.json");
    ASSERT_TRUE(in) << "missing matting_reference.json";
    const nlohmann::json ref = nlohmann::json::parse(in);
    int checked = 0;
    for (const auto& c : ref["cases"]) {
        const double r_eff = c["r_eff_um"].get<double>(), nm = c["wavelength_nm"].get<double>();
        SCOPED_TRACE(testing::Message() << "r_eff " << r_eff << " um, " << nm << " nm");
        ASSERT_LT(c["convergence"].get<double>(), 1e-6); // good enough to judge a 1e-5 tolerance by
        EnsembleOptions options;
        options.tolerance = 1e-5;
        const Ensemble e =
            ensemble({c["particle_index"].get<double>(), 0.0}, c["medium_index"].get<double>(), nm,
                     gamma(r_eff, c["v_eff"].get<double>()), options);
        EXPECT_EQ(e.rule, RadiusRule::nested);
        EXPECT_LE(e.error_estimate, options.tolerance);
        EXPECT_REL_NEAR(e.qext, c["qext"].get<double>(), options.tolerance);
        EXPECT_REL_NEAR(e.qsca, c["qsca"].get<double>(), options.tolerance);
        EXPECT_REL_NEAR(e.cext_um2, c["cext_um2"].get<double>(), options.tolerance);
        EXPECT_NEAR(e.g, c["g"].get<double>(), options.tolerance);
        const auto& beta = c["legendre"];
        ASSERT_GE(e.legendre.size(), beta.size());
        for (std::size_t l = 0; l < beta.size(); ++l)
            EXPECT_NEAR(e.legendre[l] / (2.0 * l + 1.0), beta[l].get<double>() / (2.0 * l + 1.0),
                        options.tolerance)
                << "l = " << l;
        ++checked;
    }
    EXPECT_EQ(checked, 6);
}

// Where the automatic choice uses the nested rule, it must agree with the panel rule within the
// tolerance in every quantity, every Legendre moment included (the panels' own error is ~100 times
// smaller: MatchesBruteForceIntegration in ensemble_test.cpp). Cases around the switch
// (x_max = nested_rule_min_size_parameter) and above it: matting agents (m < 1), air voids, an
// absorbing pigment, each distribution kind (the power law uses the tanh-sinh map).
TEST(NestedRule, AgreesWithPanelsWithinTolerance) {
    struct Case {
        Complex particle;
        double n_h, wavelength_nm;
        SizeDistribution d;
    };
    const Case cases[] = {
        {{1.4599, 0.0}, 1.4926, 550.0, gamma(2.0, 0.1)},     // x_max ~ 140 (below the switch)
        {{1.4599, 0.0}, 1.4926, 550.0, gamma(3.0, 0.1)},     // x_max ~ 210
        {{1.4599, 0.0}, 1.4926, 450.0, power_law(5.0, 0.1)}, // x_max ~ 200, finite support
        {{1.0, 0.0}, 1.5, 550.0, lognormal(1.0, 1.5)},       // air voids, x_max ~ 220
        {{1.9, 0.05}, 1.5, 600.0, gamma(6.0, 0.2)},          // absorbing, x_max ~ 650
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(testing::Message() << c.particle << " in " << c.n_h << ", " << c.d.describe());
        for (const double tol : {1e-5, 1e-6}) {
            SCOPED_TRACE(testing::Message() << "tolerance " << tol);
            EnsembleOptions options;
            options.tolerance = 1e-2 * tol;
            options.rule = RadiusRule::panels;
            const Ensemble panels = ensemble(c.particle, c.n_h, c.wavelength_nm, c.d, options);
            options.tolerance = tol;
            options.rule = RadiusRule::nested;
            const Ensemble nested = ensemble(c.particle, c.n_h, c.wavelength_nm, c.d, options);
            EXPECT_EQ(nested.rule, RadiusRule::nested);
            EXPECT_LE(nested.error_estimate, tol);
            const Difference d = difference(nested, panels);
            EXPECT_LT(d.cross, tol);
            EXPECT_LT(d.g, tol);
            EXPECT_LT(d.chi, tol) << "worst at l = " << d.worst_l;
            // The estimate is pessimistic but not absurdly so: within 30 times the true error.
            EXPECT_LT(nested.error_estimate, 30.0 * std::max({d.cross, d.g, d.chi, 1e-3 * tol}));
        }
    }
}

TEST(NestedRule, AutomaticChoice) {
    const auto rule_of = [](Complex particle, double n_h, const SizeDistribution& d) {
        return ensemble(particle, n_h, 550.0, d).rule;
    };
    // Large and without sharp resonances: nested.
    EXPECT_EQ(rule_of({1.46, 0.0}, 1.49, gamma(5.0, 0.1)), RadiusRule::nested);
    EXPECT_EQ(rule_of({2.0, 0.05}, 1.5, gamma(5.0, 0.1)), RadiusRule::nested);
    // Small: panels.
    EXPECT_EQ(rule_of({1.46, 0.0}, 1.49, gamma(0.5, 0.1)), RadiusRule::panels);
    // Sharp resonances (Re m > 1, k/n < 1e-2): panels, and the nested rule is refused.
    EXPECT_EQ(rule_of({2.0, 0.0}, 1.5, gamma(1.0, 0.1)), RadiusRule::panels);
    EnsembleOptions options;
    options.rule = RadiusRule::nested;
    test::expect_error_mentions<InputError>(
        [&] {
            ensemble({2.0, 0.0}, 1.5, 550.0, gamma(1.0, 0.1), options);
        },
        "sharp resonances");
    test::expect_error_mentions<InputError>(
        [&] {
            ensemble({1.46, 0.0}, 1.49, 550.0, monodisperse(10.0), options);
        },
        "size distribution");
}

// refinement = 2 halves the step once more (twice the nodes, as for the panels); the results must
// not move by more than the tolerance.
TEST(NestedRule, StopsChangingWhenResolutionDoubles) {
    const SizeDistribution d = gamma(10.0, 0.1);
    EnsembleOptions options;
    options.tolerance = 1e-5;
    const Ensemble e = ensemble({1.4599, 0.0}, 1.4926, 500.0, d, options);
    options.refinement = 2;
    const Ensemble doubled = ensemble({1.4599, 0.0}, 1.4926, 500.0, d, options);
    ASSERT_EQ(e.rule, RadiusRule::nested);
    EXPECT_EQ(doubled.radius_nodes, 2 * e.radius_nodes - 1);
    const Difference diff = difference(doubled, e);
    EXPECT_LT(diff.cross, options.tolerance);
    EXPECT_LT(diff.g, options.tolerance);
    EXPECT_LT(diff.chi, options.tolerance) << "worst at l = " << diff.worst_l;
}

// Both rules report progress: fractions in [0, 1], never decreasing, the last one 1.
TEST(NestedRule, ReportsProgress) {
    for (const double r_eff : {5.0, 0.4}) { // nested, then panels
        SCOPED_TRACE(testing::Message() << "r_eff " << r_eff);
        std::vector<double> seen;
        EnsembleOptions options;
        options.progress = [&](double fraction) { seen.push_back(fraction); };
        const Ensemble e = ensemble({1.4599, 0.0}, 1.4926, 450.0, gamma(r_eff, 0.1), options);
        EXPECT_EQ(e.rule, r_eff > 1.0 ? RadiusRule::nested : RadiusRule::panels);
        ASSERT_GE(seen.size(), 2u);
        for (std::size_t i = 0; i < seen.size(); ++i) {
            EXPECT_GE(seen[i], 0.0);
            EXPECT_LE(seen[i], 1.0);
            if (i > 0) {
                EXPECT_GE(seen[i], seen[i - 1]);
            }
        }
        EXPECT_EQ(seen.back(), 1.0);
    }
}

} // namespace
} // namespace brdf::mie
