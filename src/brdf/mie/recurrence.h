#pragma once
// Riccati-Bessel recurrences shared by mie.cpp and resonance.cpp (internal to the Mie module).
// B&H = Bohren and Huffman 1983.

#include <algorithm>
#include <cmath>
#include <complex>
#include <type_traits>
#include <vector>

namespace brdf::mie::detail {

using Complex = std::complex<double>;

/// Complex division by Smith's algorithm (Smith 1962, CACM 5, 435): no overflow of |den|^2 and much
/// faster than the library's C99 Annex G division, which also handles infinities we never produce.
inline Complex divide(Complex num, Complex den) {
    const double a = num.real(), b = num.imag(), c = den.real(), d = den.imag();
    if (std::abs(c) >= std::abs(d)) {
        const double r = d / c, t = 1.0 / (c + d * r);
        return {(a + b * r) * t, (b - a * r) * t};
    }
    const double r = c / d, t = 1.0 / (c * r + d);
    return {(a * r + b) * t, (b * r - a) * t};
}

/// Complex product written out: operator* goes through the C99 Annex G routine (__muldc3) for the
/// infinities and NaNs that never occur here, at several times the cost.
inline Complex mul(Complex p, Complex q) {
    return {p.real() * q.real() - p.imag() * q.imag(), p.real() * q.imag() + p.imag() * q.real()};
}

/// Where the downward recurrence for D_n(z) starts: max(n_max, |z|) + 8 |z|^(1/3) + 16. In the
/// oscillatory region n < |z| the recurrence neither damps nor amplifies errors (real z), so the
/// starting error must already be negligible when it reaches n = |z|. Linearised, an error at n_start
/// reaches n as (psi_{n_start} / psi_n)^2; across the Airy transition region (width ~ (|z|/2)^(1/3))
/// that is about exp(-(4/3) t^(3/2)) with t = 8 * 2^(1/3) = 10.1, i.e. 1e-19. The common
/// max(N, |z|) + 15 (BHMIE) leaves O(0.1) errors once |z| > 1e3.
inline int start_index(int n_max, double abs_z) {
    return static_cast<int>(std::max<double>(n_max, abs_z) + 8.0 * std::cbrt(abs_z) + 16.0);
}

/// The shifted logarithmic derivative E_n(z) = D_n(z) - (n+1)/z, D_n = psi_n'/psi_n, for
/// n = 0 .. n_max into out[0 .. n_max]. Substituting into B&H 4.89, D_{n-1} = n/z - 1/(D_n + n/z), gives
/// E_{n-1} = -1 / ((2n+1)/z + E_n): the same recurrence (same stability), but E_n ~ -z/(2n+3) for small
/// z, so differences such as m E_n(mx) - E_n(x) are formed from small numbers instead of the cancelling
/// (n+1)/z parts of D_n. The denominator (2n+1)/z + E_n is the ratio psi_{n-1}(z) / psi_n(z). The
/// recurrence starts from E = 0 (D = (n+1)/z, the small-argument value) at n_start >= n_max.
template <typename T>
void shifted_log_derivatives(T z, int n_max, int n_start, std::vector<T>& out) {
    out.resize(n_max + 1);
    const T zinv = T(1.0) / z;
    T e = 0.0;
    for (int n = n_start; n >= 1; --n) {
        T ratio = (2.0 * n + 1.0) * zinv + e; // psi_{n-1}(z) / psi_n(z)
        // An exact zero would turn into inf and then NaN two steps later; it needs psi_{n-1}(z) to be
        // an exact floating-point zero and never happens in practice, but costs nothing to rule out.
        if (ratio == T(0.0)) ratio = 1e-300;
        if (n <= n_max) out[n] = e;
        if constexpr (std::is_same_v<T, double>)
            e = -1.0 / ratio;
        else
            e = -divide(1.0, ratio);
    }
    out[0] = e;
}

/// E_n(z) for one order n (the same recurrence, nothing stored).
template <typename T>
T shifted_log_derivative(T z, int n) {
    const T zinv = T(1.0) / z;
    T e = 0.0;
    for (int k = start_index(n, std::abs(z)); k > n; --k) {
        T ratio = (2.0 * k + 1.0) * zinv + e;
        if (ratio == T(0.0)) ratio = 1e-300;
        if constexpr (std::is_same_v<T, double>)
            e = -1.0 / ratio;
        else
            e = -divide(1.0, ratio);
    }
    return e;
}

} // namespace brdf::mie::detail
