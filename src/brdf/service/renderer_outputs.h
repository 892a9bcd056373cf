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

/// Writes NAME.rgl.bsdf atomically (an RGB file: field "rgb"): formats::make_rgl_bsdf of the
/// table fill's interpolant model::fill_value, with rgl_description provenance.
void write_rgl_output(const std::filesystem::path& path, const model::SolvedMaterial& solved,
                      const model::FillInputs& fill, const RendererResolution& resolution);

} // namespace brdf::service
