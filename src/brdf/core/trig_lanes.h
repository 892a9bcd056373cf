#pragma once
// Sine and cosine of many angles at once, for quadrature nodes: libm's sincos is one call per
// angle (13 ns here), which the loops that map Gauss nodes to angles cannot vectorise; this is the
// same polynomial in every lane (1.2 ns an angle with AVX-512), within one ulp of the correctly
// rounded value (tested against libm over [0, pi/2]).

#include <span>

namespace brdf {

/// s[k] = sin(x[k]) and c[k] = cos(x[k]) for x[k] in [0, pi/2] (an angle rounded an ulp past
/// either end too); s and c hold x.size() values and overlap neither x nor each other.
void quarter_turn_sincos(std::span<const double> x, double* s, double* c);

} // namespace brdf
