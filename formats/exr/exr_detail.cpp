#include <formats/exr/exr_detail.h>

#include <formats/exr/exr.h>

#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputPart.h>
#include <ImfMultiPartInputFile.h>
#include <ImfThreading.h>
#include <ImfVersion.h>

#include <algorithm>
#include <thread>

#include <string_view>

namespace brdf::formats::detail {

void check_exr_magic(const InputFile& file) {
    if (file.size() == 0) throw FormatError(cat(display(file.path()), ": empty file"));
    // Magic number first: "not an OpenEXR file" says more than a parser's complaint.
    char magic[4] = {};
    if (file.read_at(0, magic, 4) != 4 || !Imf::isImfMagic(magic))
        throw FormatError(cat(display(file.path()), ": not an OpenEXR file"));
}

void check_table_header(const CoreHeader& header, const std::filesystem::path& path) {
    int parts = 0;
    exr_get_count(header.context(), &parts);
    if (parts != 1)
        throw FormatError(cat(display(path), ": ", parts, " parts (a BRDF table has one)"));
    exr_storage_t storage = EXR_STORAGE_SCANLINE;
    exr_get_storage(header.context(), 0, &storage);
    if (storage == EXR_STORAGE_DEEP_SCANLINE || storage == EXR_STORAGE_DEEP_TILED)
        throw FormatError(cat(display(path), ": deep image (a BRDF table is a flat image)"));

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
}

std::vector<std::string> channel_names(const CoreHeader& header) {
    const exr_attr_chlist_t* channels = nullptr;
    exr_get_channels(header.context(), 0, &channels);
    std::vector<std::string> names;
    for (int i = 0; channels && i < channels->num_channels; ++i)
        names.emplace_back(channels->entries[i].name.str ? channels->entries[i].name.str : "");
    return names;
}

void read_planes(const InputFile& file, const std::vector<PlaneTarget>& planes) {
    TableIStream stream(file);
    try {
        Imf::MultiPartInputFile input(stream, exr_threads());
        Imf::InputPart part(input, 0);
        const Imath::Box2i dw = part.header().dataWindow();
        Imf::FrameBuffer frame;
        for (const PlaneTarget& p : planes)
            frame.insert(p.name, Imf::Slice::Make(Imf::FLOAT, p.data, dw, sizeof(float), sizeof(float) * exr_width));
        part.setFrameBuffer(frame);
        part.readPixels(dw.min.y, dw.max.y);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        if (stream.io_error()) throw IoError(*stream.io_error());
        throw FormatError(cat(display(file.path()), ": OpenEXR: ", e.what()));
    }
}

int exr_threads() {
    static const int threads = [] {
        const int n = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
        Imf::setGlobalThreadCount(n);
        return n;
    }();
    return threads;
}

} // namespace brdf::formats::detail
