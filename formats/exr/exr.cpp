#include <formats/exr/exr.h>

#include <formats/exr/exr_detail.h>
#include <formats/file_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <formats/exr/zip_writer.h>

#include <atomic>
#include <cmath>
#include <optional>
#include <string_view>
#include <vector>

namespace brdf::formats {

namespace {

using detail::CoreHeader;
using detail::display;

constexpr const char* channel_names[3] = {"R", "G", "B"};

// The colour space whose chromaticities the file's standard attribute holds, if it is one of ours.
std::optional<std::string> colorspace_from_chromaticities(const CoreHeader& header) {
    const exr_attribute_t* a = nullptr;
    if (exr_get_attribute_by_name(header.context(), 0, "chromaticities", &a) != EXR_ERR_SUCCESS ||
        !a || a->type != EXR_ATTR_CHROMATICITIES || !a->chromaticities)
        return std::nullopt;
    const exr_attr_chromaticities_t& c = *a->chromaticities;
    const Chromaticities found{c.red_x, c.red_y, c.green_x, c.green_y,
                               c.blue_x, c.blue_y, c.white_x, c.white_y};
    for (const char* name : {"rec709", "acescg", "rec2020"}) {
        const Chromaticities ours = *colorspace_chromaticities(name);
        bool same = true;
        for (int k = 0; k < 8; ++k) same = same && std::abs(found[k] - ours[k]) <= 1e-4f;
        if (same) return name;
    }
    return std::nullopt;
}

void check_header(const CoreHeader& header, const std::filesystem::path& path) {
    detail::check_table_header(header, path);
    const exr_attr_chlist_t* channels = nullptr;
    exr_get_channels(header.context(), 0, &channels);
    std::string found;
    for (const std::string& name : detail::channel_names(header))
        found += cat(found.empty() ? "" : ", ", name);
    const auto find = [&](const char* name) -> const exr_attr_chlist_entry_t* {
        for (int i = 0; channels && i < channels->num_channels; ++i)
            if (channels->entries[i].name.str &&
                std::string_view(channels->entries[i].name.str) == name)
                return &channels->entries[i];
        return nullptr;
    };
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

std::optional<Chromaticities> colorspace_chromaticities(std::string_view colorspace) {
    const std::string name = canonical_colorspace(colorspace);
    if (name == "rec709") return Chromaticities{0.64f, 0.33f, 0.30f, 0.60f, 0.15f, 0.06f, 0.3127f, 0.3290f};
    if (name == "acescg")
        return Chromaticities{0.713f, 0.293f, 0.165f, 0.830f, 0.128f, 0.044f, 0.32168f, 0.33767f};
    if (name == "rec2020")
        return Chromaticities{0.708f, 0.292f, 0.170f, 0.797f, 0.131f, 0.046f, 0.3127f, 0.3290f};
    return std::nullopt;
}

BrdfTable read_exr(const std::filesystem::path& path) {
    const detail::InputFile file(path);
    detail::check_exr_magic(file);
    std::optional<std::string> spec, generator, colorspace;
    {
        const CoreHeader header(file);
        check_header(header, path);
        spec = header.string_attribute("brdf.spec");
        generator = header.string_attribute("brdf.generator");
        colorspace = header.string_attribute("brdf.colorspace");
        if (colorspace && *colorspace == legacy_rec709_colorspace) colorspace = default_colorspace;
        if (!colorspace) colorspace = colorspace_from_chromaticities(header);
    }

    // The header is now known to describe exactly one table: allocation is bounded.
    std::array<std::vector<float>, 3> planes;
    std::vector<detail::PlaneTarget> targets;
    for (int c = 0; c < 3; ++c) {
        planes[c].assign(cells, 0.0f);
        targets.push_back({channel_names[c], planes[c].data()});
    }
    detail::read_planes(file, targets);

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
    check_channel_sizes(table, display(path));
    const std::string colorspace =
        table.colorspace == legacy_rec709_colorspace ? default_colorspace : table.colorspace;
    const std::optional<Chromaticities> chromaticities = colorspace_chromaticities(colorspace);
    if (!chromaticities)
        log::warn(display(path), ": unknown colour space \"", colorspace,
                  "\" (rec709, acescg, rec2020): no chromaticities attribute written");
    std::vector<detail::PlaneSource> sources;
    // Rounded to float32 as the blocks are made; no data (-1) and cells below the horizon are 0.
    for (int c = 0; c < 3; ++c) sources.push_back({channel_names[c], nullptr, table.plane(c).data()});
    // Each block's cells are checked as it is compressed (in cache then, where a pass of its own
    // read the 35 MB table once more): check_table names the first bad cell of a table that fails.
    std::atomic<std::size_t> no_data_above_horizon{0};
    const std::uint8_t* below = below_horizon_mask().data();
    const auto check = [&](std::size_t first, std::size_t end) {
        if (!cells_pass_check(table, first, end)) check_table(table, display(path));
        std::size_t none = 0;
        for (std::size_t cell = first; cell < end; ++cell)
            none += (below[cell] == 0) & (table.plane(0)[cell] == BrdfTable::no_data);
        no_data_above_horizon += none;
    };
    detail::write_zip_table(path, sources,
                            {{"brdf.layout", exr_layout},
                             {"brdf.units", exr_units},
                             {"brdf.colorspace", colorspace},
                             {"brdf.spec", table.spec},
                             {"brdf.generator", table.generator}},
                            chromaticities, check);
    if (no_data_above_horizon > 0)
        log::warn(display(path), ": ", no_data_above_horizon.load(),
                  " cells above the horizon hold no data; OpenEXR tables store them as 0");
}

} // namespace brdf::formats
