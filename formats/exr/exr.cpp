#include <formats/exr/exr.h>

#include <formats/file_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <Iex.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputPart.h>
#include <ImfMultiPartInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <ImfVersion.h>
#include <openexr.h>

#include <cmath>
#include <optional>
#include <string_view>
#include <vector>

namespace brdf::formats {

namespace {

using detail::display;

constexpr const char* channel_names[3] = {"R", "G", "B"};

// OpenEXR streams over our RAII files. They throw only Iex exceptions, which OpenEXR expects (its
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

class TableOStream final : public Imf::OStream {
  public:
    explicit TableOStream(detail::AtomicFile& file)
        : Imf::OStream(file.target().c_str()), m_file(file) {}

    void write(const char c[], int n) override {
        if (n < 0) throw Iex::IoExc("negative write size");
        try {
            m_file.write_at(m_pos, c, static_cast<std::size_t>(n));
        } catch (const IoError& e) {
            if (!m_io_error) m_io_error = e.what();
            throw Iex::IoExc(e.what());
        }
        m_pos += static_cast<std::uint64_t>(n);
    }
    std::uint64_t tellp() override { return m_pos; }
    void seekp(std::uint64_t pos) override { m_pos = pos; }

    const std::optional<std::string>& io_error() const { return m_io_error; }

