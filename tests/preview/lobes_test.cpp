// plot_lobes: where the ink goes.

#include <brdf/preview/lobes.h>

#include "preview_test_support.h"
#include "test_support.h"

namespace brdf::test {
namespace {

/// Pixels that differ between two plots, in columns [x0, x1).
int changed(const preview::Image& a, const preview::Image& b, int x0, int x1) {
    int n = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = x0; x < x1; ++x)
            for (int c = 0; c < 3; ++c)
                if (std::abs(a.at(x, y)[c] - b.at(x, y)[c]) > 0.05f) {
                    ++n;
                    break;
                }
    return n;
}

TEST(PlotLobes, ForwardScattererPutsMoreInkOnTheMirrorSide) {
    // Henyey-Greenstein g = 0.9 scatters forward: in the plane of incidence the lobe leans to the
    // mirror side (phi = 180, drawn on the right). Ink is counted as the difference to the same plot
    // of a zero BRDF (same axes, legend and incidence ray).
    const model::SolvedMaterial hg = solve_text(
        R"({"name": "forward", "medium": {"albedo": 0.9, "phase": {"type": "henyey_greenstein", "g": 0.9}},
            "surface": "none", "accuracy": "draft"})");
    const preview::BrdfFunction f = [&hg](double ti, double to, double phi) { return hg.brdf(ti, to, phi); };
    const preview::BrdfFunction zero = [](double, double, double) { return preview::Rgb{0.0, 0.0, 0.0}; };
    for (bool log_scale : {false, true}) {
        preview::LobeOptions o;
        o.width = 600;
        o.log_scale = log_scale;
        const preview::Image plot = preview::plot_lobes({{"HG 0.9", f, 60.0, {}}}, o);
        const preview::Image empty = preview::plot_lobes({{"HG 0.9", zero, 60.0, {}}}, o);
        ASSERT_EQ(plot.height, empty.height);
        const int retro = changed(plot, empty, 0, plot.width / 2);
        const int mirror = changed(plot, empty, plot.width / 2, plot.width);
        EXPECT_GT(mirror, retro) << (log_scale ? "log" : "linear") << " plot: mirror side " << mirror
                                 << " pixels, retro side " << retro;
        EXPECT_GT(mirror, 200);
    }
}

TEST(PlotLobes, LegendGrowsWithCurvesAndEachCurveHasItsColour) {
    preview::LobeOptions o;
    const auto one = preview::plot_lobes({{"A", lambertian(), 30.0, {}}}, o);
    const auto three = preview::plot_lobes(
        {{"A", lambertian(), 30.0, {}}, {"B", lambertian(0.5), 30.0, {}}, {"C", lambertian(0.2), 60.0, {}}}, o);
    EXPECT_EQ(one.width, 800);
    EXPECT_GT(three.height, one.height);
    // Each palette colour appears somewhere.
    for (std::size_t k = 0; k < 3; ++k) {
        const preview::Rgb c = preview::lobe_colour(k);
        bool found = false;
        for (int y = 0; y < three.height && !found; ++y)
            for (int x = 0; x < three.width && !found; ++x) {
                const float* p = three.at(x, y);
                found = std::abs(p[0] - c[0]) < 1e-3 && std::abs(p[1] - c[1]) < 1e-3 && std::abs(p[2] - c[2]) < 1e-3;
            }
        EXPECT_TRUE(found) << "palette colour " << k;
    }
}

TEST(PlotLobes, RejectsBadInput) {
    preview::LobeOptions o;
    EXPECT_THROW(preview::plot_lobes({}, o), InputError);
    EXPECT_THROW(preview::plot_lobes({{"A", lambertian(), 95.0, {}}}, o), InputError);
    o.width = 10;
    EXPECT_THROW(preview::plot_lobes({{"A", lambertian(), 30.0, {}}}, o), InputError);
}

} // namespace
} // namespace brdf::test
