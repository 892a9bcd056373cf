#pragma once
// Strict parsing of numbers given by users (command-line flags, spec strings). Every function parses
// the whole text or throws InputError naming `what` (the flag or JSON path) and echoing the text, so
// "--v-eff 0.3x" or "--x nan" fail loudly instead of being half-read or turned into NaN.

#include <complex>
#include <string_view>

namespace brdf {

/// Parses a finite decimal floating-point number ("1.5", "+2", "-3e-4"). The whole text must be the
/// number: no surrounding spaces or trailing characters. Empty text, NaN, infinities and values that
/// overflow a double throw InputError("<what>: ...").
double parse_double(std::string_view text, std::string_view what);

/// Parses a complex refractive index written "N" or "N+Ki" (also "N+Kj"), e.g. "1.5", "2.7+0.01i",
/// "2.7+1e-3i", "0.2+3.4i". The convention is m = n + ik with the absorption k >= 0 (Bohren and
/// Huffman 1983, section 2.5): a negative imaginary part ("1.5-0.1i", the other sign convention) is
/// rejected with a message that says so, as is a real part <= 0. Throws InputError naming `what`.
std::complex<double> parse_complex_index(std::string_view text, std::string_view what);

} // namespace brdf
