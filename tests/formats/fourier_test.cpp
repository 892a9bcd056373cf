// pbrt-v3 Fourier BSDF files (formats/fourier): the bridge from our cosine series, the evaluator
// against an analytic BRDF with a known finite Fourier series, the file layout, round trips, bad
// files, and an independent Python reader (tests/formats/fourier_reader.py).

#include <formats/fourier/fourier.h>

#include <brdf/core/error.h>

#include "format_test_util.h"
#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>

namespace brdf::formats {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

// --- The analytic BRDF
// ------------------------------------------------------------------------------
//
// f_c = rho_c / pi + k_c (1 - mu_i^2)(1 - mu_o^2) ((1 - cos phi) / 2)^n: Lambertian plus a lobe on
// the mirror side (phi = pi) that vanishes at normal incidence, as an isotropic BRDF must. Its
// cosine series is finite: ((1 - cos phi)/2)^n = sin^2n(phi/2) = 4^-n [C(2n, n) + 2 sum_{m=1}^{n}
// (-1)^m C(2n, n - m) cos(m phi)].
constexpr int lobe_power = 4;
constexpr int analytic_orders = lobe_power + 1;
constexpr Rgb rho{0.5, 0.3, 0.1};
constexpr Rgb lobe{0.8, 1.2, 0.4};

double binomial(int n, int k) {
    double b = 1.0;
    for (int j = 1; j <= k; ++j) b = b * (n - k + j) / j;
    return b;
}

Rgb analytic(double theta_i, double theta_o, double phi) {
    const double mi = std::cos(theta_i), mo = std::cos(theta_o);
    const double s = (1 - mi * mi) * (1 - mo * mo) * std::pow((1 - std::cos(phi)) / 2, lobe_power);
    Rgb f;
    for (int c = 0; c < 3; ++c) f[c] = rho[c] / pi + lobe[c] * s;
    return f;
}

void analytic_series(double mu_i, double mu_o, std::span<double> out) {
    const double s = (1 - mu_i * mu_i) * (1 - mu_o * mu_o);
    const double scale = std::pow(0.25, lobe_power);
    for (int c = 0; c < 3; ++c) {
        out[c * analytic_orders] =
            rho[c] / pi + lobe[c] * s * scale * binomial(2 * lobe_power, lobe_power);
        for (int m = 1; m <= lobe_power; ++m)
            out[c * analytic_orders + m] = lobe[c] * s * scale * 2 * (m % 2 ? -1.0 : 1.0) *
                                           binomial(2 * lobe_power, lobe_power - m);
    }
}

// Nodes k / count, k = 1 .. count (1 included).
std::vector<double> uniform_nodes(int count) {
    std::vector<double> mu;
    for (int k = 1; k <= count; ++k) mu.push_back(double(k) / count);
    return mu;
}

FourierBsdf analytic_bsdf(const std::vector<double>& mu, int channels = 3) {
    FourierBuildOptions options;
    options.channels = channels;
    options.truncation = 0.0;
    options.spec = R"({"name": "analytic", "note": "quotes \" and\nnewlines, UTF-8 µm"})";
    options.generator = "formats tests";
    return make_fourier_bsdf(mu, analytic_orders, analytic_series, options);
}

// pbrt-v3 rebuilds G from Y, R, B with six-digit constants (G' = G + 7.3e-7 R + 1.1e-6 G + 1.9e-7
// B), and the coefficients are float32: at the nodes the evaluation is exact to ~3e-6 relative.
constexpr double node_tolerance = 1e-5;

// Largest relative difference (per channel, against max(|reference|, 1e-3 of the largest value))
// of evaluate() against the analytic BRDF on a grid up to `max_deg` degrees.
double max_error(const FourierBsdf& bsdf, double max_deg, int steps) {
    double worst = 0.0;
    const double top = max_deg * pi / 180;
    for (int a = 0; a <= steps; ++a)
        for (int b = 0; b <= steps; ++b)
            for (int p = 0; p <= 12; ++p) {
                const double ti = top * a / steps, to = top * b / steps, phi = pi * p / 12;
                const Rgb got = evaluate(bsdf, ti, to, phi), want = analytic(ti, to, phi);
                for (int c = 0; c < 3; ++c)
                    worst = std::max(worst, std::abs(got[c] - want[c]) / std::max(want[c], 1e-4));
            }
    return worst;
}

