#pragma once
// The renderer formats made from a solved material (not from a table): NAME.fourier.bsdf (pbrt-v3's
// Fourier BSDF, formats/fourier) and NAME.rgl.bsdf (the RGL tensor BSDF of Mitsuba 3's and pbrt-v4's
// `measured`, formats/rgl). Both are built from the same batched data as the MERL/EXR table fill
// (model::FillInputs and Reflection::order_grid), never from SolvedMaterial::brdf per direction,
// which costs a Nystrom solve per direction and wavelength.

#include <brdf/model/model.h>
#include <brdf/model/table_fill.h>

#include <filesystem>

namespace brdf::service {

/// Resolution of the renderer formats for a requested relative tolerance (the spec's accuracy).
/// docs/formats.md ("What compute writes") lists the measured accuracy of each level.
struct RendererResolution {
    int fourier_nodes = 32;          ///< positive mu nodes of the Fourier file (0 and the mirrored ones come on top)
    double fourier_truncation = 1e-5; ///< formats::FourierBuildOptions::truncation
    int rgl_theta_i = 32;            ///< formats::RglOptions::theta_i_count
    int rgl_samples = 64;            ///< formats::RglOptions::sample_resolution
};
RendererResolution renderer_resolution(double tolerance);

/// The positive Fourier nodes: Chebyshev-Lobatto points in mu on (0, 1], mu_k = (1 - cos(pi k /
/// n)) / 2, k = 1 .. n, rounded to float32 (the file's precision, at which the series is made).
std::vector<double> fourier_nodes(int n);

/// Writes NAME.fourier.bsdf atomically: per pair of nodes, the multiply scattered part's Fourier
/// orders from Reflection::order_grid combined with the colour weights, plus the single scattering
/// of `fill` expanded in cos(m phi) by an exact cosine quadrature. Provenance in the metadata.
void write_fourier_output(const std::filesystem::path& path, const model::SolvedMaterial& solved,
                          const model::FillInputs& fill, const RendererResolution& resolution);

/// Whether NAME.rgl.bsdf is spectral: every sample of `solved` is a wavelength (an analytic medium,
/// given per RGB channel, has none).
bool rgl_output_spectral(const model::SolvedMaterial& solved);

/// NAME.rgb.rgl.bsdf beside NAME.rgl.bsdf: the RGB file written with a spectral one.
std::filesystem::path rgl_rgb_companion_path(const std::filesystem::path& rgl_path);

/// Writes NAME.rgl.bsdf atomically: formats::make_rgl_bsdf of the table fill's interpolant
/// model::fill_value, with rgl_description provenance. For a material solved per wavelength a
/// spectral file ("spectra" + "wavelengths" at the solved wavelengths, read by pbrt-v4 and Mitsuba's
/// spectral variants) and beside it rgl_rgb_companion_path(path), its RGB file
/// (formats::rgl_rgb_from_spectral, read by Mitsuba's RGB variants); otherwise an RGB file ("rgb")
/// only, and a stale companion is removed.
void write_rgl_output(const std::filesystem::path& path, const model::SolvedMaterial& solved,
                      const model::FillInputs& fill, const RendererResolution& resolution);

} // namespace brdf::service
