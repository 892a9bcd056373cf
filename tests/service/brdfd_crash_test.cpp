// brdfd under abuse, as real processes with real signals on a temporary spool: a new spec noticed
// at once (inotify) despite a long poll; SIGKILL at many moments (just after a claim, mid-job, while
// a result is half written) followed by a restart; SIGTERM during a real compute; a burst of good and
// bad specs; a results folder that cannot be written; identical specs not recomputed.
// The sleep-hook tests use BRDFD_TEST_RUNNER (docs/daemon.md, "Test hook"); the others run the real
// compute pipeline on a tiny analytic spec (a few seconds on a CPU OpenCL platform).

#include "brdfd_fixture.h"
#include "spool_fixture.h"

#include <brdf/core/log.h>
#include <brdf/core/std_regex.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <map>
#include <csignal>
#include <cstdio>
#include <set>
#include <sys/stat.h>
#include <thread>

namespace brdf::test {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

/// A tiny analytic material: no Mie, three wavelengths, draft accuracy.
std::string tiny_spec(const std::string& name, double albedo = 0.9) {
    return cat(R"({"name": ")", name, R"(", "medium": {"albedo": )", albedo,
               R"(}, "accuracy": "draft", "spectrum": "rgb"})");
}
/// MERL tables are 90 x 90 x 180 cells x 3 channels of doubles after a 12-byte header.
constexpr std::uintmax_t merl_size = 12 + 90ull * 90 * 180 * 3 * 8;

/// Every file anywhere under the spool that is hidden (other than .spool.lock) or named like a
/// temporary: what a killed writer leaves behind.
std::vector<std::string> leftovers(const fs::path& spool) {
    std::vector<std::string> found;
    for (const auto& entry : fs::recursive_directory_iterator(spool)) {
        const std::string name = entry.path().filename().string();
        if (entry.path() == spool / ".spool.lock") continue;
        if (name.front() == '.' || name.find(".tmp") != std::string::npos)
            found.push_back(fs::relative(entry.path(), spool).string());
    }
    return found;
}

/// Every file in a folder, hidden ones included.
std::vector<std::string> all_files(const fs::path& dir) {
    std::vector<std::string> names;
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
        names.push_back(it->path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

/// In how many of incoming/, active/, done/, failed/ the job is: exactly 1 at any moment.
int places(const fs::path& spool, const std::string& job) {
    int n = 0;
    for (const char* dir : {"incoming", "active", "done", "failed"}) n += fs::exists(spool / dir / job);
    return n;
}

bool has_active_job(const fs::path& spool) {
    for (const std::string& name : list_files(spool / "active"))
        if (name.size() > 5 && name.substr(name.size() - 5) == ".json") return true;
    return false;
}

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// "job NAME: done in 35.2 ms" (or "3.42 s") from a daemon's log, in seconds; -1 when absent.
double job_seconds(const std::string& log, const std::string& job) {
    const std::regex re("job " + std::regex_replace(job, std::regex(R"(\.)"), R"(\.)") +
                        R"(: done in ([0-9.]+) (ms|s)\b)");
    std::smatch m;
    if (!std::regex_search(log, m, re)) return -1.0;
    return std::stod(m[1].str()) * (m[2].str() == "ms" ? 1e-3 : 1.0);
}

// --- inotify ---------------------------------------------------------------------------------------

TEST(BrdfdService, SpecDroppedWhileIdleStartsWithinASecondDespiteALongPoll) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    Brdfd d({"--spool", spool.string(), "--poll", "30"}, "sleep:0", tmp / "log");
    ASSERT_TRUE(wait_until([&] { return status_of(spool)["state"] == "running"; }, 20)) << d.log();
    for (const char* name : {"first.json", "second.json"}) {
        std::this_thread::sleep_for(std::chrono::milliseconds(300)); // the worker sleeps on its poll
        const Clock::time_point t0 = Clock::now();
        submit(spool, name);
        EXPECT_TRUE(wait_until([&] { return fs::exists(spool / "done" / name); }, 1.0))
            << name << " not done after " << seconds_since(t0) << " s\n"
            << d.log();
    }
    d.signal(SIGTERM);
    EXPECT_EQ(d.wait(10), 0) << d.log();
}

// --- SIGKILL and restart -----------------------------------------------------------------------------

// Sleep hook "sleep:0.15,write:0.3": each job computes 0.15 s, then spends 0.3 s with its result
// half written under a hidden temporary (as the table writers do). Kills land just after the first
// claim (delay 0: maybe before the owner record), mid-computation, mid-write, between jobs, while the
// failing job is filed. The restart (--once) must file every job exactly once and leave no temporary.
TEST(BrdfdService, KillNineAtManyMomentsThenRestartFilesEveryJobOnceAndLeavesNoTemporaries) {
    const std::vector<double> delays = {0.0, 0.005, 0.05, 0.12, 0.2, 0.3, 0.4, 0.55, 0.7, 0.9};
    int killed_mid_write = 0;
    for (const double delay : delays) {
        SCOPED_TRACE(cat("SIGKILL ", delay, " s after the first claim"));
        TempDir tmp;
        const fs::path spool = tmp / "spool";
        submit(spool, "a.json", R"({"a": 1, "pad": "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"})", 30);
        submit(spool, "b.json", R"({"b": 2, "pad": "bbbbbbbbbbbbbbbbbbbbbbbbbbbbbbbbbbbbbbbb"})", 20);
        submit(spool, "bad.json", R"({"brdfd-test-fail": true})", 10);
        {
            Brdfd d({"--spool", spool.string(), "--workers", "2", "--poll", "0.02"},
                    "sleep:0.15,write:0.3", tmp / "log1");
            ASSERT_TRUE(wait_until([&] { return has_active_job(spool); }, 20)) << d.log();
            std::this_thread::sleep_for(std::chrono::duration<double>(delay));
            d.signal(SIGKILL);
            ASSERT_EQ(d.wait(10), 128 + SIGKILL) << d.log();
        }
        for (const char* job : {"a.json", "b.json", "bad.json"}) EXPECT_EQ(places(spool, job), 1) << job;
        for (const std::string& f : all_files(spool / "results"))
            if (f.front() == '.') ++killed_mid_write;

        Brdfd next({"--spool", spool.string(), "--once", "--workers", "2"}, "sleep:0", tmp / "log2");
        const int status = next.wait(30);
        // 1 when the restart ran the failing job itself, 0 when the killed daemon had filed it.
        EXPECT_TRUE(status == 0 || status == 1) << status << "\n" << next.log();
        EXPECT_EQ(list_files(spool / "done"), (std::vector<std::string>{"a.json", "b.json"}));
        EXPECT_EQ(list_files(spool / "failed"), (std::vector<std::string>{"bad.error.json", "bad.json"}));
        EXPECT_EQ(all_files(spool / "incoming"), std::vector<std::string>{});
        EXPECT_EQ(all_files(spool / "active"), std::vector<std::string>{});
        EXPECT_EQ(all_files(spool / "daemons"), std::vector<std::string>{});
        EXPECT_EQ(all_files(spool / "results"), (std::vector<std::string>{"a.result", "b.result"}));
        EXPECT_EQ(read_file(spool / "results" / "a.result"), read_file(spool / "done" / "a.json"));
        EXPECT_EQ(read_file(spool / "results" / "b.result"), read_file(spool / "done" / "b.json"));
        EXPECT_EQ(leftovers(spool), std::vector<std::string>{}) << next.log();
    }
    // The delays are chosen so that some kills land while a result is half written.
    EXPECT_GT(killed_mid_write, 0);
}

// A writer killed in the middle of a table (a real AtomicFile temporary of a dead process) in a spool
// where no daemon lives: the next start removes it, and nothing that belongs to someone alive.
TEST(BrdfdService, RestartRemovesTemporariesOfKilledWritersOnly) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    fs::create_directories(spool / "results");
    fs::create_directories(spool / "incoming");
    // A writer process: creates its temporary the way formats' AtomicFile names it, half writes it,
    // and is SIGKILLed.
    int ready[2];
    ASSERT_EQ(pipe(ready), 0);
    const pid_t writer = fork();
    ASSERT_GE(writer, 0);
    if (writer == 0) {
        ::close(ready[0]);
        const std::string tmp_name = cat(".k.binary.tmp.", ::getpid(), ".0.4242");
        const int fd = ::open((spool / "results" / tmp_name).c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
        [[maybe_unused]] ssize_t k = ::write(fd, "half a table", 12);
        k = ::write(ready[1], "x", 1);
        ::pause();
        _exit(0);
    }
    ::close(ready[1]);
    char c;
    ASSERT_EQ(::read(ready[0], &c, 1), 1);
    ::close(ready[0]);
    ::kill(writer, SIGKILL);
    ::waitpid(writer, nullptr, 0);
    const fs::path killed = spool / "results" / cat(".k.binary.tmp.", writer, ".0.4242");
    ASSERT_TRUE(fs::exists(killed));
    const fs::path live = spool / "results" / cat(".k.exr.tmp.", ::getpid(), ".0.1"); // we are alive
    write_file(live, "being written");
    write_file(spool / "results" / ".keep", "");
    write_file(spool / "incoming" / ".staged.json.tmp", "{}"); // a user's, not ours
    std::this_thread::sleep_for(std::chrono::milliseconds(20)); // strictly older than the start

    Brdfd d({"--spool", spool.string(), "--once"}, "sleep:0", tmp / "log");
    EXPECT_EQ(d.wait(30), 0) << d.log();
    EXPECT_FALSE(fs::exists(killed)) << d.log();
    EXPECT_NE(d.log().find("temporary of a writer that is gone"), std::string::npos) << d.log();
    EXPECT_TRUE(fs::exists(live));
    EXPECT_TRUE(fs::exists(spool / "results" / ".keep"));
    EXPECT_TRUE(fs::exists(spool / "incoming" / ".staged.json.tmp"));
}

// The real pipeline: the same job killed again and again (just after its claim, mid-computation,
// and the moment a table's temporary appears in results/, i.e. while the tables are being written),
// each restart requeueing and recomputing it; the job is in exactly one place after every kill, and
// the final --once run removes the killed writers' temporaries and leaves complete tables.
TEST(BrdfdService, RealComputeKilledRepeatedlyEndsDoneWithCompleteTables) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    // Tables and report of an older version of material k, from an earlier submission of the same
    // job, are there: the job replaces them (another job's results it would refuse to replace).
    submit(spool, "k.json", tiny_spec("k", 0.5));
    {
        Brdfd d({"--spool", spool.string(), "--once"}, "", tmp / "log0");
        ASSERT_EQ(d.wait(120), 0) << d.log();
    }
    const std::string old_hash =
        nlohmann::json::parse(read_file(spool / "results" / "k.report.json"))["spec_hash"];
    // Resubmitted with new content: done/k.json goes back into incoming/.
    fs::remove(spool / "done" / "k.json");
    submit(spool, "k.json", tiny_spec("k"));
    const auto table_temporary = [&] {
        for (const std::string& f : all_files(spool / "results"))
            if (f.front() == '.') return true;
        return false;
    };
    bool left_temporary = false;
    int round = 0;
    for (const char* moment : {"just after the claim", "0.3 s after the claim", "while writing"}) {
        SCOPED_TRACE(cat("SIGKILL ", moment));
        if (fs::exists(spool / "done" / "k.json")) break; // a round finished it: later ones are moot
        Brdfd d({"--spool", spool.string(), "--poll", "0.02"}, "", tmp / cat("log", ++round));
        // This daemon's claim (active/k.json may still be the killed one's, not yet requeued).
        ASSERT_TRUE(wait_until(
            [&] {
                const nlohmann::json s = status_of(spool);
                return s.value("pid", 0L) == d.pid() && s.contains("running") && s["running"].size() == 1;
            },
            30))
            << d.log();
        if (round == 2) std::this_thread::sleep_for(std::chrono::milliseconds(300));
        if (round == 3) {
            EXPECT_TRUE(wait_until([&] { return table_temporary() || fs::exists(spool / "done" / "k.json"); }, 60))
                << d.log();
        }
        d.signal(SIGKILL);
        ASSERT_EQ(d.wait(10), 128 + SIGKILL) << d.log();
        EXPECT_EQ(places(spool, "k.json"), 1);
        if (table_temporary()) {
            left_temporary = true;
            // Killed while replacing the tables: the old report must not survive to vouch for them.
            EXPECT_FALSE(fs::exists(spool / "results" / "k.report.json"));
        }
    }
    // Whether the last kill caught a table half written depends on the machine's speed: reported,
    // not required (the sleep-hook test above makes that moment certain).
    RecordProperty("killed_mid_write", left_temporary ? "yes" : "no");
    std::printf("note: %s\n", left_temporary ? "a kill left a half-written table; the restart removed it"
                                             : "no kill caught a table half written on this machine");
    Brdfd next({"--spool", spool.string(), "--once"}, "", tmp / "log-final");
    EXPECT_EQ(next.wait(120), 0) << next.log();
    if (left_temporary) {
        EXPECT_NE(next.log().find("temporary of a writer that is gone"), std::string::npos) << next.log();
    }
    EXPECT_EQ(list_files(spool / "done"), (std::vector<std::string>{"k.json"}));
    EXPECT_EQ(all_files(spool / "failed"), std::vector<std::string>{});
    EXPECT_EQ(all_files(spool / "active"), std::vector<std::string>{});
    EXPECT_EQ(all_files(spool / "results"),
              (std::vector<std::string>{"k.binary", "k.exr", "k.report.json"}));
    EXPECT_EQ(fs::file_size(spool / "results" / "k.binary"), merl_size);
    const auto report = nlohmann::json::parse(read_file(spool / "results" / "k.report.json"));
    EXPECT_EQ(report["name"], "k");
    EXPECT_FALSE(report["spec_hash"].get<std::string>().empty());
    EXPECT_NE(report["spec_hash"], old_hash);
    EXPECT_EQ(report["spec"]["medium"]["albedo"], 0.9) << report["spec"].dump();
    EXPECT_EQ(leftovers(spool), std::vector<std::string>{}) << next.log();
}

// --- SIGTERM -------------------------------------------------------------------------------------------

TEST(BrdfdService, SigtermDuringARealComputeLetsItFinishAndExitsZero) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "k.json", tiny_spec("k"));
    Brdfd d({"--spool", spool.string(), "--poll", "0.02"}, "", tmp / "log");
    ASSERT_TRUE(wait_until([&] { return has_active_job(spool); }, 30)) << d.log();
    d.signal(SIGTERM);
    EXPECT_EQ(d.wait(120), 0) << d.log();
    const std::string log = d.log();
    EXPECT_NE(log.find("SIGTERM: taking no new jobs; waiting for 1 running job(s)"), std::string::npos)
        << log;
    EXPECT_LT(log.find("SIGTERM"), log.find("job k.json: done in")) << log;
    EXPECT_EQ(list_files(spool / "done"), std::vector<std::string>{"k.json"});
    EXPECT_EQ(fs::file_size(spool / "results" / "k.binary"), merl_size);
    EXPECT_TRUE(fs::exists(spool / "results" / "k.report.json"));
    EXPECT_EQ(status_of(spool)["state"], "stopped");
    EXPECT_EQ(leftovers(spool), std::vector<std::string>{});
}

