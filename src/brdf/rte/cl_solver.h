#pragma once
// The OpenCL side of the per-order solvers: a batch of order problems in one launch. Two kernels with
// the same buffers: kernels/ambartsumian.cl (cooperative: one work-group per problem, for GPUs) and
// kernels/ambartsumian_serial.cl (serial: one work-item per problem, for CPU devices such as PoCL,
// where it is several times faster). The plain C++ references are solve_order and friends
// (order_solver.h); both kernels follow them operation for operation.

#include <brdf/rte/order_solver.h>

#include <cstddef>
#include <span>
#include <utility>
#include <string_view>
#include <vector>

namespace brdf::rte {

/// Largest number of streams the OpenCL solver accepts (its pivot indices live in local memory).
inline constexpr int max_opencl_streams = 256;

/// Which kernel solve_orders_opencl runs.
enum class ClSolverKernel {
    Automatic,   ///< $BRDF_OPENCL_KERNEL if set, else Serial on a CL_DEVICE_TYPE_CPU device, else Cooperative
    Cooperative, ///< kernels/ambartsumian.cl: one work-group per problem
    Serial,      ///< kernels/ambartsumian_serial.cl: one work-item per problem, local size 1
};
std::string_view to_string(ClSolverKernel kernel);

/// The kernel Automatic resolves to on the shared context (brdf::cl::Context::shared()): env
/// BRDF_OPENCL_KERNEL=cooperative|serial overrides the device-type rule. Throws InputError for
/// another value of the variable, DeviceError without a device. Never returns Automatic.
ClSolverKernel resolve_solver_kernel(ClSolverKernel requested = ClSolverKernel::Automatic);

/// Solves a batch of order problems (many orders, many media) on the OpenCL device in one launch:
/// one work-group (cooperative) or one work-item (serial) per problem, the same algorithms as solve_order (FixedPoint, Doubling, Fast), results
/// equal to the C++ reference to ~1e-12 relative. Throws DeviceError on device failure; NumericalError
/// (naming the order m and omega) when a problem diverges or an LU pivot is zero, as the reference does.
/// InputError for a problem with more than max_opencl_streams streams or inconsistent sizes.
/// Uses brdf::cl::Context::shared(); very large batches are split into several launches
/// (launch_ranges) so that what a launch holds fits `workspace_budget_bytes`, or when 0 the device's
/// CL_DEVICE_MAX_MEM_ALLOC_SIZE capped at 1 GiB (128 MiB on a CPU device, where it is the process's
/// own memory).
std::vector<OrderSolution> solve_orders_opencl(std::span<const OrderProblem> problems, Method method,
                                               const SolveControl& control,
                                               ClSolverKernel kernel = ClSolverKernel::Automatic,
                                               std::size_t workspace_budget_bytes = 0);

/// Bytes of kernel workspace one problem of n streams needs (AMB_WORKSPACE_MATRICES n^2 doubles).
std::size_t opencl_workspace_bytes(int n);

/// Bytes a launch of `kernel` (Cooperative or Serial) holds per problem of n streams: the
/// cooperative kernel its workspace (opencl_workspace_bytes: each work-group has its own); the
/// serial one its input and output (2n + 3n^2 doubles), its few work-items sharing workspace slots.
/// Throws InputError for Automatic (resolve it first: resolve_solver_kernel).
std::size_t opencl_problem_bytes(int n, ClSolverKernel kernel);

/// The launches a batch is split into: consecutive [first, last) ranges covering every problem in
/// order, each as long as its problems' opencl_problem_bytes stay within `budget_bytes` (a problem
/// larger than the budget alone gets a launch of its own).
std::vector<std::pair<std::size_t, std::size_t>> launch_ranges(std::span<const OrderProblem> problems,
                                                               std::size_t budget_bytes, ClSolverKernel kernel);

} // namespace brdf::rte
