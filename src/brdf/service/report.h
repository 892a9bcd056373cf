#pragma once
// NAME.report.json (docs/design.md, "Report"): the resolved spec and its hash, per-wavelength optics,
// solver statistics, error estimates, directional albedo, seconds per stage.

#include <brdf/model/model.h>

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace brdf::service {

nlohmann::json make_report(const model::SolvedMaterial& material, const std::vector<std::string>& outputs);

} // namespace brdf::service