TEST(FourierBridge, NodesAreTheMirroredNodesWithTwoZerosAndBothEnds) {
    const FourierBsdf b = analytic_bsdf({0.25, 0.5, 0.75});
    // 1 added; -1 .. -0.25, 0, 0, 0.25 .. 1.
    const std::vector<float> expected{-1, -0.75f, -0.5f, -0.25f, 0, 0, 0.25f, 0.5f, 0.75f, 1};
    EXPECT_EQ(b.mu, expected);
    EXPECT_EQ(b.series.size(), expected.size() * expected.size());
    EXPECT_EQ(b.cdf.size(), expected.size() * expected.size());
    EXPECT_EQ(b.max_order, std::uint32_t(analytic_orders));
    EXPECT_EQ(b.channels, 3);
    EXPECT_EQ(b.eta, 1.0f);
    check_fourier_bsdf(b, "analytic");
    // Only reflection from above holds data: o on the viewer's side (index >= 5: +0 and up), i on
    // the light's side strictly below -0 (index < 4).
    const std::size_t n = b.nodes();
    for (std::size_t o = 0; o < n; ++o)
        for (std::size_t i = 0; i < n; ++i)
            EXPECT_EQ(b.at(o, i).length > 0, o >= 5 && i < 4) << "o " << o << ", i " << i;
}

TEST(FourierBridge, AgreesWithTheAnalyticBrdfAtTheNodes) {
    const std::vector<double> mu = uniform_nodes(8);
    const FourierBsdf b = analytic_bsdf(mu);
    for (double mi : mu)
        for (double mo : mu)
            for (double phi : {0.0, 0.7, pi / 2, 2.0, 3.0, pi}) {
                const double ti = std::acos(mi), to = std::acos(mo);
                const Rgb got = evaluate(b, ti, to, phi), want = analytic(ti, to, phi);
                for (int c = 0; c < 3; ++c)
                    EXPECT_REL_NEAR(got[c], want[c], node_tolerance)
                        << "mu_i " << mi << ", mu_o " << mo << ", phi " << phi << ", "
                        << channel_name(c);
            }
}

TEST(FourierBridge, OneChannelHoldsTheLuminance) {
    const std::vector<double> mu = uniform_nodes(4);
    const FourierBsdf b = analytic_bsdf(mu, 1);
    EXPECT_EQ(b.channels, 1);
    const double ti = std::acos(0.5), to = std::acos(0.75);
    const Rgb got = evaluate(b, ti, to, 2.5), want = analytic(ti, to, 2.5);
    const double y = fourier_luminance_weights[0] * want[0] +
                     fourier_luminance_weights[1] * want[1] +
                     fourier_luminance_weights[2] * want[2];
    for (int c = 0; c < 3; ++c) EXPECT_REL_NEAR(got[c], y, 1e-6);
}

// Between the nodes the Catmull-Rom spline in mu_i and mu_o is the only error (the series is
// exact). Measured on uniform nodes k / N, theta up to 85 degrees: N = 8: 6.5e-2, 16: 1.5e-2,
// 32: 4.3e-3 (also by tests/formats/fourier_reader.py). Second order: the end intervals have
// one-sided tangents (at mu = 1, where a_k = mu_i f is cubic in mu_i), and the tangent at mu_o = +0
// takes the zero of the transmission node -0 (the worst case of N = 8 is theta_i = theta_o = 85
// degrees, in the interval [0, 1/8]). Interior intervals of a uniform grid reproduce quadratics
// exactly. The bounds are 1.2x the measured values.
TEST(FourierBridge, BetweenNodesTheErrorIsTheSplineErrorAndConverges) {
    const double e8 = max_error(analytic_bsdf(uniform_nodes(8)), 85.0, 40);
    const double e16 = max_error(analytic_bsdf(uniform_nodes(16)), 85.0, 40);
    const double e32 = max_error(analytic_bsdf(uniform_nodes(32)), 85.0, 40);
    RecordProperty("error_8_nodes", std::to_string(e8));
    RecordProperty("error_16_nodes", std::to_string(e16));
    RecordProperty("error_32_nodes", std::to_string(e32));
    EXPECT_LT(e8, 1.2 * 6.53e-2);
    EXPECT_LT(e16, 1.2 * 1.49e-2);
    EXPECT_LT(e32, 1.2 * 4.27e-3);
    // Second order, and not exact (the test would not see a broken spline otherwise).
    EXPECT_GT(e8 / e16, 3.0);
    EXPECT_GT(e16 / e32, 3.0);
    EXPECT_GT(e32, 1e-4);
}

