// Films and layer stacks (rte/stack.h, rte/adding.h, rte/reflection.h): the limits that must hold
// exactly — zero thickness is the bare substrate under the interface, a very thick film is the
// half-space, splitting a layer changes nothing, energy is conserved at albedo 1, reciprocity — and
// the off-stream evaluation against the streams.

#include "rte_test_support.h"

#include <brdf/core/quadrature.h>
#include <brdf/rte/reflection.h>
#include <brdf/rte/stack.h>
#include <test_support.h>

#include <cmath>
#include <numbers>

namespace brdf::test {
namespace {

using rte::Layer;
using rte::Stack;
using rte::Top;

constexpr double inf = std::numeric_limits<double>::infinity();

rte::Reflection solve_stack(const Stack& stack, int streams = 24) {
    rte::ReflectionSettings settings;
    settings.streams = streams;
    settings.order_tolerance = 1e-12;
    settings.method = rte::Method::Doubling;
    rte::StackSetup setup = rte::setup_reflection(stack, settings);
    const auto problems = rte::order_problems(setup);
    auto solutions = rte::solve_orders_cpu(problems, settings.method, settings.control);
    return rte::Reflection(std::move(setup), std::move(solutions));
}

Stack film(const rte::Medium& m, double tau, double n, double substrate) {
    Stack s;
    s.top = n > 1.0 ? Top::Smooth : Top::None;
    s.layers.push_back(Layer{m, tau, n});
    s.substrate_albedo = substrate;
    return s;
}

const double kMus[] = {1.0, 0.8, 0.45, 0.15, 0.03};
const double kPhis[] = {0.0, 1.1, std::numbers::pi};

double worst_relative(const rte::Reflection& a, const rte::Reflection& b) {
    double worst = 0.0;
    for (double mi : kMus)
        for (double mo : kMus)
            for (double phi : kPhis) {
                const double x = a.brdf(mi, mo, phi), y = b.brdf(mi, mo, phi);
                worst = std::max(worst, std::abs(x - y) / std::max(std::abs(y), 1e-12));
            }
    return worst;
}

TEST(Stack, ThickFilmIsTheHalfSpace) {
    for (double n : {1.0, 1.5}) {
        const rte::Medium m{0.9, hg_beta(0.5, 40)};
        const rte::Reflection thick = solve_stack(film(m, 2000.0, n, 0.7));
        const rte::Reflection half = solve_stack(rte::half_space(m, n));
        EXPECT_LE(worst_relative(thick, half), 1e-9) << "n " << n;
        for (double mi : kMus) EXPECT_NEAR(thick.albedo(mi), half.albedo(mi), 1e-11) << "n " << n;
    }
}

TEST(Stack, ZeroThicknessIsTheBareSubstrateUnderTheInterface) {
    // A Lambertian floor of albedo a under a smooth interface of index n: light that enters is
    // reflected diffusely, and the interface sends back the fraction r_i of it (internal diffuse
    // reflectance, 2 int F_int(mu) mu dmu): f = (1 - F(mu_i)) (1 - F(mu_o)) a / (pi n^2 (1 - a r_i)).
    const double n = 1.5, a = 0.8;
    const rte::Reflection r = solve_stack(film({0.9, hg_beta(0.5, 40)}, 0.0, n, a), 32);
    // r_i exactly: total internal reflection below the critical cosine, and above it
    // 2 mu dmu = 2 mu_air dmu_air / n^2, where Fresnel is smooth. The solve's interface
    // reflectances are product-integrated (stack.h), so for a constant floor they are exact too.
    const double mu_c = std::sqrt(1.0 - 1.0 / (n * n));
    double r_i = mu_c * mu_c;
    const Quadrature q = gauss_legendre(100, 0.0, 1.0);
    for (std::size_t k = 0; k < q.x.size(); ++k) r_i += 2.0 * q.w[k] * q.x[k] / (n * n) * rte::fresnel(q.x[k], 1.0, n);
    for (double mi : kMus)
        for (double mo : kMus) {
            const double want = (1.0 - rte::fresnel(mi, 1.0, n)) * (1.0 - rte::fresnel(mo, 1.0, n)) * a /
                                (std::numbers::pi * n * n * (1.0 - a * r_i));
            EXPECT_NEAR(r.brdf(mi, mo, 0.4), want, 1e-12 * want) << mi << " " << mo;
        }
}

TEST(Stack, SplittingALayerChangesNothing) {
    const rte::Medium m{0.97, hg_beta(0.7, 60)};
    for (double n : {1.0, 1.45}) {
        const rte::Reflection one = solve_stack(film(m, 3.0, n, 0.5));
        Stack two = film(m, 1.2, n, 0.5);
        two.layers.push_back(Layer{m, 1.8, n});
        const rte::Reflection split = solve_stack(two);
        EXPECT_LE(worst_relative(split, one), 1e-9) << "n " << n;
        // and a semi-infinite layer under a slice of itself
        Stack over_half = rte::half_space(m, n);
        over_half.layers = {Layer{m, 0.6, n}, over_half.layers.front()};
        EXPECT_LE(worst_relative(solve_stack(over_half), solve_stack(rte::half_space(m, n))), 1e-9) << "n " << n;
    }
}

TEST(Stack, ClearIndexMatchedLayerChangesNothing) {
    const rte::Medium m{0.95, hg_beta(0.4, 40)};
    const rte::Medium clear{0.0, {1.0}};
    Stack with = rte::half_space(m, 1.5);
    with.layers = {Layer{clear, 0.0, 1.5}, with.layers.front()};
    EXPECT_LE(worst_relative(solve_stack(with), solve_stack(rte::half_space(m, 1.5))), 1e-12);
}

TEST(Stack, ConservesEnergyAtAlbedoOne) {
    // Conservative layers over a white floor: what is not mirrored is diffusely reflected.
    const rte::Medium m{1.0, hg_beta(0.6, 40)};
    for (double n : {1.0, 1.5})
        for (double tau : {0.2, 4.0}) {
            const rte::Reflection r = solve_stack(film(m, tau, n, 1.0));
            for (double mi : kMus) EXPECT_NEAR(r.albedo(mi) + r.mirror(mi), 1.0, 1e-10) << "n " << n << " tau " << tau;
        }
}

TEST(Stack, ConservesEnergyAcrossAnIndexChange) {
    // Two conservative layers of different index over a white floor. The lower layer's streams are
    // the Snell images of the upper one's, Gauss in another medium's cosine, so its quadrature is
    // exact to convergence, not to rounding.
    const rte::Medium a{1.0, hg_beta(0.3, 40)}, b{1.0, {1.0}};
    for (double n2 : {1.8, 1.3}) {
        Stack s;
        s.top = Top::Smooth;
        s.layers = {Layer{a, 1.0, 1.5}, Layer{b, 2.0, n2}};
        s.substrate_albedo = 1.0;
        const rte::Reflection r = solve_stack(s, 32);
        for (double mi : kMus) EXPECT_NEAR(r.albedo(mi) + r.mirror(mi), 1.0, 1e-7) << "n2 " << n2 << " mu " << mi;
    }
}

TEST(Stack, IsReciprocal) {
    Stack s;
    s.top = Top::Smooth;
    s.layers = {Layer{{0.95, hg_beta(0.3, 40)}, 1.0, 1.5}, Layer{{0.99, {1.0}}, 3.0, 1.8}};
    s.substrate_albedo = 0.5;
    for (const Stack& st : {s, film({0.9, hg_beta(0.8, 60)}, 2.0, 1.5, 0.3)}) {
        const rte::Reflection r = solve_stack(st);
        for (double mi : kMus)
            for (double mo : kMus)
                for (double phi : kPhis) {
                    const double x = r.brdf(mi, mo, phi), y = r.brdf(mo, mi, phi);
                    EXPECT_NEAR(x, y, 1e-10 * std::max(x, y)) << mi << " " << mo << " " << phi;
                }
    }
}

TEST(Stack, OffStreamValuesConvergeWithTheStreams) {
    // The film's BRDF at arbitrary angles converges with the stream count (the off-stream
    // evaluation is exact for each discrete problem, so the limit is reached quickly).
    const Stack s = film({0.95, hg_beta(0.5, 60)}, 2.0, 1.5, 0.5);
    const rte::Reflection a = solve_stack(s, 24), b = solve_stack(s, 48);
    EXPECT_LE(worst_relative(a, b), 2e-4);
}

} // namespace
} // namespace brdf::test
