#include <brdf/rte/reflection.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>
#include <brdf/core/threads.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>

namespace brdf::rte {
namespace {

// Cosines below this are treated as this: the bare medium's BRDF grows like 1/(mu_i + mu_o) and is
// infinite only at the exactly grazing pair.
constexpr double grazing_limit = 1e-6;

double clamp_mu(double mu) { return std::clamp(mu, grazing_limit, 1.0); }

// Cosine in layer k of a ray with cosine mu_air in air.
double inside_layer(const StackSetup& setup, int k, double mu_air) {
    const double n = setup.layers[k].index;
    return std::sqrt(std::max(0.0, 1.0 - (1.0 - mu_air * mu_air) / (n * n)));
}

// Pieces with fewer nodes than this use Fresnel at the nodes instead of product integration.
constexpr std::size_t min_product_nodes = 8;

// Indices closer than this meet without an interface.
constexpr double same_index = 1e-12;

// A half-space's order grid under a smooth top is interpolated from Chebyshev nodes in t = sin^2 of
// the air angle (Reflection::order_grid) to this relative accuracy, when that takes at most half as
// many directions as the grid.
constexpr double interpolated_grid_accuracy = 1e-15;

// Chebyshev points of the first kind in [0, 1], t_j = (1 - cos((2j + 1) pi / 2K)) / 2, the matrix
// that interpolates values there to the points x (row per point): the second (true) barycentric
// formula with the weights (-1)^j sin((2j + 1) pi / 2K) of these points (Berrut and Trefethen 2004,
// SIAM Review 46, 501, eqs. 4.2 and 5.3; a point on a node takes that node's value), and the one
// that takes them to Chebyshev coefficients, T_kj = (2 - delta_k0) / K cos(k (2j + 1) pi / 2K).
struct ChebyshevInterpolation {
    std::vector<double> nodes;
    Matrix to_points, to_coefficients;
};

ChebyshevInterpolation chebyshev_interpolation(int k, std::span<const double> x) {
    ChebyshevInterpolation c;
    std::vector<double> weight(static_cast<std::size_t>(k));
    for (int j = 0; j < k; ++j) {
        const double angle = (2.0 * j + 1.0) * std::numbers::pi / (2.0 * k);
        c.nodes.push_back(0.5 * (1.0 - std::cos(angle)));
        weight[j] = (j % 2 == 0 ? 1.0 : -1.0) * std::sin(angle);
    }
    c.to_points = Matrix(static_cast<int>(x.size()), k);
    for (int a = 0; a < static_cast<int>(x.size()); ++a) {
        const auto on_node = std::find(c.nodes.begin(), c.nodes.end(), x[a]);
        if (on_node != c.nodes.end()) {
            c.to_points(a, static_cast<int>(on_node - c.nodes.begin())) = 1.0;
            continue;
        }
        double sum = 0.0;
        for (int j = 0; j < k; ++j) sum += c.to_points(a, j) = weight[j] / (x[a] - c.nodes[j]);
        for (int j = 0; j < k; ++j) c.to_points(a, j) /= sum;
    }
    c.to_coefficients = Matrix(k, k);
    for (int i = 0; i < k; ++i)
        for (int j = 0; j < k; ++j)
            c.to_coefficients(i, j) = (i == 0 ? 1.0 : 2.0) / k *
                                      std::cos(i * (2.0 * j + 1.0) * std::numbers::pi / (2.0 * k));
    return c;
}

// The Chebyshev coefficients C = T V T^T of values V on the K x K first-kind grid (T:
// to_coefficients): the largest of all, and the largest of the last two rows and columns, about
// what the interpolant misses.
struct ChebyshevTail {
    double largest = 0.0, tail = 0.0;
};

ChebyshevTail chebyshev_tail(const ChebyshevInterpolation& c, const Matrix& values) {
    const int k = static_cast<int>(c.nodes.size());
    Matrix half, coefficients;
    gemm(c.to_coefficients, false, values, false, half);
    gemm(half, false, c.to_coefficients, true, coefficients);
    ChebyshevTail out;
    for (int i = 0; i < k; ++i)
        for (int j = 0; j < k; ++j) {
            const double v = std::abs(coefficients(i, j));
            out.largest = std::max(out.largest, v);
            if (std::max(i, j) >= k - 2) out.tail = std::max(out.tail, v);
        }
    return out;
}

// 1 - exp(-tau (1/a + 1/b)): a slab's single-scattering factor (1 for a half-space).
double slab_factor(double tau, double a, double b) {
    return std::isinf(tau) ? 1.0 : -std::expm1(-tau * (1.0 / a + 1.0 / b));
}

} // namespace

// The kernels' quadrature tolerance is the requested accuracy (10x the order tolerance; clamped:
// below 1e-7 the per-stream kernels cost much more and the solution's own error dominates). On the
// seed white in gloss at "default" (1e-4) the tables differ from those with kernels at 1e-5 by
// 4.5e-6 at most, for a quarter less time.
double rough_kernel_tolerance(double order_tolerance) { return std::clamp(10.0 * order_tolerance, 1e-7, 1e-4); }

StackSetup setup_reflection(const Medium& medium, const Interface& interface, const ReflectionSettings& settings) {
    if (!(interface.n >= 1.0)) throw InputError(cat("interface: binder index must be >= 1 (got ", interface.n, ")"));
    return setup_reflection(half_space(medium, interface.n), settings);
}

StackSetup setup_reflection(const Stack& stack, const ReflectionSettings& settings) {
    return setup_stack(stack, StackSettings{settings.streams, settings.order_tolerance, settings.max_orders});
}

std::vector<OrderProblem> order_problems(const StackSetup& setup) { return half_space_problems(setup); }

std::vector<OrderSolution> solve_orders_cpu(std::span<const OrderProblem> problems, Method method,
                                            const SolveControl& control, int threads) {
    std::vector<OrderSolution> out(problems.size());
    parallel_for(static_cast<int>(problems.size()), std::max(1, threads),
                 [&](int k) { out[k] = solve_order(problems[k], method, control); });
    return out;
}

Reflection::Reflection(StackSetup setup, std::vector<OrderSolution> half_space,
                       std::shared_ptr<const RoughKernelFamily> family)
    : m_setup(std::move(setup)), m_half(std::move(half_space)), m_family(std::move(family)) {
    const int orders = m_setup.orders;
    const std::size_t want = m_setup.semi_infinite() ? static_cast<std::size_t>(orders) : 0;
    if (m_half.size() != want)
        throw InputError(cat("reflection: ", m_half.size(), " half-space solutions for ", want, " orders"));
    const int nl = static_cast<int>(m_setup.layers.size());
    m_slabs.resize(static_cast<std::size_t>(nl));
    for (int k = 0; k < nl; ++k) {
        const LayerSetup& ls = m_setup.layers[k];
        if (!ls.layer.finite()) continue;
        for (const OrderProblem& p : layer_problems(m_setup, k)) m_slabs[k].emplace_back(p, ls.tau);
    }
    // Interface reflectances at the streams, by product integration over each piece.
    const auto piece_reflectance = [&](const LayerSetup& l, double n_other, std::span<const int> crosses) {
        std::vector<std::vector<double>> per_piece(m_setup.pieces.size());
        std::vector<double> f(l.s.size(), 1.0);
        for (std::size_t i = 0; i < l.s.size(); ++i) {
            if (!crosses[i]) continue;
            if (std::abs(l.index - n_other) <= same_index) { // no interface: Fresnel's 0, not integrated
                f[i] = 0.0;
                continue;
            }
            auto& pf = per_piece[l.piece_of[i]];
            const StreamPiece& piece = m_setup.pieces[l.piece_of[i]];
            // Product integration interpolates the field across the piece with its Gauss nodes'
            // polynomial; below 8 nodes that is cruder than plain Gauss (measured on the seed
            // material: 8 streams 7.8e-3 against 5.7e-3; 32 streams 3.4e-6 against 1.2e-4).
            if (piece.ref_mu.size() < min_product_nodes) {
                f[i] = fresnel(l.streams.mu[i], l.index, n_other);
                continue;
            }
            if (pf.empty()) pf = interface_reflectance(piece, l.index, n_other);
            f[i] = pf[l.node_of[i]];
        }
        return f;
    };
    {
        const LayerSetup& top = m_setup.layers.front();
        std::vector<int> crosses(top.s.size());
        for (std::size_t i = 0; i < top.s.size(); ++i) crosses[i] = top.s[i] < 1.0;
        m_top_f = piece_reflectance(top, 1.0, crosses);
    }
    for (int k = 0; k + 1 < nl; ++k) {
        const LayerSetup& a = m_setup.layers[k];
        const LayerSetup& b = m_setup.layers[k + 1];
        std::vector<int> down(a.s.size()), up(b.s.size(), 0);
        for (std::size_t i = 0; i < a.s.size(); ++i) {
            down[i] = a.below_of[i] >= 0;
            if (down[i]) up[a.below_of[i]] = 1;
        }
        m_f_above.push_back(piece_reflectance(a, b.index, down));
        m_f_below.push_back(piece_reflectance(b, a.index, up));
    }
    if (m_setup.stack.top == Top::Smooth) m_top_bounce = std::make_shared<TopBounces>(orders);
    if (!m_setup.semi_infinite()) {
        setup_rough();
        return;
    }
    // The half-space's Nystrom operators are built per order when first needed (nystrom()): a
    // rough top never evaluates the half-space off its streams, and a probe only at a few cosines.
    m_nystrom = std::make_shared<NystromOrders>(orders);
    setup_rough();
}

Reflection Reflection::with_orders(int orders) const {
    if (orders < 1 || orders > m_setup.orders)
        throw InternalError(cat("reflection: ", orders, " orders asked of a reflection with ", m_setup.orders));
    StackSetup setup = m_setup;
    setup.orders = orders;
    std::vector<OrderSolution> half;
    if (!m_half.empty()) half.assign(m_half.begin(), m_half.begin() + orders);
    Reflection cut(std::move(setup), std::move(half), m_family);
    // Order m's operators do not depend on how many orders there are: the first `orders` of what
    // this one has built (the stream check's probes, evaluated at its directions) serve the cut
    // too, not built again for the table's grids.
    if (m_nystrom) cut.m_nystrom = m_nystrom;
    if (m_top_bounce) cut.m_top_bounce = m_top_bounce;
    return cut;
}

void Reflection::setup_rough() {
    if (m_setup.stack.top != Top::Rough) return;
    const LayerSetup& top = m_setup.layers.front();
    m_rough = std::make_shared<const RoughInterface>(top.index, m_setup.stack.rough);
    // The Gauss pieces of layer 0's streams in its own cosine: product integration uses the Lagrange
    // basis of each piece (the critical-angle split keeps the internal reflection's onset of TIR
    // at a piece edge, as for the smooth top).
    std::vector<double> edges{0.0, 1.0};
    for (const StreamPiece& pc : m_setup.pieces)
        if (pc.s_hi < top.index - same_index) edges.push_back(std::sqrt(1.0 - (pc.s_hi / top.index) * (pc.s_hi / top.index)));
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    m_rough_pieces = stream_pieces(top.streams, edges);
    m_rough_tolerance = rough_kernel_tolerance(m_setup.order_tolerance);
    // A family shared by the material's wavelengths serves only the stacks it was made for.
    if (m_family &&
        !m_family->applies(top.index, m_setup.stack.rough, m_rough_pieces, m_setup.orders, m_rough_tolerance))
        m_family.reset();
    const InterfaceKernels k = rough_kernels({}, m_setup.orders, true);
    const Streams& s = top.streams;
    const int n = s.size();
    for (int m = 0; m < m_setup.orders; ++m) {
        // Adding (docs/physics.md section 9): the upward field under the interface is
        // U = (I - R_b Q R_in Q)^-1 R_b Q D for a downward field D just below it.
        const Reflector b = below_top(m, {});
        Matrix rq = b.nn;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) rq(i, j) *= 2.0 * s.w[j] * s.mu[j];
        Matrix inq = k.r_inside[m];
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) inq(i, j) *= 2.0 * s.w[j] * s.mu[j];
        Matrix a = Matrix::identity(n);
        Matrix loop = rq * inq;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) a(i, j) -= loop(i, j);
        LuFactor(std::move(a)).solve(rq);
        m_rough_zq.push_back(std::move(rq));
    }
}