TEST(FourierBridge, ConventionsMirrorSideIsPbrtPhiZeroAndLightIsMuI) {
    const FourierBsdf b = analytic_bsdf(uniform_nodes(8));
    const double mi = 0.5, mo = 0.75;
    // pbrt-v3's own variables: mu_i = cos(-wi) < 0 for light from above, phi' = 0 the mirror side.
    const Rgb mirror = evaluate_pbrt(b, -mi, mo, 1.0), retro = evaluate_pbrt(b, -mi, mo, -1.0);
    const Rgb want_mirror = analytic(std::acos(mi), std::acos(mo), pi);
    const Rgb want_retro = analytic(std::acos(mi), std::acos(mo), 0.0);
    for (int c = 0; c < 3; ++c) {
        EXPECT_REL_NEAR(mirror[c], want_mirror[c], node_tolerance);
        EXPECT_REL_NEAR(retro[c], want_retro[c], node_tolerance);
        EXPECT_GT(mirror[c], retro[c]); // the lobe is on the mirror side
    }
    // Transmission and reflection from below are black.
    for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(evaluate_pbrt(b, -mi, -mo, 1.0)[c], 0.0);
        EXPECT_EQ(evaluate_pbrt(b, mi, mo, 1.0)[c], 0.0);
        EXPECT_EQ(evaluate_pbrt(b, mi, -mo, 1.0)[c], 0.0);
        EXPECT_EQ(evaluate(b, std::acos(mi), pi - std::acos(mo), 1.0)[c], 0.0);
    }
}

TEST(FourierBridge, DirectionsAndAnglesAgree) {
    const FourierBsdf b = analytic_bsdf(uniform_nodes(8));
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> theta(0.0, 1.5), azimuth(-pi, pi);
    for (int k = 0; k < 200; ++k) {
        const double ti = theta(rng), to = theta(rng), phi_i = azimuth(rng), phi_o = azimuth(rng);
        const Vec3 wi = direction(ti, phi_i), wo = direction(to, phi_o);
        const Rgb a = evaluate(b, wi, wo), c = evaluate(b, ti, to, phi_o - phi_i);
        for (int ch = 0; ch < 3; ++ch) EXPECT_REL_NEAR(a[ch], c[ch], 1e-9);
    }
    // Normal incidence: no azimuth (pbrt-v3's CosDPhi gives 1), the lobe vanishes there.
    const Rgb normal = evaluate(b, 0.0, 0.4, 1.0);
    const Rgb want = analytic(0.0, 0.4, 1.0);
    for (int c = 0; c < 3; ++c) EXPECT_REL_NEAR(normal[c], want[c], node_tolerance);
}

TEST(FourierBridge, GrazingLightIsZeroNotNoise) {
    const FourierBsdf b = analytic_bsdf(uniform_nodes(8));
    for (int c = 0; c < 3; ++c) EXPECT_EQ(evaluate(b, pi / 2, 0.3, 1.0)[c], 0.0);
}

// The cdf of a Lambertian table: a_0 = |mu_i| rho / pi on the light's side, so the Catmull-Rom
// integral from -1 is exact: rho / (2 pi) (1 - mu_i^2) for mu_i <= 0, constant above.
TEST(FourierBridge, CdfIsTheIntegralOfA0OverMuI) {
    const auto lambert = [](double, double, std::span<double> out) {
        for (int c = 0; c < 3; ++c) out[c] = rho[c] / pi;
    };
    const std::vector<double> mu = uniform_nodes(6);
    const FourierBsdf b = make_fourier_bsdf(mu, 1, lambert);
    const double y = fourier_luminance_weights[0] * rho[0] + fourier_luminance_weights[1] * rho[1] +
                     fourier_luminance_weights[2] * rho[2];
    const std::size_t n = b.nodes();
    for (std::size_t o = 0; o < n; ++o)
        for (std::size_t i = 0; i < n; ++i) {
            const double m = b.mu[i];
            const bool viewer_above = o >= n / 2; // +0 and up
            const double want =
                viewer_above ? y / (2 * pi) * (1 - std::min(m, 0.0) * std::min(m, 0.0)) : 0.0;
            EXPECT_NEAR(b.cdf[o * n + i], want, 1e-7) << "o " << o << ", i " << i;
        }
    EXPECT_EQ(b.max_order, 1u);
}

