#include <brdf/core/legendre.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <cmath>

namespace brdf {

void normalized_legendre(int m, int lmax, double x, std::span<double> out) {
    if (m < 0 || lmax < m || out.size() < static_cast<std::size_t>(lmax - m + 1))
        throw InputError(cat("normalized_legendre: bad order/degree (m = ", m, ", lmax = ", lmax, ")"));
    const double s = std::sqrt(std::max(0.0, (1.0 - x) * (1.0 + x)));
    // Pbar_m^m = sqrt((2m - 1)!! ^ 2 / (2m)!) s^m, built as a product of factors sqrt((2k-1)/(2k)) s,
    // each below 1, so it underflows gracefully to 0 (where it is negligible) instead of overflowing.
    double pmm = 1.0;
    for (int k = 1; k <= m; ++k) pmm *= std::sqrt((2.0 * k - 1.0) / (2.0 * k)) * s;
    out[0] = pmm;
    if (lmax == m) return;
    double prev = pmm;
    double cur = std::sqrt(2.0 * m + 1.0) * x * pmm; // Pbar_{m+1}^m
    out[1] = cur;
    // (l - m) P_l^m = (2l - 1) x P_{l-1}^m - (l + m - 1) P_{l-2}^m, rescaled to the normalised functions.
    const double mm = static_cast<double>(m) * m;
    for (int l = m + 2; l <= lmax; ++l) {
        const double lm1 = l - 1.0;
        const double next =
            ((2.0 * l - 1.0) * x * cur - std::sqrt(lm1 * lm1 - mm) * prev) / std::sqrt(double(l) * l - mm);
        prev = cur;
        cur = next;
        out[l - m] = cur;
    }
}

std::vector<double> normalized_legendre(int m, int lmax, double x) {
    std::vector<double> out(static_cast<std::size_t>(lmax - m + 1));
    normalized_legendre(m, lmax, x, out);
    return out;
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

} // namespace brdf