InterfaceKernels Reflection::rough_kernels(std::span<const double> air, int orders, bool internal_reflection) const {
    if (m_family) return m_family->kernels(m_rough->index(), air, orders, internal_reflection);
    return converged_interface_kernels(*m_rough, m_rough_pieces, air, orders, m_rough_tolerance, internal_reflection);
}

Matrix Reflection::rough_body(int m, const InterfaceKernels& kernels) const {
    const Streams& s = m_setup.layers.front().streams;
    Matrix up = kernels.t_up[m];
    for (int e = 0; e < up.rows(); ++e)
        for (int j = 0; j < up.cols(); ++j) up(e, j) *= 2.0 * s.w[j] * s.mu[j];
    return (up * m_rough_zq[m]) * kernels.t_down[m];
}

double Reflection::surface_lobe(double mu_i, double mu_o, double phi) const {
    if (!m_rough) return 0.0;
    return m_rough->f_reflect_air(clamp_mu(mu_i), clamp_mu(mu_o), phi);
}

double Reflection::inside(int k, double mu_air) const { return inside_layer(m_setup, k, mu_air); }

Reflection::NystromOrders::NystromOrders(int orders)
    : building(std::make_unique<std::mutex[]>(static_cast<std::size_t>((orders + block - 1) / block))),
      ready(std::make_unique<std::atomic<bool>[]>(static_cast<std::size_t>(orders))),
      pencil(static_cast<std::size_t>(orders)), minus_w(static_cast<std::size_t>(orders)) {}

