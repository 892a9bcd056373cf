#include <formats/merl/merl.h>

#include <formats/file_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/threads.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <span>
#include <vector>

namespace brdf::formats {

namespace {

using detail::display;

constexpr std::uint64_t header_size = 12;
constexpr std::size_t plane_bytes = cells * sizeof(double);

std::uint32_t byte_swap(std::uint32_t v) {
    return (v >> 24) | ((v >> 8) & 0xff00u) | ((v << 8) & 0xff0000u) | (v << 24);
}

std::uint64_t byte_swap(std::uint64_t v) {
    return (std::uint64_t{byte_swap(static_cast<std::uint32_t>(v))} << 32) |
           byte_swap(static_cast<std::uint32_t>(v >> 32));
}

std::int32_t load_i32_le(const unsigned char* p) {
    const std::uint32_t v = std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 |
                            std::uint32_t{p[2]} << 16 | std::uint32_t{p[3]} << 24;
    return static_cast<std::int32_t>(v);
}

void store_i32_le(unsigned char* p, std::int32_t value) {
    const auto v = static_cast<std::uint32_t>(value);
    for (int b = 0; b < 4; ++b) p[b] = static_cast<unsigned char>(v >> (8 * b));
}

// The planes are read into and written from doubles in place; only a big-endian host swaps.
void to_or_from_little_endian(std::span<double> values) {
    if constexpr (std::endian::native == std::endian::big) {
        for (double& d : values)
            d = std::bit_cast<double>(byte_swap(std::bit_cast<std::uint64_t>(d)));
    }
}

// `keep ? value : otherwise` by the bits, so that a loop of them vectorises: GCC leaves a
// select of two doubles whose condition comes from comparisons as a branch.
double pick(bool keep, double value, double otherwise) {
    const std::uint64_t mask = -static_cast<std::uint64_t>(keep);
    return std::bit_cast<double>((std::bit_cast<std::uint64_t>(value) & mask) |
                                 (std::bit_cast<std::uint64_t>(otherwise) & ~mask));
}

// Cells [first, first + count) of the three planes in the file's units, into out (plane c at
// out + c * stride): each value over its channel's scale, and -1 where the cell holds no data
// (below the horizon, or -1 in the table).
void to_merl_units(const BrdfTable& table, const std::uint8_t* below, std::size_t first, std::size_t count,
                   double* out, std::size_t stride) {
    const double* __restrict r = table.plane(0).data() + first;
    const double* __restrict g = table.plane(1).data() + first;
    const double* __restrict b = table.plane(2).data() + first;
    const std::uint8_t* __restrict under = below + first;
    double* __restrict out_r = out;
    double* __restrict out_g = out + stride;
    double* __restrict out_b = out + 2 * stride;
    for (std::size_t k = 0; k < count; ++k) {
        const bool data = (under[k] == 0) & (r[k] >= 0.0) & (g[k] >= 0.0) & (b[k] >= 0.0);
        out_r[k] = pick(data, r[k] / merl_scales[0], -1.0);
        out_g[k] = pick(data, g[k] / merl_scales[1], -1.0);
        out_b[k] = pick(data, b[k] / merl_scales[2], -1.0);
    }
}

std::string truncated(const std::filesystem::path& path, std::uint64_t found) {
    return cat(display(path), ": truncated (", merl_file_size, " bytes expected, ", found,
               " found)");
}

} // namespace

BrdfTable read_merl(const std::filesystem::path& path) {
    const detail::InputFile file(path);
    const std::uint64_t size = file.size();
    if (size == 0)
        throw FormatError(cat(display(path), ": empty file (", merl_file_size, " bytes expected)"));
    if (size < header_size) throw FormatError(truncated(path, size));

    unsigned char header[header_size];
    if (file.read_at(0, header, header_size) != header_size)
        throw FormatError(truncated(path, size));
    std::int32_t dims[3], swapped[3];
    for (std::size_t d = 0; d < 3; ++d) {
        dims[d] = load_i32_le(header + 4 * d);
        swapped[d] = static_cast<std::int32_t>(byte_swap(static_cast<std::uint32_t>(dims[d])));
    }
    const auto is_merl = [](const std::int32_t* v) {
        return v[0] == merl_dims[0] && v[1] == merl_dims[1] && v[2] == merl_dims[2];
    };
    if (!is_merl(dims)) {
        if (is_merl(swapped))
            throw FormatError(cat(display(path),
                                  ": big-endian header (dims 90 90 180 after byte swapping); "
                                  "MERL tables are little-endian"));
        throw FormatError(cat(display(path), ": unsupported dims ", dims[0], " x ", dims[1], " x ",
                              dims[2], " (a MERL table has 90 x 90 x 180)"));
    }
    // Only now, with the size known to match the header, is the 35 MB table allocated.
    if (size < merl_file_size) throw FormatError(truncated(path, size));
    if (size > merl_file_size)
        throw FormatError(cat(display(path), ": wrong size (", merl_file_size, " bytes expected, ",
                              size, " found)"));

    BrdfTable table(BrdfTable::Unwritten{}); // every value is read from the file
    for (int c = 0; c < 3; ++c) {
        TablePlane& plane = table.channels[c];
        // The file may shrink between fstat and read (another process rewriting it in place).
        if (file.read_at(header_size + c * plane_bytes, plane.data(), plane_bytes) != plane_bytes)
            throw FormatError(cat(display(path), ": truncated while reading (the file changed)"));
        to_or_from_little_endian(plane);
        for (std::size_t cell = 0; cell < cells; ++cell)
            if (!std::isfinite(plane[cell]))
                throw FormatError(cat(display(path), ": non-finite value ",
                                      detail::value_text(plane[cell]), " in the ", channel_name(c),
                                      " plane at ", describe_cell(cell)));
    }
    std::size_t negative_above_horizon = 0;
    for (std::size_t cell = 0; cell < cells; ++cell) {
        // Like the reference reader: a negative value in any channel means no data for the cell.
        if (!table.has_data(cell)) {
            negative_above_horizon += !cell_below_horizon(cell);
            table.set_no_data(cell);
            continue;
        }
        for (int c = 0; c < 3; ++c) table.channels[c][cell] *= merl_scales[c];
    }
    if (negative_above_horizon > 0)
        log::debug(display(path), ": ", negative_above_horizon,
                   " cells above the horizon hold no data (negative values)");
    return table;
}

void write_merl(const std::filesystem::path& path, const BrdfTable& table) {
    check_channel_sizes(table, display(path));
    detail::AtomicFile out(path);
    unsigned char header[header_size];
    for (std::size_t d = 0; d < 3; ++d) store_i32_le(header + 4 * d, merl_dims[d]);
    out.write_at(0, header, header_size);
    // Checked, converted and written a block of cells at a time on every core: copying 35 MB into
    // the page cache is most of the write, and one thread left the other cores idle (a MERL table
    // alone is a material's output). A block's three planes (0.75 MB) are read from memory once,
    // by the check, and stay in cache for the conversion, with the buffers. A table that fails the
    // check is not written: check_table names its first bad cell, and the temporary is removed.
    constexpr std::size_t block = std::size_t{1} << 15; // cells
    constexpr std::size_t blocks = (cells + block - 1) / block;
    const int threads = std::min(available_cpus(), static_cast<int>(blocks));
    std::atomic<bool> bad{false};
    parallel_for(threads, threads, [&](int t) {
        std::vector<double> buffer(3 * block);
        const std::uint8_t* below = below_horizon_mask().data();
        for (std::size_t b = static_cast<std::size_t>(t); b < blocks && !bad.load(std::memory_order_relaxed);
             b += static_cast<std::size_t>(threads)) {
            const std::size_t first = b * block;
            const std::size_t count = std::min(block, cells - first);
            if (!cells_pass_check(table, first, first + count)) {
                bad = true;
                break;
            }
            to_merl_units(table, below, first, count, buffer.data(), block);
            for (int c = 0; c < 3; ++c) {
                const std::span<double> plane(buffer.data() + c * block, count);
                to_or_from_little_endian(plane);
                out.write_at(header_size + c * plane_bytes + first * sizeof(double), plane.data(),
                             count * sizeof(double));
            }
        }
    });
    if (bad) check_table(table, display(path)); // throws
    out.commit();
}

} // namespace brdf::formats
