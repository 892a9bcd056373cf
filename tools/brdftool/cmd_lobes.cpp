// brdftool lobes: in-plane BRDF lobes in polar form for given incidence angles, one or several
// inputs overlaid (e.g. a spec and the table computed from it), as in the seed paper's figures
// (src/brdf/preview/lobes.h).

#include "commands.h"
#include "source.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/progress.h>
#include <brdf/preview/image.h>
#include <brdf/preview/lobes.h>
#include <brdf/preview/preview.h>
#include <brdf/preview/render.h>

#include <chrono>
#include <cstdio>
#include <future>
#include <memory>
#include <optional>

#include <unistd.h>

namespace brdf::tool {
namespace {

struct LobesFlags {
    std::vector<std::string> inputs;
    std::string output, material, channel = "luminance", title;
    std::vector<double> theta_i{30.0, 60.0};
    preview::LobeOptions options;
    DeviceFlag device;
};

int run_lobes(LobesFlags& f) {
    preview::output_format(f.output);
    f.options.channel = preview::parse_lobe_channel(f.channel);
    if (!f.title.empty()) f.options.title = f.title;
    for (double t : f.theta_i)
        if (!(t >= 0.0 && t < 90.0)) throw InputError(cat("lobes: --theta-i must be in [0, 90) degrees (got ", t, ")"));

    const auto t0 = std::chrono::steady_clock::now();
    ProgressLine line(isatty(STDERR_FILENO) ? ProgressLine::terminal() : ProgressLine::Options{});
    std::optional<Progress> progress(std::in_place, "lobes", std::vector<ProgressStage>{{"solve", 0.8}, {"plot", 0.2}},
                                     &line);
    progress->stage("solve");
    // A long material says so (its estimate, a line of its own); the bar counts whole inputs.
    model::SolveFeedback feedback;
    feedback.note = [&progress](const std::string& text) { progress->note(text); };
    // The inputs at once: one solve alone leaves a core idle for much of its time (the probes, the
    // writes of a grid); errors are reported in the order of the inputs.
    std::vector<std::future<Source>> loading;
    for (const std::string& input : f.inputs)
        loading.push_back(std::async(std::launch::async, [&f, &feedback, input] {
            Source s = load_source(input, is_spec_file(input) ? f.material : std::string{}, f.device.device(), {},
                                   feedback);
            // 361 directions per curve, each a solve off the nodes without the interpolant; a
            // plot's resolution is served by the previews' grid, a third of the tables' cost.
            s.use_interpolant(preview::preview_zenith_grid);
            return s;
        }));
    std::vector<Source> sources;
    std::vector<std::string> labels;
    for (std::size_t k = 0; k < loading.size(); ++k) {
        sources.push_back(loading[k].get());
        progress->advance(static_cast<double>(sources.size()) / static_cast<double>(f.inputs.size()));
        const Source& s = sources.back();
        labels.push_back(s.model ? s.model->spec.name : std::filesystem::path(f.inputs[k]).filename().string());
    }
    std::vector<preview::LobeCurve> curves;
    for (std::size_t k = 0; k < sources.size(); ++k)
        for (double t : f.theta_i) {
            const Source* s = &sources[k];
            curves.push_back({labels[k],
                              preview::in_rec709([s](double ti, double to, double phi) { return s->brdf(ti, to, phi); },
                                                 s->colorspace()),
                              t, {}});
        }
    progress->stage("plot");
    const preview::Image image = preview::plot_lobes(curves, f.options);
    preview::write_image(image, f.output, {0.0, preview::ToneCurve::Clamp});
    progress.reset();
    std::fprintf(stderr, "brdftool lobes: %zu curves -> %s (%s)\n", curves.size(), f.output.c_str(),
                 format_duration(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()).c_str());
    return 0;
}

} // namespace

Subcommand add_lobes_command(CLI::App& root) {
    auto flags = std::make_shared<LobesFlags>();
    CLI::App* app = root.add_subcommand("lobes", "In-plane BRDF lobe plot (polar) for given incidence angles");
    app->add_option("inputs", flags->inputs, "material specs (.json) and/or tables (.binary, .exr, Fourier .bsdf, .rgl.bsdf), overlaid")
        ->required();
    app->add_option("-o,--output", flags->output, "image to write: .png (or .exr)")->required();
    app->add_option("--theta-i", flags->theta_i, "incidence angles, degrees [0, 90), comma separated")
        ->delimiter(',')
        ->capture_default_str();
    app->add_flag("--log", flags->options.log_scale, "radius = log10 of the BRDF (see --decades)");
    app->add_option("--decades", flags->options.decades, "decades shown with --log")->capture_default_str();
    app->add_option("--channel", flags->channel, "plotted value: luminance (Rec.709 Y), red, green or blue")
        ->check(CLI::IsMember({"luminance", "red", "green", "blue"}))
        ->capture_default_str();
    app->add_option("--width", flags->options.width, "image width in pixels, [200, 8192]")->capture_default_str();
    app->add_option("--title", flags->title, "title above the plot");
    app->add_option("--material", flags->material, "material name in a catalogue (applies to every spec input)");
    flags->device.add_to(*app);
    app->footer("One curve per input and incidence angle. The light comes in from the left (dashed rays); the\n"
                "outgoing angle runs from -90 (grazing, light's side, phi = 0) to +90 (grazing, mirror side,\n"
                "phi = 180). A smooth interface's mirror reflection is a delta and is not drawn.");
    return {app, [flags] { return run_lobes(*flags); }};
}

} // namespace brdf::tool
