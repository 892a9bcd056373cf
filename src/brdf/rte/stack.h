#pragma once
// A material as the radiative-transfer solve sees it at one wavelength: a stack of homogeneous layers
// (top first; each finite, or the last semi-infinite) with their refractive indices, over a
// Lambertian substrate or nothing, under an air/top interface that is absent, smooth or rough.
// setup_stack chooses each layer's streams, its delta-M truncation and the Fourier orders; the
// solve (reflection.h) then needs, per order, Ambartsumian's equation for a semi-infinite last
// layer and the slab solution (slab.h) for every finite one.
//
// Streams of a stack: n sin(theta) is conserved across smooth interfaces, so the hemisphere of
// every medium is split at s = n sin(theta) equal to each index that occurs (and 1, for air), and
// each piece gets one Gauss rule, shared by every medium that contains it (docs/physics.md
// section 9): interfaces then map streams onto streams exactly. A piece's rule is Gauss in the
// cosine of the lowest-index layer that contains it, where the piece reaches that layer's horizon.
// For one layer under a smooth interface this is the split of the interface at the critical cosine
// (streams.h), unchanged.

#include <brdf/rte/microfacet.h>
#include <brdf/rte/order_solver.h>
#include <brdf/rte/phase.h>
#include <brdf/rte/streams.h>

#include <limits>
#include <vector>

namespace brdf::rte {

struct Layer {
    Medium medium;                                        ///< full phase function
    double tau = std::numeric_limits<double>::infinity(); ///< optical thickness; infinite: semi-infinite
    double index = 1.0;                                   ///< real refractive index, >= 1
    bool finite() const { return tau < std::numeric_limits<double>::infinity(); }
};

enum class Top { None, Smooth, Rough };

struct Stack {
    Top top = Top::None;          ///< None: no interface (every index is taken as 1)
    RoughSurface rough;           ///< for Top::Rough
    std::vector<Layer> layers;    ///< top first, at least one
    double substrate_albedo = 0.0; ///< Lambertian under a finite last layer, in [0, 1]
};

/// A single semi-infinite medium under a smooth interface of index n (n = 1: no interface).
Stack half_space(const Medium& medium, double n = 1.0);

struct StackSettings {
    int streams = 32;              ///< nodes per hemisphere of the top layer (half per piece when split)
    double order_tolerance = 1e-5; ///< drop Fourier orders whose phase component is below this
    int max_orders = 0;            ///< at most this many Fourier orders (0: what the phase functions need)
};

/// One Gauss piece of n sin(theta), shared by the media that contain it.
struct StreamPiece {
    double s_lo = 0.0, s_hi = 0.0;     ///< n sin(theta) range
    double ref_index = 1.0;            ///< the rule is Gauss in the cosine of this medium
    std::vector<double> ref_mu, ref_w; ///< its nodes and weights there (ascending in mu)
};

struct LayerSetup {
    Layer layer;        ///< as given (tau unscaled)
    DeltaM truncated;   ///< the delta-M scaled medium the orders are solved for
    double tau = 0.0;   ///< delta-M scaled optical thickness (1 - omega f) tau; infinite when semi-infinite
    double index = 1.0; ///< the index used (1 under Top::None)
    Streams streams;
    std::vector<double> s; ///< n sin(theta) of each stream
    /// Per stream: the stream of the layer below with the same s, or -1 (none: totally reflected).
    std::vector<int> below_of;
    /// Per stream: its piece (StackSetup::pieces) and its node in that piece's rule.
    std::vector<int> piece_of, node_of;
    int orders = 1; ///< Fourier orders in which this layer scatters
};

struct StackSetup {
    Stack stack;
    std::vector<LayerSetup> layers;
    std::vector<StreamPiece> pieces;
    int orders = 1; ///< m = 0 .. orders - 1 (the most any layer needs; see setup_stack for a rough top)
    double order_tolerance = 1e-5; ///< as StackSettings (also the rough top's kernel tolerance)
    bool semi_infinite() const { return !layers.back().layer.finite(); }
};

/// Validates (InputError naming the fault) and sets the stack up.
StackSetup setup_stack(const Stack& stack, const StackSettings& settings);

/// Reflectance of a smooth interface between media of indices n_a and n_b at the nodes of `piece`
/// (which both media contain), for product integration: F~_k = int F(mu) l_k(mu) 2 mu dmu / q_k
/// with l_k the piece's Lagrange basis, so that sum_k q_k F~_k g(mu_k) is the exact integral of
/// F g 2 mu dmu for every polynomial g of the piece's degree. Plain F(mu_k) would meet Fresnel's
/// square-root onset at the critical angle with Gauss nodes: 4.6e-5 of error in the internal
/// diffuse reflectance of n = 1.5 with 16 nodes, instead of rounding. Symmetric in (n_a, n_b).
std::vector<double> interface_reflectance(const StreamPiece& piece, double n_a, double n_b);

/// Ambartsumian problems of the semi-infinite last layer, m = 0 .. orders - 1 (empty for a film).
std::vector<OrderProblem> half_space_problems(const StackSetup& setup);
/// Order problems of finite layer `layer` (m = 0 .. orders - 1), for the slab solution.
std::vector<OrderProblem> layer_problems(const StackSetup& setup, int layer);

} // namespace brdf::rte
