#include <brdf/rte/phase.h>

#include <brdf/core/error.h>
#include <brdf/core/legendre.h>
#include <brdf/core/log.h>

namespace brdf::rte {

double phase_value(std::span<const double> beta, double cos_theta) { return legendre_series(beta, cos_theta); }

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

Matrix legendre_basis(int m, int lmax, std::span<const double> mu) {
    Matrix psi(static_cast<int>(mu.size()), lmax - m + 1);
    for (int i = 0; i < psi.rows(); ++i) normalized_legendre(m, lmax, mu[i], psi.row(i));
    return psi;
}

PhasePair phase_components(std::span<const double> beta, int m, std::span<const double> mu_rows,
                           std::span<const double> mu_cols) {
    const int lmax = static_cast<int>(beta.size()) - 1;
    PhasePair out{Matrix(static_cast<int>(mu_rows.size()), static_cast<int>(mu_cols.size())),
                  Matrix(static_cast<int>(mu_rows.size()), static_cast<int>(mu_cols.size()))};
    if (lmax < m) return out; // p^m = 0 beyond the series
    const Matrix a = legendre_basis(m, lmax, mu_rows);
    const Matrix b = legendre_basis(m, lmax, mu_cols);
    // Pbar_l^m(-mu) = (-1)^(l+m) Pbar_l^m(mu): one pass gives both signs.
    for (int i = 0; i < out.plus.rows(); ++i) {
        for (int j = 0; j < out.plus.cols(); ++j) {
            double even = 0.0, odd = 0.0;
            for (int l = m; l <= lmax; ++l) {
                const double t = beta[l] * a(i, l - m) * b(j, l - m);
                ((l - m) % 2 == 0 ? even : odd) += t;
            }
            out.plus(i, j) = even + odd;
            out.minus(i, j) = even - odd;
        }
    }
    return out;
}

} // namespace brdf::rte
