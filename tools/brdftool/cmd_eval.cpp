// brdftool eval: the BRDF (1/sr) as "r g b" per direction triple (docs/design.md). On a spec the solved
// model is evaluated through the tables' interpolant (Source::use_interpolant: the tables' values
// at the cell centres, over 100,000 directions a second), or with --exact off the quadrature nodes
// at each direction (milliseconds each); on a table, by nearest-bin lookup. With --spectral,
// one value per wavelength instead (a spec with a spectrum: each solved wavelength; a spectral
// OpenEXR table: each plane), after a "# wavelength_nm ..." line naming them.

#include "commands.h"
#include "source.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/parse.h>
#include <brdf/core/threads.h>

#include <formats/exr/spectral_exr.h>
#include <formats/halfdiff.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <functional>
#include <memory>
#include <cstdio>
#include <numbers>
#include <string_view>

namespace brdf::tool {
namespace {

struct EvalFlags {
    std::string input, material;
    std::optional<double> theta_i, theta_o, phi;
    bool spectral = false, exact = false;
    DeviceFlag device;
};

// What eval --spectral evaluates: the solved wavelengths of a model, or the planes of a spectral table.
struct SpectralSource {
    std::vector<double> wavelengths_nm;
    std::function<std::vector<double>(double theta_i, double theta_o, double phi)> values; // radians, 1/sr
};

SpectralSource load_spectral(const EvalFlags& f) {
    SpectralSource out;
    if (!is_spec_file(f.input)) {
        if (formats::detect_format(f.input) != formats::TableFormat::SpectralExr)
            throw InputError(cat("eval --spectral: ", f.input, " is not a spectral table (NAME.spectral.exr) or a spec"));
        auto table = std::make_shared<formats::SpectralTable>(formats::read_spectral_exr(f.input));
        out.wavelengths_nm = table->wavelengths_nm;
        out.values = [table](double ti, double to, double phi) {
            std::vector<double> v(table->planes.size(), 0.0);
            if (std::cos(ti) <= 0.0 || std::cos(to) <= 0.0) return v;
            const std::size_t cell = formats::nearest_cell(ti, to, phi);
            if (!table->has_data(cell)) return v;
            for (std::size_t j = 0; j < v.size(); ++j) v[j] = table->planes[j][cell];
            return v;
        };
        return out;
    }
    auto model = std::make_shared<model::SolvedMaterial>(*load_source(f.input, f.material, f.device.device()).model);
    for (const model::WavelengthSolution& s : model->samples) {
        if (s.wavelength_nm <= 0.0)
            throw InputError(cat("eval --spectral: ", model->spec.name, " is an analytic medium, given per RGB "
                                 "channel: it has no wavelengths"));
        out.wavelengths_nm.push_back(s.wavelength_nm);
    }
    out.values = [model](double ti, double to, double phi) {
        std::vector<double> v;
        const double mi = std::cos(ti), mo = std::cos(to);
        for (const model::WavelengthSolution& s : model->samples) {
            const double x = mi <= 0.0 || mo <= 0.0 ? 0.0 : s.dipole ? s.dipole->brdf(mi, mo, phi) : s.reflection.brdf(mi, mo, phi);
            v.push_back(std::max(0.0, x)); // no output is negative (docs/colour.md)
        }
        return v;
    };
    return out;
}

double radians(double degrees) { return degrees * std::numbers::pi / 180.0; }

void check_angles(double ti, double to, double phi, const std::string& where) {
    if (!(std::isfinite(ti) && std::isfinite(to) && std::isfinite(phi)))
        throw InputError(cat(where, ": angles must be finite numbers"));
    if (ti < 0.0 || ti > 90.0 || to < 0.0 || to > 90.0)
        throw InputError(cat(where, ": zenith angles must be in [0, 90] degrees (got ", ti, ", ", to, ")"));
}

int run_eval(const EvalFlags& f) {
    std::optional<Source> source;
    std::optional<SpectralSource> spectral;
    if (f.spectral) {
        spectral = load_spectral(f);
        std::printf("# wavelength_nm");
        for (double l : spectral->wavelengths_nm) std::printf(" %.9g", l);
        std::printf("\n");
    } else {
        source = load_source(f.input, f.material, f.device.device());
        if (!f.exact) source->use_interpolant();
    }
    const auto print = [&](double ti, double to, double phi) {
        if (spectral) {
            const std::vector<double> v = spectral->values(radians(ti), radians(to), radians(phi));
            for (std::size_t j = 0; j < v.size(); ++j) std::printf(j == 0 ? "%.9g" : " %.9g", v[j]);
            std::printf("\n");
            return;
        }
        const model::Rgb v = source->brdf(radians(ti), radians(to), radians(phi));
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
    // Every line is read and checked first (a bad line fails the command before any output), then
    // the directions are evaluated on every core and printed in order. The lines are split in place
    // and the values written with std::to_chars (the same text as printf's %.9g) into one buffer:
    // a string stream per line and printf per value took as long as the 200,000 directions'
    // interpolation (bench/interactive.py's eval row).
    struct Triple {
        double ti, to, phi;
    };
    std::vector<Triple> triples;
    std::string text;
    {
        char buffer[1 << 16];
        for (std::size_t got; (got = std::fread(buffer, 1, sizeof buffer, stdin)) > 0;) text.append(buffer, got);
    }
    const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; };
    std::size_t at = 0;
    for (int number = 1; at < text.size(); ++number) {
        const std::size_t end = std::min(text.find('\n', at), text.size());
        std::string_view tokens[4];
        int count = 0;
        for (std::size_t i = at; i < end;) {
            if (is_space(text[i])) {
                ++i;
                continue;
            }
            std::size_t j = i;
            while (j < end && !is_space(text[j])) ++j;
            if (count < 4) tokens[count] = std::string_view(text).substr(i, j - i);
            ++count;
            i = j;
        }
        at = end + 1;
        if (count == 0 || tokens[0][0] == '#') continue; // a blank line or a comment
        const std::string where = cat("stdin line ", number);
        if (count != 3) throw InputError(cat(where, ": expected 'theta_i theta_o phi' in degrees"));
        const double ti = parse_double(tokens[0], where), to = parse_double(tokens[1], where);
        const double phi = parse_double(tokens[2], where);
        check_angles(ti, to, phi, where);
        triples.push_back({ti, to, phi});
    }
    if (spectral) {
        for (const Triple& t : triples) print(t.ti, t.to, t.phi);
        return 0;
    }
    std::vector<model::Rgb> values(triples.size());
    constexpr int chunk = 4096;
    parallel_for(static_cast<int>((triples.size() + chunk - 1) / chunk), available_cpus(), [&](int k) {
        const std::size_t end = std::min(triples.size(), static_cast<std::size_t>(k + 1) * chunk);
        for (std::size_t j = static_cast<std::size_t>(k) * chunk; j < end; ++j)
            values[j] = source->brdf(radians(triples[j].ti), radians(triples[j].to), radians(triples[j].phi));
    });
    std::string out;
    out.reserve(values.size() * 48);
    char number[32];
    for (const model::Rgb& v : values)
        for (int c = 0; c < 3; ++c) {
            const auto written = std::to_chars(number, number + sizeof number, v[c], std::chars_format::general, 9);
            out.append(number, written.ptr);
            out.push_back(c < 2 ? ' ' : '\n');
        }
    std::fwrite(out.data(), 1, out.size(), stdout);
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
    app->add_flag("--spectral", flags->spectral,
                  "one value per wavelength instead of r g b (a spec with a spectrum, or a .spectral.exr table)");
    app->add_flag("--exact", flags->exact,
                  "a spec: solve each direction off the quadrature nodes (ms each) instead of the tables' interpolant");
    flags->device.add_to(*app);
    app->footer("Without angle flags, reads lines 'theta_i theta_o phi' (degrees) from stdin. RGB values are in\n"
                "the colour space of the spec (its \"colorspace\") or of the table (brdf.colorspace). With\n"
                "--spectral a first line '# wavelength_nm L1 L2 ...' names the columns. A spec is evaluated\n"
                "through the interpolant its tables are filled from (each Fourier order on the table's zenith\n"
                "grid, the single scattering and a rough lobe exact per direction): the tables' values at the\n"
                "cell centres; --exact (and --spectral) solve every direction exactly instead.");
    return {app, [flags] { return run_eval(*flags); }};
}

} // namespace brdf::tool
