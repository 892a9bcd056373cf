#pragma once
// Material specs (docs/design.md, "Material spec (JSON)"): parsing, validation and resolution of one
// material or a catalogue {"materials": [...], "defaults": {...}} into MaterialSpec values that the
// compute pipeline uses directly (index models ready to evaluate, size distributions built,
// spectral set chosen).
//
// Validation reports every problem of a document at once, in one InputError, one line per problem:
//   spec.json: materials[1].pigments[0].size.r_eff_um: must be > 0 (got -0.2)
// The JSON path names the field as written; a problem in a catalogue's `defaults` is reported once,
// at its `defaults.KEY` path. Warnings (extrapolated index data, dense pigment loads) do not fail a
// spec: they are logged with log::warn and kept in MaterialSpec::warnings for the report.
//
// Resolution rules beyond docs/design.md (extensions, never renames):
//  - A pigment's or binder's index may be given as "material": ID | {"index": X} | {"nk": ROWS},
//    or with the shorthand keys "index" / "nk" beside "volume_fraction" (pigment) or
//    "absorption_per_mm" (binder). The resolved form is always "material": ...; an index X is a
//    number (1.5) or a string ("2.7+0.01i", brdf::parse_complex_index); a binder's index must be
//    real (its absorption is absorption_per_mm).
//  - An optional "description" string is kept in the resolved spec.
//  - "medium" takes an optional "index" (the medium's real refractive index), required on the top
//    layer under a smooth or rough surface; "phase" defaults to isotropic and may be written as a
//    type string ("rayleigh") where the type has no parameters.
//  - Catalogue defaults merge key by key at the top level (the material's own keys win); the model
//    keys form groups, (binder, pigments, thickness_um), (medium) and (layers): a material that
//    gives a key of one group inherits none of the others from the defaults. A "substrate" from
//    the defaults is inherited only by materials whose last layer is finite.
//  - Explicit wavelength lists follow spectrum.h (wavelength_list_problems: each in
//    [explicit_min_nm, explicit_max_nm], strictly increasing); their count is limited by
//    SpecLimits::max_wavelengths.
//  - An optional "limits" object raises the resource limits (SpecLimits); it is resolved only when
//    given, so specs without it keep their hashes.
//  - Films and stacks (docs/design.md, "Extensions ... (turn 2)"): a material is one layer, written
//    with the top-level keys binder + pigments (+ thickness_um) or medium (+ its optical_depth), or
//    a stack "layers": [layer, ...], top first. Either way MaterialSpec::layers holds them. A stack
//    of one layer resolves to the top-level form, so both spellings hash alike; specs without the
//    new keys resolve exactly as before. A finite last layer lies on a Lambertian "substrate"
//    (black unless given; written into the resolved spec only for such films).
//  - "surface" may also be rough: {"roughness": alpha, "distribution": "ggx" | "beckmann"} or the
//    named finishes "gloss", "satin", "matte"; "colorspace" is resolved only when not "rec709".
//  The complete reference of the format is docs/spec.md.

#include <brdf/core/hash.h>
#include <brdf/material/colour_space.h>
#include <brdf/material/refractive_index.h>
#include <brdf/material/spectrum.h>
#include <brdf/mie/size_distribution.h>

#include <nlohmann/json.hpp>

#include <array>
#include <complex>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace brdf::material {

/// The air/top interface: none (a bare medium), smooth (flat Fresnel) or rough (microfacets).
enum class Surface { None, Smooth, Rough };
/// The microfacet normal distribution of a rough surface (Walter et al. 2007, eqs. 25 and 33).
enum class Microfacet { Ggx, Beckmann };
enum class PhaseType { Isotropic, Rayleigh, HenyeyGreenstein, Legendre };
/// Which reflection model a material is evaluated with: the exact solve (default) or the dipole
/// diffusion comparison model of Jensen et al. 2001 (rte/dipole.h), chosen with "model": "dipole".
enum class Model { Exact, Dipole };

/// "none", "smooth", "rough".
std::string_view to_string(Surface surface);
/// "ggx", "beckmann".
std::string_view to_string(Microfacet distribution);
/// "isotropic", "rayleigh", "henyey_greenstein", "legendre".
std::string_view to_string(PhaseType type);
/// "exact", "dipole".
std::string_view to_string(Model model);

/// Largest spec file load_specs reads (bytes); larger is a LimitError.
inline constexpr std::size_t max_spec_file_bytes = 64u << 20;
/// Most Legendre coefficients an analytic medium's phase function may list.
inline constexpr std::size_t max_phase_coefficients = 10000;

