#pragma once
// Byte-level helpers for hand-made (mostly malformed) tensor and RGL files.

#include <formats/rgl/rgl_bsdf.h>

#include <cstdint>
#include <string>
#include <vector>

namespace brdf::test {

/// Little-endian encodings.
std::string le16(std::uint16_t v);
std::string le32(std::uint32_t v);
std::string le64(std::uint64_t v);
std::uint64_t load_u64_le(const std::string& bytes, std::size_t offset);

/// One field header of a tensor file.
struct RawField {
    std::string name;
    std::uint8_t dtype = 10; ///< float32
    std::uint64_t offset = 0;
    std::vector<std::uint64_t> shape;
};
/// The preamble (magic, version, count) and the field headers, as bytes.
std::string raw_tensor_header(const std::vector<RawField>& fields, std::uint8_t major = 1,
                              std::uint8_t minor = 0);

/// A small valid RGL BSDF (RGB unless `spectral`): 2 incidences, a 4 x 4 sample grid, 3 x 3 ndf,
/// sigma and vndf grids, positive values; passes rgl_bsdf_fault.
formats::RglBsdf small_rgl_bsdf(bool spectral = false);

} // namespace brdf::test
