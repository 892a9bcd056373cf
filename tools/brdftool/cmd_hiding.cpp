// brdftool hiding: the contrast ratio of a pigmented film against its thickness, and its hiding
// thickness (contrast ratio 0.98), as paint makers measure them (ISO 6504-3, ASTM D2805: luminance Y
// at normal incidence over black divided by Y over a white of albedo 0.80). Only the optics are
// computed (Mie per wavelength), then one Fourier order per thickness: no table, no full solve.

#include "commands.h"
#include "source.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/progress.h>
#include <brdf/model/film.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>

#include <unistd.h>

namespace brdf::tool {
namespace {

struct HidingFlags {
    std::string input, material;
    std::vector<double> thickness_um{1, 2, 5, 10, 20, 50, 100, 200};
    bool json = false;
};

int run_hiding(const HidingFlags& f) {
    for (double t : f.thickness_um)
        if (!(t > 0.0) || !std::isfinite(t))
            throw InputError(cat("hiding: --thickness-um values must be positive micrometres (got ", t, ")"));
    const material::MaterialSpec spec = choose_spec(f.input, f.material);
    if (!model::has_hiding_thickness(spec))
        throw InputError(cat(spec.source.empty() ? spec.name : spec.source,
                             ": hiding needs one pigmented binder layer (binder + pigments), whose thickness it "
                             "varies; this material is ",
                             spec.layers.size() > 1 ? "a stack" : "an analytic medium or a clear film"));
    const model::NumericalSettings settings = model::settings_for(spec.accuracy.tolerance);
    // A large particle's Lorenz-Mie optics are nearly all of the time (silica r_eff 40 um: seconds,
    // 200 um: minutes): the bar follows them as compute's does, with a long one's estimate; then
    // each thickness, the hiding thickness's search counted as one more.
    const auto t0 = std::chrono::steady_clock::now();
    ProgressLine line(isatty(STDERR_FILENO) ? ProgressLine::terminal() : ProgressLine::Options{});
    std::optional<Progress> progress(std::in_place, "hiding",
                                     std::vector<ProgressStage>{{"optics", 0.5}, {"solve", 0.5}}, &line);
    progress->stage("optics");
    // (feedback_on moves the bar to "solve" once the optics are done)
    const model::MaterialOptics optics = model::material_optics(spec, settings, model::feedback_on(*progress));
    const int streams = settings.streams;
    const double steps = static_cast<double>(f.thickness_um.size() + 1);
    std::vector<std::pair<double, double>> rows;
    for (double t : f.thickness_um) {
        rows.emplace_back(t, model::contrast_ratio(spec, optics, streams, t));
        progress->advance(static_cast<double>(rows.size()) / steps);
    }
    const std::optional<double> hiding = model::hiding_thickness_um(spec, optics, streams);
    progress.reset();
    std::fprintf(stderr, "brdftool hiding: %s, %zu thicknesses (%s)\n", spec.name.c_str(), rows.size(),
                 format_duration(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()).c_str());
    if (f.json) {
        nlohmann::json out = {{"material", spec.name}, {"white_albedo", model::contrast_white_albedo},
                              {"target_contrast_ratio", model::hiding_contrast_ratio}};
        for (const auto& [t, cr] : rows) out["contrast_ratio"].push_back({{"thickness_um", t}, {"contrast_ratio", cr}});
        out["hiding_thickness_um"] = hiding ? nlohmann::json(*hiding) : nlohmann::json(nullptr);
        std::printf("%s\n", out.dump(2).c_str());
        return 0;
    }
    std::printf("# %s: contrast ratio Y(black) / Y(white %.2f) at normal incidence\n", spec.name.c_str(),
                model::contrast_white_albedo);
    std::printf("# thickness_um contrast_ratio\n");
    for (const auto& [t, cr] : rows) std::printf("%g %.6f\n", t, cr);
    if (hiding) std::printf("hiding thickness (contrast ratio %.2f): %.4g um\n", model::hiding_contrast_ratio, *hiding);
    else std::printf("hiding thickness (contrast ratio %.2f): not reached below 10 mm\n", model::hiding_contrast_ratio);
    return 0;
}

} // namespace

Subcommand add_hiding_command(CLI::App& root) {
    auto flags = std::make_shared<HidingFlags>();
    CLI::App* app = root.add_subcommand("hiding", "Contrast ratio against film thickness, and the hiding thickness");
    app->add_option("spec", flags->input, "material spec (.json) with one pigmented binder layer")->required();
    app->add_option("--thickness-um", flags->thickness_um,
                    "film thicknesses, micrometres (default 1 2 5 10 20 50 100 200)")->delimiter(',');
    app->add_option("--material", flags->material, "material name in a catalogue");
    app->add_flag("--json", flags->json, "print JSON instead of text");
    app->footer("The spec's own thickness and substrate are ignored: the contrast ratio compares the\n"
                "film over black with the film over a white of albedo 0.80 (ISO 6504-3, ASTM D2805),\n"
                "both at normal incidence, specular excluded. The hiding thickness is where it reaches\n"
                "0.98. The spec's accuracy sets the streams and the Mie tolerance.");
    return {app, [flags] { return run_hiding(*flags); }};
}

} // namespace brdf::tool
