// The spool protocol on its own: layout, which files are jobs and in what order, exclusive claims,
// the error record of a failed job, liveness of owners through their flock'd lease.

#include <brdf/core/error.h>
#include <brdf/service/spool.h>

#include "spool_fixture.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <sys/wait.h>
#include <unistd.h>

namespace brdf::test {
namespace {

namespace fs = std::filesystem;
using service::DaemonLease;
using service::Spool;

TEST(Spool, CreatesLayout) {
    TempDir tmp;
    const Spool spool(tmp / "spool");
    for (const char* dir : {"incoming", "active", "results", "done", "failed", "daemons"})
        EXPECT_TRUE(fs::is_directory(tmp / "spool" / dir)) << dir;
}

TEST(Spool, UnusableRootIsIoError) {
    TempDir tmp;
    write_file(tmp / "file", "x");
    try {
        Spool spool(tmp / "file" / "spool");
        FAIL() << "expected IoError";
    } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::Io);
        EXPECT_NE(std::string(e.what()).find("file"), std::string::npos) << e.what();
    }
}

TEST(Spool, JobNames) {
    EXPECT_TRUE(Spool::is_job_name("paint.json"));
    EXPECT_FALSE(Spool::is_job_name(".paint.json"));
    EXPECT_FALSE(Spool::is_job_name("paint.json.tmp"));
    EXPECT_FALSE(Spool::is_job_name("paint.json.owner"));
    EXPECT_FALSE(Spool::is_job_name("paint.txt"));
    EXPECT_FALSE(Spool::is_job_name(".json"));
    EXPECT_EQ(Spool::error_name("paint.json"), "paint.error.json");
}

TEST(Spool, QueuedSkipsHiddenTemporariesAndFoldersOldestFirst) {
    TempDir tmp;
    const Spool spool(tmp / "spool");
    submit(spool.root(), "b.json", "{}", 100);
    submit(spool.root(), "a.json", "{}", 100); // same age as b: by name
    submit(spool.root(), "new.json", "{}", 0);
    submit(spool.root(), "old.json", "{}", 1000);
    write_file(spool.incoming() / ".hidden.json", "{}");
    write_file(spool.incoming() / "partial.json.tmp", "{");
    write_file(spool.incoming() / "notes.txt", "x");
    fs::create_directory(spool.incoming() / "folder.json");
    // Same mtime for a and b exactly, so the name decides.
    fs::last_write_time(spool.incoming() / "a.json", fs::last_write_time(spool.incoming() / "b.json"));
    EXPECT_EQ(spool.queued(), (std::vector<std::string>{"old.json", "a.json", "b.json", "new.json"}));
}

TEST(Spool, ClaimIsExclusiveAndNeverReplacesAnActiveJob) {
    TempDir tmp;
    Spool spool(tmp / "spool");
    const DaemonLease a(spool), b(spool);
    EXPECT_NE(a.id(), b.id());
    submit(spool.root(), "job.json", "first");
    EXPECT_TRUE(spool.claim("job.json", a));
    EXPECT_FALSE(spool.claim("job.json", b)); // gone from incoming: not an error
    EXPECT_TRUE(fs::exists(spool.active() / "job.json.owner"));
    const auto owner = nlohmann::json::parse(read_file(spool.active() / "job.json.owner"));
    EXPECT_EQ(owner["daemon"], a.id());
    EXPECT_EQ(owner["pid"], ::getpid());

    // A second job of the same name waits until the first leaves active/.
    submit(spool.root(), "job.json", "second");
    EXPECT_FALSE(spool.claim("job.json", b));
    EXPECT_EQ(read_file(spool.active() / "job.json"), "first");
    spool.finish("job.json");
    EXPECT_FALSE(fs::exists(spool.active() / "job.json.owner"));
    EXPECT_EQ(read_file(spool.done() / "job.json"), "first");
    EXPECT_TRUE(spool.claim("job.json", b));
    EXPECT_EQ(read_file(spool.active() / "job.json"), "second");
}

