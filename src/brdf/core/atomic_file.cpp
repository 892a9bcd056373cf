#include <brdf/core/atomic_file.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <fcntl.h>
#include <system_error>
#include <unistd.h>

namespace brdf {
namespace {

std::string reason(int error) { return std::generic_category().message(error); }

// Writes from this size on start their write-back at once (write_at).
constexpr std::size_t writeback_hint_bytes = std::size_t{1} << 16;

std::filesystem::path folder_of(const std::filesystem::path& target) {
    return target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
}

} // namespace

AtomicFile::AtomicFile(std::filesystem::path target, std::string_view suffix)
    : m_target(std::move(target)) {
    const std::filesystem::path folder = folder_of(m_target);
    static std::atomic<unsigned long> counter{0};
    const auto stamp = static_cast<unsigned long long>(
        std::chrono::steady_clock::now().time_since_epoch().count());
    // O_EXCL with a per-process counter: two threads (or two daemon workers writing the same report)
    // never share a temporary. The retry covers a leftover of an earlier process with our pid.
    for (int attempt = 0; attempt < 100; ++attempt) {
        m_temp = folder / cat(".", m_target.filename().string(), ".tmp.", ::getpid(), ".",
                              counter.fetch_add(1), ".", stamp % 1000000, suffix);
        m_fd = ::open(m_temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (m_fd >= 0) return;
        if (errno != EEXIST)
            throw IoError(cat(m_target.string(), ": cannot create temporary file ",
                              m_temp.string(), ": ", reason(errno)));
    }
    throw IoError(cat(m_target.string(), ": cannot create a temporary file in ", folder.string()));
}

AtomicFile::~AtomicFile() {
    if (m_fd >= 0) ::close(m_fd);
    if (!m_committed) ::unlink(m_temp.c_str());
}

void AtomicFile::write(std::string_view data) {
    write_at(m_end, data.data(), data.size());
}

void AtomicFile::write_at(std::uint64_t offset, const void* data, std::size_t n) {
    if (m_fd < 0) throw IoError(cat(m_target.string(), ": write after commit"));
    const auto* in = static_cast<const char*>(data);
    std::size_t done = 0;
    while (done < n) {
        // pwrite moves at most ~2 GiB per call on Linux; ask for no more than 1 GiB at a time.
        const std::size_t chunk = std::min<std::size_t>(n - done, std::size_t{1} << 30);
        const ssize_t k = ::pwrite(m_fd, in + done, chunk, static_cast<off_t>(offset + done));
        if (k < 0) {
            if (errno == EINTR) continue;
            throw IoError(cat(m_target.string(), ": write failed: ", reason(errno)));
        }
        done += static_cast<std::size_t>(k);
    }
#ifdef __linux__
    // Start the range's write-back now, without waiting for it (a hint: its failure is fsync's to
    // report), so that commit()'s fsync finds the data on its way to the disk rather than starting
    // it: a 35 MB MERL table's fsync took 17-19 ms after its last write, 0.3 ms with this, and an
    // HG table's `compute` 0.157 -> 0.150 s (docs/benchmarks.md). As PostgreSQL's
    // backend_flush_after and RocksDB's bytes_per_sync do.
    if (n >= writeback_hint_bytes)
        ::sync_file_range(m_fd, static_cast<off64_t>(offset), static_cast<off64_t>(n), SYNC_FILE_RANGE_WRITE);
#endif
    for (std::uint64_t end = m_end.load(); end < offset + n && !m_end.compare_exchange_weak(end, offset + n);) {
    }
}

void AtomicFile::commit(Commit how) {
    if (m_committed || m_fd < 0) throw IoError(cat(m_target.string(), ": committed twice"));
    if (how == Commit::Durable) {
        // Synced through a descriptor opened by name: a library that wrote temporary() itself may
        // have replaced the file we created (fsync is per inode, so for our own writes the same).
        const int fd = ::open(m_temp.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0)
            throw IoError(cat(m_target.string(), ": cannot reopen ", m_temp.string(), ": ", reason(errno)));
        const bool synced = ::fsync(fd) == 0;
        const int sync_error = errno;
        ::close(fd);
        if (!synced) throw IoError(cat(m_target.string(), ": fsync failed: ", reason(sync_error)));
    }
    const int own = m_fd;
    m_fd = -1;
    if (::close(own) != 0) throw IoError(cat(m_target.string(), ": close failed: ", reason(errno)));
    if (::rename(m_temp.c_str(), m_target.c_str()) != 0)
        throw IoError(cat(m_target.string(), ": cannot rename ", m_temp.string(),
                          " into place: ", reason(errno)));
    m_committed = true;
    if (how == Commit::Atomic) return;
    // The rename is durable once the folder's entry is on disk. Failing here does not undo the
    // (already atomic) replacement, and some file systems refuse fsync on folders: only log it.
    const std::filesystem::path folder = folder_of(m_target);
    const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dir < 0 || ::fsync(dir) != 0)
        log::debug(m_target.string(), ": could not fsync folder ", folder.string(), ": ",
                   reason(errno));
    if (dir >= 0) ::close(dir);
}

void write_file_atomically(const std::filesystem::path& path, std::string_view content) {
    AtomicFile file(path);
    file.write(content);
    file.commit();
}

} // namespace brdf
