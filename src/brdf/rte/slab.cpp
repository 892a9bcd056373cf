#include <brdf/rte/slab.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>

namespace brdf::rte {
namespace {

// (1 - exp(-x)) / x, 1 at x = 0, for either sign of x.
double one_minus_exp_over(double x) { return x == 0.0 ? 1.0 : -std::expm1(-x) / x; }

// (exp(-a tau) - exp(-b tau)) / (b - a) for a, b >= 0, tau at a = b, without overflow for any tau:
// the smaller rate's exponential times (1 - exp(-|b - a| tau)) / |b - a|.
double exp_difference(double a, double b, double tau) {
    return std::exp(-std::min(a, b) * tau) * tau * one_minus_exp_over(std::abs(b - a) * tau);
}

// (1 - exp(-k tau)) / k, tau at k = 0.
double phi_of(double k, double tau) { return tau * one_minus_exp_over(k * tau); }

// Columns scaled: m(i, j) *= s[j].
void scale_columns(Matrix& m, std::span<const double> s) {
    for (int i = 0; i < m.rows(); ++i)
        for (int j = 0; j < m.cols(); ++j) m(i, j) *= s[j];
}

} // namespace

SlabOrder::SlabOrder(const OrderProblem& pr, double tau)
    : m_m(pr.m), m_omega(pr.omega), m_tau(tau), m_mu(pr.streams.mu), m_w(pr.streams.w) {
    if (!(tau >= 0.0) || !std::isfinite(tau))
        throw InputError(cat("slab: optical thickness must be finite and >= 0 (got ", tau, ")"));
    const int n = pr.streams.size();
    const double om = pr.omega;
    // T+- = I - (w/2) W^1/2 (P+ +- P-) W^1/2 (symmetric); U = M^-1/2 T- M^-1/2, V = M^-1/2 T+ M^-1/2.
    Matrix u(n, n), v(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double sw = std::sqrt(m_w[i] * m_w[j]);
            const double smu = std::sqrt(m_mu[i] * m_mu[j]);
            const double eye = i == j ? 1.0 : 0.0;
            u(i, j) = (eye - 0.5 * om * sw * (pr.p_plus(i, j) - pr.p_minus(i, j))) / smu;
            v(i, j) = (eye - 0.5 * om * sw * (pr.p_plus(i, j) + pr.p_minus(i, j))) / smu;
        }
    // U = L L^T; the eigenvalues of L^T V L are k^2 (those of M^-1 (A - B) M^-1 (A + B)).
    const Matrix l = cholesky_lower(std::move(u));
    Matrix lt_v_l;
    {
        Matrix vl = v * l;
        gemm(l, true, vl, false, lt_v_l);
        for (int i = 0; i < n; ++i) // exactly symmetric for the eigensolver
            for (int j = 0; j < i; ++j) lt_v_l(i, j) = lt_v_l(j, i) = 0.5 * (lt_v_l(i, j) + lt_v_l(j, i));
    }
    SymmetricEigen eig = symmetric_eigen(std::move(lt_v_l));
    m_k.resize(static_cast<std::size_t>(n));
    for (int j = 0; j < n; ++j) m_k[j] = std::sqrt(std::max(0.0, eig.values[j]));
    // At albedo 1, m = 0 the smallest rate is exactly 0 (conservation); rounding leaves ~1e-8.
    if (pr.conservative()) m_k[0] = 0.0;
    const Matrix& y = eig.vectors;

    // S = Z L Y, D~ = -Z L^-T Y with Z = W^-1/2 M^-1/2.
    m_s = l * y;
    m_d = y;
    solve_lower(l, m_d, /*transpose=*/true);
    for (int i = 0; i < n; ++i) {
        const double z = 1.0 / std::sqrt(m_w[i] * m_mu[i]);
        for (int j = 0; j < n; ++j) {
            m_s(i, j) *= z;
            m_d(i, j) *= -z;
        }
    }
    // (A - B)^-1 = Z L^-T L^-1 Z^-1 with Z^-1 = W^1/2 M^1/2... written out: W^-1/2 M^-1/2 L^-T L^-1 M^-1/2 W^1/2.
    {
        Matrix linv = Matrix::identity(n);
        solve_lower(l, linv);
        Matrix t;
        gemm(linv, true, linv, false, t); // L^-T L^-1
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j)
                t(i, j) *= std::sqrt(m_w[j] / m_w[i]) / std::sqrt(m_mu[i] * m_mu[j]);
        m_a_minus_b_inv = std::move(t);
    }
    // The beam's particular solution in the eigenbasis: G = S^-1 M^-1 (A - B) M^-1 = Y^T L^T diag(sqrt(w / mu)).
    gemm(y, true, l, true, m_beam_projector);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) m_beam_projector(i, j) *= std::sqrt(m_w[j] / m_mu[j]);

    // Boundary conditions of a slab lit from the top over a black bottom, with the "difference"
    // columns divided by k (docs/physics.md section 8):
    //   Cp = X- + X+ E,  Cm = (X- - X+ E) / k,  Rp = X+ + X- E,  Rm = (X+ - X- E) / k,
    //   R = (Rp Cp^-1 + Rm Cm^-1) / 2,  T = (Rp Cp^-1 - Rm Cm^-1) / 2   (intensity operators).
    m_e.resize(static_cast<std::size_t>(n));
    m_phi.resize(static_cast<std::size_t>(n));
    Matrix cp(n, n), cm(n, n), rp(n, n), rm(n, n);
    for (int j = 0; j < n; ++j) {
        const double k = m_k[j];
        m_e[j] = std::exp(-k * tau);
        m_phi[j] = phi_of(k, tau);
        const double kk = k * k * m_phi[j]; // k (1 - e)
        for (int i = 0; i < n; ++i) {
            const double s = m_s(i, j), d = m_d(i, j);
            cp(i, j) = 0.5 * (s * (1.0 + m_e[j]) - kk * d);
            rp(i, j) = 0.5 * (s * (1.0 + m_e[j]) + kk * d);
            cm(i, j) = 0.5 * (s * m_phi[j] - d * (1.0 + m_e[j]));
            rm(i, j) = 0.5 * (s * m_phi[j] + d * (1.0 + m_e[j]));
        }
    }
    // By the unblocked LU (solve: LuFactor), not LAPACK's inverse: at tau = 0, where R = (P + Q)/2
    // cancels to 0, it leaves 1e-14 of rounding (Slab.ZeroThicknessIsTheIdentity) where dgetri
    // leaves 3e-14. Once per layer and order, off the per-direction path.
    m_cp_inv = solve(cp, Matrix::identity(n));
    m_cm_inv = solve(cm, Matrix::identity(n));
    const Matrix p = rp * m_cp_inv, q = rm * m_cm_inv;
    m_r = 0.5 * (p + q);
    m_t = 0.5 * (p - q);
    std::vector<double> inv_q(static_cast<std::size_t>(n));
    for (int j = 0; j < n; ++j) inv_q[j] = 1.0 / (2.0 * m_w[j] * m_mu[j]);
    scale_columns(m_r, inv_q);
    scale_columns(m_t, inv_q);
}

