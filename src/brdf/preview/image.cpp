#include <brdf/preview/image.h>

#include <brdf/core/atomic_file.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

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

ImageFormat output_format(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".png") return ImageFormat::Png;
    if (ext == ".exr") return ImageFormat::Exr;
    throw InputError(cat(path.string(), ": unsupported image extension '", path.extension().string(),
                         "' (expected .png or .exr)"));
}

void write_image(const Image& image, const std::filesystem::path& path, const ToneOptions& tone) {
    const ImageFormat format = output_format(path);
    if (image.width <= 0 || image.height <= 0 ||
        image.pixels.size() != static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) * 3)
        throw InputError(cat(path.string(), ": image has no pixels or a wrong pixel count"));

    // Same folder (the rename stays atomic), same extension (OpenImageIO picks the format by it).
    AtomicFile temp(path, path.extension().string());
    auto out = OIIO::ImageOutput::create(path.string());
    if (!out) throw IoError(cat(path.string(), ": OpenImageIO cannot write this format: ", OIIO::geterror()));
    OIIO::ImageSpec spec(image.width, image.height, 3,
                         format == ImageFormat::Png ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::FLOAT);
    spec.attribute("Software", "brdftool preview");
    bool ok = false;
    if (format == ImageFormat::Exr) {
        spec.attribute("compression", "zip");
        spec.attribute("oiio:ColorSpace", "Linear");
        ok = out->open(temp.temporary().string(), spec) && out->write_image(OIIO::TypeDesc::FLOAT, image.pixels.data());
    } else {
        spec.attribute("oiio:ColorSpace", "sRGB");
        std::vector<std::uint8_t> bytes(image.pixels.size());
        for (std::size_t k = 0; k < bytes.size(); ++k)
            bytes[k] = static_cast<std::uint8_t>(std::lround(255.0 * srgb_encode(tone_map(image.pixels[k], tone))));
        ok = out->open(temp.temporary().string(), spec) && out->write_image(OIIO::TypeDesc::UINT8, bytes.data());
    }
    ok = out->close() && ok;
    if (!ok) throw IoError(cat(path.string(), ": cannot write: ", out->geterror()));
    out.reset();
    temp.commit();
}

} // namespace brdf::preview
