// Per-order solver benchmarks (run by hand: build-*/bench/bench_solver; set POCL_CACHE_DIR for PoCL).
//
//   BM_Medium/method/backend/omega   all Fourier orders of one medium: Henyey-Greenstein g = 0.5,
//                                    32 streams, setup_reflection with default ReflectionSettings
//                                    otherwise (delta-M, order tolerance 1e-5), no interface.
//                                    method 0 fixed point, 1 doubling, 2 fast (as rte::Method);
//                                    backend 0 the C++ reference (one thread), 1 OpenCL cooperative
//                                    kernel, 2 OpenCL serial kernel (one launch for all orders,
//                                    rte::ClSolverKernel); omega index 0, 1, 2 = 0.9, 0.99999, 1.
//                                    Counters: orders, total iterations over the orders.
//   BM_Order/method/m/omega          one order (C++ reference), m = 0, 1, 4, 16: time and iterations.
//   BM_PencilShifts/streams          ShiftedPencil::solve of a table grid's 181 shifts (the Nystrom
//                                    evaluation off the nodes of one order), one thread.
//   BM_PencilSetup/streams           ShiftedPencil's construction (the Hessenberg reduction of one
//                                    order's D^-1 G), one thread.
//   BM_PencilBatch/streams           eight orders' pencils reduced together (ShiftedPencil::batch, as
//                                    a half-space's Nystrom operators are built), one thread.
// Iterations stop at the "default" accuracy's tolerance (1e-8 relative change).
// The fixed point at omega -> 1 runs to SolveControl's default cap (100000 sweeps) at m = 0: it is the
// baseline the doubling replaces, and slow on purpose.

#include <brdf/cl/context.h>
#include <brdf/rte/cl_solver.h>
#include <brdf/rte/reflection.h>

#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <vector>

