#pragma once
// Usage errors of brdftool and brdfd as one line, the way git and pbrt-v4's tools report them:
//   brdftool: compute: unknown option --foo (see 'brdftool help compute')
// CLI11 (2.1) reports a missing positional before an unknown option ("spec is required" for
// `compute --foo`) and some errors over several lines; these helpers name the real fault first and
// always in one line. Exit status 2 is the tools' business.

#include <CLI/CLI.hpp>

#include <optional>
#include <string>

namespace brdf::tool {

/// Makes `app` and its subcommands keep unknown arguments instead of failing on the first, so that
/// usage_problem() can name them. Call once every option and subcommand has been added.
void keep_unknown_arguments(CLI::App& app);

/// The innermost subcommand given on the command line `root` parsed (root itself when none).
const CLI::App& innermost_command(const CLI::App& root);

/// What is wrong with the command line `root` just parsed, in one line without the program name:
/// the first unknown argument ("compute: unknown option --foo", "unknown command 'frob'"), else
/// `error`'s text with the subcommand named ("compute: spec is required"). nullopt when the parse
/// succeeded (`error` null) and nothing was left over.
std::optional<std::string> usage_problem(const CLI::App& root, const CLI::ParseError* error);

} // namespace brdf::tool