TEST(FourierBridge, TruncationDropsNegligibleOrdersWithinTheTolerance) {
    // b_m = 0.2 / pi * 0.5^m, m < 40: a geometric series; with tolerance t the dropped tail sums to
    // at most t * b_0.
    const auto geometric = [](double mu_i, double mu_o, std::span<double> out) {
        const double s = (1 - mu_i * mu_i) * (1 - mu_o * mu_o);
        for (int c = 0; c < 3; ++c)
            for (int m = 0; m < 40; ++m)
                out[c * 40 + m] = (0.2 / pi) * (m == 0 ? 1.0 : s * std::pow(0.5, m));
    };
    FourierBuildOptions options;
    options.truncation = 1e-3;
    const std::vector<double> mu = uniform_nodes(4);
    const FourierBsdf cut = make_fourier_bsdf(mu, 40, geometric, options);
    options.truncation = 0.0;
    const FourierBsdf full = make_fourier_bsdf(mu, 40, geometric, options);
    EXPECT_EQ(full.max_order, 40u);
    EXPECT_LE(cut.max_order, 12u); // 0.5^11 * 2 <= 1e-3 of b_0
    EXPECT_GE(cut.max_order, 9u);
    EXPECT_LT(cut.coefficients.size(), full.coefficients.size());
    for (double mi : mu)
        for (double mo : mu)
            for (int p = 0; p <= 24; ++p) {
                const double ti = std::acos(mi), to = std::acos(mo), phi = pi * p / 24;
                const Rgb a = evaluate(cut, ti, to, phi), c = evaluate(full, ti, to, phi);
                // Relative to b_0 = the mean over phi (0.2 / pi), with float rounding on top.
                for (int ch = 0; ch < 3; ++ch)
                    EXPECT_LE(std::abs(a[ch] - c[ch]), 1.1e-3 * 0.2 / pi);
            }
}

TEST(FourierBridge, RefusesBadInput) {
    const auto none = [](double, double, std::span<double>) {};
    const std::vector<double> zero{0.0, 0.5}, unsorted{0.5, 0.25}, above{0.5, 1.5},
        same{0.5, 0.50000001};
    EXPECT_THROW_MESSAGE(make_fourier_bsdf(zero, 1, none), InputError,
                         "make_fourier_bsdf: mu[0] = 0 is not in (0, 1]");
    EXPECT_THROW_MESSAGE(make_fourier_bsdf(above, 1, none), InputError,
                         "make_fourier_bsdf: mu[1] = 1.5 is not in (0, 1]");
    EXPECT_THROW_MESSAGE(make_fourier_bsdf(unsorted, 1, none), InputError,
                         "make_fourier_bsdf: mu[1] = 0.25 is not above mu[0] = 0.5 in float32 "
                         "(nodes ascending, distinct)");
    EXPECT_THROW_MESSAGE(
        make_fourier_bsdf(same, 1, none), InputError,
        "make_fourier_bsdf: mu[1] = 0.50000001 is not above mu[0] = 0.5 in float32 "
        "(nodes ascending, distinct)");
    const std::vector<double> ok{0.5};
    EXPECT_THROW_MESSAGE(make_fourier_bsdf(ok, 0, none), InputError,
                         "make_fourier_bsdf: orders must be >= 1 (got 0)");
    const auto nan = [](double, double mu_o, std::span<double> out) {
        if (mu_o == 1.0) out[1] = std::nan("");
    };
    EXPECT_THROW_MESSAGE(make_fourier_bsdf(ok, 1, nan), NumericalError,
                         "make_fourier_bsdf: non-finite coefficient NaN of order 0 in the green "
                         "channel at mu_i 1, mu_o 1");
}

// --- The file
// --------------------------------------------------------------------------------------

std::uint32_t u32_at(const std::string& s, std::size_t offset) {
    std::uint32_t v = 0;
    for (int b = 3; b >= 0; --b) v = (v << 8) | static_cast<unsigned char>(s.at(offset + b));
    return v;
}
float f32_at(const std::string& s, std::size_t offset) {
    return std::bit_cast<float>(u32_at(s, offset));
}
void put_u32_at(std::string& s, std::size_t offset, std::uint32_t v) {
    for (int b = 0; b < 4; ++b) s.at(offset + b) = static_cast<char>((v >> (8 * b)) & 0xff);
}

