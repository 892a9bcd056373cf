#include <brdf/mie/size_distribution.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <cmath>
#include <functional>
#include <numbers>

namespace brdf::mie {
namespace {

constexpr double pi = std::numbers::pi;
constexpr double min_v_eff = 1e-6; // narrower distributions: use monodisperse

// The checks of parameter_problems as the constructors use them: one InputError listing them all.
void check(DistributionKind kind, double p1, double p2) {
    const std::vector<ParameterProblem> problems = parameter_problems(kind, p1, p2);
    if (problems.empty()) return;
    std::string text;
    for (const ParameterProblem& p : problems) text += (text.empty() ? "" : "; ") + p.text();
    throw InputError(cat(to_string(kind), ": ", text));
}

// Bisection for an increasing function with f(lo) < 0 < f(hi): 200 halvings reach the resolution of
// a double from any bracket, and the cost is irrelevant next to one Mie evaluation. Robustness
// matters more than speed here (the brackets below are proven, not guessed).
double bisect(const std::function<double(double)>& f, double lo, double hi) {
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi) break;
        (f(mid) < 0.0 ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// Regularised incomplete gamma functions P(a, t) = gamma(a, t) / Gamma(a) and Q = 1 - P, each
// computed where it is small without cancellation: the series (Abramowitz and Stegun 6.5.29) for
// t < a + 1, the continued fraction for Gamma(a, t) (A&S 6.5.31) by the modified Lentz method
// otherwise (as in Press et al., Numerical Recipes, 3rd ed., section 6.2).
double log_prefactor(double a, double t) { return -t + a * std::log(t) - std::lgamma(a); }

double gamma_p_series(double a, double t) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 1000000; ++n) {
        term *= t / (a + n);
        sum += term;
        if (term < sum * 1e-17) break;
    }
    return sum * std::exp(log_prefactor(a, t));
}

double gamma_q_fraction(double a, double t) {
    constexpr double tiny = 1e-300;
    double b = t + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
    for (int i = 1; i < 1000000; ++i) {
        const double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (std::abs(d) < tiny) d = tiny;
        c = b + an / c;
        if (std::abs(c) < tiny) c = tiny;
        d = 1.0 / d;
        const double delta = d * c;
        h *= delta;
        if (std::abs(delta - 1.0) < 1e-16) break;
    }
    return std::exp(log_prefactor(a, t)) * h;
}

double gamma_p(double a, double t) {
    if (t <= 0.0) return 0.0;
    return t < a + 1.0 ? gamma_p_series(a, t) : 1.0 - gamma_q_fraction(a, t);
}

double gamma_q(double a, double t) {
    if (t <= 0.0) return 1.0;
    return t < a + 1.0 ? 1.0 - gamma_p_series(a, t) : gamma_q_fraction(a, t);
}

} // namespace

const char* to_string(DistributionKind kind) {
    switch (kind) {
    case DistributionKind::Monodisperse: return "monodisperse";
    case DistributionKind::PowerLaw: return "power_law";
    case DistributionKind::Gamma: return "gamma";
    case DistributionKind::Lognormal: return "lognormal";
    }
    return "unknown";
}

const char* parameter1_key(DistributionKind kind) {
    switch (kind) {
    case DistributionKind::Monodisperse: return "radius_um";
    case DistributionKind::PowerLaw:
    case DistributionKind::Gamma: return "r_eff_um";
    case DistributionKind::Lognormal: return "r_g_um";
    }
    return "";
}

const char* parameter2_key(DistributionKind kind) {
    switch (kind) {
    case DistributionKind::Monodisperse: return "";
    case DistributionKind::PowerLaw:
    case DistributionKind::Gamma: return "v_eff";
    case DistributionKind::Lognormal: return "sigma_g";
    }
    return "";
}

