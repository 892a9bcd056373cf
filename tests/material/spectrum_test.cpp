// Spectral sets and colour weights, against tests/reference/material/spectral_weights.py.

#include <brdf/core/error.h>
#include <brdf/material/spectrum.h>

#include "reference_data.h"
#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace brdf::material {
namespace {

std::vector<double> ones(std::size_t n) {
    return std::vector<double>(n, 1.0);
}

int largest_channel(const Rgb& rgb) {
    return static_cast<int>(std::max_element(rgb.begin(), rgb.end()) - rgb.begin());
}

template <typename E, typename F> std::string message_of(F&& f) {
    try {
        f();
    } catch (const E& e) {
        return e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << "threw another exception type: " << e.what();
        return {};
    }
    ADD_FAILURE() << "did not throw";
    return {};
}

// Weights against the Python reference: absolute 1e-14 (the largest weights are ~0.1; sums of ~80
// terms in a different order differ by a few ulp).
void expect_weights(const SpectralSet& set, const std::string& reference) {
    const auto rows = test::read_reference_csv(reference);
    ASSERT_EQ(rows.size(), set.size());
    for (std::size_t j = 0; j < set.size(); ++j) {
        ASSERT_EQ(rows[j].size(), 7u);
        EXPECT_EQ(set.wavelengths_nm()[j], std::stod(rows[j][0]));
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(set.xyz_weights()[j][c], std::stod(rows[j][1 + c]), 1e-14)
                << reference << " row " << j << " xyz " << c;
            EXPECT_NEAR(set.rgb_weights()[j][c], std::stod(rows[j][4 + c]), 1e-14)
                << reference << " row " << j << " rgb " << c;
        }
    }
}

TEST(ColourCieTables, AreTheEmbeddedFiveNanometreTables) {
    const CieTables& t = cie_tables();
    ASSERT_EQ(t.wavelength_nm.size(), 95u); // 360..830 in 5 nm steps
    EXPECT_EQ(t.wavelength_nm.front(), 360.0);
    EXPECT_EQ(t.wavelength_nm.back(), 830.0);
    EXPECT_EQ(t.ybar[(555 - 360) / 5], 1.0);  // photopic peak
    EXPECT_EQ(t.d65[(560 - 360) / 5], 100.0); // D65 normalisation
    EXPECT_EQ(t.xbar[(600 - 360) / 5], 1.0622);
}

TEST(SpectrumVisible, Has41WavelengthsAndMatchesTheReferenceWeights) {
    const SpectralSet v = SpectralSet::visible();
    EXPECT_EQ(v.kind(), SpectralSet::Kind::Visible);
    EXPECT_EQ(v.name(), "visible");
    ASSERT_EQ(v.size(), 41u);
    for (std::size_t j = 0; j < v.size(); ++j) EXPECT_EQ(v.wavelengths_nm()[j], 380.0 + 10.0 * j);
    expect_weights(v, "spectral_weights_visible.csv");
    const auto balance = test::read_summary_values("white_balance");
    ASSERT_EQ(balance.size(), 3u);
    for (int c = 0; c < 3; ++c) {
        EXPECT_REL_NEAR(v.white_balance()[c], balance[c], 1e-13);
        EXPECT_NEAR(v.white_balance()[c], 1.0, 3e-4); // as documented in spectrum.h
    }
}

TEST(SpectrumVisible, WhiteIsExactlyOneOneOne) {
    const SpectralSet v = SpectralSet::visible();
    const Rgb white = v.to_rgb(ones(v.size()));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(white[c], 1.0, 1e-12) << c;
    const Rgb grey = v.to_rgb(std::vector<double>(v.size(), 0.18));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(grey[c], 0.18, 1e-12) << c;
    EXPECT_NEAR(v.to_xyz(ones(v.size()))[1], 1.0, 1e-12); // Y of white = 1
}

// The D65 white of the 5 nm tables: (0.3127, 0.3290) to the tables' precision (the tables give
// 0.312721, 0.329031; the reference script computes the same sums).
TEST(ColourD65, WhiteChromaticity) {
    const SpectralSet v = SpectralSet::visible();
    const Chromaticity xy = chromaticity(v.to_xyz(ones(v.size())));
    EXPECT_NEAR(xy.x, 0.3127, 5e-5);
    EXPECT_NEAR(xy.y, 0.3290, 5e-5);
    const auto reference = test::read_summary_values("white_xy");
    ASSERT_EQ(reference.size(), 2u);
    EXPECT_REL_NEAR(xy.x, reference[0], 1e-13);
    EXPECT_REL_NEAR(xy.y, reference[1], 1e-13);
    // The IEC matrix turns the Rec.709 white into (1, 1, 1) to its 4-digit rounding.
    const double x = 0.3127, y = 0.3290;
    const Rgb w = xyz_to_linear_rec709({x / y, 1.0, (1.0 - x - y) / y});
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(w[c], 1.0, 2e-4);
}