Reflection::TopBounces::TopBounces(int orders)
    : once(static_cast<std::size_t>(orders)), inverse(static_cast<std::size_t>(orders)) {}

const Matrix& Reflection::top_bounce(int m) const {
    TopBounces& all = *m_top_bounce;
    std::call_once(all.once[m], [&] {
        all.inverse[m] =
            bounce_inverse(top_interface({}), below_top(m, {}).nn, m_setup.layers.front().streams);
    });
    return all.inverse[m];
}

Reflection::NystromOrder Reflection::nystrom(int m) const {
    NystromOrders& all = *m_nystrom;
    if (!all.ready[m].load(std::memory_order_acquire)) {
        const int first = m / NystromOrders::block * NystromOrders::block;
        std::lock_guard lock(all.building[m / NystromOrders::block]);
        // The block's orders this reflection has (a copy cut to fewer orders shares the operators)
        // and no caller has built yet.
        std::vector<int> todo;
        for (int k = first; k < std::min(first + NystromOrders::block, m_setup.orders); ++k)
            if (!all.ready[k].load(std::memory_order_relaxed)) todo.push_back(k);
        const LayerSetup& ls = m_setup.layers.back();
        const Streams& s = ls.streams;
        const int n = s.size();
        const double om = ls.truncated.scaled.omega;
        std::vector<Matrix> g;
        for (int k : todo) {
            const PhasePair p = phase_components(ls.truncated.scaled.beta, k, s.mu, s.mu);
            // G = I - (w/2) P+ W - w M X W P- W: the half-node equation is (M + u G) r = rhs(u).
            Matrix wpw(n, n);
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) wpw(i, j) = s.w[i] * p.minus(i, j) * s.w[j];
            const Matrix xwpw = m_half[k].x * wpw;
            Matrix gk = Matrix::identity(n);
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) gk(i, j) -= 0.5 * om * p.plus(i, j) * s.w[j] + om * s.mu[i] * xwpw(i, j);
            g.push_back(std::move(gk));
            Matrix minus_w = p.minus;
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) minus_w(i, j) *= s.w[j];
            all.minus_w[k] = std::move(minus_w);
        }
        std::vector<ShiftedPencil> pencils = ShiftedPencil::batch(g, s.mu);
        for (std::size_t q = 0; q < todo.size(); ++q) {
            all.pencil[todo[q]].emplace(std::move(pencils[q]));
            all.ready[todo[q]].store(true, std::memory_order_release);
        }
    }
    return {*all.pencil[m], all.minus_w[m]};
}

