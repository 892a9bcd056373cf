// Lorenz-Mie series for a homogeneous sphere.
//
// Sources and the equations used (B&H = Bohren and Huffman 1983):
//   a_n, b_n from the logarithmic derivative D_n(mx) = psi_n'(mx) / psi_n(mx):       B&H 4.88
//   D_n by downward recurrence D_{n-1} = n/z - 1 / (D_n + n/z):                       B&H 4.89
//   Riccati-Bessel recurrence f_{n+1} = (2n+1)/x f_n - f_{n-1} for psi_n, chi_n (x times the
//     spherical Bessel recurrence, Abramowitz and Stegun 10.1.19); xi_n = psi_n - i chi_n,
//     chi_n = -x y_n (B&H section 4.8)
//   efficiencies Qsca, Qext:                                                          B&H 4.61, 4.62
//   asymmetry parameter (B&H section 4.5, p. 120), backscattering efficiency (B&H p. 122)
//   series length N = x + 4.05 x^(1/3) + 2: Wiscombe 1980 (Appl. Opt. 19, 1505, and the MIEV0
//     report NCAR/TN-140+STR)
//
// Stability choices, and why:
// * D_n(mx) runs downward (as E_n = D_n - (n+1)/z) from n_start = max(N, |mx|) + 8 |mx|^(1/3) + 16;
//   recurrence.h says why that start and why E_n.
// * psi_n(x) is NOT computed by the upward recurrence: for n > x that recurrence amplifies rounding by
//   chi_n / psi_n (1e7 at n = N for large x, and total loss of accuracy at x = 1e-3, where
//   psi_1 = sin x / x - cos x cancels). Instead the ratio r_n = psi_{n-1} / psi_n = D_n(x) + n/x comes
//   from the downward recurrence at the real argument x, and psi_n = psi_{n-1} / r_n is stable in both
//   regimes (each step adds one rounding).
// * chi_n(x) grows for n > x and its upward recurrence is stable.
// * The numerators of B&H 4.88 are psi_n (D_n(mx)/m - D_n(x)) and psi_n (m D_n(mx) - D_n(x)); for small
//   x both D's are ~ (n+1)/z and the textbook form cancels to eps/x^2. Written with E_n they are
//   psi_n (E_n(mx)/m - E_n(x) + (n+1)(1/m^2 - 1)/x) and psi_n (m E_n(mx) - E_n(x)): no cancellation.
// * Absorption per term is computed without cancellation. With z_a = D_n(mx)/m + n/x,
//   A = z_a psi_n - psi_{n-1}, B = z_a chi_n - chi_{n-1}, a_n = A / (A - iB). Then
//   Re(a_n) - |a_n|^2 = Im(B conj A) / |A - iB|^2, and Im(B conj A) = Im(z_a) (psi_n chi_{n-1} -
//   psi_{n-1} chi_n) = -Im(z_a) by the Casorati determinant of the recurrence (constant, -1 at n = 0).
//   So Re(a_n) - |a_n|^2 = -Im(D_n(mx)/m) / |A - iB|^2: exactly 0 for real m and never a difference of
//   nearly equal numbers, which keeps Qabs accurate (and >= 0) down to x = 1e-12 and k = 1e-10.
//   Likewise for b_n with z_b = m D_n(mx) + n/x. Qext = Qsca + Qabs.
// * Truncation: with Wiscombe's N, Qsca and g are converged to ~1e-15 (they are sums of |a_n|^2 and
//   products), and for real m Qext = Qsca too; but Qabs = sum (Re a_n - |a_n|^2) and the amplitudes
//   S1, S2 see the first dropped term to first order (Im a_n ~ |a_n|): ~1e-9 relative, measured
//   against a 40-term-longer 40-digit series (tests/mie/mie_test.cpp).

#include <brdf/mie/mie.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/mie/phase_function.h>
#include <brdf/mie/recurrence.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string_view>
#include <type_traits>