// --- a burst of good and bad specs -----------------------------------------------------------------------

TEST(BrdfdService, BurstOfFiftySpecsFilesGoodAndBadAndKeepsServing) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    struct Bad {
        std::string file, content, kind, says;
    };
    const std::vector<Bad> bad = {
        {"json-cut.json", R"({"name": )", "input", "json-cut.json"},
        {"json-garbage.json", "this is not JSON", "input", "json-garbage.json"},
        {"json-array.json", "[1, 2,", "input", "json-array.json"},
        {"empty.json", "", "input", "empty.json"},
        {"albedo-range.json", tiny_spec("ar", 1.5), "input", "medium.albedo"},
        {"albedo-type.json", R"({"name": "at", "medium": {"albedo": "high"}})", "input", "medium.albedo"},
        {"accuracy.json", R"({"name": "ac", "medium": {"albedo": 0.5}, "accuracy": "sloppy"})", "input",
         "accuracy"},
        {"unknown-key.json", R"({"name": "uk", "medium": {"albdo": 0.5}})", "input", "albdo"},
        {"spectrum.json", R"({"name": "sp", "medium": {"albedo": 0.5}, "spectrum": "rgbb"})", "input",
         "spectrum"},
        // Valid input that exceeds what the Mie series supports: a LimitError from the computation.
        {"limit.json",
         R"({"name": "huge", "binder": {"material": "pmma"}, "accuracy": "draft", "spectrum": "rgb",
             "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.1,
                           "size": {"distribution": "monodisperse", "radius_um": 100000}}]})",
         "limit", "size parameter"},
    };
    // 40 good specs: the same material (one computation, then "up to date" skips), so the burst
    // stays quick while every file still goes through the whole job path.
    std::vector<std::string> good;
    for (int i = 0; i < 40; ++i) good.push_back(cat("good-", i < 10 ? "0" : "", i, ".json"));
    std::vector<std::string> order;
    for (std::size_t i = 0; i < good.size(); ++i) {
        order.push_back(good[i]);
        if (i % 4 == 1 && i / 4 < bad.size()) order.push_back(bad[i / 4].file);
    }
    ASSERT_EQ(order.size(), 50u);

    Brdfd d({"--spool", spool.string(), "--workers", "2", "--poll", "0.05"}, "", tmp / "log");
    ASSERT_TRUE(wait_until([&] { return status_of(spool)["state"] == "running"; }, 20)) << d.log();
    for (const std::string& file : order) {
        std::string content = tiny_spec("burst");
        for (const Bad& b : bad)
            if (b.file == file) content = b.content;
        submit(spool, file, content);
    }
    ASSERT_TRUE(wait_until(
        [&] { return list_files(spool / "done").size() + list_files(spool / "failed").size() == 60; }, 120))
        << d.log();
    std::vector<std::string> expect_done = good, expect_failed;
    std::sort(expect_done.begin(), expect_done.end());
    for (const Bad& b : bad) {
        expect_failed.push_back(b.file);
        expect_failed.push_back(b.file.substr(0, b.file.size() - 5) + ".error.json");
    }
    std::sort(expect_failed.begin(), expect_failed.end());
    EXPECT_EQ(list_files(spool / "done"), expect_done);
    EXPECT_EQ(list_files(spool / "failed"), expect_failed);
    for (const Bad& b : bad) {
        const auto record = nlohmann::json::parse(
            read_file(spool / "failed" / (b.file.substr(0, b.file.size() - 5) + ".error.json")));
        EXPECT_EQ(record["spec"], b.file);
        EXPECT_EQ(record["kind"], b.kind) << record.dump();
        EXPECT_NE(record["error"].get<std::string>().find(b.says), std::string::npos) << record.dump();
    }
    // Still serving.
    submit(spool, "after.json", tiny_spec("burst"));
    EXPECT_TRUE(wait_until([&] { return fs::exists(spool / "done" / "after.json"); }, 30)) << d.log();
    EXPECT_TRUE(wait_until([&] { return status_of(spool)["done"] == 41; }, 5));
    EXPECT_EQ(status_of(spool)["failed"], 10);
    d.signal(SIGTERM);
    EXPECT_EQ(d.wait(30), 0) << d.log();
    EXPECT_EQ(leftovers(spool), std::vector<std::string>{});
}

