// Size-distribution averages: reduction to one sphere, physical units, cross-checks against an
// independent reference and a brute-force integration, and convergence under doubled resolution for
// the benchmark pigment and for a narrow distribution on a sharp resonance.

#include <brdf/core/error.h>
#include <brdf/core/quadrature.h>
#include <brdf/mie/ensemble.h>
#include <brdf/mie/kronrod.h>
#include <brdf/mie/phase_function.h>
#include <brdf/mie/resonance.h>

#include "mie_test_support.h"
#include "test_support.h"

#include <cmath>
#include <numbers>

namespace brdf::mie {
namespace {

using Complex = std::complex<double>;
constexpr double pi = std::numbers::pi;

// Rutile, the ordinary and extraordinary indices of DeVore (1951, JOSA 41, 416), averaged as
// (2 n_o + n_e) / 3 for random orientation (docs/physics.md section 7), k = 0 as in the benchmark.
Complex rutile(double wavelength_nm) {
    const double l2 = wavelength_nm * wavelength_nm * 1e-6;
    const double n_o = std::sqrt(5.913 + 0.2441 / (l2 - 0.0803));
    const double n_e = std::sqrt(7.197 + 0.3322 / (l2 - 0.0843));
    return {(2.0 * n_o + n_e) / 3.0, 0.0};
}

// The 15-point Kronrod rule the ensemble integrates with (kronrod.h, constants from QUADPACK) is
// exact for polynomials of degree 22, its embedded Gauss rule for degree 13 with the nodes of
// gauss_legendre(7).
TEST(Ensemble, KronrodRuleIsExact) {
    using detail::gauss_w;
    using detail::kronrod_w;
    using detail::kronrod_x;
    for (int k = 0; k <= 22; ++k) {
        double kronrod = k == 0 ? kronrod_w[7] : 0.0, gauss = k == 0 ? gauss_w[3] : 0.0;
        for (int i = 0; i < 7; ++i) {
            const double v = std::pow(kronrod_x[i], k) * (k % 2 ? 0.0 : 2.0);
            kronrod += kronrod_w[i] * v;
            if (i % 2 == 1) gauss += gauss_w[i / 2] * v;
        }
        const double exact = k % 2 ? 0.0 : 2.0 / (k + 1);
        EXPECT_NEAR(kronrod, exact, 2e-16) << "k = " << k;
        if (k <= 13) {
            EXPECT_NEAR(gauss, exact, 2e-16) << "k = " << k;
        }
    }
    const auto g7 = gauss_legendre(7);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(g7->x[6 - i], kronrod_x[2 * i + 1], 1e-16);
}

// A monodisperse "distribution" is exactly the single sphere, with the size parameter formed from
// the wavelength in the binder, x = 2 pi r n_h / lambda (docs/physics.md section 1).
TEST(Ensemble, MonodisperseIsExactlyTheSphere) {
    const Complex particle(2.7, 0.01);
    const double n_h = 1.5, wavelength = 550.0, radius = 0.25;
    const Ensemble e = ensemble(particle, n_h, wavelength, monodisperse(radius));
    const double x = 2.0 * pi * radius * n_h / (wavelength * 1e-3);
    const Sphere s = sphere(particle / n_h, x);
    EXPECT_EQ(e.m, particle / n_h);
    EXPECT_REL_NEAR(e.x_max, x, 1e-15);
    EXPECT_REL_NEAR(e.qext, s.q.qext, 1e-15);
    EXPECT_REL_NEAR(e.qsca, s.q.qsca, 1e-15);
    EXPECT_REL_NEAR(e.qabs, s.q.qabs, 1e-15);
    EXPECT_REL_NEAR(e.qback, s.q.qback, 1e-15);
    EXPECT_REL_NEAR(e.g, s.q.g, 1e-15);
    EXPECT_REL_NEAR(e.albedo, s.albedo, 1e-15);
    EXPECT_EQ(e.legendre, s.legendre);
    EXPECT_REL_NEAR(e.cext_um2, s.q.qext * pi * radius * radius, 1e-15);
    EXPECT_EQ(e.radius_nodes, 1);
    EXPECT_REL_NEAR(e.mean_volume_um3, 4.0 / 3.0 * pi * std::pow(radius, 3), 1e-15);
}

// Against tests/reference/mie/ensemble_reference.py (miepython, an independent Mie code, and the
// distributions written out independently there): an absorbing pigment (k = 0.05: no sharp
// resonances, so that the reference's plain quadrature converges to 1e-12).
TEST(Ensemble, MatchesIndependentReference) {
    std::ifstream in(test::source_dir() / "tests/reference/mie/ensemble_reference.json");
    ASSERT_TRUE(in) << "missing ensemble_reference.json";
    const nlohmann::json ref = nlohmann::json::parse(in);
    const Complex particle(ref["particle_index"][0].get<double>(), ref["particle_index"][1].get<double>());
    const double n_h = ref["medium_index"].get<double>(), wavelength = ref["wavelength_nm"].get<double>();
    int checked = 0;
    for (const auto& c : ref["cases"]) {
        const std::string name = c["distribution"];
        const double p1 = c["parameters"][0].get<double>(), p2 = c["parameters"][1].get<double>();
        const SizeDistribution d = name == "power_law" ? power_law(p1, p2)
                                   : name == "gamma"   ? gamma(p1, p2)
                                                       : lognormal(p1, p2);
        SCOPED_TRACE(d.describe());
        const Ensemble e = ensemble(particle, n_h, wavelength, d);
        // The tolerance (1e-6) bounds the radius integration; the references agree to 1e-9.
        EXPECT_REL_NEAR(e.cext_um2, c["cext_um2"].get<double>(), 1e-8);
        EXPECT_REL_NEAR(e.csca_um2, c["csca_um2"].get<double>(), 1e-8);
        EXPECT_REL_NEAR(e.cabs_um2, c["cabs_um2"].get<double>(), 1e-8);
        EXPECT_NEAR(e.g, c["g"].get<double>(), 1e-8);
        EXPECT_NEAR(e.albedo, c["albedo"].get<double>(), 1e-8);
        ++checked;
    }
    EXPECT_EQ(checked, 3);
}

// Against a brute-force integration written out here (composite Gauss-Legendre in radius with many
// more nodes than needed, straight from the single-sphere functions), including the Legendre moments:
// one absorbing and one air-void (m < 1, no internal reflection, no sharp resonances) case per kind.
struct Brute {
    double cext = 0.0, csca = 0.0, cabs = 0.0, g = 0.0;
    std::vector<double> legendre;
};

Brute brute_force(Complex particle, double n_h, double wavelength, const SizeDistribution& d) {
    const double k = 2.0 * pi * n_h / (wavelength * 1e-3);
    const Complex m = particle / n_h;
    PhaseFunctionAccumulator phase(series_length(k * d.r_max_um()));
    const auto rule = gauss_legendre(24);
    const int panels = 600;
    double ext = 0.0, sca = 0.0, abs = 0.0, gsca = 0.0;
    for (int p = 0; p < panels; ++p) {
        // uniform in ln r: the log-normal spans decades
        const double lo = d.r_min_um() * std::pow(d.r_max_um() / d.r_min_um(), double(p) / panels);
        const double hi = d.r_min_um() * std::pow(d.r_max_um() / d.r_min_um(), double(p + 1) / panels);
        for (std::size_t i = 0; i < rule->size(); ++i) {
            const double r = 0.5 * (lo + hi) + 0.5 * (hi - lo) * rule->x[i];
            const double w = 0.5 * (hi - lo) * rule->w[i] * d.number_density(r);
            const Coefficients c = coefficients(m, k * r);
            const Efficiencies q = efficiencies(c);
            const double area = pi * r * r;
            ext += w * area * q.qext;
            sca += w * area * q.qsca;
            abs += w * area * q.qabs;
            gsca += w * area * q.qsca * q.g;
            phase.add(c, w);
        }
    }
    return {ext, sca, abs, gsca / sca, phase.legendre()};
}

TEST(Ensemble, MatchesBruteForceIntegration) {
    struct Case {
        Complex particle;
        double n_h;
        SizeDistribution d;
    };
    const Case cases[] = {{{2.0, 0.05}, 1.5, power_law(0.4, 0.3)},
                          {{2.0, 0.05}, 1.5, gamma(0.3, 0.05)},
                          {{2.0, 0.05}, 1.5, lognormal(0.15, 1.4)},
                          {{1.0, 0.0}, 1.5, power_law(0.5, 0.2)},
                          {{1.0, 0.0}, 1.5, gamma(0.5, 0.1)},
                          {{1.0, 0.0}, 1.5, lognormal(0.3, 1.5)}};
    for (const Case& c : cases) {
        SCOPED_TRACE(testing::Message() << c.particle << " " << c.d.describe());
        const Ensemble e = ensemble(c.particle, c.n_h, 550.0, c.d);
        const Brute b = brute_force(c.particle, c.n_h, 550.0, c.d);
        EXPECT_REL_NEAR(e.cext_um2, b.cext, 1e-8);
        EXPECT_REL_NEAR(e.csca_um2, b.csca, 1e-8);
        if (c.particle.imag() > 0.0) {
            EXPECT_REL_NEAR(e.cabs_um2, b.cabs, 1e-8);
        } else {
            EXPECT_EQ(e.cabs_um2, 0.0);
            EXPECT_EQ(e.cext_um2, e.csca_um2);
        }
        EXPECT_NEAR(e.g, b.g, 1e-8);
        ASSERT_GE(e.legendre.size(), 12u);
        for (std::size_t l = 0; l < 12; ++l)
            EXPECT_NEAR(e.legendre[l], b.legendre[l], 1e-8 * (2.0 * l + 1.0)) << "l = " << l;
    }
}

// The ensemble's derived quantities are consistent.
TEST(Ensemble, DerivedQuantitiesAreConsistent) {
    const SizeDistribution d = gamma(0.3, 0.2);
    const Ensemble e = ensemble({2.4, 0.02}, 1.5, 450.0, d);
    EXPECT_REL_NEAR(e.qext, e.cext_um2 / d.mean_area_um2(), 1e-15);
    EXPECT_REL_NEAR(e.qsca, e.csca_um2 / d.mean_area_um2(), 1e-15);
    EXPECT_REL_NEAR(e.cext_um2, e.csca_um2 + e.cabs_um2, 1e-15);
    EXPECT_REL_NEAR(e.albedo, e.csca_um2 / e.cext_um2, 1e-15);
    EXPECT_GT(e.cabs_um2, 0.0);
    EXPECT_EQ(e.legendre[0], 1.0);
    EXPECT_NEAR(e.legendre[1], 3.0 * e.g, 1e-10);
    EXPECT_EQ(e.r_min_um, d.r_min_um());
    EXPECT_EQ(e.r_max_um, d.r_max_um());
    EXPECT_EQ(e.mean_volume_um3, d.mean_volume_um3());
    EXPECT_GT(e.radius_nodes, 100);
    EXPECT_LE(e.error_estimate, 1e-6);
}

// Doubling every panel's points (EnsembleOptions::refinement = 2) must change <Cext>, <Csca> (relative),
// g and the Legendre moments chi_l = beta_l / (2l + 1) (absolute; |chi_l| <= 1) by less than the
// tolerance.
void expect_converged(const Ensemble& e, const Ensemble& doubled, double tol) {
    EXPECT_LT(std::abs(doubled.cext_um2 / e.cext_um2 - 1.0), tol);
    EXPECT_LT(std::abs(doubled.csca_um2 / e.csca_um2 - 1.0), tol);
    if (e.cabs_um2 > 0.0) {
        EXPECT_LT(std::abs(doubled.cabs_um2 / e.cabs_um2 - 1.0), tol);
    }
    EXPECT_LT(std::abs(doubled.g - e.g), tol);
    const std::size_t count = std::min<std::size_t>(16, std::min(e.legendre.size(), doubled.legendre.size()));
    for (std::size_t l = 0; l < count; ++l)
        EXPECT_LT(std::abs(doubled.legendre[l] - e.legendre[l]) / (2.0 * l + 1.0), tol) << "l = " << l;
}

// (a) The seed material: rutile (k = 0, full of sharp resonances) in a binder of index 1.5,
// power law r_eff = 0.4 um, v_eff = 0.3, across the visible.
TEST(EnsembleConvergence, RutilePowerLawStopsChangingWhenResolutionDoubles) {
    const SizeDistribution d = power_law(0.4, 0.3);
    for (const double wavelength : {380.0, 450.0, 550.0, 650.0, 780.0}) {
        SCOPED_TRACE(testing::Message() << wavelength << " nm");
        EnsembleOptions options;
        const Ensemble e = ensemble(rutile(wavelength), 1.5, wavelength, d, options);
        options.refinement = 2;
        const Ensemble doubled = ensemble(rutile(wavelength), 1.5, wavelength, d, options);
        EXPECT_EQ(doubled.radius_nodes, 2 * e.radius_nodes);
        EXPECT_GT(e.resonances, 10); // sharp resonances were found and integrated
        expect_converged(e, doubled, options.tolerance);
    }
}

// (b) A narrow gamma distribution (v_eff = 1e-3 and 1e-4) centred on a sharp resonance of a
// non-absorbing m = 1.5 sphere: a_40 at x = 30.924 (half width 2.3e-5 in x), located here with
// resonance.h. Its contribution alone exceeds twice the tolerance, so a rule that missed it would
// fail; the ensemble must resolve it and stop changing.
TEST(EnsembleConvergence, NarrowGammaOnASharpResonanceStopsChanging) {
    const double m = 1.5;
    ModeSample a, b;
    sample_modes(m, 30.8, 40, a);
    sample_modes(m, 31.0, 40, b);
    ASSERT_EQ(count_resonances(a, b, 40, true), 1);
    const auto r = locate_resonance(m, 40, true, 30.8, 31.0);
    ASSERT_TRUE(r.has_value());
    EXPECT_NEAR(r->x, 30.9242280555, 1e-8);
    EXPECT_NEAR(r->hwhm, 2.335e-5, 0.01e-5);

    const double wavelength = 500.0, n_h = 1.0;
    const double k = 2.0 * pi * n_h / (wavelength * 1e-3);
    for (const double v_eff : {1e-3, 1e-4}) {
        SCOPED_TRACE(testing::Message() << "v_eff = " << v_eff);
        const SizeDistribution d = gamma(r->x / k, v_eff);
        EnsembleOptions options;
        const Ensemble e = ensemble({m, 0.0}, n_h, wavelength, d, options);
        options.refinement = 2;
        const Ensemble doubled = ensemble({m, 0.0}, n_h, wavelength, d, options);
        expect_converged(e, doubled, options.tolerance);
        EXPECT_GE(e.resonances, 1);

        // The resonance's own share of <Csca>: (2/x^2)(2n+1)|a_n|^2 w(x) over +-1000 half widths,
        // integrated finely.
        const auto rule = gauss_legendre(64);
        double share = 0.0;
        const double lo = r->x - 1000.0 * r->hwhm, hi = r->x + 1000.0 * r->hwhm;
        for (int p = 0; p < 400; ++p) {
            const double p0 = lo + (hi - lo) * p / 400.0, p1 = lo + (hi - lo) * (p + 1) / 400.0;
            for (std::size_t i = 0; i < rule->size(); ++i) {
                const double x = 0.5 * (p0 + p1) + 0.5 * (p1 - p0) * rule->x[i];
                const double radius = x / k;
                const double w = 0.5 * (p1 - p0) * rule->w[i] * d.number_density(radius) / k *
                                 pi * radius * radius;
                share += w * 2.0 / (x * x) * 81.0 * std::norm(coefficients({m, 0.0}, x).a[39]);
            }
        }
        EXPECT_GT(share / e.csca_um2, 2.0 * options.tolerance);
    }
}

// Weak absorption: the resonances then dominate <Cabs>, which must converge relative to itself.
TEST(EnsembleConvergence, WeaklyAbsorbingRutileConvergesInAbsorption) {
    const SizeDistribution d = power_law(0.4, 0.3);
    EnsembleOptions options;
    const Ensemble e = ensemble({2.9, 1e-4}, 1.5, 400.0, d, options);
    options.refinement = 2;
    const Ensemble doubled = ensemble({2.9, 1e-4}, 1.5, 400.0, d, options);
    EXPECT_GT(e.cabs_um2, 0.0);
    expect_converged(e, doubled, options.tolerance);
}

TEST(Ensemble, RejectsInvalidInputs) {
    using test::expect_error_mentions;
    const SizeDistribution d = power_law(0.4, 0.3);
    expect_error_mentions<InputError>([&] { ensemble({2.7, -0.01}, 1.5, 550.0, d); }, "absorption");
    expect_error_mentions<InputError>([&] { ensemble({0.0, 0.0}, 1.5, 550.0, d); }, "real part > 0");
    expect_error_mentions<InputError>([&] { ensemble({2.7, 0.0}, 0.0, 550.0, d); }, "medium index");
    expect_error_mentions<InputError>([&] { ensemble({2.7, 0.0}, 1.5, std::nan(""), d); }, "wavelength");
    expect_error_mentions<InputError>([&] { ensemble({2.7, 0.0}, 1.5, -550.0, d); }, "-550");
    EnsembleOptions bad;
    bad.tolerance = 0.0;
    expect_error_mentions<InputError>([&] { ensemble({2.7, 0.0}, 1.5, 550.0, d, bad); }, "tolerance");
    bad = {};
    bad.refinement = 0;
    expect_error_mentions<InputError>([&] { ensemble({2.7, 0.0}, 1.5, 550.0, d, bad); }, "refinement");
    // 5 mm spheres: x ~ 1e5 at the largest radius of the distribution.
    expect_error_mentions<LimitError>([&] { ensemble({2.7, 0.0}, 1.5, 550.0, power_law(5000.0, 0.1)); },
                                      "exceeds the supported maximum");
}

} // namespace
} // namespace brdf::mie
