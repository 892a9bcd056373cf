// brdftool albedo: directional-hemispherical reflectance "r g b" per incidence angle (docs/design.md).
// The diffuse part only; a smooth interface's mirror reflection is printed on its own line.

#include "commands.h"
#include "source.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace brdf::tool {
namespace {

struct AlbedoFlags {
    std::string input, material;
    std::vector<double> theta_i{0.0, 30.0, 60.0, 80.0};
    DeviceFlag device;
};

int run_albedo(const AlbedoFlags& f) {
    for (double t : f.theta_i)
        if (!(t >= 0.0 && t < 90.0)) throw InputError(cat("albedo: --theta-i must be in [0, 90) degrees (got ", t, ")"));
    const Source source = load_source(f.input, f.material, f.device.device());
    const bool mirror = source.model && source.model->spec.surface.kind == material::Surface::Smooth;
    for (double deg : f.theta_i) {
        const double t = deg * std::numbers::pi / 180.0;
        const model::Rgb a = source.albedo(t);
        std::printf("%.9g %.9g %.9g\n", a[0], a[1], a[2]);
        if (mirror) {
            const model::Rgb m = source.model->mirror(t);
            std::printf("mirror %.9g %.9g %.9g\n", m[0], m[1], m[2]);
        }
    }
    return 0;
}

} // namespace

Subcommand add_albedo_command(CLI::App& root) {
    auto flags = std::make_shared<AlbedoFlags>();
    CLI::App* app = root.add_subcommand("albedo", "Directional-hemispherical reflectance 'r g b' per incidence angle");
    app->add_option("input", flags->input, "material spec (.json) or table (.binary, .exr, Fourier .bsdf, .rgl.bsdf)")->required();
    app->add_option("--theta-i", flags->theta_i, "incidence zenith angles, degrees (default 0 30 60 80)")->delimiter(',');
    app->add_option("--material", flags->material, "material name in a catalogue");
    flags->device.add_to(*app);
    app->footer("One line per angle; with a smooth interface each is followed by 'mirror r g b', the\n"
                "specular reflectance, which the diffuse albedo excludes.");
    return {app, [flags] { return run_albedo(*flags); }};
}

} // namespace brdf::tool
