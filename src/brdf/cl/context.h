#pragma once
// OpenCL context, device selection and program building for the solvers' device side.
//
//   auto ctx = brdf::cl::Context::shared();               // throws DeviceError without a device
//   ::cl::Program program = ctx->program("ambartsumian");   // kernels/ambartsumian.cl
//   cl_int err;
//   ::cl::Kernel kernel(program, "ambartsumian_solve", &err);
//   brdf::cl::check(err, "create kernel 'ambartsumian_solve'");
//
// Sources are kernels/NAME.cl plus kernels/shared/*.h, embedded at build time (adding a kernel:
// list it in src/brdf/cl/CMakeLists.txt). The bindings do not throw; pass every cl_int to check().

#include <brdf/cl/opencl.h>

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>

namespace brdf::cl {

struct DeviceInfo {
    std::string platform, name, version, driver;
    std::size_t global_mem_bytes = 0, local_mem_bytes = 0, max_work_group_size = 0;
    unsigned compute_units = 0;
    std::string opencl_c_version; ///< e.g. "OpenCL C 1.2 PoCL"
    bool cpu = false; ///< CL_DEVICE_TYPE_CPU (PoCL): the device works in the host's own memory
};

/// true when some OpenCL platform has a device with cl_khr_fp64 (tests use it to GTEST_SKIP). Never
/// throws; the answer is computed once per process.
bool available();

/// When available() is false: why, as the DeviceError creating a context would say it (e.g. "OpenCL
/// platform found but it has no device: PoCL could not write its cache folder ..."). Empty otherwise.
std::string unavailable_reason();

/// Gives PoCL a kernel-cache folder it can write, before the first OpenCL call. PoCL's CPU device
/// needs one: without it (no writable home, as under tools/systemd/brdfd.service) the device fails
/// to initialise and the platform looks empty. POCL_CACHE_DIR, when set, is left alone. Otherwise it
/// is set to the first of these that can be created and written: $XDG_CACHE_HOME/brdf/pocl,
/// $HOME/.cache/brdf/pocl (only when $HOME exists: a home that is not there is not created),
/// `fallback`/pocl (brdfd passes a folder under its spool), $TMPDIR/brdf-pocl-UID (else /tmp; mode
/// 0700 and owned by this user, since PoCL loads code from it). The first call decides; later calls
/// return the same folder. The tools' mains call it before starting threads (setenv is not
/// thread-safe); the first OpenCL call makes it otherwise. Returns POCL_CACHE_DIR (empty when no
/// folder could be used).
std::filesystem::path prepare_environment(const std::filesystem::path& fallback = {});

/// Removes the empty files tempfile_* at least `min_age` old that PoCL's start leaves in `folder`
/// (PoCL 3.1: one per process). After PoCL started, the folder prepare_environment chose is swept
/// with a min_age of an hour, where pocl_sweep_due says so. Returns how many were removed.
/// Exposed for tests.
std::size_t remove_pocl_leftovers(const std::filesystem::path& folder, std::chrono::seconds min_age);

/// Whether `folder` is due a sweep: its stamp file .brdf-pocl-swept is missing or at least `period`
/// old. When it is, the stamp is touched (the processes starting within `period` skip it). Exposed
/// for tests.
bool pocl_sweep_due(const std::filesystem::path& folder, std::chrono::seconds period);

/// Why `folder` cannot serve as a cache folder ("cannot create it: Permission denied"), or empty
/// when it can be created and a file written in it. Exposed for tests.
std::string cache_folder_problem(const std::filesystem::path& folder);

/// Where a Context finds its device, its sources and its binary cache.
struct ContextOptions {
    /// Case-sensitive substring of the device or platform name; empty: first device with fp64.
    std::string device_filter;
    /// Read NAME.cl and shared/X.h from this folder instead of the embedded copies; empty:
    /// embedded.
    std::filesystem::path kernel_dir;
    /// Program binaries go to cache_dir/opencl/; empty: no disk cache.
    std::filesystem::path cache_dir;
};

/// Options from the environment: BRDF_OPENCL_DEVICE, BRDF_KERNEL_DIR, and the cache folder
/// brdf::cache_root() ($BRDF_CACHE_DIR, else $XDG_CACHE_HOME/brdf-service, else
/// $HOME/.cache/brdf-service; BRDF_CACHE_DIR=off: none).
ContextOptions options_from_environment();

/// One device as seen by device selection.
struct DeviceCandidate {
    std::string platform, name;
    bool fp64 = false;
};

/// Index of the device to use: the first with fp64 whose device or platform name contains `filter`
/// (any, when empty). Throws DeviceError naming the fault: no platform, no device matching the
/// filter, or no double precision. `platforms` counts the platforms found (0 gives "no OpenCL
/// platform found ..."). Exposed so tests can exercise every message without special hardware.
std::size_t select_device(std::span<const DeviceCandidate> devices, std::size_t platforms,
                          std::string_view filter);

/// Counters of program(): memoised hits, disk-cache hits, builds from source, binaries written.
struct ProgramCacheStats {
    std::size_t memory_hits = 0, disk_hits = 0, builds = 0, disk_writes = 0;
};

class Context {
  public:
    /// Process-wide context, created lazily and thread-safely on first use from
    /// options_from_environment(). Picks the first device with fp64; env
    /// BRDF_OPENCL_DEVICE=substring selects by device or platform name. Throws brdf::DeviceError
    /// with a message naming the fault, e.g. "no OpenCL platform found (install pocl-opencl-icd, or
    /// use --device cpu)". A failed creation is not remembered: the next call tries again.
    static std::shared_ptr<Context> shared();

