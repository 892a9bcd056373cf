#include <brdf/cl/context.h>

#include <brdf/cl/kernel_sources.h>
#include <brdf/core/atomic_file.h>
#include <brdf/core/blob_cache.h>
#include <brdf/core/error.h>
#include <brdf/core/hash.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <sys/stat.h>
#include <system_error>
#include <unistd.h>
#include <vector>

namespace brdf::cl {
namespace fs = std::filesystem;

namespace {

// ocl-icd returns this from clGetPlatformIDs when no vendor is installed (cl_khr_icd).
constexpr cl_int platform_not_found_khr = -1001;

const char* const no_platform_message =
    "no OpenCL platform found (install pocl-opencl-icd, or use --device cpu)";

std::string env(const char* name) {
    const char* value = std::getenv(name);
    return value ? std::string(value) : std::string();
}

bool has_extension(const std::string& extensions, std::string_view wanted) {
    std::istringstream is(extensions);
    std::string token;
    while (is >> token)
        if (token == wanted) return true;
    return false;
}

void sweep_pocl_leftovers();

struct Enumerated {
    std::size_t platforms = 0;
    std::vector<::cl::Device> devices;
    std::vector<DeviceCandidate> candidates;
};

Enumerated enumerate_devices() {
    prepare_environment();
    Enumerated result;
    std::vector<::cl::Platform> platforms;
    const cl_int err = ::cl::Platform::get(&platforms);
    sweep_pocl_leftovers();
    if (err == platform_not_found_khr || (err == CL_SUCCESS && platforms.empty())) return result;
    check(err, "list OpenCL platforms (clGetPlatformIDs)");
    result.platforms = platforms.size();
    for (const ::cl::Platform& platform : platforms) {
        cl_int e = CL_SUCCESS;
        const std::string platform_name = platform.getInfo<CL_PLATFORM_NAME>(&e);
        check(e, "query OpenCL platform name");
        std::vector<::cl::Device> devices;
        e = platform.getDevices(CL_DEVICE_TYPE_ALL, &devices);
        if (e == CL_DEVICE_NOT_FOUND) continue; // a platform without devices is not an error
        check(e, cat("list devices of OpenCL platform '", platform_name, "'"));
        for (const ::cl::Device& device : devices) {
            DeviceCandidate c;
            c.platform = platform_name;
            c.name = device.getInfo<CL_DEVICE_NAME>(&e);
            check(e, "query OpenCL device name");
            const std::string extensions = device.getInfo<CL_DEVICE_EXTENSIONS>(&e);
            check(e, cat("query extensions of OpenCL device '", c.name, "'"));
            c.fp64 = has_extension(extensions, "cl_khr_fp64");
            result.devices.push_back(device);
            result.candidates.push_back(std::move(c));
        }
    }
    return result;
}

std::string list_devices(std::span<const DeviceCandidate> devices) {
    std::string out;
    for (const DeviceCandidate& d : devices) {
        if (!out.empty()) out += ", ";
        out += cat("'", d.name, "' (", d.platform, d.fp64 ? "" : ", no fp64", ")");
    }
    return out;
}

template <typename T>
T device_info(const ::cl::Device& device, cl_device_info name, const char* what) {
    T value{};
    check(device.getInfo(name, &value), cat("query OpenCL device ", what));
    return value;
}

// Options that trade IEEE semantics for speed: the solvers' accuracy budget does not allow them.
bool is_fast_math_option(std::string_view options) {
    for (const char* bad : {"-cl-fast-relaxed-math", "-cl-unsafe-math-optimizations",
                            "-cl-finite-math-only", "-cl-mad-enable", "-cl-no-signed-zeros"})
        if (options.find(bad) != std::string_view::npos) return true;
    return false;
}

bool valid_program_name(std::string_view name) {
    return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
               c == '_' || c == '-';
    });
}

// The quoted path of an `#include "..."` line, or nullopt for any other line. `#include <...>` is
// left to the device compiler: shared headers use it in their host-only branches (<cstdint>).
std::optional<std::string> include_path(std::string_view line) {
    std::size_t i = line.find_first_not_of(" \t");
    if (i == std::string_view::npos || line[i] != '#') return std::nullopt;
    i = line.find_first_not_of(" \t", i + 1);
    if (i == std::string_view::npos || line.substr(i, 7) != "include") return std::nullopt;
    i = line.find_first_not_of(" \t", i + 7);
    if (i == std::string_view::npos || line[i] != '"') return std::nullopt;
    const std::size_t end = line.find('"', i + 1);
    if (end == std::string_view::npos) return std::nullopt;
    return std::string(line.substr(i + 1, end - i - 1));
}

