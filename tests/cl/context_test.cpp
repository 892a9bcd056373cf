// brdf::cl: error names, device selection, the shared context, and the environment it reads
// (exercised in a child process, tests/cl/cl_probe.cpp, so this process's environment stays as is).

#include <brdf/cl/context.h>
#include <brdf/cl/kernel_sources.h>
#include <brdf/core/error.h>

#include <test_support.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace {

using brdf::DeviceError;
using brdf::cl::DeviceCandidate;
namespace fs = std::filesystem;

// The message of the DeviceError that `f` throws; fails the test if it throws nothing or another
// type.
template <typename F> std::string device_error(F&& f) {
    try {
        f();
    } catch (const DeviceError& e) {
        return e.what();
    }
    ADD_FAILURE() << "expected brdf::DeviceError";
    return {};
}

brdf::test::ProcessResult run_probe(const std::vector<std::string>& env,
                                    const std::vector<std::string>& args) {
    std::vector<std::string> argv{"/usr/bin/env"};
    argv.insert(argv.end(), env.begin(), env.end());
    argv.push_back(BRDF_CL_PROBE);
    argv.insert(argv.end(), args.begin(), args.end());
    return brdf::test::run_process(argv);
}

constexpr int device_exit_status = 5; // brdf::exit_status(ErrorKind::Device)

TEST(ClCheck, MessageNamesWhatAndStatus) {
    EXPECT_NO_THROW(brdf::cl::check(CL_SUCCESS, "anything"));
    EXPECT_EQ(device_error([] { brdf::cl::check(CL_OUT_OF_RESOURCES, "enqueue solve"); }),
              "enqueue solve: CL_OUT_OF_RESOURCES (-5)");
    EXPECT_EQ(device_error([] { brdf::cl::check(-9999, "x"); }), "x: CL_UNKNOWN_ERROR (-9999)");
}

TEST(ClCheck, ErrorNames) {
    EXPECT_STREQ(brdf::cl::error_name(CL_SUCCESS), "CL_SUCCESS");
    EXPECT_STREQ(brdf::cl::error_name(CL_BUILD_PROGRAM_FAILURE), "CL_BUILD_PROGRAM_FAILURE");
    EXPECT_STREQ(brdf::cl::error_name(CL_INVALID_KERNEL_ARGS), "CL_INVALID_KERNEL_ARGS");
    EXPECT_STREQ(brdf::cl::error_name(-1001), "CL_PLATFORM_NOT_FOUND_KHR");
    EXPECT_STREQ(brdf::cl::error_name(1), "CL_UNKNOWN_ERROR");
}

TEST(ClSelectDevice, NoPlatform) {
    EXPECT_EQ(device_error([] { brdf::cl::select_device({}, 0, ""); }),
              "no OpenCL platform found (install pocl-opencl-icd, or use --device cpu)");
}

TEST(ClSelectDevice, PlatformWithoutDevices) {
    EXPECT_NE(device_error([] { brdf::cl::select_device({}, 1, ""); }).find("no device"),
              std::string::npos);
}

TEST(ClSelectDevice, FirstDeviceWithFp64) {
    const std::vector<DeviceCandidate> devices{
        {"Vendor A", "Small GPU", false}, {"Vendor A", "Big GPU", true}, {"PoCL", "cpu", true}};
    EXPECT_EQ(brdf::cl::select_device(devices, 2, ""), 1u);
    EXPECT_EQ(brdf::cl::select_device(devices, 2, "cpu"), 2u);
    EXPECT_EQ(brdf::cl::select_device(devices, 2, "PoCL"), 2u); // by platform name
    EXPECT_EQ(brdf::cl::select_device(devices, 2, "GPU"), 1u);  // skips the match without fp64
}