namespace brdf::mie {
namespace {

using detail::Complex;
using detail::divide;
using detail::mul;
using detail::shifted_log_derivatives;
using detail::start_index;

std::string format_index(Complex m) {
    return cat(m.real(), m.imag() < 0 ? "-" : "+", std::abs(m.imag()), "i");
}

// Spheres side by side in a vector (real_lanes below): GCC vector extensions of W
// doubles, W the width of the target's registers (8 under AVX-512, 4 under AVX2, 2 on SSE2). A wider
// vector than the registers GCC lowers through the stack, piece by piece, and the pieces' stores
// cannot be forwarded to the whole's loads: under AVX2 the eight-wide series took 55 % of the seed's
// Mie (bench_mie, perf).

constexpr int mie_lanes = 8; // spheres per batch; the kernels take them W at a time
template <int W> struct LanesType { // (an alias template would drop the attribute)
    typedef double type __attribute__((vector_size(8 * W)));
    typedef unsigned long long bits __attribute__((vector_size(8 * W)));
};
template <int W> using LanesOf = typename LanesType<W>::type;

template <int W> [[gnu::always_inline]] inline LanesOf<W> splat(double v) { return LanesOf<W>{} + v; }
// std::abs of a double, and per lane (the sign bit cleared).
[[gnu::always_inline]] inline double magnitude(double v) { return std::abs(v); }
template <typename V> [[gnu::always_inline]] inline V magnitude(V v) {
    typename LanesType<sizeof(V) / 8>::bits b;
    std::memcpy(&b, &v, sizeof b);
    b &= 0x7fffffffffffffffULL;
    std::memcpy(&v, &b, sizeof v);
    return v;
}

// Term n of a real index's upward series, for one sphere (T = double) or several side by side (T =
// Lanes), the same operations in the same order: psi_n and chi_n from the two before them
// (advanced here), E_n(x) = e_x, E_n(mx) = e, and E_{n-1}(x) = e_x_prev, which gives psi_n without
// a division: the downward recurrence's E_{n-1} = -1 / ratio_n, ratio_n = psi_{n-1} / psi_n. Then
// a_n = A / (A - iB) = (A^2 + iAB) / (A^2 + B^2), and b_n alike, from the ratio r of the smaller of
// |A|, |B| to the larger (nothing overflows; at a tie r = B / A): re = 1 / (1 + r^2) or
// r^2 / (1 + r^2), im = r / (1 + r^2). Two divisions per coefficient where scaling A and B by the
// larger took three (and psi_n a fourth): the seed's 41 ensembles 1.5 % faster (bench_mie).
template <typename T> struct RealTerm {
    T a_re, a_im, b_re, b_im;
};
template <typename T>
[[gnu::always_inline]] inline RealTerm<T> real_term(int n, double m, double minv, double minv2,
                                                    double one_minus_m2_over_m2, T xinv, T e, T e_x, T e_x_prev,
                                                    T& psi_prev, T& chi_prev, T& chi_prev2) {
    const T psi = -psi_prev * e_x_prev; // psi_{n-1}(x) / ratio_n
    const T chi = static_cast<double>(2 * n - 1) * xinv * chi_prev - chi_prev2;
    const T za = e * minv + (n + 1.0) * xinv * minv2 + static_cast<double>(n) * xinv;
    const T zb = m * e + (2.0 * n + 1.0) * xinv;
    const T num_a = psi * (e * minv - e_x + (n + 1.0) * xinv * one_minus_m2_over_m2);
    const T num_b = psi * (m * e - e_x);
    RealTerm<T> out;
    const auto coefficient = [](T a, T b, T& re, T& im) {
        const auto a_larger = magnitude(b) <= magnitude(a);
        const T r = (a_larger ? b : a) / (a_larger ? a : b);
        const T r2 = r * r, inverse = 1.0 / (1.0 + r2);
        re = a_larger ? inverse : r2 * inverse;
        im = r * inverse;
    };
    coefficient(num_a, za * chi - chi_prev, out.a_re, out.a_im);
    coefficient(num_b, zb * chi - chi_prev, out.b_re, out.b_im);
    psi_prev = psi;
    chi_prev2 = chi_prev;
    chi_prev = chi;
    return out;
}

// The sums of the efficiencies, term by term: B&H 4.61-4.62 and, for g Qsca and the
// backscattering, B&H pp. 120-122,
//   g Qsca = (4/x^2) [sum n(n+2)/(n+1) Re(a_n a*_{n+1} + b_n b*_{n+1}) + sum (2n+1)/(n(n+1)) Re(a_n b*_n)].
// For one sphere (T = double: efficiencies()) or several (T = Lanes: the real series, as it makes the
// terms), the same additions in the same order: order n's own terms, then its cross term with n + 1,
// which the lanes add when they make order n + 1.
template <typename T> struct EfficiencySums {
    T sca{}, absorbed{}, asym{}, back_r{}, back_i{};
};
template <typename T>
[[gnu::always_inline]] inline void add_order_terms(int n, T ar, T ai, T br, T bi, T absorption,
                                                   EfficiencySums<T>& s) {
    const double f = 2.0 * n + 1.0;
    s.sca += f * (ar * ar + ai * ai + br * br + bi * bi);
    s.absorbed += f * absorption;
    const double sf = n % 2 ? -f : f;
    s.back_r += sf * (ar - br);
    s.back_i += sf * (ai - bi);
    s.asym += f / (n * (n + 1.0)) * (ar * br + ai * bi);
}
// Order n's cross term with order n + 1 (primed).
template <typename T>
[[gnu::always_inline]] inline void add_cross_term(int n, T ar, T ai, T br, T bi, T ar1, T ai1, T br1, T bi1,
                                                  EfficiencySums<T>& s) {
    s.asym += n * (n + 2.0) / (n + 1.0) * (ar * ar1 + ai * ai1 + br * br1 + bi * bi1);
}
Efficiencies finish_efficiencies(double x, double sca, double absorbed, double asym, double back_r, double back_i) {
    const double x2 = x * x;
    Efficiencies q;
    q.qsca = 2.0 * sca / x2;
    q.qabs = 2.0 * absorbed / x2;
    q.qext = q.qsca + q.qabs;
    q.qback = (back_r * back_r + back_i * back_i) / x2;
    q.g = 2.0 * asym / sca;
    return q;
}

// coefficients() for a real index (a non-absorbing sphere), in real arithmetic: E_n(mx) and E_n(x) run in
// one loop (two independent division chains the processor overlaps), then the terms (real_term).
// The absorption is exactly 0.
void coefficients_real(double m, double x, int n_terms, Coefficients& out, SeriesWork& work) {
    std::vector<double>& ez = work.ez_real;
    std::vector<double>& ex = work.ex;
    ez.resize(n_terms + 1);
    ex.resize(n_terms + 1);
    const double z = m * x;
    const int start_z = start_index(n_terms, z), start_x = start_index(n_terms, x);
    const double zinv = 1.0 / z, xinv = 1.0 / x;
    double e_z = 0.0, e_x = 0.0;
    for (int n = std::max(start_z, start_x); n >= 1; --n) {
        if (n <= start_z) {
            double ratio = (2.0 * n + 1.0) * zinv + e_z;
            if (ratio == 0.0) ratio = 1e-300; // see shifted_log_derivatives
            if (n <= n_terms) ez[n] = e_z;
            e_z = -1.0 / ratio;
        }
        if (n <= start_x) {
            double ratio = (2.0 * n + 1.0) * xinv + e_x;
            if (ratio == 0.0) ratio = 1e-300;
            if (n <= n_terms) ex[n] = e_x;
            e_x = -1.0 / ratio;
        }
    }
    ex[0] = e_x; // E_0(x), for psi_1
    const double minv = 1.0 / m, minv2 = minv * minv;
    const double one_minus_m2_over_m2 = (1.0 - m) * (1.0 + m) * minv2;
    const double sinx = std::sin(x), cosx = std::cos(x);
    double psi_prev = sinx, chi_prev2 = -sinx, chi_prev = cosx;
    for (int n = 1; n <= n_terms; ++n) {
        const RealTerm<double> t =
            real_term(n, m, minv, minv2, one_minus_m2_over_m2, xinv, ez[n], ex[n], ex[n - 1], psi_prev, chi_prev, chi_prev2);
        out.a[n - 1] = Complex(t.a_re, t.a_im);
        out.b[n - 1] = Complex(t.b_re, t.b_im);
        out.absorption[n - 1] = 0.0;
    }
}

// coefficients_real for W spheres of one index at once, sphere l in lane l: every operation of
// coefficients_real element by element and in its order (the upward series is the same real_term),
// so each sphere's coefficients are its own bits, whatever W and whichever spheres share its
// vector; where a lane's sphere has fewer terms or starts its recurrence lower, the lane's values
// are kept (select) or not stored. A sphere's two downward recurrences are chains of divisions,
// each waiting for the one before: one sphere at a time left the divider mostly idle; W chains side
// by side keep it busy. Nothing here allocates or throws: the caller sizes `out` and the lanes'
// E_n storage, ez and ex, (terms + 1) x W values each.
template <int W>
[[gnu::always_inline]] inline void real_lanes(double m, const double* x, const int* n_terms, int count,
                                              Coefficients* const* out, Efficiencies* const* q, double* ez,
                                              double* ex) noexcept {
    using Lanes = LanesOf<W>;
    Lanes start_z, start_x, zinv, xinv, last;
    int top = 0, terms = 0;
    for (int l = 0; l < W; ++l) {
        const double z = m * x[l];
        const int sz = start_index(n_terms[l], z), sx = start_index(n_terms[l], x[l]);
        start_z[l] = sz;
        start_x[l] = sx;
        last[l] = n_terms[l];
        zinv[l] = 1.0 / z;
        xinv[l] = 1.0 / x[l];
        top = std::max({top, sz, sx});
        terms = std::max(terms, n_terms[l]);
    }
    Lanes e_z = splat<W>(0.0), e_x = splat<W>(0.0);
    for (int n = top; n >= 1; --n) {
        const Lanes order = splat<W>(2.0 * n + 1.0), at = splat<W>(n);
        Lanes ratio_z = order * zinv + e_z;
        ratio_z = ratio_z == 0.0 ? splat<W>(1e-300) : ratio_z;
        Lanes ratio_x = order * xinv + e_x;
        ratio_x = ratio_x == 0.0 ? splat<W>(1e-300) : ratio_x;
        if (n <= terms) { // read back only where n <= the lane's own terms (< its starts)
            std::memcpy(ez + W * n, &e_z, sizeof e_z);
            std::memcpy(ex + W * n, &e_x, sizeof e_x);
        }
        e_z = at <= start_z ? -1.0 / ratio_z : e_z;
        e_x = at <= start_x ? -1.0 / ratio_x : e_x;
    }
    const double minv = 1.0 / m, minv2 = minv * minv;
    const double one_minus_m2_over_m2 = (1.0 - m) * (1.0 + m) * minv2;
    Lanes sinx, cosx;
    for (int l = 0; l < W; ++l) sinx[l] = std::sin(x[l]), cosx[l] = std::cos(x[l]);
    Lanes psi_prev = sinx, chi_prev2 = -sinx, chi_prev = cosx;
    Lanes e_x_prev = e_x; // E_0(x)
    // The efficiencies' sums (when asked for): a lane adds nothing past its own terms (a select,
    // not a product: its values there are whatever the recurrences make of them).
    EfficiencySums<Lanes> sums;
    RealTerm<Lanes> before{};
    const Lanes zero = splat<W>(0.0);
    for (int n = 1; n <= terms; ++n) {
        Lanes e, e_x_n;
        std::memcpy(&e, ez + W * n, sizeof e);
        std::memcpy(&e_x_n, ex + W * n, sizeof e_x_n);
        const RealTerm<Lanes> t = real_term(n, m, minv, minv2, one_minus_m2_over_m2, xinv, e, e_x_n, e_x_prev,
                                            psi_prev, chi_prev, chi_prev2);
        e_x_prev = e_x_n;
        if (q[0]) {
            const auto in = splat<W>(n) <= last;
            const RealTerm<Lanes> kept{in ? t.a_re : zero, in ? t.a_im : zero, in ? t.b_re : zero,
                                       in ? t.b_im : zero};
            if (n > 1)
                add_cross_term(n - 1, before.a_re, before.a_im, before.b_re, before.b_im, kept.a_re, kept.a_im,
                               kept.b_re, kept.b_im, sums);
            add_order_terms(n, kept.a_re, kept.a_im, kept.b_re, kept.b_im, zero, sums);
            before = kept;
        }
        for (int l = 0; l < count; ++l)
            if (n <= n_terms[l]) {
                out[l]->a[n - 1] = Complex(t.a_re[l], t.a_im[l]);
                out[l]->b[n - 1] = Complex(t.b_re[l], t.b_im[l]);
                out[l]->absorption[n - 1] = 0.0;
            }
    }
    if (q[0])
        for (int l = 0; l < count; ++l)
            *q[l] = finish_efficiencies(x[l], sums.sca[l], sums.absorbed[l], sums.asym[l], sums.back_r[l],
                                        sums.back_i[l]);
}

/// A batch of mie_lanes spheres (`count` of them real, the lanes past it repeating the last) and
/// where their results go: the caller sizes `out` and the lanes' E_n storage, ez and ex.
struct RealBatch {
    double m;
    const double (&x)[mie_lanes];
    const int (&n_terms)[mie_lanes];
    int count;
    Coefficients* const (&out)[mie_lanes];
    Efficiencies* const (&q)[mie_lanes]; ///< all null for the coefficients alone
    double *ez, *ex;
};
/// The batch W spheres at a time.
template <int W> [[gnu::always_inline]] inline void real_batch(const RealBatch& b) noexcept {
    for (int first = 0; first < b.count; first += W)
        real_lanes<W>(b.m, b.x + first, b.n_terms + first, std::min(W, b.count - first), b.out + first, b.q + first,
                      b.ez, b.ex);
}

// One kernel per instruction set, picked once at run time; the same bits from each (above), since
// this file is compiled without contraction (no FMA).
using RealBatchKernel = void (*)(const RealBatch&) noexcept;
void real_batch_baseline(const RealBatch& b) noexcept { real_batch<2>(b); }
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target("avx2"))) void real_batch_avx2(const RealBatch& b) noexcept { real_batch<4>(b); }
__attribute__((target("avx512f"))) void real_batch_avx512(const RealBatch& b) noexcept { real_batch<8>(b); }
#endif
/// The set series_kernels() names (phase_function.h: the CPU's widest, or the narrower one that
/// BRDF_MIE_KERNELS asks for, so that the tests run each set's lanes on one machine).
RealBatchKernel real_batch_kernel() {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
    static const RealBatchKernel kernel = [] {
        const std::string_view set = series_kernels();
        return set == "avx512-fma" ? real_batch_avx512 : set == "avx2-fma" ? real_batch_avx2 : real_batch_baseline;
    }();
    return kernel;
#else
    return real_batch_baseline;
#endif
}

} // namespace

