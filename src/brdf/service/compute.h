#pragma once
// The compute pipeline shared by `brdftool compute` and each brdfd job: spec file(s) -> per material
// Mie, solve, table fill -> NAME.binary, NAME.exr, NAME.report.json in an output folder.

#include <brdf/core/error.h>
#include <brdf/model/model.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace brdf::service {

struct ComputeOptions {
    std::filesystem::path output_dir = ".";
    std::vector<std::string> formats;  ///< "merl", "exr"; empty: what each spec's `outputs` asks for
    model::Device device = model::Device::OpenCL;
    int shard_index = 0;               ///< --shard I/N: compute materials I, I+N, I+2N, ...
    int shard_count = 1;
    int jobs = 1;                      ///< materials computed concurrently
    bool progress = false;             ///< progress bar on stderr (only when it is a terminal)
    /// Overrides every spec's accuracy: "draft", "default", "reference" or a tolerance ("1e-3").
    /// Applied to the spec before it is resolved, so it is part of the spec hash. Empty: the spec's.
    std::string accuracy;
    /// Recompute even when a material's report says its outputs are up to date.
    bool force = false;
    /// The daemon job this run is (the spec's file name in the spool, e.g. "paint.json"); empty for
    /// brdftool. Stamped into each report as "job"; a material whose results were written by
    /// another job from other content is refused instead of overwritten (docs/daemon.md).
    std::string job;
    /// Added to every report's warnings[] (the daemon's "computed on the CPU" fallback).
    std::vector<std::string> warnings;
    /// When set, called for each computed material with DIR/NAME.png (brdftool compute --preview
    /// passes preview::write_preview; the service does not depend on the preview library).
    std::function<void(const model::SolvedMaterial&, const std::filesystem::path&)> preview;
};

struct MaterialOutcome {
    std::string name;
    bool ok = false;
    bool skipped = false;              ///< outputs already present for this spec hash
    std::string error;                 ///< one line, when !ok
    ErrorKind kind = ErrorKind::Internal; ///< of the failure, when !ok
    std::vector<std::filesystem::path> outputs;
    double seconds = 0.0;
};

/// Computes every material of the given spec or catalogue files (of this shard). The error boundary:
/// a problem of the run as a whole throws before anything is computed (a spec file that cannot be
/// read, parsed or validated: InputError/LimitError/IoError listing every problem; two materials of
/// one name; an output folder that cannot be created); anything thrown while one material is
/// computed or written fails that material alone (its outcome has the kind and message; a
/// std::exception that is not a brdf::Error is kind Internal, std::bad_alloc kind Limit) and the
/// others go on. Failures are not logged here: the caller reports each once.
/// Throws InputError for an invalid `options.accuracy`.
std::vector<MaterialOutcome> compute_files(const std::vector<std::filesystem::path>& specs,
                                           const ComputeOptions& options);

/// One daemon job: computes every material of `spec_file` into `results_dir`; throws a brdf::Error
/// (the first failure's kind, all failures' messages) when any material failed. Uses OpenCL when a
/// device is there, else the CPU reference (a warning, once per process, and in each report).
void run_compute_job(const std::filesystem::path& spec_file, const std::filesystem::path& results_dir);

} // namespace brdf::service
