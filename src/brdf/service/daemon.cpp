#include <brdf/service/daemon.h>

#include <brdf/core/atomic_file.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/progress.h>
#include <brdf/service/spool.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstring>
#include <cstdint>
#include <fcntl.h>
#include <map>
#include <mutex>
#include <optional>
#include <poll.h>
#include <sys/inotify.h>
#include <stdexcept>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

namespace brdf::service {
namespace {

using Clock = std::chrono::steady_clock;

/// Jobs of daemons that died while this one keeps running are picked up this often.
constexpr std::chrono::seconds orphan_scan_interval{30};

constexpr char wake_stop = 's';     // options.stop was requested
constexpr char wake_finished = 'x'; // the last worker has ended
constexpr char wake_incoming = 'i'; // inotify: something arrived in incoming/

/// A pipe the control thread blocks on; signal handlers, the stop callback and the last worker write
/// one byte each. The write end is non-blocking so a signal handler can never hang on a full pipe.
class WakePipe {
public:
    WakePipe() {
        if (::pipe2(m_fd, O_CLOEXEC) != 0)
            throw IoError(cat("brdfd: cannot create a pipe: ", std::strerror(errno)));
        ::fcntl(m_fd[1], F_SETFL, ::fcntl(m_fd[1], F_GETFL) | O_NONBLOCK);
    }
    ~WakePipe() {
        ::close(m_fd[0]);
        ::close(m_fd[1]);
    }
    WakePipe(const WakePipe&) = delete;
    WakePipe& operator=(const WakePipe&) = delete;

    int write_fd() const { return m_fd[1]; }
    void notify(char c) const { [[maybe_unused]] const ssize_t k = ::write(m_fd[1], &c, 1); }
    /// The next byte written into the pipe, or wake_incoming when `watch_fd` (an inotify descriptor,
    /// or -1) becomes readable first; the caller drains `watch_fd`.
    char wait(int watch_fd = -1) const {
        // poll with a timeout rather than a blocking read: ThreadSanitizer delivers a signal to a
        // thread only when it leaves a call, and a read that never returns would never see it.
        for (;;) {
            pollfd fds[2] = {{m_fd[0], POLLIN, 0}, {watch_fd, POLLIN, 0}};
            const int n = ::poll(fds, watch_fd >= 0 ? 2 : 1, 250);
            if (n < 0 && errno != EINTR)
                throw IoError(cat("brdfd: cannot wait on the wake pipe: ", std::strerror(errno)));
            if (n <= 0) continue;
            if (fds[0].revents & POLLIN) {
                char c = 0;
                if (::read(m_fd[0], &c, 1) == 1) return c;
            }
            if (watch_fd >= 0 && (fds[1].revents & (POLLIN | POLLERR | POLLHUP))) return wake_incoming;
        }
    }

private:
    int m_fd[2] = {-1, -1};
};

// The self-pipe trick: the handler only writes the signal number into the daemon's wake pipe.
std::atomic<int> g_signal_fd{-1};

extern "C" void on_stop_signal(int signo) {
    const int saved = errno;
    const int fd = g_signal_fd.load();
    if (fd >= 0) {
        const char c = static_cast<char>(signo);
        [[maybe_unused]] const ssize_t k = ::write(fd, &c, 1);
    }
    errno = saved;
}

/// Routes SIGTERM and SIGINT into a wake pipe while it lives; restores the previous handlers after.
class SignalRoute {
public:
    explicit SignalRoute(int fd) {
        int expected = -1;
        if (!g_signal_fd.compare_exchange_strong(expected, fd))
            throw std::logic_error("run_daemon: another daemon in this process already handles signals");
        struct sigaction action{};
        action.sa_handler = on_stop_signal;
        sigemptyset(&action.sa_mask);
        action.sa_flags = SA_RESTART;
        ::sigaction(SIGTERM, &action, &m_old_term);
        ::sigaction(SIGINT, &action, &m_old_int);
    }
    ~SignalRoute() {
        ::sigaction(SIGTERM, &m_old_term, nullptr);
        ::sigaction(SIGINT, &m_old_int, nullptr);
        g_signal_fd = -1;
    }
    SignalRoute(const SignalRoute&) = delete;
    SignalRoute& operator=(const SignalRoute&) = delete;

private:
    struct sigaction m_old_term{};
    struct sigaction m_old_int{};
};

/// Whether some process has `file` open for writing, asked the kernel's way: a read lease
/// (fcntl F_SETLEASE, F_RDLCK) is granted only when nobody does. nullopt when the kernel cannot
/// say: leases need a local file system and a file we own (or CAP_LEASE).
std::optional<bool> open_for_writing(const std::filesystem::path& file) {
    const int fd = ::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0) return std::nullopt;
    std::optional<bool> answer;
    if (::fcntl(fd, F_SETLEASE, F_RDLCK) == 0) {
        ::fcntl(fd, F_SETLEASE, F_UNLCK);
        answer = false;
    } else if (errno == EAGAIN) {
        answer = true;
    }
    ::close(fd);
    return answer;
}

/// Which specs in incoming/ may be claimed. A spec renamed in (the protocol) is complete the moment
/// its name appears. One written in place is complete only when its writer is done, which nothing
/// says for certain; so, by what is known of it:
///  - renamed in (inotify IN_MOVED_TO, which is also how requeued jobs come back): at once;
///  - being written (IN_MODIFY seen, no IN_CLOSE_WRITE since): never, however long the writer
///    pauses; the kernel closes the file when the writer exits, whatever way it dies;
///  - closed after writing (IN_CLOSE_WRITE), just created (IN_CREATE: an empty file, or a link),
///    or never seen by inotify (there before the daemon started, written from another host of a
///    network file system, no inotify): once its size and modification time have stayed the same
///    for the settle time, and a just-created file only once it is not empty.
/// A file that changes is timed again from the change. On top of all this, a file that the kernel
/// says is open for writing by anyone (open_for_writing) is never taken: that covers a writer that
/// pauses for longer than the settle time where inotify is off, as long as leases work (a local
/// file system, specs owned by the daemon's user or a daemon with CAP_LEASE).
/// The owner (Daemon) serialises all calls.
class IncomingTracker {
public:
    enum class Seen { Unknown, Created, Writing, Closed, RenamedIn };

