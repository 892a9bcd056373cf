#include <brdf/core/legendre.h>

#include <brdf/core/error.h>
#include <brdf/core/lane_set.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>

namespace brdf {

void normalized_legendre(int m, int lmax, double x, std::span<double> out) {
    if (m < 0 || lmax < m || out.size() < static_cast<std::size_t>(lmax - m + 1))
        throw InputError(cat("normalized_legendre: bad order/degree (m = ", m, ", lmax = ", lmax, ")"));
    normalized_legendre(m, lmax, std::span<const double>(&x, 1), out);
}

std::vector<double> normalized_legendre(int m, int lmax, double x) {
    std::vector<double> out(static_cast<std::size_t>(lmax - m + 1));
    normalized_legendre(m, lmax, x, out);
    return out;
}

namespace {

// normalized_legendre at every x[k], divided by (1 - x^2)^(power/2): that power of the sine left
// out of the start Pbar_m^m (the recurrence in l involves x alone).
void legendre_rows(int m, int lmax, std::span<const double> x, std::span<double> out, int power) {
    if (m < 0 || lmax < m || power < 0 || power > m)
        throw InputError(cat("normalized_legendre: bad order/degree/power (m = ", m,
                             ", lmax = ", lmax, ", power = ", power, ")"));
    const std::size_t count = static_cast<std::size_t>(lmax - m + 1);
    if (out.size() < x.size() * count)
        throw InternalError(cat("normalized_legendre: ", out.size(), " outputs for ", x.size(), " points of ",
                                count, " degrees"));
    // Pbar_m^m = prod_{k=1..m} sqrt((2k - 1)/(2k)) s underflows for large m (s^m), and starting the
    // recurrence from a denormal would amplify its few bits into O(1) garbage further up in l. So the
    // recurrence runs on scaled values v_l = Pbar_l^m * 2^-e, starting from v_m = 1 with
    // e = log2(Pbar_m^m), rescaling when v grows; values are unscaled on output (true zeros stay 0).
    // prod_k (2k - 1)/(2k) ~ 1/sqrt(pi m) stays normal for any m: one log of it, one of s per point.
    // Per point the start (its scale and first two values), then the recurrence
    // (l - m) P_l^m = (2l - 1) x P_{l-1}^m - (l + m - 1) P_{l-2}^m, rescaled to the normalised
    // functions, degree by degree over a block of points: each point's operations are those of a
    // block of one.
    double ratio = 1.0;
    for (int k = 1; k <= m; ++k) ratio *= (2.0 * k - 1.0) / (2.0 * k);
    const double half_log_ratio = m == 0 ? 0.0 : 0.5 * std::log2(ratio);
    const double first = std::sqrt(2.0 * m + 1.0);
    const double mm = static_cast<double>(m) * m;
    constexpr std::size_t block = 64;
    double prev[block], cur[block], e[block], scale[block];
    bool zero[block];
    for (std::size_t start = 0; start < x.size(); start += block) {
        const std::size_t points = std::min(block, x.size() - start);
        const double* xs = x.data() + start;
        double* rows = out.data() + start * count;
        for (std::size_t k = 0; k < points; ++k) {
            const double s = std::sqrt(std::max(0.0, (1.0 - xs[k]) * (1.0 + xs[k])));
            zero[k] = m > power && s == 0.0;
            e[k] = m == 0 ? 0.0 : half_log_ratio + (m > power ? (m - power) * std::log2(s) : 0.0);
            scale[k] = std::exp2(e[k]);
            double* row = rows + k * count;
            if (zero[k]) {
                std::fill_n(row, count, 0.0);
                continue;
            }
            prev[k] = 1.0;
            row[0] = (e[k] < -1100.0) ? 0.0 : prev[k] * scale[k];
            if (lmax == m) continue;
            cur[k] = first * xs[k];
            row[1] = (e[k] < -1100.0) ? 0.0 : cur[k] * scale[k];
        }
        for (int l = m + 2; l <= lmax; ++l) {
            const double lm1 = l - 1.0;
            const double a = 2.0 * l - 1.0, b = std::sqrt(lm1 * lm1 - mm), c = std::sqrt(double(l) * l - mm);
            const std::size_t column = static_cast<std::size_t>(l - m);
            for (std::size_t k = 0; k < points; ++k) {
                if (zero[k]) continue;
                const double next = (a * xs[k] * cur[k] - b * prev[k]) / c;
                prev[k] = cur[k];
                cur[k] = next;
                if (e[k] < 0.0 && std::abs(cur[k]) > 0x1p+100) { // keep v moderate while the values are tiny
                    prev[k] *= 0x1p-100, cur[k] *= 0x1p-100;
                    e[k] += 100.0;
                    scale[k] = std::exp2(e[k]);
                }
                rows[k * count + column] = (e[k] < -1100.0) ? 0.0 : cur[k] * scale[k];
            }
        }
    }
}

} // namespace

void normalized_legendre(int m, int lmax, std::span<const double> x, std::span<double> out) {
    legendre_rows(m, lmax, x, out, 0);
}

void normalized_legendre_over_sine(int m, int lmax, std::span<const double> x,
                                   std::span<double> out, int power) {
    legendre_rows(m, lmax, x, out, power);
}

void legendre_polynomials(int lmax, double x, std::span<double> out) { normalized_legendre(0, lmax, x, out); }

double legendre_series(std::span<const double> beta, double x) {
    // Clenshaw: b_l = beta_l + a_l x b_{l+1} - c_{l+1} b_{l+2} with P_{l+1} = ((2l+1) x P_l - l P_{l-1})/(l+1).
    double b1 = 0.0, b2 = 0.0;
    for (std::size_t i = beta.size(); i-- > 0;) {
        const double l = static_cast<double>(i);
        const double alpha = (2.0 * l + 1.0) / (l + 1.0) * x;
        const double betac = (l + 1.0) / (l + 2.0);
        const double b0 = beta[i] + alpha * b1 - betac * b2;
        b2 = b1;
        b1 = b0;
    }
    return b1;
}

// Compiled for AVX-512, AVX2 and the baseline, one picked at run time. The points go W to a vector,
// W the width of the target's registers (GCC vector extensions): a plain loop over the points was
// not vectorised (GCC interchanged it with the loop over l), and a vector wider than the registers
// GCC lowers through the stack piece by piece (eight under AVX2: the 40 um matting agent's phase
// tables took 12 % of its compute with its Mie on disk). The phase tables of a big sphere's series,
// thousands of terms at thousands of points, took a fifth of the time before. Element-wise
// operations in the scalar sum's order and no contraction (cmake/BrdfWarnings.cmake): every set,
// and the scalar legendre_series above, give the same bits.
namespace {
template <int W> struct PointLanes { // (an alias template would drop the attribute)
    typedef double vec __attribute__((vector_size(8 * W)));
};
template <int W>
[[gnu::always_inline]] inline void legendre_series_blocks(std::span<const double> beta, std::span<const double> x,
                                                          std::span<double> out) {
    using Vec = typename PointLanes<W>::vec;
    // Points in blocks whose two recurrence rows stay in the L1 cache.
    constexpr std::size_t lanes = W, vectors = 256 / W, block = lanes * vectors;
    Vec xs[vectors], b1[vectors], b2[vectors];
    for (std::size_t first = 0; first < x.size(); first += block) {
        const std::size_t count = std::min(block, x.size() - first);
        const std::size_t used = (count + lanes - 1) / lanes;
        for (std::size_t v = 0; v < used; ++v)
            for (std::size_t k = 0; k < lanes; ++k) {
                const std::size_t j = v * lanes + k;
                xs[v][k] = j < count ? x[first + j] : 0.0;
                b1[v][k] = 0.0;
                b2[v][k] = 0.0;
            }
        for (std::size_t i = beta.size(); i-- > 0;) {
            const double l = static_cast<double>(i);
            const double a = (2.0 * l + 1.0) / (l + 1.0);
            const double betac = (l + 1.0) / (l + 2.0);
            const double bl = beta[i];
            for (std::size_t v = 0; v < used; ++v) {
                const Vec b0 = bl + a * xs[v] * b1[v] - betac * b2[v];
                b2[v] = b1[v];
                b1[v] = b0;
            }
        }
        for (std::size_t j = 0; j < count; ++j) out[first + j] = b1[j / lanes][j % lanes];
    }
}

using SeriesBlocks = void (*)(std::span<const double>, std::span<const double>, std::span<double>);
void series_blocks_baseline(std::span<const double> beta, std::span<const double> x, std::span<double> out) {
    legendre_series_blocks<2>(beta, x, out);
}
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target("avx2"))) void series_blocks_avx2(std::span<const double> beta, std::span<const double> x,
                                                        std::span<double> out) {
    legendre_series_blocks<4>(beta, x, out);
}
__attribute__((target("avx512f"))) void series_blocks_avx512(std::span<const double> beta, std::span<const double> x,
                                                            std::span<double> out) {
    legendre_series_blocks<8>(beta, x, out);
}
#endif
SeriesBlocks series_blocks() {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
    switch (lane_set()) {
    case LaneSet::avx512: return series_blocks_avx512;
    case LaneSet::avx2: return series_blocks_avx2;
    case LaneSet::baseline: break;
    }
#endif
    return series_blocks_baseline;
}
} // namespace

void legendre_series(std::span<const double> beta, std::span<const double> x, std::span<double> out) {
    if (out.size() < x.size())
        throw InternalError(cat("legendre_series: ", out.size(), " outputs for ", x.size(), " points"));
    series_blocks()(beta, x, out);
}

} // namespace brdf
