#include <brdf/core/quadrature.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <numbers>

namespace brdf {
namespace {

// Nodes are refined in blocks: the three-term recurrence is a long dependency chain (a product and
// a difference per degree), and running several nodes side by side lets the compiler overlap and
// vectorise them. Large rules (the Mie moments at x = 1e4 need 2e4 nodes) were about ten times
// faster with eight nodes than with one; with 32, compiled for AVX-512 and AVX2 as well as the
// baseline, the recurrence has four AVX-512 vectors in flight instead of one (or four SSE2 pairs),
// and the rules take a third of the time they did (64 to 7,001 nodes; the 40 um matting agent's
// 41 wavelengths each need their own of ~7,000, 3,500 and 1,750): the same products and
// differences per node, so the same bits.
constexpr int block = 32;

// P_n and P_{n-1} at `block` points by the recurrence with precomputed coefficients
// a_l = (2l-1)/l, b_l = (l-1)/l. Must not throw (target_clones: see core/legendre.cpp).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void legendre_block(int n, const double* a, const double* b, const double* x, double* pn, double* pn1) {
    double p0[block], p1[block];
    for (int j = 0; j < block; ++j) {
        p0[j] = 1.0;
        p1[j] = x[j];
    }
    for (int l = 2; l <= n; ++l) {
        for (int j = 0; j < block; ++j) {
            const double p2 = a[l] * x[j] * p1[j] - b[l] * p0[j];
            p0[j] = p1[j];
            p1[j] = p2;
        }
    }
    for (int j = 0; j < block; ++j) {
        pn[j] = p1[j];
        pn1[j] = p0[j];
    }
}

Quadrature compute_gauss_legendre(int n) {
    Quadrature q;
    q.x.assign(n, 0.0);
    q.w.assign(n, 2.0);
    if (n == 1) return q;
    std::vector<double> a(n + 1, 0.0), b(n + 1, 0.0);
    for (int l = 2; l <= n; ++l) {
        a[l] = (2.0 * l - 1.0) / l;
        b[l] = (l - 1.0) / l;
    }
    const int half = (n + 1) / 2;
    for (int k0 = 0; k0 < half; k0 += block) {
        double x[block], pn[block], pn1[block], dp[block];
        for (int j = 0; j < block; ++j) {
            // Tricomi: x_k ~ (1 - (n-1)/(8 n^3)) cos(pi (k + 3/4) / (n + 1/2)), k counted from x = 1.
            // Lanes past the last node repeat it; their results are discarded.
            const int k = std::min(k0 + j, half - 1);
            x[j] = (1.0 - (n - 1.0) / (8.0 * n * n * n)) *
                   std::cos(std::numbers::pi * (k + 0.75) / (n + 0.5));
        }
        for (int iter = 0; iter < 100; ++iter) {
            legendre_block(n, a.data(), b.data(), x, pn, pn1);
            double largest_step = 0.0;
            for (int j = 0; j < block; ++j) {
                dp[j] = n * (x[j] * pn[j] - pn1[j]) / (x[j] * x[j] - 1.0);
                const double dx = pn[j] / dp[j];
                x[j] -= dx;
                largest_step = std::max(largest_step, std::abs(dx));
            }
            if (largest_step <= 1e-16) break;
        }
        // Weights from the derivative at the converged nodes.
        legendre_block(n, a.data(), b.data(), x, pn, pn1);
        for (int j = 0; j < block && k0 + j < half; ++j) {
            const int k = k0 + j;
            const double d = n * (x[j] * pn[j] - pn1[j]) / (x[j] * x[j] - 1.0);
            q.x[n - 1 - k] = x[j];
            q.x[k] = -x[j];
            q.w[k] = q.w[n - 1 - k] = 2.0 / ((1.0 - x[j] * x[j]) * d * d);
        }
    }
    if (n % 2 == 1) q.x[n / 2] = 0.0;
    return q;
}

} // namespace

std::shared_ptr<const Quadrature> gauss_legendre(int n) {
    if (n < 1 || n > 200000)
        throw LimitError(cat("Gauss-Legendre rule: size ", n, " outside [1, 200000]"));
    static std::mutex mutex;
    static std::map<int, std::shared_ptr<const Quadrature>> cache;
    {
        std::lock_guard lock(mutex);
        if (auto it = cache.find(n); it != cache.end()) return it->second;
    }
    auto rule = std::make_shared<const Quadrature>(compute_gauss_legendre(n));
    std::lock_guard lock(mutex);
    return cache.emplace(n, std::move(rule)).first->second;
}

Quadrature gauss_legendre(int n, double a, double b) {
    const auto base = gauss_legendre(n);
    Quadrature q;
    q.x.resize(n);
    q.w.resize(n);
    const double half = 0.5 * (b - a), mid = 0.5 * (a + b);
    for (int i = 0; i < n; ++i) {
        q.x[i] = mid + half * base->x[i];
        q.w[i] = half * base->w[i];
    }
    return q;
}

std::vector<double> chebyshev_lobatto(int n, double a, double b) {
    std::vector<double> out;
    const double mid = 0.5 * (a + b), half = 0.5 * (b - a);
    for (int j = 0; j < n; ++j) out.push_back(mid - half * std::cos(std::numbers::pi * j / (n - 1)));
    out.front() = a; // exactly: a sample at either end is then a node
    out.back() = b;
    return out;
}

std::vector<double> lagrange_weights(std::span<const double> nodes, double x) {
    std::vector<double> weight(nodes.size(), 1.0);
    for (std::size_t j = 0; j < nodes.size(); ++j)
        for (std::size_t i = 0; i < nodes.size(); ++i)
            if (i != j) weight[j] *= (x - nodes[i]) / (nodes[j] - nodes[i]);
    return weight;
}

} // namespace brdf