    void saw(const std::string& name, Seen what) {
        Entry& e = m_entries[name];
        // A file being written stays so until it is closed: a create or rename event in between
        // cannot make it complete.
        if (e.seen == Seen::Writing && what == Seen::Created) return;
        e.seen = what;
        e.stable_since.reset();
    }
    void forget(const std::string& name) { m_entries.erase(name); }
    /// inotify's queue overflowed: what was known is lost; every file is judged by stability.
    void lose_track() {
        for (auto& [name, e] : m_entries) {
            e.seen = Seen::Unknown;
            e.stable_since.reset();
        }
    }

    /// Of `queued` (oldest first), the names that may be claimed at `now`, in the same order.
    /// `next` is set to the soonest moment another one may become ready (unchanged when none can).
    std::vector<std::string> ready(const std::filesystem::path& incoming,
                                   const std::vector<Spool::Queued>& queued, Clock::time_point now,
                                   Clock::duration settle, std::optional<Clock::time_point>& next) {
        std::vector<std::string> names;
        std::map<std::string, Entry> kept;
        for (const Spool::Queued& q : queued) {
            Entry e = m_entries.count(q.name) ? m_entries[q.name] : Entry{};
            const bool changed = !e.stable_since || e.size != q.size || e.mtime != q.mtime;
            if (changed) {
                e.size = q.size;
                e.mtime = q.mtime;
                e.stable_since = now;
            }
            const bool settled = now - *e.stable_since >= settle;
            bool take = false;
            switch (e.seen) {
            case Seen::RenamedIn: take = true; break;
            case Seen::Writing: take = false; break;
            case Seen::Created: take = settled && q.size > 0; break;
            case Seen::Closed:
            case Seen::Unknown: take = settled; break;
            }
            if (take && open_for_writing(incoming / q.name).value_or(false)) {
                take = false; // timed again once its writer has closed it
                e.stable_since = now;
            }
            if (take) {
                names.push_back(q.name);
            } else if (e.seen != Seen::Writing && !(e.seen == Seen::Created && settled)) {
                const Clock::time_point at = *e.stable_since + settle;
                if (!next || at < *next) next = at;
            }
            kept[q.name] = e;
        }
        m_entries = std::move(kept); // claimed or removed files are forgotten
        return names;
    }

private:
    struct Entry {
        Seen seen = Seen::Unknown;
        std::uintmax_t size = 0;
        std::filesystem::file_time_type mtime{};
        std::optional<Clock::time_point> stable_since; ///< when size and mtime were last seen to change
    };
    std::map<std::string, Entry> m_entries;
};

/// inotify on incoming/: renames in, creations, writes, closes after writing and removals make the
/// descriptor readable; drain() hands each to the IncomingTracker. Not available (inotify_init1
/// or the watch fails: no inotify, out of watches): fd() is -1 and the daemon relies on polling and
/// the settle time alone. On network file systems the watch succeeds but sees only this host's
/// changes; polling covers the rest.
class IncomingWatch {
public:
    IncomingWatch(const std::filesystem::path& dir, bool enabled) {
        if (!enabled) return;
        m_fd = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
        if (m_fd < 0) {
            log::warn("brdfd: inotify unavailable (", std::strerror(errno), "); polling ", dir.string());
            return;
        }
        constexpr std::uint32_t mask = IN_MOVED_TO | IN_CREATE | IN_MODIFY | IN_CLOSE_WRITE |
                                       IN_DELETE | IN_MOVED_FROM | IN_ONLYDIR;
        if (::inotify_add_watch(m_fd, dir.c_str(), mask) < 0) {
            log::warn("brdfd: cannot watch ", dir.string(), " with inotify (", std::strerror(errno),
                      "); polling it");
            ::close(m_fd);
            m_fd = -1;
        }
    }
    ~IncomingWatch() {
        if (m_fd >= 0) ::close(m_fd);
    }
    IncomingWatch(const IncomingWatch&) = delete;
    IncomingWatch& operator=(const IncomingWatch&) = delete;

