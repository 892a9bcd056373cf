#pragma once
// Threads: how many to run, and the one parallel loop every stage uses (wavelengths, Fourier
// orders, table rows, image rows). Work items are independent and each writes only its own results,
// so the output does not depend on the thread count or scheduling (tables are byte-identical run to
// run).
//
// The loops run on worker threads started once per process (available_cpus() - 1 of them, the
// calling thread making up the last), not on threads started per loop: a seed material runs ~70
// loops, and while another thread is inside dlopen (PoCL loading its compiler, ~40 ms) glibc makes
// every pthread_create wait for it (the new thread's TLS is set up under the loader's lock), so a
// loop that started threads then stalled for the whole load. start_worker_threads() starts them
// before that load (model::solve_material does).

#include <atomic>
#include <exception>
#include <mutex>

namespace brdf {

/// CPUs in this process's affinity mask (>= 1), not the machine's online cores: a Slurm task given
/// 4 CPUs of a 64-core node, or a container with a CPU set, runs 4 threads rather than 64.
int available_cpus();

/// Starts the worker threads if they are not running yet (the first parallel loop starts them
/// otherwise). Throws nothing: a worker that cannot be started leaves the loops to fewer threads.
void start_worker_threads() noexcept;

namespace detail {

/// One parallel loop as the workers see it: its items are claimed one at a time from `next`.
struct ParallelLoop {
    int count = 0;
    int max_threads = 1;
    std::atomic<int> next{0};
    int threads = 1; ///< the caller and the workers in the loop; guarded by the workers' mutex
    void (*call)(const void* body, int k) = nullptr;
    const void* body = nullptr;
    /// The loop whose item started this one, if any (its items wait for this loop).
    ParallelLoop* parent = nullptr;
    std::exception_ptr error; ///< the first exception of a body; the loop stops at it
    std::mutex error_mutex;

    /// Runs items until none is left.
    void work() noexcept;
};

/// Offers `loop` to the workers (when it may use more than one thread), works on it on the calling
/// thread, and returns once every worker that joined it has left; while it waits for them, the
/// calling thread works on the loops their items started.
void run_parallel_loop(ParallelLoop& loop);

} // namespace detail

/// body(k) for k = 0 .. count - 1 on min(threads, count) threads, the calling thread included
/// (threads <= 0: available_cpus()). The first exception stops the loop and is rethrown here once
/// every thread has left it. Loops may nest (a body may run a loop): a thread waits only for items
/// that other threads are running, never for a worker to become free.
template <typename Body> void parallel_for(int count, int threads, const Body& body) {
    if (count <= 0) return;
    if (threads <= 0) threads = available_cpus();
    detail::ParallelLoop loop;
    loop.count = count;
    loop.max_threads = threads < count ? threads : count;
    loop.call = [](const void* b, int k) { (*static_cast<const Body*>(b))(k); };
    loop.body = &body;
    detail::run_parallel_loop(loop);
    if (loop.error) std::rethrow_exception(loop.error);
}

} // namespace brdf
