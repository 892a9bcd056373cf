// Mie benchmarks (run by hand: build-*/bin/bench_mie). The target of the Mie work: the benchmark
// pigment, 41 wavelengths at the default tolerance, under 0.1 s on one core.
//
//   BM_RutilePowerLaw41Wavelengths  rutile (DeVore 1951 indices, (2 n_o + n_e) / 3, k = 0) in a binder of
//                                   index 1.5, power law r_eff = 0.4 um, v_eff = 0.3, 380..780 nm step
//                                   10, EnsembleOptions defaults (tolerance 1e-6): one iteration is the
//                                   whole spectrum. /tol1e5:1 at tolerance 1e-5, what "default"
//                                   accuracy asks of the radius integration (service/model.cpp).
//   BM_SingleSphere/x               one sphere, m = 1.5, efficiencies and Legendre moments, for
//                                   information (x = 1e4 needs 2e4 angular nodes).
//   BM_PhaseIntensities/x           the nested rule's two kernels apart (silica in acrylic, m =
//   BM_PhaseProjection/x            0.98): one sphere's intensities on the angular rule of its own
//                                   series (N + 1 node pairs), and the Legendre projection of that
//                                   rule's sums (2N + 1 moments): what a 40 um matting agent spends
//                                   nearly all its time in, each per node and per level.
//   BM_MattingAgent/r_eff/threads   matting agents: silica spheres (Malitson 1965) in acrylic (PMMA,
//                                   Sultanova et al. 2009), m ~ 0.98, gamma distribution r_eff = 5 or
//                                   40 um, v_eff = 0.1, 380..780 nm step 10 at the tolerance 1e-5 of
//                                   "default" accuracy; the wavelengths on one thread or split over two
//                                   (as the pipeline does; wall-clock time). Target: <= 2 s (5 um) and
//                                   <= 5 s (40 um) on two cores. Three repetitions, median printed.

#include <brdf/core/quadrature.h>
#include <brdf/mie/ensemble.h>
#include <brdf/mie/mie.h>
#include <brdf/mie/phase_function.h>

#include <benchmark/benchmark.h>

#include <cmath>
#include <complex>
#include <thread>
#include <vector>

namespace {

using namespace brdf::mie;

// Rutile, DeVore (1951, JOSA 41, 416): n_o^2 = 5.913 + 0.2441 / (lambda^2 - 0.0803),
// n_e^2 = 7.197 + 0.3322 / (lambda^2 - 0.0843), lambda in um; random orientation (2 n_o + n_e) / 3.
// Valid from 430 nm; used down to 380 nm here as the benchmark prescribes. A temporary inline
// formula: the material catalogue will provide it.
std::complex<double> rutile(double wavelength_nm) {
    const double l2 = wavelength_nm * wavelength_nm * 1e-6;
    const double n_o = std::sqrt(5.913 + 0.2441 / (l2 - 0.0803));
    const double n_e = std::sqrt(7.197 + 0.3322 / (l2 - 0.0843));
    return {(2.0 * n_o + n_e) / 3.0, 0.0};
}

void BM_RutilePowerLaw41Wavelengths(benchmark::State& state) {
    const SizeDistribution sizes = power_law(0.4, 0.3);
    EnsembleOptions options;
    options.tolerance = state.range(0) == 0 ? 1e-6 : 1e-5; // defaults; the pipeline's "default" accuracy
    long nodes = 0, resonances = 0;
    for (auto _ : state) {
        nodes = resonances = 0;
        for (int nm = 380; nm <= 780; nm += 10) {
            const Ensemble e = ensemble(rutile(nm), 1.5, nm, sizes, options);
            benchmark::DoNotOptimize(e.legendre.data());
            nodes += e.radius_nodes;
            resonances += e.resonances;
        }
    }
    state.counters["radius_nodes"] = static_cast<double>(nodes);
    state.counters["resonance_windows"] = static_cast<double>(resonances);
}
BENCHMARK(BM_RutilePowerLaw41Wavelengths)
    ->Arg(0)
    ->Arg(1)
    ->ArgName("tol1e5")
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true);