    int fd() const { return m_fd; }
    /// Reads every pending event into `tracker`. Stops watching if the descriptor fails; an
    /// overflowed queue only makes the tracker forget what it knew.
    void drain(IncomingTracker& tracker) {
        alignas(inotify_event) char buf[16384];
        for (;;) {
            const ssize_t k = ::read(m_fd, buf, sizeof buf);
            if (k > 0) {
                for (ssize_t at = 0; at + static_cast<ssize_t>(sizeof(inotify_event)) <= k;) {
                    const auto* ev = reinterpret_cast<const inotify_event*>(buf + at);
                    apply(*ev, tracker);
                    at += static_cast<ssize_t>(sizeof(inotify_event) + ev->len);
                }
                continue;
            }
            if (k < 0 && errno == EINTR) continue;
            if (k < 0 && errno != EAGAIN) {
                log::warn("brdfd: inotify read failed (", std::strerror(errno), "); polling only");
                ::close(m_fd);
                m_fd = -1;
                tracker.lose_track();
            }
            return;
        }
    }

private:
    static void apply(const inotify_event& ev, IncomingTracker& tracker) {
        using Seen = IncomingTracker::Seen;
        if (ev.mask & IN_Q_OVERFLOW) {
            log::warn("brdfd: inotify queue overflowed; specs written in place are judged by the "
                      "settle time alone until the queue drains");
            tracker.lose_track();
            return;
        }
        if (ev.len == 0 || (ev.mask & IN_ISDIR)) return;
        const std::string name(ev.name);
        if (ev.mask & (IN_DELETE | IN_MOVED_FROM)) tracker.forget(name);
        if (ev.mask & IN_CREATE) tracker.saw(name, Seen::Created);
        if (ev.mask & IN_MOVED_TO) tracker.saw(name, Seen::RenamedIn);
        if (ev.mask & IN_MODIFY) tracker.saw(name, Seen::Writing);
        if (ev.mask & IN_CLOSE_WRITE) tracker.saw(name, Seen::Closed);
    }

