#pragma once
// Threads: how many to run, and the one parallel loop every stage uses (wavelengths, Fourier orders,
// table rows, image rows). Work items are independent and each writes only its own results, so the
// output does not depend on the thread count or scheduling (tables are byte-identical run to run).

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace brdf {

/// CPUs in this process's affinity mask (>= 1), not the machine's online cores: a Slurm task given 4
/// CPUs of a 64-core node, or a container with a CPU set, runs 4 threads rather than 64.
int available_cpus();

/// body(k) for k = 0 .. count - 1 on min(threads, count) threads (available_cpus() when threads <= 0),
/// the calling thread included. The first exception stops the loop and is rethrown here once every
/// worker has stopped.
template <typename Body> void parallel_for(int count, int threads, const Body& body) {
    if (count <= 0) return;
    if (threads <= 0) threads = available_cpus();
    threads = std::max(1, std::min(threads, count));
    std::atomic<int> next{0};
    std::exception_ptr error;
    std::mutex error_mutex;
    const auto work = [&] {
        for (int k = next++; k < count; k = next++) {
            try {
                body(k);
            } catch (...) {
                std::lock_guard lock(error_mutex);
                if (!error) error = std::current_exception();
                next = count;
            }
        }
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
    if (error) std::rethrow_exception(error);
}

} // namespace brdf
