// render_sphere: geometry, lighting direction, the white furnace, the mirror highlight.

#include <brdf/preview/preview.h>
#include <brdf/preview/render.h>

#include "preview_test_support.h"
#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace brdf::test {
namespace {

preview::RenderOptions small(int size = 64) {
    preview::RenderOptions o;
    o.size = size;
    o.threads = 2;
    return o;
}

TEST(RenderSphere, ImageHasRequestedSizeAndBackgroundCorners) {
    preview::RenderOptions o = small(48);
    const preview::Image image = preview::render_sphere(lambertian(), o);
    EXPECT_EQ(image.width, 48);
    EXPECT_EQ(image.height, 48);
    ASSERT_EQ(image.pixels.size(), 48u * 48u * 3u);
    for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(image.at(0, 0)[c], static_cast<float>(o.background[c]));
    for (float v : image.pixels) EXPECT_TRUE(std::isfinite(v));
}

TEST(RenderSphere, LightFromTheLeftLightsTheLeftThird) {
    preview::RenderOptions o = small(96);
    o.light_theta_deg = 90.0;
    o.light_phi_deg = 180.0; // from the left
    const preview::Image image = preview::render_sphere(lambertian(), o);
    const double left = column_mean(image, 0, 32), right = column_mean(image, 64, 96);
    EXPECT_GT(left, 5.0 * right) << "left third " << left << ", right third " << right;
}

TEST(RenderSphere, FrontalLambertianShadingIsCosine) {
    // Light along the view: L = (1/pi) * pi * cos(theta) = n.z at every point.
    preview::RenderOptions o = small(65);
    o.light_theta_deg = 0.0;
    o.light_size_deg = 0.0;
    o.supersample = 1;
    o.margin = 0.0;
    const preview::Image image = preview::render_sphere(lambertian(), o);
    const double radius = 32.5;
    for (int y = 0; y < 65; y += 8)
        for (int x = 0; x < 65; x += 8) {
            const double px = (x + 0.5 - 32.5) / radius, py = (32.5 - (y + 0.5)) / radius;
            const double r2 = px * px + py * py;
            if (r2 >= 1.0) continue;
            EXPECT_NEAR(image.at(x, y)[1], std::sqrt(1.0 - r2), 2e-3) << "pixel " << x << ", " << y;
        }
}

TEST(RenderSphere, WhiteFurnaceIsUniform) {
    // A conservative semi-infinite medium reflects all light (plane albedo 1 for every incidence), so
    // under a uniform environment every point of the sphere has the environment's radiance. Measured
    // within 3e-4 of 1 (draft streams, the 24 x 13 BRDF grid, the 8 x 16 local rule); 1% leaves room for
    // solver changes while still catching a wrong frame, weight or phi convention.
    const model::SolvedMaterial white = solve_text(
        R"({"name": "furnace", "medium": {"albedo": 1.0, "phase": "isotropic"}, "surface": "none",
            "spectrum": "rgb", "accuracy": "draft"})");
    preview::RenderOptions o = small(64);
    o.light_irradiance = 0.0;
    o.environment = preview::Environment::Constant;
    o.environment_radiance = 1.0;
    const preview::Image image = preview::render_material(white, o);
    const double centre = 32.0, radius = 32.0 * (1.0 - 2.0 * o.margin);
    int inside = 0;
    double lo = 1e9, hi = -1e9;
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x) {
            const double px = (x + 0.5 - centre) / radius, py = (y + 0.5 - centre) / radius;
            if (px * px + py * py > 0.93 * 0.93) continue; // pixels fully inside the disc
            ++inside;
            for (int c = 0; c < 3; ++c) {
                lo = std::min(lo, static_cast<double>(image.at(x, y)[c]));
                hi = std::max(hi, static_cast<double>(image.at(x, y)[c]));
                EXPECT_REL_NEAR(image.at(x, y)[c], 1.0, 0.01) << "pixel " << x << ", " << y;
            }
        }
    EXPECT_GT(inside, 2000);
    EXPECT_LT(hi - lo, 0.01) << "min " << lo << ", max " << hi;
}

