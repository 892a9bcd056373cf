#include <formats/file_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <fcntl.h>
#include <sys/stat.h>
#include <system_error>
#include <unistd.h>

namespace brdf::formats::detail {

namespace {

std::string reason(int error) {
    return std::generic_category().message(error);
}

} // namespace

std::string value_text(double value) {
    if (std::isnan(value)) return "NaN";
    if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
    return cat(value);
}

std::string display(const std::filesystem::path& path) {
    return path.string();
}

InputFile::InputFile(const std::filesystem::path& path) : m_path(path) {
    // O_NONBLOCK: opening a FIFO must not wait for a writer (fstat then refuses it); it does not
    // change reads from a regular file.
    m_fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (m_fd < 0) throw IoError(cat(display(path), ": cannot open: ", reason(errno)));
    // From here on the destructor does not run if we throw: close by hand.
    struct stat st {};
    if (::fstat(m_fd, &st) != 0) {
        const int error = errno;
        ::close(m_fd);
        throw IoError(cat(display(path), ": cannot stat: ", reason(error)));
    }
    if (!S_ISREG(st.st_mode)) {
        ::close(m_fd);
        throw IoError(cat(display(path), S_ISDIR(st.st_mode) ? ": is a directory, not a table file"
                                                             : ": not a regular file"));
    }
    m_size = static_cast<std::uint64_t>(st.st_size);
}

InputFile::~InputFile() {
    if (m_fd >= 0) ::close(m_fd);
}

std::size_t InputFile::read_at(std::uint64_t offset, void* buffer, std::size_t n) const {
    auto* out = static_cast<char*>(buffer);
    std::size_t done = 0;
    while (done < n) {
        // pread moves at most ~2 GiB per call on Linux; ask for no more than 1 GiB at a time.
        const std::size_t chunk = std::min<std::size_t>(n - done, std::size_t{1} << 30);
        const ssize_t k = ::pread(m_fd, out + done, chunk, static_cast<off_t>(offset + done));
        if (k < 0) {
            if (errno == EINTR) continue;
            throw IoError(cat(display(m_path), ": read failed: ", reason(errno)));
        }
        if (k == 0) break; // end of file
        done += static_cast<std::size_t>(k);
    }
    return done;
}

AtomicFile::AtomicFile(const std::filesystem::path& target) : m_target(target) {
    const std::filesystem::path folder =
        target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
    static std::atomic<unsigned> counter{0};
    const auto stamp = static_cast<unsigned long long>(
        std::chrono::steady_clock::now().time_since_epoch().count());
    for (int attempt = 0; attempt < 100; ++attempt) {
        // Hidden, and named after the target, so a leftover from a crash is recognisable.
        m_temp = folder / cat(".", target.filename().string(), ".tmp.", ::getpid(), ".",
                              counter.fetch_add(1), ".", stamp % 1000000);
        m_fd = ::open(m_temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (m_fd >= 0) return;
        if (errno != EEXIST)
            throw IoError(cat(display(target), ": cannot create temporary file ", display(m_temp),
                              ": ", reason(errno)));
    }
    throw IoError(cat(display(target), ": cannot create a temporary file in ", display(folder)));
}

AtomicFile::~AtomicFile() {
    if (m_committed) return;
    if (m_fd >= 0) ::close(m_fd);
    ::unlink(m_temp.c_str());
}

void AtomicFile::write_at(std::uint64_t offset, const void* data, std::size_t n) {
    const auto* in = static_cast<const char*>(data);
    std::size_t done = 0;
    while (done < n) {
        const std::size_t chunk = std::min<std::size_t>(n - done, std::size_t{1} << 30);
        const ssize_t k = ::pwrite(m_fd, in + done, chunk, static_cast<off_t>(offset + done));
        if (k < 0) {
            if (errno == EINTR) continue;
            throw IoError(cat(display(m_target), ": write failed: ", reason(errno)));
        }
        done += static_cast<std::size_t>(k);
    }
}

void AtomicFile::commit() {
    if (::fsync(m_fd) != 0)
        throw IoError(cat(display(m_target), ": fsync failed: ", reason(errno)));
    const int fd = m_fd;
    m_fd = -1;
    if (::close(fd) != 0) throw IoError(cat(display(m_target), ": close failed: ", reason(errno)));
    if (::rename(m_temp.c_str(), m_target.c_str()) != 0)
        throw IoError(cat(display(m_target), ": cannot rename ", display(m_temp),
                          " into place: ", reason(errno)));
    m_committed = true;
    // The rename is durable once the folder's entry is on disk. Failing here does not undo the
    // (already atomic) replacement, and some file systems refuse fsync on folders: only log it.
    const std::filesystem::path folder =
        m_target.has_parent_path() ? m_target.parent_path() : std::filesystem::path(".");
    const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dir < 0 || ::fsync(dir) != 0)
        log::debug(display(m_target), ": could not fsync folder ", display(folder), ": ",
                   reason(errno));
    if (dir >= 0) ::close(dir);
}

} // namespace brdf::formats::detail