// --- results that cannot be written ---------------------------------------------------------------

// results/ replaced by a file while the daemon serves: the job fails with an I/O error naming the
// folder, is filed under failed/ (not requeued: it would only fail again), and succeeds once the
// folder is back and the spec is moved back into incoming/.
TEST(BrdfdService, UnwritableResultsFailTheJobWithAClearErrorAndLoseNothing) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    Brdfd d({"--spool", spool.string(), "--poll", "0.05"}, "", tmp / "log");
    ASSERT_TRUE(wait_until([&] { return status_of(spool)["state"] == "running"; }, 20)) << d.log();
    fs::remove_all(spool / "results");
    write_file(spool / "results", "not a folder");
    submit(spool, "k.json", tiny_spec("k"));
    ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "failed" / "k.json"); }, 60)) << d.log();
    const auto record = nlohmann::json::parse(read_file(spool / "failed" / "k.error.json"));
    EXPECT_EQ(record["kind"], "io") << record.dump();
    EXPECT_NE(record["error"].get<std::string>().find("results"), std::string::npos) << record.dump();
    EXPECT_EQ(places(spool, "k.json"), 1);

    fs::remove(spool / "results");
    fs::create_directory(spool / "results");
    fs::rename(spool / "failed" / "k.json", spool / "incoming" / "k.json"); // resubmit
    ASSERT_TRUE(wait_until([&] { return fs::exists(spool / "done" / "k.json"); }, 60)) << d.log();
    EXPECT_EQ(fs::file_size(spool / "results" / "k.binary"), merl_size);
    d.signal(SIGTERM);
    EXPECT_EQ(d.wait(30), 0) << d.log();
    EXPECT_EQ(leftovers(spool), std::vector<std::string>{});
}

