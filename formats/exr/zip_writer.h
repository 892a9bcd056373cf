#pragma once
// Writing a ZIP-compressed scanline table through OpenEXR's Core (C) API, with the compression done
// here (internal to brdf_formats; exr.cpp and spectral_exr.cpp write through it).
//
// OpenEXR 3.1 (Debian 12) compresses ZIP blocks with zlib: 0.15-0.2 s of every table's 17.5 MB,
// most of a material's write. OpenEXR 3.2 moved to libdeflate for that reason; here the blocks are
// compressed by libdeflate on every core and handed to OpenEXR ready to write
// (exr_write_scanline_chunk), so OpenEXR still writes the header, the blocks and the offset table.
// What a ZIP block holds is OpenEXR's (the file format's "ZIP compression"): 16 scanlines in
// Xdr layout (per line, each channel's row in the header's channel order, little-endian), the bytes
// split into the even and the odd ones, each byte replaced by its difference to the one before plus
// 128, then zlib-compressed; a block that does not shrink is stored as it is.

#include <formats/exr/exr.h>

#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace brdf::formats::detail {

/// One float channel of a table image: its name and its exr_width x exr_height plane, of floats or
/// of doubles (rounded to float as written). A value below 0 (no data) and every cell below the
/// horizon are written as 0.
struct PlaneSource {
    std::string name;
    const float* data = nullptr;
    const double* doubles = nullptr; ///< when data is null
};

/// Called on the cells [first, end) of each block (pixel (x, y) is cell y * exr_width + x) just
/// before the block is compressed, on the thread that compresses it: a writer's check of its
/// source, which throws to stop the write (no file is left).
using BlockCheck = std::function<void(std::size_t first, std::size_t end)>;

/// Writes the planes as one ZIP scanline part of exr_width x exr_height FLOAT channels, with the
/// string attributes and, when given, the chromaticities, atomically (AtomicFile). IoError naming
/// the path when it cannot be written; what `check` throws.
void write_zip_table(const std::filesystem::path& path, const std::vector<PlaneSource>& planes,
                     const std::vector<std::pair<std::string, std::string>>& attributes,
                     const std::optional<Chromaticities>& chromaticities, const BlockCheck& check = {});

} // namespace brdf::formats::detail
