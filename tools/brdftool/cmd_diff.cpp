// brdftool diff A B [--floor X] [--json]: per-channel max / mean / RMS relative difference of A
// against the reference B (formats::diff: |a - b| / max(|b|, floor) over the cells with data in
// both), with the cell of each maximum given as the bin-centre angles (theta_h, theta_d, phi_d) in
// degrees and both values there (docs/design.md, "Executables").
//
// Operands are loaded by load_operand(), the one place that knows what an operand may be: a table
// file (.binary, .exr), or a material spec (.json), solved and tabulated exactly as `compute` would
// (the "table and a spec" case of docs/design.md: how much does a stored table differ from the model?).

#include "commands.h"
#include "source.h"

#include <brdf/model/cl_table_fill.h>

#include <formats/halfdiff.h>
#include <formats/table_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/parse.h>
#include <brdf/material/spec.h>

#include <nlohmann/json.hpp>

#include <thread>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

namespace brdf::tool {

/// One operand of `diff` as a table: a table file of any format (formats::read_table: recognised by
/// content; a Fourier BSDF evaluated at the cell centres, a spectral one as RGB). A
/// material spec (.json) is refused for now (InputError naming the path). Throws what read_table
/// throws: InputError for an unknown extension, IoError / FormatError for a bad file.
formats::BrdfTable load_operand(const std::filesystem::path& path, const std::string& material,
                                model::Device device, const std::string& recorded = {});

namespace {

namespace fs = std::filesystem;

struct DiffFlags {
    std::string a, b, floor, material;
    DeviceFlag device;
    bool json = false;
    CLI::Option* o_floor = nullptr;
};

std::string lower_extension(const fs::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    return ext;
}

double degrees(double radians) {
    return radians * 180.0 / formats::pi;
}

/// Bin-centre angles of a cell in degrees, theta_h, theta_d, phi_d.
std::array<double, 3> centre_degrees(std::size_t cell) {
    const formats::CellIndices ix = formats::cell_indices(cell);
    return {degrees(formats::theta_h_centre(ix.theta_h)),
            degrees(formats::theta_d_centre(ix.theta_d)), degrees(formats::phi_d_centre(ix.phi_d))};
}

int run_diff(const DiffFlags& f) {
    double floor = formats::default_diff_floor;
    if (f.o_floor->count() > 0) {
        floor = parse_double(f.floor, "diff: --floor");
        if (!(floor > 0.0))
            throw InputError(cat("diff: --floor must be > 0 (1/sr; got ", f.floor, ")"));
    }
    const fs::path path_a = f.a, path_b = f.b;
    // A table against a catalogue: the material is the one the table says it came from (unless
    // --material says otherwise). Tables are read first so that their record is known.
    const bool a_spec = lower_extension(path_a) == ".json", b_spec = lower_extension(path_b) == ".json";
    // Errors still come in operand order: A's before B's.
    std::optional<formats::BrdfTable> loaded_a, loaded_b;
    std::string recorded;
    if (!a_spec) {
        loaded_a = formats::read_table(path_a);
        recorded = recorded_material(path_a, *loaded_a);
    }
    std::exception_ptr b_error;
    if (!b_spec) {
        try {
            loaded_b = formats::read_table(path_b);
            if (recorded.empty()) recorded = recorded_material(path_b, *loaded_b);
        } catch (...) {
            b_error = std::current_exception();
        }
    }
    if (a_spec) {
        if (b_error) { // A's own faults first, then B's
            material::load_specs(path_a);
            std::rethrow_exception(b_error);
        }
        loaded_a = load_operand(path_a, f.material, f.device.device(), recorded);
    }
    if (b_error) std::rethrow_exception(b_error);
    if (b_spec) loaded_b = load_operand(path_b, f.material, f.device.device(), recorded);
    const formats::BrdfTable& a = *loaded_a;
    const formats::BrdfTable& b = *loaded_b;
    const formats::TableDiff d = formats::diff(a, b, floor);
    const bool compared = d.compared_cells > 0;

    if (f.json) {
        nlohmann::ordered_json out;
        out["a"] = path_a.string();
        out["b"] = path_b.string();
        out["reference"] = "b";
        out["floor"] = d.floor;
        out["compared_cells"] = d.compared_cells;
        out["only_in_a"] = d.only_in_a;
        out["only_in_b"] = d.only_in_b;
        nlohmann::ordered_json channels = nlohmann::ordered_json::object();
        for (int c = 0; c < 3; ++c) {
            const formats::ChannelDiff& ch = d.channels[c];
            nlohmann::ordered_json j = {{"max", ch.max}, {"mean", ch.mean}, {"rms", ch.rms}};
            if (ch.max > 0.0) {
                const formats::CellIndices ix = formats::cell_indices(ch.max_cell);
                const auto deg = centre_degrees(ch.max_cell);
                j["max_at"] = {{"cell", ch.max_cell},
                               {"index", {ix.theta_h, ix.theta_d, ix.phi_d}},
                               {"theta_h_deg", deg[0]},
                               {"theta_d_deg", deg[1]},
                               {"phi_d_deg", deg[2]},
                               {"a", a.plane(c)[ch.max_cell]},
                               {"b", b.plane(c)[ch.max_cell]}};
            } else {
                j["max_at"] = nullptr;
            }
            channels[formats::channel_name(c)] = j;
        }
        out["channels"] = channels;
        std::cout << out.dump(2) << '\n';
        return 0;
    }

    std::ostringstream os;
    os << "A: " << path_a.string() << "\nB: " << path_b.string() << " (reference)\n";
    os << "cells compared: " << d.compared_cells << " (with data in A only: " << d.only_in_a
       << ", in B only: " << d.only_in_b << ")\n";
    char line[256];
    std::snprintf(line, sizeof line, "relative difference |A - B| / max(|B|, %g 1/sr):\n", d.floor);
    os << line;
    if (!compared) {
        os << "  no cell has data in both tables\n";
        std::cout << os.str();
        return 0;
    }
    std::snprintf(line, sizeof line, "  %-7s %11s %12s %12s   %-36s %12s %12s\n", "channel", "max",
                  "mean", "rms", "max at (theta_h, theta_d, phi_d) deg", "A", "B");
    os << line;
    for (int c = 0; c < 3; ++c) {
        const formats::ChannelDiff& ch = d.channels[c];
        if (ch.max == 0.0) { // identical: there is no "where"
            std::snprintf(line, sizeof line, "  %-7s %11.4g %12.4g %12.4g   -\n",
                          formats::channel_name(c), ch.max, ch.mean, ch.rms);
            os << line;
            continue;
        }
        const auto deg = centre_degrees(ch.max_cell);
        char angles[64];
        std::snprintf(angles, sizeof angles, "(%.3f, %.3f, %.3f)", deg[0], deg[1], deg[2]);
        std::snprintf(line, sizeof line, "  %-7s %11.4g %12.4g %12.4g   %-36s %12.6g %12.6g\n",
                      formats::channel_name(c), ch.max, ch.mean, ch.rms, angles,
                      a.plane(c)[ch.max_cell], b.plane(c)[ch.max_cell]);
        os << line;
    }
    std::cout << os.str();
    return 0;
}

} // namespace

formats::BrdfTable load_operand(const std::filesystem::path& path, const std::string& material,
                                model::Device device, const std::string& recorded) {
    if (lower_extension(path) != ".json") return formats::read_table(path, spectral_to_rgb());
    const Source source = load_source(path, material, device, recorded);
    return model::fill_table(model::prepare_fill(*source.model), device);
}

Subcommand add_diff_command(CLI::App& root) {
    auto flags = std::make_shared<DiffFlags>();
    Subcommand cmd;
    cmd.app = root.add_subcommand("diff", "Per-channel relative difference of two BRDF tables, or of a table and its spec");
    CLI::App& app = *cmd.app;
    app.add_option("A", flags->a, "table to check (.binary, .exr, Fourier .bsdf, .rgl.bsdf), or a material spec (.json)")->required();
    app.add_option("B", flags->b, "reference table (.binary or .exr), or a material spec (.json)")->required();
    app.add_option("--material", flags->material, "material name in a spec catalogue");
    flags->device.add_to(app);
    flags->o_floor = app.add_option("--floor", flags->floor,
                                    cat("relative-difference floor in 1/sr, > 0 (default ",
                                        formats::default_diff_floor, ")"))
                         ->type_name("X");
    app.add_flag("--json", flags->json, "print one JSON object instead of text");
    app.footer(
        "Over the cells with data in both tables, per channel: rel = |A - B| / max(|B|, floor), "
        "and\n"
        "its max, mean and RMS. B is the reference. The floor keeps near-black cells from "
        "dominating\n"
        "the maximum (below it the difference is absolute, in units of the floor). The cell of "
        "the\n"
        "maximum is given by its bin centre (theta_h, theta_d, phi_d) in degrees, with A and B "
        "there\n"
        "(none when the maximum is 0; --json then gives max_at: null).\n"
        "Cells with data in only one table are counted, not compared. Exit status 0 whatever the\n"
        "difference.");
    cmd.run = [flags]() -> int { return run_diff(*flags); };
    return cmd;
}

} // namespace brdf::tool
