#pragma once
// Each subcommand lives in its own cmd_*.cpp and registers itself on the root app. Parsing fills the
// options; main then runs the one subcommand that was given. Commands throw brdf::Error on failure.

#include <CLI/CLI.hpp>

#include <functional>

namespace brdf::tool {

struct Subcommand {
    CLI::App* app = nullptr;
    std::function<int()> run; ///< returns the exit status (0 success)
};

Subcommand add_mie_command(CLI::App& root);
Subcommand add_compute_command(CLI::App& root);
Subcommand add_eval_command(CLI::App& root);
Subcommand add_albedo_command(CLI::App& root);
Subcommand add_convert_command(CLI::App& root);
Subcommand add_info_command(CLI::App& root);
Subcommand add_diff_command(CLI::App& root);
Subcommand add_render_command(CLI::App& root);
Subcommand add_lobes_command(CLI::App& root);
Subcommand add_hiding_command(CLI::App& root);

} // namespace brdf::tool
