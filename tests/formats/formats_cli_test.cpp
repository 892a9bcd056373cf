// brdftool info / eval / albedo / convert / diff on the formats beyond MERL and OpenEXR RGB:
// pbrt-v3 Fourier BSDFs, spectral OpenEXR, and files whose extension does not say what they hold.
// The real brdftool runs on files made with formats' own writers; its output is compared with the
// library.

#include <formats/exr/exr.h>
#include <formats/exr/spectral_exr.h>
#include <formats/fourier/fourier.h>
#include <formats/merl/merl.h>
#include <formats/table_io.h>

#include <brdf/material/spectrum.h>

#include "format_test_util.h"
#include "test_support.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <sstream>

namespace brdf::formats {
namespace {

namespace fs = std::filesystem;
using test::run_tool;
using test::TempDir;

bool contains(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

std::string rgb_line(const Rgb& v) {
    char line[128];
    std::snprintf(line, sizeof line, "%.9g %.9g %.9g\n", v[0], v[1], v[2]);
    return line;
}

// Lambertian + a mirror-side lobe, on 6 nodes.
FourierBsdf sample_bsdf() {
    const std::vector<double> mu{0.15, 0.4, 0.65, 0.85, 1.0};
    const auto series = [](double mu_i, double mu_o, std::span<double> out) {
        const double s = (1 - mu_i * mu_i) * (1 - mu_o * mu_o);
        for (int c = 0; c < 3; ++c) {
            out[c * 3 + 0] = (0.2 + 0.2 * c) / pi + 0.3 * s;
            out[c * 3 + 1] = -0.4 * s;
            out[c * 3 + 2] = 0.1 * s;
        }
    };
    FourierBuildOptions options;
    options.generator = "formats cli tests";
    options.spec = R"({"name": "fourier-sample"})";
    return make_fourier_bsdf(mu, 3, series, options);
}

TEST(FormatsCli, InfoOfAFourierBsdf) {
    TempDir dir;
    const FourierBsdf b = sample_bsdf();
    write_fourier_bsdf(dir / "a.fourier.bsdf", b);
    const test::ProcessResult text =
        run_tool("brdftool", {"info", (dir / "a.fourier.bsdf").string()});
    ASSERT_EQ(text.status, 0) << text.err;
    EXPECT_TRUE(contains(text.out, "format:      pbrt-v3 Fourier BSDF (SCATFUN v1)")) << text.out;
    EXPECT_TRUE(
        contains(text.out,
                 "12 nodes in mu from -1 to 1, Fourier series of up to 3 orders, channels Y, R, B"))
        << text.out;
    EXPECT_TRUE(contains(text.out, "generator:   formats cli tests")) << text.out;
    EXPECT_TRUE(contains(text.out, R"(spec:        {"name": "fourier-sample"})")) << text.out;
    const test::ProcessResult json =
        run_tool("brdftool", {"info", "--json", (dir / "a.fourier.bsdf").string()});
    ASSERT_EQ(json.status, 0) << json.err;
    const nlohmann::json j = nlohmann::json::parse(json.out);
    EXPECT_EQ(j["format"], "pbrt-v3 Fourier BSDF");
    EXPECT_EQ(j["nodes"], 12);
    EXPECT_EQ(j["max_order"], 3);
    EXPECT_EQ(j["channels"], "Y, R, B");
    EXPECT_EQ(j["eta"], 1.0);
    EXPECT_EQ(j["coefficients"], b.coefficients.size());
    EXPECT_EQ(j["provenance"]["brdf.generator"], "formats cli tests");
    EXPECT_EQ(j["provenance"]["brdf.colorspace"], "rec709");
    // The albedo integrates the evaluation: at normal incidence the lobe vanishes, rho = 0.2, 0.4,
    // 0.6 up to the spline's error.
    const auto& rho0 = j["directional_albedo"][0]["rgb"];
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rho0[c].get<double>(), 0.2 + 0.2 * c, 3e-3);
}

TEST(FormatsCli, EvalAndAlbedoOfAFourierBsdfUseEvaluate) {
    TempDir dir;
    const FourierBsdf b = sample_bsdf();
    write_fourier_bsdf(dir / "a.bsdf", b);
    const test::ProcessResult r =
        run_tool("brdftool", {"eval", (dir / "a.bsdf").string()}, "30 20 170\n55 40 10\n");
    ASSERT_EQ(r.status, 0) << r.err;
    const double d = pi / 180;
    EXPECT_EQ(r.out, rgb_line(evaluate(b, 30 * d, 20 * d, 170 * d)) +
                         rgb_line(evaluate(b, 55 * d, 40 * d, 10 * d)));
    const test::ProcessResult a =
        run_tool("brdftool", {"albedo", (dir / "a.bsdf").string(), "--theta-i", "45"});
    ASSERT_EQ(a.status, 0) << a.err;
    const Rgb want = directional_albedo(
        [&](double to, double phi) { return evaluate(b, 45 * d, to, phi); }, 45 * d);
    EXPECT_EQ(a.out, rgb_line(want));
}

TEST(FormatsCli, ConvertFourierToExrEvaluatesAtTheCellCentresAndKeepsProvenance) {
    TempDir dir;
    const FourierBsdf b = sample_bsdf();
    write_fourier_bsdf(dir / "a.bsdf", b);
    const test::ProcessResult r =
        run_tool("brdftool", {"convert", (dir / "a.bsdf").string(), (dir / "a.exr").string()});
    ASSERT_EQ(r.status, 0) << r.err;
    const BrdfTable exr = read_exr(dir / "a.exr");
    const BrdfTable want = tabulate_fourier(b);
    EXPECT_EQ(exr.generator, "formats cli tests");
    EXPECT_EQ(exr.spec, R"({"name": "fourier-sample"})");
    EXPECT_EQ(exr.colorspace, "rec709");
    for (std::size_t cell = 0; cell < cells; cell += 997)
        for (int c = 0; c < 3; ++c)
            ASSERT_EQ(exr.channels[c][cell], double(float(want.channels[c][cell])))
                << describe_cell(cell);
    // diff of the table against the BSDF: float rounding only.
    const test::ProcessResult d = run_tool(
        "brdftool", {"diff", "--json", (dir / "a.exr").string(), (dir / "a.bsdf").string()});
    ASSERT_EQ(d.status, 0) << d.err;
    const nlohmann::json j = nlohmann::json::parse(d.out);
    for (const char* c : {"red", "green", "blue"})
        EXPECT_LT(j["channels"][c]["max"].get<double>(), 1e-7);
}

TEST(FormatsCli, ConvertSpectralToMerlWithCieWeights) {
    TempDir dir;
    SpectralTable s({450.0, 550.0, 650.0});
    for (std::size_t j = 0; j < 3; ++j)
        for (std::size_t cell = 0; cell < cells; ++cell)
            if (s.planes[j][cell] >= 0)
                s.planes[j][cell] = float(0.05 * (j + 1) + 1e-8 * double(cell % 1000));
    s.generator = "spectral cli";
    write_spectral_exr(dir / "s.spectral.exr", s);
    const test::ProcessResult r = run_tool(
        "brdftool", {"convert", (dir / "s.spectral.exr").string(), (dir / "s.binary").string()});
    ASSERT_EQ(r.status, 0) << r.err;
    const BrdfTable merl = read_merl(dir / "s.binary");
    const material::SpectralSet set = material::SpectralSet::integrating(s.wavelengths_nm);
    const BrdfTable want = spectral_to_rgb(s, set.rgb_weights());
    for (std::size_t cell = 0; cell < cells; cell += 991)
        for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(merl.channels[c][cell], want.channels[c][cell], 1e-15)
                << describe_cell(cell);
    const test::ProcessResult info =
        run_tool("brdftool", {"info", (dir / "s.spectral.exr").string()});
    ASSERT_EQ(info.status, 0) << info.err;
    EXPECT_TRUE(contains(info.out, "format:      spectral OpenEXR")) << info.out;
    EXPECT_TRUE(contains(info.out, "wavelengths: 3 (450 to 650 nm)")) << info.out;
    EXPECT_TRUE(contains(info.out, "generator:   spectral cli")) << info.out;
}

TEST(FormatsCli, ContentDecidesAndTheExtensionWarnsOnce) {
    TempDir dir;
    write_merl(dir / "m.binary", BrdfTable{});
    fs::copy_file(dir / "m.binary", dir / "m.exr");
    const std::string warning = "m.exr: the extension says OpenEXR but the content is MERL .binary";
    for (const std::vector<std::string>& args :
         {std::vector<std::string>{"info", (dir / "m.exr").string()},
          std::vector<std::string>{"eval", (dir / "m.exr").string(), "--theta-i", "10", "--theta-o", "20"},
          std::vector<std::string>{"convert", (dir / "m.exr").string(), (dir / "o.exr").string()}}) {
        const test::ProcessResult r = run_tool("brdftool", args);
        ASSERT_EQ(r.status, 0) << args[0] << ": " << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args[0] << ": " << r.err;
        EXPECT_TRUE(contains(r.err, warning)) << args[0] << ": " << r.err;
        if (args[0] == "info") {
            EXPECT_TRUE(contains(r.out, "format:      MERL .binary")) << r.out;
        }
    }
}

TEST(FormatsCli, RefusalsAreOneLineWithTheDocumentedStatus) {
    TempDir dir;
    const fs::path bad = test::source_dir() / "tests/data/bad";
    write_fourier_bsdf(dir / "a.bsdf", sample_bsdf());
    struct Case {
        std::vector<std::string> args;
        int status;
        std::string message;
    };
    const std::vector<Case> cases{
        {{"info", (bad / "fourier_truncated.bsdf").string()},
         4,
         "fourier_truncated.bsdf: truncated ("},
        {{"eval", (bad / "fourier_nan.bsdf").string(), "--theta-i", "0", "--theta-o", "0"},
         4,
         "fourier_nan.bsdf: non-finite coefficient NaN at index 0"},
        {{"convert", (bad / "fourier_bad_offset.bsdf").string(), (dir / "o.exr").string()},
         4,
         "runs past the coefficients"},
        {{"convert", (dir / "a.bsdf").string(), (dir / "o.bsdf").string()},
         3,
         "o.bsdf: convert writes .binary (MERL) or .exr (OpenEXR), not pbrt-v3 Fourier BSDF"},
        {{"convert", (dir / "a.bsdf").string(), (dir / "o.spectral.exr").string()},
         3,
         "o.spectral.exr: convert writes .binary (MERL) or .exr (OpenEXR), not spectral OpenEXR"},
    };
    for (const Case& c : cases) {
        const test::ProcessResult r = run_tool("brdftool", c.args);
        EXPECT_EQ(r.status, c.status) << c.args[0] << ' ' << c.args[1] << ": " << r.err;
        EXPECT_TRUE(contains(r.err, c.message)) << "expected '" << c.message << "' in " << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    }
    EXPECT_FALSE(fs::exists(dir / "o.exr"));
    EXPECT_FALSE(fs::exists(dir / "o.bsdf"));
}

} // namespace
} // namespace brdf::formats