Reflector Reflection::half_space_reflector(int m, std::span<const double> u, bool with_single,
                                           int sine_power) const {
    // Nystrom: the equation at (mu_k, u) is linear in r_k = R^m(mu_k, u) once X is known:
    //   (mu_k + u) r_k - (w/2) u (P+ W r)_k - w u mu_k (X W P- W r)_k
    //     = (w/4) [p^m(-mu_k, u) + 2 mu_k (X W p^m(., u))_k],
    // and then Ambartsumian's equation itself gives R^m between two off-stream cosines.
    const LayerSetup& ls = m_setup.layers.back();
    const Streams& s = ls.streams;
    const auto& beta = ls.truncated.scaled.beta;
    const int n = s.size();
    const int ne = static_cast<int>(u.size());
    const double om = ls.truncated.scaled.omega;
    const Matrix& x = m_half[m].x;
    Reflector r;
    r.nn = x;
    r.en = Matrix(ne, n);
    r.ee = Matrix(ne, ne);
    r.spec.assign(static_cast<std::size_t>(ne), 0.0);
    if (ne == 0) return r; // the streams alone (a rough top's adding): no Nystrom operator needed
    if (sine_power != 0 && with_single)
        throw InternalError(
            "half_space_reflector: the single scattering is not made without its sines");
    const PhasePair pu = phase_components(beta, m, u, s.mu, sine_power); // E x N
    // Right-hand sides, one column per direction: (w/4) [p-(mu_k, u) + 2 mu_k (X W p+(., u))_k].
    Matrix pw = pu.plus;
    for (int e = 0; e < ne; ++e)
        for (int j = 0; j < n; ++j) pw(e, j) *= s.w[j];
    Matrix rhs;
    gemm(x, false, pw, true, rhs); // N x E
    for (int i = 0; i < n; ++i)
        for (int e = 0; e < ne; ++e) rhs(i, e) = 0.25 * om * (pu.minus(e, i) + 2.0 * s.mu[i] * rhs(i, e));
    const NystromOrder nys = nystrom(m);
    nys.pencil.solve(u, rhs);
    for (int e = 0; e < ne; ++e)
        for (int i = 0; i < n; ++i) r.en(e, i) = rhs(i, e);
    // (w/4)[p(-u_a, u_b) + 2 u_b (Pu W Rn^T)_ab + 2 u_a (Rn W Pu^T)_ab + 4 u_a u_b (Rn W P- W Rn^T)_ab] / (u_a + u_b)
    // The first term is the single scattering: the one of the four that costs E^2 L. With
    // X = diag(u) Rn and A = Pu W + X W P- W, the other three are 2 (C + C^T)_ab, C = A X^T: W P- W
    // is symmetric (p^m(-mu, mu') = p^m(-mu', mu): P_l^m(-x) = (-1)^(l+m) P_l^m(x)), so the last
    // term is 2 u_a u_b (Rn W P- W Rn^T)_ab twice over. One E x E product instead of two (HG's 181
    // grid cosines at 64 streams: 2.8 instead of 4.9 million multiply-adds an order).
    const Matrix single = with_single ? phase_components(beta, m, u, u).minus : Matrix(ne, ne);
    Matrix rnw = r.en;
    for (int e = 0; e < ne; ++e)
        for (int k = 0; k < n; ++k) rnw(e, k) *= s.w[k];
    Matrix a_rows = rnw * nys.minus_w; // Rn W P- W, then A
    Matrix x_rows = r.en;
    for (int e = 0; e < ne; ++e)
        for (int k = 0; k < n; ++k) {
            a_rows(e, k) = pu.plus(e, k) * s.w[k] + u[e] * a_rows(e, k);
            x_rows(e, k) *= u[e];
        }
    const Matrix c = multiply_transposed(a_rows, x_rows);
    for (int a = 0; a < ne; ++a)
        for (int b = 0; b < ne; ++b) {
            const double num = single(a, b) + 2.0 * (c(a, b) + c(b, a));
            r.ee(a, b) = 0.25 * om * num / (u[a] + u[b]);
        }
    return r;
}

Reflector Reflection::substrate_reflector(int m, int n, int e) const {
    // A Lambertian floor of albedo a: BRDF a / pi, i.e. R^0 = a everywhere, no other order.
    const double a = m == 0 ? m_setup.stack.substrate_albedo : 0.0;
    return Reflector{Matrix(n, n, a), Matrix(e, n, a), Matrix(e, e, a), std::vector<double>(static_cast<std::size_t>(e), 0.0)};
}