TEST(RenderSphere, MirrorAddsAHighlightOnlyWithAnInterface) {
    preview::RenderOptions o = small(128);
    o.light_theta_deg = 40.0;
    o.light_phi_deg = 90.0; // from above: the glint sits on the upper half
    o.light_size_deg = 6.0;
    const preview::Image diffuse = preview::render_sphere(lambertian(0.5), o);
    o.mirror = [](double) { return preview::Rgb{0.04, 0.04, 0.04}; };
    const preview::Image glossy = preview::render_sphere(lambertian(0.5), o);
    double brightest = 0.0, brightest_diffuse = 0.0;
    int by = 0;
    for (int y = 0; y < 128; ++y)
        for (int x = 0; x < 128; ++x) {
            brightest_diffuse = std::max(brightest_diffuse, static_cast<double>(diffuse.at(x, y)[0]));
            if (glossy.at(x, y)[0] > brightest) {
                brightest = glossy.at(x, y)[0];
                by = y;
            }
        }
    EXPECT_GT(brightest, 2.0 * brightest_diffuse);
    EXPECT_LT(by, 64) << "the glint of a light from above is on the upper half";
}

// render_material draws a rough top's first-surface lobe: a gloss finish gets a bright, small
// highlight on the upper half (light from above), a matte one of the same paint a dim, wide one; a
// surface without an interface none.
TEST(RenderMaterial, RoughSurfaceDrawsItsLobe) {
    const auto peak = [](const std::string& surface, int& at_y, int& bright_pixels) {
        const model::SolvedMaterial m = solve_text(
            R"({"name": "p", "medium": {"albedo": 0.9, "index": 1.5}, "surface": )" + surface +
            R"(, "spectrum": "rgb", "accuracy": "draft"})");
        preview::RenderOptions o = small(96);
        o.light_theta_deg = 40.0;
        o.light_phi_deg = 90.0;
        const preview::Image image = preview::render_material(m, o);
        double best = 0.0;
        for (int y = 0; y < 96; ++y)
            for (int x = 0; x < 96; ++x)
                if (image.at(x, y)[1] > best) best = image.at(x, y)[1], at_y = y;
        bright_pixels = 0;
        for (int y = 0; y < 96; ++y)
            for (int x = 0; x < 96; ++x) bright_pixels += image.at(x, y)[1] > 0.5 * best;
        return best;
    };
    int y_gloss = 0, y_matte = 0, y_none = 0, n_gloss = 0, n_matte = 0, n_none = 0;
    const double gloss = peak(R"({"roughness": 0.05})", y_gloss, n_gloss);
    const double matte = peak(R"("matte")", y_matte, n_matte);
    const double none = peak(R"("none")", y_none, n_none);
    EXPECT_GT(gloss, 3.0 * matte);
    EXPECT_GT(gloss, 3.0 * none);
    EXPECT_LT(y_gloss, 48) << "the highlight of a light from above is on the upper half";
    EXPECT_LT(n_gloss, n_matte) << "the gloss highlight is the smaller one";
}

TEST(RenderSphere, RejectsBadOptions) {
    preview::RenderOptions o = small();
    o.size = 2;
    EXPECT_THROW(preview::render_sphere(lambertian(), o), InputError);
    o = small();
    o.light_theta_deg = 200.0;
    EXPECT_THROW(preview::render_sphere(lambertian(), o), InputError);
    EXPECT_THROW(preview::parse_environment("studio"), InputError);
}

