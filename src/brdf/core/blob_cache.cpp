#include <brdf/core/blob_cache.h>

#include <brdf/core/atomic_file.h>
#include <brdf/core/error.h>
#include <brdf/core/hash.h>
#include <brdf/core/log.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>

namespace brdf {
namespace fs = std::filesystem;
namespace {

constexpr std::uint64_t max_file_bytes = std::uint64_t{1} << 30;

std::string env(const char* name) {
    const char* value = std::getenv(name);
    return value ? value : "";
}

void put_u64(std::string& out, std::uint64_t v) {
    for (int i = 0; i < 8; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
}

std::uint64_t get_u64(std::string_view in, std::size_t at) {
    std::uint64_t v = 0;
    for (int i = 7; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(in[at + static_cast<std::size_t>(i)]);
    return v;
}

} // namespace

fs::path cache_root() {
    if (const std::string dir = env("BRDF_CACHE_DIR"); !dir.empty()) return dir == "off" ? fs::path() : fs::path(dir);
    if (const std::string xdg = env("XDG_CACHE_HOME"); !xdg.empty()) return fs::path(xdg) / "brdf-service";
    if (const std::string home = env("HOME"); !home.empty()) return fs::path(home) / ".cache" / "brdf-service";
    return {};
}

BlobCache::BlobCache(fs::path dir, std::string_view magic) : m_dir(std::move(dir)), m_magic(magic) {}

fs::path BlobCache::file(std::string_view key) const { return m_dir / (fnv1a64_hex(key) + ".bin"); }

std::optional<std::string> BlobCache::load(std::string_view key) const {
    const fs::path path = file(key);
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(path, ec);
    if (ec || size < m_magic.size() + 24 || size > max_file_bytes) return std::nullopt;
    std::ifstream in(path, std::ios::binary);
    std::string data(static_cast<std::size_t>(size), '\0');
    if (!in.read(data.data(), static_cast<std::streamsize>(size))) return std::nullopt;
    const std::string_view view(data);
    if (view.substr(0, m_magic.size()) != m_magic) return std::nullopt;
    std::size_t at = m_magic.size();
    const std::uint64_t key_bytes = get_u64(view, at);
    at += 8;
    if (key_bytes != key.size() || size - at < key_bytes + 16 || view.substr(at, key_bytes) != key)
        return std::nullopt;
    at += key_bytes;
    const std::uint64_t blob_bytes = get_u64(view, at);
    at += 8;
    if (blob_bytes != size - at - 8) return std::nullopt;
    const std::string_view blob = view.substr(at, blob_bytes);
    if (get_u64(view, at + blob_bytes) != fnv1a64(blob)) return std::nullopt;
    return std::string(blob);
}

bool BlobCache::store(std::string_view key, std::string_view blob) const {
    std::string data(m_magic);
    put_u64(data, key.size());
    data += key;
    put_u64(data, blob.size());
    data += blob;
    put_u64(data, fnv1a64(blob));
    std::error_code ec;
    fs::create_directories(m_dir, ec);
    if (ec) {
        log::debug("cache ", m_dir.string(), ": cannot create it: ", ec.message());
        return false;
    }
    // Concurrent processes (brdfd and brdftool) never read a half-written file.
    try {
        AtomicFile out(file(key));
        out.write(data);
        out.commit(AtomicFile::Commit::Atomic);
        return true;
    } catch (const Error& e) {
        log::debug("cache ", m_dir.string(), ": ", e.what());
        return false;
    }
}

} // namespace brdf
