// brdfd: the batch daemon. Serves a spool folder (docs/daemon.md, docs/design.md "Daemon").
// Like brdftool's main, this is one of the two places errors are caught: a brdf::Error that stops the
// daemon (a spool it cannot create, bad flags) becomes one line on stderr and its exit status; job
// errors are caught per job inside run_daemon and never get here.

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/version.h>
#include <brdf/service/compute.h>
#include <brdf/service/daemon.h>
#include <brdf/service/spool.h>

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <string>
#include <thread>
#include <unistd.h>

namespace {

constexpr int usage_status = 2;
constexpr int internal_status = 70;

const char* footer = R"(Spool layout (created when missing):
  DIR/incoming/   drop NAME.json specs here (write elsewhere, then rename in;
                  hidden files and *.tmp are ignored); oldest first
  DIR/active/     jobs being computed (claimed by an atomic rename)
  DIR/results/    NAME.binary, NAME.exr, NAME.report.json
  DIR/done/       specs that succeeded
  DIR/failed/     specs that failed, each with NAME.error.json
  DIR/status.json queue length, running jobs, done, failed, state
SIGTERM/SIGINT: take no new jobs, let running jobs finish, exit 0.

Exit status:
  0  stopped by SIGTERM/SIGINT, or --once and every job succeeded
  1  --once: at least one job failed (see DIR/failed/*.error.json)
  2  usage error          3  invalid input (flags)   7  spool not usable (I/O)
  70 internal error)";

/// Test hook, not a user feature: BRDFD_TEST_RUNNER=sleep:SECONDS[,write:SECONDS] replaces the compute
/// pipeline by a runner that sleeps, then fails with an input error if the spec contains
/// "brdfd-test-fail" and otherwise writes results/NAME.result (a copy of the spec). With `write:W` the
/// result is written the way the table writers do it, slowly: a hidden temporary
/// ".NAME.result.tmp.PID.N.STAMP", half the text, W seconds, the rest, rename; so tests can kill the
/// daemon while a result is half written. Lets tests drive the real binary (signals, exit statuses,
/// kills) without computing anything.
brdf::service::JobRunner test_runner(const std::string& hook) {
    using namespace brdf;
    double seconds = -1.0, write_seconds = 0.0;
    const auto number = [](const std::string& text, const std::string& prefix) {
        if (text.rfind(prefix, 0) != 0) return -1.0;
        try {
            std::size_t used = 0;
            const double v = std::stod(text.substr(prefix.size()), &used);
            return used == text.size() - prefix.size() ? v : -1.0;
        } catch (const std::exception&) {
            return -1.0;
        }
    };
    const std::size_t comma = hook.find(',');
    seconds = number(hook.substr(0, comma), "sleep:");
    if (comma != std::string::npos) write_seconds = number(hook.substr(comma + 1), "write:");
    if (!(seconds >= 0.0) || !std::isfinite(seconds) || !(write_seconds >= 0.0) ||
        !std::isfinite(write_seconds))
        throw InputError(
            cat("BRDFD_TEST_RUNNER: expected sleep:SECONDS[,write:SECONDS] (got '", hook, "')"));
    log::warn("brdfd: test hook BRDFD_TEST_RUNNER=", hook, ": jobs sleep instead of computing");
    return [seconds, write_seconds](const std::filesystem::path& spec,
                                    const std::filesystem::path& results) {
        std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
        std::ifstream in(spec, std::ios::binary);
        std::string text;
        char buf[4096];
        while (in.read(buf, sizeof buf) || in.gcount() > 0)
            text.append(buf, static_cast<std::size_t>(in.gcount()));
        if (text.find("brdfd-test-fail") != std::string::npos)
            throw InputError(cat(spec.filename().string(), ": test hook: failing as asked"));
        const std::filesystem::path target = results / (spec.stem().string() + ".result");
        if (write_seconds <= 0.0) {
            service::write_file_atomic(target, text, false);
            return;
        }
        static std::atomic<unsigned> counter{0};
        const std::filesystem::path tmp =
            results / cat(".", target.filename().string(), ".tmp.", ::getpid(), ".", counter++, ".",
                          std::chrono::steady_clock::now().time_since_epoch().count() % 1000000);
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        if (!out) throw IoError(cat(target.string(), ": cannot create a temporary file"));
        out << text.substr(0, text.size() / 2) << std::flush;
        std::this_thread::sleep_for(std::chrono::duration<double>(write_seconds));
        out << text.substr(text.size() / 2) << std::flush;
        out.close();
        if (!out || std::rename(tmp.c_str(), target.c_str()) != 0) {
            std::remove(tmp.c_str());
            throw IoError(cat(target.string(), ": cannot write"));
        }
    };
}

} // namespace

int main(int argc, char** argv) {
    using namespace brdf;
    CLI::App app{"brdfd: the BRDF batch daemon. Serves a spool folder: computes every spec dropped "
                 "into DIR/incoming/ and files it under DIR/done/ or DIR/failed/",
                 "brdfd"};
    app.set_version_flag("--version", generator_string);
    app.footer(footer);
    service::DaemonOptions options;
    std::string log_level;
    app.add_option("--spool", options.spool, "spool folder DIR")->required();
    app.add_option("--workers", options.workers, "jobs computed at once (default 1)")
        ->check(CLI::Range(1, 1024));
    app.add_flag("--once", options.once,
                 "drain the spool and exit: status 0 if every job succeeded, 1 if any failed");
    app.add_option("--poll", options.poll_seconds,
                   "seconds between looks into DIR/incoming/ when idle (default 0.5); new "
                   "specs wake idle workers at once through inotify, polling is the fallback")
        ->check(CLI::Range(0.001, 3600.0));
    app.add_option("--log-level", log_level, "error, warn, info (default) or debug")
        ->envname("BRDF_LOG");

    try {
        app.parse(argc, argv);
        // A daemon's log is its record of work: one line per job start and finish by default.
        log::set_level(log_level.empty() ? log::Level::Info : log::parse_level(log_level));
        service::JobRunner runner = service::run_compute_job;
        if (const char* hook = std::getenv("BRDFD_TEST_RUNNER"); hook && *hook)
            runner = test_runner(hook);
        options.handle_signals = true;
        return service::run_daemon(options, runner);
    } catch (const CLI::ParseError& e) {
        const int status = app.exit(e);
        return status == 0 ? 0 : usage_status;
    } catch (const Error& e) {
        std::fprintf(stderr, "brdfd: %s\n", e.what());
        return exit_status(e.kind());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "brdfd: internal error: %s\n", e.what());
        return internal_status;
    }
}
