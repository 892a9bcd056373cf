// brdftool: compute, inspect and convert BRDF tables. See ../../README.md and docs/design.md.
// This is one of the two places errors are caught (the other is each daemon job): every brdf::Error
// becomes one line on stderr and its documented exit status; anything else is an internal error.

#include "commands.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/version.h>

#include <cstdio>
#include <exception>
#include <iostream>
#include <vector>

namespace {

constexpr int usage_status = 2;
constexpr int internal_status = 70;

const char* exit_status_help = R"(Exit status:
  0  success            2  usage error          3  invalid input (spec, flags, values)
  4  malformed table    5  OpenCL device error  6  numerical failure
  7  file I/O error     8  resource limit       70 internal error
  1  compute: at least one material failed (the others were written))";

} // namespace

int main(int argc, char** argv) {
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

    // `brdftool help [CMD]` prints the same usage as `brdftool CMD --help`.
    std::string help_topic;
    CLI::App* help = app.add_subcommand("help", "Show usage of brdftool or of one subcommand");
    help->add_option("command", help_topic, "subcommand name");

    try {
        app.parse(argc, argv);
        if (!log_level.empty()) log::set_level(log::parse_level(log_level));
        if (help->parsed()) {
            if (help_topic.empty()) {
                std::cout << app.help();
                return 0;
            }
            for (const tool::Subcommand& c : commands)
                if (c.app->get_name() == help_topic) {
                    std::cout << c.app->help();
                    return 0;
                }
            throw InputError(cat("help: unknown subcommand '", help_topic, "'"));
        }
        for (const tool::Subcommand& c : commands)
            if (c.app->parsed()) return c.run();
        return usage_status;
    } catch (const CLI::ParseError& e) {
        const int status = app.exit(e);
        return status == 0 ? 0 : usage_status;
    } catch (const Error& e) {
        std::fprintf(stderr, "brdftool: %s\n", e.what());
        return exit_status(e.kind());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "brdftool: internal error: %s\n", e.what());
        return internal_status;
    }
}