LayerOperators Reflection::layer_operators(int k, int m, std::span<const double> u, bool with_t_ee) const {
    const LayerSetup& ls = m_setup.layers[k];
    const SlabOrder& slab = m_slabs[k][m];
    const auto& beta = ls.truncated.scaled.beta;
    LayerOperators op;
    op.r_nn = slab.reflection();
    op.t_nn = slab.transmission();
    SlabRows rows = slab.rows(beta, u);
    op.r_en = std::move(rows.r);
    op.t_en = std::move(rows.t);
    SlabOrder::Beams beams = slab.beams(beta, u);
    op.r_ee = std::move(beams.block.r);
    if (with_t_ee) op.t_ee = std::move(beams.block.t);
    for (double ue : u) op.t_e.push_back(std::exp(-ls.tau / ue));
    return op;
}

SmoothInterface Reflection::interface_below(int k, std::span<const double> u) const {
    const LayerSetup& a = m_setup.layers[k];
    const LayerSetup& b = m_setup.layers[k + 1];
    SmoothInterface f;
    f.n_above = a.index;
    f.n_below = b.index;
    f.below_of = a.below_of;
    f.f_above = m_f_above[k];
    f.f_below = m_f_below[k];
    for (double ue : u) f.f_e.push_back(fresnel(ue, a.index, b.index));
    return f;
}

SmoothInterface Reflection::top_interface(std::span<const double> mu_air) const {
    const LayerSetup& top = m_setup.layers.front();
    SmoothInterface f;
    f.n_above = 1.0;
    f.n_below = top.index;
    f.f_below = m_top_f;
    for (double mu : mu_air) f.f_e.push_back(fresnel(mu, 1.0, top.index));
    return f;
}

Reflector Reflection::below_top(int m, std::span<const double> mu_air, bool with_single) const {
    const int nl = static_cast<int>(m_setup.layers.size());
    const int ne = static_cast<int>(mu_air.size());
    std::vector<std::vector<double>> u(static_cast<std::size_t>(nl));
    for (int k = 0; k < nl; ++k)
        for (double mu : mu_air) u[k].push_back(inside(k, mu));
    Reflector b = m_setup.semi_infinite() ? half_space_reflector(m, u.back(), with_single)
                                          : substrate_reflector(m, m_setup.layers.back().streams.size(), ne);
    for (int k = nl - 1; k >= 0; --k) {
        const LayerSetup& ls = m_setup.layers[k];
        if (ls.layer.finite()) {
            const bool specular = std::any_of(b.spec.begin(), b.spec.end(), [](double s) { return s != 0.0; });
            b = add_layer(layer_operators(k, m, u[k], specular), b, ls.streams);
        }
        if (k > 0 && std::abs(m_setup.layers[k - 1].index - ls.index) > same_index)
            b = add_interface(interface_below(k - 1, u[k - 1]), b, m_setup.layers[k - 1].streams, ls.streams);
    }
    return b;
}

Reflector Reflection::external(int m, std::span<const double> mu_air, bool with_single) const {
    Reflector b = below_top(m, mu_air, with_single);
    switch (m_setup.stack.top) {
    case Top::None: return b;
    case Top::Smooth:
        return add_interface(top_interface(mu_air), b, Streams{}, m_setup.layers.front().streams,
                             top_bounce(m));
    case Top::Rough: break;
    }
    throw InternalError("reflection: a rough top's orders come from order_grid");
}

double path_factor(const StackSetup& setup, int k, double mu_air) {
    const double mu = clamp_mu(mu_air);
    double f = 1.0;
    if (setup.stack.top != Top::None) f *= 1.0 - fresnel(mu, 1.0, setup.layers.front().index);
    for (int j = 0; j < k; ++j) {
        const LayerSetup& a = setup.layers[j];
        const double u = inside_layer(setup, j, mu);
        f *= std::exp(-a.tau / u) * (1.0 - fresnel(u, a.index, setup.layers[j + 1].index));
    }
    return f / setup.layers[k].index;
}

ScatteringLayer scattering_layer(const StackSetup& setup, int k) {
    const LayerSetup& ls = setup.layers[k];
    // Nakajima and Tanaka 1988 (eq. 15; DISORT's TMS, eq. 68 of its report): delta-M counts light
    // scattered into the truncated forward peak as unscattered, so each path that leaves the peak
    // once carries the geometric series of peak events, 1 / (1 - f omega); exactly omega when
    // nothing is truncated.
    const double f = ls.truncated.f, om = ls.layer.medium.omega;
    return ScatteringLayer{&ls.layer.medium.beta, om / (1.0 - f * om), ls.tau, ls.index};
}

namespace {

// One direction's direct path in layer k of a set-up stack: its cosine and sine there and its
// factor A_k(mu) / n_k (path_factor).
struct DirectPath {
    double u = 0.0, s = 0.0, path = 0.0;
};

DirectPath direct_path(const StackSetup& setup, int k, double mu_air) {
    const double mu = clamp_mu(mu_air);
    const double u = inside_layer(setup, k, mu);
    return {u, std::sqrt(std::max(0.0, 1.0 - u * u)), path_factor(setup, k, mu)};
}

double scattering_cosine(const DirectPath& o, const DirectPath& i, double cos_phi) {
    return std::clamp(-o.u * i.u - o.s * i.s * cos_phi, -1.0, 1.0);
}

// Layer l's single scattering of the pair without the phase function's value.
double single_factor(const ScatteringLayer& l, const DirectPath& o, const DirectPath& i) {
    return o.path * i.path * 0.25 * l.albedo / (o.u + i.u) * slab_factor(l.tau, o.u, i.u);
}

} // namespace

