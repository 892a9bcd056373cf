#include <brdf/core/threads.h>

#include <algorithm>
#include <condition_variable>
#include <system_error>
#include <thread>
#include <vector>

#include <sched.h>

namespace brdf {

int available_cpus() {
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof(set), &set) == 0) return std::max(1, CPU_COUNT(&set));
    return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

namespace detail {

namespace {
// The loop whose item this thread is running (nullptr outside any): a loop started in that item
// records it as its parent. A plain pointer: nothing to construct or destroy per thread.
thread_local ParallelLoop* current_loop = nullptr;
} // namespace

void ParallelLoop::work() noexcept {
    ParallelLoop* const outer = current_loop;
    current_loop = this;
    for (int k = next++; k < count; k = next++) {
        try {
            call(body, k);
        } catch (...) {
            std::lock_guard lock(error_mutex);
            if (!error) error = std::current_exception();
            next = count;
        }
    }
    current_loop = outer;
}

namespace {

// The process's worker threads and the loops they may join. Never destroyed: the workers wait for
// loops until the process ends (a loop run by a static destructor still finds them).
class Workers {
  public:
    static Workers& shared() {
        static Workers* const workers = new Workers(available_cpus() - 1);
        return *workers;
    }

    void offer(ParallelLoop& loop) {
        {
            std::lock_guard lock(m_mutex);
            m_loops.push_back(&loop);
        }
        m_wake.notify_all();
        if (loop.parent) m_left.notify_all(); // a caller waiting in withdraw may help with it
    }

    int size() const { return m_size; }

    // Takes `loop` off the offers and waits until the workers in it have left, meanwhile running
    // items of the loops that its items started. A worker in `loop` may be inside an item that
    // runs a loop of its own (the stream check's two probe stacks, each computing its rough
    // interface kernels over the cores): the caller, done with its share, helps with that loop
    // rather than leave its core idle until the worker is done (~30 ms of a gloss finish's check).
    // Only those: another caller's loop could hold it far longer than `loop` needs.
    void withdraw(ParallelLoop& loop) {
        std::unique_lock lock(m_mutex);
        m_loops.erase(std::find(m_loops.begin(), m_loops.end(), &loop));
        for (;;) {
            ParallelLoop* nested = nullptr;
            m_left.wait(lock, [&] { return loop.threads == 1 || (nested = joinable(&loop)) != nullptr; });
            if (loop.threads == 1) return;
            run(*nested, lock);
        }
    }

  private:
    explicit Workers(int count) {
        for (int t = 0; t < count; ++t) {
            try {
                std::thread([this] { serve(); }).detach();
                ++m_size;
            } catch (const std::system_error&) {
                break; // fewer workers: the callers run the items themselves
            }
        }
    }

    // A loop with items left and room for one more thread, or nullptr; with `within`, only a loop
    // started (at any depth) by an item of `within`.
    ParallelLoop* joinable(const ParallelLoop* within = nullptr) const {
        for (ParallelLoop* loop : m_loops) {
            if (!(loop->threads < loop->max_threads && loop->next.load() < loop->count)) continue;
            if (!within) return loop;
            for (const ParallelLoop* p = loop->parent; p; p = p->parent)
                if (p == within) return loop;
        }
        return nullptr;
    }

    // Joins `loop` until its items are taken; `lock` holds m_mutex on entry and on return.
    void run(ParallelLoop& loop, std::unique_lock<std::mutex>& lock) {
        ++loop.threads;
        lock.unlock();
        loop.work();
        lock.lock();
        --loop.threads;
        m_left.notify_all();
    }
    void serve() {
        std::unique_lock lock(m_mutex);
        for (;;) {
            ParallelLoop* loop = nullptr;
            m_wake.wait(lock, [&] { return (loop = joinable()) != nullptr; });
            run(*loop, lock);
        }
    }

    std::mutex m_mutex;
    std::condition_variable m_wake; // a loop was offered
    std::condition_variable m_left; // a worker left a loop
    std::vector<ParallelLoop*> m_loops;
    int m_size = 0;
};

} // namespace

void run_parallel_loop(ParallelLoop& loop) {
    loop.parent = current_loop;
    if (loop.max_threads <= 1) {
        loop.work();
        return;
    }
    Workers& workers = Workers::shared();
    // A loop asking for more threads than the workers and the caller (compute --jobs above the
    // CPUs: materials that wait on their writes) gets the rest started for it alone.
    std::vector<std::thread> extra;
    extra.reserve(static_cast<std::size_t>(std::max(0, loop.max_threads - 1 - workers.size())));
    for (int t = workers.size() + 1; t < loop.max_threads; ++t) {
        try {
            extra.emplace_back([&loop] { loop.work(); });
        } catch (const std::system_error&) {
            break;
        }
    }
    workers.offer(loop);
    loop.work();
    workers.withdraw(loop);
    for (std::thread& t : extra) t.join();
}

} // namespace detail

void start_worker_threads() noexcept {
    try {
        detail::Workers::shared();
    } catch (...) {
    }
}

} // namespace brdf
