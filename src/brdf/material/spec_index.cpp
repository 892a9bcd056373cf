// Refractive indices of binders and pigments: a catalogue ID, a constant (real or "n+ki") or an nk
// table, and the check that the index data cover the spec's spectrum.

#include "spec_parser.h"

#include <brdf/core/error.h>
#include <brdf/core/parse.h>
#include <brdf/material/catalogue.h>

namespace brdf::material::spec_detail {
namespace {

const std::vector<std::string_view> index_object_keys = {"index", "nk"};

} // namespace

std::optional<IndexSpec> MaterialParser::parse_constant(const json& v, const std::string& path,
                                                        bool binder, json& resolved) {
    std::complex<double> m;
    if (v.is_number()) {
        const auto n = c.number(v, path);
        if (!n) return std::nullopt;
        if (!(*n > 0.0)) {
            c.fail(path, cat("must be > 0 (got ", show(v), ")"));
            return std::nullopt;
        }
        m = {*n, 0.0};
    } else if (v.is_string()) {
        try {
            m = parse_complex_index(v.get<std::string>(), path);
        } catch (const InputError& e) {
            c.fail_raw(e.what());
            return std::nullopt;
        }
    } else {
        c.fail(path, cat("expected a refractive index, a number like 1.5 or a string like "
                         "\"2.7+0.01i\", got ",
                         type_name(v), " (got ", show(v), ")"));
        return std::nullopt;
    }
    if (binder && m.imag() != 0.0) {
        c.fail(path, cat("a binder's index must be real; give its absorption as "
                         "\"absorption_per_mm\" (got ",
                         show(v), ")"));
        return std::nullopt;
    }
    IndexSpec spec;
    spec.constant = m;
    spec.model = IndexModel::constant(m.real(), m.imag(), complex_text(m));
    resolved = m.imag() == 0.0 ? json(m.real()) : json(complex_text(m));
    return spec;
}

std::optional<IndexSpec> MaterialParser::parse_nk(const json& v, const std::string& path,
                                                  json& resolved) {
    if (!c.array(v, path, "of rows [wavelength_nm, n, k]")) return std::nullopt;
    if (v.size() > max_nk_rows) {
        c.fail(path, cat("has ", v.size(), " rows, more than the limit of ", max_nk_rows));
        return std::nullopt;
    }
    std::vector<NkRow> rows;
    bool ok = true;
    for (std::size_t i = 0; i < v.size(); ++i) {
        const json& row = v[i];
        const std::string row_path = elem_path(path, i);
        if (!row.is_array() || row.size() != 3) {
            c.fail(row_path, cat("expected a row [wavelength_nm, n, k] (got ", show(row), ")"));
            ok = false;
            continue;
        }
        const auto l = c.number(row[0], elem_path(row_path, 0));
        const auto n = c.number(row[1], elem_path(row_path, 1));
        const auto k = c.number(row[2], elem_path(row_path, 2));
        if (!l || !n || !k) {
            ok = false;
            continue;
        }
        rows.push_back({*l, *n, *k});
    }
    if (!ok) return std::nullopt;
    const auto problems = nk_table_problems(rows, path);
    for (const std::string& p : problems) c.fail_raw(p);
    if (!problems.empty()) return std::nullopt;
    IndexSpec spec;
    spec.nk = rows;
    try {
        spec.model = IndexModel::from_nk_table(rows, "the nk table");
    } catch (const Error& e) {
        c.fail_raw(e.what());
        return std::nullopt;
    }
    resolved = json::array();
    for (const NkRow& r : rows) resolved.push_back(json::array({r.wavelength_nm, r.n, r.k}));
    return spec;
}

std::optional<IndexSpec> MaterialParser::parse_index(const json& holder,
                                                     const std::string& holder_path, bool binder,
                                                     json& resolved_material) {
    std::vector<std::string> given;
    for (std::string_view k : index_object_keys)
        if (holder.contains(k)) given.emplace_back(k);
    const bool has_material = holder.contains("material");
    const char* example = binder ? "{\"material\": \"pmma\"} or {\"index\": 1.5}"
                                 : "{\"material\": \"tio2-rutile\"}, {\"index\": \"2.7+0.01i\"} "
                                   "or {\"nk\": [[nm, n, k], ...]}";
    if (!has_material && given.empty()) {
        c.fail(key_path(holder_path, "material"), cat("missing (give the index as ", example, ")"));
        return std::nullopt;
    }
    if (given.size() + (has_material ? 1 : 0) > 1) {
        std::string names = has_material ? "\"material\"" : "";
        for (const auto& g : given) names += (names.empty() ? "\"" : " and \"") + g + "\"";
        c.fail(holder_path, cat("give the index one way only (got ", names, ")"));
        return std::nullopt;
    }
    const json* source = &holder;
    std::string source_path = holder_path;
    if (has_material) {
        const json& m = holder["material"];
        const std::string mpath = key_path(holder_path, "material");
        if (m.is_string()) {
            const std::string id = m.get<std::string>();
            const CatalogueEntry* entry = find_material(id);
            if (!entry) {
                try {
                    material(id); // throws the catalogue's message: close matches and valid IDs
                    c.fail(mpath, cat("unknown material \"", id, "\""));
                } catch (const InputError& e) {
                    c.fail(mpath, e.what());
                }
                return std::nullopt;
            }
            if (binder && (entry->kind == MaterialKind::Pigment || entry->kind == MaterialKind::Metal))
                warn(mpath, cat(entry->id, " is a ", to_string(entry->kind),
                                ", not a binder; its index is used as the host medium's"));
            IndexSpec spec;
            spec.id = std::string(entry->id);
            spec.model = entry->model;
            resolved_material = spec.id;
            return spec;
        }
        if (!m.is_object()) {
            c.fail(mpath, cat("expected a material ID (a string) or ", example, ", got ",
                              type_name(m), " (got ", show(m), ")"));
            return std::nullopt;
        }
        c.check_keys(m, mpath, index_object_keys);
        source = &m;
        source_path = mpath;
        given.clear();
        for (std::string_view k : index_object_keys)
            if (m.contains(k)) given.emplace_back(k);
        if (given.size() != 1) {
            c.fail(mpath, given.empty() ? cat("expected ", example, " (got ", show(m), ")")
                                        : std::string("give \"index\" or \"nk\", not both"));
            return std::nullopt;
        }
    }
    json value;
    std::optional<IndexSpec> spec;
    const std::string vpath = key_path(source_path, given.front());
    if (given.front() == "index")
        spec = parse_constant((*source)["index"], vpath, binder, value);
    else
        spec = parse_nk((*source)["nk"], vpath, value);
    if (spec) resolved_material = json{{given.front(), value}};
    return spec;
}

void MaterialParser::queue_range_check(const json& holder, const std::string& holder_path,
                                       const IndexSpec& index) {
    // The path of the key that gave the index: "material", "material.nk", "index", ...
    std::string path;
    if (holder.contains("material")) {
        const json& m = holder["material"];
        path = key_path(holder_path, "material");
        if (m.is_object()) path = key_path(path, m.contains("nk") ? "nk" : "index");
    } else {
        path = key_path(holder_path, holder.contains("nk") ? "nk" : "index");
    }
    m_index_checks.push_back({std::move(path), index});
}

void MaterialParser::check_ranges(const SpectralSet& spectrum) {
    const auto wavelengths = spectrum.wavelengths_nm();
    for (const IndexCheck& check : m_index_checks) {
        std::vector<double> bad, extrapolated;
        std::string first_message;
        for (double l : wavelengths) {
            try {
                if (check.index.model.at(l).extrapolated) extrapolated.push_back(l);
            } catch (const Error& e) {
                if (bad.empty()) first_message = e.what();
                bad.push_back(l);
            }
        }
        if (!bad.empty()) {
            std::string message = first_message;
            if (bad.size() > 1)
                message += cat(" (", bad.size(), " of the spectrum's ", wavelengths.size(),
                               " wavelengths, which span ", wavelengths.front(), "-",
                               wavelengths.back(), " nm, are outside)");
            if (!check.index.nk.empty())
                message += "; tables are never extrapolated: extend the table or choose a spectrum "
                           "within it";
            c.fail(check.path, message);
        }
        if (!extrapolated.empty()) {
            const WavelengthRange data = check.index.model.data_range();
            warn(check.path,
                 cat(check.index.describe(), ": ", extrapolated.size(), " wavelength",
                     extrapolated.size() > 1 ? "s" : "", " (", extrapolated.front(), "-",
                     extrapolated.back(), " nm) lie outside its data (", data.min_nm, "-",
                     data.max_nm, " nm) and use the documented extension of its dispersion "
                     "formula"));
        }
    }
}

} // namespace brdf::material::spec_detail
