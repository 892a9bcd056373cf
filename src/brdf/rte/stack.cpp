#include <brdf/rte/stack.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>
#include <brdf/rte/adding.h>
#include <brdf/rte/rough_interface.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace brdf::rte {
namespace {

// Indices closer than this are the same medium for the split of the streams.
constexpr double same_index = 1e-12;

double max_abs_component(std::span<const double> beta, int m, const Streams& s) {
    const PhasePair p = phase_components(beta, m, s.mu, s.mu);
    return std::max(max_abs(p.plus), max_abs(p.minus));
}

struct Piece : StreamPiece {
    std::vector<double> s; // nodes
    int nodes = 0;
};

// Lagrange basis polynomial k of the nodes x at point t.
double lagrange(std::span<const double> x, std::size_t k, double t) {
    double v = 1.0;
    for (std::size_t j = 0; j < x.size(); ++j)
        if (j != k) v *= (t - x[j]) / (x[k] - x[j]);
    return v;
}

// Fourier orders of the rough top's transmission lobe above `tolerance` (relative to order 0),
// measured on f_transmit_down at 45 degrees in air, to its Snell image (the lobe's peak), by the
// trapezoidal rule in the azimuth (exact for the orders it resolves; 32768 points resolve the
// narrowest lobe, alpha 0.001, whose azimuthal width at 45 degrees is ~1e-2).
int rough_transmission_orders(const RoughInterface& rough, double tolerance, int max_orders) {
    const double mu_a = std::sqrt(0.5), n = rough.index();
    const double mu_b = std::sqrt(1.0 - 0.5 / (n * n));
    constexpr int points = 32768;
    std::vector<double> f(points), c(points);
    for (int j = 0; j < points; ++j) {
        const double phi_rt = 2.0 * std::numbers::pi * (j + 0.5) / points;
        f[j] = rough.f_transmit_down(mu_a, mu_b, phi_rt - std::numbers::pi);
        c[j] = std::cos(phi_rt);
    }
    std::vector<double> t_prev(points, 1.0), t_cur = c;
    double f0 = 0.0;
    for (double v : f) f0 += v;
    int last = 0;
    for (int m = 1; m < max_orders; ++m) {
        double fm = 0.0;
        for (int j = 0; j < points; ++j) fm += f[j] * t_cur[j];
        if (std::abs(fm) > tolerance * f0) last = m;
        for (int j = 0; j < points; ++j) {
            const double next = 2.0 * c[j] * t_cur[j] - t_prev[j];
            t_prev[j] = t_cur[j];
            t_cur[j] = next;
        }
    }
    return last + 1;
}

} // namespace

Stack half_space(const Medium& medium, double n) {
    Stack s;
    s.top = n > 1.0 ? Top::Smooth : Top::None;
    s.layers.push_back(Layer{medium, std::numeric_limits<double>::infinity(), n});
    return s;
}

