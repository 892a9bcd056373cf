#include <brdf/rte/phase.h>

#include <brdf/core/error.h>
#include <brdf/core/legendre.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace brdf::rte {

double phase_value(std::span<const double> beta, double cos_theta) { return legendre_series(beta, cos_theta); }

void phase_values(std::span<const double> beta, std::span<const double> cos_theta, std::span<double> out) {
    legendre_series(beta, cos_theta, out);
}

DeltaM delta_m(const Medium& medium, int first_dropped) {
    const int size = static_cast<int>(medium.beta.size());
    if (first_dropped < 1) throw InputError(cat("delta-M: truncation order must be >= 1 (got ", first_dropped, ")"));
    if (size <= first_dropped) return DeltaM{medium, 0.0};
    double f = medium.beta[first_dropped] / (2.0 * first_dropped + 1.0);
    // Delta-M removes a forward peak. A backward-peaked phase function (g < 0) has none: there f only
    // picks up the alternating tail of its moments, and taking it out would put a spurious negative
    // forward lobe in and mis-scale the single scattering (measured: tests/hard, HG g = -0.9).
    // Plain truncation is used instead; the exact single scattering is still added back.
    if (f <= 0.0 || medium.beta[1] < 0.0) f = 0.0;
    DeltaM out;
    out.f = f;
    out.scaled.omega = medium.omega * (1.0 - f) / (1.0 - medium.omega * f);
    out.scaled.beta.resize(static_cast<std::size_t>(first_dropped));
    for (int l = 0; l < first_dropped; ++l) {
        const double chi = medium.beta[l] / (2.0 * l + 1.0);
        out.scaled.beta[l] = (2.0 * l + 1.0) * (chi - f) / (1.0 - f);
    }
    out.scaled.beta[0] = 1.0; // exactly, whatever the rounding above
    return out;
}

double spread_delta_m_residual(const Medium& medium, int first_dropped, double sigma) {
    if (!(sigma > 0.0)) throw InputError(cat("delta-M residual: spread must be > 0 (got ", sigma, ")"));
    const double f = delta_m(medium, first_dropped).f;
    const int size = static_cast<int>(medium.beta.size());
    // The spread's factor falls below e^-40 at l = sqrt(80) / sigma: nothing beyond counts.
    const double s = std::max(sigma, 2.5e-3);
    const int terms = std::max(size, static_cast<int>(std::ceil(std::sqrt(80.0) / s)) + 1);
    std::vector<double> spread(static_cast<std::size_t>(terms)), residual(static_cast<std::size_t>(terms), 0.0);
    for (int l = 0; l < terms; ++l) {
        const double beta = l < size ? medium.beta[l] : 0.0;
        const double damping = std::exp(-0.5 * l * (l + 1.0) * s * s);
        spread[l] = beta * damping;
        if (l >= first_dropped) residual[l] = (beta - (2.0 * l + 1.0) * f) * damping;
    }
    constexpr int angles = 91; // every degree from 90 to 180
    std::vector<double> x(angles), p(angles), r(angles);
    for (int a = 0; a < angles; ++a) x[a] = -std::sin(std::numbers::pi / 2.0 * a / (angles - 1));
    legendre_series(spread, x, p);
    legendre_series(residual, x, r);
    // As the stream check compares (model.cpp, disagreement): values below 1e-2 of the largest on
    // that absolute scale.
    double largest = 0.0;
    for (double v : p) largest = std::max(largest, std::abs(v));
    double worst = 0.0;
    for (int a = 0; a < angles; ++a) worst = std::max(worst, std::abs(r[a]) / std::max(std::abs(p[a]), 1e-2 * largest));
    return worst;
}

Matrix legendre_basis(int m, int lmax, std::span<const double> mu, int sine_power) {
    Matrix psi(static_cast<int>(mu.size()), lmax - m + 1);
    normalized_legendre_over_sine(m, lmax, mu, psi.data(), sine_power);
    return psi;
}

PhasePair phase_components(std::span<const double> beta, int m, std::span<const double> mu_rows,
                           std::span<const double> mu_cols, int rows_sine_power) {
    const int lmax = static_cast<int>(beta.size()) - 1;
    PhasePair out{Matrix(static_cast<int>(mu_rows.size()), static_cast<int>(mu_cols.size())),
                  Matrix(static_cast<int>(mu_rows.size()), static_cast<int>(mu_cols.size()))};
    if (lmax < m) return out; // p^m = 0 beyond the series
    // Pbar_l^m(-mu) = (-1)^(l+m) Pbar_l^m(mu): with A_lb = beta_l Pbar_l^m(row) and B = Pbar_l^m(col),
    // the even and odd l - m parts are two products, and p+ = even + odd, p- = even - odd.
    Matrix a = legendre_basis(m, lmax, mu_rows, rows_sine_power);
    Matrix b = legendre_basis(m, lmax, mu_cols);
    Matrix a_odd(a.rows(), a.cols());
    for (int i = 0; i < a.rows(); ++i)
        for (int l = m; l <= lmax; ++l) {
            double& v = a(i, l - m);
            v *= beta[l];
            if ((l - m) % 2 == 1) std::swap(v, a_odd(i, l - m));
        }
    Matrix even, odd;
    gemm(a, false, b, true, even);
    gemm(a_odd, false, b, true, odd);
    for (int i = 0; i < out.plus.rows(); ++i)
        for (int j = 0; j < out.plus.cols(); ++j) {
            out.plus(i, j) = even(i, j) + odd(i, j);
            out.minus(i, j) = even(i, j) - odd(i, j);
        }
    return out;
}

} // namespace brdf::rte
