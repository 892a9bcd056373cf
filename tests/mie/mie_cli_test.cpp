// brdftool mie as users run it: valid runs print one JSON object with the documented fields; every
// invalid input exits with status 3 (invalid input), one line on stderr naming the problem, nothing on
// stdout, and never crashes.

#include <brdf/mie/ensemble.h>
#include <brdf/mie/mie.h>
#include <brdf/mie/phase_function.h>

#include "test_support.h"

#include <nlohmann/json.hpp>

#include <algorithm>

namespace brdf::test {
namespace {

nlohmann::json run_json(const std::vector<std::string>& args) {
    std::vector<std::string> full{"mie"};
    full.insert(full.end(), args.begin(), args.end());
    const ProcessResult r = run_tool("brdftool", full);
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
    return nlohmann::json::parse(r.out); // throws (fails the test) unless stdout is exactly JSON
}

TEST(MieCli, SingleSphereFromRelativeIndex) {
    const nlohmann::json j = run_json({"--m", "1.5+0.1i", "--x", "10"});
    for (const char* key : {"m", "x", "qext", "qsca", "qabs", "qback", "g", "albedo", "legendre"})
        EXPECT_TRUE(j.contains(key)) << key;
    // docs/physics.md section 1 (MIEV0): Qext = 2.4597905, Qsca = 1.2351442, g = 0.9223496.
    EXPECT_REL_NEAR(j["qext"].get<double>(), 2.4597905, 1e-7);
    EXPECT_REL_NEAR(j["qsca"].get<double>(), 1.2351442, 1e-7);
    EXPECT_REL_NEAR(j["g"].get<double>(), 0.9223496, 1e-7);
    EXPECT_EQ(j["m"], nlohmann::json({1.5, 0.1}));
    EXPECT_EQ(j["x"].get<double>(), 10.0);
    const auto beta = j["legendre"].get<std::vector<double>>();
    ASSERT_GT(beta.size(), 10u);
    EXPECT_EQ(beta[0], 1.0);
    EXPECT_NEAR(beta[1], 3.0 * j["g"].get<double>(), 1e-10);
    EXPECT_EQ(beta, mie::sphere({1.5, 0.1}, 10.0).legendre);
}

// The series kernels with FMA (AVX-512, AVX2) and without (the baseline) agree to rounding: a 10 um
// matting agent's moments (1293 of them, nested rule; 1.7e-14 apart) and a rutile pigment's (panels,
// resonances), run in two processes, the second forced to the baseline (BRDF_MIE_KERNELS). Where
// this CPU runs an FMA set, the bits differ somewhere: the variable took effect.
TEST(MieCli, SeriesKernelSetsAgreeToRounding) {
    const std::vector<std::vector<std::string>> cases{
        {"--index", "1.46", "--medium-index", "1.49", "--wavelength-nm", "550", "--distribution", "gamma",
         "--r-eff-um", "10", "--v-eff", "0.1", "--tolerance", "1e-5"},
        {"--index", "2.6", "--medium-index", "1.5", "--wavelength-nm", "550", "--distribution", "power_law",
         "--r-eff-um", "0.4", "--v-eff", "0.3", "--tolerance", "1e-5"}};
    bool any_bit_differs = false;
    for (const auto& args : cases) {
        const nlohmann::json ours = run_json(args);
        nlohmann::json baseline;
        {
            ScopedEnv kernels("BRDF_MIE_KERNELS", "baseline");
            baseline = run_json(args);
        }
        const auto a = ours["legendre"].get<std::vector<double>>(), b = baseline["legendre"].get<std::vector<double>>();
        ASSERT_EQ(a.size(), b.size());
        ASSERT_GT(a.size(), 10u);
        double worst = 0.0; // chi_l = beta_l / (2l + 1), as the integration's tolerance counts them
        for (std::size_t l = 0; l < a.size(); ++l) worst = std::max(worst, std::abs(a[l] - b[l]) / (2.0 * l + 1.0));
        EXPECT_LT(worst, 1e-12) << args[1];
        EXPECT_REL_NEAR(ours["qsca"].get<double>(), baseline["qsca"].get<double>(), 1e-13);
        any_bit_differs = any_bit_differs || a != b;
    }
    if (std::string(mie::series_kernels()) != "baseline") {
        EXPECT_TRUE(any_bit_differs);
    }
}

TEST(MieCli, LegendreFlagCapsTheMoments) {
    const nlohmann::json j = run_json({"--m", "1.5", "--x", "10", "--legendre", "4"});
    EXPECT_EQ(j["legendre"].size(), 4u);
}

TEST(MieCli, PhysicalUnitsWithOneRadius) {
    const nlohmann::json j = run_json({"--index", "2.7+0.01i", "--medium-index", "1.5",
                                       "--wavelength-nm", "550", "--radius-um", "0.25"});
    for (const char* key : {"index", "medium_index", "wavelength_nm", "size", "m", "qext", "qsca",
                            "qabs", "qback", "g", "albedo", "legendre", "cext_um2", "csca_um2",
                            "radius_range_um"})
        EXPECT_TRUE(j.contains(key)) << key;
    // The size parameter is formed with the wavelength in the binder (docs/physics.md section 1).
    const double x = 2.0 * M_PI * 0.25 * 1.5 / 0.55;
    const mie::Sphere s = mie::sphere(std::complex<double>(2.7, 0.01) / 1.5, x);
    EXPECT_REL_NEAR(j["qext"].get<double>(), s.q.qext, 1e-14);
    EXPECT_REL_NEAR(j["cext_um2"].get<double>(), s.q.qext * M_PI * 0.0625, 1e-14);
    EXPECT_EQ(j["radius_range_um"], nlohmann::json({0.25, 0.25}));
    EXPECT_EQ(j["size"]["distribution"], "monodisperse");
}

TEST(MieCli, SizeDistributions) {
    const std::vector<std::vector<std::string>> runs{
        {"--distribution", "power_law", "--r-eff-um", "0.4", "--v-eff", "0.3"},
        {"--distribution", "gamma", "--r-eff-um", "0.3", "--v-eff", "0.1"},
        {"--distribution", "lognormal", "--r-g-um", "0.2", "--sigma-g", "1.5"},
        {"--distribution", "monodisperse", "--radius-um", "0.3"}};
    for (const auto& size : runs) {
        std::vector<std::string> args{"--index", "2.0+0.05i", "--medium-index", "1.5",
                                      "--wavelength-nm", "550", "--legendre", "8"};
        args.insert(args.end(), size.begin(), size.end());
        SCOPED_TRACE(size[1]);
        const nlohmann::json j = run_json(args);
        for (const char* key : {"qext", "qsca", "qabs", "qback", "g", "albedo", "legendre",
                                "cext_um2", "csca_um2", "radius_range_um"})
            EXPECT_TRUE(j.contains(key)) << key;
        EXPECT_EQ(j["legendre"].size(), 8u);
        EXPECT_EQ(j["size"]["distribution"], size[1]);
        const auto range = j["radius_range_um"].get<std::vector<double>>();
        ASSERT_EQ(range.size(), 2u);
        EXPECT_LE(range[0], range[1]);
        EXPECT_REL_NEAR(j["albedo"].get<double>(),
                        j["csca_um2"].get<double>() / j["cext_um2"].get<double>(), 1e-14);
    }
    // The numbers are the library's.
    const nlohmann::json j = run_json({"--index", "2.0+0.05i", "--medium-index", "1.5",
                                       "--wavelength-nm", "550", "--distribution", "power_law",
                                       "--r-eff-um", "0.4", "--v-eff", "0.3"});
    const mie::Ensemble e = mie::ensemble({2.0, 0.05}, 1.5, 550.0, mie::power_law(0.4, 0.3));
    EXPECT_EQ(j["cext_um2"].get<double>(), e.cext_um2);
    EXPECT_EQ(j["g"].get<double>(), e.g);
}

// Invalid input: status 3, one line on stderr that names the problem, nothing on stdout.
void expect_invalid(const std::vector<std::string>& args, const std::string& mentions) {
    std::vector<std::string> full{"mie"};
    full.insert(full.end(), args.begin(), args.end());
    const ProcessResult r = run_tool("brdftool", full);
    SCOPED_TRACE(testing::Message() << "brdftool mie " << testing::PrintToString(args));
    EXPECT_EQ(r.status, 3);
    EXPECT_TRUE(r.out.empty()) << r.out;
    ASSERT_FALSE(r.err.empty());
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(mentions), std::string::npos) << r.err;
}

TEST(MieCli, InvalidInputIsStatus3WithOneLine) {
    const std::vector<std::string> phys{"--index", "2.7", "--medium-index", "1.5",
                                        "--wavelength-nm", "550"};
    const auto with = [&](std::vector<std::string> more) {
        std::vector<std::string> args = phys;
        args.insert(args.end(), more.begin(), more.end());
        return args;
    };
    expect_invalid({"--m", "1.5-0.1i", "--x", "10"}, "k >= 0");
    expect_invalid({"--m", "0", "--x", "10"}, "--m");
    expect_invalid({"--m", "1.5", "--x", "nan"}, "--x");
    expect_invalid({"--m", "1.5", "--x", "-3"}, "size parameter");
    expect_invalid({"--m", "1.5", "--x", "1O"}, "'1O'");
    expect_invalid({"--x", "10"}, "--x needs --m");
    expect_invalid({"--m", "1.5"}, "--m needs --x");
    expect_invalid({"--m", "1.5", "--x", "10", "--index", "2.7"}, "cannot be combined");
    expect_invalid({}, "give --m and --x");
    expect_invalid({"--m", "1.5", "--x", "1", "--legendre", "0"}, "--legendre");
    expect_invalid(with({"--radius-um", "-0.2"}), "radius_um: must be > 0 (got -0.2)");
    expect_invalid(with({"--radius-um", "nan"}), "--radius-um");
    expect_invalid(with({"--distribution", "power_law", "--r-eff-um", "0.4"}), "needs --v-eff");
    expect_invalid(with({"--distribution", "power_law", "--r-eff-um", "0.4", "--v-eff", "3"}),
                   "v_eff: must be in");
    expect_invalid(with({"--distribution", "gamma", "--r-eff-um", "0.4", "--v-eff", "0.5"}),
                   "v_eff: must be in");
    expect_invalid(with({"--distribution", "lognormal", "--r-g-um", "0.2", "--sigma-g", "0.9"}),
                   "sigma_g");
    expect_invalid(with({"--distribution", "weibull"}), "'weibull'");
    expect_invalid(with({"--r-eff-um", "0.4"}), "--r-eff-um needs --distribution");
    expect_invalid(with({"--distribution", "gamma", "--r-eff-um", "0.4", "--v-eff", "0.1",
                         "--radius-um", "1"}),
                   "--radius-um does not apply");
    expect_invalid({"--index", "2.7", "--wavelength-nm", "550", "--radius-um", "0.3"},
                   "missing --medium-index");
    expect_invalid(with({}), "--radius-um");
    expect_invalid({"--index", "2.7", "--medium-index", "-1.5", "--wavelength-nm", "550",
                    "--radius-um", "0.3"},
                   "medium index");
    expect_invalid({"--index", "2.7", "--medium-index", "1.5", "--wavelength-nm", "0",
                    "--radius-um", "0.3"},
                   "wavelength");
}

} // namespace
} // namespace brdf::test
