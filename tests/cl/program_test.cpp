// brdf::cl::Context::program(): the self-test kernels against C++, build failures with the build
// log, shared-header inlining, the per-context memo and the on-disk binary cache.

#include <brdf/cl/context.h>
#include <brdf/core/error.h>

#include <test_support.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

namespace {

using brdf::DeviceError;
using brdf::cl::Context;
using brdf::cl::ContextOptions;
namespace fs = std::filesystem;

#define SKIP_WITHOUT_DEVICE()                                                                      \
    if (!brdf::cl::available()) GTEST_SKIP() << "no OpenCL device with fp64"

template <typename F> std::string device_error(F&& f) {
    try {
        f();
    } catch (const DeviceError& e) {
        return e.what();
    }
    ADD_FAILURE() << "expected brdf::DeviceError";
    return {};
}

// A context with no disk cache unless a folder is given, so tests do not depend on each other.
ContextOptions options(const fs::path& cache_dir = {}, const fs::path& kernel_dir = {}) {
    ContextOptions o;
    o.cache_dir = cache_dir;
    o.kernel_dir = kernel_dir;
    return o;
}

std::vector<fs::path> cache_files(const fs::path& cache_dir) {
    std::vector<fs::path> files;
    if (!fs::exists(cache_dir / "opencl")) return files;
    for (const auto& entry : fs::directory_iterator(cache_dir / "opencl"))
        files.push_back(entry.path());
    return files;
}

TEST(ClProgram, AxpyMatchesCpp) {
    SKIP_WITHOUT_DEVICE();
    const auto ctx = Context::shared();
    const ::cl::Program program = ctx->program("selftest");
    cl_int err = CL_SUCCESS;
    constexpr std::size_t n = 257; // not a multiple of any work-group size
    const double a = -0.7;
    std::vector<double> x(n), y(n), reference(n);
    for (std::size_t i = 0; i < n; ++i) {
        x[i] = std::sin(0.1 * static_cast<double>(i));
        y[i] = 1.0 / (1.0 + static_cast<double>(i));
        reference[i] = a * x[i] + y[i];
    }
    ::cl::Buffer xb(ctx->context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * sizeof(double),
                    x.data(), &err);
    brdf::cl::check(err, "buffer x");
    ::cl::Buffer yb(ctx->context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, n * sizeof(double),
                    y.data(), &err);
    brdf::cl::check(err, "buffer y");
    ::cl::Kernel kernel(program, "selftest_axpy", &err);
    brdf::cl::check(err, "kernel");
    brdf::cl::check(kernel.setArg(0, a), "arg 0");
    brdf::cl::check(kernel.setArg(1, xb), "arg 1");
    brdf::cl::check(kernel.setArg(2, yb), "arg 2");
    brdf::cl::check(kernel.setArg(3, static_cast<cl_int>(n)), "arg 3");
    brdf::cl::check(ctx->queue().enqueueNDRangeKernel(kernel, ::cl::NullRange, ::cl::NDRange(n)),
                    "run");
    brdf::cl::check(ctx->queue().enqueueReadBuffer(yb, CL_TRUE, 0, n * sizeof(double), y.data()),
                    "read");
    // A few ulp: the device may contract a*x+y into one fma (OpenCL C's FP_CONTRACT default), the
    // host does not; single precision would be off by ~1e-8.
    for (std::size_t i = 0; i < n; ++i) EXPECT_REL_NEAR(y[i], reference[i], 1e-14) << "i = " << i;
}

TEST(ClProgram, SelfTestPassesAndNamesDevice) {
    SKIP_WITHOUT_DEVICE();
    const std::string line = brdf::cl::self_test();
    EXPECT_EQ(line.rfind("OpenCL self-test OK: ", 0), 0u) << line;
    EXPECT_NE(line.find(Context::shared()->info().name), std::string::npos) << line;
    EXPECT_EQ(line.find('\n'), std::string::npos) << line;
}

TEST(ClProgram, SourceInlinesSharedHeadersOnce) {
    SKIP_WITHOUT_DEVICE();
    const std::string src = Context::shared()->source("selftest");
    EXPECT_EQ(src.find("\n#include \""), std::string::npos) << src; // <cstdint> stays: host-only
    EXPECT_EQ(src.find("#pragma once"), std::string::npos) << src;
    EXPECT_NE(src.find("typedef struct SelftestParams"), std::string::npos);
    // types.h is included by selftest_layout.h only; still exactly one copy.
    const std::size_t first = src.find("typedef long brdf_i64;");
    ASSERT_NE(first, std::string::npos) << src;
    EXPECT_EQ(src.find("typedef long brdf_i64;", first + 1), std::string::npos);
    EXPECT_NE(src.find("#line 1 \"shared/types.h\""), std::string::npos) << src;
}

TEST(ClProgram, MemoisedPerNameAndOptions) {
    SKIP_WITHOUT_DEVICE();
    Context ctx(options());
    const ::cl::Program a = ctx.program("selftest");
    const ::cl::Program b = ctx.program("selftest");
    const ::cl::Program c = ctx.program("selftest", "-DBRDF_UNUSED=1");
    EXPECT_EQ(a(), b());
    EXPECT_NE(a(), c());
    const brdf::cl::ProgramCacheStats s = ctx.cache_stats();
    EXPECT_EQ(s.builds, 2u);
    EXPECT_EQ(s.memory_hits, 1u);
    EXPECT_EQ(s.disk_hits + s.disk_writes, 0u);
}

TEST(ClProgram, ConcurrentCallsBuildOnce) {
    SKIP_WITHOUT_DEVICE();
    Context ctx(options());
    std::vector<cl_program> handles(4);
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < handles.size(); ++i)
        threads.emplace_back([&, i] { handles[i] = ctx.program("selftest")(); });
    for (std::thread& t : threads) t.join();
    for (cl_program h : handles) EXPECT_EQ(h, handles[0]);
    EXPECT_EQ(ctx.cache_stats().builds, 1u);
    EXPECT_EQ(ctx.cache_stats().memory_hits, 3u);
}

