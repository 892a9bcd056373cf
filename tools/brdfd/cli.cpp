// brdfd: the batch daemon. Serves a spool folder (docs/daemon.md, docs/design.md "Daemon").
// Like brdftool's main, this is one of the two places errors are caught: a brdf::Error that stops the
// daemon (a spool it cannot create, bad flags) becomes one line on stderr and its exit status; job
// errors are caught per job inside run_daemon and never get here.

#include "cli.h"

#include <brdf/cl/context.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/version.h>
#include <brdf/service/daemon.h>

#include <usage.h>

#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <string>

namespace brdf::tool {
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

} // namespace

int brdfd_main(int argc, char** argv, const std::function<service::JobRunner()>& make_runner) {
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
    app.add_option("--settle", options.settle_seconds,
                   "seconds a spec written in place into DIR/incoming/ must stay unchanged before "
                   "it is taken (default 1; specs renamed in are taken at once)")
        ->check(CLI::Range(0.0, 3600.0));
    app.add_option("--log-level", log_level, "error, warn, info (default) or debug")
        ->envname("BRDF_LOG");
    keep_unknown_arguments(app);

    try {
        try {
            app.parse(argc, argv);
        } catch (const CLI::CallForHelp&) {
            throw;
        } catch (const CLI::CallForVersion&) {
            throw;
        } catch (const CLI::ParseError& e) {
            std::fprintf(stderr, "brdfd: %s (see brdfd --help)\n", usage_problem(app, &e)->c_str());
            return usage_status;
        }
        if (const auto problem = usage_problem(app, nullptr)) {
            std::fprintf(stderr, "brdfd: %s (see brdfd --help)\n", problem->c_str());
            return usage_status;
        }
        // A daemon's log is its record of work: one line per job start and finish by default.
        log::set_level(log_level.empty() ? log::Level::Info : log::parse_level(log_level));
        // Before any thread starts and before OpenCL is first touched (the daemon usually has no
        // writable home: PoCL's kernel cache goes under the spool then).
        brdf::cl::prepare_environment(options.spool / ".cache");
        const service::JobRunner runner = make_runner();
        options.handle_signals = true;
        return service::run_daemon(options, runner);
    } catch (const CLI::ParseError& e) { // --help, --version
        return app.exit(e);
    } catch (const Error& e) {
        std::fprintf(stderr, "brdfd: %s\n", e.what());
        return exit_status(e.kind());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "brdfd: internal error: %s\n", e.what());
        return internal_status;
    }
}

} // namespace brdf::tool
