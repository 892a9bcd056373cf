#pragma once
// The numbers paint makers use for a film (a finite last layer over a substrate): the contrast ratio
// (ISO 6504-3, ASTM D2805 practice) and the hiding thickness, and the film's optical depth and diffuse
// transmittance per wavelength. All of them come from the same stack solve as the BRDF, in Fourier
// order 0 only (what hemispherical quantities need), so they cost a small fraction of the material.

#include <brdf/model/model.h>

#include <optional>
#include <vector>

namespace brdf::model {

/// White substrate of the contrast ratio (ISO 6504-3 / ASTM D2805: a white of luminous reflectance 0.80).
constexpr double contrast_white_albedo = 0.80;
/// Contrast ratio at which a film hides its substrate (the "hiding" of ISO 6504-3).
constexpr double hiding_contrast_ratio = 0.98;

/// Luminance Y (in [0, 1]) of the diffuse reflectance at normal incidence (specular excluded, as a
/// 45/0 or d/8 SCE instrument measures) of the optics' stacks over a Lambertian substrate of
/// `substrate_albedo`; `thickness_um`, when given, replaces the single layer's thickness
/// (pigmented binder layers only).
double normal_luminance(const material::MaterialSpec& spec, const MaterialOptics& optics, int streams,
                        double substrate_albedo, std::optional<double> thickness_um = std::nullopt);

/// Y over black divided by Y over white (contrast_white_albedo), at normal incidence.
double contrast_ratio(const material::MaterialSpec& spec, const MaterialOptics& optics, int streams,
                      std::optional<double> thickness_um = std::nullopt);

/// Whether hiding_thickness applies: one pigmented binder layer (its thickness is what varies).
bool has_hiding_thickness(const material::MaterialSpec& spec);
/// The thickness (um) at which the contrast ratio reaches `target`, to 1e-4 relative; nullopt when
/// not reached below 10 mm.
std::optional<double> hiding_thickness_um(const material::MaterialSpec& spec, const MaterialOptics& optics, int streams,
                                          double target = hiding_contrast_ratio);

/// Per solved sample: the hemispherical transmittance of the whole film (every layer and interface)
/// for diffuse light from air into the substrate, from three order-0 solves over substrates of
/// albedo 0, 1/2 and 1 (R(a) = R0 + a T T' / (1 - a r), with T' = T / n^2 by reciprocity).
std::vector<double> diffuse_transmittance(const material::MaterialSpec& spec, const MaterialOptics& optics, int streams);

struct FilmReport {
    std::vector<std::vector<double>> optical_depth; ///< [sample][layer]; infinite layers as -1
    std::vector<double> diffuse_transmittance;      ///< [sample]
    double contrast_ratio = 0.0;
    std::optional<double> hiding_thickness_um;      ///< set when has_hiding_thickness and reached
};
/// The film section of a solved material's report; nullopt unless its last layer is finite.
std::optional<FilmReport> film_report(const SolvedMaterial& material);

} // namespace brdf::model
