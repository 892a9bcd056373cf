// The quadrature study behind rte/streams.h (docs/quadrature-study.md): which rule in mu to solve
// Ambartsumian's equation on. For each rule and node count it prints
//  - the worst relative BRDF error of isotropic scattering against Chandrasekhar's exact solution
//    (omega 0.9 and 1; angles 0 to 89.9 degrees; Nystrom evaluation off the nodes);
//  - the energy-conservation error |A(mu0) - 1| at omega = 1 for Henyey-Greenstein g = 0.9, which
//    needs the rule to integrate the phase function's Fourier components exactly.
// Run: build/bin/quadrature_study (reads tests/reference/rte/chandrasekhar_h.json from the source tree).

#include <brdf/core/quadrature.h>
#include <brdf/rte/reflection.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <numbers>

using namespace brdf;

namespace {

using Rule = std::function<rte::Streams(int)>;

rte::Streams gauss_mu(int n) { return rte::gauss_streams(n); }

rte::Streams gauss_t_squared(int n) { // mu = t^2, t Gauss on (0, 1): crowds nodes near mu = 0
    const Quadrature q = gauss_legendre(n, 0.0, 1.0);
    rte::Streams s;
    for (int i = 0; i < n; ++i) {
        s.mu.push_back(q.x[i] * q.x[i]);
        s.w.push_back(2.0 * q.x[i] * q.w[i]);
    }
    s.exact_degree = n - 1; // polynomials in mu of degree k are degree 2k in t
    return s;
}

rte::Streams gauss_theta(int n) { // theta Gauss on (0, pi/2), weight sin(theta)
    const Quadrature q = gauss_legendre(n, 0.0, 0.5 * std::numbers::pi);
    rte::Streams s;
    for (int i = n - 1; i >= 0; --i) {
        s.mu.push_back(std::cos(q.x[i]));
        s.w.push_back(std::sin(q.x[i]) * q.w[i]);
    }
    s.exact_degree = 1;
    return s;
}

rte::Reflection solve_with(const rte::Medium& medium, const rte::Streams& streams) {
    // A half-space on a custom rule: the stack set up by hand (setup_stack would choose Gauss in mu).
    rte::StackSetup setup;
    setup.stack = rte::half_space(medium);
    rte::LayerSetup layer;
    layer.layer = setup.stack.layers.front();
    layer.truncated = rte::delta_m(medium, 2 * streams.size());
    layer.tau = layer.layer.tau;
    layer.streams = streams;
    for (double mu : streams.mu) layer.s.push_back(std::sqrt(1.0 - mu * mu));
    layer.below_of.assign(streams.mu.size(), -1);
    layer.orders = static_cast<int>(layer.truncated.scaled.beta.size());
    setup.orders = layer.orders;
    setup.layers.push_back(std::move(layer));
    const auto problems = rte::order_problems(setup);
    auto solutions = rte::solve_orders_cpu(problems, rte::Method::Doubling, {});
    return rte::Reflection(std::move(setup), std::move(solutions));
}

} // namespace

int main() {
    std::ifstream in(std::string(BRDF_SOURCE_DIR) + "/tests/reference/rte/chandrasekhar_h.json");
    const auto ref = nlohmann::json::parse(in);
    const std::pair<const char*, Rule> rules[] = {
        {"Gauss in mu", gauss_mu}, {"Gauss in t, mu = t^2", gauss_t_squared}, {"Gauss in theta", gauss_theta}};
    std::printf("%-22s %5s %14s %14s %16s\n", "rule", "N", "iso w=0.9", "iso w=1", "HG0.9 |A-1|");
    for (const auto& [name, rule] : rules) {
        for (int n : {8, 16, 24, 32, 48, 64}) {
            double err[2] = {0, 0};
            int k = 0;
            for (const auto& c : ref["cases"]) {
                const double om = c["omega"];
                if (om != 0.9 && om != 1.0) continue;
                const rte::Reflection r = solve_with({om, {1.0}}, rule(n));
                const std::vector<double> mu = c["mu"], h = c["h"];
                for (std::size_t i = 0; i < mu.size(); ++i)
                    for (std::size_t o = 0; o < mu.size(); ++o) {
                        const double exact = 0.25 * om * h[i] * h[o] / (mu[i] + mu[o]) / std::numbers::pi;
                        err[k] = std::max(err[k], std::abs(r.brdf(mu[i], mu[o], 0.3) - exact) / exact);
                    }
                ++k;
            }
            std::vector<double> hg(400);
            for (int l = 0; l < 400; ++l) hg[l] = (2 * l + 1) * std::pow(0.9, l);
            const rte::Reflection r = solve_with({1.0, hg}, rule(n));
            double cons = 0.0;
            for (double mu0 : {1.0, 0.5, 0.1}) cons = std::max(cons, std::abs(r.albedo(mu0) - 1.0));
            std::printf("%-22s %5d %14.2e %14.2e %16.2e\n", name, n, err[0], err[1], cons);
        }
    }
}