TEST(ClProgram, BuildFailureCarriesBuildLog) {
    SKIP_WITHOUT_DEVICE();
    brdf::test::TempDir dir;
    brdf::test::write_file(dir / "broken.cl", "// a kernel with a mistake on line 4\n"
                                              "__kernel void broken(__global double* y) {\n"
                                              "    const int i = get_global_id(0);\n"
                                              "    y[i] = undeclared_identifier_xyz;\n"
                                              "}\n");
    Context ctx(options({}, dir.path()));
    const std::string message = device_error([&] { ctx.program("broken"); });
    EXPECT_NE(message.find("OpenCL program 'broken' failed to build"), std::string::npos)
        << message;
    EXPECT_NE(message.find("CL_BUILD_PROGRAM_FAILURE"), std::string::npos) << message;
    EXPECT_NE(message.find("undeclared_identifier_xyz"), std::string::npos) << message;
    // The #line markers make clang-based compilers (PoCL) report the real file and line.
    EXPECT_NE(message.find("broken.cl:4:"), std::string::npos) << message;
    EXPECT_NE(message.find("error"), std::string::npos) << message;
    // A failed build is not memoised: it fails again the same way.
    EXPECT_EQ(device_error([&] { ctx.program("broken"); }), message);
}

TEST(ClProgram, BuildFailureInSharedHeaderNamesHeader) {
    SKIP_WITHOUT_DEVICE();
    brdf::test::TempDir dir;
    fs::create_directory(dir / "shared");
    brdf::test::write_file(dir / "shared/bad.h", "#pragma once\n\ntypedef not_a_type Bad;\n");
    brdf::test::write_file(dir / "user.cl", "#include \"shared/bad.h\"\n__kernel void k() {}\n");
    Context ctx(options({}, dir.path()));
    const std::string message = device_error([&] { ctx.program("user"); });
    EXPECT_NE(message.find("shared/bad.h:3:"), std::string::npos) << message;
}

TEST(ClProgram, BadIncludesAreDeviceErrors) {
    SKIP_WITHOUT_DEVICE();
    brdf::test::TempDir dir;
    brdf::test::write_file(dir / "missing.cl", "\n#include \"shared/missing.h\"\n");
    brdf::test::write_file(dir / "outside.cl", "#include \"other.h\"\n");
    brdf::test::write_file(dir / "system.cl", "#include <stdio.h>\n");
    Context ctx(options({}, dir.path()));
    std::string message = device_error([&] { ctx.program("missing"); });
    EXPECT_NE(message.find("missing.cl:2: #include \"shared/missing.h\""), std::string::npos)
        << message;
    message = device_error([&] { ctx.program("outside"); });
    EXPECT_NE(message.find("\"other.h\""), std::string::npos) << message;
    message = device_error([&] { ctx.program("system"); });
    // Left to the device compiler, whose build log names it.
    EXPECT_NE(message.find("stdio.h"), std::string::npos) << message;
}

