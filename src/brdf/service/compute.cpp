#include <brdf/service/compute.h>

#include <brdf/cl/context.h>
#include <brdf/core/atomic_file.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/threads.h>
#include <brdf/core/version.h>
#include <brdf/material/spec.h>
#include <brdf/service/model.h>
#include <brdf/service/report.h>
#include <brdf/service/cl_table_fill.h>
#include <formats/exr/exr.h>
#include <formats/merl/merl.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <future>
#include <mutex>
#include <optional>
#include <unistd.h>

namespace brdf::service {
namespace fs = std::filesystem;
namespace {

constexpr double table_tolerance_floor = 1e-6;

std::vector<std::string> formats_for(const material::MaterialSpec& spec, const ComputeOptions& options) {
    return options.formats.empty() ? spec.outputs : options.formats;
}

fs::path output_path(const fs::path& dir, const std::string& name, const std::string& format) {
    return dir / (name + (format == "merl" ? ".binary" : ".exr"));
}

// Outputs are named by the material and stamped with the spec hash in the report: a rerun (after a
// node failure, or of another shard) skips a material whose report and tables are already there.
bool already_done(const material::MaterialSpec& spec, const fs::path& dir, const std::vector<std::string>& formats) {
    const fs::path report = dir / (spec.name + ".report.json");
    std::ifstream in(report);
    if (!in) return false;
    const auto j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_discarded() || j.value("spec_hash", "") != spec.hash) return false;
    return std::all_of(formats.begin(), formats.end(),
                       [&](const std::string& f) {
                           std::error_code ec; // a folder or a broken link in a table's place is no table
                           return fs::is_regular_file(output_path(dir, spec.name, f), ec);
                       });
}

MaterialOutcome compute_one(const material::MaterialSpec& spec, const ComputeOptions& options) {
    MaterialOutcome outcome;
    outcome.name = spec.name;
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<std::string> formats = formats_for(spec, options);
    if (already_done(spec, options.output_dir, formats)) {
        outcome.ok = outcome.skipped = true;
        log::info(spec.name, ": up to date (spec hash ", spec.hash, "), skipped");
        return outcome;
    }
    // Tables hold float32 (EXR) values at bin centres, filled by interpolating a Fourier grid whose
    // error is about 1e-6 at the finest grid: solving tighter than that changes no table a renderer
    // can tell apart, so the tables' solve stops there (eval on a spec keeps the requested tolerance).
    const double tolerance = std::max(spec.accuracy.tolerance, table_tolerance_floor);
    if (tolerance > spec.accuracy.tolerance)
        log::info(spec.name, ": tables are solved to ", tolerance, ", not the requested ", spec.accuracy.tolerance,
                  " (finer than the tables can hold)");
    SolvedMaterial solved = solve_material(spec, options.device, settings_for(tolerance));
    auto t = std::chrono::steady_clock::now();
    formats::BrdfTable table = fill_table(prepare_fill(solved), options.device);
    table.spec = spec.resolved.dump();
    table.generator = std::string(generator_string);
    solved.seconds.table = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    t = std::chrono::steady_clock::now();
    // The report is the "up to date" stamp: drop an old one before the tables are replaced, so that a
    // kill between two table writes can never leave a report whose spec_hash vouches for tables of
    // another spec (already_done would then skip a job whose outputs are mixed).
    {
        std::error_code ec;
        fs::remove(options.output_dir / (spec.name + ".report.json"), ec);
    }
    // The writers are independent (and the EXR one spends its time compressing): one thread each.
    std::vector<std::future<void>> writes;
    for (const std::string& f : formats) {
        const fs::path path = output_path(options.output_dir, spec.name, f);
        writes.push_back(std::async(std::launch::async, [path, f, &table] {
            if (f == "merl") formats::write_merl(path, table);
            else formats::write_exr(path, table);
        }));
        outcome.outputs.push_back(path);
    }
    for (auto& w : writes) w.get(); // rethrows a writer's error
    solved.seconds.write = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    if (options.preview) {
        const fs::path png = options.output_dir / (spec.name + ".png");
        options.preview(solved, png);
        outcome.outputs.push_back(png);
    }
    const fs::path report = options.output_dir / (spec.name + ".report.json");
    // Through the same AtomicFile as the tables (fsync, rename, fsync of the folder): the stamp is
    // never more durable than what it vouches for, nor less.
    write_file_atomically(report, make_report(solved, formats).dump(1) + "\n");
    outcome.outputs.push_back(report);
    outcome.ok = true;
    outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return outcome;
}

} // namespace

