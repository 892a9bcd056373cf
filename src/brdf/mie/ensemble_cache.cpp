#include <brdf/mie/ensemble_cache.h>
#include <brdf/mie/phase_function.h>

#include <bit>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>
#include <string_view>
#include <tuple>

#ifndef BRDF_MIE_BUILD_ID
#error "BRDF_MIE_BUILD_ID is set by src/brdf/mie/CMakeLists.txt"
#endif

namespace brdf::mie {
namespace {

constexpr std::string_view disk_magic = "BRDFMIE1";

// The request (the in-memory cache's key: every input of mie::ensemble) as text, each number exact
// (hexadecimal floating point), with the build and the CPU's kernel set (phase_function.h: FMA or
// not rounds differently): one list of the inputs for both caches.
template <class Key>
std::string disk_key(const Key& request) {
    std::string key = "brdf-mie-ensemble 3\nbuild " BRDF_MIE_BUILD_ID "\nkernels ";
    key += series_kernels();
    key += '\n';
    std::apply(
        [&key](const auto&... field) {
            const auto add = [&key](double v) {
                char text[40];
                std::snprintf(text, sizeof text, "%a\n", v);
                key += text;
            };
            (add(static_cast<double>(field)), ...);
        },
        request);
    return key;
}

// An Ensemble as the bytes of its fields (this host's byte order: the key's build fixes the host).
static_assert(std::endian::native == std::endian::little, "the ensembles on disk are little-endian");

template <class T>
void put(std::string& out, const T& v) {
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

template <class T>
bool get(std::string_view& in, T& v) {
    if (in.size() < sizeof v) return false;
    std::memcpy(&v, in.data(), sizeof v);
    in.remove_prefix(sizeof v);
    return true;
}

// Every field of an Ensemble (E: Ensemble or const Ensemble) but the Legendre moments, in one
// order for writing and reading. A field added to Ensemble changes its size: add it here too (and
// to disk_magic's version).
static_assert(sizeof(Ensemble) == 224, "Ensemble changed: update visit_fields");
template <class E, class Visit>
bool visit_fields(E& e, Visit&& visit) {
    return visit(e.particle_index) && visit(e.medium_index) && visit(e.wavelength_nm) && visit(e.m) &&
           visit(e.cext_um2) && visit(e.csca_um2) && visit(e.cabs_um2) && visit(e.cback_um2) && visit(e.qext) &&
           visit(e.qsca) && visit(e.qabs) && visit(e.qback) && visit(e.g) && visit(e.albedo) &&
           visit(e.mean_volume_um3) && visit(e.mean_area_um2) && visit(e.r_min_um) && visit(e.r_max_um) &&
           visit(e.x_min) && visit(e.x_max) && visit(e.radius_nodes) && visit(e.resonances) && visit(e.rule) &&
           visit(e.error_estimate);
}

std::string to_bytes(const Ensemble& e) {
    std::string out;
    visit_fields(e, [&out](const auto& v) {
        put(out, v);
        return true;
    });
    put(out, static_cast<std::uint64_t>(e.legendre.size()));
    out.append(reinterpret_cast<const char*>(e.legendre.data()), e.legendre.size() * sizeof(double));
    return out;
}

std::optional<Ensemble> from_bytes(std::string_view in) {
    Ensemble e;
    std::uint64_t terms = 0;
    if (!visit_fields(e, [&in](auto& v) { return get(in, v); }) || !get(in, terms) ||
        in.size() != terms * sizeof(double))
        return std::nullopt;
    e.legendre.resize(terms);
    std::memcpy(e.legendre.data(), in.data(), in.size());
    return e;
}

} // namespace

EnsembleCache::EnsembleCache(std::size_t max_bytes, std::filesystem::path disk_dir)
    : m_max_bytes(max_bytes),
      m_disk(disk_dir.empty() ? std::nullopt : std::optional<BlobCache>(BlobCache(disk_dir, disk_magic))) {}

EnsembleCache& EnsembleCache::shared() {
    static EnsembleCache cache(std::size_t{64} << 20,
                               cache_root().empty() ? std::filesystem::path() : cache_root() / "mie");
    return cache;
}

std::shared_ptr<const Ensemble> EnsembleCache::get(std::complex<double> particle_index, double medium_index,
                                                   double wavelength_nm, const SizeDistribution& sizes,
                                                   const EnsembleOptions& options) {
    const Key key{particle_index.real(),
                  particle_index.imag(),
                  medium_index,
                  wavelength_nm,
                  static_cast<int>(sizes.kind()),
                  sizes.parameter1(),
                  sizes.parameter2(),
                  options.tolerance,
                  options.legendre.tolerance,
                  options.legendre.max_terms,
                  options.refinement,
                  options.max_nodes,
                  static_cast<int>(options.rule),
                  options.checked_moments,
                  options.checked_cosine,
                  options.value_tolerance};
    std::promise<std::shared_ptr<const Ensemble>> promise;
    {
        std::unique_lock lock(m_mutex);
        if (auto it = m_entries.find(key); it != m_entries.end()) {
            ++m_stats.reused;
            m_recent.splice(m_recent.begin(), m_recent, it->second.recent);
            std::shared_future<std::shared_ptr<const Ensemble>> result = it->second.result;
            lock.unlock();
            return result.get(); // waits while another thread computes it; rethrows its error
        }
        m_recent.push_front(key);
        m_entries.emplace(key, Entry{promise.get_future().share(), 0, m_recent.begin()});
    }
    std::shared_ptr<const Ensemble> result;
    try {
        const std::string stored_key = m_disk ? disk_key(key) : std::string();
        std::optional<Ensemble> stored;
        if (m_disk)
            if (const std::optional<std::string> bytes = m_disk->load(stored_key)) stored = from_bytes(*bytes);
        {
            std::lock_guard lock(m_mutex);
            ++(stored ? m_stats.loaded : m_stats.computed);
        }
        if (stored) {
            result = std::make_shared<const Ensemble>(std::move(*stored));
        } else {
            result = std::make_shared<const Ensemble>(
                ensemble(particle_index, medium_index, wavelength_nm, sizes, options));
            if (m_disk) m_disk->store(stored_key, to_bytes(*result));
        }
    } catch (...) {
        promise.set_exception(std::current_exception()); // for the callers already waiting
        std::lock_guard lock(m_mutex);
        if (auto it = m_entries.find(key); it != m_entries.end()) {
            m_recent.erase(it->second.recent);
            m_entries.erase(it);
        }
        throw;
    }
    promise.set_value(result);
    std::lock_guard lock(m_mutex);
    if (auto it = m_entries.find(key); it != m_entries.end()) {
        it->second.bytes = sizeof(Ensemble) + result->legendre.capacity() * sizeof(double);
        m_stats.bytes += it->second.bytes;
        evict_locked();
    }
    return result;
}

void EnsembleCache::evict_locked() {
    // From the least recently used end; entries still in flight (bytes 0) stay.
    for (auto k = m_recent.end(); m_stats.bytes > m_max_bytes && k != m_recent.begin();) {
        --k;
        auto it = m_entries.find(*k);
        if (it->second.bytes == 0) continue;
        m_stats.bytes -= it->second.bytes;
        m_entries.erase(it);
        k = m_recent.erase(k);
    }
}

EnsembleCache::Stats EnsembleCache::stats() const {
    std::lock_guard lock(m_mutex);
    Stats s = m_stats;
    s.entries = m_entries.size();
    return s;
}

} // namespace brdf::mie
