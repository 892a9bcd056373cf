// brdftool info FILE [--json]: what a table file holds (docs/design.md, "Executables"): its format
// (recognised by content, formats::detect_format), layout and size, its provenance (the EXR brdf.*
// attributes, the Fourier BSDF's metadata), how many cells hold data, per-channel value statistics
// (formats::table_stats) and the directional albedo at a few incidence angles
// (formats::directional_albedo). A spectral table also lists its wavelengths, and its statistics
// are those of its RGB; a Fourier BSDF has no cells: its nodes, orders, channels, eta and metadata
// are printed, and the albedo integrates its evaluation; an RGL tensor BSDF likewise prints its
// grids (incidences, sample grid, warps), channels and description. Human-readable by default; --json prints
// one JSON object with the same content for scripts.

#include "commands.h"
#include "source.h"

#include <formats/exr/exr.h>
#include <formats/exr/spectral_exr.h>
#include <formats/fourier/fourier.h>
#include <formats/merl/merl.h>
#include <formats/rgl/rgl_eval.h>
#include <formats/table_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace brdf::tool {
namespace {

namespace fs = std::filesystem;

struct InfoFlags {
    std::string file;
    bool json = false;
};

/// Incidence angles of the albedo summary, degrees.
constexpr std::array<double, 4> albedo_angles_deg{0.0, 30.0, 60.0, 80.0};

struct AlbedoRow {
    double theta_i_deg = 0.0;
    formats::Rgb rho{};
};

/// The directional albedo rows under their heading ("evaluated as ..."), one line per angle.
void print_albedo(std::ostream& os, const std::string& how, const std::vector<AlbedoRow>& albedo) {
    char line[128];
    os << "  directional albedo (" << how << "):\n";
    std::snprintf(line, sizeof line, "    %-9s %12s %12s %12s\n", "theta_i", "red", "green", "blue");
    os << line;
    for (const AlbedoRow& row : albedo) {
        std::snprintf(line, sizeof line, "    %5.0f deg %12.6g %12.6g %12.6g\n", row.theta_i_deg, row.rho[0],
                      row.rho[1], row.rho[2]);
        os << line;
    }
}

/// info --json: `out` with its directional albedo rows, to stdout.
int print_json(nlohmann::ordered_json out, const std::vector<AlbedoRow>& albedo) {
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (const AlbedoRow& row : albedo) rows.push_back({{"theta_i_deg", row.theta_i_deg}, {"rgb", row.rho}});
    out["directional_albedo"] = rows;
    std::cout << out.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << '\n';
    return 0;
}

/// "%.6g" of a value: enough digits to compare with a reference, short enough to read.
std::string num(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

/// The spec text for a terminal: as given when it fits on one line, else its first line and a
/// count.
std::string spec_summary(const std::string& spec) {
    const std::size_t newline = spec.find('\n');
    if (newline == std::string::npos && spec.size() <= 100) return spec;
    std::string first = spec.substr(0, std::min<std::size_t>(newline, 60));
    return cat(first, " ... (", spec.size(), " bytes; --json prints all of it)");
}

/// A Fourier BSDF: its layout and metadata, and the albedo of its evaluation.
int info_fourier(const fs::path& path, std::uintmax_t size, bool json) {
    const formats::FourierBsdf b = formats::read_fourier_bsdf(path);
    const formats::FourierProvenance p = formats::fourier_provenance(b);
    std::size_t pairs_with_data = 0;
    for (const auto& s : b.series) pairs_with_data += s.length > 0;
    std::vector<AlbedoRow> albedo;
    for (double deg : albedo_angles_deg) {
        const double ti = deg * formats::pi / 180.0;
        albedo.push_back({deg, formats::directional_albedo(
                                   [&](double to, double phi) { return formats::evaluate(b, ti, to, phi); }, ti)});
    }
    const std::string channels = b.channels == 3 ? "Y, R, B" : "Y";
    if (json) {
        nlohmann::ordered_json out;
        out["file"] = path.string();
        out["format"] = formats::to_string(formats::TableFormat::Fourier);
        out["file_size_bytes"] = size;
        out["layout"] = "SCATFUN v1: Catmull-Rom in mu_i, mu_o x Fourier series in phi";
        out["nodes"] = b.nodes();
        out["mu"] = b.mu;
        out["max_order"] = b.max_order;
        out["channels"] = channels;
        out["eta"] = b.eta;
        out["alpha"] = b.alpha;
        out["coefficients"] = b.coefficients.size();
        out["pairs_with_data"] = pairs_with_data;
        out["units"] = "1/sr";
        nlohmann::ordered_json provenance = nlohmann::ordered_json::object();
        if (p.ours) {
            provenance["brdf.spec"] = p.spec;
            provenance["brdf.generator"] = p.generator;
            provenance["brdf.colorspace"] = p.colorspace;
        } else if (!b.metadata.empty()) {
            provenance["metadata"] = b.metadata; // foreign (layerlab writes JSON describing its layers)
        }
        out["provenance"] = provenance;
        return print_json(std::move(out), albedo);
    }
    std::ostringstream os;
    os << path.string() << '\n';
    os << "  format:      " << formats::to_string(formats::TableFormat::Fourier) << " (SCATFUN v1), " << size
       << " bytes\n";
    os << "  layout:      " << b.nodes() << " nodes in mu from " << b.mu.front() << " to " << b.mu.back()
       << ", Fourier series of up to " << b.max_order << " orders, channels " << channels << "\n";
    os << "               " << b.coefficients.size() << " coefficients in " << pairs_with_data
       << " of " << b.series.size() << " node pairs; eta " << b.eta << ", alpha " << b.alpha[0] << ' '
       << b.alpha[1] << '\n';
    if (p.ours) {
        os << "  colorspace:  " << (p.colorspace.empty() ? "(absent)" : p.colorspace) << '\n';
        os << "  generator:   " << (p.generator.empty() ? "(absent)" : p.generator) << '\n';
        os << "  spec:        " << (p.spec.empty() ? "(absent)" : spec_summary(p.spec)) << '\n';
    } else {
        os << "  metadata:    " << (b.metadata.empty() ? "(none)" : spec_summary(b.metadata)) << '\n';
    }
    print_albedo(os, "the Fourier series evaluated as pbrt-v3 does", albedo);
    std::cout << os.str();
    return 0;
}

std::string shape_text(const std::vector<std::size_t>& shape) {
    std::string out;
    for (std::size_t d : shape) out += cat(out.empty() ? "" : " x ", d);
    return out;
}

/// An RGL tensor BSDF: its grids, channels, description, and the albedo of its evaluation (as
/// Mitsuba 3's `measured` evaluates it).
int info_rgl(const fs::path& path, std::uintmax_t size, bool json) {
    const Source source = load_source(path, {}, model::Device::Cpu); // the file, with RGB weights if spectral
    const formats::RglBsdf& b = source.rgl->bsdf();
    const formats::RglProvenance p = formats::rgl_provenance(b);
    std::vector<AlbedoRow> albedo;
    for (double deg : albedo_angles_deg) albedo.push_back({deg, source.albedo(deg * formats::pi / 180.0)});
    const double max_theta_deg = b.theta_i.back() * 180.0 / formats::pi;
    const std::string channels =
        b.spectral() ? cat(b.wavelengths.size(), " wavelengths, ", b.wavelengths.front(), " to ", b.wavelengths.back(), " nm")
                     : std::string("R, G, B");
    if (json) {
        nlohmann::ordered_json out;
        out["file"] = path.string();
        out["format"] = formats::to_string(formats::TableFormat::RglTensor);
        out["file_size_bytes"] = size;
        out["layout"] = "Dupuy and Jakob 2018: BRDF samples on a visible-normal warp per incidence";
        out["theta_i"] = b.theta_i;
        out["phi_i"] = b.phi_i;
        out["isotropic"] = b.isotropic();
        out["sample_resolution"] = b.sample_resolution();
        out["ndf_shape"] = b.ndf.shape;
        out["sigma_shape"] = b.sigma.shape;
        out["vndf_shape"] = b.vndf.shape;
        out["channels"] = b.spectral() ? "spectra" : "rgb";
        if (b.spectral()) out["wavelengths_nm"] = b.wavelengths;
        out["jacobian"] = b.jacobian;
        out["units"] = "1/sr";
        nlohmann::ordered_json provenance = nlohmann::ordered_json::object();
        if (p.ours) {
            provenance["brdf.spec"] = p.spec;
            provenance["brdf.generator"] = p.generator;
        } else {
            provenance["description"] = b.description;
        }
        out["provenance"] = provenance;
        return print_json(std::move(out), albedo);
    }
    std::ostringstream os;
    os << path.string() << '\n';
    os << "  format:      " << formats::to_string(formats::TableFormat::RglTensor) << " (Dupuy and Jakob 2018), "
       << size << " bytes\n";
    os << "  layout:      " << b.theta_i.size() << " incidences theta_i from 0 to " << num(max_theta_deg) << " deg, "
       << b.phi_i.size() << " phi_i (" << (b.isotropic() ? "isotropic" : "anisotropic") << "), "
       << b.sample_resolution() << " x " << b.sample_resolution() << " samples each\n";
    os << "               ndf " << shape_text(b.ndf.shape) << ", sigma " << shape_text(b.sigma.shape) << ", vndf "
       << shape_text(b.vndf.shape) << ", jacobian " << (b.jacobian ? 1 : 0) << '\n';
    os << "  channels:    " << channels << '\n';
    if (p.ours) {
        os << "  generator:   " << (p.generator.empty() ? "(absent)" : p.generator) << '\n';
        os << "  spec:        " << (p.spec.empty() ? "(absent)" : spec_summary(p.spec)) << '\n';
    } else {
        os << "  description: " << (b.description.empty() ? "(none)" : spec_summary(b.description)) << '\n';
    }
    print_albedo(os, "evaluated as Mitsuba 3's measured does", albedo);
    std::cout << os.str();
    return 0;
}

int run_info(const InfoFlags& f) {
    const fs::path path = f.file;
    const formats::TableFormat format = formats::detect_format(path); // by content; IoError, InputError
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(path, ec);
    if (ec) throw IoError(cat(path.string(), ": cannot stat: ", ec.message()));
    if (format == formats::TableFormat::Fourier) return info_fourier(path, size, f.json);
    if (format == formats::TableFormat::RglTensor) return info_rgl(path, size, f.json);
    std::optional<formats::SpectralTable> spectral;
    if (format == formats::TableFormat::SpectralExr) spectral = formats::read_spectral_exr(path);
    const formats::BrdfTable table = spectral ? spectral_to_rgb()(*spectral)
                                              : formats::read_table(path, format); // IoError / FormatError

    const formats::TableStats stats = formats::table_stats(table);
    // Cells above the horizon without data: 0 for computed tables, the unmeasured cells of MERL's
    // measurements (-1 there).
    // Cells below the horizon with data: only foreign MERL files have them (writers drop them).
    std::size_t missing_above = 0, data_below = 0;
    for (std::size_t cell = 0; cell < formats::cells; ++cell) {
        const bool below = formats::cell_below_horizon(cell), data = table.has_data(cell);
        missing_above += !data && !below;
        data_below += data && below;
    }
    std::vector<AlbedoRow> albedo;
    for (double deg : albedo_angles_deg)
        albedo.push_back({deg, formats::directional_albedo(table, deg * formats::pi / 180.0)});

    const bool is_exr = format == formats::TableFormat::Exr || format == formats::TableFormat::SpectralExr;
    if (f.json) {
        nlohmann::ordered_json out;
        out["file"] = path.string();
        out["format"] = formats::to_string(format);
        out["file_size_bytes"] = size;
        out["layout"] = formats::exr_layout;
        out["dims"] = {{"theta_h", formats::theta_h_bins},
                       {"theta_d", formats::theta_d_bins},
                       {"phi_d", formats::phi_d_bins}};
        out["cells"] = formats::cells;
        out["units"] = "1/sr";
        if (!is_exr) out["merl_scales"] = formats::merl_scales;
        if (spectral) {
            out["wavelengths_nm"] = spectral->wavelengths_nm;
            out["spectral_layout_version"] = formats::spectral_layout_version;
            out["values"] = "RGB of the spectral planes (CIE 1931, D65, linear Rec.709)";
        }
        nlohmann::ordered_json provenance = nlohmann::ordered_json::object();
        if (is_exr) {
            if (!table.spec.empty()) provenance["brdf.spec"] = table.spec;
            if (!table.generator.empty()) provenance["brdf.generator"] = table.generator;
            provenance["brdf.colorspace"] = table.colorspace;
        }
        out["provenance"] = provenance;
        out["colorspace"] = table.colorspace;
        out["data_cells"] = stats.data_cells;
        out["below_horizon_cells"] = stats.below_horizon_cells;
        out["no_data_above_horizon_cells"] = missing_above;
        out["data_below_horizon_cells"] = data_below;
        nlohmann::ordered_json channels = nlohmann::ordered_json::object();
        for (int c = 0; c < 3; ++c)
            channels[formats::channel_name(c)] = {{"min", stats.channels[c].min},
                                                  {"max", stats.channels[c].max},
                                                  {"mean", stats.channels[c].mean}};
        out["channels"] = channels;
        return print_json(std::move(out), albedo);
    }

    std::ostringstream os;
    os << path.string() << '\n';
    os << "  format:      " << formats::to_string(format) << ", " << size << " bytes\n";
    os << "  layout:      " << formats::exr_layout << " (theta_h " << formats::theta_h_bins
       << " x theta_d " << formats::theta_d_bins << " x phi_d " << formats::phi_d_bins << " = "
       << formats::cells << " cells), BRDF in 1/sr";
    if (!is_exr)
        os << " (stored / scale " << num(formats::merl_scales[0]) << ' '
           << num(formats::merl_scales[1]) << ' ' << num(formats::merl_scales[2]) << ')';
    os << '\n';
    if (spectral)
        os << "  wavelengths: " << spectral->wavelengths_nm.size() << " (" << spectral->wavelengths_nm.front()
           << " to " << spectral->wavelengths_nm.back()
           << " nm), one T.<wavelength>nm channel each; values below are their RGB (CIE 1931, D65)\n";
    if (is_exr) {
        os << "  colorspace:  " << table.colorspace << '\n';
        os << "  generator:   " << (table.generator.empty() ? "(absent)" : table.generator) << '\n';
        os << "  spec:        " << (table.spec.empty() ? "(absent)" : spec_summary(table.spec))
           << '\n';
    } else {
        os << "  provenance:  none (a MERL .binary file has no metadata); colour space assumed "
           << table.colorspace << '\n';
    }
    os << "  cells:       " << stats.data_cells << " with data, " << stats.below_horizon_cells
       << " below the horizon, " << missing_above << " above the horizon without data\n";
    if (data_below > 0)
        os << "               (" << data_below
           << " cells below the horizon hold data; converting drops it)\n";
    os << "  values (1/sr, over cells with data):\n";
    char line[128];
    std::snprintf(line, sizeof line, "    %-7s %12s %12s %12s\n", "channel", "min", "max", "mean");
    os << line;
    for (int c = 0; c < 3; ++c) {
        std::snprintf(line, sizeof line, "    %-7s %12.6g %12.6g %12.6g\n",
                      formats::channel_name(c), stats.channels[c].min, stats.channels[c].max,
                      stats.channels[c].mean);
        os << line;
    }
    print_albedo(os, "table lookup", albedo);
    std::cout << os.str();
    return 0;
}

} // namespace

Subcommand add_info_command(CLI::App& root) {
    auto flags = std::make_shared<InfoFlags>();
    Subcommand cmd;
    cmd.app = root.add_subcommand(
        "info", "Format, layout, provenance and value statistics of a BRDF table");
    CLI::App& app = *cmd.app;
    app.add_option("FILE", flags->file, "table (.binary, .exr, .spectral.exr, Fourier .bsdf, .rgl.bsdf)")->required();
    app.add_flag("--json", flags->json, "print one JSON object instead of text");
    app.footer("Prints the format, file size, layout (90 x 90 x 180 half/difference cells), "
               "provenance (the\n"
               ".exr attributes brdf.generator, brdf.spec, brdf.colorspace; a .binary file has "
               "none), the\n"
               "cells with data and below the horizon, min / max / mean per channel (1/sr, "
               "unweighted over\n"
               "cells with data) and the directional albedo at theta_i = 0, 30, 60, 80 degrees.\n"
               "The format is recognised by content. A spectral .exr lists its wavelengths; a Fourier\n"
               ".bsdf (pbrt-v3) prints nodes, orders, channels, eta and its metadata instead of cells, an\n"
               ".rgl.bsdf (Mitsuba 3, pbrt-v4) its incidences, sample grid, warps, channels and description.");
    cmd.run = [flags]() -> int { return run_info(*flags); };
    return cmd;
}

} // namespace brdf::tool
