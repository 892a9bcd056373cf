#include <brdf/mie/ensemble_cache.h>

#include <exception>

namespace brdf::mie {

EnsembleCache::EnsembleCache(std::size_t max_bytes) : m_max_bytes(max_bytes) {}

EnsembleCache& EnsembleCache::shared() {
    static EnsembleCache cache(std::size_t{64} << 20);
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
                  static_cast<int>(options.rule)};
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
        ++m_stats.computed;
        m_recent.push_front(key);
        m_entries.emplace(key, Entry{promise.get_future().share(), 0, m_recent.begin()});
    }
    std::shared_ptr<const Ensemble> result;
    try {
        result = std::make_shared<const Ensemble>(
            ensemble(particle_index, medium_index, wavelength_nm, sizes, options));
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
