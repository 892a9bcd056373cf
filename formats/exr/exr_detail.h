#pragma once
// OpenEXR plumbing shared by the RGB (exr.cpp) and spectral (spectral_exr.cpp) table readers and
// writers; internal to brdf_formats (it includes OpenEXR, which no public header does).

#include <formats/file_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <Iex.h>
#include <ImfIO.h>
#include <openexr.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace brdf::formats::detail {

// OpenEXR's input stream over our RAII file. It throws only Iex exceptions, which OpenEXR expects (its
// destructors catch those and nothing else); the brdf::IoError behind a failure is kept so that the
// caller can rethrow it as what it is.
class TableIStream final : public Imf::IStream {
  public:
    explicit TableIStream(const detail::InputFile& file)
        : Imf::IStream(file.path().c_str()), m_file(file) {}

    bool read(char c[], int n) override {
        if (n < 0) throw Iex::InputExc("negative read size");
        std::size_t got = 0;
        try {
            got = m_file.read_at(m_pos, c, static_cast<std::size_t>(n));
        } catch (const IoError& e) {
            m_io_error = e.what();
            throw Iex::IoExc(e.what());
        }
        m_pos += got;
        if (got < static_cast<std::size_t>(n))
            throw Iex::InputExc(cat("unexpected end of file (", n, " bytes wanted at offset ",
                                    m_pos - got, ", ", got, " there)"));
        return m_pos < m_file.size();
    }
    std::uint64_t tellg() override { return m_pos; }
    void seekg(std::uint64_t pos) override { m_pos = pos; }
    void clear() override {}

    const std::optional<std::string>& io_error() const { return m_io_error; }

  private:
    const detail::InputFile& m_file;
    std::uint64_t m_pos = 0;
    std::optional<std::string> m_io_error;
};

// The header is validated with OpenEXR's Core (C) API before the C++ API opens the file: Core
// checks every attribute size against the file size and allocates only what the header really
// holds, while the C++ API of OpenEXR 3.1 allocates whatever size an attribute claims (a forged
// size makes it ask for 2 GiB). Only a header that passed these checks reaches the C++ API, which
// then reads the pixels (converting any pixel type to float).
class CoreHeader {
  public:
    explicit CoreHeader(const detail::InputFile& file) : m_file(file) {
        exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
        init.user_data = this;
        init.read_fn = &CoreHeader::read;
        init.size_fn = &CoreHeader::size;
        init.error_handler_fn = &CoreHeader::error;
        const exr_result_t rv = exr_start_read(&m_context.handle, file.path().c_str(), &init);
        // Core skips some broken attributes and carries on (an impossible size, for one); any error
        // it reports makes the header unacceptable here.
        if (rv != EXR_ERR_SUCCESS || !m_message.empty()) {
            if (m_io_error) throw IoError(*m_io_error);
            throw FormatError(cat(
                display(file.path()),
                ": OpenEXR: ", m_message.empty() ? exr_get_default_error_message(rv) : m_message));
        }
    }
    CoreHeader(const CoreHeader&) = delete;
    CoreHeader& operator=(const CoreHeader&) = delete;

    exr_const_context_t context() const { return m_context.handle; }

    // A string attribute of part 0: absent -> nullopt; present but not a string -> FormatError.
    std::optional<std::string> string_attribute(const char* name) const {
        const exr_attribute_t* attribute = nullptr;
        if (exr_get_attribute_by_name(m_context.handle, 0, name, &attribute) != EXR_ERR_SUCCESS ||
            !attribute)
            return std::nullopt;
        if (attribute->type != EXR_ATTR_STRING || !attribute->string)
            throw FormatError(cat(display(m_file.path()), ": attribute ", name, " has type ",
                                  attribute->type_name ? attribute->type_name : "?",
                                  " (expected string)"));
        const exr_attr_string_t& value = *attribute->string;
        return std::string(value.str ? value.str : "",
                           static_cast<std::size_t>(std::max(value.length, 0)));
    }

  private:
    static int64_t read(exr_const_context_t, void* self, void* buffer, uint64_t n, uint64_t offset,
                        exr_stream_error_func_ptr_t) {
        auto* header = static_cast<CoreHeader*>(self);
        try {
            return static_cast<int64_t>(header->m_file.read_at(offset, buffer, n));
        } catch (const IoError& e) {
            header->m_io_error = e.what();
            return -1;
        }
    }
    static int64_t size(exr_const_context_t, void* self) {
        return static_cast<int64_t>(static_cast<CoreHeader*>(self)->m_file.size());
    }
    static void error(exr_const_context_t context, exr_result_t, const char* message) {
        void* self = nullptr;
        if (exr_get_user_data(context, &self) == EXR_ERR_SUCCESS && self && message) {
            auto* header = static_cast<CoreHeader*>(self);
            if (header->m_message.empty()) header->m_message = message; // the first is the cause
        }
    }

    // A member with its own destructor, so that the context is finished also when the constructor
    // throws (a successful exr_start_read can still have reported errors).
    struct Context {
        exr_context_t handle = nullptr;
        Context() = default;
        Context(const Context&) = delete;
        Context& operator=(const Context&) = delete;
        ~Context() {
            if (handle) exr_finish(&handle);
        }
    };

    const detail::InputFile& m_file;
    std::string m_message;
    std::optional<std::string> m_io_error;
    Context m_context; // last: finished first, while the members its callbacks use still exist
};

/// Reads the first 4 bytes: FormatError "PATH: empty file" / "PATH: not an OpenEXR file".
void check_exr_magic(const InputFile& file);

/// The header checks both table kinds share: one part, flat (not deep), brdf.layout present and
/// the MERL layout, brdf.units absent or "1/sr", the brdf.* attributes that are present strings,
/// and a data window of 180 x 8100. FormatError naming the path.
void check_table_header(const CoreHeader& header, const std::filesystem::path& path);

/// The part's channel names, in the file's (alphabetical) order.
std::vector<std::string> channel_names(const CoreHeader& header);

/// A channel to read and where its exr_width-wide float plane goes (sized by the caller).
struct PlaneTarget {
    std::string name;
    float* data = nullptr;
};
/// Reads the pixels of part 0 (whose header check_table_header passed) into the planes through the
/// C++ API; IoError or FormatError naming the path.
void read_planes(const InputFile& file, const std::vector<PlaneTarget>& planes);

/// The number of threads OpenEXR decompresses line blocks on: one per core, set once before the
/// first file is opened (the writers compress their blocks themselves: zip_writer.h).
int exr_threads();

} // namespace brdf::formats::detail