int series_length(double x) {
    return static_cast<int>(x + 4.05 * std::cbrt(x) + 2.0);
}

void validate(Complex m, double x, const char* what) {
    if (!std::isfinite(m.real()) || !std::isfinite(m.imag()))
        throw InputError(cat(what, ": relative refractive index m = ", format_index(m),
                             " is not a finite number"));
    if (!(m.real() > 0.0))
        throw InputError(cat(what, ": relative refractive index m = ", format_index(m),
                             ": the real part must be > 0"));
    if (m.imag() < 0.0)
        throw InputError(cat(what, ": relative refractive index m = ", format_index(m),
                             ": the imaginary part (absorption) must be >= 0; the convention is "
                             "m = n + ik with k >= 0"));
    if (!std::isfinite(x) || !(x > 0.0))
        throw InputError(cat(what, ": size parameter x must be a finite number > 0 (got ", x, ")"));
    if (x < min_size_parameter)
        throw InputError(cat(what, ": size parameter x = ", x, " is below the supported minimum ",
                             min_size_parameter, " (the Rayleigh formulas are exact there)"));
    if (x > max_size_parameter)
        throw LimitError(cat(what, ": size parameter x = ", x, " exceeds the supported maximum ",
                             max_size_parameter, " (use geometric optics)"));
}