// Fused silica, Malitson (1965, JOSA 55, 1205): n^2 - 1 = sum B_i l^2 / (l^2 - C_i^2), l in um; PMMA,
// Sultanova et al. (2009, Acta Phys. Pol. A 116, 585): n^2 - 1 = 1.1819 l^2 / (l^2 - 0.011313). The
// formulas of the catalogue's data files (data/refractiveindex), written out as for rutile above.
double silica(double wavelength_nm) {
    const double l2 = wavelength_nm * wavelength_nm * 1e-6;
    return std::sqrt(1.0 + 0.6961663 * l2 / (l2 - 0.0684043 * 0.0684043) +
                     0.4079426 * l2 / (l2 - 0.1162414 * 0.1162414) +
                     0.8974794 * l2 / (l2 - 9.896161 * 9.896161));
}
double pmma(double wavelength_nm) {
    const double l2 = wavelength_nm * wavelength_nm * 1e-6;
    return std::sqrt(1.0 + 1.1819 * l2 / (l2 - 0.011313));
}

void BM_MattingAgent(benchmark::State& state) {
    const SizeDistribution sizes = gamma(static_cast<double>(state.range(0)), 0.1);
    const int threads = static_cast<int>(state.range(1));
    EnsembleOptions options;
    options.tolerance = 1e-5;
    std::vector<int> wavelengths;
    for (int nm = 380; nm <= 780; nm += 10) wavelengths.push_back(nm);
    std::vector<long> nodes(threads);
    const auto share = [&](int t) {
        nodes[t] = 0;
        for (std::size_t i = t; i < wavelengths.size(); i += threads) {
            const double nm = wavelengths[i];
            const Ensemble e = ensemble({silica(nm), 0.0}, pmma(nm), nm, sizes, options);
            benchmark::DoNotOptimize(e.legendre.data());
            nodes[t] += e.radius_nodes;
        }
    };
    for (auto _ : state) {
        if (threads == 1) { // on the benchmark's thread: its CPU time is the work's
            share(0);
            continue;
        }
        std::vector<std::thread> pool;
        for (int t = 0; t < threads; ++t) pool.emplace_back(share, t);
        for (auto& t : pool) t.join();
    }
    long total = 0;
    for (long n : nodes) total += n;
    state.counters["radius_nodes"] = static_cast<double>(total);
}
BENCHMARK(BM_MattingAgent)
    ->ArgsProduct({{5, 40}, {1, 2}})
    ->ArgNames({"r_eff_um", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true)
    ->UseRealTime();

void BM_SingleSphere(benchmark::State& state) {
    const double x = static_cast<double>(state.range(0));
    // The Gauss rule is built once and cached (core/quadrature.h): build it outside the timing.
    brdf::gauss_legendre(2 * series_length(x) + 2);
    std::size_t moments = 0;
    for (auto _ : state) {
        const Sphere s = sphere({1.5, 0.0}, x);
        benchmark::DoNotOptimize(s.q.qext);
        moments = s.legendre.size();
    }
    state.counters["legendre_moments"] = static_cast<double>(moments);
}
BENCHMARK(BM_SingleSphere)->Arg(10)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond);

void BM_PhaseIntensities(benchmark::State& state) {
    const Coefficients c = coefficients({0.98, 0.0}, static_cast<double>(state.range(0)));
    PhaseFunctionAccumulator rule(c.size());
    for (auto _ : state) rule.add(c, 1.0);
    state.counters["pairs"] = static_cast<double>(rule.pairs());
}
BENCHMARK(BM_PhaseIntensities)->Arg(500)->Arg(3000)->Unit(benchmark::kMillisecond);

void BM_PhaseProjection(benchmark::State& state) {
    const Coefficients c = coefficients({0.98, 0.0}, static_cast<double>(state.range(0)));
    PhaseFunctionAccumulator rule(c.size());
    rule.add(c, 1.0);
    LegendreOptions all;
    all.tolerance = 0.0;
    std::size_t moments = 0;
    for (auto _ : state) moments = rule.legendre(all).size();
    state.counters["moments"] = static_cast<double>(moments);
}
BENCHMARK(BM_PhaseProjection)->Arg(500)->Arg(3000)->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
