// The spool protocol on its own: layout, which files are jobs and in what order, exclusive claims,
// the error record of a failed job, liveness of owners through their flock'd lease.

#include <brdf/core/error.h>
#include <brdf/service/spool.h>

#include "spool_fixture.h"

#include <nlohmann/json.hpp>

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

} // namespace
} // namespace brdf::test
