#pragma once
// File handling shared by the table readers and writers (internal to brdf_formats).
//   InputFile:  an open, regular, readable file with its size, closed on every path (RAII).
//   AtomicFile: core's (brdf/core/atomic_file.h): a temporary file beside the target that becomes
//               the target only on commit(), so no reader ever sees a partial table.
// Errors are brdf::IoError naming the path and the system's reason.

#include <brdf/core/atomic_file.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace brdf::formats::detail {

/// "NaN", "inf", "-inf", or the number with 10 significant digits: message text that does not
/// depend on the C library's spelling of non-finite values.
std::string value_text(double value);

/// The path as written in error messages.
std::string display(const std::filesystem::path& path);

class InputFile {
  public:
    /// Opens `path` for reading. Throws IoError for a missing or unreadable file, a folder, or
    /// anything that is not a regular file (a FIFO or a device could block or never end).
    explicit InputFile(const std::filesystem::path& path);
    ~InputFile();
    InputFile(const InputFile&) = delete;
    InputFile& operator=(const InputFile&) = delete;

    const std::filesystem::path& path() const { return m_path; }
    /// Size in bytes when opened.
    std::uint64_t size() const { return m_size; }
    /// Reads exactly `n` bytes at `offset`. Returns the number of bytes read, which is less than
    /// `n` only at the end of the file; throws IoError on a read error.
    std::size_t read_at(std::uint64_t offset, void* buffer, std::size_t n) const;

  private:
    std::filesystem::path m_path;
    int m_fd = -1;
    std::uint64_t m_size = 0;
};

/// Tables are written like every other file of the project: core's AtomicFile (temporary beside the
/// target, fsync, rename, fsync of the folder).
using AtomicFile = brdf::AtomicFile;

} // namespace brdf::formats::detail
