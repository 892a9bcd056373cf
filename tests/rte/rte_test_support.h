#pragma once
// Shared helpers of the rte tests: analytic phase functions and solving a medium on the CPU.

#include <brdf/rte/reflection.h>

#include <cmath>
#include <vector>

namespace brdf::test {

inline std::vector<double> hg_beta(double g, int count) {
    std::vector<double> b(static_cast<std::size_t>(count));
    for (int l = 0; l < count; ++l) b[l] = (2.0 * l + 1.0) * std::pow(g, l);
    return b;
}

inline std::vector<double> rayleigh_beta() { return {1.0, 0.0, 0.5}; }

inline rte::Reflection solve_cpu(const rte::Medium& medium, int streams, double n = 1.0,
                                 rte::Method method = rte::Method::Doubling) {
    rte::ReflectionSettings settings;
    settings.streams = streams;
    settings.method = method;
    settings.order_tolerance = 1e-12;
    rte::StackSetup setup = rte::setup_reflection(medium, rte::Interface{n}, settings);
    const auto problems = rte::order_problems(setup);
    auto solutions = rte::solve_orders_cpu(problems, method, settings.control);
    return rte::Reflection(std::move(setup), std::move(solutions));
}

} // namespace brdf::test
