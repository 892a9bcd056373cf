#include <brdf/service/compute.h>

#include <brdf/cl/context.h>
#include <brdf/core/atomic_file.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/parse.h>
#include <brdf/core/progress.h>
#include <brdf/core/threads.h>
#include <brdf/core/version.h>
#include <brdf/material/spec.h>
#include <brdf/model/model.h>
#include <brdf/service/renderer_outputs.h>
#include <brdf/service/report.h>
#include <brdf/model/cl_table_fill.h>
#include <brdf/material/colour.h>
#include <brdf/model/table_fill.h>
#include <formats/exr/exr.h>
#include <formats/exr/spectral_exr.h>
#include <formats/merl/merl.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <future>
#include <map>
#include <mutex>
#include <new>
#include <optional>

namespace brdf::service {
namespace fs = std::filesystem;
namespace {

constexpr double table_tolerance_floor = 1e-6;

std::vector<std::string> formats_for(const material::MaterialSpec& spec, const ComputeOptions& options) {
    return options.formats.empty() ? spec.outputs : options.formats;
}

fs::path output_path(const fs::path& dir, const std::string& name, const std::string& format) {
    if (format == "spectral_exr") return dir / (name + ".spectral.exr");
    if (format == "fourier") return dir / (name + ".fourier.bsdf");
    if (format == "rgl") return dir / (name + ".rgl.bsdf");
    return dir / (name + (format == "merl" ? ".binary" : ".exr"));
}

/// The spectral output refuses what has no spectrum before anything is solved.
void check_spectral_output(const material::MaterialSpec& spec, const std::vector<std::string>& formats) {
    if (std::find(formats.begin(), formats.end(), "spectral_exr") == formats.end()) return;
    if (!spec.layers.empty() && spec.layers[0].medium)
        throw InputError(cat(spec.source.empty() ? spec.name : spec.source, ": material '", spec.name,
                             "': the output \"spectral_exr\" needs wavelengths, and an analytic "
                             "\"medium\" is given per RGB channel; use \"merl\" or \"exr\""));
}

/// NAME.spectral.exr (formats/exr/spectral_exr.h, the JCGT 2021 layout): one plane per solved
/// wavelength, the same cells as the RGB tables. Each plane is the RGB fill with a one-hot colour
/// weight, three wavelengths per pass (model::for_each_spectral_fill), on the same device.
void write_spectral_table(const fs::path& path, const model::SolvedMaterial& solved, const std::string& spec_json,
                          model::Device device) {
    std::vector<double> wavelengths;
    for (const model::WavelengthSolution& s : solved.samples) wavelengths.push_back(s.wavelength_nm);
    formats::SpectralTable table(wavelengths);
    table.spec = spec_json;
    table.generator = std::string(generator_string);
    const auto t0 = std::chrono::steady_clock::now();
    int passes = 0;
    model::for_each_spectral_fill(solved, [&](const model::SpectralFill& group) {
        ++passes;
        const formats::BrdfTable filled = model::fill_table(group.inputs, device);
        for (int c = 0; c < 3; ++c) {
            if (group.sample[c] < 0) continue;
            std::vector<float>& plane = table.planes[static_cast<std::size_t>(group.sample[c])];
            for (std::size_t cell = 0; cell < plane.size(); ++cell)
                plane[cell] = filled.has_data(cell) ? static_cast<float>(filled.plane(c)[cell])
                                                    : formats::SpectralTable::no_data;
        }
    });
    const auto t1 = std::chrono::steady_clock::now();
    formats::write_spectral_exr(path, table);
    log::info(solved.spec.name, ": spectral table of ", wavelengths.size(), " wavelengths filled in ", passes,
              " passes (", std::chrono::duration<double>(t1 - t0).count(), " s), written in ",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count(), " s");
}

/// The --accuracy override as a spec overlay (material::parse_specs): {"accuracy": "draft"} or
/// {"accuracy": {"tolerance": 0.001}}; empty when there is none.
nlohmann::json accuracy_overlay(const std::string& accuracy) {
    if (accuracy.empty()) return nlohmann::json::object();
    if (accuracy == "draft" || accuracy == "default" || accuracy == "reference")
        return {{"accuracy", accuracy}};
    const std::string expected = cat("--accuracy: expected draft, default, reference or a relative "
                                     "tolerance in (0, 0.5] such as 1e-3 (got '", accuracy, "')");
    double tolerance = 0.0;
    try {
        tolerance = parse_double(accuracy, "--accuracy");
    } catch (const InputError&) {
        throw InputError(expected);
    }
    if (!(tolerance > 0.0 && tolerance <= 0.5)) throw InputError(expected);
    return {{"accuracy", {{"tolerance", tolerance}}}};
}

/// DIR/NAME.report.json as JSON, or nullopt when it is missing or unreadable.
std::optional<nlohmann::json> read_report(const fs::path& dir, const std::string& name) {
    std::ifstream in(dir / (name + ".report.json"));
    if (!in) return std::nullopt;
    auto j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return std::nullopt;
    return j;
}

// Outputs are named by the material and stamped with the spec hash in the report: a rerun (after a
// node failure, or of another shard) skips a material whose report and tables are already there.
bool already_done(const material::MaterialSpec& spec, const std::optional<nlohmann::json>& report,
                  const fs::path& dir, const std::vector<std::string>& formats) {
    if (!report || report->value("spec_hash", "") != spec.hash) return false;
    return std::all_of(formats.begin(), formats.end(),
                       [&](const std::string& f) {
                           std::error_code ec; // a folder or a broken link in a table's place is no table
                           return fs::is_regular_file(output_path(dir, spec.name, f), ec);
                       });
}

/// Materials being computed by daemon jobs of this process, by name: two jobs that define one
/// material name with different content must not write the same results at once. (Identical
/// content may: both write the same bytes, each file atomically.)
class MaterialsInFlight {
public:
    struct Owner {
        std::string job, hash;
        int count = 0;
    };
    /// Registers `job` as computing `name` from content `hash`; returns the other job when one
    /// computes `name` from other content (and registers nothing).
    std::optional<std::string> enter(const std::string& name, const std::string& job, const std::string& hash) {
        std::lock_guard lock(m_mutex);
        Owner& o = m_owners[name];
        if (o.count > 0 && o.hash != hash) return o.job;
        if (o.count == 0) o = {job, hash, 0};
        ++o.count;
        return std::nullopt;
    }
    void leave(const std::string& name) {
        std::lock_guard lock(m_mutex);
        if (--m_owners[name].count <= 0) m_owners.erase(name);
    }

private:
    std::mutex m_mutex;
    std::map<std::string, Owner> m_owners;
};

MaterialsInFlight& materials_in_flight() {
    static MaterialsInFlight registry;
    return registry;
}

/// Refuses a daemon job's material when its results belong to another job: results/NAME.* are
/// named by the material alone, so a second spec defining the same name would silently replace
/// the first one's tables. The same job (a resubmitted, edited spec) may replace its own results;
/// the same content under any job is "up to date" and never gets here.
void check_results_owner(const material::MaterialSpec& spec, const std::optional<nlohmann::json>& report,
                         const ComputeOptions& options) {
    if (options.job.empty() || !report) return;
    const std::string owner = report->value("job", "");
    if (owner.empty() || owner == options.job || report->value("spec_hash", "") == spec.hash) return;
    throw InputError(cat(options.job, ": material '", spec.name, "' is already in ",
                         (options.output_dir / (spec.name + ".report.json")).string(),
                         " from job ", owner, " with other content (spec hash ",
                         report->value("spec_hash", "?"), "); give this material another name, or "
                         "resubmit it as ", owner, " to replace those results"));
}

MaterialOutcome compute_one(const material::MaterialSpec& spec, const ComputeOptions& options,
                            ProgressLine* line) {
    MaterialOutcome outcome;
    outcome.name = spec.name;
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<std::string> formats = formats_for(spec, options);
    // The stages as they are called below; solve_material does the optics (Lorenz-Mie) first, and
    // weighs them by their projected seconds where they take long (model::feedback_on).
    Progress progress(spec.name, {{"optics", 0.1}, {"solve", 0.35}, {"table", 0.45}, {"write", 0.1}}, line);
    std::optional<std::string> other_job;
    if (!options.job.empty() && (other_job = materials_in_flight().enter(spec.name, options.job, spec.hash)))
        throw InputError(cat(options.job, ": material '", spec.name, "' is being computed by job ", *other_job,
                             " from other content; give this material another name, or submit it "
                             "again once ", *other_job, " is done"));
    struct Leave {
        const ComputeOptions& options;
        const std::string& name;
        ~Leave() {
            if (!options.job.empty()) materials_in_flight().leave(name);
        }
    } leave{options, spec.name};
    const std::optional<nlohmann::json> old_report = read_report(options.output_dir, spec.name);
    if (!options.force && already_done(spec, old_report, options.output_dir, formats)) {
        outcome.ok = outcome.skipped = true;
        return outcome;
    }
    check_results_owner(spec, old_report, options);
    check_spectral_output(spec, formats);
    progress.stage("optics");
    // Tables hold float32 (EXR) values at bin centres, filled by interpolating a Fourier grid whose
    // error is about 1e-6 at the finest grid: solving tighter than that changes no table a renderer
    // can tell apart, so the tables' solve stops there (eval on a spec keeps the requested tolerance).
    const double tolerance = std::max(spec.accuracy.tolerance, table_tolerance_floor);
    if (tolerance > spec.accuracy.tolerance)
        log::info(spec.name, ": tables are solved to ", tolerance, ", not the requested ", spec.accuracy.tolerance,
                  " (finer than the tables can hold)");
    // The MERL/EXR table only when one of them is written (the renderer formats use `fill`): a
    // table is 35 MB, filled once (an empty one first would be zeroed and marked for nothing).
    const bool tabulated =
        std::any_of(formats.begin(), formats.end(), [](const std::string& f) { return f == "merl" || f == "exr"; });
    // The fill's program loads on the thread that opens the device (PoCL reads it from its cache
    // through LLVM, on one core) while the per-order grids are made; a failure is left to the fill,
    // which loads it again and says why.
    model::SolvedMaterial solved =
        model::solve_material(spec, options.device, model::settings_for(tolerance), model::feedback_on(progress),
                              tabulated ? model::DeviceCheck::CallerFillsTable : model::DeviceCheck::Caller);
    progress.stage("table");
    auto t = std::chrono::steady_clock::now();
    const model::FillInputs fill = model::prepare_fill(solved);
    const std::string spec_json = spec.resolved.dump();
    std::optional<formats::BrdfTable> table;
    if (tabulated) {
        table = model::fill_table(fill, options.device);
        table->spec = spec_json;
        table->generator = std::string(generator_string);
        table->colorspace = std::string(material::to_string(spec.colorspace)); // EXR chromaticities follow
    }
    // The device asked for, where the batch had nothing for it and no table was filled: there
    // before anything is written (DeviceError otherwise), and named in the report.
    if (solved.device.empty()) solved.device = model::device_label(options.device);
    solved.seconds.table = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    progress.stage("write");
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
        writes.push_back(std::async(std::launch::async, [path, f, &table, &spec_json, &solved, &options, &fill] {
            if (f == "merl") formats::write_merl(path, *table);
            else if (f == "spectral_exr") write_spectral_table(path, solved, spec_json, options.device);
            else if (f == "fourier") write_fourier_output(path, solved, fill, renderer_resolution(solved.settings.tolerance));
            else if (f == "rgl") write_rgl_output(path, solved, fill, renderer_resolution(solved.settings.tolerance));
            else formats::write_exr(path, *table);
        }));
        outcome.outputs.push_back(path);
        if (f == "rgl" && rgl_output_spectral(solved)) outcome.outputs.push_back(rgl_rgb_companion_path(path));
    }
    for (auto& w : writes) w.get(); // rethrows a writer's error
    solved.seconds.write = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    if (options.preview) {
        const fs::path png = options.output_dir / (spec.name + ".png");
        options.preview(solved, png);
        outcome.outputs.push_back(png);
    }
    const fs::path report = options.output_dir / (spec.name + ".report.json");
    nlohmann::json report_json = make_report(solved, formats);
    if (!options.job.empty()) report_json["job"] = options.job;
    for (const std::string& w : options.warnings) report_json["warnings"].push_back(w);
    // Through the same AtomicFile as the tables (fsync, rename, fsync of the folder): the stamp is
    // never more durable than what it vouches for, nor less.
    write_file_atomically(report, report_json.dump(1) + "\n");
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
    const nlohmann::json overlay = accuracy_overlay(options.accuracy);
    std::vector<material::MaterialSpec> jobs; // this shard's materials
    std::size_t index = 0;
    std::vector<std::string> names;
    for (const fs::path& file : specs) {
        for (material::MaterialSpec& spec : material::load_specs(file, overlay)) {
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
    ProgressLine line(options.progress ? ProgressLine::terminal() : ProgressLine::Options{});
    line.set_total(jobs.size());
    parallel_for(static_cast<int>(jobs.size()), std::max(1, options.jobs), [&](int k) {
        const material::MaterialSpec& spec = jobs[k];
        const auto t0 = std::chrono::steady_clock::now();
        // The per-material error boundary (see compute.h): whatever one material throws fails it
        // alone. A brdf::Error keeps its kind; any other exception is a bug (kind Internal, exit
        // status 70), except running out of memory, which is a resource limit.
        const auto failed = [&](ErrorKind kind, const std::string& message) {
            MaterialOutcome o;
            o.name = spec.name;
            o.error = message;
            o.kind = kind;
            o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            return o;
        };
        try {
            outcomes[k] = compute_one(spec, options, &line);
        } catch (const Error& e) {
            outcomes[k] = failed(e.kind(), e.what());
        } catch (const std::bad_alloc&) {
            outcomes[k] = failed(ErrorKind::Limit, "out of memory");
        } catch (const std::exception& e) {
            outcomes[k] = failed(ErrorKind::Internal, cat("internal error: ", e.what()));
        }
        const std::size_t done = ++finished;
        const MaterialOutcome& o = outcomes[k];
        // One line per material; a failure's message is the caller's to print, once.
        const std::string what = !o.ok ? cat("failed (", to_string(o.kind), ")")
                                 : o.skipped ? cat("up to date (spec hash ", spec.hash, "), skipped")
                                             : cat("done in ", format_duration(o.seconds));
        // "[2/8] NAME done in 3.42 s": scripts read these lines (tests/cluster/shard_test.sh).
        if (line.enabled()) line.print(cat("[", done, "/", jobs.size(), "] ", o.name, " ", what));
        else log::info("[", done, "/", jobs.size(), "] ", o.name, " ", what);
    });
    return outcomes;
}

void run_compute_job(const fs::path& spec_file, const fs::path& results_dir) {
    ComputeOptions options;
    options.output_dir = results_dir;
    options.job = spec_file.filename().string();
    // The daemon runs without a terminal and possibly without an OpenCL platform: fall back to the
    // CPU reference rather than failing every job, and say so (once in the log, in every report).
    if (cl::available()) {
        options.device = model::Device::OpenCL;
    } else {
        options.device = model::Device::Cpu;
        const std::string why = cat("OpenCL unavailable (", cl::unavailable_reason(),
                                    "): computed with the CPU reference instead");
        static std::once_flag logged;
        std::call_once(logged, [&] { log::warn(why); });
        options.warnings.push_back(why);
    }
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
