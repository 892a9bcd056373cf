// brdftool mie: Lorenz-Mie results of one sphere or a size distribution as one JSON object
// (docs/design.md, "brdftool mie"). Values are taken as strings and parsed strictly (core/parse.h), and
// the combination of flags is checked here, so that every mistake is an InputError (exit status 3)
// with one line naming the flags, not a half-read number.

#include "commands.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/parse.h>
#include <brdf/mie/ensemble.h>
#include <brdf/mie/mie.h>
#include <brdf/mie/size_distribution.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace brdf::tool {
namespace {

struct MieFlags {
    std::string m, x, index, medium_index, wavelength, radius, distribution, r_eff, v_eff, r_g,
        sigma_g, legendre, tolerance;
    CLI::Option *o_m = nullptr, *o_x = nullptr, *o_index = nullptr, *o_medium = nullptr,
                *o_wavelength = nullptr, *o_radius = nullptr, *o_distribution = nullptr,
                *o_r_eff = nullptr, *o_v_eff = nullptr, *o_r_g = nullptr, *o_sigma_g = nullptr,
                *o_legendre = nullptr, *o_tolerance = nullptr;
};

bool given(const CLI::Option* o) { return o->count() > 0; }

/// "--a, --b and --c" for the given options.
std::string names(const std::vector<const CLI::Option*>& options) {
    std::string out;
    for (std::size_t i = 0; i < options.size(); ++i) {
        if (i > 0) out += i + 1 == options.size() ? " and " : ", ";
        out += options[i]->get_name();
    }
    return out;
}

std::vector<const CLI::Option*> present(const std::vector<const CLI::Option*>& options) {
    std::vector<const CLI::Option*> out;
    for (const CLI::Option* o : options)
        if (given(o)) out.push_back(o);
    return out;
}

nlohmann::json complex_json(std::complex<double> z) { return {z.real(), z.imag()}; }

std::vector<double> capped(std::vector<double> beta, int cap) {
    if (cap > 0 && static_cast<int>(beta.size()) > cap) beta.resize(cap);
    return beta;
}

int run_mie(const MieFlags& f) {
    const std::vector<const CLI::Option*> relative{f.o_m, f.o_x};
    const std::vector<const CLI::Option*> physical{f.o_index,  f.o_medium,       f.o_wavelength,
                                                   f.o_radius, f.o_distribution, f.o_r_eff,
                                                   f.o_v_eff,  f.o_r_g,          f.o_sigma_g};
    const auto rel_given = present(relative), phys_given = present(physical);
    if (!rel_given.empty() && !phys_given.empty())
        throw InputError(cat("mie: ", names(rel_given),
                             " (relative index and size parameter) cannot be combined with ",
                             names(phys_given), " (physical units)"));
    if (rel_given.empty() && phys_given.empty())
        throw InputError("mie: give --m and --x, or --index, --medium-index and --wavelength-nm with "
                         "--radius-um or --distribution");

    int cap = 0;
    if (given(f.o_legendre)) {
        const double value = parse_double(f.legendre, "--legendre");
        if (!(value >= 1.0) || value != std::floor(value) || value > 1e9)
            throw InputError(cat("mie: --legendre must be a whole number >= 1 (got '", f.legendre,
                                 "')"));
        cap = static_cast<int>(value);
    }
    nlohmann::json out;

    if (!rel_given.empty()) {
        if (!given(f.o_m)) throw InputError("mie: --x needs --m (the relative refractive index)");
        if (!given(f.o_x)) throw InputError("mie: --m needs --x (the size parameter)");
        if (given(f.o_tolerance))
            throw InputError("mie: --tolerance applies to size distributions only");
        const std::complex<double> m = parse_complex_index(f.m, "--m");
        const double x = parse_double(f.x, "--x");
        const mie::Sphere s = mie::sphere(m, x);
        out["m"] = complex_json(m);
        out["x"] = x;
        out["terms"] = s.terms;
        out["qext"] = s.q.qext;
        out["qsca"] = s.q.qsca;
        out["qabs"] = s.q.qabs;
        out["qback"] = s.q.qback;
        out["g"] = s.q.g;
        out["albedo"] = s.albedo;
        out["legendre"] = capped(s.legendre, cap);
        std::cout << out.dump(2) << '\n';
        return 0;
    }

    // Physical units.
    std::vector<const CLI::Option*> missing;
    for (const CLI::Option* o : {f.o_index, f.o_medium, f.o_wavelength})
        if (!given(o)) missing.push_back(o);
    if (!missing.empty())
        throw InputError(cat("mie: physical units need --index, --medium-index and --wavelength-nm "
                             "(missing ",
                             names(missing), ")"));
    const std::complex<double> index = parse_complex_index(f.index, "--index");
    const double medium = parse_double(f.medium_index, "--medium-index");
    const double wavelength = parse_double(f.wavelength, "--wavelength-nm");

    // The size: --radius-um alone (one radius) or --distribution with its own parameters.
    std::string kind = given(f.o_distribution) ? f.distribution : "";
    const std::vector<const CLI::Option*> size_flags{f.o_radius, f.o_r_eff, f.o_v_eff, f.o_r_g,
                                                     f.o_sigma_g};
    std::vector<const CLI::Option*> needed, allowed;
    if (kind.empty()) {
        if (!given(f.o_radius)) {
            const auto stray = present({f.o_r_eff, f.o_v_eff, f.o_r_g, f.o_sigma_g});
            if (!stray.empty())
                throw InputError(cat("mie: ", names(stray), stray.size() == 1 ? " needs" : " need",
                                     " --distribution (power_law or gamma for --r-eff-um and "
                                     "--v-eff, lognormal for --r-g-um and --sigma-g)"));
            throw InputError("mie: give the size: --radius-um, or --distribution with its parameters");
        }
        kind = "monodisperse";
    }
    if (kind == "monodisperse") {
        needed = allowed = {f.o_radius};
    } else if (kind == "power_law" || kind == "gamma") {
        needed = allowed = {f.o_r_eff, f.o_v_eff};
    } else if (kind == "lognormal") {
        needed = allowed = {f.o_r_g, f.o_sigma_g};
    } else {
        throw InputError(cat("mie: --distribution must be monodisperse, power_law, gamma or "
                             "lognormal (got '",
                             kind, "')"));
    }
    std::vector<const CLI::Option*> absent, extra;
    for (const CLI::Option* o : needed)
        if (!given(o)) absent.push_back(o);
    for (const CLI::Option* o : size_flags)
        if (given(o) && std::find(allowed.begin(), allowed.end(), o) == allowed.end())
            extra.push_back(o);
    if (!absent.empty())
        throw InputError(cat("mie: --distribution ", kind, " needs ", names(absent)));
    if (!extra.empty())
        throw InputError(cat("mie: ", names(extra), " do", extra.size() == 1 ? "es" : "",
                             " not apply to --distribution ", kind));

    mie::SizeDistribution sizes = mie::monodisperse(1.0);
    nlohmann::json size;
    size["distribution"] = kind;
    if (kind == "monodisperse") {
        const double r = parse_double(f.radius, "--radius-um");
        sizes = mie::monodisperse(r);
        size["radius_um"] = r;
    } else if (kind == "lognormal") {
        const double r_g = parse_double(f.r_g, "--r-g-um");
        const double sigma_g = parse_double(f.sigma_g, "--sigma-g");
        sizes = mie::lognormal(r_g, sigma_g);
        size["r_g_um"] = r_g;
        size["sigma_g"] = sigma_g;
    } else {
        const double r_eff = parse_double(f.r_eff, "--r-eff-um");
        const double v_eff = parse_double(f.v_eff, "--v-eff");
        sizes = kind == "gamma" ? mie::gamma(r_eff, v_eff) : mie::power_law(r_eff, v_eff);
        size["r_eff_um"] = r_eff;
        size["v_eff"] = v_eff;
    }

    mie::EnsembleOptions options;
    if (given(f.o_tolerance)) options.tolerance = parse_double(f.tolerance, "--tolerance");
    const mie::Ensemble e = mie::ensemble(index, medium, wavelength, sizes, options);

    out["index"] = complex_json(index);
    out["medium_index"] = medium;
    out["wavelength_nm"] = wavelength;
    out["size"] = size;
    out["m"] = complex_json(e.m);
    out["x_range"] = {e.x_min, e.x_max};
    out["radius_range_um"] = {e.r_min_um, e.r_max_um};
    out["qext"] = e.qext;
    out["qsca"] = e.qsca;
    out["qabs"] = e.qabs;
    out["qback"] = e.qback;
    out["g"] = e.g;
    out["albedo"] = e.albedo;
    out["cext_um2"] = e.cext_um2;
    out["csca_um2"] = e.csca_um2;
    out["cabs_um2"] = e.cabs_um2;
    out["mean_volume_um3"] = e.mean_volume_um3;
    out["radius_nodes"] = e.radius_nodes;
    out["error_estimate"] = e.error_estimate;
    out["legendre"] = capped(e.legendre, cap);
    std::cout << out.dump(2) << '\n';
    return 0;
}

} // namespace

