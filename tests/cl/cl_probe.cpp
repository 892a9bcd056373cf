// test_cl_probe MODE [ARG]: runs one brdf::cl entry point under the environment it was started
// with.
//   available       prints 1 or 0
//   self-test       prints brdf::cl::self_test()
//   program NAME    builds NAME on Context::shared() and prints "built NAME"
// A brdf::Error prints "error: MESSAGE" on stderr and exits with the kind's documented status.

#include <brdf/cl/context.h>
#include <brdf/core/error.h>

#include <cstdio>
#include <string>

int main(int argc, char** argv) {
    const std::string mode = argc > 1 ? argv[1] : "";
    try {
        if (mode == "available") {
            std::printf("%d\n", brdf::cl::available() ? 1 : 0);
        } else if (mode == "self-test") {
            std::printf("%s\n", brdf::cl::self_test().c_str());
        } else if (mode == "program" && argc > 2) {
            brdf::cl::Context::shared()->program(argv[2]);
            std::printf("built %s\n", argv[2]);
        } else {
            std::fprintf(stderr, "usage: test_cl_probe available|self-test|program NAME\n");
            return 2;
        }
    } catch (const brdf::Error& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return brdf::exit_status(e.kind());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "unexpected exception: %s\n", e.what());
        return 70;
    }
    return 0;
}
