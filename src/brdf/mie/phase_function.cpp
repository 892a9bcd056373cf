#include <brdf/mie/phase_function.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string_view>

namespace brdf::mie {
namespace {

// The nodes are processed in blocks of `block`, with the series summed over n for a whole block in
// registers. tau_n = n mu pi_n - (n+1) pi_{n-1} (B&H 4.47) is not formed: substituted into
// S1 = sum c_n (a_n pi_n + b_n tau_n) and S2 = sum c_n (a_n tau_n + b_n pi_n), with the sum over
// (n+1) pi_{n-1} shifted by one order (pi_0 = 0),
//   S1 = sum pi_n C1_n + mu sum pi_n D1_n,  C1_n = c_n a_n - (n+2) c_{n+1} b_{n+1},  D1_n = n c_n b_n,
//   S2 = sum pi_n C2_n + mu sum pi_n D2_n,  C2_n = c_n b_n - (n+2) c_{n+1} a_{n+1},  D2_n = n c_n a_n,
// where (n+2) c_{n+1} = (2n+3)/(n+1) and n c_n = (2n+1)/(n+1). Per order: eight multiply-adds and
// the recurrence pi_{n+1} = ((2n+1)/n) mu pi_n - ((n+1)/n) pi_{n-1}; tau_n took three operations
// more (BM_PhaseIntensities/3000 on AVX2: 6.6-6.9 -> 6.1 ms). The reflected node follows from
// pi_n(-mu) = (-1)^(n-1) pi_n(mu) (B&H section 4.3): with the sums split by the parity of n (E even,
// O odd),
//   S(+mu) = (E_C + O_C) + mu (E_D + O_D),   S(-mu) = (O_C - E_C) - mu (O_D - E_D).
// The two sums cancel towards mu = +-1 (pi_n(1) = n(n+1)/2: each grows as x^3 for an S of x^2),
// which costs ~x eps of the forward intensity, ~1e-12 at x = 4000.
// Keeping the sums in registers instead of arrays (one pass over memory per order) made this three
// times faster. Under AVX2 four of the sixteen sums live on the stack; two passes over the orders,
// the C sums and then the D sums, each in registers, took 50 % longer (the recurrence twice).
// GCC/Clang vector extensions: two, four or eight doubles, lowered to whatever registers the target has.
typedef double Vec2 __attribute__((vector_size(16)));
typedef double Vec4 __attribute__((vector_size(32)));
typedef double Vec8 __attribute__((vector_size(64)));

/// Per order n: C1_n, D1_n, C2_n, D2_n (real, imaginary), then (2n+1)/n, (n+1)/n.
constexpr std::size_t per_order = 10;

/// Partial sums of one parity: sum pi_n C1_n, pi_n D1_n, pi_n C2_n, pi_n D2_n.
template <typename V>
struct ParitySums {
    V c1_r, c1_i, d1_r, d1_i, c2_r, c2_i, d2_r, d2_i;
};

/// Adds order n to the sums of its parity and steps pi_n, pi_{n-1} to pi_{n+1}, pi_n.
template <typename V>
[[gnu::always_inline]] inline void add_order(const double* c, const V& m, V& pi, V& pi_prev,
                                             ParitySums<V>& s) {
    const double up = c[8], down = c[9];
    const V p = pi, pm = pi_prev;
    s.c1_r += c[0] * p;
    s.c1_i += c[1] * p;
    s.d1_r += c[2] * p;
    s.d1_i += c[3] * p;
    s.c2_r += c[4] * p;
    s.c2_i += c[5] * p;
    s.d2_r += c[6] * p;
    s.d2_i += c[7] * p;
    pi_prev = p;
    // (up m) p rather than up (m p): the recurrence is the one chain of dependent operations through
    // the orders, and with up m formed beside it each order waits on one multiply-add instead of a
    // product and then a multiply-add (the 40 um matting agent's ensembles: 11 % faster).
    pi = (up * m) * p - down * pm;
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
    const V s1p_r = (even.c1_r + odd.c1_r) + m * (even.d1_r + odd.d1_r);
    const V s1p_i = (even.c1_i + odd.c1_i) + m * (even.d1_i + odd.d1_i);
    const V s1m_r = (odd.c1_r - even.c1_r) - m * (odd.d1_r - even.d1_r);
    const V s1m_i = (odd.c1_i - even.c1_i) - m * (odd.d1_i - even.d1_i);
    const V s2p_r = (even.c2_r + odd.c2_r) + m * (even.d2_r + odd.d2_r);
    const V s2p_i = (even.c2_i + odd.c2_i) + m * (even.d2_i + odd.d2_i);
    const V s2m_r = (odd.c2_r - even.c2_r) - m * (odd.d2_r - even.d2_r);
    const V s2m_i = (odd.c2_i - even.c2_i) - m * (odd.d2_i - even.d2_i);
    const V ip = s1p_r * s1p_r + s1p_i * s1p_i + s2p_r * s2p_r + s2p_i * s2p_i;
    const V im = s1m_r * s1m_r + s1m_i * s1m_i + s2m_r * s2m_r + s2m_i * s2m_i;
    for (std::size_t j = 0; j < B; ++j) {
        plus[j] = ip[j];
        minus[j] = im[j];
    }
}

// On x86-64 the kernels are compiled three times and one set is picked at run time (kernel_set()):
// AVX-512 (eight nodes per block, 32 registers: no spills), AVX2 (four) and baseline SSE2 (two: four
// nodes' sixteen running sums spilled its sixteen registers, 6x slower).
// This file alone is compiled with -ffp-contract=fast (src/brdf/mie/CMakeLists.txt): the AVX-512 and
// AVX2 sets fuse each a * b + c into one FMA, which halves the instructions of the series (eight
// accumulations and two recurrences per order) and rounds once instead of twice. Measured on the
// 40 um matting agent (41 wavelengths, two threads, with the projection below): 4.9 -> 3.0 s. The
// baseline has no FMA, so its results differ from the others' in the last bits (1.7e-14 in chi_l:
// MieCli.SeriesKernelSetsAgreeToRounding); the Mie disk cache keys its files by the set
// (ensemble_cache.cpp), so a cache shared between machines never mixes them.
enum class KernelSet { baseline, avx2_fma, avx512_fma };

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define BRDF_X86_DISPATCH 1
#endif

/// The widest set this CPU runs, or a narrower one that BRDF_MIE_KERNELS names ("baseline",
/// "avx2-fma": comparisons and tests of the other sets on one machine); read once.
KernelSet kernel_set() {
#ifdef BRDF_X86_DISPATCH
    static const KernelSet set = [] {
        const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("fma");
        const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
        const char* wanted = std::getenv("BRDF_MIE_KERNELS");
        const std::string_view name = wanted ? wanted : "";
        if (name == "baseline") return KernelSet::baseline;
        if (name == "avx2-fma" && avx2) return KernelSet::avx2_fma;
        return avx512 ? KernelSet::avx512_fma : avx2 ? KernelSet::avx2_fma : KernelSet::baseline;
    }();
    return set;
#else
    return KernelSet::baseline;
#endif
}

void intensity_block2(const double* coef, int n_terms, const double* mu, double* plus,
                      double* minus) {
    intensity_kernel<Vec2, 2>(coef, n_terms, mu, plus, minus);
}

#ifdef BRDF_X86_DISPATCH
__attribute__((target("avx2,fma")))
void intensity_block4_avx2(const double* coef, int n_terms, const double* mu, double* plus,
                           double* minus) {
    intensity_kernel<Vec4, 4>(coef, n_terms, mu, plus, minus);
}

__attribute__((target("avx512f,fma")))
void intensity_block8(const double* coef, int n_terms, const double* mu, double* plus,
                      double* minus) {
    intensity_kernel<Vec8, 8>(coef, n_terms, mu, plus, minus);
}
#endif

// The Legendre projection, eight nodes at a time: P_l(mu_j) of the eight follows the three-term
// recurrence (l+1) P_{l+1} = (2l+1) mu P_l - l P_{l-1} in registers, and each order adds
// P_l(mu_j) w_j into its own eight-wide partial sum (sums[8 l .. 8 l + 7]), reduced once at the end.
// The plain form, one pass over all nodes per order into a single running sum, waits on that sum's
// latency. Orders come in pairs so that the parity (which weight, even or odd) is fixed in the code.
// The eight nodes are W vectors of 8 / W: one register under AVX-512, two under AVX2, whose
// recurrences are independent chains. (GCC lowers an eight-double vector on AVX2 through the stack,
// half by half: the halves' stores and the whole's reload cannot be forwarded, and the projection
// took four times as long as the intensities it projects; BM_PhaseProjection/3000 26.4 ms.)
// Element-wise arithmetic in a fixed order: the same result within each kernel set (below).
template <typename V, int W>
[[gnu::always_inline]] inline void projection_kernel(const double* __restrict rec, int orders,
                                                     const double* mu_in, const double* even_in,
                                                     const double* odd_in, double* __restrict sums) {
    constexpr int lanes = 8 / W;
    V mu[W], even[W], odd[W], p_prev[W], p[W];
    for (int k = 0; k < W; ++k)
        for (int i = 0; i < lanes; ++i) {
            mu[k][i] = mu_in[lanes * k + i], even[k][i] = even_in[lanes * k + i];
            odd[k][i] = odd_in[lanes * k + i];
            p_prev[k][i] = 1.0;                // P_0
            p[k][i] = mu_in[lanes * k + i]; // P_1
        }
    const auto add = [&](int l, const V* w) {
        for (int k = 0; k < W; ++k) {
            V s;
            __builtin_memcpy(&s, sums + 8 * l + lanes * k, sizeof(V));
            s += p[k] * w[k];
            __builtin_memcpy(sums + 8 * l + lanes * k, &s, sizeof(V));
            const V next = rec[2 * l] * mu[k] * p[k] - rec[2 * l + 1] * p_prev[k];
            p_prev[k] = p[k];
            p[k] = next;
        }
    };
    int l = 1;
    for (; l + 1 < orders; l += 2) {
        add(l, odd);
        add(l + 1, even);
    }
    if (l < orders) add(l, odd);
}

void projection_block(const double* rec, int orders, const double* mu, const double* even,
                      const double* odd, double* sums) {
    projection_kernel<Vec2, 4>(rec, orders, mu, even, odd, sums);
}

#ifdef BRDF_X86_DISPATCH
__attribute__((target("avx2,fma")))
void projection_block_avx2(const double* rec, int orders, const double* mu, const double* even,
                           const double* odd, double* sums) {
    projection_kernel<Vec4, 2>(rec, orders, mu, even, odd, sums);
}

__attribute__((target("avx512f,fma")))
void projection_block_avx512(const double* rec, int orders, const double* mu, const double* even,
                             const double* odd, double* sums) {
    projection_kernel<Vec8, 1>(rec, orders, mu, even, odd, sums);
}
#endif

} // namespace

const char* series_kernels() {
    switch (kernel_set()) {
    case KernelSet::avx512_fma: return "avx512-fma";
    case KernelSet::avx2_fma: return "avx2-fma";
    case KernelSet::baseline: break;
    }
    return "baseline";
}

PhaseFunctionAccumulator::PhaseFunctionAccumulator(int max_terms) : m_max_terms(max_terms) {
    if (max_terms < 1)
        throw InputError(cat("phase function: series length ", max_terms, " must be >= 1"));
    m_rule = gauss_legendre(2 * max_terms + 2);
    const int half = max_terms + 1;
    m_mu.assign(m_rule->x.end() - half, m_rule->x.end()); // the positive nodes, ascending
    m_weight.assign(m_rule->w.end() - half, m_rule->w.end());
    m_plus.assign(half, 0.0);
    m_minus.assign(half, 0.0);
    // c_n = (2n+1)/(n(n+1)), n c_n, (n+2) c_{n+1} and the pi_n recurrence's (2n+1)/n, (n+1)/n:
    // divisions done once.
    m_recurrence.resize(recurrence_stride * static_cast<std::size_t>(max_terms));
    for (int n = 1; n <= max_terms; ++n) {
        double* r = m_recurrence.data() + recurrence_stride * (n - 1);
        r[0] = (2.0 * n + 1.0) / (n * (n + 1.0));
        r[1] = (2.0 * n + 1.0) / (n + 1.0);
        r[2] = (2.0 * n + 3.0) / (n + 1.0);
        r[3] = (2.0 * n + 1.0) / n;
        r[4] = (n + 1.0) / n;
    }
}

void PhaseFunctionAccumulator::clear() {
    std::fill(m_plus.begin(), m_plus.end(), 0.0);
    std::fill(m_minus.begin(), m_minus.end(), 0.0);
}

void PhaseFunctionAccumulator::add(const Coefficients& c, double weight) {
    accumulate(c, weight, m_plus.data(), m_minus.data(), m_work);
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
    std::vector<double> work;
    accumulate(c, weight, plus, minus, work);
}

void PhaseFunctionAccumulator::accumulate(const Coefficients& c, double weight, double* plus, double* minus,
                                          std::vector<double>& coef) const {
    const int n_terms = c.size();
    if (n_terms > m_max_terms)
        throw InputError(cat("phase function: series of ", n_terms, " terms exceeds the ",
                             m_max_terms, " the accumulator was built for"));
    if (!(weight >= 0.0) || !std::isfinite(weight))
        throw InputError(cat("phase function: weight ", weight, " must be finite and >= 0"));
    if (weight == 0.0) return;
    const std::size_t half = m_mu.size();
    coef.resize(per_order * static_cast<std::size_t>(n_terms));
    const std::complex<double> none = 0.0; // a_{N+1}, b_{N+1}
    for (int n = 1; n <= n_terms; ++n) {
        const double* r = m_recurrence.data() + recurrence_stride * (n - 1);
        const std::complex<double> a = c.a[n - 1], b = c.b[n - 1];
        const std::complex<double> a_next = n < n_terms ? c.a[n] : none;
        const std::complex<double> b_next = n < n_terms ? c.b[n] : none;
        double* cn = coef.data() + per_order * (n - 1);
        cn[0] = r[0] * a.real() - r[2] * b_next.real(); // C1_n
        cn[1] = r[0] * a.imag() - r[2] * b_next.imag();
        cn[2] = r[1] * b.real(); // D1_n
        cn[3] = r[1] * b.imag();
        cn[4] = r[0] * b.real() - r[2] * a_next.real(); // C2_n
        cn[5] = r[0] * b.imag() - r[2] * a_next.imag();
        cn[6] = r[1] * a.real(); // D2_n
        cn[7] = r[1] * a.imag();
        cn[8] = r[3];
        cn[9] = r[4];
    }
    std::size_t block = 2;
    auto kernel = intensity_block2;
#ifdef BRDF_X86_DISPATCH
    if (kernel_set() == KernelSet::avx512_fma) block = 8, kernel = intensity_block8;
    if (kernel_set() == KernelSet::avx2_fma) block = 4, kernel = intensity_block4_avx2;
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

std::vector<double> PhaseFunctionAccumulator::project(std::size_t half, int l_last, double total) const {
    const std::size_t orders = static_cast<std::size_t>(l_last) + 1;
    std::vector<double> recurrence, sums; // once per ensemble
    recurrence.assign(2 * (orders + 1), 0.0);
    for (std::size_t l = 1; l < orders; ++l) {
        recurrence[2 * l] = (2.0 * l + 1.0) / (l + 1.0);
        recurrence[2 * l + 1] = static_cast<double>(l) / (l + 1.0);
    }
    sums.assign(8 * (orders + 1), 0.0);
    auto project_block = projection_block;
#ifdef BRDF_X86_DISPATCH
    if (kernel_set() == KernelSet::avx512_fma) project_block = projection_block_avx512;
    if (kernel_set() == KernelSet::avx2_fma) project_block = projection_block_avx2;
#endif
    double mu[8], even[8], odd[8];
    for (std::size_t j0 = 0; j0 < half; j0 += 8) {
        for (std::size_t i = 0; i < 8; ++i) {
            const std::size_t j = j0 + i;
            const bool in = j < half;
            mu[i] = in ? m_mu[j] : 0.0;
            even[i] = in ? m_weight[j] * (m_plus[j] + m_minus[j]) : 0.0;
            odd[i] = in ? m_weight[j] * (m_plus[j] - m_minus[j]) : 0.0;
        }
        project_block(recurrence.data(), static_cast<int>(orders), mu, even, odd, sums.data());
    }
    std::vector<double> beta{1.0};
    beta.reserve(orders);
    for (std::size_t l = 1; l < orders; ++l) {
        double sum = 0.0;
        for (std::size_t i = 0; i < 8; ++i) sum += sums[8 * l + i];
        beta.push_back((2.0 * l + 1.0) * sum / total);
    }
    return beta;
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
    const int l_max = 2 * m_max_terms; // the intensity is a polynomial of this degree
    int l_last = l_max;
    if (options.max_terms > 0) l_last = std::min(l_last, options.max_terms - 1);
    std::vector<double> beta = project(half, l_last, total);
    // Cut after the last moment above the tolerance.
    std::size_t keep = beta.size();
    while (keep > 1 && !(std::abs(beta[keep - 1]) > options.tolerance)) --keep;
    beta.resize(keep);
    return beta;
}

} // namespace brdf::mie