bool is_pragma_once(std::string_view line) {
    std::size_t i = line.find_first_not_of(" \t");
    if (i == std::string_view::npos || line[i] != '#') return false;
    i = line.find_first_not_of(" \t", i + 1);
    if (i == std::string_view::npos || line.substr(i, 6) != "pragma") return false;
    i = line.find_first_not_of(" \t", i + 6);
    return i != std::string_view::npos && line.substr(i, 4) == "once";
}

// Appends `text` (the file `file`) to `out`, replacing each `#include "shared/X.h"` with the file's
// text. Every file is inlined at most once: the shared headers are all `#pragma once`, and inlining
// once also ends include cycles. #line markers keep build-log locations pointing at the real files.
template <typename Read>
void inline_includes(std::string_view text, const std::string& file, const Read& read,
                     std::set<std::string>& seen, std::string& out) {
    std::size_t line_no = 0;
    std::size_t pos = 0;
    while (pos < text.size()) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string_view::npos) end = text.size();
        const std::string_view line = text.substr(pos, end - pos);
        pos = end + 1;
        ++line_no;
        if (is_pragma_once(line)) {
            out += '\n'; // keep line numbers
            continue;
        }
        const std::optional<std::string> path = include_path(line);
        if (!path) {
            out.append(line);
            out += '\n';
            continue;
        }
        if (path->rfind("shared/", 0) != 0 || path->find("..") != std::string::npos)
            throw DeviceError(cat(file, ":", line_no, ": #include \"", *path,
                                  "\": kernels may include only \"shared/NAME.h\""));
        if (seen.insert(*path).second) {
            const std::optional<std::string> included = read(*path);
            if (!included)
                throw DeviceError(cat(file, ":", line_no, ": #include \"", *path,
                                      "\": no such file in kernels/"));
            out += cat("#line 1 \"", *path, "\"\n");
            inline_includes(*included, *path, read, seen, out);
        }
        out += cat("#line ", line_no + 1, " \"", file, "\"\n");
    }
}

// ---- disk cache of program binaries ---------------------------------------------------------
// opencl/HASH.bin under the cache folder (core/blob_cache.h): the full key is checked on load, so
// a hash collision is a miss, never a wrong program.

constexpr std::string_view cache_magic = "BRDFCLB2";

constexpr std::size_t max_build_log = 64 * 1024;

// ---- PoCL's kernel cache -----------------------------------------------------------------------

/// $TMPDIR/brdf-pocl-UID, created 0700; refused unless it is our own private folder: PoCL loads
/// compiled kernels from its cache, so a folder another user can write would run their code.
fs::path private_temporary_folder() {
    const std::string tmp = env("TMPDIR");
    const fs::path dir = fs::path(tmp.empty() ? "/tmp" : tmp) / cat("brdf-pocl-", ::geteuid());
    if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) return {};
    struct stat st {};
    if (::lstat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) || st.st_uid != ::geteuid() ||
        (st.st_mode & 077) != 0)
        return {};
    return dir;
}

/// The folder PoCL uses for its cache (pocl_cache.c: POCL_CACHE_DIR, else
/// $XDG_CACHE_HOME/pocl/kcache, else $HOME/.cache/pocl/kcache).
fs::path pocl_cache_folder() {
    if (const std::string dir = env("POCL_CACHE_DIR"); !dir.empty()) return dir;
    if (const std::string xdg = env("XDG_CACHE_HOME"); !xdg.empty()) return fs::path(xdg) / "pocl" / "kcache";
    if (const std::string home = env("HOME"); !home.empty()) return fs::path(home) / ".cache" / "pocl" / "kcache";
    return {};
}

/// The cause behind "a platform but no device" when we can name it.
std::string empty_platform_cause() {
    const fs::path folder = pocl_cache_folder();
    if (folder.empty()) return "PoCL has no cache folder (set POCL_CACHE_DIR to a writable folder)";
    if (const std::string problem = cache_folder_problem(folder); !problem.empty())
        return cat("PoCL could not write its cache folder ", folder.string(), ": ", problem,
                   " (set POCL_CACHE_DIR to a writable folder)");
    return {};
}

