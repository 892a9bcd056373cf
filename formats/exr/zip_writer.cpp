#include <formats/exr/zip_writer.h>

#include <formats/file_io.h>
#include <formats/halfdiff.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/threads.h>

#include <libdeflate.h>
#include <openexr.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <new>

namespace brdf::formats::detail {
namespace {

// OpenEXR's ZIP_COMPRESSION: 16 scanlines per block (the file format's definition).
constexpr int zip_lines = 16;
// libdeflate's fastest level: 9.8 MB for a seed table's 17.5 MB where level 4 (OpenEXR's own
// default) gives 9.7 MB at 1.2 times the time; the tables are written for every material.
constexpr int deflate_level = 1;

struct CompressorDeleter {
    void operator()(libdeflate_compressor* c) const { libdeflate_free_compressor(c); }
};
using Compressor = std::unique_ptr<libdeflate_compressor, CompressorDeleter>;

// One block: the Xdr bytes of lines [y0, y0 + lines) of every plane, then OpenEXR's ZIP transform
// (even/odd byte split and the byte predictor), compressed. `scratch` holds the Xdr bytes and the
// transformed ones. Stored raw when compression does not shrink it, as OpenEXR does.
std::vector<unsigned char> zip_block(const std::vector<PlaneSource>& planes, int y0, int lines,
                                     libdeflate_compressor* compressor,
                                     std::vector<unsigned char>& scratch) {
    const std::size_t row_bytes = sizeof(float) * exr_width;
    const std::size_t size = row_bytes * planes.size() * static_cast<std::size_t>(lines);
    scratch.resize(2 * size);
    unsigned char* xdr = scratch.data();
    unsigned char* split = scratch.data() + size;
    unsigned char* at = xdr;
    std::uint32_t row[exr_width];
    const std::uint8_t* below = below_horizon_mask().data();
    for (int y = y0; y < y0 + lines; ++y) {
        const std::size_t first = static_cast<std::size_t>(y) * exr_width;
        for (const PlaneSource& p : planes) {
            for (int x = 0; x < exr_width; ++x) {
                const float v =
                    p.data ? p.data[first + x] : static_cast<float>(p.doubles[first + x]);
                const float stored = v >= 0.0f && below[first + x] == 0 ? v : 0.0f;
                std::uint32_t bits;
                std::memcpy(&bits, &stored, sizeof bits);
                row[x] = bits; // little-endian host: the Xdr order
            }
            std::memcpy(at, row, row_bytes);
            at += row_bytes;
        }
    }
    static_assert(std::endian::native == std::endian::little,
                  "Xdr bytes are written as the host holds them");
    // Even bytes first, then odd ones; then each byte as its difference to the one before + 128.
    // In one pass from the Xdr bytes (stride-two loads that vectorise), not a split and a backward
    // pass over it.
    const std::size_t half = (size + 1) / 2;
    const auto delta = [](unsigned char now, unsigned char before) {
        return static_cast<unsigned char>(now - before + 128);
    };
    split[0] = xdr[0];
    for (std::size_t i = 1; i < half; ++i) split[i] = delta(xdr[2 * i], xdr[2 * i - 2]);
    if (size > 1) split[half] = delta(xdr[1], xdr[2 * (half - 1)]);
    for (std::size_t i = 1; half + i < size; ++i)
        split[half + i] = delta(xdr[2 * i + 1], xdr[2 * i - 1]);
    std::vector<unsigned char> out(libdeflate_zlib_compress_bound(compressor, size));
    const std::size_t packed =
        libdeflate_zlib_compress(compressor, split, size, out.data(), out.size());
    if (packed == 0 || packed >= size) return std::vector<unsigned char>(xdr, xdr + size);
    out.resize(packed);
    return out;
}

// The Core context writing through an AtomicFile; its errors are collected, the first kept.
class CoreWriter {
  public:
    CoreWriter(AtomicFile& file, const std::filesystem::path& path) : m_file(file), m_path(path) {
        exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
        init.user_data = this;
        init.write_fn = &CoreWriter::write;
        init.error_handler_fn = &CoreWriter::error;
        check(exr_start_write(&m_context, path.c_str(), EXR_WRITE_FILE_DIRECTLY, &init));
    }
    ~CoreWriter() {
        if (m_context) exr_finish(&m_context);
    }
    CoreWriter(const CoreWriter&) = delete;
    CoreWriter& operator=(const CoreWriter&) = delete;

    exr_context_t context() const { return m_context; }

    void check(exr_result_t rv) const {
        if (rv == EXR_ERR_SUCCESS) return;
        if (m_io_error) throw IoError(*m_io_error);
        throw IoError(cat(display(m_path), ": cannot write: OpenEXR: ",
                          m_message.empty() ? exr_get_default_error_message(rv) : m_message));
    }
    // Writes the offset table and closes the context.
    void finish() {
        const exr_result_t rv = exr_finish(&m_context);
        m_context = nullptr;
        check(rv);
    }