Coefficients coefficients(Complex m, double x) {
    Coefficients c;
    coefficients(m, x, c);
    return c;
}

void coefficients(Complex m, double x, Coefficients& out) {
    SeriesWork work;
    coefficients(m, x, out, work);
}

// Both span forms: `q` empty for the coefficients alone.
void coefficients(Complex m, std::span<const double> x, std::span<Coefficients> out, std::span<Efficiencies> q,
                  SeriesWork& work) {
    if (x.size() != out.size() || (!q.empty() && q.size() != x.size()))
        throw InternalError(cat("Mie coefficients: ", x.size(), " size parameters for ", out.size(), " results and ",
                                q.size(), " efficiencies"));
    if (m.imag() != 0.0) {
        for (std::size_t i = 0; i < x.size(); ++i) {
            coefficients(m, x[i], out[i], work);
            if (!q.empty()) q[i] = efficiencies(out[i]);
        }
        return;
    }
    for (double xi : x) validate(m, xi); // first: series_length casts x to int
    for (std::size_t first = 0; first < x.size(); first += mie_lanes) {
        const int count = static_cast<int>(std::min<std::size_t>(mie_lanes, x.size() - first));
        // Lanes past `count` repeat the last sphere (finite values throughout) and store nothing.
        double xs[mie_lanes];
        int terms[mie_lanes];
        Coefficients* dst[mie_lanes];
        Efficiencies* sums[mie_lanes] = {};
        int most = 0;
        for (int l = 0; l < mie_lanes; ++l) {
            const std::size_t i = first + static_cast<std::size_t>(std::min(l, count - 1));
            xs[l] = x[i];
            terms[l] = series_length(x[i]);
            dst[l] = &out[i];
            if (!q.empty()) sums[l] = &q[i];
            most = std::max(most, terms[l]);
        }
        for (int l = 0; l < count; ++l) {
            Coefficients& c = *dst[l];
            c.m = m;
            c.x = xs[l];
            c.a.resize(static_cast<std::size_t>(terms[l]));
            c.b.resize(static_cast<std::size_t>(terms[l]));
            c.absorption.resize(static_cast<std::size_t>(terms[l]));
        }
        work.ez_lanes.resize(static_cast<std::size_t>(mie_lanes) * (most + 1));
        work.ex_lanes.resize(static_cast<std::size_t>(mie_lanes) * (most + 1));
        real_batch_kernel()({m.real(), xs, terms, count, dst, sums, work.ez_lanes.data(), work.ex_lanes.data()});
    }
}

