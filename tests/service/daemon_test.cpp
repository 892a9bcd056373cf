// run_daemon with fake job runners: the claim/finish/fail paths, --once, requeueing orphans (and not
// the jobs of live daemons), two daemons on one spool, status.json, and a graceful stop.

#include <brdf/core/atomic_file.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/std_regex.h>
#include <brdf/service/daemon.h>
#include <brdf/service/spool.h>

#include "spool_fixture.h"

#include <nlohmann/json.hpp>

#include <atomic>
#include <cstdio>
#include <future>
#include <map>
#include <mutex>
#include <set>
#include <stop_token>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace brdf::test {
namespace {

namespace fs = std::filesystem;
using service::DaemonOptions;
using service::JobRunner;
using service::run_daemon;

DaemonOptions options_for(const fs::path& spool, int workers = 1, bool once = true) {
    DaemonOptions o;
    o.spool = spool;
    o.workers = workers;
    o.once = once;
    o.poll_seconds = 0.02;
    // Specs here are renamed in, or there before the daemon starts (taken once settled): a short
    // settle time keeps these tests quick; the settle tests below set their own.
    o.settle_seconds = 0.05;
    o.handle_signals = false; // several daemons share this process; they stop through o.stop
    return o;
}

/// A fake compute job: counts calls per spec, optionally sleeps, writes results/STEM.result, and
/// fails when the spec says "fail-input" (InputError) or "fail-other" (a plain std::exception).
class FakeRunner {
public:
    explicit FakeRunner(double sleep_seconds = 0.0) : m_sleep(sleep_seconds) {}

    JobRunner runner() {
        return [this](const fs::path& spec, const fs::path& results) { run(spec, results); };
    }
    int calls(const std::string& name) {
        std::lock_guard lock(m_mutex);
        return m_calls[name];
    }
    std::map<std::string, int> all_calls() {
        std::lock_guard lock(m_mutex);
        return m_calls;
    }
    std::vector<std::string> order() {
        std::lock_guard lock(m_mutex);
        return m_order;
    }
    int started() const { return m_started; }

private:
    void run(const fs::path& spec, const fs::path& results) {
        const std::string name = spec.filename().string();
        {
            std::lock_guard lock(m_mutex);
            ++m_calls[name];
            m_order.push_back(name);
        }
        EXPECT_EQ(spec.parent_path().filename(), "active");
        ++m_started;
        const std::string text = read_file(spec);
        if (m_sleep > 0) std::this_thread::sleep_for(std::chrono::duration<double>(m_sleep));
        if (text.find("fail-input") != std::string::npos)
            throw InputError(cat(name, ": pigments[0].size.r_eff_um: must be > 0 (got -0.2)"));
        if (text.find("fail-other") != std::string::npos) throw std::runtime_error("out of luck");
        write_file_atomically(results / (spec.stem().string() + ".result"), text);
    }

    double m_sleep;
    std::mutex m_mutex;
    std::map<std::string, int> m_calls;
    std::vector<std::string> m_order;
    std::atomic<int> m_started{0};
};

TEST(Daemon, OnceRunsEveryJobAndFilesItUnderDone) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    for (int i = 0; i < 5; ++i) submit(spool, cat("job", i, ".json"), cat("{\"i\": ", i, "}"));
    FakeRunner fake;
    EXPECT_EQ(run_daemon(options_for(spool, 2), fake.runner()), 0);
    EXPECT_EQ(list_files(spool / "incoming"), std::vector<std::string>{});
    EXPECT_EQ(list_files(spool / "active"), std::vector<std::string>{});
    EXPECT_EQ(list_files(spool / "done").size(), 5u);
    EXPECT_EQ(list_files(spool / "failed"), std::vector<std::string>{});
    for (int i = 0; i < 5; ++i) {
        EXPECT_EQ(fake.calls(cat("job", i, ".json")), 1);
        EXPECT_EQ(read_file(spool / "results" / cat("job", i, ".result")), cat("{\"i\": ", i, "}"));
    }
    const auto status = nlohmann::json::parse(read_file(spool / "status.json"));
    EXPECT_EQ(status["state"], "stopped");
    EXPECT_EQ(status["done"], 5);
    EXPECT_EQ(status["failed"], 0);
    EXPECT_EQ(status["queued"], 0);
    EXPECT_EQ(status["workers"], 2);
    EXPECT_EQ(status["pid"], ::getpid());
    EXPECT_TRUE(status["running"].empty());
    // The daemon's lease is gone with it.
    EXPECT_EQ(list_files(spool / "daemons"), std::vector<std::string>{});
}

