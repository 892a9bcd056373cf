#pragma once
// The rough air/binder interface (issue 16): the single-scattering microfacet dielectric of Walter,
// Marschner, Li and Torrance 2007 ("Microfacet models for refraction through rough surfaces", EGSR):
// BRDF eq. 20 and BTDF eq. 21 with the generalised half vectors (eqs. 13 and 16), GGX (eq. 33) or
// Beckmann (eq. 25) normals, exact unpolarised Fresnel per microfacet (total internal reflection on
// the facet when light comes from inside), and Smith shadowing-masking either height-correlated
// (Heitz 2014, JCGT 3(2), "Understanding the masking-shadowing function in microfacet-based BRDFs":
// eq. 99 for reflection, and for transmission the Beta-function form of section 6.2, see
// rough_interface.cpp) or separable G1(wi) G1(wo) (eq. 98; Mitsuba 3's roughdielectric).
//
// Conventions. Air (index 1) is above, the binder (real index n > 1) below. Every cosine is the
// positive cosine of a direction's zenith angle in its own medium, mu in (0, 1]. The closed forms take
// the graphics azimuth of docs/design.md: directions point away from the surface, phi = phi_o - phi_i,
// and a narrow lobe (reflected or refracted) peaks at phi = pi. BSDFs are in 1/sr in radiance form
// (Walter's eq. 21 with its n^2), so L_o = int f L_i |cos| dw holds in each medium and
// f_transmit_up(mu_b, mu_a, phi) = f_transmit_down(mu_a, mu_b, phi) / n^2.
//
// Fourier orders. With phi_rt = phi + pi the azimuth difference of the propagation directions,
// f = sum_m (2 - delta_m0) f^m cos(m phi_rt) and K^m(mu_out, mu_in) = pi f^m = int_0^pi f cos(m phi_rt)
// dphi_rt, so that an outgoing intensity of order m is I(mu) = int K^m(mu, mu') I_in(mu') 2 mu' dmu'.
// Every K^m of a narrow lobe is positive. Stream-side arguments are product-integrated against the
// Lagrange basis of the Gauss piece holding each stream (see interface_kernels below).
//
// Quadrature. Each kernel integral is taken for one fixed direction as an integral over the outgoing
// cosine (outer) and, at each outgoing cosine, over the microfacet normals that send the fixed
// direction there (inner, parametrised by the azimuth). Along that curve of normals
// tan^2(theta_h) = (A + B sin^2(phi_rt/2)) / C exactly, so the inner nodes are placed by D(h) (a
// Moebius map that flattens the GGX core, geometric grading in its power-law tail); the outer nodes
// are graded around the specular cosine on the same scale (alpha). Every place where the integrand
// is not smooth sits at a node-interval boundary, in closed form: the Gauss pieces' edges, the facet
// total internal reflection, the end of the valid refraction pairs. See rough_interface.cpp.

#include <brdf/core/linalg.h>
#include <brdf/rte/microfacet.h>
#include <brdf/rte/streams.h>

#include <span>
#include <vector>

namespace brdf::rte {

class RoughInterface {
public:
    /// n: binder index, 1 < n <= 4; surface.alpha in [0.001, 1]. Throws InputError otherwise.
    RoughInterface(double n, RoughSurface surface);

    double index() const { return m_n; }
    const RoughSurface& surface() const { return m_surface; }
    /// Critical cosine inside: smooth-surface total internal reflection for mu_inside < critical().
    double critical() const { return m_critical; }

    /// Microfacet normal distribution D(h) in 1/sr for a normal at cosine cos_h in (0, 1] from the
    /// macro normal (normalised: int D cos_h dw_h = 1).
    double distribution(double cos_h) const;
    /// Smith Lambda for a direction at cosine mu in (0, 1] (exact for both distributions).
    double smith_lambda(double mu) const;
    /// Smith masking G1 = 1 / (1 + Lambda) (Walter eqs. 27 and 34).
    double smith_g1(double mu) const { return 1.0 / (1.0 + smith_lambda(mu)); }
    /// Shadowing-masking of a reflection (both directions on one side) and of a transmission.
    double masking_reflect(double mu_i, double mu_o) const;
    double masking_transmit(double mu_i, double mu_o) const;

    /// First-surface reflection in air (1/sr): light from air at mu_i, seen in air at mu_o.
    double f_reflect_air(double mu_i, double mu_o, double phi) const;
    /// Internal reflection inside the binder (1/sr), with facet total internal reflection.
    double f_reflect_inside(double mu_i, double mu_o, double phi) const;
    /// Transmission from air at mu_air into the binder at mu_binder (1/sr, radiance form).
    double f_transmit_down(double mu_air, double mu_binder, double phi) const;
    /// Transmission from the binder at mu_binder out to air at mu_air (1/sr, radiance form).
    double f_transmit_up(double mu_binder, double mu_air, double phi) const;

