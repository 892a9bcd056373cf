#include <brdf/core/trig_lanes.h>

#include <cstddef>

namespace brdf {
namespace {

// Taylor coefficients 1/k! with alternating signs: on |y| <= pi/4 the sine's series to y^17 and the
// cosine's to y^18 leave 1e-19 and 3e-21, far below an ulp; Horner's rounding is the error.
constexpr double factorial_inverse(int k) {
    double f = 1.0;
    for (int i = 2; i <= k; ++i) f *= i;
    return 1.0 / f;
}
constexpr double s3 = -factorial_inverse(3), s5 = factorial_inverse(5), s7 = -factorial_inverse(7),
                 s9 = factorial_inverse(9), s11 = -factorial_inverse(11), s13 = factorial_inverse(13),
                 s15 = -factorial_inverse(15), s17 = factorial_inverse(17);
constexpr double c4 = factorial_inverse(4), c6 = -factorial_inverse(6), c8 = factorial_inverse(8),
                 c10 = -factorial_inverse(10), c12 = factorial_inverse(12), c14 = -factorial_inverse(14),
                 c16 = factorial_inverse(16), c18 = -factorial_inverse(18);

} // namespace

// Above pi/4 the angle is reflected, y = pi/2 - x, and the two series swap: pi/2 in two parts, the
// first the double nearest it, so that pio2_hi - x is exact (Sterbenz) and pio2_lo restores the
// rest. The cosine is 1 - y^2/2 plus that subtraction's rounding error (as fdlibm's __kernel_cos
// does) plus the series' tail. Compiled for AVX-512, AVX2 and the baseline: the same operations in
// each lane and clone (no contraction, cmake/BrdfWarnings.cmake), so every clone gives the same bits.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void quarter_turn_sincos(std::span<const double> x, double* s, double* c) {
    constexpr double pio2_hi = 1.5707963267948966, pio2_lo = 6.123233995736766e-17, pio4 = 0.7853981633974483;
    const double* in = x.data();
    const std::size_t n = x.size();
    for (std::size_t k = 0; k < n; ++k) {
        const double v = in[k];
        const bool reflected = v > pio4;
        const double y = reflected ? (pio2_hi - v) + pio2_lo : v;
        const double z = y * y;
        const double sine = y + y * z * (s3 + z * (s5 + z * (s7 + z * (s9 + z * (s11 + z * (s13 + z * (s15 + z * s17)))))));
        const double hz = 0.5 * z, w = 1.0 - hz;
        const double tail = z * z * (c4 + z * (c6 + z * (c8 + z * (c10 + z * (c12 + z * (c14 + z * (c16 + z * c18)))))));
        const double cosine = w + (((1.0 - w) - hz) + tail);
        s[k] = reflected ? cosine : sine;
        c[k] = reflected ? sine : cosine;
    }
}

} // namespace brdf
