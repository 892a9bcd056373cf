// Material specs: good specs (tests/data/specs/good) resolve to the expected values; every bad spec
// (tests/data/specs/bad, one file per fault kind) fails with one InputError naming the JSON path of
// each fault; hashes and resolved JSON are canonical.

#include <brdf/core/error.h>
#include <brdf/material/spec.h>

#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace brdf::material {
namespace {

std::filesystem::path good(const std::string& name) {
    return test::source_dir() / "tests/data/specs/good" / name;
}
std::filesystem::path bad(const std::string& name) {
    return test::source_dir() / "tests/data/specs/bad" / name;
}

// The message of the InputError that loading `file` throws ("" and a failure if none).
std::string input_error(const std::filesystem::path& file) {
    try {
        load_specs(file);
    } catch (const InputError& e) {
        return e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << file << ": expected InputError, got " << e.what();
        return {};
    }
    ADD_FAILURE() << file << " loaded without error";
    return {};
}

std::string input_error(const nlohmann::json& document) {
    try {
        parse_specs(document, "doc.json");
    } catch (const InputError& e) {
        return e.what();
    }
    ADD_FAILURE() << document.dump() << " parsed without error";
    return {};
}

std::size_t line_count(const std::string& text) {
    return text.empty() ? 0 : 1 + static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

// ------------------------------------------------------------------------------------------------
// Good specs

TEST(SpecGood, DesignExampleResolves) {
    const auto specs = load_specs(good("design_example.json"));
    ASSERT_EQ(specs.size(), 1u);
    const MaterialSpec& s = specs[0];
    EXPECT_EQ(s.name, "seed-tio2-white");
    EXPECT_EQ(s.source, good("design_example.json").string());
    ASSERT_TRUE(s.layers[0].binder.has_value());
    EXPECT_EQ(s.layers[0].binder->index.id, "pmma");
    EXPECT_EQ(s.layers[0].binder->index.describe(), "pmma");
    EXPECT_EQ(s.layers[0].binder->absorption_per_mm, 0.0);
    ASSERT_EQ(s.layers[0].pigments.size(), 1u);
    EXPECT_EQ(s.layers[0].pigments[0].index.id, "tio2-rutile");
    EXPECT_EQ(s.layers[0].pigments[0].volume_fraction, 0.1);
    EXPECT_EQ(s.layers[0].pigments[0].size.kind(), mie::DistributionKind::PowerLaw);
    EXPECT_EQ(s.layers[0].pigments[0].size.r_eff_um(), 0.4);
    EXPECT_EQ(s.layers[0].pigments[0].size.v_eff(), 0.3);
    EXPECT_FALSE(s.layers[0].medium.has_value());
    EXPECT_EQ(s.surface.kind, Surface::Smooth);
    EXPECT_EQ(s.spectrum.kind(), SpectralSet::Kind::Visible);
    EXPECT_EQ(s.spectrum.size(), 41u);
    EXPECT_EQ(s.accuracy.level, "default");
    EXPECT_EQ(s.accuracy.tolerance, 1e-4);
    EXPECT_EQ(s.outputs, (std::vector<std::string>{"merl", "exr"}));
    EXPECT_EQ(s.hash.size(), 16u);
    EXPECT_EQ(s.hash.find_first_not_of("0123456789abcdef"), std::string::npos);
    // The models are ready to evaluate at the spec's wavelengths.
    EXPECT_GT(s.layers[0].pigments[0].index.model.at(550.0).n, 2.5);
    EXPECT_NEAR(s.layers[0].binder->index.model.at(550.0).n, 1.49, 0.01);
}

TEST(SpecGood, EveryDistribution) {
    const auto specs = load_specs(good("distributions.json"));
    ASSERT_EQ(specs.size(), 4u);
    EXPECT_EQ(specs[0].source, good("distributions.json").string() + ": materials[0]");
    EXPECT_EQ(specs[3].source, good("distributions.json").string() + ": materials[3]");

    const auto& mono = specs[0].layers[0].pigments.at(0);
    EXPECT_EQ(mono.size.kind(), mie::DistributionKind::Monodisperse);
    EXPECT_EQ(mono.size.r_min_um(), 0.25);
    EXPECT_EQ(mono.index.id, "silica");

    const auto& power = specs[1].layers[0].pigments.at(0);
    EXPECT_EQ(power.size.kind(), mie::DistributionKind::PowerLaw);
    EXPECT_EQ(power.size.parameter1(), 0.4);
    EXPECT_EQ(power.size.parameter2(), 0.3);

    const auto& gamma = specs[2].layers[0].pigments.at(0);
    EXPECT_EQ(gamma.size.kind(), mie::DistributionKind::Gamma);
    EXPECT_EQ(gamma.size.r_eff_um(), 0.3);
    EXPECT_EQ(gamma.size.v_eff(), 0.1);
    EXPECT_EQ(gamma.volume_fraction, 0.2);
    EXPECT_EQ(specs[2].layers[0].binder->index.id, "polystyrene");

    const auto& logn = specs[3].layers[0].pigments.at(0);
    EXPECT_EQ(logn.size.kind(), mie::DistributionKind::Lognormal);
    EXPECT_EQ(logn.size.parameter1(), 0.15);
    EXPECT_EQ(logn.size.parameter2(), 1.5);
    EXPECT_EQ(specs[3].layers[0].binder->index.id, "");
    EXPECT_EQ(specs[3].layers[0].binder->index.describe(), "1.5");
    EXPECT_EQ(specs[3].layers[0].binder->index.model.at(600.0).n, 1.5);
    EXPECT_EQ(specs[3].resolved["pigments"][0]["size"],
              (nlohmann::json{{"distribution", "lognormal"}, {"r_g_um", 0.15}, {"sigma_g", 1.5}}));
}

TEST(SpecGood, AnalyticMediaOfEachPhaseType) {
    const auto specs = load_specs(good("media.json"));
    ASSERT_EQ(specs.size(), 5u);
    for (const auto& s : specs) {
        ASSERT_TRUE(s.layers[0].medium.has_value()) << s.name;
        EXPECT_FALSE(s.layers[0].binder.has_value());
        EXPECT_TRUE(s.layers[0].pigments.empty());
    }
    const MediumSpec& iso = *specs[0].layers[0].medium;
    EXPECT_EQ(iso.phase, PhaseType::Isotropic);
    EXPECT_TRUE(iso.grey);
    EXPECT_EQ(iso.albedo, (std::array<double, 3>{0.9, 0.9, 0.9}));
    EXPECT_EQ(iso.g, 0.0);
    EXPECT_EQ(specs[0].surface.kind, Surface::None); // the default for an analytic medium
    EXPECT_EQ(specs[0].resolved["medium"]["phase"], (nlohmann::json{{"type", "isotropic"}}));

    const MediumSpec& ray = *specs[1].layers[0].medium;
    EXPECT_EQ(ray.phase, PhaseType::Rayleigh);
    EXPECT_FALSE(ray.grey);
    EXPECT_EQ(ray.albedo, (std::array<double, 3>{0.9, 0.8, 0.7}));

    const MediumSpec& hg = *specs[2].layers[0].medium;
    EXPECT_EQ(hg.phase, PhaseType::HenyeyGreenstein);
    EXPECT_EQ(hg.g, 0.5);
    EXPECT_TRUE(hg.coefficients.empty());

    const MediumSpec& leg = *specs[3].layers[0].medium;
    EXPECT_EQ(leg.phase, PhaseType::Legendre);
    EXPECT_EQ(leg.coefficients, (std::vector<double>{1.0, 1.5, 0.5}));
    EXPECT_DOUBLE_EQ(leg.g, 0.5);
    EXPECT_EQ(leg.albedo[0], 1.0);

    EXPECT_EQ(specs[4].surface.kind, Surface::Smooth);
    ASSERT_TRUE(specs[4].layers[0].medium->index.has_value());
    EXPECT_EQ(*specs[4].layers[0].medium->index, 1.5);
    EXPECT_EQ(specs[4].layers[0].medium->g, -0.3);
}

TEST(SpecGood, CatalogueDefaultsAreMergedAndOwnKeysWin) {
    const auto specs = load_specs(good("catalogue_defaults.json"));
    ASSERT_EQ(specs.size(), 3u);
    const MaterialSpec& white = specs[0];
    EXPECT_EQ(white.layers[0].binder->index.id, "pmma");
    EXPECT_EQ(white.layers[0].binder->absorption_per_mm, 0.01);
    EXPECT_EQ(white.spectrum.kind(), SpectralSet::Kind::RgbWavelengths);
    EXPECT_EQ(white.accuracy.level, "draft");
    EXPECT_EQ(white.accuracy.tolerance, 1e-2);
    EXPECT_EQ(white.outputs, (std::vector<std::string>{"exr"}));

    const MaterialSpec& own = specs[1];
    EXPECT_EQ(own.layers[0].binder->index.describe(), "1.49"); // the whole binder object is the material's
    EXPECT_EQ(own.layers[0].binder->absorption_per_mm, 0.0);
    EXPECT_EQ(own.outputs, (std::vector<std::string>{"merl"}));
    EXPECT_EQ(own.accuracy.level, "custom");
    EXPECT_EQ(own.accuracy.tolerance, 1e-3);
    EXPECT_EQ(own.spectrum.kind(), SpectralSet::Kind::RgbWavelengths);

    // A medium does not inherit the defaults' binder.
    const MaterialSpec& fog = specs[2];
    EXPECT_TRUE(fog.layers[0].medium.has_value());
    EXPECT_FALSE(fog.layers[0].binder.has_value());
    EXPECT_FALSE(fog.resolved.contains("binder"));
    EXPECT_EQ(fog.surface.kind, Surface::None);
    EXPECT_EQ(fog.spectrum.kind(), SpectralSet::Kind::RgbWavelengths);
}

TEST(SpecGood, ExplicitWavelengthsConstantIndexAndNkTable) {
    const auto specs = load_specs(good("explicit_wavelengths.json"));
    ASSERT_EQ(specs.size(), 1u);
    const MaterialSpec& s = specs[0];
    EXPECT_EQ(s.description, "a user nk table and a constant index at explicit wavelengths");
    EXPECT_EQ(s.spectrum.kind(), SpectralSet::Kind::Explicit);
    const auto w = s.spectrum.wavelengths_nm();
    EXPECT_EQ(std::vector<double>(w.begin(), w.end()), (std::vector<double>{450.0, 500.5, 650.0}));
    EXPECT_EQ(s.surface.kind, Surface::None);
    EXPECT_EQ(s.accuracy.tolerance, 1e-6);
    EXPECT_EQ(s.layers[0].binder->index.describe(), "1.5");

    ASSERT_EQ(s.layers[0].pigments.size(), 2u);
    const IndexSpec& table = s.layers[0].pigments[0].index;
    EXPECT_EQ(table.id, "");
    EXPECT_EQ(table.nk.size(), 3u);
    EXPECT_EQ(table.describe(), "nk table (3 rows)");
    EXPECT_NEAR(table.model.at(475.0).n, 2.8, 1e-12); // linear between (400, 2.9) and (550, 2.7)
    EXPECT_NEAR(table.model.at(475.0).k, 0.015, 1e-12);

    const IndexSpec& constant = s.layers[0].pigments[1].index;
    ASSERT_TRUE(constant.constant.has_value());
    EXPECT_EQ(*constant.constant, std::complex<double>(2.0, 0.001));
    EXPECT_EQ(constant.describe(), "2+0.001i");
    EXPECT_EQ(constant.model.at(1000.0).k, 0.001);

    // Resolved: one canonical form for every index source.
    EXPECT_EQ(s.resolved["binder"]["material"], (nlohmann::json{{"index", 1.5}}));
    EXPECT_EQ(s.resolved["pigments"][1]["material"], (nlohmann::json{{"index", "2+0.001i"}}));
    EXPECT_EQ(s.resolved["pigments"][0]["material"]["nk"][1],
              (nlohmann::json::array({550.0, 2.7, 0.01})));
    EXPECT_EQ(s.resolved["spectrum"], (nlohmann::json{{"wavelengths_nm", {450.0, 500.5, 650.0}}}));
}

TEST(SpecGood, ExampleCatalogueOfPaints) {
    const auto specs = load_specs(good("paint_catalogue.json"));
    ASSERT_EQ(specs.size(), 8u);
    std::vector<std::string> names, hashes;
    for (const auto& s : specs) {
        names.push_back(s.name);
        hashes.push_back(s.hash);
    }
    EXPECT_EQ(names, (std::vector<std::string>{"titanium-white", "zinc-white", "red-oxide",
                                                "cadmium-yellow", "iron-black-glaze",
                                                "carbon-black", "matte-powder", "grey-fog"}));
    std::sort(hashes.begin(), hashes.end());
    EXPECT_EQ(std::unique(hashes.begin(), hashes.end()), hashes.end()) << "hashes must differ";
    EXPECT_EQ(specs[2].layers[0].pigments.size(), 2u);
    EXPECT_NEAR(specs[2].layers[0].pigment_volume_fraction(), 0.15, 1e-15);
    EXPECT_EQ(specs[3].layers[0].binder->index.id, "polycarbonate");
    EXPECT_EQ(specs[0].layers[0].binder->absorption_per_mm, 0.002);
    EXPECT_EQ(specs[6].layers[0].binder->index.id, "air");
    EXPECT_EQ(specs[6].surface.kind, Surface::None);
    EXPECT_EQ(specs[7].surface.kind, Surface::None);
    EXPECT_EQ(specs[7].layers[0].medium->phase, PhaseType::HenyeyGreenstein);
}

TEST(SpecGood, AliasesResolveToCanonicalIds) {
    const auto a = load_specs(good("design_example.json"));
    const auto b = load_specs(good("design_example_minimal.json"));
    EXPECT_EQ(b[0].layers[0].binder->index.id, "pmma"); // "acrylic" is an alias
    EXPECT_EQ(a[0].resolved, b[0].resolved);
    EXPECT_EQ(a[0].hash, b[0].hash);
}

TEST(SpecGood, ResolvedHasDefaultsFilledIn) {
    const auto specs = load_specs(good("design_example_minimal.json"));
    const nlohmann::json& r = specs[0].resolved;
    EXPECT_EQ(r["surface"], "smooth");
    EXPECT_EQ(r["spectrum"], "visible");
    EXPECT_EQ(r["accuracy"], "default");
    EXPECT_EQ(r["outputs"], (nlohmann::json{"merl", "exr"}));
    EXPECT_EQ(r["binder"]["absorption_per_mm"], 0.0);
    EXPECT_EQ(r["binder"]["material"], "pmma");
    // The resolved spec is itself a valid spec that resolves to itself.
    const auto again = parse_specs(r, "resolved");
    EXPECT_EQ(again[0].resolved, r);
    EXPECT_EQ(again[0].hash, specs[0].hash);
}

TEST(SpecGood, HashIsStableAcrossKeyOrderAndWhitespace) {
    const auto a = load_specs(good("design_example.json"));
    const auto b = load_specs(good("design_example_reordered.json"));
    EXPECT_EQ(a[0].resolved.dump(), b[0].resolved.dump());
    EXPECT_EQ(a[0].hash, b[0].hash);
    // 1 and 1.0 are the same number.
    nlohmann::json doc = a[0].resolved;
    doc["binder"]["absorption_per_mm"] = 0; // an integer
    EXPECT_EQ(parse_specs(doc, "x")[0].hash, a[0].hash);
}

TEST(SpecGood, HashDiffersForDifferentContent) {
    const nlohmann::json base = load_specs(good("design_example.json"))[0].resolved;
    const std::string h = parse_specs(base, "x")[0].hash;
    nlohmann::json changed = base;
    changed["pigments"][0]["volume_fraction"] = 0.11;
    EXPECT_NE(parse_specs(changed, "x")[0].hash, h);
    changed = base;
    changed["name"] = "other";
    EXPECT_NE(parse_specs(changed, "x")[0].hash, h);
    changed = base;
    changed["accuracy"] = "draft";
    EXPECT_NE(parse_specs(changed, "x")[0].hash, h);
}

// The hashes every checked-in spec had before the spec format grew films, stacks, rough surfaces,
// colour spaces and new outputs (and before spec.cpp was split): a spec that does not use the new
// keys must keep its resolved JSON byte for byte, or every table computed from it would be redone
// (compute skips a material whose report carries the same spec hash). The hash is FNV-1a of
// resolved.dump(), so it pins the resolved JSON too.
TEST(SpecGood, HashesOfCheckedInSpecsArePinned) {
    const std::vector<std::pair<std::string, std::vector<std::string>>> pinned = {
        {"examples/catalogue.json",
         {"7d8e9b2438246122", "9bfe6a1413f737d1", "43426795aa9f24f7", "b555a77bc3bf00b5",
          "7c4fd50514e982d7", "9dc46c52f3f748d8", "d15500fe100fcd15", "0f2f0e92551f26b2",
          "693df724ffb7adc2", "39c32e71af656fa5", "49ad2ab72950d810", "da8fde8975d6d0b0"}},
        {"tests/data/specs/good/catalogue_defaults.json",
         {"e0e035345e16b196", "1cffaf55a2ca4911", "f710615ae2587d3d"}},
        {"tests/data/specs/good/design_example.json",
         {"53bd56fecc5e79d0"}},
        {"tests/data/specs/good/design_example_minimal.json",
         {"53bd56fecc5e79d0"}},
        {"tests/data/specs/good/design_example_reordered.json",
         {"53bd56fecc5e79d0"}},
        {"tests/data/specs/good/distributions.json",
         {"87ba131c3bb9a856", "53cd83806afd6e46", "375194b3e79d3d3e", "d2a16ad72f413064"}},
        {"tests/data/specs/good/explicit_wavelengths.json",
         {"c928ede2e55d9cba"}},
        {"tests/data/specs/good/media.json",
         {"59c6968202bbc4d4", "beb14ecc4fd20509", "dd532c9c5369b542", "4e3a4f87e530ce2f",
          "231d7726488cc9a2"}},
        {"tests/data/specs/good/paint_catalogue.json",
         {"46fa2f1c5d13d905", "2c3175c39efbedf5", "1cbd3c6332598f61", "010fa687f2bc429d",
          "9b49437cb7122de7", "710758727435cf22", "be25851460941ce2", "855e82618784dc32"}},
    };
    for (const auto& [file, hashes] : pinned) {
        const auto specs = load_specs(test::source_dir() / file);
        std::vector<std::string> got;
        for (const MaterialSpec& s : specs) got.push_back(s.hash);
        EXPECT_EQ(got, hashes) << file;
    }
}

TEST(SpecGood, Fnv1aKnownValues) {
    // FNV-1a 64 test vectors (Fowler, Noll, Vo; http://www.isthe.com/chongo/tech/comp/fnv/).
    EXPECT_EQ(fnv1a64_hex(""), "cbf29ce484222325");
    EXPECT_EQ(fnv1a64_hex("a"), "af63dc4c8601ec8c");
    EXPECT_EQ(fnv1a64_hex("foobar"), "85944171f73967e8");
}

TEST(SpecGood, ExtrapolatedIndexIsAWarningNotAnError) {
    // Rutile's formula is extended over part of the visible range (catalogue.h): a warning.
    const auto specs = load_specs(good("design_example.json"));
    bool found = false;
    for (const auto& w : specs[0].warnings)
        if (w.find("pigments[0].material: tio2-rutile") != std::string::npos) found = true;
    if (!specs[0].layers[0].pigments[0].index.model.is_extended()) GTEST_SKIP() << "rutile is not extended";
    EXPECT_TRUE(found) << ::testing::PrintToString(specs[0].warnings);
}

TEST(SpecGood, DensePigmentLoadWarns) {
    nlohmann::json doc = load_specs(good("design_example.json"))[0].resolved;
    doc["pigments"][0]["volume_fraction"] = 0.7;
    const auto specs = parse_specs(doc, "dense.json");
    bool found = false;
    for (const auto& w : specs[0].warnings)
        if (w.find("dense.json: pigments: volume fractions sum to 0.7") == 0) found = true;
    EXPECT_TRUE(found) << ::testing::PrintToString(specs[0].warnings);
}

// ------------------------------------------------------------------------------------------------
// Bad specs: one file per fault kind, each message line "SOURCE: PATH: fault"

struct BadCase {
    std::string file;                  // under tests/data/specs/bad, without ".json"
    std::vector<std::string> expected; // substrings of the message (most start with " PATH:")
};

std::ostream& operator<<(std::ostream& os, const BadCase& c) { return os << c.file; }

class SpecBad : public ::testing::TestWithParam<BadCase> {};

TEST_P(SpecBad, NamesThePathOfEachFault) {
    const BadCase& c = GetParam();
    const std::filesystem::path file = bad(c.file + ".json");
    const std::string message = input_error(file);
    for (const std::string& e : c.expected)
        EXPECT_NE(message.find(e), std::string::npos)
            << "expected \"" << e << "\" in:\n"
            << message;
    // Every line names the file.
    std::size_t start = 0;
    while (start < message.size()) {
        const std::size_t end = std::min(message.find('\n', start), message.size());
        EXPECT_EQ(message.compare(start, file.string().size(), file.string()), 0)
            << message.substr(start, end - start);
        start = end + 1;
    }
}

const BadCase bad_cases[] = {
    {"unknown_key",
     {" pigments[0].volume_fracton: unknown key (did you mean \"volume_fraction\"?)"}},
    {"unknown_top_key", {" spectrun: unknown key (did you mean \"spectrum\"?)"}},
    {"wrong_type", {" pigments[0].volume_fraction: expected a number, got a string (got \"0.1\")"}},
    {"bad_name", {" name: must be 1 to 100 characters from A-Z a-z 0-9 . _ - "}},
    {"duplicate_names", {" materials[1].name: duplicate name (also at materials[0].name"}},
    {"binder_and_medium", {" medium: cannot be combined with \"binder\""}},
    {"pigments_without_binder", {" binder: missing (pigments need a binder"}},
    {"binder_without_pigments", {" pigments: missing"}},
    {"empty_pigments", {" pigments: must list at least one pigment (got [])"}},
    {"no_model", {" needs either \"binder\" + \"pigments\""}},
    {"unknown_material",
     {" pigments[0].material: unknown material \"rutile\" (did you mean \"tio2-rutile\"?)",
      "built-in materials: tio2-rutile, tio2-anatase"}},
    {"bad_index_string", {" pigments[0].material.index: imaginary part of '2.7-0.01i' is negative"}},
    {"complex_binder_index", {" binder.index: a binder's index must be real"}},
    {"nk_too_few_rows", {" pigments[0].material.nk: needs at least 2 rows"}},
    {"nk_not_ascending", {" pigments[0].material.nk[2][0]: wavelength 550 nm is not greater"}},
    {"nk_negative_k", {" pigments[0].material.nk[1][2]: k must be finite and >= 0 (got -0.1"}},
    {"nk_bad_n", {" pigments[0].material.nk[0][1]: n must be finite and > 0 (got 0)"}},
    {"nk_not_covering_spectrum",
     {" pigments[0].material.nk: wavelength 380 nm is outside the data of the nk table (400-700 "
      "nm) (10 of the spectrum's 41 wavelengths, which span 380-780 nm, are outside); tables are "
      "never extrapolated"}},
    {"volume_fraction_out_of_range", {" pigments[0].volume_fraction: must be in (0, 1] (got 1.5)"}},
    {"volume_fraction_sum", {" pigments: volume fractions sum to 1.2, more than 1 (got 0.7 + 0.5)"}},
    {"negative_radius", {" pigments[0].size.r_eff_um: must be > 0 (got -0.2)"}},
    {"monodisperse_zero_radius", {" pigments[0].size.radius_um: must be > 0 (got 0)"}},
    {"gamma_v_eff", {" pigments[0].size.v_eff: must be in [1e-06, 0.5) for the gamma distribution (it is not "
                     "normalisable at 0.5) (got 0.6)"}},
    {"power_law_v_eff", {" pigments[0].size.v_eff: must be in [1e-06, 2] (got 3)"}},
    {"lognormal_sigma_g", {" pigments[0].size.sigma_g: must be in (1, 3] (got 5)"}},
    {"size_key_of_other_distribution",
     {" pigments[0].size.v_eff: not used by the monodisperse distribution (it takes radius_um)"}},
    {"size_missing_key", {" pigments[0].size.v_eff: missing (the gamma distribution takes"}},
    {"unknown_distribution", {" pigments[0].size.distribution: must be one of monodisperse, "
                              "power_law, gamma, lognormal (did you mean \"gamma\"?)"}},
    {"negative_absorption", {" binder.absorption_per_mm: must be >= 0 (got -1)"}},
    {"albedo_out_of_range", {" medium.albedo[1]: must be in [0, 1] (got 1.2)"}},
    {"bad_phase_type", {" medium.phase.type: must be one of isotropic, rayleigh, "
                        "henyey_greenstein, legendre (did you mean \"henyey_greenstein\"?)"}},
    {"hg_g_out_of_range", {" medium.phase.g: must satisfy |g| < 1 (got 1.0)"}},
    {"legendre_beta0", {" medium.phase.coefficients[0]: beta_0 must be 1"}},
    {"legendre_bound", {" medium.phase.coefficients[2]: must satisfy |beta_2| <= 5"}},
    {"phase_key_of_other_type", {" medium.phase.g: not used by the isotropic phase function"}},
    {"bad_surface",
     {" surface: must be \"none\", \"smooth\", \"gloss\", \"satin\", \"matte\" or {\"roughness\": "
      "alpha} (did you mean \"gloss\"?) (got \"glossy\")"}},
    {"smooth_medium_without_index", {" medium.index: missing (\"surface\": \"smooth\""}},
    {"bad_spectrum", {" spectrum: must be \"visible\", \"rgb\" or {\"wavelengths_nm\": [...]} "
                      "(did you mean \"visible\"?)"}},
    {"wavelengths_not_ascending", {" spectrum.wavelengths_nm[2]: "}},
    {"wavelength_out_of_range", {" spectrum.wavelengths_nm[1]: "}},
    {"wavelength_outside_material_data",
     {" pigments[0].material: wavelength 1000 nm is outside the data of tio2-anatase"}},
    {"bad_accuracy", {" accuracy.tolerance: must be in [1e-8, 0.5]"}},
    {"bad_accuracy_name", {" accuracy: must be \"draft\", \"default\", \"reference\""}},
    {"bad_outputs",
     {" outputs[1]: must be one of merl, exr, fourier, rgl, spectral_exr (got \"png\")"}},
    {"defaults_fault", {" defaults.spectrum: must be \"visible\", \"rgb\""}},
    {"not_an_object", {" expected a JSON object"}},
    {"nan", {"nan.json:3:24: invalid JSON: ", "JSON has no NaN or Infinity"}},
    {"syntax_error", {"syntax_error.json:4:1: invalid JSON: "}},
    {"duplicate_key", {" medium.albedo: duplicate key"}},
    {"three_faults",
     {" materials[1].name: must be 1 to 100 characters",
      " materials[1].pigments[0].size.r_eff_um: must be > 0 (got -0.2)",
      " materials[1].surface: must be \"none\", \"smooth\", \"gloss\", \"satin\", \"matte\" or "
      "{\"roughness\": alpha} (did you mean \"gloss\"?) (got \"glossy\")"}},
};

INSTANTIATE_TEST_SUITE_P(Files, SpecBad, ::testing::ValuesIn(bad_cases),
                         [](const ::testing::TestParamInfo<BadCase>& param_info) {
                             return param_info.param.file;
                         });

TEST(SpecErrors, ThreeFaultsAreThreeLines) {
    const std::string message = input_error(bad("three_faults.json"));
    EXPECT_EQ(line_count(message), 3u) << message;
}

TEST(SpecErrors, DefaultsFaultIsReportedOnce) {
    const std::string message = input_error(bad("defaults_fault.json"));
    EXPECT_EQ(line_count(message), 1u) << message;
}

TEST(SpecErrors, NonFiniteNumbersInADocument) {
    nlohmann::json doc = {{"name", "x"}, {"medium", {{"albedo", std::nan("")}}}};
    EXPECT_NE(input_error(doc).find("doc.json: medium.albedo: must be a finite number (got NaN)"),
              std::string::npos);
    doc["medium"]["albedo"] = std::numeric_limits<double>::infinity();
    EXPECT_NE(input_error(doc).find("medium.albedo: must be a finite number (got Infinity)"),
              std::string::npos);
}

TEST(SpecErrors, EveryWrongTypeIsNamed) {
    const nlohmann::json doc = {{"name", 5},
                                {"binder", "pmma"},
                                {"pigments", {{{"material", 3}, {"volume_fraction", true},
                                               {"size", "big"}}}},
                                {"spectrum", 5},
                                {"accuracy", {1}},
                                {"outputs", "merl"}};
    const std::string message = input_error(doc);
    for (const char* e : {"doc.json: name: expected a string, got a number (got 5)",
                          "doc.json: binder: expected an object",
                          "doc.json: pigments[0].material: expected a material ID",
                          "doc.json: pigments[0].volume_fraction: expected a number, got a boolean",
                          "doc.json: pigments[0].size: expected an object",
                          "doc.json: spectrum: expected \"visible\", \"rgb\"",
                          "doc.json: accuracy: expected \"draft\"",
                          "doc.json: outputs: expected an array"})
        EXPECT_NE(message.find(e), std::string::npos) << e << "\nin:\n" << message;
}

TEST(SpecErrors, UnknownKeysAtEveryLevel) {
    const nlohmann::json doc = {
        {"materials",
         {{{"name", "a"},
           {"colour", "red"},
           {"binder", {{"material", "pmma"}, {"absorption", 1}}},
           {"pigments",
            {{{"material", {{"index", 2.0}, {"k", 0}}},
              {"volume_fraction", 0.1},
              {"size", {{"distribution", "gamma"}, {"r_eff", 0.3}, {"v_eff", 0.1}}}}}}},
          {{"name", "b"}, {"medium", {{"albedo", 0.5}, {"phase", {{"type", "isotropic"}, {"gg", 1}}}}}}}},
        {"default", {}}};
    const std::string message = input_error(doc);
    for (const char* e :
         {"doc.json: default: unknown key (did you mean \"defaults\"?)",
          "doc.json: materials[0].colour: unknown key",
          "doc.json: materials[0].binder.absorption: unknown key (did you mean \"absorption_per_mm\"?)",
          "doc.json: materials[0].pigments[0].material.k: unknown key",
          "doc.json: materials[0].pigments[0].size.r_eff: unknown key (did you mean \"r_eff_um\"?)",
          "doc.json: materials[1].medium.phase.gg: unknown key (did you mean \"g\"?)"})
        EXPECT_NE(message.find(e), std::string::npos) << e << "\nin:\n" << message;
    // The typo "r_eff" is reported; the then missing "r_eff_um" is not reported again.
    EXPECT_EQ(message.find("r_eff_um: missing"), std::string::npos) << message;
    EXPECT_EQ(line_count(message), 6u) << message;
}

TEST(SpecErrors, ATypoOfARequiredKeyIsOneLine) {
    const std::string message = input_error(bad("unknown_key.json"));
    EXPECT_EQ(line_count(message), 1u) << message;
}

TEST(SpecErrors, DuplicateKeysAnywhere) {
    const std::string text = R"({"materials": [
      {"name": "a", "medium": {"albedo": 1}},
      {"name": "b", "binder": {"material": "pmma"},
       "pigments": [{"material": "zno", "volume_fraction": 0.1,
                     "size": {"distribution": "monodisperse", "radius_um": 1, "radius_um": 2}}],
       "name": "c"}]})";
    try {
        parse_specs_text(text, "dup.json");
        ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("dup.json: materials[1].pigments[0].size.radius_um: duplicate key"),
                  std::string::npos)
            << message;
        EXPECT_NE(message.find("dup.json: materials[1].name: duplicate key"), std::string::npos)
            << message;
        EXPECT_EQ(line_count(message), 2u) << message;
    }
}

