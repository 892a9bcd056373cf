#include <brdf/preview/image.h>

#include <brdf/core/atomic_file.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <png.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

namespace brdf::preview {

Image::Image(int w, int h, const Rgb& fill) : width(w), height(h) {
    pixels.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3);
    for (std::size_t k = 0; k < pixels.size(); k += 3)
        for (int c = 0; c < 3; ++c) pixels[k + c] = static_cast<float>(fill[c]);
}

ToneCurve parse_tone_curve(const std::string& name) {
    if (name == "filmic") return ToneCurve::Filmic;
    if (name == "reinhard") return ToneCurve::Reinhard;
    if (name == "clamp") return ToneCurve::Clamp;
    throw InputError(cat("tone curve: expected filmic, reinhard or clamp (got '", name, "')"));
}

double tone_map(double linear, const ToneOptions& options) {
    const double x = std::max(0.0, linear) * std::exp2(options.exposure);
    if (!std::isfinite(x)) return 1.0;
    switch (options.curve) {
    case ToneCurve::Filmic: {
        // K. Narkowicz, "ACES Filmic Tone Mapping Curve" (2016): a rational fit of the ACES RRT + ODT.
        const double a = 2.51, b = 0.03, c = 2.43, d = 0.59, e = 0.14;
        return std::clamp(x * (a * x + b) / (x * (c * x + d) + e), 0.0, 1.0);
    }
    case ToneCurve::Reinhard: return x / (1.0 + x);
    case ToneCurve::Clamp: return std::min(x, 1.0);
    }
    return std::min(x, 1.0);
}

double srgb_encode(double v) {
    v = std::clamp(v, 0.0, 1.0);
    return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

namespace {

/// The code as written out: what DisplayCodes reproduces.
int display_code(double linear, const ToneOptions& tone) {
    return static_cast<int>(std::lround(255.0 * srgb_encode(tone_map(linear, tone))));
}

} // namespace

DisplayCodes::DisplayCodes(const ToneOptions& tone) {
    constexpr std::uint32_t infinity_bits = 0x7f800000u;
    // Non-negative floats are ordered as their bit patterns, 0 .. +inf; code(+inf) = 255.
    const int at_zero = display_code(0.0, tone);
    for (int k = 1; k <= 255; ++k) {
        // code(lo) < k <= code(hi), unless code(0) >= k already (then x_k = 0)
        std::uint32_t lo = 0, hi = at_zero >= k ? 0 : infinity_bits;
        while (hi - lo > 1) {
            const std::uint32_t mid = lo + (hi - lo) / 2;
            (display_code(std::bit_cast<float>(mid), tone) >= k ? hi : lo) = mid;
        }
        m_threshold[static_cast<std::size_t>(k - 1)] = std::bit_cast<float>(hi);
    }
    m_threshold[255] = std::numeric_limits<float>::quiet_NaN();
    // Buckets of the floats by their top bits (sign, exponent, 7 of the mantissa: 1/128 of an
    // octave wide), each with the count of thresholds at or below its least float; a value then
    // steps over the few thresholds inside its bucket: ~3.5 ns a value, where a binary search over
    // all 255 took 6 to 12 ns (10 to 17 ms of an 800 x 600 plot).
    m_below.resize((infinity_bits >> bucket_shift) + 1);
    unsigned count = 0;
    for (std::size_t b = 0; b < m_below.size(); ++b) {
        const float least = std::bit_cast<float>(static_cast<std::uint32_t>(b << bucket_shift));
        while (m_threshold[count] <= least) ++count;
        m_below[b] = static_cast<unsigned char>(count);
    }
}

unsigned char DisplayCodes::operator()(float linear) const {
    if (!(linear > 0.0f)) return 0; // negative, zero or NaN: tone_map's max(0, x)
    unsigned count = m_below[std::bit_cast<std::uint32_t>(linear) >> bucket_shift];
    while (m_threshold[count] <= linear) ++count; // the NaN in the last slot stops it
    return static_cast<unsigned char>(count);
}

ImageFormat output_format(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".png") return ImageFormat::Png;
    if (ext == ".exr") return ImageFormat::Exr;
    throw InputError(cat(path.string(), ": unsupported image extension '", path.extension().string(),
                         "' (expected .png or .exr)"));
}

namespace {

// 8-bit sRGB through libpng's simplified API (the sRGB chunk comes with it).
bool write_png(const Image& image, const std::filesystem::path& file, const ToneOptions& tone, std::string& error) {
    const DisplayCodes code(tone);
    std::vector<std::uint8_t> bytes(image.pixels.size());
    for (std::size_t k = 0; k < bytes.size(); ++k) bytes[k] = code(image.pixels[k]);
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    png.width = static_cast<png_uint_32>(image.width);
    png.height = static_cast<png_uint_32>(image.height);
    png.format = PNG_FORMAT_RGB;
    // No row filters and zlib level 3: 800 x 600 lobe plot 28 -> 7 ms (44 -> 42 kB), a 512 x 512
    // render 31 -> 6 ms (49 -> 77 kB); a preview is looked at, not archived.
    png.flags = PNG_IMAGE_FLAG_FAST;
    const bool ok = png_image_write_to_file(&png, file.c_str(), 0, bytes.data(), 3 * image.width, nullptr) != 0;
    if (!ok) error = png.message;
    png_image_free(&png);
    return ok;
}

// Linear 32-bit float R, G, B, ZIP compressed, Rec.709 chromaticities.
bool write_exr(const Image& image, const std::filesystem::path& file, std::string& error) {
    try {
        Imf::Header header(image.width, image.height);
        header.compression() = Imf::ZIP_COMPRESSION;
        Imf::addChromaticities(header, Imf::Chromaticities());
        header.insert("software", Imf::StringAttribute("brdftool preview"));
        Imf::FrameBuffer frame;
        const char* names[] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c) {
            header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
            // OpenEXR's slices take a non-const base pointer; the writer only reads through it.
            char* base = reinterpret_cast<char*>(const_cast<float*>(image.pixels.data() + c));
            frame.insert(names[c], Imf::Slice(Imf::FLOAT, base, 3 * sizeof(float), 3 * sizeof(float) * image.width));
        }
        Imf::OutputFile out(file.c_str(), header);
        out.setFrameBuffer(frame);
        out.writePixels(image.height);
        return true;
    } catch (const std::exception& e) {
        error = e.what();
        return false;
    }
}

} // namespace

void write_image(const Image& image, const std::filesystem::path& path, const ToneOptions& tone) {
    const ImageFormat format = output_format(path);
    if (image.width <= 0 || image.height <= 0 ||
        image.pixels.size() != static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) * 3)
        throw InputError(cat(path.string(), ": image has no pixels or a wrong pixel count"));
    // Same folder (the rename stays atomic), same extension.
    AtomicFile temp(path, path.extension().string());
    std::string error;
    const bool ok = format == ImageFormat::Exr ? write_exr(image, temp.temporary(), error)
                                               : write_png(image, temp.temporary(), tone, error);
    if (!ok) throw IoError(cat(path.string(), ": cannot write: ", error));
    temp.commit();
}

} // namespace brdf::preview