    /// Directional albedos: the fraction of the energy arriving at cosine mu that is reflected into
    /// and transmitted out of the side it came from (int f |cos_o| dw_o). Their sum is below 1 by the
    /// energy of the light the single-scattering model drops (masked after one bounce).
    struct Albedo {
        double reflected = 0.0;
        double transmitted = 0.0;
        double total() const { return reflected + transmitted; }
    };
    /// mu in (0, 1]; relative tolerance in [1e-13, 1e-2] (the quadrature is refined until two
    /// levels agree to it; NumericalError if the finest level does not).
    Albedo albedo_from_air(double mu, double tolerance = 1e-10) const;
    Albedo albedo_from_inside(double mu, double tolerance = 1e-10) const;
    /// albedo_from_air(mu, tolerance).reflected alone (the first-surface lobe's albedo), at half the cost.
    double lobe_albedo(double mu, double tolerance = 1e-10) const;

private:
    double m_n = 1.5;
    double m_critical = 0.0;
    RoughSurface m_surface;
};

/// Streams with the Gauss pieces they are made of: piece p holds nodes first[p] .. first[p+1] - 1,
/// all inside (edges[p], edges[p+1]); edges run from 0 to 1. Product integration uses the Lagrange
/// basis of each piece's nodes.
struct StreamPieces {
    Streams streams;
    std::vector<double> edges;
    std::vector<int> first;
    int pieces() const { return static_cast<int>(edges.size()) - 1; }
};

/// The pieces of split_gauss_streams(n_below, n_above, split) (the same nodes and weights).
StreamPieces split_gauss_pieces(int n_below, int n_above, double split);
/// Pieces of an existing stream set: edges ascending from 0 to 1, every piece holding at least one
/// node and no node on an edge. Throws InputError otherwise.
StreamPieces stream_pieces(const Streams& streams, std::span<const double> edges);

/// What a kernel computation measured: the quadrature level chosen, the largest difference between
/// that level and the next coarser one (relative to each direction's order-0 size), and sizes.
struct QuadratureReport {
    int level = 0;
    double estimated_error = 0.0;
    long long nodes = 0;         ///< integrand evaluations in the final pass
    int directions = 0;          ///< fixed directions integrated in the final pass
    int probe_directions = 0;    ///< directions of the convergence check
};

/// The interface per Fourier order m = 0 .. orders - 1 for the combination with the body's solution.
/// Stream k = the inside cosine mu_k, air direction e = the cosine air_mu[e]; q_k = 2 w_k mu_k.
struct InterfaceKernels {
    /// t_down[m](k, e) = [int K^m_down(mu, u_e) ell_k(mu) 2 mu dmu] / q_k: air u_e into stream k.
    std::vector<Matrix> t_down;
    /// t_up[m](e, k) = [int K^m_up(u_e, mu) ell_k(mu) 2 mu dmu] / q_k: stream k out to air u_e.
    std::vector<Matrix> t_up;
    /// r_inside[m](i, k) = [int int K^m_in(mu, mu') ell_i(mu) ell_k(mu') 2 mu dmu 2 mu' dmu'] /
    /// (q_i q_k): stream k -> stream i, facet total internal reflection included; symmetric.
    std::vector<Matrix> r_inside;
    QuadratureReport quadrature;
};

/// For any polynomial g of degree below the node count of each piece, sum_k X(., k) q_k g(mu_k) is
/// the exact integral of the kernel against g (and both-sided for r_inside). air_mu in (0, 1],
/// orders in [1, 512], tolerance as for the albedos. Reciprocity holds to rounding:
/// t_up[m](e, k) = t_down[m](k, e) / n^2 (computed from f_transmit_up, not copied) and r_inside is
/// symmetric by construction (each pair of inside directions is integrated once).
/// internal_reflection = false leaves r_inside empty (the transmissions alone, for callers that keep
/// r_inside of an earlier call: it does not depend on air_mu).
InterfaceKernels interface_kernels(const RoughInterface& surface, const StreamPieces& streams,
                                   std::span<const double> air_mu, int orders, double tolerance = 1e-6,
                                   bool internal_reflection = true);

/// The first-surface lobe between air directions, point values for the Fourier output:
/// result[m](e, e') = K^m_air(air_mu[e], air_mu[e']) (row = outgoing), symmetric.
std::vector<Matrix> air_reflection_orders(const RoughInterface& surface, std::span<const double> air_mu,
                                          int orders, double tolerance = 1e-6,
                                          QuadratureReport* report = nullptr);

} // namespace brdf::rte
