// Size-distribution averages of Mie results.
//
// The radius integral, in size parameter x = k r (k = 2 pi n_h / lambda), is
//   <C> = int n(r) pi r^2 Q(x) dr = int w(x) Q(x) dx,   w(x) = n(x/k) pi (x/k)^2 / k,
// with n normalised over the untruncated distribution (size_distribution.h), so the means are per
// particle. Large spheres without sharp resonances take the nested rule further down
// (integrate_nested); everything else the panels, where three ingredients make it accurate and cheap:
//
// 1. Sharp resonances first. For Re m > 1 the coefficients a_n, b_n with x < n + 1/2 < m x have
//    resonances of half width down to 1e-12 in x (at m = 2, x < 24: about 20 per decade of width
//    between 1e-6 and 1e-3, measured). Their contributions to <Csca> scale with their width: for a
//    broad power law of rutile, widths ~1e-4 still contribute 1e-5 relative, widths ~1e-5 1e-6. A
//    sampled rule sees such a peak only when a node happens to land on it, so neither adaptive
//    bisection nor uniform refinement converges (uniform panels down to 4e-4 in x, 274000 nodes, still
//    moved <Cext> by 4e-7: measured). resonance.h counts the resonances of every order between sample
//    points 0.25 apart and just below every n + 1/2 exactly and locates each one (|a_n| = 1 to 1e-10) with its half width gamma
//    (damped for absorbing spheres; for k/n >= 1e-2 the damping makes them broad and this step is
//    skipped). Each gets a window [x_r - c, x_r + c] integrated in u = asinh((x - x_r) / gamma),
//    which turns the Lorentzian gamma dx / (gamma^2 + (x - x_r)^2) into sech(u) du, smooth on the
//    scale of 1; the dispersive tails gamma / (x - x_r) of the cross terms (g, the phase function)
//    become constants, and the smooth background only picks up the factor gamma cosh(u). Windows
//    are carved broadest first: from the plain panels (whose remainder, if short, is merged into the
//    neighbour) or from a broader resonance's window (whose pieces keep their grading); see
//    carve_windows for the sizes and rules. Resonances whose whole contribution is provably below
//    1e-3 of the budget (the tolerance times <Csca>, or times <Cabs> for a weakly absorbing sphere)
//    are skipped without being located: their half width is bounded above by the Debye tunnelling
//    factor psi_n / chi_n ~ exp(-2 nu (alpha - tanh alpha)) / 2, cosh alpha = nu / x, times 6 times
//    the measured ratio. Of the located ones the smallest are skipped too while the skipped
//    contributions sum to less than 0.1 of the budget, but each becomes a panel end: a node within a
//    few widths of the peak would count it over the node's whole weight, far more than its true
//    contribution. The error bounds of skipped resonances and of small trusted rules are booked
//    against the tolerance.
//
// 2. Adaptive Gauss-Kronrod panels on everything else. Initial panels are at most 2 wide in x (the
//    interference and ripple structure of Q has periods of order 1: pi / (m - 1) and, for the ripple,
//    about arctan(sqrt(m^2-1)) / sqrt(m^2-1) = 0.6 at m = 2, Chylek 1990, J. Opt. Soc. Am. A 7, 1609;
//    the adaptive rule notices it), at most x/2 (below x ~ 2 the Rayleigh growth Q ~ x^4 is smooth in
//    ln x) and at most x s/2 where s is the relative width of the distribution (sqrt(v_eff) for the
//    gamma, ln sigma_g for the log-normal), so that a narrow distribution is resolved. Every panel
//    (plain in x, or a window piece in u) that is not a trusted small rule is integrated by the
//    15-point Kronrod rule with QUADPACK's error estimate from the embedded 7-point Gauss rule
//    (qk15, Piessens et al. 1983). Panels are bisected in their own coordinate, worst first
//    (QUADPACK's QAG strategy), until the summed estimates of <Cext>, <Csca>, <Cabs> (each relative
//    to itself) and <Csca g> (relative to <Csca>) plus the booked bounds are below 0.8 of the
//    tolerance. A panel whose estimate is explained by the small tail (<= 1e-3 of the budget) of a
//    located resonance next to it is not bisected (that would chase the tail forever); the tail's
//    content is counted as its error instead. The broad resonances above their barrier tops
//    (x > n + 1/2) and everything that is not a sharp peak are resolved here.
//
// The intensities of every evaluation go into its panel's own partial sums; the accepted panels'
// sums are added at the end (the few evaluations in panels that were bisected are wasted). Measured
// (tests/mie/ensemble_test.cpp, docs/mie.md): doubling every panel's points changes <Cext>, <Csca>, g
// and the Legendre moments by < 1e-7 for the benchmark pigment at 1e-6 tolerance, all 41 wavelengths.
//
// 3. One angular rule. The intensities |S1|^2 + |S2|^2 of every node are accumulated with the number
//    weights on the Gauss rule of the largest sphere and projected onto Legendre polynomials once
//    (phase_function.h); the efficiencies come from the same coefficients.

#include <brdf/mie/ensemble.h>

#include <brdf/core/error.h>
#include <brdf/core/legendre.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>
#include <brdf/mie/kronrod.h>
#include <brdf/mie/phase_function.h>
#include <brdf/mie/resonance.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <functional>
#include <memory>
#include <numbers>
#include <string>

namespace brdf::mie {
namespace {

using Complex = std::complex<double>;
constexpr double pi = std::numbers::pi;

using detail::gauss_w;
using detail::kronrod_w;
using detail::kronrod_x;
constexpr int kronrod = 15; // Panel::rule value for the verified Gauss-Kronrod rule

struct Sums {
    double ext = 0.0, sca = 0.0, abs = 0.0, back = 0.0, gsca = 0.0;
    Sums& operator+=(const Sums& o) {
        ext += o.ext, sca += o.sca, abs += o.abs, back += o.back, gsca += o.gsca;
        return *this;
    }
    Sums scaled(double w) const { return {w * ext, w * sca, w * abs, w * back, w * gsca}; }
};

/// A panel [a, b], integrated in x, or for a window in u = asinh((x - focus) / scale).
struct Panel {
    double a = 0.0, b = 0.0;
    bool mapped = false;
    double focus = 0.0, scale = 1.0;
    int rule = kronrod; ///< kronrod (adaptive), or the size of a trusted Gauss-Legendre rule
    double lo() const { return mapped ? std::asinh((a - focus) / scale) : a; }
    double hi() const { return mapped ? std::asinh((b - focus) / scale) : b; }
    /// Node in x and its weight factor dx/ds at the panel coordinate s.
    double x_at(double s) const { return mapped ? focus + scale * std::sinh(s) : s; }
    double jacobian(double s) const { return mapped ? scale * std::cosh(s) : 1.0; }
    /// The sub-panel between panel coordinates s0 < s1.
    Panel piece(double s0, double s1) const {
        Panel p = *this;
        p.a = s0 == lo() ? a : x_at(s0);
        p.b = s1 == hi() ? b : x_at(s1);
        return p;
    }
};

/// Nodes (x) and weights (in x) of a panel's rule, `refinement` pieces in its own coordinate.
void panel_nodes(const Panel& p, int refinement, std::vector<double>& x, std::vector<double>& w) {
    x.clear();
    w.clear();
    const double lo = p.lo(), hi = p.hi();
    for (int part = 0; part < refinement; ++part) {
        const double s0 = lo + (hi - lo) * part / refinement;
        const double s1 = lo + (hi - lo) * (part + 1) / refinement;
        const double mid = 0.5 * (s0 + s1), half = 0.5 * (s1 - s0);
        const auto add = [&](double t, double weight) {
            const double s = mid + half * t;
            x.push_back(p.x_at(s));
            w.push_back(half * weight * p.jacobian(s));
        };
        if (p.rule == kronrod) {
            for (int i = 0; i < 7; ++i) {
                add(-kronrod_x[i], kronrod_w[i]);
                add(kronrod_x[i], kronrod_w[i]);
            }
            add(0.0, kronrod_w[7]);
        } else {
            const auto rule = gauss_legendre(p.rule);
            for (std::size_t i = 0; i < rule->size(); ++i) add(rule->x[i], rule->w[i]);
        }
    }
}

class Integrand {
public:
    Integrand(Complex m, double k, const SizeDistribution& sizes) : m_m(m), m_k(k), m_sizes(sizes) {}

