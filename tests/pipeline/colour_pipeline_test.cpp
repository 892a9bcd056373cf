// Colour end to end (issue 18): the spec's colour space through the solve, the gamut fit and its
// warnings, the tables, the EXR attributes and the spectral output.

#include <brdf/core/log.h>
#include <brdf/material/colour.h>
#include <brdf/material/spec.h>
#include <brdf/model/model.h>
#include <brdf/model/table_fill.h>
#include <brdf/service/compute.h>
#include <formats/exr/exr.h>
#include <formats/exr/spectral_exr.h>
#include <formats/halfdiff.h>
#include <formats/table_io.h>
#include <test_support.h>

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <numbers>
#include <random>

namespace brdf::test {
namespace {

using material::ColorSpace;

// A material of the example catalogue in a colour space, at draft accuracy (the colour questions
// do not depend on the last digits; draft keeps the tests quick).
material::MaterialSpec example(const std::string& name, ColorSpace space) {
    const nlohmann::json overlay = {{"accuracy", "draft"}, {"colorspace", std::string(material::to_string(space))}};
    for (auto& spec : material::load_specs(source_dir() / "examples/catalogue.json", overlay))
        if (spec.name == name) return spec;
    ADD_FAILURE() << name << " is not in examples/catalogue.json";
    return {};
}

double radians(double degrees) { return degrees * std::numbers::pi / 180.0; }

// Diffuse + mirror at normal incidence: the colour of the paint as a whole.
material::Rgb reflectance(const model::SolvedMaterial& m, double theta) {
    const auto a = m.albedo(theta), r = m.mirror(theta);
    return {a[0] + r[0], a[1] + r[1], a[2] + r[2]};
}

// The two saturated yellows of the example catalogue: CdS alone (outside Rec.709 in its blue and
// at its brightest, issue 18's "gamut_scale": 0.514) and the CdS-copper mixture (its diffuse blue
// below 0 in Rec.709, hidden by the grey mirror from the old fit).
const char* const yellows[] = {"cds-yellow", "cds-copper-mixture"};

TEST(PipelineColour, AcesCgHoldsTheExampleYellowsWhereRec709ScalesThem) {
    for (const char* name : yellows) {
        const model::SolvedMaterial aces = model::solve_material(example(name, ColorSpace::AcesCg), model::Device::Cpu);
        const model::SolvedMaterial rec = model::solve_material(example(name, ColorSpace::Rec709), model::Device::Cpu);
        // ACEScg: nothing scaled, nothing clipped, nothing to warn about.
        EXPECT_EQ(aces.gamut_scale, 1.0) << name;
        EXPECT_FALSE(aces.gamut_clipped) << name;
        EXPECT_TRUE(aces.warnings.empty()) << name << ": " << (aces.warnings.empty() ? "" : aces.warnings[0]);
        // Rec.709: scaled, and said so, naming the material, the space, the factor and the way out.
        EXPECT_LT(rec.gamut_scale, 1.0) << name;
        ASSERT_EQ(rec.warnings.size(), 1u) << name;
        const std::string& w = rec.warnings[0];
        for (const std::string& part : {std::string(name) + ": ", std::string("rec709 gamut"), std::string("chroma scaled by"),
                                       std::string("acescg"), std::string("spectral_exr")})
            EXPECT_NE(w.find(part), std::string::npos) << "'" << part << "' missing from: " << w;
        // The same physics: the solves differ only in their colour weights.
        ASSERT_EQ(aces.samples.size(), rec.samples.size());
        for (double deg : {0.0, 30.0, 60.0, 80.0}) {
            const double t = radians(deg);
            const auto xyz_aces = material::rgb_to_xyz(reflectance(aces, t), ColorSpace::AcesCg);
            const auto xyz_rec = material::rgb_to_xyz(reflectance(rec, t), ColorSpace::Rec709);
            // ACEScg keeps more of the colour (CIE 1976 chroma, independent of any RGB space)...
            EXPECT_GT(material::chroma_ab(xyz_aces), material::chroma_ab(xyz_rec) + 1.0) << name << " at " << deg;
            // ...and the fit keeps the luminance: a fit that lost 20 % (or 1e-6) of it fails here.
            EXPECT_NEAR(xyz_rec[1], xyz_aces[1], 1e-9 * xyz_aces[1]) << name << " at " << deg;
            for (int c = 0; c < 3; ++c) {
                EXPECT_GE(reflectance(aces, t)[c], 0.0);
                EXPECT_LE(reflectance(aces, t)[c], 1.0);
            }
        }
        std::printf("%-20s C*ab at 0 deg: acescg %.2f, rec709 %.2f (scale %.3f)\n", name,
                    material::chroma_ab(material::rgb_to_xyz(reflectance(aces, 0.0), ColorSpace::AcesCg)),
                    material::chroma_ab(material::rgb_to_xyz(reflectance(rec, 0.0), ColorSpace::Rec709)),
                    rec.gamut_scale);
    }
}

TEST(PipelineColour, NoNegativeValueInAnyOutputOfTheMixture) {
    const model::SolvedMaterial aces =
        model::solve_material(example("cds-copper-mixture", ColorSpace::AcesCg), model::Device::Cpu);
    const model::SolvedMaterial rec =
        model::solve_material(example("cds-copper-mixture", ColorSpace::Rec709), model::Device::Cpu);
    // The case is real: unfitted, the mixture's diffuse blue is negative in Rec.709 (issue 18:
    // -0.014) while diffuse + mirror is not.
    const auto unfitted = material::apply_matrix(material::rgb_to_rec709_matrix(ColorSpace::AcesCg), aces.albedo(0.0));
    ASSERT_LT(unfitted[2], -1e-3);
    for (double deg : {0.0, 30.0, 60.0, 80.0, 89.0}) {
        const auto a = rec.albedo(radians(deg)), r = rec.mirror(radians(deg));
        for (int c = 0; c < 3; ++c) {
            EXPECT_GE(a[c], 0.0) << "albedo channel " << c << " at " << deg;
            EXPECT_GE(r[c], 0.0) << "mirror channel " << c << " at " << deg;
        }
    }
    for (double ti = 0.0; ti < 90.0; ti += 7.5)
        for (double to = 0.0; to < 90.0; to += 7.5)
            for (double phi : {0.0, 60.0, 120.0, 180.0}) {
                const auto v = rec.brdf(radians(ti), radians(to), radians(phi));
                for (int c = 0; c < 3; ++c) ASSERT_GE(v[c], 0.0) << ti << " " << to << " " << phi << " channel " << c;
            }
    const formats::BrdfTable table = model::fill_table_cpu(model::prepare_fill(rec), 2);
    std::size_t negative = 0;
    for (std::size_t cell = 0; cell < formats::cells; ++cell)
        if (!formats::cell_below_horizon(cell))
            for (int c = 0; c < 3; ++c) negative += table.plane(c)[cell] < 0.0;
    EXPECT_EQ(negative, 0u);
    // The blue table channel is not simply zeroed: the fit keeps a positive blue where it was.
    EXPECT_GT(rec.albedo(0.0)[2], 0.0);
}

TEST(PipelineColour, AnalyticMediumNeverEvaluatesNegative) {
    // A strongly forward-peaked phase function: its Fourier series rings near grazing.
    const auto spec = material::parse_specs_text(R"({"name": "peaked", "accuracy": "draft",
        "medium": {"albedo": [0.99, 0.3, 0.0], "phase": {"type": "henyey_greenstein", "g": 0.85}, "index": 1.5}})",
                                                 "peaked.json").at(0);
    const model::SolvedMaterial m = model::solve_material(spec, model::Device::Cpu);
    for (double ti = 0.0; ti <= 89.9; ti += 9.0)
        for (double to = 0.0; to <= 89.9; to += 9.0)
            for (double phi = 0.0; phi <= 180.0; phi += 15.0) {
                const auto v = m.brdf(radians(ti), radians(to), radians(phi));
                for (int c = 0; c < 3; ++c) ASSERT_GE(v[c], 0.0) << ti << " " << to << " " << phi;
            }
}