TEST(SpecErrors, CatalogueShapeProblems) {
    EXPECT_NE(input_error(nlohmann::json{{"materials", nlohmann::json::array()}})
                  .find("doc.json: materials: must list at least one material"),
              std::string::npos);
    EXPECT_NE(input_error(nlohmann::json{{"materials", {1}}})
                  .find("doc.json: materials[0]: expected an object"),
              std::string::npos);
    EXPECT_NE(input_error(nlohmann::json{{"materials", {{{"name", "a"}, {"medium", {{"albedo", 1}}}}}},
                                         {"defaults", {{"name", "x"}}}})
                  .find("doc.json: defaults.name: not allowed"),
              std::string::npos);
    // Names that differ only in case collide on case-insensitive file systems.
    EXPECT_NE(input_error(nlohmann::json{{"materials",
                                          {{{"name", "Paint"}, {"medium", {{"albedo", 1}}}},
                                           {{"name", "paint"}, {"medium", {{"albedo", 1}}}}}}})
                  .find("doc.json: materials[1].name: duplicate name"),
              std::string::npos);
}

TEST(SpecErrors, NameLimits) {
    nlohmann::json doc = {{"name", std::string(100, 'a')}, {"medium", {{"albedo", 1}}}};
    EXPECT_NO_THROW(parse_specs(doc, "x"));
    doc["name"] = std::string(101, 'a');
    EXPECT_NE(input_error(doc).find("doc.json: name: must be 1 to 100"), std::string::npos);
    doc["name"] = "";
    EXPECT_NE(input_error(doc).find("doc.json: name: must be 1 to 100"), std::string::npos);
    doc["name"] = "a/b";
    EXPECT_NE(input_error(doc).find("doc.json: name: must be 1 to 100"), std::string::npos);
    doc.erase("name");
    EXPECT_NE(input_error(doc).find("doc.json: name: missing"), std::string::npos);
}