Subcommand add_mie_command(CLI::App& root) {
    auto flags = std::make_shared<MieFlags>();
    Subcommand cmd;
    cmd.app = root.add_subcommand("mie", "Lorenz-Mie results of one sphere or a size distribution");
    CLI::App& app = *cmd.app;
    app.footer(
        "Either --m and --x (relative index, size parameter), or physical units: --index,\n"
        "--medium-index, --wavelength-nm with --radius-um, or --distribution power_law|gamma\n"
        "--r-eff-um A --v-eff B, or --distribution lognormal --r-g-um R --sigma-g S. Indices are\n"
        "written N or N+Ki with the absorption K >= 0. Prints one JSON object: qext qsca qabs qback\n"
        "g albedo legendre (beta_l, beta_0 = 1), for a distribution also cext_um2 csca_um2\n"
        "radius_range_um (efficiencies are then cross-section-weighted means).");
    MieFlags& f = *flags;
    f.o_m = app.add_option("--m", f.m, "relative refractive index n + ik, e.g. 1.5 or 2.7+0.01i");
    f.o_x = app.add_option("--x", f.x, "size parameter 2 pi r / lambda (in the medium)");
    f.o_index = app.add_option("--index", f.index, "particle refractive index n + ik");
    f.o_medium = app.add_option("--medium-index", f.medium_index, "real index of the binder");
    f.o_wavelength = app.add_option("--wavelength-nm", f.wavelength, "vacuum wavelength in nm");
    f.o_radius = app.add_option("--radius-um", f.radius, "sphere radius in um (one size)");
    f.o_distribution = app.add_option("--distribution", f.distribution,
                                      "monodisperse, power_law, gamma or lognormal");
    f.o_r_eff = app.add_option("--r-eff-um", f.r_eff, "effective radius in um (power_law, gamma)");
    f.o_v_eff = app.add_option("--v-eff", f.v_eff, "effective variance (power_law, gamma)");
    f.o_r_g = app.add_option("--r-g-um", f.r_g, "geometric mean radius in um (lognormal)");
    f.o_sigma_g = app.add_option("--sigma-g", f.sigma_g, "geometric standard deviation (lognormal)");
    f.o_legendre = app.add_option("--legendre", f.legendre,
                                  "print at most this many Legendre moments (default: all > 1e-12)");
    f.o_tolerance = app.add_option("--tolerance", f.tolerance,
                                   "relative accuracy of the radius integration (default 1e-6)");
    cmd.run = [flags]() -> int { return run_mie(*flags); };
    return cmd;
}

} // namespace brdf::tool
