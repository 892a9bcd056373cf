#include <brdf/mie/ensemble_cache.h>
#include <brdf/mie/phase_function.h>

#include <brdf/core/error.h>

#include <gtest/gtest.h>
#include <test_support.h>

#include <filesystem>
#include <thread>
#include <vector>

namespace brdf::mie {
namespace {

const std::complex<double> rutile{2.6, 0.0};
constexpr double pmma = 1.49;

// A repeat is the first result itself (mie::ensemble is not run again), equal to a fresh
// computation bit for bit; any change of an input is another entry.
TEST(EnsembleCache, ARepeatIsAnsweredWithTheFirstResult) {
    EnsembleCache cache(std::size_t{16} << 20);
    const SizeDistribution sizes = power_law(0.4, 0.3);
    EnsembleOptions options;
    options.tolerance = 1e-5;
    const auto first = cache.get(rutile, pmma, 550.0, sizes, options);
    const auto again = cache.get(rutile, pmma, 550.0, power_law(0.4, 0.3), options);
    EXPECT_EQ(first.get(), again.get());
    EXPECT_EQ(cache.stats().computed, 1);
    EXPECT_EQ(cache.stats().reused, 1);
    const Ensemble fresh = ensemble(rutile, pmma, 550.0, sizes, options);
    EXPECT_EQ(first->csca_um2, fresh.csca_um2);
    EXPECT_EQ(first->legendre, fresh.legendre);

    EnsembleOptions tighter = options;
    tighter.tolerance = 1e-6;
    const auto other_tolerance = cache.get(rutile, pmma, 550.0, sizes, tighter);
    const auto other_wavelength = cache.get(rutile, pmma, 560.0, sizes, options);
    const auto other_binder = cache.get(rutile, 1.5, 550.0, sizes, options);
    const auto other_sizes = cache.get(rutile, pmma, 550.0, power_law(0.4, 0.2), options);
    const auto other_kind = cache.get(rutile, pmma, 550.0, gamma(0.4, 0.3), options);
    const auto other_index = cache.get({2.6, 1e-3}, pmma, 550.0, sizes, options);
    EnsembleOptions reads = options; // what the convergence test checks is part of the request
    reads.checked_moments = 129;
    const auto other_reads = cache.get(rutile, pmma, 550.0, sizes, reads);
    reads.value_tolerance = 1e-4;
    const auto other_values = cache.get(rutile, pmma, 550.0, sizes, reads);
    for (const auto& e :
         {other_tolerance, other_wavelength, other_binder, other_sizes, other_kind, other_index, other_reads, other_values})
        EXPECT_NE(e.get(), first.get());
    EXPECT_NE(other_values.get(), other_reads.get());
    EXPECT_EQ(cache.stats().computed, 9);
    EXPECT_EQ(cache.stats().entries, 9u);
    EXPECT_NE(other_sizes->csca_um2, first->csca_um2);
}

// Threads asking for the same ensemble at once share one computation.
TEST(EnsembleCache, ConcurrentRequestsComputeOnce) {
    EnsembleCache cache(std::size_t{16} << 20);
    std::vector<std::shared_ptr<const Ensemble>> got(4);
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&, t] { got[t] = cache.get(rutile, pmma, 450.0, power_law(0.4, 0.3)); });
    for (auto& t : threads) t.join();
    for (const auto& e : got) EXPECT_EQ(e.get(), got[0].get());
    EXPECT_EQ(cache.stats().computed, 1);
    EXPECT_EQ(cache.stats().reused, 3);
}

// A failed computation is not kept: each request sees the error.
TEST(EnsembleCache, ErrorsAreNotKept) {
    EnsembleCache cache(std::size_t{16} << 20);
    const SizeDistribution sizes = monodisperse(0.3);
    EXPECT_THROW(cache.get(rutile, pmma, -1.0, sizes), InputError);
    EXPECT_THROW(cache.get(rutile, pmma, -1.0, sizes), InputError);
    EXPECT_EQ(cache.stats().computed, 2);
    EXPECT_EQ(cache.stats().entries, 0u);
}

// Beyond its byte budget the least recently used entries go.
TEST(EnsembleCache, TheLeastRecentlyUsedEntriesAreDroppedBeyondTheBudget) {
    const SizeDistribution sizes = monodisperse(0.3);
    EnsembleCache probe(std::size_t{16} << 20);
    probe.get(rutile, pmma, 500.0, sizes);
    const std::size_t one = probe.stats().bytes;
    ASSERT_GT(one, 0u);
    EnsembleCache cache(2 * one + one / 2); // room for two (their sizes differ by a few moments)
    const auto a = cache.get(rutile, pmma, 500.0, sizes);
    cache.get(rutile, pmma, 501.0, sizes);
    cache.get(rutile, pmma, 500.0, sizes); // a is now the most recent
    cache.get(rutile, pmma, 502.0, sizes); // drops 501
    EXPECT_EQ(cache.stats().entries, 2u);
    EXPECT_LE(cache.stats().bytes, 2 * one + one / 2);
    EXPECT_EQ(cache.get(rutile, pmma, 500.0, sizes).get(), a.get());
    const long long computed = cache.stats().computed;
    cache.get(rutile, pmma, 501.0, sizes);
    EXPECT_EQ(cache.stats().computed, computed + 1);
}

