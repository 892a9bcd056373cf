#include "usage.h"

#include <vector>

namespace brdf::tool {

void keep_unknown_arguments(CLI::App& app) {
    app.allow_extras();
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
        keep_unknown_arguments(*sub);
}

const CLI::App& innermost_command(const CLI::App& root) {
    const CLI::App* app = &root;
    for (;;) {
        const std::vector<const CLI::App*> given =
            app->get_subcommands([](const CLI::App* s) { return s->parsed(); });
        if (given.empty()) return *app;
        app = given.front();
    }
}

namespace {

std::string one_line(std::string text) {
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    for (std::size_t at; (at = text.find('\n')) != std::string::npos;) text.replace(at, 1, "; ");
    return text;
}

} // namespace

std::optional<std::string> usage_problem(const CLI::App& root, const CLI::ParseError* error) {
    // The deepest command with leftovers: an argument a subcommand did not know stays with it.
    const CLI::App* app = &root;
    const CLI::App* with_extras = root.remaining_size() > 0 ? &root : nullptr;
    for (;;) {
        const std::vector<const CLI::App*> given =
            app->get_subcommands([](const CLI::App* s) { return s->parsed(); });
        if (given.empty()) break;
        app = given.front();
        if (app->remaining_size() > 0) with_extras = app;
    }
    const std::string prefix = app == &root ? "" : app->get_name() + ": ";
    if (with_extras) {
        const std::string arg = with_extras->remaining().front();
        const std::string where = with_extras == &root ? "" : with_extras->get_name() + ": ";
        if (!arg.empty() && arg.front() == '-') return where + "unknown option " + arg;
        const bool has_commands =
            !root.get_subcommands([](const CLI::App*) { return true; }).empty();
        if (with_extras == &root && app == &root && has_commands)
            return "unknown command '" + arg + "'";
        return where + "unexpected argument '" + arg + "'";
    }
    if (!error) return std::nullopt;
    if (app == &root && error->get_name() == "RequiredError" &&
        std::string(error->what()).find("subcommand") != std::string::npos)
        return std::string("no command given");
    return prefix + one_line(error->what());
}

} // namespace brdf::tool
