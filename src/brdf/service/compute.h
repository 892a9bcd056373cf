#pragma once
// The compute pipeline shared by `brdftool compute` and each brdfd job: spec file(s) -> per material
// Mie, solve, table fill -> NAME.binary, NAME.exr, NAME.report.json in an output folder.

#include <brdf/core/error.h>
#include <brdf/service/model.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace brdf::service {

struct ComputeOptions {
    std::filesystem::path output_dir = ".";
    std::vector<std::string> formats;  ///< "merl", "exr"; empty: what each spec's `outputs` asks for
    Device device = Device::OpenCL;
    int shard_index = 0;               ///< --shard I/N: compute materials I, I+N, I+2N, ...
    int shard_count = 1;
    int jobs = 1;                      ///< materials computed concurrently
    bool progress = false;             ///< progress bar on stderr
    /// When set, called for each computed material with DIR/NAME.png (brdftool compute --preview
    /// passes preview::write_preview; the service does not depend on the preview library).
    std::function<void(const SolvedMaterial&, const std::filesystem::path&)> preview;
};

struct MaterialOutcome {
    std::string name;
    bool ok = false;
    bool skipped = false;              ///< outputs already present for this spec hash
    std::string error;                 ///< one line, when !ok
    ErrorKind kind = ErrorKind::Numerical; ///< of the failure, when !ok
    std::vector<std::filesystem::path> outputs;
    double seconds = 0.0;
};

/// Computes every material of the given spec or catalogue files (of this shard). A bad material fails
/// alone; a spec file that does not parse or validate throws InputError listing every problem.
std::vector<MaterialOutcome> compute_files(const std::vector<std::filesystem::path>& specs,
                                           const ComputeOptions& options);

/// One daemon job: computes every material of `spec_file` into `results_dir`; throws a brdf::Error
/// (the first failure's kind, all failures' messages) when any material failed.
void run_compute_job(const std::filesystem::path& spec_file, const std::filesystem::path& results_dir);

} // namespace brdf::service