    /// A new, independent context (own queue, own program memo); tests and tools that need other
    /// options than the environment's use this.
    explicit Context(ContextOptions options);
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    const DeviceInfo& info() const { return m_info; }
    const ContextOptions& options() const { return m_options; }
    ::cl::Context& context() { return m_context; }
    ::cl::Device& device() { return m_device; }
    /// One in-order queue. OpenCL calls are thread-safe, but commands from several threads
    /// interleave; a caller that needs a private order makes its own ::cl::CommandQueue on
    /// context().
    ::cl::CommandQueue& queue() { return m_queue; }

    /// The program built from kernels/NAME.cl (e.g. name "ambartsumian"), with `options` appended
    /// to
    /// "-cl-std=CL1.2"; fast-math options are refused. `#include "shared/X.h"` lines are inlined
    /// from kernels/shared/ (each file once). Built programs are memoised per (name, options) and
    /// cached on disk as binaries keyed by the preprocessed source, options, device and driver. A
    /// build failure throws DeviceError with the program name and the device's build log.
    /// Thread-safe.
    ::cl::Program program(std::string_view name, std::string_view options = {});

    /// The preprocessed source program(name) compiles (includes inlined, #line markers added).
    std::string source(std::string_view name) const;

    ProgramCacheStats cache_stats() const;

  private:
    struct Entry;
    ::cl::Program build(std::string_view name, const std::string& options);
    std::string read_kernel_file(std::string_view path) const;

    ContextOptions m_options;
    DeviceInfo m_info;
    ::cl::Context m_context;
    ::cl::Device m_device;
    ::cl::CommandQueue m_queue;

    mutable std::mutex m_mutex; // guards m_programs and m_stats; builds run outside it
    std::map<std::string, std::shared_ptr<Entry>, std::less<>> m_programs;
    ProgramCacheStats m_stats;
};

/// Throws DeviceError("WHAT: CL_OUT_OF_RESOURCES (-5)") when status != CL_SUCCESS.
void check(cl_int status, std::string_view what);
/// The symbolic name of an OpenCL status ("CL_OUT_OF_RESOURCES"), "CL_UNKNOWN_ERROR" if unknown.
const char* error_name(cl_int status);

/// Runs kernels/selftest.cl on the shared context (or `context`) and compares it with the same
/// computation in C++. Returns one line, "OpenCL self-test OK: DEVICE (PLATFORM, VERSION, driver
/// DRIVER)"; throws DeviceError naming the first mismatch.
std::string self_test();
std::string self_test(Context& context);

} // namespace brdf::cl