// ------------------------------------------------------------------------------------------------
// Resource limits (SpecLimits): LimitError naming the limit and the "limits" key that overrides it

std::filesystem::path bad_table_folder(const std::string& name) {
    return test::source_dir() / "tests/data/bad" / name;
}

// The message of the LimitError that `f` throws ("" and a failure if none).
template <typename F>
std::string limit_error(F&& f) {
    try {
        f();
    } catch (const LimitError& e) {
        return e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << "expected LimitError, got " << e.what();
        return {};
    }
    ADD_FAILURE() << "no LimitError";
    return {};
}

nlohmann::json hg_medium(double tolerance) {
    return {{"name", "m"},
            {"medium", {{"albedo", 0.9}}},
            {"surface", "none"},
            {"accuracy", {{"tolerance", tolerance}}}};
}

TEST(SpecLimits, DefaultsAndAbsentFromTheResolvedSpec) {
    const MaterialSpec s = load_specs(good("design_example.json")).at(0);
    EXPECT_EQ(s.limits.max_wavelengths, 2000u);
    EXPECT_EQ(s.limits.max_size_parameter, 5e4);
    EXPECT_EQ(s.limits.min_tolerance, 1e-8);
    EXPECT_EQ(s.limits.max_legendre_terms, 100000u);
    // Not written when not given: the hashes of existing specs do not change.
    EXPECT_FALSE(s.resolved.contains("limits"));
}

