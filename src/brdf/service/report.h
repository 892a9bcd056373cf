#pragma once
// NAME.report.json (docs/design.md, "Report"): the resolved spec and its hash, per-wavelength optics,
// solver statistics, error estimates, directional albedo, seconds per stage.

#include <brdf/service/model.h>

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace brdf::service {

nlohmann::json make_report(const SolvedMaterial& material, const std::vector<std::string>& outputs);

/// Writes text to `path` through a temporary file in the same folder and a rename, so that readers
/// (and the daemon's users) see the whole file or none of it.
void write_text_atomically(const std::filesystem::path& path, const std::string& text);

} // namespace brdf::service