    /// Number density per unit x times the geometric cross section: w(x) in the header comment.
    double weight(double x) const {
        const double r = x / m_k;
        return m_sizes.number_density(r) / m_k * pi * r * r;
    }
    /// Number density per unit x: the weight of the intensities (|S1|^2 + |S2|^2 integrates to
    /// x^2 Qsca = k^2 Csca / pi, so these weights make the average sum C_sca p / sum C_sca).
    double density(double x) const { return m_sizes.number_density(x / m_k) / m_k; }

    /// w(x) Q(x); leaves the coefficients in last_coefficients().
    Sums at(double x) {
        coefficients(m_m, x, m_coef, m_series);
        ++m_evaluations;
        return weighted(m_coef);
    }
    /// at(x[i]) for every i, the coefficients into `c` (the same size), all computed at once
    /// (mie.h: a real index runs eight spheres side by side), the same bits as at() one by one.
    void at(std::span<const double> x, std::span<Coefficients> c, std::span<Sums> out) {
        m_efficiencies.resize(x.size());
        coefficients(m_m, x, c, m_efficiencies, m_series);
        m_evaluations += static_cast<long>(x.size());
        for (std::size_t i = 0; i < x.size(); ++i) out[i] = weighted(x[i], m_efficiencies[i]);
    }

    const Coefficients& last_coefficients() const { return m_coef; }
    long evaluations() const { return m_evaluations; }

    /// integrate()'s working storage, reused from panel to panel (mie.h, SeriesWork, says why not
    /// thread_local): a rule's nodes and weights, a panel's 15 spheres, the intensity sums' terms.
    struct PanelWork {
        std::vector<double> x, w, accumulate;
        std::vector<Coefficients> coefficients = std::vector<Coefficients>(15);
        std::vector<Sums> sums;
    };
    PanelWork& panel_work() { return m_panel; }

private:
    Sums weighted(const Coefficients& c) const { return weighted(c.x, efficiencies(c)); }
    Sums weighted(double x, const Efficiencies& q) const {
        const double w = weight(x);
        return {w * q.qext, w * q.qsca, w * q.qabs, w * q.qback, w * q.qsca * q.g};
    }

    Complex m_m;
    double m_k;
    const SizeDistribution& m_sizes;
    Coefficients m_coef;
    SeriesWork m_series;
    std::vector<Efficiencies> m_efficiencies; ///< at()'s, for the spheres of one call
    PanelWork m_panel;
    long m_evaluations = 0;
};

/// A panel with its integral and error estimate (|K15 - G7| per quantity; 0 for trusted rules,
/// whose error is booked separately).
struct Leaf {
    Panel panel;
    Sums value;
    Sums error;
    std::vector<double> plus, minus; ///< its share of the accumulated intensities I(+-mu_j)
    /// Share of <Csca> in this panel from the Lorentzian tails of located resonances outside it
    /// (already booked): an error estimate below twice this is the tails', not the panel's.
    double tails = 0.0;
};

/// Integrates over a panel; the intensities go into the leaf's own partial sums (most evaluations
/// end up in the final rule, so they are not repeated; the few in panels that get split are wasted).
/// For the Kronrod rule, when the 15- and the embedded 7-point results of <Csca> and <Csca g> agree to
/// 1e-3 of the tolerance relative to the panel's <Csca>, the 7-point Gauss rule is accurate enough for
/// the intensities too and only its nodes are accumulated: the intensities cost more than the
/// coefficients, and most panels are that well resolved. The phase function's error is then at most
/// 1e-3 of the tolerance relative to <Csca>, so beta_1 / 3 and g stay consistent to that.
Leaf integrate(Integrand& f, const Panel& p, const PhaseFunctionAccumulator& phase, double tol) {
    Leaf leaf{p, {}, {}, std::vector<double>(phase.pairs(), 0.0),
              std::vector<double>(phase.pairs(), 0.0), 0.0};
    const double lo = p.lo(), hi = p.hi();
    const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
    Integrand::PanelWork& work = f.panel_work();
    if (p.rule != kronrod) {
        std::vector<double>& x = work.x;
        std::vector<double>& w = work.w;
        panel_nodes(p, 1, x, w);
        if (work.coefficients.size() < x.size()) work.coefficients.resize(x.size());
        work.sums.resize(x.size());
        const std::span<Coefficients> c(work.coefficients.data(), x.size());
        f.at(x, c, work.sums);
        for (std::size_t i = 0; i < x.size(); ++i) {
            leaf.value += work.sums[i].scaled(w[i]);
            phase.accumulate(c[i], w[i] * f.density(x[i]), leaf.plus.data(), leaf.minus.data(), work.accumulate);
        }
        return leaf;
    }
    // QUADPACK's qk15 error estimate: with resasc = int |f - mean| (by the Kronrod rule),
    // err = resasc min(1, (200 |K15 - G7| / resasc)^(3/2)). The 3/2 power encodes that the Kronrod
    // result converges much faster than the Gauss one whose error |K15 - G7| measures.
    struct Node {
        Sums value;      // w(x) Q(x) dx/dt
        double kronrod;  // Kronrod weight
        double gauss;    // Gauss weight, 0 for a Kronrod-only node
        double density;  // n(x) dx/dt
    };
    // The fifteen nodes' spheres first, then their coefficients at once (mie.h).
    Node nodes[15];
    double xs[15], jacobians[15];
    int count = 0;
    const auto term = [&](double t, double kw, double gw) {
        const double s = mid + half * t;
        xs[count] = p.x_at(s);
        jacobians[count] = half * p.jacobian(s);
        nodes[count] = {{}, kw, gw, f.density(xs[count]) * jacobians[count]};
        ++count;
    };
    for (int i = 0; i < 7; ++i) {
        const double gw = i % 2 == 1 ? gauss_w[i / 2] : 0.0;
        term(-kronrod_x[i], kronrod_w[i], gw);
        term(kronrod_x[i], kronrod_w[i], gw);
    }
    term(0.0, kronrod_w[7], gauss_w[3]);
    if (work.coefficients.size() < 15) work.coefficients.resize(15);
    const std::span<Coefficients> coefficients(work.coefficients.data(), 15);
    Sums values[15];
    f.at(xs, coefficients, values);
    for (int i = 0; i < count; ++i) nodes[i].value = values[i].scaled(jacobians[i]);
    Sums gauss;
    for (const Node& n : nodes) {
        leaf.value += n.value.scaled(n.kronrod);
        gauss += n.value.scaled(n.gauss);
    }
    const auto estimate = [&](double Sums::*q) {
        const double mean = leaf.value.*q / 2.0; // the integrand's mean over t in [-1, 1]
        double resasc = 0.0;
        for (const Node& n : nodes) resasc += n.kronrod * std::abs(n.value.*q - mean);
        const double diff = std::abs(leaf.value.*q - gauss.*q);
        if (resasc == 0.0 || diff == 0.0) return diff;
        return resasc * std::min(1.0, std::pow(200.0 * diff / resasc, 1.5));
    };
    leaf.error = {estimate(&Sums::ext), estimate(&Sums::sca), estimate(&Sums::abs), 0.0,
                  estimate(&Sums::gsca)};
    const double allowed = 1e-3 * tol * std::abs(leaf.value.sca);
    const bool gauss_enough = std::abs(leaf.value.sca - gauss.sca) <= allowed &&
                              std::abs(leaf.value.gsca - gauss.gsca) <= allowed;
    for (int i = 0; i < count; ++i) {
        const double w = gauss_enough ? nodes[i].gauss : nodes[i].kronrod;
        if (w != 0.0)
            phase.accumulate(coefficients[i], w * nodes[i].density, leaf.plus.data(),
                             leaf.minus.data(), work.accumulate);
    }
    return leaf;
}

/// Relative widths of the distribution's cross-section-weighted density, used to size initial
/// panels: sqrt(v_eff) for the gamma distribution (its r^2 n is a gamma density of shape 1/v_eff),
/// ln sigma_g for the log-normal; the power law r^-1 has no scale of its own.
double relative_width(const SizeDistribution& d) {
    switch (d.kind()) {
    case DistributionKind::Gamma: return std::sqrt(d.v_eff());
    case DistributionKind::Lognormal: return std::log(d.parameter2());
    default: return std::numeric_limits<double>::infinity();
    }
}

std::vector<double> initial_breaks(double x_min, double x_max, double rel_width) {
    std::vector<double> breaks{x_min};
    double x = x_min;
    while (x < x_max) {
        const double h = std::min({2.0, 0.5 * x, 0.5 * rel_width * x});
        x = (x_max - x < 1.5 * h) ? x_max : x + h;
        breaks.push_back(x);
    }
    if (breaks.size() == 2 && x_max > x_min) { // at least two panels
        breaks = {x_min, 0.5 * (x_min + x_max), x_max};
    }
    return breaks;
}

/// Upper bound of a resonance's half width for order n at size parameters below x (x < n + 1/2):
/// q (1/2) exp(-2 nu (alpha - tanh alpha)), cosh alpha = nu / x (Debye asymptotics of psi_n / chi_n).
/// The measured ratio q = hwhm / ((1/2) exp(...)) is about 1.6 / sqrt(m^2 - 1) (0.09 .. 2.2 for
/// m = 1.2 .. 3); 10 / sqrt(m^2 - 1) is the bound used.
double hwhm_bound(double m, int n, double x) {
    const double nu = n + 0.5;
    const double alpha = std::acosh(nu / x);
    return 10.0 / std::sqrt(m * m - 1.0) * 0.5 * std::exp(-2.0 * nu * (alpha - std::tanh(alpha)));
}

/// A located resonance and what is done with it.
struct Window {
    double x = 0.0;
    double width = 0.0;        ///< effective half width (damped for absorbing spheres)
    double contribution = 0.0; ///< estimated share of <Csca>, um^2
    bool skipped = false;      ///< not integrated: only a panel end
    double half_width = 0.0;   ///< of its window, 0 if it has none
};

class ResonanceFinder {
public:
    /// `importance` >= 1 scales contributions to <Csca> into units of the budget of the most
    /// demanding quantity (<Cabs> of a weakly absorbing sphere: its resonant absorption is at most
    /// the undamped scattering contribution, and its budget is tol <Cabs>).
    ResonanceFinder(double m_real, const Integrand& f, double budget, double importance)
        : m_m(m_real), m_f(f), m_budget(budget), m_importance(importance) {}

