#pragma once
// The reflection of a layer stack (stack.h) at one wavelength: per Fourier order, the semi-infinite
// last layer by Ambartsumian's equation (order_solver.h, solved in one batch on the CPU or OpenCL),
// every finite layer by the slab solution (slab.h), and everything combined by the adding equations
// (adding.h) under the top interface. Off the streams the BRDF is exact: the half-space by Nystrom
// interpolation through Ambartsumian's equation (the "source-function integration" of DISORT), the
// slabs by the same integration of their eigen solution. The single scattering of the full phase
// function is added back per direction (TMS, Nakajima and Tanaka 1988).
//
// Angles: mu = cosines of the zenith angles in air; phi is the graphics azimuth of docs/design.md
// (phi = 0 on the light's side, pi on the mirror side). The radiative-transfer azimuth of the equation
// is phi + pi, hence the (-1)^m of every Fourier sum here. BRDF = R / pi.

#include <brdf/core/linalg.h>
#include <brdf/rte/adding.h>
#include <brdf/rte/interface.h>
#include <brdf/rte/order_solver.h>
#include <brdf/rte/phase.h>
#include <brdf/rte/rough_family.h>
#include <brdf/rte/rough_interface.h>
#include <brdf/rte/slab.h>
#include <brdf/rte/stack.h>
#include <brdf/rte/streams.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

namespace brdf::rte {

struct ReflectionSettings {
    int streams = 32;              ///< Gauss nodes in mu on (0, 1)
    double order_tolerance = 1e-5; ///< drop Fourier orders whose phase component is below this
    /// At most this many Fourier orders (0: what the phase functions need); solve_material sets it
    /// from what the reflection of its probes needs (model::reflection_orders).
    int max_orders = 0;
    Method method = Method::Fast;
    SolveControl control;
};

/// A rough top's kernel quadrature tolerance for an order tolerance (Reflection::setup_rough).
double rough_kernel_tolerance(double order_tolerance);

/// A semi-infinite medium under a smooth interface of index interface.n (1: none), set up.
StackSetup setup_reflection(const Medium& medium, const Interface& interface, const ReflectionSettings& settings);
/// The stack set up with the solve settings' streams and order tolerance.
StackSetup setup_reflection(const Stack& stack, const ReflectionSettings& settings);
/// Ambartsumian problems of the semi-infinite last layer (half_space_problems).
std::vector<OrderProblem> order_problems(const StackSetup& setup);

/// Solves a batch of order problems (possibly from many media). The OpenCL backend lives in
/// rte/cl_solver.h; this is the CPU reference, one problem after another on `threads` threads.
std::vector<OrderSolution> solve_orders_cpu(std::span<const OrderProblem> problems, Method method,
                                            const SolveControl& control, int threads = 1);

/// Per Fourier order, R^m of the light that is not single scattered on its direct path (that part is
/// added exactly per direction by Reflection::single_scattering), between cosines in air: row a =
/// outgoing, column b = incident; interface factors included: BRDF = sum_m (2 - delta_m0) (-1)^m
/// orders[m](a, b) cos(m phi) / pi + single scattering + the rough surface's lobe.
struct OrderGrid {
    std::vector<double> mu; ///< the cosines in air (clamped away from 0)
    std::vector<Matrix> orders;
    /// Chebyshev nodes in sin^2 the orders were interpolated from (Reflection::order_grid under a
    /// smooth top; 0: none), and how many orders were (the others, whose coefficients had not
    /// fallen to rounding at the last nodes, are solved at every direction).
    int nodes = 0;
    int interpolated = 0;
};

/// What a per-direction single-scattering evaluation needs of layer k of a stack (table fills
/// tabulate it).
struct ScatteringLayer {
    const std::vector<double>* beta = nullptr; ///< full phase function
    double albedo = 0.0;                       ///< omega / (1 - f omega) (TMS)
    double tau = 0.0;                          ///< delta-M scaled thickness (infinite: half-space)
    double index = 1.0;
};
/// Layer k of a set-up stack for its single scattering.
ScatteringLayer scattering_layer(const StackSetup& setup, int k);
/// A_k(mu) / n_k: the factor of layer k's single scattering for an air cosine, one per direction
/// (Fresnel transmissions of every interface above it and the attenuation by the layers above).
double path_factor(const StackSetup& setup, int k, double mu_air);
/// The exact single scattering of the full phase functions on the direct paths of every layer of
/// a set-up stack, as R (BRDF = R / pi), with interface and attenuation factors; 0 under a rough
/// top (whose orders carry it). It needs the stack's set-up only, not its solution: a wavelength
/// whose multiple scattering is interpolated from its neighbours' gets its own exactly.
double single_scattering(const StackSetup& setup, double mu_o, double mu_i, double phi);
/// single_scattering at every pair of the cosines in air `mu` and every azimuth: entry
/// (i ne + o) np + p is (mu_o = mu[o], mu_i = mu[i], phi[p]), as in Reflection::brdf_grid.
std::vector<double> single_scattering_grid(const StackSetup& setup, std::span<const double> mu,
                                           std::span<const double> phi);

class Reflection {
public:
    /// `half_space`: the solutions of half_space_problems(setup), one per order (none for a film).
    /// The finite layers are solved here.
    /// `family`: a rough top's kernels shared with the material's other wavelengths
    /// (rough_family.h); used where it applies to this stack (its pieces and tolerance), else the
    /// kernels are computed for this stack alone.
    Reflection(StackSetup setup, std::vector<OrderSolution> half_space,
               std::shared_ptr<const RoughKernelFamily> family = nullptr);

