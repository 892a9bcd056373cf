#pragma once
// Tables by file name, and the statistics behind `brdftool info` and `brdftool diff`.

#include <formats/table.h>

#include <array>
#include <cstddef>
#include <filesystem>

namespace brdf::formats {

enum class TableFormat { Merl, Exr };

/// "MERL .binary" or "OpenEXR".
const char* to_string(TableFormat format);

/// The format named by the extension, case-insensitive: .binary -> Merl, .exr -> Exr. Anything else
/// is an InputError naming the path and listing the supported extensions.
TableFormat table_format(const std::filesystem::path& path);

/// read_merl or read_exr by extension.
BrdfTable read_table(const std::filesystem::path& path);
/// write_merl or write_exr by extension (checked before anything is written).
void write_table(const std::filesystem::path& path, const BrdfTable& table);

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
