#include <brdf/service/spool.h>

#include <brdf/core/atomic_file.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fcntl.h>
#include <csignal>
#include <random>
#include <sys/file.h>
#include <unistd.h>
#include <utility>

namespace brdf::service {
namespace fs = std::filesystem;

namespace {

std::string errno_text(int err) { return std::strerror(err); }

/// flock(2) on a file, opened for this lock only: flock belongs to the open file description, so
/// threads that shared one descriptor would share (and release) each other's lock.
class FileLock {
public:
    FileLock(const fs::path& path, int operation) {
        m_fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (m_fd < 0) throw IoError(cat(path.string(), ": cannot open lock file: ", errno_text(errno)));
        int rc;
        do {
            rc = ::flock(m_fd, operation);
        } while (rc != 0 && errno == EINTR);
        if (rc != 0) {
            const int err = errno;
            ::close(m_fd);
            throw IoError(cat(path.string(), ": cannot lock: ", errno_text(err)));
        }
    }
    ~FileLock() { ::close(m_fd); } // closing the last descriptor releases the lock
    FileLock(const FileLock&) = delete;
    FileLock& operator=(const FileLock&) = delete;

private:
    int m_fd = -1;
};

enum class RenameResult { Done, Missing, Exists };

/// rename(2) that never replaces `to`: renameat2(RENAME_NOREPLACE), or link + unlink on file systems
/// without it (NFS). Either way exactly one of several racing callers gets Done.
RenameResult rename_noreplace(const fs::path& from, const fs::path& to) {
    if (::renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), RENAME_NOREPLACE) == 0)
        return RenameResult::Done;
    int err = errno;
    if (err == EINVAL || err == ENOSYS) {
        if (::link(from.c_str(), to.c_str()) == 0) {
            ::unlink(from.c_str());
            return RenameResult::Done;
        }
        err = errno;
    }
    if (err == ENOENT) return RenameResult::Missing;
    if (err == EEXIST) return RenameResult::Exists;
    throw IoError(cat(from.string(), ": cannot move to ", to.string(), ": ", errno_text(err)));
}

void rename_or_throw(const fs::path& from, const fs::path& to) {
    if (::rename(from.c_str(), to.c_str()) != 0)
        throw IoError(cat(from.string(), ": cannot move to ", to.string(), ": ", errno_text(errno)));
}

