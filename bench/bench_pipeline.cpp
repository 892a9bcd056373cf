// End-to-end stages of the seed material (rutile in acrylic, visible spectrum, default accuracy):
// optics (Mie per wavelength), the batched solve, the table fill, and writing both tables.
// Run: build/bin/bench_pipeline [--benchmark_filter=...]

#include <brdf/material/spec.h>
#include <brdf/core/error.h>
#include <brdf/model/cl_table_fill.h>
#include <brdf/model/model.h>
#include <brdf/model/table_fill.h>

#include <benchmark/benchmark.h>

#include <thread>

namespace {

using namespace brdf;

const char* seed_spec = R"({"name": "seed-tio2-white", "binder": {"material": "pmma"},
  "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.10,
                "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}]})";

material::MaterialSpec seed() { return material::parse_specs_text(seed_spec, "seed").at(0); }

void BM_SolveSeed(benchmark::State& state) {
    const auto spec = seed();
    const auto device = state.range(0) ? model::Device::OpenCL : model::Device::Cpu;
    for (auto _ : state) {
        const model::SolvedMaterial m = model::solve_material(spec, device);
        state.counters["optics_s"] = m.seconds.optics;
        state.counters["solve_s"] = m.seconds.solve;
        state.counters["wavelengths"] = static_cast<double>(m.samples.size());
    }
}
BENCHMARK(BM_SolveSeed)->Arg(0)->Arg(1)->ArgName("opencl")->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_FillSeed(benchmark::State& state) {
    const model::SolvedMaterial m = model::solve_material(seed(), model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    const int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    for (auto _ : state) benchmark::DoNotOptimize(model::fill_table_cpu(in, threads));
    state.counters["orders"] = in.orders;
    state.counters["samples"] = in.samples;
}
BENCHMARK(BM_FillSeed)->Unit(benchmark::kMillisecond)->Iterations(2);

// The same fill on the OpenCL device (one launch, one work-item per cell; includes the transfers).
void BM_FillSeedOpenCL(benchmark::State& state) {
    const model::SolvedMaterial m = model::solve_material(seed(), model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    try {
        benchmark::DoNotOptimize(model::fill_table_opencl(in)); // build the program outside the timing
    } catch (const Error& e) {
        state.SkipWithError(e.what());
        return;
    }
    for (auto _ : state) benchmark::DoNotOptimize(model::fill_table_opencl(in));
    state.counters["orders"] = in.orders;
    state.counters["samples"] = in.samples;
}
BENCHMARK(BM_FillSeedOpenCL)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_PrepareFillSeed(benchmark::State& state) {
    const model::SolvedMaterial m = model::solve_material(seed(), model::Device::Cpu);
    for (auto _ : state) benchmark::DoNotOptimize(model::prepare_fill(m));
}
BENCHMARK(BM_PrepareFillSeed)->Unit(benchmark::kMillisecond)->Iterations(2);

} // namespace

BENCHMARK_MAIN();
