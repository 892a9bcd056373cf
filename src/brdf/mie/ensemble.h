#pragma once
// Optical properties of a size distribution of spheres in a host medium (a pigment in a binder):
// number-weighted mean cross sections, the averaged phase function and its Legendre moments.
//
// Physical units: the host has real index n_h; the sphere's relative index is m = n_particle / n_h and
// its size parameter x = 2 pi r n_h / lambda (the wavelength in the host, docs/physics.md section 1). The
// averaged phase function is sum C_sca(r) p_r / sum C_sca(r) over the number density (docs/physics.md
// section 2; Hansen and Travis 1974): the intensities |S1|^2 + |S2|^2 are accumulated with the number
// weights on one angular rule and projected onto Legendre polynomials once (phase_function.h).
//
// Radius integration (ensemble.cpp explains it in full), two rules:
// - panels: for Re m > 1 every sharp resonance ("whispering gallery" mode) is first counted and
//   located exactly (resonance.h) and gets a window graded onto it, however narrow, unless its whole
//   contribution is provably negligible; everything else is integrated by adaptive Gauss-Kronrod
//   panels until the estimated errors of <Cext>, <Csca>, <Cabs> and <Csca g> are below the
//   tolerance. Measured: doubling every panel's points changes the results by < 1e-7 at the default
//   tolerance 1e-6 for rutile (k = 0) across the visible.
// - nested: large spheres without sharp resonances (Re m <= 1, or absorbing, k/n >= 1e-2), x_max >=
//   nested_rule_min_size_parameter: one nested trapezoid rule in ln x (tanh-sinh for the power law's
//   finite support), its step halved until the averaged quantities themselves, cross sections and
//   every Legendre moment (or what the caller reads: EnsembleOptions::checked_moments), stop
//   changing within the tolerance. The averaged phase function needs far fewer radii than resolving
//   each sphere's structure would (matting agents: silica in acrylic, r_eff 40 um: 40 s -> 0.3 s per
//   wavelength); see docs/mie.md.

#include <brdf/mie/mie.h>
#include <brdf/mie/size_distribution.h>

#include <complex>
#include <functional>
#include <vector>

namespace brdf::mie {

/// Which radius rule integrates a size distribution (see the header comment).
enum class RadiusRule {
    automatic, ///< nested for large non-resonant spheres, panels otherwise
    panels,    ///< resonance windows + adaptive Gauss-Kronrod panels
    nested,    ///< nested trapezoid rule; refused (InputError) where sharp resonances need panels
};

/// Smallest x_max for which RadiusRule::automatic picks the nested rule: below it the panels are
/// cheap (the angular work per radius grows as N x_max) and 100x more accurate than asked.
inline constexpr double nested_rule_min_size_parameter = 200.0;

struct EnsembleOptions {
    /// Target relative accuracy of the radius integration for <Cext>, <Csca>, <Cabs> (each relative
    /// to itself), and absolute for g and the normalised Legendre moments chi_l = beta_l / (2l + 1)
    /// (|chi_l| <= 1); in (0, 0.1].
    double tolerance = 1e-6;
    /// Truncation of the averaged Legendre moments (mie.h).
    LegendreOptions legendre;
    /// Resolution multiplier for convergence studies: every final panel is split into this many
    /// equal panels (2 doubles the number of radius nodes everywhere). >= 1.
    int refinement = 1;
    /// Upper bound on radius nodes; LimitError beyond (the integration would not converge).
    int max_nodes = 400000;
    /// The radius rule (tests and studies force one; the default chooses).
    RadiusRule rule = RadiusRule::automatic;
    /// What the caller reads of the averaged phase function, for the nested rule's convergence test
    /// (docs/mie.md, "What the nested rule checks"). 0: every moment chi_l at `tolerance` (the
    /// default). > 0: chi_l for l < checked_moments at `tolerance`, and, where value_tolerance > 0,
    /// the phase function's values p(mu) (normalised to a mean of 1) at mu <= checked_cosine,
    /// absolute, at value_tolerance; the moments beyond are returned all the same, summed from the
    /// same radius nodes, but unchecked. A tabulated BRDF reads no more than that: the solver chi_l
    /// up to twice its streams (delta-M), the exact single scattering p beyond the refracted cone.
    /// The panels rule is not affected (its nodes follow the cross sections).
    int checked_moments = 0;
    double checked_cosine = -1.0;
    double value_tolerance = 0.0;
    /// Called with the completed fraction in [0, 1] (non-decreasing, 1 at the end) from the calling
    /// thread while a long integration runs; empty: not called. Must not throw.
    std::function<void(double fraction)> progress;
};

struct Ensemble {
    std::complex<double> particle_index; ///< n_particle, Im >= 0
    double medium_index = 0.0;           ///< n_h
    double wavelength_nm = 0.0;          ///< vacuum wavelength
    std::complex<double> m;              ///< relative index n_particle / n_h

    // Number-weighted means per particle, um^2.
    double cext_um2 = 0.0;
    double csca_um2 = 0.0;
    double cabs_um2 = 0.0;  ///< computed directly (not cext - csca), >= 0
    double cback_um2 = 0.0; ///< backscattering cross section
    // Cross-section-weighted efficiencies <C> / <pi r^2>.
    double qext = 0.0;
    double qsca = 0.0;
    double qabs = 0.0;
    double qback = 0.0;
    double g = 0.0;      ///< <Csca g> / <Csca>
    double albedo = 0.0; ///< <Csca> / <Cext>
    std::vector<double> legendre; ///< beta_l of the averaged phase function, beta_0 = 1

    double mean_volume_um3 = 0.0; ///< <4/3 pi r^3> of the distribution
    double mean_area_um2 = 0.0;   ///< <pi r^2>
    double r_min_um = 0.0, r_max_um = 0.0; ///< integration range
    double x_min = 0.0, x_max = 0.0;       ///< the same in size parameter
    int radius_nodes = 0;                  ///< Mie evaluations in the final quadrature
    int resonances = 0;                    ///< sharp resonances given their own windows
    RadiusRule rule = RadiusRule::panels;  ///< the rule that was used (never automatic)
    double error_estimate = 0.0;           ///< estimated relative error (pessimistic)
};

/// Mie properties of spheres of index `particle_index` (Re > 0, Im >= 0) distributed as `sizes` in a
/// host of real index `medium_index` (> 0), at the vacuum wavelength `wavelength_nm` (> 0). A
/// monodisperse distribution reduces exactly to sphere(m, x). Throws InputError for invalid values,
/// LimitError when the largest size parameter exceeds max_legendre_size_parameter or the node budget.
Ensemble ensemble(std::complex<double> particle_index, double medium_index, double wavelength_nm,
                  const SizeDistribution& sizes, const EnsembleOptions& options = {});

} // namespace brdf::mie
