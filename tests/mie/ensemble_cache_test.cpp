#include <brdf/mie/ensemble_cache.h>

#include <brdf/core/error.h>

#include <gtest/gtest.h>

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
    for (const auto& e : {other_tolerance, other_wavelength, other_binder, other_sizes, other_kind, other_index})
        EXPECT_NE(e.get(), first.get());
    EXPECT_EQ(cache.stats().computed, 7);
    EXPECT_EQ(cache.stats().entries, 7u);
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

} // namespace
} // namespace brdf::mie