TEST(SpecLimits, GivenLimitsAreResolvedAndChangeTheHash) {
    nlohmann::json doc = hg_medium(1e-3);
    const MaterialSpec plain = parse_specs(doc, "doc.json").at(0);
    doc["limits"] = {{"max_size_parameter", 1e6}, {"max_legendre_terms", 200000}};
    const MaterialSpec raised = parse_specs(doc, "doc.json").at(0);
    EXPECT_EQ(raised.limits.max_size_parameter, 1e6);
    EXPECT_EQ(raised.limits.max_legendre_terms, 200000u);
    EXPECT_EQ(raised.limits.max_wavelengths, 2000u);
    EXPECT_EQ(raised.resolved["limits"],
              (nlohmann::json{{"max_legendre_terms", 200000.0}, {"max_size_parameter", 1e6}}));
    EXPECT_NE(raised.hash, plain.hash);
    // parse_specs(resolved) gives the same material again.
    EXPECT_EQ(parse_specs(raised.resolved, "r.json").at(0).hash, raised.hash);
}

TEST(SpecLimits, ToleranceBelowTheLimitNeedsAnOverride) {
    EXPECT_EQ(limit_error([] { parse_specs(hg_medium(1e-9), "doc.json"); }),
              "doc.json: accuracy.tolerance: 1e-09 is below the limit of 1e-08 (the solver's "
              "double-precision floor; streams and time grow as the tolerance falls); to override, "
              "set \"limits\": {\"min_tolerance\": 1e-09}");
    nlohmann::json doc = hg_medium(1e-9);
    doc["limits"] = {{"min_tolerance", 1e-9}};
    EXPECT_EQ(parse_specs(doc, "doc.json").at(0).accuracy.tolerance, 1e-9);
    // Zero and negative tolerances stay input errors, whatever the limits.
    EXPECT_NE(input_error(hg_medium(0.0)).find("accuracy.tolerance: must be in [1e-8, 0.5]"),
              std::string::npos);
}

TEST(SpecLimits, MoreWavelengthsThanTheLimitNeedAnOverride) {
    nlohmann::json doc = hg_medium(1e-3);
    std::vector<double> wavelengths;
    for (int i = 0; i < 2001; ++i) wavelengths.push_back(400.0 + 0.1 * i);
    doc["spectrum"] = {{"wavelengths_nm", wavelengths}};
    EXPECT_EQ(limit_error([&] { parse_specs(doc, "doc.json"); }),
              "doc.json: spectrum.wavelengths_nm: lists 2001 wavelengths, more than the limit of "
              "2000 (the solve's time grows with the count); to override, set \"limits\": "
              "{\"max_wavelengths\": 2001}");
    doc["limits"] = {{"max_wavelengths", 2001}};
    EXPECT_EQ(parse_specs(doc, "doc.json").at(0).spectrum.size(), 2001u);
    // Below the limit and above spectrum.h's own list cap (1000) is accepted as it is.
    wavelengths.resize(1500);
    doc.erase("limits");
    doc["spectrum"] = {{"wavelengths_nm", wavelengths}};
    EXPECT_EQ(parse_specs(doc, "doc.json").at(0).spectrum.size(), 1500u);
}

// One pigment of spheres of one radius in a binder of index 1.5, in RGB.
nlohmann::json one_sphere_size(double radius_um) {
    return {{"name", "p"},
            {"binder", {{"index", 1.5}}},
            {"pigments",
             {{{"index", 2.0},
               {"volume_fraction", 0.1},
               {"size", {{"distribution", "monodisperse"}, {"radius_um", radius_um}}}}}},
            {"spectrum", "rgb"}};
}

TEST(SpecLimits, SizeParameterAboveTheLimitNeedsAnOverride) {
    nlohmann::json doc = one_sphere_size(1000.0);
    doc["limits"] = {{"max_size_parameter", 1e4}};
    // x = 2 pi 1000 um 1.5 / 0.464 um = 20312 at the shortest wavelength of the rgb set: above a
    // lowered limit, below what the Mie module computes.
    EXPECT_EQ(limit_error([&] { parse_specs(doc, "doc.json"); }),
              "doc.json: pigments[0].size: size parameter x = 2 pi r_max n_binder / lambda reaches "
              "20312 (r_max 1000 um, n_binder 1.5 at 464 nm), above the limit of 10000 (Mie "
              "series need about x terms per radius); to override, set \"limits\": "
              "{\"max_size_parameter\": 20313}");
    doc["limits"] = {{"max_size_parameter", 3e4}};
    EXPECT_NO_THROW(parse_specs(doc, "doc.json"));
    // The distribution's upper integration radius counts, not its effective radius.
    doc["pigments"][0]["size"] = {{"distribution", "lognormal"}, {"r_g_um", 8.0}, {"sigma_g", 2.0}};
    EXPECT_NE(limit_error([&] { parse_specs(doc, "doc.json"); }).find("above the limit of 30000"),
              std::string::npos);
}

