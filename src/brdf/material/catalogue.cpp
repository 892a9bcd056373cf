#include <brdf/material/catalogue.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/text.h>
#include <brdf/material/embedded_data.h>

#include <algorithm>
#include <cctype>
#include <optional>

namespace brdf::material {

std::string_view to_string(MaterialKind kind) {
    switch (kind) {
    case MaterialKind::Pigment:
        return "pigment";
    case MaterialKind::Metal:
        return "metal";
    case MaterialKind::Binder:
        return "binder";
    case MaterialKind::Void:
        return "void";
    }
    return "unknown";
}

namespace {

constexpr std::string_view cc0 =
    "CC0 1.0, refractiveindex.info database (data/refractiveindex/LICENSE)";
constexpr std::string_view johnson_christy =
    "P. B. Johnson and R. W. Christy, Optical constants of the noble metals, Phys. Rev. B 6, "
    "4370-4379 (1972)";
constexpr std::string_view querry_1985 =
    "M. R. Querry, Optical constants, Contractor Report CRDC-CR-85034 (1985)";
constexpr std::string_view sultanova =
    "N. Sultanova, S. Kasarova, I. Nikolov, Dispersion properties of optical polymers, Acta "
    "Physica Polonica A 116, 585-587 (2009); Sellmeier fit by M. Polyanskiy";

// Extensions of formula ranges. A zero bound keeps the data's own end.
constexpr WavelengthRange down_to_380{380.0, 0.0};
constexpr WavelengthRange visible{380.0, 780.0};

// One row of the catalogue. docs/materials.md mirrors this table; keep them in step.
struct Source {
    std::string_view id;
    std::vector<std::string_view> aliases;
    MaterialKind kind;
    std::string_view description;
    std::string_view citation;
    std::string_view file;   // isotropic data or the ordinary ray; empty for air
    std::string_view file_e; // extraordinary ray of a uniaxial crystal, else empty
    std::optional<WavelengthRange> extend_to;
    std::string_view range_policy;
    std::string_view note; // appended to out-of-range messages: why, and what to do instead
};

// The table. Range policies: see catalogue.h and docs/materials.md.
const std::vector<Source>& sources() {
    static const std::vector<Source> table = {
        // ---- pigments
        {"tio2-rutile",
         {},
         MaterialKind::Pigment,
         "Titanium dioxide, rutile (the white pigment); uniaxial, (2 o + e)/3",
         "J. R. DeVore, Refractive indices of rutile and sphalerite, J. Opt. Soc. Am. 41, 416-419 "
         "(1951)",
         "refractiveindex/main_TiO2__Devore-o.yml",
         "refractiveindex/main_TiO2__Devore-e.yml",
         down_to_380,
         "formula 430-1530 nm, extended to 380 nm (extrapolated): real rutile starts absorbing "
         "near 400-410 nm (band gap ~3.0 eV) where the formula still gives k = 0",
         "DeVore's formula holds for 430-1530 nm and is extended only down to 380 nm, because "
         "rutile absorbs strongly below ~410 nm; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"tio2-anatase",
         {},
         MaterialKind::Pigment,
         "Titanium dioxide, anatase (ALD thin film deposited at 300 C)",
         "A. Jolivet et al., Structural, optical, and electrical properties of TiO2 thin films "
         "deposited by ALD, Appl. Surf. Sci. 608, 155214 (2023)",
         "refractiveindex/main_TiO2__Jolivet-anatase.yml",
         "",
         std::nullopt,
         "tabulated 206.64-826.56 nm (covers the visible), never extrapolated",
         "tabulated data are never extrapolated; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"zno",
         {},
         MaterialKind::Pigment,
         "Zinc oxide (zinc white); uniaxial, (2 o + e)/3",
         "W. L. Bond, Measurement of the refractive indices of several crystals, J. Appl. Phys. "
         "36, 1674-1677 (1965); formula from Handbook of Optics, 3rd ed., Vol. 4 (2009)",
         "refractiveindex/main_ZnO__Bond-o.yml",
         "refractiveindex/main_ZnO__Bond-e.yml",
         down_to_380,
         "formula 450-4000 nm, extended to 380 nm (extrapolated): ZnO's band edge is at ~375-390 "
         "nm (3.3 eV); below ~450 nm the real index rises towards the excitonic peak and k grows, "
         "which the formula (k = 0) does not describe",
         "Bond's formula holds for 450-4000 nm and is extended only down to 380 nm, ZnO's band "
         "edge; give measured data with {\"nk\": [[nm, n, k], ...]}"},
        {"calcite",
         {},
         MaterialKind::Pigment,
         "Calcium carbonate, calcite (whiting, chalk filler); uniaxial, (2 o + e)/3",
         "G. Ghosh, Dispersion-equation coefficients for the refractive index and birefringence "
         "of calcite and quartz crystals, Opt. Commun. 163, 95-102 (1999)",
         "refractiveindex/main_CaCO3__Ghosh-o.yml",
         "refractiveindex/main_CaCO3__Ghosh-e.yml",
         std::nullopt,
         "formula 204-2172 nm (covers the visible), not extended",
         "Ghosh's formula holds for 204-2172 nm; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"hematite",
         {},
         MaterialKind::Pigment,
         "Alpha-Fe2O3, hematite (red iron oxide); uniaxial, (2 o + e)/3",
         querry_1985,
         "refractiveindex/main_Fe2O3__Querry-o.yml",
         "refractiveindex/main_Fe2O3__Querry-e.yml",
         std::nullopt,
         "tabulated 210-55556 nm (covers the visible), never extrapolated",
         "tabulated data are never extrapolated; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"magnetite",
         {},
         MaterialKind::Pigment,
         "Fe3O4, magnetite (black iron oxide)",
         querry_1985,
         "refractiveindex/main_Fe3O4__Querry.yml",
         "",
         std::nullopt,
         "tabulated 210-55556 nm (covers the visible), never extrapolated",
         "tabulated data are never extrapolated; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"cds",
         {},
         MaterialKind::Pigment,
         "Cadmium sulfide (cadmium yellow), RF-sputtered film",
         "R. E. Treharne et al., Optical design and fabrication of fully sputtered CdTe/CdS solar "
         "cells, J. Phys. Conf. Ser. 286, 012038 (2011)",
         "refractiveindex/main_CdS__Treharne.yml",
         "",
         std::nullopt,
         "tabulated 301.42-1497.94 nm (covers the visible), never extrapolated",
         "tabulated data are never extrapolated; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"vermilion",
         {},
         MaterialKind::Pigment,
         "Mercury sulfide, cinnabar (vermilion); uniaxial, (2 o + e)/3; red wavelengths only",
         "W. L. Bond, G. D. Boyd and H. L. Carter Jr., Refractive indices of HgS (cinnabar) "
         "between 0.62 and 11 um, J. Appl. Phys. 38, 4090-4091 (1967); formula by G. C. Bhar, "
         "Appl. Opt. 15, 305-307 (1976)",
         "refractiveindex/main_HgS__Bond-o.yml",
         "refractiveindex/main_HgS__Bond-e.yml",
         std::nullopt,
         "formula 620-11000 nm, NOT extended: below 620 nm every wavelength is an error (HgS "
         "absorbs there; the transparent-region formula would make vermilion white, not red)",
         "HgS absorbs strongly below ~600 nm (which is what makes vermilion red), and Bond's "
         "formula, a fit to transparent-region data from 620 nm on, would give a white pigment "
         "there, so it is not extended; give measured visible data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"cu2o",
         {},
         MaterialKind::Pigment,
         "Cuprous oxide (pressed pellet); infrared data only",
         querry_1985,
         "refractiveindex/main_Cu2O__Querry.yml",
         "",
         std::nullopt,
         "tabulated 2500-55556 nm only (infrared), never extrapolated: every visible wavelength "
         "is an error",
         "the built-in Cu2O data (Querry 1985) cover only the infrared; give measured visible "
         "data with {\"nk\": [[nm, n, k], ...]}"},
        {"silica",
         {},
         MaterialKind::Pigment,
         "Fused silica (amorphous SiO2)",
         "I. H. Malitson, Interspecimen comparison of the refractive index of fused silica, J. "
         "Opt. Soc. Am. 55, 1205-1208 (1965)",
         "refractiveindex/main_SiO2__Malitson.yml",
         "",
         std::nullopt,
         "formula 210-6700 nm (covers the visible), not extended",
         "Malitson's formula holds for 210-6700 nm; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"alumina",
         {},
         MaterialKind::Pigment,
         "Aluminium oxide, synthetic sapphire; ordinary ray only (uniaxial, n_e is ~0.008 lower)",
         "I. H. Malitson and M. J. Dodge, Refractive index and birefringence of synthetic "
         "sapphire, J. Opt. Soc. Am. 62, 1405 (1972); formula by M. J. Dodge, Handbook of Laser "
         "Science and Technology IV, CRC Press (1986)",
         "refractiveindex/main_Al2O3__Malitson-o.yml",
         "",
         std::nullopt,
         "formula 200-5000 nm (covers the visible), not extended; o-ray only, so n is ~0.003 "
         "above the (2 o + e)/3 average",
         "the Malitson-Dodge formula holds for 200-5000 nm; give measured data with {\"nk\": "
         "[[nm, n, k], ...]}"},
        {"zns",
         {},
         MaterialKind::Pigment,
         "Zinc sulfide (the white of lithopone)",
         "M. R. Querry, Optical constants of minerals and other materials from the millimeter to "
         "the ultraviolet, Contractor Report CRDEC-CR-88009 (1987)",
         "refractiveindex/main_ZnS__Querry.yml",
         "",
         std::nullopt,
         "tabulated 220-166667 nm (covers the visible), never extrapolated",
         "tabulated data are never extrapolated; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"mgo",
         {},
         MaterialKind::Pigment,
         "Magnesium oxide (periclase)",
         "R. E. Stephens and I. H. Malitson, Index of refraction of magnesium oxide, J. Res. Natl. "
         "Bur. Stand. 49, 249-252 (1952)",
         "refractiveindex/main_MgO__Stephens-vis.yml",
         "",
         visible,
         "formula 404.7-767.9 nm, extended to 380-780 nm (extrapolated): MgO is transparent from "
         "~165 nm (band gap 7.8 eV) into the infrared, so the small extension is benign",
         "the Stephens-Malitson visible formula holds for 404.7-767.9 nm and is extended only to "
         "380-780 nm; give measured data with {\"nk\": [[nm, n, k], ...]}"},
        // ---- metals
        {"gold",
         {},
         MaterialKind::Metal,
         "Gold (evaporated film)",
         johnson_christy,
         "refractiveindex/main_Au__Johnson.yml",
         "",
         std::nullopt,
         "tabulated 187.9-1937 nm (covers the visible), never extrapolated",
         "tabulated data are never extrapolated; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"silver",
         {},
         MaterialKind::Metal,
         "Silver (evaporated film)",
         johnson_christy,
         "refractiveindex/main_Ag__Johnson.yml",
         "",
         std::nullopt,
         "tabulated 187.9-1937 nm (covers the visible), never extrapolated",
         "tabulated data are never extrapolated; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"copper",
         {},
         MaterialKind::Metal,
         "Copper (evaporated film)",
         johnson_christy,
         "refractiveindex/main_Cu__Johnson.yml",
         "",
         std::nullopt,
         "tabulated 187.9-1937 nm (covers the visible), never extrapolated",
         "tabulated data are never extrapolated; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        // ---- absorbing carbons (pigments: particles in a binder)
        {"carbon",
         {},
         MaterialKind::Pigment,
         "Amorphous carbon, arc-evaporated film (a carbon-black stand-in)",
         "E. T. Arakawa, M. W. Williams, T. Inagaki, Optical properties of arc-evaporated carbon "
         "films between 0.6 and 3.8 eV, J. Appl. Phys. 48, 3176-3177 (1977)",
         "refractiveindex/main_C__Arakawa.yml",
         "",
         std::nullopt,
         "tabulated 326.3-2066.4 nm (covers the visible), never extrapolated",
         "tabulated data are never extrapolated; give measured data with {\"nk\": [[nm, n, k], "
         "...]}"},
        {"soot",
         {},
         MaterialKind::Pigment,
         "Acetylene soot; data from 435.8 nm only",
         "W. H. Dalzell and A. F. Sarofim, Optical constants of soot and their application to "
         "heat-flux calculations, J. Heat Transfer 91, 100-104 (1969)",
         "refractiveindex/other_soots_acetylene_soot__Dalzell.yml",
         "",
         std::nullopt,
         "tabulated 435.8-10000 nm, never extrapolated: visible wavelengths below 435.8 nm are "
         "errors (use the \"rgb\" spectrum, carbon, or your own data)",
         "Dalzell and Sarofim measured from 435.8 nm on and tabulated data are never "
         "extrapolated; use \"carbon\", or give data with {\"nk\": [[nm, n, k], ...]} (theirs "
         "are nearly flat in the visible, n ~ 1.56, k ~ 0.46)"},
        // ---- binders
        {"pmma",
         {"acrylic"},
         MaterialKind::Binder,
         "Poly(methyl methacrylate), acrylic",
         sultanova,
         "refractiveindex/organic__C5H8O2_n_-_poly_methyl_methacrylate___Sultanova.yml",
         "",
         down_to_380,
         "formula 436.8-1052 nm, extended to 380 nm (extrapolated): PMMA is transparent there, "
         "but the fit's dispersion below 437 nm is not measured",
         "the Sultanova fit holds for 436.8-1052 nm and is extended only down to 380 nm; give "
         "measured data with {\"nk\": [[nm, n, k], ...]} or a constant {\"index\": ...}"},
        {"polystyrene",
         {},
         MaterialKind::Binder,
         "Polystyrene",
         sultanova,
         "refractiveindex/organic__C8H8_n_-_polystyrene__Sultanova.yml",
         "",
         down_to_380,
         "formula 436.8-1052 nm, extended to 380 nm (extrapolated): the dispersion below 437 nm "
         "is not measured and polystyrene's UV absorption rises towards 300 nm (k = 0 here)",
         "the Sultanova fit holds for 436.8-1052 nm and is extended only down to 380 nm; give "
         "measured data with {\"nk\": [[nm, n, k], ...]} or a constant {\"index\": ...}"},
        {"polycarbonate",
         {},
         MaterialKind::Binder,
         "Bisphenol-A polycarbonate",
         sultanova,
         "refractiveindex/organic__C16H14O3_n_-_polycarbonate__Sultanova.yml",
         "",
         down_to_380,
         "formula 436.8-1052 nm, extended to 380 nm (extrapolated): polycarbonate starts "
         "absorbing below ~400 nm (UV cut-off near 380-400 nm), where the formula gives k = 0",
         "the Sultanova fit holds for 436.8-1052 nm and is extended only down to 380 nm; give "
         "measured data with {\"nk\": [[nm, n, k], ...]} or a constant {\"index\": ...}"},
        // ---- voids
        {"air",
         {},
         MaterialKind::Void,
         "Air or vacuum: n = 1, k = 0 (voids)",
         "definition (the index of real air, 1.0003, differs by less than 3e-4)",
         "",
         "",
         std::nullopt,
         "constant, every wavelength",
         ""},
    };
    return table;
}

IndexModel load(std::string_view path, const std::string& name, std::vector<std::string>& repairs) {
    const std::optional<std::string_view> text = find_embedded(embedded::material_data(), path);
    if (!text)
        throw FormatError(cat("data/", path, ": not embedded in this binary (material catalogue)"));
    ReadOptions options;
    options.repair_tables = true; // the files are kept as published; see IndexFile::repairs
    const IndexFile file = parse_index_file(*text, cat("data/", path), options);
    repairs.insert(repairs.end(), file.repairs.begin(), file.repairs.end());
    return IndexModel::from_file(file, name);
}

IndexModel apply_policy(const IndexModel& model, const Source& s) {
    if (!s.extend_to) return model.with_range_note(std::string(s.note));
    WavelengthRange usable = *s.extend_to;
    const WavelengthRange data = model.data_range();
    if (usable.max_nm == 0.0) usable.max_nm = data.max_nm;
    usable.min_nm = std::min(usable.min_nm, data.min_nm);
    usable.max_nm = std::max(usable.max_nm, data.max_nm);
    return model.extended(usable, std::string(s.note));
}

CatalogueEntry build(const Source& s) {
    std::vector<std::string> repairs;
    std::vector<CrystalAxis> axes;
    std::optional<IndexModel> model;
    const std::string id(s.id);
    if (s.file.empty()) {
        model = IndexModel::constant(1.0, 0.0, id);
        axes.push_back({"", 1.0, *model});
    } else if (s.file_e.empty()) {
        model = apply_policy(load(s.file, id, repairs), s);
        axes.push_back({"", 1.0, *model});
    } else {
        // Random orientation of a uniaxial crystal: m = (2 m_o + m_e) / 3 (docs/physics.md section 7).
        const IndexModel o = apply_policy(load(s.file, id + " (ordinary ray)", repairs), s);
        const IndexModel e = apply_policy(load(s.file_e, id + " (extraordinary ray)", repairs), s);
        const std::pair<double, IndexModel> parts[] = {{2.0 / 3.0, o}, {1.0 / 3.0, e}};
        model = IndexModel::average(parts, id);
        if (s.extend_to)
            model = model->extended(model->usable_range(), std::string(s.note));
        else
            model = model->with_range_note(std::string(s.note));
        axes.push_back({"o", 2.0 / 3.0, o});
        axes.push_back({"e", 1.0 / 3.0, e});
    }
    std::vector<std::string_view> files;
    if (!s.file.empty()) files.push_back(s.file);
    if (!s.file_e.empty()) files.push_back(s.file_e);
    return CatalogueEntry{s.id,
                          s.aliases,
                          s.kind,
                          s.description,
                          s.citation,
                          s.file.empty() ? "none" : cc0,
                          std::move(files),
                          s.range_policy,
                          std::move(*model),
                          std::move(axes),
                          std::move(repairs)};
}

// Built on first use; C++ guarantees that concurrent first calls wait for one initialisation.
const std::vector<CatalogueEntry>& entries() {
    static const std::vector<CatalogueEntry> all = [] {
        std::vector<CatalogueEntry> out;
        for (const Source& s : sources()) out.push_back(build(s));
        return out;
    }();
    return all;
}



// Up to three IDs or aliases close to `id`: equal ignoring case, containing it or contained in it
// (3 characters or more), or within an edit distance of about a quarter of its length.
std::vector<std::string_view> close_ids(std::string_view id) {
    const std::string query = ascii_lower(id);
    std::vector<std::pair<std::size_t, std::string_view>> scored;
    for (const CatalogueEntry& e : entries()) {
        std::vector<std::string_view> names{e.id};
        names.insert(names.end(), e.aliases.begin(), e.aliases.end());
        for (std::string_view name : names) {
            const std::string candidate = ascii_lower(name);
            const std::size_t distance = edit_distance(query, candidate);
            const bool contains =
                query.size() >= 3 && (candidate.find(query) != std::string::npos ||
                                      query.find(candidate) != std::string::npos);
            if (contains || distance <= std::max<std::size_t>(1, query.size() / 4))
                scored.emplace_back(contains ? 0 : distance, name);
        }
    }
    std::stable_sort(scored.begin(), scored.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<std::string_view> out;
    for (std::size_t i = 0; i < scored.size() && i < 3; ++i) out.push_back(scored[i].second);
    return out;
}

} // namespace

std::span<const CatalogueEntry> catalogue() {
    return entries();
}

const CatalogueEntry* find_material(std::string_view id) {
    for (const CatalogueEntry& e : entries()) {
        if (e.id == id) return &e;
        if (std::find(e.aliases.begin(), e.aliases.end(), id) != e.aliases.end()) return &e;
    }
    return nullptr;
}

const CatalogueEntry& material(std::string_view id) {
    if (const CatalogueEntry* e = find_material(id)) return *e;
    std::string message = cat("unknown material \"", id, "\"");
    const auto close = close_ids(id);
    if (!close.empty()) {
        message += " (did you mean ";
        for (std::size_t i = 0; i < close.size(); ++i) {
            if (i) message += i + 1 == close.size() ? " or " : ", ";
            message += cat("\"", close[i], "\"");
        }
        message += "?)";
    }
    message += "; built-in materials: ";
    bool first = true;
    for (const CatalogueEntry& e : entries()) {
        if (!first) message += ", ";
        first = false;
        message += e.id;
        for (std::string_view alias : e.aliases) message += cat(" (alias ", alias, ")");
    }
    throw InputError(message);
}

std::vector<std::string> material_ids() {
    std::vector<std::string> ids;
    for (const CatalogueEntry& e : entries()) ids.emplace_back(e.id);
    return ids;
}

IndexSample index_of(std::string_view id, double wavelength_nm) {
    return material(id).at(wavelength_nm);
}

} // namespace brdf::material
