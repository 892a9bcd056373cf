#pragma once
// The brdfd spool folder: DIR/{incoming,active,results,done,failed}/ plus the ownership records that
// keep two daemons apart. See docs/daemon.md for the protocol and why it is built on flock(2).
//
//   incoming/NAME.json   dropped in by users (written elsewhere, then renamed in)
//   active/NAME.json     claimed by a daemon: an atomic rename out of incoming/ is the claim
//   active/NAME.json.owner   {"daemon": ID, "pid", "host", "claimed"}: which daemon runs it
//   daemons/ID.lock      held with flock(LOCK_EX) by daemon ID for as long as it lives
//   done/NAME.json       finished; failed/NAME.json + failed/NAME.error.json when the job threw
//   results/             what the jobs write
//   status.json          the daemon's state (written by the daemon, not by this class)
//   .spool.lock          flock: claims take it shared, the orphan scan exclusive

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace brdf::service {

class DaemonLease;

class Spool {
public:
    /// Opens the spool at `root`, creating it and its folders when missing; throws IoError when a
    /// folder cannot be created. root() is absolute (a relative `root` is taken from the current
    /// folder now), so every path the spool and the daemon report names the real place.
    explicit Spool(std::filesystem::path root);

    const std::filesystem::path& root() const { return m_root; }
    std::filesystem::path incoming() const { return m_root / "incoming"; }
    std::filesystem::path active() const { return m_root / "active"; }
    std::filesystem::path results() const { return m_root / "results"; }
    std::filesystem::path done() const { return m_root / "done"; }
    std::filesystem::path failed() const { return m_root / "failed"; }
    std::filesystem::path daemons() const { return m_root / "daemons"; }
    std::filesystem::path status_file() const { return m_root / "status.json"; }

    /// A job is a file name ending in ".json" that is not hidden (".*"); temporaries ("*.tmp") and
    /// ownership records never qualify.
    static bool is_job_name(std::string_view name);
    /// The error record beside a failed spec: "paint.json" -> "paint.error.json".
    static std::string error_name(std::string_view name);

    /// A job waiting in incoming/ as last seen: what tells a finished spec from one being written.
    struct Queued {
        std::string name;
        std::filesystem::file_time_type mtime;
        std::uintmax_t size = 0;
    };
    /// Jobs waiting in incoming/ (regular files only), oldest first: by modification time, then name.
    std::vector<Queued> queued_jobs() const;
    /// The names of queued_jobs().
    std::vector<std::string> queued() const;
    /// Jobs in active/, by name.
    std::vector<std::string> active_jobs() const;

    /// Claims incoming/NAME for the lease's daemon: renames it into active/ (never replacing a job of
    /// the same name that is running there) and records the owner. Returns false, without error, when
    /// the job is gone (another daemon won) or a same-named job is active.
    bool claim(const std::string& name, const DaemonLease& owner);
    /// active/NAME -> done/NAME; drops the owner record, and failed/NAME.error.json when no
    /// failed/NAME is beside it (the leftover of a daemon killed while failing this job earlier).
    void finish(const std::string& name);
    /// Writes failed/NAME.error.json {"spec", "error", "kind", "time", "seconds"}, then moves
    /// active/NAME -> failed/NAME and drops the owner record.
    void fail(const std::string& name, const std::string& kind, const std::string& message,
              double seconds);
    /// active/NAME -> incoming/NAME (keeping its modification time, so it is taken first again);
    /// drops the owner record. Returns false when a newer incoming/NAME exists: the stale copy then
    /// fails as superseded instead of overwriting the user's new file.
    bool requeue(const std::string& name);

    /// Requeues every active job whose owner daemon is gone (or that has no owner record), removes
    /// owner records and daemon locks of dead daemons. Safe against live daemons: runs under the
    /// exclusive spool lock, so no claim is half done while it looks. Returns the requeued names.
    std::vector<std::string> requeue_orphans();

    /// Whether daemon ID holds its lock, i.e. its process is alive.
    bool daemon_alive(const std::string& id) const;

    /// Whether a file name is a temporary of one of the spool's writers: hidden, with a "tmp"
    /// component (".NAME.tmp.PID.N.STAMP" of core's AtomicFile, which writes every result, record
    /// and status file; ".ID.lock.tmp" of a starting daemon; ".NAME.PID.tmp" and ".NAME.PID.N.tmp"
    /// of the writers of earlier versions).
    static bool is_temporary_name(std::string_view name);
    /// Removes temporaries that a killed writer left in the spool (results/, active/, done/,
    /// failed/, daemons/ and the root; never incoming/, where users stage their own files). A file
    /// is removed only when all of these hold, so a live writer's file is never touched:
    ///  - its name is a temporary (is_temporary_name) and it is a regular file;
    ///  - it was last modified before `started` (this daemon's start), and no daemon other than
    ///    `self` holds a lease on the spool: every writer older than `started` belonged to a
    ///    process that is gone; or else it is older than `stale_after` (no writer keeps a
    ///    temporary open that long: tables are computed first and written in seconds);
    ///  - no number in its name is the pid of a live process on this host (other than ours: our
    ///    own temporaries are younger than `started`), and it is not flock-ed by anyone.
    /// Runs under the exclusive spool lock. Returns the removed paths.
    std::vector<std::filesystem::path> remove_stale_temporaries(
        std::filesystem::file_time_type started, const DaemonLease& self,
        std::chrono::seconds stale_after = std::chrono::hours(24));

private:
    std::filesystem::path owner_file(const std::string& name) const;

    std::filesystem::path m_root;
};

/// A daemon's registration on a spool: a unique ID ("host-pid-random") and daemons/ID.lock, held with
/// flock for the lease's lifetime. The kernel drops the lock when the process dies in any way
/// (SIGKILL, OOM, power loss), which is what tells other daemons that its jobs are orphans.
class DaemonLease {
public:
    explicit DaemonLease(const Spool& spool);
    ~DaemonLease();
    DaemonLease(const DaemonLease&) = delete;
    DaemonLease& operator=(const DaemonLease&) = delete;

    const std::string& id() const { return m_id; }

private:
    std::filesystem::path m_path;
    std::string m_id;
    int m_fd = -1;
};

/// Now as ISO 8601 UTC, e.g. "2024-05-01T12:34:56Z".
std::string iso8601_now();

} // namespace brdf::service
