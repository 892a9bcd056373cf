// The real brdfd binary as a user runs it: help, version, usage errors, --once exit statuses, SIGTERM
// and SIGINT while a job runs, a SIGKILLed daemon's job picked up by the next one. Jobs use the
// BRDFD_TEST_RUNNER=sleep:SECONDS test hook (docs/daemon.md) instead of the compute pipeline.

#include <brdf/core/version.h>

#include "brdfd_fixture.h"
#include "spool_fixture.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <optional>
#include <thread>
#include <sys/wait.h>
#include <unistd.h>

namespace brdf::test {
namespace {

namespace fs = std::filesystem;

TEST(Brdfd, VersionAndHelp) {
    const ProcessResult version = run_tool("brdfd", {"--version"});
    EXPECT_EQ(version.status, 0);
    EXPECT_NE(version.out.find(version_string), std::string::npos) << version.out;
    const ProcessResult help = run_tool("brdfd", {"--help"});
    EXPECT_EQ(help.status, 0);
    for (const char* text : {"--spool", "--workers", "--once", "--poll", "--log-level", "Exit status",
                             "incoming", "SIGTERM"})
        EXPECT_NE(help.out.find(text), std::string::npos) << text << " not in\n" << help.out;
}

TEST(Brdfd, UsageErrors) {
    TempDir tmp;
    const std::string spool = (tmp / "s").string();
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{}, "brdfd: --spool is required"},
        {{"--spool", spool, "--workers", "0"}, "brdfd: --workers: "},
        {{"--spool", spool, "--poll", "-1"}, "brdfd: --poll: "},
        {{"--spool", spool, "--settle", "x"}, "brdfd: --settle: "},
        {{"--spool", spool, "--frobnicate"}, "brdfd: unknown option --frobnicate"},
        {{"--frobnicate"}, "brdfd: unknown option --frobnicate"}, // before "--spool is required"
        {{"--spool", spool, "extra"}, "brdfd: unexpected argument 'extra'"},
    };
    for (const auto& [args, start] : cases) {
        const ProcessResult r = run_tool("brdfd", args);
        EXPECT_EQ(r.status, 2) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
        EXPECT_EQ(r.err.rfind(start, 0), 0u) << "expected '" << start << "...', got " << r.err;
    }
    EXPECT_FALSE(fs::exists(tmp / "s")) << "a usage error touches nothing";
    const ProcessResult level =
        run_tool("brdfd", {"--spool", (tmp / "s").string(), "--once", "--log-level", "loud"});
    EXPECT_EQ(level.status, 3);
    EXPECT_NE(level.err.find("loud"), std::string::npos) << level.err;
}

TEST(Brdfd, UnusableSpoolIsIoError) {
    TempDir tmp;
    write_file(tmp / "file", "x");
    const ProcessResult r = run_tool("brdfd", {"--spool", (tmp / "file" / "spool").string(), "--once"});
    EXPECT_EQ(r.status, 7);
    EXPECT_NE(r.err.find("brdfd: "), std::string::npos) << r.err;
}

TEST(Brdfd, OnceExitStatusTellsWhetherAnyJobFailed) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "a.json");
    submit(spool, "b.json");
    {
        Brdfd d({"--spool", spool.string(), "--once", "--workers", "2"}, "sleep:0", tmp / "log1");
        EXPECT_EQ(d.wait(30), 0) << d.log();
        EXPECT_NE(d.log().find("job a.json: done in"), std::string::npos) << d.log();
    }
    EXPECT_EQ(list_files(spool / "done"), (std::vector<std::string>{"a.json", "b.json"}));
    EXPECT_TRUE(fs::exists(spool / "results" / "a.result"));

    submit(spool, "c.json");
    submit(spool, "bad.json", "{\"brdfd-test-fail\": true}");
    Brdfd d({"--spool", spool.string(), "--once"}, "sleep:0", tmp / "log2");
    EXPECT_EQ(d.wait(30), 1) << d.log();
    EXPECT_TRUE(fs::exists(spool / "done" / "c.json"));
    const auto record = nlohmann::json::parse(read_file(spool / "failed" / "bad.error.json"));
    EXPECT_EQ(record["kind"], "input");
    EXPECT_NE(d.log().find("job bad.json: failed after"), std::string::npos) << d.log();
}

