// The OpenCL per-order solvers (kernels/ambartsumian.cl through rte/cl_solver.h) against their plain
// C++ references (solve_order): every order of isotropic, Rayleigh and Henyey-Greenstein media at
// several albedos and stream counts, for all three methods, in batched launches; each test for both
// kernels (cooperative: kernels/ambartsumian.cl, serial: kernels/ambartsumian_serial.cl).

#include "rte_test_support.h"
#include <test_support.h>

#include <brdf/cl/context.h>
#include <brdf/core/error.h>
#include <brdf/rte/cl_solver.h>
#include <brdf/rte/reflection.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace brdf;
using namespace brdf::rte;

struct Case {
    std::string name;
    std::vector<double> beta;
};

std::vector<Case> phase_functions() {
    return {{"isotropic", {1.0}},
            {"rayleigh", test::rayleigh_beta()},
            {"hg0.5", test::hg_beta(0.5, 200)},
            {"hg0.9", test::hg_beta(0.9, 400)}};
}

const double omegas[] = {0.5, 0.9, 0.99999, 1.0};

struct Labelled {
    std::string label;
    OrderProblem problem;
};

std::vector<Labelled> problems_for(int streams) {
    std::vector<Labelled> out;
    for (const Case& c : phase_functions()) {
        for (double omega : omegas) {
            ReflectionSettings settings;
            settings.streams = streams;
            const StackSetup setup = setup_reflection(Medium{omega, c.beta}, Interface{1.0}, settings);
            for (OrderProblem& p : order_problems(setup))
                out.push_back({c.name + " omega " + std::to_string(omega) + " N " + std::to_string(streams) +
                                   " m " + std::to_string(p.m),
                               std::move(p)});
        }
    }
    return out;
}

// Fixed point at omega -> 1, m = 0 needs tens of thousands of sweeps: cap it (both paths stop at the
// cap, so iterates and counts still compare).
SolveControl control_for(Method method) {
    SolveControl control;
    if (method == Method::FixedPoint) control.max_iterations = 2000;
    return control;
}

double relative_difference(const Matrix& a, const Matrix& reference) {
    const double scale = max_abs(reference);
    const double diff = max_abs_diff(a, reference);
    return scale > 0.0 ? diff / scale : diff;
}

void compare_batch(const std::vector<Labelled>& batch, Method method, ClSolverKernel kernel) {
    const SolveControl control = control_for(method);
    std::vector<OrderProblem> problems;
    for (const Labelled& l : batch) problems.push_back(l.problem);
    const std::vector<OrderSolution> device = solve_orders_opencl(problems, method, control, kernel);
    ASSERT_EQ(device.size(), problems.size());
    for (std::size_t k = 0; k < problems.size(); ++k) {
        SCOPED_TRACE(batch[k].label + " " + std::string(to_string(method)));
        const OrderSolution ref = solve_order(problems[k], method, control);
        ASSERT_EQ(device[k].x.rows(), ref.x.rows());
        ASSERT_EQ(device[k].x.cols(), ref.x.cols());
        EXPECT_LE(relative_difference(device[k].x, ref.x), 1e-11);
        EXPECT_EQ(device[k].iterations, ref.iterations);
        EXPECT_EQ(device[k].converged, ref.converged);
        EXPECT_LE(device[k].residual, std::max(10.0 * ref.residual, 1e-12));
    }
}

class ClSolver : public ::testing::TestWithParam<ClSolverKernel> {
protected:
    void SetUp() override {
        if (!brdf::cl::available()) GTEST_SKIP() << "no OpenCL device with fp64";
    }
    ClSolverKernel kernel() const { return GetParam(); }
};

INSTANTIATE_TEST_SUITE_P(Kernels, ClSolver, ::testing::Values(ClSolverKernel::Cooperative, ClSolverKernel::Serial),
                         [](const ::testing::TestParamInfo<ClSolverKernel>& param_info) {
                             return std::string(to_string(param_info.param));
                         });

TEST_P(ClSolver, DoublingMatchesReference) {
    for (int streams : {8, 16, 32}) compare_batch(problems_for(streams), Method::Doubling, kernel());
}