TEST(PipelineColour, Rec709ScalingIsAWarningInTheReportAndOnStderr) {
    TempDir dir;
    service::ComputeOptions options;
    options.output_dir = dir / "out";
    options.device = model::Device::Cpu;
    options.accuracy = "draft";
    options.formats = {"exr"};
    write_file(dir / "cds.json", nlohmann::json(example("cds-yellow", ColorSpace::Rec709).resolved).dump());
    testing::internal::CaptureStderr();
    const auto outcomes = service::compute_files({dir / "cds.json"}, options);
    const std::string err = testing::internal::GetCapturedStderr();
    ASSERT_TRUE(outcomes.at(0).ok) << outcomes[0].error;
    const auto report = nlohmann::json::parse(read_file(dir / "out/cds-yellow.report.json"));
    EXPECT_EQ(report["colorspace"], "rec709");
    EXPECT_LT(report["gamut_scale"].get<double>(), 1.0);
    EXPECT_FALSE(report["gamut_clipped"].get<bool>());
    std::string warning;
    for (const auto& w : report["warnings"])
        if (w.get<std::string>().find("gamut") != std::string::npos) warning = w.get<std::string>();
    ASSERT_FALSE(warning.empty()) << report["warnings"].dump();
    EXPECT_NE(warning.find("cds-yellow: colour outside the rec709 gamut"), std::string::npos) << warning;
    EXPECT_NE(err.find(warning), std::string::npos) << "stderr: " << err;
    // Every reported albedo is non-negative.
    for (const auto& a : report["directional_albedo"])
        for (const char* key : {"diffuse_rgb", "mirror_rgb"})
            for (const auto& v : a[key]) EXPECT_GE(v.get<double>(), 0.0);
}

