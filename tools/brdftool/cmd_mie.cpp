#include "commands.h"

#include <brdf/core/error.h>

namespace brdf::tool {

Subcommand add_mie_command(CLI::App& root) {
    Subcommand cmd;
    cmd.app = root.add_subcommand("mie", "Lorenz-Mie results of one sphere or a size distribution");
    static double wavelength = 0;
    cmd.app->add_option("--wavelength-nm", wavelength, "vacuum wavelength in nm");
    cmd.run = [] () -> int { throw InputError("mie: not implemented yet"); };
    return cmd;
}

} // namespace brdf::tool