TEST(Daemon, OnceWithEmptySpoolReturnsAtOnce) {
    TempDir tmp;
    FakeRunner fake;
    EXPECT_EQ(run_daemon(options_for(tmp / "spool"), fake.runner()), 0);
    EXPECT_TRUE(fs::is_directory(tmp / "spool" / "incoming"));
}

TEST(Daemon, BadSpecFailsAloneWithErrorRecord) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "good1.json", "{}", 30);
    submit(spool, "bad.json", "fail-input", 20);
    submit(spool, "weird.json", "fail-other", 10);
    submit(spool, "good2.json", "{}", 0);
    FakeRunner fake;
    EXPECT_EQ(run_daemon(options_for(spool, 1), fake.runner()), 1); // --once: 1 when any failed
    EXPECT_EQ(list_files(spool / "done"), (std::vector<std::string>{"good1.json", "good2.json"}));
    EXPECT_EQ(list_files(spool / "failed"), (std::vector<std::string>{"bad.error.json", "bad.json",
                                                                      "weird.error.json", "weird.json"}));
    const auto bad = nlohmann::json::parse(read_file(spool / "failed" / "bad.error.json"));
    EXPECT_EQ(bad["spec"], "bad.json");
    EXPECT_EQ(bad["kind"], "input");
    EXPECT_EQ(bad["error"], "bad.json: pigments[0].size.r_eff_um: must be > 0 (got -0.2)");
    EXPECT_TRUE(std::regex_match(bad["time"].get<std::string>(),
                                 std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)")))
        << bad["time"];
    EXPECT_GE(bad["seconds"].get<double>(), 0.0);
    const auto weird = nlohmann::json::parse(read_file(spool / "failed" / "weird.error.json"));
    EXPECT_EQ(weird["kind"], "internal");
    EXPECT_EQ(weird["error"], "out of luck");
    const auto status = nlohmann::json::parse(read_file(spool / "status.json"));
    EXPECT_EQ(status["done"], 2);
    EXPECT_EQ(status["failed"], 2);
}

TEST(Daemon, TakesOldestFirst) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "c.json", "{}", 10);
    submit(spool, "a.json", "{}", 0);
    submit(spool, "b.json", "{}", 20);
    FakeRunner fake;
    EXPECT_EQ(run_daemon(options_for(spool, 1), fake.runner()), 0);
    EXPECT_EQ(fake.order(), (std::vector<std::string>{"b.json", "c.json", "a.json"}));
}

TEST(Daemon, IgnoresHiddenAndTemporaryFiles) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "real.json");
    write_file(spool / "incoming" / ".hidden.json", "{}");
    write_file(spool / "incoming" / "upload.json.tmp", "{");
    FakeRunner fake;
    EXPECT_EQ(run_daemon(options_for(spool), fake.runner()), 0);
    EXPECT_EQ(fake.all_calls().size(), 1u);
    EXPECT_TRUE(fs::exists(spool / "incoming" / ".hidden.json"));
    EXPECT_TRUE(fs::exists(spool / "incoming" / "upload.json.tmp"));
}

/// pid of a process that has exited and been reaped.
pid_t dead_pid() {
    const pid_t child = fork();
    if (child == 0) _exit(0);
    waitpid(child, nullptr, 0);
    return child;
}