TEST_P(ClSolver, FastMatchesReference) {
    for (int streams : {8, 16, 32}) compare_batch(problems_for(streams), Method::Fast, kernel());
}

TEST_P(ClSolver, FixedPointMatchesReference) {
    for (int streams : {8, 16, 32}) compare_batch(problems_for(streams), Method::FixedPoint, kernel());
}

TEST_P(ClSolver, BatchMixesStreamCounts) {
    // Different n in one launch, including a split rule and n = 1, interleaved. A short phase series
    // (no delta-M here): the few-stream rules must still integrate it well enough to converge. The
    // serial kernel's products run in row pairs over 32-, 16- and single-column blocks: odd n, n
    // below 16, 16 + 8 (24), 32 + 16 (48) and 32 + 9 (41) each take another path.
    std::vector<Labelled> batch;
    const std::vector<double> beta = test::hg_beta(0.5, 4);
    for (int n : {5, 32, 1, 12, 24, 48, 41}) {
        const Streams s = gauss_streams(n);
        for (int m : {0, 1, 3})
            batch.push_back({"n " + std::to_string(n) + " m " + std::to_string(m),
                             make_order_problem(beta, 0.95, m, s)});
    }
    const Streams split = split_gauss_streams(7, 9, 0.66);
    batch.push_back({"split m 0", make_order_problem(beta, 1.0, 0, split)});
    batch.push_back({"split m 2", make_order_problem(beta, 1.0, 2, split)});
    for (Method method : {Method::Doubling, Method::Fast, Method::FixedPoint}) compare_batch(batch, method, kernel());
}

// The stream counts the service uses at tight tolerances (settings_for: 64 at 1e-6, a cap of 128):
// a few orders of the hardest media (the conservative m = 0, a forward peak, Rayleigh) against the
// reference. Fewer orders than problems_for keeps this well under a minute on PoCL.
std::vector<Labelled> large_problems(int streams) {
    std::vector<Labelled> out;
    const std::vector<std::pair<const char*, std::vector<double>>> media = {{"hg0.9", test::hg_beta(0.9, 400)},
                                                                           {"rayleigh", test::rayleigh_beta()}};
    for (const auto& [name, beta] : media)
        for (double omega : {0.9, 1.0}) {
            ReflectionSettings settings;
            settings.streams = streams;
            const StackSetup setup = setup_reflection(Medium{omega, beta}, Interface{1.0}, settings);
            std::vector<OrderProblem> all = order_problems(setup);
            for (int m : {0, 1, 7})
                if (m < static_cast<int>(all.size()))
                    out.push_back({std::string(name) + " omega " + std::to_string(omega) + " N " +
                                       std::to_string(streams) + " m " + std::to_string(m),
                                   std::move(all[static_cast<std::size_t>(m)])});
        }
    return out;
}

TEST_P(ClSolver, FastMatchesReferenceAt64And128Streams) {
    for (int streams : {64, 128}) compare_batch(large_problems(streams), Method::Fast, kernel());
}