std::vector<ParameterProblem> parameter_problems(DistributionKind kind, double p1, double p2) {
    std::vector<ParameterProblem> out;
    const auto fail = [&](const char* key, std::string fault, double got) {
        out.push_back({key, cat(fault, " (got ", got, ")")});
    };
    // The radius (radius_um, r_eff_um, r_g_um): a length, so finite and > 0.
    if (!std::isfinite(p1))
        fail(parameter1_key(kind), "must be a finite number > 0", p1);
    else if (!(p1 > 0.0))
        fail(parameter1_key(kind), "must be > 0", p1);
    const char* key2 = parameter2_key(kind);
    switch (kind) {
    case DistributionKind::Monodisperse: break;
    case DistributionKind::PowerLaw:
        // Beyond v_eff = 2 the smallest radius falls below 1.5% of r_eff (header).
        if (!(std::isfinite(p2) && p2 >= min_v_eff && p2 <= 2.0))
            fail(key2, cat("must be in [", min_v_eff, ", 2]"), p2);
        break;
    case DistributionKind::Gamma:
        if (!(std::isfinite(p2) && p2 >= min_v_eff && p2 < 0.5))
            fail(key2,
                 cat("must be in [", min_v_eff,
                     ", 0.5) for the gamma distribution (it is not normalisable at 0.5)"),
                 p2);
        break;
    case DistributionKind::Lognormal:
        if (!(std::isfinite(p2) && p2 > 1.0 && p2 <= 3.0)) {
            fail(key2, "must be in (1, 3]", p2);
        } else if (const double s = std::log(p2); std::expm1(s * s) < min_v_eff) {
            // v_eff = exp(ln^2 sigma_g) - 1 (H&T): too narrow to integrate as a distribution.
            fail(key2,
                 cat("is narrower than v_eff = ", min_v_eff,
                     " (sigma_g >= 1.001); use monodisperse"),
                 p2);
        }
        break;
    }
    return out;
}

double SizeDistribution::number_density(double r) const {
    if (!(r > 0.0)) return 0.0;
    switch (m_kind) {
    case DistributionKind::Monodisperse: return 0.0;
    case DistributionKind::PowerLaw:
        return (r < m_r_min || r > m_r_max) ? 0.0 : m_c0 / (r * r * r);
    case DistributionKind::Gamma: return std::exp(m_c0 + m_c1 * std::log(r) - r / m_c2);
    case DistributionKind::Lognormal: {
        const double u = (std::log(r) - m_c0) / m_c1;
        return m_c2 / r * std::exp(-0.5 * u * u);
    }
    }
    return 0.0;
}

std::string SizeDistribution::describe() const {
    switch (m_kind) {
    case DistributionKind::Monodisperse: return cat("monodisperse(radius = ", m_p1, " um)");
    case DistributionKind::PowerLaw:
        return cat("power_law(r_eff = ", m_p1, " um, v_eff = ", m_p2, ")");
    case DistributionKind::Gamma: return cat("gamma(r_eff = ", m_p1, " um, v_eff = ", m_p2, ")");
    case DistributionKind::Lognormal:
        return cat("lognormal(r_g = ", m_p1, " um, sigma_g = ", m_p2, ")");
    }
    return "unknown";
}

SizeDistribution monodisperse(double radius_um) {
    check(DistributionKind::Monodisperse, radius_um, 0.0);
    SizeDistribution d;
    d.m_kind = DistributionKind::Monodisperse;
    d.m_p1 = radius_um;
    d.m_r_min = d.m_r_max = radius_um;
    d.m_r_eff = radius_um;
    d.m_v_eff = 0.0;
    d.m_mean_volume = 4.0 / 3.0 * pi * radius_um * radius_um * radius_um;
    d.m_mean_area = pi * radius_um * radius_um;
    return d;
}

SizeDistribution power_law(double r_eff_um, double v_eff) {
    check(DistributionKind::PowerLaw, r_eff_um, v_eff);
    // r1 + r2 = S and (r2 - r1) / ln(r2 / r1) = r_eff. As r1 goes from 0 to S/2 the left side grows
    // monotonically from 0 to S/2 = r_eff (1 + v_eff) > r_eff, so the root is bracketed. For
    // v_eff <= 2 the root lies above 1e-12 S (there the left side is S / ln(1e12) < r_eff).
    const double sum = 2.0 * r_eff_um * (1.0 + v_eff);
    const auto f = [&](double r1) {
        const double width = sum - 2.0 * r1; // r2 - r1, without forming r2 first
        return width / std::log1p(width / r1) - r_eff_um;
    };
    const double r1 = bisect(f, 1e-12 * sum, 0.5 * sum);
    const double r2 = sum - r1;
    SizeDistribution d;
    d.m_kind = DistributionKind::PowerLaw;
    d.m_p1 = r_eff_um;
    d.m_p2 = v_eff;
    d.m_r_min = r1;
    d.m_r_max = r2;
    d.m_r_eff = r_eff_um;
    d.m_v_eff = v_eff;
    // n = C r^-3 with int_{r1}^{r2} n dr = 1: C = 2 / (r1^-2 - r2^-2).
    const double c = 2.0 * r1 * r1 * r2 * r2 / ((r2 - r1) * (r2 + r1));
    d.m_c0 = c;
    d.m_mean_volume = 4.0 / 3.0 * pi * c * (r2 - r1);
    d.m_mean_area = pi * c * std::log(r2 / r1);
    return d;
}

