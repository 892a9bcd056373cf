#pragma once
// MERL .binary tables (Matusik et al. 2003; the layout of the MERL reference reader BRDFRead.cpp,
// pbrt-v2's `measured` material and Disney's BRDF Explorer).
//
// File: little-endian; three int32 dims 90 90 180 (theta_h, theta_d, phi_d); then three planes of
// 1,458,000 float64 in the order red, green, blue, each in MERL index order (formats/halfdiff.h);
// 34,992,012 bytes in all. A stored value is BRDF / scale with the scales below; cells without data
// hold -1 in all three planes.

#include <formats/table.h>

#include <array>
#include <cstdint>
#include <filesystem>

namespace brdf::formats {

/// Stored value * scale = BRDF in 1/sr, for red, green, blue.
inline constexpr std::array<double, 3> merl_scales{1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};
/// The header's dims.
inline constexpr std::array<std::int32_t, 3> merl_dims{theta_h_bins, theta_d_bins, phi_d_bins};
/// 12 + 3 * 8 * 1,458,000 = 34,992,012.
inline constexpr std::uint64_t merl_file_size = 12 + 3 * 8 * std::uint64_t{cells};

/// Reads a MERL table. Checks, in this order and before allocating anything large: that the path is
/// a readable regular file (IoError); that it holds at least the 12-byte header; that the dims are
/// 90 90 180 (a byte-swapped header is reported as big-endian); that the size is exactly
/// merl_file_size. Then every stored value: NaN or infinite is a FormatError naming the channel and
/// cell; a negative value in any channel marks the cell "no data" in all three (the reference
/// reader treats negative values as "below horizon"), whatever its geometry. Cells with data are
/// returned in 1/sr (stored * scale). `spec` and `generator` are empty: the format has no metadata.
/// Every message starts with the path, e.g. "paint.binary: truncated (34992012 bytes expected,
/// 1200 found)". Throws IoError (cannot read) or FormatError (content).
BrdfTable read_merl(const std::filesystem::path& path);

/// Writes a MERL table atomically (a temporary file in the same folder, fsync, rename). Cells below
/// the horizon and cells without data are written as -1 in all three planes; the others as BRDF /
/// scale. A table read by read_merl and written again gives the same bytes for files this writer
/// made (and 1-ulp differences at most for others). Throws NumericalError if check_table fails,
/// IoError naming the path if the file cannot be written (the temporary file is then removed).
void write_merl(const std::filesystem::path& path, const BrdfTable& table);

} // namespace brdf::formats
