#pragma once
// The reflection of a semi-infinite medium, optionally under a smooth interface: set up the per-order
// problems (delta-M, streams, order truncation), solve them in one batch (CPU reference or OpenCL),
// then evaluate the BRDF at any angles through the equation itself (Nystrom interpolation, the
// "source-function integration" of DISORT) with the exact single scattering added back (TMS).
//
// Angles: mu = cosines of the zenith angles in air; phi is the graphics azimuth of docs/design.md
// (phi = 0 on the light's side, pi on the mirror side). The radiative-transfer azimuth of the equation
// is phi + pi, hence the (-1)^m of every Fourier sum here. BRDF = R / pi.

#include <brdf/core/linalg.h>
#include <brdf/rte/interface.h>
#include <brdf/rte/order_solver.h>
#include <brdf/rte/phase.h>
#include <brdf/rte/streams.h>

#include <span>
#include <vector>

namespace brdf::rte {

struct ReflectionSettings {
    int streams = 32;              ///< Gauss nodes in mu on (0, 1)
    double order_tolerance = 1e-5; ///< drop Fourier orders whose phase component is below this
    Method method = Method::Fast;
    SolveControl control;
};

/// Everything needed before the solve.
struct ReflectionSetup {
    Medium medium;       ///< as given (full phase function)
    DeltaM truncated;    ///< delta-M scaled medium the orders are solved for
    Interface interface;
    Streams streams;
    int orders = 1;      ///< m = 0 .. orders - 1
};

ReflectionSetup setup_reflection(const Medium& medium, const Interface& interface,
                                 const ReflectionSettings& settings);
std::vector<OrderProblem> order_problems(const ReflectionSetup& setup);

/// Solves a batch of order problems (possibly from many media). The OpenCL backend lives in
/// rte/cl_solver.h; this is the CPU reference, one problem after another on `threads` threads.
std::vector<OrderSolution> solve_orders_cpu(std::span<const OrderProblem> problems, Method method,
                                            const SolveControl& control, int threads = 1);

/// R^m of the multiply scattered light (single scattering of the truncated phase function removed)
/// at internal cosines u[a] (rows, outgoing) x u[b] (columns, incident), including the interface's
/// internal reflections; one E x E matrix per order.
struct OrderGrid {
    std::vector<double> u;
    std::vector<Matrix> orders;
};

class Reflection {
public:
    Reflection(ReflectionSetup setup, std::vector<OrderSolution> solutions);

    const ReflectionSetup& setup() const { return m_setup; }
    const std::vector<OrderSolution>& solutions() const { return m_solutions; }

    /// BRDF (1/sr) of the diffuse part; the mirror reflection of a smooth interface is not included.
    double brdf(double mu_i, double mu_o, double phi) const;
    /// Directional-hemispherical reflectance of the diffuse part (from the delta-M solution, which
    /// conserves energy exactly on the streams).
    double albedo(double mu_i) const;
    /// Reflectance of the mirror (specular delta) at the interface; 0 without one.
    double mirror(double mu_i) const;

    /// The multiply scattered part on a set of cosines in air, for tables: row a = outgoing.
    OrderGrid order_grid(std::span<const double> mu_air) const;
    /// Single scattering with the full phase function at internal cosines (no interface factors),
    /// with the TMS albedo below.
    double single_scattering(double u_o, double u_i, double phi) const;
    /// omega / (1 - f omega): the albedo of the exact single-scattering term under delta-M (TMS).
    double single_scattering_albedo() const;
    /// T(mu_o) T(mu_i) / n^2 with 1/pi: turns internal R into the external BRDF.
    double transmission_factor(double mu_o, double mu_i) const;
    /// Internal cosine for a cosine in air (identity without an interface).
    double inside(double mu_air) const;

private:
    /// R^m(u_e, mu_k) for internal cosines u_e (rows) and the streams (columns), by Nystrom.
    Matrix half_node(int m, std::span<const double> u) const;

    ReflectionSetup m_setup;
    std::vector<OrderSolution> m_solutions;
    std::vector<Matrix> m_gain;        ///< per order: I - (w/2) P+ W - w M X W P- W (Nystrom kernel)
    std::vector<Matrix> m_minus_w;     ///< per order: P- W, for the quadratic term of the evaluation
    std::vector<LuFactor> m_bounce;    ///< per order: I - X Q, Q = diag(2 w mu F) (interface only)
};

} // namespace brdf::rte