TEST(Spool, FailWritesErrorRecordBesideSpec) {
    TempDir tmp;
    Spool spool(tmp / "spool");
    const DaemonLease lease(spool);
    submit(spool.root(), "bad.json", "{");
    ASSERT_TRUE(spool.claim("bad.json", lease));
    spool.fail("bad.json", "input", "bad.json: not JSON", 1.5);
    EXPECT_EQ(list_files(spool.active()), std::vector<std::string>{});
    EXPECT_EQ(list_files(spool.failed()), (std::vector<std::string>{"bad.error.json", "bad.json"}));
    const auto record = nlohmann::json::parse(read_file(spool.failed() / "bad.error.json"));
    EXPECT_EQ(record["spec"], "bad.json");
    EXPECT_EQ(record["kind"], "input");
    EXPECT_EQ(record["error"], "bad.json: not JSON");
    EXPECT_EQ(record["seconds"], 1.5);
    EXPECT_EQ(record["time"].get<std::string>().size(), std::string("2024-05-01T12:34:56Z").size());
}

TEST(Spool, LeaseTellsLiveFromDead) {
    TempDir tmp;
    Spool spool(tmp / "spool");
    std::string id;
    {
        const DaemonLease lease(spool);
        id = lease.id();
        EXPECT_TRUE(spool.daemon_alive(id));
        EXPECT_TRUE(fs::exists(spool.daemons() / (id + ".lock")));
    }
    EXPECT_FALSE(spool.daemon_alive(id));
    EXPECT_FALSE(spool.daemon_alive("never-existed"));
    EXPECT_FALSE(spool.daemon_alive("../escape"));
}

// A lock file left behind by a process that died without cleaning up (SIGKILL) reads as dead.
TEST(Spool, LeaseOfKilledProcessIsDead) {
    TempDir tmp;
    Spool spool(tmp / "spool");
    int ready[2];
    ASSERT_EQ(pipe(ready), 0);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        // Only async-signal-safe-enough work: take a lease, say its name, wait to be killed.
        close(ready[0]);
        const DaemonLease lease(spool);
        const std::string id = lease.id() + "\n";
        [[maybe_unused]] ssize_t k = write(ready[1], id.data(), id.size());
        pause();
        _exit(0);
    }
    close(ready[1]);
    std::string id;
    char c;
    while (read(ready[0], &c, 1) == 1 && c != '\n') id += c;
    close(ready[0]);
    ASSERT_FALSE(id.empty());
    EXPECT_TRUE(spool.daemon_alive(id));
    kill(child, SIGKILL);
    waitpid(child, nullptr, 0);
    EXPECT_TRUE(fs::exists(spool.daemons() / (id + ".lock"))); // left behind
    EXPECT_FALSE(spool.daemon_alive(id));
    spool.requeue_orphans(); // collects it
    EXPECT_FALSE(fs::exists(spool.daemons() / (id + ".lock")));
}

TEST(Spool, RequeueDoesNotOverwriteANewerSubmission) {
    TempDir tmp;
    Spool spool(tmp / "spool");
    {
        const DaemonLease gone(spool);
        submit(spool.root(), "job.json", "old");
        ASSERT_TRUE(spool.claim("job.json", gone));
    }
    submit(spool.root(), "job.json", "new");
    EXPECT_EQ(spool.requeue_orphans(), std::vector<std::string>{});
    EXPECT_EQ(read_file(spool.incoming() / "job.json"), "new");
    EXPECT_EQ(read_file(spool.failed() / "job.json"), "old");
    const auto record = nlohmann::json::parse(read_file(spool.failed() / "job.error.json"));
    EXPECT_EQ(record["kind"], "interrupted");
}


// A daemon killed inside fail() leaves failed/NAME.error.json without failed/NAME; when the requeued
// job then succeeds, finish() drops that record. A record beside a failed spec is kept.
TEST(Spool, FinishDropsAnErrorRecordLeftWithoutItsSpec) {
    TempDir tmp;
    Spool spool(tmp / "spool");
    const DaemonLease lease(spool);
    write_file(spool.failed() / "x.error.json", "{}");
    submit(spool.root(), "x.json");
    ASSERT_TRUE(spool.claim("x.json", lease));
    spool.finish("x.json");
    EXPECT_FALSE(fs::exists(spool.failed() / "x.error.json"));
    write_file(spool.failed() / "y.json", "old");
    write_file(spool.failed() / "y.error.json", "{}");
    submit(spool.root(), "y.json");
    ASSERT_TRUE(spool.claim("y.json", lease));
    spool.finish("y.json");
    EXPECT_TRUE(fs::exists(spool.failed() / "y.error.json"));
    EXPECT_TRUE(fs::exists(spool.done() / "y.json"));
}