TEST(PipelineColour, ExrChromaticitiesAndColourSpaceFollowTheSpecReadByOpenImageIO) {
    TempDir dir;
    for (const ColorSpace space : material::all_color_spaces) {
        const std::string name(material::to_string(space));
        write_file(dir / (name + ".json"),
                   cat(R"({"name": ")", name, R"(", "medium": {"albedo": [0.9, 0.6, 0.3]}, "accuracy": "draft",
                          "outputs": ["exr"], "colorspace": ")", name, R"("})"));
        service::ComputeOptions options;
        options.output_dir = dir / "out";
        options.device = model::Device::Cpu;
        const auto outcomes = service::compute_files({dir / (name + ".json")}, options);
        ASSERT_TRUE(outcomes.at(0).ok) << outcomes[0].error;
        const std::filesystem::path exr = dir / "out" / (name + ".exr");
        auto in = OIIO::ImageInput::open(exr.string());
        ASSERT_TRUE(in) << OIIO::geterror();
        const OIIO::ImageSpec& spec = in->spec();
        EXPECT_EQ(spec.get_string_attribute("brdf.colorspace"), name);
        const OIIO::ParamValue* chroma = spec.find_attribute("chromaticities");
        ASSERT_NE(chroma, nullptr) << name;
        ASSERT_EQ(chroma->type(), OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8)) << name;
        const float* xy = static_cast<const float*>(chroma->data());
        const material::Chromaticities& c = material::chromaticities(space);
        const double expected[8] = {c.red.x, c.red.y, c.green.x, c.green.y, c.blue.x, c.blue.y, c.white.x, c.white.y};
        for (int k = 0; k < 8; ++k) EXPECT_EQ(xy[k], static_cast<float>(expected[k])) << name << " entry " << k;
        in->close();
        // Our reader names the space back, and the report says it.
        EXPECT_EQ(formats::read_exr(exr).colorspace, name);
        EXPECT_EQ(nlohmann::json::parse(read_file(dir / "out" / (name + ".report.json")))["colorspace"], name);
    }
}