    /// Examines every order countable between consecutive sample points.
    void scan(const std::vector<double>& points) {
        std::vector<ModeSample> samples(points.size());
        for (std::size_t i = 0; i < points.size(); ++i)
            sample_modes(m_m, points[i], series_length(points[i]), samples[i]);
        for (std::size_t i = 0; i + 1 < points.size(); ++i) {
            const double x1 = points[i], x2 = points[i + 1];
            const int n_lo = std::max(1, static_cast<int>(std::floor(x2)));
            const int n_hi = std::min(samples[i].n_max, samples[i + 1].n_max);
            const double w_max = 2.0 * std::max({m_f.weight(x1), m_f.weight(x2),
                                                 m_f.weight(0.5 * (x1 + x2))});
            for (int n = n_lo; n <= n_hi; ++n) {
                if (!countable(m_m, n, x1, x2)) continue;
                for (const bool electric : {true, false}) {
                    const int count = count_resonances(samples[i], samples[i + 1], n, electric);
                    if (count <= 0) continue;
                    // Provably negligible: skip without locating (see the header comment).
                    const double bound = count * pi * hwhm_bound(m_m, n, x2) * 2.0 *
                                         (2.0 * n + 1.0) / (x1 * x1) * w_max * m_importance;
                    if (bound < 1e-3 * m_budget && m_skipped + bound < 0.1 * m_budget) {
                        m_skipped += bound;
                        continue;
                    }
                    isolate(n, electric, x1, x2, 0);
                }
            }
        }
    }

    const std::vector<Resonance>& found() const { return m_found; }
    double skipped() const { return m_skipped; }

private:
    void isolate(int n, bool electric, double x1, double x2, int depth) {
        ModeSample a, b;
        sample_modes(m_m, x1, n, a);
        sample_modes(m_m, x2, n, b);
        const int count = count_resonances(a, b, n, electric);
        if (count <= 0) return;
        if (count == 1 && a.zeros[n] == b.zeros[n]) {
            if (auto r = locate_resonance(m_m, n, electric, x1, x2)) m_found.push_back(*r);
            return;
        }
        if (depth > 60) return; // interval at rounding level: nothing more to separate
        const double mid = 0.5 * (x1 + x2);
        isolate(n, electric, x1, mid, depth + 1);
        isolate(n, electric, mid, x2, depth + 1);
    }