void coefficients(Complex m, std::span<const double> x, std::span<Coefficients> out, SeriesWork& work) {
    coefficients(m, x, out, {}, work);
}

void coefficients(Complex m, double x, Coefficients& out, SeriesWork& work) {
    validate(m, x);
    const int n_terms = series_length(x);
    out.m = m;
    out.x = x;
    out.a.resize(n_terms);
    out.b.resize(n_terms);
    out.absorption.resize(n_terms);

    if (m.imag() == 0.0) {
        coefficients_real(m.real(), x, n_terms, out, work);
        return;
    }
    // E_n(mx) and E_n(x).
    std::vector<Complex>& ez = work.ez;
    std::vector<double>& ex = work.ex;
    const Complex z = m * x;
    shifted_log_derivatives(z, n_terms, start_index(n_terms, std::abs(z)), ez);
    shifted_log_derivatives(x, n_terms, start_index(n_terms, x), ex);

    const Complex minv = divide(1.0, m);
    const Complex minv2 = mul(minv, minv);
    const Complex one_minus_m2_over_m2 = mul(mul(1.0 - m, 1.0 + m), minv2); // 1/m^2 - 1, no cancellation
    const double xinv = 1.0 / x;
    const double sinx = std::sin(x), cosx = std::cos(x);
    double psi_prev = sinx;   // psi_0
    double chi_prev2 = -sinx; // chi_{-1}
    double chi_prev = cosx;   // chi_0
    for (int n = 1; n <= n_terms; ++n) {
        const double ratio = (2.0 * n + 1.0) * xinv + ex[n]; // psi_{n-1}(x) / psi_n(x)
        const double psi = psi_prev / ratio;
        const double chi = (2 * n - 1) * xinv * chi_prev - chi_prev2;
        const Complex e = ez[n];
        // z_a = D_n(mx)/m + n/x and z_b = m D_n(mx) + n/x (B&H 4.88), and the numerators
        // z psi_n - psi_{n-1} = psi_n (z - ratio) in the cancellation-free E form.
        const Complex e_over_m = mul(e, minv);
        const Complex m_e = mul(m, e);
        const Complex za = e_over_m + (n + 1.0) * xinv * minv2 + n * xinv;
        const Complex zb = m_e + (2.0 * n + 1.0) * xinv;
        const Complex num_a = psi * (e_over_m - ex[n] + (n + 1.0) * xinv * one_minus_m2_over_m2);
        const Complex num_b = psi * (m_e - ex[n]);
        // Denominators z xi_n - xi_{n-1} = (z psi_n - psi_{n-1}) - i (z chi_n - chi_{n-1}).
        const Complex ba = za * chi - chi_prev, bb = zb * chi - chi_prev;
        const Complex den_a(num_a.real() + ba.imag(), num_a.imag() - ba.real()); // num - i B
        const Complex den_b(num_b.real() + bb.imag(), num_b.imag() - bb.real());
        out.a[n - 1] = divide(num_a, den_a);
        out.b[n - 1] = divide(num_b, den_b);
        // Cancellation-free absorption (see the header comment): -Im z / |den|^2, with
        // Im z_a = Im(E/m) + (n+1)/x Im(1/m^2) and Im z_b = Im(m E). |den| is divided twice rather
        // than squared so that |den|^2 cannot overflow for tiny x.
        const double abs_den_a = std::abs(den_a), abs_den_b = std::abs(den_b);
        const double im_za = e_over_m.imag() + (n + 1.0) * xinv * minv2.imag();
        out.absorption[n - 1] =
            -im_za / abs_den_a / abs_den_a - m_e.imag() / abs_den_b / abs_den_b;
        psi_prev = psi;
        chi_prev2 = chi_prev;
        chi_prev = chi;
    }
}

