#pragma once
// One Fourier order of a homogeneous slab of finite optical thickness tau: its reflection and
// transmission on the streams and at any other cosines, from the discrete-ordinates eigen solution
// (Stamnes and Swanson 1981, J. Atmos. Sci. 38, 387; Stamnes et al. 1988, Appl. Opt. 27, 2502:
// DISORT). docs/physics.md section 8 derives every formula used here.
//
// The discrete-ordinates equations of order m on the N streams (M = diag mu, W = diag w),
//   M dI+/dt = A I+ + B I-,   -M dI-/dt = B I+ + A I-,   A = I - (w/2) P+ W, B = -(w/2) P- W,
// (t the optical depth from the top, + up, -) have the solutions (G+_j, G-_j) e^(-k_j t) and
// (G-_j, G+_j) e^(-k_j (tau - t)), where k_j^2 are the eigenvalues of M^-1 (A - B) M^-1 (A + B),
// found from one symmetric eigenproblem. Writing G+- = (S -+ k D~) / 2 with D~ = -(A - B)^-1 M S
// and dividing the "difference" columns by k makes every matrix below well conditioned for all
// k >= 0: the critical case (albedo 1, m = 0, k_min = 0) needs no dithering and conserves energy.
//
// Normalisation: matrices are R^m and T^m of docs/physics.md section 3 (BRDF = R / pi), i.e. the
// response to an input intensity I at stream j is R(i, j) q_j I with q_j = 2 w_j mu_j. Transmission
// on the streams includes the direct beam, diag(exp(-tau / mu_j) / q_j); off the streams it is the
// diffuse part only, the direct attenuation being exp(-tau / u).

#include <brdf/core/linalg.h>
#include <brdf/rte/order_solver.h>
#include <brdf/rte/phase.h>

#include <span>
#include <vector>

namespace brdf::rte {

/// A slab's responses at a set of cosines u_e off the streams (e.g. the output angles of a table).
struct SlabRows {
    Matrix r; ///< R^m(u_e, mu_j): light from stream j at the top, reflected towards u_e (E x N)
    Matrix t; ///< T^m(u_e, mu_j), diffuse: light from stream j at the top, leaving the bottom at u_e
};

/// Both arguments off the streams: light arriving collimated at the top from cosine u_b.
struct SlabBlock {
    Matrix r; ///< R^m(u_a, u_b) (E x E)
    Matrix t; ///< T^m(u_a, u_b), diffuse (the direct beam exp(-tau/u_b) continues at u_b)
};

class SlabOrder {
public:
    /// `problem` holds the order, the albedo, the streams and P+- on them (make_order_problem);
    /// tau >= 0 (0: the identity). InputError for a negative or non-finite tau.
    SlabOrder(const OrderProblem& problem, double tau);

    int order() const { return m_m; }
    double tau() const { return m_tau; }
    /// R^m on the streams (symmetric: reciprocity).
    const Matrix& reflection() const { return m_r; }
    /// T^m on the streams, direct beam included (symmetric).
    const Matrix& transmission() const { return m_t; }
    /// Decay rates k_j >= 0 of the homogeneous solutions (ascending).
    std::span<const double> decay_rates() const { return m_k; }

    /// Reflection and diffuse transmission towards cosines u (each in (0, 1]) of light from the
    /// streams, by integrating the source function along u (the discrete-ordinates analogue of the
    /// Nystrom evaluation of the half-space). `beta` is the (delta-M scaled) phase function the
    /// problem was built from.
    SlabRows rows(std::span<const double> beta, std::span<const double> u) const;
    /// Both arguments at cosines u: light collimated from u_b (the particular solution of a beam,
    /// as DISORT's) seen at u_a, single scattering of the beam included. Also returns the columns
    /// R^m(mu_i, u_b), T^m(mu_i, u_b) on the streams (by reciprocity the transposes of rows()).
    struct Beams {
        SlabBlock block;
        Matrix r_columns; ///< N x E
        Matrix t_columns; ///< N x E, diffuse
    };
    Beams beams(std::span<const double> beta, std::span<const double> u) const;

private:
    // Row coefficients of the source-function integration for the cosines u: the homogeneous field's
    // contribution to the emerging intensity is (1/2) [a (c + d) + b (c - d) k] at the top and
    // (1/2) [a (c + d) - b (c - d) k] at the bottom (see slab.cpp).
    struct RowCoefficients {
        Matrix plus, minus; // E x N
    };
    RowCoefficients row_coefficients(std::span<const double> beta, std::span<const double> u, PhasePair& pu) const;

    int m_m = 0;
    double m_omega = 0.0;
    double m_tau = 0.0;
    std::vector<double> m_mu, m_w;
    std::vector<double> m_k;        // decay rates
    std::vector<double> m_e;        // exp(-k tau)
    std::vector<double> m_phi;      // (1 - exp(-k tau)) / k, tau at k = 0
    Matrix m_s, m_d;                // S and D~ (columns = modes)
    Matrix m_cp_inv, m_cm_inv;      // (X- + X+ E)^-1 and k (X- - X+ E)^-1
    Matrix m_a_minus_b_inv;         // (A - B)^-1
    Matrix m_beam_projector;        // S^-1 M^-1 (A - B) M^-1: the particular solution in the eigenbasis
    Matrix m_r, m_t;
};

} // namespace brdf::rte