TEST(ClSelectDevice, FilteredDeviceLacksFp64) {
    const std::vector<DeviceCandidate> devices{{"Vendor A", "Small GPU", false},
                                               {"PoCL", "cpu", true}};
    EXPECT_EQ(device_error([&] { brdf::cl::select_device(devices, 2, "Small"); }),
              "OpenCL device 'Small GPU' lacks double precision (cl_khr_fp64)");
}

TEST(ClSelectDevice, NoDeviceHasFp64) {
    const std::vector<DeviceCandidate> one{{"Vendor A", "Small GPU", false}};
    EXPECT_EQ(device_error([&] { brdf::cl::select_device(one, 1, ""); }),
              "OpenCL device 'Small GPU' lacks double precision (cl_khr_fp64)");
    const std::vector<DeviceCandidate> two{{"A", "gpu0", false}, {"A", "gpu1", false}};
    const std::string message = device_error([&] { brdf::cl::select_device(two, 1, ""); });
    EXPECT_NE(message.find("no OpenCL device has double precision (cl_khr_fp64)"),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("'gpu1'"), std::string::npos) << message;
}

TEST(ClSelectDevice, FilterMatchesNothing) {
    const std::vector<DeviceCandidate> devices{{"PoCL", "cpu", true}};
    const std::string message =
        device_error([&] { brdf::cl::select_device(devices, 1, "Radeon"); });
    EXPECT_NE(message.find("BRDF_OPENCL_DEVICE='Radeon' matches no OpenCL device"),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("'cpu' (PoCL)"), std::string::npos) << message;
}

TEST(ClOptions, CacheDirFromEnvironment) {
    // test_support sets BRDF_CACHE_DIR into the build tree before any test runs.
    const brdf::cl::ContextOptions options = brdf::cl::options_from_environment();
    ASSERT_NE(std::getenv("BRDF_CACHE_DIR"), nullptr);
    EXPECT_EQ(options.cache_dir, fs::path(std::getenv("BRDF_CACHE_DIR")));
}

// Hiding every platform from the ICD loader (ocl-icd reads vendors from OCL_ICD_VENDORS) must give
// DeviceError with the documented message, not a crash, and available() must say false.
TEST(ClNoPlatform, SharedContextThrowsDeviceError) {
    const auto result = run_probe({"OCL_ICD_VENDORS=/nonexistent"}, {"self-test"});
    EXPECT_EQ(result.status, device_exit_status) << result.err;
    EXPECT_NE(
        result.err.find("no OpenCL platform found (install pocl-opencl-icd, or use --device cpu)"),
        std::string::npos)
        << result.err;
    const auto avail = run_probe({"OCL_ICD_VENDORS=/nonexistent"}, {"available"});
    EXPECT_EQ(avail.status, 0) << avail.err;
    EXPECT_EQ(avail.out, "0\n");
}

TEST(ClContext, Shared) {
    if (!brdf::cl::available()) GTEST_SKIP() << "no OpenCL device with fp64";
    const auto a = brdf::cl::Context::shared();
    const auto b = brdf::cl::Context::shared();
    ASSERT_TRUE(a);
    EXPECT_EQ(a.get(), b.get());
    const brdf::cl::DeviceInfo& info = a->info();
    EXPECT_FALSE(info.platform.empty());
    EXPECT_FALSE(info.name.empty());
    EXPECT_FALSE(info.version.empty());
    EXPECT_FALSE(info.driver.empty());
    EXPECT_GT(info.global_mem_bytes, 0u);
    EXPECT_GT(info.local_mem_bytes, 0u);
    EXPECT_GT(info.max_work_group_size, 0u);
    EXPECT_GT(info.compute_units, 0u);
    EXPECT_NE(a->context()(), nullptr);
    EXPECT_NE(a->device()(), nullptr);
    EXPECT_NE(a->queue()(), nullptr);
}

