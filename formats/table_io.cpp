#include <formats/table_io.h>

#include <formats/exr/exr.h>
#include <formats/exr/exr_detail.h>
#include <formats/exr/spectral_exr.h>
#include <formats/file_io.h>
#include <formats/fourier/fourier.h>
#include <formats/merl/merl.h>
#include <formats/rgl/rgl_eval.h>
#include <brdf/core/threads.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

namespace brdf::formats {

namespace {

using detail::display;

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    return s;
}

bool ends_with(const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// Formats that share an extension (.exr, .bsdf) are one family: no warning between them.
int family(TableFormat f) {
    switch (f) {
    case TableFormat::Merl:
        return 0;
    case TableFormat::Exr:
    case TableFormat::SpectralExr:
        return 1;
    case TableFormat::Fourier:
    case TableFormat::RglTensor:
        return 2;
    }
    return -1;
}

std::optional<TableFormat> format_by_extension(const std::filesystem::path& path) {
    const std::string name = lower(path.filename().string());
    if (ends_with(name, ".binary")) return TableFormat::Merl;
    if (ends_with(name, ".spectral.exr")) return TableFormat::SpectralExr;
    if (ends_with(name, ".exr")) return TableFormat::Exr;
    if (ends_with(name, ".rgl.bsdf")) return TableFormat::RglTensor;
    if (ends_with(name, ".bsdf")) return TableFormat::Fourier;
    return std::nullopt;
}

// OpenEXR: spectral when a channel is a reflective spectral one. A header OpenEXR cannot parse is
// left to the RGB reader, which names the fault.
TableFormat exr_kind(const detail::InputFile& file) {
    try {
        const detail::CoreHeader header(file);
        for (const std::string& name : detail::channel_names(header))
            if (parse_spectral_channel(name) > 0) return TableFormat::SpectralExr;
    } catch (const Error&) {
    }
    return TableFormat::Exr;
}

std::optional<TableFormat> format_by_content(const detail::InputFile& file) {
    unsigned char head[12] = {};
    const std::size_t got = file.read_at(0, head, sizeof head);
    if (got >= 7 && std::memcmp(head, fourier_magic.data(), 7) == 0) return TableFormat::Fourier;
    if (got >= 12 && std::memcmp(head, "tensor_file", 12) == 0) return TableFormat::RglTensor;
    if (got >= 4 && head[0] == 0x76 && head[1] == 0x2f && head[2] == 0x31 && head[3] == 0x01)
        return exr_kind(file);
    if (got == 12 && file.size() == merl_file_size) {
        bool merl = true;
        for (int d = 0; d < 3; ++d) {
            const std::uint32_t v = std::uint32_t{head[4 * d]} | std::uint32_t{head[4 * d + 1]} << 8 |
                                    std::uint32_t{head[4 * d + 2]} << 16 |
                                    std::uint32_t{head[4 * d + 3]} << 24;
            merl = merl && v == static_cast<std::uint32_t>(merl_dims[d]);
        }
        if (merl) return TableFormat::Merl;
    }
    return std::nullopt;
}

} // namespace

const char* to_string(TableFormat format) {
    switch (format) {
    case TableFormat::Merl:
        return "MERL .binary";
    case TableFormat::Exr:
        return "OpenEXR";
    case TableFormat::SpectralExr:
        return "spectral OpenEXR";
    case TableFormat::Fourier:
        return "pbrt-v3 Fourier BSDF";
    case TableFormat::RglTensor:
        return "RGL tensor";
    }
    return "unknown";
}

TableFormat table_format(const std::filesystem::path& path) {
    if (const auto f = format_by_extension(path)) return *f;
    throw InputError(cat(display(path), ": unsupported table format '", lower(path.extension().string()),
                         "' (supported: .binary (MERL), .exr (OpenEXR), .spectral.exr (spectral "
                         "OpenEXR), .bsdf (pbrt-v3 Fourier BSDF), .rgl.bsdf (RGL tensor))"));
}

TableFormat detect_format(const std::filesystem::path& path) {
    const std::optional<TableFormat> by_name = format_by_extension(path);
    std::optional<TableFormat> by_content;
    {
        const detail::InputFile file(path);
        by_content = format_by_content(file);
    }
    if (!by_content) return table_format(path); // the extension's reader names the fault
    if (!by_name)
        log::warn(display(path), ": '", lower(path.extension().string()),
                  "' is not a table extension; the content is ", to_string(*by_content),
                  ", read as that");
    else if (family(*by_name) != family(*by_content))
        log::warn(display(path), ": the extension says ", to_string(*by_name),
                  " but the content is ", to_string(*by_content), "; reading it as ",
                  to_string(*by_content));
    return *by_content;
}

BrdfTable read_table(const std::filesystem::path& path, const SpectralToRgb& spectral_to_rgb) {
    return read_table(path, detect_format(path), spectral_to_rgb);
}

BrdfTable tabulate_rgl(const RglBsdf& bsdf, const std::string& what, const SpectralToRgb& spectral_to_rgb) {
    if (bsdf.spectral() && !spectral_to_rgb)
        throw InputError(cat(what, ": a spectral RGL file (", bsdf.wavelengths.size(),
                             " wavelengths) needs colour weights to become RGB"));
    const RglEvaluator evaluator(bsdf);
    // One value per channel and cell: R, G, B, or the file's wavelengths (then weighted to RGB).
    const std::size_t channels = evaluator.channels();
    std::vector<std::vector<float>> planes(channels, std::vector<float>(theta_h_bins * theta_d_bins * phi_d_bins, 0.0f));
    parallel_for(theta_h_bins, 0, [&](int i) {
        for (int j = 0; j < theta_d_bins; ++j)
            for (int k = 0; k < phi_d_bins; ++k) {
                const std::size_t cell = cell_index(i, j, k);
                if (cell_below_horizon(cell)) continue;
                const DirectionPair d = to_directions(theta_h_centre(i), theta_d_centre(j), phi_d_centre(k));
                const std::vector<double> v = evaluator.brdf(d.wi, d.wo);
                // pbrt-v4 clamps negative samples; a table holds none.
                for (std::size_t c = 0; c < channels; ++c) planes[c][cell] = static_cast<float>(std::max(0.0, v[c]));
            }
    });
    BrdfTable table;
    if (bsdf.spectral()) {
        SpectralTable spectral(std::vector<double>(bsdf.wavelengths.begin(), bsdf.wavelengths.end()));
        for (std::size_t c = 0; c < channels; ++c)
            for (std::size_t cell = 0; cell < planes[c].size(); ++cell)
                if (!cell_below_horizon(cell)) spectral.planes[c][cell] = planes[c][cell];
        table = spectral_to_rgb(spectral);
    } else {
        for (std::size_t cell = 0; cell < planes[0].size(); ++cell)
            if (!cell_below_horizon(cell)) table.set(cell, {planes[0][cell], planes[1][cell], planes[2][cell]});
    }
    const RglProvenance p = rgl_provenance(bsdf);
    table.spec = p.spec;
    table.generator = p.generator;
    return table;
}

BrdfTable read_table(const std::filesystem::path& path, TableFormat format,
                     const SpectralToRgb& spectral_to_rgb) {
    switch (format) {
    case TableFormat::Merl:
        return read_merl(path);
    case TableFormat::Exr:
        return read_exr(path);
    case TableFormat::SpectralExr: {
        const SpectralTable spectral = read_spectral_exr(path);
        if (!spectral_to_rgb)
            throw InputError(cat(display(path), ": a spectral table (", spectral.wavelengths_nm.size(),
                                 " wavelengths) needs colour weights to become RGB"));
        return spectral_to_rgb(spectral);
    }
    case TableFormat::Fourier:
        return tabulate_fourier(read_fourier_bsdf(path));
    case TableFormat::RglTensor:
        return tabulate_rgl(read_rgl_bsdf(path), display(path), spectral_to_rgb);
    }
    throw InputError(cat(display(path), ": unsupported table format"));
}

void write_table(const std::filesystem::path& path, const BrdfTable& table) {
    const TableFormat format = table_format(path);
    switch (format) {
    case TableFormat::Merl:
        write_merl(path, table);
        return;
    case TableFormat::Exr:
        write_exr(path, table);
        return;
    case TableFormat::SpectralExr:
    case TableFormat::Fourier:
    case TableFormat::RglTensor:
        break;
    }
    throw InputError(cat(display(path), ": cannot write a ", to_string(format),
                         " file from an RGB table (it is computed from the material: brdftool "
                         "compute with \"outputs\"); write .binary or .exr"));
}

BrdfTable spectral_to_rgb(const SpectralTable& spectral, std::span<const Rgb> weights,
                          const std::string& colorspace) {
    const std::size_t n = spectral.wavelengths_nm.size();
    if (weights.size() != n || spectral.planes.size() != n)
        throw InputError(cat("spectral_to_rgb: ", weights.size(), " weights and ",
                             spectral.planes.size(), " planes for ", n, " wavelengths"));
    BrdfTable table;
    table.spec = spectral.spec;
    table.generator = spectral.generator;
    table.colorspace = colorspace;
    std::size_t clamped = 0;
    for (std::size_t cell = 0; cell < cells; ++cell) {
        if (cell_below_horizon(cell)) continue;
        if (!spectral.has_data(cell)) {
            table.set_no_data(cell);
            continue;
        }
        Rgb rgb{0.0, 0.0, 0.0};
        for (std::size_t j = 0; j < n; ++j)
            for (int c = 0; c < 3; ++c) rgb[c] += weights[j][c] * double(spectral.planes[j][cell]);
        for (double& v : rgb)
            if (v < 0.0) {
                v = 0.0;
                ++clamped;
            }
        table.set(cell, rgb);
    }
    if (clamped > 0)
        log::warn("spectral_to_rgb: ", clamped,
                  " negative RGB values (colours outside the gamut) clamped to 0");
    return table;
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
            const double v = table.plane(c)[cell];
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
            const double va = a.plane(c)[cell], vb = b.plane(c)[cell];
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