TEST(ClProgram, UnknownAndInvalidNames) {
    SKIP_WITHOUT_DEVICE();
    Context ctx(options());
    std::string message = device_error([&] { ctx.program("no_such_kernel"); });
    EXPECT_NE(message.find("no_such_kernel.cl"), std::string::npos) << message;
    message = device_error([&] { ctx.program("../selftest"); });
    EXPECT_NE(message.find("invalid name"), std::string::npos) << message;
}

TEST(ClProgram, FastMathIsRefused) {
    SKIP_WITHOUT_DEVICE();
    Context ctx(options());
    const std::string message =
        device_error([&] { ctx.program("selftest", "-cl-fast-relaxed-math"); });
    EXPECT_NE(message.find("-cl-fast-relaxed-math"), std::string::npos) << message;
}

TEST(ClProgram, KernelDirFromEnvironmentInChildProcess) {
    SKIP_WITHOUT_DEVICE();
    brdf::test::TempDir dir;
    brdf::test::write_file(dir / "broken.cl", "__kernel void k() { oops_xyz; }\n");
    const auto result = brdf::test::run_process({"/usr/bin/env", "BRDF_LOG=info",
                                                 "BRDF_KERNEL_DIR=" + dir.path().string(),
                                                 BRDF_CL_PROBE, "program", "broken"});
    EXPECT_EQ(result.status, 5) << result.err;
    EXPECT_NE(result.err.find("oops_xyz"), std::string::npos) << result.err;
    EXPECT_NE(result.err.find("BRDF_KERNEL_DIR"), std::string::npos) << result.err;
    EXPECT_EQ(result.out, "") << "build logs must not go to stdout";
}

TEST(ClProgramCache, WrittenThenHitBySecondContext) {
    SKIP_WITHOUT_DEVICE();
    brdf::test::TempDir cache;
    {
        Context first(options(cache.path()));
        EXPECT_NO_THROW(brdf::cl::self_test(first));
        const brdf::cl::ProgramCacheStats s = first.cache_stats();
        EXPECT_EQ(s.builds, 1u);
        EXPECT_EQ(s.disk_writes, 1u);
        EXPECT_EQ(s.disk_hits, 0u);
    }
    const std::vector<fs::path> files = cache_files(cache.path());
    ASSERT_EQ(files.size(), 1u);
    EXPECT_EQ(files[0].extension(), ".bin");
    EXPECT_GT(fs::file_size(files[0]), 0u);

    Context second(options(cache.path()));
    EXPECT_NO_THROW(
        brdf::cl::self_test(second)); // the program loaded from the binary runs correctly
    const brdf::cl::ProgramCacheStats s = second.cache_stats();
    EXPECT_EQ(s.disk_hits, 1u);
    EXPECT_EQ(s.builds, 0u);
    EXPECT_EQ(s.disk_writes, 0u);

    // Other options are another key, hence another file.
    Context third(options(cache.path()));
    third.program("selftest", "-DBRDF_UNUSED=2");
    EXPECT_EQ(third.cache_stats().builds, 1u);
    EXPECT_EQ(cache_files(cache.path()).size(), 2u);
}

TEST(ClProgramCache, CorruptOrTruncatedFileIsRebuilt) {
    SKIP_WITHOUT_DEVICE();
    brdf::test::TempDir cache;
    {
        Context first(options(cache.path()));
        first.program("selftest");
    }
    const std::vector<fs::path> files = cache_files(cache.path());
    ASSERT_EQ(files.size(), 1u);
    const std::string good = brdf::test::read_file(files[0]);

    for (const std::string& bad :
         {good.substr(0, good.size() / 2), std::string("garbage"), std::string(good.size(), 'x')}) {
        brdf::test::write_file(files[0], bad);
        Context ctx(options(cache.path()));
        EXPECT_NO_THROW(brdf::cl::self_test(ctx));
        EXPECT_EQ(ctx.cache_stats().disk_hits, 0u);
        EXPECT_EQ(ctx.cache_stats().builds, 1u);
        EXPECT_EQ(ctx.cache_stats().disk_writes, 1u);
    }
    EXPECT_EQ(cache_files(cache.path()).size(), 1u) << "no temporary files left behind";
}

TEST(ClProgramCache, UncreatableCacheDirIsSkipped) {
    SKIP_WITHOUT_DEVICE();
    brdf::test::TempDir tmp;
    brdf::test::write_file(tmp / "not-a-dir", "a file where the cache folder should be");
    Context ctx(options(tmp / "not-a-dir"));
    EXPECT_NO_THROW(brdf::cl::self_test(ctx));
    EXPECT_EQ(ctx.cache_stats().builds, 1u);
    EXPECT_EQ(ctx.cache_stats().disk_writes, 0u);
}

} // namespace
