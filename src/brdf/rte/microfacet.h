#pragma once
// Names shared by the rough air/binder interface (rte/rough_interface.h) and the layer stack
// (rte/stack.h): the microfacet distribution and the shadowing-masking form of a rough surface.

namespace brdf::rte {

/// Normal distribution of the microfacets (Walter et al. 2007): GGX (Trowbridge-Reitz) or Beckmann.
enum class Microfacet { Ggx, Beckmann };

/// Smith shadowing-masking: height-correlated (Heitz 2014, the default) or separable G1(wi) G1(wo)
/// (what Mitsuba 3's roughdielectric uses; offered so that Monte Carlo comparisons are exact).
enum class Masking { HeightCorrelated, Separable };

/// A rough dielectric surface: roughness alpha (Walter et al. 2007), 0.001 <= alpha <= 1.
struct RoughSurface {
    double alpha = 0.1;
    Microfacet distribution = Microfacet::Ggx;
    Masking masking = Masking::HeightCorrelated;
    bool operator==(const RoughSurface&) const = default;
};

} // namespace brdf::rte