    double m_m;
    const Integrand& m_f;
    double m_budget; ///< tolerance * <Csca>
    double m_importance;
    double m_skipped = 0.0;
    std::vector<Resonance> m_found;
};

/// Whether two panels are pieces of one (plain, or graded onto the same focus with the same scale).
bool same_family(const Panel& p, const Panel& q) {
    return p.mapped == q.mapped && (!p.mapped || (p.focus == q.focus && p.scale == q.scale));
}

/// Carves the windows of `resonances` into `panels` (sorted, contiguous), broadest first. Returns
/// the number of windows and adds the error bounds of trusted rules and of the tails left outside
/// the windows to `booked`.
///
/// Sizes: a resonance at least a quarter as wide as the local scale of the panel it falls in (the
/// panel's length, or for a window the distance to its focus, at least its width) is resolved by
/// that panel and left alone. Otherwise the window's half width c makes the Lorentzian tail beyond
/// it, a fraction ~gamma / (pi c) of the contribution E, at most 1e-3 of the budget, with c >= 8 gamma
/// (8% of E), but c <= a quarter of the local scale (so that whatever the panel resolved varies
/// slowly across the window), relaxed to half of it when that is needed to fit 4 widths, and limited
/// the same way by every other window it would overlap. The window cuts through whatever panels it
/// overlaps; their remainders keep their own grading, and a remainder shorter than half its panel is
/// merged into the neighbour of the same family beyond it.
///
/// Pieces and rules: the core |u| <= 2 holds 96% of the Lorentzian, pieces at most 8 long in u
/// continue outward (over them cosh u, the Jacobian that multiplies the smooth background, changes by
/// e^4 either side of the centre, which 8 Gauss points integrate to 3e-9, and the tail sech u ~
/// 2 exp(-u) is smooth). A piece longer than 0.05 in x gets the adaptive rule: it may hold whatever
/// the plain panels resolved, which a trusted rule built for one Lorentzian would not (every resonance
/// below its barrier top n + 1/2 is located, the broad ones above it are > 0.1 wide; 0.05 is
/// measured: the benchmark pigment's results then move by < 1e-7 when the resolution doubles, 1e-7
/// at 0.1). Shorter ones get trusted rules,
/// chosen by the contribution E: for E below 1e-2 of the budget a single piece with 2 points (sech u
/// over +-asinh(8) to 30%); otherwise the core with 4 points below 0.1 of the budget (sech u over
/// [-2, 2] to 3e-3), 8 points below 1e3 budgets (1e-5), 12 points below 1e5 budgets (3e-8), the
/// adaptive rule above; the outer pieces with 8 points (1e-8 of their share of the Lorentzian), or 4
/// (1e-4) where they are tiny. The trusted rules' bounds are booked.
int carve_windows(std::vector<Window>& resonances, std::vector<Panel>& panels, double budget,
                  double tol, double x_min, double x_max, double& booked) {
    // Background over an x extent of 10 tol (x_max - x_min) integrated to 1e-4 is 1e-3 of the
    // budget of a background spread evenly over the range.
    const double small_extent = 10.0 * tol * (x_max - x_min);
    std::sort(resonances.begin(), resonances.end(),
              [](const Window& p, const Window& q) { return p.width > q.width; });
    const auto length = [](const Panel& p) { return p.hi() - p.lo(); }; // in its own coordinate
    int carved = 0;
    for (Window& w : resonances) {
        auto it = std::upper_bound(panels.begin(), panels.end(), w.x,
                                   [](double x, const Panel& p) { return x < p.a; });
        if (it == panels.begin()) continue;
        --it;
        const Panel p = *it;
        if (!(w.x > p.a && w.x < p.b)) continue;
        if (w.skipped) { // a panel end at the peak
            Panel left = p, right = p;
            left.b = right.a = w.x;
            *it = left;
            panels.insert(it + 1, right);
            continue;
        }
        const double local = p.mapped ? std::hypot(p.scale, w.x - p.focus) : p.b - p.a;
        if (w.width >= 0.25 * local) continue; // resolved by the panel it is in
        // A large contribution of a resonance not much narrower than its panel: the adaptive
        // panels resolve its tails cheaply, so its window stops at 64 widths (1% of it left
        // outside).
        const bool broad = w.contribution >= 1e3 * budget && w.width >= 2e-3 * local;
        const double wanted =
            w.width * (broad ? 64.0 : std::max(8.0, w.contribution / (pi * 1e-3 * budget)));
        double c = std::min(wanted, 0.25 * local);
        if (c < 4.0 * w.width) c = std::min(4.0 * w.width, 0.5 * local);
        c = std::min({c, w.x - x_min, x_max - w.x});
        // Nor may it reach far into another window: every window it overlaps limits it as if the
        // resonance sat in that window.
        auto first = it, last = it;
        for (;;) {
            bool changed = false;
            while (first->a > w.x - c && first != panels.begin()) --first;
            while (last->b < w.x + c && last + 1 != panels.end()) ++last;
            for (auto q = first; q != last + 1; ++q) {
                if (!q->mapped || q == it) continue;
                const double limit = 0.25 * std::hypot(q->scale, w.x - q->focus);
                if (c > limit) c = limit, changed = true;
            }
            if (!changed) break;
            while (first != it && first->b <= w.x - c) ++first;
            while (last != it && last->a >= w.x + c) --last;
        }
        if (!(c > 0.0)) continue;
        w.half_width = c;
        Panel left = *first, right = *last;
        left.b = w.x - c;
        right.a = w.x + c;
        const Panel window{w.x - c, w.x + c, true, w.x, w.width, kronrod};
        std::vector<Panel> pieces;
        if (left.b > left.a) {
            if (first != panels.begin() && same_family(*(first - 1), left) &&
                length(left) < 0.5 * length(*first))
                (first - 1)->b = left.b; // a short remainder joins its neighbour
            else
                pieces.push_back(left);
        }
        // The window's pieces in u: the core |u| <= 2 (96% of the Lorentzian), then pieces at most
        // 8 long outward.
        const double ratio = w.contribution / budget;
        const double u_lo = window.lo(), u_hi = window.hi();
        std::vector<double> cuts;
        if (u_lo < -2.0) {
            const int outer = static_cast<int>(std::ceil((-2.0 - u_lo) / 8.0));
            for (int i = 0; i < outer; ++i) cuts.push_back(u_lo + (-2.0 - u_lo) * i / outer);
        }
        cuts.push_back(std::max(u_lo, -2.0));
        if (u_hi > 2.0) {
            const int outer = static_cast<int>(std::ceil((u_hi - 2.0) / 8.0));
            for (int i = 0; i < outer; ++i) cuts.push_back(2.0 + (u_hi - 2.0) * i / outer);
        }
        cuts.push_back(u_hi);
        if (ratio < 1e-2 && u_hi - u_lo <= 6.0) cuts = {u_lo, u_hi}; // one small piece
        for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
            Panel piece = window.piece(cuts[i], cuts[i + 1]);
            const bool core = cuts[i] < 0.0 && cuts[i + 1] > 0.0;
            const double extent = piece.b - piece.a;
            const double share = std::abs(std::atan(std::sinh(cuts[i + 1])) -
                                          std::atan(std::sinh(cuts[i]))) / pi;
            if (extent > 0.05 || (core && ratio >= 1e5)) {
                // Long in x: it may hold whatever the plain panels resolved, so the adaptive rule
                // checks it.
                piece.rule = kronrod;
            } else if (core) {
                piece.rule = ratio < 1e-2 ? 2 : ratio < 0.1 ? 4 : ratio < 1e3 ? 8 : 12;
                booked += w.contribution * (ratio < 1e-2  ? 0.3
                                            : ratio < 0.1 ? 3e-3
                                            : ratio < 1e3 ? 1e-5
                                                          : 3e-8);
            } else {
                // Mostly background and the Lorentzian's share (gd(u1) - gd(u0)) / pi with
                // gd(u) = atan(sinh u): 8 points (1e-8 of it), or 4 (1e-4) where the piece is tiny.
                piece.rule = extent <= small_extent ? 4 : 8;
                booked += w.contribution * share * (piece.rule == 4 ? 1e-4 : 1e-8);
            }
            pieces.push_back(piece);
        }
        bool merge_right = false;
        if (right.b > right.a) {
            if (last + 1 != panels.end() && same_family(*(last + 1), right) &&
                length(right) < 0.5 * length(*last))
                merge_right = true;
            else
                pieces.push_back(right);
        }
        auto at = panels.erase(first, last + 1);
        at = panels.insert(at, pieces.begin(), pieces.end());
        if (merge_right) (at + static_cast<long>(pieces.size()))->a = right.a;
        ++carved;
    }
    return carved;
}

// ---- The nested rule: large spheres without sharp resonances ------------------------------------
//
// Where no resonance is sharp (Re m <= 1: no internal reflection; or k/n >= 1e-2: damped), the
// integrand is smooth in ln x on the scale of the distribution, but the angular work of one radius
// grows as N x_max (N ~ x terms on an angular rule of 2 x_max nodes): 5 ms at x ~ 1500 on the rule
// of x_max ~ 4000. The averaged quantities are what must be accurate, not each sphere, so the rule
// is chosen for them:
// - In t = ln x the weight w(x) x of a gamma or log-normal distribution decays at both ends of
//   [x_min, x_max] (tails of 5e-9, size_distribution.h), so the trapezoid rule converges
//   geometrically (exponentially in 1/h for an integrand analytic in a strip; Trefethen and
//   Weideman 2014, SIAM Rev. 56, 385, section 5). For the power law the density does not vanish at
//   r1, r2; the tanh-sinh map t = c + d tanh((pi/2) sinh s) (Takahasi and Mori 1974) makes the
//   integrand in s decay double exponentially, and the trapezoid rule in s converges the same way.
// - Halving the step keeps every node (nested): T(h) = T(2h)/2 + h sum_new f. The difference
//   d(h) = |T(h) - T(2h)| of each averaged quantity (<Cext>, <Csca>, <Cabs> relative, g and every
//   chi_l = beta_l/(2l+1) absolute) measures the error of T(2h); with geometric convergence the
//   error of T(h) is about r d(h), r = d(h)/d(2h). The estimate used is max(r, 1/4) d(h) (never
//   assume more than a factor 4 per halving), and d(h) itself until the differences decrease.
//   Measured (docs/mie.md, tests/mie/nested_rule_test.cpp): 0.9 to 25 times the true error.
// - The features that need the most nodes are in the moments near l = 2x (each sphere's moments
//   fall from ~1e-2 to 0 over l ~ 2x +- 4 x^(1/3)): 65-130 nodes at r_eff = 5 um, 250-500 at 40 um.
//   Cross sections converge with far fewer.
// - A node whose share density of <Csca> (per unit of the rule's variable, which spans 1) is below
//   1e-4 tol (the far tails) gets its cross sections but not its intensities: at most 1e-4 tol of
//   <Csca> in all, booked (a missing share s moves every chi_l by at most 2 s). The angular rule is
//   sized for the largest node that may need intensities, bounded with 1.5 times the largest Qsca
//   seen on the first level.

/// Reports progress as the estimated error falls from its first value towards the target, on a
/// log scale (the work grows about that way), never backwards and below 1 until the end.
class Progress {
public:
    explicit Progress(const std::function<void(double)>& callback) : m_callback(callback) {}
    void error(double estimate, double target) {
        if (!m_callback || !(estimate > 0.0) || !std::isfinite(estimate)) return;
        if (m_first == 0.0) m_first = std::max(estimate, 10.0 * target);
        const double f = std::log(m_first / estimate) / std::log(m_first / target);
        report(std::clamp(0.05 + 0.9 * f, 0.0, 0.95));
    }
    void report(double fraction) {
        if (!m_callback || fraction < m_last) return;
        m_last = fraction;
        m_callback(fraction);
    }

private:
    const std::function<void(double)>& m_callback;
    double m_first = 0.0, m_last = -1.0;
};

/// t = ln x as a function of the rule's variable s, and dt/ds.
struct NestedMap {
    bool tanh_sinh = false;
    double c = 0.0, d = 1.0; ///< line: t = s; tanh-sinh: t = c + d tanh((pi/2) sinh s)
    double s_lo = 0.0, s_hi = 0.0;
    double t(double s) const { return tanh_sinh ? c + d * std::tanh(0.5 * pi * std::sinh(s)) : s; }
    double dt_ds(double s) const {
        if (!tanh_sinh) return 1.0;
        const double ch = std::cosh(0.5 * pi * std::sinh(s));
        return d * 0.5 * pi * std::cosh(s) / (ch * ch);
    }
};

/// Accumulated intensities of the nested rule on up to three angular rules: one for the largest
/// series, and halves and quarters of it for the smaller spheres. A sphere of N terms needs a rule
/// of N + 1 node pairs only (phase_function.h), and its intensities cost N per pair, so with one
/// rule for all the many small spheres would cost as much per pair as the largest: measured, the
/// groups save a third of the angular work at r_eff = 40 um. The moments of the groups are combined
/// with their integrals as weights (beta_l = sum_g I_g beta_l^g / sum_g I_g).
class GroupedIntensities {
public:
    explicit GroupedIntensities(int max_terms) {
        for (int n = max_terms; m_rules.size() < 3; n = (n + 1) / 2) {
            m_rules.push_back(std::make_unique<PhaseFunctionAccumulator>(n));
            m_sums.push_back({std::vector<double>(m_rules.back()->pairs(), 0.0),
                              std::vector<double>(m_rules.back()->pairs(), 0.0)});
            if (n < 128) break; // small rules cost little; no point in more
        }
    }
    struct Sums2 {
        std::vector<double> plus, minus;
    };
    using State = std::vector<Sums2>;

