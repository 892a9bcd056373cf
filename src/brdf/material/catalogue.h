#pragma once
// The built-in refractive-index catalogue: material IDs (as used by a spec's `binder.material` and
// `pigments[].material`) mapped to refractiveindex.info data files embedded into the binary from
// data/refractiveindex/ (CC0). The table in catalogue.cpp defines the entries; docs/materials.md
// mirrors it with each entry's source, range and extension policy.
//
// Uniaxial crystals (rutile, ZnO, calcite, hematite, cinnabar) are modelled in random orientation
// by the average m = (2 m_o + m_e) / 3 of n and of k (docs/physics.md section 7); the per-axis models
// are kept in CatalogueEntry::axes for code that averages the scattering instead.
//
// Range policy (see IndexModel): tabulated data are never extrapolated; formula data hold in their
// stated range and are extended to cover 380-780 nm only where the formula is a transparent-region
// fit and the entry says so (rutile, ZnO, MgO, the polymers); such samples have extrapolated =
// true. Out-of-range wavelengths throw InputError, e.g.
//   "wavelength 300 nm is outside the data of tio2-anatase (206.64-826.56 nm)".
//
// The files are parsed once, on first use, thread-safely (a function-local static); every function
// here may be called from any thread.

#include <brdf/material/refractive_index.h>

#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace brdf::material {

enum class MaterialKind {
    Pigment, ///< a scattering or absorbing particle (dielectric or semiconductor)
    Metal,   ///< a metal (particles or flakes)
    Binder,  ///< a host medium (polymer)
    Void,    ///< an empty inclusion (air)
};

/// "pigment", "metal", "binder", "void".
std::string_view to_string(MaterialKind kind);

/// One principal axis of a material's index data with its weight in the orientation average.
struct CrystalAxis {
    std::string_view axis; ///< "o" (ordinary), "e" (extraordinary), or "" for isotropic data
    double weight = 1.0;   ///< 2/3 for o and 1/3 for e of a uniaxial crystal; 1 otherwise
    IndexModel model;      ///< this axis alone (same range policy as the entry)
};

struct CatalogueEntry {
    std::string_view id;                   ///< canonical ID, e.g. "tio2-rutile"
    std::vector<std::string_view> aliases; ///< other accepted IDs, e.g. "acrylic" for pmma
    MaterialKind kind = MaterialKind::Pigment;
    std::string_view description;        ///< one line
    std::string_view citation;           ///< the measurement (and the fit, where different)
    std::string_view licence;            ///< licence of the data file(s)
    std::vector<std::string_view> files; ///< data files, relative to data/ (empty for air)
    std::string_view range_policy;       ///< one line: data range, extension and why
    IndexModel model;                    ///< the index to use (orientation-averaged if uniaxial)
    std::vector<CrystalAxis> axes;       ///< per-axis data behind `model`
    /// What reading changed in the published files (IndexFile::repairs): dropped out-of-order or
    /// duplicated rows, noise-level negative k set to 0. Empty for clean files.
    std::vector<std::string> data_repairs;

    /// model.at(wavelength_nm).
    IndexSample at(double wavelength_nm) const { return model.at(wavelength_nm); }
};

/// Every entry, in the documented order (pigments, metals, binders, void).
std::span<const CatalogueEntry> catalogue();

/// The entry with this canonical ID or alias (exact, case-sensitive), or nullptr.
const CatalogueEntry* find_material(std::string_view id);

/// The entry with this ID or alias; InputError for an unknown ID, naming close matches and listing
/// every valid ID: `unknown material "rutile" (did you mean "tio2-rutile"?); built-in materials:
/// tio2-rutile, tio2-anatase, ...`.
const CatalogueEntry& material(std::string_view id);

/// The canonical IDs, in catalogue order (aliases not included).
std::vector<std::string> material_ids();

/// material(id).at(wavelength_nm): throws InputError for unknown IDs and out-of-range wavelengths.
IndexSample index_of(std::string_view id, double wavelength_nm);

} // namespace brdf::material