TEST(Spool, TemporaryNames) {
    for (const char* name : {".k.binary.tmp.123.0.456789", ".k.report.json.123.4.tmp", ".k.report.json.123.tmp",
                             ".status.json.9.1.tmp", ".host-1-abc.lock.tmp", ".x.tmp"})
        EXPECT_TRUE(Spool::is_temporary_name(name)) << name;
    for (const char* name : {"k.binary", ".spool.lock", ".keep", "x.tmp", ".tmpfile", ".k.tmpx.1", ""})
        EXPECT_FALSE(Spool::is_temporary_name(name)) << name;
}

// The pid of a process that has ended (and been reaped): what a SIGKILLed writer's pid looks like.
pid_t dead_pid() {
    const pid_t child = fork();
    if (child == 0) _exit(0);
    waitpid(child, nullptr, 0);
    return child;
}

TEST(Spool, RemovesTemporariesOfDeadWritersOnly) {
    TempDir tmp;
    Spool spool(tmp / "spool");
    const std::string dead = std::to_string(dead_pid());
    const std::string live = std::to_string(getppid()); // the test runner's parent: alive, not us
    const auto now = fs::file_time_type::clock::now();
    const auto plant = [&](const fs::path& path, fs::file_time_type mtime) {
        write_file(path, "partial");
        fs::last_write_time(path, mtime);
        return path;
    };
    const auto old = now - std::chrono::seconds(10);
    // Leftovers of a killed daemon, in each writer's naming.
    const std::vector<fs::path> stale = {
        plant(spool.results() / (".k.binary.tmp." + dead + ".0.123456"), old),
        plant(spool.results() / (".k.report.json." + dead + ".3.tmp"), old),
        plant(spool.results() / (".k.report.json." + dead + ".tmp"), old),
        plant(spool.root() / (".status.json." + dead + ".7.tmp"), old),
        plant(spool.active() / (".x.json.owner." + dead + ".1.tmp"), old),
        plant(spool.failed() / (".x.error.json." + dead + ".2.tmp"), old),
        plant(spool.daemons() / (".host-" + dead + "-0badf00d.lock.tmp"), old)};
    // Never touched: a live writer's temporary, a hidden file that is not a temporary, a table, a
    // user's staging file in incoming/, and (while young) a dead writer's file newer than the start.
    const std::vector<fs::path> kept = {
        plant(spool.results() / (".k.exr.tmp." + live + ".0.1"), old),
        plant(spool.results() / ".keep", old),
        plant(spool.results() / "k.binary", old),
        plant(spool.incoming() / (".user.json." + dead + ".tmp"), old)};
    const fs::path young = plant(spool.results() / (".y.binary.tmp." + dead + ".0.1"), now);
    const auto started = now - std::chrono::seconds(5);

    const DaemonLease self(spool);
    {
        // Another daemon is alive: its writers could be anywhere (another host), so only files older
        // than stale_after go; none is.
        const DaemonLease other(spool);
        EXPECT_EQ(spool.remove_stale_temporaries(started, self), std::vector<fs::path>{});
    }
    std::vector<fs::path> removed = spool.remove_stale_temporaries(started, self);
    std::sort(removed.begin(), removed.end());
    std::vector<fs::path> expected = stale;
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(removed, expected);
    for (const fs::path& p : kept) EXPECT_TRUE(fs::exists(p)) << p;
    EXPECT_TRUE(fs::exists(young));
    EXPECT_TRUE(fs::exists(spool.root() / ".spool.lock"));
    {
        // Past stale_after a dead writer's temporary goes even while other daemons live.
        const DaemonLease other(spool);
        EXPECT_EQ(spool.remove_stale_temporaries(started, self, std::chrono::seconds(0)),
                  std::vector<fs::path>{young});
    }
    for (const fs::path& p : kept) EXPECT_TRUE(fs::exists(p)) << p;
}

} // namespace
} // namespace brdf::test