// A CdS paint at six wavelengths, in Rec.709 (where its weights are fitted, so the integration
// below uses weights with negative entries), computed with the spectral output.
struct SpectralRun {
    TempDir dir;
    nlohmann::json report;
    formats::SpectralTable spectral;
    formats::BrdfTable rgb;
};

const char* cds_six = R"({"name": "cds6", "binder": {"material": "pmma"}, "accuracy": "draft",
    "spectrum": {"wavelengths_nm": [450, 500, 520, 540, 580, 650]}, "outputs": ["exr", "spectral_exr"],
    "pigments": [{"material": "cds", "volume_fraction": 0.1,
                  "size": {"distribution": "power_law", "r_eff_um": 0.2, "v_eff": 0.2}}]})";

// The same CdS under a gloss finish: the first-surface lobe of each channel is its wavelength's own.
const char* cds_six_gloss = R"({"name": "cds6", "binder": {"material": "pmma"}, "accuracy": "draft", "surface": "gloss",
    "spectrum": {"wavelengths_nm": [450, 500, 520, 540, 580, 650]}, "outputs": ["exr", "spectral_exr"],
    "pigments": [{"material": "cds", "volume_fraction": 0.1,
                  "size": {"distribution": "power_law", "r_eff_um": 0.2, "v_eff": 0.2}}]})";

std::unique_ptr<SpectralRun> compute_spectral(const char* text = cds_six) {
    auto run = std::make_unique<SpectralRun>();
    write_file(run->dir / "cds6.json", text);
    service::ComputeOptions options;
    options.output_dir = run->dir / "out";
    options.device = model::Device::Cpu;
    const auto outcomes = service::compute_files({run->dir / "cds6.json"}, options);
    EXPECT_TRUE(outcomes.at(0).ok) << outcomes[0].error;
    run->report = nlohmann::json::parse(read_file(run->dir / "out/cds6.report.json"));
    run->spectral = formats::read_spectral_exr(run->dir / "out/cds6.spectral.exr");
    run->rgb = formats::read_exr(run->dir / "out/cds6.exr");
    return run;
}

