#pragma once
// Which instruction set the lane kernels of core (linalg.cpp's Hessenberg lanes, legendre.cpp's
// series at many points) run: each is a template on its vector width W, compiled once per set
// with W the width of that set's registers, because GCC lowers a vector wider than the registers
// through the stack, two to six times slower (docs/style.md).

namespace brdf {

enum class LaneSet {
    baseline, ///< SSE2: two doubles to a register
    avx2,     ///< four
    avx512,   ///< eight
};

/// The widest set this CPU runs, or a narrower one that the environment variable BRDF_LANES names
/// ("avx2" or "baseline": the tests run each set's kernels on one machine). Read once. Every set
/// gives the same bits (element-wise operations, no contraction).
LaneSet lane_set();

} // namespace brdf