// Beyond the largest size parameter whose Legendre series the Mie module computes, the refusal
// comes with the spec and offers no override: raising the limit would only move it to the optics.
TEST(SpecLimits, SizeParameterAboveWhatMieComputesIsRefusedWithoutAnOverride) {
    nlohmann::json doc = one_sphere_size(10000.0);
    const std::string fixed =
        "doc.json: pigments[0].size: size parameter x = 2 pi r_max n_binder / lambda reaches "
        "203120 (r_max 1e+04 um, n_binder 1.5 at 464 nm), above 50000, the largest this service "
        "computes (a phase function's Legendre series needs about 2x terms per radius; a fixed "
        "limit)";
    EXPECT_EQ(limit_error([&] { parse_specs(doc, "doc.json"); }), fixed);
    doc["limits"] = {{"max_size_parameter", 3e5}};
    EXPECT_EQ(limit_error([&] { parse_specs(doc, "doc.json"); }), fixed);
    // Just below it the spec is accepted: 2450 um reaches x = 49,764.
    doc.erase("limits");
    doc["pigments"][0]["size"]["radius_um"] = 2450.0;
    EXPECT_NO_THROW(parse_specs(doc, "doc.json"));
}

TEST(SpecLimits, LimitsAndInputFaultsTogetherAreOneInputError) {
    nlohmann::json doc = hg_medium(1e-9);
    doc["surface"] = "glossy";
    const std::string message = input_error(doc);
    EXPECT_NE(message.find("doc.json: surface: must be \"none\", \"smooth\", \"gloss\""),
              std::string::npos);
    EXPECT_NE(message.find("doc.json: accuracy.tolerance: 1e-09 is below the limit"),
              std::string::npos);
}

TEST(SpecLimits, CatalogueDefaultsCanRaiseLimits) {
    const nlohmann::json doc = {
        {"defaults", {{"limits", {{"min_tolerance", 1e-10}}}}},
        {"materials", {hg_medium(1e-9)}}};
    EXPECT_EQ(parse_specs(doc, "doc.json").at(0).limits.min_tolerance, 1e-10);
}

// The malformed specs kept with the malformed tables (tests/data/bad/spec_*.json), each with its
// exact message.
TEST(SpecLimits, CheckedInSpecimens) {
    const auto path = [](const char* name) { return bad_table_folder(name).string(); };
    EXPECT_EQ(limit_error([&] { load_specs(path("spec_too_many_wavelengths.json")); }),
              path("spec_too_many_wavelengths.json") +
                  ": spectrum.wavelengths_nm: lists 2001 wavelengths, more than the limit of 2000 "
                  "(the solve's time grows with the count); to override, set \"limits\": "
                  "{\"max_wavelengths\": 2001}");
    EXPECT_EQ(limit_error([&] { load_specs(path("spec_size_parameter.json")); }),
              path("spec_size_parameter.json") +
                  ": pigments[0].size: size parameter x = 2 pi r_max n_binder / lambda reaches "
                  "124899 (r_max 5000 um, n_binder 1.511 at 380 nm), above 50000, the largest this "
                  "service computes (a phase function's Legendre series needs about 2x terms per "
                  "radius; a fixed limit)");
    EXPECT_EQ(limit_error([&] { load_specs(path("spec_tolerance_below_limit.json")); }),
              path("spec_tolerance_below_limit.json") +
                  ": accuracy.tolerance: 1e-09 is below the limit of 1e-08 (the solver's "
                  "double-precision floor; streams and time grow as the tolerance falls); to "
                  "override, set \"limits\": {\"min_tolerance\": 1e-09}");
    const std::string limits = path("spec_bad_limits.json");
    EXPECT_EQ(input_error(bad_table_folder("spec_bad_limits.json")),
              limits + ": limits.max_size_parametr: unknown key (did you mean "
                       "\"max_size_parameter\"?); expected one of: max_wavelengths, "
                       "max_size_parameter, min_tolerance, max_legendre_terms\n" +
                  limits + ": limits.max_wavelengths: must be a whole number in [1, 1e9] (got 2.5)\n" +
                  limits + ": limits.min_tolerance: must be in (0, 0.5] (got 0)");
    EXPECT_EQ(input_error(bad_table_folder("spec_truncated.json")),
              path("spec_truncated.json") +
                  ":4:6: invalid JSON: syntax error while parsing object key - invalid string: "
                  "missing closing quote; last read: '\"'; expected string literal");
}

// Found by fuzz_spec: a number beyond the range of a double escaped parse_specs_text as a
// nlohmann::json out_of_range exception instead of an InputError.
TEST(SpecErrors, NumberOverflowIsAnInputError) {
    EXPECT_NE(input_error(test::source_dir() /
                          "tests/data/fuzz/regressions/spec-number-overflow.json")
                  .find(": invalid JSON: number overflow parsing '0.1e30815'"),
              std::string::npos);
    try {
        parse_specs_text(R"({"name": "x", "medium": {"albedo": 1e400}})", "doc.json");
        ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()), "doc.json: invalid JSON: number overflow parsing '1e400' "
                                         "(every number in a spec must fit in a double)");
    }
}

TEST(SpecErrors, UnreadableFileIsAnIoError) {
    EXPECT_THROW(load_specs(bad("does_not_exist.json")), IoError);
    EXPECT_THROW(load_specs(test::source_dir() / "tests/data/specs"), IoError);
}

// ------------------------------------------------------------------------------------------------
// "model": "exact" (default) | "dipole" (the Jensen et al. 2001 comparison model)

nlohmann::json model_medium() {
    return {{"name", "m"}, {"medium", {{"albedo", 0.9}, {"phase", {{"type", "henyey_greenstein"}, {"g", 0.5}}}}},
            {"spectrum", "rgb"}};
}

TEST(SpecModel, DefaultIsExactAndLeavesTheResolvedSpecAndHashUnchanged) {
    nlohmann::json plain = model_medium(), exact = model_medium();
    exact["model"] = "exact";
    const auto a = parse_specs(plain, "a.json"), b = parse_specs(exact, "b.json");
    ASSERT_EQ(a.size(), 1u);
    ASSERT_EQ(b.size(), 1u);
    EXPECT_EQ(a[0].model, Model::Exact);
    EXPECT_EQ(b[0].model, Model::Exact);
    EXPECT_FALSE(a[0].resolved.contains("model"));
    EXPECT_FALSE(b[0].resolved.contains("model"));
    EXPECT_EQ(a[0].hash, b[0].hash);
}

TEST(SpecModel, DipoleIsResolvedHashedAndRoundTrips) {
    nlohmann::json doc = model_medium();
    doc["model"] = "dipole";
    const auto d = parse_specs(doc, "d.json");
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].model, Model::Dipole);
    EXPECT_EQ(d[0].resolved["model"], "dipole");
    EXPECT_NE(d[0].hash, parse_specs(model_medium(), "e.json")[0].hash);
    const auto again = parse_specs(d[0].resolved, "again.json");
    EXPECT_EQ(again[0].model, Model::Dipole);
    EXPECT_EQ(again[0].hash, d[0].hash);
    EXPECT_EQ(to_string(Model::Dipole), "dipole");
    EXPECT_EQ(to_string(Model::Exact), "exact");
}

TEST(SpecModel, CatalogueDefaultsCarryTheModel) {
    const nlohmann::json doc = {{"defaults", {{"model", "dipole"}}},
                                {"materials", {model_medium(), [] { auto m = model_medium(); m["name"] = "n"; m["model"] = "exact"; return m; }()}}};
    const auto specs = parse_specs(doc, "cat.json");
    ASSERT_EQ(specs.size(), 2u);
    EXPECT_EQ(specs[0].model, Model::Dipole);
    EXPECT_EQ(specs[1].model, Model::Exact);
}

TEST(SpecModel, BadValuesNameThePath) {
    nlohmann::json typo = model_medium();
    typo["model"] = "dipol";
    EXPECT_EQ(input_error(typo),
              "doc.json: model: must be \"exact\" or \"dipole\" (did you mean \"dipole\"?) (got \"dipol\")");
    nlohmann::json number = model_medium();
    number["model"] = 3;
    const std::string e = input_error(number);
    EXPECT_NE(e.find("doc.json: model: "), std::string::npos) << e;
    EXPECT_EQ(line_count(e), 1u) << e;
    // Reported together with other faults, each on its own line.
    nlohmann::json two = typo;
    two["surface"] = "shiny";
    EXPECT_EQ(line_count(input_error(two)), 2u);
}

// ------------------------------------------------------------------------------------------------
// Films, stacks, rough surfaces, colour spaces and the new outputs (docs/spec.md; docs/design.md,
// "Extensions ... (turn 2)")

nlohmann::json white_layer() {
    return {{"binder", {{"material", "pmma"}}},
            {"pigments",
             {{{"material", "tio2-rutile"},
               {"volume_fraction", 0.1},
               {"size", {{"distribution", "power_law"}, {"r_eff_um", 0.4}, {"v_eff", 0.3}}}}}}};
}

nlohmann::json white(const std::string& name = "w") {
    nlohmann::json doc = white_layer();
    doc["name"] = name;
    return doc;
}

// parse_specs(resolved) gives the same material: the same resolved JSON and hash, and the same
// values of every new field.
void expect_round_trip(const MaterialSpec& s) {
    const auto again = parse_specs(s.resolved, "resolved.json");
    ASSERT_EQ(again.size(), 1u) << s.name;
    const MaterialSpec& r = again[0];
    EXPECT_EQ(r.resolved, s.resolved) << s.name;
    EXPECT_EQ(r.hash, s.hash) << s.name;
    ASSERT_EQ(r.layers.size(), s.layers.size()) << s.name;
    for (std::size_t k = 0; k < s.layers.size(); ++k) {
        const LayerSpec &a = s.layers[k], &b = r.layers[k];
        EXPECT_EQ(a.thickness_um, b.thickness_um) << s.name << " layer " << k;
        EXPECT_EQ(a.binder.has_value(), b.binder.has_value()) << s.name << " layer " << k;
        EXPECT_EQ(a.pigments.size(), b.pigments.size()) << s.name << " layer " << k;
        EXPECT_EQ(a.pigment_volume_fraction(), b.pigment_volume_fraction()) << s.name;
        ASSERT_EQ(a.medium.has_value(), b.medium.has_value()) << s.name << " layer " << k;
        if (a.medium) {
            EXPECT_EQ(a.medium->optical_depth, b.medium->optical_depth) << s.name;
            EXPECT_EQ(a.medium->index, b.medium->index) << s.name;
            EXPECT_EQ(a.medium->albedo, b.medium->albedo) << s.name;
        }
        EXPECT_EQ(a.semi_infinite(), b.semi_infinite()) << s.name << " layer " << k;
    }
    ASSERT_EQ(r.substrate.has_value(), s.substrate.has_value()) << s.name;
    if (s.substrate) {
        EXPECT_EQ(r.substrate->albedo, s.substrate->albedo) << s.name;
        EXPECT_EQ(r.substrate->grey, s.substrate->grey) << s.name;
    }
    EXPECT_EQ(r.surface.kind, s.surface.kind) << s.name;
    EXPECT_EQ(r.surface.roughness, s.surface.roughness) << s.name;
    EXPECT_EQ(r.surface.distribution, s.surface.distribution) << s.name;
    EXPECT_EQ(r.surface.finish, s.surface.finish) << s.name;
    EXPECT_EQ(r.colorspace, s.colorspace) << s.name;
    EXPECT_EQ(r.outputs, s.outputs) << s.name;
}

