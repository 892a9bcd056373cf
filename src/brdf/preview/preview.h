#pragma once
// The one-call preview of a solved material, for `brdftool compute --preview` and anything else that
// has a SolvedMaterial in hand: the default sphere rendering (render.h) with the material's mirror
// reflection when it has a smooth interface (its lobe when it has a rough one), written as a
// tone-mapped PNG.

#include <brdf/preview/render.h>
#include <brdf/model/model.h>

#include <filesystem>

namespace brdf::preview {

/// The zenith angles of the Fourier grid (model::prepare_fill) that previews draw a spec's body
/// from: the draft tables' grid (about 2 degrees apart, model::zenith_grid_cosine), at about a
/// third of the cost of the default tables' 91. At the render's nodes it is within 8.6e-5 of the
/// table grid below 88 degrees and 4.2e-4 at the grazing corner
/// (PipelineTable.PreviewGridAgreesWithTheTableGridAtTheRenderNodes); a lobe plot's curves within
/// 5.4e-5 of their peak up to the horizon (PipelineTable.LobesFromThePreviewGridMatchTheTableGrid).
inline constexpr int preview_zenith_grid = 46;

/// render_sphere of the material's BRDF with `options`: with surface "smooth" its mirror, with a
/// rough surface the body on the BRDF grid and the first-surface lobe exactly (RenderOptions::lobe).
Image render_material(const model::SolvedMaterial& material, RenderOptions options = {});

/// Renders `material` at 256 x 256 pixels (light from the upper left, a dim sky) and writes it to
/// `png` atomically (write_image). InputError if `png` does not end in .png or .exr, IoError if it
/// cannot be written.
void write_preview(const model::SolvedMaterial& material, const std::filesystem::path& png);

} // namespace brdf::preview