TEST(RenderSphere, TabulatedBrdfMatchesTheFunction) {
    // A smooth BRDF: the grid interpolation must reproduce it to well under the look of a preview.
    const preview::BrdfFunction f = [](double ti, double to, double phi) {
        const double v = 0.2 + 0.1 * std::cos(ti) * std::cos(to) + 0.05 * std::cos(phi);
        return preview::Rgb{v, v, v};
    };
    const preview::BrdfFunction t = preview::tabulate_brdf(f, 30, 25, 2);
    for (double ti : {0.1, 0.5, 1.0, 1.4})
        for (double to : {0.05, 0.7, 1.3})
            for (double phi : {0.0, 1.0, 3.0, -2.0}) EXPECT_NEAR(t(ti, to, phi)[0], f(ti, to, phi)[0], 2e-3);
}

// The tabulated body is looked up once per sub-pixel at the light disc's cosine-weighted centroid,
// the cosine and the horizon integrated sample by sample. Against the exact BRDF at every one of
// the disc's samples (theta_nodes 0: the BRDF as given), beside the table looked up at every
// sample, for a BRDF with azimuthal structure and a light along the view (the disc holds the
// normal: phi degenerates) or at 60 degrees (the terminator crosses the sphere). The table's own
// interpolation dominates (0.4-12 % here, at grazing); the centroid moves the image by less than
// one step of an 8-bit PNG from the table at each sample, also for a 10-degree disc, and adds
// less than half a step to the table's error.
TEST(RenderSphere, DiscCentroidLookupMatchesSampleBySample) {
    const preview::BrdfFunction f = [](double ti, double to, double phi) {
        const double v = 0.2 + 0.15 * std::cos(phi) * std::sin(ti) * std::sin(to) + 0.1 * std::cos(ti) * std::cos(ti);
        return preview::Rgb{v, 0.5 * v, 0.25 * v};
    };
    for (double size : {2.0, 10.0})
        for (double light : {0.0, 60.0}) {
            preview::RenderOptions centroid = small(96);
            centroid.light_theta_deg = light;
            centroid.light_size_deg = size;
            preview::RenderOptions each = centroid;
            each.theta_nodes = each.phi_nodes = 0;
            const preview::Image exact = preview::render_sphere(f, each);
            const preview::Image once = preview::render_sphere(f, centroid);
            const preview::Image table = preview::render_sphere(
                preview::tabulate_brdf(f, centroid.theta_nodes, centroid.phi_nodes, 2), each);
            double brightest = 0.0;
            for (float v : exact.pixels) brightest = std::max(brightest, static_cast<double>(v));
            const auto largest = [&](const preview::Image& image, const preview::Image& from) {
                double worst = 0.0;
                for (std::size_t k = 0; k < image.pixels.size(); ++k)
                    worst = std::max(worst, std::abs(image.pixels[k] - from.pixels[k]) / brightest);
                return worst;
            };
            const double e_once = largest(once, exact), e_table = largest(table, exact), apart = largest(once, table);
            std::printf("%2.0f-degree disc at %2.0f degrees, of the brightest pixel: against the exact BRDF at each "
                        "sample, centroid %.2e, table at each sample %.2e; the two apart %.2e\n",
                        size, light, e_once, e_table, apart);
            EXPECT_GT(brightest, 0.1);
            EXPECT_LT(apart, 1.0 / 255.0) << size << " " << light;
            EXPECT_LT(e_once, e_table + 0.5 / 255.0) << size << " " << light;
        }
}

TEST(WritePreview, WritesA256PixelPng) {
    const model::SolvedMaterial m = solve_text(
        R"({"name": "orange", "medium": {"albedo": [0.9, 0.6, 0.3], "index": 1.5}, "surface": "smooth",
            "accuracy": "draft"})");
    TempDir dir;
    preview::write_preview(m, dir / "orange.png");
    const ReadImage image = read_image(dir / "orange.png");
    EXPECT_EQ(image.width, 256);
    EXPECT_EQ(image.height, 256);
    EXPECT_EQ(image.channels, 3);
    EXPECT_EQ(image.format, OIIO::TypeDesc::UINT8);
    EXPECT_THROW(preview::write_preview(m, dir / "orange.jpg"), InputError);
}

} // namespace
} // namespace brdf::test
