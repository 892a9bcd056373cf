// Tone mapping and the OpenImageIO writer.

#include <brdf/preview/image.h>

#include "preview_test_support.h"
#include "test_support.h"

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
