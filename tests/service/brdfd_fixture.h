#pragma once
// The real brdfd binary as a child process (shared by the brdfd tests): started with arguments, its
// stdout and stderr going to a log file, signalled, waited for. With a BRDFD_TEST_RUNNER hook it is
// brdfd_test (the same daemon with the sleep hook, tests/service/brdfd_test_main.cpp); without one,
// the shipped brdfd.

#include "spool_fixture.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <optional>
#include <stdexcept>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

extern char** environ;

namespace brdf::test {

namespace fs = std::filesystem;

/// brdfd running in the background, its stdout and stderr going to a file; killed if still running
/// when destroyed.
class Brdfd {
public:
    /// `extra_env`: NAME=VALUE entries added to (or replacing) the test's environment.
    Brdfd(const std::vector<std::string>& args, const std::string& test_runner, const fs::path& log,
          const std::vector<std::string>& extra_env = {})
        : m_log(log) {
        std::vector<std::string> argv{(bin_dir() / (test_runner.empty() ? "brdfd" : "brdfd_test")).string()};
        argv.insert(argv.end(), args.begin(), args.end());
        std::vector<std::string> env;
        const auto replaced = [&](const char* entry) {
            if (std::strncmp(entry, "BRDFD_TEST_RUNNER=", 18) == 0) return true;
            for (const std::string& x : extra_env)
                if (std::strncmp(entry, x.c_str(), x.find('=') + 1) == 0) return true;
            return false;
        };
        for (char** e = environ; *e; ++e)
            if (!replaced(*e)) env.emplace_back(*e);
        if (!test_runner.empty()) env.push_back("BRDFD_TEST_RUNNER=" + test_runner);
        env.insert(env.end(), extra_env.begin(), extra_env.end());
        // Everything exec needs is built before fork: the child only dup2s and execs.
        std::vector<char*> cargv, cenv;
        for (std::string& a : argv) cargv.push_back(a.data());
        cargv.push_back(nullptr);
        for (std::string& e : env) cenv.push_back(e.data());
        cenv.push_back(nullptr);
        const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0) throw std::runtime_error("cannot create " + log.string());
        m_pid = fork();
        if (m_pid < 0) throw std::runtime_error("fork failed");
        if (m_pid == 0) {
            dup2(fd, 1);
            dup2(fd, 2);
            execve(cargv[0], cargv.data(), cenv.data());
            _exit(127);
        }
        ::close(fd);
    }
    ~Brdfd() {
        if (m_pid > 0 && !m_status) {
            kill(m_pid, SIGKILL);
            waitpid(m_pid, nullptr, 0);
        }
    }
    Brdfd(const Brdfd&) = delete;
    Brdfd& operator=(const Brdfd&) = delete;

    void signal(int signo) const { kill(m_pid, signo); }
    pid_t pid() const { return m_pid; }
    /// Exit status (128 + signal when killed by one), or -1 if still running after `seconds`.
    int wait(double seconds) {
        if (m_status) return *m_status;
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
        for (;;) {
            int status = 0;
            if (waitpid(m_pid, &status, WNOHANG) == m_pid) {
                m_status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
                return *m_status;
            }
            if (std::chrono::steady_clock::now() > deadline) return -1;
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
    }
    std::string log() const { return read_file(m_log); }

private:
    fs::path m_log;
    pid_t m_pid = -1;
    std::optional<int> m_status;
};

inline nlohmann::json status_of(const fs::path& spool) {
    try {
        return nlohmann::json::parse(read_file(spool / "status.json"));
    } catch (const std::exception&) {
        return nlohmann::json::object();
    }
}

inline bool running_jobs(const fs::path& spool, std::size_t n) {
    const nlohmann::json s = status_of(spool);
    return s.contains("running") && s["running"].size() == n;
}

} // namespace brdf::test