    void add(const Coefficients& c, double weight) {
        std::size_t g = 0;
        while (g + 1 < m_rules.size() && m_rules[g + 1]->max_terms() >= c.size()) ++g;
        m_rules[g]->accumulate(c, weight, m_sums[g].plus.data(), m_sums[g].minus.data(), m_work);
    }
    void scale(double factor) {
        for (Sums2& s : m_sums) {
            for (double& v : s.plus) v *= factor;
            for (double& v : s.minus) v *= factor;
        }
    }
    const State& state() const { return m_sums; }

    /// All moments beta_0 .. (no truncation) of `state` (this object's or an earlier copy); uses
    /// the rules' own sums as scratch.
    std::vector<double> moments(const State& state) {
        std::vector<double> beta;
        double total = 0.0;
        LegendreOptions all;
        all.tolerance = 0.0;
        for (std::size_t g = 0; g < m_rules.size(); ++g) {
            PhaseFunctionAccumulator& rule = *m_rules[g];
            rule.clear();
            rule.add_sums(state[g].plus, state[g].minus);
            const double integral = rule.integral();
            if (!(integral > 0.0)) continue;
            const std::vector<double> b = rule.legendre(all);
            if (beta.size() < b.size()) beta.resize(b.size(), 0.0);
            for (std::size_t l = 0; l < b.size(); ++l) beta[l] += integral * b[l];
            total += integral;
        }
        if (!(total > 0.0))
            throw NumericalError("Mie ensemble: the accumulated phase function integrates to 0");
        for (double& b : beta) b /= total;
        beta[0] = 1.0;
        return beta;
    }

private:
    std::vector<std::unique_ptr<PhaseFunctionAccumulator>> m_rules;
    State m_sums;
    std::vector<double> m_work; ///< accumulate()'s working storage
};

/// Truncates moments as LegendreOptions says (the same rule as PhaseFunctionAccumulator::legendre).
std::vector<double> truncated(std::vector<double> beta, const LegendreOptions& options) {
    if (options.max_terms > 0 && beta.size() > static_cast<std::size_t>(options.max_terms))
        beta.resize(static_cast<std::size_t>(options.max_terms));
    std::size_t keep = beta.size();
    while (keep > 1 && !(std::abs(beta[keep - 1]) > options.tolerance)) --keep;
    beta.resize(keep);
    return beta;
}

struct NestedResult {
    Sums total;
    std::vector<double> legendre;
    int nodes = 0;
    double error_estimate = 0.0;
};

/// Relative change of each cross section (g absolute), the largest.
double cross_section_change(const Sums& now, const Sums& before, bool absorbing) {
    double d = 0.0;
    const auto rel = [](double a, double b) {
        return b != 0.0 ? std::abs(a / b - 1.0) : std::abs(a - b);
    };
    d = std::max(d, rel(now.sca + now.abs, before.sca + before.abs));
    d = std::max(d, rel(now.sca, before.sca));
    if (absorbing) d = std::max(d, rel(now.abs, before.abs));
    if (now.sca > 0.0 && before.sca > 0.0)
        d = std::max(d, std::abs(now.gsca / now.sca - before.gsca / before.sca));
    return d;
}

/// Error estimate of the finer of two levels from their difference d and the previous difference.
double nested_estimate(double d, double d_before) {
    if (!(d_before > 0.0) || !(d < d_before)) return d; // not yet converging geometrically
    return std::max(0.25, d / d_before) * d;
}

NestedResult integrate_nested(Complex m, double k, const SizeDistribution& sizes, double x_min,
                              double x_max, const EnsembleOptions& options) {
    const double tol = options.tolerance;
    const bool absorbing = m.imag() > 0.0;
    Integrand f(m, k, sizes);
    NestedMap map;
    const double t_min = std::log(x_min), t_max = std::log(x_max);
    Sums tails;        // the trimmed tails' cross sections (line map), um^2
    int intervals = 0; // level 0
    if (sizes.kind() == DistributionKind::PowerLaw) {
        map.tanh_sinh = true;
        map.c = 0.5 * (t_min + t_max);
        map.d = 0.5 * (t_max - t_min);
        // At |s| = 3 the map's weight d (pi/2) cosh s / cosh^2((pi/2) sinh s) is 1e-13 of its value
        // at s = 0.
        map.s_lo = -3.0, map.s_hi = 3.0;
        intervals = 12;
    } else {
        // Trim the far tails: [t_min, t_max] keeps all but 1e-8 of the distribution, but the
        // trapezoid nodes there cost as much as any (the upper tail's the most: N is largest). The
        // rule covers [t_lo, t_hi], outside which a bound of the <Csca> density, w(x) x 1.5 max
        // Qsca (Qsca sampled at nine sizes), holds at most 0.01 tol of its total per side; the
        // tails' cross sections come from 16-point Gauss rules, their intensities are left out
        // (booked).
        double q_max = 0.0;
        for (int j = 0; j <= 8; ++j) {
            const double x = std::exp(t_min + (t_max - t_min) * j / 8.0);
            const double w = f.weight(x);
            if (w > 0.0) q_max = std::max(q_max, f.at(x).sca / w);
        }
        constexpr int grid = 2048;
        std::vector<double> cumulative(grid + 1, 0.0);
        const auto bound = [&](int i) {
            const double x = std::exp(t_min + (t_max - t_min) * i / grid);
            return f.weight(x) * x * 1.5 * q_max;
        };
        for (int i = 1; i <= grid; ++i)
            cumulative[i] =
                cumulative[i - 1] + 0.5 * (bound(i - 1) + bound(i)) * (t_max - t_min) / grid;
        const double allowed = 0.01 * tol * cumulative[grid];
        int i_lo = 0, i_hi = grid;
        while (i_lo + 1 < grid && cumulative[i_lo + 1] <= allowed) ++i_lo;
        while (i_hi - 1 > i_lo + 1 && cumulative[grid] - cumulative[i_hi - 1] <= allowed) --i_hi;
        map.s_lo = t_min + (t_max - t_min) * i_lo / grid;
        map.s_hi = t_min + (t_max - t_min) * i_hi / grid;
        const auto g16 = gauss_legendre(16);
        for (const auto& [a, b] : {std::pair{t_min, map.s_lo}, std::pair{map.s_hi, t_max}}) {
            if (!(b > a)) continue;
            for (std::size_t i = 0; i < g16->size(); ++i) {
                const double t = 0.5 * (a + b) + 0.5 * (b - a) * g16->x[i];
                const double x = std::exp(t);
                tails += f.at(x).scaled(0.5 * (b - a) * g16->w[i] * x);
            }
        }
        intervals = std::max(8, static_cast<int>(std::ceil((map.s_hi - map.s_lo) / 0.25)));
    }
    const auto x_at = [&](double s) {
        return std::exp(map.t(map.s_lo + (map.s_hi - map.s_lo) * s));
    };
    // Node j of level L sits at s = j / (intervals 2^L) in [0, 1] (scaled); its trapezoid weight in
    // x is h dx/ds (halved at the two ends).
    const auto dx_ds = [&](double s) {
        const double u = map.s_lo + (map.s_hi - map.s_lo) * s;
        return std::exp(map.t(u)) * map.dt_ds(u) * (map.s_hi - map.s_lo);
    };

    // Level 0: cross sections only, to size the angular rule.
    struct Node {
        double s, x, weight_density; // weight_density: dx/ds (without the step h)
        Sums value;                  // w(x) Q(x) dx/ds
    };
    std::vector<Node> level0;
    double qsca_max = 0.0;
    for (int j = 0; j <= intervals; ++j) {
        const double s = static_cast<double>(j) / intervals;
        const double x = x_at(s), wd = dx_ds(s);
        const Sums v = f.at(x).scaled(wd);
        const double w = f.weight(x);
        if (w > 0.0) qsca_max = std::max(qsca_max, v.sca / (w * wd));
        level0.push_back({s, x, wd, v});
    }
    Sums total;
    double h = 1.0 / intervals;
    for (const Node& n : level0)
        total += n.value.scaled(h * ((n.s == 0.0 || n.s == 1.0) ? 0.5 : 1.0));
    // A node needs its intensities when its share density of <Csca> (per unit s, relative) may
    // reach skip_density: its contribution h w Q dx/ds is then >= 1e-4 tol of the total at any step
    // h.
    const double skip_density = 1e-4 * tol * total.sca;
    const double q_bound = 1.5 * qsca_max;
    // The largest x whose bound w(x) q_bound dx/ds can exceed that, scanned finely (no Mie needed).
    double x_intensity_max = x_min;
    for (int j = 0; j <= 64 * intervals; ++j) {
        const double s = static_cast<double>(j) / (64 * intervals);
        const double x = x_at(s);
        if (f.weight(x) * q_bound * dx_ds(s) >= skip_density)
            x_intensity_max = std::max(x_intensity_max, x);
    }
    x_intensity_max = std::min(x_max, x_intensity_max * 1.001);
    if (!(options.legendre.tolerance >= 0.0) || options.legendre.max_terms < 0)
        throw InputError("Mie ensemble: Legendre tolerance and max_terms must be >= 0");
    GroupedIntensities intensities(series_length(x_intensity_max));
    double skipped = 0.0; // share of <Csca> without intensities (um^2, at this step)
    Coefficients c;
    SeriesWork work;
    const auto add_intensities = [&](const std::vector<Node>& nodes, double step) {
        for (const Node& n : nodes) {
            const double end = (n.s == 0.0 || n.s == 1.0) ? 0.5 : 1.0;
            // Below skip_density over a range of s of at most 1: at most 1e-4 tol in all.
            if (n.x > x_intensity_max || n.value.sca < skip_density) {
                skipped += step * end * n.value.sca;
                continue;
            }
            coefficients(m, n.x, c, work);
            intensities.add(c, step * end * n.weight_density * f.density(n.x));
        }
    };
    add_intensities(level0, h);
    int nodes = intervals + 1;

    // What the test checks (EnsembleOptions::checked_moments): every moment, or those the caller
    // reads and the phase function's values where it reads them. Measured at 40 um (docs/mie.md):
    // the moments up to 128 and the cross sections settle to 1e-8 at 121 nodes, the moments near
    // l = 2x need 241, and the values beyond 96 degrees change by 3e-5 to 6e-5 at every level.
    const std::size_t moments_checked = options.checked_moments > 0
                                           ? static_cast<std::size_t>(options.checked_moments)
                                           : std::numeric_limits<std::size_t>::max();
    const bool values_checked = options.checked_moments > 0 && options.value_tolerance > 0.0;
    const double theta_min = std::acos(options.checked_cosine); // validated: in [-1, 1]
    std::vector<double> value_cosines; // 64 scattering angles from theta_min to pi
    if (values_checked) {
        for (int i = 0; i < 64; ++i) value_cosines.push_back(std::cos(theta_min + (pi - theta_min) * i / 63.0));
    }
    const auto values_of = [&](const std::vector<double>& beta) {
        std::vector<double> p(value_cosines.size());
        legendre_series(beta, value_cosines, p);
        return p;
    };
    const auto value_change = [](const std::vector<double>& a, const std::vector<double>& b) {
        double d = 0.0;
        for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
        return d;
    };
    const auto moment_change = [](const std::vector<double>& a, const std::vector<double>& b, std::size_t count) {
        double d = 0.0;
        for (std::size_t l = 0; l < std::min(std::max(a.size(), b.size()), count); ++l) {
            const double x = l < a.size() ? a[l] : 0.0, y = l < b.size() ? b[l] : 0.0;
            d = std::max(d, std::abs(x - y) / (2.0 * l + 1.0));
        }
        return d;
    };
    GroupedIntensities::State prev_state;
    Sums prev_total;
    std::vector<double> beta, prev_beta; // projections of this level and the one before (or empty)
    std::vector<double> values, prev_values; // p at value_cosines of this level and the one before
    double d_cross_before = 0.0, d_phase_before = 0.0, d_all_before = 0.0, d_values_before = 0.0;
    double e_values = 0.0;
    double error = std::numeric_limits<double>::infinity();
    Progress progress(options.progress);
    const int extra_levels =
        options.refinement > 1 ? static_cast<int>(std::ceil(std::log2(options.refinement))) : 0;
    int converged_levels = -1; // levels still to add after convergence (refinement studies)
    for (int level = 1;; ++level) {
        const int count = intervals << level; // intervals at this level
        if (count + 1 > options.max_nodes)
            throw LimitError(cat("Mie ensemble: ", count + 1,
                                 " radius nodes needed, more than the limit ", options.max_nodes));
        prev_total = total;
        prev_state = intensities.state();
        prev_beta = std::move(beta);
        beta.clear();
        h = 1.0 / count;
        std::vector<Node> fresh;
        for (int j = 1; j < count; j += 2) {
            const double s = static_cast<double>(j) / count;
            const double x = x_at(s), wd = dx_ds(s);
            fresh.push_back({s, x, wd, f.at(x).scaled(wd)});
        }
        total = total.scaled(0.5);
        for (const Node& n : fresh) total += n.value.scaled(h);
        intensities.scale(0.5);
        skipped *= 0.5;
        add_intensities(fresh, h);
        nodes = count + 1;

        const double d_cross = cross_section_change(total, prev_total, absorbing);
        const double booked = 2.0 * (skipped + tails.sca) / (total.sca + tails.sca);
        // The estimate is pessimistic already (the floor 1/4), so it may use the whole tolerance.
        const double target = tol - booked;
        // One projection per level (12 ms for 8000 moments on 4000 node pairs); a cheaper bound,
        // int |p - p_before| dmu, was 10 to 90 times the largest change of a moment.
        if (prev_beta.empty()) prev_beta = intensities.moments(prev_state);
        beta = intensities.moments(intensities.state());
        const double d_phase = moment_change(beta, prev_beta, moments_checked);
        const double e_cross = level >= 2 ? nested_estimate(d_cross, d_cross_before) : d_cross;
        const double e_phase = level >= 2 ? nested_estimate(d_phase, d_phase_before) : d_phase;
        // Every moment as well where only some are checked: the rule never goes on longer than
        // the full test would (the values' level differences carry the aliased ripple, which need
        // not fall level by level).
        const double d_all = moments_checked < beta.size() || moments_checked < prev_beta.size()
                                 ? moment_change(beta, prev_beta, std::numeric_limits<std::size_t>::max())
                                 : d_phase;
        const double e_all = level >= 2 ? nested_estimate(d_all, d_all_before) : d_all;
        d_cross_before = d_cross;
        d_phase_before = d_phase;
        d_all_before = d_all;
        if (values_checked) {
            prev_values = prev_values.empty() ? values_of(prev_beta) : std::move(values);
            values = values_of(beta);
            const double d_values = value_change(values, prev_values);
            e_values = level >= 2 ? nested_estimate(d_values, d_values_before) : d_values;
            d_values_before = d_values;
        }
        error = std::max(e_cross, e_phase) + booked;
        if (converged_levels < 0) progress.error(error, target);
        const bool read_converged = e_phase <= target && e_values <= options.value_tolerance;
        if (converged_levels < 0 && level >= 2 && e_cross <= target && (read_converged || e_all <= target))
            converged_levels = extra_levels;
        if (converged_levels == 0) break;
        if (converged_levels > 0) --converged_levels;
    }
    NestedResult out;
    out.total = total;
    out.total += tails;
    out.nodes = nodes;
    out.error_estimate = error;
    out.legendre = truncated(std::move(beta), options.legendre);
    log::debug("Mie ensemble (nested rule): ", nodes, " nodes, angular rule for x <= ", x_intensity_max,
               ", estimated error ", error,
               values_checked ? cat(" (", options.checked_moments, " moments; the phase function beyond ",
                                    theta_min * 180.0 / pi,
                                    " degrees: ", e_values, ")")
                              : std::string());
    return out;
}

/// Fills the derived quantities of `out` from the integrated cross sections (um^2).
void finish(Ensemble& out, const Sums& total, std::vector<double> legendre) {
    out.csca_um2 = total.sca;
    out.cabs_um2 = total.abs;
    out.cext_um2 = total.sca + total.abs;
    out.cback_um2 = total.back;
    out.qext = out.cext_um2 / out.mean_area_um2;
    out.qsca = out.csca_um2 / out.mean_area_um2;
    out.qabs = out.cabs_um2 / out.mean_area_um2;
    out.qback = out.cback_um2 / out.mean_area_um2;
    out.g = total.gsca / total.sca;
    out.albedo = total.sca / out.cext_um2;
    out.legendre = std::move(legendre);
}

void validate_inputs(Complex particle_index, double medium_index, double wavelength_nm,
                     const EnsembleOptions& options) {
    if (!std::isfinite(particle_index.real()) || !std::isfinite(particle_index.imag()) ||
        !(particle_index.real() > 0.0) || particle_index.imag() < 0.0)
        throw InputError(cat("Mie ensemble: particle index ", particle_index.real(),
                             particle_index.imag() < 0 ? "" : "+", particle_index.imag(),
                             "i must have a real part > 0 and an absorption (imaginary part) >= 0"));
    if (!std::isfinite(medium_index) || !(medium_index > 0.0))
        throw InputError(cat("Mie ensemble: medium index must be a finite number > 0 (got ",
                             medium_index, ")"));
    if (!std::isfinite(wavelength_nm) || !(wavelength_nm > 0.0))
        throw InputError(cat("Mie ensemble: wavelength must be a finite number > 0 nm (got ",
                             wavelength_nm, ")"));
    if (!(options.tolerance > 0.0 && options.tolerance <= 0.1))
        throw InputError(cat("Mie ensemble: tolerance must be in (0, 0.1] (got ", options.tolerance,
                             ")"));
    if (options.checked_moments < 0 || !(options.checked_cosine >= -1.0 && options.checked_cosine <= 1.0) ||
        !(options.value_tolerance >= 0.0))
        throw InputError(cat("Mie ensemble: checked moments must be >= 0, the checked cosine in [-1, 1] and the value "
                             "tolerance >= 0 (got ", options.checked_moments, ", ", options.checked_cosine, ", ",
                             options.value_tolerance, ")"));
    if (options.refinement < 1)
        throw InputError(cat("Mie ensemble: refinement must be >= 1 (got ", options.refinement, ")"));
}

} // namespace

