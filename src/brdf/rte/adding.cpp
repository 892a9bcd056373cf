#include <brdf/rte/adding.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>

namespace brdf::rte {
namespace {

std::vector<double> weights_q(const Streams& s) {
    std::vector<double> q(static_cast<std::size_t>(s.size()));
    for (int k = 0; k < s.size(); ++k) q[k] = 2.0 * s.w[k] * s.mu[k];
    return q;
}

// m(i, j) *= d[j]
Matrix scale_cols(Matrix m, std::span<const double> d) {
    for (int i = 0; i < m.rows(); ++i)
        for (int j = 0; j < m.cols(); ++j) m(i, j) *= d[j];
    return m;
}

// m(i, j) *= d[i]
Matrix scale_rows(Matrix m, std::span<const double> d) {
    for (int i = 0; i < m.rows(); ++i)
        for (int j = 0; j < m.cols(); ++j) m(i, j) *= d[i];
    return m;
}

void check_sizes(const Reflector& r, int n, int e, const char* what) {
    if (r.nn.rows() != n || r.nn.cols() != n || r.en.rows() != e || r.en.cols() != n || r.ee.rows() != e ||
        r.ee.cols() != e || static_cast<int>(r.spec.size()) != e)
        throw InputError(cat(what, ": reflector sizes do not match ", n, " streams and ", e, " directions"));
}

} // namespace

double fresnel(double mu_1, double n_1, double n_2) {
    const double ratio = n_1 / n_2;
    const double sin2 = ratio * ratio * (1.0 - mu_1 * mu_1);
    if (sin2 >= 1.0) return 1.0;
    const double mu_2 = std::sqrt(1.0 - sin2);
    const double rs = (n_1 * mu_1 - n_2 * mu_2) / (n_1 * mu_1 + n_2 * mu_2);
    const double rp = (n_2 * mu_1 - n_1 * mu_2) / (n_2 * mu_1 + n_1 * mu_2);
    return 0.5 * (rs * rs + rp * rp);
}

Reflector add_layer(const LayerOperators& l, const Reflector& b, const Streams& streams) {
    const int n = streams.size();
    const int e = static_cast<int>(l.t_e.size());
    check_sizes(b, n, e, "add_layer");
    const std::vector<double> q = weights_q(streams);
    const bool specular_below = std::any_of(b.spec.begin(), b.spec.end(), [](double s) { return s != 0.0; });
    if (specular_below && (l.t_ee.rows() != e || l.t_ee.cols() != e))
        throw InputError("add_layer: a specular reflector below needs the layer's off-stream transmission block");

    // Light between the layer and the reflector: u (up-going at the streams) solves
    // (I - B Q R_L Q) u = source; W = (I - B Q R_L Q)^-1.
    const Matrix bq = scale_cols(b.nn, q);
    const Matrix rlq = scale_cols(l.r_nn, q);
    const Matrix w = inverse(Matrix::identity(n) - bq * rlq);
    const Matrix tlq_en = scale_cols(l.t_en, q), rlq_en = scale_cols(l.r_en, q), bq_en = scale_cols(b.en, q);

    Reflector out;
    // Light from the streams above: u_n = W B Q T_L, d_n = T_L + R_L Q u_n (down-going below the layer).
    const Matrix u_n = w * (bq * l.t_nn);
    const Matrix d_n = l.t_nn + rlq * u_n;
    out.nn = l.r_nn + scale_cols(l.t_nn, q) * u_n;
    // Towards direction e: the layer's own rows, its diffuse transmission of u_n, and the direct
    // transmission of what rises at e below it: B's smooth field and B's specular reflection of the
    // layer's down-going diffuse radiance at e.
    {
        Matrix below_e = bq_en * d_n; // B_en Q d_n
        if (specular_below) below_e += scale_rows(l.t_en + rlq_en * u_n, b.spec);
        out.en = l.r_en + tlq_en * u_n + scale_rows(std::move(below_e), l.t_e);
    }
    // A collimated beam from e' above: it crosses the layer directly (t_e'), B reflects it diffusely
    // and specularly (c_up = spec t_e', which rises collimated through the layer again).
    std::vector<double> c_up(static_cast<std::size_t>(e));
    for (int k = 0; k < e; ++k) c_up[k] = b.spec[k] * l.t_e[k];
    const Matrix r_ne = transpose(l.r_en), t_ne = transpose(l.t_en), b_ne = transpose(b.en);
    Matrix down_diffuse = t_ne; // the layer's diffuse transmission of the beam, plus its reflection of c_up
    if (specular_below) down_diffuse += scale_cols(r_ne, c_up);
    const Matrix u_e = w * (bq * down_diffuse + scale_cols(b_ne, l.t_e));
    const Matrix d_e = down_diffuse + rlq * u_e;
    Matrix below_e = bq_en * d_e + scale_cols(b.ee, l.t_e); // what rises at e below the layer, smooth
    if (specular_below) {
        Matrix down_at_e = rlq_en * u_e + l.t_ee + scale_cols(l.r_ee, c_up);
        below_e += scale_rows(std::move(down_at_e), b.spec);
    }
    out.ee = l.r_ee + tlq_en * u_e + scale_rows(std::move(below_e), l.t_e);
    if (specular_below) out.ee += scale_cols(l.t_ee, c_up);
    out.spec.resize(static_cast<std::size_t>(e));
    for (int k = 0; k < e; ++k) out.spec[k] = l.t_e[k] * l.t_e[k] * b.spec[k];
    return out;
}

namespace {

// g = diag(q F) on the lower streams: internal reflection of the up-going field.
std::vector<double> internal_reflection(const SmoothInterface& f, const Streams& lower) {
    const std::vector<double> q = weights_q(lower);
    std::vector<double> g(q.size());
    for (std::size_t k = 0; k < q.size(); ++k) g[k] = q[k] * f.f_below[k];
    return g;
}

} // namespace

Matrix bounce_inverse(const SmoothInterface& f, const Matrix& below_nn, const Streams& lower) {
    const int n = lower.size();
    if (below_nn.rows() != n || below_nn.cols() != n || static_cast<int>(f.f_below.size()) != n)
        throw InputError(
            "bounce_inverse: the reflector, the interface and the streams do not match");
    return inverse(Matrix::identity(n) - scale_cols(below_nn, internal_reflection(f, lower)));
}

namespace {

// bounce_under_interface with W = (I - B g)^-1 given, or (null) computed here.
Reflector bounced(const SmoothInterface& f, const Reflector& b, const Streams& lower,
                  const Matrix* given) {
    const int n = lower.size();
    const int e = static_cast<int>(f.f_e.size());
    check_sizes(b, n, e, "add_interface");
    const Matrix computed = given ? Matrix() : bounce_inverse(f, b.nn, lower);
    const Matrix& w = given ? *given : computed;
    if (w.rows() != n || w.cols() != n || static_cast<int>(f.f_below.size()) != n)
        throw InputError(
            "add_interface: the bounce inverse or the interface does not match the streams");
    const std::vector<double> g = internal_reflection(f, lower);
    Reflector z;
    z.nn = w * b.nn;
    // Radiance at an off-stream direction bounces between the interface and B's specular part:
    // a_e = 1 / (1 - F_e spec_e), on the way in and on the way out.
    std::vector<double> a(static_cast<std::size_t>(e));
    for (int k = 0; k < e; ++k) a[k] = 1.0 / (1.0 - f.f_e[k] * b.spec[k]);
    const Matrix y = b.en + scale_cols(b.en, g) * z.nn; // B_en (I - g B)^-1
    z.en = scale_rows(y, a);
    z.ee = scale_cols(scale_rows(b.ee + scale_cols(b.en, g) * multiply_transposed(w, b.en), a), a);
    z.spec.resize(static_cast<std::size_t>(e));
    for (int k = 0; k < e; ++k) z.spec[k] = b.spec[k] * a[k];
    return z;
}

// add_interface with the bounce inverse given, or (null) computed by bounced().
Reflector with_interface(const SmoothInterface& f, const Reflector& b, const Streams& above,
                         const Streams& lower, const Matrix* given) {
    const int n1 = above.size();
    const int e = static_cast<int>(f.f_e.size());
    if (static_cast<int>(f.below_of.size()) != n1 || static_cast<int>(f.f_above.size()) != n1 ||
        static_cast<int>(f.f_below.size()) != lower.size())
        throw InputError("add_interface: the interface's stream maps do not match the streams");
    const Reflector z = bounced(f, b, lower, given);
    const double ratio2 = (f.n_above / f.n_below) * (f.n_above / f.n_below);
    Reflector out;
    out.nn = Matrix(n1, n1);
    out.en = Matrix(e, n1);
    for (int k = 0; k < n1; ++k) {
        out.nn(k, k) = f.f_above[k] / (2.0 * above.w[k] * above.mu[k]);
        const int kb = f.below_of[k];
        if (kb < 0) continue;
        const double tk = 1.0 - f.f_above[k];
        for (int j = 0; j < n1; ++j) {
            const int jb = f.below_of[j];
            if (jb >= 0) out.nn(k, j) += tk * (1.0 - f.f_above[j]) * ratio2 * z.nn(kb, jb);
        }
        for (int x = 0; x < e; ++x) out.en(x, k) = (1.0 - f.f_e[x]) * tk * ratio2 * z.en(x, kb);
    }
    out.ee = Matrix(e, e);
    out.spec.resize(static_cast<std::size_t>(e));
    for (int x = 0; x < e; ++x) {
        const double tx = 1.0 - f.f_e[x];
        for (int y = 0; y < e; ++y) out.ee(x, y) = tx * (1.0 - f.f_e[y]) * ratio2 * z.ee(x, y);
        out.spec[x] = f.f_e[x] + tx * tx * z.spec[x];
    }
    return out;
}

} // namespace

Reflector bounce_under_interface(const SmoothInterface& f, const Reflector& b,
                                 const Streams& lower) {
    return bounced(f, b, lower, nullptr);
}

Reflector bounce_under_interface(const SmoothInterface& f, const Reflector& b, const Streams& lower,
                                 const Matrix& w) {
    return bounced(f, b, lower, &w);
}

Reflector add_interface(const SmoothInterface& f, const Reflector& b, const Streams& above,
                        const Streams& lower) {
    return with_interface(f, b, above, lower, nullptr);
}

Reflector add_interface(const SmoothInterface& f, const Reflector& b, const Streams& above,
                        const Streams& lower, const Matrix& w) {
    return with_interface(f, b, above, lower, &w);
}

} // namespace brdf::rte