namespace {

using namespace brdf::rte;

constexpr double omegas[] = {0.9, 0.99999, 1.0};
// The iteration tolerance of "default" accuracy (service/model.cpp, settings_for(1e-4)).
constexpr double default_tolerance = 1e-8;

std::vector<OrderProblem> medium_problems(double omega) {
    std::vector<double> beta(200);
    for (int l = 0; l < 200; ++l) beta[static_cast<std::size_t>(l)] = (2.0 * l + 1.0) * std::pow(0.5, l);
    ReflectionSettings settings;
    settings.streams = 32;
    return order_problems(setup_reflection(Medium{omega, beta}, Interface{1.0}, settings));
}

void BM_Medium(benchmark::State& state) {
    const auto method = static_cast<Method>(state.range(0));
    const bool opencl = state.range(1) != 0;
    const ClSolverKernel kernel = state.range(1) == 2 ? ClSolverKernel::Serial : ClSolverKernel::Cooperative;
    const double omega = omegas[state.range(2)];
    state.SetLabel(std::string(to_string(method)) +
                   (opencl ? " opencl " + std::string(to_string(kernel)) : std::string(" cpu")) + " omega " +
                   std::to_string(omega));
    if (opencl && !brdf::cl::available()) {
        state.SkipWithError("no OpenCL device with fp64");
        return;
    }
    const std::vector<OrderProblem> problems = medium_problems(omega);
    SolveControl control;
    control.tolerance = default_tolerance;
    if (opencl) solve_orders_opencl(problems, method, control, kernel); // build the program outside the timing
    long iterations = 0;
    for (auto _ : state) {
        const std::vector<OrderSolution> s =
            opencl ? solve_orders_opencl(problems, method, control, kernel) : solve_orders_cpu(problems, method, control);
        iterations = 0;
        for (const OrderSolution& o : s) iterations += o.iterations;
        benchmark::DoNotOptimize(s.data());
    }
    state.counters["orders"] = static_cast<double>(problems.size());
    state.counters["iterations"] = static_cast<double>(iterations);
}
BENCHMARK(BM_Medium)
    ->ArgsProduct({{0, 1, 2}, {0, 1, 2}, {0, 1, 2}})
    ->ArgNames({"method", "opencl", "omega"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// One Fourier order at a time (C++ reference): where the time goes. m = 0 is the slow order for the
// fixed point as omega -> 1; m >= 1 converge in a few sweeps, which the fast method exploits.
void BM_Order(benchmark::State& state) {
    const auto method = static_cast<Method>(state.range(0));
    const int m = static_cast<int>(state.range(1));
    const double omega = omegas[state.range(2)];
    const std::vector<OrderProblem> problems = medium_problems(omega);
    if (m >= static_cast<int>(problems.size())) {
        state.SkipWithError("order beyond the truncation");
        return;
    }
    SolveControl control;
    control.tolerance = default_tolerance;
    int iterations = 0;
    for (auto _ : state) {
        const OrderSolution s = solve_order(problems[m], method, control);
        iterations = s.iterations;
        benchmark::DoNotOptimize(s.x.data().data());
    }
    state.SetLabel(std::string(to_string(method)) + " m " + std::to_string(m) + " omega " + std::to_string(omega));
    state.counters["iterations"] = iterations;
}
BENCHMARK(BM_Order)
    ->ArgsProduct({{0, 1, 2}, {0, 1, 4, 16}, {0, 1, 2}})
    ->ArgNames({"method", "m", "omega"})
    ->Unit(benchmark::kMillisecond);

// A made-up G of the Nystrom operators' shape (the identity less a small dense part) and the node
// cosines as D, spanning `smallest` to 1.
brdf::Matrix pencil_g(int n) {
    brdf::Matrix g(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) g(i, j) = (i == j ? 1.0 : 0.0) - 0.4 * std::cos(0.3 * i * j + 0.1 * j) / n;
    return g;
}

std::vector<double> pencil_d(int n) {
    std::vector<double> d(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) d[i] = std::pow(1e-4, i / (n - 1.0));
    return d;
}

void BM_PencilSetup(benchmark::State& state) {
    const int n = static_cast<int>(state.range(0));
    const brdf::Matrix g = pencil_g(n);
    const std::vector<double> d = pencil_d(n);
    for (auto _ : state) benchmark::DoNotOptimize(brdf::ShiftedPencil(g, d));
}
BENCHMARK(BM_PencilSetup)->Arg(32)->Arg(64)->Arg(96)->Arg(128)->ArgName("streams")->Unit(benchmark::kMicrosecond);

void BM_PencilBatch(benchmark::State& state) {
    const int n = static_cast<int>(state.range(0));
    const std::vector<brdf::Matrix> g(8, pencil_g(n));
    const std::vector<double> d = pencil_d(n);
    for (auto _ : state) benchmark::DoNotOptimize(brdf::ShiftedPencil::batch(g, d));
}
BENCHMARK(BM_PencilBatch)->Arg(32)->Arg(64)->Arg(96)->ArgName("streams")->Unit(benchmark::kMicrosecond);

// The shifts of one order's table grid (181 zenith angles) against a pencil of `streams` nodes, as
// Reflection::half_space_reflector solves them (the time does not depend on G's values).
void BM_PencilShifts(benchmark::State& state) {
    const int n = static_cast<int>(state.range(0)), shifts = 181;
    const brdf::Matrix g = pencil_g(n);
    const std::vector<double> d = pencil_d(n);
    std::vector<double> u(static_cast<std::size_t>(shifts));
    for (int e = 0; e < shifts; ++e) u[e] = std::cos(std::acos(-1.0) / 2.0 * e / (shifts - 1.0)) + 1e-6;
    const brdf::ShiftedPencil pencil(g, d);
    brdf::Matrix b(n, shifts);
    for (auto _ : state) {
        state.PauseTiming();
        for (int i = 0; i < n; ++i)
            for (int e = 0; e < shifts; ++e) b(i, e) = std::sin(1.0 + i + 0.37 * e);
        state.ResumeTiming();
        pencil.solve(u, b);
        benchmark::DoNotOptimize(b.data().data());
    }
}
BENCHMARK(BM_PencilShifts)->Arg(32)->Arg(64)->Arg(128)->ArgName("streams")->Unit(benchmark::kMicrosecond);

} // namespace

BENCHMARK_MAIN();
