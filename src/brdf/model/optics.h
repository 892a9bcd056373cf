#pragma once
// Bulk scattering properties of a material at one wavelength: Lorenz-Mie per pigment, mixed by
// number density in the binder (independent scattering; Chen et al., section 3; Hansen and Travis
// 1974 for the size averages). The result is what the radiative-transfer solve needs: the
// single-scattering albedo and the Legendre coefficients of the mixed phase function.

#include <brdf/material/spec.h>
#include <brdf/rte/phase.h>

#include <vector>

namespace brdf::model {

struct PigmentOptics {
    double albedo = 0.0, g = 0.0;
    double csca_um2 = 0.0, cext_um2 = 0.0;
    double number_density_um3 = 0.0; ///< particles per um^3 = volume fraction / mean volume
    int legendre = 0, radius_nodes = 0;
    double mie_error = 0.0;
};

struct SpectralOptics {
    double wavelength_nm = 0.0;
    double binder_index = 1.0;        ///< real part; 1 for an analytic medium without an index
    rte::Medium medium;               ///< mixed albedo and phase function
    double g = 0.0;                   ///< asymmetry of the mixed phase function
    double scattering_per_um = 0.0;   ///< 0 for an analytic medium
    double extinction_per_um = 0.0;
    std::vector<PigmentOptics> pigments;
};

/// Optics of a particulate material (binder + pigments) at one vacuum wavelength. `mie_tolerance`
/// is the relative accuracy of the size-distribution integrals.
SpectralOptics particulate_optics(const material::MaterialSpec& spec, double wavelength_nm, double mie_tolerance);

/// Legendre coefficients of an analytic phase function; Henyey-Greenstein is truncated where its
/// coefficients (2l + 1) g^l fall below `tolerance` of beta_0.
std::vector<double> analytic_phase(const material::MediumSpec& medium, double tolerance);

} // namespace brdf::model
