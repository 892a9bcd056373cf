#pragma once
// The one way this project writes a file that others read: tables, reports, previews, the daemon's
// status and records, the disk caches (core/blob_cache.h: renamed into place, not synced). The data
// goes into a temporary file beside the target (same folder, so the same file system and an atomic
// rename), is fsynced, renamed over the target, and the folder is fsynced so that the rename itself
// survives a power loss. A reader sees the old
// file or the new one, never a partial one; a writer that fails or is destroyed before commit()
// removes its temporary. A writer killed outright (SIGKILL) leaves it behind under a name that says
// what it is, which brdfd's start-up clean-up recognises (service::Spool::is_temporary_name):
//
//   .TARGET.tmp.PID.N.STAMP[SUFFIX]   PID: the writer's process, N: a per-process counter, STAMP: a
//                                     clock reading; unique per call, also across threads.
//
//   AtomicFile out(path);
//   out.write(header);
//   out.write_at(offset, data, size);
//   out.commit();                      // only now does `path` change
//
// Errors are IoError naming the target and the system's reason.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>

namespace brdf {

class AtomicFile {
public:
    /// Creates the temporary (O_EXCL, mode 0666 less the umask) in the folder of `target`.
    /// `suffix` ends its name, for writers that pick a format by the extension.
    explicit AtomicFile(std::filesystem::path target, std::string_view suffix = {});
    /// Removes the temporary unless commit() succeeded.
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    const std::filesystem::path& target() const { return m_target; }
    /// Where the data goes until commit(). A library that opens files by name itself may write
    /// there (truncating or replacing it); commit() syncs whatever it left.
    const std::filesystem::path& temporary() const { return m_temp; }

    /// Appends `data` at the end of what write() has written so far.
    void write(std::string_view data);
    /// Writes all `n` bytes at `offset` (pwrite: does not move write()'s position). Several threads
    /// may write disjoint ranges at once. On Linux a write of 64 KiB or more starts its write-back
    /// to the disk (sync_file_range), so that a durable commit waits for less.
    void write_at(std::uint64_t offset, const void* data, std::size_t n);
    /// What commit() makes sure of: Durable, that the new file survives a power loss; Atomic, only
    /// that it replaces the target at once (a cache, whose reader checks what it reads).
    enum class Commit { Durable, Atomic };
    /// fsync the temporary, rename it over the target, fsync the folder (Atomic: only the rename).
    /// Throws IoError naming the target when any step up to the rename fails (the destructor then
    /// removes the temporary); a folder that refuses fsync (some network file systems) is only
    /// logged at debug level.
    void commit(Commit how = Commit::Durable);

private:
    std::filesystem::path m_target;
    std::filesystem::path m_temp;
    int m_fd = -1;
    std::atomic<std::uint64_t> m_end{0}; ///< where the next write() goes: the end of all written
    bool m_committed = false;
};

/// Writes `content` to `path` with an AtomicFile: the whole file appears at once, durably.
void write_file_atomically(const std::filesystem::path& path, std::string_view content);

} // namespace brdf
