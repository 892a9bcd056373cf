// End-to-end stages of the seed material (rutile in acrylic, visible spectrum, default accuracy):
// optics (Mie per wavelength), the batched solve, the table fill, and writing both tables. The same
// stages of the HG half-space that bench/interactive.py times against DISORT (BM_*Hg).
// Run: build/bin/bench_pipeline [--benchmark_filter=...]

#include <brdf/material/spec.h>
#include <brdf/core/error.h>
#include <brdf/model/cl_table_fill.h>
#include <brdf/model/model.h>
#include <brdf/model/table_fill.h>
#include <formats/exr/exr.h>
#include <formats/merl/merl.h>

#include <benchmark/benchmark.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <thread>

#include <unistd.h>

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

// The seed material as a half-space (0), a 25 um film over a white substrate of albedo 0.8 (1) and
// that film under a 20 um clear acrylic coat (2): solve plus the table's per-order grids (what the
// film changes; the fill itself is the same), CPU. The issue's target: a film <= 2x the half-space.
material::MaterialSpec seed_shape(int shape) {
    nlohmann::json spec = nlohmann::json::parse(seed_spec);
    if (shape == 0) return material::parse_specs_text(spec.dump(), "seed").at(0);
    nlohmann::json film = {{"binder", spec["binder"]}, {"pigments", spec["pigments"]}, {"thickness_um", 25}};
    nlohmann::json out = {{"name", shape == 1 ? "seed-film" : "seed-coated"}, {"substrate", {{"albedo", 0.8}}}};
    out["layers"] = shape == 1 ? nlohmann::json::array({film})
                               : nlohmann::json::array({{{"binder", spec["binder"]}, {"thickness_um", 20}}, film});
    return material::parse_specs_text(out.dump(), "seed").at(0);
}