TEST(Daemon, RequeuesJobOfDeadOwnerAtStart) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    service::Spool layout(spool);
    // What a daemon killed mid-job leaves: the spec in active/, its owner record, its stale lock file.
    write_file(spool / "active" / "orphan.json", "{}");
    const std::string ghost = cat("ghost-", dead_pid(), "-0000");
    write_file(spool / "active" / "orphan.json.owner",
               nlohmann::json{{"daemon", ghost}, {"pid", dead_pid()}, {"host", "ghost"}}.dump());
    write_file(spool / "daemons" / (ghost + ".lock"), "{}");
    // And one that died between claiming and recording its ownership.
    write_file(spool / "active" / "unowned.json", "{}");
    FakeRunner fake;
    EXPECT_EQ(run_daemon(options_for(spool), fake.runner()), 0);
    EXPECT_EQ(fake.calls("orphan.json"), 1);
    EXPECT_EQ(fake.calls("unowned.json"), 1);
    EXPECT_EQ(list_files(spool / "done"), (std::vector<std::string>{"orphan.json", "unowned.json"}));
    EXPECT_EQ(list_files(spool / "active"), std::vector<std::string>{});
    EXPECT_EQ(list_files(spool / "daemons"), std::vector<std::string>{});
}

TEST(Daemon, KeepsJobOfLiveOwner) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    service::Spool layout(spool);
    const service::DaemonLease live(layout); // a daemon alive in this very process
    submit(spool, "busy.json");
    ASSERT_TRUE(layout.claim("busy.json", live));
    submit(spool, "other.json");
    FakeRunner fake;
    EXPECT_EQ(run_daemon(options_for(spool), fake.runner()), 0);
    EXPECT_EQ(fake.calls("busy.json"), 0);
    EXPECT_EQ(fake.calls("other.json"), 1);
    EXPECT_EQ(list_files(spool / "active"), (std::vector<std::string>{"busy.json", "busy.json.owner"}));
}

TEST(Daemon, SecondDaemonDoesNotStealRunningJob) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "long.json");
    FakeRunner slow(1.0);
    std::stop_source stop_a;
    DaemonOptions a = options_for(spool, 1, false);
    a.stop = stop_a.get_token();
    auto daemon_a = std::async(std::launch::async, [&] { return run_daemon(a, slow.runner()); });
    ASSERT_TRUE(wait_until([&] { return slow.started() == 1; }));

    FakeRunner other;
    EXPECT_EQ(run_daemon(options_for(spool), other.runner()), 0); // starts, requeues nothing, drains
    EXPECT_EQ(other.all_calls().size(), 0u);
    EXPECT_TRUE(fs::exists(spool / "active" / "long.json"));

    ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "done" / "long.json"); }));
    stop_a.request_stop();
    EXPECT_EQ(daemon_a.get(), 0);
    EXPECT_EQ(slow.calls("long.json"), 1);
}

TEST(Daemon, TwoDaemonsProcessEachOfFortyJobsExactlyOnce) {
    for (int round = 0; round < 3; ++round) {
        TempDir tmp;
        const fs::path spool = tmp / "spool";
        for (int i = 0; i < 40; ++i) submit(spool, cat("job", i, ".json"), "{}", i % 7);
        FakeRunner fake(0.002);
        auto d1 = std::async(std::launch::async, [&] { return run_daemon(options_for(spool, 3), fake.runner()); });
        auto d2 = std::async(std::launch::async, [&] { return run_daemon(options_for(spool, 3), fake.runner()); });
        EXPECT_EQ(d1.get(), 0);
        EXPECT_EQ(d2.get(), 0);
        const auto calls = fake.all_calls();
        EXPECT_EQ(calls.size(), 40u);
        for (const auto& [name, n] : calls) EXPECT_EQ(n, 1) << name << " in round " << round;
        EXPECT_EQ(list_files(spool / "done").size(), 40u);
        EXPECT_EQ(list_files(spool / "results").size(), 40u);
        EXPECT_EQ(list_files(spool / "active"), std::vector<std::string>{});
    }
}