TEST(FourierFile, HeaderAndArraysAreWherePbrtV3ReadsThem) {
    TempDir dir;
    const FourierBsdf b = analytic_bsdf({0.5});
    write_fourier_bsdf(dir / "a.bsdf", b);
    const std::string s = test::read_file(dir / "a.bsdf");
    const std::size_t n = b.nodes(); // -1, -0.5, 0, 0, 0.5, 1
    ASSERT_EQ(n, 6u);
    EXPECT_EQ(s.substr(0, 8), std::string("SCATFUN\x01", 8));
    EXPECT_EQ(u32_at(s, 8), 1u);                              // flags: a BSDF
    EXPECT_EQ(u32_at(s, 12), n);                              // nMu
    EXPECT_EQ(u32_at(s, 16), b.coefficients.size());          // nCoeffs
    EXPECT_EQ(u32_at(s, 20), std::uint32_t(analytic_orders)); // mMax
    EXPECT_EQ(u32_at(s, 24), 3u);                             // nChannels
    EXPECT_EQ(u32_at(s, 28), 1u);                             // nBases
    EXPECT_EQ(u32_at(s, 32), b.metadata.size());              // nMetadataBytes
    EXPECT_EQ(u32_at(s, 36), 0u);                             // nParameters
    EXPECT_EQ(u32_at(s, 40), 0u);                             // nParameterValues
    EXPECT_EQ(f32_at(s, 44), 1.0f);                           // eta
    for (std::size_t k = 48; k < 64; k += 4) EXPECT_EQ(u32_at(s, k), 0u);
    for (std::size_t k = 0; k < n; ++k) EXPECT_EQ(f32_at(s, 64 + 4 * k), b.mu[k]);
    const std::size_t cdf = 64 + 4 * n, table = cdf + 4 * n * n, coeffs = table + 8 * n * n;
    for (std::size_t k = 0; k < n * n; ++k) {
        EXPECT_EQ(f32_at(s, cdf + 4 * k), b.cdf[k]);
        EXPECT_EQ(u32_at(s, table + 8 * k), b.series[k].offset);
        EXPECT_EQ(u32_at(s, table + 8 * k + 4), b.series[k].length);
    }
    for (std::size_t k = 0; k < b.coefficients.size(); ++k)
        EXPECT_EQ(f32_at(s, coeffs + 4 * k), b.coefficients[k]);
    EXPECT_EQ(s.substr(coeffs + 4 * b.coefficients.size()), b.metadata);
    // Pair (o = mu 1, i = mu -1): normal incidence, normal view: Y, R, B of rho / pi (the lobe is 0
    // there, so the series is one coefficient long).
    const FourierBsdf::Series& normal = b.at(5, 0);
    ASSERT_EQ(normal.length, 1u);
    const double y = fourier_luminance_weights[0] * rho[0] + fourier_luminance_weights[1] * rho[1] +
                     fourier_luminance_weights[2] * rho[2];
    EXPECT_REL_NEAR(b.coefficients[normal.offset], y / pi, 1e-7);
    EXPECT_REL_NEAR(b.coefficients[normal.offset + 1], rho[0] / pi, 1e-7);
    EXPECT_REL_NEAR(b.coefficients[normal.offset + 2], rho[2] / pi, 1e-7);
}

TEST(FourierFile, RoundTripKeepsEverything) {
    TempDir dir;
    FourierBsdf b = analytic_bsdf(uniform_nodes(5));
    b.alpha = {0.25f, 0.5f};
    b.eta = 1.5f;
    write_fourier_bsdf(dir / "a.bsdf", b);
    const FourierBsdf r = read_fourier_bsdf(dir / "a.bsdf");
    EXPECT_EQ(r.mu, b.mu);
    EXPECT_EQ(r.channels, b.channels);
    EXPECT_EQ(r.max_order, b.max_order);
    EXPECT_EQ(r.eta, b.eta);
    EXPECT_EQ(r.alpha, b.alpha);
    ASSERT_EQ(r.series.size(), b.series.size());
    for (std::size_t k = 0; k < b.series.size(); ++k) {
        EXPECT_EQ(r.series[k].offset, b.series[k].offset);
        EXPECT_EQ(r.series[k].length, b.series[k].length);
    }
    EXPECT_EQ(r.coefficients, b.coefficients);
    EXPECT_EQ(r.cdf, b.cdf);
    EXPECT_EQ(r.metadata, b.metadata);
    const FourierProvenance p = fourier_provenance(r);
    EXPECT_TRUE(p.ours);
    EXPECT_EQ(p.spec, R"({"name": "analytic", "note": "quotes \" and\nnewlines, UTF-8 µm"})");
    EXPECT_EQ(p.generator, "formats tests");
    EXPECT_EQ(p.colorspace, "rec709");
    // Written again: the same bytes.
    write_fourier_bsdf(dir / "b.bsdf", r);
    EXPECT_EQ(test::read_file(dir / "a.bsdf"), test::read_file(dir / "b.bsdf"));
}

TEST(FourierFile, ForeignMetadataIsKeptVerbatimAndIsNotOurs) {
    TempDir dir;
    FourierBsdf b = analytic_bsdf({0.5});
    b.metadata = "{\n    \"layers\": [], \"roughness\": 0.2\n}";
    write_fourier_bsdf(dir / "a.bsdf", b);
    const FourierBsdf r = read_fourier_bsdf(dir / "a.bsdf");
    EXPECT_EQ(r.metadata, b.metadata);
    EXPECT_FALSE(fourier_provenance(r).ours);
    b.metadata.clear();
    write_fourier_bsdf(dir / "a.bsdf", b);
    EXPECT_EQ(read_fourier_bsdf(dir / "a.bsdf").metadata, "");
}

