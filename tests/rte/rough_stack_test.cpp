// A layer stack under a rough top (rte/reflection.h with Top::Rough): against Mitsuba 3's Monte
// Carlo of a semi-infinite HG medium under roughdielectric (tests/reference/rte/mitsuba_rough_slab.json),
// the smooth limit, reciprocity, and the white furnace against the interface's own energy balance.

#include "rte_test_support.h"

#include <brdf/core/quadrature.h>
#include <brdf/rte/reflection.h>
#include <brdf/rte/rough_interface.h>
#include <brdf/rte/stack.h>
#include <test_support.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>

namespace brdf::test {
namespace {

using rte::Layer;
using rte::Stack;
using rte::Top;

constexpr double pi = std::numbers::pi;
constexpr double inf = std::numeric_limits<double>::infinity();

rte::Reflection solve(const Stack& stack, int streams = 32, double order_tolerance = 1e-6) {
    rte::ReflectionSettings settings;
    settings.streams = streams;
    settings.order_tolerance = order_tolerance;
    settings.method = rte::Method::Doubling;
    rte::StackSetup setup = rte::setup_reflection(stack, settings);
    const auto problems = rte::order_problems(setup);
    auto solutions = rte::solve_orders_cpu(problems, settings.method, settings.control);
    return rte::Reflection(std::move(setup), std::move(solutions));
}

Stack rough_half_space(const rte::Medium& m, double alpha, rte::Masking masking, double n = 1.5) {
    Stack s;
    s.top = Top::Rough;
    s.rough = rte::RoughSurface{alpha, rte::Microfacet::Ggx, masking};
    s.layers.push_back(Layer{m, inf, n});
    return s;
}

double rad(double deg) { return deg * pi / 180.0; }

TEST(RoughStack, MatchesMitsubaMonteCarlo) {
    std::ifstream in(source_dir() / "tests/reference/rte/mitsuba_rough_slab.json");
    ASSERT_TRUE(in) << "reference missing";
    const auto j = nlohmann::json::parse(in);
    int checked = 0;
    for (const auto& c : j.at("cases")) {
        const double alpha = c.at("alpha"), omega = c.at("omega"), g = c.at("g");
        const rte::Reflection r = solve(rough_half_space(rte::Medium{omega, hg_beta(g, 200)}, alpha, rte::Masking::Separable));
        double worst_total = 0.0, worst_body = 0.0;
        for (const auto& v : c.at("values")) {
            const double ti = v[0], to = v[1], phi = v[2], f = v[3], f_se = v[4], surface = v[5], body = v[6], body_se = v[7];
            const double mu_i = std::cos(rad(ti)), mu_o = std::cos(rad(to));
            const double ours = r.brdf(mu_i, mu_o, rad(phi));
            const double ours_body = ours - r.surface_lobe(mu_i, mu_o, rad(phi));
            EXPECT_NEAR(ours, f, 3.0 * f_se + 0.005 * f) << "alpha " << alpha << " omega " << omega << " g " << g << " at "
                                                         << ti << " " << to << " " << phi << " (surface " << surface << ")";
            EXPECT_NEAR(ours_body, body, 3.0 * body_se + 0.005 * body)
                << "body: alpha " << alpha << " omega " << omega << " g " << g << " at " << ti << " " << to << " " << phi;
            worst_total = std::max(worst_total, std::abs(ours - f) / (3.0 * f_se + 0.005 * f));
            worst_body = std::max(worst_body, std::abs(ours_body - body) / (3.0 * body_se + 0.005 * body));
            ++checked;
        }
        std::printf("alpha %.1f omega %.2f g %.1f: orders %d, worst |diff| / (3 se + 0.5 %%): total %.2f body %.2f\n",
                    alpha, omega, g, r.orders(), worst_total, worst_body);
    }
    EXPECT_EQ(checked, 480);
}

TEST(RoughStack, SmoothLimitIsTheSmoothInterface) {
    const rte::Medium m{0.9, hg_beta(0.5, 200)};
    Stack smooth;
    smooth.top = Top::Smooth;
    smooth.layers.push_back(Layer{m, inf, 1.5});
    const rte::Reflection ref = solve(smooth);
    double previous = inf;
    for (double alpha : {0.01, 0.003, 0.001}) {
        const rte::Reflection r = solve(rough_half_space(m, alpha, rte::Masking::HeightCorrelated));
        double worst = 0.0;
        for (double mi : {0.95, 0.7, 0.4})
            for (double mo : {0.9, 0.6, 0.3})
                for (double phi : {0.0, 1.5, 2.5}) {
                    const double body = r.brdf(mi, mo, phi) - r.surface_lobe(mi, mo, phi);
                    worst = std::max(worst, std::abs(body - ref.brdf(mi, mo, phi)) / ref.brdf(mi, mo, phi));
                }
        std::printf("alpha %.3f: body vs smooth interface, worst relative difference %.2e\n", alpha, worst);
        EXPECT_LT(worst, previous);
        previous = worst;
    }
    EXPECT_LT(previous, 5e-3);
}

TEST(RoughStack, IsReciprocal) {
    for (double alpha : {0.05, 0.3}) {
        Stack s = rough_half_space(rte::Medium{0.95, hg_beta(0.6, 200)}, alpha, rte::Masking::HeightCorrelated);
        const rte::Reflection r = solve(s, 24);
        for (double a : {0.9, 0.5, 0.2})
            for (double b : {0.8, 0.35})
                for (double phi : {0.3, 2.0, pi})
                    EXPECT_NEAR(r.brdf(a, b, phi), r.brdf(b, a, phi), 1e-8 * std::max(1.0, r.brdf(a, b, phi)));
    }
    // A film over a Lambertian substrate and two layers of different index.
    Stack film;
    film.top = Top::Rough;
    film.rough = rte::RoughSurface{0.2};
    film.layers.push_back(Layer{rte::Medium{0.9, hg_beta(0.4, 200)}, 0.7, 1.5});
    film.layers.push_back(Layer{rte::Medium{0.8, hg_beta(0.2, 200)}, 2.0, 1.3});
    film.substrate_albedo = 0.6;
    const rte::Reflection r = solve(film, 24);
    for (double a : {0.9, 0.3})
        for (double b : {0.7, 0.45})
            EXPECT_NEAR(r.brdf(a, b, 2.2), r.brdf(b, a, 2.2), 1e-8 * std::max(1.0, r.brdf(a, b, 2.2)));
}

// Under a clear, zero-thickness film on a white Lambertian floor the light below the interface is
// isotropic after every floor bounce, so the albedo follows from the interface's own albedos:
// A(mu) = R_air(mu) + T_air(mu) E / (1 - rho), E and rho the hemispherical averages (2 mu dmu) of the
// inside transmission and reflection. Its shortfall from 1 is the single-scattering microfacet loss.
TEST(RoughStack, WhiteFurnaceLosesWhatTheInterfaceLoses) {
    // Measured loss at normal incidence: 0.0745 (alpha 0.1), 0.2997 (alpha 0.3); at alpha 1 the inside
    // albedo's quadrature does not converge to 1e-6 (rough_interface.cpp), so it is not checked here.
    for (double alpha : {0.1, 0.3}) {
        Stack s;
        s.top = Top::Rough;
        s.rough = rte::RoughSurface{alpha, rte::Microfacet::Ggx, rte::Masking::HeightCorrelated};
        s.layers.push_back(Layer{rte::Medium{1.0, hg_beta(0.0, 1)}, 0.0, 1.5});
        s.substrate_albedo = 1.0;
        const rte::Reflection r = solve(s, 32);
        const rte::RoughInterface& ri = *r.rough_interface();
        double e = 0.0, rho = 0.0;
        for (auto [lo, hi] : {std::pair{0.0, ri.critical()}, std::pair{ri.critical(), 1.0}}) {
            const Quadrature q = gauss_legendre(40, lo, hi);
            for (std::size_t k = 0; k < q.size(); ++k) {
                const auto a = ri.albedo_from_inside(q.x[k], 1e-6);
                e += q.w[k] * 2.0 * q.x[k] * a.transmitted;
                rho += q.w[k] * 2.0 * q.x[k] * a.reflected;
            }
        }
        for (double mu : {1.0, 0.5, 0.2}) {
            const auto out = ri.albedo_from_air(mu, 1e-8);
            const double expected = out.reflected + out.transmitted * e / (1.0 - rho);
            std::printf("alpha %.1f mu %.1f: white furnace albedo %.5f (expected %.5f): loss %.4f\n", alpha, mu,
                        r.albedo(mu), expected, 1.0 - r.albedo(mu));
            EXPECT_NEAR(r.albedo(mu), expected, 2e-3) << "alpha " << alpha << " mu " << mu;
        }
        // The semi-infinite conservative medium loses at most what the interface loses.
        const rte::Reflection h = solve(rough_half_space(rte::Medium{1.0, hg_beta(0.5, 200)}, alpha, rte::Masking::HeightCorrelated), 32);
        for (double mu : {1.0, 0.5}) {
            std::printf("alpha %.1f mu %.1f: half-space white furnace albedo %.5f\n", alpha, mu, h.albedo(mu));
            EXPECT_LE(h.albedo(mu), ri.albedo_from_air(mu, 1e-8).total() + 1e-4);
            EXPECT_GT(h.albedo(mu), 0.3);
        }
    }
}

TEST(RoughStack, MirrorIsZeroAndLobeIsTheClosedForm) {
    const rte::Reflection r = solve(rough_half_space(rte::Medium{0.9, hg_beta(0.5, 200)}, 0.2, rte::Masking::HeightCorrelated), 16);
    const rte::RoughInterface ri(1.5, rte::RoughSurface{0.2});
    EXPECT_EQ(r.mirror(0.7), 0.0);
    EXPECT_EQ(r.surface_lobe(0.7, 0.6, 3.0), ri.f_reflect_air(0.7, 0.6, 3.0));
    // The lobe lies on the mirror side.
    EXPECT_GT(r.surface_lobe(0.7, 0.7, pi), 10.0 * r.surface_lobe(0.7, 0.7, 0.5 * pi));
}

TEST(RoughStack, BatchedEvaluationEqualsPointwise) {
    // brdf_grid, albedo(span) and mirror(span) (one order grid, one order-0 solve for every
    // direction: what the stream check, the gamut fit, the report and the previews use) against
    // brdf(), albedo() and mirror() per direction,
    // under a rough, a smooth and no top.
    const double mus[] = {1.0, 0.6, 0.05};
    const double phis[] = {0.0, 2.0, pi};
    for (const Top top : {Top::Rough, Top::Smooth, Top::None}) {
        Stack s = rough_half_space(rte::Medium{0.95, hg_beta(0.6, 200)}, 0.1, rte::Masking::HeightCorrelated);
        s.top = top;
        const rte::Reflection r = solve(s, 16);
        const std::vector<double> grid = r.brdf_grid(mus, phis);
        const std::vector<double> albedo = r.albedo(std::span<const double>(mus));
        const std::vector<double> mirror = r.mirror(std::span<const double>(mus));
        for (std::size_t i = 0; i < 3; ++i) {
            EXPECT_NEAR(albedo[i], r.albedo(mus[i]), 1e-11) << "top " << static_cast<int>(top);
            EXPECT_NEAR(mirror[i], r.mirror(mus[i]), 1e-12) << "top " << static_cast<int>(top);
            if (top == Top::Smooth) {
                EXPECT_GT(mirror[i], 0.03); // Fresnel of n 1.5, at least the normal 0.04
            }
            for (std::size_t o = 0; o < 3; ++o)
                for (std::size_t p = 0; p < 3; ++p) {
                    const double one = r.brdf(mus[i], mus[o], phis[p]);
                    // Equal up to the rounding of differently sized products (a mix-up of
                    // directions would differ at O(1)).
                    EXPECT_NEAR(grid[(i * 3 + o) * 3 + p], one, 1e-9 * one) << "top " << static_cast<int>(top);
                }
        }
    }
}

} // namespace
} // namespace brdf::test
