#include "format_test_util.h"

#include "test_support.h"

#include <formats/exr/spectral_exr.h>
#include <formats/fourier/fourier.h>
#include <formats/merl/merl.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <half.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>

// --- the allocation probe: a global operator new that can remember its largest request ----------

namespace {
std::atomic<bool> probe_on{false};
std::atomic<std::size_t> probe_largest{0};

void* allocate(std::size_t n) {
    if (probe_on.load(std::memory_order_relaxed)) {
        std::size_t seen = probe_largest.load(std::memory_order_relaxed);
        while (n > seen && !probe_largest.compare_exchange_weak(seen, n)) {
        }
    }
    if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
} // namespace

void* operator new(std::size_t n) {
    return allocate(n);
}
void* operator new[](std::size_t n) {
    return allocate(n);
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete[](void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
    std::free(p);
}

namespace brdf::test {

AllocationProbe::AllocationProbe() {
    probe_largest = 0;
    probe_on = true;
}
AllocationProbe::~AllocationProbe() {
    probe_on = false;
}
std::size_t AllocationProbe::largest() const {
    return probe_largest.load();
}

// --- tables ------------------------------------------------------------------------------------

formats::Rgb analytic_brdf(const formats::Vec3& wi, const formats::Vec3& wo) {
    const double hx = wi.x + wo.x, hy = wi.y + wo.y, hz = wi.z + wo.z;
    const double len = std::sqrt(hx * hx + hy * hy + hz * hz);
    const double cos_h = len > 0 ? std::max(hz / len, 0.0) : 0.0;
    constexpr double n = 50.0;
    const double lobe = (n + 2.0) / (2.0 * formats::pi) * std::pow(cos_h, n);
    const formats::Rgb kd{0.5, 0.3, 0.1}, ks{0.04, 0.05, 0.06};
    formats::Rgb f;
    for (int c = 0; c < 3; ++c) f[c] = kd[c] / formats::pi + ks[c] * lobe;
    return f;
}

const formats::BrdfTable& analytic_table() {
    static const formats::BrdfTable table = [] {
        formats::BrdfTable t = formats::tabulate(
            [](const formats::CellCentre& c) { return analytic_brdf(c.dirs.wi, c.dirs.wo); });
        t.spec = R"({"name": "analytic", "note": "quotes \" and\nnewlines, UTF-8 µm"})";
        t.generator = "formats tests";
        return t;
    }();
    return table;
}

// --- MERL bytes ----------------------------------------------------------------------------------

namespace {
void put_u32_le(std::string& s, std::uint32_t v) {
    for (int b = 0; b < 4; ++b) s.push_back(static_cast<char>((v >> (8 * b)) & 0xff));
}
void put_u32_be(std::string& s, std::uint32_t v) {
    for (int b = 3; b >= 0; --b) s.push_back(static_cast<char>((v >> (8 * b)) & 0xff));
}
} // namespace

std::string merl_header(std::int32_t d0, std::int32_t d1, std::int32_t d2) {
    std::string s;
    for (std::int32_t d : {d0, d1, d2}) put_u32_le(s, static_cast<std::uint32_t>(d));
    return s;
}

std::string merl_header_big_endian(std::int32_t d0, std::int32_t d1, std::int32_t d2) {
    std::string s;
    for (std::int32_t d : {d0, d1, d2}) put_u32_be(s, static_cast<std::uint32_t>(d));
    return s;
}

std::string merl_truncated(std::size_t n) {
    std::string s = merl_header(90, 90, 180);
    s.resize(n, '\0');
    return s;
}

double load_f64_le(const std::string& bytes, std::size_t offset) {
    std::uint64_t v = 0;
    for (int b = 7; b >= 0; --b) v = (v << 8) | static_cast<unsigned char>(bytes.at(offset + b));
    return std::bit_cast<double>(v);
}

void store_f64_le(std::string& bytes, std::size_t offset, double value) {
    const auto v = std::bit_cast<std::uint64_t>(value);
    for (int b = 0; b < 8; ++b) bytes.at(offset + b) = static_cast<char>((v >> (8 * b)) & 0xff);
}

std::size_t merl_offset(int channel, std::size_t cell) {
    return 12 + 8 * (static_cast<std::size_t>(channel) * formats::cells + cell);
}

// --- OpenEXR specimens ---------------------------------------------------------------------------

void write_exr_specimen(const std::filesystem::path& path, const ExrSpecimen& s) {
    Imf::Header header(s.width, s.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const auto& [key, value] : s.attributes) header.insert(key, Imf::StringAttribute(value));
    const std::size_t n = static_cast<std::size_t>(s.width) * static_cast<std::size_t>(s.height);
    std::vector<float> floats(s.half ? 0 : n, s.value);
    std::vector<half> halves(s.half ? n : 0, half(s.value));
    Imf::FrameBuffer frame;
    for (const std::string& name : s.channels) {
        header.channels().insert(name, Imf::Channel(s.half ? Imf::HALF : Imf::FLOAT));
        if (s.half)
            frame.insert(name, Imf::Slice(Imf::HALF, reinterpret_cast<char*>(halves.data()),
                                          sizeof(half), sizeof(half) * s.width));
        else
            frame.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(floats.data()),
                                          sizeof(float), sizeof(float) * s.width));
    }
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(frame);
    file.writePixels(s.height);
}

std::vector<MerlSpecimen> merl_specimens() {
    return {
        {"merl_empty.binary", ""},
        {"merl_truncated.binary", merl_truncated(1200)},
        {"merl_big_endian.binary", merl_header_big_endian(90, 90, 180)},
        {"merl_huge_dims.binary", merl_header(90, 90, 2147483647)},
        {"merl_short_header.binary", merl_header(90, 90, 180).substr(0, 8)},
        {"merl_wrong_dims.binary", merl_header(90, 90, 360) + std::string(24, '\0')},
    };
}