double single_scattering(const StackSetup& setup, double mu_o, double mu_i, double phi) {
    if (setup.stack.top == Top::Rough) return 0.0;
    const double cos_phi = std::cos(phi);
    double sum = 0.0;
    for (int k = 0; k < static_cast<int>(setup.layers.size()); ++k) {
        const ScatteringLayer l = scattering_layer(setup, k);
        const DirectPath o = direct_path(setup, k, mu_o), i = direct_path(setup, k, mu_i);
        sum += single_factor(l, o, i) * phase_value(*l.beta, scattering_cosine(o, i, cos_phi));
    }
    return sum;
}

std::vector<double> single_scattering_grid(const StackSetup& setup, std::span<const double> mu,
                                           std::span<const double> phi) {
    const std::size_t ne = mu.size(), np = phi.size();
    std::vector<double> out(ne * ne * np, 0.0);
    if (setup.stack.top == Top::Rough) return out;
    std::vector<double> cos_phi(np), cos_scatter(out.size()), p(out.size());
    std::vector<DirectPath> paths(ne);
    for (std::size_t q = 0; q < np; ++q) cos_phi[q] = std::cos(phi[q]);
    for (int k = 0; k < static_cast<int>(setup.layers.size()); ++k) {
        const ScatteringLayer l = scattering_layer(setup, k);
        for (std::size_t e = 0; e < ne; ++e) paths[e] = direct_path(setup, k, mu[e]);
        for (std::size_t i = 0; i < ne; ++i)
            for (std::size_t o = 0; o < ne; ++o)
                for (std::size_t q = 0; q < np; ++q)
                    cos_scatter[(i * ne + o) * np + q] = scattering_cosine(paths[o], paths[i], cos_phi[q]);
        // One pass of the series over every direction: a big sphere's runs to thousands of terms,
        // summed eight points at a time instead of one Clenshaw chain per direction (the same
        // values as single_scattering's).
        phase_values(*l.beta, cos_scatter, p);
        for (std::size_t i = 0; i < ne; ++i)
            for (std::size_t o = 0; o < ne; ++o) {
                const double f = single_factor(l, paths[o], paths[i]);
                for (std::size_t q = 0; q < np; ++q) out[(i * ne + o) * np + q] += f * p[(i * ne + o) * np + q];
            }
    }
    return out;
}

bool Reflection::interpolated_orders(std::span<const double> mu, int threads,
                                     OrderGrid& grid) const {
    // Below a smooth top of index n > 1, order m of what rises is sin^m of each inside direction
    // times an analytic function of t = 1 - mu_air^2: the inside cosine u = sqrt(1 - t / n^2) is
    // analytic for t < n^2, and the Nystrom solution's poles (D + u G singular) lie at u < 0, on
    // the square root's other branch. sin^m is a polynomial in t for even m and sqrt(t) / n times
    // one for odd m, so R^m over sin^(m mod 2) is analytic in t, and its Chebyshev series on [0, 1]
    // converges as rho^-K, rho = x + sqrt(x^2 - 1) with x = 2 n^2 - 1 the singularity t = n^2 on
    // the interval's scale (n = 1.5: rho = 6.9). Once the multiple scattering's own angular
    // bandwidth is resolved too, K nodes in t carry the whole grid (14-36 instead of a table's 91
    // or 181 directions). Each order checks that from its Chebyshev coefficients (the last two rows
    // and columns at rounding) and is solved at every direction instead where they are not. The air
    // side's Fresnel transmissions, the interface's 1 / n^2 and the odd orders' sine are applied
    // per direction.
    const int ne = static_cast<int>(mu.size());
    const double n = m_setup.layers.front().index;
    const double x = 2.0 * n * n - 1.0;
    if (!(x > 1.0)) return false;
    const int analytic = static_cast<int>(std::ceil(std::log(1.0 / interpolated_grid_accuracy) /
                                                    std::log(x + std::sqrt(x * x - 1.0))));
    // The multiple scattering's angular detail resolves in about half as many nodes as its
    // (truncated) phase function has Legendre terms: measured Chebyshev coefficients at rounding
    // from 33 nodes on for a 5 um silica agent (64 terms), from 16 for rutile (32 terms).
    const std::size_t terms = m_setup.layers.front().truncated.scaled.beta.size();
    const int k = std::max(analytic, static_cast<int>(terms / 2) + 4);
    if (2 * k > ne) return false;
    grid.nodes = k;
    std::vector<double> t;
    for (double m : mu) t.push_back((1.0 - m) * (1.0 + m));
    const ChebyshevInterpolation c = chebyshev_interpolation(k, t);
    std::vector<double> mu_nodes, u_nodes, sine, transmission;
    for (double tj : c.nodes) {
        mu_nodes.push_back(std::sqrt(1.0 - tj));
        u_nodes.push_back(inside(0, mu_nodes.back()));
    }
    for (int a = 0; a < ne; ++a) {
        sine.push_back(std::sqrt(t[a]) / n); // of the inside angle
        transmission.push_back((1.0 - fresnel(mu[a], 1.0, n)) / n);
    }
    const SmoothInterface top = top_interface(mu_nodes);
    const Streams& streams = m_setup.layers.front().streams;
    // Order 0's largest coefficient: what every order's error is measured against.
    double scale = 0.0;
    std::atomic<int> interpolated = 0;
    const auto order = [&](int m) {
        const int odd = m % 2;
        // What rises below the interface at the nodes, odd orders over their sine
        // (half_space_reflector without the single scattering, as the direct path; add_interface's
        // inner part).
        const Matrix inner =
            bounce_under_interface(top, half_space_reflector(m, u_nodes, false, odd), streams,
                                   top_bounce(m))
                .ee;
        const ChebyshevTail tail = chebyshev_tail(c, inner);
        if (m == 0) scale = tail.largest;
        Matrix r;
        // At rounding: the target, with room for the rounding of the transform's K-term sums.
        const bool resolved =
            tail.tail <= interpolated_grid_accuracy * 100.0 * std::max(scale, tail.largest);
        if (resolved) {
            Matrix rows;
            gemm(c.to_points, false, inner, false, rows); // E x K
            gemm(rows, false, c.to_points, true, r);      // E x E
            for (int a = 0; a < ne; ++a)
                for (int b = 0; b < ne; ++b)
                    r(a, b) *= transmission[a] * transmission[b] * (odd ? sine[a] * sine[b] : 1.0);
            ++interpolated;
        } else {
            r = external(m, mu, false).ee;
        }
        grid.orders[m] = std::move(r);
    };
    order(0);
    parallel_for(m_setup.orders - 1, threads, [&](int m) { order(m + 1); });
    grid.interpolated = interpolated;
    return true;
}

