#include <brdf/service/report.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/version.h>
#include <brdf/material/colour.h>
#include <brdf/model/film.h>

#include <atomic>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <numbers>
#include <unistd.h>

namespace brdf::service {

nlohmann::json make_report(const model::SolvedMaterial& m, const std::vector<std::string>& outputs) {
    using nlohmann::json;
    json samples = json::array();
    int max_orders = 0;
    double worst_residual = 0.0;
    for (const model::WavelengthSolution& s : m.samples) {
        const auto& setup = s.reflection.setup();
        json iterations = json::array(), residuals = json::array();
        for (const auto& sol : s.reflection.solutions()) {
            iterations.push_back(sol.iterations);
            residuals.push_back(sol.residual);
            worst_residual = std::max(worst_residual, sol.residual);
        }
        max_orders = std::max(max_orders, setup.orders);
        const auto pigments_of = [](const model::LayerOptics& l) {
            json pigments = json::array();
            for (const model::PigmentOptics& p : l.pigments)
                pigments.push_back({{"albedo", p.albedo}, {"g", p.g}, {"csca_um2", p.csca_um2}, {"cext_um2", p.cext_um2},
                                    {"number_density_per_um3", p.number_density_um3}, {"legendre", p.legendre},
                                    {"radius_nodes", p.radius_nodes}, {"mie_error_estimate", p.mie_error}});
            return pigments;
        };
        // The top layer's optics at the top level (as for a single layer); every layer's under
        // "layers" when there is more than one or a finite one.
        const model::LayerOptics& top = s.optics.top();
        const json pigments = pigments_of(top);
        json entry = {{"albedo", top.medium.omega},
                      {"g", top.g},
                      {"legendre", top.medium.beta.size()},
                      {"binder_index", top.index},
                      {"weight_rgb", s.weight},
                      {"delta_m_fraction", setup.layers.front().truncated.f},
                      {"fourier_orders", setup.orders},
                      {"iterations", iterations},
                      {"residuals", residuals}};
        if (s.optics.layers.size() > 1 || top.finite()) {
            json layers = json::array();
            for (std::size_t k = 0; k < s.optics.layers.size(); ++k) {
                const model::LayerOptics& l = s.optics.layers[k];
                json layer = {{"albedo", l.medium.omega}, {"g", l.g}, {"legendre", l.medium.beta.size()},
                              {"index", setup.layers[k].index}, {"delta_m_fraction", setup.layers[k].truncated.f}};
                if (l.finite()) layer["optical_depth"] = l.optical_depth;
                if (l.extinction_per_um > 0.0) layer["extinction_per_um"] = l.extinction_per_um;
                if (!l.pigments.empty()) layer["pigments"] = pigments_of(l);
                layers.push_back(layer);
            }
            entry["layers"] = layers;
            if (top.finite() || s.optics.layers.back().finite()) entry["substrate_albedo"] = s.optics.substrate_albedo;
        }
        if (s.wavelength_nm > 0.0) entry["wavelength_nm"] = s.wavelength_nm;
        if (!pigments.empty()) entry["pigments"] = pigments;
        samples.push_back(entry);
    }
    // The spec's warnings, then the solve's (the gamut fit: chroma scaled or clipped, and what
    // keeps the colour).
    json warnings = m.spec.warnings;
    for (const std::string& w : m.warnings) warnings.push_back(w);
    json albedo = json::array();
    const auto& albedo_deg = model::reflectance_angles_deg;
    std::vector<double> albedo_theta;
    for (double deg : albedo_deg) albedo_theta.push_back(deg * std::numbers::pi / 180.0);
    const std::vector<model::Rgb> diffuse = m.albedo(albedo_theta), mirror = m.mirror(albedo_theta);
    for (std::size_t k = 0; k < albedo_theta.size(); ++k)
        albedo.push_back({{"theta_i_deg", albedo_deg[k]}, {"diffuse_rgb", diffuse[k]}, {"mirror_rgb", mirror[k]}});
    json report = {
        {"name", m.spec.name},
        {"generator", std::string(generator_string)},
        {"spec", m.spec.resolved},
        {"spec_hash", m.spec.hash},
        {"device", m.device},
        {"outputs", outputs},
        {"solver",
         {{"method", rte::to_string(m.settings.method)},
          {"streams", m.settings.streams},
          {"max_fourier_orders", max_orders},
          {"order_tolerance", m.settings.order_tolerance},
          {"iteration_tolerance", m.settings.solver_tolerance},
          {"worst_residual", worst_residual},
          {"table_grid_zenith_angles", m.settings.table_grid}}},
        {"error_estimate",
         {{"requested_tolerance", m.spec.accuracy.tolerance},
          {"solved_tolerance", m.settings.tolerance},
          {"solver_estimate", m.error_estimate},
          {"tolerance_met", m.error_estimate <= m.settings.tolerance},
          {"checked_streams", m.checked_streams},
          {"note", "solver_estimate: relative BRDF difference between the chosen stream count and "
                   "the last count checked against it (3/4 of it, or 1.5 times as many) on the "
                   "hardest wavelengths (docs/quadrature-study.md), or that difference from 3/4 of "
                   "it extrapolated where a third count (9/16) measured the error falling as N^-4 "
                   "or faster (docs/physics.md, \"Stream count\"); checked_streams: the counts "
                   "solved, in order (under a rough top the check skips the counts its spread "
                   "delta-M residual rules out and confirms the first it keeps from above: "
                   "docs/physics.md, \"Rough interface\"); tables add their binning error"}}},
        {"wavelengths", samples},
        {"wavelengths_interpolated", m.wavelengths_interpolated},
        {"wavelengths_single_scattering_only", m.single_only.size()},
        {"colorspace", std::string(material::to_string(m.spec.colorspace))},
        {"colorspace_name", std::string(material::long_name(m.spec.colorspace))},
        {"gamut_scale", m.gamut_scale},
        {"gamut_clipped", m.gamut_clipped},
        {"directional_albedo", albedo},
        {"seconds", {{"optics", m.seconds.optics}, {"solve", m.seconds.solve}, {"table", m.seconds.table},
                     {"write", m.seconds.write}}},
        {"warnings", warnings},
    };
    if (const auto film = model::film_report(m)) {
        json per_wavelength = json::array();
        for (std::size_t k = 0; k < m.samples.size(); ++k) {
            json depth = json::array();
            for (double t : film->optical_depth[k]) depth.push_back(t < 0.0 ? json(nullptr) : json(t));
            json entry = {{"optical_depth", depth}, {"diffuse_transmittance", film->diffuse_transmittance[k]}};
            if (m.samples[k].wavelength_nm > 0.0) entry["wavelength_nm"] = m.samples[k].wavelength_nm;
            else entry["weight_rgb"] = m.samples[k].weight;
            per_wavelength.push_back(entry);
        }
        report["film"] = {
            {"per_wavelength", per_wavelength},
            {"contrast_ratio", film->contrast_ratio},
            {"hiding_thickness_um", film->hiding_thickness_um ? json(*film->hiding_thickness_um) : json(nullptr)},
            {"note", "contrast_ratio: luminance Y of the diffuse reflectance at normal incidence (specular "
                     "excluded) over black divided by Y over a white substrate of albedo 0.80 (ISO 6504-3, "
                     "ASTM D2805); hiding_thickness_um: the thickness of this film at which it reaches 0.98 "
                     "(one pigmented layer only); diffuse_transmittance: of the whole film, diffuse light from "
                     "air into the substrate (docs/films.md)"}};
    }
    return report;
}

} // namespace brdf::service