TEST(ClContext, DeviceFilterFromEnvironment) {
    if (!brdf::cl::available()) GTEST_SKIP() << "no OpenCL device with fp64";
    const auto result =
        run_probe({"BRDF_OPENCL_DEVICE=no-such-device-xyz"}, {"program", "selftest"});
    EXPECT_EQ(result.status, device_exit_status) << result.err;
    EXPECT_NE(result.err.find("BRDF_OPENCL_DEVICE='no-such-device-xyz' matches no OpenCL device"),
              std::string::npos)
        << result.err;

    const std::string name = brdf::cl::Context::shared()->info().name;
    const auto ok = run_probe({"BRDF_OPENCL_DEVICE=" + name}, {"self-test"});
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_NE(ok.out.find(name), std::string::npos) << ok.out;
}

TEST(ClContext, SelfTestInChildProcess) {
    if (!brdf::cl::available()) GTEST_SKIP() << "no OpenCL device with fp64";
    const auto result = run_probe({}, {"self-test"});
    EXPECT_EQ(result.status, 0) << result.err;
    EXPECT_EQ(result.out.rfind("OpenCL self-test OK: ", 0), 0u) << result.out;
    EXPECT_EQ(result.out.find('\n'), result.out.size() - 1) << "one line expected: " << result.out;
}

// PoCL's start leaves an empty tempfile_* in its cache folder: only those are removed, and only
// once they are old enough not to be another process's file about to be written.
TEST(ClPoclCache, RemovesOnlyOldEmptyTempfiles) {
    const brdf::test::TempDir dir;
    const auto now = fs::file_time_type::clock::now();
    const auto make = [&](const std::string& name, const std::string& content, auto age) {
        const fs::path p = dir.path() / name;
        std::ofstream(p) << content;
        fs::last_write_time(p, now - age);
        return p;
    };
    using std::chrono::hours;
    using std::chrono::minutes;
    const fs::path old_empty = make("tempfile_AbC123", "", hours(2));
    const fs::path young_empty = make("tempfile_XyZ789", "", minutes(5));
    const fs::path old_written = make("tempfile_Q1w2E3", "kernel", hours(2));
    const fs::path other_name = make("program.bc", "", hours(2));
    fs::create_directory(dir.path() / "tempfile_dir0");
    const fs::path target = make("target", "", hours(2));
    fs::create_symlink(target, dir.path() / "tempfile_link1");
    fs::last_write_time(target, now - hours(2));

    EXPECT_EQ(brdf::cl::remove_pocl_leftovers(dir.path(), hours(1)), 1u);
    EXPECT_FALSE(fs::exists(old_empty));
    for (const fs::path& kept : {young_empty, old_written, other_name, target, dir.path() / "tempfile_dir0"})
        EXPECT_TRUE(fs::exists(kept)) << kept;
    EXPECT_TRUE(fs::is_symlink(dir.path() / "tempfile_link1"));
    EXPECT_EQ(brdf::cl::remove_pocl_leftovers(dir.path() / "missing", hours(1)), 0u);
}

// A folder is swept at most once a period: the first look touches its stamp, the next within the
// period skips, and one after it (the stamp made older) sweeps again.
TEST(ClPoclCache, AFolderIsSweptAtMostOnceAPeriod) {
    const brdf::test::TempDir dir;
    using std::chrono::hours;
    EXPECT_TRUE(brdf::cl::pocl_sweep_due(dir.path(), hours(1)));
    const fs::path stamp = dir.path() / ".brdf-pocl-swept";
    ASSERT_TRUE(fs::exists(stamp));
    EXPECT_FALSE(brdf::cl::pocl_sweep_due(dir.path(), hours(1)));
    EXPECT_FALSE(brdf::cl::pocl_sweep_due(dir.path(), hours(1)));
    fs::last_write_time(stamp, fs::file_time_type::clock::now() - std::chrono::minutes(61));
    EXPECT_TRUE(brdf::cl::pocl_sweep_due(dir.path(), hours(1)));
    EXPECT_FALSE(brdf::cl::pocl_sweep_due(dir.path(), hours(1)));
}

