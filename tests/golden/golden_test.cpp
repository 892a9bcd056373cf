// Golden tables: BRDF values of a few fixed specs on a coarse grid, checked in
// (tests/golden/brdf_grid.json) and compared at 1e-9 relative, so that any change to the numbers is
// noticed: a deliberate one regenerates the file (tests/golden/README.md gives the command), an
// accidental one fails here. The CPU reference solver is used (deterministic, no device needed).

#include <brdf/material/spec.h>
#include <brdf/model/model.h>
#include <test_support.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <numbers>
#include <string>
#include <vector>

namespace brdf::test {
namespace {

using nlohmann::json;

const char* const golden_file = "tests/golden/brdf_grid.json";
constexpr double relative_tolerance = 1e-9;

// The specs: fixed, small and quick (draft accuracy), covering an interface, a forward peak,
// albedo 1 and a coloured medium.
const char* const specs[] = {
    R"({"name": "hg-interface", "accuracy": "draft", "surface": "smooth",
        "medium": {"albedo": 0.9, "phase": {"type": "henyey_greenstein", "g": 0.6}, "index": 1.5}})",
    R"({"name": "white-isotropic", "accuracy": "draft", "surface": "none", "medium": {"albedo": 1}})",
    R"({"name": "coloured-rayleigh", "accuracy": "draft",
        "medium": {"albedo": [0.95, 0.7, 0.3], "phase": {"type": "rayleigh"}}})",
};

const double zeniths_deg[] = {0.0, 30.0, 60.0, 80.0};
const double azimuths_deg[] = {0.0, 90.0, 180.0};

// {"name": ..., "brdf": [[theta_i, theta_o, phi, r, g, b], ...]} per spec.
json compute() {
    json out = json::array();
    for (const char* text : specs) {
        const material::MaterialSpec spec = material::parse_specs(json::parse(text), "golden").at(0);
        const model::SolvedMaterial m = model::solve_material(spec, model::Device::Cpu);
        json values = json::array();
        for (double ti : zeniths_deg)
            for (double to : zeniths_deg)
                for (double phi : azimuths_deg) {
                    const double d = std::numbers::pi / 180.0;
                    const auto f = m.brdf(ti * d, to * d, phi * d);
                    values.push_back({ti, to, phi, f[0], f[1], f[2]});
                }
        out.push_back({{"name", spec.name}, {"brdf", values}});
    }
    return out;
}

// Every value of `computed` that differs from `golden` by more than `tolerance` relative (or whose
// layout differs), one line each.
std::vector<std::string> differences(const json& golden, const json& computed, double tolerance) {
    std::vector<std::string> out;
    if (golden.size() != computed.size()) return {"different number of specs"};
    for (std::size_t s = 0; s < golden.size(); ++s) {
        const json& g = golden[s]["brdf"];
        const json& c = computed[s]["brdf"];
        if (golden[s]["name"] != computed[s]["name"] || g.size() != c.size()) {
            out.push_back(golden[s]["name"].get<std::string>() + ": different layout");
            continue;
        }
        for (std::size_t k = 0; k < g.size(); ++k)
            for (std::size_t q = 0; q < 6; ++q) {
                const double a = g[k][q].get<double>(), b = c[k][q].get<double>();
                if (!(std::abs(a - b) <= tolerance * std::abs(a)))
                    out.push_back(golden[s]["name"].get<std::string>() + " row " + std::to_string(k) + " column " +
                                  std::to_string(q) + ": golden " + std::to_string(a) + ", now " +
                                  std::to_string(b));
            }
    }
    return out;
}

TEST(Golden, BrdfGridMatchesTheCheckedInTable) {
    const json computed = compute();
    const auto path = source_dir() / golden_file;
    if (const char* env = std::getenv("BRDF_REGENERATE_GOLDEN"); env != nullptr && std::string(env) == "1") {
        // One row per line, full precision (nlohmann writes the shortest round-trip form).
        std::string text = "[\n";
        for (std::size_t k = 0; k < computed.size(); ++k) {
            text += " {\"name\": " + computed[k]["name"].dump() + ", \"brdf\": [\n";
            const json& rows = computed[k]["brdf"];
            for (std::size_t r = 0; r < rows.size(); ++r) text += "  " + rows[r].dump() + (r + 1 < rows.size() ? ",\n" : "\n");
            text += k + 1 < computed.size() ? " ]},\n" : " ]}\n";
        }
        write_file(path, text + "]\n");
        GTEST_SKIP() << "regenerated " << path;
    }
    const json golden = json::parse(read_file(path));
    const auto diff = differences(golden, computed, relative_tolerance);
    for (std::size_t k = 0; k < diff.size() && k < 20; ++k) ADD_FAILURE() << diff[k];
    EXPECT_TRUE(diff.empty()) << diff.size() << " values changed beyond " << relative_tolerance
                              << " relative; if intended, regenerate (tests/golden/README.md)";
}

TEST(Golden, AChangeBeyondTheToleranceIsNoticed) {
    const json golden = json::parse(read_file(source_dir() / golden_file));
    ASSERT_EQ(golden.size(), std::size(specs));
    json changed = golden;
    double& v = changed[1]["brdf"][7][4].get_ref<double&>();
    ASSERT_GT(v, 0.0);
    v *= 1.0 + 3e-9;
    EXPECT_EQ(differences(golden, changed, relative_tolerance).size(), 1u);
    json within = golden;
    within[1]["brdf"][7][4].get_ref<double&>() *= 1.0 + 3e-10;
    EXPECT_TRUE(differences(golden, within, relative_tolerance).empty());
    EXPECT_TRUE(differences(golden, golden, relative_tolerance).empty());
}

} // namespace
} // namespace brdf::test