Efficiencies efficiencies(const Coefficients& c) {
    // Written out in real arithmetic: std::complex products go through the C99 Annex G routine
    // (__muldc3), which made this loop as expensive as computing the coefficients.
    const int n_terms = c.size();
    EfficiencySums<double> s;
    for (int n = 1; n <= n_terms; ++n) {
        const double ar = c.a[n - 1].real(), ai = c.a[n - 1].imag();
        const double br = c.b[n - 1].real(), bi = c.b[n - 1].imag();
        add_order_terms(n, ar, ai, br, bi, c.absorption[n - 1], s);
        if (n < n_terms)
            add_cross_term(n, ar, ai, br, bi, c.a[n].real(), c.a[n].imag(), c.b[n].real(), c.b[n].imag(), s);
    }
    return finish_efficiencies(c.x, s.sca, s.absorbed, s.asym, s.back_r, s.back_i);
}

Amplitudes amplitudes(const Coefficients& c, double mu) {
    if (!(mu >= -1.0 && mu <= 1.0))
        throw InputError(cat("Mie amplitudes: cos(theta) = ", mu, " outside [-1, 1]"));
    // pi_n, tau_n by B&H 4.47: pi_n = (2n-1)/(n-1) mu pi_{n-1} - n/(n-1) pi_{n-2},
    // tau_n = n mu pi_n - (n+1) pi_{n-1}; pi_0 = 0, pi_1 = 1.
    Amplitudes s{0.0, 0.0};
    double pi_prev = 0.0, pi = 1.0;
    for (int n = 1; n <= c.size(); ++n) {
        if (n > 1) {
            const double next = ((2.0 * n - 1.0) * mu * pi - n * pi_prev) / (n - 1.0);
            pi_prev = pi;
            pi = next;
        }
        const double tau = n * mu * pi - (n + 1.0) * pi_prev;
        const double f = (2.0 * n + 1.0) / (n * (n + 1.0));
        s.s1 += f * (c.a[n - 1] * pi + c.b[n - 1] * tau); // B&H 4.74
        s.s2 += f * (c.a[n - 1] * tau + c.b[n - 1] * pi);
    }
    return s;
}

std::vector<double> legendre_coefficients(const Coefficients& c, const LegendreOptions& options) {
    if (c.x > max_legendre_size_parameter)
        throw LimitError(cat("Mie Legendre moments: size parameter x = ", c.x,
                             " exceeds the supported maximum ", max_legendre_size_parameter));
    PhaseFunctionAccumulator acc(c.size());
    acc.add(c, 1.0);
    return acc.legendre(options);
}

Sphere sphere(Complex m, double x, const LegendreOptions& options) {
    Sphere s;
    const Coefficients c = coefficients(m, x);
    s.m = m;
    s.x = x;
    s.q = efficiencies(c);
    s.albedo = s.q.qsca / s.q.qext;
    s.legendre = legendre_coefficients(c, options);
    s.terms = c.size();
    return s;
}

} // namespace brdf::mie