TEST(FourierFile, WriteIsAtomicAndRefusesBadContent) {
    TempDir dir;
    FourierBsdf b = analytic_bsdf({0.5});
    write_fourier_bsdf(dir / "a.bsdf", b);
    const std::string before = test::read_file(dir / "a.bsdf");
    FourierBsdf bad = b;
    bad.coefficients[3] = std::nanf("");
    EXPECT_THROW_MESSAGE(write_fourier_bsdf(dir / "a.bsdf", bad), NumericalError,
                         (dir / "a.bsdf").string() + ": non-finite coefficient NaN at index 3");
    bad = b;
    bad.series[0] = {0, 99};
    EXPECT_THROW(write_fourier_bsdf(dir / "a.bsdf", bad), InputError);
    EXPECT_EQ(test::read_file(dir / "a.bsdf"), before);
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir.path())) names.push_back(e.path().filename());
    EXPECT_EQ(names, std::vector<std::string>{"a.bsdf"});
    EXPECT_THROW(write_fourier_bsdf(dir / "missing" / "a.bsdf", b), IoError);
}

// --- Bad files
// -------------------------------------------------------------------------------------

class FourierBad : public ::testing::Test {
  protected:
    TempDir dir;
    std::string valid = test::fourier_specimen_bytes();
    fs::path write(const std::string& bytes) {
        const fs::path p = dir / "bad.bsdf";
        test::write_file(p, bytes);
        return p;
    }
    // The specimen: 6 nodes; the offset table starts at 64 + 24 + 144 = 232.
    static constexpr std::size_t nodes = 6, table = 64 + 4 * nodes + 4 * nodes * nodes,
                                 coefficients = table + 8 * nodes * nodes;
};

TEST_F(FourierBad, EachFaultIsOneLineNamingIt) {
    const auto message = [&](const std::string& bytes) -> std::string {
        const fs::path p = write(bytes);
        try {
            read_fourier_bsdf(p);
        } catch (const FormatError& e) {
            const std::string m = e.what();
            EXPECT_EQ(m.find('\n'), std::string::npos) << m;
            const std::string prefix = p.string() + ": ";
            EXPECT_EQ(m.substr(0, prefix.size()), prefix);
            return m.substr(prefix.size());
        }
        ADD_FAILURE() << "accepted";
        return {};
    };
    EXPECT_NO_THROW(read_fourier_bsdf(write(valid)));
    const std::size_t size = valid.size();
    EXPECT_EQ(message(""), "empty file (not a Fourier BSDF)");
    EXPECT_EQ(message(valid.substr(0, 40)), "truncated header (64 bytes expected, 40 found)");
    EXPECT_EQ(message(test::merl_header(90, 90, 180)),
              "not a Fourier BSDF file (no \"SCATFUN\" magic)");
    EXPECT_EQ(message(valid.substr(0, size - 1)),
              "truncated (" + std::to_string(size) + " bytes expected from the header: 6 nodes, " +
                  std::to_string(u32_at(valid, 16)) + " coefficients, " +
                  std::to_string(u32_at(valid, 32)) + " metadata bytes; " +
                  std::to_string(size - 1) + " found)");
    EXPECT_EQ(message(valid + "x").substr(0, 11), "wrong size ");
    std::string v = valid;
    v[7] = 2;
    EXPECT_EQ(message(v), "unsupported SCATFUN version 2 (pbrt-v3 reads version 1)");
    v = valid;
    put_u32_at(v, 8, 3);
    EXPECT_EQ(message(v),
              "harmonic extrapolation (flags 0x3) is not supported (pbrt-v3 reads flags 0x1 only)");
    put_u32_at(v, 8, 0);
    EXPECT_EQ(message(v), "unsupported flags 0x0 (pbrt-v3 reads flags 0x1: a BSDF)");
    v = valid;
    put_u32_at(v, 24, 2);
    EXPECT_EQ(message(v), "2 channels (pbrt-v3 reads 1 or 3)");
    v = valid;
    put_u32_at(v, 28, 4);
    EXPECT_EQ(message(v), "textured BSDF (4 bases, 0 parameters) is not supported (pbrt-v3 reads 1 "
                          "basis, no parameters)");
    v = valid;
    put_u32_at(v, 12, 0xffffffffu);
    EXPECT_EQ(message(v).substr(0, 26), "header counts out of range");
    v = valid;
    put_u32_at(v, 20, 9);
    EXPECT_EQ(message(v), "mMax is 9 but the longest series has 3 coefficients");
    put_u32_at(v, 20, 1);
    EXPECT_EQ(message(v).substr(0, 24), "series of pair o 3, i 1 ");
    v = valid;
    put_u32_at(v, 64 + 4, std::bit_cast<std::uint32_t>(-2.0f));
    EXPECT_EQ(message(v), "node mu[1] = -2 outside [-1, 1]");
    v = valid;
    put_u32_at(v, 64 + 4, std::bit_cast<std::uint32_t>(0.9f));
    EXPECT_EQ(message(v), "nodes not in increasing order (mu[1] = 0.9, mu[2] = 0)");
    v = valid;
    put_u32_at(v, 64 + 4 * 4, std::bit_cast<std::uint32_t>(1.0f));
    EXPECT_EQ(message(v),
              "the last two nodes are equal (1): the last spline interval has zero width");
    v = valid;
    put_u32_at(v, 64 + 4 * nodes + 4 * 7, 0x7f800000u);
    EXPECT_EQ(message(v), "non-finite cdf value inf of pair o 1, i 1 (mu_o -0.5, mu_i -0.5)");
    v = valid;
    put_u32_at(v, 44, 0x7fc00000u);
    EXPECT_EQ(message(v), "non-finite eta NaN");
    v = valid;
    put_u32_at(v, table + 8 * 7 + 4, 0x80000000u); // a negative int32 length for pbrt-v3
    EXPECT_EQ(message(v), "series of pair o 1, i 1 (mu_o -0.5, mu_i -0.5) has offset " +
                              std::to_string(u32_at(valid, table + 8 * 7)) +
                              " and length -2147483648 (must be >= 0)");
}

