#pragma once
// What eval, albedo and diff read: a material spec (solved on the spot, evaluated exactly at the
// requested angles) or a table file (.binary, .exr; evaluated by nearest-bin lookup).

#include <brdf/service/model.h>
#include <formats/table.h>

#include <CLI/CLI.hpp>

#include <filesystem>
#include <optional>
#include <string>

namespace brdf::tool {

/// --device opencl|cpu, shared by the commands that solve.
struct DeviceFlag {
    std::string value = "opencl";
    void add_to(CLI::App& app);
    service::Device device() const;
};

struct Source {
    std::optional<service::SolvedMaterial> model;
    std::optional<formats::BrdfTable> table;

    /// BRDF (1/sr) at angles in radians.
    service::Rgb brdf(double theta_i, double theta_o, double phi) const;
};

/// A spec file (.json: the material named `material`, or its only one) or a table file. `recorded`
/// (diff TABLE CATALOGUE: the material the table says it was computed from) picks the material of
/// a spec holding several when `material` is empty. A name that is not there is an InputError
/// listing the names there are.
Source load_source(const std::filesystem::path& path, const std::string& material, service::Device device,
                   const std::string& recorded = {});

/// The name of the material a table file was computed from: the "name" of the spec in its EXR
/// brdf.spec attribute, else of the report written beside it (DIR/NAME.report.json for
/// DIR/NAME.binary or DIR/NAME.exr); empty when neither says.
std::string recorded_material(const std::filesystem::path& table_path, const formats::BrdfTable& table);

bool is_spec_file(const std::filesystem::path& path);

} // namespace brdf::tool
