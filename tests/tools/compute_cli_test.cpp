// brdftool compute / eval / albedo as a user runs them: real processes, exit statuses, output format,
// the OpenCL-less fallback.

#include <brdf/core/log.h>
#include <test_support.h>

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <numbers>
#include <poll.h>
#include <pty.h>
#include <sstream>
#include <stdexcept>
#include <sys/wait.h>
#include <unistd.h>
#include <utmp.h>

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

// eval of a spec goes through the tables' interpolant; --exact solves each direction off the
// nodes. Both give the solved model: within the spec's tolerance (default, 1e-4) below 80 degrees,
// off the grid's nodes and under an interface.
TEST(ComputeCli, EvalInterpolantAgreesWithExact) {
    TempDir dir;
    write_file(dir / "hg.json", R"({"name": "hg", "medium": {"albedo": 0.95, "index": 1.5,
        "phase": {"type": "henyey_greenstein", "g": 0.6}}, "surface": "smooth", "spectrum": "rgb"})");
    const std::string lines = "12.3 47.9 33\n0.4 71.7 170\n63.2 28.8 95\n77.7 77.1 181\n";
    const ProcessResult fast = run_tool("brdftool", {"eval", (dir / "hg.json").string(), "--device", "cpu"}, lines);
    const ProcessResult exact =
        run_tool("brdftool", {"eval", (dir / "hg.json").string(), "--exact", "--device", "cpu"}, lines);
    ASSERT_EQ(fast.status, 0) << fast.err;
    ASSERT_EQ(exact.status, 0) << exact.err;
    const auto a = numbers(fast.out), b = numbers(exact.out);
    ASSERT_EQ(a.size(), 12u) << fast.out;
    ASSERT_EQ(b.size(), 12u) << exact.out;
    for (std::size_t k = 0; k < a.size(); ++k) {
        EXPECT_GT(b[k], 0.0);
        EXPECT_REL_NEAR(a[k], b[k], 1e-4) << "value " << k;
    }
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

/// A small analytic material that computes in about a second on the CPU.
std::string tiny(const std::string& name, double albedo = 0.9) {
    return cat(R"({"name": ")", name, R"(", "medium": {"albedo": )", albedo,
               R"(}, "accuracy": "draft", "spectrum": "rgb", "outputs": ["merl"]})");
}

std::size_t count_of(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (std::size_t at = 0; (at = text.find(what, at)) != std::string::npos; at += what.size()) ++n;
    return n;
}

/// Runs argv with stderr (and stdout) on a pseudo-terminal: what a user at a terminal sees.
/// The test keeps its own descriptor of the terminal open, so the master never reports the
/// hang-up (EIO) that forkpty's callers wait for: on some kernels (CI's) it came while the
/// child's last lines were still on their way, and they were lost. It reads until the child has
/// exited and the terminal has been quiet for a while after.
ProcessResult run_on_terminal(const std::vector<std::string>& argv) {
    int master = -1, terminal = -1;
    if (openpty(&master, &terminal, nullptr, nullptr, nullptr) != 0)
        throw std::runtime_error("openpty failed");
    const pid_t pid = fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
        ::close(master);
        if (login_tty(terminal) != 0) _exit(126);
        std::vector<char*> args;
        for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
        args.push_back(nullptr);
        execv(args[0], args.data());
        _exit(127);
    }
    ProcessResult r;
    int status = 0;
    bool exited = false;
    char buf[4096];
    for (;;) {
        pollfd ready{master, POLLIN, 0};
        const int n = ::poll(&ready, 1, exited ? 200 : 50);
        if (n < 0 && errno == EINTR) continue;
        if (n > 0 && (ready.revents & POLLIN)) {
            const ssize_t k = ::read(master, buf, sizeof buf);
            if (k > 0) {
                r.err.append(buf, static_cast<std::size_t>(k));
                continue;
            }
        }
        if (exited) break; // quiet for 200 ms after the exit: all of it has arrived
        exited = waitpid(pid, &status, WNOHANG) == pid;
    }
    ::close(master);
    ::close(terminal);
    r.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return r;
}