    /// The same reflection with only its first `orders` Fourier orders (1 <= orders <= orders()):
    /// setup and solutions cut, the per-order operators built again.
    Reflection with_orders(int orders) const;

    const StackSetup& setup() const { return m_setup; }
    /// The Ambartsumian solutions of the semi-infinite layer (empty for a film).
    const std::vector<OrderSolution>& solutions() const { return m_half; }
    int orders() const { return m_setup.orders; }

    /// BRDF (1/sr) without the specular (delta) reflection of smooth interfaces. Under a rough top
    /// (Top::Rough) the whole BRDF: the first-surface lobe exactly (surface_lobe) plus the body.
    double brdf(double mu_i, double mu_o, double phi) const;
    /// brdf() at every (mu_i, mu_o, phi) of the cosines `mu` (both directions) and azimuths `phi`,
    /// from one order_grid: value [(i * mu.size() + o) * phi.size() + p]. Evaluating many
    /// directions, this costs about what one brdf() call does. Without `with_lobe`, a rough top's
    /// first-surface lobe is left out (the body alone: what the streams and orders decide). The
    /// orders are evaluated on up to `threads` cores (the same values on any number).
    std::vector<double> brdf_grid(std::span<const double> mu, std::span<const double> phi,
                                  bool with_lobe = true, int threads = 1) const;
    /// Directional-hemispherical reflectance of that BRDF (from the streams' own rule, for which the
    /// discrete equations conserve energy exactly). Under a rough top: of the WHOLE BRDF, lobe
    /// (its closed-form integral) plus body (order 0 on a 32-point Gauss rule in the air cosine);
    /// at albedo 1 it falls short of 1 by the microfacet model's single-scattering loss.
    double albedo(double mu_i) const;
    /// albedo() at each cosine, from one solve of the order-0 field for all of them.
    std::vector<double> albedo(std::span<const double> mu_i) const;
    /// Specular reflectance: the top interface's mirror plus every specular path through the stack
    /// (clear layers over index changes); 0 without a smooth top interface (and so under a rough one).
    double mirror(double mu_i) const;
    /// mirror() at each cosine, from one solve for all of them.
    std::vector<double> mirror(std::span<const double> mu_i) const;
    /// The rough top's first-surface reflection lobe f_reflect_air (1/sr; graphics azimuth), never
    /// Fourier expanded: tables add it per cell. 0 unless the top is rough.
    double surface_lobe(double mu_i, double mu_o, double phi) const;
    /// The rough top interface (null unless Top::Rough).
    const RoughInterface* rough_interface() const { return m_rough.get(); }