OrderGrid Reflection::order_grid(std::span<const double> mu_air, int threads) const {
    OrderGrid grid;
    for (double mu : mu_air) grid.mu.push_back(clamp_mu(mu));
    const std::vector<double>& mu = grid.mu;
    const int ne = static_cast<int>(mu.size());
    const int nl = static_cast<int>(m_setup.layers.size());
    const bool tms = m_setup.stack.top != Top::Rough;
    // Per layer: the path factors and cosines of every direction, for the truncated single
    // scattering removed below (the exact one is added back per direction: TMS).
    std::vector<std::vector<double>> factor(static_cast<std::size_t>(nl)), u(static_cast<std::size_t>(nl));
    if (m_rough) {
        // Under a rough top the body's orders carry the single scattering too, with the delta-M
        // phase function: the rough refraction spreads every direct path over the lobe, so the
        // TMS correction (exact phase function on one pair of refracted directions) does not
        // apply as it does under a smooth top (docs/physics.md, "Rough interface").
        const InterfaceKernels k = rough_kernels(mu, m_setup.orders, false);
        grid.orders.resize(static_cast<std::size_t>(m_setup.orders));
        parallel_for(m_setup.orders, threads, [&](int m) { grid.orders[m] = rough_body(m, k); });
        return grid;
    }
    for (int k = 0; k < nl; ++k)
        for (double m : mu) factor[k].push_back(path_factor(k, m)), u[k].push_back(inside(k, m));
    grid.orders.resize(static_cast<std::size_t>(m_setup.orders));
    // One half-space under at most a smooth interface: what the interface makes of the half-space's
    // single scattering is path_factor(mu_o) path_factor(mu_i) times it (add_interface; the
    // half-space has no specular part), exactly the term removed below, so it is left out where it
    // is made instead, saving its phase components (E^2 L per order).
    const bool single_left_out = tms && nl == 1 && m_setup.semi_infinite() &&
                                 (m_setup.stack.top == Top::Smooth || m_setup.layers.front().index == 1.0);
    if (single_left_out && m_setup.stack.top == Top::Smooth &&
        interpolated_orders(mu, threads, grid))
        return grid;
    parallel_for(m_setup.orders, threads, [&](int m) {
        Matrix r = external(m, mu, !single_left_out).ee;
        if (tms && !single_left_out)
            for (int k = 0; k < nl; ++k) {
                const LayerSetup& ls = m_setup.layers[k];
                const double om = ls.truncated.scaled.omega;
                const PhasePair puu = phase_components(ls.truncated.scaled.beta, m, u[k], u[k]);
                for (int a = 0; a < ne; ++a)
                    for (int b = 0; b < ne; ++b)
                        r(a, b) -= factor[k][a] * factor[k][b] * 0.25 * om * puu.minus(a, b) / (u[k][a] + u[k][b]) *
                                   slab_factor(ls.tau, u[k][a], u[k][b]);
            }
        grid.orders[m] = std::move(r);
    });
    return grid;
}

double Reflection::brdf(double mu_i, double mu_o, double phi) const {
    mu_i = clamp_mu(mu_i);
    mu_o = clamp_mu(mu_o);
    const double mus[2] = {mu_o, mu_i};
    const OrderGrid grid = order_grid(mus);
    double sum = 0.0;
    for (int m = 0; m < m_setup.orders; ++m) {
        const double sign = (m % 2 == 0) ? 1.0 : -1.0;
        sum += (m == 0 ? 1.0 : 2.0) * sign * grid.orders[m](0, 1) * std::cos(m * phi);
    }
    sum += single_scattering(mu_o, mu_i, phi);
    return std::max(0.0, sum) * std::numbers::inv_pi + surface_lobe(mu_i, mu_o, phi);
}