SlabOrder::RowCoefficients SlabOrder::row_coefficients(std::span<const double> beta, std::span<const double> u,
                                                       PhasePair& pu) const {
    // Source at cosine u from the homogeneous field: J(t, u) = sum_j a_j e^(-k_j t) c_j + b_j e^(-k_j (tau - t)) d_j
    // with a = sigma + k rho, b = sigma - k rho,
    //   sigma_j = (w/4) sum_i (p(u, mu_i) + p(-u, mu_i)) w_i S_ij,  rho_j = (w/4) sum_i (p(u, mu_i) - p(-u, mu_i)) w_i D~_ij.
    // Integrated along u to the top: alpha_j = int e^(-k t) e^(-t/u) dt/u, beta_j = int e^(-k (tau - t)) e^(-t/u) dt/u.
    // The emerging intensity is (1/2) [plus (c + d) + minus k (c - d)] with plus = a alpha + b beta,
    // minus = (a alpha - b beta) / k; at the bottom the same with the sign of the second term flipped.
    const int n = static_cast<int>(m_mu.size());
    const int ne = static_cast<int>(u.size());
    pu = phase_components(beta, m_m, u, m_mu);
    Matrix sum(ne, n), dif(ne, n);
    for (int e = 0; e < ne; ++e)
        for (int i = 0; i < n; ++i) {
            sum(e, i) = 0.25 * m_omega * (pu.plus(e, i) + pu.minus(e, i)) * m_w[i];
            dif(e, i) = 0.25 * m_omega * (pu.plus(e, i) - pu.minus(e, i)) * m_w[i];
        }
    const Matrix sigma = sum * m_s, rho = dif * m_d;
    RowCoefficients c{Matrix(ne, n), Matrix(ne, n)};
    for (int e = 0; e < ne; ++e) {
        const double ue = u[e];
        if (!(ue > 0.0 && ue <= 1.0)) throw InputError(cat("slab: cosine must be in (0, 1] (got ", ue, ")"));
        const double big_e = std::exp(-m_tau / ue);
        for (int j = 0; j < n; ++j) {
            const double k = m_k[j], ej = m_e[j];
            const double alpha = -std::expm1(-(k + 1.0 / ue) * m_tau) / (1.0 + k * ue);
            // beta = (e^(-k tau) - e^(-tau/u)) / (1 - k u), removable at k u = 1.
            const double beta_j = exp_difference(k, 1.0 / ue, m_tau) / ue;
            // (alpha - beta) / k, exactly [phi (1 + E) - u (1 + e) (1 - E)] / (1 - k^2 u^2) away from k u = 1.
            const double diff_over_k =
                std::abs(1.0 - k * ue) > 0.5
                    ? (m_phi[j] * (1.0 + big_e) - ue * (1.0 + ej) * (1.0 - big_e)) / (1.0 - k * k * ue * ue)
                    : (alpha - beta_j) / k;
            const double s = sigma(e, j), r = rho(e, j);
            c.plus(e, j) = s * (alpha + beta_j) + k * k * r * diff_over_k;
            c.minus(e, j) = s * diff_over_k + r * (alpha + beta_j);
        }
    }
    return c;
}

