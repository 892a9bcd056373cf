#include "test_support.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <poll.h>
#include <random>
#include <signal.h>
#include <sstream>
#include <stdexcept>
#include <sys/wait.h>
#include <unistd.h>

namespace brdf::test {

::testing::AssertionResult rel_near(const char* value_expr, const char* ref_expr,
                                    const char* tol_expr, double value, double reference,
                                    double tol) {
    const double diff = std::abs(value - reference);
    const double scale = reference == 0.0 ? 1.0 : std::abs(reference);
    if (std::isfinite(value) && diff <= tol * scale) return ::testing::AssertionSuccess();
    std::ostringstream os;
    os.precision(12);
    os << value_expr << " = " << value << ", reference " << ref_expr << " = " << reference
       << ": relative difference " << diff / scale << " exceeds " << tol_expr << " = " << tol;
    return ::testing::AssertionFailure() << os.str();
}

namespace {
// Before any test touches OpenCL: PoCL's kernel cache and ours go into the build tree (unless the
// caller chose other places), so test runs are reproducible and never write to $HOME.
const bool cache_dirs_set = [] {
    setenv("POCL_CACHE_DIR", BRDF_TEST_CACHE_DIR "/pocl", 0);
    setenv("BRDF_CACHE_DIR", BRDF_TEST_CACHE_DIR "/brdf", 0);
    return true;
}();
} // namespace

std::filesystem::path source_dir() { return BRDF_TEST_SOURCE_DIR; }
std::filesystem::path bin_dir() { return BRDF_TEST_BIN_DIR; }

TempDir::TempDir() {
    std::random_device rd;
    for (int attempt = 0; attempt < 100; ++attempt) {
        auto candidate = std::filesystem::temp_directory_path() /
                         ("brdf-test-" + std::to_string(::getpid()) + "-" + std::to_string(rd()));
        if (std::filesystem::create_directory(candidate)) {
            m_path = candidate;
            return;
        }
    }
    throw std::runtime_error("TempDir: cannot create a temporary folder");
}

TempDir::~TempDir() {
    std::error_code ec;
    // Tests may leave read-only folders behind (permission tests); make them removable first.
    for (auto it = std::filesystem::recursive_directory_iterator(m_path, ec);
         it != std::filesystem::recursive_directory_iterator(); it.increment(ec))
        std::filesystem::permissions(it->path(), std::filesystem::perms::owner_all,
                                     std::filesystem::perm_options::add, ec);
    std::filesystem::remove_all(m_path, ec);
}

ProcessResult run_process(const std::vector<std::string>& argv, const std::string& input) {
    int in_pipe[2], out_pipe[2], err_pipe[2];
    if (pipe(in_pipe) || pipe(out_pipe) || pipe(err_pipe)) throw std::runtime_error("pipe failed");
    const pid_t pid = fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
        dup2(in_pipe[0], 0);
        dup2(out_pipe[1], 1);
        dup2(err_pipe[1], 2);
        for (int fd : {in_pipe[0], in_pipe[1], out_pipe[0], out_pipe[1], err_pipe[0], err_pipe[1]})
            close(fd);
        std::vector<char*> args;
        for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
        args.push_back(nullptr);
        execv(args[0], args.data());
        _exit(127);
    }
    close(in_pipe[0]);
    close(out_pipe[1]);
    close(err_pipe[1]);
    // Feed stdin and drain both outputs together so no pipe fills up and deadlocks.
    signal(SIGPIPE, SIG_IGN);
    std::size_t written = 0;
    if (input.empty()) close(in_pipe[1]);
    ProcessResult result;
    bool out_open = true, err_open = true, in_open = !input.empty();
    while (out_open || err_open) {
        pollfd fds[3];
        int n = 0;
        if (out_open) fds[n++] = {out_pipe[0], POLLIN, 0};
        if (err_open) fds[n++] = {err_pipe[0], POLLIN, 0};
        if (in_open) fds[n++] = {in_pipe[1], POLLOUT, 0};
        if (poll(fds, n, -1) < 0) break;
        for (int i = 0; i < n; ++i) {
            if (!fds[i].revents) continue;
            if (fds[i].fd == in_pipe[1]) {
                const ssize_t k = write(in_pipe[1], input.data() + written, input.size() - written);
                if (k > 0) written += static_cast<std::size_t>(k);
                if (k <= 0 || written == input.size()) {
                    close(in_pipe[1]);
                    in_open = false;
                }
                continue;
            }
            char buf[65536];
            const ssize_t k = read(fds[i].fd, buf, sizeof buf);
            std::string& sink = fds[i].fd == out_pipe[0] ? result.out : result.err;
            if (k > 0) {
                sink.append(buf, static_cast<std::size_t>(k));
            } else {
                close(fds[i].fd);
                (fds[i].fd == out_pipe[0] ? out_open : err_open) = false;
            }
        }
    }
    if (in_open) close(in_pipe[1]);
    int status = 0;
    waitpid(pid, &status, 0);
    result.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return result;
}

ProcessResult run_tool(const std::string& tool, const std::vector<std::string>& args,
                       const std::string& input) {
    std::vector<std::string> argv{(bin_dir() / tool).string()};
    argv.insert(argv.end(), args.begin(), args.end());
    return run_process(argv, input);
}

std::string read_file(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read " + path.string());
    std::ostringstream os;
    os << in.rdbuf();
    return os.str();
}

void write_file(const std::filesystem::path& path, const std::string& content) {
    std::ofstream out(path, std::ios::binary);
    out << content;
    if (!out) throw std::runtime_error("cannot write " + path.string());
}

ScopedEnv::ScopedEnv(const char* name, const char* value) : m_name(name) {
    if (const char* old = std::getenv(name)) m_old = old;
    if (value) ::setenv(name, value, 1);
    else ::unsetenv(name);
}

ScopedEnv::~ScopedEnv() {
    if (m_old) ::setenv(m_name.c_str(), m_old->c_str(), 1);
    else ::unsetenv(m_name.c_str());
}

} // namespace brdf::test