// chmod 555 results/: the table writer cannot create its temporary. Root ignores the mode bits (CI
// runs as root): then there is nothing to test and the test says so.
TEST(BrdfdService, ReadOnlyResultsFolderFailsTheJobWithAnIoError) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    fs::create_directories(spool / "results");
    fs::permissions(spool / "results", fs::perms(0555));
    const int probe = ::open((spool / "results" / "probe").c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
    if (probe >= 0) {
        ::close(probe);
        fs::permissions(spool / "results", fs::perms(0755));
        GTEST_SKIP() << "chmod 555 does not stop this user's writes (root or CAP_DAC_OVERRIDE); "
                        "UnwritableResultsFailTheJobWithAClearErrorAndLoseNothing covers the failure";
    }
    submit(spool, "k.json", tiny_spec("k"));
    Brdfd d({"--spool", spool.string(), "--once"}, "", tmp / "log");
    EXPECT_EQ(d.wait(120), 1) << d.log();
    fs::permissions(spool / "results", fs::perms(0755));
    const auto record = nlohmann::json::parse(read_file(spool / "failed" / "k.error.json"));
    EXPECT_EQ(record["kind"], "io") << record.dump();
    EXPECT_NE(record["error"].get<std::string>().find("results"), std::string::npos) << record.dump();
    EXPECT_EQ(places(spool, "k.json"), 1);
}

