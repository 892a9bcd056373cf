#pragma once
// brdfd's serving loop: N workers take specs from a spool (see spool.h), run each through a JobRunner
// and file it under done/ or failed/. Protocol, signals and status.json: docs/daemon.md.

#include <filesystem>
#include <functional>
#include <stop_token>

namespace brdf::service {

/// Runs one job: reads `spec_file`, writes its outputs into `results_dir` (complete files only).
/// Throws brdf::Error (or any std::exception) on failure; the daemon catches it and fails the job.
/// Called concurrently from several workers.
using JobRunner = std::function<void(const std::filesystem::path& spec_file,
                                     const std::filesystem::path& results_dir)>;

struct DaemonOptions {
    std::filesystem::path spool;   ///< spool folder; created with its subfolders when missing
    int workers = 1;               ///< concurrent jobs, >= 1
    bool once = false;             ///< drain the spool and return instead of serving forever
    double poll_seconds = 0.5;     ///< how often idle workers look into incoming/, > 0
    /// A spec written in place into incoming/ (not renamed in, as the protocol asks) is taken only
    /// once it has not changed for this long, in seconds, >= 0: a writer that pauses mid-write must
    /// not have its half a spec claimed. With inotify a file still open for writing is never taken
    /// and one renamed in is taken at once (docs/daemon.md, "Noticing new specs").
    double settle_seconds = 1.0;
    /// Watch incoming/ with inotify: a file renamed in (IN_MOVED_TO) wakes idle workers at once;
    /// writes in place (IN_CREATE, IN_MODIFY ... IN_CLOSE_WRITE) are tracked so that an open file
    /// is not taken. Polling every `poll_seconds` stays on as the fallback (inotify unavailable, or
    /// a network file system where it does not see other hosts' writes).
    bool watch_incoming = true;
    /// Turn SIGTERM/SIGINT into a graceful stop while run_daemon runs (previous handlers are restored
    /// afterwards). Only one run_daemon per process may do this at a time; daemons embedded in tests
    /// turn it off and use `stop` instead.
    bool handle_signals = true;
    /// Requesting a stop has the effect of SIGTERM: intake stops, running jobs finish.
    std::stop_token stop = {};
};

/// Serves the spool until stopped (SIGTERM, SIGINT or `options.stop`) or, with `once`, until
/// incoming/ is empty and no job of this daemon is running. Requeues orphaned jobs at start (and
/// every 30 s). Returns the exit status: 0, or with `once` 1 when any job failed. Throws IoError when
/// the spool cannot be set up and InputError for invalid options.
int run_daemon(const DaemonOptions& options, const JobRunner& runner);

} // namespace brdf::service