StackSetup setup_stack(const Stack& stack, const StackSettings& settings) {
    if (stack.layers.empty()) throw InputError("stack: at least one layer is needed");
    if (settings.streams < 2 || settings.streams > 1024)
        throw InputError(cat("solver: streams must be in [2, 1024] (got ", settings.streams, ")"));
    for (std::size_t k = 0; k < stack.layers.size(); ++k) {
        const Layer& l = stack.layers[k];
        if (!(l.medium.omega >= 0.0 && l.medium.omega <= 1.0))
            throw InputError(cat("layer ", k, ": single-scattering albedo must be in [0, 1] (got ", l.medium.omega, ")"));
        if (l.medium.beta.empty() || std::abs(l.medium.beta[0] - 1.0) > 1e-9)
            throw InputError(cat("layer ", k, ": phase function must have beta_0 = 1"));
        if (!(l.tau >= 0.0)) throw InputError(cat("layer ", k, ": optical thickness must be >= 0 (got ", l.tau, ")"));
        if (!l.finite() && k + 1 != stack.layers.size())
            throw InputError(cat("layer ", k, ": only the last layer may be semi-infinite"));
        if (!(l.index >= 1.0)) throw InputError(cat("layer ", k, ": refractive index must be >= 1 (got ", l.index, ")"));
    }
    if (!(stack.substrate_albedo >= 0.0 && stack.substrate_albedo <= 1.0))
        throw InputError(cat("substrate: albedo must be in [0, 1] (got ", stack.substrate_albedo, ")"));

    StackSetup out;
    out.stack = stack;
    const int nl = static_cast<int>(stack.layers.size());
    std::vector<double> index(static_cast<std::size_t>(nl));
    for (int k = 0; k < nl; ++k) index[k] = stack.top == Top::None ? 1.0 : stack.layers[k].index;

    // Break points of n sin(theta): 1 (air) and every index.
    std::vector<double> breaks{1.0};
    for (double n : index) breaks.push_back(n);
    std::sort(breaks.begin(), breaks.end());
    breaks.erase(std::unique(breaks.begin(), breaks.end(), [](double a, double b) { return std::abs(a - b) <= same_index; }),
                 breaks.end());
    const int pieces = static_cast<int>(breaks.size());
    std::vector<Piece> piece(static_cast<std::size_t>(pieces));
    for (int p = 0; p < pieces; ++p) {
        Piece& pc = piece[p];
        pc.s_lo = p == 0 ? 0.0 : breaks[p - 1];
        pc.s_hi = breaks[p];
        // The top piece keeps the larger half, as the split rule of one interface does (streams.h).
        pc.nodes = pieces == 1 ? settings.streams : p == 0 ? settings.streams - settings.streams / 2 : settings.streams / 2;
        // Gauss in the cosine of the lowest-index layer containing the piece: there the piece reaches
        // that layer's horizon. (Gauss in the layer's own cosine keeps the quadrature exact for the
        // delta-M truncated phase function, so energy is conserved to rounding; what crosses an
        // interface meets Fresnel's square-root onset at the critical angle, which the effective
        // reflectances of smooth_interface_reflectance integrate exactly instead.)
        double ref = std::numeric_limits<double>::infinity();
        for (double n : index)
            if (n >= pc.s_hi - same_index) ref = std::min(ref, n);
        pc.ref_index = ref;
        const double mu_lo = std::sqrt(std::max(0.0, 1.0 - (pc.s_hi / ref) * (pc.s_hi / ref)));
        const double mu_hi = std::sqrt(std::max(0.0, 1.0 - (pc.s_lo / ref) * (pc.s_lo / ref)));
        const Quadrature q = gauss_legendre(pc.nodes, mu_lo, mu_hi);
        pc.ref_mu = q.x;
        pc.ref_w = q.w;
        for (double mu : q.x) pc.s.push_back(ref * std::sqrt(std::max(0.0, 1.0 - mu * mu)));
    }

    // Each layer's streams: the pieces it contains, in ascending cosine (descending s).
    std::vector<std::vector<std::pair<int, int>>> node_id(static_cast<std::size_t>(nl)); // (piece, node)
    out.layers.resize(static_cast<std::size_t>(nl));
    for (int k = 0; k < nl; ++k) {
        LayerSetup& ls = out.layers[k];
        ls.layer = stack.layers[k];
        ls.index = index[k];
        const double n = index[k];
        int degree = std::numeric_limits<int>::max();
        for (int p = pieces - 1; p >= 0; --p) {
            const Piece& pc = piece[p];
            if (n < pc.s_hi - same_index) continue;
            degree = std::min(degree, 2 * pc.nodes - 1);
            // Gauss nodes ascend in the reference cosine, hence descend in s: ascending here too.
            for (int i = 0; i < pc.nodes; ++i) {
                const double s = pc.s[i];
                const double mu = std::sqrt(std::max(0.0, 1.0 - (s / n) * (s / n)));
                // n^2 mu dmu is conserved: w = w_ref n_ref^2 mu_ref / (n^2 mu).
                const double w = pc.ref_w[i] * pc.ref_index * pc.ref_index * pc.ref_mu[i] / (n * n * mu);
                ls.streams.mu.push_back(mu);
                ls.streams.w.push_back(w);
                ls.s.push_back(s);
                ls.piece_of.push_back(p);
                ls.node_of.push_back(i);
                node_id[k].emplace_back(p, i);
            }
        }
        ls.streams.exact_degree = degree;
    }
    for (int k = 0; k < nl; ++k) {
        LayerSetup& ls = out.layers[k];
        ls.below_of.assign(ls.s.size(), -1);
        if (k + 1 == nl) continue;
        for (std::size_t a = 0; a < node_id[k].size(); ++a) {
            const auto it = std::find(node_id[k + 1].begin(), node_id[k + 1].end(), node_id[k][a]);
            if (it != node_id[k + 1].end()) ls.below_of[a] = static_cast<int>(it - node_id[k + 1].begin());
        }
    }

    for (const Piece& pc : piece) out.pieces.push_back(pc);

    // Delta-M where each layer's streams integrate p^m exactly (to rounding for its own Gauss
    // pieces, to quadrature accuracy for pieces mapped from another medium), and its orders.
    out.orders = 1;
    for (LayerSetup& ls : out.layers) {
        // Within 1e-14 of 1 an albedo is 1: the half-space there is critical to rounding (unshifted
        // doubling can diverge), and R changes by ~3.5 sqrt(1 - omega) <= 4e-7 (docs/physics.md
        // section 3), below every tolerance the service offers.
        if (ls.layer.medium.omega > 1.0 - 1e-14) ls.layer.medium.omega = 1.0;
        ls.truncated = delta_m(ls.layer.medium, ls.streams.exact_degree + 1);
        const double om = ls.layer.medium.omega;
        ls.tau = ls.layer.finite() ? (1.0 - om * ls.truncated.f) * ls.layer.tau : ls.layer.tau;
        const auto& beta = ls.truncated.scaled.beta;
        const int max_orders = static_cast<int>(beta.size());
        const double p0 = max_abs_component(beta, 0, ls.streams);
        ls.orders = 1;
        while (ls.orders < max_orders && max_abs_component(beta, ls.orders, ls.streams) > settings.order_tolerance * p0)
            ++ls.orders;
        if (ls.truncated.scaled.omega == 0.0) ls.orders = 1;
        out.orders = std::max(out.orders, ls.orders);
    }
    out.order_tolerance = settings.order_tolerance;
    if (stack.top == Top::Rough) {
        const RoughInterface rough(index.front(), stack.rough); // validates
        // Under a rough top the body's order m is T_up (I - R_b R_in)^-1 R_b T_down: zero where R_b^m
        // is, i.e. beyond the orders in which the layers scatter, unless the stack reflects
        // specularly inside (an index change between layers: Fresnel on every order). Then the
        // rough transmissions' own orders count too (alpha 0.1: 51 orders at 1e-5, alpha 0.3: 19).
        bool specular_inside = false;
        for (int k = 0; k + 1 < nl; ++k) specular_inside |= std::abs(index[k] - index[k + 1]) > same_index;
        if (specular_inside)
            out.orders = std::max(out.orders, rough_transmission_orders(rough, settings.order_tolerance, 512));
    }
    if (settings.max_orders > 0) out.orders = std::min(out.orders, settings.max_orders);
    return out;
}

