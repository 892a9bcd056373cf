// brdftool compute / eval / albedo as a user runs them: real processes, exit statuses, output format,
// the OpenCL-less fallback.

#include <test_support.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <numbers>
#include <sstream>

namespace brdf::test {
namespace {

namespace fs = std::filesystem;

std::vector<double> numbers(const std::string& line) {
    std::istringstream in(line);
    std::vector<double> out;
    for (double v; in >> v;) out.push_back(v);
    return out;
}

// Isotropic scattering, albedo 0.9: R = (w/4) H(mu) H(mu0) / (mu + mu0), H from the checked-in
// reference (tests/reference/rte/chandrasekhar_h.json) at mu = 1 and mu = 0.5.
TEST(ComputeCli, EvalOnASpecMatchesTheExactSolution) {
    const auto ref = nlohmann::json::parse(read_file(source_dir() / "tests/reference/rte/chandrasekhar_h.json"));
    double h1 = 0, h05 = 0;
    for (const auto& c : ref["cases"])
        if (c["omega"] == 0.9)
            for (std::size_t k = 0; k < c["mu"].size(); ++k) {
                if (c["mu"][k] == 1.0) h1 = c["h"][k];
                if (c["mu"][k] == 0.5) h05 = c["h"][k];
            }
    ASSERT_GT(h1, 1.0);
    TempDir dir;
    write_file(dir / "iso.json", R"({"name": "iso", "medium": {"albedo": 0.9}})");
    const ProcessResult r =
        run_tool("brdftool", {"eval", (dir / "iso.json").string(), "--theta-i", "0", "--theta-o", "60", "--device", "cpu"});
    ASSERT_EQ(r.status, 0) << r.err;
    const auto v = numbers(r.out);
    ASSERT_EQ(v.size(), 3u) << r.out;
    const double exact = 0.25 * 0.9 * h1 * h05 / 1.5 / std::numbers::pi;
    for (double x : v) EXPECT_REL_NEAR(x, exact, 1e-4);
}

TEST(ComputeCli, EvalReadsAngleTriplesFromStdin) {
    TempDir dir;
    write_file(dir / "hg.json", R"({"name": "hg", "medium": {"albedo": 0.9, "phase": {"type": "henyey_greenstein", "g": 0.9}}})");
    const ProcessResult r = run_tool("brdftool", {"eval", (dir / "hg.json").string(), "--device", "cpu"},
                                     "# theta_i theta_o phi\n60 60 0\n60 60 180\n\n");
    ASSERT_EQ(r.status, 0) << r.err;
    std::istringstream lines(r.out);
    std::string back, mirror;
    std::getline(lines, back);
    std::getline(lines, mirror);
    // A forward scatterer puts its lobe on the mirror side (phi = 180).
    EXPECT_GT(numbers(mirror).at(0), 3.0 * numbers(back).at(0)) << r.out;
    const ProcessResult bad = run_tool("brdftool", {"eval", (dir / "hg.json").string(), "--device", "cpu"}, "60 abc 0\n");
    EXPECT_EQ(bad.status, 3);
    EXPECT_NE(bad.err.find("stdin line 1"), std::string::npos) << bad.err;
}

TEST(ComputeCli, AlbedoReportsTheMirrorOnItsOwnLine) {
    TempDir dir;
    write_file(dir / "w.json", R"({"name": "w", "medium": {"albedo": 1, "index": 1.5}, "surface": "smooth"})");
    const ProcessResult r = run_tool("brdftool", {"albedo", (dir / "w.json").string(), "--theta-i", "0,60", "--device", "cpu"});
    ASSERT_EQ(r.status, 0) << r.err;
    std::istringstream lines(r.out);
    std::string l;
    std::vector<std::string> all;
    while (std::getline(lines, l)) all.push_back(l);
    ASSERT_EQ(all.size(), 4u) << r.out;
    for (int k : {0, 2}) {
        const auto diffuse = numbers(all[k]);
        ASSERT_EQ(all[k + 1].rfind("mirror ", 0), 0u) << all[k + 1];
        const auto mirror = numbers(all[k + 1].substr(7));
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(diffuse[c] + mirror[c], 1.0, 1e-9);
    }
}

TEST(ComputeCli, WithoutAnOpenClPlatformTheDeviceErrorIsClearAndCpuWorks) {
    TempDir dir;
    write_file(dir / "iso.json", R"({"name": "iso", "medium": {"albedo": 0.5}, "accuracy": "draft"})");
    const std::string tool = (bin_dir() / "brdftool").string();
    const ProcessResult r = run_process({"/usr/bin/env", "OCL_ICD_VENDORS=/nonexistent", tool, "albedo", (dir / "iso.json").string()});
    EXPECT_EQ(r.status, 5) << r.err;
    EXPECT_NE(r.err.find("OpenCL"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--device cpu"), std::string::npos) << r.err;
    const ProcessResult cpu =
        run_process({"/usr/bin/env", "OCL_ICD_VENDORS=/nonexistent", tool, "albedo", (dir / "iso.json").string(), "--device", "cpu"});
    EXPECT_EQ(cpu.status, 0) << cpu.err;
}

TEST(ComputeCli, BadSpecWritesNothingAndNamesEveryFault) {
    TempDir dir;
    write_file(dir / "bad.json", R"({"materials": [{"name": "a", "medium": {"albedo": 2}},
                                                   {"name": "b", "medium": {"albedo": 0.5, "phase": {"type": "henyey_greenstein", "g": 1.2}}}]})");
    const ProcessResult r = run_tool("brdftool", {"compute", (dir / "bad.json").string(), "-o", (dir / "out").string(), "--device", "cpu"});
    EXPECT_EQ(r.status, 3) << r.err;
    EXPECT_NE(r.err.find("materials[0].medium.albedo"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("materials[1].medium.phase.g"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out/a.binary"));
}

TEST(ComputeCli, PreviewWritesASphereRendering) {
    TempDir dir;
    write_file(dir / "p.json", R"({"name": "p", "medium": {"albedo": 0.8}, "accuracy": "draft", "outputs": ["exr"]})");
    const ProcessResult r = run_tool("brdftool", {"compute", (dir / "p.json").string(), "-o", (dir / "out").string(),
                                                  "--device", "cpu", "--preview"});
    ASSERT_EQ(r.status, 0) << r.err;
    const std::string png = read_file(dir / "out/p.png");
    ASSERT_GT(png.size(), 100u);
    EXPECT_EQ(png.substr(1, 3), "PNG");
}

TEST(ComputeCli, ShardFlagIsValidated) {
    TempDir dir;
    write_file(dir / "s.json", R"({"name": "s", "medium": {"albedo": 0.5}})");
    for (const char* shard : {"3/3", "x/2", "1", "-1/2"}) {
        const ProcessResult r = run_tool("brdftool", {"compute", (dir / "s.json").string(), "-o", (dir / "o").string(), "--shard", shard});
        EXPECT_EQ(r.status, 3) << shard << ": " << r.err;
        EXPECT_NE(r.err.find("--shard"), std::string::npos) << r.err;
    }
}

} // namespace
} // namespace brdf::test