// A process that starts PoCL in the cache folder it chose sweeps what earlier starts left there;
// the file its own start leaves stays, being young (at most one per process remains).
TEST(ClPoclCache, StartingPoclSweepsTheFolderItChose) {
    if (!brdf::cl::available()) GTEST_SKIP() << "no OpenCL device with fp64";
    const brdf::test::TempDir home;
    const fs::path folder = home.path() / "brdf" / "pocl";
    fs::create_directories(folder);
    const fs::path leftover = folder / "tempfile_Old001";
    std::ofstream(leftover).close();
    fs::last_write_time(leftover, fs::file_time_type::clock::now() - std::chrono::hours(3));
    const auto count = [&] {
        std::size_t n = 0;
        for (const fs::directory_entry& e : fs::directory_iterator(folder))
            n += e.path().filename().string().starts_with("tempfile_");
        return n;
    };
    const auto result =
        run_probe({"-u", "POCL_CACHE_DIR", "XDG_CACHE_HOME=" + home.path().string()}, {"available"});
    EXPECT_EQ(result.status, 0) << result.err;
    EXPECT_EQ(result.out, "1\n");
    EXPECT_FALSE(fs::exists(leftover));
    EXPECT_LE(count(), 1u);
    // Within the hour the next start does not look again (the folder's stamp is new).
    std::ofstream(leftover).close();
    fs::last_write_time(leftover, fs::file_time_type::clock::now() - std::chrono::hours(3));
    EXPECT_EQ(run_probe({"-u", "POCL_CACHE_DIR", "XDG_CACHE_HOME=" + home.path().string()}, {"available"}).status, 0);
    EXPECT_TRUE(fs::exists(leftover));

    // A folder named by POCL_CACHE_DIR is the user's: left alone.
    const fs::path theirs = home.path() / "theirs";
    fs::create_directories(theirs);
    std::ofstream(theirs / "tempfile_Old002").close();
    fs::last_write_time(theirs / "tempfile_Old002", fs::file_time_type::clock::now() - std::chrono::hours(3));
    const auto set = run_probe({"POCL_CACHE_DIR=" + theirs.string()}, {"available"});
    EXPECT_EQ(set.status, 0) << set.err;
    EXPECT_TRUE(fs::exists(theirs / "tempfile_Old002"));
}

// Every kernels/*.cl and kernels/shared/*.h is embedded, byte for byte, and nothing else: a kernel
// added to kernels/ but not listed in src/brdf/cl/CMakeLists.txt fails here, not at run time.
TEST(ClKernelSources, EmbeddedMatchKernelFolder) {
    const fs::path dir = brdf::test::source_dir() / "kernels";
    std::map<std::string, std::string> on_disk;
    for (const auto& entry : fs::recursive_directory_iterator(dir)) {
        if (!entry.is_regular_file()) continue;
        const std::string rel = fs::relative(entry.path(), dir).generic_string();
        const bool kernel = entry.path().extension() == ".cl" && rel.find('/') == std::string::npos;
        const bool shared = rel.rfind("shared/", 0) == 0 && entry.path().extension() == ".h";
        if (kernel || shared) on_disk[rel] = brdf::test::read_file(entry.path());
    }
    std::map<std::string, std::string> embedded;
    for (const brdf::EmbeddedFile& f : brdf::embedded::kernel_sources())
        embedded[std::string(f.path)] = std::string(f.data);
    ASSERT_TRUE(on_disk.count("selftest.cl"));
    for (const auto& [path, data] : on_disk) {
        ASSERT_TRUE(embedded.count(path))
            << "kernels/" << path << " is not listed in src/brdf/cl/CMakeLists.txt";
        EXPECT_EQ(embedded[path], data) << "kernels/" << path << " differs from its embedded copy";
    }
    for (const auto& [path, data] : embedded)
        EXPECT_TRUE(on_disk.count(path)) << "embedded kernels/" << path << " is not in kernels/";
}

} // namespace