std::vector<double> Reflection::brdf_grid(std::span<const double> mu, std::span<const double> phi,
                                          bool with_lobe, int threads) const {
    const OrderGrid grid = order_grid(mu, threads);
    const std::size_t ne = grid.mu.size(), np = phi.size();
    std::vector<double> out = single_scattering_grid(m_setup, grid.mu, phi);
    for (std::size_t p = 0; p < np; ++p) {
        std::vector<double> c(static_cast<std::size_t>(m_setup.orders)); // (2 - delta_m0) (-1)^m cos(m phi)
        for (int m = 0; m < m_setup.orders; ++m)
            c[m] = (m == 0 ? 1.0 : 2.0) * (m % 2 == 0 ? 1.0 : -1.0) * std::cos(m * phi[p]);
        for (std::size_t i = 0; i < ne; ++i)
            for (std::size_t o = 0; o < ne; ++o) {
                double sum = 0.0;
                for (int m = 0; m < m_setup.orders; ++m) sum += c[m] * grid.orders[m](o, i);
                sum += out[(i * ne + o) * np + p];
                out[(i * ne + o) * np + p] = std::max(0.0, sum) * std::numbers::inv_pi +
                                             (with_lobe ? surface_lobe(grid.mu[i], grid.mu[o], phi[p]) : 0.0);
            }
    }
    return out;
}

double Reflection::albedo(double mu_i) const {
    const double mus[1] = {mu_i};
    return albedo(std::span<const double>(mus)).front();
}

std::vector<double> Reflection::albedo(std::span<const double> mu_in) const {
    // The streams' own rule, under which the discrete equations conserve energy exactly (mirror +
    // diffuse = 1 at albedo 1): A = T(mu_i) sum_k q_k T_k Z(mu_k, u_i) over the streams that reach air.
    std::vector<double> mus;
    for (double mu : mu_in) mus.push_back(clamp_mu(mu));
    const int ne = static_cast<int>(mus.size());
    std::vector<double> a(mus.size(), 0.0);
    const LayerSetup& top = m_setup.layers.front();
    const Streams& s = top.streams;
    switch (m_setup.stack.top) {
    case Top::None: {
        const Reflector b = below_top(0, mus);
        for (int e = 0; e < ne; ++e)
            for (int k = 0; k < s.size(); ++k) a[e] += 2.0 * s.w[k] * s.mu[k] * b.en(e, k);
        return a;
    }
    case Top::Smooth: {
        const Reflector b = below_top(0, mus);
        const SmoothInterface f = top_interface(mus);
        const Reflector z = bounce_under_interface(f, b, s, top_bounce(0));
        for (int e = 0; e < ne; ++e) {
            for (int k = 0; k < s.size(); ++k) a[e] += 2.0 * s.w[k] * s.mu[k] * (1.0 - f.f_below[k]) * z.en(e, k);
            a[e] *= 1.0 - f.f_e[e];
        }
        return a;
    }
    case Top::Rough: {
        // Lobe: its closed-form albedo; body: order 0 on a Gauss rule in the outgoing air cosine.
        constexpr int rule = 32;
        const Quadrature g = gauss_legendre(rule, 0.0, 1.0);
        std::vector<double> us = g.x;
        us.insert(us.end(), mus.begin(), mus.end());
        const InterfaceKernels k = rough_kernels(us, 1, false);
        const Matrix body = rough_body(0, k);
        for (int e = 0; e < ne; ++e) {
            for (int j = 0; j < rule; ++j) a[e] += g.w[j] * 2.0 * g.x[j] * body(j, rule + e);
            // The lobe's closed-form albedo to 1 % of the kernels' tolerance: it is exact next to the body.
            a[e] += m_rough->lobe_albedo(mus[e], std::clamp(0.01 * m_rough_tolerance, 1e-9, 1e-6));
        }
        return a;
    }
    }
    throw InternalError("reflection: unknown top");
}

double Reflection::mirror(double mu_i) const {
    const double mus[1] = {mu_i};
    return mirror(std::span<const double>(mus)).front();
}

std::vector<double> Reflection::mirror(std::span<const double> mu_i) const {
    if (m_setup.stack.top != Top::Smooth) return std::vector<double>(mu_i.size(), 0.0);
    if (m_setup.layers.size() == 1 && m_setup.semi_infinite()) {
        // A half-space reflects nothing specularly from below (its Reflector's spec is zero), so
        // the mirror is the interface's own Fresnel reflectance (add_interface: f_e + t^2 0).
        std::vector<double> out;
        for (double mu : mu_i) out.push_back(fresnel(clamp_mu(mu), 1.0, m_setup.layers.front().index));
        return out;
    }
    // In blocks: external() also builds the BRDF between every two of its cosines, which grows as
    // their square and is not needed here.
    constexpr std::size_t block = 64;
    std::vector<double> out;
    for (std::size_t first = 0; first < mu_i.size(); first += block) {
        std::vector<double> mus;
        for (std::size_t k = first; k < std::min(mu_i.size(), first + block); ++k) mus.push_back(clamp_mu(mu_i[k]));
        const std::vector<double> spec = external(0, mus).spec;
        out.insert(out.end(), spec.begin(), spec.end());
    }
    return out;
}

} // namespace brdf::rte
