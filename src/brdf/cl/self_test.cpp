// brdf::cl::self_test(): runs kernels/selftest.cl and compares it with the same arithmetic in C++.

#include <brdf/cl/context.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <shared/selftest_layout.h>

#include <cmath>
#include <cstddef>
#include <vector>

namespace brdf::cl {

// The layout the device must see too (the selftest_layout kernel reports its own view).
static_assert(sizeof(SelftestParams) == 24);
static_assert(offsetof(SelftestParams, scale) == 0);
static_assert(offsetof(SelftestParams, offset) == 8);
static_assert(offsetof(SelftestParams, count) == 16);
static_assert(offsetof(SelftestParams, flags) == 20);

namespace {

// 1/3 and friends are not representable in float: a device that silently ran single precision would
// miss by ~1e-8 relative, where double precision agrees to a few ulp (the device may contract a*x+y
// into an fma, so bitwise equality is not required).
constexpr double tolerance = 1e-14;

void expect_near(const Context& ctx, const char* what, std::size_t i, double value,
                 double reference) {
    const double scale = reference == 0.0 ? 1.0 : std::abs(reference);
    if (!(std::abs(value - reference) <= tolerance * scale))
        throw DeviceError(cat("OpenCL self-test failed on '", ctx.info().name, "': ", what, "[", i,
                              "] = ", value, ", expected ", reference));
}

} // namespace

std::string self_test() {
    return self_test(*Context::shared());
}

std::string self_test(Context& ctx) {
    const ::cl::Program program = ctx.program("selftest");
    ::cl::CommandQueue& queue = ctx.queue();
    cl_int err = CL_SUCCESS;

    // y = a * x + y
    constexpr int n = 1000;
    const double a = 1.0 / 3.0;
    std::vector<double> x(n), y(n), expected(n);
    for (int i = 0; i < n; ++i) {
        x[static_cast<std::size_t>(i)] = 1.0 + i / 7.0;
        y[static_cast<std::size_t>(i)] = std::sqrt(2.0 + i);
        expected[static_cast<std::size_t>(i)] =
            a * x[static_cast<std::size_t>(i)] + y[static_cast<std::size_t>(i)];
    }
    const std::size_t bytes = n * sizeof(double);
    ::cl::Buffer x_buf(ctx.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes, x.data(),
                       &err);
    check(err, "self-test: create buffer x");
    ::cl::Buffer y_buf(ctx.context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, bytes, y.data(),
                       &err);
    check(err, "self-test: create buffer y");
    ::cl::Kernel axpy(program, "selftest_axpy", &err);
    check(err, "self-test: create kernel selftest_axpy");
    check(axpy.setArg(0, a), "self-test: set argument a");
    check(axpy.setArg(1, x_buf), "self-test: set argument x");
    check(axpy.setArg(2, y_buf), "self-test: set argument y");
    check(axpy.setArg(3, n), "self-test: set argument n");
    check(queue.enqueueNDRangeKernel(axpy, ::cl::NullRange, ::cl::NDRange(n)),
          "self-test: run selftest_axpy");
    check(queue.enqueueReadBuffer(y_buf, CL_TRUE, 0, bytes, y.data()), "self-test: read y");
    for (std::size_t i = 0; i < n; ++i) expect_near(ctx, "selftest_axpy y", i, y[i], expected[i]);

    // The shared struct: values computed from it and the device's view of its layout.
    SelftestParams params{};
    params.scale = 0.1;
    params.offset = -2.0 / 3.0;
    params.count = 37;
    constexpr std::size_t m = 64; // more work-items than count: the guard must hold
    std::vector<double> out(m, -1.0);
    std::vector<cl_long> layout(5, -1);
    ::cl::Buffer p_buf(ctx.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof params,
                       &params, &err);
    check(err, "self-test: create buffer params");
    ::cl::Buffer out_buf(ctx.context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR,
                         m * sizeof(double), out.data(), &err);
    check(err, "self-test: create buffer out");
    ::cl::Buffer layout_buf(ctx.context(), CL_MEM_WRITE_ONLY, layout.size() * sizeof(cl_long),
                            nullptr, &err);
    check(err, "self-test: create buffer layout");
    ::cl::Kernel layout_kernel(program, "selftest_layout", &err);
    check(err, "self-test: create kernel selftest_layout");
    check(layout_kernel.setArg(0, p_buf), "self-test: set argument params");
    check(layout_kernel.setArg(1, out_buf), "self-test: set argument out");
    check(layout_kernel.setArg(2, layout_buf), "self-test: set argument layout");
    check(queue.enqueueNDRangeKernel(layout_kernel, ::cl::NullRange, ::cl::NDRange(m)),
          "self-test: run selftest_layout");
    check(queue.enqueueReadBuffer(out_buf, CL_TRUE, 0, m * sizeof(double), out.data()),
          "self-test: read out");
    check(queue.enqueueReadBuffer(layout_buf, CL_TRUE, 0, layout.size() * sizeof(cl_long),
                                  layout.data()),
          "self-test: read layout");

    const cl_long host_layout[5] = {
        sizeof(SelftestParams), offsetof(SelftestParams, scale), offsetof(SelftestParams, offset),
        offsetof(SelftestParams, count), offsetof(SelftestParams, flags)};
    for (std::size_t i = 0; i < 5; ++i)
        if (layout[i] != host_layout[i])
            throw DeviceError(cat("OpenCL self-test failed on '", ctx.info().name,
                                  "': SelftestParams layout differs (device layout[", i,
                                  "] = ", layout[i], ", host ", host_layout[i],
                                  "; [0] is sizeof, then offsets of scale, offset, count, flags)"));
    for (std::size_t i = 0; i < m; ++i) {
        const double reference = i < static_cast<std::size_t>(params.count)
                                     ? params.scale * static_cast<double>(i) + params.offset
                                     : -1.0;
        expect_near(ctx, "selftest_layout out", i, out[i], reference);
    }

    const DeviceInfo& info = ctx.info();
    return cat("OpenCL self-test OK: ", info.name, " (", info.platform, ", ", info.version,
               ", driver ", info.driver, ")");
}

} // namespace brdf::cl
