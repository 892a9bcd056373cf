#pragma once
// Locating the sharp Mie resonances ("morphology-dependent resonances", whispering-gallery modes) of
// a sphere with real relative index m > 1, so that a size-distribution integral can place nodes on
// them. Between the size parameters where the internal function psi_n(m x) vanishes, the resonance
// condition of the electric (a_n) and magnetic (b_n) modes of order n,
//   F_a(x) = D_n(mx)/m + n/x - chi_{n-1}(x)/chi_n(x) = 0,   F_b(x) = m D_n(mx) + n/x - chi_{n-1}/chi_n = 0,
// (the zeros of B = z chi_n - chi_{n-1} in a_n = A / (A - iB), B&H 4.88, which are exactly the points
// where |a_n| = 1) has exactly one root per branch: for x < n + 1/2 < m x the function F decreases
// monotonically from +inf to -inf between consecutive poles (D_n' = n(n+1)/z^2 - 1 - D_n^2 < 0 inside,
// and chi_{n-1}/chi_n varies slowly outside the turning point). The poles are counted without finding
// them: the number of zeros of psi_n(t) for 0 < t < z is
//   Z_n(z) = floor(z / pi) - #{k = 1..n : psi_{k-1}(z) / psi_k(z) < 0}
// (zeros of consecutive orders interlace, so the sign pattern of psi_0 .. psi_n(z) gives the count;
// the ratios are the denominators of the downward recurrence already computed for D_n). Hence the
// number of resonances of order n in (x1, x2) is
//   R = Z_n(m x2) - Z_n(m x1) + [F(x1) > 0] - [F(x2) > 0],
// which needs only one evaluation at each end: a resonance of width 1e-9 between two samples 0.1 apart
// is found as reliably as a broad one. A located resonance is refined by safeguarded Newton steps on
// F (F' from the Riccati equations D' = n(n+1)/z^2 - 1 - D^2 and c' = -1 - c^2 + 2 c n / x for
// c = chi_{n-1}/chi_n), and its half width at half maximum in x is 1 / |T'(x_r)| with T = B / A
// (|a_n|^2 = 1 / (1 + T^2) for real m).

#include <complex>
#include <optional>
#include <vector>

namespace brdf::mie {

/// Per-order data at one size parameter, for counting resonances between two samples.
struct ModeSample {
    double x = 0.0;
    int n_max = 0;
    std::vector<int> zeros;            ///< Z_n(m x), n = 0 .. n_max
    std::vector<signed char> positive; ///< bit 0: F_a(x) > 0, bit 1: F_b(x) > 0, n = 0 .. n_max
};

/// Fills `out` for real index m > 1 at size parameter x, orders 1 .. n_max.
void sample_modes(double m, double x, int n_max, ModeSample& out);

/// Whether the counting formula applies to order n on [x1, x2]: x2 < n + 1/2 (chi_n > 0, F smooth
/// outside) and m x2 > n + 1/2 (there is an oscillating interior, the only place resonances live).
bool countable(double m, int n, double x1, double x2);

/// Number of resonances of order n (electric: a_n, else b_n) strictly between the two samples.
/// Requires countable(m, n, a.x, b.x) and n <= both samples' n_max.
int count_resonances(const ModeSample& a, const ModeSample& b, int n, bool electric);

struct Resonance {
    int n = 0;
    bool electric = true; ///< a_n (TM) or b_n (TE)
    double x = 0.0;       ///< size parameter where |a_n| (or |b_n|) = 1 for the real index
    double hwhm = 0.0;    ///< half width at half maximum of |a_n|^2 in x, real index
};

/// Finds the single resonance of order n between x1 < x2, given F(x1) > 0 > F(x2) and no pole of
/// D_n(m x) in between (count_resonances = 1 and equal Z_n). Returns nothing if the iteration fails
/// (it has not been seen to).
std::optional<Resonance> locate_resonance(double m, int n, bool electric, double x1, double x2);

/// For an absorbing sphere the resonance found with Re m is damped: |a_n|^2 peaks at
/// 1 / (1 + Im T)^2 with half width (1 + Im T) * hwhm, T = B / A evaluated with the complex m.
/// Returns Im T at the resonance (0 for real m).
double resonance_damping(std::complex<double> m, const Resonance& r);

} // namespace brdf::mie
