#include <formats/rgl/tensor_file.h>

#include <formats/file_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>
#include <set>
#include <string_view>

namespace brdf::formats {

namespace {

using detail::display;

// Smallest field header: name length, rank, dtype, offset (an empty name of rank 0).
constexpr std::uint64_t min_field_header = 2 + 2 + 1 + 8;
constexpr std::uint64_t data_alignment = 8;

std::string shape_text(const std::vector<std::uint64_t>& shape) {
    std::string out = "[";
    for (std::size_t d = 0; d < shape.size(); ++d) out += cat(d ? ", " : "", shape[d]);
    return out + "]";
}

// Reads the header sequentially from the file, checking each read against the file's size first,
// so that a header that claims more than the file holds is refused before anything is allocated.
class HeaderCursor {
  public:
    explicit HeaderCursor(const detail::InputFile& file) : m_file(file) {}

    std::uint64_t position() const { return m_position; }
    std::uint64_t remaining() const { return m_file.size() - m_position; }

    /// Fails with "truncated in <where>" if fewer than n bytes are left.
    void require(std::uint64_t n, const std::string& where) const {
        if (n > remaining())
            throw FormatError(cat(display(m_file.path()), ": truncated in ", where, " (", n,
                                  " more bytes needed at byte ", m_position, ", the file has ",
                                  m_file.size(), ")"));
    }

    void read(void* out, std::size_t n, const std::string& where) {
        require(n, where);
        if (m_file.read_at(m_position, out, n) != n)
            throw FormatError(
                cat(display(m_file.path()), ": truncated while reading (the file changed)"));
        m_position += n;
    }

    template <typename T> T read_le(const std::string& where) {
        unsigned char b[sizeof(T)];
        read(b, sizeof(T), where);
        std::uint64_t v = 0;
        for (std::size_t i = 0; i < sizeof(T); ++i) v |= std::uint64_t{b[i]} << (8 * i);
        return static_cast<T>(v);
    }

