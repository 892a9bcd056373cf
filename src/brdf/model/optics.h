#pragma once
// Bulk scattering properties of a material at one wavelength, layer by layer: Lorenz-Mie per pigment,
// mixed by number density in the binder (independent scattering; Chen et al., section 3; Hansen and
// Travis 1974 for the size averages), the binder's own absorption, and each finite layer's optical
// depth. The result is what the radiative-transfer solve needs (rte::Stack): per layer the
// single-scattering albedo, the Legendre coefficients of the mixed phase function, the optical
// thickness and the refractive index.

#include <brdf/material/spec.h>
#include <brdf/mie/ensemble.h>
#include <brdf/rte/phase.h>
#include <brdf/rte/stack.h>

#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace brdf::model {

struct PigmentOptics {
    double albedo = 0.0, g = 0.0;
    double csca_um2 = 0.0, cext_um2 = 0.0;
    double number_density_um3 = 0.0; ///< particles per um^3 = volume fraction / mean volume
    int legendre = 0, radius_nodes = 0;
    double mie_error = 0.0;
};

/// One layer at one wavelength (or one colour channel of an analytic medium).
struct LayerOptics {
    double index = 1.0;              ///< real index of the binder or medium
    bool index_from_above = false;   ///< an analytic medium given without an index: matched to the layer above
    rte::Medium medium;              ///< mixed albedo and phase function; omega 0 for a clear binder
    double g = 0.0;                  ///< asymmetry of the mixed phase function
    double scattering_per_um = 0.0;  ///< 0 for an analytic medium
    double extinction_per_um = 0.0;  ///< 0 for an analytic medium
    /// Extinction times thickness; infinite for a semi-infinite layer.
    double optical_depth = std::numeric_limits<double>::infinity();
    std::vector<PigmentOptics> pigments;
    bool finite() const { return optical_depth < std::numeric_limits<double>::infinity(); }
};

struct SpectralOptics {
    double wavelength_nm = 0.0;      ///< 0 for a channel of an analytic material
    std::vector<LayerOptics> layers; ///< top first, as in the spec
    double substrate_albedo = 0.0;   ///< Lambertian, under a finite last layer
    const LayerOptics& top() const { return layers.front(); }
};

/// The optics of one layer of particles in a binder (or a clear binder film) at one wavelength.
/// thickness_um absent: semi-infinite. `mie`: the Lorenz-Mie integration's accuracy and what of the
/// phase functions the tables read (its tolerance clamped to [1e-8, 0.1]; its progress unused).
/// `heartbeat`, when given, is called while a long Lorenz-Mie integration runs
/// (mie::EnsembleOptions::progress), from this thread; it must not throw.
LayerOptics particulate_layer_optics(const material::LayerSpec& layer, double wavelength_nm,
                                     const mie::EnsembleOptions& mie,
                                     const std::string& who, const std::function<void()>& heartbeat = {});

/// Every layer of a spec at one wavelength of its spectrum. An analytic medium layer in such a stack
/// takes its grey albedo (the spec refuses coloured ones there: solve_material); the substrate's
/// albedo is that of `substrate_channel` (0, 1, 2; all equal for a grey substrate). `heartbeat`:
/// as particulate_layer_optics'.
SpectralOptics spectral_optics(const material::MaterialSpec& spec, double wavelength_nm, const mie::EnsembleOptions& mie,
                               int substrate_channel = 0, const std::function<void()>& heartbeat = {});

/// Every layer of a spec made only of analytic media, for colour channel c (0, 1, 2).
SpectralOptics analytic_optics(const material::MaterialSpec& spec, int channel, double order_tolerance);

/// Legendre coefficients of an analytic medium's phase function (Henyey-Greenstein truncated where
/// its terms fall below `tolerance`).
std::vector<double> analytic_phase(const material::MediumSpec& medium, double tolerance);

/// The stack the radiative-transfer solve sees: the optics under the spec's surface. Indices: a medium
/// layer without one is index-matched to the layer above; with surface "none" the ambient is
/// index-matched to the top layer (every index relative to it; a single layer then has none at all).
rte::Stack make_stack(const SpectralOptics& optics, const material::SurfaceSpec& surface);

} // namespace brdf::model
