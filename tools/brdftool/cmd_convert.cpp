// brdftool convert IN OUT: a table into MERL .binary or OpenEXR (docs/design.md, "Table formats").
// IN is recognised by content (formats::detect_format: MERL, OpenEXR, spectral OpenEXR, pbrt-v3
// Fourier BSDF), OUT's format by its extension. The output extension and the paths are checked
// before the 35 MB input is read, so a typo costs nothing; the output is written atomically by
// write_table, so a failed conversion never leaves a partial OUT (and never clobbers an existing
// one).
//
// Values: every valid cell keeps its value up to float32 rounding (what the OpenEXR file stores);
// MERL -> MERL and EXR -> EXR are exact up to the MERL scale round trip (one ulp of a double). A
// spectral table becomes RGB with the CIE 1931 / D65 weights of its wavelengths (here, in the tool
// layer: formats depends on core only); a Fourier BSDF is evaluated at the cell centres.
// Provenance: the EXR attributes brdf.spec, brdf.generator and brdf.colorspace (a Fourier BSDF's
// metadata) travel with the table. A .binary file has no metadata, so converting to it drops them
// (said on a log line, a warning when a non-default colour space is dropped) and converting from
// it has none to keep.

#include "commands.h"
#include "source.h"

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
    if (from == TableFormat::SpectralExr)
        log::info("convert: ", in.string(), ": spectral planes integrated to linear Rec.709 (CIE 1931, D65)");
    if (from == TableFormat::Fourier)
        log::info("convert: ", in.string(), ": Fourier BSDF evaluated at the bin centres");
    if (from == TableFormat::RglTensor)
        log::info("convert: ", in.string(), ": RGL BSDF evaluated at the bin centres (as Mitsuba 3's measured does)");
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
    // The output's extension first (InputError naming the path and listing the supported ones).
    const formats::TableFormat to = formats::table_format(out);
    if (to != formats::TableFormat::Merl && to != formats::TableFormat::Exr)
        throw InputError(cat(out.string(), ": convert writes .binary (MERL) or .exr (OpenEXR), not ",
                             formats::to_string(to), " (that is computed from the material: brdftool "
                             "compute with \"outputs\")"));
    if (same_file(in, out))
        throw InputError(cat(out.string(), ": convert: the output is the input file (", in.string(),
                             "); choose another output path"));
    std::error_code ec;
    if (fs::is_directory(out, ec))
        throw InputError(
            cat(out.string(), ": convert: the output is a directory, not a file name"));

    const formats::TableFormat from = formats::detect_format(in); // by content; IoError, InputError
    const formats::BrdfTable table = formats::read_table(in, from, spectral_to_rgb());
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
        root.add_subcommand("convert", "Convert a BRDF table (MERL, OpenEXR, spectral OpenEXR, Fourier BSDF, RGL BSDF) to .binary or .exr");
    CLI::App& app = *cmd.app;
    app.add_option("IN", flags->in, "table to read (.binary, .exr, .spectral.exr, Fourier .bsdf, .rgl.bsdf)")->required();
    app.add_option("OUT", flags->out, "table to write (.binary or .exr); replaced atomically")
        ->required();
    app.footer(
        "IN is recognised by its content (a misnamed file is read as what it is, with a warning);\n"
        "OUT's format by its extension (.binary: MERL, .exr: OpenEXR; case-insensitive). A spectral\n"
        "table becomes linear Rec.709 (CIE 1931, D65); a Fourier or RGL BSDF is evaluated at the\n"
        "bin centres. Valid values are unchanged beyond float32 rounding (the precision\n"
        "of the .exr file). brdf.spec, brdf.generator and brdf.colorspace are kept from .exr to\n"
        ".exr; a .binary file has no metadata, so they are dropped going to it (brdftool\n"
        "--log-level info convert ... says so). OUT is written to a temporary file and renamed,\n"
        "so it is never left half-written.");
    cmd.run = [flags]() -> int { return run_convert(*flags); };
    return cmd;
}

} // namespace brdf::tool