  private:
    const detail::InputFile& m_file;
    std::uint64_t m_position = 0;
};

void put_le(std::vector<unsigned char>& out, std::uint64_t value, std::size_t bytes) {
    for (std::size_t i = 0; i < bytes; ++i) out.push_back(static_cast<unsigned char>(value >> (8 * i)));
}

std::string field_label(std::size_t index, std::size_t count, const std::string& name) {
    return cat("field ", index + 1, " of ", count, name.empty() ? "" : cat(" ('", name, "')"));
}

} // namespace

std::size_t dtype_size(TensorDType dtype) {
    switch (dtype) {
    case TensorDType::UInt8:
    case TensorDType::Int8:
        return 1;
    case TensorDType::UInt16:
    case TensorDType::Int16:
    case TensorDType::Float16:
        return 2;
    case TensorDType::UInt32:
    case TensorDType::Int32:
    case TensorDType::Float32:
        return 4;
    case TensorDType::UInt64:
    case TensorDType::Int64:
    case TensorDType::Float64:
        return 8;
    }
    return 0;
}

const char* to_string(TensorDType dtype) {
    switch (dtype) {
    case TensorDType::UInt8: return "uint8";
    case TensorDType::Int8: return "int8";
    case TensorDType::UInt16: return "uint16";
    case TensorDType::Int16: return "int16";
    case TensorDType::UInt32: return "uint32";
    case TensorDType::Int32: return "int32";
    case TensorDType::UInt64: return "uint64";
    case TensorDType::Int64: return "int64";
    case TensorDType::Float16: return "float16";
    case TensorDType::Float32: return "float32";
    case TensorDType::Float64: return "float64";
    }
    return "invalid";
}

bool has_tensor_file_magic(std::string_view first_bytes) {
    return first_bytes.size() >= tensor_file_magic.size() &&
           first_bytes.substr(0, tensor_file_magic.size()) == tensor_file_magic;
}

std::uint64_t TensorField::element_count() const {
    std::uint64_t n = 1;
    for (std::uint64_t d : shape) n *= d;
    return n;
}

TensorField TensorField::float32(std::string name, std::vector<std::uint64_t> shape,
                                 const std::vector<float>& values) {
    TensorField field;
    field.name = std::move(name);
    field.dtype = TensorDType::Float32;
    field.shape = std::move(shape);
    if (field.element_count() != values.size())
        throw InputError(cat("tensor field '", field.name, "': shape ", shape_text(field.shape),
                             " does not hold ", values.size(), " values"));
    field.bytes.resize(values.size() * 4);
    for (std::size_t i = 0; i < values.size(); ++i) {
        const auto bits = std::bit_cast<std::uint32_t>(values[i]);
        for (int b = 0; b < 4; ++b) field.bytes[4 * i + b] = static_cast<unsigned char>(bits >> (8 * b));
    }
    return field;
}

TensorField TensorField::uint8(std::string name, std::vector<std::uint64_t> shape,
                               const std::vector<unsigned char>& values) {
    TensorField field;
    field.name = std::move(name);
    field.dtype = TensorDType::UInt8;
    field.shape = std::move(shape);
    if (field.element_count() != values.size())
        throw InputError(cat("tensor field '", field.name, "': shape ", shape_text(field.shape),
                             " does not hold ", values.size(), " values"));
    field.bytes = values;
    return field;
}

std::vector<float> TensorField::to_float32() const {
    if (dtype != TensorDType::Float32)
        throw FormatError(cat("tensor field '", name, "': dtype ", to_string(dtype),
                              " (float32 expected)"));
    std::vector<float> out(bytes.size() / 4);
    for (std::size_t i = 0; i < out.size(); ++i) {
        std::uint32_t bits = 0;
        for (int b = 0; b < 4; ++b) bits |= std::uint32_t{bytes[4 * i + b]} << (8 * b);
        out[i] = std::bit_cast<float>(bits);
    }
    return out;
}

const TensorField* TensorFile::find(std::string_view name) const {
    for (const TensorField& f : fields)
        if (f.name == name) return &f;
    return nullptr;
}

TensorFile read_tensor_file(const std::filesystem::path& path, TensorFileLimits limits) {
    const detail::InputFile file(path);
    const std::uint64_t size = file.size();
    const std::string where = display(path);
    if (size == 0) throw FormatError(cat(where, ": empty file (not a tensor file)"));
    if (size < tensor_file_preamble_size) {
        // A short file that does not even start like a tensor file is named as such.
        char start[tensor_file_preamble_size] = {};
        const std::size_t got = file.read_at(0, start, static_cast<std::size_t>(size));
        const std::string_view head(start, got);
        if (head != tensor_file_magic.substr(0, std::min(got, tensor_file_magic.size())))
            throw FormatError(cat(where, ": not a tensor file (no \"tensor_file\" magic)"));
        throw FormatError(cat(where, ": truncated (the tensor file preamble needs ",
                              tensor_file_preamble_size, " bytes, ", size, " found)"));
    }

    HeaderCursor in(file);
    char magic[12];
    in.read(magic, sizeof magic, "the preamble");
    if (std::string_view(magic, sizeof magic) != tensor_file_magic)
        throw FormatError(cat(where, ": not a tensor file (no \"tensor_file\" magic)"));
    // Both bytes of the version are checked (Mitsuba 3.9's reader tests the minor byte twice and
    // never the major one).
    const auto major = in.read_le<std::uint8_t>("the preamble");
    const auto minor = in.read_le<std::uint8_t>("the preamble");
    if (major != 1 || minor != 0)
        throw FormatError(cat(where, ": unsupported tensor file version ", int{major}, ".",
                              int{minor}, " (1.0 expected)"));
    const auto count = in.read_le<std::uint32_t>("the preamble");
    if (std::uint64_t{count} * min_field_header > in.remaining())
        throw FormatError(cat(where, ": truncated: ", count, " fields announced, but the ",
                              in.remaining(), " bytes after the preamble hold at most ",
                              in.remaining() / min_field_header, " field headers"));

    struct Pending {
        TensorField field;
        std::uint64_t offset = 0;
        std::uint64_t byte_count = 0;
    };
    std::vector<Pending> pending;
    pending.reserve(count);
    std::set<std::string, std::less<>> names;
    for (std::uint32_t i = 0; i < count; ++i) {
        Pending p;
        const std::string label = field_label(i, count, "");
        const std::string header_of = cat("the header of ", label);
        const auto name_length = in.read_le<std::uint16_t>(header_of);
        p.field.name.resize(name_length);
        in.read(p.field.name.data(), name_length, header_of);
        const std::string named = field_label(i, count, p.field.name);
        const std::string named_header = cat("the header of ", named);
        const auto rank = in.read_le<std::uint16_t>(named_header);
        const auto dtype = in.read_le<std::uint8_t>(named_header);
        p.offset = in.read_le<std::uint64_t>(named_header);
        in.require(std::uint64_t{rank} * 8, named_header);
        p.field.shape.resize(rank);
        for (auto& extent : p.field.shape) extent = in.read_le<std::uint64_t>(named_header);

        const std::string field_where = cat(where, ": field '", p.field.name, "'");
        if (dtype < 1 || dtype > 11)
            throw FormatError(cat(field_where, ": unknown dtype ", int{dtype},
                                  " (1..11: uint8 .. float64)"));
        p.field.dtype = static_cast<TensorDType>(dtype);
        if (!names.insert(p.field.name).second)
            throw FormatError(cat(field_where, ": the name appears twice"));

        // Element and byte counts, refusing any product that overflows or exceeds the file.
        std::uint64_t elements = 1;
        bool too_large = false;
        for (std::uint64_t extent : p.field.shape) {
            if (extent != 0 && elements > std::numeric_limits<std::uint64_t>::max() / extent)
                too_large = true;
            else
                elements *= extent;
        }
        const std::uint64_t element_bytes = dtype_size(p.field.dtype);
        if (too_large || elements > size / element_bytes)
            throw FormatError(cat(field_where, ": shape ", shape_text(p.field.shape), " of ",
                                  to_string(p.field.dtype),
                                  " needs more bytes than the file holds (", size, ")"));
        p.byte_count = elements * element_bytes;
        if (p.offset > size || p.byte_count > size - p.offset)
            throw FormatError(cat(field_where, ": data [", p.offset, ", ",
                                  p.offset > size ? "..." : cat(p.offset + p.byte_count),
                                  ") lies past the end of the file (", size, " bytes)"));
        pending.push_back(std::move(p));
    }
    const std::uint64_t header_end = in.position();

    // Data must follow the header and not overlap: then the fields together hold at most the
    // file's size, which bounds what is allocated below.
    std::vector<const Pending*> by_offset;
    for (const Pending& p : pending) {
        if (p.byte_count == 0) continue;
        if (p.offset < header_end)
            throw FormatError(cat(where, ": field '", p.field.name, "': data at offset ", p.offset,
                                  " overlaps the header (which ends at byte ", header_end, ")"));
        by_offset.push_back(&p);
    }
    std::sort(by_offset.begin(), by_offset.end(),
              [](const Pending* a, const Pending* b) { return a->offset < b->offset; });
    std::uint64_t total = 0;
    for (std::size_t k = 0; k < by_offset.size(); ++k) {
        total += by_offset[k]->byte_count;
        if (k > 0) {
            const Pending& a = *by_offset[k - 1];
            const Pending& b = *by_offset[k];
            if (a.offset + a.byte_count > b.offset)
                throw FormatError(cat(where, ": fields '", a.field.name, "' and '", b.field.name,
                                      "' overlap (data [", a.offset, ", ", a.offset + a.byte_count,
                                      ") and [", b.offset, ", ", b.offset + b.byte_count, "))"));
        }
    }
    if (total > limits.max_data_bytes)
        throw LimitError(cat(where, ": the fields hold ", total, " bytes of data, above the limit of ",
                             limits.max_data_bytes, " bytes"));

    TensorFile out;
    out.fields.reserve(pending.size());
    for (Pending& p : pending) {
        p.field.bytes.resize(static_cast<std::size_t>(p.byte_count));
        if (file.read_at(p.offset, p.field.bytes.data(), p.field.bytes.size()) !=
            p.field.bytes.size())
            throw FormatError(cat(where, ": truncated while reading (the file changed)"));
        out.fields.push_back(std::move(p.field));
    }
    return out;
}

void write_tensor_file(const std::filesystem::path& path, const TensorFile& file) {
    const std::string where = display(path);
    if (file.fields.size() > std::numeric_limits<std::uint32_t>::max())
        throw InputError(cat(where, ": too many tensor fields (", file.fields.size(), ")"));
    std::set<std::string, std::less<>> names;
    for (const TensorField& f : file.fields) {
        const std::string field_where = cat(where, ": tensor field '", f.name, "'");
        if (f.name.empty()) throw InputError(cat(where, ": a tensor field has an empty name"));
        if (f.name.size() > 0xffff)
            throw InputError(cat(field_where, ": name longer than 65535 bytes"));
        if (!names.insert(f.name).second) throw InputError(cat(field_where, ": name used twice"));
        if (f.shape.size() > 0xffff) throw InputError(cat(field_where, ": rank above 65535"));
        if (dtype_size(f.dtype) == 0) throw InputError(cat(field_where, ": invalid dtype"));
        std::uint64_t elements = 1;
        for (std::uint64_t extent : f.shape) {
            if (extent != 0 && elements > std::numeric_limits<std::uint64_t>::max() / extent)
                throw InputError(cat(field_where, ": shape ", shape_text(f.shape), " overflows"));
            elements *= extent;
        }
        if (elements > std::numeric_limits<std::uint64_t>::max() / dtype_size(f.dtype) ||
            elements * dtype_size(f.dtype) != f.bytes.size())
            throw InputError(cat(field_where, ": ", f.bytes.size(), " bytes do not match shape ",
                                 shape_text(f.shape), " of ", to_string(f.dtype)));
    }

    std::vector<unsigned char> header(tensor_file_magic.begin(), tensor_file_magic.end());
    header.push_back(1); // version 1.0
    header.push_back(0);
    put_le(header, file.fields.size(), 4);
    std::vector<std::size_t> offset_slots;
    for (const TensorField& f : file.fields) {
        put_le(header, f.name.size(), 2);
        header.insert(header.end(), f.name.begin(), f.name.end());
        put_le(header, f.shape.size(), 2);
        header.push_back(static_cast<unsigned char>(f.dtype));
        offset_slots.push_back(header.size());
        put_le(header, 0, 8); // patched below
        for (std::uint64_t extent : f.shape) put_le(header, extent, 8);
    }
    std::uint64_t position = header.size();
    std::vector<std::uint64_t> offsets;
    for (std::size_t k = 0; k < file.fields.size(); ++k) {
        position = (position + data_alignment - 1) / data_alignment * data_alignment;
        offsets.push_back(position);
        for (int b = 0; b < 8; ++b)
            header[offset_slots[k] + b] = static_cast<unsigned char>(position >> (8 * b));
        position += file.fields[k].bytes.size();
    }

    detail::AtomicFile out(path);
    out.write_at(0, header.data(), header.size());
    std::uint64_t written = header.size();
    const unsigned char zeros[data_alignment] = {};
    for (std::size_t k = 0; k < file.fields.size(); ++k) {
        // Explicit zero padding, so the file's bytes do not depend on the file system.
        if (offsets[k] > written)
            out.write_at(written, zeros, static_cast<std::size_t>(offsets[k] - written));
        const auto& bytes = file.fields[k].bytes;
        if (!bytes.empty()) out.write_at(offsets[k], bytes.data(), bytes.size());
        written = offsets[k] + bytes.size();
    }
    out.commit();
}

} // namespace brdf::formats