// --- identical specs ---------------------------------------------------------------------------------

TEST(BrdfdService, IdenticalSpecIsNotRecomputed) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    const std::string spec = tiny_spec("k");
    submit(spool, "k.json", spec);
    {
        Brdfd d({"--spool", spool.string(), "--once"}, "", tmp / "log1");
        ASSERT_EQ(d.wait(120), 0) << d.log();
    }
    std::map<std::string, fs::file_time_type> mtimes;
    for (const char* f : {"k.binary", "k.exr", "k.report.json"})
        mtimes[f] = fs::last_write_time(spool / "results" / f);
    std::this_thread::sleep_for(std::chrono::milliseconds(20)); // a rewrite would show in the mtime

    // The same spec again, and the same content under another file name: both up to date.
    submit(spool, "k.json", spec);
    submit(spool, "k-again.json", spec);
    Brdfd d({"--spool", spool.string(), "--once"}, "", tmp / "log2");
    EXPECT_EQ(d.wait(60), 0) << d.log();
    EXPECT_EQ(list_files(spool / "done"), (std::vector<std::string>{"k-again.json", "k.json"}));
    for (const char* job : {"k.json", "k-again.json"}) {
        const double seconds = job_seconds(d.log(), job);
        EXPECT_GE(seconds, 0.0) << d.log();
        EXPECT_LT(seconds, 1.0) << job << "\n" << d.log();
    }
    EXPECT_NE(d.log().find("up to date"), std::string::npos) << d.log();
    for (const auto& [f, t] : mtimes) EXPECT_EQ(fs::last_write_time(spool / "results" / f), t) << f;
    EXPECT_EQ(all_files(spool / "results"), (std::vector<std::string>{"k.binary", "k.exr", "k.report.json"}));
}

