// End-to-end checks of brdftool as a user runs it: help, version, exit statuses, one-line errors.

#include <brdf/core/version.h>

#include "test_support.h"

namespace brdf::test {
namespace {

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

TEST(Cli, HelpSubcommandPrintsCommandUsage) {
    const ProcessResult r = run_tool("brdftool", {"help", "mie"});
    EXPECT_EQ(r.status, 0);
    EXPECT_NE(r.out.find("--wavelength-nm"), std::string::npos) << r.out;
    const ProcessResult bad = run_tool("brdftool", {"help", "nonsense"});
    EXPECT_EQ(bad.status, 3);
    EXPECT_NE(bad.err.find("nonsense"), std::string::npos) << bad.err;
}

TEST(Cli, UnknownSubcommandIsUsageError) {
    const ProcessResult r = run_tool("brdftool", {"frobnicate"});
    EXPECT_EQ(r.status, 2);
    EXPECT_FALSE(r.err.empty());
}

TEST(Cli, NoSubcommandIsUsageError) {
    const ProcessResult r = run_tool("brdftool", {});
    EXPECT_EQ(r.status, 2);
}

} // namespace
} // namespace brdf::test