// A reflectance that is 1 at one solved wavelength and 0 at the others (a 20 nm wide hat) lands in
// the primary of its hue.
TEST(ColourNarrowBand, LandsInTheRightPrimary) {
    const SpectralSet v = SpectralSet::visible();
    auto hat = [&](double nm) {
        std::vector<double> r(v.size(), 0.0);
        r[static_cast<std::size_t>((nm - 380.0) / 10.0)] = 1.0;
        return v.to_rgb(r);
    };
    for (double nm : {440.0, 450.0, 460.0}) EXPECT_EQ(largest_channel(hat(nm)), 2) << nm;
    for (double nm : {520.0, 530.0, 540.0, 550.0}) EXPECT_EQ(largest_channel(hat(nm)), 1) << nm;
    for (double nm : {610.0, 620.0, 650.0}) EXPECT_EQ(largest_channel(hat(nm)), 0) << nm;
    // Spectral colours lie outside the Rec.709 gamut: some channel is negative for pure green.
    const Rgb green = hat(520.0);
    EXPECT_LT(std::min({green[0], green[2]}), 0.0);
    // The eye barely sees at 780 nm: a tiny, positive red weight.
    const Rgb edge = hat(780.0);
    EXPECT_GT(edge[0], 0.0);
    EXPECT_LT(edge[0], 1e-4);
}

// A linear ramp is reproduced exactly by the piecewise-linear rule, so 10 nm sampling equals the 1
// nm reference; a smooth bump (Gaussian, sigma 40 nm) agrees to the interpolation error.
TEST(ColourSmoothSpectra, AgreeWithOneNanometreIntegration) {
    const SpectralSet v = SpectralSet::visible();
    std::vector<double> ramp, bump;
    for (double nm : v.wavelengths_nm()) {
        ramp.push_back(0.2 + 0.6 * (nm - 380.0) / 400.0);
        bump.push_back(0.1 + 0.8 * std::exp(-0.5 * std::pow((nm - 530.0) / 40.0, 2)));
    }
    const auto ramp_ref = test::read_summary_values("ramp_1nm_rgb");
    const auto bump_ref = test::read_summary_values("bump_1nm_rgb");
    ASSERT_EQ(ramp_ref.size(), 3u);
    ASSERT_EQ(bump_ref.size(), 3u);
    const Rgb r = v.to_rgb(ramp), b = v.to_rgb(bump);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(r[c], ramp_ref[c], 1e-12) << c;
        EXPECT_NEAR(b[c], bump_ref[c], 3e-3) << c;
    }
    // The same through the helper for arbitrary spectra, on a 1 nm grid.
    std::vector<double> fine, fine_ramp;
    for (int nm = 380; nm <= 780; ++nm) {
        fine.push_back(nm);
        fine_ramp.push_back(0.2 + 0.6 * (nm - 380.0) / 400.0);
    }
    const Rgb h = reflectance_to_rgb(fine, fine_ramp);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(h[c], ramp_ref[c], 1e-12) << c;
    const Tristimulus xyz = reflectance_to_xyz(fine, ones(fine.size()));
    EXPECT_NEAR(xyz[1], 1.0, 1e-12);
}

TEST(SpectrumRgb, ThreeDominantWavelengthsWithIdentityWeights) {
    const SpectralSet s = SpectralSet::rgb();
    EXPECT_EQ(s.kind(), SpectralSet::Kind::RgbWavelengths);
    EXPECT_EQ(s.name(), "rgb");
    ASSERT_EQ(s.size(), 3u);
    EXPECT_EQ(std::vector<double>(s.wavelengths_nm().begin(), s.wavelengths_nm().end()),
              (std::vector<double>{464.0, 549.0, 611.0}));
    // The choice: the dominant wavelengths of the Rec.709 primaries, rounded.
    EXPECT_EQ(std::round(test::read_summary_values("dominant_wavelength_blue").at(0)), 464.0);
    EXPECT_EQ(std::round(test::read_summary_values("dominant_wavelength_green").at(0)), 549.0);
    EXPECT_EQ(std::round(test::read_summary_values("dominant_wavelength_red").at(0)), 611.0);
    // Values are given in wavelength order (blue, green, red) and come out as r, g, b.
    const Rgb rgb = s.to_rgb(std::vector<double>{0.1, 0.2, 0.3});
    EXPECT_EQ(rgb, (Rgb{0.3, 0.2, 0.1}));
    const Rgb white = s.to_rgb(ones(3));
    EXPECT_EQ(white, (Rgb{1.0, 1.0, 1.0}));
    // xyz weights are M^-1 applied to the identity: back through M they give the identity.
    for (std::size_t j = 0; j < 3; ++j) {
        const Rgb back = xyz_to_linear_rec709(s.xyz_weights()[j]);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(back[c], s.rgb_weights()[j][c], 1e-14);
    }
}