std::vector<double> interface_reflectance(const StreamPiece& piece, double n_a, double n_b) {
    const double n_low = std::min(n_a, n_b), n_high = std::max(n_a, n_b);
    if (piece.s_hi > n_low + same_index)
        throw InputError(cat("interface reflectance: the piece reaches n sin(theta) = ", piece.s_hi,
                             ", beyond the medium of index ", n_low));
    // Integrate in the cosine of the medium that reaches its horizon first (index min(n_low, n_ref)):
    // both Fresnel's onset and the rule's own end are smooth in that variable.
    const double n_var = std::min(n_low, piece.ref_index);
    const auto cosine = [](double s, double n) { return std::sqrt(std::max(0.0, 1.0 - (s / n) * (s / n))); };
    const Quadrature q = gauss_legendre(96, cosine(piece.s_hi, n_var), cosine(piece.s_lo, n_var));
    const std::size_t nodes = piece.ref_mu.size();
    std::vector<double> f(nodes, 0.0);
    for (std::size_t g = 0; g < q.x.size(); ++g) {
        const double v = q.x[g];
        const double s = n_var * std::sqrt(std::max(0.0, 1.0 - v * v));
        const double mu_ref = cosine(s, piece.ref_index);
        // n^2 mu dmu is conserved: 2 mu_ref dmu_ref = 2 v dv (n_var / n_ref)^2.
        const double w = q.w[g] * 2.0 * v * (n_var / piece.ref_index) * (n_var / piece.ref_index);
        const double fresnel_g = fresnel(cosine(s, n_low), n_low, n_high);
        for (std::size_t k = 0; k < nodes; ++k) f[k] += w * fresnel_g * lagrange(piece.ref_mu, k, mu_ref);
    }
    for (std::size_t k = 0; k < nodes; ++k) f[k] /= 2.0 * piece.ref_w[k] * piece.ref_mu[k];
    return f;
}

std::vector<OrderProblem> layer_problems(const StackSetup& setup, int layer) {
    const LayerSetup& ls = setup.layers.at(static_cast<std::size_t>(layer));
    std::vector<OrderProblem> problems;
    problems.reserve(static_cast<std::size_t>(setup.orders));
    for (int m = 0; m < setup.orders; ++m)
        problems.push_back(make_order_problem(ls.truncated.scaled.beta, ls.truncated.scaled.omega, m, ls.streams));
    return problems;
}

std::vector<OrderProblem> half_space_problems(const StackSetup& setup) {
    if (!setup.semi_infinite()) return {};
    return layer_problems(setup, static_cast<int>(setup.layers.size()) - 1);
}

} // namespace brdf::rte