    /// The multiply scattered part on a set of cosines in air, for tables and evaluation. Under a
    /// rough top: the body (every order of the light that entered; its single scattering included,
    /// see order_grid in reflection.cpp), without the first-surface lobe. The orders are
    /// independent: `threads` > 1 computes them on that many threads (a material of one or two
    /// samples would leave cores idle otherwise).
    OrderGrid order_grid(std::span<const double> mu_air, int threads = 1) const;
    /// rte::single_scattering of this stack.
    double single_scattering(double mu_o, double mu_i, double phi) const {
        return rte::single_scattering(m_setup, mu_o, mu_i, phi);
    }
    double path_factor(int k, double mu_air) const { return rte::path_factor(m_setup, k, mu_air); }
    /// Cosine in layer k of a ray with cosine mu_air in air.
    double inside(int k, double mu_air) const;

private:
    /// `with_single` false: R^m without the first order of scattering between the two
    /// off-stream cosines (the term order_grid replaces by the exact one: TMS). Each off-stream
    /// direction's rows and columns divided by sin^sine_power of it (phase_components); only
    /// without the single scattering.
    Reflector half_space_reflector(int m, std::span<const double> u, bool with_single = true,
                                   int sine_power = 0) const;
    /// order_grid's orders of a half-space under a smooth top from Chebyshev nodes in sin^2 (false,
    /// and `grid` untouched, where the nodes would not be fewer than half the directions).
    bool interpolated_orders(std::span<const double> mu_air, int threads, OrderGrid& grid) const;
    Reflector substrate_reflector(int m, int n, int e) const;
    LayerOperators layer_operators(int k, int m, std::span<const double> u, bool with_t_ee) const;
    SmoothInterface interface_below(int k, std::span<const double> u) const;
    SmoothInterface top_interface(std::span<const double> mu_air) const;
    /// What layer 1 sees below its top at cosines u (of layer 1) for order m.
    Reflector below_top(int m, std::span<const double> mu_air, bool with_single = true) const;
    /// R^m between air cosines, specular part separate (`with_single`: half_space_reflector).
    Reflector external(int m, std::span<const double> mu_air, bool with_single = true) const;
    /// Rough top: the interface, its stream pieces and the body's Z Q per order (constructor).
    void setup_rough();
    /// Rough top: the interface kernels for air cosines `air` (from the family where there is one).
    InterfaceKernels rough_kernels(std::span<const double> air, int orders, bool internal_reflection) const;
    /// Rough top: the body's R^m between the air cosines of `kernels` (T_up Q (Z Q) T_down).
    Matrix rough_body(int m, const InterfaceKernels& kernels) const;
    /// The truncated single scattering on the direct paths that order_grid removes.
    double truncated_single_scattering(int m, int k, double mu_o_air, double mu_i_air) const;

    StackSetup m_setup;
    std::vector<OrderSolution> m_half;
    std::vector<std::vector<SlabOrder>> m_slabs; ///< per finite layer, per order
    /// Effective reflectances at the streams (interface_reflectance) of the top interface (per
    /// stream of layer 0) and of the interface under layer k (above: per stream of layer k; below:
    /// per stream of layer k + 1); 1 where the light is totally reflected.
    std::vector<double> m_top_f;
    std::vector<std::vector<double>> m_f_above, m_f_below;
    /// Rough top: the interface, the pieces of layer 0's streams and, per order,
    /// Z Q = (I - R_b Q R_in Q)^-1 R_b Q (R_b: what layer 0 sees below its top, R_in: the
    /// interface's internal reflection, Q = diag(q)), so that body = T_up Q (Z Q) T_down.
    std::shared_ptr<const RoughInterface> m_rough;
    StreamPieces m_rough_pieces;
    std::vector<Matrix> m_rough_zq;
    double m_rough_tolerance = 1e-6;
    std::shared_ptr<const RoughKernelFamily> m_family;
    /// Half-space, per order: the Nystrom half-node equation (M + u G) r = rhs(u), with
    /// G = I - (w/2) P+ W - w M X W P- W, reduced once for every direction u, and P- W; built on
    /// first use (thread-safe), shared by copies. The orders of a block are built together, their
    /// pencils reduced side by side (ShiftedPencil::batch).
    struct NystromOrders {
        static constexpr int block = 8;
        explicit NystromOrders(int orders);
        std::unique_ptr<std::mutex[]> building; ///< per block of orders
        std::unique_ptr<std::atomic<bool>[]> ready; ///< per order: pencil and minus_w are built
        std::vector<std::optional<ShiftedPencil>> pencil;
        std::vector<Matrix> minus_w;
    };
    struct NystromOrder {
        const ShiftedPencil& pencil;
        const Matrix& minus_w;
    };
    NystromOrder nystrom(int m) const;
    std::shared_ptr<NystromOrders> m_nystrom;
    /// Smooth top, per order: bounce_inverse, (I - B g)^-1 between the top's internal reflection
    /// and what lies below it on layer 0's streams. The same for every direction, and an inverse
    /// that dominated the gamut fit's probes when redone per call; built on first use
    /// (thread-safe), shared by copies.
    struct TopBounces {
        explicit TopBounces(int orders);
        std::vector<std::once_flag> once;
        std::vector<Matrix> inverse;
    };
    const Matrix& top_bounce(int m) const;
    std::shared_ptr<TopBounces> m_top_bounce;
};

} // namespace brdf::rte
