// brdfd: the batch daemon (docs/daemon.md). The command line is tools/brdfd/cli.cpp; the shipped
// daemon runs every job through the compute pipeline.

#include "cli.h"

#include <leak_check.h>

#include <brdf/service/compute.h>

int main(int argc, char** argv) {
    return brdf::tool::after_leak_check(brdf::tool::brdfd_main(
        argc, argv, [] { return brdf::service::JobRunner(brdf::service::run_compute_job); }));
}
