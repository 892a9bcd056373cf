#pragma once
// Particle size distributions of Hansen and Travis (1974), "Light scattering in planetary
// atmospheres", Space Sci. Rev. 16, 527 (H&T), as also used by Mishchenko, Travis and Lacis (2002),
// "Scattering, Absorption, and Emission of Light by Small Particles" (Cambridge), and the effective
// radius and variance H&T define:
//   r_eff = int r^3 n dr / int r^2 n dr,   v_eff = int (r - r_eff)^2 r^2 n dr / (r_eff^2 int r^2 n dr).
// Radii are in micrometres. number_density() is normalised to int_0^inf n dr = 1 (the untruncated
// distribution), so averages over it are per particle; mean_volume_um3() and mean_area_um2() are the
// exact (untruncated) moments.
//
// Integration range: [r_min, r_max] is where the ensemble integrates. For the power law it is the
// support [r1, r2]. The gamma and log-normal distributions have infinite tails; they are cut where
// the neglected part of the cross-section-weighted (r^2 n) distribution below r_min and of the
// volume-weighted (r^3 n) distribution above r_max are each tail_fraction = 5e-9 (1e-8 together).
// Cross sections grow no faster than r^2 at large r (Qext -> 2) and much faster than r^2 at small r
// (Rayleigh: Csca ~ r^6, Cabs ~ r^3), so the neglected part of any ensemble cross section is below
// 1e-8 relative.

#include <string>
#include <vector>

namespace brdf::mie {

enum class DistributionKind { Monodisperse, PowerLaw, Gamma, Lognormal };

const char* to_string(DistributionKind kind);

/// The tail fraction cut off at each end of the gamma and log-normal distributions (see above).
inline constexpr double tail_fraction = 5e-9;

class SizeDistribution {
public:
    DistributionKind kind() const { return m_kind; }

    /// Number density n(r) in 1/um, normalised to int_0^inf n dr = 1 (0 outside the support). Not
    /// defined for the monodisperse case (a delta function): returns 0 there.
    double number_density(double r_um) const;

    /// The radius range the ensemble integrates over, um. r_min == r_max for monodisperse.
    double r_min_um() const { return m_r_min; }
    double r_max_um() const { return m_r_max; }

    /// Effective radius (um) and variance of the untruncated distribution (H&T).
    double r_eff_um() const { return m_r_eff; }
    double v_eff() const { return m_v_eff; }

    /// Number-weighted mean particle volume <4/3 pi r^3>, um^3: turns a volume fraction into a
    /// number density (N = f_v / <V>).
    double mean_volume_um3() const { return m_mean_volume; }
    /// Number-weighted mean geometric cross section <pi r^2>, um^2.
    double mean_area_um2() const { return m_mean_area; }

    /// A short description for messages and reports, e.g. "gamma(r_eff = 0.4 um, v_eff = 0.1)".
    std::string describe() const;

    /// The parameters as given: radius_um / r_eff_um / r_g_um and 0 / v_eff / v_eff / sigma_g.
    double parameter1() const { return m_p1; }
    double parameter2() const { return m_p2; }

    friend SizeDistribution monodisperse(double radius_um);
    friend SizeDistribution power_law(double r_eff_um, double v_eff);
    friend SizeDistribution gamma(double r_eff_um, double v_eff);
    friend SizeDistribution lognormal(double r_g_um, double sigma_g);

private:
    SizeDistribution() = default;

    DistributionKind m_kind = DistributionKind::Monodisperse;
    double m_p1 = 0.0, m_p2 = 0.0;
    double m_r_min = 0.0, m_r_max = 0.0;
    double m_r_eff = 0.0, m_v_eff = 0.0;
    double m_mean_volume = 0.0, m_mean_area = 0.0;
    // Shape constants: power law: log normalisation; gamma: exponent alpha, scale a b, log
    // normalisation; log-normal: ln r_g, ln sigma_g, normalisation.
    double m_c0 = 0.0, m_c1 = 0.0, m_c2 = 0.0;
};

/// The keys of a distribution's two parameters as a spec spells them (docs/spec.md): "radius_um" and
/// "" (monodisperse has one), "r_eff_um" and "v_eff" (power law, gamma), "r_g_um" and "sigma_g".
const char* parameter1_key(DistributionKind kind);
const char* parameter2_key(DistributionKind kind);

/// One fault of a parameter set, e.g. {"v_eff", "must be in [1e-06, 0.5) for the gamma
/// distribution (it is not normalisable at 0.5) (got 0.6)"}.
struct ParameterProblem {
    std::string key;   ///< parameter1_key or parameter2_key of the distribution
    std::string fault; ///< what is wrong, ending "(got VALUE)"
    /// "KEY: FAULT", e.g. "v_eff: must be in [1e-06, 0.5) ... (got 0.6)".
    std::string text() const { return key + ": " + fault; }
};

/// Every problem of the parameters (parameter1(), parameter2() of the distribution they would
/// make; parameter2 is ignored for monodisperse), in parameter order; empty when the constructor
/// below accepts them. The constructors throw InputError("KIND: " + the problems' text(), joined
/// by "; "), so a spec parser and a direct caller see the same words.
std::vector<ParameterProblem> parameter_problems(DistributionKind kind, double parameter1,
                                                 double parameter2 = 0.0);

/// All particles of one radius, um (> 0).
SizeDistribution monodisperse(double radius_um);

/// H&T power law: n(r) ~ r^-3 on [r1, r2], with r_eff = (r2 - r1) / ln(r2 / r1) and
/// r1 + r2 = 2 r_eff (1 + v_eff); r1 from a bracketing root finder. r_eff_um > 0, 0 < v_eff <= 2
/// (beyond 2 the smallest radius falls below 1.5% of r_eff: use a log-normal instead).
SizeDistribution power_law(double r_eff_um, double v_eff);

/// H&T gamma distribution: n(r) ~ r^((1 - 3b)/b) exp(-r / (a b)) with a = r_eff, b = v_eff. r_eff_um > 0,
/// 0 < v_eff < 0.5 (the number density is not normalisable at b >= 1/2); v_eff >= 1e-6.
SizeDistribution gamma(double r_eff_um, double v_eff);

/// H&T log-normal distribution: n(r) ~ (1/r) exp(-(ln r - ln r_g)^2 / (2 ln^2 sigma_g)), with
/// r_eff = r_g exp(2.5 ln^2 sigma_g) and v_eff = exp(ln^2 sigma_g) - 1. r_g_um > 0,
/// 1 < sigma_g <= 3 (sigma_g = 3 already spans six decades of radius); sigma_g >= 1.001.
SizeDistribution lognormal(double r_g_um, double sigma_g);

} // namespace brdf::mie
