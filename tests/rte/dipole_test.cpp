// The Jensen et al. 2001 dipole diffusion BRDF plus single scattering (rte/dipole.h), kept as a
// comparison model: its formulas, energy bounds, reciprocity, and the known directions of its bias
// against the exact solution (Chandrasekhar's isotropic H-function oracle and our solver).

#include "rte_test_support.h"

#include <brdf/rte/dipole.h>
#include <brdf/rte/reflection.h>
#include <test_support.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace brdf::test {
namespace {

TEST(Dipole, Formulas) {
    EXPECT_EQ(rte::dipole_fresnel_dr(1.0), 0.0);
    EXPECT_NEAR(rte::dipole_fresnel_dr(1.5), -1.44 / 2.25 + 0.71 / 1.5 + 0.668 + 0.0636 * 1.5, 1e-15);
    EXPECT_NEAR(rte::dipole_reduced_albedo(0.9, 0.5), 0.45 / 0.55, 1e-15);
    EXPECT_EQ(rte::dipole_reduced_albedo(1.0, 0.9), 1.0);
    // alpha' = 1: R_d = 1 (no absorption, everything diffuses out); alpha' = 0: nothing.
    EXPECT_NEAR(rte::dipole_rd(1.0, 1.0), 1.0, 1e-15);
    EXPECT_NEAR(rte::dipole_rd(1.0, 1.5), 1.0, 1e-15);
    EXPECT_EQ(rte::dipole_rd(0.0, 1.3), 0.0);
    // A hand evaluation: alpha' = 0.9, eta = 1 (A = 1): s = sqrt(0.3).
    const double s = std::sqrt(0.3);
    EXPECT_NEAR(rte::dipole_rd(0.9, 1.0), 0.45 * (1.0 + std::exp(-4.0 / 3.0 * s)) * std::exp(-s), 1e-15);
    // R_d grows with alpha'; in this form it falls with eta (A > 1 moves the image source away).
    EXPECT_LT(rte::dipole_rd(0.8, 1.0), rte::dipole_rd(0.9, 1.0));
    EXPECT_LT(rte::dipole_rd(0.9, 1.5), rte::dipole_rd(0.9, 1.0));
}

TEST(Dipole, Reciprocity) {
    for (double eta : {1.0, 1.5})
        for (double g : {0.0, 0.7}) {
            const rte::Dipole d(0.95, g, eta, hg_beta(g, 200));
            for (double a : {0.1, 0.4, 0.8, 1.0})
                for (double b : {0.15, 0.5, 0.95})
                    for (double phi : {0.0, 1.0, std::numbers::pi}) {
                        const double x = d.brdf(a, b, phi), y = d.brdf(b, a, phi);
                        EXPECT_NEAR(x, y, 1e-14 * x) << eta << " " << g << " " << a << " " << b;
                        EXPECT_GT(x, 0.0);
                    }
        }
}

TEST(Dipole, SingleScatteringIsTheExactModelsOwn) {
    // The two models differ only in the multiple scattering. (The solver's single-scattering term
    // carries the TMS factor 1 / (1 - f omega) of its delta-M truncation; the dipole has none.)
    for (double eta : {1.0, 1.5}) {
        const rte::Medium medium{0.8, hg_beta(0.6, 200)};
        const rte::Reflection r = solve_cpu(medium, 16, eta);
        const rte::Dipole d(medium.omega, 0.6, eta, medium.beta);
        for (double a : {0.2, 0.7, 1.0})
            for (double b : {0.3, 0.9})
                for (double phi : {0.0, 2.0}) {
                    const double tms = rte::scattering_layer(r.setup(), 0).albedo / medium.omega;
                    const double want = r.single_scattering(b, a, phi) / tms / std::numbers::pi;
                    EXPECT_NEAR(d.single_scattering_brdf(a, b, phi), want, 1e-13 * want);
                }
    }
}

TEST(Dipole, EnergyBounds) {
    // Never negative; with a smooth interface (eta = 1.5) diffuse + mirror stays <= 1 even at
    // omega = 1; without one, for omega <= 0.9.
    for (double eta : {1.0, 1.5})
        for (double g : {0.0, 0.5, 0.9})
            for (double omega : {0.3, 0.9, 0.99, 1.0}) {
                const rte::Dipole d(omega, g, eta, hg_beta(g, 400));
                for (double mu : {0.1, 0.5, 1.0}) {
                    const double a = d.albedo(mu), m = d.mirror(mu);
                    EXPECT_GT(a, 0.0);
                    if (eta > 1.0 || omega <= 0.9) {
                        EXPECT_LE(a + m, 1.0) << eta << " " << g << " " << omega << " " << mu;
                    }
                }
            }
    // The known excess: R_d = 1 at alpha' = 1 already holds every scattering order, and the single
    // scattering is added on top, so without an interface the model reflects more than it receives
    // (1.15 at normal incidence for isotropic scattering, 1.38 at mu = 0.1).
    const rte::Dipole white(1.0, 0.0, 1.0, {1.0});
    EXPECT_GT(white.albedo(1.0), 1.1);
    EXPECT_GT(white.albedo(0.1), 1.3);
}

// Chandrasekhar's exact isotropic R = (w/4) H(mu) H(mu0) / (mu + mu0) against the dipole (no interface).
TEST(Dipole, BiasedAgainstTheExactIsotropicSolution) {
    const auto j = nlohmann::json::parse(read_file(source_dir() / "tests/reference/rte/chandrasekhar_h.json"));
    for (const auto& c : j["cases"]) {
        const double omega = c["omega"];
        const std::vector<double> mu = c["mu"], h = c["h"];
        const rte::Dipole d(omega, 0.0, 1.0, {1.0});
        const auto ratio = [&](std::size_t i, std::size_t o) {
            const double exact = 0.25 * omega * h[i] * h[o] / (mu[i] + mu[o]) / std::numbers::pi;
            return d.brdf(mu[i], mu[o], 0.5) / exact;
        };
        // mu[3] = 0.1, mu[5] = 0.5, mu[7] = 1.
        ASSERT_EQ(mu[3], 0.1);
        ASSERT_EQ(mu[7], 1.0);
        // Too bright wherever one direction is steep (the Lambertian diffusion term has no limb
        // brightening): 20 to 50 per cent at (1, 0.1) for every albedo ...
        EXPECT_GT(ratio(7, 3), 1.2) << omega;
        EXPECT_LT(ratio(7, 3), 1.6) << omega;
        // ... and its angular shape is wrong: relatively darker at grazing-grazing than at
        // normal-grazing by more than 15 per cent.
        EXPECT_GT(ratio(7, 3) / ratio(3, 3), 1.15) << omega;
        // Reflectance too high at normal incidence for every albedo.
        EXPECT_GT(ratio(7, 7), 1.05) << omega;
        // Slightly too dark at grazing-grazing for moderate albedo (0.98-0.99), too bright near 1.
        if (omega <= 0.9) {
            EXPECT_LT(ratio(3, 3), 1.0) << omega;
        }
        if (omega >= 0.999) {
            EXPECT_GT(ratio(3, 3), 1.1) << omega;
        }
    }
}

// With the interface and a forward-scattering phase function, against our solver: too bright at
// low and moderate albedo, too dark at high albedo (the diffusion level is biased both ways), and
// the azimuthal structure of the multiple scattering is missing.
TEST(Dipole, BiasedBothWaysAgainstTheSolverWithAnInterface) {
    const auto ratios = [](double omega) {
        const rte::Medium medium{omega, hg_beta(0.5, 200)};
        const rte::Reflection r = solve_cpu(medium, 24, 1.5);
        const rte::Dipole d(omega, 0.5, 1.5, medium.beta);
        std::vector<double> out;
        for (double a : {1.0, 0.5, 0.17})
            for (double b : {1.0, 0.5, 0.17})
                for (double phi : {0.0, std::numbers::pi}) out.push_back(d.brdf(a, b, phi) / r.brdf(a, b, phi));
        return out;
    };
    for (double x : ratios(0.5)) EXPECT_GT(x, 1.5);
    for (double x : ratios(0.9)) EXPECT_GT(x, 1.05);
    for (double x : ratios(0.99)) EXPECT_LT(x, 0.98);
    const rte::Medium medium{0.9, hg_beta(0.5, 200)};
    const rte::Reflection r = solve_cpu(medium, 24, 1.5);
    const rte::Dipole d(0.9, 0.5, 1.5, medium.beta);
    EXPECT_GT(d.albedo(1.0), 1.3 * r.albedo(1.0));
}

} // namespace
} // namespace brdf::test