TEST(SpecFilms, ThicknessSubstrateAndOpticalDepth) {
    const auto specs = load_specs(good("films.json"));
    ASSERT_EQ(specs.size(), 4u);

    const MaterialSpec& film = specs[0];
    ASSERT_EQ(film.layers.size(), 1u);
    EXPECT_EQ(film.layers[0].thickness_um, 25.0);
    EXPECT_FALSE(film.layers[0].semi_infinite());
    EXPECT_EQ(film.layers[0].pigments.size(), 1u);
    EXPECT_DOUBLE_EQ(film.layers[0].pigment_volume_fraction(), 0.1);
    ASSERT_TRUE(film.substrate.has_value());
    EXPECT_EQ(film.substrate->albedo, (std::array<double, 3>{0.8, 0.8, 0.8}));
    EXPECT_TRUE(film.substrate->grey);
    EXPECT_EQ(film.surface.kind, Surface::Smooth);
    EXPECT_EQ(film.resolved["thickness_um"], 25.0);
    EXPECT_EQ(film.resolved["substrate"], (nlohmann::json{{"albedo", 0.8}}));
    EXPECT_FALSE(film.resolved.contains("layers"));

    // A finite layer without a substrate lies on a black one, written into the resolved spec.
    const MaterialSpec& on_black = specs[1];
    ASSERT_TRUE(on_black.substrate.has_value());
    EXPECT_EQ(on_black.substrate->albedo, (std::array<double, 3>{0.0, 0.0, 0.0}));
    EXPECT_EQ(on_black.resolved["substrate"], (nlohmann::json{{"albedo", 0.0}}));

    // A clear binder film: no pigments, resolved without the key; a coloured substrate.
    const MaterialSpec& clear = specs[2];
    EXPECT_TRUE(clear.layers[0].pigments.empty());
    EXPECT_EQ(clear.layers[0].pigment_volume_fraction(), 0.0);
    EXPECT_EQ(clear.layers[0].thickness_um, 5.0);
    EXPECT_FALSE(clear.resolved.contains("pigments"));
    EXPECT_EQ(clear.substrate->albedo, (std::array<double, 3>{0.8, 0.7, 0.6}));
    EXPECT_FALSE(clear.substrate->grey);
    EXPECT_EQ(clear.resolved["substrate"]["albedo"], (nlohmann::json{0.8, 0.7, 0.6}));

    // An analytic medium of finite optical depth.
    const MaterialSpec& slab = specs[3];
    ASSERT_TRUE(slab.layers[0].medium.has_value());
    EXPECT_EQ(slab.layers[0].medium->optical_depth, 2.0);
    EXPECT_FALSE(slab.layers[0].thickness_um.has_value());
    EXPECT_FALSE(slab.layers[0].semi_infinite());
    EXPECT_EQ(slab.substrate->albedo[1], 0.5);
    EXPECT_EQ(slab.surface.kind, Surface::None);
    EXPECT_EQ(slab.resolved["medium"]["optical_depth"], 2.0);

    for (const MaterialSpec& s : specs) expect_round_trip(s);
}

TEST(SpecFilms, SemiInfiniteLayersHaveNoSubstrate) {
    const MaterialSpec s = parse_specs(white(), "w.json").at(0);
    ASSERT_EQ(s.layers.size(), 1u);
    EXPECT_TRUE(s.layers[0].semi_infinite());
    EXPECT_FALSE(s.substrate.has_value());
    EXPECT_FALSE(s.resolved.contains("substrate"));
    EXPECT_FALSE(s.resolved.contains("thickness_um"));
}

TEST(SpecFilms, AnExplicitBlackSubstrateIsTheDefault) {
    nlohmann::json doc = white();
    doc["thickness_um"] = 10;
    const std::string implicit = parse_specs(doc, "a.json").at(0).hash;
    doc["substrate"] = {{"albedo", 0}};
    EXPECT_EQ(parse_specs(doc, "b.json").at(0).hash, implicit);
    doc["substrate"] = {{"albedo", 0.5}};
    EXPECT_NE(parse_specs(doc, "c.json").at(0).hash, implicit);
    doc.erase("substrate");
    doc["thickness_um"] = 11;
    EXPECT_NE(parse_specs(doc, "d.json").at(0).hash, implicit);
}

TEST(SpecStacks, LayersTopFirst) {
    const auto specs = load_specs(good("stacks.json"));
    ASSERT_EQ(specs.size(), 3u);

    const MaterialSpec& coat = specs[0];
    ASSERT_EQ(coat.layers.size(), 2u);
    EXPECT_TRUE(coat.layers[0].pigments.empty()); // the clear coat on top
    EXPECT_EQ(coat.layers[0].thickness_um, 20.0);
    EXPECT_EQ(coat.layers[1].pigments.size(), 1u);
    EXPECT_TRUE(coat.layers[1].semi_infinite());
    EXPECT_FALSE(coat.substrate.has_value());
    EXPECT_EQ(coat.surface.kind, Surface::Rough);
    EXPECT_EQ(coat.surface.finish, "gloss");
    EXPECT_EQ(coat.surface.roughness, 0.03);
    EXPECT_EQ(coat.resolved["surface"], "gloss");
    ASSERT_TRUE(coat.resolved.contains("layers"));
    EXPECT_EQ(coat.resolved["layers"].size(), 2u);
    EXPECT_FALSE(coat.resolved.contains("binder"));
    EXPECT_EQ(coat.resolved["layers"][0],
              (nlohmann::json{{"binder", {{"material", "pmma"}, {"absorption_per_mm", 0.0}}},
                              {"thickness_um", 20.0}}));

    const MaterialSpec& base = specs[1];
    ASSERT_EQ(base.layers.size(), 2u);
    EXPECT_EQ(base.layers[0].thickness_um, 15.0);
    EXPECT_EQ(base.layers[0].binder->absorption_per_mm, 0.01);
    ASSERT_TRUE(base.layers[1].medium.has_value());
    EXPECT_EQ(base.layers[1].medium->optical_depth, 3.0);
    EXPECT_EQ(base.layers[1].medium->index, 1.5);
    EXPECT_EQ(base.substrate->albedo, (std::array<double, 3>{0.2, 0.2, 0.2}));
    EXPECT_FALSE(base.substrate->grey);
    EXPECT_EQ(base.surface.kind, Surface::Rough);
    EXPECT_EQ(base.surface.distribution, Microfacet::Beckmann);
    EXPECT_EQ(base.surface.roughness, 0.2);
    EXPECT_EQ(base.surface.finish, "");
    EXPECT_EQ(base.resolved["surface"],
              (nlohmann::json{{"roughness", 0.2}, {"distribution", "beckmann"}}));
    EXPECT_EQ(base.colorspace, ColorSpace::AcesCg);
    EXPECT_EQ(base.resolved["colorspace"], "acescg");
    // Outputs in their canonical order, whatever the order written.
    EXPECT_EQ(base.outputs,
              (std::vector<std::string>{"merl", "exr", "fourier", "rgl", "spectral_exr"}));

    // Media all the way down; the lower one has no index (index-matched to the one above).
    const MaterialSpec& media = specs[2];
    ASSERT_EQ(media.layers.size(), 2u);
    EXPECT_EQ(media.layers[0].medium->optical_depth, 1.0);
    EXPECT_FALSE(media.layers[1].medium->index.has_value());
    EXPECT_EQ(media.layers[1].medium->phase, PhaseType::HenyeyGreenstein);
    EXPECT_EQ(media.surface.kind, Surface::None);

    for (const MaterialSpec& s : specs) expect_round_trip(s);
}

TEST(SpecStacks, AStackOfOneLayerIsThatLayer) {
    const MaterialSpec plain = load_specs(good("design_example.json")).at(0);
    nlohmann::json doc = {{"name", "seed-tio2-white"}, {"layers", {white_layer()}}};
    const MaterialSpec stacked = parse_specs(doc, "stack.json").at(0);
    EXPECT_EQ(stacked.resolved, plain.resolved);
    EXPECT_EQ(stacked.hash, plain.hash);
    // The same for a film.
    nlohmann::json film = white("f");
    film["thickness_um"] = 8;
    nlohmann::json layer = white_layer();
    layer["thickness_um"] = 8;
    EXPECT_EQ(parse_specs({{"name", "f"}, {"layers", {layer}}}, "a.json").at(0).hash,
              parse_specs(film, "b.json").at(0).hash);
}

TEST(SpecStacks, TheTopLayerSetsTheDefaultSurface) {
    nlohmann::json doc = {{"name", "s"},
                          {"layers", {{{"medium", {{"albedo", 0.5}, {"optical_depth", 1}}}},
                                      white_layer()}}};
    EXPECT_EQ(parse_specs(doc, "a.json").at(0).surface.kind, Surface::None);
    doc["layers"] = {{{"binder", {{"index", 1.5}}}, {"thickness_um", 3}},
                     {{"medium", {{"albedo", 0.5}}}}};
    EXPECT_EQ(parse_specs(doc, "b.json").at(0).surface.kind, Surface::Smooth);
}

