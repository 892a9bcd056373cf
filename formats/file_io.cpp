#include <formats/file_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <cerrno>
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

} // namespace brdf::formats::detail
