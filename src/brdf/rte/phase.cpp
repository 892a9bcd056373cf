#include <brdf/rte/phase.h>

#include <brdf/core/error.h>
#include <brdf/core/legendre.h>
#include <brdf/core/log.h>

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
