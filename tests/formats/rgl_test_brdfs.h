#pragma once
// Analytic, reciprocal, isotropic test BRDFs for the RGL builder and the Mitsuba check, in RGB
// (3 channels) or spectral form (per wavelength in nm), and the accuracy statistics both report.

#include <formats/halfdiff.h>
#include <formats/rgl/rgl_build.h>
#include <formats/rgl/rgl_eval.h>

#include <cstdint>
#include <string>
#include <vector>

namespace brdf::test {

enum class RglTestModel {
    Lambertian, ///< rho(channel) / pi
    Glossy,     ///< a GGX lobe (alpha 0.2, Schlick F0 0.04, height-correlated Smith) + diffuse base
    Retro,      ///< a strong back-scattering lobe (n + 1)/(2 pi) k max(0, wi.wo)^n, n = 20, + diffuse
};

const char* to_string(RglTestModel model);

/// The model as a builder callback, for RGB (wavelengths empty) or the given wavelengths.
formats::RglBrdfCallback rgl_test_brdf(RglTestModel model, const std::vector<double>& wavelengths_nm);

/// 380, 400, ..., 780 nm (21 wavelengths).
std::vector<double> visible_wavelengths();

/// The resolutions of the Mitsuba check (rgl_mitsuba_cases) and the tests: incidences x samples.
struct RglResolution {
    const char* name;
    int theta_i;
    int samples;
};
inline constexpr RglResolution rgl_resolutions[] = {
    {"coarse", 8, 16},
    {"default", 16, 32}, // RglOptions' defaults
    {"fine", 32, 64},
};
/// Whether a model at a resolution is held to the accuracy thresholds (median <= 1 %, p95 <= 5 %):
/// the Lambertian and glossy models from "default" up, the retro-reflective lobe at "fine" only (its
/// peak moves with theta_i, which the renderers interpolate linearly, and is narrower than the
/// NDF it makes: docs/formats.md, "RGL tensor files").
bool rgl_enforced(RglTestModel model, const RglResolution& resolution);
/// Builder options of one case: the resolution, RGB or the visible wavelengths, other options at
/// their defaults.
formats::RglOptions rgl_case_options(const RglResolution& resolution, bool spectral);

/// Directions for accuracy checks, wi and wo drawn independently (a fixed seed: the same pairs on
/// every run). Cosine-weighted is the measure a rendering weighs a BRDF by: light arrives with
/// cos(theta_i), and the pixels of a convex object seen from afar have normals distributed as
/// cos(theta_o) (projected area). Uniform in solid angle puts 17 % of the directions beyond 80
/// degrees, where every table format's relative error grows (docs/formats.md, "RGL tensor files").
enum class DirectionWeighting { Cosine, SolidAngle };
struct DirectionSample {
    formats::Vec3 wi, wo;
};
std::vector<DirectionSample> random_direction_pairs(
    std::size_t count, std::uint64_t seed, DirectionWeighting weighting = DirectionWeighting::Cosine);

/// Directional albedo int f cos(theta_o) dwo of the model per channel at incidence theta_i
/// (degrees): Gauss-Legendre in cos(theta_o) (128 nodes) times the midpoint rule in phi (256).
std::vector<double> model_albedo(const formats::RglBrdfCallback& brdf, double theta_i_deg);

/// Relative differences |a - b| / max(|b|, floor) of every channel of every pair, b the reference.
struct RelativeStats {
    double median = 0.0;
    double p95 = 0.0;
    double max = 0.0;
    std::size_t count = 0;
};
RelativeStats relative_stats(std::vector<double> differences);

/// The evaluator's BRDF against the callback's at `pairs` (floor 1e-4 1/sr).
RelativeStats rgl_accuracy(const formats::RglEvaluator& evaluator,
                           const formats::RglBrdfCallback& brdf,
                           const std::vector<DirectionSample>& pairs);

} // namespace brdf::test