    int m_fd = -1;
};

const char* signal_name(char c) {
    if (c == SIGTERM) return "SIGTERM";
    if (c == SIGINT) return "SIGINT";
    return "stop request";
}

class Daemon {
public:
    Daemon(const DaemonOptions& options, const JobRunner& runner)
        : m_options(options), m_runner(runner), m_spool(options.spool),
          m_start_time(std::filesystem::file_time_type::clock::now()), m_lease(m_spool),
          m_started(iso8601_now()),
          m_poll(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options.poll_seconds))),
          m_settle(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options.settle_seconds))) {}

    int run() {
        for (const std::string& name : m_spool.requeue_orphans())
            log::info("brdfd: requeued ", name, " (left in active/ by a daemon that is gone)");
        remove_stale_temporaries();
        m_last_orphan_scan = Clock::now();
        // Before the workers start, so nothing that arrives after their first look is missed.
        IncomingWatch watch(m_spool.incoming(), m_options.watch_incoming);

        std::optional<SignalRoute> signals;
        if (m_options.handle_signals) signals.emplace(m_wake.write_fd());
        std::stop_callback on_stop(m_options.stop, [this] { m_wake.notify(wake_stop); });

        log::info("brdfd: serving ", m_spool.root().string(), " as ", m_lease.id(), " with ",
                  m_options.workers, " worker(s)", m_options.once ? ", until drained (--once)" : "");
        {
            std::lock_guard lock(m_mutex);
            write_status_locked();
        }
        std::vector<std::thread> workers;
        m_live_workers = m_options.workers;
        try {
            for (int i = 0; i < m_options.workers; ++i) workers.emplace_back([this, i] { worker(i); });
        } catch (...) {
            request_stop(wake_stop);
            for (std::thread& t : workers) t.join();
            throw;
        }

        for (;;) {
            const char c = m_wake.wait(watch.fd());
            if (c == wake_finished) break;
            if (c == wake_incoming) {
                // Under the mutex: a worker is either before its look into incoming/ (and will see
                // the new file) or already waiting on m_cv (and is woken). No wake-up is lost.
                std::lock_guard lock(m_mutex);
                watch.drain(m_incoming);
                m_cv.notify_all();
                continue;
            }
            request_stop(c);
        }
        for (std::thread& t : workers) t.join();

        std::lock_guard lock(m_mutex);
        m_state = "stopped";
        write_status_locked();
        log::info("brdfd: stopped (", m_done, " done, ", m_failed, " failed)");
        return m_options.once && m_failed > 0 ? 1 : 0;
    }

