// OpenBLAS on one thread in every program of the project.
//
// OpenBLAS starts a thread per core when it loads, and each spins on sched_yield for about 2^28
// cycles (0.1 s) before it sleeps: after loading, and again after every call it splits over them.
// These programs split their work over the cores themselves (samples, orders, rows of a grid) and
// call BLAS on small matrices (N <= 100 streams) from those threads, so BLAS's threads only take
// cores from ours: on two cores the seed material spent its first 0.1 s with one of them spinning;
// without the spin it takes 0.59 s instead of 0.66 (CPU 0.95 s instead of 1.04), and no command got
// slower (README, "Speed").
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

#include <cblas.h>

extern "C" [[gnu::weak]] int blas_thread_shutdown_(void);

namespace {

[[gnu::constructor]] void one_blas_thread() {
    openblas_set_num_threads(1);
    if (blas_thread_shutdown_) blas_thread_shutdown_();
}

} // namespace
