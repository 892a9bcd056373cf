// libFuzzer target: arbitrary bytes -> brdf::fuzz::fourier (entry_points.h). A brdf::Error is the
// expected answer to malformed input; any other exception, crash, leak or sanitizer report is a
// bug.
#include "entry_points.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return brdf::fuzz::run_expecting_error_or_success(&brdf::fuzz::fourier, data, size);
}