SizeDistribution gamma(double r_eff_um, double v_eff) {
    check(DistributionKind::Gamma, r_eff_um, v_eff);
    const double b = v_eff;
    const double alpha = (1.0 - 3.0 * b) / b; // > -1
    const double scale = r_eff_um * b;        // a b
    SizeDistribution d;
    d.m_kind = DistributionKind::Gamma;
    d.m_p1 = r_eff_um;
    d.m_p2 = v_eff;
    d.m_r_eff = r_eff_um;
    d.m_v_eff = v_eff;
    d.m_c0 = -std::lgamma(alpha + 1.0) - (alpha + 1.0) * std::log(scale);
    d.m_c1 = alpha;
    d.m_c2 = scale;
    // <r^k> = scale^k Gamma(alpha + 1 + k) / Gamma(alpha + 1).
    d.m_mean_volume = 4.0 / 3.0 * pi * scale * scale * scale * (alpha + 1.0) * (alpha + 2.0) *
                      (alpha + 3.0);
    d.m_mean_area = pi * scale * scale * (alpha + 1.0) * (alpha + 2.0);
    // r^k n(r) is a gamma density of shape alpha + 1 + k in r / scale. Cut the r^2-weighted one
    // (shape 1/b) below and the r^3-weighted one (shape 1/b + 1) above at tail_fraction each.
    const double shape2 = alpha + 3.0, shape3 = alpha + 4.0;
    const double t_min = std::exp(bisect(
        [&](double log_t) { return gamma_p(shape2, std::exp(log_t)) - tail_fraction; },
        std::log(1e-12 * shape2), std::log(shape2)));
    const double t_max = bisect([&](double t) { return tail_fraction - gamma_q(shape3, t); },
                                shape3, shape3 + 60.0 * std::sqrt(shape3) + 100.0);
    d.m_r_min = scale * t_min;
    d.m_r_max = scale * t_max;
    return d;
}

SizeDistribution lognormal(double r_g_um, double sigma_g) {
    check(DistributionKind::Lognormal, r_g_um, sigma_g);
    const double s = std::log(sigma_g);
    SizeDistribution d;
    d.m_kind = DistributionKind::Lognormal;
    d.m_p1 = r_g_um;
    d.m_p2 = sigma_g;
    d.m_r_eff = r_g_um * std::exp(2.5 * s * s);
    d.m_v_eff = std::expm1(s * s);
    d.m_c0 = std::log(r_g_um);
    d.m_c1 = s;
    d.m_c2 = 1.0 / (std::sqrt(2.0 * pi) * s);
    // <r^k> = r_g^k exp(k^2 s^2 / 2).
    d.m_mean_volume = 4.0 / 3.0 * pi * std::pow(r_g_um, 3) * std::exp(4.5 * s * s);
    d.m_mean_area = pi * r_g_um * r_g_um * std::exp(2.0 * s * s);
    // r^k n(r) is a normal density in ln r with mean ln r_g + k s^2 and deviation s. z solves
    // Phi(-z) = erfc(z / sqrt 2) / 2 = tail_fraction (z = 5.73).
    const double z =
        bisect([](double t) { return tail_fraction - 0.5 * std::erfc(t / std::sqrt(2.0)); }, 0.0,
               40.0);
    d.m_r_min = r_g_um * std::exp(2.0 * s * s - z * s);
    d.m_r_max = r_g_um * std::exp(3.0 * s * s + z * s);
    return d;
}

} // namespace brdf::mie