TEST_F(FourierBad, CheckedInSpecimens) {
    const fs::path folder = test::source_dir() / "tests/data/bad";
    for (const test::MerlSpecimen& s : test::fourier_specimens())
        EXPECT_EQ(test::read_file(folder / s.name), s.bytes)
            << s.name << " differs from its definition";
    const auto expect = [&](const char* name, const std::string& message) {
        const fs::path p = folder / name;
        EXPECT_THROW_MESSAGE(read_fourier_bsdf(p), FormatError, p.string() + ": " + message);
    };
    const std::size_t size = valid.size();
    const std::string counts = "6 nodes, " + std::to_string(u32_at(valid, 16)) + " coefficients, " +
                               std::to_string(u32_at(valid, 32)) + " metadata bytes";
    expect("fourier_truncated.bsdf", "truncated (" + std::to_string(size) +
                                         " bytes expected from the header: " + counts + "; " +
                                         std::to_string(size / 2) + " found)");
    expect("fourier_wrong_magic.bsdf", "not a Fourier BSDF file (no \"SCATFUN\" magic)");
    expect("fourier_bad_offset.bsdf", "series of pair o 5, i 0 (mu_o 1, mu_i -1) runs past the "
                                      "coefficients (offset 1000000 + 3 x 1 > " +
                                          std::to_string(u32_at(valid, 16)) + ")");
    // 64 + 4 n + 12 n^2 + 4 c + metadata with n = c = 2^31 - 1: 55340232186768916548 + metadata.
    __extension__ typedef unsigned __int128 Uint128;
    Uint128 huge = Uint128{5534023218676891654u} * 10 + 8 + u32_at(valid, 32);
    std::string digits;
    for (; huge > 0; huge /= 10) digits.insert(digits.begin(), char('0' + int(huge % 10)));
    expect("fourier_huge_counts.bsdf", "truncated (" + digits +
                                           " bytes expected from the header: 2147483647 nodes, "
                                           "2147483647 coefficients, " +
                                           std::to_string(u32_at(valid, 32)) +
                                           " metadata bytes; 64 found)");
    expect("fourier_nan.bsdf", "non-finite coefficient NaN at index 0");
}

TEST_F(FourierBad, HugeCountsAllocateNothingLarge) {
    std::string v = valid.substr(0, 64);
    put_u32_at(v, 12, 0x7fffffff);
    const fs::path p = write(v);
    test::AllocationProbe probe;
    EXPECT_THROW(read_fourier_bsdf(p), FormatError);
    EXPECT_LT(probe.largest(), 1u << 16);
}

TEST_F(FourierBad, MissingFileAndFolderAreIoErrors) {
    EXPECT_THROW(read_fourier_bsdf(dir / "none.bsdf"), IoError);
    EXPECT_THROW(read_fourier_bsdf(dir.path()), IoError);
}

// --- Tables
// ----------------------------------------------------------------------------------------

TEST(FourierTable, TabulatesAtTheCellCentresWithProvenance) {
    const FourierBsdf b = analytic_bsdf(uniform_nodes(8));
    const BrdfTable t = tabulate_fourier(b);
    EXPECT_EQ(t.generator, "formats tests");
    EXPECT_EQ(t.colorspace, "rec709");
    EXPECT_EQ(t.spec.substr(0, 20), R"({"name": "analytic",)");
    for (std::size_t cell :
         {cell_index(10, 20, 30), cell_index(60, 5, 170), cell_index(89, 80, 1)}) {
        if (cell_below_horizon(cell)) continue;
        const CellIndices ix = cell_indices(cell);
        const DirectionPair d = to_directions(theta_h_centre(ix.theta_h),
                                              theta_d_centre(ix.theta_d), phi_d_centre(ix.phi_d));
        const Rgb want = evaluate(b, d.wi, d.wo);
        for (int c = 0; c < 3; ++c) EXPECT_EQ(t.channels[c][cell], want[c]);
    }
    EXPECT_EQ(t.data_cells(), cells - 361784);
}

