#include <brdf/service/report.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/version.h>
#include <brdf/material/colour.h>

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
        json pigments = json::array();
        for (const model::PigmentOptics& p : s.optics.pigments)
            pigments.push_back({{"albedo", p.albedo}, {"g", p.g}, {"csca_um2", p.csca_um2}, {"cext_um2", p.cext_um2},
                                {"number_density_per_um3", p.number_density_um3}, {"legendre", p.legendre},
                                {"radius_nodes", p.radius_nodes}, {"mie_error_estimate", p.mie_error}});
        json entry = {{"albedo", s.optics.medium.omega},
                      {"g", s.optics.g},
                      {"legendre", s.optics.medium.beta.size()},
                      {"binder_index", s.optics.binder_index},
                      {"weight_rgb", s.weight},
                      {"delta_m_fraction", setup.layers.front().truncated.f},
                      {"fourier_orders", setup.orders},
                      {"iterations", iterations},
                      {"residuals", residuals}};
        if (s.wavelength_nm > 0.0) entry["wavelength_nm"] = s.wavelength_nm;
        if (!pigments.empty()) entry["pigments"] = pigments;
        samples.push_back(entry);
    }
    // The spec's warnings, then the solve's (the gamut fit: chroma scaled or clipped, and what
    // keeps the colour).
    json warnings = m.spec.warnings;
    for (const std::string& w : m.warnings) warnings.push_back(w);
    json albedo = json::array();
    for (double deg : {0.0, 30.0, 60.0, 80.0}) {
        const double t = deg * std::numbers::pi / 180.0;
        albedo.push_back({{"theta_i_deg", deg}, {"diffuse_rgb", m.albedo(t)}, {"mirror_rgb", m.mirror(t)}});
    }
    return {
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
          {"note", "solver_estimate: relative BRDF difference between the chosen stream count and "
                   "1.5 times as many on the hardest wavelengths (docs/quadrature-study.md); tables "
                   "add their binning error"}}},
        {"wavelengths", samples},
        {"wavelengths_interpolated", m.wavelengths_interpolated},
        {"colorspace", std::string(material::to_string(m.spec.colorspace))},
        {"colorspace_name", std::string(material::long_name(m.spec.colorspace))},
        {"gamut_scale", m.gamut_scale},
        {"gamut_clipped", m.gamut_clipped},
        {"directional_albedo", albedo},
        {"seconds", {{"optics", m.seconds.optics}, {"solve", m.seconds.solve}, {"table", m.seconds.table},
                     {"write", m.seconds.write}}},
        {"warnings", warnings},
    };
}

} // namespace brdf::service
