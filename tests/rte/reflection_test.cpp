// Accuracy of the reflection function: Chandrasekhar's exact isotropic solution, energy
// conservation at albedo 1 (with and without the interface), reciprocity, azimuth convention.

#include "rte_test_support.h"

#include <brdf/rte/reflection.h>
#include <test_support.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <numbers>

namespace brdf::test {
namespace {

struct HCase {
    double omega;
    std::vector<double> mu, h;
};

std::vector<HCase> chandrasekhar_cases() {
    const auto j = nlohmann::json::parse(read_file(source_dir() / "tests/reference/rte/chandrasekhar_h.json"));
    std::vector<HCase> out;
    for (const auto& c : j["cases"]) out.push_back({c["omega"], c["mu"], c["h"]});
    return out;
}

// Max relative error of the BRDF against R = (w/4) H H / (mu + mu0) over all pairs of reference angles.
double isotropic_error(const HCase& c, int streams) {
    const rte::Reflection r = solve_cpu({c.omega, {1.0}}, streams);
    double worst = 0.0;
    for (std::size_t i = 0; i < c.mu.size(); ++i) {
        for (std::size_t o = 0; o < c.mu.size(); ++o) {
            const double exact = 0.25 * c.omega * c.h[i] * c.h[o] / (c.mu[i] + c.mu[o]) / std::numbers::pi;
            const double got = r.brdf(c.mu[i], c.mu[o], 0.7);
            worst = std::max(worst, std::abs(got - exact) / exact);
        }
    }
    return worst;
}

TEST(Isotropic, MatchesChandrasekharAtDefaultAccuracy) {
    for (const HCase& c : chandrasekhar_cases()) {
        const double err = isotropic_error(c, 32);
        EXPECT_LE(err, 1e-4) << "omega " << c.omega;
    }
}

TEST(Isotropic, MatchesChandrasekharAtReferenceAccuracy) {
    for (const HCase& c : chandrasekhar_cases()) {
        const double err = isotropic_error(c, 64);
        EXPECT_LE(err, 1e-6) << "omega " << c.omega;
    }
}

TEST(Isotropic, FixedPointAndDoublingAgree) {
    const rte::Reflection a = solve_cpu({0.9, {1.0}}, 16, 1.0, rte::Method::FixedPoint);
    const rte::Reflection b = solve_cpu({0.9, {1.0}}, 16, 1.0, rte::Method::Doubling);
    EXPECT_LE(max_abs_diff(a.solutions()[0].x, b.solutions()[0].x), 1e-11 * max_abs(b.solutions()[0].x));
}

TEST(Solvers, AllThreeAgreeOnEveryOrder) {
    // HG g = 0.5 at albedo 0.99: m = 0 is slow for the fixed point, m >= 1 fast.
    rte::ReflectionSettings settings;
    settings.streams = 16;
    const rte::StackSetup setup = rte::setup_reflection({0.99, hg_beta(0.5, 100)}, {}, settings);
    for (const auto& problem : rte::order_problems(setup)) {
        const auto fp = rte::solve_order(problem, rte::Method::FixedPoint);
        const auto sda = rte::solve_order(problem, rte::Method::Doubling);
        const auto fast = rte::solve_order(problem, rte::Method::Fast);
        const double scale = max_abs(sda.x);
        EXPECT_TRUE(fp.converged && sda.converged && fast.converged) << "m " << problem.m;
        EXPECT_LE(max_abs_diff(fp.x, sda.x), 1e-11 * scale) << "m " << problem.m;
        EXPECT_LE(max_abs_diff(fast.x, sda.x), 1e-11 * scale) << "m " << problem.m;
        EXPECT_LE(sda.iterations, 30) << "m " << problem.m;
        EXPECT_LE(sda.residual, 1e-12) << "m " << problem.m;
    }
}

// Below albedo 1 doubling runs its symmetric form (solve_doubling: F_k = E_k^T never formed, one LU
// a step): on a forward-peaked phase function at 64 streams, where the steps' rounding has most
// room to grow, every order still matches the fixed point run to rounding, stays reciprocal (X =
// X^T) and solves the equation to rounding.
TEST(Solvers, SymmetricDoublingMatchesTheFixedPoint) {
    rte::ReflectionSettings settings;
    settings.streams = 64;
    for (double omega : {0.999, 0.9}) {
        const rte::StackSetup setup =
            rte::setup_reflection({omega, hg_beta(0.85, 300)}, {}, settings);
        for (const auto& problem : rte::order_problems(setup)) {
            ASSERT_FALSE(problem.conservative());
            rte::SolveControl control;
            control.tolerance = 1e-14;
            const auto sda = rte::solve_doubling(problem, control);
            const auto fp = rte::solve_fixed_point(problem, control);
            const double scale = max_abs(sda.x);
            if (scale == 0.0) continue; // an order the phase function does not have
            EXPECT_TRUE(sda.converged && fp.converged) << "omega " << omega << " m " << problem.m;
            EXPECT_LE(max_abs_diff(sda.x, fp.x), 1e-11 * scale)
                << "omega " << omega << " m " << problem.m;
            EXPECT_LE(max_abs_diff(sda.x, transpose(sda.x)), 1e-12 * scale)
                << "omega " << omega << " m " << problem.m;
            EXPECT_LE(sda.residual, 1e-12) << "omega " << omega << " m " << problem.m;
        }
    }
}

// Doubling's automatic Cayley parameter (doubling_gamma): the geometric mean of the decay rates it
// contracts, sqrt(lambda_min / mu_min). Against gamma = 1 on every order of HG media at 64 streams
// (albedo 1 with the conservative shift, 0.999 and 0.9): the same solution to the iteration's
// tolerance, the residual still at rounding, and at least a quarter fewer steps in all (measured:
// 9-12 steps an order instead of 15).
TEST(Solvers, DoublingsCayleyParameterSavesStepsNotAccuracy) {
    rte::ReflectionSettings settings;
    settings.streams = 64;
    int automatic_steps = 0, unit_steps = 0;
    for (double omega : {1.0, 0.999, 0.9})
        for (double g : {0.0, 0.85}) {
            const rte::StackSetup setup =
                rte::setup_reflection({omega, hg_beta(g, 300)}, {}, settings);
            for (const auto& problem : rte::order_problems(setup)) {
                rte::SolveControl unit;
                unit.tolerance = 1e-10;
                unit.gamma = 1.0;
                rte::SolveControl automatic = unit;
                automatic.gamma = 0.0;
                const double gamma = rte::doubling_gamma(problem);
                EXPECT_GT(gamma, 1.0) << "m " << problem.m;
                const auto a = rte::solve_doubling(problem, unit);
                const auto b = rte::solve_doubling(problem, automatic);
                const double scale = max_abs(a.x);
                if (scale == 0.0) continue; // an order the phase function does not have
                EXPECT_TRUE(b.converged) << "omega " << omega << " g " << g << " m " << problem.m;
                EXPECT_LE(max_abs_diff(a.x, b.x), 1e-9 * scale)
                    << "omega " << omega << " g " << g << " m " << problem.m;
                EXPECT_LE(b.residual, std::max(1e-13, 10.0 * a.residual)) << "m " << problem.m;
                automatic_steps += b.iterations;
                unit_steps += a.iterations;
            }
        }
    std::printf("doubling steps: %d with gamma = 1, %d with doubling_gamma\n", unit_steps,
                automatic_steps);
    EXPECT_LT(automatic_steps, 0.75 * unit_steps);
}

TEST(Solvers, FastGivesUpOnlyAFixedPointThatCannotConvergeByItsCap) {
    // Albedo 1, HG g = 0.9: low orders m >= 1 need more fixed-point sweeps than Method::Fast's cap,
    // higher ones fewer. A try given up early must be one that the capped sweeps would not have
    // finished (so the answer is doubling's, bit for bit, and fewer sweeps were spent), and a try
    // that finishes within the cap must run as the plain fixed point does.
    rte::ReflectionSettings settings;
    settings.streams = 32;
    const rte::StackSetup setup = rte::setup_reflection({1.0, hg_beta(0.9, 200)}, {}, settings);
    const rte::SolveControl control;
    rte::SolveControl capped = control;
    capped.max_iterations = control.fast_sweeps;
    int given_up = 0, finished = 0, straight = 0;
    for (const auto& problem : rte::order_problems(setup)) {
        const auto fp = rte::solve_fixed_point(problem, capped);
        if (amb_fast_starts_with_doubling(problem.order_albedo)) { // m = 0 and the lowest orders
            ++straight;
            EXPECT_FALSE(fp.converged) << "m " << problem.m; // the try would have been wasted
            continue;
        }
        const auto fast = rte::solve_order(problem, rte::Method::Fast, control);
        if (fp.converged) {
            ++finished;
            EXPECT_EQ(fast.iterations, fp.iterations) << "m " << problem.m;
            EXPECT_EQ(max_abs_diff(fast.x, fp.x), 0.0) << "m " << problem.m;
        } else {
            const auto sda = rte::solve_order(problem, rte::Method::Doubling, control);
            const int sweeps = fast.iterations - sda.iterations;
            given_up += sweeps < control.fast_sweeps;
            EXPECT_LT(sweeps, control.fast_sweeps) << "m " << problem.m;
            EXPECT_EQ(max_abs_diff(fast.x, sda.x), 0.0) << "m " << problem.m;
        }
    }
    std::printf(
        "orders straight to doubling %d, given up early %d, finished by the fixed point %d\n",
        straight, given_up, finished);
    EXPECT_GE(straight, 2);
    EXPECT_GE(given_up, 2);
    EXPECT_GE(finished, 2);
}

// Method::Fast sends an order straight to doubling by its order albedo
// (amb_fast_starts_with_doubling): over HG g 0.3-0.99 at albedo 0.9-1 under an interface, 16-64
// streams, every order it sends there is one whose fixed point would not have finished within the
// capped try at the service's loosest iteration tolerance (1e-8), and the orders it leaves to the
// fixed point include ones that finish.
TEST(Solvers, StraightToDoublingOnlyWhereTheFixedPointCannotFinish) {
    const rte::SolveControl control;
    rte::SolveControl capped;
    capped.tolerance = 1e-8;
    capped.max_iterations = control.fast_sweeps;
    int straight = 0, finished = 0;
    double highest_finished = 0.0;
    for (int streams : {16, 32, 64})
        for (double g : {0.3, 0.6, 0.85, 0.95, 0.99})
            for (double omega : {1.0, 0.999, 0.99, 0.9}) {
                rte::ReflectionSettings settings;
                settings.streams = streams;
                const rte::StackSetup setup =
                    rte::setup_reflection({omega, hg_beta(g, 1000)}, {1.5}, settings);
                for (const auto& problem : rte::order_problems(setup)) {
                    const bool direct = amb_fast_starts_with_doubling(problem.order_albedo);
                    if (!direct && problem.order_albedo < 0.7) continue; // converge in a few sweeps
                    const auto fp = rte::solve_fixed_point(problem, capped);
                    if (direct) ++straight;
                    if (fp.converged)
                        ++finished,
                            highest_finished = std::max(highest_finished, problem.order_albedo);
                    EXPECT_FALSE(direct && fp.converged)
                        << streams << " streams, g " << g << ", omega " << omega << ", m "
                        << problem.m;
                }
            }
    std::printf(
        "straight to doubling %d; finished by the fixed point %d, the highest order albedo %.3f\n",
        straight, finished, highest_finished);
    EXPECT_GT(straight, 50);
    EXPECT_GT(finished, 20);
}

TEST(Solvers, FastGivesUpFromTheRateOfAGeometricChange) {
    // A change falling by 0.9 per sweep from 1 at sweep 4 reaches 0.9^26 = 0.065 at the cap of 30.
    EXPECT_EQ(amb_fast_gives_up(4, 30, 1.0, 1.0 / 0.9, 1.0 / 0.81, 0.07), 0);
    EXPECT_EQ(amb_fast_gives_up(4, 30, 1.0, 1.0 / 0.9, 1.0 / 0.81, 0.06), 1);
    // The faster of the last two ratios decides, and no decision before sweep 4 or
    // while the change does not fall.
    EXPECT_EQ(amb_fast_gives_up(4, 30, 1.0, 2.0, 2.0 / 0.99, 1e-7), 0); // 0.5^26 = 1.5e-8
    EXPECT_EQ(amb_fast_gives_up(3, 30, 1.0, 1.0 / 0.99, 1.0 / 0.98, 1e-8), 0);
    EXPECT_EQ(amb_fast_gives_up(10, 30, 1.0, 1.0, 1.0, 1e-8), 0);
    EXPECT_EQ(amb_fast_gives_up(10, 30, 1.0, 1.0 / 0.99, 1.0 / 0.98, 1e-8), 1);
}

TEST(Conservation, PlaneAlbedoIsOneAtAlbedoOne) {
    const std::vector<std::vector<double>> phases = {{1.0}, rayleigh_beta(), hg_beta(0.5, 200), hg_beta(0.9, 400),
                                                     hg_beta(-0.5, 200)};
    for (const auto& beta : phases) {
        const rte::Reflection r = solve_cpu({1.0, beta}, 24);
        for (double mu : {1.0, 0.8, 0.5, 0.2, 0.05, 0.001})
            EXPECT_NEAR(r.albedo(mu), 1.0, 1e-9) << "beta size " << beta.size() << " mu " << mu;
    }
}

TEST(Conservation, MirrorPlusDiffuseIsOneUnderAnInterface) {
    for (double n : {1.33, 1.5, 1.8}) {
        const rte::Reflection r = solve_cpu({1.0, hg_beta(0.6, 200)}, 24, n);
        for (double mu : {1.0, 0.7, 0.3, 0.05})
            EXPECT_NEAR(r.albedo(mu) + r.mirror(mu), 1.0, 1e-9) << "n " << n << " mu " << mu;
    }
}

TEST(Reciprocity, BrdfIsSymmetric) {
    for (double n : {1.0, 1.5}) {
        const rte::Reflection r = solve_cpu({0.95, hg_beta(0.7, 300)}, 16, n);
        for (double a : {0.9, 0.4, 0.1})
            for (double b : {0.95, 0.3, 0.02})
                for (double phi : {0.0, 1.0, 3.0}) {
                    const double f = r.brdf(a, b, phi), g = r.brdf(b, a, phi);
                    EXPECT_NEAR(f, g, 1e-12 * std::max(1.0, f)) << a << " " << b << " " << phi << " n " << n;
                }
    }
}

// The single scattering of a grid of directions (one pass of the Legendre series over all of them,
// eight points at a time: Reflection::brdf_grid and the gamut fit's probes) is the per-direction
// sum's, bit for bit, in every entry of the grid's layout, with and without an interface.
TEST(SingleScattering, GridEqualsEveryDirection) {
    const std::vector<double> mu{1.0, 0.7, 0.3, 0.05, 0.001}, phi{0.0, 1.2, std::numbers::pi};
    for (double n : {1.0, 1.5}) {
        const rte::Reflection r = solve_cpu({0.95, hg_beta(0.7, 300)}, 16, n);
        const std::vector<double> grid = rte::single_scattering_grid(r.setup(), mu, phi);
        ASSERT_EQ(grid.size(), mu.size() * mu.size() * phi.size());
        for (std::size_t i = 0; i < mu.size(); ++i)
            for (std::size_t o = 0; o < mu.size(); ++o)
                for (std::size_t p = 0; p < phi.size(); ++p) {
                    const double one = r.single_scattering(mu[o], mu[i], phi[p]);
                    EXPECT_GT(one, 0.0);
                    EXPECT_EQ(grid[(i * mu.size() + o) * phi.size() + p], one)
                        << "mu_i " << mu[i] << " mu_o " << mu[o] << " phi " << phi[p] << " n " << n;
                }
    }
}

// The orders are independent: computed on several threads the grid is the same, bit for bit, each
// order in its place.
TEST(OrderGrid, SeveralThreadsGiveTheSameGrid) {
    const rte::Reflection r = solve_cpu({0.95, hg_beta(0.7, 300)}, 16, 1.5);
    const std::vector<double> mu{1.0, 0.7, 0.3, 0.05};
    const rte::OrderGrid one = r.order_grid(mu), three = r.order_grid(mu, 3);
    ASSERT_GT(one.orders.size(), 2u);
    ASSERT_EQ(one.orders.size(), three.orders.size());
    for (std::size_t m = 0; m < one.orders.size(); ++m)
        EXPECT_EQ(max_abs_diff(one.orders[m], three.orders[m]), 0.0) << "order " << m;
}

// Under a smooth top the orders of a table-sized grid come from Chebyshev nodes in sin^2 of the air
// angle (Reflection::order_grid): against every pair solved directly (a short list of directions,
// which is never interpolated), from normal to 0.06 degrees off grazing, for isotropic and forward
// scattering at albedo 1 and below, binder indices 1.33 to 2 and 16 to 64 streams.
TEST(OrderGrid, InterpolatedUnderASmoothTopMatchesEveryDirectionSolved) {
    const std::vector<double> probes{1.0, 0.97, 0.8, 0.55, 0.3, 0.12, 0.04, 0.001};
    struct Case {
        rte::Medium medium;
        int streams;
        double n;
    };
    const Case cases[] = {{{1.0, {1.0}}, 16, 1.5},
                          {{0.99, hg_beta(0.5, 200)}, 32, 1.33},
                          {{1.0, hg_beta(0.9, 400)}, 32, 1.5},
                          {{0.999, hg_beta(0.85, 400)}, 64, 1.5},
                          {{0.9, hg_beta(0.7, 300)}, 16, 2.0}};
    for (const Case& c : cases) {
        SCOPED_TRACE(testing::Message()
                     << "omega " << c.medium.omega << ", " << c.streams << " streams, n " << c.n);
        const rte::Reflection r = solve_cpu(c.medium, c.streams, c.n);
        std::vector<double> table;
        for (int a = 0; a < 181; ++a) table.push_back(std::cos(0.5 * std::numbers::pi * a / 180.0));
        const std::size_t first = table.size();
        table.insert(table.end(), probes.begin(), probes.end());
        const rte::OrderGrid interpolated = r.order_grid(table), direct = r.order_grid(probes);
        EXPECT_GT(interpolated.nodes, 0);
        EXPECT_LT(2 * interpolated.nodes, static_cast<int>(table.size()));
        EXPECT_EQ(interpolated.interpolated, static_cast<int>(interpolated.orders.size()));
        EXPECT_EQ(direct.nodes, 0);
        const double scale = max_abs(direct.orders[0]);
        double worst = 0.0;
        for (std::size_t m = 0; m < direct.orders.size(); ++m)
            for (std::size_t a = 0; a < probes.size(); ++a)
                for (std::size_t b = 0; b < probes.size(); ++b)
                    worst = std::max(
                        worst,
                        std::abs(interpolated.orders[m](static_cast<int>(first + a),
                                                        static_cast<int>(first + b)) -
                                 direct.orders[m](static_cast<int>(a), static_cast<int>(b))));
        std::printf("n %.2f, %d streams, %d nodes: %.1e of the largest R^0\n", c.n, c.streams,
                    interpolated.nodes, worst / scale);
        EXPECT_LE(worst, 1e-12 * scale);
    }
}

TEST(Azimuth, ForwardScatteringLobeIsOnTheMirrorSide) {
    const rte::Reflection r = solve_cpu({0.9, hg_beta(0.9, 400)}, 32);
    const double mu = std::cos(60.0 * std::numbers::pi / 180.0);
    EXPECT_GT(r.brdf(mu, mu, std::numbers::pi), 3.0 * r.brdf(mu, mu, 0.0));
}

TEST(Grazing, FiniteAndNonNegative) {
    for (double n : {1.0, 1.5}) {
        const rte::Reflection r = solve_cpu({1.0, hg_beta(0.8, 300)}, 16, n);
        for (double a : {0.0, 1e-9, 1e-3, 1.0})
            for (double b : {0.0, 1e-9, 0.5, 1.0})
                for (double phi : {0.0, 2.0, std::numbers::pi}) {
                    const double f = r.brdf(a, b, phi);
                    EXPECT_TRUE(std::isfinite(f) && f >= 0.0) << a << " " << b << " " << phi << ": " << f;
                }
    }
}

} // namespace
} // namespace brdf::test

