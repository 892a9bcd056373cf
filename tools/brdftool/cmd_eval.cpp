// brdftool eval: the BRDF (1/sr) as "r g b" per direction triple (docs/design.md). On a spec the solved
// model is evaluated at exactly the given angles; on a table, by nearest-bin lookup.

#include "commands.h"
#include "source.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/parse.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <sstream>

namespace brdf::tool {
namespace {

struct EvalFlags {
    std::string input, material;
    std::optional<double> theta_i, theta_o, phi;
    DeviceFlag device;
};

double radians(double degrees) { return degrees * std::numbers::pi / 180.0; }

void check_angles(double ti, double to, double phi, const std::string& where) {
    if (!(std::isfinite(ti) && std::isfinite(to) && std::isfinite(phi)))
        throw InputError(cat(where, ": angles must be finite numbers"));
    if (ti < 0.0 || ti > 90.0 || to < 0.0 || to > 90.0)
        throw InputError(cat(where, ": zenith angles must be in [0, 90] degrees (got ", ti, ", ", to, ")"));
}

int run_eval(const EvalFlags& f) {
    const Source source = load_source(f.input, f.material, f.device.device());
    const auto print = [&](double ti, double to, double phi) {
        const model::Rgb v = source.brdf(radians(ti), radians(to), radians(phi));
        std::printf("%.9g %.9g %.9g\n", v[0], v[1], v[2]);
    };
    if (f.theta_i || f.theta_o || f.phi) {
        if (!(f.theta_i && f.theta_o))
            throw InputError("eval: give --theta-i and --theta-o (and optionally --phi), or none to read stdin");
        const double phi = f.phi.value_or(0.0);
        check_angles(*f.theta_i, *f.theta_o, phi, "eval");
        print(*f.theta_i, *f.theta_o, phi);
        return 0;
    }
    std::string line;
    int number = 0;
    while (std::getline(std::cin, line)) {
        ++number;
        std::istringstream in(line);
        std::string a, b, c, extra;
        if (!(in >> a)) continue; // blank line
        if (a[0] == '#') continue;
        if (!(in >> b >> c) || (in >> extra))
            throw InputError(cat("stdin line ", number, ": expected 'theta_i theta_o phi' in degrees"));
        const std::string where = cat("stdin line ", number);
        const double ti = parse_double(a, where), to = parse_double(b, where), phi = parse_double(c, where);
        check_angles(ti, to, phi, where);
        print(ti, to, phi);
    }
    return 0;
}

} // namespace

Subcommand add_eval_command(CLI::App& root) {
    auto flags = std::make_shared<EvalFlags>();
    CLI::App* app = root.add_subcommand("eval", "BRDF (1/sr) as 'r g b' per direction triple, of a spec or a table");
    app->add_option("input", flags->input, "material spec (.json) or table (.binary, .exr, Fourier .bsdf, .rgl.bsdf)")->required();
    app->add_option("--theta-i", flags->theta_i, "light zenith angle, degrees [0, 90]");
    app->add_option("--theta-o", flags->theta_o, "viewer zenith angle, degrees [0, 90]");
    app->add_option("--phi", flags->phi, "azimuth phi_o - phi_i, degrees (0: light's side, 180: mirror side)");
    app->add_option("--material", flags->material, "material name in a catalogue");
    flags->device.add_to(*app);
    app->footer("Without angle flags, reads lines 'theta_i theta_o phi' (degrees) from stdin.");
    return {app, [flags] { return run_eval(*flags); }};
}

} // namespace brdf::tool