/// A pigment's or binder's refractive index.
struct IndexSpec {
    std::string id; ///< catalogue ID (canonical, aliases resolved), or "" for a constant / nk table
    /// Ready to evaluate at any wavelength of the spec's spectrum (from the catalogue, a constant
    /// or an nk table); the spec's wavelengths are checked to lie in its usable range.
    IndexModel model = IndexModel::constant(1.0);
    std::optional<std::complex<double>> constant; ///< n + i k when given as a constant index
    std::vector<NkRow> nk;                        ///< the rows when given as an nk table

    /// "tio2-rutile", "2.7+0.01i", "1.5", "nk table (12 rows)".
    std::string describe() const;
};

struct PigmentSpec {
    IndexSpec index;
    double volume_fraction = 0.0;                      ///< in (0, 1]
    mie::SizeDistribution size = mie::monodisperse(1.0); ///< radii in um
};

struct BinderSpec {
    IndexSpec index;                ///< real index (k = 0 for constants; catalogue binders are clear)
    double absorption_per_mm = 0.0; ///< absorption coefficient of the binder, 1/mm, >= 0
};

struct MediumSpec {
    std::array<double, 3> albedo{1.0, 1.0, 1.0}; ///< single-scattering albedo r, g, b in [0, 1]
    bool grey = true;                             ///< albedo was given as one number
    PhaseType phase = PhaseType::Isotropic;
    /// Asymmetry parameter <cos theta> of the phase function for every type (the given g for
    /// Henyey-Greenstein, beta_1 / 3 for Legendre, 0 for isotropic and Rayleigh).
    double g = 0.0;
    /// beta_l, l = 0, 1, ... with beta_0 = 1: only for Legendre (as given, |beta_l| <= 2l + 1).
    std::vector<double> coefficients;
    /// The medium's real refractive index, > 0. Needed by the top layer under a smooth or rough
    /// surface; a lower layer without one is index-matched to the layer above.
    std::optional<double> index;
    /// Optical depth (extinction times thickness) of a finite layer, > 0; absent: semi-infinite.
    std::optional<double> optical_depth;
};

/// The air/top interface. "none" | "smooth" | {"roughness": alpha, "distribution": "ggx" |
/// "beckmann"} | the named finishes "gloss" (alpha 0.03), "satin" (0.15), "matte" (0.40), GGX.
struct SurfaceSpec {
    Surface kind = Surface::Smooth;
    double roughness = 0.0; ///< alpha of Walter et al. 2007, in [0.001, 1] for Rough; 0 otherwise
    Microfacet distribution = Microfacet::Ggx;
    std::string finish; ///< "gloss", "satin", "matte" when named, else ""
};

/// One layer, top first: a pigmented or clear binder, or an analytic medium.
struct LayerSpec {
    std::optional<BinderSpec> binder;
    std::vector<PigmentSpec> pigments; ///< empty: a clear binder layer (needs a thickness)
    std::optional<MediumSpec> medium;
    std::optional<double> thickness_um; ///< binder layers: > 0; absent: semi-infinite

    /// True when the layer has neither thickness_um nor medium->optical_depth.
    bool semi_infinite() const;
    /// Sum of the pigments' volume fractions (0 for a clear binder or an analytic medium).
    double pigment_volume_fraction() const;
};

/// Lambertian substrate under a finite last layer: "substrate": {"albedo": a | [r, g, b]}, each in
/// [0, 1] (0 = black, the default).
struct SubstrateSpec {
    std::array<double, 3> albedo{0.0, 0.0, 0.0};
    bool grey = true; ///< albedo was given as one number
};

struct AccuracySpec {
    std::string level = "default"; ///< "draft", "default", "reference" or "custom"
    /// Relative BRDF error to meet: draft 1e-2, default 1e-4, reference 1e-6; custom in
    /// [SpecLimits::min_tolerance (1e-8 unless raised), 0.5].
    double tolerance = 1e-4;
};

