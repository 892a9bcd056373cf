// The nested radius rule for large spheres without sharp resonances (ensemble.cpp): against an
// independent brute-force distribution average of matting agents (miepython), against the panel
// rule (exact series on adaptive Gauss-Kronrod panels, ~100 times more accurate than its tolerance)
// where the automatic choice switches, under doubled resolution, and the progress callback.

#include <brdf/core/error.h>
#include <brdf/core/legendre.h>
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

// A caller that reads only the moments up to 128 and the phase function beyond the refracted cone
// (model/model.cpp, mie_accuracy: a smooth paint's tables) has the nested rule check only those:
// the 40 um matting agent then stops at half the radius nodes at most wavelengths (never more than
// the full test's), and what it reads is as accurate as asked: against the brute-force reference's
// moments, and against the full test refined once more.
TEST(NestedRule, ChecksOnlyWhatTheCallerReads) {
    std::ifstream in(test::source_dir() / "tests/reference/mie/matting_reference.json");
    ASSERT_TRUE(in) << "missing matting_reference.json";
    const nlohmann::json ref = nlohmann::json::parse(in);
    int checked = 0, halved = 0;
    for (const auto& c : ref["cases"]) {
        if (c["r_eff_um"].get<double>() != 40.0) continue;
        const double nm = c["wavelength_nm"].get<double>(), n_h = c["medium_index"].get<double>();
        const Complex m{c["particle_index"].get<double>(), 0.0};
        const SizeDistribution d = gamma(40.0, c["v_eff"].get<double>());
        SCOPED_TRACE(testing::Message() << nm << " nm");
        EnsembleOptions full;
        full.tolerance = 1e-5;
        EnsembleOptions reads = full;
        reads.checked_moments = 129;
        reads.checked_cosine = 2.0 / (n_h * n_h) - 1.0;
        reads.value_tolerance = 3e-5; // as model.cpp asks at "default" (mie_accuracy)
        const Ensemble e = ensemble(m, n_h, nm, d, reads);
        full.refinement = 2;
        const Ensemble fine = ensemble(m, n_h, nm, d, full);
        const int full_nodes = (fine.radius_nodes + 1) / 2; // the full test's, without the refinement
        EXPECT_LE(e.radius_nodes, full_nodes);
        if (2 * e.radius_nodes - 1 <= full_nodes) ++halved;
        EXPECT_LE(e.error_estimate, reads.tolerance);
        EXPECT_REL_NEAR(e.cext_um2, c["cext_um2"].get<double>(), reads.tolerance);
        EXPECT_NEAR(e.g, c["g"].get<double>(), reads.tolerance);
        const auto& beta = c["legendre"];
        for (std::size_t l = 0; l < beta.size(); ++l)
            EXPECT_NEAR(e.legendre[l] / (2.0 * l + 1.0), beta[l].get<double>() / (2.0 * l + 1.0), reads.tolerance)
                << "l = " << l;
        for (std::size_t l = 0; l < 129; ++l)
            EXPECT_NEAR(e.legendre[l] / (2.0 * l + 1.0), fine.legendre[l] / (2.0 * l + 1.0), reads.tolerance)
                << "l = " << l;
        // The values the single scattering reads, at 200 angles (the rule's test samples 64). What
        // they carry is aliasing, the level differences only estimate it (the finer rule has its
        // own, about half): within twice the tolerance.
        for (int i = 0; i < 200; ++i) {
            const double mu = -1.0 + (reads.checked_cosine + 1.0) * i / 199.0;
            EXPECT_NEAR(legendre_series(e.legendre, mu), legendre_series(fine.legendre, mu),
                        2.0 * reads.value_tolerance)
                << "mu = " << mu;
        }
        ++checked;
    }
    EXPECT_EQ(checked, 3);
    EXPECT_GE(halved, 2) << "the nodes were not halved";
    // The values are checked: asked for far more of them than of the moments, the rule goes on, as
    // far as the full test would (never further: their level differences carry aliasing).
    EnsembleOptions loose, tight;
    loose.tolerance = tight.tolerance = 1e-5;
    loose.checked_moments = tight.checked_moments = 129;
    loose.checked_cosine = tight.checked_cosine = -0.1;
    loose.value_tolerance = 1e-4;
    tight.value_tolerance = 1e-8;
    const Ensemble a = ensemble({1.46, 0.0}, 1.49, 550.0, gamma(5.0, 0.1), loose);
    const Ensemble b = ensemble({1.46, 0.0}, 1.49, 550.0, gamma(5.0, 0.1), tight);
    EXPECT_GT(b.radius_nodes, a.radius_nodes);
    EnsembleOptions every = loose;
    every.checked_moments = 0;
    EXPECT_EQ(b.radius_nodes, ensemble({1.46, 0.0}, 1.49, 550.0, gamma(5.0, 0.1), every).radius_nodes);
    EnsembleOptions bad;
    bad.checked_moments = -1;
    test::expect_error_mentions<InputError>([&] { ensemble({1.46, 0.0}, 1.49, 550.0, gamma(5.0, 0.1), bad); },
                                            "checked moments");
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
