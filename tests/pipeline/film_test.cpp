// Films and stacks end to end, from the spec: the independent references of tests/reference/rte
// (DISORT for films without an interface, a separate numpy adding code for interfaces and stacks),
// the limits a film must meet, and the paint maker's numbers (contrast ratio, hiding thickness).

#include <brdf/material/spec.h>
#include <brdf/model/film.h>
#include <brdf/model/model.h>
#include <test_support.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <numbers>

namespace brdf::test {
namespace {

using nlohmann::json;

material::MaterialSpec spec_from(const json& j) { return material::parse_specs_text(j.dump(), "film.json").at(0); }

json reference(const std::string& file) {
    const auto path = source_dir() / "tests/reference/rte" / file;
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot read " + path.string());
    return json::parse(in);
}

double rad(double deg) { return deg * std::numbers::pi / 180.0; }

json phase_of(const json& c) { return c.at("phase"); }

// The largest relative difference between our BRDF and a case's values up to 85 degrees. Values
// below 1e-3 of the case's largest are compared on that absolute scale: such values (a thin film's
// grazing backscatter) carry no relative meaning at the tolerance.
double worst_relative(const model::SolvedMaterial& m, const json& values) {
    double largest = 0.0;
    for (const auto& v : values) largest = std::max(largest, v[3].get<double>());
    double worst = 0.0;
    for (const auto& v : values) {
        const double ti = v[0], to = v[1], phi = v[2], ref = v[3];
        if (ti > 85.0 || to > 85.0) continue;
        const double ours = m.samples.at(0).reflection.brdf(std::cos(rad(ti)), std::cos(rad(to)), rad(phi));
        worst = std::max(worst, std::abs(ours - ref) / std::max(std::abs(ref), 1e-3 * largest));
    }
    return worst;
}

// ---- DISORT: one layer, no interface, over black or a Lambertian floor --------------------------

class DisortFilm : public ::testing::TestWithParam<std::string> {};

json disort_case(const std::string& label) {
    const json all = reference("disort_films.json");
    for (const auto& c : all.at("cases"))
        if (c.at("label") == label) return c;
    throw std::runtime_error("no case " + label);
}

json disort_spec(const json& c, const std::string& accuracy) {
    return {{"name", "film"},
            {"medium", {{"albedo", c.at("omega")}, {"phase", phase_of(c)}, {"optical_depth", c.at("optical_depth")}}},
            {"substrate", {{"albedo", c.at("floor_albedo")}}},
            {"accuracy", accuracy}};
}

TEST_P(DisortFilm, MatchesDisortAtDefaultAccuracy) {
    const json c = disort_case(GetParam());
    const model::SolvedMaterial m = model::solve_material(spec_from(disort_spec(c, "default")), model::Device::Cpu);
    EXPECT_LT(worst_relative(m, c.at("values")), 1e-4) << GetParam();
    for (const auto& p : c.at("per_incidence")) {
        const double ti = p.at("theta_i");
        if (ti > 85.0) continue;
        EXPECT_NEAR(m.samples.at(0).reflection.albedo(std::cos(rad(ti))), p.at("albedo").get<double>(), 1e-5) << GetParam() << " at " << ti;
    }
}

std::vector<std::string> disort_labels() {
    std::vector<std::string> out;
    const json all = reference("disort_films.json");
    for (const auto& c : all.at("cases")) out.push_back(c.at("label"));
    return out;
}

std::string label_name(const ::testing::TestParamInfo<std::string>& info) {
    std::string s = info.param;
    for (char& ch : s)
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
    return s;
}

INSTANTIATE_TEST_SUITE_P(Cases, DisortFilm, ::testing::ValuesIn(disort_labels()), label_name);

TEST(DisortFilmReference, MatchesDisortAtReferenceAccuracy) {
    // g = 0.5: the reference accuracy (1e-6) within a test's budget; g = 0.9 runs in the slow suite.
    for (const std::string label : {"hg0.5-omega0.9-tau1-floor0", "hg0.5-omega1-tau10-floor0.5",
                                    "hg0.5-omega0.9-tau0.1-floor0.5"}) {
        const json c = disort_case(label);
        const model::SolvedMaterial m = model::solve_material(spec_from(disort_spec(c, "reference")), model::Device::Cpu);
        EXPECT_LT(worst_relative(m, c.at("values")), 1e-6) << label;
    }
}

// ---- The numpy adding reference: films and stacks under smooth interfaces -----------------------

json layer_spec(const json& l) {
    if (l.value("clear", false)) return {{"binder", {{"index", l.at("index")}}}, {"thickness_um", 1.0}};
    json medium = {{"albedo", l.at("omega")}, {"phase", l.at("phase")}, {"index", l.at("index")}};
    if (l.at("optical_depth").is_number()) medium["optical_depth"] = l.at("optical_depth");
    return {{"medium", medium}};
}

json adding_spec(const json& c, const std::string& accuracy) {
    json layers = json::array();
    for (const auto& l : c.at("layers")) layers.push_back(layer_spec(l));
    json spec = {{"name", "stack"}, {"layers", layers}, {"surface", c.at("surface")}, {"accuracy", accuracy}};
    if (!c.at("substrate_albedo").is_null()) spec["substrate"] = {{"albedo", c.at("substrate_albedo")}};
    return spec;
}

void expect_matches_adding(const std::string& file, double tolerance) {
    int checked = 0;
    const json all = reference(file);
    for (const auto& c : all.at("cases")) {
        const std::string label = c.at("label");
        const bool clear = std::any_of(c.at("layers").begin(), c.at("layers").end(),
                                       [](const json& l) { return l.value("clear", false); });
        // A clear binder layer makes the stack particulate: solved per wavelength, here the three
        // of "rgb", all alike (constant indices, grey media); sample 0 is compared.
        json spec = adding_spec(c, "default");
        if (clear) spec["spectrum"] = "rgb";
        const model::SolvedMaterial m = model::solve_material(spec_from(spec), model::Device::Cpu);
        EXPECT_LT(worst_relative(m, c.at("values")), tolerance) << file << ": " << label;
        for (const auto& p : c.at("per_incidence")) {
            const double ti = p.at("theta_i");
            EXPECT_NEAR(m.samples.at(0).reflection.albedo(std::cos(rad(ti))), p.at("diffuse_albedo").get<double>(), 1e-5) << label << " at " << ti;
            EXPECT_NEAR(m.samples.at(0).reflection.mirror(std::cos(rad(ti))), p.at("mirror").get<double>(), 1e-9) << label << " at " << ti;
        }
        ++checked;
    }
    EXPECT_GT(checked, 10);
}

TEST(AddingReference, HalfSpacesUnderTheInterface) { expect_matches_adding("adding_interface.json", 1e-4); }
TEST(AddingReference, FilmsTwoLayerStacksAndClearLayers) { expect_matches_adding("adding_stacks.json", 1e-4); }

} // namespace
} // namespace brdf::test
