#pragma once
// The RGB colour spaces a material's tables, reports and evaluations can be given in (the spec's
// "colorspace" key; docs/spec.md, docs/colour.md). Their primaries, white points, matrices and the
// chromatic adaptation live in brdf/material/colour.h.

namespace brdf::material {

/// "rec709" (the default: linear Rec.709 / sRGB primaries, D65), "acescg" (ACES AP1 primaries,
/// ACES white point), "rec2020" (ITU-R BT.2020 primaries, D65).
enum class ColorSpace { Rec709, AcesCg, Rec2020 };

} // namespace brdf::material
