#pragma once
// The adding equations per Fourier order (van de Hulst 1980, "Multiple Light Scattering", ch. 4;
// Stamnes 1982; docs/physics.md section 9): the reflection of everything below a plane, built from
// the bottom up by putting a homogeneous layer or a smooth index change on top of it.
//
// Operators live on a medium's streams (N) and on E directions off them: the Snell images, in that
// medium, of the output angles in air (n sin(theta) is conserved across smooth interfaces, so the
// images of one air angle in every medium belong together). Normalisation as R^m everywhere: a
// response to light from stream j carries the contraction weight q_j = 2 w_j mu_j; a column for an
// off-stream direction is the response to a collimated beam of unit flux.
//
// Specular (delta) parts: a smooth interface reflects specularly and a layer transmits its direct
// beam. On the streams they are diagonal matrices divided by q; off the streams they cannot be
// matrix entries and are carried as per-direction factors: the specular reflectance `spec` of a
// reflector, the direct transmission t_e of a layer. Radiance at an off-stream direction keeps
// bouncing between specular parts (a geometric series per direction); once it is scattered it joins
// the smooth field and has zero measure.

#include <brdf/core/linalg.h>
#include <brdf/rte/streams.h>

#include <span>
#include <vector>

namespace brdf::rte {

/// What a medium sees below it (one Fourier order). Reciprocal: the response of stream j to a beam
/// from e is en(e, j).
struct Reflector {
    Matrix nn;                ///< N x N (specular parts on the streams included as diag(F / q))
    Matrix en;                ///< E x N, smooth: towards off-stream direction e from stream j
    Matrix ee;                ///< E x E, smooth
    std::vector<double> spec; ///< E: specular reflectance at each off-stream direction
};

/// A homogeneous layer's operators (one order), the same from above and below.
struct LayerOperators {
    Matrix r_nn, t_nn;        ///< on the streams; t_nn includes the direct beam
    Matrix r_en, t_en;        ///< E x N, diffuse
    Matrix r_ee, t_ee;        ///< E x E, diffuse (t_ee is used only when the reflector below is specular)
    std::vector<double> t_e;  ///< E: direct transmission exp(-tau / u_e)
};

/// The layer put on top of `below` (both in the same medium, on the same streams and directions).
Reflector add_layer(const LayerOperators& layer, const Reflector& below, const Streams& streams);

/// A smooth (Fresnel) interface between an upper medium of index n_above and a lower one of index
/// n_below, whose streams correspond one to one where both exist (same n sin(theta)).
struct SmoothInterface {
    double n_above = 1.0, n_below = 1.0;
    /// Per upper stream: the lower stream it refracts into, or -1 (totally reflected from above).
    std::vector<int> below_of;
    /// Per upper stream: Fresnel reflectance (1 when totally reflected).
    std::vector<double> f_above;
    /// Per lower stream: Fresnel reflectance from below (1 when totally reflected).
    std::vector<double> f_below;
    /// Per off-stream direction (all of which cross): Fresnel reflectance.
    std::vector<double> f_e;
};

/// What the upper medium sees: the interface on top of `below` (lower medium). With no upper
/// streams (air above) only ee and spec are filled.
Reflector add_interface(const SmoothInterface& interface, const Reflector& below, const Streams& above,
                        const Streams& lower);
/// The same with bounce_inverse(interface, below.nn, lower) given.
Reflector add_interface(const SmoothInterface& interface, const Reflector& below,
                        const Streams& above, const Streams& lower, const Matrix& bounce);

/// The light below a smooth interface that travels up again, internal reflections summed:
/// Z = (I - B R_int)^-1 B on the lower medium's streams and directions (add_interface applies the
/// Fresnel transmissions to it). Exposed for hemispherical sums (the albedo under an interface).
Reflector bounce_under_interface(const SmoothInterface& interface, const Reflector& below, const Streams& lower);
/// The same with bounce_inverse(interface, below.nn, lower) given.
Reflector bounce_under_interface(const SmoothInterface& interface, const Reflector& below,
                                 const Streams& lower, const Matrix& bounce);
/// (I - B g)^-1, g = diag(q F) the interface's internal reflection on the lower streams and B what
/// lies below on them: the sum of the bounces between the two, the same for every off-stream
/// direction (rte::Reflection keeps it per order).
Matrix bounce_inverse(const SmoothInterface& interface, const Matrix& below_nn,
                      const Streams& lower);

/// Fresnel reflectance (unpolarised) of a smooth interface for a ray with cosine mu_1 in a medium of
/// index n_1 going into one of index n_2: 1 beyond the critical angle.
double fresnel(double mu_1, double n_1, double n_2);

} // namespace brdf::rte
