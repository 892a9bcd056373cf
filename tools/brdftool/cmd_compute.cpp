// brdftool compute: every material of the given specs or catalogues -> DIR/NAME.binary, NAME.exr,
// NAME.report.json (docs/design.md). Exit status 0 only if every material succeeded.

#include "commands.h"
#include "source.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/parse.h>
#include <brdf/core/progress.h>
#include <brdf/preview/preview.h>
#include <brdf/service/compute.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <unistd.h>

namespace brdf::tool {
namespace {

struct ComputeFlags {
    std::vector<std::string> specs;
    std::string output = "out";
    std::vector<std::string> formats;
    std::string shard;
    int jobs = 1;
    bool preview = false;
    bool force = false;
    std::string accuracy;
    DeviceFlag device;
};

void parse_shard(const std::string& text, service::ComputeOptions& options) {
    const auto slash = text.find('/');
    if (slash == std::string::npos) throw InputError(cat("--shard: expected I/N, e.g. 0/4 (got '", text, "')"));
    const double i = parse_double(text.substr(0, slash), "--shard I"), n = parse_double(text.substr(slash + 1), "--shard N");
    if (i != std::floor(i) || n != std::floor(n) || n < 1 || i < 0 || i >= n)
        throw InputError(cat("--shard: expected integers I/N with 0 <= I < N (got '", text, "')"));
    options.shard_index = static_cast<int>(i);
    options.shard_count = static_cast<int>(n);
}

int run_compute(const ComputeFlags& f) {
    service::ComputeOptions options;
    options.output_dir = f.output;
    options.formats = f.formats;
    options.device = f.device.device();
    options.jobs = f.jobs;
    options.accuracy = f.accuracy;
    options.force = f.force;
    options.progress = isatty(STDERR_FILENO); // a bar on a terminal; quiet in logs and pipes
    if (!f.shard.empty()) parse_shard(f.shard, options);
    if (f.preview) options.preview = preview::write_preview;
    std::vector<std::filesystem::path> files(f.specs.begin(), f.specs.end());
    const auto t0 = std::chrono::steady_clock::now();
    const auto outcomes = service::compute_files(files, options);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // Each failure once, here at the end where it is not scrolled away by the others' progress.
    int failed = 0, skipped = 0;
    for (const auto& o : outcomes) {
        if (!o.ok) {
            ++failed;
            std::fprintf(stderr, "brdftool: %s: %s\n", o.name.c_str(), o.error.c_str());
        }
        skipped += o.skipped;
    }
    // The summary line, always (terminal or not).
    std::fprintf(stderr, "brdftool compute: %zu materials, %zu written, %d up to date, %d failed -> %s (%s)\n",
                 outcomes.size(), outcomes.size() - failed - skipped, skipped, failed, f.output.c_str(),
                 format_duration(seconds).c_str());
    return failed > 0 ? 1 : 0; // documented: 1 when at least one material failed
}

} // namespace

Subcommand add_compute_command(CLI::App& root) {
    auto flags = std::make_shared<ComputeFlags>();
    CLI::App* app = root.add_subcommand("compute", "Compute BRDF tables and reports for every material of specs or catalogues");
    app->add_option("spec", flags->specs, "material spec or catalogue files (.json)")->required();
    app->add_option("-o,--output", flags->output, "output folder (created if missing; default out)");
    app->add_option("--formats", flags->formats,
                    "formats to write: merl, exr, fourier, rgl, spectral_exr (default: each spec's outputs)")
        ->delimiter(',')
        ->check(CLI::IsMember({"merl", "exr", "fourier", "rgl", "spectral_exr"}));
    app->add_option("--shard", flags->shard, "I/N: compute materials I, I+N, I+2N, ... (cluster job arrays)");
    app->add_flag("--preview", flags->preview, "also write DIR/NAME.png, a sphere rendering of each material");
    app->add_option("--jobs", flags->jobs, "materials computed at once (default 1)")->check(CLI::Range(1, 256));
    app->add_option("--accuracy", flags->accuracy,
                    "override every spec's accuracy: draft, default, reference, or a relative "
                    "tolerance such as 1e-3 (part of the spec hash)")
        ->type_name("LEVEL|TOL");
    app->add_flag("--force", flags->force, "recompute materials whose outputs are up to date");
    flags->device.add_to(*app);
    return {app, [flags] { return run_compute(*flags); }};
}

} // namespace brdf::tool