// --- The independent Python reader
// ----------------------------------------------------------------

TEST(FourierPythonReader, AgreesWithEvaluateToOneInAMillion) {
    TempDir dir;
    const FourierBsdf b = analytic_bsdf({0.1, 0.3, 0.45, 0.7, 0.9});
    write_fourier_bsdf(dir / "a.bsdf", b);
    std::ofstream csv(dir / "ours.txt");
    csv.precision(17);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> theta(0.0, pi / 2), azimuth(0.0, 2 * pi);
    std::size_t rows = 0;
    const auto row = [&](double ti, double to, double phi) {
        const Rgb v = evaluate(b, ti, to, phi);
        csv << ti << ' ' << to << ' ' << phi << ' ' << v[0] << ' ' << v[1] << ' ' << v[2] << '\n';
        ++rows;
    };
    for (int k = 0; k < 400; ++k) row(theta(rng), theta(rng), azimuth(rng));
    for (float m : b.mu) // on the nodes, where the interval search decides
        if (m > 0) row(std::acos(double(m)), std::acos(0.3), 1.0);
    row(0.0, 0.0, 0.0);
    csv.close();
    const test::ProcessResult r = test::run_process(
        {BRDF_PYTHON3, (test::source_dir() / "tests/formats/fourier_reader.py").string(),
         (dir / "a.bsdf").string(), "--check", (dir / "ours.txt").string(), "--tolerance", "1e-6"});
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_NE(r.out.find(std::to_string(rows) + " directions"), std::string::npos) << r.out;
    // The reader can fail: a file evaluated with the azimuth reversed does not pass.
    std::ofstream wrong(dir / "wrong.txt");
    wrong.precision(17);
    for (double phi : {0.0, 0.5, 1.0}) {
        const Rgb v = evaluate(b, 0.6, 0.8, pi - phi);
        wrong << 0.6 << ' ' << 0.8 << ' ' << phi << ' ' << v[0] << ' ' << v[1] << ' ' << v[2]
              << '\n';
    }
    wrong.close();
    const test::ProcessResult w = test::run_process(
        {BRDF_PYTHON3, (test::source_dir() / "tests/formats/fourier_reader.py").string(),
         (dir / "a.bsdf").string(), "--check", (dir / "wrong.txt").string()});
    EXPECT_EQ(w.status, 1) << w.out << w.err;
}

// The reader's --model mode (how real tables will be checked against the model: median <= 0.2 %,
// worst <= 2 % below 85 degrees): 32 uniform nodes pass (worst 4.3e-3), 8 do not (6.5e-2).
TEST(FourierPythonReader, ModelModeChecksTheSplineErrorAgainstLimits) {
    TempDir dir;
    write_fourier_bsdf(dir / "n32.bsdf", analytic_bsdf(uniform_nodes(32)));
    write_fourier_bsdf(dir / "n8.bsdf", analytic_bsdf(uniform_nodes(8)));
    std::ofstream csv(dir / "model.txt");
    csv.precision(17);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> theta(0.0, 85 * pi / 180), azimuth(0.0, 2 * pi);
    for (int k = 0; k < 300; ++k) {
        const double ti = theta(rng), to = theta(rng), phi = azimuth(rng);
        const Rgb v = analytic(ti, to, phi);
        csv << ti << ' ' << to << ' ' << phi << ' ' << v[0] << ' ' << v[1] << ' ' << v[2] << '\n';
    }
    csv << 0.0 << ' ' << 1.55 << ' ' << 0.0 << " 1 1 1\n"; // beyond 85 degrees: not compared
    csv.close();
    const auto run = [&](const char* file) {
        return test::run_process({BRDF_PYTHON3,
                                  (test::source_dir() / "tests/formats/fourier_reader.py").string(),
                                  (dir / file).string(), "--model", (dir / "model.txt").string()});
    };
    const test::ProcessResult fine = run("n32.bsdf"), coarse = run("n8.bsdf");
    EXPECT_EQ(fine.status, 0) << fine.out << fine.err;
    EXPECT_NE(fine.out.find("300 directions below 85 degrees"), std::string::npos) << fine.out;
    EXPECT_EQ(coarse.status, 1) << coarse.out << coarse.err;
}

} // namespace
} // namespace brdf::formats
