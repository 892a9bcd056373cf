#include "source.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/material/colour.h>
#include <brdf/material/spec.h>
#include <brdf/material/spectrum.h>
#include <formats/exr/spectral_exr.h>
#include <formats/table_io.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>

namespace brdf::tool {

void DeviceFlag::add_to(CLI::App& app) {
    app.add_option("--device", value, "opencl (default: PoCL or a GPU) or cpu (the C++ reference)")
        ->check(CLI::IsMember({"opencl", "cpu"}));
}

model::Device DeviceFlag::device() const { return value == "cpu" ? model::Device::Cpu : model::Device::OpenCL; }

bool is_spec_file(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext == ".json";
}

material::MaterialSpec choose_spec(const std::filesystem::path& path, const std::string& material,
                                   const std::string& recorded) {
    std::vector<material::MaterialSpec> specs = material::load_specs(path);
    std::string names;
    for (const auto& m : specs) names += cat(names.empty() ? "" : ", ", m.name);
    const std::string wanted = !material.empty() ? material : specs.size() > 1 ? recorded : std::string();
    const material::MaterialSpec* chosen = nullptr;
    if (wanted.empty()) {
        if (specs.size() != 1)
            throw InputError(cat(path.string(), ": holds ", specs.size(), " materials (", names,
                                 "); choose one with --material NAME"));
        chosen = &specs.front();
    } else {
        for (const auto& m : specs)
            if (m.name == wanted) chosen = &m;
        if (!chosen)
            throw InputError(cat(path.string(), ": no material named '", wanted, "'",
                                 material.empty() ? " (the name the table records)" : "", "; it holds ",
                                 names, material.empty() ? "; choose one with --material NAME" : ""));
    }
    return *chosen;
}

Source load_source(const std::filesystem::path& path, const std::string& material, model::Device device,
                   const std::string& recorded, const model::SolveFeedback& feedback) {
    Source s;
    if (!is_spec_file(path)) {
        if (!material.empty()) throw InputError(cat("--material: only meaningful for a spec file, not ", path.string()));
        const formats::TableFormat format = formats::detect_format(path);
        if (format == formats::TableFormat::Fourier) {
            s.fourier = formats::read_fourier_bsdf(path);
        } else if (format == formats::TableFormat::RglTensor) {
            s.rgl.emplace(formats::read_rgl_bsdf(path));
            if (s.rgl->bsdf().spectral()) {
                const std::vector<float>& nm = s.rgl->bsdf().wavelengths;
                const material::SpectralSet set =
                    material::SpectralSet::integrating(std::vector<double>(nm.begin(), nm.end()));
                const auto w = set.rgb_weights();
                s.rgl_weights.assign(w.begin(), w.end());
            }
        } else
            s.table = formats::read_table(path, format, spectral_to_rgb());
        return s;
    }
    const material::MaterialSpec spec = choose_spec(path, material, recorded);
    s.model = model::solve_material(spec, device, model::settings_for(spec.accuracy.tolerance), feedback);
    return s;
}

std::string recorded_material(const std::filesystem::path& table_path, const formats::BrdfTable& table) {
    const auto name_in = [](const nlohmann::json& j) {
        return j.is_object() && j.contains("name") && j["name"].is_string() ? j["name"].get<std::string>()
                                                                            : std::string();
    };
    if (!table.spec.empty())
        if (const std::string name = name_in(nlohmann::json::parse(table.spec, nullptr, false)); !name.empty())
            return name;
    std::filesystem::path report = table_path;
    report.replace_extension(".report.json");
    std::ifstream in(report);
    if (!in) return {};
    return name_in(nlohmann::json::parse(in, nullptr, false));
}

void Source::use_interpolant(int zenith_grid) {
    if (!model || interpolant) return;
    for (const model::WavelengthSolution& s : model->samples)
        if (s.dipole) return;
    interpolant = model::prepare_fill(*model, zenith_grid);
}

model::Rgb Source::brdf(double theta_i, double theta_o, double phi) const {
    if (interpolant) return model::fill_value(*interpolant, theta_i, theta_o, phi);
    if (model) return model->brdf(theta_i, theta_o, phi);
    if (fourier) return formats::evaluate(*fourier, theta_i, theta_o, phi);
    if (rgl) {
        // wi in the plane phi = 0, wo at azimuth phi (docs/design.md).
        const formats::Vec3 wi{std::sin(theta_i), 0.0, std::cos(theta_i)};
        const formats::Vec3 wo{std::sin(theta_o) * std::cos(phi), std::sin(theta_o) * std::sin(phi), std::cos(theta_o)};
        const std::vector<double> v = rgl->brdf(wi, wo);
        model::Rgb out{0.0, 0.0, 0.0};
        if (!rgl->bsdf().spectral()) {
            out = {v[0], v[1], v[2]};
        } else {
            for (std::size_t k = 0; k < v.size(); ++k)
                for (int c = 0; c < 3; ++c) out[c] += rgl_weights[k][c] * v[k];
        }
        for (double& x : out) x = std::max(0.0, x); // pbrt-v4 clamps negative samples
        return out;
    }
    return formats::lookup(*table, theta_i, theta_o, phi);
}

model::Rgb Source::albedo(double theta_i) const {
    if (model) return model->albedo(theta_i);
    if (fourier || rgl)
        return formats::directional_albedo([&](double theta_o, double phi) { return brdf(theta_i, theta_o, phi); },
                                           theta_i);
    return formats::directional_albedo(*table, theta_i);
}

material::ColorSpace Source::colorspace() const {
    if (model) return model->spec.colorspace;
    if (table)
        if (const auto space = material::color_space_from_string(formats::canonical_colorspace(table->colorspace)))
            return *space;
    return material::ColorSpace::Rec709;
}

namespace {

// The "colorspace" of the spec JSON a table records, Rec.709 when it records none.
material::ColorSpace recorded_colorspace(const std::string& spec) {
    const nlohmann::json j = nlohmann::json::parse(spec, nullptr, false);
    if (j.is_object() && j.contains("colorspace") && j["colorspace"].is_string())
        if (const auto space = material::color_space_from_string(j["colorspace"].get<std::string>())) return *space;
    return material::ColorSpace::Rec709;
}

} // namespace

formats::SpectralToRgb spectral_to_rgb() {
    return [](const formats::SpectralTable& spectral) {
        const material::SpectralSet set = material::SpectralSet::integrating(spectral.wavelengths_nm);
        const material::ColorSpace space = recorded_colorspace(spectral.spec);
        return formats::spectral_to_rgb(spectral, set.rgb_weights(space), std::string(material::to_string(space)));
    };
}

} // namespace brdf::tool