TEST(SpecStacks, VolumeFractionsAndDenseLoadsArePerLayer) {
    nlohmann::json layer = white_layer();
    layer["pigments"][0]["volume_fraction"] = 0.5;
    layer["thickness_um"] = 10;
    nlohmann::json last = white_layer();
    last["pigments"][0]["volume_fraction"] = 0.7;
    // 0.5 + 0.7 over two layers is fine: each layer's pigments share that layer only.
    const MaterialSpec s = parse_specs({{"name", "s"}, {"layers", {layer, last}}}, "v.json").at(0);
    bool dense = false;
    for (const auto& w : s.warnings)
        if (w.find("v.json: layers[1].pigments: volume fractions sum to 0.7") == 0) dense = true;
    EXPECT_TRUE(dense) << ::testing::PrintToString(s.warnings);
    // Within one layer they must not exceed 1.
    last["pigments"].push_back(last["pigments"][0]);
    EXPECT_EQ(input_error(nlohmann::json{{"name", "s"}, {"layers", {layer, last}}}),
              "doc.json: layers[1].pigments: volume fractions sum to 1.4, more than 1 (got 0.7 + "
              "0.7)");
}

TEST(SpecStacks, TheSizeParameterLimitAppliesToEveryLayer) {
    nlohmann::json top = white_layer();
    top["thickness_um"] = 10;
    nlohmann::json big = {
        {"binder", {{"index", 1.5}}},
        {"pigments",
         {white_layer()["pigments"][0],
          {{"index", 2.0},
           {"volume_fraction", 0.1},
           {"size", {{"distribution", "monodisperse"}, {"radius_um", 10000.0}}}}}}};
    const nlohmann::json doc = {{"name", "p"}, {"layers", {top, big}}, {"spectrum", "rgb"}};
    EXPECT_EQ(limit_error([&] { parse_specs(doc, "doc.json"); }),
              "doc.json: layers[1].pigments[1].size: size parameter x = 2 pi r_max n_binder / "
              "lambda reaches 203120 (r_max 1e+04 um, n_binder 1.5 at 464 nm), above 50000, the "
              "largest this service computes (a phase function's Legendre series needs about 2x "
              "terms per radius; a fixed limit)");
}

TEST(SpecSurface, NamedFinishesAndRoughness) {
    const struct {
        const char* finish;
        double alpha;
    } finishes[] = {{"gloss", 0.03}, {"satin", 0.15}, {"matte", 0.40}};
    for (const auto& f : finishes) {
        nlohmann::json doc = white();
        doc["surface"] = f.finish;
        const MaterialSpec s = parse_specs(doc, "f.json").at(0);
        EXPECT_EQ(s.surface.kind, Surface::Rough) << f.finish;
        EXPECT_EQ(s.surface.roughness, f.alpha) << f.finish;
        EXPECT_EQ(s.surface.distribution, Microfacet::Ggx) << f.finish;
        EXPECT_EQ(s.surface.finish, f.finish);
        EXPECT_EQ(s.resolved["surface"], f.finish);
        expect_round_trip(s);
    }
    nlohmann::json doc = white();
    doc["surface"] = {{"roughness", 0.001}}; // the distribution defaults to GGX
    MaterialSpec s = parse_specs(doc, "r.json").at(0);
    EXPECT_EQ(s.surface.kind, Surface::Rough);
    EXPECT_EQ(s.surface.roughness, 0.001);
    EXPECT_EQ(s.surface.distribution, Microfacet::Ggx);
    EXPECT_EQ(s.resolved["surface"], (nlohmann::json{{"roughness", 0.001}, {"distribution", "ggx"}}));
    expect_round_trip(s);
    doc["surface"] = {{"roughness", 1}, {"distribution", "beckmann"}};
    s = parse_specs(doc, "r.json").at(0);
    EXPECT_EQ(s.surface.roughness, 1.0);
    EXPECT_EQ(s.surface.distribution, Microfacet::Beckmann);
    // "smooth" and "none" are unchanged and carry no roughness.
    doc["surface"] = "none";
    s = parse_specs(doc, "n.json").at(0);
    EXPECT_EQ(s.surface.kind, Surface::None);
    EXPECT_EQ(s.surface.roughness, 0.0);
    EXPECT_EQ(s.surface.finish, "");
    EXPECT_EQ(to_string(Surface::Rough), "rough");
    EXPECT_EQ(to_string(Microfacet::Ggx), "ggx");
    EXPECT_EQ(to_string(Microfacet::Beckmann), "beckmann");
}

TEST(SpecSurface, ARoughSurfaceOnAMediumNeedsItsIndex) {
    nlohmann::json doc = {{"name", "m"},
                          {"medium", {{"albedo", 0.9}, {"index", 1.4}}},
                          {"surface", "satin"}};
    EXPECT_EQ(parse_specs(doc, "m.json").at(0).layers[0].medium->index, 1.4);
    // In a stack only the top medium needs one.
    doc = {{"name", "m"},
           {"surface", {{"roughness", 0.3}}},
           {"layers", {{{"medium", {{"albedo", 0.9}, {"optical_depth", 1}}}},
                       {{"medium", {{"albedo", 0.9}}}}}}};
    EXPECT_EQ(input_error(doc),
              "doc.json: layers[0].medium.index: missing (a rough \"surface\" on an analytic "
              "medium needs the medium's real refractive index, e.g. \"index\": 1.5)");
    doc["layers"][0]["medium"]["index"] = 1.5;
    EXPECT_NO_THROW(parse_specs(doc, "doc.json"));
}

TEST(SpecColorspace, DefaultIsRec709AndLeavesTheHashUnchanged) {
    const MaterialSpec plain = parse_specs(white(), "a.json").at(0);
    EXPECT_EQ(plain.colorspace, ColorSpace::Rec709);
    EXPECT_FALSE(plain.resolved.contains("colorspace"));
    nlohmann::json doc = white();
    doc["colorspace"] = "rec709";
    EXPECT_EQ(parse_specs(doc, "b.json").at(0).hash, plain.hash);
    doc["colorspace"] = "rec2020";
    const MaterialSpec wide = parse_specs(doc, "c.json").at(0);
    EXPECT_EQ(wide.colorspace, ColorSpace::Rec2020);
    EXPECT_EQ(wide.resolved["colorspace"], "rec2020");
    EXPECT_NE(wide.hash, plain.hash);
    expect_round_trip(wide);
}

TEST(SpecCatalogue, DefaultsMergeByModelGroup) {
    const nlohmann::json doc = {
        {"defaults",
         {{"binder", {{"material", "pmma"}}}, {"thickness_um", 30}, {"substrate", {{"albedo", 0.8}}}}},
        {"materials",
         {// inherits binder, thickness and substrate: a film
          {{"name", "paint"}, {"pigments", white_layer()["pigments"]}},
          // its own thickness: still inherits the binder (the same group) and the substrate
          {{"name", "thin"}, {"pigments", white_layer()["pigments"]}, {"thickness_um", 5}},
          // a semi-infinite medium: neither the particulate keys nor the films' substrate
          {{"name", "fog"}, {"medium", {{"albedo", 0.9}}}},
          // a stack: no single-layer keys; its last layer is finite, so the substrate applies
          {{"name", "stack"},
           {"layers", {{{"medium", {{"albedo", 0.9}, {"optical_depth", 1}, {"index", 1.5}}}}}}}}}};
    const auto specs = parse_specs(doc, "cat.json");
    ASSERT_EQ(specs.size(), 4u);
    EXPECT_EQ(specs[0].layers[0].thickness_um, 30.0);
    EXPECT_EQ(specs[0].layers[0].binder->index.id, "pmma");
    EXPECT_EQ(specs[0].substrate->albedo[0], 0.8);
    EXPECT_EQ(specs[1].layers[0].thickness_um, 5.0);
    EXPECT_EQ(specs[1].layers[0].binder->index.id, "pmma");
    EXPECT_FALSE(specs[2].layers[0].binder.has_value());
    EXPECT_TRUE(specs[2].layers[0].semi_infinite());
    EXPECT_FALSE(specs[2].substrate.has_value());
    EXPECT_FALSE(specs[2].resolved.contains("substrate"));
    EXPECT_FALSE(specs[3].layers[0].binder.has_value());
    EXPECT_EQ(specs[3].layers[0].medium->optical_depth, 1.0);
    EXPECT_EQ(specs[3].substrate->albedo[2], 0.8);
    // The other way round: a catalogue of stacks does not give its layers to a top-level material.
    const nlohmann::json stacks = {
        {"defaults", {{"layers", {{{"medium", {{"albedo", 0.9}}}}}}}},
        {"materials", {white("own"), {{"name", "inherited"}}}}};
    const auto s2 = parse_specs(stacks, "stacks.json");
    ASSERT_EQ(s2.size(), 2u);
    EXPECT_EQ(s2[0].hash, parse_specs(white("own"), "x.json").at(0).hash);
    EXPECT_TRUE(s2[1].layers[0].medium.has_value());
}

// Every fault of the new keys, with its exact message (tests/data/specs/bad, one file each).
struct ExactCase {
    std::string file;               // under tests/data/specs/bad, without ".json"
    std::vector<std::string> lines; // the whole message, each line without "FILE: "
};

std::ostream& operator<<(std::ostream& os, const ExactCase& c) { return os << c.file; }

class SpecBadExact : public ::testing::TestWithParam<ExactCase> {};

TEST_P(SpecBadExact, ExactMessage) {
    const ExactCase& c = GetParam();
    const std::filesystem::path file = bad(c.file + ".json");
    std::string expected;
    for (const std::string& line : c.lines) {
        if (!expected.empty()) expected += '\n';
        expected += file.string();
        expected += ": ";
        expected += line;
    }
    EXPECT_EQ(input_error(file), expected);
}

