#pragma once
// Preview pictures: a linear RGB float image, the tone mapping that turns it into a display image, and
// the one writer (libpng and OpenEXR, atomically: temporary name in the same folder, then rename).
// PNG gets exposure + a tone curve + the sRGB transfer function, 8 bits; EXR keeps the linear
// floats. (Not OpenImageIO: linking it loads some 260 libraries, 0.3 s at every start of brdftool.)

#include <array>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace brdf::preview {

using Rgb = std::array<double, 3>;

/// Linear Rec.709 RGB, 32-bit float, row 0 at the top, pixels interleaved r g b.
struct Image {
    int width = 0;
    int height = 0;
    std::vector<float> pixels; ///< width * height * 3 values

    Image() = default;
    Image(int w, int h, const Rgb& fill = {0.0, 0.0, 0.0});
    float* at(int x, int y) { return pixels.data() + 3 * (static_cast<std::size_t>(y) * width + x); }
    const float* at(int x, int y) const { return pixels.data() + 3 * (static_cast<std::size_t>(y) * width + x); }
};

enum class ToneCurve {
    Filmic,   ///< Narkowicz's fit of the ACES filmic curve: gentle shoulder, white 1 maps to 0.8
    Reinhard, ///< x / (1 + x) per channel
    Clamp,    ///< min(x, 1): no curve
};

/// "filmic", "reinhard", "clamp" (InputError otherwise).
ToneCurve parse_tone_curve(const std::string& name);

struct ToneOptions {
    double exposure = 0.0; ///< stops: values are multiplied by 2^exposure before the curve
    ToneCurve curve = ToneCurve::Filmic;
};

/// Display value in [0, 1] (before the sRGB encoding) of a linear value.
double tone_map(double linear, const ToneOptions& options);
/// The sRGB transfer function (IEC 61966-2-1) of a display value in [0, 1].
double srgb_encode(double display);

/// The 8-bit display code of a linear value, lround(255 srgb_encode(tone_map(x))), without a pow
/// and an exp2 per channel (those took 45 ms of an 800 x 600 lobe plot's 80 ms write; now 5): the
/// code does not decrease with x (no curve does), so it is the count of the thresholds
/// x_k = min{x : code(x) >= k}, k = 1 .. 255, at or below x, found once by bisection over the
/// floats. Negative and NaN values code as 0 (tone_map takes them as 0).
class DisplayCodes {
public:
    explicit DisplayCodes(const ToneOptions& tone);
    unsigned char operator()(float linear) const;

private:
    static constexpr int bucket_shift = 16;
    std::array<float, 256> m_threshold{}; ///< m_threshold[k - 1] = x_k, non-decreasing; then NaN
    std::vector<unsigned char> m_below;   ///< per bucket of floats (bits >> bucket_shift): thresholds <= its least
};

enum class ImageFormat { Png, Exr };

/// The format a file name asks for by its extension (.png, .exr; any case). InputError naming the
/// file for any other extension.
ImageFormat output_format(const std::filesystem::path& path);

/// Writes `image` to `path` (format by extension, see output_format): PNG tone-mapped and sRGB
/// encoded, 8 bits per channel; EXR linear 32-bit float, ZIP compressed. The file appears only
/// complete: written under a temporary name in the same folder, then renamed. InputError for a bad
/// extension, IoError when the file cannot be written.
void write_image(const Image& image, const std::filesystem::path& path, const ToneOptions& tone = {});

} // namespace brdf::preview