/// Resource limits: a spec whose settings would need absurd memory or time is refused with a
/// LimitError naming the limit, unless the spec raises it explicitly with an optional "limits"
/// object, e.g. "limits": {"max_size_parameter": 1e6}. The object is kept in the resolved spec (and
/// so in the hash) only when given. Limits that the spec alone decides are checked by parse_specs;
/// max_legendre_terms needs the optics and is checked by model::solve_material.
struct SpecLimits {
    /// Most wavelengths in the spectrum (an explicit list); the solve is linear in the count.
    std::size_t max_wavelengths = 2000;
    /// Largest Mie size parameter x = 2 pi r_max n_binder / lambda of any pigment at any wavelength
    /// (r_max: the size distribution's upper integration radius); Mie series need ~x terms. The
    /// default is the most the Mie module computes (mie::max_legendre_size_parameter), which no
    /// limit raises: a spec lowers it to refuse particles whose optics take long.
    double max_size_parameter = 5e4;
    /// Smallest accuracy tolerance (relative BRDF error); below 1e-8 double precision runs out.
    double min_tolerance = 1e-8;
    /// Longest Legendre series of a phase function (terms beta_0 .. beta_{L-1}).
    std::size_t max_legendre_terms = 100000;
};

struct MaterialSpec {
    std::string name;        ///< [A-Za-z0-9._-]{1,100}; names the output files
    std::string description; ///< optional free text
    /// Top first, at least one: a particulate layer (binder + pigments), a clear binder film or an
    /// analytic medium. Only the last may be semi-infinite.
    std::vector<LayerSpec> layers;
    std::optional<SubstrateSpec> substrate; ///< present iff the last layer is finite
    SurfaceSpec surface;
    /// "colorspace": "rec709" (default) | "acescg" | "rec2020"; in the resolved spec only when not
    /// the default, so that existing specs keep their hashes.
    ColorSpace colorspace = ColorSpace::Rec709;
    /// "model": "exact" (default) | "dipole"; in the resolved spec only when not the default, so that
    /// existing specs keep their hashes.
    Model model = Model::Exact;
    SpectralSet spectrum = SpectralSet::visible();
    AccuracySpec accuracy;
    /// Subset of "merl", "exr", "fourier", "rgl", "spectral_exr", in that order.
    std::vector<std::string> outputs{"merl", "exr"};
    SpecLimits limits; ///< the defaults, or those raised by the spec's "limits" object

    /// The spec as resolved: defaults filled in, aliases resolved, numbers as doubles, keys in
    /// canonical (sorted) order. parse_specs(resolved) gives the same material again.
    nlohmann::json resolved;
    /// 16 lowercase hex digits: FNV-1a 64 of resolved.dump(), stable across key order, whitespace
    /// and equivalent spellings (1 vs 1.0, "acrylic" vs "pmma", defaults vs explicit values).
    std::string hash;
    /// Where it came from, for messages: "file.json" or "file.json: materials[3]".
    std::string source;
    /// Non-fatal findings, each "SOURCE: PATH: text" (also logged with log::warn).
    std::vector<std::string> warnings;
};

/// Parses one material or a catalogue {"materials": [...], "defaults": {...}} (defaults merged into
/// each material, the material's own keys win). Validates everything first and throws ONE
/// InputError whose message lists every problem, one per line, each "SOURCE: JSON.PATH: fault (got
/// VALUE)", e.g. "spec.json: materials[1].pigments[0].size.r_eff_um: must be > 0 (got -0.2)".
/// `source` names the document in messages (usually the file name). When every problem is a
/// resource limit (SpecLimits) the one exception is a LimitError instead, each line naming the limit
/// and the "limits" key that overrides it.
///
/// `overlay` (an object; empty: none) is set on every material before anything is parsed, over the
/// material's own keys and the catalogue's defaults: `brdftool compute --accuracy` overrides each
/// spec's accuracy so, e.g. {"accuracy": "draft"}. What is resolved and hashed is the overlaid
/// material, so an override changes the spec hash (and "up to date" means up to date for it).
std::vector<MaterialSpec> parse_specs(const nlohmann::json& document, std::string_view source,
                                      const nlohmann::json& overlay = nlohmann::json::object());

/// Parses JSON text (InputError "SOURCE:LINE:COLUMN: invalid JSON: ..." on syntax errors, which
/// include NaN and Infinity; duplicate keys in an object are reported with the other problems) and
/// then parse_specs.
std::vector<MaterialSpec> parse_specs_text(std::string_view text, std::string_view source,
                                           const nlohmann::json& overlay = nlohmann::json::object());

/// Reads a file (IoError if unreadable, LimitError above max_spec_file_bytes) and parses it with
/// parse_specs_text, the file's path as given naming it in messages.
std::vector<MaterialSpec> load_specs(const std::filesystem::path& file,
                                     const nlohmann::json& overlay = nlohmann::json::object());

/// FNV-1a 64 of `text` as 16 lowercase hex digits (the spec hash; the one implementation is in core).
using brdf::fnv1a64_hex;

} // namespace brdf::material
