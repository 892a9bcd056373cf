#pragma once
// What the film tests share: specs from JSON, the checked-in references of tests/reference/rte and
// the comparison of a solved material with a reference case's values.

#include <brdf/material/spec.h>
#include <brdf/model/model.h>
#include <test_support.h>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>
#include <numbers>

namespace brdf::test {

using nlohmann::json;

inline material::MaterialSpec spec_from(const json& j) { return material::parse_specs_text(j.dump(), "film.json").at(0); }

inline json reference(const std::string& file) {
    const auto path = source_dir() / "tests/reference/rte" / file;
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot read " + path.string());
    return json::parse(in);
}

inline double rad(double deg) { return deg * std::numbers::pi / 180.0; }

inline json phase_of(const json& c) { return c.at("phase"); }

// The largest relative difference between our BRDF and a case's values up to 85 degrees. Values
// below 1e-3 of the case's largest are compared on that absolute scale: such values (a thin film's
// grazing backscatter) carry no relative meaning at the tolerance.
inline double worst_relative(const model::SolvedMaterial& m, const json& values) {
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

inline json disort_case(const std::string& label) {
    const json all = reference("disort_films.json");
    for (const auto& c : all.at("cases"))
        if (c.at("label") == label) return c;
    throw std::runtime_error("no case " + label);
}

inline json disort_spec(const json& c, const std::string& accuracy) {
    return {{"name", "film"},
            {"medium", {{"albedo", c.at("omega")}, {"phase", phase_of(c)}, {"optical_depth", c.at("optical_depth")}}},
            {"substrate", {{"albedo", c.at("floor_albedo")}}},
            {"accuracy", accuracy}};
}

/// Labels of the DISORT film cases whose label contains `part`.
inline std::vector<std::string> disort_labels(const std::string& part) {
    std::vector<std::string> out;
    const json all = reference("disort_films.json");
    for (const auto& c : all.at("cases"))
        if (c.at("label").get<std::string>().find(part) != std::string::npos) out.push_back(c.at("label"));
    return out;
}

inline std::string label_name(const ::testing::TestParamInfo<std::string>& info) {
    std::string s = info.param;
    for (char& ch : s)
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
    return s;
}

} // namespace brdf::test
