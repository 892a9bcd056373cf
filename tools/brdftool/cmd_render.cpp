// brdftool render: a preview image of a material (spec or table): a sphere under a directional light
// and optionally an environment, like the renderings of the seed paper (src/brdf/preview/render.h).
// PNG is tone-mapped for display; EXR keeps linear radiance.

#include "commands.h"
#include "source.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/progress.h>
#include <brdf/core/threads.h>
#include <brdf/model/table_fill.h>
#include <brdf/preview/image.h>
#include <brdf/preview/preview.h>
#include <brdf/preview/render.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>

#include <unistd.h>

namespace brdf::tool {
namespace {

struct RenderFlags {
    std::string input, output, material;
    std::string environment = "none", tone = "filmic";
    preview::RenderOptions options;
    double exposure = 0.0;
    DeviceFlag device;
};

int run_render(RenderFlags& f) {
    // Everything the user typed is checked before the (possibly long) solve.
    preview::output_format(f.output);
    f.options.environment = preview::parse_environment(f.environment);
    const preview::ToneOptions tone{f.exposure, preview::parse_tone_curve(f.tone)};
    preview::check_options(f.options);

    const auto t0 = std::chrono::steady_clock::now();
    ProgressLine line(isatty(STDERR_FILENO) ? ProgressLine::terminal() : ProgressLine::Options{});
    std::optional<Progress> progress(std::in_place, f.input,
                                     std::vector<ProgressStage>{{"optics", 0.1}, {"solve", 0.5}, {"render", 0.4}}, &line);
    progress->stage(is_spec_file(f.input) ? "optics" : "solve");
    const Source source = load_source(f.input, f.material, f.device.device(), {}, model::feedback_on(*progress));
    progress->stage("render");
    preview::Image image;
    if (source.model) {
        image = preview::render_material(*source.model, f.options); // mirror or rough lobe as the surface has
    } else {
        if (source.table) {
            log::info(f.input, ": a table holds no mirror reflection (a rough surface's lobe is in it)");
            // A nearest-bin lookup is cheap: look the table up at every shading point, so that a rough
            // surface's narrow lobe (fine in theta_h) is not smoothed away by the BRDF grid.
            f.options.theta_nodes = f.options.phi_nodes = 0;
        }
        // Shaded and displayed in Rec.709: the table's colour space converted (preview::in_rec709).
        image = preview::render_sphere(
            preview::in_rec709([&source](double ti, double to, double phi) { return source.brdf(ti, to, phi); },
                               source.colorspace()),
            f.options);
    }
    preview::write_image(image, f.output, tone);
    progress.reset();
    // The summary line, always (terminal or not), as compute's.
    std::fprintf(stderr, "brdftool render: %d x %d -> %s (%s)\n", f.options.size, f.options.size, f.output.c_str(),
                 format_duration(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()).c_str());
    return 0;
}

} // namespace

Subcommand add_render_command(CLI::App& root) {
    auto flags = std::make_shared<RenderFlags>();
    preview::RenderOptions& o = flags->options;
    CLI::App* app = root.add_subcommand("render", "Preview image: a sphere of the material under a directional light");
    app->add_option("input", flags->input, "material spec (.json) or table (.binary, .exr, Fourier .bsdf, .rgl.bsdf)")->required();
    app->add_option("-o,--output", flags->output, "image to write: .png (tone-mapped, sRGB) or .exr (linear float)")
        ->required();
    app->add_option("--size", o.size, "width and height in pixels, [8, 8192]")->capture_default_str();
    app->add_option("--light-theta", o.light_theta_deg,
                    "angle between light and view direction, degrees [0, 180] (0: light from the camera)")
        ->capture_default_str();
    app->add_option("--light-phi", o.light_phi_deg, "light azimuth in the image plane, degrees: 0 right, 90 up, 180 left")
        ->capture_default_str();
    app->add_option("--light-size", o.light_size_deg, "angular diameter of the light disc, degrees [0, 90] (soft light)")
        ->capture_default_str();
    app->add_option("--light-irradiance", o.light_irradiance,
                    "irradiance normal to the light (pi: a white Lambertian surface facing it has radiance 1); 0 "
                    "turns the light off")
        ->capture_default_str();
    app->add_option("--environment", flags->environment, "none, constant (uniform radiance) or sky (gradient)")
        ->check(CLI::IsMember({"none", "constant", "sky"}))
        ->capture_default_str();
    app->add_option("--environment-radiance", o.environment_radiance, "radiance of the constant environment, or scale of the sky")
        ->capture_default_str();
    app->add_option("--exposure", flags->exposure, "exposure in stops before tone mapping (PNG only)")->capture_default_str();
    app->add_option("--tone", flags->tone, "PNG tone curve: filmic, reinhard or clamp")
        ->check(CLI::IsMember({"filmic", "reinhard", "clamp"}))
        ->capture_default_str();
    app->add_option("--supersample", o.supersample, "samples per pixel along each axis, [1, 8]")->capture_default_str();
    app->add_option("--material", flags->material, "material name in a catalogue");
    flags->device.add_to(*app);
    app->footer("View space: x right, y up, the camera looks along -z (orthographic). A smooth interface's mirror\n"
                "reflection of the light and environment is added for a spec; a table holds only the diffuse part.\n"
                "A rough surface's lobe is drawn exactly for a spec and from its table bins for a table.");
    return {app, [flags] { return run_render(*flags); }};
}

} // namespace brdf::tool