private:
    void request_stop(char why) {
        std::lock_guard lock(m_mutex);
        if (!m_stopping) {
            m_stopping = true;
            m_state = "draining";
            log::info("brdfd: ", signal_name(why), ": taking no new jobs; waiting for ",
                      m_running.size(), " running job(s)");
            write_status_locked();
            m_cv.notify_all();
        } else if (why != wake_stop) {
            log::warn("brdfd: ", signal_name(why), ": already stopping; waiting for ", m_running.size(),
                      " running job(s). SIGKILL aborts them; the next daemon start requeues them");
        }
    }

    void worker(int index) {
        std::unique_lock lock(m_mutex);
        while (!m_stopping && !m_drained) {
            std::optional<std::string> job;
            try {
                scan_orphans_locked();
                job = claim_next_locked();
            } catch (const std::exception& e) {
                log::error("brdfd: ", e.what());
                m_cv.wait_for(lock, m_poll);
                continue;
            }
            if (job) {
                m_running.push_back(*job);
                write_status_locked();
                lock.unlock();
                const bool ok = run_job(*job, index);
                lock.lock();
                m_running.erase(std::find(m_running.begin(), m_running.end(), *job));
                ++(ok ? m_done : m_failed);
                write_status_locked();
                m_cv.notify_all();
                continue;
            }
            if (m_options.once && m_running.empty() && m_spool.queued().empty()) {
                // Nothing queued (not even a spec still being written) and nothing of ours
                // running: drained.
                m_drained = true;
                m_cv.notify_all();
                break;
            }
            // Until the next poll, or sooner when a spec written in place will have settled.
            Clock::duration wait = m_poll;
            if (m_next_settled) wait = std::min(wait, std::max(Clock::duration(std::chrono::milliseconds(1)),
                                                               *m_next_settled - Clock::now()));
            m_cv.wait_for(lock, wait);
            if (m_spool.queued().size() != m_last_queued) write_status_locked();
        }
        if (--m_live_workers == 0) m_wake.notify(wake_finished);
    }

    void scan_orphans_locked() {
        if (Clock::now() - m_last_orphan_scan < orphan_scan_interval) return;
        m_last_orphan_scan = Clock::now();
        for (const std::string& name : m_spool.requeue_orphans())
            log::info("brdfd: requeued ", name, " (left in active/ by a daemon that is gone)");
        remove_stale_temporaries();
    }

    /// Temporaries of writers killed mid-write (a SIGKILLed daemon's table or status file): see
    /// Spool::remove_stale_temporaries for why this never touches a live writer's file.
    void remove_stale_temporaries() {
        try {
            for (const std::filesystem::path& p : m_spool.remove_stale_temporaries(m_start_time, m_lease))
                log::info("brdfd: removed ", p.string(), " (temporary of a writer that is gone)");
        } catch (const std::exception& e) {
            log::warn("brdfd: cleaning stale temporaries: ", e.what());
        }
    }

    /// Claims the oldest job this daemon can get; none when incoming/ is empty or others won them all.
    std::optional<std::string> claim_next_locked() {
        m_next_settled.reset();
        for (const std::string& name :
             m_incoming.ready(m_spool.incoming(), m_spool.queued_jobs(), Clock::now(), m_settle,
                              m_next_settled))
            if (m_spool.claim(name, m_lease)) return name;
        return std::nullopt;
    }

    /// Runs one job and files it; the one place (with tools' mains) where job errors are caught.
    bool run_job(const std::string& name, int index) {
        log::info("job ", name, ": started (worker ", index, ")");
        const Clock::time_point t0 = Clock::now();
        bool ok = false;
        std::string kind, message;
        try {
            m_runner(m_spool.active() / name, m_spool.results());
            ok = true;
        } catch (const Error& e) {
            kind = to_string(e.kind());
            message = e.what();
        } catch (const std::exception& e) {
            kind = "internal";
            message = e.what();
        } catch (...) {
            kind = "internal";
            message = "unknown exception";
        }
        const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
        // The runner named the spec where it ran (active/NAME); say where it is now.
        const std::string ran_at = (m_spool.active() / name).string();
        const std::string filed_at = (m_spool.failed() / name).string();
        for (std::size_t at = 0; !ok && (at = message.find(ran_at, at)) != std::string::npos;
             at += filed_at.size())
            message.replace(at, ran_at.size(), filed_at);
        try {
            if (ok)
                m_spool.finish(name);
            else
                m_spool.fail(name, kind, message, seconds);
        } catch (const std::exception& e) {
            log::error("job ", name, ": cannot file it under ", ok ? "done/" : "failed/", ": ",
                       e.what());
        }
        if (ok)
            log::info("job ", name, ": done in ", format_duration(seconds));
        else
            log::error("job ", name, ": failed after ", format_duration(seconds), " (", kind, "): ", message);
        return ok;
    }

    void write_status_locked() {
        const std::vector<std::string> queued = m_spool.queued();
        m_last_queued = queued.size();
        const nlohmann::json status = {{"daemon", m_lease.id()},
                                       {"pid", static_cast<long>(::getpid())},
                                       {"spool", m_spool.root().string()},
                                       {"started", m_started},
                                       {"updated", iso8601_now()},
                                       {"state", m_state},
                                       {"workers", m_options.workers},
                                       {"queued", queued.size()},
                                       {"running", m_running},
                                       {"done", m_done},
                                       {"failed", m_failed}};
        try {
            write_file_atomically(m_spool.status_file(), status.dump(2) + "\n");
        } catch (const Error& e) {
            log::warn("brdfd: ", e.what());
        }
    }

    const DaemonOptions& m_options;
    const JobRunner& m_runner;
    Spool m_spool;
    const std::filesystem::file_time_type m_start_time; ///< before the lease: older files predate us
    DaemonLease m_lease;
    const std::string m_started;
    const Clock::duration m_poll;
    const Clock::duration m_settle;
    WakePipe m_wake;

    std::mutex m_mutex; // guards everything below
    std::condition_variable m_cv;
    bool m_stopping = false;
    bool m_drained = false;
    std::string m_state = "running";
    std::vector<std::string> m_running;
    long m_done = 0;
    long m_failed = 0;
    int m_live_workers = 0;
    std::size_t m_last_queued = 0;
    Clock::time_point m_last_orphan_scan;
    IncomingTracker m_incoming;
    std::optional<Clock::time_point> m_next_settled; ///< when a waiting spec will have settled
};

} // namespace

int run_daemon(const DaemonOptions& options, const JobRunner& runner) {
    if (options.spool.empty()) throw InputError("--spool: a folder is required");
    if (options.workers < 1)
        throw InputError(cat("--workers: must be >= 1 (got ", options.workers, ")"));
    if (!(options.poll_seconds > 0.0) || !std::isfinite(options.poll_seconds) ||
        options.poll_seconds > 3600.0)
        throw InputError(cat("--poll: must be in (0, 3600] seconds (got ", options.poll_seconds, ")"));
    if (!(options.settle_seconds >= 0.0) || !std::isfinite(options.settle_seconds) ||
        options.settle_seconds > 3600.0)
        throw InputError(cat("--settle: must be in [0, 3600] seconds (got ", options.settle_seconds, ")"));
    if (!runner) throw std::invalid_argument("run_daemon: no job runner");
    Daemon daemon(options, runner);
    return daemon.run();
}

} // namespace brdf::service