/// The folder prepare_environment gave PoCL, when it chose one (not when POCL_CACHE_DIR was set).
fs::path& folder_chosen_here() {
    static fs::path folder;
    return folder;
}

// PoCL 3.1's start creates an empty file tempfile_XXXXXX in its cache folder and leaves it there
// (strace: O_CREAT | O_EXCL before it loads its devices, no unlink): one per process, 1,342 of them
// in a folder of ours after a day of tests. Once PoCL has started, the empty ones older than an
// hour are removed from the folder we chose (one POCL_CACHE_DIR names is left alone), at most once
// an hour (pocl_sweep_due): every process had looked at each of them, and a busy hour's files are
// many (a Slurm array's thousands of starts; a benchmark's few hundred took 1-3 ms of each start,
// on the thread that opens the device). A younger one may be another process's file on its way to
// being written and renamed.
void sweep_pocl_leftovers() {
    static std::once_flag once;
    std::call_once(once, [] {
        const fs::path& folder = folder_chosen_here();
        if (!folder.empty() && pocl_sweep_due(folder, std::chrono::hours(1)))
            remove_pocl_leftovers(folder, std::chrono::hours(1));
    });
}

} // namespace

std::string cache_folder_problem(const fs::path& folder) {
    std::error_code ec;
    fs::create_directories(folder, ec);
    if (ec) return cat("cannot create it: ", ec.message());
    if (!fs::is_directory(folder, ec)) return "not a folder";
    const fs::path probe = folder / cat(".brdf-write-probe.", ::getpid());
    const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0) return cat("cannot write in it: ", std::strerror(errno));
    ::close(fd);
    ::unlink(probe.c_str());
    return {};
}

namespace {

// When `st` was last modified, on the system clock.
std::chrono::system_clock::time_point modified_at(const struct stat& st) {
    return std::chrono::system_clock::time_point(
        std::chrono::duration_cast<std::chrono::system_clock::duration>(
            std::chrono::seconds(st.st_mtim.tv_sec) + std::chrono::nanoseconds(st.st_mtim.tv_nsec)));
}

} // namespace

