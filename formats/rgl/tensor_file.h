#pragma once
// The `tensor_file` container of Mitsuba 3 (include/mitsuba/core/tensor.h, src/core/tensor.cpp,
// src/python/python/tensor_io.py) that the RGL material database, Mitsuba's `measured` BSDF and
// pbrt-v4's `measured` BxDF read. All integers are little-endian:
//
//   12 bytes  magic "tensor_file\0"
//    2 bytes  version: major 1, minor 0 (uint8 each)
//    4 bytes  field count (uint32)
//   per field, in file order:
//     uint16 name length, the name (UTF-8, no terminator), uint16 rank, uint8 dtype,
//     uint64 offset of the data from the start of the file, rank x uint64 shape
//   then each field's data, row-major (the last index varies fastest).
//
// dtype codes are those of Mitsuba's Struct::Type (TensorDType below). Our writer places each
// field's data at an 8-byte aligned offset after the header, in field order (as tensor_io.write
// does); the reader accepts any layout whose data lie inside the file, after the header, and do not
// overlap.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace brdf::formats {

/// Element types, numbered as in the file (Mitsuba's Struct::Type; 0 is invalid).
enum class TensorDType : std::uint8_t {
    UInt8 = 1,
    Int8 = 2,
    UInt16 = 3,
    Int16 = 4,
    UInt32 = 5,
    Int32 = 6,
    UInt64 = 7,
    Int64 = 8,
    Float16 = 9,
    Float32 = 10,
    Float64 = 11,
};

/// Bytes per element.
std::size_t dtype_size(TensorDType dtype);
/// "uint8", "float32", ...
const char* to_string(TensorDType dtype);

/// The 12 magic bytes every tensor file starts with ("tensor_file" and a NUL).
inline constexpr std::string_view tensor_file_magic{"tensor_file\0", 12};
/// Bytes before the first field header: magic, version, field count.
inline constexpr std::size_t tensor_file_preamble_size = 12 + 2 + 4;

/// True when `first_bytes` (the start of a file, any length) begins with tensor_file_magic. For
/// format detection by content (formats/table_io); reads nothing else.
bool has_tensor_file_magic(std::string_view first_bytes);

/// One named array.
struct TensorField {
    std::string name;
    TensorDType dtype = TensorDType::Float32;
    std::vector<std::uint64_t> shape; ///< rank = shape.size(); rank 0 holds one element
    /// The elements, little-endian, row-major: element_count() * dtype_size(dtype) bytes.
    std::vector<unsigned char> bytes;

    /// Product of the shape (1 for rank 0). Callers check the product fits (the reader does).
    std::uint64_t element_count() const;

    /// A float32 field holding `values` (size must equal the product of `shape`).
    static TensorField float32(std::string name, std::vector<std::uint64_t> shape,
                               const std::vector<float>& values);
    /// A uint8 field holding `values` (size must equal the product of `shape`).
    static TensorField uint8(std::string name, std::vector<std::uint64_t> shape,
                             const std::vector<unsigned char>& values);
    /// The elements of a float32 field as floats (host order). Requires dtype Float32.
    std::vector<float> to_float32() const;
};

struct TensorFile {
    std::vector<TensorField> fields; ///< in file order; names are unique
    /// The field called `name`, or nullptr.
    const TensorField* find(std::string_view name) const;
};

/// What a reader is willing to allocate. A file is refused (LimitError) when its fields hold more
/// data than this, before anything is allocated.
struct TensorFileLimits {
    std::uint64_t max_data_bytes = std::uint64_t{4} << 30; ///< 4 GiB of field data in all
};

/// Reads a tensor file. Every count, size and offset is checked against the file before anything
/// is allocated or read, in file order: the preamble (18 bytes), the magic, the version (1.0), the
/// field count (each field header needs at least 13 bytes), each field header (name, rank, dtype
/// 1..11, offset, shape), the element count (no 64-bit overflow), the data range (inside the file,
/// after the header, not overlapping another field's), unique names, then the total against
/// `limits`. Every fault is one line starting with the path, e.g.
///   "paint.rgl.bsdf: field 'vndf': data [4096, 135168) lies past the end of the file (70000 bytes)".
/// Throws IoError (cannot read), FormatError (content) or LimitError.
TensorFile read_tensor_file(const std::filesystem::path& path, TensorFileLimits limits = {});

/// Writes `file` atomically (a temporary file in the same folder, fsync, rename): the header, then
/// each field's data at the next 8-byte aligned offset, in field order. Throws InputError naming
/// `path` and the field for a field the format cannot hold (empty or duplicate name, name above
/// 65535 bytes, rank above 65535, byte count that does not match shape and dtype), before any
/// file is created; IoError if the file cannot be written (the temporary file is then removed).
void write_tensor_file(const std::filesystem::path& path, const TensorFile& file);

} // namespace brdf::formats