// Not a terminal (a pipe here, a log file in CI): no progress bar, no '\r', and the summary line.
TEST(ComputeCli, QuietWhenStderrIsNotATerminalButSummarises) {
    TempDir dir;
    write_file(dir / "q.json", tiny("q"));
    const ProcessResult r = run_tool("brdftool", {"compute", (dir / "q.json").string(), "-o", (dir / "out").string(),
                                                  "--device", "cpu"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err.find('\r'), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("ETA"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.rfind("brdftool compute: 1 materials, 1 written, 0 up to date, 0 failed -> ", 0), 0u) << r.err;
    EXPECT_EQ(count_of(r.err, "\n"), 1u) << r.err;
}

// On a terminal: a bar redrawn with '\r', the stage and an ETA, each material's line, the summary.
TEST(ComputeCli, ProgressBarOnATerminal) {
    TempDir dir;
    write_file(dir / "c.json", cat(R"({"materials": [)", tiny("t1"), ", ", tiny("t2", 0.5), "]}"));
    const ProcessResult r = run_on_terminal({(bin_dir() / "brdftool").string(), "compute", (dir / "c.json").string(),
                                             "-o", (dir / "out").string(), "--device", "cpu"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find('\r'), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("ETA"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("t1: optics"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("] t1 done in "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("brdftool compute: 2 materials, 2 written"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find('\x1b'), std::string::npos) << "no escape sequences";
}

// A material that fails is reported once, at the end, and the others are written.
TEST(ComputeCli, AFailureIsPrintedOnce) {
    TempDir dir;
    write_file(dir / "c.json", cat(R"({"materials": [)", tiny("good"), ", ", tiny("bad", 0.5), "]}"));
    fs::create_directories(dir / "out" / "bad.binary" / "in-the-way"); // its table cannot be written
    const ProcessResult r = run_tool("brdftool", {"compute", (dir / "c.json").string(), "-o", (dir / "out").string(),
                                                  "--device", "cpu"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_EQ(count_of(r.err, "into place"), 1u) << r.err;
    EXPECT_EQ(r.err.rfind("brdftool: bad: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("1 written, 0 up to date, 1 failed"), std::string::npos) << r.err;
    EXPECT_TRUE(fs::exists(dir / "out" / "good.binary"));
}

TEST(ComputeCli, AccuracyAndForceFlags) {
    TempDir dir;
    write_file(dir / "a.json", tiny("a"));
    const std::vector<std::string> base = {"compute", (dir / "a.json").string(), "-o", (dir / "out").string(),
                                           "--device", "cpu"};
    const auto with = [&](std::vector<std::string> extra) {
        std::vector<std::string> args = base;
        args.insert(args.end(), extra.begin(), extra.end());
        return run_tool("brdftool", args);
    };
    ASSERT_EQ(with({}).status, 0);
    EXPECT_NE(with({}).err.find("0 written, 1 up to date"), std::string::npos);
    // Another accuracy is another spec: computed again, and stamped so.
    const ProcessResult custom = with({"--accuracy", "5e-3"});
    ASSERT_EQ(custom.status, 0) << custom.err;
    EXPECT_NE(custom.err.find("1 written, 0 up to date"), std::string::npos) << custom.err;
    const auto report = nlohmann::json::parse(read_file(dir / "out/a.report.json"));
    EXPECT_EQ(report["spec"]["accuracy"]["tolerance"], 5e-3);
    EXPECT_NE(with({"--accuracy", "5e-3"}).err.find("0 written, 1 up to date"), std::string::npos);
    EXPECT_NE(with({"--accuracy", "5e-3", "--force"}).err.find("1 written, 0 up to date"), std::string::npos);
    const ProcessResult bad = with({"--accuracy", "fastest"});
    EXPECT_EQ(bad.status, 3) << bad.err;
    EXPECT_EQ(bad.err.rfind("brdftool: --accuracy: expected draft, default, reference or", 0), 0u) << bad.err;
    EXPECT_EQ(count_of(bad.err, "\n"), 1u) << bad.err;
}

// A film as a user writes it: the thickness matters (the issue's complaint: three volume fractions
// gave one table), the report carries the paint maker's numbers, and `hiding` prints them.
TEST(ComputeCli, FilmsReportContrastAndHidingPrintsIt) {
    TempDir dir;
    const auto film = [](const std::string& name, double vf, const std::string& rest) {
        return cat(R"({"name": ")", name, R"(", "binder": {"material": "pmma"}, "spectrum": "rgb", "accuracy": "draft",
                   "pigments": [{"material": "hematite", "volume_fraction": )", vf,
                   R"(, "size": {"distribution": "lognormal", "r_g_um": 0.12, "sigma_g": 1.4}}])", rest, "}");
    };
    write_file(dir / "films.json",
               cat(R"({"materials": [)", film("dilute", 1e-5, R"(, "thickness_um": 25, "substrate": {"albedo": 0.8})"),
                   ", ", film("dense", 0.05, R"(, "thickness_um": 25, "substrate": {"albedo": 0.8})"), ", ",
                   film("halfspace", 0.05, ""), "]}"));
    const ProcessResult c = run_tool("brdftool", {"compute", (dir / "films.json").string(), "-o", (dir / "out").string(),
                                                  "--device", "cpu"});
    ASSERT_EQ(c.status, 0) << c.err;
    const auto dilute = nlohmann::json::parse(read_file(dir / "out/dilute.report.json"));
    const auto dense = nlohmann::json::parse(read_file(dir / "out/dense.report.json"));
    const auto half = nlohmann::json::parse(read_file(dir / "out/halfspace.report.json"));
    EXPECT_FALSE(half.contains("film"));
    ASSERT_TRUE(dense.contains("film")) << dense.dump();
    // Nearly clear over white: the substrate shows; the dense red film hides most of it.
    EXPECT_LT(dilute["film"]["contrast_ratio"].get<double>(), 0.05);
    EXPECT_GT(dense["film"]["contrast_ratio"].get<double>(), 0.5);
    const double t_dilute = dilute["film"]["per_wavelength"][0]["diffuse_transmittance"];
    const double t_dense = dense["film"]["per_wavelength"][0]["diffuse_transmittance"];
    EXPECT_GT(t_dilute, 0.85);
    EXPECT_LT(t_dense, t_dilute);
    EXPECT_NEAR(dense["film"]["per_wavelength"][0]["optical_depth"][0].get<double>(),
                25.0 * dense["wavelengths"][0]["layers"][0]["extinction_per_um"].get<double>(), 1e-9);
    EXPECT_GT(std::abs(dilute["directional_albedo"][0]["diffuse_rgb"][1].get<double>() -
                       dense["directional_albedo"][0]["diffuse_rgb"][1].get<double>()),
              0.1);

    const ProcessResult h = run_tool("brdftool", {"hiding", (dir / "films.json").string(), "--material", "dense",
                                                  "--thickness-um", "1,10,100", "--json"});
    ASSERT_EQ(h.status, 0) << h.err;
    const auto j = nlohmann::json::parse(h.out);
    ASSERT_EQ(j["contrast_ratio"].size(), 3u);
    EXPECT_LT(j["contrast_ratio"][0]["contrast_ratio"].get<double>(), j["contrast_ratio"][1]["contrast_ratio"].get<double>());
    EXPECT_LT(j["contrast_ratio"][1]["contrast_ratio"].get<double>(), j["contrast_ratio"][2]["contrast_ratio"].get<double>());
    ASSERT_TRUE(j["hiding_thickness_um"].is_number());
    EXPECT_NE(h.err.find("brdftool hiding: dense, 3 thicknesses ("), std::string::npos) << h.err;
    EXPECT_EQ(h.err.find('\r'), std::string::npos) << "no progress line off a terminal";
    const ProcessResult text = run_tool("brdftool", {"hiding", (dir / "films.json").string(), "--material", "dense"});
    EXPECT_NE(text.out.find("hiding thickness (contrast ratio 0.98): "), std::string::npos) << text.out;
    // On a terminal its progress line (the optics, then the thicknesses), then the summary.
    const ProcessResult shown = run_on_terminal({(bin_dir() / "brdftool").string(), "hiding",
                                                 (dir / "films.json").string(), "--material", "dense"});
    ASSERT_EQ(shown.status, 0) << shown.err;
    EXPECT_NE(shown.err.find('\r'), std::string::npos) << shown.err;
    EXPECT_NE(shown.err.find("hiding: "), std::string::npos) << shown.err;
    EXPECT_NE(shown.err.find("brdftool hiding: dense, 8 thicknesses ("), std::string::npos) << shown.err;

    const ProcessResult bad = run_tool("brdftool", {"hiding", (dir / "films.json").string(), "--material", "dense",
                                                    "--thickness-um", "-3"});
    EXPECT_EQ(bad.status, 3) << bad.err;
    EXPECT_NE(bad.err.find("--thickness-um values must be positive micrometres (got -3)"), std::string::npos) << bad.err;
    write_file(dir / "medium.json", R"({"name": "m", "medium": {"albedo": 0.9, "optical_depth": 1}})");
    const ProcessResult analytic = run_tool("brdftool", {"hiding", (dir / "medium.json").string()});
    EXPECT_EQ(analytic.status, 3) << analytic.err;
    EXPECT_NE(analytic.err.find("hiding needs one pigmented binder layer"), std::string::npos) << analytic.err;
}

/// true when this machine has an OpenCL device the project can use.
bool opencl_here() { return run_tool("test_cl_probe", {"available"}).out == "1\n"; }

// No writable home (HOME=/nonexistent, as under the shipped systemd unit): PoCL's cache goes to a
// folder of ours and OpenCL works, instead of "platform found but it has no device".
TEST(ComputeCli, OpenClWorksWithoutAHome) {
    if (!opencl_here()) GTEST_SKIP() << "no OpenCL device here";
    ASSERT_FALSE(fs::exists("/nonexistent"));
    TempDir dir;
    write_file(dir / "h.json", tiny("h"));
    const ProcessResult r = run_process({"/usr/bin/env", "-u", "POCL_CACHE_DIR", "-u", "XDG_CACHE_HOME",
                                         "HOME=/nonexistent", "TMPDIR=" + dir.path().string(),
                                         (bin_dir() / "brdftool").string(), "compute", (dir / "h.json").string(),
                                         "-o", (dir / "out").string(), "--device", "opencl"});
    ASSERT_EQ(r.status, 0) << r.err;
    const auto report = nlohmann::json::parse(read_file(dir / "out/h.report.json"));
    EXPECT_EQ(report["device"].get<std::string>().rfind("opencl", 0), 0u) << report["device"];
    EXPECT_TRUE(fs::is_directory(dir / cat("brdf-pocl-", ::geteuid()))) << "the private fallback folder";
    EXPECT_FALSE(fs::exists("/nonexistent")) << "a home that is not there is not created";
}

// When PoCL still cannot write its cache, the error says so rather than "no device".
TEST(ComputeCli, OpenClFailureNamesPoclsCacheFolder) {
    if (!opencl_here()) GTEST_SKIP() << "no OpenCL device here";
    TempDir dir;
    write_file(dir / "h.json", tiny("h"));
    const ProcessResult r = run_process({"/usr/bin/env", "POCL_CACHE_DIR=/dev/null/pocl", (bin_dir() / "brdftool").string(),
                                         "albedo", (dir / "h.json").string(), "--device", "opencl"});
    EXPECT_EQ(r.status, 5) << r.err;
    EXPECT_NE(r.err.find("PoCL could not write its cache folder /dev/null/pocl"), std::string::npos) << r.err;
    EXPECT_EQ(count_of(r.err, "\n"), 1u) << r.err;
}

// The example catalogue uses rutile in six materials: its extrapolation warning is one line naming
// the six places, not six lines (each material's report still carries its own).
TEST(ComputeCli, EachWarningIsSaidOnce) {
    const ProcessResult r = run_tool("brdftool", {"eval", (source_dir() / "examples/catalogue.json").string(),
                                                  "--material", "analytic-hg-orange", "--theta-i", "0",
                                                  "--theta-o", "0", "--phi", "0", "--device", "cpu"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(count_of(r.err, "tio2-rutile: 5 wavelengths"), 1u) << r.err;
    EXPECT_NE(r.err.find("(at materials[0].pigments[0].material, materials[3].pigments[0].material, "
                         "materials[6].pigments[0].material, materials[9].pigments[0].material, "
                         "materials[10].pigments[0].material, materials[11].pigments[0].material)"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(count_of(r.err, " warn "), 4u) << r.err; // pmma, rutile, zno, silica as a binder
}

} // namespace
} // namespace brdf::test
