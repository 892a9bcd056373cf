#pragma once
// The one place that knows every table format: which one a file holds (by its magic bytes), which
// one a file name asks for (by its extension), reading any of them as an RGB table; and the
// statistics behind `brdftool info` and `brdftool diff`.

#include <formats/table.h>

#include <array>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <span>
#include <string>

namespace brdf::formats {

struct SpectralTable;
struct RglBsdf;

enum class TableFormat {
    Merl,        ///< MERL .binary (formats/merl)
    Exr,         ///< OpenEXR RGB table (formats/exr/exr.h)
    SpectralExr, ///< OpenEXR spectral table, JCGT 2021 layout (formats/exr/spectral_exr.h)
    Fourier,     ///< pbrt-v3 Fourier BSDF, SCATFUN v1 (formats/fourier)
    RglTensor,   ///< RGL tensor file of Mitsuba 3 / pbrt-v4 `measured` (formats/rgl)
};

/// "MERL .binary", "OpenEXR", "spectral OpenEXR", "pbrt-v3 Fourier BSDF", "RGL tensor".
const char* to_string(TableFormat format);

/// The format a file name asks for, by extension, case-insensitive: .binary -> Merl,
/// .spectral.exr -> SpectralExr, other .exr -> Exr, .rgl.bsdf -> RglTensor, other .bsdf -> Fourier.
/// Anything else is an InputError naming the path and listing the supported extensions. Writers
/// go by this.
TableFormat table_format(const std::filesystem::path& path);

/// The format a file holds, by its first bytes: "SCATFUN" -> Fourier; "tensor_file\0" ->
/// RglTensor; the OpenEXR magic 0x762f3101 -> SpectralExr when a channel is a reflective spectral
/// one (T.<wavelength>nm), else Exr; three int32 90 90 180 and exactly 34,992,012 bytes -> Merl
/// (MERL has no magic). A file none of these recognise (a truncated MERL table, say) has the format
/// of its extension, so that its reader names the fault; with an unknown extension too it is the
/// InputError of table_format. Recognised content under another extension's name (a MERL table
/// called paint.exr) is read as what it is, with a warning naming both. IoError when the file
/// cannot be opened.
TableFormat detect_format(const std::filesystem::path& path);

/// Turns a spectral table into RGB (the weights live outside formats: brdftool passes those of
/// brdf/material/spectrum.h).
using SpectralToRgb = std::function<BrdfTable(const SpectralTable&)>;

/// The table a file holds, whatever its format (detect_format): MERL and OpenEXR read as they are;
/// a Fourier BSDF evaluated at the cell centres (tabulate_fourier); a spectral table through
/// `spectral_to_rgb` (InputError naming the path without it); an RGL tensor file evaluated at the
/// cell centres as Mitsuba 3 evaluates it (tabulate_rgl).
BrdfTable read_table(const std::filesystem::path& path, const SpectralToRgb& spectral_to_rgb = {});
/// The same for a format detect_format already gave (so that a misnamed file warns once).
BrdfTable read_table(const std::filesystem::path& path, TableFormat format,
                     const SpectralToRgb& spectral_to_rgb = {});
/// The table of an RGL BSDF at the bin centres of the MERL layout: formats::RglEvaluator::brdf
/// (Mitsuba 3's `measured`), negative samples clamped to 0 as pbrt-v4 clamps them; a spectral file
/// through `spectral_to_rgb` (InputError starting with `what` without it). Provenance from the
/// description when it is ours (rgl_provenance).
BrdfTable tabulate_rgl(const RglBsdf& bsdf, const std::string& what, const SpectralToRgb& spectral_to_rgb = {});
/// write_merl or write_exr by extension (checked before anything is written); other formats are an
/// InputError (they are made from the model, not from a table).
void write_table(const std::filesystem::path& path, const BrdfTable& table);

/// The RGB table of a spectral one: each cell sum_j weights[j] * plane_j (weights per wavelength,
/// one Rgb each, in the order of table.wavelengths_nm), negative sums clamped to 0 with the number
/// of clamped values logged; no-data cells stay no data. InputError when the counts differ.
BrdfTable spectral_to_rgb(const SpectralTable& table, std::span<const Rgb> weights,
                          const std::string& colorspace = default_colorspace);

/// Statistics of one channel over the cells with data, BRDF in 1/sr; all 0 when there are none.
struct ChannelStats {
    double min = 0.0;
    double max = 0.0;
    double mean = 0.0; ///< unweighted mean over cells (not a solid-angle average)
};

struct TableStats {
    std::size_t data_cells = 0;          ///< cells with data
    std::size_t below_horizon_cells = 0; ///< cells whose bin centre is below the horizon (geometry)
    std::array<ChannelStats, 3> channels;
};

TableStats table_stats(const BrdfTable& table);

/// Relative difference floor of diff(), in 1/sr: about 1e-3 of a white Lambertian surface (1/pi).
/// Reference values below it are compared on an absolute scale, so that near-black cells (where
/// rounding noise is large relative to the value) do not dominate the maximum.
inline constexpr double default_diff_floor = 3e-4;

struct ChannelDiff {
    double max = 0.0;         ///< largest relative difference
    double mean = 0.0;        ///< mean relative difference
    double rms = 0.0;         ///< root mean square relative difference
    std::size_t max_cell = 0; ///< a cell where `max` occurs (the first in index order)
};

struct TableDiff {
    std::size_t compared_cells = 0; ///< cells with data in both tables
    std::size_t only_in_a = 0;      ///< cells with data in A only
    std::size_t only_in_b = 0;      ///< cells with data in B only
    double floor = default_diff_floor;
    std::array<ChannelDiff, 3> channels;
};

/// Per-channel relative difference of A against the reference B over the cells with data in both:
/// rel = |a - b| / max(|b|, floor), floor in 1/sr (> 0). Cells with data in only one table are
/// counted, not compared. All statistics are 0 when no cell is compared.
TableDiff diff(const BrdfTable& a, const BrdfTable& b, double floor = default_diff_floor);

} // namespace brdf::formats
