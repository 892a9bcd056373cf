#pragma once
// brdfd's command line, shared by the shipped daemon (main.cpp) and the test-only daemon of
// tests/service (brdfd_test_main.cpp), which differ only in the job runner they pass.

#include <brdf/service/daemon.h>

#include <functional>

namespace brdf::tool {

/// Parses brdfd's flags, then serves the spool with the runner `make_runner` returns (called after
/// the flags parsed, so `--help` never needs it). The one place brdfd catches errors: each becomes
/// one line on stderr with the prefix "brdfd: " and its exit status (docs/daemon.md, "Exit status").
int brdfd_main(int argc, char** argv, const std::function<service::JobRunner()>& make_runner);

} // namespace brdf::tool
