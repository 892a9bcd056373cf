// Host side of kernels/ambartsumian.cl (cooperative) and kernels/ambartsumian_serial.cl (serial): packs
// a batch of order problems into one input buffer, one task array, one output and one workspace
// buffer, runs one work-group (cooperative) or one work-item (serial) per problem and unpacks the
// solutions. The residual is computed here with the reference's riccati_residual, so an OrderSolution
// from this path is filled exactly like one from solve_order.

#include <brdf/rte/cl_solver.h>

#include <brdf/cl/context.h>
#include <brdf/core/error.h>
#include <brdf/core/threads.h>
#include <brdf/core/unwritten_allocator.h>
#include <brdf/core/log.h>

#include <shared/ambartsumian_layout.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

namespace brdf::rte {

static_assert(sizeof(AmbTask) == 72);
static_assert(offsetof(AmbTask, input_offset) == 0);
static_assert(offsetof(AmbTask, output_offset) == 8);
static_assert(offsetof(AmbTask, workspace_offset) == 16);
static_assert(offsetof(AmbTask, omega) == 24);
static_assert(offsetof(AmbTask, tolerance) == 32);
static_assert(offsetof(AmbTask, gamma) == 40);
static_assert(offsetof(AmbTask, n) == 48);
static_assert(offsetof(AmbTask, m) == 52);
static_assert(offsetof(AmbTask, method) == 56);
static_assert(offsetof(AmbTask, max_iterations) == 60);
static_assert(offsetof(AmbTask, fast_sweeps) == 64);
static_assert(offsetof(AmbTask, doubling_first) == 68);
static_assert(sizeof(AmbStatus) == 16);
static_assert(offsetof(AmbStatus, iterations) == 0);
static_assert(offsetof(AmbStatus, converged) == 4);
static_assert(offsetof(AmbStatus, error) == 8);
static_assert(offsetof(AmbStatus, detail) == 12);
static_assert(static_cast<int>(Method::FixedPoint) == AMB_FIXED_POINT);
static_assert(static_cast<int>(Method::Doubling) == AMB_DOUBLING);
static_assert(static_cast<int>(Method::Fast) == AMB_FAST);
static_assert(max_opencl_streams == AMB_MAX_N);

namespace {

constexpr std::size_t preferred_local_size = 64;
// The cooperative kernel's local reduction arrays hold AMB_MAX_WG partials, one per work-item; the
// local size chosen below is clamped to it.
static_assert(preferred_local_size <= AMB_MAX_WG);
// The kernels' workspace slots 0..14 (ambartsumian.cl, ambartsumian_serial.cl) fit what is allocated.
static_assert(AMB_WORKSPACE_MATRICES >= 15);

std::size_t floor_power_of_two(std::size_t v) {
    std::size_t p = 1;
    while (p * 2 <= v) p *= 2;
    return p;
}

std::size_t input_doubles(int n) { return 2 * static_cast<std::size_t>(n) + 2 * static_cast<std::size_t>(n) * n; }
std::size_t workspace_doubles(int n) { return AMB_WORKSPACE_MATRICES * static_cast<std::size_t>(n) * n; }

void validate(const OrderProblem& p, std::size_t index) {
    const int n = p.streams.size();
    if (n < 1 || n > max_opencl_streams)
        throw InputError(cat("OpenCL order solver: problem ", index, " (order ", p.m, ") has ", n,
                             " streams; the kernel takes 1 to ", max_opencl_streams));
    if (static_cast<int>(p.streams.w.size()) != n || p.p_plus.rows() != n || p.p_plus.cols() != n ||
        p.p_minus.rows() != n || p.p_minus.cols() != n)
        throw InputError(cat("OpenCL order solver: problem ", index, " (order ", p.m,
                             ") has inconsistent sizes (", n, " streams)"));
}

// A buffer holding `data`: a copy, or (`in_place`) `data` itself, which must then outlive the
// launch.
template <typename Vector>
::cl::Buffer make_buffer(::cl::Context& context, cl_mem_flags flags, Vector& data, const char* what,
                         bool in_place = false) {
    cl_int err = CL_SUCCESS;
    const cl_mem_flags source = in_place ? CL_MEM_USE_HOST_PTR : CL_MEM_COPY_HOST_PTR;
    ::cl::Buffer buffer(context, flags | (data.empty() ? 0 : source),
                        std::max<std::size_t>(1, data.size()) * sizeof(typename Vector::value_type),
                        data.empty() ? nullptr : data.data(), &err);
    brdf::cl::check(err, cat("OpenCL order solver: create buffer ", what));
    return buffer;
}

// One launch over problems[first, last).
// `serial`: the serial kernel, whose work-items take tasks from a counter, each in its own
// workspace slot (kernels/ambartsumian_serial.cl); otherwise one slot per task.
// `host_memory`: the device works in the host's memory (a CPU device), so the input and output
// buffers are the host's vectors themselves rather than copies (a gloss finish's batch at 48 streams
// had copied 46 MB in and 22 MB out).
void solve_range(brdf::cl::Context& ctx, ::cl::Kernel& kernel, bool serial, bool host_memory,
                 std::size_t local_size, std::span<const OrderProblem> problems, std::size_t first,
                 std::size_t last, Method method, const SolveControl& control, std::vector<OrderSolution>& out) {
    const std::size_t count = last - first;
    std::vector<AmbTask> tasks(count);
    std::size_t in_size = 0, out_size = 0, ws_size = 0;
    for (std::size_t k = 0; k < count; ++k) {
        const OrderProblem& p = problems[first + k];
        const int n = p.streams.size();
        AmbTask& t = tasks[k];
        t.input_offset = static_cast<brdf_i64>(in_size);
        t.output_offset = static_cast<brdf_i64>(out_size);
        t.workspace_offset = static_cast<brdf_i64>(ws_size);
        t.omega = p.omega;
        t.tolerance = control.tolerance;
        t.gamma = control.gamma > 0.0 ? control.gamma : doubling_gamma(p);
        t.n = n;
        t.m = p.m;
        t.method = static_cast<brdf_i32>(method);
        t.max_iterations = control.max_iterations;
        t.fast_sweeps = control.fast_sweeps;
        t.doubling_first = amb_fast_starts_with_doubling(p.order_albedo);
        in_size += input_doubles(n);
        out_size += static_cast<std::size_t>(n) * n;
        ws_size += workspace_doubles(n);
    }
    // Unwritten until packed, on every core: tens of MB of fresh pages for a rough finish's batch
    // (zeroed first, on one core, they had kept the other idle for some 20-40 ms of a gloss).
    std::vector<double, UnwrittenAllocator<double>> input(in_size);
    parallel_for(static_cast<int>(count), available_cpus(), [&](int k) {
        const OrderProblem& p = problems[first + static_cast<std::size_t>(k)];
        double* dst = input.data() + tasks[static_cast<std::size_t>(k)].input_offset;
        dst = std::copy(p.streams.mu.begin(), p.streams.mu.end(), dst);
        dst = std::copy(p.streams.w.begin(), p.streams.w.end(), dst);
        dst = std::copy(p.p_plus.data().begin(), p.p_plus.data().end(), dst);
        std::copy(p.p_minus.data().begin(), p.p_minus.data().end(), dst);
    });

    cl_int err = CL_SUCCESS;
    ::cl::Context& context = ctx.context();
    ::cl::Buffer task_buf = make_buffer(context, CL_MEM_READ_ONLY, tasks, "tasks");
    ::cl::Buffer in_buf = make_buffer(context, CL_MEM_READ_ONLY, input, "input", host_memory);
    std::vector<double, UnwrittenAllocator<double>> output(out_size); // the device writes every entry
    ::cl::Buffer out_buf(context, CL_MEM_WRITE_ONLY | (host_memory ? CL_MEM_USE_HOST_PTR : 0),
                         out_size * sizeof(double), host_memory ? output.data() : nullptr, &err);
    brdf::cl::check(err, "OpenCL order solver: create buffer output");
    // The serial kernel: about one work-item per core (a few more than cores would only queue), each
    // with a slot the size of the largest task's workspace.
    std::size_t work_items = count * local_size, slot_doubles = 0;
    if (serial) {
        for (const AmbTask& t : tasks) slot_doubles = std::max(slot_doubles, workspace_doubles(t.n));
        work_items = std::min<std::size_t>(count, std::max<cl_uint>(1, ctx.info().compute_units));
        ws_size = work_items * slot_doubles;
    }
    ::cl::Buffer ws_buf(context, CL_MEM_READ_WRITE, ws_size * sizeof(double), nullptr, &err);
    brdf::cl::check(err, "OpenCL order solver: create buffer workspace");
    ::cl::Buffer status_buf(context, CL_MEM_WRITE_ONLY, count * sizeof(AmbStatus), nullptr, &err);
    brdf::cl::check(err, "OpenCL order solver: create buffer status");

    brdf::cl::check(kernel.setArg(0, task_buf), "OpenCL order solver: set argument tasks");
    brdf::cl::check(kernel.setArg(1, in_buf), "OpenCL order solver: set argument input");
    brdf::cl::check(kernel.setArg(2, out_buf), "OpenCL order solver: set argument output");
    brdf::cl::check(kernel.setArg(3, ws_buf), "OpenCL order solver: set argument workspace");
    brdf::cl::check(kernel.setArg(4, status_buf), "OpenCL order solver: set argument status");
    std::vector<cl_int> next{0};
    ::cl::Buffer next_buf;
    if (serial) {
        next_buf = make_buffer(context, CL_MEM_READ_WRITE, next, "task counter");
        brdf::cl::check(kernel.setArg(5, next_buf), "OpenCL order solver: set argument task counter");
        brdf::cl::check(kernel.setArg(6, static_cast<cl_int>(count)), "OpenCL order solver: set argument count");
        brdf::cl::check(kernel.setArg(7, static_cast<cl_long>(slot_doubles)), "OpenCL order solver: set argument slot");
    }

    ::cl::CommandQueue& queue = ctx.queue();
    brdf::cl::check(queue.enqueueNDRangeKernel(kernel, ::cl::NullRange, ::cl::NDRange(work_items),
                                               ::cl::NDRange(local_size)),
                    "OpenCL order solver: run the order kernel");
    std::vector<AmbStatus> status(count);
    if (host_memory) {
        // Mapping makes `output` hold the results (the pointer returned is its own).
        void* mapped = queue.enqueueMapBuffer(out_buf, CL_TRUE, CL_MAP_READ, 0, out_size * sizeof(double), nullptr,
                                              nullptr, &err);
        brdf::cl::check(err, "OpenCL order solver: map output");
        if (mapped != output.data())
            throw InternalError("OpenCL order solver: the device mapped the output elsewhere than the host's");
        brdf::cl::check(queue.enqueueUnmapMemObject(out_buf, mapped), "OpenCL order solver: unmap output");
    } else {
        brdf::cl::check(queue.enqueueReadBuffer(out_buf, CL_FALSE, 0, out_size * sizeof(double), output.data()),
                        "OpenCL order solver: read output");
    }
    brdf::cl::check(queue.enqueueReadBuffer(status_buf, CL_FALSE, 0, count * sizeof(AmbStatus), status.data()),
                    "OpenCL order solver: read status");
    brdf::cl::check(queue.finish(), "OpenCL order solver: finish");

    for (std::size_t k = 0; k < count; ++k) {
        const OrderProblem& p = problems[first + k];
        const AmbStatus& st = status[k];
        switch (st.error) {
        case AMB_OK: break;
        case AMB_FIXED_POINT_DIVERGED:
            throw NumericalError(cat("fixed-point iteration diverged at order ", p.m, ", omega ", p.omega,
                                     " (OpenCL)"));
        case AMB_DOUBLING_DIVERGED:
            throw NumericalError(cat("doubling diverged at order ", p.m, ", omega ", p.omega, " (OpenCL)"));
        case AMB_SINGULAR:
            throw NumericalError(cat("LU: matrix is singular or not finite at column ", st.detail, " of ",
                                     p.streams.size(), " (order ", p.m, ", omega ", p.omega, ", OpenCL)"));
        default:
            throw DeviceError(cat("OpenCL order solver: unknown status ", st.error, " for order ", p.m));
        }
    }
    // The solutions and their residuals (a few n^3 each, on the host): one problem per core.
    parallel_for(static_cast<int>(count), available_cpus(), [&](int k) {
        const OrderProblem& p = problems[first + k];
        const int n = p.streams.size();
        OrderSolution s;
        s.x = Matrix(n, n);
        std::copy_n(output.begin() + tasks[k].output_offset, static_cast<std::size_t>(n) * n, s.x.data().begin());
        s.iterations = status[k].iterations;
        s.converged = status[k].converged != 0;
        s.residual = riccati_residual(riccati_matrices(p), s.x);
        out[first + k] = std::move(s);
    });
}

ClSolverKernel resolve_on(brdf::cl::Context& ctx, ClSolverKernel requested) {
    if (requested != ClSolverKernel::Automatic) return requested;
    if (const char* env = std::getenv("BRDF_OPENCL_KERNEL"); env != nullptr && *env != '\0') {
        const std::string v(env);
        if (v == "cooperative") return ClSolverKernel::Cooperative;
        if (v == "serial") return ClSolverKernel::Serial;
        throw InputError(cat("BRDF_OPENCL_KERNEL='", v, "': expected 'cooperative' or 'serial'"));
    }
    return ctx.info().cpu ? ClSolverKernel::Serial : ClSolverKernel::Cooperative;
}

} // namespace

std::string_view to_string(ClSolverKernel kernel) {
    switch (kernel) {
    case ClSolverKernel::Automatic: return "automatic";
    case ClSolverKernel::Cooperative: return "cooperative";
    case ClSolverKernel::Serial: return "serial";
    }
    return "?";
}

ClSolverKernel resolve_solver_kernel(ClSolverKernel requested) {
    if (requested != ClSolverKernel::Automatic) return requested;
    return resolve_on(*brdf::cl::Context::shared(), requested);
}

std::size_t opencl_workspace_bytes(int n) { return workspace_doubles(n) * sizeof(double); }

std::size_t opencl_problem_bytes(int n, ClSolverKernel kernel) {
    switch (kernel) {
    case ClSolverKernel::Cooperative: return opencl_workspace_bytes(n);
    case ClSolverKernel::Serial: return (input_doubles(n) + static_cast<std::size_t>(n) * n) * sizeof(double);
    case ClSolverKernel::Automatic: break;
    }
    throw InputError("OpenCL order solver: launch sizes need a resolved kernel (cooperative or serial)");
}

std::vector<std::pair<std::size_t, std::size_t>> launch_ranges(std::span<const OrderProblem> problems,
                                                               std::size_t budget_bytes, ClSolverKernel kernel) {
    std::vector<std::pair<std::size_t, std::size_t>> ranges;
    std::size_t first = 0;
    while (first < problems.size()) {
        std::size_t last = first, bytes = 0;
        while (last < problems.size()) {
            const std::size_t b = opencl_problem_bytes(problems[last].streams.size(), kernel);
            if (last > first && bytes + b > budget_bytes) break;
            bytes += b;
            ++last;
        }
        ranges.emplace_back(first, last);
        first = last;
    }
    return ranges;
}

std::vector<OrderSolution> solve_orders_opencl(std::span<const OrderProblem> problems, Method method,
                                               const SolveControl& control, ClSolverKernel which,
                                               std::size_t workspace_budget_bytes) {
    if (method != Method::FixedPoint && method != Method::Doubling && method != Method::Fast)
        throw InputError("unknown solver method");
    for (std::size_t k = 0; k < problems.size(); ++k) validate(problems[k], k);
    std::vector<OrderSolution> out(problems.size());
    if (problems.empty()) return out;

    auto ctx = brdf::cl::Context::shared();
    const bool serial = resolve_on(*ctx, which) == ClSolverKernel::Serial;
    const char* const program_name = serial ? "ambartsumian_serial" : "ambartsumian";
    const char* const kernel_name = serial ? "ambartsumian_solve_serial" : "ambartsumian_solve";
    // The serial kernel's products without their 32-column blocks where the device's native double
    // vectors are narrower than eight (kernels/ambartsumian_serial.cl, MAT_MUL_WIDE): the same sums.
    cl_uint native_doubles = 0;
    if (serial) ctx->device().getInfo(CL_DEVICE_NATIVE_VECTOR_WIDTH_DOUBLE, &native_doubles);
    const ::cl::Program program =
        ctx->program(program_name, serial && native_doubles < 8 ? "-DMAT_MUL_WIDE=0" : "");
    cl_int err = CL_SUCCESS;
    ::cl::Kernel kernel(program, kernel_name, &err);
    brdf::cl::check(err, cat("OpenCL order solver: create kernel ", kernel_name));
    std::size_t local_size = 1; // serial: one work-item per problem, each its own work-group
    if (!serial) {
        std::size_t kernel_max = 0;
        brdf::cl::check(kernel.getWorkGroupInfo(ctx->device(), CL_KERNEL_WORK_GROUP_SIZE, &kernel_max),
                        "OpenCL order solver: query kernel work-group size");
        local_size = floor_power_of_two(
            std::max<std::size_t>(1, std::min({preferred_local_size, ctx->info().max_work_group_size, kernel_max,
                                               static_cast<std::size_t>(AMB_MAX_WG)})));
    }
    cl_ulong max_alloc = 0;
    brdf::cl::check(ctx->device().getInfo(CL_DEVICE_MAX_MEM_ALLOC_SIZE, &max_alloc),
                    "OpenCL order solver: query max allocation size");
    // A GPU gets up to 1 GiB of workspace per launch, for enough work-groups to fill it. On a CPU
    // device (PoCL: host memory) a few hundred problems per launch keep every core busy, and 128
    // MiB caps the process's peak: the seed at "reference" (2255 problems of 64 streams) held
    // 916 MB in one launch.
    const std::size_t cap = ctx->info().cpu ? std::size_t{128} << 20 : std::size_t{1} << 30;
    const std::size_t budget = workspace_budget_bytes > 0
                                   ? workspace_budget_bytes
                                   : std::min<std::size_t>(static_cast<std::size_t>(max_alloc), cap);
    // Launches that fit the budget. The serial kernel's workspace is a slot per work-item, so its
    // launches count the problems' inputs and outputs: a gloss finish's batch (1,211 problems of 48
    // streams) goes in one launch rather than two, each with its input packed beforehand and its
    // residuals checked after while the device stood idle.
    for (const auto& [first, last] :
         launch_ranges(problems, budget, serial ? ClSolverKernel::Serial : ClSolverKernel::Cooperative))
        solve_range(*ctx, kernel, serial, ctx->info().cpu, local_size, problems, first, last,
                    method, control, out);
    return out;
}

} // namespace brdf::rte