void expect_channels_are_single_wavelength_solves(const char* text) {
    const auto run = compute_spectral(text);
    const auto& samples = run->report["wavelengths"];
    ASSERT_EQ(run->spectral.wavelengths_nm.size(), samples.size());
    const int streams = run->report["solver"]["streams"];
    // The spectral table sums at each grid node only the blocks of orders that node needs in its
    // group of three wavelengths (model::node_order_blocks over the group's channels); the single
    // solves below keep every order, so each is filled with its group's blocks, solved again here.
    std::vector<std::vector<int>> group_blocks(samples.size());
    model::for_each_spectral_fill(
        model::solve_material(material::parse_specs_text(text, "all.json").at(0), model::Device::Cpu),
        [&](const model::SpectralFill& group) {
            for (int c : group.sample)
                if (c >= 0) group_blocks.at(static_cast<std::size_t>(c)) = group.inputs.node_blocks;
        });
    std::mt19937 rng(5);
    std::uniform_int_distribution<std::size_t> pick(0, formats::cells - 1);
    std::vector<std::size_t> cells;
    while (cells.size() < 3000) {
        const std::size_t cell = pick(rng);
        if (!formats::cell_below_horizon(cell)) cells.push_back(cell);
    }
    for (std::size_t j = 0; j < samples.size(); ++j) {
        const double lambda = samples[j]["wavelength_nm"];
        EXPECT_EQ(run->spectral.wavelengths_nm[j], lambda);
        // The same spec at this wavelength alone, with the material's stream count and Fourier
        // orders (the convergence check and the order fit would pick their own from other probes).
        nlohmann::json one = nlohmann::json::parse(text);
        one["spectrum"] = {{"wavelengths_nm", {lambda}}};
        const auto spec = material::parse_specs_text(one.dump(), "one.json").at(0);
        model::NumericalSettings settings = model::settings_for(spec.accuracy.tolerance);
        settings.streams = settings.max_streams = streams;
        settings.fit_orders = false; // the material's orders, fitted to its own probes
        settings.max_orders = run->report["solver"]["max_fourier_orders"];
        const model::SolvedMaterial single = model::solve_material(spec, model::Device::Cpu, settings);
        ASSERT_EQ(single.samples.size(), 1u);
        model::FillInputs in = model::prepare_fill(single);
        ASSERT_TRUE(in.node_blocks.empty()); // every order: fit_orders is off
        ASSERT_EQ(group_blocks[j].size(), static_cast<std::size_t>(in.grid) * in.grid);
        in.node_blocks = group_blocks[j];
        double worst = 0.0;
        for (std::size_t cell : cells) {
            const auto ix = formats::cell_indices(cell);
            const auto d = formats::to_directions(formats::theta_h_centre(ix.theta_h), formats::theta_d_centre(ix.theta_d),
                                                  formats::phi_d_centre(ix.phi_d));
            const double ti = std::acos(std::clamp(d.wi.z, -1.0, 1.0)), to = std::acos(std::clamp(d.wo.z, -1.0, 1.0));
            const double phi = std::atan2(d.wo.y, d.wo.x) - std::atan2(d.wi.y, d.wi.x);
            const double expected = model::fill_value(in, ti, to, phi)[0]; // weight (1, 1, 1): any channel
            const double got = run->spectral.planes[j][cell];
            // float32 in the file: 6e-8 relative; 1e-6 with a floor of 1e-6 of a white Lambertian.
            worst = std::max(worst, std::abs(got - expected) / std::max(std::abs(expected), 3e-7));
        }
        EXPECT_LE(worst, 1e-6) << lambda << " nm";
        std::printf("%.0f nm: worst relative difference %.2e over %zu cells\n", lambda, worst, cells.size());
    }
}

TEST(PipelineSpectral, EachChannelIsASingleWavelengthSolve) { expect_channels_are_single_wavelength_solves(cds_six); }

TEST(PipelineSpectral, EachChannelIsASingleWavelengthSolveUnderAGlossFinish) {
    expect_channels_are_single_wavelength_solves(cds_six_gloss);
}

TEST(PipelineSpectral, IntegratingTheSpectralTableGivesTheRgbTable) {
    const auto run = compute_spectral();
    // The colour weights of the solved wavelengths (the spectrum's CIE weights in the spec's colour
    // space, folded for skipped wavelengths, after the gamut fit): the report holds them.
    std::vector<formats::Rgb> weights;
    bool negative_weight = false;
    for (const auto& s : run->report["wavelengths"]) {
        weights.push_back(s["weight_rgb"].get<formats::Rgb>());
        for (double w : weights.back()) negative_weight |= w < 0.0;
    }
    EXPECT_TRUE(negative_weight); // Rec.709 colour matching functions go negative: a real test of the sum
    const formats::BrdfTable integrated = formats::spectral_to_rgb(run->spectral, weights, "rec709");
    const formats::TableDiff d = formats::diff(integrated, run->rgb);
    EXPECT_EQ(d.only_in_a + d.only_in_b, 0u);
    for (int c = 0; c < 3; ++c) {
        EXPECT_LE(d.channels[c].max, 1e-4) << formats::channel_name(c) << " at " << formats::describe_cell(d.channels[c].max_cell);
        std::printf("%s: max relative difference %.2e, mean %.2e\n", formats::channel_name(c), d.channels[c].max,
                    d.channels[c].mean);
    }
}

} // namespace
} // namespace brdf::test
