// Writes the inputs of tests/reference/formats/mitsuba_measured_check.py: for each analytic test
// BRDF (rgl_test_brdfs.h), in RGB and spectral form, at each resolution, an RGL file made by
// make_rgl_bsdf and a JSON case beside it with random direction pairs, the model's BRDF there (the
// reference) and our evaluator's value (what Mitsuba's `measured` should return to float rounding).
// It prints our evaluator's accuracy against the model per case: the resolution study.
//
//   rgl_mitsuba_cases OUTDIR [--pairs N] [--resolutions coarse,default,fine]

#include "rgl_test_brdfs.h"

#include <formats/rgl/rgl_bsdf.h>

#include <brdf/core/log.h>
#include <brdf/core/version.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

namespace {

using namespace brdf;
using formats::RglOptions;

std::vector<std::string> split(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream in(s);
    for (std::string item; std::getline(in, item, ',');) out.push_back(item);
    return out;
}

} // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::cerr << "usage: rgl_mitsuba_cases OUTDIR [--pairs N] [--resolutions a,b]\n";
        return 2;
    }
    const std::filesystem::path out_dir = argv[1];
    std::size_t pair_count = 600;
    std::vector<std::string> wanted{"coarse", "default", "fine"};
    for (int a = 2; a + 1 < argc; a += 2) {
        const std::string flag = argv[a];
        if (flag == "--pairs")
            pair_count = std::strtoul(argv[a + 1], nullptr, 10);
        else if (flag == "--resolutions")
            wanted = split(argv[a + 1]);
        else {
            std::cerr << "rgl_mitsuba_cases: unknown flag " << flag << "\n";
            return 2;
        }
    }
    try {
        std::filesystem::create_directories(out_dir);
        const auto pairs = test::random_direction_pairs(pair_count, 20181204);
        std::printf("%-28s %8s %9s %9s %9s %7s\n", "case", "nodes", "median", "p95", "max",
                    "build s");
        for (const test::RglResolution& r : test::rgl_resolutions) {
            if (std::find(wanted.begin(), wanted.end(), r.name) == wanted.end()) continue;
            for (auto model : {test::RglTestModel::Lambertian, test::RglTestModel::Glossy,
                               test::RglTestModel::Retro})
                for (bool spectral : {false, true}) {
                    const std::string name = std::string(test::to_string(model)) + "-" +
                                             (spectral ? "spectral" : "rgb") + "-" + r.name;
                    RglOptions options = test::rgl_case_options(r, spectral);
                    options.description = formats::rgl_description(
                        generator_string, cat("{\"test_brdf\": \"", name, "\"}"));
                    const auto brdf = test::rgl_test_brdf(model, options.wavelengths_nm);
                    const auto start = std::chrono::steady_clock::now();
                    formats::RglBsdf bsdf = formats::make_rgl_bsdf(brdf, options);
                    const double seconds = std::chrono::duration<double>(
                                               std::chrono::steady_clock::now() - start)
                                               .count();
                    const std::string file = name + ".rgl.bsdf";
                    formats::write_rgl_bsdf(out_dir / file, bsdf);
                    const formats::RglEvaluator evaluator(std::move(bsdf));

                    nlohmann::json pairs_json = nlohmann::json::array(),
                                   reference = nlohmann::json::array(),
                                   ours = nlohmann::json::array();
                    std::vector<double> values;
                    for (const auto& p : pairs) {
                        pairs_json.push_back({p.wi.x, p.wi.y, p.wi.z, p.wo.x, p.wo.y, p.wo.z});
                        brdf(p.wi, p.wo, values);
                        reference.push_back(values);
                        ours.push_back(evaluator.eval_cosine(p.wi, p.wo));
                    }
                    nlohmann::json c{{"name", name},
                                     {"bsdf", file},
                                     {"variant", spectral ? "scalar_spectral" : "scalar_rgb"},
                                     {"enforce", test::rgl_enforced(model, r)},
                                     {"theta_i_count", r.theta_i},
                                     {"sample_resolution", r.samples},
                                     {"pairs", pairs_json},
                                     {"reference_brdf", reference},
                                     {"ours_eval_cosine", ours}};
                    if (spectral) c["wavelengths_nm"] = options.wavelengths_nm;
                    // The model's directional albedo, for the check of Mitsuba's sampling.
                    nlohmann::json albedo = nlohmann::json::array();
                    for (double theta_i_deg : {30.0, 70.0})
                        albedo.push_back({{"theta_i_deg", theta_i_deg},
                                          {"albedo", test::model_albedo(brdf, theta_i_deg)}});
                    c["albedo"] = albedo;
                    std::ofstream(out_dir / (name + ".json")) << c.dump() << "\n";

                    const auto stats = test::rgl_accuracy(evaluator, brdf, pairs);
                    std::printf("%-28s %8s %9.2e %9.2e %9.2e %7.2f\n", name.c_str(),
                                cat(r.theta_i, "x", r.samples).c_str(), stats.median, stats.p95,
                                stats.max, seconds);
                }
        }
    } catch (const std::exception& e) {
        std::cerr << "rgl_mitsuba_cases: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