// A batch whose workspace exceeds the launch budget is split (launch_ranges) into several launches;
// every answer equals the one the problem gets solved alone, bit for bit (the same kernel on the
// same data), in the batch's order.
TEST_P(ClSolver, SplitLaunchesGiveTheAnswersOfSolvingEachAlone) {
    std::vector<OrderProblem> problems;
    const std::vector<double> beta = test::hg_beta(0.7, 40);
    for (int n : {6, 12, 9, 16, 4, 12, 20, 8})
        for (int m : {0, 2}) problems.push_back(make_order_problem(beta, m == 0 ? 1.0 : 0.95, m, gauss_streams(n)));
    // Room for about three of the middle-sized problems per launch.
    const ClSolverKernel resolved = resolve_solver_kernel(kernel());
    const std::size_t budget = 3 * opencl_problem_bytes(12, resolved);
    const auto ranges = launch_ranges(problems, budget, resolved);
    ASSERT_GE(ranges.size(), 4u);
    std::size_t next = 0;
    for (const auto& [first, last] : ranges) {
        EXPECT_EQ(first, next);
        EXPECT_LT(first, last);
        std::size_t bytes = 0;
        for (std::size_t k = first; k < last; ++k) bytes += opencl_problem_bytes(problems[k].streams.size(), resolved);
        EXPECT_TRUE(bytes <= budget || last == first + 1) << first << ".." << last;
        if (last < problems.size()) { // greedy: the next problem would not have fitted
            EXPECT_GT(bytes + opencl_problem_bytes(problems[last].streams.size(), resolved), budget);
        }
        next = last;
    }
    EXPECT_EQ(next, problems.size());

    const SolveControl control;
    const std::vector<OrderSolution> split = solve_orders_opencl(problems, Method::Fast, control, kernel(), budget);
    const std::vector<OrderSolution> whole = solve_orders_opencl(problems, Method::Fast, control, kernel());
    ASSERT_EQ(split.size(), problems.size());
    for (std::size_t k = 0; k < problems.size(); ++k) {
        SCOPED_TRACE(k);
        const std::vector<OrderProblem> one{problems[k]};
        const OrderSolution alone = solve_orders_opencl(one, Method::Fast, control, kernel()).at(0);
        EXPECT_EQ(max_abs_diff(split[k].x, alone.x), 0.0);
        EXPECT_EQ(max_abs_diff(whole[k].x, alone.x), 0.0);
        EXPECT_GT(max_abs(alone.x), 0.0);
        EXPECT_EQ(split[k].iterations, alone.iterations);
        EXPECT_EQ(split[k].converged, alone.converged);
    }
}

TEST(ClSolverLaunches, OversizedProblemGetsItsOwnLaunch) {
    std::vector<OrderProblem> problems;
    for (int n : {4, 40, 4, 4}) problems.push_back(make_order_problem(std::vector<double>{1.0}, 0.5, 0, gauss_streams(n)));
    const std::vector<std::pair<std::size_t, std::size_t>> expected{{0, 1}, {1, 2}, {2, 4}};
    for (ClSolverKernel k : {ClSolverKernel::Cooperative, ClSolverKernel::Serial}) {
        SCOPED_TRACE(to_string(k));
        EXPECT_EQ(launch_ranges(problems, 2 * opencl_problem_bytes(4, k), k), expected);
        EXPECT_TRUE(launch_ranges({}, 1, k).empty());
    }
    EXPECT_EQ(opencl_workspace_bytes(10), 16u * 100u * sizeof(double));
    EXPECT_THROW(launch_ranges(problems, 1, ClSolverKernel::Automatic), InputError);
}

// What a launch holds per problem: the cooperative kernel a workspace per problem (16 n^2 doubles),
// the serial one the problem's input and output (2n + 3n^2 doubles), its workspace being per
// work-item. A budget that holds the serial inputs of a gloss finish's batch in one launch splits
// the cooperative one.
TEST(ClSolverLaunches, SerialLaunchesCountInputAndOutput) {
    EXPECT_EQ(opencl_problem_bytes(10, ClSolverKernel::Cooperative), 16u * 100u * sizeof(double));
    EXPECT_EQ(opencl_problem_bytes(10, ClSolverKernel::Serial), (20u + 300u) * sizeof(double));
    EXPECT_THROW(opencl_problem_bytes(10, ClSolverKernel::Automatic), InputError);
    std::vector<OrderProblem> problems;
    for (int k = 0; k < 40; ++k) problems.push_back(make_order_problem(std::vector<double>{1.0}, 0.5, 0, gauss_streams(48)));
    const std::size_t budget = 40 * opencl_problem_bytes(48, ClSolverKernel::Serial);
    EXPECT_EQ(launch_ranges(problems, budget, ClSolverKernel::Serial).size(), 1u);
    EXPECT_GT(launch_ranges(problems, budget, ClSolverKernel::Cooperative).size(), 1u);
}

TEST_P(ClSolver, EmptyBatch) {
    EXPECT_TRUE(solve_orders_opencl({}, Method::Fast, {}, kernel()).empty());
}