  private:
    detail::AtomicFile& m_file;
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

void check_header(const CoreHeader& header, const std::filesystem::path& path) {
    int parts = 0;
    exr_get_count(header.context(), &parts);
    if (parts != 1)
        throw FormatError(cat(display(path), ": ", parts, " parts (a BRDF table has one)"));
    exr_storage_t storage = EXR_STORAGE_SCANLINE;
    exr_get_storage(header.context(), 0, &storage);
    if (storage == EXR_STORAGE_DEEP_SCANLINE || storage == EXR_STORAGE_DEEP_TILED)
        throw FormatError(cat(display(path), ": deep image (a BRDF table is a flat RGB image)"));

    const std::optional<std::string> layout = header.string_attribute("brdf.layout");
    if (!layout)
        throw FormatError(
            cat(display(path), ": missing attribute brdf.layout (expected \"", exr_layout, "\")"));
    if (*layout != exr_layout)
        throw FormatError(cat(display(path), ": attribute brdf.layout is \"", *layout,
                              "\" (expected \"", exr_layout, "\")"));
    const std::optional<std::string> units = header.string_attribute("brdf.units");
    if (units && *units != exr_units)
        throw FormatError(cat(display(path), ": attribute brdf.units is \"", *units,
                              "\" (expected \"", exr_units, "\")"));
    for (const char* name : {"brdf.spec", "brdf.generator", "brdf.colorspace"})
        header.string_attribute(name); // type check

    exr_attr_box2i_t dw{};
    exr_get_data_window(header.context(), 0, &dw);
    // In 64 bits: a hostile window can span more than INT_MAX.
    const std::int64_t width = std::int64_t{dw.max.x} - dw.min.x + 1;
    const std::int64_t height = std::int64_t{dw.max.y} - dw.min.y + 1;
    if (width != exr_width || height != exr_height)
        throw FormatError(cat(display(path), ": wrong size ", width, " x ", height,
                              " (a BRDF table is ", exr_width, " x ", exr_height, ")"));

    const exr_attr_chlist_t* channels = nullptr;
    exr_get_channels(header.context(), 0, &channels);
    std::string found;
    const auto find = [&](const char* name) -> const exr_attr_chlist_entry_t* {
        for (int i = 0; channels && i < channels->num_channels; ++i)
            if (channels->entries[i].name.str &&
                std::string_view(channels->entries[i].name.str) == name)
                return &channels->entries[i];
        return nullptr;
    };
    for (int i = 0; channels && i < channels->num_channels; ++i)
        found += cat(found.empty() ? "" : ", ",
                     channels->entries[i].name.str ? channels->entries[i].name.str : "");
    for (const char* name : channel_names) {
        const exr_attr_chlist_entry_t* channel = find(name);
        if (!channel)
            throw FormatError(cat(display(path), ": missing channel ", name, " (found ",
                                  found.empty() ? "none" : found, ")"));
        if (channel->x_sampling != 1 || channel->y_sampling != 1)
            throw FormatError(cat(display(path), ": channel ", name, " is subsampled (",
                                  channel->x_sampling, " x ", channel->y_sampling, ")"));
    }
}

} // namespace

BrdfTable read_exr(const std::filesystem::path& path) {
    const detail::InputFile file(path);
    if (file.size() == 0) throw FormatError(cat(display(path), ": empty file"));
    {
        // Magic number first: "not an OpenEXR file" says more than a parser's complaint.
        char magic[4] = {};
        if (file.read_at(0, magic, 4) != 4 || !Imf::isImfMagic(magic))
            throw FormatError(cat(display(path), ": not an OpenEXR file"));
    }
    std::optional<std::string> spec, generator, colorspace;
    {
        const CoreHeader header(file);
        check_header(header, path);
        spec = header.string_attribute("brdf.spec");
        generator = header.string_attribute("brdf.generator");
        colorspace = header.string_attribute("brdf.colorspace");
    }

    TableIStream stream(file);
    std::array<std::vector<float>, 3> planes;
    try {
        Imf::MultiPartInputFile input(stream);
        Imf::InputPart part(input, 0);
        const Imath::Box2i dw = part.header().dataWindow();
        // The header is now known to describe exactly one table: allocation is bounded.
        Imf::FrameBuffer frame;
        for (int c = 0; c < 3; ++c) {
            planes[c].assign(cells, 0.0f);
            frame.insert(channel_names[c],
                         Imf::Slice::Make(Imf::FLOAT, planes[c].data(), dw, sizeof(float),
                                          sizeof(float) * exr_width));
        }
        part.setFrameBuffer(frame);
        part.readPixels(dw.min.y, dw.max.y);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        if (stream.io_error()) throw IoError(*stream.io_error());
        throw FormatError(cat(display(path), ": OpenEXR: ", e.what()));
    }

    BrdfTable table;
    table.spec = spec.value_or("");
    table.generator = generator.value_or("");
    table.colorspace = colorspace.value_or(default_colorspace);
    for (std::size_t cell = 0; cell < cells; ++cell) {
        if (cell_below_horizon(cell)) continue; // BrdfTable() marked it no data
        for (int c = 0; c < 3; ++c) {
            const float v = planes[c][cell];
            if (!std::isfinite(v))
                throw FormatError(cat(display(path), ": non-finite value ", detail::value_text(v),
                                      " in channel ", channel_names[c], " at ",
                                      describe_cell(cell)));
            if (v < 0.0f)
                throw FormatError(cat(display(path), ": negative value ", detail::value_text(v),
                                      " in channel ", channel_names[c], " at ",
                                      describe_cell(cell)));
            table.channels[c][cell] = v;
        }
    }
    return table;
}

void write_exr(const std::filesystem::path& path, const BrdfTable& table) {
    check_table(table, display(path));
    std::array<std::vector<float>, 3> planes;
    for (auto& plane : planes) plane.assign(cells, 0.0f);
    std::size_t no_data_above_horizon = 0;
    for (std::size_t cell = 0; cell < cells; ++cell) {
        if (cell_below_horizon(cell)) continue;
        if (!table.has_data(cell)) {
            ++no_data_above_horizon;
            continue;
        }
        for (int c = 0; c < 3; ++c) planes[c][cell] = static_cast<float>(table.channels[c][cell]);
    }
    if (no_data_above_horizon > 0)
        log::warn(display(path), ": ", no_data_above_horizon,
                  " cells above the horizon hold no data; OpenEXR tables store them as 0");

    Imf::Header header(exr_width, exr_height);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const char* name : channel_names) header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    header.insert("brdf.layout", Imf::StringAttribute(exr_layout));
    header.insert("brdf.units", Imf::StringAttribute(exr_units));
    header.insert("brdf.colorspace", Imf::StringAttribute(table.colorspace));
    header.insert("brdf.spec", Imf::StringAttribute(table.spec));
    header.insert("brdf.generator", Imf::StringAttribute(table.generator));

    detail::AtomicFile out(path);
    TableOStream stream(out);
    try {
        // The file's offset table is written when `file` is destroyed: end its scope before commit.
        Imf::OutputFile file(stream, header);
        Imf::FrameBuffer frame;
        for (int c = 0; c < 3; ++c)
            frame.insert(channel_names[c],
                         Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(planes[c].data()),
                                    sizeof(float), sizeof(float) * exr_width));
        file.setFrameBuffer(frame);
        file.writePixels(exr_height);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        if (stream.io_error()) throw IoError(*stream.io_error());
        throw IoError(cat(display(path), ": cannot write: OpenEXR: ", e.what()));
    }
    // OpenEXR's destructor swallows errors while it writes the offset table; the stream did not.
    if (stream.io_error()) throw IoError(*stream.io_error());
    out.commit();
}

} // namespace brdf::formats