bool ends_with(std::string_view s, std::string_view suffix) {
    return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

std::string host_name() {
    char buf[256] = {};
    if (::gethostname(buf, sizeof buf - 1) != 0 || buf[0] == '\0') return "localhost";
    std::string name = buf;
    // The name becomes part of a file name.
    for (char& c : name)
        if (c == '/' || c == '.' || c == ' ') c = '_';
    return name;
}

/// The daemon ID in an owner record, or "" when there is none or it does not parse.
std::string read_owner(const fs::path& owner_file) {
    const int fd = ::open(owner_file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return {};
    std::string text;
    char buf[4096];
    ssize_t k;
    while ((k = ::read(fd, buf, sizeof buf)) > 0) text.append(buf, static_cast<std::size_t>(k));
    ::close(fd);
    const nlohmann::json record = nlohmann::json::parse(text, nullptr, false);
    if (!record.is_object() || !record.contains("daemon") || !record["daemon"].is_string()) return {};
    return record["daemon"].get<std::string>();
}

bool valid_daemon_id(std::string_view id) {
    return !id.empty() && id.front() != '.' && id.find('/') == std::string_view::npos;
}

} // namespace

std::string iso8601_now() {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char stamp[32];
    std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return stamp;
}

// --- Spool ---------------------------------------------------------------------------------------

namespace {

fs::path absolute_folder(const fs::path& root) {
    std::error_code ec;
    fs::path path = fs::absolute(root, ec).lexically_normal();
    if (ec) path = root.lexically_normal();
    if (path.has_parent_path() && path.filename().empty()) path = path.parent_path(); // "spool/"
    return path;
}

} // namespace

Spool::Spool(fs::path root) : m_root(absolute_folder(root)) {
    for (const fs::path& dir : {m_root, incoming(), active(), results(), done(), failed(), daemons()}) {
        std::error_code ec;
        fs::create_directories(dir, ec);
        if (ec || !fs::is_directory(dir))
            throw IoError(cat(dir.string(), ": cannot create spool folder: ",
                              ec ? ec.message() : std::string("not a directory")));
    }
}

bool Spool::is_job_name(std::string_view name) {
    return name.size() > 5 && name.front() != '.' && ends_with(name, ".json");
}

std::string Spool::error_name(std::string_view name) {
    std::string_view stem = name;
    if (ends_with(stem, ".json")) stem.remove_suffix(5);
    return cat(stem, ".error.json");
}

fs::path Spool::owner_file(const std::string& name) const { return active() / (name + ".owner"); }

std::vector<Spool::Queued> Spool::queued_jobs() const {
    std::vector<Queued> entries;
    std::error_code ec;
    for (fs::directory_iterator it(incoming(), ec), end; !ec && it != end; it.increment(ec)) {
        std::string name = it->path().filename().string();
        if (!is_job_name(name)) continue;
        std::error_code entry_ec;
        if (!it->is_regular_file(entry_ec)) continue;
        const fs::file_time_type mtime = it->last_write_time(entry_ec);
        if (entry_ec) continue; // taken by someone else while we looked
        const std::uintmax_t size = it->file_size(entry_ec);
        if (entry_ec) continue;
        entries.push_back({std::move(name), mtime, size});
    }
    std::sort(entries.begin(), entries.end(), [](const Queued& a, const Queued& b) {
        return a.mtime != b.mtime ? a.mtime < b.mtime : a.name < b.name;
    });
    return entries;
}

std::vector<std::string> Spool::queued() const {
    std::vector<std::string> names;
    for (Queued& q : queued_jobs()) names.push_back(std::move(q.name));
    return names;
}

std::vector<std::string> Spool::active_jobs() const {
    std::vector<std::string> names;
    std::error_code ec;
    for (fs::directory_iterator it(active(), ec), end; !ec && it != end; it.increment(ec)) {
        std::string name = it->path().filename().string();
        std::error_code entry_ec;
        if (is_job_name(name) && it->is_regular_file(entry_ec)) names.push_back(std::move(name));
    }
    std::sort(names.begin(), names.end());
    return names;
}

bool Spool::claim(const std::string& name, const DaemonLease& owner) {
    // Shared: many daemons claim at once; the orphan scan (exclusive) never sees a claim half done.
    FileLock lock(m_root / ".spool.lock", LOCK_SH);
    if (rename_noreplace(incoming() / name, active() / name) != RenameResult::Done) return false;
    const nlohmann::json record = {{"daemon", owner.id()},
                                   {"pid", static_cast<long>(::getpid())},
                                   {"host", host_name()},
                                   {"claimed", iso8601_now()}};
    // Should this throw, the job sits in active/ without an owner and the next orphan scan requeues it.
    write_file_atomically(owner_file(name), record.dump() + "\n");
    return true;
}

void Spool::finish(const std::string& name) {
    rename_or_throw(active() / name, done() / name);
    std::error_code ec;
    fs::remove(owner_file(name), ec);
    // An error record without its spec is what a daemon killed inside fail() (between the record and
    // the rename) leaves; the rerun has now succeeded, so it describes nothing. A record beside an
    // older failed/NAME stays: it belongs to that spec.
    if (!fs::exists(failed() / name, ec)) fs::remove(failed() / error_name(name), ec);
}

void Spool::fail(const std::string& name, const std::string& kind, const std::string& message,
                 double seconds) {
    const nlohmann::json record = {{"spec", name},
                                   {"error", message},
                                   {"kind", kind},
                                   {"time", iso8601_now()},
                                   {"seconds", seconds}};
    // The record first, so whoever sees failed/NAME also finds its reason.
    write_file_atomically(failed() / error_name(name), record.dump(2) + "\n");
    rename_or_throw(active() / name, failed() / name);
    std::error_code ec;
    fs::remove(owner_file(name), ec);
}

bool Spool::requeue(const std::string& name) {
    const RenameResult r = rename_noreplace(active() / name, incoming() / name);
    if (r == RenameResult::Exists) {
        fail(name, "interrupted",
             cat(name, ": interrupted (its daemon stopped) and superseded by a newer incoming/", name),
             0.0);
        return false;
    }
    std::error_code ec;
    fs::remove(owner_file(name), ec);
    return r == RenameResult::Done;
}

bool Spool::daemon_alive(const std::string& id) const {
    if (!valid_daemon_id(id)) return false;
    const fs::path path = daemons() / (id + ".lock");
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return false; // a live daemon never removes its own lock file
    int rc;
    do {
        rc = ::flock(fd, LOCK_EX | LOCK_NB);
    } while (rc != 0 && errno == EINTR);
    const bool held_by_other = rc != 0 && errno == EWOULDBLOCK;
    ::close(fd);
    return held_by_other;
}

std::vector<std::string> Spool::requeue_orphans() {
    FileLock lock(m_root / ".spool.lock", LOCK_EX);
    std::vector<std::string> requeued;
    for (const std::string& name : active_jobs()) {
        const std::string owner = read_owner(owner_file(name));
        if (!owner.empty() && daemon_alive(owner)) continue;
        log::warn("spool: requeueing ", name, ": its daemon ",
                  owner.empty() ? std::string("(unrecorded)") : owner, " is gone");
        if (requeue(name)) requeued.push_back(name);
    }
    // Leftovers of dead daemons: owner records without a job, and their lock files.
    std::error_code ec;
    for (fs::directory_iterator it(active(), ec), end; !ec && it != end; it.increment(ec)) {
        const std::string file = it->path().filename().string();
        if (file.front() == '.' || !ends_with(file, ".owner")) continue;
        const std::string job = file.substr(0, file.size() - 6);
        std::error_code e;
        if (fs::exists(active() / job, e)) continue;
        const std::string owner = read_owner(it->path());
        if (owner.empty() || !daemon_alive(owner)) fs::remove(it->path(), e);
    }
    for (fs::directory_iterator it(daemons(), ec), end; !ec && it != end; it.increment(ec)) {
        const std::string file = it->path().filename().string();
        if (file.front() == '.' || !ends_with(file, ".lock")) continue;
        std::error_code e;
        if (!daemon_alive(file.substr(0, file.size() - 5))) fs::remove(it->path(), e);
    }
    return requeued;
}

bool Spool::is_temporary_name(std::string_view name) {
    if (name.size() < 2 || name.front() != '.') return false;
    std::string_view rest = name.substr(1);
    while (!rest.empty()) {
        const std::size_t dot = rest.find('.');
        if (rest.substr(0, dot) == "tmp") return true;
        if (dot == std::string_view::npos) break;
        rest.remove_prefix(dot + 1);
    }
    return false;
}

namespace {

std::vector<std::string_view> split_dots(std::string_view s) {
    std::vector<std::string_view> parts;
    for (;;) {
        const std::size_t dot = s.find('.');
        parts.push_back(s.substr(0, dot));
        if (dot == std::string_view::npos) return parts;
        s.remove_prefix(dot + 1);
    }
}

bool all_digits(std::string_view s) {
    return !s.empty() && s.size() <= 9 &&
           std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

/// The writer's pid in a temporary's name, or 0 when the name does not carry one. Names:
/// ".T.tmp.PID.N.STAMP[.EXT]" (core's AtomicFile), where T is the target's name,
/// ".HOST-PID-RANDOM.lock.tmp" (a daemon lease being registered), and ".T.PID.tmp", ".T.PID.N.tmp"
/// (writers of earlier versions, whose leftovers may still be in a spool).
pid_t temporary_writer_pid(std::string_view name) {
    const std::vector<std::string_view> parts = split_dots(name.substr(1));
    const std::size_t n = parts.size();
    if (n == 3 && parts[1] == "lock" && parts[2] == "tmp") {
        // A daemon lease being registered: ".HOST-PID-RANDOM.lock.tmp" (DaemonLease).
        const std::string_view id = parts[0];
        const std::size_t last = id.rfind('-');
        const std::size_t before = last == std::string_view::npos || last == 0 ? std::string_view::npos
                                                                                : id.rfind('-', last - 1);
        if (before == std::string_view::npos) return 0;
        const std::string_view pid = id.substr(before + 1, last - before - 1);
        return all_digits(pid) ? static_cast<pid_t>(std::stol(std::string(pid))) : 0;
    }
    if (n >= 2 && parts[n - 1] == "tmp") {
        // The first of the (at most two) numbers right before the final "tmp".
        std::size_t first = n - 1;
        while (first > 0 && n - 1 - first < 2 && all_digits(parts[first - 1])) --first;
        return first < n - 1 ? static_cast<pid_t>(std::stol(std::string(parts[first]))) : 0;
    }
    for (std::size_t i = n; i-- > 0;)
        if (parts[i] == "tmp")
            return i + 1 < n && all_digits(parts[i + 1])
                       ? static_cast<pid_t>(std::stol(std::string(parts[i + 1])))
                       : 0;
    return 0;
}

bool process_alive(pid_t pid) { return pid > 0 && (::kill(pid, 0) == 0 || errno == EPERM); }

bool flocked_by_someone(const fs::path& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    if (fd < 0) return false;
    const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
    ::close(fd);
    return held;
}

} // namespace

std::vector<fs::path> Spool::remove_stale_temporaries(fs::file_time_type started,
                                                      const DaemonLease& self,
                                                      std::chrono::seconds stale_after) {
    FileLock lock(m_root / ".spool.lock", LOCK_EX);
    bool others_alive = false;
    std::error_code ec;
    for (fs::directory_iterator it(daemons(), ec), end; !ec && it != end; it.increment(ec)) {
        const std::string file = it->path().filename().string();
        if (file.front() == '.' || !ends_with(file, ".lock")) continue;
        const std::string id = file.substr(0, file.size() - 5);
        if (id != self.id() && daemon_alive(id)) others_alive = true;
    }
    const fs::file_time_type now = fs::file_time_type::clock::now();
    std::vector<fs::path> removed;
    for (const fs::path& dir : {m_root, active(), results(), done(), failed(), daemons()}) {
        for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
            const std::string file = it->path().filename().string();
            if (!is_temporary_name(file)) continue;
            std::error_code e;
            if (!it->is_regular_file(e) || it->is_symlink(e)) continue;
            const fs::file_time_type mtime = it->last_write_time(e);
            if (e) continue;
            const bool old_enough = (!others_alive && mtime < started) || now - mtime > stale_after;
            if (!old_enough) continue;
            const pid_t pid = temporary_writer_pid(file);
            if (pid != ::getpid() && process_alive(pid)) continue;
            // A lease of this very process is another daemon here registering right now (it is
            // unlocked for the instant between open and flock): two daemons starting together raced.
            if (pid == ::getpid() && dir == daemons()) continue;
            if (flocked_by_someone(it->path())) continue;
            if (fs::remove(it->path(), e)) removed.push_back(it->path());
        }
    }
    return removed;
}

// --- DaemonLease ---------------------------------------------------------------------------------

DaemonLease::DaemonLease(const Spool& spool) {
    std::random_device rd;
    char suffix[16];
    std::snprintf(suffix, sizeof suffix, "%08x", static_cast<unsigned>(rd()));
    m_id = cat(host_name(), "-", ::getpid(), "-", suffix);
    m_path = spool.daemons() / (m_id + ".lock");
    // Lock under a hidden name, then rename into place: the lock file is never visible unlocked, so
    // no scan can take a starting daemon for a dead one.
    const fs::path tmp = spool.daemons() / ("." + m_id + ".lock.tmp");
    m_fd = ::open(tmp.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (m_fd < 0) throw IoError(cat(tmp.string(), ": cannot create daemon lock: ", errno_text(errno)));
    const std::string info = nlohmann::json{{"daemon", m_id},
                                            {"pid", static_cast<long>(::getpid())},
                                            {"host", host_name()},
                                            {"started", iso8601_now()}}
                                 .dump() +
                             "\n";
    const bool ok = ::write(m_fd, info.data(), info.size()) == static_cast<ssize_t>(info.size()) &&
                    ::flock(m_fd, LOCK_EX | LOCK_NB) == 0 && ::rename(tmp.c_str(), m_path.c_str()) == 0;
    if (!ok) {
        const int err = errno;
        ::close(m_fd);
        ::unlink(tmp.c_str());
        throw IoError(cat(m_path.string(), ": cannot register daemon: ", errno_text(err)));
    }
}

DaemonLease::~DaemonLease() {
    // Unlink while still holding the lock; the daemon has finished or requeued all its jobs by now.
    ::unlink(m_path.c_str());
    ::close(m_fd);
}

} // namespace brdf::service
