// Films and stacks end to end, from the spec: the independent references of tests/reference/rte
// (DISORT for films without an interface, a separate numpy adding code for interfaces and stacks),
// the limits a film must meet, and the paint maker's numbers (contrast ratio, hiding thickness).
// The forward-peaked DISORT cases and the reference accuracy run in film_slow_test.cpp.

#include "film_support.h"

#include <brdf/cl/context.h>
#include <brdf/model/film.h>

namespace brdf::test {
namespace {

// ---- DISORT: one layer, no interface, over black or a Lambertian floor --------------------------

class DisortFilm : public ::testing::TestWithParam<std::string> {};

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

INSTANTIATE_TEST_SUITE_P(Cases, DisortFilm, ::testing::ValuesIn(disort_labels("hg0.5")), label_name);

// ---- The numpy adding reference: films and stacks under smooth interfaces -----------------------

// A clear binder layer of the reference ({"clear": true}).
bool is_clear(const json& l) { return l.contains("clear") && l.at("clear") == true; }

json layer_spec(const json& l) {
    if (is_clear(l)) return {{"binder", {{"index", l.at("index")}}}, {"thickness_um", 1.0}};
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
        const bool clear = std::any_of(c.at("layers").begin(), c.at("layers").end(), is_clear);
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

// The same half-spaces through the tables' path: every reference direction in one order grid with a
// table's 91 zenith angles, which Reflection::order_grid interpolates from Chebyshev nodes in sin^2
// (the test above evaluates each pair alone, solved at its own two directions).
TEST(AddingReference, HalfSpacesUnderTheInterfaceThroughTheTableGrid) {
    int checked = 0;
    const json all = reference("adding_interface.json");
    for (const auto& c : all.at("cases")) {
        const std::string label = c.at("label");
        const model::SolvedMaterial m =
            model::solve_material(spec_from(adding_spec(c, "default")), model::Device::Cpu);
        const rte::Reflection& r = m.samples.at(0).reflection;
        std::vector<double> mu;
        for (int a = 0; a < 91; ++a) mu.push_back(std::cos(rad(a)));
        const std::size_t first = mu.size(); // then every reference direction's own cosine
        for (const auto& v : c.at("values")) mu.push_back(std::cos(rad(v[0])));
        for (const auto& v : c.at("values")) mu.push_back(std::cos(rad(v[1])));
        const rte::OrderGrid grid = r.order_grid(mu);
        ASSERT_GT(grid.nodes, 0) << label;
        EXPECT_EQ(grid.interpolated, static_cast<int>(grid.orders.size())) << label;
        const std::size_t count = c.at("values").size();
        double largest = 0.0, worst = 0.0;
        for (const auto& v : c.at("values")) largest = std::max(largest, v[3].get<double>());
        for (std::size_t k = 0; k < count; ++k) {
            const auto& v = c.at("values")[k];
            const double ti = v[0], to = v[1], phi = v[2], ref = v[3];
            if (ti > 85.0 || to > 85.0) continue;
            const int i = static_cast<int>(first + k), o = static_cast<int>(first + count + k);
            double sum = r.single_scattering(grid.mu[o], grid.mu[i], rad(phi));
            for (std::size_t q = 0; q < grid.orders.size(); ++q)
                sum += (q == 0 ? 1.0 : 2.0) * (q % 2 == 0 ? 1.0 : -1.0) * grid.orders[q](o, i) *
                       std::cos(q * rad(phi));
            const double ours = std::max(0.0, sum) / std::numbers::pi;
            worst = std::max(worst, std::abs(ours - ref) / std::max(std::abs(ref), 1e-3 * largest));
        }
        EXPECT_LT(worst, 1e-4) << label;
        ++checked;
    }
    EXPECT_EQ(checked, 18);
}

// ---- Limits a film must meet, through the spec ----------------------------------------------------

json hg_medium(double omega, double g, std::optional<double> depth) {
    json m = {{"albedo", omega}, {"phase", {{"type", "henyey_greenstein"}, {"g", g}}}, {"index", 1.5}};
    if (depth) m["optical_depth"] = *depth;
    return m;
}

model::SolvedMaterial solve(const json& spec) { return model::solve_material(spec_from(spec), model::Device::Cpu); }

// Largest relative difference of two solved materials' BRDF (channel 1) over a spread of directions.
double brdf_difference(const model::SolvedMaterial& a, const model::SolvedMaterial& b) {
    double worst = 0.0;
    for (double ti : {0.0, 30.0, 60.0, 80.0})
        for (double to : {0.0, 20.0, 45.0, 70.0, 85.0})
            for (double phi : {0.0, 90.0, 180.0}) {
                const double x = a.brdf(rad(ti), rad(to), rad(phi))[1], y = b.brdf(rad(ti), rad(to), rad(phi))[1];
                worst = std::max(worst, std::abs(x - y) / std::abs(y));
            }
    return worst;
}

TEST(FilmLimits, AThickFilmIsTheHalfSpace) {
    const json half = {{"name", "h"}, {"medium", hg_medium(0.9, 0.5, std::nullopt)}, {"surface", "smooth"}};
    json film = half;
    film["medium"] = hg_medium(0.9, 0.5, 80.0); // exp(-80) of the substrate reaches the top
    film["substrate"] = {{"albedo", 0.7}};
    const model::SolvedMaterial a = solve(film), b = solve(half);
    EXPECT_LT(brdf_difference(a, b), 1e-6);
    for (double ti : {0.0, 45.0, 80.0}) EXPECT_NEAR(a.albedo(rad(ti))[1], b.albedo(rad(ti))[1], 1e-8);
}

// A Lambertian substrate of albedo a under a smooth interface of index n (closed form, written here
// independently of the solver): BRDF = (1 - F(mu_i)) (1 - F(mu_o)) a / (pi n^2 (1 - a r_i)), with r_i
// the interface's hemispherical reflectance for diffuse light from inside.
double fresnel(double cos_i, double n) { // unpolarised, from the side of index 1 into n
    const double sin_t2 = (1.0 - cos_i * cos_i) / (n * n);
    if (sin_t2 >= 1.0) return 1.0;
    const double cos_t = std::sqrt(1.0 - sin_t2);
    const double rs = (cos_i - n * cos_t) / (cos_i + n * cos_t), rp = (n * cos_i - cos_t) / (n * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

TEST(FilmLimits, AVanishingFilmIsTheBareSubstrateUnderTheInterface) {
    const double n = 1.5, a = 0.6;
    const model::SolvedMaterial m =
        solve({{"name", "thin"}, {"medium", hg_medium(0.9, 0.5, 1e-9)}, {"surface", "smooth"}, {"substrate", {{"albedo", a}}}});
    // r_i = 1 - (1 - r_e) / n^2 with r_e the external diffuse reflectance (2 int F mu dmu).
    double r_e = 0.0;
    const int steps = 200000;
    for (int k = 0; k < steps; ++k) {
        const double mu = (k + 0.5) / steps;
        r_e += 2.0 * fresnel(mu, n) * mu / steps;
    }
    const double r_i = 1.0 - (1.0 - r_e) / (n * n);
    for (double ti : {0.0, 40.0, 75.0})
        for (double to : {10.0, 50.0, 85.0}) {
            const double expected =
                (1.0 - fresnel(std::cos(rad(ti)), n)) * (1.0 - fresnel(std::cos(rad(to)), n)) * a /
                (std::numbers::pi * n * n * (1.0 - a * r_i));
            EXPECT_NEAR(m.brdf(rad(ti), rad(to), 1.0)[1] / expected, 1.0, 1e-6) << ti << " " << to;
        }
}

const char* rutile = R"({"material": "tio2-rutile", "volume_fraction": VF,
    "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}})";

json rutile_film(double volume_fraction, std::optional<double> thickness_um) {
    std::string p = rutile;
    p.replace(p.find("VF"), 2, std::to_string(volume_fraction));
    json spec = {{"name", "white"},  {"binder", {{"material", "pmma"}}}, {"pigments", json::array({json::parse(p)})},
                 {"spectrum", "rgb"}, {"accuracy", "draft"}};
    if (thickness_um) {
        spec["thickness_um"] = *thickness_um;
        spec["substrate"] = {{"albedo", 0.0}};
    }
    return spec;
}

TEST(FilmLimits, AClearIndexMatchedLayerChangesNothing) {
    const json base = rutile_film(0.1, 20.0);
    json stacked = {{"name", "coated"}, {"spectrum", "rgb"}, {"accuracy", "draft"}, {"substrate", {{"albedo", 0.0}}}};
    json pigmented = {{"binder", base["binder"]}, {"pigments", base["pigments"]}, {"thickness_um", 20.0}};
    stacked["layers"] = json::array({{{"binder", {{"material", "pmma"}}}, {"thickness_um", 30.0}}, pigmented});
    const model::SolvedMaterial a = solve(stacked), b = solve(base);
    EXPECT_LT(brdf_difference(a, b), 1e-9);
    for (double ti : {0.0, 60.0}) EXPECT_NEAR(a.mirror(rad(ti))[1], b.mirror(rad(ti))[1], 1e-12);
}

TEST(FilmLimits, PigmentAmountMatters) {
    // The complaint of the issue: three volume fractions of one film must give three tables.
    const model::SolvedMaterial a = solve(rutile_film(1e-3, 25.0)), b = solve(rutile_film(0.05, 25.0));
    EXPECT_GT(brdf_difference(a, b), 0.5);
}

// ---- The paint maker's numbers ---------------------------------------------------------------------

TEST(FilmHiding, ContrastRatioRisesWithThicknessAndVolumeFraction) {
    for (double vf : {0.02, 0.1}) {
        const material::MaterialSpec spec = spec_from(rutile_film(vf, std::nullopt));
        const model::MaterialOptics optics = model::material_optics(spec, model::settings_for(1e-2));
        double last = 0.0;
        for (double t : {0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0}) {
            const double cr = model::contrast_ratio(spec, optics, 16, t);
            EXPECT_GT(cr, last) << "volume fraction " << vf << ", " << t << " um";
            EXPECT_LT(cr, 1.0);
            last = cr;
        }
    }
    const auto cr_at = [](double vf) {
        const material::MaterialSpec spec = spec_from(rutile_film(vf, std::nullopt));
        return model::contrast_ratio(spec, model::material_optics(spec, model::settings_for(1e-2)), 16, 10.0);
    };
    EXPECT_LT(cr_at(0.01), cr_at(0.03));
    EXPECT_LT(cr_at(0.03), cr_at(0.1));
}

TEST(FilmHiding, HidingThicknessFallsWithVolumeFractionAndMeetsItsContrastRatio) {
    double last = std::numeric_limits<double>::infinity();
    for (double vf : {0.02, 0.05, 0.15}) {
        const material::MaterialSpec spec = spec_from(rutile_film(vf, std::nullopt));
        const model::MaterialOptics optics = model::material_optics(spec, model::settings_for(1e-2));
        const std::optional<double> t = model::hiding_thickness_um(spec, optics, 16);
        ASSERT_TRUE(t.has_value()) << vf;
        EXPECT_LT(*t, last) << vf;
        EXPECT_NEAR(model::contrast_ratio(spec, optics, 16, *t), model::hiding_contrast_ratio, 1e-4);
        last = *t;
    }
}

TEST(FilmHiding, AThinFilmOverBlackIsFarDarkerThanOverWhite) {
    json black = rutile_film(0.1, 1.0), white = black;
    white["substrate"] = {{"albedo", 0.8}};
    const model::SolvedMaterial b = solve(black), w = solve(white);
    EXPECT_LT(b.albedo(0.0)[1], 0.5 * w.albedo(0.0)[1]);
    EXPECT_LT(b.brdf(rad(10.0), rad(30.0), 1.0)[1], 0.5 * w.brdf(rad(10.0), rad(30.0), 1.0)[1]);
}

TEST(FilmTransmittance, AConservativeFilmOverBlackTransmitsWhatItDoesNotReflect) {
    // omega = 1: nothing is absorbed in the film, so T = 1 - R for diffuse light (R: hemispherical,
    // diffuse + mirror), a check of the three-substrate algebra and its 1 / n^2.
    const material::MaterialSpec spec = spec_from(
        {{"name", "w"}, {"medium", hg_medium(1.0, 0.5, 2.0)}, {"surface", "smooth"}, {"substrate", {{"albedo", 0.0}}}});
    const model::SolvedMaterial m = model::solve_material(spec, model::Device::Cpu);
    model::MaterialOptics optics;
    optics.optics = {m.samples[0].optics};
    optics.weights = {m.samples[0].weight};
    const double t = model::diffuse_transmittance(spec, optics, m.settings.streams).at(0);
    double r = 0.0;
    const int steps = 400;
    for (int k = 0; k < steps; ++k) {
        const double mu = (k + 0.5) / steps;
        r += 2.0 * mu / steps * (m.samples[0].reflection.albedo(mu) + m.samples[0].reflection.mirror(mu));
    }
    EXPECT_NEAR(t, 1.0 - r, 2e-5);
    EXPECT_GT(t, 0.1);
}

TEST(FilmReport, FilmSectionOnlyForFilms) {
    EXPECT_FALSE(model::film_report(solve(rutile_film(0.1, std::nullopt))).has_value());
    const auto film = model::film_report(solve(rutile_film(0.1, 10.0)));
    ASSERT_TRUE(film.has_value());
    EXPECT_GT(film->contrast_ratio, 0.0);
    EXPECT_LT(film->contrast_ratio, 1.0);
    ASSERT_TRUE(film->hiding_thickness_um.has_value());
    EXPECT_GT(*film->hiding_thickness_um, 10.0); // CR < 0.98 at 10 um
    for (double t : film->diffuse_transmittance) {
        EXPECT_GT(t, 0.0);
        EXPECT_LT(t, 1.0);
    }
}

// ---- Devices --------------------------------------------------------------------------------------

TEST(FilmDevices, OpenClAndCpuAgreeForStacks) {
    if (!brdf::cl::available()) GTEST_SKIP() << "no OpenCL device with fp64";
    json spec = {{"name", "stack"}, {"surface", "smooth"}, {"accuracy", "draft"}};
    json top = {{"medium", hg_medium(0.95, 0.3, 1.0)}}, bottom = {{"medium", hg_medium(0.99, 0.6, std::nullopt)}};
    bottom["medium"]["index"] = 1.8;
    spec["layers"] = json::array({top, bottom});
    const model::SolvedMaterial cpu = model::solve_material(spec_from(spec), model::Device::Cpu);
    const model::SolvedMaterial gpu = model::solve_material(spec_from(spec), model::Device::OpenCL);
    EXPECT_LT(brdf_difference(gpu, cpu), 1e-10);
}

} // namespace
} // namespace brdf::test
