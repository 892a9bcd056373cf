#include <brdf/mie/phase_function.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>

namespace brdf::mie {
namespace {

// The nodes are processed in blocks of `block`, with the series summed over n for a whole block in
// registers: S1(+-mu), S2(+-mu) are eight running sums per node, and pi_n, tau_n follow B&H 4.47,
//   pi_{n+1} = ((2n+1) mu pi_n - (n+1) pi_{n-1}) / n,   tau_n = n mu pi_n - (n+1) pi_{n-1},
// with the reflected node from pi_n(-mu) = (-1)^(n-1) pi_n(mu), tau_n(-mu) = (-1)^n tau_n(mu):
//   S1(-mu) = sum (-1)^(n-1) c_n (a_n pi_n - b_n tau_n),  S2(-mu) = sum (-1)^n c_n (a_n tau_n - b_n pi_n).
// Keeping the sums in registers instead of arrays (one pass over memory per order) made this three
// times faster.
// GCC/Clang vector extensions: four (eight) doubles, lowered to whatever registers the target has.
typedef double Vec4 __attribute__((vector_size(32)));
typedef double Vec8 __attribute__((vector_size(64)));

/// Per order n: c_n a_n, c_n b_n (real, imaginary), then n, n + 1, (2n+1)/n, (n+1)/n.
constexpr std::size_t per_order = 8;

/// Partial sums of one parity: sum c_n a_n pi_n, c_n b_n tau_n, c_n a_n tau_n, c_n b_n pi_n.
template <typename V>
struct ParitySums {
    V api_r, api_i, btau_r, btau_i, atau_r, atau_i, bpi_r, bpi_i;
};

/// Adds order n to the sums of its parity and steps pi_n, pi_{n-1} to pi_{n+1}, pi_n.
template <typename V>
[[gnu::always_inline]] inline void add_order(const double* c, const V& m, V& pi, V& pi_prev,
                                             ParitySums<V>& s) {
    const double dn = c[4], dn1 = c[5], up = c[6], down = c[7];
    const V p = pi, pm = pi_prev;
    const V tau = dn * m * p - dn1 * pm;
    s.api_r += c[0] * p;
    s.api_i += c[1] * p;
    s.btau_r += c[2] * tau;
    s.btau_i += c[3] * tau;
    s.atau_r += c[0] * tau;
    s.atau_i += c[1] * tau;
    s.bpi_r += c[2] * p;
    s.bpi_i += c[3] * p;
    pi_prev = p;
    pi = up * m * p - down * pm;
}

/// I(+mu_j), I(-mu_j) for a block of nodes (see above).
template <typename V, std::size_t B>
[[gnu::always_inline]] inline void intensity_kernel(const double* __restrict coef, int n_terms,
                                                    const double* __restrict mu,
                                                    double* __restrict plus,
                                                    double* __restrict minus) {
    V m, zero, pi;
    for (std::size_t j = 0; j < B; ++j) m[j] = mu[j], zero[j] = 0.0, pi[j] = 1.0;
    V pi_prev = zero;
    ParitySums<V> odd{zero, zero, zero, zero, zero, zero, zero, zero}, even = odd;
    int n = 1;
    for (; n + 1 <= n_terms; n += 2) {
        add_order(coef + per_order * (n - 1), m, pi, pi_prev, odd);
        add_order(coef + per_order * n, m, pi, pi_prev, even);
    }
    if (n <= n_terms) add_order(coef + per_order * (n - 1), m, pi, pi_prev, odd);
    // S1(+mu) = E(a pi + b tau) + O(a pi + b tau),  S1(-mu) = O(a pi - b tau) - E(a pi - b tau),
    // S2(+mu) = E(a tau + b pi) + O(a tau + b pi),  S2(-mu) = E(a tau - b pi) - O(a tau - b pi).
    const V s1p_r = even.api_r + even.btau_r + odd.api_r + odd.btau_r;
    const V s1p_i = even.api_i + even.btau_i + odd.api_i + odd.btau_i;
    const V s1m_r = (odd.api_r - odd.btau_r) - (even.api_r - even.btau_r);
    const V s1m_i = (odd.api_i - odd.btau_i) - (even.api_i - even.btau_i);
    const V s2p_r = even.atau_r + even.bpi_r + odd.atau_r + odd.bpi_r;
    const V s2p_i = even.atau_i + even.bpi_i + odd.atau_i + odd.bpi_i;
    const V s2m_r = (even.atau_r - even.bpi_r) - (odd.atau_r - odd.bpi_r);
    const V s2m_i = (even.atau_i - even.bpi_i) - (odd.atau_i - odd.bpi_i);
    const V ip = s1p_r * s1p_r + s1p_i * s1p_i + s2p_r * s2p_r + s2p_i * s2p_i;
    const V im = s1m_r * s1m_r + s1m_i * s1m_i + s2m_r * s2m_r + s2m_i * s2m_i;
    for (std::size_t j = 0; j < B; ++j) {
        plus[j] = ip[j];
        minus[j] = im[j];
    }
}

// On x86-64 the kernel is compiled three times and picked at run time: AVX-512 (eight nodes per
// block, 32 registers: no spills), AVX2 and baseline SSE2 (four nodes). Element-wise arithmetic
// only and no FMA contraction in ISO C++ mode, so every variant gives bit-identical results.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define BRDF_X86_DISPATCH 1
__attribute__((target_clones("avx2", "default")))
#endif
void intensity_block4(const double* coef, int n_terms, const double* mu, double* plus,
                      double* minus) {
    intensity_kernel<Vec4, 4>(coef, n_terms, mu, plus, minus);
}

#ifdef BRDF_X86_DISPATCH
__attribute__((target("avx512f"))) void intensity_block8(const double* coef, int n_terms,
                                                         const double* mu, double* plus,
                                                         double* minus) {
    intensity_kernel<Vec8, 8>(coef, n_terms, mu, plus, minus);
}

bool use_avx512() {
    static const bool supported = __builtin_cpu_supports("avx512f");
    return supported;
}
#endif

} // namespace

PhaseFunctionAccumulator::PhaseFunctionAccumulator(int max_terms) : m_max_terms(max_terms) {
    if (max_terms < 1)
        throw InputError(cat("phase function: series length ", max_terms, " must be >= 1"));
    m_rule = gauss_legendre(2 * max_terms + 2);
    const int half = max_terms + 1;
    m_mu.assign(m_rule->x.end() - half, m_rule->x.end()); // the positive nodes, ascending
    m_weight.assign(m_rule->w.end() - half, m_rule->w.end());
    m_plus.assign(half, 0.0);
    m_minus.assign(half, 0.0);
    // c_n = (2n+1)/(n(n+1)) and the pi_n recurrence's (2n+1)/n, (n+1)/n: divisions done once.
    m_recurrence.resize(4 * static_cast<std::size_t>(max_terms));
    for (int n = 1; n <= max_terms; ++n) {
        double* r = m_recurrence.data() + 4 * (n - 1);
        r[0] = (2.0 * n + 1.0) / (n * (n + 1.0));
        r[1] = (2.0 * n + 1.0) / n;
        r[2] = (n + 1.0) / n;
        r[3] = 0.0;
    }
}

void PhaseFunctionAccumulator::clear() {
    std::fill(m_plus.begin(), m_plus.end(), 0.0);
    std::fill(m_minus.begin(), m_minus.end(), 0.0);
}

void PhaseFunctionAccumulator::add(const Coefficients& c, double weight) {
    accumulate(c, weight, m_plus.data(), m_minus.data());
}

void PhaseFunctionAccumulator::add_sums(const std::vector<double>& plus,
                                        const std::vector<double>& minus) {
    if (plus.size() != m_plus.size() || minus.size() != m_minus.size())
        throw InputError("phase function: partial sums of the wrong size");
    for (std::size_t j = 0; j < m_plus.size(); ++j) {
        m_plus[j] += plus[j];
        m_minus[j] += minus[j];
    }
}

void PhaseFunctionAccumulator::accumulate(const Coefficients& c, double weight, double* plus,
                                          double* minus) const {
    const int n_terms = c.size();
    if (n_terms > m_max_terms)
        throw InputError(cat("phase function: series of ", n_terms, " terms exceeds the ",
                             m_max_terms, " the accumulator was built for"));
    if (!(weight >= 0.0) || !std::isfinite(weight))
        throw InputError(cat("phase function: weight ", weight, " must be finite and >= 0"));
    if (weight == 0.0) return;
    const std::size_t half = m_mu.size();
    thread_local std::vector<double> coef;
    coef.resize(per_order * static_cast<std::size_t>(n_terms));
    for (int n = 1; n <= n_terms; ++n) {
        const double* r = m_recurrence.data() + 4 * (n - 1); // c_n, n, n + 1, (2n+1)/n, (n+1)/n
        double* cn = coef.data() + per_order * (n - 1);
        cn[0] = r[0] * c.a[n - 1].real();
        cn[1] = r[0] * c.a[n - 1].imag();
        cn[2] = r[0] * c.b[n - 1].real();
        cn[3] = r[0] * c.b[n - 1].imag();
        cn[4] = n;
        cn[5] = n + 1.0;
        cn[6] = r[1];
        cn[7] = r[2];
    }
    std::size_t block = 4;
    auto kernel = intensity_block4;
#ifdef BRDF_X86_DISPATCH
    if (use_avx512()) block = 8, kernel = intensity_block8;
#endif
    double mu[8], ip[8], im[8];
    for (std::size_t j0 = 0; j0 < half; j0 += block) {
        const std::size_t count = std::min(block, half - j0);
        for (std::size_t j = 0; j < block; ++j) mu[j] = j < count ? m_mu[j0 + j] : 0.0;
        kernel(coef.data(), n_terms, mu, ip, im);
        for (std::size_t j = 0; j < count; ++j) {
            plus[j0 + j] += weight * ip[j];
            minus[j0 + j] += weight * im[j];
        }
    }
}

double PhaseFunctionAccumulator::integral() const {
    double sum = 0.0;
    for (std::size_t j = 0; j < m_mu.size(); ++j) sum += m_weight[j] * (m_plus[j] + m_minus[j]);
    return sum;
}

std::vector<double> PhaseFunctionAccumulator::legendre(const LegendreOptions& options) const {
    if (!(options.tolerance >= 0.0))
        throw InputError(cat("Legendre moments: tolerance ", options.tolerance, " must be >= 0"));
    if (options.max_terms < 0)
        throw InputError(cat("Legendre moments: max_terms ", options.max_terms, " must be >= 0"));
    const std::size_t half = m_mu.size();
    const double total = integral();
    if (!(total > 0.0) || !std::isfinite(total))
        throw NumericalError(cat("Legendre moments: the accumulated phase function integrates to ",
                                 total, " (nothing scattered?)"));
    // beta_l = (2l+1)/2 int p P_l dmu with p = 2 I / int I, and P_l(-mu) = (-1)^l P_l(mu):
    // beta_l = (2l+1) / total * sum_j P_l(mu_j) w_j (I(+mu_j) + (-1)^l I(-mu_j)).
    std::vector<double> even(half), odd(half), p_prev(half, 1.0), p(m_mu);
    for (std::size_t j = 0; j < half; ++j) {
        even[j] = m_weight[j] * (m_plus[j] + m_minus[j]);
        odd[j] = m_weight[j] * (m_plus[j] - m_minus[j]);
    }
    const int l_max = 2 * m_max_terms; // the intensity is a polynomial of this degree
    int l_last = l_max;
    if (options.max_terms > 0) l_last = std::min(l_last, options.max_terms - 1);
    std::vector<double> beta;
    beta.reserve(l_last + 1);
    beta.push_back(1.0);
    for (int l = 1; l <= l_last; ++l) {
        // p holds P_l, p_prev P_{l-1} at the nodes.
        const double* w = (l % 2) ? odd.data() : even.data();
        double sum = 0.0;
        for (std::size_t j = 0; j < half; ++j) sum += p[j] * w[j];
        beta.push_back((2.0 * l + 1.0) * sum / total);
        const double up = (2.0 * l + 1.0) / (l + 1.0), down = l / (l + 1.0);
        for (std::size_t j = 0; j < half; ++j) {
            const double next = up * m_mu[j] * p[j] - down * p_prev[j];
            p_prev[j] = p[j];
            p[j] = next;
        }
    }
    // Cut after the last moment above the tolerance.
    std::size_t keep = beta.size();
    while (keep > 1 && !(std::abs(beta[keep - 1]) > options.tolerance)) --keep;
    beta.resize(keep);
    return beta;
}

} // namespace brdf::mie