namespace brdf::test {
namespace {

TEST(Interface, ExternalAlbedoMatchesIndependentValues) {
    // docs/physics.md section 4: external albedo (mirror + diffuse) of a semi-infinite medium under a
    // smooth interface of index 1.5 at normal incidence, derived independently and verified to
    // ~1e-6. A Fresnel term that kept one polarisation, or a radiance factor 1/n instead of 1/n^2,
    // moves these by percents.
    struct Row {
        std::vector<double> beta;
        double values[3]; // omega 0.999, 0.99, 0.9
    };
    const Row rows[] = {{{1.0}, {0.841459, 0.601982, 0.259919}},
                        {hg_beta(0.5, 200), {0.786373, 0.500607, 0.171065}},
                        {hg_beta(0.8, 400), {0.691321, 0.360440, 0.095253}}};
    const double omegas[] = {0.999, 0.99, 0.9};
    for (const Row& row : rows)
        for (int k = 0; k < 3; ++k) {
            const rte::Reflection r = solve_cpu({omegas[k], row.beta}, 64, 1.5);
            EXPECT_NEAR(r.mirror(1.0), 0.04, 1e-15);
            EXPECT_NEAR(r.albedo(1.0) + r.mirror(1.0), row.values[k], 2e-6)
                << "beta_1 " << (row.beta.size() > 1 ? row.beta[1] : 0.0) << " omega " << omegas[k];
        }
}

} // namespace
} // namespace brdf::test
