// make_rgl_bsdf and the evaluator: the warp's inverse pair, the NDF the power iteration recovers
// (against GGX, whose sigma is known in closed form), exactness at the nodes, accuracy at the
// resolutions the Mitsuba check uses, albedo, and agreement with Mitsuba's own values (checked in
// by tests/reference/formats/mitsuba_measured_check.py --write-reference).

#include "format_test_util.h"
#include "rgl_test_brdfs.h"
#include "rgl_test_files.h"
#include "test_support.h"

#include <formats/rgl/rgl_build.h>
#include <formats/rgl/rgl_eval.h>
#include <formats/rgl/rgl_warp.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>
#include <brdf/core/version.h>

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>

namespace brdf::formats {
namespace {

constexpr double pi = std::numbers::pi;

using test::RglTestModel;

// --- the warp ------------------------------------------------------------------------------------

rgl::PiecewiseLinearWarp bumpy_warp(bool normalize) {
    // 5 x 4 grid, two slices for a parameter at nodes 0 and 1.
    std::vector<float> data;
    for (int s = 0; s < 2; ++s)
        for (int y = 0; y < 4; ++y)
            for (int x = 0; x < 5; ++x)
                data.push_back(0.2f + static_cast<float>((x * 7 + y * 3 + s * 5) % 11));
    return rgl::PiecewiseLinearWarp(data, 5, 4, {{0.0f, 1.0f}}, normalize, true);
}

TEST(RglWarp, SampleAndInvertAreInverses) {
    for (bool normalize : {true, false}) {
        const auto warp = bumpy_warp(normalize);
        std::mt19937 rng(5);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        for (int k = 0; k < 1000; ++k) {
            const float param = u(rng);
            const rgl::Point2f s{u(rng), u(rng)};
            const auto [p, density] = warp.sample(s, &param);
            const auto [back, density2] = warp.invert(p, &param);
            // Float rounding, amplified where the density is small.
            EXPECT_NEAR(back.x, s.x, 1e-4f);
            EXPECT_NEAR(back.y, s.y, 1e-4f);
            EXPECT_NEAR(density, density2, 1e-4f * density);
            EXPECT_NEAR(density, warp.eval(p, &param), 1e-4f * density);
        }
    }
}

TEST(RglWarp, NormalisedDensityIntegratesToOne) {
    const auto warp = bumpy_warp(true);
    // The interpolant is bilinear per patch: a 2-point Gauss rule per patch and axis is exact.
    const auto rule = gauss_legendre(2, 0.0, 1.0);
    for (float param : {0.0f, 0.3f, 1.0f}) {
        double integral = 0.0;
        for (int py = 0; py < 3; ++py)
            for (int px = 0; px < 4; ++px)
                for (std::size_t a = 0; a < 2; ++a)
                    for (std::size_t b = 0; b < 2; ++b) {
                        const rgl::Point2f p{static_cast<float>((px + rule.x[a]) / 4.0),
                                             static_cast<float>((py + rule.x[b]) / 3.0)};
                        integral += warp.eval(p, &param) * rule.w[a] * rule.w[b] / 12.0;
                    }
        EXPECT_NEAR(integral, 1.0, 1e-6) << "param " << param;
    }
}

// --- the builder -----------------------------------------------------------------------------------

double ggx_d(double cos_h, double alpha) {
    const double t = cos_h * cos_h * (alpha * alpha - 1.0) + 1.0;
    return alpha * alpha / (pi * t * t);
}
double ggx_lambda(double cos_t, double alpha) {
    const double tan2 = std::max(1.0 - cos_t * cos_t, 0.0) / (cos_t * cos_t);
    return 0.5 * (std::sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}

// A microfacet BRDF whose retro-reflection is exactly the one the paper's NDF equation assumes:
// G(wi, wo) = 1 / (1 + max(Lambda(wi), Lambda(wo))) is G1 when wi = wo.
RglBrdfCallback ggx_retro_consistent(double alpha, double f0) {
    return [=](const Vec3& wi, const Vec3& wo, std::vector<double>& out) {
        Vec3 h{wi.x + wo.x, wi.y + wo.y, wi.z + wo.z};
        const double len = std::sqrt(h.x * h.x + h.y * h.y + h.z * h.z);
        const double g =
            1.0 / (1.0 + std::max(ggx_lambda(wi.z, alpha), ggx_lambda(wo.z, alpha)));
        out.assign(3, f0 * ggx_d(h.z / len, alpha) * g / (4.0 * wi.z * wo.z));
    };
}

TEST(RglBuild, PowerIterationRecoversTheGgxNdfAndItsProjectedArea) {
    constexpr double alpha = 0.3;
    RglOptions options;
    options.theta_i_count = 2;
    options.sample_resolution = 2;
    const RglBsdf b = make_rgl_bsdf(ggx_retro_consistent(alpha, 0.5), options);
    const std::size_t n = b.ndf.shape[1];
    for (std::size_t k = 0; k + 1 < n; ++k) {
        const double u = static_cast<double>(k) / (n - 1), theta = u * u * pi / 2;
        if (theta > 80.0 * pi / 180.0) break;
        EXPECT_REL_NEAR(b.ndf.values[k], ggx_d(std::cos(theta), alpha), 5e-4) << "theta " << theta;
        EXPECT_EQ(b.ndf.values[k], b.ndf.values[n + k]); // two equal azimuth rows
    }
    // sigma(w) = cos(theta) (1 + Lambda(theta)) for GGX (Heitz 2014, eq. 2 with Smith's G1).
    const std::size_t m = b.sigma.shape[1];
    for (std::size_t k = 0; k < m; ++k) {
        const double u = static_cast<double>(k) / (m - 1), theta = u * u * pi / 2;
        const double expected = k + 1 < m ? std::cos(theta) * (1.0 + ggx_lambda(std::cos(theta), alpha))
                                          : alpha / 2.0; // the horizon limit of cos (1 + Lambda)
        EXPECT_REL_NEAR(b.sigma.values[k], expected, 2e-4) << "theta " << theta;
    }
}

TEST(RglBuild, ExactAtTheNodes) {
    RglOptions options = test::rgl_case_options(test::rgl_resolutions[1], false);
    const auto brdf = test::rgl_test_brdf(RglTestModel::Glossy, {});
    const RglBsdf b = make_rgl_bsdf(brdf, options);
    const RglEvaluator e(b);
    const rgl::PiecewiseLinearWarp warp(b.vndf.values, static_cast<std::uint32_t>(b.vndf.shape[3]),
                                        static_cast<std::uint32_t>(b.vndf.shape[2]),
                                        {b.phi_i, b.theta_i}, true, true);
    const int n = options.sample_resolution;
    std::vector<double> reference;
    int checked = 0;
    for (std::size_t t = 0; t < b.theta_i.size(); t += 3) {
        const double theta_i = b.theta_i[t];
        const Vec3 wi{std::sin(theta_i), 0.0, std::cos(theta_i)};
        const float params[2] = {0.0f, b.theta_i[t]};
        for (int y = 1; y < n - 1; y += 2)
            for (int x = 1; x < n - 1; x += 2) {
                const rgl::Point2f s{static_cast<float>(x) / (n - 1), static_cast<float>(y) / (n - 1)};
                const rgl::Point2f u = warp.sample(s, params).first;
                const double tm = double{u.x} * u.x * pi / 2, pm = (2.0 * u.y - 1.0) * pi;
                const Vec3 m{std::sin(tm) * std::cos(pm), std::sin(tm) * std::sin(pm), std::cos(tm)};
                const double c = wi.x * m.x + wi.z * m.z;
                const Vec3 wo{2 * c * m.x - wi.x, 2 * c * m.y, 2 * c * m.z - wi.z};
                if (c <= 0.0 || wo.z < 0.05) continue;
                brdf(wi, wo, reference);
                const std::vector<double> value = e.eval_cosine(wi, wo);
                for (int ch = 0; ch < 3; ++ch)
                    EXPECT_REL_NEAR(value[ch], reference[ch] * wo.z, 5e-5)
                        << "theta_i " << theta_i << " node " << x << ", " << y;
                ++checked;
            }
    }
    EXPECT_GT(checked, 200);
}

struct AccuracyCase {
    RglTestModel model;
    std::size_t resolution; ///< index into rgl_resolutions
};

class RglAccuracy : public ::testing::TestWithParam<AccuracyCase> {};

// The thresholds of the Mitsuba check, on our evaluator (which agrees with Mitsuba to float
// rounding: RglMitsubaReference below), at 2000 cosine-weighted pairs, for each model at the
// lowest resolution the check holds it to.
TEST_P(RglAccuracy, MedianAndP95WithinTheThresholds) {
    const auto [model, resolution] = GetParam();
    ASSERT_TRUE(test::rgl_enforced(model, test::rgl_resolutions[resolution]));
    for (bool spectral : {false, true}) {
        const RglOptions options = test::rgl_case_options(test::rgl_resolutions[resolution], spectral);
        const auto brdf = test::rgl_test_brdf(model, options.wavelengths_nm);
        const RglEvaluator e(make_rgl_bsdf(brdf, options));
        const auto stats = test::rgl_accuracy(e, brdf, test::random_direction_pairs(2000, 7));
        EXPECT_LE(stats.median, 0.01) << test::to_string(model) << (spectral ? " spectral" : " rgb");
        EXPECT_LE(stats.p95, 0.05) << test::to_string(model) << (spectral ? " spectral" : " rgb");
    }
}

INSTANTIATE_TEST_SUITE_P(Models, RglAccuracy,
                         ::testing::Values(AccuracyCase{RglTestModel::Lambertian, 1},
                                           AccuracyCase{RglTestModel::Glossy, 1},
                                           AccuracyCase{RglTestModel::Retro, 2}),
                         [](const ::testing::TestParamInfo<AccuracyCase>& param_info) {
                             return cat(test::to_string(param_info.param.model), "_",
                                        test::rgl_resolutions[param_info.param.resolution].name);
                         });

// Directional albedo of a Lambertian file: int f cos dw = rho, by quadrature of eval_cosine.
TEST(RglBuild, LambertianAlbedoIsKept) {
    const auto brdf = test::rgl_test_brdf(RglTestModel::Lambertian, {});
    const RglEvaluator e(make_rgl_bsdf(brdf, test::rgl_case_options(test::rgl_resolutions[1], false)));
    const auto mu = gauss_legendre(64, 0.0, 1.0);
    for (double theta_i_deg : {0.0, 30.0, 60.0}) {
        const double ti = theta_i_deg * pi / 180.0;
        const Vec3 wi{std::sin(ti), 0.0, std::cos(ti)};
        double albedo = 0.0;
        constexpr int phis = 128;
        for (std::size_t q = 0; q < mu.size(); ++q)
            for (int k = 0; k < phis; ++k) {
                const double z = mu.x[q], s = std::sqrt(1.0 - z * z), phi = 2 * pi * (k + 0.5) / phis;
                const Vec3 wo{s * std::cos(phi), s * std::sin(phi), z};
                albedo += e.eval_cosine(wi, wo)[0] * mu.w[q] * 2 * pi / phis;
            }
        EXPECT_REL_NEAR(albedo, 0.8, 5e-3) << "theta_i " << theta_i_deg;
    }
}

TEST(RglBuild, SpectralFileInterpolatesLinearlyInWavelength) {
    const RglOptions options = test::rgl_case_options(test::rgl_resolutions[0], true);
    const auto brdf = test::rgl_test_brdf(RglTestModel::Glossy, options.wavelengths_nm);
    const RglEvaluator e(make_rgl_bsdf(brdf, options));
    const Vec3 wi{0.5, 0.0, std::sqrt(0.75)}, wo{-0.3, 0.2, std::sqrt(0.87)};
    const std::vector<double> v = e.eval_cosine(wi, wo);
    ASSERT_EQ(v.size(), 21u);
    EXPECT_FLOAT_EQ(static_cast<float>(e.eval_cosine(wi, wo, 400.0)), static_cast<float>(v[1]));
    EXPECT_NEAR(e.eval_cosine(wi, wo, 410.0), 0.5 * (v[1] + v[2]), 1e-6 * v[1]);
    EXPECT_FLOAT_EQ(static_cast<float>(e.eval_cosine(wi, wo, 300.0)), static_cast<float>(v[0]));
    EXPECT_FLOAT_EQ(static_cast<float>(e.eval_cosine(wi, wo, 900.0)), static_cast<float>(v[20]));
}

TEST(RglBuild, BelowTheHorizonIsZero) {
    const RglEvaluator e(test::small_rgl_bsdf());
    EXPECT_EQ(e.eval_cosine({0, 0, 1}, {0, 0.6, -0.8}), (std::vector<double>{0, 0, 0}));
    EXPECT_EQ(e.eval_cosine({0.6, 0, -0.8}, {0, 0, 1}), (std::vector<double>{0, 0, 0}));
    EXPECT_EQ(e.brdf({1, 0, 0}, {0, 0, 1}), (std::vector<double>{0, 0, 0}));
}

TEST(RglBuild, BlackBrdfGivesAValidFileOfZeros) {
    const auto black = [](const Vec3&, const Vec3&, std::vector<double>& v) { v.assign(3, 0.0); };
    const RglBsdf b = make_rgl_bsdf(black, test::rgl_case_options(test::rgl_resolutions[0], false));
    EXPECT_EQ(rgl_bsdf_fault(b), "");
    const RglEvaluator e(b);
    EXPECT_EQ(e.brdf({0.6, 0, 0.8}, {0, 0.6, 0.8}), (std::vector<double>{0, 0, 0}));
}

TEST(RglBuild, DeterministicAndWithProvenance) {
    RglOptions options = test::rgl_case_options(test::rgl_resolutions[0], false);
    const auto brdf = test::rgl_test_brdf(RglTestModel::Retro, {});
    const RglBsdf a = make_rgl_bsdf(brdf, options), b = make_rgl_bsdf(brdf, options);
    EXPECT_EQ(a.values.values, b.values.values);
    EXPECT_EQ(a.vndf.values, b.vndf.values);
    EXPECT_EQ(a.description, cat("{\"generator\": \"", generator_string, "\"}"));
    EXPECT_EQ(rgl_description("brdf-service 1.2", " {\"name\": \"x\"}\n"),
              "{\"generator\": \"brdf-service 1.2\", \"spec\": {\"name\": \"x\"}}");
    EXPECT_EQ(rgl_description("g\"1", "not json"),
              "{\"generator\": \"g\\\"1\", \"spec\": \"not json\"}");
    options.description = "mine";
    EXPECT_EQ(make_rgl_bsdf(brdf, options).description, "mine");
}

TEST(RglBuild, OptionsOutOfRangeAreInputErrors) {
    const auto brdf = test::rgl_test_brdf(RglTestModel::Lambertian, {});
    RglOptions o;
    o.sample_resolution = 1;
    EXPECT_THROW_MESSAGE(make_rgl_bsdf(brdf, o), InputError,
                         "RGL options: sample_resolution = 1 (2 .. 4096 expected)");
    o = {};
    o.max_theta_i_deg = 95.0;
    EXPECT_THROW_MESSAGE(make_rgl_bsdf(brdf, o), InputError,
                         "RGL options: max_theta_i_deg = 95 ((0, 90] expected)");
    o = {};
    o.wavelengths_nm = {500.0, 450.0};
    EXPECT_THROW_MESSAGE(make_rgl_bsdf(brdf, o), InputError,
                         "RGL options: wavelengths_nm[1] = 450 (positive and increasing expected)");
    o = {};
    o.luminance_weights = {1.0, 1.0};
    EXPECT_THROW_MESSAGE(make_rgl_bsdf(brdf, o), InputError,
                         "RGL options: 2 luminance weights for 3 channels");
}

TEST(RglBuild, BadCallbackValuesAreNumericalErrors) {
    RglOptions o = test::rgl_case_options(test::rgl_resolutions[0], false);
    const auto nan = [](const Vec3&, const Vec3&, std::vector<double>& v) {
        v = {0.1, std::nan(""), 0.1};
    };
    EXPECT_THROW_MESSAGE(make_rgl_bsdf(nan, o), NumericalError,
                         "RGL: the BRDF returned nan for channel 1 at wi (0, 0, 1), wo (0, 0, 1) "
                         "(a finite value >= 0 expected)");
    const auto short_list = [](const Vec3&, const Vec3&, std::vector<double>& v) { v = {0.1}; };
    EXPECT_THROW_MESSAGE(make_rgl_bsdf(short_list, o), NumericalError,
                         "RGL: the BRDF returned 1 values (3 channels expected) at wi (0, 0, 1), "
                         "wo (0, 0, 1)");
    const auto negative = [](const Vec3& wi, const Vec3&, std::vector<double>& v) {
        v.assign(3, wi.z > 0.9 ? 0.1 : -0.1);
    };
    EXPECT_THROW(make_rgl_bsdf(negative, o), NumericalError);
}

// --- Mitsuba's own values -------------------------------------------------------------------------

// Mitsuba 3.9's `measured` eval of the two coarse glossy cases at 64 pairs, written by
// mitsuba_measured_check.py --write-reference: our evaluator, on the same files rebuilt here, must
// agree to float rounding. This pins our reading of the format in builds without Mitsuba.
TEST(RglMitsubaReference, EvaluatorMatchesMitsubasMeasuredEval) {
    std::ifstream in(test::source_dir() / "tests/reference/formats/mitsuba_measured_reference.json");
    ASSERT_TRUE(in) << "reference file missing";
    const nlohmann::json ref = nlohmann::json::parse(in);
    ASSERT_EQ(ref.at("cases").size(), 2u);
    for (const auto& c : ref.at("cases")) {
        const bool spectral = c.at("name") == "glossy-spectral-coarse";
        const RglOptions options = test::rgl_case_options(test::rgl_resolutions[0], spectral);
        const RglEvaluator e(
            make_rgl_bsdf(test::rgl_test_brdf(RglTestModel::Glossy, options.wavelengths_nm), options));
        double worst = 0.0;
        for (std::size_t k = 0; k < c.at("pairs").size(); ++k) {
            const auto& p = c.at("pairs")[k];
            const std::vector<double> ours = e.eval_cosine({p[0], p[1], p[2]}, {p[3], p[4], p[5]});
            const std::vector<double> theirs = c.at("mitsuba_eval")[k];
            ASSERT_EQ(ours.size(), theirs.size());
            for (std::size_t ch = 0; ch < ours.size(); ++ch)
                worst = std::max(worst, std::abs(ours[ch] - theirs[ch]) /
                                            std::max(std::abs(theirs[ch]), 1e-6));
        }
        EXPECT_LT(worst, 1e-4) << c.at("name");
    }
}

// The RGB companion of a spectral file: the renderer's value at any direction is the colour-weighted
// sum of the spectral file's values (same warp, same factor), clamped at 0.
TEST(RglBuild, RgbFromSpectralIsTheWeightedSumEverywhere) {
    const RglOptions options = test::rgl_case_options(test::rgl_resolutions[0], true);
    const auto brdf = test::rgl_test_brdf(RglTestModel::Glossy, options.wavelengths_nm);
    const RglBsdf spectral = make_rgl_bsdf(brdf, options);
    std::vector<std::array<double, 3>> weights(spectral.channels());
    for (std::size_t l = 0; l < weights.size(); ++l) // red fades out, blue in, green a negative lobe
        weights[l] = {1.0 - 0.05 * l, 0.3 - 0.04 * l, 0.05 * l};
    const RglBsdf rgb = rgl_rgb_from_spectral(spectral, weights);
    ASSERT_FALSE(rgb.spectral());
    EXPECT_EQ(rgb.values.shape, (std::vector<std::size_t>{1, spectral.theta_i.size(), 3,
                                                          spectral.sample_resolution(), spectral.sample_resolution()}));
    EXPECT_EQ(rgl_bsdf_fault(rgb), "");
    const RglEvaluator es(spectral), ec(rgb);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int k = 0; k < 200; ++k) {
        const double ti = std::acos(u(rng)), to = std::acos(u(rng)), phi = 2 * pi * u(rng);
        const Vec3 wi{std::sin(ti), 0.0, std::cos(ti)};
        const Vec3 wo{std::sin(to) * std::cos(phi), std::sin(to) * std::sin(phi), std::cos(to)};
        const std::vector<double> s = es.eval_cosine(wi, wo), c = ec.eval_cosine(wi, wo);
        for (int ch = 0; ch < 3; ++ch) {
            double sum = 0.0, scale = 0.0;
            for (std::size_t l = 0; l < s.size(); ++l) {
                sum += weights[l][ch] * s[l];
                scale += std::abs(weights[l][ch] * s[l]);
            }
            EXPECT_NEAR(c[ch], std::max(sum, 0.0), 1e-5 * scale + 1e-12) << "pair " << k << " channel " << ch;
        }
    }
    EXPECT_THROW(rgl_rgb_from_spectral(rgb, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}), InputError);
    weights.pop_back();
    EXPECT_THROW(rgl_rgb_from_spectral(spectral, weights), InputError);
}

} // namespace
} // namespace brdf::formats
