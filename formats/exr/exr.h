#pragma once
// OpenEXR BRDF tables: the cells of the MERL layout (formats/halfdiff.h) as an image.
//
// One scanline part, ZIP compression, 32-bit float channels R, G, B; width 180 (phi_d bins), height
// 8100 (row = 90 * theta_h index + theta_d index), so pixel (x, y) is cell y * 180 + x: the image
// is the MERL plane in the same order. Values are BRDF in 1/sr; cells below the horizon (and cells
// without data) are 0. String attributes: brdf.layout = "merl-halfdiff-90x90x180", brdf.units =
// "1/sr", brdf.colorspace, brdf.spec (the material spec JSON), brdf.generator; and OpenEXR's
// standard chromaticities attribute for the colour space ("rec709", "acescg", "rec2020").

#include <formats/table.h>

#include <array>
#include <filesystem>
#include <optional>
#include <string_view>

namespace brdf::formats {

inline constexpr int exr_width = phi_d_bins;                   // 180
inline constexpr int exr_height = theta_h_bins * theta_d_bins; // 8100
inline constexpr const char* exr_layout = "merl-halfdiff-90x90x180";
inline constexpr const char* exr_units = "1/sr";

/// CIE xy of the red, green and blue primaries and the white point: red_x, red_y, green_x, ...,
/// white_y, as OpenEXR's chromaticities attribute holds them.
using Chromaticities = std::array<float, 8>;

/// The chromaticities of a BrdfTable::colorspace (canonical_colorspace): Rec.709 / sRGB (ITU-R
/// BT.709: R 0.64 0.33, G 0.30 0.60, B 0.15 0.06, D65 0.3127 0.3290), ACEScg (ACES AP1, SMPTE ST
/// 2065-1 / Academy S-2014-004: R 0.713 0.293, G 0.165 0.830, B 0.128 0.044, ACES white 0.32168
/// 0.33767), Rec.2020 (ITU-R BT.2020: R 0.708 0.292, G 0.170 0.797, B 0.131 0.046, D65). Empty for
/// an unknown name.
std::optional<Chromaticities> colorspace_chromaticities(std::string_view colorspace);

/// Reads an OpenEXR table. Refuses (FormatError naming the path and the fault): a file that is not
/// OpenEXR, deep data, more than one part, a data window other than 180 x 8100, a missing R, G or B
/// channel, a missing or different brdf.layout, a brdf.units other than "1/sr", a non-string brdf.*
/// attribute, and a NaN, infinite or negative value in a cell above the horizon (naming channel and
/// cell). Channels of any pixel type are converted to float by OpenEXR. Cells below the horizon are
/// restored as no data from the geometry, whatever the file holds there. brdf.spec and
/// brdf.generator may be absent (then empty). brdf.colorspace holding the legacy string reads as
/// "rec709"; without brdf.colorspace, chromaticities matching one of ours (to 1e-4) name it, else
/// the default.
/// OpenEXR's own errors are rethrown as FormatError with the path. Missing or unreadable files,
/// folders: IoError.
BrdfTable read_exr(const std::filesystem::path& path);

/// Writes an OpenEXR table atomically (temporary file in the same folder, fsync, rename). Values
/// are rounded to float32; cells below the horizon and cells without data are written as 0 (a cell
/// above the horizon without data therefore reads back as 0; it is logged as a warning). Throws
/// NumericalError if check_table fails, IoError naming the path if the file cannot be written.
/// brdf.colorspace is the table's (the legacy string as "rec709"); the chromaticities attribute is
/// written for a known colour space, and a warning is logged for an unknown one.
void write_exr(const std::filesystem::path& path, const BrdfTable& table);

} // namespace brdf::formats
