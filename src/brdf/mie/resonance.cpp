#include <brdf/mie/resonance.h>

#include <brdf/mie/recurrence.h>

#include <cmath>
#include <numbers>

namespace brdf::mie {
namespace {

using detail::Complex;

// chi_{n-1}(x) / chi_n(x) by the upward ratio recurrence c_k = 1 / ((2k-1)/x - c_{k-1}),
// c_0 = chi_{-1}/chi_0 = -tan x. The upward direction is the stable one for chi (dominant for k > x);
// a zero of chi_k below x turns into inf and then 0 in IEEE arithmetic and the recurrence goes on
// correctly. Also accumulates log |chi_n| and the sign of chi_n.
struct ChiRatio {
    double c = 0.0;          ///< chi_{n-1} / chi_n
    double log_abs = 0.0;    ///< log |chi_n|
    double sign = 1.0;       ///< sign of chi_n
};

ChiRatio chi_ratio(double x, int n) {
    ChiRatio r;
    double c = -std::tan(x);
    r.log_abs = std::log(std::abs(std::cos(x)));
    r.sign = std::cos(x) < 0.0 ? -1.0 : 1.0;
    for (int k = 1; k <= n; ++k) {
        c = 1.0 / ((2.0 * k - 1.0) / x - c);
        r.log_abs -= std::log(std::abs(c));
        if (c < 0.0) r.sign = -r.sign;
    }
    r.c = c;
    return r;
}

// log |psi_n(x)|, its sign and r_n = psi_{n-1}(x) / psi_n(x) from the downward ratios.
struct PsiValue {
    double ratio = 0.0;
    double log_abs = 0.0;
    double sign = 1.0;
};

PsiValue psi_value(double x, int n) {
    std::vector<double> e; // a call costs n logarithms: its allocation is nothing beside them
    detail::shifted_log_derivatives(x, n, detail::start_index(n, x), e);
    PsiValue p;
    const double s = std::sin(x);
    p.log_abs = std::log(std::abs(s));
    p.sign = s < 0.0 ? -1.0 : 1.0;
    for (int k = 1; k <= n; ++k) {
        const double r = (2.0 * k + 1.0) / x + e[k];
        p.log_abs -= std::log(std::abs(r));
        if (r < 0.0) p.sign = -p.sign;
        p.ratio = r;
    }
    return p;
}

struct ModeEval {
    double f = 0.0;  ///< F(x)
    double df = 0.0; ///< F'(x)
    double zz = 0.0; ///< z_a or z_b
    double chi_ratio = 0.0;
};

// F and F' at x (no logarithms: this runs in the Newton loop).
ModeEval evaluate(double m, int n, bool electric, double x) {
    const double z = m * x;
    const double d = detail::shifted_log_derivative(z, n) + (n + 1.0) / z; // D_n(mx)
    double c = -std::tan(x);                                                // chi_{k-1} / chi_k
    for (int k = 1; k <= n; ++k) c = 1.0 / ((2.0 * k - 1.0) / x - c);
    ModeEval out;
    out.zz = electric ? d / m + n / x : m * d + n / x;
    out.chi_ratio = c;
    out.f = out.zz - c;
    // Riccati equations: D_n'(z) = n(n+1)/z^2 - 1 - D_n^2, (chi_{n-1}/chi_n)' = -1 - c^2 + 2cn/x.
    const double dd = n * (n + 1.0) / (z * z) - 1.0 - d * d;
    const double dc = -1.0 - c * c + 2.0 * c * n / x;
    out.df = (electric ? dd : m * m * dd) - n / (x * x) - dc;
    return out;
}

// Half width at a root of F: T = B / A = chi_n F / (psi_n (zz - r_n)), so T' = chi_n F' / (psi_n
// (zz - r_n)) and the half width at half maximum of |a_n|^2 = 1 / (1 + T^2) is 1 / |T'|.
double half_width(double x, int n, const ModeEval& at) {
    const PsiValue psi = psi_value(x, n);
    const ChiRatio chi = chi_ratio(x, n);
    return std::exp(psi.log_abs - chi.log_abs) * std::abs(at.zz - psi.ratio) / std::abs(at.df);
}

} // namespace

void sample_modes(double m, double x, int n_max, ModeSample& out) {
    out.x = x;
    out.n_max = n_max;
    out.zeros.assign(n_max + 1, 0);
    out.positive.assign(n_max + 1, 0);
    const double z = m * x;
    std::vector<double> e; // beside out's own two
    detail::shifted_log_derivatives(z, n_max, detail::start_index(n_max, z), e);
    int zeros = static_cast<int>(std::floor(z / std::numbers::pi));
    out.zeros[0] = zeros;
    double c = -std::tan(x); // chi_{k-1} / chi_k, see chi_ratio
    for (int k = 1; k <= n_max; ++k) {
        if ((2.0 * k + 1.0) / z + e[k] < 0.0) --zeros; // psi_{k-1}(z) and psi_k(z) differ in sign
        out.zeros[k] = zeros;
        c = 1.0 / ((2.0 * k - 1.0) / x - c);
        const double d = e[k] + (k + 1.0) / z;
        const double fa = d / m + k / x - c;
        const double fb = m * d + k / x - c;
        out.positive[k] = static_cast<signed char>((fa > 0.0 ? 1 : 0) | (fb > 0.0 ? 2 : 0));
    }
}

bool countable(double m, int n, double x1, double x2) {
    const double nu = n + 0.5;
    return x1 < x2 && x2 < nu && m * x2 > nu;
}

int count_resonances(const ModeSample& a, const ModeSample& b, int n, bool electric) {
    const int bit = electric ? 1 : 2;
    return b.zeros[n] - a.zeros[n] + ((a.positive[n] & bit) ? 1 : 0) -
           ((b.positive[n] & bit) ? 1 : 0);
}

std::optional<Resonance> locate_resonance(double m, int n, bool electric, double x1, double x2) {
    // Safeguarded Newton on F, which decreases through its root: the bracket [lo, hi] keeps
    // F(lo) > 0 > F(hi); a Newton step that leaves it is replaced by bisection. Newton converges
    // quadratically, so iterating to the rounding level of x costs one or two more evaluations and
    // needs no width estimate.
    const auto found = [&](double root, const ModeEval& at) -> std::optional<Resonance> {
        const double hwhm = half_width(root, n, at);
        if (!std::isfinite(hwhm) || !(hwhm > 0.0)) return std::nullopt;
        return Resonance{n, electric, root, hwhm};
    };
    double lo = x1, hi = x2, x = 0.5 * (x1 + x2);
    for (int iter = 0; iter < 300; ++iter) {
        const ModeEval ev = evaluate(m, n, electric, x);
        if (!std::isfinite(ev.f)) return std::nullopt;
        if (ev.f == 0.0) return found(x, ev);
        (ev.f > 0.0 ? lo : hi) = x;
        const double resolution = 4e-16 * x;
        if (hi - lo <= resolution) {
            const double mid = 0.5 * (lo + hi);
            return found(mid, evaluate(m, n, electric, mid));
        }
        const double newton = x - ev.f / ev.df;
        if (ev.df < 0.0 && std::abs(newton - x) <= resolution) {
            // Converged, unless F' is huge (a pole of D_n just outside the bracket): x counts as
            // the root only if F changes sign across it. F's rounding error (~1e-14, the
            // difference of two O(1) terms) can exceed F' times two ulps of x, so where two miss
            // the change, 64 are tried. Either way the root is Newton's x, accurate to F's
            // rounding error over F'. Bisecting on from here would halve the bracket's far side
            // down to the rounding level: ~25 evaluations for a root already found.
            for (const double ulps : {2.0, 64.0}) {
                const double d = ulps * resolution;
                if (evaluate(m, n, electric, x - d).f > 0.0 && evaluate(m, n, electric, x + d).f < 0.0)
                    return found(x, ev);
            }
            x = 0.5 * (lo + hi);
            continue;
        }
        x = (ev.df < 0.0 && newton > lo && newton < hi) ? newton : 0.5 * (lo + hi);
    }
    return std::nullopt;
}

double resonance_damping(Complex m, const Resonance& r) {
    if (m.imag() == 0.0) return 0.0;
    const double x = r.x;
    const int n = r.n;
    const Complex z = m * x;
    const Complex d = detail::shifted_log_derivative(z, n) + (n + 1.0) / z;
    const Complex zz = r.electric ? d / m + n / x : m * d + n / x;
    const ChiRatio chi = chi_ratio(x, n);
    const PsiValue psi = psi_value(x, n);
    // T = (zz chi_n - chi_{n-1}) / (zz psi_n - psi_{n-1}) = (chi_n / psi_n) (zz - c_n) / (zz - r_n).
    const double scale = chi.sign * psi.sign * std::exp(chi.log_abs - psi.log_abs);
    return scale * detail::divide(zz - chi.c, zz - psi.ratio).imag();
}

} // namespace brdf::mie