const ExactCase exact_cases[] = {
    {"thickness_negative", {"thickness_um: must be > 0 (got -5)"}},
    {"optical_depth_zero", {"medium.optical_depth: must be > 0 (got 0)"}},
    {"thickness_on_medium",
     {"thickness_um: not used by an analytic medium (give its optical depth instead: \"medium\": "
      "{..., \"optical_depth\": tau})"}},
    {"substrate_semi_infinite",
     {"substrate: not allowed under a semi-infinite layer (nothing lies under it; give the last "
      "layer \"thickness_um\", or \"optical_depth\" in its medium, to make it a film)"}},
    {"layers_empty", {"layers: must list at least one layer, top first (got [])"}},
    {"layers_semi_infinite_not_last",
     {"layers[0].medium.optical_depth: missing (only the last layer may be semi-infinite)"}},
    {"clear_binder_without_thickness",
     {"pigments: missing (a particulate material needs at least one pigment; a clear binder "
      "layer needs \"thickness_um\")"}},
    {"substrate_albedo_out_of_range", {"substrate.albedo[2]: must be in [0, 1] (got 1.5)"}},
    {"substrate_albedo_shape",
     {"substrate.albedo: expected one number or three [r, g, b] (got [0.5,0.5])"}},
    {"layers_and_single_layer_keys",
     {"binder: cannot be combined with \"layers\" (a material is one layer given by its own "
      "binder, pigments, medium, thickness_um, or a stack given by \"layers\"; move it into a "
      "layer)",
      "thickness_um: cannot be combined with \"layers\" (a material is one layer given by its own "
      "binder, pigments, medium, thickness_um, or a stack given by \"layers\"; move it into a "
      "layer)"}},
    {"layer_unknown_key",
     {"layers[0].thicknes_um: unknown key (did you mean \"thickness_um\"?); expected one of: "
      "binder, pigments, medium, thickness_um (a layer is \"binder\" + \"pigments\" + "
      "\"thickness_um\", or \"medium\" with its \"optical_depth\" inside)"}},
    {"roughness_out_of_range",
     {"surface.roughness: must be in [0.001, 1] (alpha of Walter et al. 2007; below 0.001 use "
      "\"smooth\") (got 2)"}},
    {"unknown_microfacet",
     {"surface.distribution: must be one of ggx, beckmann (did you mean \"ggx\"?) (got \"gxx\")"}},
    {"unknown_finish",
     {"surface: must be \"none\", \"smooth\", \"gloss\", \"satin\", \"matte\" or {\"roughness\": "
      "alpha} (did you mean \"satin\"?) (got \"satine\")"}},
    {"unknown_colorspace",
     {"colorspace: must be one of rec709, acescg, rec2020 (did you mean \"acescg\"?) (got "
      "\"aces\")"}},
    {"unknown_output",
     {"outputs[1]: must be one of merl, exr, fourier, rgl, spectral_exr (did you mean "
      "\"spectral_exr\"?) (got \"spectral-exr\")"}},
    {"rough_medium_without_index",
     {"medium.index: missing (a rough \"surface\" on an analytic medium needs the medium's real "
      "refractive index, e.g. \"index\": 1.5)"}},
};

INSTANTIATE_TEST_SUITE_P(Files, SpecBadExact, ::testing::ValuesIn(exact_cases),
                         [](const ::testing::TestParamInfo<ExactCase>& param_info) {
                             return param_info.param.file;
                         });

TEST(SpecNewKeyFaults, NonFiniteAndNonPositiveValues) {
    nlohmann::json doc = white();
    doc["thickness_um"] = std::nan("");
    EXPECT_EQ(input_error(doc), "doc.json: thickness_um: must be a finite number (got NaN)");
    doc["thickness_um"] = 0;
    EXPECT_EQ(input_error(doc), "doc.json: thickness_um: must be > 0 (got 0)");
    doc["thickness_um"] = "10";
    EXPECT_EQ(input_error(doc),
              "doc.json: thickness_um: expected a number, got a string (got \"10\")");

    nlohmann::json medium = {{"name", "m"}, {"medium", {{"albedo", 0.9}, {"optical_depth", -1}}}};
    EXPECT_EQ(input_error(medium), "doc.json: medium.optical_depth: must be > 0 (got -1)");
    medium["medium"]["optical_depth"] = std::numeric_limits<double>::infinity();
    EXPECT_EQ(input_error(medium),
              "doc.json: medium.optical_depth: must be a finite number (got Infinity)");

    doc = white();
    doc["surface"] = {{"roughness", std::nan("")}};
    EXPECT_EQ(input_error(doc), "doc.json: surface.roughness: must be a finite number (got NaN)");
    doc["surface"] = {{"roughness", 0.0009}};
    EXPECT_EQ(input_error(doc),
              "doc.json: surface.roughness: must be in [0.001, 1] (alpha of Walter et al. 2007; "
              "below 0.001 use \"smooth\") (got 0.0009)");
    doc["surface"] = {{"distribution", "ggx"}};
    EXPECT_EQ(input_error(doc),
              "doc.json: surface.roughness: missing (the microfacet roughness alpha of Walter et "
              "al. 2007, in [0.001, 1])");
    doc["surface"] = {{"roughnes", 0.1}};
    EXPECT_EQ(input_error(doc),
              "doc.json: surface.roughnes: unknown key (did you mean \"roughness\"?); expected one "
              "of: roughness, distribution");
    doc["surface"] = 0.1;
    EXPECT_EQ(input_error(doc),
              "doc.json: surface: expected \"none\", \"smooth\", a finish (\"gloss\", \"satin\", "
              "\"matte\") or {\"roughness\": alpha}, got a number (got 0.1)");
}

TEST(SpecNewKeyFaults, SubstrateShapes) {
    nlohmann::json doc = white();
    doc["thickness_um"] = 10;
    doc["substrate"] = {{"albedo", -0.1}};
    EXPECT_EQ(input_error(doc), "doc.json: substrate.albedo: must be in [0, 1] (got -0.1)");
    doc["substrate"] = {{"albedo", "white"}};
    EXPECT_EQ(input_error(doc),
              "doc.json: substrate.albedo: expected a number in [0, 1] or [r, g, b], got a string "
              "(got \"white\")");
    doc["substrate"] = 0.5;
    EXPECT_EQ(input_error(doc),
              "doc.json: substrate: expected an object (e.g. {\"albedo\": 0.8} or {\"albedo\": "
              "[0.8, 0.7, 0.6]}), got a number (got 0.5)");
    doc["substrate"] = nlohmann::json::object();
    EXPECT_EQ(input_error(doc),
              "doc.json: substrate.albedo: missing (the substrate's Lambertian albedo: a number "
              "in [0, 1] or [r, g, b]; 0 is black)");
    doc["substrate"] = {{"albedo", 0.5}, {"colour", "red"}};
    EXPECT_EQ(input_error(doc),
              "doc.json: substrate.colour: unknown key; expected one of: albedo");
}

TEST(SpecNewKeyFaults, LayerShapes) {
    EXPECT_EQ(input_error(nlohmann::json{{"name", "s"}, {"layers", white_layer()}}),
              "doc.json: layers: expected an array of layers, top first, got an object (got "
              "{\"binder\":{\"material\":\"pmma\"},\"pigments\":[{\"material\":\"t ...)");
    EXPECT_EQ(input_error(nlohmann::json{{"name", "s"}, {"layers", {5}}}),
              "doc.json: layers[0]: expected an object (a layer: {\"binder\": ..., \"pigments\": "
              "[...], \"thickness_um\": T} or {\"medium\": {...}}), got a number (got 5)");
    EXPECT_EQ(input_error(nlohmann::json{{"name", "s"}, {"layers", {nlohmann::json::object()}}}),
              "doc.json: layers[0]: needs either \"binder\" + \"pigments\" (a particulate layer; "
              "a clear film needs no pigments) or \"medium\" (an analytic medium)");
    // A binder layer that is not last needs a thickness; a clear one needs it anyway.
    nlohmann::json clear = {{"binder", {{"material", "pmma"}}}};
    EXPECT_EQ(input_error(nlohmann::json{{"name", "s"}, {"layers", {white_layer(), clear}}}),
              "doc.json: layers[0].thickness_um: missing (only the last layer may be "
              "semi-infinite)\n"
              "doc.json: layers[1].pigments: missing (a particulate layer needs at least one "
              "pigment; a clear binder layer needs \"thickness_um\")");
    // Binder and medium in one layer.
    nlohmann::json both = white_layer();
    both["medium"] = {{"albedo", 0.5}};
    EXPECT_EQ(input_error(nlohmann::json{{"name", "s"}, {"layers", {both}}}),
              "doc.json: layers[0].medium: cannot be combined with \"binder\": a layer is either "
              "particulate (binder + pigments) or an analytic medium");
    // A substrate under a stack whose last layer is semi-infinite.
    nlohmann::json top = white_layer();
    top["thickness_um"] = 4;
    EXPECT_EQ(input_error(nlohmann::json{{"name", "s"},
                                         {"layers", {top, white_layer()}},
                                         {"substrate", {{"albedo", 1}}}}),
              "doc.json: substrate: not allowed under a semi-infinite layer (nothing lies under "
              "it; give the last layer \"thickness_um\", or \"optical_depth\" in its medium, to "
              "make it a film)");
    // Every fault of every layer at once, each with its path.
    nlohmann::json bad_top = white_layer();
    bad_top["thickness_um"] = -1;
    nlohmann::json bad_last = {{"medium", {{"albedo", 2}, {"optical_depth", 0}}}};
    EXPECT_EQ(input_error(nlohmann::json{{"name", "s"}, {"layers", {bad_top, bad_last}}}),
              "doc.json: layers[0].thickness_um: must be > 0 (got -1)\n"
              "doc.json: layers[1].medium.albedo: must be in [0, 1] (got 2)\n"
              "doc.json: layers[1].medium.optical_depth: must be > 0 (got 0)");
}

TEST(SpecNewKeyFaults, OldSpecsKeepTheirOtherMessages) {
    // A binder without pigments and without thickness is still "pigments: missing".
    EXPECT_EQ(input_error(nlohmann::json{{"name", "x"}, {"binder", {{"index", 1.5}}}}),
              "doc.json: pigments: missing (a particulate material needs at least one pigment; a "
              "clear binder layer needs \"thickness_um\")");
    // A clear film may write its empty pigment list.
    nlohmann::json doc = {{"name", "x"}, {"binder", {{"index", 1.5}}},
                          {"pigments", nlohmann::json::array()}};
    EXPECT_NE(input_error(doc).find("pigments: must list at least one pigment (got [])"),
              std::string::npos);
    doc["thickness_um"] = 2;
    const MaterialSpec s = parse_specs(doc, "x.json").at(0);
    EXPECT_TRUE(s.layers[0].pigments.empty());
    EXPECT_FALSE(s.resolved.contains("pigments"));
}

} // namespace
} // namespace brdf::material