// --- no usable OpenCL; two specs of one material name ----------------------------------------------

// PoCL cannot write its kernel cache (POCL_CACHE_DIR points below a file): OpenCL has no device.
// The daemon computes on the CPU and says so once in its log, naming the cause, and in every
// report. A second spec defining an existing material with other content is refused, naming the
// spec whose results are there.
TEST(BrdfdService, WithoutOpenClJobsRunOnTheCpuAndAnotherSpecCannotTakeAName) {
    TempDir tmp;
    const fs::path spool = tmp / "spool";
    submit(spool, "a.json", tiny_spec("a"), 30);
    submit(spool, "b.json", tiny_spec("b"), 20);
    submit(spool, "c.json", tiny_spec("a", 0.5), 10); // material "a" again, other content
    Brdfd d({"--spool", spool.string(), "--once"}, "", tmp / "log",
            {"POCL_CACHE_DIR=/dev/null/pocl"});
    EXPECT_EQ(d.wait(180), 1) << d.log();
    const std::string log = d.log();
    std::size_t warnings = 0;
    for (std::size_t at = 0; (at = log.find("OpenCL unavailable", at)) != std::string::npos; ++at) ++warnings;
    EXPECT_EQ(warnings, 1u) << log;
    if (log.find("platform found but it has no device") != std::string::npos) { // PoCL is the platform
        EXPECT_NE(log.find("PoCL could not write its cache folder /dev/null/pocl"), std::string::npos) << log;
    }
    for (const char* name : {"a", "b"}) {
        const auto report = nlohmann::json::parse(read_file(spool / "results" / cat(name, ".report.json")));
        EXPECT_EQ(report["device"], "cpu");
        const std::string warnings_text = report["warnings"].dump();
        EXPECT_NE(warnings_text.find("OpenCL unavailable"), std::string::npos) << warnings_text;
        EXPECT_EQ(report["job"], cat(name, ".json"));
    }
    EXPECT_EQ(list_files(spool / "done"), (std::vector<std::string>{"a.json", "b.json"}));
    const auto record = nlohmann::json::parse(read_file(spool / "failed" / "c.error.json"));
    EXPECT_EQ(record["kind"], "input");
    const std::string error = record["error"];
    EXPECT_NE(error.find("material 'a'"), std::string::npos) << error;
    EXPECT_NE(error.find("from job a.json"), std::string::npos) << error;
    EXPECT_NE(error.find((spool / "results" / "a.report.json").string()), std::string::npos) << error;
    EXPECT_EQ(nlohmann::json::parse(read_file(spool / "results" / "a.report.json"))["spec"]["medium"]["albedo"], 0.9);
}

} // namespace
} // namespace brdf::test