Ensemble ensemble(Complex particle_index, double medium_index, double wavelength_nm,
                  const SizeDistribution& sizes, const EnsembleOptions& options) {
    validate_inputs(particle_index, medium_index, wavelength_nm, options);
    Ensemble out;
    out.particle_index = particle_index;
    out.medium_index = medium_index;
    out.wavelength_nm = wavelength_nm;
    out.m = particle_index / medium_index;
    out.mean_volume_um3 = sizes.mean_volume_um3();
    out.mean_area_um2 = sizes.mean_area_um2();
    out.r_min_um = sizes.r_min_um();
    out.r_max_um = sizes.r_max_um();
    const double k = 2.0 * pi * medium_index / (wavelength_nm * 1e-3); // 1/um, in the host
    out.x_min = std::max(k * out.r_min_um, min_size_parameter);
    out.x_max = k * out.r_max_um;
    if (out.x_max > max_legendre_size_parameter)
        throw LimitError(cat("Mie ensemble: the largest size parameter ", out.x_max, " (radius ",
                             out.r_max_um, " um at ", wavelength_nm,
                             " nm) exceeds the supported maximum ", max_legendre_size_parameter));
    validate(out.m, out.x_max, "Mie ensemble");

    // Sharp resonances exist inside a sphere that reflects internally (Re m > 1) and absorbs little:
    // the absorption width of a mode is about (k/n) x, and for k/n >= 1e-2 that is wide enough for
    // the adaptive panels (and smooth enough for the nested rule).
    const bool resonant = out.m.real() > 1.0 && out.m.imag() < 1e-2 * out.m.real();
    const bool distribution = sizes.kind() != DistributionKind::Monodisperse;
    if (options.rule == RadiusRule::nested && (resonant || !distribution))
        throw InputError(
            cat("Mie ensemble: the nested radius rule needs a size distribution without "
                "sharp resonances (Re m <= 1 or k/n >= 1e-2; got m = ",
                out.m.real(), "+", out.m.imag(), "i)"));
    const bool nested =
        distribution && !resonant &&
        (options.rule == RadiusRule::nested ||
         (options.rule == RadiusRule::automatic && out.x_max >= nested_rule_min_size_parameter));
    out.rule = nested ? RadiusRule::nested : RadiusRule::panels;
    if (nested) {
        NestedResult r = integrate_nested(out.m, k, sizes, out.x_min, out.x_max, options);
        finish(out, r.total, std::move(r.legendre));
        out.radius_nodes = r.nodes;
        out.error_estimate = r.error_estimate;
        Progress(options.progress).report(1.0);
        return out;
    }
    PhaseFunctionAccumulator phase(series_length(out.x_max));
    Sums total;

    if (sizes.kind() == DistributionKind::Monodisperse) {
        // Exactly sphere(m, x): one node of weight 1.
        const double r = out.r_min_um;
        const Coefficients c = coefficients(out.m, out.x_max);
        const Efficiencies q = efficiencies(c);
        const double area = pi * r * r;
        total = {area * q.qext, area * q.qsca, area * q.qabs, area * q.qback, area * q.qsca * q.g};
        phase.add(c, 1.0);
        out.radius_nodes = 1;
    } else {
        Integrand f(out.m, k, sizes);
        const double tol = options.tolerance;
        const std::vector<double> breaks =
            initial_breaks(out.x_min, out.x_max, relative_width(sizes));
        std::vector<Panel> panels;
        for (std::size_t i = 0; i + 1 < breaks.size(); ++i)
            panels.push_back({breaks[i], breaks[i + 1]});

        // 1. Sharp resonances.
        double booked = 0.0; // error bounds of skipped resonances and trusted windows, um^2
        double budget = 0.0; // allowed absolute error of <Csca> (resonant case)
        std::vector<Window> windows; // located resonances, sorted by x at the end
        // Resonances sharp enough to need this exist only inside a sphere that reflects internally
        // (Re m > 1) and absorbs little: the absorption width of a mode is about (k/n) x, and for
        // k/n >= 1e-2 that is wide enough for the adaptive panels.
        if (resonant) {
            // The scales of <Csca> and <Cabs> for the budgets: a 4-point rule per initial panel.
            double scale = 0.0, scale_abs = 0.0;
            const auto g4 = gauss_legendre(4);
            for (const Panel& p : panels) {
                const double mid = 0.5 * (p.a + p.b), half = 0.5 * (p.b - p.a);
                for (std::size_t i = 0; i < g4->size(); ++i) {
                    const Sums v = f.at(mid + half * g4->x[i]);
                    scale += half * g4->w[i] * v.sca;
                    scale_abs += half * g4->w[i] * v.abs;
                }
            }
            budget = tol * scale;
            // A resonance's absorption, peak T_i / (1 + T_i)^2 against the scattering's 1 / (1 + T_i)^2
            // with the same shape, in units of the <Csca> budget.
            const double abs_weight = scale_abs > 0.0 ? scale / scale_abs : 0.0;
            ResonanceFinder finder(out.m.real(), f, budget, std::max(1.0, abs_weight));
            // Counting needs x2 < n + 1/2 over a sample interval [x1, x2]: samples at most 0.25
            // apart, and one just below every n + 1/2.
            std::vector<double> samples;
            for (std::size_t i = 0; i + 1 < breaks.size(); ++i) {
                const int parts = static_cast<int>(std::ceil((breaks[i + 1] - breaks[i]) / 0.25));
                for (int j = 0; j < parts; ++j)
                    samples.push_back(breaks[i] + (breaks[i + 1] - breaks[i]) * j / parts);
            }
            samples.push_back(breaks.back());
            // And just below every n + 1/2 in range, so that every resonance below its barrier
            // top is counted (above it they are broad, > 0.1).
            for (int n = 1; n + 0.5 < out.x_max; ++n)
                if (n + 0.5 - 1e-3 > out.x_min) samples.push_back(n + 0.5 - 1e-3);
            std::sort(samples.begin(), samples.end());
            finder.scan(samples);
            for (const Resonance& r : finder.found()) {
                if (r.n > series_length(r.x)) continue; // outside the series at that size
                const double damping = resonance_damping(out.m, r);
                Window w;
                w.x = r.x;
                w.width = (1.0 + damping) * r.hwhm;
                const double peak = 1.0 / ((1.0 + damping) * (1.0 + damping));
                const double scattering =
                    pi * w.width * peak * 2.0 * (2.0 * r.n + 1.0) / (r.x * r.x) * f.weight(r.x);
                w.contribution = std::max(scattering, scattering * damping * abs_weight);
                windows.push_back(w);
            }
            std::sort(windows.begin(), windows.end(), [](const Window& p, const Window& q) {
                return p.contribution < q.contribution;
            });
            booked = finder.skipped();
            for (Window& w : windows) {
                if (booked + w.contribution >= 0.1 * budget) break;
                booked += w.contribution;
                w.skipped = true;
            }
            out.resonances = carve_windows(windows, panels, budget, tol, out.x_min, out.x_max, booked);
            std::sort(windows.begin(), windows.end(),
                      [](const Window& p, const Window& q) { return p.x < q.x; });
        }
        // The Lorentzian content of the located resonances' tails in a panel (not counting a window's
        // own resonance): E / pi (atan((b - x_r) / gamma) - atan((a - x_r) / gamma)), for the
        // resonances within ten panel lengths.
        const auto tails = [&](const Panel& p) {
            const double reach = 10.0 * (p.b - p.a);
            auto it = std::lower_bound(windows.begin(), windows.end(), p.a - reach,
                                       [](const Window& w, double x) { return w.x < x; });
            double sum = 0.0;
            for (; it != windows.end() && it->x < p.b + reach; ++it) {
                if (p.mapped && p.focus == it->x) continue;
                sum += it->contribution / pi *
                       std::abs(std::atan((p.b - it->x) / it->width) -
                                std::atan((p.a - it->x) / it->width));
            }
            return sum;
        };
        const auto make_leaf = [&](const Panel& p) {
            Leaf leaf = integrate(f, p, phase, tol);
            leaf.tails = tails(p);
            return leaf;
        };
        // Error of a leaf for the refinement. A small tail of a located resonance next to a panel
        // looks like a steep feature at its end, and bisecting after it would never end; when such a
        // tail (at most 1e-3 of the budget) explains the estimate, the panel is not refined and the
        // tail's whole content is counted as its error instead.
        const double tail_allowance = 1e-3 * budget;
        const auto tail_dominated = [&](const Leaf& l) {
            return l.tails > 0.0 && l.tails <= tail_allowance &&
                   std::max(l.error.ext, l.error.sca) <= 2.0 * l.tails;
        };
        const auto leaf_error = [&](const Leaf& l) {
            return tail_dominated(l) ? Sums{l.tails, l.tails, 0.0, 0.0, 0.0} : l.error;
        };

        // 2. Adaptive Gauss-Kronrod panels.
        std::vector<Leaf> leaves;
        leaves.reserve(panels.size());
        for (const Panel& p : panels) leaves.push_back(make_leaf(p));
        const bool absorbing = out.m.imag() > 0.0;
        const long evaluation_cap = 3L * options.max_nodes;
        Progress progress(options.progress);
        long iterations = 0;
        progress.report(0.05); // the resonances are located
        for (;;) {
            Sums value, error;
            for (const Leaf& l : leaves) value += l.value, error += leaf_error(l);
            // Relative to each total; g Csca relative to Csca (g itself may be ~0).
            const auto relative = [&](const Sums& e) {
                double r = 0.0;
                if (value.ext > 0.0) r = std::max(r, e.ext / value.ext);
                if (value.sca > 0.0) r = std::max({r, e.sca / value.sca, e.gsca / value.sca});
                if (absorbing && value.abs > 0.0) r = std::max(r, e.abs / value.abs);
                return r;
            };
            // The booked errors (skipped resonances, trusted rules) cannot be refined away; the
            // panels get what they leave of the tolerance, but at least a fifth of it.
            const double booked_relative = value.sca > 0.0 ? booked / value.sca : 0.0;
            const double target = std::max(0.8 * tol - booked_relative, 0.2 * tol);
            const double panels_error = relative(error);
            out.error_estimate = panels_error + booked_relative;
            if (!(panels_error > target)) break;
            if (++iterations % 64 == 0) progress.error(panels_error, target);
            if (f.evaluations() > evaluation_cap) {
                log::warn("Mie ensemble: radius integration stopped at ", f.evaluations(),
                          " evaluations with estimated error ", out.error_estimate, " > ", tol);
                break;
            }
            std::size_t worst = leaves.size();
            double worst_error = 0.0;
            for (std::size_t i = 0; i < leaves.size(); ++i) {
                if (tail_dominated(leaves[i])) continue;
                const double r = relative(leaves[i].error);
                if (r > worst_error) worst_error = r, worst = i;
            }
            if (worst == leaves.size()) break; // only trusted rules left
            const Panel p = leaves[worst].panel;
            const double mid = 0.5 * (p.lo() + p.hi());
            const Panel left = p.piece(p.lo(), mid), right = p.piece(mid, p.hi());
            if (!(left.b > left.a && right.b > right.a)) { // at the resolution of a double
                leaves[worst].error = {};
                continue;
            }
            leaves[worst] = make_leaf(left);
            leaves.push_back(make_leaf(right));
        }
        const long adaptive_evaluations = f.evaluations();

        // 3. The final rule: the leaves' sums, or for a refined rule (convergence studies) every
        // node again.
        long nodes = 0;
        for (const Leaf& l : leaves) nodes += static_cast<long>(l.panel.rule) * options.refinement;
        if (nodes > options.max_nodes)
            throw LimitError(cat("Mie ensemble: ", nodes,
                                 " radius nodes needed, more than the limit ", options.max_nodes));
        if (options.refinement == 1) {
            for (const Leaf& l : leaves) {
                total += l.value;
                phase.add_sums(l.plus, l.minus);
            }
        } else {
            std::vector<double> xs, ws;
            for (const Leaf& l : leaves) {
                panel_nodes(l.panel, options.refinement, xs, ws);
                for (std::size_t i = 0; i < xs.size(); ++i) {
                    total += f.at(xs[i]).scaled(ws[i]);
                    phase.add(f.last_coefficients(), ws[i] * f.density(xs[i]));
                }
            }
        }
        out.radius_nodes = static_cast<int>(nodes);
        log::debug("Mie ensemble: ", out.resonances, " resonance windows, ", leaves.size(),
                   " panels, ", adaptive_evaluations, " evaluations for ", nodes, " nodes");
    }

    finish(out, total, phase.legendre(options.legendre));
    Progress(options.progress).report(1.0);
    return out;
}

} // namespace brdf::mie
