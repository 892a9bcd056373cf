#pragma once
// A folder of blobs stored under text keys, for results that cost far more to compute than to
// keep: the OpenCL program binaries (cl/context.cpp) and the Mie ensembles (mie/ensemble_cache.h).
//
//   DIR/HASH.bin   HASH: FNV-1a 64 of the key, hex. The file holds a magic string, the key, the
//                  blob and the blob's FNV-1a 64; a load checks every one of them, so a hash
//                  collision, a torn, truncated or foreign file is a miss, never a wrong blob.
//
// Files appear whole (AtomicFile) but are not synced: a cache may lose its newest entries in a
// power loss, and the check above turns whatever is left of them into misses. Nothing here throws:
// a folder that cannot be created or written only means nothing is kept (logged at debug level).

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace brdf {

/// The folder caches live under: $BRDF_CACHE_DIR, else $XDG_CACHE_HOME/brdf-service, else
/// $HOME/.cache/brdf-service; empty (no disk caches) when none is set or BRDF_CACHE_DIR is "off".
std::filesystem::path cache_root();

class BlobCache {
public:
    /// Blobs in `dir` (created on the first store), their files starting with `magic`.
    BlobCache(std::filesystem::path dir, std::string_view magic);

    /// The blob stored under `key`, or nullopt.
    std::optional<std::string> load(std::string_view key) const;
    /// Stores `blob` under `key`, replacing any; false when it could not.
    bool store(std::string_view key, std::string_view blob) const;

    const std::filesystem::path& dir() const { return m_dir; }
    /// The file `key` is stored in.
    std::filesystem::path file(std::string_view key) const;

private:
    std::filesystem::path m_dir;
    std::string m_magic;
};

} // namespace brdf
