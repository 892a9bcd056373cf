// libFuzzer target: arbitrary bytes -> brdf::fuzz::rgl (entry_points.h): the tensor-file and RGL
// readers, then the evaluator on whatever reads. A brdf::Error is the expected answer to malformed
// input; any other exception (a NaN from the evaluator included), crash, leak or sanitizer report
// is a bug.
#include "entry_points.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return brdf::fuzz::run_expecting_error_or_success(&brdf::fuzz::rgl, data, size);
}
