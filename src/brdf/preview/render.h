#pragma once
// A sphere rendered with a BRDF, like the renderings of the seed paper: orthographic view of a unit
// sphere, a directional (optionally disc-shaped, soft) light and an optional environment, each
// surface point shaded in its local frame
//
//   L_o = sum_lights f(theta_i, theta_o, phi) E cos theta_i                      (light)
//       + sum_j f(theta_j, theta_o, phi_j) L_env(w_j) cos theta_j dw_j           (environment)
//       + F(theta_o) [L_env(r) + L_light(r)]                                     (smooth interface)
//       + sum_lights f_lobe(theta_i, theta_o, phi) E cos theta_i + A_lobe(theta_o) L_env(r)
//                                                                                (rough interface)
//
// with theta_i, theta_o from the normal and phi = phi_o - phi_i (docs/design.md: 0 on the light's side,
// pi on the mirror side), r the mirror direction of the view and F the interface's mirror
// reflectance. A rough interface's first-surface lobe f_lobe is too narrow for the BRDF grid and the
// environment rule (a gloss lobe is a degree or two wide): it is evaluated exactly at every shading
// point for the light, and lit by the environment through its directional albedo A_lobe and the
// environment in the mirror direction (exact for a constant environment, the narrow-lobe limit of a
// slowly varying one). Everything is deterministic: the environment is integrated with a fixed product rule
// in each point's local frame (Gauss-Legendre in cos theta times the midpoint rule in azimuth), which
// integrates a constant environment to the directional albedo without noise.
//
// View space: x to the right, y up, z towards the viewer; the view direction (surface to eye) is +z
// everywhere.

#include <brdf/material/colour_space.h>
#include <brdf/preview/image.h>

#include <functional>

namespace brdf::preview {

/// BRDF (1/sr) at zenith angles theta_i, theta_o and azimuth phi (radians, docs/design.md conventions).
/// render_sphere calls it from several threads at once.
using BrdfFunction = std::function<Rgb(double theta_i, double theta_o, double phi)>;
/// A BRDF (1/sr) in the cosines of the zenith angles and of the azimuth between the directions:
/// the rough lobe, evaluated at every light sample, where the angles' trigonometry cost as much as
/// the lobe itself. Also called from several threads at once.
using CosineBrdfFunction = std::function<Rgb(double mu_i, double mu_o, double cos_phi)>;
/// Reflectance of a smooth interface's mirror reflection at incidence theta (radians).
using MirrorFunction = std::function<Rgb(double theta)>;

enum class Environment {
    None,
    Constant, ///< the same radiance from every direction (a white furnace)
    Sky,      ///< a gradient: bluish zenith (+y), white horizon, brown ground
};

/// "none", "constant", "sky" (InputError otherwise).
Environment parse_environment(const std::string& name);

struct RenderOptions {
    int size = 512;        ///< width and height in pixels, [8, 8192]
    int supersample = 2;   ///< samples per pixel along each axis, [1, 8]
    double margin = 0.06;  ///< empty border around the sphere, fraction of the image size

    double light_theta_deg = 45.0; ///< angle between the light and the view direction, [0, 180]
    double light_phi_deg = 135.0;  ///< azimuth in the image plane: 0 right, 90 up, 180 left
    double light_size_deg = 2.0;   ///< angular diameter of the light disc, [0, 90]; 0: a point
    double light_irradiance = 3.141592653589793; ///< E normal to the light; 0 turns it off
    Rgb light_colour{1.0, 1.0, 1.0};

    Environment environment = Environment::None;
    double environment_radiance = 0.3; ///< constant radiance, or the scale of the sky
    int environment_mu = 8;            ///< Gauss-Legendre nodes in cos theta of the local rule
    int environment_phi = 16;          ///< azimuths of the local rule

    Rgb background{0.02, 0.02, 0.02}; ///< linear; dark grey after tone mapping

    /// The smooth interface's mirror reflectance; empty when the material has none.
    MirrorFunction mirror;
    /// A rough interface's first-surface lobe (1/sr), never tabulated, and its directional albedo;
    /// both empty when the material has none. The BRDF passed to render_sphere is then the rest.
    CosineBrdfFunction lobe;
    MirrorFunction lobe_albedo;

    /// The BRDF is sampled on a grid of theta_nodes x theta_nodes x phi_nodes (cell-centred zenith
    /// angles, phi 0..180 inclusive, reciprocity halves the work) and interpolated trilinearly;
    /// 0 evaluates it at every shading point (slow for a solved model).
    int theta_nodes = 24;
    int phi_nodes = 13;
    int threads = 0; ///< 0: one per hardware thread
};

/// `brdf`, whose values are RGB in `space`, as linear Rec.709, the space previews are shaded and
/// displayed in (material::rgb_to_rec709_matrix: white stays white). Colours outside Rec.709
/// (an ACEScg cadmium yellow) get negative channels there, which a display cannot show: they are
/// clamped to 0. The function itself for Rec.709.
BrdfFunction in_rec709(BrdfFunction brdf, material::ColorSpace space); // a CosineBrdfFunction too
/// The same for a mirror reflectance.
MirrorFunction in_rec709(MirrorFunction mirror, material::ColorSpace space);

/// Throws InputError naming the first option out of range.
void check_options(const RenderOptions& options);

/// The linear RGB image (size x size) of the sphere.
Image render_sphere(const BrdfFunction& brdf, const RenderOptions& options);

/// `brdf` sampled as RenderOptions describes and interpolated (what render_sphere shades with).
BrdfFunction tabulate_brdf(const BrdfFunction& brdf, int theta_nodes, int phi_nodes, int threads = 0);

} // namespace brdf::preview
