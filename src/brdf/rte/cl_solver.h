#pragma once
// The OpenCL side of the per-order solvers (kernels/ambartsumian.cl): a batch of order problems in one
// launch, one work-group per problem. The plain C++ references are solve_order and friends
// (order_solver.h); the kernel follows them operation for operation.

#include <brdf/rte/order_solver.h>

#include <span>
#include <vector>

namespace brdf::rte {

/// Largest number of streams the OpenCL solver accepts (its pivot indices live in local memory).
inline constexpr int max_opencl_streams = 256;

/// Solves a batch of order problems (many orders, many media) on the OpenCL device in one launch:
/// one work-group per problem, the same algorithms as solve_order (FixedPoint, Doubling, Fast), results
/// equal to the C++ reference to ~1e-12 relative. Throws DeviceError on device failure; NumericalError
/// (naming the order m and omega) when a problem diverges or an LU pivot is zero, as the reference does.
/// InputError for a problem with more than max_opencl_streams streams or inconsistent sizes.
/// Uses brdf::cl::Context::shared(); very large batches are split into several launches so that the
/// workspace (16 n^2 doubles per problem) fits the device's allocation limit.
std::vector<OrderSolution> solve_orders_opencl(std::span<const OrderProblem> problems, Method method,
                                               const SolveControl& control);

} // namespace brdf::rte