TEST(Daemon, StatusJsonIsValidWhileBeingRewritten) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    for (int i = 0; i < 60; ++i) submit(spool, cat("job", i, ".json"), i % 10 == 0 ? "fail-input" : "{}");
    FakeRunner fake(0.001);
    std::atomic<bool> finished{false};
    auto daemon = std::async(std::launch::async, [&] {
        const int status = run_daemon(options_for(spool, 2), fake.runner());
        finished = true;
        return status;
    });
    int reads = 0, parse_failures = 0;
    std::set<std::string> states;
    while (!finished) {
        std::string text;
        try {
            text = read_file(spool / "status.json");
        } catch (const std::exception&) {
            continue; // not written yet
        }
        ++reads;
        const auto status = nlohmann::json::parse(text, nullptr, false);
        if (status.is_discarded()) {
            ++parse_failures;
            ADD_FAILURE() << "status.json is not JSON: " << text;
            continue;
        }
        for (const char* key : {"pid", "started", "queued", "running", "done", "failed", "workers", "state"})
            EXPECT_TRUE(status.contains(key)) << key << " missing in " << text;
        EXPECT_TRUE(status["running"].is_array());
        EXPECT_LE(status["running"].size(), 2u);
        states.insert(status["state"].get<std::string>());
    }
    EXPECT_EQ(daemon.get(), 1);
    EXPECT_GT(reads, 0);
    EXPECT_EQ(parse_failures, 0);
    EXPECT_TRUE(states.count("running")) << reads << " reads";
    const auto last = nlohmann::json::parse(read_file(spool / "status.json"));
    EXPECT_EQ(last["state"], "stopped");
    EXPECT_EQ(last["done"], 54);
    EXPECT_EQ(last["failed"], 6);
    // No temporaries left behind.
    for (const auto& entry : fs::directory_iterator(spool))
        EXPECT_NE(entry.path().extension(), ".tmp") << entry.path();
}

TEST(Daemon, StopLetsRunningJobFinishAndLeavesTheQueue) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "first.json", "{}", 30);
    submit(spool, "second.json", "{}", 20);
    submit(spool, "third.json", "{}", 10);
    FakeRunner slow(0.5);
    std::stop_source stop;
    DaemonOptions o = options_for(spool, 1, false);
    o.stop = stop.get_token();
    auto daemon = std::async(std::launch::async, [&] { return run_daemon(o, slow.runner()); });
    ASSERT_TRUE(wait_until([&] { return slow.started() == 1; }));
    stop.request_stop();
    ASSERT_TRUE(wait_until([&] {
        return nlohmann::json::parse(read_file(spool / "status.json"))["state"] != "running";
    }));
    EXPECT_EQ(daemon.get(), 0);
    EXPECT_EQ(list_files(spool / "done"), std::vector<std::string>{"first.json"});
    EXPECT_EQ(list_files(spool / "incoming"), (std::vector<std::string>{"second.json", "third.json"}));
    EXPECT_EQ(list_files(spool / "active"), std::vector<std::string>{});
    EXPECT_EQ(nlohmann::json::parse(read_file(spool / "status.json"))["state"], "stopped");
}

TEST(Daemon, ServesJobsThatArriveLater) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    FakeRunner fake;
    std::stop_source stop;
    DaemonOptions o = options_for(spool, 2, false);
    o.stop = stop.get_token();
    auto daemon = std::async(std::launch::async, [&] { return run_daemon(o, fake.runner()); });
    ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "status.json"); }));
    submit(spool, "late.json");
    EXPECT_TRUE(wait_until([&] { return fs::exists(spool / "done" / "late.json"); }));
    submit(spool, "bad.json", "fail-input");
    EXPECT_TRUE(wait_until([&] { return fs::exists(spool / "failed" / "bad.json"); }));
    EXPECT_TRUE(fs::exists(spool / "failed" / "bad.error.json"));
    stop.request_stop();
    EXPECT_EQ(daemon.get(), 0); // serving mode: a failed job does not change the exit status
}

TEST(Daemon, InvalidOptionsAreInputErrors) {
    TempDir tmp;
    FakeRunner fake;
    DaemonOptions o = options_for(tmp / "spool");
    o.workers = 0;
    EXPECT_THROW(run_daemon(o, fake.runner()), InputError);
    o.workers = 1;
    o.poll_seconds = 0;
    EXPECT_THROW(run_daemon(o, fake.runner()), InputError);
    o.poll_seconds = 0.1;
    o.settle_seconds = -1;
    EXPECT_THROW(run_daemon(o, fake.runner()), InputError);
    o.settle_seconds = 1;
    o.spool.clear();
    EXPECT_THROW(run_daemon(o, fake.runner()), InputError);
}


