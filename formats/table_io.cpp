#include <formats/table_io.h>

#include <formats/exr/exr.h>
#include <formats/file_io.h>
#include <formats/merl/merl.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

namespace brdf::formats {

const char* to_string(TableFormat format) {
    switch (format) {
    case TableFormat::Merl:
        return "MERL .binary";
    case TableFormat::Exr:
        return "OpenEXR";
    }
    return "unknown";
}

TableFormat table_format(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    if (ext == ".binary") return TableFormat::Merl;
    if (ext == ".exr") return TableFormat::Exr;
    throw InputError(cat(detail::display(path), ": unsupported table format '", ext,
                         "' (supported: .binary (MERL), .exr (OpenEXR))"));
}

BrdfTable read_table(const std::filesystem::path& path) {
    switch (table_format(path)) {
    case TableFormat::Merl:
        return read_merl(path);
    case TableFormat::Exr:
        return read_exr(path);
    }
    throw InputError(cat(detail::display(path), ": unsupported table format"));
}

void write_table(const std::filesystem::path& path, const BrdfTable& table) {
    switch (table_format(path)) {
    case TableFormat::Merl:
        write_merl(path, table);
        return;
    case TableFormat::Exr:
        write_exr(path, table);
        return;
    }
}

TableStats table_stats(const BrdfTable& table) {
    TableStats stats;
    std::array<double, 3> sum{0.0, 0.0, 0.0};
    for (auto& ch : stats.channels) {
        ch.min = std::numeric_limits<double>::infinity();
        ch.max = -std::numeric_limits<double>::infinity();
    }
    for (std::size_t cell = 0; cell < cells; ++cell) {
        stats.below_horizon_cells += cell_below_horizon(cell);
        if (!table.has_data(cell)) continue;
        ++stats.data_cells;
        for (int c = 0; c < 3; ++c) {
            const double v = table.channels[c][cell];
            stats.channels[c].min = std::min(stats.channels[c].min, v);
            stats.channels[c].max = std::max(stats.channels[c].max, v);
            sum[c] += v;
        }
    }
    for (int c = 0; c < 3; ++c) {
        if (stats.data_cells == 0) {
            stats.channels[c] = {};
            continue;
        }
        stats.channels[c].mean = sum[c] / static_cast<double>(stats.data_cells);
    }
    return stats;
}

TableDiff diff(const BrdfTable& a, const BrdfTable& b, double floor) {
    if (!(floor > 0.0) || !std::isfinite(floor))
        throw InputError(cat("diff: the relative-difference floor must be > 0 (got ",
                             detail::value_text(floor), ")"));
    TableDiff d;
    d.floor = floor;
    std::array<double, 3> sum{0.0, 0.0, 0.0}, sum_sq{0.0, 0.0, 0.0};
    for (std::size_t cell = 0; cell < cells; ++cell) {
        const bool in_a = a.has_data(cell), in_b = b.has_data(cell);
        d.only_in_a += in_a && !in_b;
        d.only_in_b += in_b && !in_a;
        if (!in_a || !in_b) continue;
        ++d.compared_cells;
        for (int c = 0; c < 3; ++c) {
            const double va = a.channels[c][cell], vb = b.channels[c][cell];
            const double rel = std::abs(va - vb) / std::max(std::abs(vb), floor);
            if (rel > d.channels[c].max) {
                d.channels[c].max = rel;
                d.channels[c].max_cell = cell;
            }
            sum[c] += rel;
            sum_sq[c] += rel * rel;
        }
    }
    if (d.compared_cells > 0)
        for (int c = 0; c < 3; ++c) {
            const auto n = static_cast<double>(d.compared_cells);
            d.channels[c].mean = sum[c] / n;
            d.channels[c].rms = std::sqrt(sum_sq[c] / n);
        }
    return d;
}

} // namespace brdf::formats