TEST(SpectrumExplicit, WeightsMatchTheReference) {
    const std::vector<double> wl{450.0, 500.5, 610.0, 700.0};
    const SpectralSet s = SpectralSet::from_wavelengths(wl);
    EXPECT_EQ(s.kind(), SpectralSet::Kind::Explicit);
    EXPECT_EQ(s.name(), "wavelengths");
    expect_weights(s, "spectral_weights_explicit.csv");
    const Rgb white = s.to_rgb(ones(4));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(white[c], 1.0, 1e-12);
}

// Outside the listed wavelengths R is held constant, so one wavelength carries the whole white.
TEST(SpectrumExplicit, OneWavelengthCarriesEverything) {
    for (double nm : {550.0, 1000.0}) {
        const SpectralSet s = SpectralSet::from_wavelengths(std::vector<double>{nm});
        ASSERT_EQ(s.size(), 1u);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.rgb_weights()[0][c], 1.0, 1e-12) << nm;
    }
}

// Every colour space has one weight per wavelength, for every kind of set (values: colour_test.cpp).
TEST(SpectrumColourSpaces, EverySetHasWeightsInEverySpace) {
    for (const SpectralSet& s : {SpectralSet::visible(), SpectralSet::rgb(),
                                 SpectralSet::from_wavelengths(std::vector<double>{500.0, 600.0})})
        for (ColorSpace space : {ColorSpace::Rec709, ColorSpace::AcesCg, ColorSpace::Rec2020})
            EXPECT_EQ(s.rgb_weights(space).size(), s.size()) << s.name();
}

TEST(SpectrumExplicit, ValidationMessages) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(wavelength_list_problems(std::vector<double>{500.0, 450.0, 3000.0, nan, 600.0, 600.0},
                                       "spectrum.wavelengths_nm"),
              (std::vector<std::string>{
                  "spectrum.wavelengths_nm[1]: 450 nm is not greater than "
                  "spectrum.wavelengths_nm[0] = 500 nm (list the wavelengths in increasing order, "
                  "without repeats)",
                  "spectrum.wavelengths_nm[2]: must be within 200-2500 nm (got 3000)",
                  "spectrum.wavelengths_nm[3]: must be a finite wavelength > 0 nm (got nan)",
                  "spectrum.wavelengths_nm[5]: 600 nm is not greater than "
                  "spectrum.wavelengths_nm[4] = 600 nm (list the wavelengths in increasing order, "
                  "without repeats)",
              }));
    EXPECT_EQ(message_of<InputError>([] { SpectralSet::from_wavelengths({}); }),
              "wavelengths_nm: needs at least one wavelength");
    EXPECT_EQ(message_of<InputError>([] {
                  SpectralSet::from_wavelengths(std::vector<double>{150.0, 500.0});
              }),
              "wavelengths_nm[0]: must be within 200-2500 nm (got 150)");
    std::vector<double> many;
    for (int i = 0; i <= 1000; ++i) many.push_back(300.0 + 0.5 * i);
    EXPECT_EQ(message_of<LimitError>([&] { SpectralSet::from_wavelengths(many); }),
              "wavelengths_nm: 1001 wavelengths exceed the limit of 1000");
    many.pop_back();
    EXPECT_EQ(SpectralSet::from_wavelengths(many).size(), 1000u);
    const SpectralSet v = SpectralSet::visible();
    EXPECT_EQ(message_of<InputError>([&] { v.to_rgb(ones(3)); }),
              "SpectralSet visible: 3 values for 41 wavelengths");
    EXPECT_EQ(message_of<InputError>([&] { v.to_rgb(ones(3), ColorSpace::AcesCg); }),
              "SpectralSet visible: 3 values for 41 wavelengths");
}

} // namespace
} // namespace brdf::material
