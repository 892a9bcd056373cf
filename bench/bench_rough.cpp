// What a rough surface costs (issue 16: at most 2x the smooth one), run by hand:
// build-*/bench/bench_rough. One semi-infinite medium (Henyey-Greenstein g = 0.5, omega 0.9, index
// 1.5, 32 streams, order tolerance 1e-5, the fast method on one CPU thread: the "default" settings)
// under a smooth top and rough GGX tops of alpha 0.3, 0.1 and 0.01, height-correlated masking.
//
//   BM_Solve/top      the solve of one wavelength: setup, every Fourier order of the half-space
//                     (solve_orders_cpu) and the Reflection (under a rough top its interface kernels
//                     and the adding per order). top 0 smooth, 1, 2, 3 = alpha 0.3, 0.1, 0.01.
//   BM_OrderGrid/top  the table fill's part of one wavelength: Reflection::order_grid on 91 air
//                     cosines (under a rough top the transmissions to and from those cosines).
// Medians of 5 repetitions; counters: orders.

#include <brdf/rte/reflection.h>

#include <benchmark/benchmark.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

namespace {

using namespace brdf::rte;

constexpr double alphas[] = {0.0, 0.3, 0.1, 0.01}; // 0: smooth

Stack medium_stack(int top) {
    std::vector<double> beta(200);
    for (int l = 0; l < 200; ++l) beta[static_cast<std::size_t>(l)] = (2.0 * l + 1.0) * std::pow(0.5, l);
    Stack s;
    s.top = top == 0 ? Top::Smooth : Top::Rough;
    s.rough = RoughSurface{alphas[top], Microfacet::Ggx, Masking::HeightCorrelated};
    s.layers.push_back(Layer{Medium{0.9, beta}, std::numeric_limits<double>::infinity(), 1.5});
    return s;
}

Reflection solve(const Stack& stack) {
    ReflectionSettings settings; // 32 streams, order tolerance 1e-5, fast
    settings.control.tolerance = 1e-8; // "default" accuracy's iteration tolerance
    StackSetup setup = setup_reflection(stack, settings);
    const std::vector<OrderProblem> problems = order_problems(setup);
    std::vector<OrderSolution> solutions = solve_orders_cpu(problems, settings.method, settings.control);
    return Reflection(std::move(setup), std::move(solutions));
}

std::string label(int top) { return top == 0 ? "smooth" : "rough alpha " + std::to_string(alphas[top]).substr(0, 4); }

void BM_Solve(benchmark::State& state) {
    const int top = static_cast<int>(state.range(0));
    const Stack stack = medium_stack(top);
    int orders = 0;
    for (auto _ : state) {
        const Reflection r = solve(stack);
        orders = r.orders();
        benchmark::DoNotOptimize(&r);
    }
    state.SetLabel(label(top));
    state.counters["orders"] = orders;
}
BENCHMARK(BM_Solve)->DenseRange(0, 3)->ArgName("top")->Unit(benchmark::kMillisecond)->Repetitions(5)
    ->ReportAggregatesOnly(true);

void BM_OrderGrid(benchmark::State& state) {
    const int top = static_cast<int>(state.range(0));
    const Reflection r = solve(medium_stack(top));
    std::vector<double> mu(91);
    for (int a = 0; a < 91; ++a) mu[static_cast<std::size_t>(a)] = std::cos(0.5 * std::numbers::pi * a / 90.0);
    for (auto _ : state) {
        const OrderGrid g = r.order_grid(mu);
        benchmark::DoNotOptimize(g.orders.data());
    }
    state.SetLabel(label(top));
    state.counters["orders"] = r.orders();
}
BENCHMARK(BM_OrderGrid)->DenseRange(0, 3)->ArgName("top")->Unit(benchmark::kMillisecond)->Repetitions(5)
    ->ReportAggregatesOnly(true);

// The kernels alone at the "default" settings' tolerance (rough_kernel_tolerance of 1e-5: 1e-4) for
// the gloss finish (GGX alpha 0.03, n 1.5), streams split at the critical cosine: args streams,
// then 0 for the internal reflection (computed once per stack) or the air cosines' count (the
// table's 91, the probes' 5; transmissions only). Counters: nodes (integrand evaluations).
void BM_InterfaceKernels(benchmark::State& state) {
    const int streams = static_cast<int>(state.range(0)), air_count = static_cast<int>(state.range(1));
    const RoughInterface surface(1.5, RoughSurface{0.03, Microfacet::Ggx, Masking::HeightCorrelated});
    const StreamPieces pieces = split_gauss_pieces(streams / 2, streams - streams / 2, surface.critical());
    std::vector<double> air;
    for (int a = 0; a < air_count; ++a) air.push_back(std::cos(0.5 * std::numbers::pi * a / air_count));
    long long nodes = 0;
    for (auto _ : state) {
        const InterfaceKernels k = interface_kernels(surface, pieces, air, 34, 1e-4, air_count == 0);
        nodes = k.quadrature.nodes;
        benchmark::DoNotOptimize(&k);
    }
    state.counters["nodes"] = static_cast<double>(nodes);
}
BENCHMARK(BM_InterfaceKernels)->ArgsProduct({{24, 32, 48, 64}, {0, 5, 91}})->ArgNames({"streams", "air"})
    ->Unit(benchmark::kMillisecond)->Repetitions(3)->ReportAggregatesOnly(true)->UseRealTime();

} // namespace

BENCHMARK_MAIN();