// inotify: with a 30 s poll, a spec dropped while every worker is idle starts at once when it is
// renamed in (IN_MOVED_TO); written in place (IN_CLOSE_WRITE), once the settle time has passed.
TEST(Daemon, NewSpecWakesAnIdleDaemonWithoutWaitingForThePoll) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    FakeRunner fake;
    std::stop_source stop;
    DaemonOptions o = options_for(spool, 2, false);
    o.poll_seconds = 30;
    o.settle_seconds = 0.3;
    o.stop = stop.get_token();
    auto daemon = std::async(std::launch::async, [&] { return run_daemon(o, fake.runner()); });
    ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "status.json"); }));
    std::this_thread::sleep_for(std::chrono::milliseconds(200)); // both workers asleep on the poll
    submit(spool, "renamed.json");
    EXPECT_TRUE(wait_until([&] { return fs::exists(spool / "done" / "renamed.json"); }, 1.0));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    write_file(spool / "incoming" / "written.json", "{}");
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    EXPECT_FALSE(fs::exists(spool / "done" / "written.json")) << "taken before it settled";
    EXPECT_TRUE(wait_until([&] { return fs::exists(spool / "done" / "written.json"); }, 1.5));
    stop.request_stop();
    EXPECT_EQ(daemon.get(), 0);
}

/// Writes `content` into `path` in place (no rename), in two halves with a pause between, the way
/// an editor or a slow network copy might; returns when the file is closed.
void write_slowly(const fs::path& path, const std::string& content, double pause_seconds) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    std::fwrite(content.data(), 1, content.size() / 2, f);
    std::fflush(f);
    std::this_thread::sleep_for(std::chrono::duration<double>(pause_seconds));
    std::fwrite(content.data() + content.size() / 2, 1, content.size() - content.size() / 2, f);
    std::fclose(f);
}

/// A runner that keeps the text of each spec it was given.
struct RecordingRunner {
    std::mutex mutex;
    std::map<std::string, std::string> seen;
    JobRunner runner() {
        return [this](const fs::path& spec, const fs::path&) {
            std::lock_guard lock(mutex);
            seen[spec.filename().string()] = read_file(spec);
        };
    }
};

const std::string paused_spec = R"({"name": "slow", "medium": {"albedo": 0.5}, "description": ")" +
                                std::string(4000, 'x') + "\"}";

// A writer that pauses 3 s in the middle of a spec written in place, three times the settle time:
// the daemon must wait for the whole spec, with inotify (the file is open: IN_MODIFY without
// IN_CLOSE_WRITE) and without it (the kernel refuses a read lease on a file open for writing).
TEST(Daemon, SpecWrittenInPlaceIsNotTakenWhileItsWriterPauses) {
    for (const bool watch : {true, false}) {
        SCOPED_TRACE(watch ? "inotify" : "polling only");
        TempDir tmp;
        const fs::path spool = tmp / "spool";
        RecordingRunner recorder;
        std::stop_source stop;
        DaemonOptions o = options_for(spool, 1, false);
        o.watch_incoming = watch;
        o.poll_seconds = 0.05;
        o.settle_seconds = 1.0;
        o.stop = stop.get_token();
        auto daemon = std::async(std::launch::async, [&] { return run_daemon(o, recorder.runner()); });
        ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "status.json"); }));
        write_slowly(spool / "incoming" / "slow.json", paused_spec, 3.0);
        EXPECT_FALSE(fs::exists(spool / "done" / "slow.json")) << "taken while being written";
        ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "done" / "slow.json"); }, 5.0));
        EXPECT_EQ(recorder.seen["slow.json"], paused_spec);
        stop.request_stop();
        EXPECT_EQ(daemon.get(), 0);
    }
}

// A spec appended to in place, its writer closing it between appends (so no lease and no open file
// says it is unfinished): taken only once its size and time have stood still for the settle time.
TEST(Daemon, SpecThatKeepsChangingIsTakenOnlyOnceItSettles) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    RecordingRunner recorder;
    std::stop_source stop;
    DaemonOptions o = options_for(spool, 1, false);
    o.watch_incoming = false;
    o.poll_seconds = 0.05;
    o.settle_seconds = 0.6;
    o.stop = stop.get_token();
    auto daemon = std::async(std::launch::async, [&] { return run_daemon(o, recorder.runner()); });
    ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "status.json"); }));
    const fs::path target = spool / "incoming" / "grow.json";
    std::string text;
    for (int i = 0; i < 10; ++i) { // 2 s of appends, 0.2 s apart
        text += cat("chunk ", i, "\n");
        write_file(target, text);
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
        ASSERT_FALSE(fs::exists(spool / "done" / "grow.json")) << "taken after append " << i;
    }
    ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "done" / "grow.json"); }, 3.0));
    EXPECT_EQ(recorder.seen["grow.json"], text);
    stop.request_stop();
    EXPECT_EQ(daemon.get(), 0);
}