// On disk, an ensemble outlives its process: a second cache on the same folder (a later run) loads
// it instead of integrating Mie again, every field and moment bit for bit; another request is
// another file; a damaged file is computed again (and replaced), never read.
TEST(EnsembleCache, OnDiskARepeatInALaterRunIsLoadedBitForBit) {
    test::TempDir dir;
    const SizeDistribution sizes = power_law(0.4, 0.3);
    EnsembleOptions options;
    options.tolerance = 1e-5;
    std::shared_ptr<const Ensemble> first;
    {
        EnsembleCache run(std::size_t{16} << 20, dir.path());
        first = run.get(rutile, pmma, 550.0, sizes, options);
        run.get(rutile, pmma, 560.0, sizes, options);
        EXPECT_EQ(run.stats().computed, 2);
        EXPECT_EQ(run.stats().loaded, 0);
    }
    const auto files = [&] {
        std::vector<std::filesystem::path> out;
        for (const auto& e : std::filesystem::directory_iterator(dir.path())) out.push_back(e.path());
        return out;
    };
    ASSERT_EQ(files().size(), 2u);
    // Each file holds its key, and the key names the kernel set that computed it: the sets round
    // differently (phase_function.h), so a folder shared by machines never mixes them.
    for (const auto& f : files())
        EXPECT_NE(test::read_file(f).find(std::string("\nkernels ") + series_kernels() + "\n"), std::string::npos);

    EnsembleCache later(std::size_t{16} << 20, dir.path());
    const auto loaded = later.get(rutile, pmma, 550.0, sizes, options);
    EXPECT_EQ(later.stats().loaded, 1);
    EXPECT_EQ(later.stats().computed, 0);
    EXPECT_EQ(loaded->particle_index, first->particle_index);
    EXPECT_EQ(loaded->m, first->m);
    for (double Ensemble::*field : {&Ensemble::medium_index, &Ensemble::wavelength_nm, &Ensemble::cext_um2,
                                    &Ensemble::csca_um2, &Ensemble::cabs_um2, &Ensemble::cback_um2, &Ensemble::qext,
                                    &Ensemble::qsca, &Ensemble::qabs, &Ensemble::qback, &Ensemble::g,
                                    &Ensemble::albedo, &Ensemble::mean_volume_um3, &Ensemble::mean_area_um2,
                                    &Ensemble::r_min_um, &Ensemble::r_max_um, &Ensemble::x_min, &Ensemble::x_max,
                                    &Ensemble::error_estimate})
        EXPECT_EQ((*loaded).*field, (*first).*field);
    EXPECT_EQ(loaded->radius_nodes, first->radius_nodes);
    EXPECT_EQ(loaded->resonances, first->resonances);
    EXPECT_EQ(loaded->rule, first->rule);
    EXPECT_EQ(loaded->legendre, first->legendre);
    // In this run it is now in memory: no second read.
    EXPECT_EQ(later.get(rutile, pmma, 550.0, sizes, options).get(), loaded.get());
    EXPECT_EQ(later.stats().loaded, 1);
    // Another tolerance is another request: computed, and kept beside the others.
    EnsembleOptions tighter = options;
    tighter.tolerance = 1e-6;
    later.get(rutile, pmma, 550.0, sizes, tighter);
    EXPECT_EQ(later.stats().computed, 1);
    EXPECT_EQ(files().size(), 3u);

    // Every file damaged: the next run computes each again, with the same result.
    for (const auto& f : files()) {
        std::string bytes = test::read_file(f);
        bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 1);
        test::write_file(f, bytes);
    }
    EnsembleCache damaged(std::size_t{16} << 20, dir.path());
    const auto again = damaged.get(rutile, pmma, 550.0, sizes, options);
    EXPECT_EQ(damaged.stats().computed, 1);
    EXPECT_EQ(damaged.stats().loaded, 0);
    EXPECT_EQ(again->legendre, first->legendre);
    EXPECT_EQ(again->csca_um2, first->csca_um2);
    EnsembleCache repaired(std::size_t{16} << 20, dir.path());
    repaired.get(rutile, pmma, 550.0, sizes, options);
    EXPECT_EQ(repaired.stats().loaded, 1);
}

} // namespace
} // namespace brdf::mie
