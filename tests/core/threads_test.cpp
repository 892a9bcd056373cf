// parallel_for on the process's worker threads: every item once, loops inside loops, the first
// exception rethrown after every thread has left, the thread count kept (one thread: the caller
// alone; more than the CPUs: threads of the loop's own), the same workers from loop to loop, and a
// caller helping with the loops its loop's items started.

#include <brdf/core/threads.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

namespace brdf::test {
namespace {

TEST(ParallelFor, RunsEveryItemOnce) {
    for (int threads : {0, 1, 2, 5}) {
        std::vector<std::atomic<int>> runs(1000);
        parallel_for(1000, threads, [&](int k) { ++runs[static_cast<std::size_t>(k)]; });
        for (const auto& r : runs) ASSERT_EQ(r.load(), 1) << threads << " threads";
    }
    parallel_for(0, 4, [](int) { FAIL() << "no items, no calls"; });
}

TEST(ParallelFor, LoopsNestWithoutWaitingForFreeWorkers) {
    std::vector<std::atomic<int>> runs(8 * 200);
    parallel_for(8, 0, [&](int i) {
        parallel_for(200, 0, [&](int j) {
            parallel_for(3, 0, [&](int) {});
            ++runs[static_cast<std::size_t>(i * 200 + j)];
        });
    });
    for (const auto& r : runs) ASSERT_EQ(r.load(), 1);
}

TEST(ParallelFor, TheFirstExceptionStopsTheLoopAndIsRethrown) {
    // Item 0 (among the first claimed) throws at once; every other item takes 5 ms. A loop that
    // did not stop would run all 199 of them; one that stops runs those already started.
    std::atomic<int> ran{0};
    EXPECT_THROW(parallel_for(200, 0,
                              [&](int k) {
                                  if (k == 0) throw std::runtime_error("item 0");
                                  std::this_thread::sleep_for(std::chrono::milliseconds(5));
                                  ++ran;
                              }),
                 std::runtime_error);
    EXPECT_LT(ran.load(), 2 * available_cpus() + 2);
    // The workers are free again.
    std::atomic<int> sum{0};
    parallel_for(100, 0, [&](int k) { sum += k; });
    EXPECT_EQ(sum.load(), 4950);
}

TEST(ParallelFor, OneThreadIsTheCaller) {
    const auto caller = std::this_thread::get_id();
    std::atomic<int> elsewhere{0};
    parallel_for(500, 1, [&](int) { elsewhere += std::this_thread::get_id() != caller; });
    EXPECT_EQ(elsewhere.load(), 0);
}

// A loop may ask for more threads than there are CPUs (compute --jobs): that many items run at
// once. Each item waits (up to 10 s) until all have started, which only as many threads can pass.
TEST(ParallelFor, MoreThreadsThanCpusRunAtOnce) {
    const int n = available_cpus() + 3;
    std::atomic<int> started{0};
    std::atomic<int> all_met{0};
    parallel_for(n, n, [&](int) {
        ++started;
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (started.load() < n && std::chrono::steady_clock::now() < until)
            std::this_thread::yield();
        all_met += started.load() == n;
    });
    EXPECT_EQ(all_met.load(), n);
}

// The workers start once: however many loops run, the threads that run their items are the caller
// and at most available_cpus() - 1 others. Each item takes 20 us, so that a worker woken first
// cannot take every item of a loop before the caller takes one (trivial items had let it, now and
// then, in all 50 loops).
TEST(ParallelFor, TheSameWorkersRunEveryLoop) {
    std::mutex mutex;
    std::set<std::thread::id> seen;
    for (int loop = 0; loop < 50; ++loop)
        parallel_for(16, 0, [&](int) {
            std::this_thread::sleep_for(std::chrono::microseconds(20));
            std::lock_guard lock(mutex);
            seen.insert(std::this_thread::get_id());
        });
    EXPECT_LE(seen.size(), static_cast<std::size_t>(available_cpus()));
    EXPECT_TRUE(seen.count(std::this_thread::get_id()));
}

// A caller done with its share of a loop works on the loops that the loop's other items started,
// rather than waiting idle for them (the stream check's two probe stacks, each computing its
// rough interface kernels over the cores). Here the caller's item returns once the other item has
// started, and that item runs a nested loop whose items, on that thread, wait (up to 10 s in all)
// for the caller to take one: with help the caller runs some of them, however late it is
// scheduled; without, the loop ends after the wait with the caller in none.
TEST(ParallelFor, ACallerHelpsWithTheLoopsItsItemsStarted) {
    if (available_cpus() < 2) GTEST_SKIP() << "needs two CPUs";
    const auto caller = std::this_thread::get_id();
    std::atomic<bool> other_started{false}, caller_joined{false};
    std::mutex mutex;
    std::set<std::thread::id> nested_threads;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    parallel_for(2, 2, [&](int) {
        if (std::this_thread::get_id() == caller) {
            while (!other_started.load() && std::chrono::steady_clock::now() < until) std::this_thread::yield();
            return;
        }
        other_started = true;
        parallel_for(8, 2, [&](int) {
            if (std::this_thread::get_id() == caller)
                caller_joined = true;
            else
                while (!caller_joined.load() && std::chrono::steady_clock::now() < until) std::this_thread::yield();
            std::lock_guard lock(mutex);
            nested_threads.insert(std::this_thread::get_id());
        });
    });
    ASSERT_TRUE(other_started.load()) << "no worker took the second item";
    EXPECT_TRUE(nested_threads.count(caller)) << "the caller waited idle for the nested loop";
    EXPECT_EQ(nested_threads.size(), 2u);
}

// Loops from several threads at once (materials computed side by side) all finish.
TEST(ParallelFor, LoopsFromSeveralThreadsAtOnce) {
    std::vector<std::thread> callers;
    std::atomic<long> total{0};
    for (int c = 0; c < 4; ++c)
        callers.emplace_back([&] {
            for (int loop = 0; loop < 20; ++loop) parallel_for(100, 0, [&](int k) { total += k; });
        });
    for (std::thread& t : callers) t.join();
    EXPECT_EQ(total.load(), 4L * 20 * 4950);
}

} // namespace
} // namespace brdf::test
