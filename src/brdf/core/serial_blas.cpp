// OpenBLAS on one thread in every program of the project.
//
// OpenBLAS starts a thread per core when it loads, and each spins on sched_yield for about 2^28
// cycles (0.1 s) before it sleeps: after loading, and again after every call it splits over them.
// These programs split their work over the cores themselves (samples, orders, rows of a grid) and
// call BLAS on small matrices (N <= 100 streams) from those threads, so BLAS's threads only take
// cores from ours: on two cores the seed material spent its first 0.1 s with one of them spinning;
// without the spin it takes 0.59 s instead of 0.66 (CPU 0.95 s instead of 1.04), and no command got
// slower (measured when this was added, 2026-12-04).
//
// A constructor of the executable runs after OpenBLAS's (a library's initialisers run before the
// program's) and before main: it sets one thread (openblas_set_num_threads, public API) and stops
// the idle workers already started (blas_thread_shutdown_, which OpenBLAS exports for its fork
// handling; looked up weakly, so a BLAS without it still links and only its first spin remains).
// OpenBLAS starts them again on the next openblas_set_num_threads call (its lazy re-start after a
// fork), so core/linalg.cpp sets the count only where it is not 1 already.
//
// Linked as an object library (brdf_serial_blas) into each executable: from a static library the
// linker would drop an object that nothing refers to.
//
// The kernels OpenBLAS picked. A DYNAMIC_ARCH OpenBLAS chooses its kernels by the CPU's model
// number, and one older than the CPU (Debian 12's 0.3.21 and an Intel Xeon of model 207) falls back
// to its generic Prescott (SSE3) kernels although the CPU has AVX-512: there its dgemm ran at a
// third of the speed, and a gloss finish, whose rough interface kernels are matrix products, took
// 1.20 s instead of 1.08. OpenBLAS reads its choice from OPENBLAS_CORETYPE once, when it loads,
// before anything of ours runs. So the same constructor, finding the fallback on a CPU whose
// features name better kernels (AVX-512: SkylakeX, AVX2 with FMA: Haswell) and no OPENBLAS_CORETYPE
// set, sets it and executes the program again (/proc/self/exe, the same arguments): a few
// milliseconds once, before any thread of ours exists. The variable is also the guard against a
// second round, and a user's own OPENBLAS_CORETYPE (OPENBLAS_CORETYPE=Prescott keeps the fallback)
// is never overridden. Where the execution fails, the program goes on with the fallback.

#include <cblas.h>

#include <strings.h>
#include <unistd.h>

#include <cstdlib>

extern "C" [[gnu::weak]] int blas_thread_shutdown_(void);

namespace {

// The kernels this CPU's features allow where OpenBLAS fell back to Prescott's; nullptr otherwise.
const char* better_kernels() {
    const char* picked = openblas_get_corename();
    if (!picked || strcasecmp(picked, "Prescott") != 0 || std::getenv("OPENBLAS_CORETYPE")) return nullptr;
#if defined(__x86_64__)
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
        __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl"))
        return "SkylakeX";
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return "Haswell";
#endif
    return nullptr;
}

// glibc passes the program's arguments to the executable's constructors.
[[gnu::constructor]] void one_blas_thread(int, char** argv, char**) {
    if (const char* kernels = better_kernels(); kernels && argv && argv[0]) {
        if (setenv("OPENBLAS_CORETYPE", kernels, 0) == 0) execv("/proc/self/exe", argv);
        unsetenv("OPENBLAS_CORETYPE"); // not executed: the process keeps OpenBLAS's kernels as they are
    }
    openblas_set_num_threads(1);
    if (blas_thread_shutdown_) blas_thread_shutdown_();
}

} // namespace