  private:
    static int64_t write(exr_const_context_t, void* self, const void* buffer, uint64_t n,
                         uint64_t offset, exr_stream_error_func_ptr_t) {
        auto* writer = static_cast<CoreWriter*>(self);
        try {
            writer->m_file.write_at(offset, buffer, static_cast<std::size_t>(n));
            return static_cast<int64_t>(n);
        } catch (const IoError& e) {
            if (!writer->m_io_error) writer->m_io_error = e.what();
            return -1;
        }
    }
    static void error(exr_const_context_t context, exr_result_t, const char* message) {
        void* self = nullptr;
        if (exr_get_user_data(context, &self) == EXR_ERR_SUCCESS && self && message) {
            auto* writer = static_cast<CoreWriter*>(self);
            if (writer->m_message.empty()) writer->m_message = message;
        }
    }

    AtomicFile& m_file;
    std::filesystem::path m_path;
    std::string m_message;
    std::optional<std::string> m_io_error;
    exr_context_t m_context = nullptr;
};

} // namespace

void write_zip_table(const std::filesystem::path& path, const std::vector<PlaneSource>& planes,
                     const std::vector<std::pair<std::string, std::string>>& attributes,
                     const std::optional<Chromaticities>& chromaticities, const BlockCheck& check) {
    AtomicFile out(path);
    {
        CoreWriter writer(out, path);
        exr_context_t ctx = writer.context();
        int part = 0;
        writer.check(exr_add_part(ctx, "", EXR_STORAGE_SCANLINE, &part));
        writer.check(exr_initialize_required_attr_simple(ctx, part, exr_width, exr_height,
                                                         EXR_COMPRESSION_ZIP));
        for (const PlaneSource& p : planes)
            writer.check(exr_add_channel(ctx, part, p.name.c_str(), EXR_PIXEL_FLOAT,
                                         EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1));
        for (const auto& [name, value] : attributes)
            writer.check(exr_attr_set_string(ctx, part, name.c_str(), value.c_str()));
        if (chromaticities) {
            const Chromaticities& c = *chromaticities;
            const exr_attr_chromaticities_t chroma{c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]};
            writer.check(exr_attr_set_chromaticities(ctx, part, "chromaticities", &chroma));
        }
        writer.check(exr_write_header(ctx));

        // The planes in the header's channel order (OpenEXR sorts channels by name).
        const exr_attr_chlist_t* list = nullptr;
        writer.check(exr_get_channels(ctx, part, &list));
        std::vector<PlaneSource> ordered;
        for (int i = 0; list && i < list->num_channels; ++i)
            for (const PlaneSource& p : planes)
                if (p.name == list->entries[i].name.str) ordered.push_back(p);
        if (ordered.size() != planes.size())
            throw InternalError(cat(display(path), ": OpenEXR kept ", ordered.size(), " of ",
                                    planes.size(), " channels"));

        // Blocks are claimed one at a time by every core (the MERL writer runs beside this one, so
        // fixed runs per thread finished unevenly) and written in order as soon as a block and all
        // before it are done, so the file's writes overlap the compression of later blocks.
        const int blocks = (exr_height + zip_lines - 1) / zip_lines;
        const int threads = std::min(available_cpus(), blocks);
        std::vector<std::vector<unsigned char>> packed(static_cast<std::size_t>(blocks));
        std::vector<char> ready(static_cast<std::size_t>(blocks), 0);
        int next_to_write = 0; // guarded by write_mutex, as ready and writing
        bool writing = false;
        std::mutex write_mutex;
        // A compressor and scratch per thread; each thread takes the next block from `next_block`.
        std::vector<Compressor> compressors;
        std::vector<std::vector<unsigned char>> scratch(static_cast<std::size_t>(threads));
        for (int t = 0; t < threads; ++t) {
            compressors.emplace_back(libdeflate_alloc_compressor(deflate_level));
            if (!compressors.back()) throw std::bad_alloc();
        }
        std::atomic<int> next_block{0};
        // Block b compressed, then handed on for writing.
        const auto compress_and_write = [&](int b, int t) {
            const int y0 = b * zip_lines;
            const int lines = std::min(zip_lines, exr_height - y0);
            if (check)
                check(static_cast<std::size_t>(y0) * exr_width, static_cast<std::size_t>(y0 + lines) * exr_width);
            std::vector<unsigned char> block = zip_block(ordered, y0, lines, compressors[t].get(), scratch[t]);
            // The thread that finds the next block ready writes the run that is ready, outside the
            // lock, while the others go on compressing.
            std::unique_lock lock(write_mutex);
            packed[b] = std::move(block);
            ready[b] = 1;
            if (writing) return;
            writing = true;
            for (;;) {
                int end = next_to_write;
                while (end < blocks && ready[end]) ++end;
                if (end == next_to_write) break;
                lock.unlock();
                for (int k = next_to_write; k < end; ++k) {
                    std::vector<unsigned char>& chunk = packed[k];
                    writer.check(exr_write_scanline_chunk(ctx, part, k * zip_lines, chunk.data(),
                                                          chunk.size()));
                    std::vector<unsigned char>().swap(chunk);
                }
                lock.lock();
                next_to_write = end;
            }
            writing = false;
        };
        parallel_for(threads, threads, [&](int t) {
            try {
                for (int b = next_block++; b < blocks; b = next_block++) compress_and_write(b, t);
            } catch (...) {
                next_block = blocks; // the other threads stop too; parallel_for rethrows it
                throw;
            }
        });
        if (next_to_write != blocks)
            throw InternalError(cat(display(path), ": wrote ", next_to_write, " of ", blocks,
                                    " blocks"));
        writer.finish();
    }
    out.commit();
}

} // namespace brdf::formats::detail