SlabRows SlabOrder::rows(std::span<const double> beta, std::span<const double> u) const {
    PhasePair pu;
    const RowCoefficients c = row_coefficients(beta, u, pu);
    const Matrix a = c.plus * m_cp_inv, b = c.minus * m_cm_inv;
    SlabRows out{0.5 * (a + b), 0.5 * (a - b)};
    std::vector<double> inv_q(m_mu.size());
    for (std::size_t j = 0; j < m_mu.size(); ++j) inv_q[j] = 1.0 / (2.0 * m_w[j] * m_mu[j]);
    scale_columns(out.r, inv_q);
    scale_columns(out.t, inv_q);
    return out;
}

SlabOrder::Beams SlabOrder::beams(std::span<const double> beta, std::span<const double> u_in) const {
    const int n = static_cast<int>(m_mu.size());
    const int ne = static_cast<int>(u_in.size());
    // A beam whose 1/u0 equals a decay rate makes the particular solution resonant (its secular
    // term t e^(-t/u0)); such a cosine is moved by a relative 1e-9, far below any tolerance.
    std::vector<double> u0(u_in.begin(), u_in.end());
    for (double& c : u0) {
        if (!(c > 0.0 && c <= 1.0)) throw InputError(cat("slab: cosine must be in (0, 1] (got ", c, ")"));
        for (double k : m_k)
            if (std::abs(k * k * c * c - 1.0) < 1e-9) c *= 1.0 - 2e-9;
    }
    // Beam sources at the streams: up J+ = (w / 4u0) p(-mu_i, u0), down J- = (w / 4u0) p(mu_i, u0).
    const PhasePair pb = phase_components(beta, m_m, m_mu, u0); // N x E
    Matrix j_sum(n, ne), j_dif(n, ne);
    for (int i = 0; i < n; ++i)
        for (int b = 0; b < ne; ++b) {
            const double f = 0.25 * m_omega / u0[b];
            j_sum(i, b) = f * (pb.minus(i, b) + pb.plus(i, b));
            j_dif(i, b) = f * (pb.minus(i, b) - pb.plus(i, b));
        }
    // [(A + B) - M (A - B)^-1 M / u0^2] Sigma = (J+ + J-) - M (A - B)^-1 (J+ - J-) / u0, solved in the
    // eigenbasis: Sigma = S diag(1 / (k^2 - 1/u0^2)) G rhs; Delta = (A - B)^-1 [(J+ - J-) - M Sigma / u0].
    const Matrix abj = m_a_minus_b_inv * j_dif;
    Matrix rhs = j_sum;
    for (int i = 0; i < n; ++i)
        for (int b = 0; b < ne; ++b) rhs(i, b) -= m_mu[i] * abj(i, b) / u0[b];
    Matrix g = m_beam_projector * rhs;
    for (int j = 0; j < n; ++j)
        for (int b = 0; b < ne; ++b) g(j, b) /= m_k[j] * m_k[j] - 1.0 / (u0[b] * u0[b]);
    const Matrix sigma = m_s * g;
    Matrix t = j_dif;
    for (int i = 0; i < n; ++i)
        for (int b = 0; b < ne; ++b) t(i, b) -= m_mu[i] * sigma(i, b) / u0[b];
    const Matrix delta = m_a_minus_b_inv * t;
    Matrix z_up(n, ne), z_down(n, ne), f_sum(n, ne), f_dif(n, ne);
    for (int i = 0; i < n; ++i)
        for (int b = 0; b < ne; ++b) {
            z_up(i, b) = 0.5 * (sigma(i, b) + delta(i, b));
            z_down(i, b) = 0.5 * (sigma(i, b) - delta(i, b));
            // Diffuse field vanishing on entry: I-(0) = 0, I+(tau) = 0: f1 = -Z-, f2 = -Z+ e^(-tau/u0).
            const double e0 = std::exp(-m_tau / u0[b]);
            const double f1 = -z_down(i, b), f2 = -z_up(i, b) * e0;
            f_sum(i, b) = f1 + f2;
            f_dif(i, b) = f1 - f2;
        }
    const Matrix cs = m_cp_inv * f_sum, cd = m_cm_inv * f_dif; // c + d and k (c - d)

    Beams out;
    // At the streams: I+(0) = Z+ + (Rp (c + d) + Rm k (c - d)) / 2 and I-(tau) = Z- e0 + (Rp (c + d) - Rm k (c - d)) / 2,
    // with Rp, Rm recovered from the slab's own operators: Rp Cp^-1 = R_op + T_op, Rm Cm^-1 = R_op - T_op.
    {
        Matrix r_op = m_r, t_op = m_t; // back to intensity operators
        std::vector<double> q(static_cast<std::size_t>(n));
        for (int j = 0; j < n; ++j) q[j] = 2.0 * m_w[j] * m_mu[j];
        scale_columns(r_op, q);
        scale_columns(t_op, q);
        const Matrix p = r_op + t_op, qq = r_op - t_op;
        const Matrix ps = p * f_sum, qd = qq * f_dif;
        out.r_columns = Matrix(n, ne);
        out.t_columns = Matrix(n, ne);
        for (int i = 0; i < n; ++i)
            for (int b = 0; b < ne; ++b) {
                const double e0 = std::exp(-m_tau / u0[b]);
                out.r_columns(i, b) = z_up(i, b) + 0.5 * (ps(i, b) + qd(i, b));
                out.t_columns(i, b) = z_down(i, b) * e0 + 0.5 * (ps(i, b) - qd(i, b));
            }
    }
    // Off the streams: the homogeneous part through the row coefficients, plus the particular
    // field's and the beam's own single scattering, integrated along u_a.
    PhasePair pu;
    const RowCoefficients c = row_coefficients(beta, u_in, pu); // rows at u_a = the same cosines
    const Matrix ha = c.plus * cs, hb = c.minus * cd;
    // Particular field's source at u_a: (w/2) [p(u, mu) W Z+ + p(-u, mu) W Z-] (up) and the mirror (down).
    Matrix pw_plus = pu.plus, pw_minus = pu.minus; // E x N
    scale_columns(pw_plus, m_w);
    scale_columns(pw_minus, m_w);
    const Matrix up = pw_plus * z_up + pw_minus * z_down;
    const Matrix down = pw_minus * z_up + pw_plus * z_down;
    const PhasePair pab = phase_components(beta, m_m, u_in, u0); // p(+-u_a, u0_b)
    out.block.r = Matrix(ne, ne);
    out.block.t = Matrix(ne, ne);
    for (int a = 0; a < ne; ++a) {
        const double ua = u_in[a];
        for (int b = 0; b < ne; ++b) {
            const double ub = u0[b];
            // int_0^tau e^(-t/u0) e^(-t/u) dt/u and int_0^tau e^(-t/u0) e^(-(tau - t)/u) dt/u.
            const double to_top = ub / (ua + ub) * -std::expm1(-m_tau * (1.0 / ua + 1.0 / ub));
            const double to_bottom = exp_difference(1.0 / ua, 1.0 / ub, m_tau) / ua;
            const double f = 0.25 * m_omega / ub;
            out.block.r(a, b) = 0.5 * (ha(a, b) + hb(a, b)) +
                                (0.5 * m_omega * up(a, b) + f * pab.minus(a, b)) * to_top;
            out.block.t(a, b) = 0.5 * (ha(a, b) - hb(a, b)) +
                                (0.5 * m_omega * down(a, b) + f * pab.plus(a, b)) * to_bottom;
        }
    }
    return out;
}

} // namespace brdf::rte
