// End-to-end checks of brdftool as a user runs it: help, version, exit statuses, one-line errors.

#include <brdf/core/version.h>

#include "test_support.h"

#include <algorithm>

namespace brdf::test {
namespace {

const std::vector<std::string> subcommands = {"compute", "eval",   "albedo", "mie",  "convert",
                                              "info",    "diff",   "render", "lobes", "help"};

/// Exactly one line, ending in a newline.
bool one_line(const std::string& text) {
    return !text.empty() && text.back() == '\n' && std::count(text.begin(), text.end(), '\n') == 1;
}

TEST(Cli, VersionPrintsGeneratorString) {
    const ProcessResult r = run_tool("brdftool", {"--version"});
    EXPECT_EQ(r.status, 0);
    EXPECT_NE(r.out.find(version_string), std::string::npos) << r.out;
}

TEST(Cli, HelpListsSubcommands) {
    const ProcessResult r = run_tool("brdftool", {"--help"});
    EXPECT_EQ(r.status, 0);
    EXPECT_NE(r.out.find("mie"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("Exit status"), std::string::npos) << r.out;
}

TEST(Cli, HelpCommandListsEveryCommand) {
    const ProcessResult r = run_tool("brdftool", {"help"});
    EXPECT_EQ(r.status, 0) << r.err;
    for (const std::string& c : subcommands) EXPECT_NE(r.out.find("  " + c), std::string::npos) << c << "\n" << r.out;
    EXPECT_EQ(r.out, run_tool("brdftool", {"--help"}).out);
}

// As git does: the command list, but not a success (nothing was done).
TEST(Cli, NoArgumentsPrintsTheCommandListAndExitsTwo) {
    const ProcessResult r = run_tool("brdftool", {});
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.out, run_tool("brdftool", {"help"}).out);
    EXPECT_EQ(r.err, "");
}

TEST(Cli, HelpSubcommandPrintsCommandUsage) {
    const ProcessResult r = run_tool("brdftool", {"help", "mie"});
    EXPECT_EQ(r.status, 0);
    EXPECT_NE(r.out.find("--wavelength-nm"), std::string::npos) << r.out;
    const ProcessResult bad = run_tool("brdftool", {"help", "nonsense"});
    EXPECT_EQ(bad.status, 2); // a usage error
    EXPECT_TRUE(one_line(bad.err)) << bad.err;
    EXPECT_EQ(bad.err.rfind("brdftool: help: unknown command 'nonsense'", 0), 0u) << bad.err;
}

TEST(Cli, HelpCommandIsTheSameAsDashDashHelp) {
    for (const std::string& c : subcommands) {
        if (c == "help") continue;
        const ProcessResult a = run_tool("brdftool", {"help", c});
        const ProcessResult b = run_tool("brdftool", {c, "--help"});
        EXPECT_EQ(a.status, 0) << c;
        EXPECT_EQ(b.status, 0) << c;
        EXPECT_EQ(a.out, b.out) << c;
        EXPECT_NE(a.out.find("brdftool " + c), std::string::npos) << a.out;
    }
}

TEST(Cli, HelpHelpWorks) {
    const ProcessResult r = run_tool("brdftool", {"help", "help"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("brdftool help"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("command"), std::string::npos) << r.out;
    EXPECT_EQ(r.out, run_tool("brdftool", {"help", "--help"}).out);
}

TEST(Cli, UnknownOptionIsOneLineNamingTheCommandForEverySubcommand) {
    for (const std::string& c : subcommands) {
        const ProcessResult r = run_tool("brdftool", {c, "--foo"});
        EXPECT_EQ(r.status, 2) << c << ": " << r.err;
        EXPECT_TRUE(one_line(r.err)) << c << ": " << r.err;
        EXPECT_EQ(r.err.rfind("brdftool: " + c + ": unknown option --foo", 0), 0u) << r.err;
        EXPECT_NE(r.err.find("brdftool help " + c), std::string::npos) << r.err;
        EXPECT_EQ(r.out, "") << c;
    }
}

TEST(Cli, ParserErrorsAreOneLineWithThePrefix) {
    TempDir dir;
    write_file(dir / "s.json", R"({"name": "s", "medium": {"albedo": 0.5}})");
    const std::string spec = (dir / "s.json").string();
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{"compute"}, "brdftool: compute: spec is required"},
        {{"compute", spec, "--formats", "tiff"}, "brdftool: compute: --formats: "},
        {{"compute", spec, "--jobs", "0"}, "brdftool: compute: --jobs: "},
        {{"compute", spec, "--jobs"}, "brdftool: compute: --jobs: "},
        {{"compute", spec, "--device", "gpu"}, "brdftool: compute: --device: "},
        {{"eval"}, "brdftool: eval: "},
        {{"convert", "a.binary"}, "brdftool: convert: "},
        {{"frobnicate"}, "brdftool: unknown command 'frobnicate'"},
        {{"--bogus", "info", "x"}, "brdftool: unknown option --bogus"},
        {{"info", "a", "b"}, "brdftool: info: unexpected argument 'b'"},
    };
    for (const auto& [args, start] : cases) {
        const ProcessResult r = run_tool("brdftool", args);
        EXPECT_EQ(r.status, 2) << args.front() << ": " << r.err;
        EXPECT_TRUE(one_line(r.err)) << r.err;
        EXPECT_EQ(r.err.rfind(start, 0), 0u) << "expected '" << start << "...', got " << r.err;
    }
}

} // namespace
} // namespace brdf::test
