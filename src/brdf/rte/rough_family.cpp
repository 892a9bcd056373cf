#include <brdf/rte/rough_family.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>

#include <algorithm>
#include <cmath>

namespace brdf::rte {
namespace {

// Sets of air cosines kept at once: a material asks for a handful (the stream check's and the gamut
// fit's probes, the table's grid, the albedo rule, the report's angles); eval --exact asks for a new
// one per direction and must not grow memory without bound.
constexpr std::size_t kept_entries = 8;

// Matrices of `orders` entries (or none), each the weighted sum of the nodes' matrices.
std::vector<Matrix> combine(const std::vector<InterfaceKernels>& at, std::span<const double> weight, int orders,
                            std::vector<Matrix> InterfaceKernels::*member) {
    std::vector<Matrix> out;
    if ((at.front().*member).empty()) return out;
    for (int m = 0; m < orders; ++m) {
        Matrix sum = weight[0] * (at[0].*member)[m];
        for (std::size_t j = 1; j < at.size(); ++j) {
            const std::span<const double> src = (at[j].*member)[m].data();
            const std::span<double> dst = sum.data();
            for (std::size_t k = 0; k < dst.size(); ++k) dst[k] += weight[j] * src[k];
        }
        out.push_back(std::move(sum));
    }
    return out;
}

} // namespace

InterfaceKernels converged_interface_kernels(const RoughInterface& rough, const StreamPieces& pieces,
                                             std::span<const double> air, int orders, double tolerance,
                                             bool internal_reflection) {
    for (double tol = tolerance;; tol *= 10.0) {
        try {
            InterfaceKernels k = interface_kernels(rough, pieces, air, orders, tol, internal_reflection);
            if (tol != tolerance)
                log::warn("rough interface: kernels converged to ", tol, " instead of ", tolerance);
            return k;
        } catch (const NumericalError&) {
            if (tol * 10.0 > 1e-3) throw;
        }
    }
}

std::vector<double> family_indices(double n_lo, double n_hi, int nodes) {
    if (!(n_lo > 1.0 && n_hi >= n_lo && n_hi <= 4.0))
        throw InputError(cat("rough kernel family: index range [", n_lo, ", ", n_hi, "] is not within (1, 4]"));
    if (n_hi == n_lo) return {n_lo};
    if (nodes < 2) throw InputError(cat("rough kernel family: at least 2 indices for a range (got ", nodes, ")"));
    return chebyshev_lobatto(nodes, n_lo, n_hi);
}

int family_nodes(double n_lo, double n_hi, double tolerance) {
    if (n_hi == n_lo) return 1;
    // Measured (tests/rte/rough_family_test.cpp, HG g 0.5 half-spaces under GGX alpha 0.03 and 0.3,
    // n from 1.5, w = 0.025 to 0.2): the body's BRDF between the nodes is off by at most C_c w^c of
    // its largest value for an index range of width w, C_3 = 0.42, C_4 = 0.36, C_5 = 0.04,
    // C_6 = 0.057, C_7 = 0.0065 (from 5 nodes at w = 0.025 and 7 at w = 0.1 the differences are the
    // quadrature's own noise, ~1e-8). A sixth node gains little over five, so the counts are 3, 4,
    // 5, 7, 9, ... with C_c taken as 0.5, 0.5, then 0.05 / 10^((c - 5) / 2) (C_7 = 0.005: the 0.0065
    // was measured at w = 0.2, twice the range the rule was fitted on, where 7 nodes would meet
    // 1.3 % of the tolerance instead of 1 %); w is scaled by how fast
    // the critical cosine moves with n against n = 1.5 (d mu_c / dn = 1 / (n^3 mu_c)): low indices
    // move the streams' split faster. A paint binder across the visible (PMMA: 1.485 to 1.511) at
    // the default tolerance takes 4.
    const auto speed = [](double n) { return 1.0 / (n * n * n * std::sqrt(1.0 - 1.0 / (n * n))); };
    const double w = (n_hi - n_lo) * std::max(1.0, speed(n_lo) / speed(1.5));
    const auto error = [&](int c) {
        const double coefficient = c <= 4 ? 0.5 : 0.05 * std::pow(0.1, (c - 5) / 2);
        return coefficient * std::pow(w, c);
    };
    int c = 3;
    while (c < 15 && error(c) > 0.01 * tolerance) c += c < 5 ? 1 : 2;
    return c;
}

RoughKernelFamily::RoughKernelFamily(RoughSurface surface, int n_below, int n_above, double n_lo, double n_hi,
                                     int nodes, int orders, double tolerance)
    : m_surface(surface), m_below(n_below), m_above(n_above), m_orders(orders), m_lo(n_lo), m_hi(n_hi),
      m_tolerance(tolerance), m_indices(family_indices(n_lo, n_hi, nodes)) {
    if (n_below < 1 || n_above < 1)
        throw InputError(cat("rough kernel family: streams below and above the critical cosine must be >= 1 (got ",
                             n_below, ", ", n_above, ")"));
    if (orders < 1) throw InputError(cat("rough kernel family: orders must be >= 1 (got ", orders, ")"));
    for (double n : m_indices) RoughInterface(n, surface); // validates surface and index
}

StreamPieces RoughKernelFamily::pieces(double n) const {
    return split_gauss_pieces(m_below, m_above, std::sqrt(1.0 - 1.0 / (n * n)));
}

bool RoughKernelFamily::applies(double n, const RoughSurface& surface, const StreamPieces& p, int orders,
                                double tolerance) const {
    if (!(n >= m_lo && n <= m_hi) || orders > m_orders || tolerance != m_tolerance) return false;
    if (surface != m_surface) return false;
    const StreamPieces mine = pieces(n);
    if (p.first != mine.first || p.edges.size() != mine.edges.size() || p.streams.mu.size() != mine.streams.mu.size())
        return false;
    const auto close = [](const std::vector<double>& a, const std::vector<double>& b) {
        for (std::size_t k = 0; k < a.size(); ++k)
            if (std::abs(a[k] - b[k]) > 1e-12 * std::max(1.0, std::abs(b[k]))) return false;
        return true;
    };
    return close(p.edges, mine.edges) && close(p.streams.mu, mine.streams.mu) && close(p.streams.w, mine.streams.w);
}

std::shared_ptr<RoughKernelFamily::Entry> RoughKernelFamily::entry(std::span<const double> air, int orders,
                                                                   bool internal) const {
    const std::lock_guard lock(m_mutex);
    for (auto it = m_entries.begin(); it != m_entries.end(); ++it) {
        const Entry& e = **it;
        if (e.orders == orders && e.internal == internal && std::equal(air.begin(), air.end(), e.air.begin(), e.air.end())) {
            std::shared_ptr<Entry> found = *it;
            m_entries.erase(it);
            m_entries.push_back(found);
            return found;
        }
    }
    auto e = std::make_shared<Entry>();
    e->air.assign(air.begin(), air.end());
    e->orders = orders;
    e->internal = internal;
    e->at.resize(m_indices.size());
    e->state.assign(m_indices.size(), 0);
    m_entries.push_back(e);
    if (m_entries.size() > kept_entries) m_entries.erase(m_entries.begin()); // in use elsewhere: kept alive there
    return e;
}

void RoughKernelFamily::complete(Entry& e) const {
    for (std::size_t j = 0; j < m_indices.size(); ++j) {
        {
            const std::lock_guard lock(e.mutex);
            if (e.state[j] != 0) continue;
            e.state[j] = 1;
        }
        InterfaceKernels k;
        std::exception_ptr error;
        try {
            const RoughInterface rough(m_indices[j], m_surface);
            k = converged_interface_kernels(rough, pieces(m_indices[j]), e.air, e.orders, m_tolerance, e.internal);
        } catch (...) {
            error = std::current_exception();
        }
        {
            const std::lock_guard lock(e.mutex);
            e.at[j] = std::move(k);
            if (error && !e.error) e.error = error;
            e.state[j] = 2;
        }
        e.done.notify_all();
    }
    std::unique_lock lock(e.mutex);
    e.done.wait(lock, [&] { return std::all_of(e.state.begin(), e.state.end(), [](int s) { return s == 2; }); });
    if (e.error) std::rethrow_exception(e.error);
}

InterfaceKernels RoughKernelFamily::kernels(double n, std::span<const double> air, int orders,
                                            bool internal_reflection) const {
    if (!(n >= m_lo && n <= m_hi))
        throw InternalError(cat("rough kernel family: index ", n, " outside its range [", m_lo, ", ", m_hi, "]"));
    if (orders < 1 || orders > m_orders)
        throw InternalError(cat("rough kernel family: ", orders, " orders asked of a family of ", m_orders));
    // One order (albedos) is computed as such; any other count as the family's, of which the
    // first `orders` are the answer (more orders only add quadrature nodes).
    const std::shared_ptr<Entry> e = entry(air, orders == 1 ? 1 : m_orders, internal_reflection);
    complete(*e);
    const std::vector<double> weight = lagrange_weights(m_indices, n);
    InterfaceKernels out;
    out.t_down = combine(e->at, weight, orders, &InterfaceKernels::t_down);
    out.t_up = combine(e->at, weight, orders, &InterfaceKernels::t_up);
    out.r_inside = combine(e->at, weight, orders, &InterfaceKernels::r_inside);
    for (const InterfaceKernels& k : e->at) {
        out.quadrature.level = std::max(out.quadrature.level, k.quadrature.level);
        out.quadrature.estimated_error = std::max(out.quadrature.estimated_error, k.quadrature.estimated_error);
        out.quadrature.nodes += k.quadrature.nodes;
        out.quadrature.directions = std::max(out.quadrature.directions, k.quadrature.directions);
        out.quadrature.probe_directions = std::max(out.quadrature.probe_directions, k.quadrature.probe_directions);
    }
    return out;
}

} // namespace brdf::rte