TEST_P(ClSolver, NonFiniteInputFailsCleanly) {
    const Streams s = gauss_streams(16);
    std::vector<OrderProblem> problems;
    for (int m = 0; m < 3; ++m) problems.push_back(make_order_problem(test::hg_beta(0.5, 40), 0.9, m, s));
    problems[1].p_plus(3, 5) = std::numeric_limits<double>::quiet_NaN();
    for (Method method : {Method::Doubling, Method::Fast, Method::FixedPoint}) {
        SCOPED_TRACE(std::string(to_string(method)));
        // The reference fails too.
        EXPECT_THROW(solve_order(problems[1], method), NumericalError);
        try {
            solve_orders_opencl(problems, method, {}, kernel());
            ADD_FAILURE() << "no exception";
        } catch (const Error& e) {
            EXPECT_TRUE(e.kind() == ErrorKind::Numerical || e.kind() == ErrorKind::Device) << e.what();
            EXPECT_NE(std::string(e.what()).find("order 1"), std::string::npos) << e.what();
        }
    }
}

TEST_P(ClSolver, NonFinitePivotFailsCleanly) {
    // An infinite P+ entry makes a diagonal entry of D_g infinite: the first LU of the doubling's
    // set-up meets a non-finite pivot, in the reference as on the device.
    const Streams s = gauss_streams(8);
    OrderProblem p = make_order_problem(std::vector<double>{1.0}, 0.9, 0, s);
    p.p_plus(0, 0) = std::numeric_limits<double>::infinity();
    EXPECT_THROW(solve_order(p, Method::Doubling), NumericalError);
    std::vector<OrderProblem> problems{p};
    try {
        solve_orders_opencl(problems, Method::Doubling, {}, kernel());
        ADD_FAILURE() << "no exception";
    } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::Numerical) << e.what();
        EXPECT_NE(std::string(e.what()).find("order 0"), std::string::npos) << e.what();
    }
}

TEST_P(ClSolver, RefusesTooManyStreams) {
    std::vector<OrderProblem> problems{make_order_problem(std::vector<double>{1.0}, 0.5, 0, gauss_streams(257))};
    EXPECT_THROW(solve_orders_opencl(problems, Method::Doubling, {}, kernel()), InputError);
}

// The automatic choice: BRDF_OPENCL_KERNEL overrides, otherwise the device type decides.
TEST(ClSolverKernelChoice, EnvironmentOverridesDeviceType) {
    if (!brdf::cl::available()) GTEST_SKIP() << "no OpenCL device with fp64";
    EXPECT_EQ(resolve_solver_kernel(ClSolverKernel::Serial), ClSolverKernel::Serial);
    EXPECT_EQ(resolve_solver_kernel(ClSolverKernel::Cooperative), ClSolverKernel::Cooperative);
    {
        const brdf::test::ScopedEnv serial("BRDF_OPENCL_KERNEL", "serial");
        EXPECT_EQ(resolve_solver_kernel(), ClSolverKernel::Serial);
    }
    {
        const brdf::test::ScopedEnv cooperative("BRDF_OPENCL_KERNEL", "cooperative");
        EXPECT_EQ(resolve_solver_kernel(), ClSolverKernel::Cooperative);
    }
    {
        const brdf::test::ScopedEnv gpu("BRDF_OPENCL_KERNEL", "gpu");
        EXPECT_THROW(resolve_solver_kernel(), InputError);
    }
    const brdf::test::ScopedEnv unset("BRDF_OPENCL_KERNEL", nullptr);
    const ClSolverKernel automatic = resolve_solver_kernel();
    EXPECT_NE(automatic, ClSolverKernel::Automatic);
    const std::string info = brdf::cl::Context::shared()->info().name;
    cl_device_type type = 0;
    brdf::cl::Context::shared()->device().getInfo(CL_DEVICE_TYPE, &type);
    EXPECT_EQ(automatic, (type & CL_DEVICE_TYPE_CPU) ? ClSolverKernel::Serial : ClSolverKernel::Cooperative) << info;
}

} // namespace
