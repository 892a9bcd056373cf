// brdftool convert IN OUT: one table format into the other, chosen by the file extensions
// (docs/design.md, "Table formats"). Both extensions and the paths are checked before the 35 MB input is
// read, so a typo costs nothing; the output is written atomically by write_table, so a failed
// conversion never leaves a partial OUT (and never clobbers an existing one).
//
// Values: every valid cell keeps its value up to float32 rounding (what the OpenEXR file stores);
// MERL -> MERL and EXR -> EXR are exact up to the MERL scale round trip (one ulp of a double).
// Provenance: the EXR attributes brdf.spec, brdf.generator and brdf.colorspace travel with the
// table. A .binary file has no metadata, so converting to it drops them (said on a log line, a
// warning when a non-default colour space is dropped) and converting from it has none to keep.

#include "commands.h"

#include <formats/table_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <filesystem>
#include <memory>
#include <string>
#include <system_error>

namespace brdf::tool {
namespace {

namespace fs = std::filesystem;

struct ConvertFlags {
    std::string in, out;
};

/// True when `a` and `b` name the same file: the same existing file (through links, `./`, `..`), or
/// the same normalised absolute path when `b` does not exist yet.
bool same_file(const fs::path& a, const fs::path& b) {
    std::error_code ec;
    if (fs::exists(a, ec) && fs::exists(b, ec)) {
        const bool same = fs::equivalent(a, b, ec);
        if (!ec) return same;
    }
    const fs::path ca = fs::weakly_canonical(a, ec);
    if (ec) return false;
    const fs::path cb = fs::weakly_canonical(b, ec);
    if (ec) return false;
    return ca == cb;
}

void log_provenance(const formats::BrdfTable& table, formats::TableFormat from,
                    formats::TableFormat to, const fs::path& in, const fs::path& out) {
    using formats::TableFormat;
    if (from == TableFormat::Merl) {
        log::info("convert: ", in.string(),
                  ": a MERL .binary file carries no provenance (spec, generator, colour space); "
                  "nothing to keep");
        return;
    }
    if (to == TableFormat::Exr) {
        log::info("convert: ", out.string(), ": keeping brdf.spec (",
                  table.spec.empty() ? "absent" : cat(table.spec.size(), " bytes"),
                  "), brdf.generator (",
                  table.generator.empty() ? "absent" : "\"" + table.generator + "\"",
                  ") and brdf.colorspace (\"", table.colorspace, "\")");
        return;
    }
    // EXR -> MERL: the attributes have nowhere to go.
    if (!table.spec.empty() || !table.generator.empty())
        log::info("convert: ", out.string(),
                  ": a MERL .binary file has no metadata; brdf.spec and brdf.generator of ",
                  in.string(), " are not kept");
    else
        log::info("convert: ", in.string(), ": no brdf.spec or brdf.generator to keep");
    if (table.colorspace != formats::default_colorspace)
        log::warn("convert: ", out.string(), ": the values are in \"", table.colorspace,
                  "\" but a MERL .binary file cannot say so (readers assume \"",
                  formats::default_colorspace, "\")");
}

int run_convert(const ConvertFlags& f) {
    const fs::path in = f.in, out = f.out;
    // Extensions first (InputError naming the path and listing the supported ones).
    const formats::TableFormat from = formats::table_format(in);
    const formats::TableFormat to = formats::table_format(out);
    if (same_file(in, out))
        throw InputError(cat(out.string(), ": convert: the output is the input file (", in.string(),
                             "); choose another output path"));
    std::error_code ec;
    if (fs::is_directory(out, ec))
        throw InputError(
            cat(out.string(), ": convert: the output is a directory, not a file name"));

    const formats::BrdfTable table = formats::read_table(in);
    log_provenance(table, from, to, in, out);
    formats::write_table(out, table);
    log::info("convert: wrote ", out.string(), " (", formats::to_string(to), ", ",
              table.data_cells(), " cells with data) from ", in.string(), " (",
              formats::to_string(from), ")");
    return 0;
}

} // namespace

Subcommand add_convert_command(CLI::App& root) {
    auto flags = std::make_shared<ConvertFlags>();
    Subcommand cmd;
    cmd.app =
        root.add_subcommand("convert", "Convert a BRDF table between .binary (MERL) and .exr");
    CLI::App& app = *cmd.app;
    app.add_option("IN", flags->in, "table to read (.binary or .exr)")->required();
    app.add_option("OUT", flags->out, "table to write (.binary or .exr); replaced atomically")
        ->required();
    app.footer(
        "The formats are chosen by the extensions (.binary: MERL, .exr: OpenEXR;\n"
        "case-insensitive). Valid values are unchanged beyond float32 rounding (the precision\n"
        "of the .exr file). brdf.spec, brdf.generator and brdf.colorspace are kept from .exr to\n"
        ".exr; a .binary file has no metadata, so they are dropped going to it (brdftool\n"
        "--log-level info convert ... says so). OUT is written to a temporary file and renamed,\n"
        "so it is never left half-written.");
    cmd.run = [flags]() -> int { return run_convert(*flags); };
    return cmd;
}

} // namespace brdf::tool