bool pocl_sweep_due(const fs::path& folder, std::chrono::seconds period) {
    const fs::path stamp = folder / ".brdf-pocl-swept";
    struct stat st {};
    if (::stat(stamp.c_str(), &st) == 0 && std::chrono::system_clock::now() - modified_at(st) < period)
        return false;
    // Touched before the sweep: a process starting meanwhile skips it.
    const int fd = ::open(stamp.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
    if (fd >= 0) {
        ::futimens(fd, nullptr);
        ::close(fd);
    }
    return true;
}

std::size_t remove_pocl_leftovers(const fs::path& folder, std::chrono::seconds min_age) {
    std::error_code ec;
    fs::directory_iterator it(folder, ec);
    if (ec) return 0;
    const auto now = std::chrono::system_clock::now();
    std::size_t removed = 0;
    for (const fs::directory_entry& entry : it) {
        if (!entry.path().filename().string().starts_with("tempfile_")) continue;
        // One lstat for type, size and age: a link is not a regular file, so none is followed.
        struct stat st {};
        if (::lstat(entry.path().c_str(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_size != 0) continue;
        if (now - modified_at(st) < min_age) continue;
        if (fs::remove(entry.path(), ec) && !ec) ++removed;
    }
    if (removed > 0) log::debug("PoCL cache: removed ", removed, " empty tempfile_* left by PoCL's start");
    return removed;
}

fs::path prepare_environment(const fs::path& fallback) {
    static std::once_flag once;
    static fs::path chosen;
    std::call_once(once, [&] {
        if (const std::string set = env("POCL_CACHE_DIR"); !set.empty()) {
            chosen = set;
            return;
        }
        std::vector<fs::path> candidates;
        if (const std::string xdg = env("XDG_CACHE_HOME"); !xdg.empty())
            candidates.push_back(fs::path(xdg) / "brdf" / "pocl");
        std::error_code ec;
        if (const std::string home = env("HOME"); !home.empty() && fs::is_directory(home, ec))
            candidates.push_back(fs::path(home) / ".cache" / "brdf" / "pocl");
        if (!fallback.empty()) candidates.push_back(fs::absolute(fallback, ec) / "pocl");
        if (const fs::path tmp = private_temporary_folder(); !tmp.empty()) candidates.push_back(tmp);
        for (const fs::path& dir : candidates) {
            const std::string problem = cache_folder_problem(dir);
            if (!problem.empty()) {
                log::debug("PoCL cache: not ", dir.string(), " (", problem, ")");
                continue;
            }
            ::setenv("POCL_CACHE_DIR", dir.c_str(), 0);
            chosen = dir;
            folder_chosen_here() = dir;
            log::debug("PoCL cache: POCL_CACHE_DIR=", dir.string());
            return;
        }
        log::debug("PoCL cache: no writable folder found; POCL_CACHE_DIR stays unset");
    });
    return chosen;
}

// ---- errors ------------------------------------------------------------------------------------

const char* error_name(cl_int status) {
    struct Name {
        cl_int code;
        const char* name;
    };
    // From CL/cl.h (1.0 to 3.0) and cl_khr_icd; spelled out so unknown codes still print a name.
    static constexpr Name names[] = {
        {0, "CL_SUCCESS"},
        {-1, "CL_DEVICE_NOT_FOUND"},
        {-2, "CL_DEVICE_NOT_AVAILABLE"},
        {-3, "CL_COMPILER_NOT_AVAILABLE"},
        {-4, "CL_MEM_OBJECT_ALLOCATION_FAILURE"},
        {-5, "CL_OUT_OF_RESOURCES"},
        {-6, "CL_OUT_OF_HOST_MEMORY"},
        {-7, "CL_PROFILING_INFO_NOT_AVAILABLE"},
        {-8, "CL_MEM_COPY_OVERLAP"},
        {-9, "CL_IMAGE_FORMAT_MISMATCH"},
        {-10, "CL_IMAGE_FORMAT_NOT_SUPPORTED"},
        {-11, "CL_BUILD_PROGRAM_FAILURE"},
        {-12, "CL_MAP_FAILURE"},
        {-13, "CL_MISALIGNED_SUB_BUFFER_OFFSET"},
        {-14, "CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST"},
        {-15, "CL_COMPILE_PROGRAM_FAILURE"},
        {-16, "CL_LINKER_NOT_AVAILABLE"},
        {-17, "CL_LINK_PROGRAM_FAILURE"},
        {-18, "CL_DEVICE_PARTITION_FAILED"},
        {-19, "CL_KERNEL_ARG_INFO_NOT_AVAILABLE"},
        {-30, "CL_INVALID_VALUE"},
        {-31, "CL_INVALID_DEVICE_TYPE"},
        {-32, "CL_INVALID_PLATFORM"},
        {-33, "CL_INVALID_DEVICE"},
        {-34, "CL_INVALID_CONTEXT"},
        {-35, "CL_INVALID_QUEUE_PROPERTIES"},
        {-36, "CL_INVALID_COMMAND_QUEUE"},
        {-37, "CL_INVALID_HOST_PTR"},
        {-38, "CL_INVALID_MEM_OBJECT"},
        {-39, "CL_INVALID_IMAGE_FORMAT_DESCRIPTOR"},
        {-40, "CL_INVALID_IMAGE_SIZE"},
        {-41, "CL_INVALID_SAMPLER"},
        {-42, "CL_INVALID_BINARY"},
        {-43, "CL_INVALID_BUILD_OPTIONS"},
        {-44, "CL_INVALID_PROGRAM"},
        {-45, "CL_INVALID_PROGRAM_EXECUTABLE"},
        {-46, "CL_INVALID_KERNEL_NAME"},
        {-47, "CL_INVALID_KERNEL_DEFINITION"},
        {-48, "CL_INVALID_KERNEL"},
        {-49, "CL_INVALID_ARG_INDEX"},
        {-50, "CL_INVALID_ARG_VALUE"},
        {-51, "CL_INVALID_ARG_SIZE"},
        {-52, "CL_INVALID_KERNEL_ARGS"},
        {-53, "CL_INVALID_WORK_DIMENSION"},
        {-54, "CL_INVALID_WORK_GROUP_SIZE"},
        {-55, "CL_INVALID_WORK_ITEM_SIZE"},
        {-56, "CL_INVALID_GLOBAL_OFFSET"},
        {-57, "CL_INVALID_EVENT_WAIT_LIST"},
        {-58, "CL_INVALID_EVENT"},
        {-59, "CL_INVALID_OPERATION"},
        {-60, "CL_INVALID_GL_OBJECT"},
        {-61, "CL_INVALID_BUFFER_SIZE"},
        {-62, "CL_INVALID_MIP_LEVEL"},
        {-63, "CL_INVALID_GLOBAL_WORK_SIZE"},
        {-64, "CL_INVALID_PROPERTY"},
        {-65, "CL_INVALID_IMAGE_DESCRIPTOR"},
        {-66, "CL_INVALID_COMPILER_OPTIONS"},
        {-67, "CL_INVALID_LINKER_OPTIONS"},
        {-68, "CL_INVALID_DEVICE_PARTITION_COUNT"},
        {-69, "CL_INVALID_PIPE_SIZE"},
        {-70, "CL_INVALID_DEVICE_QUEUE"},
        {-71, "CL_INVALID_SPEC_ID"},
        {-72, "CL_MAX_SIZE_RESTRICTION_EXCEEDED"},
        {-1001, "CL_PLATFORM_NOT_FOUND_KHR"},
    };
    for (const Name& n : names)
        if (n.code == status) return n.name;
    return "CL_UNKNOWN_ERROR";
}

void check(cl_int status, std::string_view what) {
    if (status != CL_SUCCESS)
        throw DeviceError(cat(what, ": ", error_name(status), " (", status, ")"));
}

// ---- device selection --------------------------------------------------------------------------

std::size_t select_device(std::span<const DeviceCandidate> devices, std::size_t platforms,
                          std::string_view filter) {
    if (platforms == 0) throw DeviceError(no_platform_message);
    if (devices.empty())
        throw DeviceError(cat("OpenCL platform found but it has no device (", platforms,
                              " platform(s); use --device cpu)"));
    const auto matches = [&](const DeviceCandidate& d) {
        return filter.empty() || d.name.find(filter) != std::string::npos ||
               d.platform.find(filter) != std::string::npos;
    };
    const DeviceCandidate* first_match = nullptr;
    for (std::size_t i = 0; i < devices.size(); ++i) {
        if (!matches(devices[i])) continue;
        if (devices[i].fp64) return i;
        if (!first_match) first_match = &devices[i];
    }
    if (!first_match)
        throw DeviceError(cat("BRDF_OPENCL_DEVICE='", filter, "' matches no OpenCL device (found ",
                              list_devices(devices), ")"));
    std::size_t match_count = 0;
    for (const DeviceCandidate& d : devices) match_count += matches(d) ? 1 : 0;
    if (match_count == 1)
        throw DeviceError(
            cat("OpenCL device '", first_match->name, "' lacks double precision (cl_khr_fp64)"));
    throw DeviceError(cat("no OpenCL device", filter.empty() ? "" : cat(" matching '", filter, "'"),
                          " has double precision (cl_khr_fp64); found ", list_devices(devices)));
}

namespace {

/// available() and unavailable_reason(), found out once: device selection as Context does it.
const std::string& availability() {
    static const std::string reason = [] {
        try {
            const Enumerated e = enumerate_devices();
            try {
                select_device(e.candidates, e.platforms, {});
            } catch (const DeviceError& error) {
                if (e.platforms == 0 || !e.devices.empty()) throw;
                const std::string cause = empty_platform_cause();
                throw DeviceError(cause.empty() ? std::string(error.what()) : cat(error.what(), ": ", cause));
            }
            return std::string();
        } catch (const std::exception& error) {
            return std::string(error.what());
        }
    }();
    return reason;
}

} // namespace

bool available() { return availability().empty(); }

std::string unavailable_reason() { return availability(); }

ContextOptions options_from_environment() {
    ContextOptions options;
    options.device_filter = env("BRDF_OPENCL_DEVICE");
    options.kernel_dir = env("BRDF_KERNEL_DIR");
    options.cache_dir = cache_root();
    return options;
}

// ---- context -----------------------------------------------------------------------------------

struct Context::Entry {
    std::mutex mutex; // held while building, so each (name, options) is built once
    ::cl::Program program;
    bool built = false;
};

Context::Context(ContextOptions options) : m_options(std::move(options)) {
    const Enumerated e = enumerate_devices();
    const std::size_t index = [&] {
        try {
            return select_device(e.candidates, e.platforms, m_options.device_filter);
        } catch (const DeviceError& error) {
            // PoCL's CPU device does not initialise when it cannot write its cache: say so.
            if (e.platforms == 0 || !e.devices.empty()) throw;
            const std::string cause = empty_platform_cause();
            if (cause.empty()) throw;
            throw DeviceError(cat(error.what(), ": ", cause));
        }
    }();
    m_device = e.devices[index];

    m_info.platform = e.candidates[index].platform;
    m_info.name = e.candidates[index].name;
    m_info.version = device_info<std::string>(m_device, CL_DEVICE_VERSION, "version");
    m_info.driver = device_info<std::string>(m_device, CL_DRIVER_VERSION, "driver version");
    m_info.opencl_c_version =
        device_info<std::string>(m_device, CL_DEVICE_OPENCL_C_VERSION, "OpenCL C version");
    m_info.global_mem_bytes = device_info<cl_ulong>(m_device, CL_DEVICE_GLOBAL_MEM_SIZE, "memory");
    m_info.local_mem_bytes =
        device_info<cl_ulong>(m_device, CL_DEVICE_LOCAL_MEM_SIZE, "local memory");
    m_info.max_work_group_size =
        device_info<std::size_t>(m_device, CL_DEVICE_MAX_WORK_GROUP_SIZE, "max work-group size");
    m_info.compute_units =
        device_info<cl_uint>(m_device, CL_DEVICE_MAX_COMPUTE_UNITS, "compute units");
    m_info.cpu = (device_info<cl_device_type>(m_device, CL_DEVICE_TYPE, "type") & CL_DEVICE_TYPE_CPU) != 0;

    cl_int err = CL_SUCCESS;
    m_context = ::cl::Context(m_device, nullptr, nullptr, nullptr, &err);
    check(err, cat("create OpenCL context on '", m_info.name, "'"));
    m_queue = ::cl::CommandQueue(m_context, m_device, 0, &err);
    check(err, cat("create OpenCL command queue on '", m_info.name, "'"));

    log::debug("OpenCL device: ", m_info.name, " (", m_info.platform, ", ", m_info.version,
               ", driver ", m_info.driver, ")");
    if (!m_options.kernel_dir.empty()) {
        static std::atomic<bool> logged{false};
        if (!logged.exchange(true))
            log::info("OpenCL kernels are read from ", m_options.kernel_dir.string(),
                      " (BRDF_KERNEL_DIR), not the embedded copies");
    }
}

std::shared_ptr<Context> Context::shared() {
    static std::mutex mutex;
    static std::shared_ptr<Context> instance;
    const std::lock_guard lock(mutex);
    if (!instance) instance = std::make_shared<Context>(options_from_environment());
    return instance;
}

ProgramCacheStats Context::cache_stats() const {
    const std::lock_guard lock(m_mutex);
    return m_stats;
}

std::string Context::read_kernel_file(std::string_view path) const {
    if (m_options.kernel_dir.empty()) {
        if (const auto data = find_embedded(embedded::kernel_sources(), path))
            return std::string(*data);
        throw DeviceError(
            cat("kernels/", path, ": not embedded (list it in src/brdf/cl/CMakeLists.txt)"));
    }
    const fs::path file = m_options.kernel_dir / fs::path(path);
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(file, ec);
    std::ifstream in(file, std::ios::binary);
    std::string text(ec ? 0 : static_cast<std::size_t>(size), '\0');
    if (ec || !in || !in.read(text.data(), static_cast<std::streamsize>(text.size())))
        throw DeviceError(cat(file.string(), ": cannot read kernel source (BRDF_KERNEL_DIR)"));
    return text;
}

std::string Context::source(std::string_view name) const {
    if (!valid_program_name(name))
        throw DeviceError(
            cat("OpenCL program '", name, "': invalid name (letters, digits, _ and -)"));
    const std::string file = cat(name, ".cl");
    const std::string text = read_kernel_file(file);
    const auto read = [this](const std::string& path) -> std::optional<std::string> {
        try {
            return read_kernel_file(path);
        } catch (const DeviceError&) {
            return std::nullopt;
        }
    };
    std::set<std::string> seen;
    std::string out = cat("#line 1 \"", file, "\"\n");
    try {
        inline_includes(text, file, read, seen, out);
    } catch (const DeviceError& e) {
        throw DeviceError(cat("OpenCL program '", name, "': ", e.what()));
    }
    return out;
}

::cl::Program Context::program(std::string_view name, std::string_view options) {
    const std::string key = cat(name, '\n', options);
    std::shared_ptr<Entry> entry;
    {
        const std::lock_guard lock(m_mutex);
        auto it = m_programs.find(key);
        if (it == m_programs.end()) it = m_programs.emplace(key, std::make_shared<Entry>()).first;
        entry = it->second;
    }
    const std::lock_guard lock(entry->mutex);
    if (entry->built) {
        const std::lock_guard stats_lock(m_mutex);
        ++m_stats.memory_hits;
        return entry->program;
    }
    std::string all_options = "-cl-std=CL1.2";
    if (!options.empty()) all_options += cat(" ", options);
    entry->program = build(name, all_options);
    entry->built = true; // only after success: a failed build is retried by the next call
    return entry->program;
}

::cl::Program Context::build(std::string_view name, const std::string& options) {
    if (is_fast_math_option(options))
        throw DeviceError(cat("OpenCL program '", name, "': options '", options,
                              "' relax IEEE arithmetic, which the solvers do not allow"));
    const std::string src = source(name);
    const std::string key =
        cat("brdf-cl-cache 1\nplatform ", m_info.platform, "\ndevice ", m_info.name, "\nversion ",
            m_info.version, "\ndriver ", m_info.driver, "\noptions ", options, "\nsource\n", src);

    std::optional<BlobCache> cache;
    if (!m_options.cache_dir.empty()) cache.emplace(m_options.cache_dir / "opencl", cache_magic);

    cl_int err = CL_SUCCESS;
    if (cache) {
        if (const std::optional<std::string> stored = cache->load(key)) {
            std::vector<unsigned char> binary(stored->begin(), stored->end());
            std::vector<cl_int> status;
            ::cl::Program program(m_context, {m_device}, ::cl::Program::Binaries{std::move(binary)},
                                  &status, &err);
            if (err == CL_SUCCESS && !status.empty() && status[0] == CL_SUCCESS)
                err = program.build({m_device}, options.c_str());
            if (err == CL_SUCCESS) {
                const std::lock_guard lock(m_mutex);
                ++m_stats.disk_hits;
                return program;
            }
            log::debug("OpenCL binary cache: ", cache->file(key).string(), " unusable (", error_name(err),
                       "); building '", name, "' from source");
        }
    }

    ::cl::Program program(m_context, src, false, &err);
    check(err, cat("OpenCL program '", name, "': create from source"));
    err = program.build({m_device}, options.c_str());
    if (err != CL_SUCCESS) {
        cl_int log_err = CL_SUCCESS;
        std::string build_log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(m_device, &log_err);
        if (log_err != CL_SUCCESS) build_log = cat("(no build log: ", error_name(log_err), ")");
        if (build_log.size() > max_build_log)
            build_log = build_log.substr(0, max_build_log) + "\n... (build log truncated)";
        throw DeviceError(cat("OpenCL program '", name, "' failed to build on '", m_info.name,
                              "' (", error_name(err), ", options '", options, "'):\n", build_log));
    }
    {
        const std::lock_guard lock(m_mutex);
        ++m_stats.builds;
    }

    if (cache) {
        // A single device, so CL_PROGRAM_BINARIES holds exactly one binary.
        const auto binaries = program.getInfo<CL_PROGRAM_BINARIES>(&err);
        if (err == CL_SUCCESS && binaries.size() == 1 && !binaries[0].empty() &&
            cache->store(key, std::string_view(reinterpret_cast<const char*>(binaries[0].data()), binaries[0].size()))) {
            const std::lock_guard lock(m_mutex);
            ++m_stats.disk_writes;
        } else {
            log::debug("OpenCL binary cache: cannot write ", cache->file(key).string());
        }
    }
    return program;
}

} // namespace brdf::cl
