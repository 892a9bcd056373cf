// Tone mapping and the OpenImageIO writer.

#include <brdf/preview/image.h>

#include "preview_test_support.h"
#include "test_support.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

namespace brdf::test {
namespace {

TEST(ToneMap, CurvesAreMonotonicAndBounded) {
    for (auto curve : {preview::ToneCurve::Filmic, preview::ToneCurve::Reinhard, preview::ToneCurve::Clamp}) {
        double previous = 0.0;
        for (double x = 0.0; x < 100.0; x = x * 1.3 + 0.01) {
            const double v = preview::tone_map(x, {0.0, curve});
            EXPECT_GE(v, previous);
            EXPECT_LE(v, 1.0);
            previous = v;
        }
    }
    EXPECT_EQ(preview::tone_map(-1.0, {}), 0.0);
    EXPECT_NEAR(preview::tone_map(0.5, {1.0, preview::ToneCurve::Clamp}), 1.0, 1e-12); // +1 stop
    EXPECT_NEAR(preview::srgb_encode(0.0), 0.0, 1e-12);
    EXPECT_NEAR(preview::srgb_encode(1.0), 1.0, 1e-12);
    EXPECT_NEAR(preview::srgb_encode(0.18), 0.4613561, 1e-6); // IEC 61966-2-1
}

// The PNG writer's codes (thresholds found once per image) are the formula's, value for value: on a
// fine logarithmic sweep of each curve's working range, at each of the 255 places where the code
// steps (found between two points of the sweep by bisection over the floats) and the 16 floats on
// either side, and at the special values.
TEST(DisplayCodes, EqualTheToneCurveAndSrgbFormula) {
    const auto formula = [](float x, const preview::ToneOptions& tone) {
        return static_cast<int>(std::lround(255.0 * preview::srgb_encode(preview::tone_map(x, tone))));
    };
    for (auto curve : {preview::ToneCurve::Filmic, preview::ToneCurve::Reinhard, preview::ToneCurve::Clamp})
        for (double exposure : {-2.0, 0.0, 1.5}) {
            const preview::ToneOptions tone{exposure, curve};
            SCOPED_TRACE(testing::Message() << "curve " << static_cast<int>(curve) << ", exposure " << exposure);
            const preview::DisplayCodes code(tone);
            int mismatches = 0, steps = 0;
            const auto check = [&](float x) {
                if (code(x) != formula(x, tone) && ++mismatches <= 5)
                    ADD_FAILURE() << "x = " << x << ": " << int{code(x)} << " against " << formula(x, tone);
            };
            // 1e-7 to 1e4 (times 2^-exposure): code 1 begins near 1.5e-4, Reinhard's 255 near 200.
            constexpr int points = 200000;
            const double scale = std::exp2(-exposure);
            float before = 0.0f;
            for (int i = 0; i <= points; ++i) {
                const float x = static_cast<float>(scale * 1e-7 * std::pow(1e11, static_cast<double>(i) / points));
                check(x);
                if (formula(x, tone) != formula(before, tone)) {
                    ++steps;
                    // The first float after `before` with x's code; its neighbours either side.
                    std::uint32_t lo = std::bit_cast<std::uint32_t>(before), hi = std::bit_cast<std::uint32_t>(x);
                    while (hi - lo > 1) {
                        const std::uint32_t mid = lo + (hi - lo) / 2;
                        (formula(std::bit_cast<float>(mid), tone) == formula(x, tone) ? hi : lo) = mid;
                    }
                    for (std::uint32_t b = hi - 16; b <= hi + 16; ++b) check(std::bit_cast<float>(b));
                }
                before = x;
            }
            EXPECT_EQ(steps, 255) << "each code from 1 to 255 begins once";
            for (float x : {-1.0f, -0.0f, 0.0f, std::numeric_limits<float>::denorm_min(),
                            std::numeric_limits<float>::min(), 1e-30f, 1e30f, std::numeric_limits<float>::max(),
                            std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()})
                check(x);
            EXPECT_EQ(code(std::numeric_limits<float>::quiet_NaN()), 0);
            EXPECT_EQ(mismatches, 0);
        }
}

TEST(WriteImage, PngIsEightBitRgbAndExrIsLinearFloat) {
    preview::Image image(40, 30, {0.25, 0.5, 2.0});
    TempDir dir;
    preview::write_image(image, dir / "a.png");
    preview::write_image(image, dir / "a.EXR");
    const ReadImage png = read_image(dir / "a.png");
    EXPECT_EQ(png.width, 40);
    EXPECT_EQ(png.height, 30);
    EXPECT_EQ(png.channels, 3);
    EXPECT_EQ(png.format, OIIO::TypeDesc::UINT8);
    EXPECT_NEAR(png.at(3, 4, 0), std::round(255.0 * preview::srgb_encode(preview::tone_map(0.25, {}))) / 255.0, 1e-6);
    const ReadImage exr = read_image(dir / "a.EXR");
    EXPECT_EQ(exr.channels, 3);
    EXPECT_EQ(exr.format, OIIO::TypeDesc::FLOAT);
    EXPECT_FLOAT_EQ(exr.at(5, 6, 2), 2.0f);
    // Only the two finished files remain: no temporaries left behind.
    int files = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++files;
    EXPECT_EQ(files, 2);
}

TEST(WriteImage, BadExtensionIsInputErrorAndUnwritableFolderIsIoError) {
    preview::Image image(8, 8);
    TempDir dir;
    EXPECT_THROW(preview::write_image(image, dir / "a.jpg"), InputError);
    EXPECT_THROW(preview::write_image(image, dir / "noext"), InputError);
    EXPECT_THROW(preview::write_image(image, dir / "missing" / "a.png"), IoError);
}

} // namespace
} // namespace brdf::test