TEST(Brdfd, SigtermLetsTheRunningJobFinishAndStopsIntake) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "first.json", "{}", 10);
    submit(spool, "second.json", "{}", 0);
    Brdfd d({"--spool", spool.string(), "--poll", "0.05"}, "sleep:1.5", tmp / "log");
    ASSERT_TRUE(wait_until([&] { return running_jobs(spool, 1); }, 20)) << d.log();
    d.signal(SIGTERM);
    EXPECT_TRUE(wait_until([&] { return status_of(spool)["state"] == "draining"; }, 5)) << d.log();
    EXPECT_EQ(d.wait(30), 0) << d.log();
    EXPECT_EQ(list_files(spool / "done"), std::vector<std::string>{"first.json"});
    EXPECT_EQ(list_files(spool / "incoming"), std::vector<std::string>{"second.json"});
    EXPECT_EQ(list_files(spool / "active"), std::vector<std::string>{});
    EXPECT_EQ(status_of(spool)["state"], "stopped");
}

TEST(Brdfd, SecondSigintStillWaitsForTheRunningJob) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "only.json");
    Brdfd d({"--spool", spool.string(), "--poll", "0.05"}, "sleep:1.5", tmp / "log");
    ASSERT_TRUE(wait_until([&] { return running_jobs(spool, 1); }, 20)) << d.log();
    d.signal(SIGINT);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    d.signal(SIGINT);
    EXPECT_EQ(d.wait(30), 0) << d.log();
    EXPECT_EQ(list_files(spool / "done"), std::vector<std::string>{"only.json"});
    EXPECT_NE(d.log().find("already stopping"), std::string::npos) << d.log();
}

TEST(Brdfd, JobOfAKilledDaemonIsRequeuedByTheNextStart) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "victim.json");
    {
        Brdfd d({"--spool", spool.string()}, "sleep:60", tmp / "log1");
        ASSERT_TRUE(wait_until([&] { return running_jobs(spool, 1); }, 20)) << d.log();
        d.signal(SIGKILL);
        EXPECT_EQ(d.wait(10), 128 + SIGKILL);
    }
    EXPECT_TRUE(fs::exists(spool / "active" / "victim.json"));
    Brdfd next({"--spool", spool.string(), "--once"}, "sleep:0", tmp / "log2");
    EXPECT_EQ(next.wait(30), 0) << next.log();
    EXPECT_EQ(list_files(spool / "done"), std::vector<std::string>{"victim.json"});
    EXPECT_NE(next.log().find("requeued victim.json"), std::string::npos) << next.log();
}

// The shipped daemon has no test hook: the variable changes nothing and the code is not in it.
TEST(Brdfd, ShippedDaemonHasNoTestHook) {
    const std::string binary = read_file(bin_dir() / "brdfd");
    EXPECT_EQ(binary.find("BRDFD_TEST_RUNNER"), std::string::npos);
    EXPECT_EQ(binary.find("brdfd-test-fail"), std::string::npos);
    EXPECT_NE(read_file(bin_dir() / "brdfd_test").find("BRDFD_TEST_RUNNER"), std::string::npos);
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "hook.json", "{}"); // the hook would copy it; the pipeline refuses it (no name)
    std::vector<std::string> env_argv = {"/usr/bin/env", "BRDFD_TEST_RUNNER=sleep:0",
                                         (bin_dir() / "brdfd").string(), "--spool", spool.string(), "--once"};
    const ProcessResult r = run_process(env_argv);
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_EQ(r.err.find("test hook"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(spool / "results" / "hook.result"));
    EXPECT_TRUE(fs::exists(spool / "failed" / "hook.json"));
}

// The real compute pipeline: whatever it grows into, a spec that is not JSON fails alone.
TEST(Brdfd, RealRunnerFailsASpecThatIsNotJson) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "broken.json", "{\"name\": ");
    Brdfd d({"--spool", spool.string(), "--once"}, "", tmp / "log");
    EXPECT_EQ(d.wait(60), 1) << d.log();
    EXPECT_EQ(list_files(spool / "failed"), (std::vector<std::string>{"broken.error.json", "broken.json"}));
    const auto record = nlohmann::json::parse(read_file(spool / "failed" / "broken.error.json"));
    EXPECT_EQ(record["spec"], "broken.json");
    EXPECT_EQ(record["kind"], "input");
}

} // namespace
} // namespace brdf::test
