// brdftool: compute, inspect and convert BRDF tables. See ../../README.md and docs/design.md.
// This is one of the two places errors are caught (the other is each daemon job): every brdf::Error
// becomes one line on stderr and its documented exit status; anything else is an internal error.
//
// Like git: `brdftool help` prints the command list (status 0), `brdftool` alone prints it too but
// exits 2 (nothing was done: a usage error), and every usage error is one line on stderr,
// "brdftool: compute: unknown option --foo (see 'brdftool help compute')", exit status 2.

#include "commands.h"

#include <brdf/cl/context.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/version.h>

#include <leak_check.h>
#include <usage.h>

#include <cstdio>
#include <exception>
#include <iostream>
#include <malloc.h>
#include <vector>

namespace {

constexpr int usage_status = 2;
constexpr int internal_status = 70;

const char* exit_status_help = R"(Run 'brdftool help COMMAND' (or 'brdftool COMMAND --help') for a command's options.

Exit status:
  0  success            2  usage error          3  invalid input (spec, flags, values)
  4  malformed table    5  OpenCL device error  6  numerical failure
  7  file I/O error     8  resource limit       70 internal error
  1  compute: at least one material failed (the others were written))";

/// A usage error, already worded; printed as "brdftool: MESSAGE".
struct UsageError {
    std::string message;
};

/// How to get help for what the user was typing.
std::string help_hint(const CLI::App& root) {
    const CLI::App& command = brdf::tool::innermost_command(root);
    return &command == &root ? std::string(" (see 'brdftool help')")
                             : " (see 'brdftool help " + command.get_name() + "')";
}

} // namespace

int run_brdftool(int argc, char** argv) {
    using namespace brdf;
    CLI::App app{"brdftool: BRDF tables of real materials from first principles "
                 "(Lorenz-Mie + Ambartsumian's equation)",
                 "brdftool"};
    app.set_version_flag("--version", generator_string);
    app.require_subcommand(1);
    app.footer(exit_status_help);
    std::string log_level;
    app.add_option("--log-level", log_level, "error, warn (default), info or debug")
        ->envname("BRDF_LOG");

    std::vector<tool::Subcommand> commands;
    commands.push_back(tool::add_compute_command(app));
    commands.push_back(tool::add_eval_command(app));
    commands.push_back(tool::add_albedo_command(app));
    commands.push_back(tool::add_mie_command(app));
    commands.push_back(tool::add_convert_command(app));
    commands.push_back(tool::add_info_command(app));
    commands.push_back(tool::add_diff_command(app));
    commands.push_back(tool::add_render_command(app));
    commands.push_back(tool::add_lobes_command(app));
    commands.push_back(tool::add_hiding_command(app));

    // `brdftool help [CMD]` prints the same usage as `brdftool CMD --help`.
    std::string help_topic;
    CLI::App* help = app.add_subcommand("help", "Show the command list, or the usage of one command");
    help->add_option("command", help_topic, "command name");
    tool::keep_unknown_arguments(app);

    // The root's own usage: app.help() would show the usage of whichever subcommand was parsed.
    const auto command_list = [&app] {
        return app.get_formatter()->make_help(&app, app.get_name(), CLI::AppFormatMode::Normal);
    };
    if (argc <= 1) { // nothing asked: the command list, as git does, but not a success
        std::cout << command_list();
        return usage_status;
    }
    try {
        try {
            app.parse(argc, argv);
        } catch (const CLI::Success&) { // --help, --version
            throw;
        } catch (const CLI::ParseError& e) {
            throw UsageError{*tool::usage_problem(app, &e) + help_hint(app)};
        }
        if (const auto problem = tool::usage_problem(app, nullptr))
            throw UsageError{*problem + help_hint(app)};
        if (!log_level.empty()) log::set_level(log::parse_level(log_level));
        if (help->parsed()) {
            if (help_topic.empty()) {
                std::cout << command_list();
                return 0;
            }
            if (help_topic == "help") {
                std::cout << help->help(app.get_name());
                return 0;
            }
            for (const tool::Subcommand& c : commands)
                if (c.app->get_name() == help_topic) {
                    std::cout << c.app->help(app.get_name());
                    return 0;
                }
            throw UsageError{cat("help: unknown command '", help_topic, "' (see 'brdftool help')")};
        }
        // Before any thread starts and before OpenCL is first touched: PoCL's kernel cache must go
        // somewhere writable (a home that is not there, a read-only one).
        brdf::cl::prepare_environment();
        for (const tool::Subcommand& c : commands)
            if (c.app->parsed()) return c.run();
        throw UsageError{"no command given (see 'brdftool help')"};
    } catch (const UsageError& e) {
        std::fprintf(stderr, "brdftool: %s\n", e.message.c_str());
        return usage_status;
    } catch (const CLI::ParseError& e) {
        return app.exit(e); // help or version, printed on stdout, status 0
    } catch (const Error& e) {
        std::fprintf(stderr, "brdftool: %s%s\n", e.kind() == ErrorKind::Internal ? "internal error: " : "",
                     e.what());
        return exit_status(e.kind());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "brdftool: internal error: %s\n", e.what());
        return internal_status;
    }
}

int main(int argc, char** argv) {
    // A run allocates, frees and allocates again buffers of 0.1-30 MB (the solves' matrices, the
    // grids, the single-scattering tables): glibc maps each one above 128 KB afresh and the kernel
    // zeroes its pages on first touch, 14 % of a seed run's CPU time in page faults. brdftool is a
    // short-lived process: freed memory stays in the heap for the next buffer (only the 35 MB
    // tables are mapped on their own), and is returned at exit. 0.375 -> 0.357 s for the seed.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
    return brdf::tool::after_leak_check(run_brdftool(argc, argv));
}