void write_exr_specimens(const std::filesystem::path& folder) {
    ExrSpecimen missing;
    missing.channels = {"R", "B"};
    missing.value = 0.0f; // compresses to almost nothing
    write_exr_specimen(folder / "exr_missing_channel.exr", missing);
    ExrSpecimen small;
    small.height = 100;
    write_exr_specimen(folder / "exr_wrong_size.exr", small);
    ExrSpecimen nan;
    nan.value = std::nanf(""); // a constant compresses to almost nothing
    write_exr_specimen(folder / "exr_nan.exr", nan);
    // A valid table cut off in its pixel data, and one whose magic number is byte-swapped (what a
    // big-endian writer that forgot OpenEXR is little-endian would produce).
    ExrSpecimen zero;
    zero.value = 0.0f;
    const std::filesystem::path whole = folder / "exr_truncated.exr";
    write_exr_specimen(whole, zero);
    std::string bytes = read_file(whole);
    write_file(whole, bytes.substr(0, bytes.size() / 2));
    std::swap(bytes[0], bytes[3]);
    std::swap(bytes[1], bytes[2]);
    write_file(folder / "exr_wrong_endian.exr", bytes.substr(0, 4096));
}

// --- Fourier BSDF specimens -----------------------------------------------------------------------

std::string fourier_specimen_bytes() {
    const std::vector<double> mu{0.5, 1.0};
    const auto series = [](double mu_i, double mu_o, std::span<double> out) {
        // (0.2 + 0.1 c) / pi + s (0.05 - 0.05 cos phi + 0.01 cos 2 phi), s = (1 - mu_i^2)(1 - mu_o^2).
        const double s = (1 - mu_i * mu_i) * (1 - mu_o * mu_o);
        for (int c = 0; c < 3; ++c) {
            out[c * 3 + 0] = (0.2 + 0.1 * c) / formats::pi + 0.05 * s;
            out[c * 3 + 1] = -0.05 * s;
            out[c * 3 + 2] = 0.01 * s;
        }
    };
    formats::FourierBuildOptions options;
    options.generator = "formats tests";
    options.spec = R"({"name": "specimen"})";
    const formats::FourierBsdf bsdf = formats::make_fourier_bsdf(mu, 3, series, options);
    TempDir dir;
    formats::write_fourier_bsdf(dir / "s.bsdf", bsdf);
    return read_file(dir / "s.bsdf");
}

namespace {
void store_u32_at(std::string& s, std::size_t offset, std::uint32_t v) {
    for (int b = 0; b < 4; ++b) s.at(offset + b) = static_cast<char>((v >> (8 * b)) & 0xff);
}
} // namespace

void write_fuzz_seeds(const std::filesystem::path& folder) {
    std::filesystem::create_directories(folder / "fourier");
    std::filesystem::create_directories(folder / "spectral_exr");
    write_file(folder / "fourier" / "specimen.bsdf", fourier_specimen_bytes());
    // One channel, a few more nodes and orders, foreign (layerlab-like) metadata.
    const std::vector<double> mu{0.2, 0.6, 0.9};
    const auto series = [](double mu_i, double mu_o, std::span<double> out) {
        const double s = (1 - mu_i * mu_i) * (1 - mu_o * mu_o);
        for (int c = 0; c < 3; ++c)
            for (int m = 0; m < 4; ++m) out[c * 4 + m] = (m == 0 ? 0.1 : 0.02 * s / m);
    };
    formats::FourierBuildOptions options;
    options.channels = 1;
    formats::FourierBsdf grey = formats::make_fourier_bsdf(mu, 4, series, options);
    grey.metadata = R"({"layers": [{"type": 1, "roughness": 0.2}]})";

    formats::write_fourier_bsdf(folder / "fourier" / "grey_foreign_metadata.bsdf", grey);
    // A spectral table of one wavelength, all zero (compresses to a few kB).
    formats::SpectralTable zero({550.0});
    zero.generator = "fuzz seed";
    formats::write_spectral_exr(folder / "spectral_exr" / "zero_550nm.exr", zero);
}

std::vector<MerlSpecimen> fourier_specimens() {
    const std::string valid = fourier_specimen_bytes();
    // Layout of the specimen: 64-byte header, 6 nodes, 36 cdf values, 36 (offset, length) pairs.
    constexpr std::size_t nodes = 6, table = 64 + 4 * nodes + 4 * nodes * nodes;
    std::string wrong_magic = valid.substr(0, 64);
    wrong_magic[6] = 'X';
    std::string bad_offset = valid;
    // Pair o = 5 (mu_o = 1), i = 0 (mu_i = -1): a reflection pair with a series; point it past the
    // end of the coefficients.
    store_u32_at(bad_offset, table + 8 * (5 * nodes + 0), 1000000);
    std::string huge = valid.substr(0, 64);
    store_u32_at(huge, 12, 0x7fffffff); // nMu
    store_u32_at(huge, 16, 0x7fffffff); // nCoeffs
    std::string nan = valid;
    const std::size_t coefficients = table + 8 * nodes * nodes;
    store_u32_at(nan, coefficients, 0x7fc00000u); // the first coefficient
    return {
        {"fourier_truncated.bsdf", valid.substr(0, valid.size() / 2)},
        {"fourier_wrong_magic.bsdf", wrong_magic},
        {"fourier_bad_offset.bsdf", bad_offset},
        {"fourier_huge_counts.bsdf", huge},
        {"fourier_nan.bsdf", nan},
    };
}

} // namespace brdf::test
