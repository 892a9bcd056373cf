// src/brdf/core/serial_blas.cpp: OpenBLAS runs on one thread in every program of the project, and
// the workers it started when it loaded are gone before main. Its own executable (test_serial_blas):
// nothing here calls core/linalg.cpp, which would set one thread by itself, nor starts a thread.
// Where OpenBLAS falls back to its generic Prescott kernels on a CPU it does not know, the program
// runs again with the kernels of the CPU's features, unless the user chose them.

#include <cblas.h>
#include <gtest/gtest.h>

#include <strings.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

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

bool has_better_kernels_than_prescott() {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}

// The kernels OpenBLAS reported (OPENBLAS_VERBOSE=2: "Core: NAME" when it loads) while this test
// program ran with `environment` in front, once per start of the program.
std::vector<std::string> cores_reported(const std::string& environment) {
    const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
    const std::string command = "env -u OPENBLAS_CORETYPE OPENBLAS_VERBOSE=2 " + environment + " '" + self +
                                "' --gtest_list_tests 2>&1";
    std::vector<std::string> cores;
    FILE* pipe = popen(command.c_str(), "r");
    if (!pipe) return cores;
    char line[512];
    while (std::fgets(line, sizeof line, pipe)) {
        std::string text(line);
        if (text.rfind("Core: ", 0) == 0) cores.push_back(text.substr(6, text.find_first_of(" \r\n", 6) - 6));
    }
    pclose(pipe);
    return cores;
}

TEST(SerialBlas, ThisProgramRunsWithKernelsForTheCpusFeatures) {
    const char* chosen = std::getenv("OPENBLAS_CORETYPE");
    if (chosen && strcasecmp(chosen, "Prescott") == 0) GTEST_SKIP() << "OPENBLAS_CORETYPE=Prescott chosen";
    if (!has_better_kernels_than_prescott()) GTEST_SKIP() << "no AVX2 with FMA on this CPU";
    EXPECT_STRCASENE(openblas_get_corename(), "Prescott");
}

TEST(SerialBlas, AProgramStartsAgainOnlyFromOpenBlassFallback) {
    const std::vector<std::string> cores = cores_reported("");
    ASSERT_FALSE(cores.empty()) << "OpenBLAS printed no core with OPENBLAS_VERBOSE=2";
    if (strcasecmp(cores.front().c_str(), "Prescott") == 0 && has_better_kernels_than_prescott()) {
        ASSERT_EQ(cores.size(), 2u); // started again once, with the CPU's kernels
        EXPECT_STRCASENE(cores.back().c_str(), "Prescott");
    } else {
        EXPECT_EQ(cores.size(), 1u); // OpenBLAS's own choice stands
    }
    // A user's choice is never overridden, the fallback included.
    const std::vector<std::string> kept = cores_reported("OPENBLAS_CORETYPE=Prescott");
    ASSERT_EQ(kept.size(), 1u);
    EXPECT_STRCASEEQ(kept.front().c_str(), "Prescott");
}

} // namespace
