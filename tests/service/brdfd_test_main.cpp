// brdfd_test: brdfd with a test hook, built only with the tests. The shipped brdfd has no hook; this
// binary links the same command line and daemon (tools/brdfd/cli.cpp, brdf_service) and, when
// BRDFD_TEST_RUNNER is set, replaces the compute pipeline by a runner that computes nothing, so the
// tests can drive a real daemon process (signals, exit statuses, kills) in a fraction of a second:
//
//   BRDFD_TEST_RUNNER=sleep:SECONDS[,write:SECONDS]
//
// Each job sleeps SECONDS, then fails with an input error if the spec contains "brdfd-test-fail",
// and otherwise writes results/NAME.result, a copy of the spec. With `write:W` the copy is written
// the way the table writers write (core's AtomicFile): half of it into the hidden temporary, W
// seconds, the rest, commit; so a test can kill the daemon while a result is half written.
// Without the variable it is brdfd.

#include "cli.h"

#include <leak_check.h>

#include <brdf/core/atomic_file.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/service/compute.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>

namespace {

using namespace brdf;

/// The number after `prefix` in `text` ("sleep:1.5" -> 1.5), or -1 when it is not one.
double number_after(const std::string& text, const std::string& prefix) {
    if (text.rfind(prefix, 0) != 0) return -1.0;
    try {
        std::size_t used = 0;
        const double v = std::stod(text.substr(prefix.size()), &used);
        return used == text.size() - prefix.size() && std::isfinite(v) ? v : -1.0;
    } catch (const std::exception&) {
        return -1.0;
    }
}

service::JobRunner sleep_runner(const std::string& hook) {
    const std::size_t comma = hook.find(',');
    const double seconds = number_after(hook.substr(0, comma), "sleep:");
    const double write_seconds =
        comma == std::string::npos ? 0.0 : number_after(hook.substr(comma + 1), "write:");
    if (!(seconds >= 0.0) || !(write_seconds >= 0.0))
        throw InputError(
            cat("BRDFD_TEST_RUNNER: expected sleep:SECONDS[,write:SECONDS] (got '", hook, "')"));
    log::warn("brdfd: test hook BRDFD_TEST_RUNNER=", hook, ": jobs sleep instead of computing");
    return [seconds, write_seconds](const std::filesystem::path& spec,
                                    const std::filesystem::path& results) {
        std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
        std::ifstream in(spec, std::ios::binary);
        std::string text;
        char buf[4096];
        while (in.read(buf, sizeof buf) || in.gcount() > 0) text.append(buf, static_cast<std::size_t>(in.gcount()));
        if (text.find("brdfd-test-fail") != std::string::npos)
            throw InputError(cat(spec.filename().string(), ": test hook: failing as asked"));
        AtomicFile out(results / (spec.stem().string() + ".result"));
        out.write(text.substr(0, text.size() / 2));
        std::this_thread::sleep_for(std::chrono::duration<double>(write_seconds));
        out.write(text.substr(text.size() / 2));
        out.commit();
    };
}

} // namespace

int main(int argc, char** argv) {
    return tool::after_leak_check(tool::brdfd_main(argc, argv, []() -> service::JobRunner {
        if (const char* hook = std::getenv("BRDFD_TEST_RUNNER"); hook && *hook)
            return sleep_runner(hook);
        return service::run_compute_job;
    }));
}
