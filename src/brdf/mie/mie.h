#pragma once
// Lorenz-Mie theory for a homogeneous sphere: series coefficients a_n, b_n, efficiencies, amplitude
// functions S1, S2 and the Legendre moments of the phase function.
//
// Conventions (Bohren and Huffman 1983, "Absorption and Scattering of Light by Small Particles",
// hereafter B&H): time dependence exp(-i omega t), relative refractive index m = n + ik with the
// absorption k >= 0, size parameter x = 2 pi r n_h / lambda (lambda in vacuum, n_h the host index; see
// ensemble.h for the physical units). Wiscombe's MIEV0 (NCAR/TN-140+STR, 1980) uses m = n - ik; its
// complex results are the complex conjugates of ours, its real results are identical.
//
// Accuracy (tests/mie, docs/mie.md): Qsca and g to ~1e-14 relative for x up to 1e3 and ~3e-12 at
// x = 1e4; Qabs, Qext of absorbing spheres to ~1e-9, the amplitudes to ~1e-9 of |S(0)|: what limits
// these is the truncation at Wiscombe's N (a 40-term-longer series is the reference), not rounding.
// Qabs is computed without cancellation, so Qext == Qsca exactly for real m and Qabs >= 0 always.

#include <complex>
#include <span>
#include <vector>

namespace brdf::mie {

/// Largest size parameter accepted by coefficients(), efficiencies() and amplitudes(); above it
/// LimitError (the series needs more than 1e5 terms and geometric optics is the better tool).
inline constexpr double max_size_parameter = 1e5;
/// Largest size parameter for the Legendre moments (sphere(), legendre_coefficients()): the exact
/// angular quadrature needs 2N + 2 nodes and O(N^2) work, 2 s at x = 5e4. Above it LimitError.
inline constexpr double max_legendre_size_parameter = 5e4;
/// Smallest size parameter accepted (InputError below it). Far below the Rayleigh regime; it only
/// keeps chi_n(x) ~ (2n-1)!! / x^(n+1) and x^-2 far from overflow.
inline constexpr double min_size_parameter = 1e-12;

/// Number of series terms, Wiscombe (1980): N = x + 4.05 x^(1/3) + 2, rounded down (as BHMIE
/// does). x > 0.
int series_length(double x);

/// Checks a relative index and size parameter; throws InputError (NaN, x <= 0, Re m <= 0,
/// Im m < 0, x below min_size_parameter) or LimitError (x > max_size_parameter). `what` prefixes
/// the message.
void validate(std::complex<double> m, double x, const char* what = "Mie");

/// The external series coefficients of one sphere (B&H 4.53, 4.88), n = 1 .. N stored at [n - 1].
struct Coefficients {
    std::complex<double> m; ///< relative index, Re m > 0, Im m >= 0
    double x = 0.0;         ///< size parameter
    std::vector<std::complex<double>> a; ///< a_n
    std::vector<std::complex<double>> b; ///< b_n
    /// Per-term absorption Re(a_n) - |a_n|^2 + Re(b_n) - |b_n|^2, computed in a cancellation-free
    /// form (see mie.cpp); >= 0, exactly 0 for real m.
    std::vector<double> absorption;
    int size() const { return static_cast<int>(a.size()); }
};

/// Computes a_n, b_n for n = 1 .. series_length(x). Validates m and x (see validate()).
Coefficients coefficients(std::complex<double> m, double x);
/// Working storage of coefficients() (the log-derivative series E_n of m x and x), kept by a caller
/// that computes many spheres: the size-distribution loops call it per radius, 10^4-10^5 times per
/// material. Held by the caller rather than in thread_local storage: a thread's first use of a
/// thread_local with a destructor registers it under glibc's loader lock, which a dlopen in another
/// thread (PoCL loading its compiler: ~40 ms) holds throughout (docs/mie.md, "Scratch storage").
struct SeriesWork {
    std::vector<std::complex<double>> ez;
    std::vector<double> ez_real, ex;
    std::vector<double> ez_lanes, ex_lanes; ///< eight spheres' E_n, lane by lane
};

/// Same, reusing the storage of `out` and of `work`.
void coefficients(std::complex<double> m, double x, Coefficients& out, SeriesWork& work);
/// Same, reusing the storage of `out`.
void coefficients(std::complex<double> m, double x, Coefficients& out);
/// coefficients(m, x[i], out[i], work) for every i (x and out the same size), the same bits. A real
/// index runs eight spheres at a time, one to a lane of a vector: the log-derivative recurrences are
/// chains of divisions, each waiting for the last, and eight chains side by side overlap.
void coefficients(std::complex<double> m, std::span<const double> x, std::span<Coefficients> out, SeriesWork& work);

/// Efficiencies (cross section / pi r^2) and asymmetry parameter.
struct Efficiencies {
    double qext = 0.0;  ///< extinction, = qsca + qabs
    double qsca = 0.0;  ///< scattering, B&H 4.61
    double qabs = 0.0;  ///< absorption, >= 0, exactly 0 for real m
    double qback = 0.0; ///< backscattering (radar) efficiency, B&H p. 122: |sum (2n+1)(-1)^n (a_n - b_n)|^2 / x^2
    double g = 0.0;     ///< asymmetry parameter <cos theta>, B&H p. 120
};

Efficiencies efficiencies(const Coefficients& c);

/// coefficients(m, x, out, work) and efficiencies(out[i]) into q[i] for every i (x, out and q the
/// same size), the same bits. A real index sums the efficiencies in the series lanes as their terms
/// are made, where the terms are still in registers and each order's factors are divided once for
/// the spheres of a vector.
void coefficients(std::complex<double> m, std::span<const double> x, std::span<Coefficients> out,
                  std::span<Efficiencies> q, SeriesWork& work);

/// Scattering amplitudes S1 (perpendicular) and S2 (parallel), B&H 4.74, dimensionless (B&H
/// normalisation: S1(0) = S2(0) = x^2 Qext / 4 + i ...).
struct Amplitudes {
    std::complex<double> s1;
    std::complex<double> s2;
};

/// S1, S2 at the scattering-angle cosine mu in [-1, 1].
Amplitudes amplitudes(const Coefficients& c, double mu);

/// How many Legendre moments to keep.
struct LegendreOptions {
    /// Trailing moments with |beta_l| <= tolerance are dropped: the series is cut after the last l
    /// with |beta_l| > tolerance. Relative to beta_0 = 1; >= 0.
    double tolerance = 1e-12;
    /// At most this many moments (beta_0 .. beta_{max_terms-1}); 0 means no cap.
    int max_terms = 0;
};

/// Legendre moments beta_l of the phase function p(mu) = sum_l beta_l P_l(mu), normalised so that
/// (1/2) int_{-1}^{1} p dmu = beta_0 = 1 and beta_1 = 3 g. Exact up to rounding: see
/// phase_function.h. Throws LimitError for x > max_legendre_size_parameter.
std::vector<double> legendre_coefficients(const Coefficients& c, const LegendreOptions& options = {});

/// Everything the radiative-transfer side needs from one sphere.
struct Sphere {
    std::complex<double> m;
    double x = 0.0;
    Efficiencies q;
    double albedo = 0.0;         ///< single-scattering albedo qsca / qext
    std::vector<double> legendre; ///< beta_l, beta_0 = 1
    int terms = 0;               ///< series length N
};

Sphere sphere(std::complex<double> m, double x, const LegendreOptions& options = {});

} // namespace brdf::mie
