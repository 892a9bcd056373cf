// src/brdf/core/serial_blas.cpp: OpenBLAS runs on one thread in every program of the project, and
// the workers it started when it loaded are gone before main. Its own executable (test_serial_blas):
// nothing here calls core/linalg.cpp, which would set one thread by itself, nor starts a thread.

#include <cblas.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <iterator>
#include <thread>

namespace {

TEST(SerialBlas, OpenBlasRunsOnOneThreadAndItsWorkersAreGone) {
    EXPECT_EQ(openblas_get_num_threads(), 1);
    // OpenBLAS starts one worker per further core when it loads: on a machine of one core this
    // cannot tell, elsewhere the process has this thread alone.
    const auto tasks = std::distance(std::filesystem::directory_iterator("/proc/self/task"),
                                     std::filesystem::directory_iterator());
    if (std::thread::hardware_concurrency() > 1) {
        EXPECT_EQ(tasks, 1);
    }
}

} // namespace
