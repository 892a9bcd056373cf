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

/// A spec file (.json: the material named `material`, or its only one) or a table file.
Source load_source(const std::filesystem::path& path, const std::string& material, service::Device device);

bool is_spec_file(const std::filesystem::path& path);

} // namespace brdf::tool