std::vector<MaterialOutcome> compute_files(const std::vector<fs::path>& specs, const ComputeOptions& options) {
    if (options.shard_count < 1 || options.shard_index < 0 || options.shard_index >= options.shard_count)
        throw InputError(cat("--shard: expected I/N with 0 <= I < N (got ", options.shard_index, "/", options.shard_count, ")"));
    // Parse and validate every file before computing anything.
    std::vector<material::MaterialSpec> jobs; // this shard's materials
    std::size_t index = 0;
    std::vector<std::string> names;
    for (const fs::path& file : specs) {
        for (material::MaterialSpec& spec : material::load_specs(file)) {
            if (std::find(names.begin(), names.end(), spec.name) != names.end())
                throw InputError(cat(spec.source, ": name '", spec.name, "' is used by another material; outputs would collide"));
            names.push_back(spec.name);
            if (index % options.shard_count == static_cast<std::size_t>(options.shard_index))
                jobs.push_back(std::move(spec));
            ++index;
        }
    }
    std::error_code ec;
    fs::create_directories(options.output_dir, ec);
    if (ec) throw IoError(cat(options.output_dir.string(), ": cannot create output folder (", ec.message(), ")"));

    std::vector<MaterialOutcome> outcomes(jobs.size());
    std::atomic<std::size_t> finished{0};
    std::mutex print;
    const bool tty = options.progress && isatty(STDERR_FILENO);
    parallel_for(static_cast<int>(jobs.size()), std::max(1, options.jobs), [&](int k) {
        const material::MaterialSpec& spec = jobs[k];
        try {
            outcomes[k] = compute_one(spec, options);
        } catch (const Error& e) {
            outcomes[k] = MaterialOutcome{spec.name, false, false, e.what(), e.kind(), {}, 0.0};
        } catch (const std::exception& e) {
            outcomes[k] = MaterialOutcome{spec.name, false, false, cat("internal error: ", e.what()),
                                          ErrorKind::Numerical, {}, 0.0};
        }
        const std::size_t done = ++finished;
        std::lock_guard lock(print);
        const MaterialOutcome& o = outcomes[k];
        if (!o.ok) log::error(o.name, ": ", o.error);
        else if (tty) std::fprintf(stderr, "\r[%zu/%zu] %-40s %6.2f s\n", done, jobs.size(), o.name.c_str(), o.seconds);
        else log::info("[", done, "/", jobs.size(), "] ", o.name, o.skipped ? " skipped" : " done", " in ", o.seconds, " s");
    });
    return outcomes;
}

void run_compute_job(const fs::path& spec_file, const fs::path& results_dir) {
    ComputeOptions options;
    options.output_dir = results_dir;
    // The daemon runs without a terminal and possibly without an OpenCL platform: fall back to the
    // CPU reference rather than failing every job.
    options.device = cl::available() ? Device::OpenCL : Device::Cpu;
    const auto outcomes = compute_files({spec_file}, options);
    std::string failures;
    std::optional<ErrorKind> kind;
    for (const auto& o : outcomes) {
        if (o.ok) continue;
        failures += cat(failures.empty() ? "" : "; ", o.name, ": ", o.error);
        if (!kind) kind = o.kind;
    }
    if (kind) throw Error(*kind, failures);
}

} // namespace brdf::service