// Renamed in, the protocol: taken at once, however long the settle time.
TEST(Daemon, RenamedInSpecIsTakenWithoutWaitingToSettle) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    FakeRunner fake;
    std::stop_source stop;
    DaemonOptions o = options_for(spool, 1, false);
    o.poll_seconds = 30;
    o.settle_seconds = 30;
    o.stop = stop.get_token();
    auto daemon = std::async(std::launch::async, [&] { return run_daemon(o, fake.runner()); });
    ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "status.json"); }));
    submit(spool, "quick.json");
    EXPECT_TRUE(wait_until([&] { return fs::exists(spool / "done" / "quick.json"); }, 2.0));
    stop.request_stop();
    EXPECT_EQ(daemon.get(), 0);
}

// --once is not drained while a spec is still being written into incoming/.
TEST(Daemon, OnceWaitsForASpecBeingWritten) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    fs::create_directories(spool / "incoming");
    RecordingRunner recorder;
    DaemonOptions o = options_for(spool, 1, true);
    o.settle_seconds = 0.2;
    std::thread writer([&] { write_slowly(spool / "incoming" / "late.json", paused_spec, 1.0); });
    std::this_thread::sleep_for(std::chrono::milliseconds(100)); // the first half is there
    EXPECT_EQ(run_daemon(o, recorder.runner()), 0);
    writer.join();
    EXPECT_EQ(recorder.seen["late.json"], paused_spec);
    EXPECT_EQ(list_files(spool / "done"), std::vector<std::string>{"late.json"});
}

// Messages and status.json name the spool by an absolute path, whatever the daemon was given.
TEST(Daemon, StatusAndErrorsNameAbsolutePathsThatExist) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "bad.json", "x");
    DaemonOptions o = options_for(spool, 1, true);
    o.spool = fs::relative(spool);
    ASSERT_TRUE(o.spool.is_relative());
    const JobRunner runner = [](const fs::path& spec, const fs::path&) {
        throw InputError(cat(spec.string(), ": invalid JSON"));
    };
    EXPECT_EQ(run_daemon(o, runner), 1);
    const auto status = nlohmann::json::parse(read_file(spool / "status.json"));
    EXPECT_EQ(fs::path(status["spool"].get<std::string>()), fs::canonical(spool));
    const auto record = nlohmann::json::parse(read_file(spool / "failed" / "bad.error.json"));
    const std::string error = record["error"];
    // The spec is named where it is now (failed/), not where it ran (active/).
    const std::string named = error.substr(0, error.find(": "));
    EXPECT_TRUE(fs::path(named).is_absolute()) << error;
    EXPECT_TRUE(fs::exists(named)) << error;
    EXPECT_EQ(fs::canonical(named), fs::canonical(spool / "failed" / "bad.json")) << error;
}

// Without the watch (no inotify, or a network file system where it does not fire) polling serves.
TEST(Daemon, PollingServesWhenTheWatchIsOff) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    FakeRunner fake;
    std::stop_source stop;
    DaemonOptions o = options_for(spool, 1, false);
    o.watch_incoming = false;
    o.poll_seconds = 1.5;
    o.stop = stop.get_token();
    auto daemon = std::async(std::launch::async, [&] { return run_daemon(o, fake.runner()); });
    ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "status.json"); }));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    submit(spool, "polled.json");
    // Nothing wakes the worker before its poll: the watch is what makes the other test fast...
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_FALSE(fs::exists(spool / "done" / "polled.json"));
    // ...and the poll finds the spec all the same.
    EXPECT_TRUE(wait_until([&] { return fs::exists(spool / "done" / "polled.json"); }, 5.0));
    stop.request_stop();
    EXPECT_EQ(daemon.get(), 0);
}

} // namespace
} // namespace brdf::test