void BM_SeedShapes(benchmark::State& state) {
    const auto spec = seed_shape(static_cast<int>(state.range(0)));
    for (auto _ : state) {
        const model::SolvedMaterial m = model::solve_material(spec, model::Device::Cpu);
        benchmark::DoNotOptimize(model::prepare_fill(m));
        state.counters["solve_s"] = m.seconds.solve;
        state.counters["streams"] = m.settings.streams;
        state.counters["wavelengths"] = static_cast<double>(m.samples.size());
    }
}
BENCHMARK(BM_SeedShapes)->Arg(0)->Arg(1)->Arg(2)->ArgName("shape")->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_FillSeed(benchmark::State& state) {
    const model::SolvedMaterial m = model::solve_material(seed(), model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    const int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    for (auto _ : state) benchmark::DoNotOptimize(model::fill_table_cpu(in, threads));
    state.counters["orders"] = in.orders;
    state.counters["samples"] = in.samples;
}
BENCHMARK(BM_FillSeed)->Unit(benchmark::kMillisecond)->Iterations(2);

// The same cells one at a time (cell_value, the reference the lanes of BM_FillSeed equal bit for bit).
void BM_FillSeedReference(benchmark::State& state) {
    const model::SolvedMaterial m = model::solve_material(seed(), model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    const int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    for (auto _ : state) benchmark::DoNotOptimize(model::fill_table_reference(in, threads));
}
BENCHMARK(BM_FillSeedReference)->Unit(benchmark::kMillisecond)->Iterations(2);

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

// The parts of the fill: the multiply scattered orders alone (no single-scattering terms), the
// single scattering alone (no orders) and neither (the cells' geometry, the launch and the
// read-back), on the OpenCL device.
void BM_FillSeedParts(benchmark::State& state) {
    const model::SolvedMaterial m = model::solve_material(seed(), model::Device::Cpu);
    model::FillInputs in = model::prepare_fill(m);
    if (state.range(0) != 1) {
        in.samples = 0;
        in.phase.clear(), in.refractive_index.clear(), in.transmission.clear(), in.tau.clear();
    }
    if (state.range(0) != 0) {
        in.orders = 0;
        in.fourier.clear();
    }
    benchmark::DoNotOptimize(model::fill_table_opencl(in));
    for (auto _ : state) benchmark::DoNotOptimize(model::fill_table_opencl(in));
    const char* labels[] = {"orders only", "single scattering only", "geometry only"};
    state.SetLabel(labels[state.range(0)]);
}
BENCHMARK(BM_FillSeedParts)->Arg(0)->Arg(1)->Arg(2)->ArgName("part")->Unit(benchmark::kMillisecond)->Iterations(2);

// The HG half-space of the DISORT row (bench/interactive.py): a grey table, 16 orders, no interface.
material::MaterialSpec hg_spec() {
    return material::parse_specs_text(
        R"({"name": "hg", "medium": {"albedo": 0.99, "phase": {"type": "henyey_greenstein", "g": 0.5}},
            "accuracy": {"tolerance": 1e-6}, "spectrum": "rgb"})", "hg").at(0);
}

model::FillInputs hg_fill_inputs() { return model::prepare_fill(model::solve_material(hg_spec(), model::Device::Cpu)); }

// The HG half-space's solve: its stream check, whose probe at the chosen count is its one sample.
void BM_SolveHg(benchmark::State& state) {
    for (auto _ : state) benchmark::DoNotOptimize(model::solve_material(hg_spec(), model::Device::Cpu));
}
BENCHMARK(BM_SolveHg)->Unit(benchmark::kMillisecond)->Iterations(10)->Repetitions(3);

// Its table's per-order grids (the Nystrom evaluation at 181 zenith angles per order), each from a
// fresh solve as in a command (the solution keeps what one evaluation sets up for the next).
void BM_PrepareFillHg(benchmark::State& state) {
    for (auto _ : state) {
        state.PauseTiming();
        const model::SolvedMaterial m = model::solve_material(hg_spec(), model::Device::Cpu);
        state.ResumeTiming();
        benchmark::DoNotOptimize(model::prepare_fill(m));
    }
}
BENCHMARK(BM_PrepareFillHg)->Unit(benchmark::kMillisecond)->Iterations(10)->Repetitions(3);

// Its table fill: the C++ lanes (0) or the OpenCL kernel (1), both over every core.
void BM_FillHg(benchmark::State& state) {
    const model::FillInputs in = hg_fill_inputs();
    const bool opencl = state.range(0) != 0;
    const int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    try {
        if (opencl) benchmark::DoNotOptimize(model::fill_table_opencl(in)); // build the program outside the timing
    } catch (const Error& e) {
        state.SkipWithError(e.what());
        return;
    }
    for (auto _ : state)
        benchmark::DoNotOptimize(opencl ? model::fill_table_opencl(in) : model::fill_table_cpu(in, threads));
    state.counters["orders"] = in.orders;
}
BENCHMARK(BM_FillHg)->Arg(0)->Arg(1)->ArgName("opencl")->Unit(benchmark::kMillisecond)->Iterations(10)->Repetitions(3);

void BM_PrepareFillSeed(benchmark::State& state) {
    const model::SolvedMaterial m = model::solve_material(seed(), model::Device::Cpu);
    for (auto _ : state) benchmark::DoNotOptimize(model::prepare_fill(m));
}
BENCHMARK(BM_PrepareFillSeed)->Unit(benchmark::kMillisecond)->Iterations(2);

// Writing the seed's table as compute does (a temporary file, written, fsynced and renamed):
// MERL (0) or OpenEXR (1). The file is removed between runs, outside the timing.
void BM_WriteSeedTable(benchmark::State& state) {
    const model::FillInputs in = model::prepare_fill(model::solve_material(seed(), model::Device::Cpu));
    const int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    const formats::BrdfTable table = model::fill_table_cpu(in, threads);
    const bool exr = state.range(0) != 0;
    const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                       ("brdf-bench-" + std::to_string(::getpid()) + (exr ? ".exr" : ".binary"));
    for (auto _ : state) {
        exr ? formats::write_exr(path, table) : formats::write_merl(path, table);
        state.PauseTiming();
        std::filesystem::remove(path);
        state.ResumeTiming();
    }
}
BENCHMARK(BM_WriteSeedTable)->Arg(0)->Arg(1)->ArgName("exr")->Unit(benchmark::kMillisecond)->Iterations(5)->Repetitions(3);

} // namespace

BENCHMARK_MAIN();
