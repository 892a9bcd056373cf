#pragma once
// Ensembles computed once per process. The same pigment in the same binder at the same wavelength
// recurs: a catalogue's finishes of one paint (examples/catalogue.json has the seed white four
// times), `brdftool lobes` of a paint beside its gloss version, a daemon's jobs. mie::ensemble is a
// pure function of its inputs, so a repeat is answered with the first result, bit for bit.
//
// Thread-safe. A caller asking for an ensemble another thread is computing waits for it rather than
// computing it again; a computation that throws is not kept (each caller sees the error). The
// entries are bounded in memory: beyond max_bytes the least recently used ones are dropped.
//
// The process's cache also keeps every ensemble on disk (core/blob_cache.h, under
// brdf::cache_root()/mie): editing a paint's pigment amount, film thickness, substrate or finish,
// recomputing a catalogue, a daemon after a restart all solve with the particles' optics of the
// run before, bit for bit, instead of integrating Mie again (2.4 s a run for 40 um silica). The
// files are keyed by every input and by the build (BRDF_MIE_BUILD_ID: the Mie and core sources,
// the compiler and its flags), so another build never reads them.

#include <brdf/core/blob_cache.h>
#include <brdf/mie/ensemble.h>

#include <complex>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <future>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <tuple>

namespace brdf::mie {

class EnsembleCache {
public:
    /// Entries in memory up to `max_bytes`; and on disk in `disk_dir`, unless it is empty.
    explicit EnsembleCache(std::size_t max_bytes, std::filesystem::path disk_dir = {});
    EnsembleCache(const EnsembleCache&) = delete;
    EnsembleCache& operator=(const EnsembleCache&) = delete;

    /// The process's cache (64 MiB: a visible spectrum of 41 wavelengths holds 0.1-3 MB per
    /// pigment), on disk in cache_root()/mie (none when cache_root() is empty).
    static EnsembleCache& shared();

    /// mie::ensemble(particle_index, medium_index, wavelength_nm, sizes, options), from the cache
    /// when an equal request was made before. options.progress is not part of the request (it is
    /// called only when this call computes the ensemble).
    std::shared_ptr<const Ensemble> get(std::complex<double> particle_index, double medium_index, double wavelength_nm,
                                        const SizeDistribution& sizes, const EnsembleOptions& options = {});

    struct Stats {
        long long computed = 0; ///< requests that ran mie::ensemble
        long long loaded = 0;   ///< requests answered from the disk
        long long reused = 0;   ///< requests answered by an earlier or concurrent computation
        std::size_t entries = 0;
        std::size_t bytes = 0;
    };
    Stats stats() const;

private:
    // Every input of mie::ensemble but the progress callback.
    using Key = std::tuple<double, double, double, double, int, double, double, double, double, int, int, int, int, int,
                           double, double>;
    struct Entry {
        std::shared_future<std::shared_ptr<const Ensemble>> result;
        std::size_t bytes = 0; // 0 while in flight
        std::list<Key>::iterator recent;
    };
    void evict_locked();

    const std::size_t m_max_bytes;
    const std::optional<BlobCache> m_disk;
    mutable std::mutex m_mutex;
    std::map<Key, Entry> m_entries;
    std::list<Key> m_recent; // most recently used first
    Stats m_stats;
};

} // namespace brdf::mie
