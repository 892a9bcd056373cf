// The material's settings: surface (none, smooth, rough, named finishes), reflection model,
// spectrum, accuracy, outputs, colour space and resource limits.

#include "spec_parser.h"

#include <brdf/core/error.h>

#include <cmath>

namespace brdf::material::spec_detail {
namespace {

// Named finishes: GGX roughness alpha (Walter et al. 2007) of a gloss, satin and matte coating.
struct Finish {
    std::string_view name;
    double roughness;
};
constexpr Finish finishes[] = {{"gloss", 0.03}, {"satin", 0.15}, {"matte", 0.40}};

const std::vector<std::string_view> surface_names = {"none", "smooth", "gloss", "satin", "matte"};
const std::vector<std::string_view> rough_keys = {"roughness", "distribution"};
const std::vector<std::string_view> microfacet_names = {"ggx", "beckmann"};
constexpr double min_roughness = 1e-3, max_roughness = 1.0;

const std::vector<std::string_view> output_names = {"merl", "exr", "fourier", "rgl",
                                                    "spectral_exr"};
const std::vector<std::string_view> colorspace_names = {"rec709", "acescg", "rec2020"};
const ColorSpace colorspaces[] = {ColorSpace::Rec709, ColorSpace::AcesCg, ColorSpace::Rec2020};

const std::vector<std::string_view> limit_keys = {"max_wavelengths", "max_size_parameter",
                                                  "min_tolerance", "max_legendre_terms"};

} // namespace

std::optional<SurfaceSpec> MaterialParser::parse_surface_value(const json& v,
                                                               const std::string& path,
                                                               json& resolved) {
    SurfaceSpec s;
    if (v.is_string()) {
        const auto which =
            c.one_of(v.get<std::string>(), v, path, surface_names,
                     "\"none\", \"smooth\", \"gloss\", \"satin\", \"matte\" or {\"roughness\": "
                     "alpha}");
        if (!which) return std::nullopt;
        const std::string_view name = surface_names[*which];
        resolved = name;
        if (name == "none") {
            s.kind = Surface::None;
        } else if (name == "smooth") {
            s.kind = Surface::Smooth;
        } else {
            for (const Finish& f : finishes)
                if (f.name == name) s.roughness = f.roughness;
            s.kind = Surface::Rough;
            s.distribution = Microfacet::Ggx;
            s.finish = std::string(name);
        }
        return s;
    }
    if (!v.is_object()) {
        c.fail(path, cat("expected \"none\", \"smooth\", a finish (\"gloss\", \"satin\", "
                         "\"matte\") or {\"roughness\": alpha}, got ",
                         type_name(v), " (got ", show(v), ")"));
        return std::nullopt;
    }
    c.check_keys(v, path, rough_keys);
    bool ok = true;
    const std::string rpath = key_path(path, "roughness");
    if (!v.contains("roughness")) {
        c.fail(rpath, "missing (the microfacet roughness alpha of Walter et al. 2007, in [0.001, "
                      "1])");
        ok = false;
    } else if (const auto a = c.number(v["roughness"], rpath)) {
        if (*a >= min_roughness && *a <= max_roughness) {
            s.roughness = *a;
        } else {
            c.fail(rpath, cat("must be in [0.001, 1] (alpha of Walter et al. 2007; below 0.001 use "
                              "\"smooth\") (got ",
                              show(v["roughness"]), ")"));
            ok = false;
        }
    } else {
        ok = false;
    }
    if (v.contains("distribution")) {
        if (const auto d = c.one_of(v["distribution"], key_path(path, "distribution"),
                                    microfacet_names))
            s.distribution = *d == 0 ? Microfacet::Ggx : Microfacet::Beckmann;
        else
            ok = false;
    }
    if (!ok) return std::nullopt;
    s.kind = Surface::Rough;
    resolved = json{{"roughness", s.roughness}, {"distribution", to_string(s.distribution)}};
    return s;
}

void MaterialParser::parse_surface(MaterialSpec& spec, json& resolved) {
    // The top layer decides the default (smooth over a binder, none over an analytic medium) and
    // whether a medium needs its index for the interface.
    const json* top = &obj;
    if (obj.contains("layers")) {
        const json& layers = obj["layers"];
        top = layers.is_array() && !layers.empty() && layers[0].is_object() ? &layers[0] : nullptr;
    }
    const bool top_medium = top && top->contains("medium");
    const std::string path = in.path("surface");
    std::optional<SurfaceSpec> surface;
    if (obj.contains("surface")) {
        json r;
        surface = parse_surface_value(obj["surface"], path, r);
        if (surface) resolved["surface"] = r;
    } else {
        surface = SurfaceSpec{};
        surface->kind = top_medium ? Surface::None : Surface::Smooth;
        resolved["surface"] = to_string(surface->kind);
    }
    if (!surface) return;
    spec.surface = *surface;
    const MediumSpec* medium = !m_layers.empty() && m_layers[0] && m_layers[0]->medium
                                   ? &*m_layers[0]->medium
                                   : nullptr;
    if (!top_medium || !medium) return;
    const std::string ipath = key_path(m_layer_paths[0].medium, "index");
    if (surface->kind != Surface::None && !medium->index)
        c.fail(ipath, surface->kind == Surface::Smooth
                          ? "missing (\"surface\": \"smooth\" on an analytic medium needs the "
                            "medium's real refractive index, e.g. \"index\": 1.5)"
                          : "missing (a rough \"surface\" on an analytic medium needs the medium's "
                            "real refractive index, e.g. \"index\": 1.5)");
    // In a stack the top medium's index still sets the interface to the layer below it.
    if (surface->kind == Surface::None && medium->index && m_layers.size() == 1)
        warn(ipath, "unused with \"surface\": \"none\" (the index only matters for a smooth or "
                    "rough surface)");
}

void MaterialParser::parse_model(MaterialSpec& spec, json& resolved) {
    // "exact" (default) or "dipole"; resolved only when not the default, so that specs without it
    // keep their hashes
    if (!obj.contains("model")) return;
    if (const auto m = c.one_of(obj["model"], in.path("model"), {"exact", "dipole"},
                                "\"exact\" or \"dipole\"")) {
        spec.model = *m == 0 ? Model::Exact : Model::Dipole;
        if (spec.model == Model::Dipole) resolved["model"] = "dipole";
    }
}

void MaterialParser::parse_colorspace(MaterialSpec& spec, json& resolved) {
    // Resolved only when not the default, like "model".
    if (!obj.contains("colorspace")) return;
    if (const auto cs = c.one_of(obj["colorspace"], in.path("colorspace"), colorspace_names)) {
        spec.colorspace = colorspaces[*cs];
        if (spec.colorspace != ColorSpace::Rec709)
            resolved["colorspace"] = colorspace_names[*cs];
    }
}

std::optional<SpectralSet> MaterialParser::parse_spectrum(const json& v, const std::string& path,
                                                          json& resolved) {
    if (v.is_string()) {
        const auto which = c.one_of(v.get<std::string>(), v, path, {"visible", "rgb"},
                                    "\"visible\", \"rgb\" or {\"wavelengths_nm\": [...]}");
        if (!which) return std::nullopt;
        resolved = *which == 0 ? "visible" : "rgb";
        return *which == 0 ? SpectralSet::visible() : SpectralSet::rgb();
    }
    if (!v.is_object()) {
        c.fail(path, cat("expected \"visible\", \"rgb\" or {\"wavelengths_nm\": [...]}, got ",
                         type_name(v), " (got ", show(v), ")"));
        return std::nullopt;
    }
    c.check_keys(v, path, {"wavelengths_nm"});
    const std::string wpath = key_path(path, "wavelengths_nm");
    if (!v.contains("wavelengths_nm")) {
        c.fail(wpath, "missing (a list of vacuum wavelengths in nm)");
        return std::nullopt;
    }
    const json& list_json = v["wavelengths_nm"];
    if (!c.array(list_json, wpath, "of wavelengths in nm")) return std::nullopt;
    if (list_json.size() > m_limits.max_wavelengths) {
        c.fail_limit(wpath, cat("lists ", list_json.size(), " wavelengths, more than the limit of ",
                                m_limits.max_wavelengths,
                                " (the solve's time grows with the count); to override, set "
                                "\"limits\": {\"max_wavelengths\": ",
                                list_json.size(), "}"));
        return std::nullopt;
    }
    std::vector<double> wavelengths;
    bool ok = true;
    for (std::size_t i = 0; i < list_json.size(); ++i) {
        const auto x = c.number(list_json[i], elem_path(wpath, i));
        if (x)
            wavelengths.push_back(*x);
        else
            ok = false;
    }
    if (!ok) return std::nullopt;
    const auto problems = wavelength_list_problems(wavelengths, wpath);
    for (const std::string& p : problems) c.fail_raw(p);
    if (!problems.empty()) return std::nullopt;
    try {
        // from_wavelengths keeps spectrum.h's own cap (max_explicit_wavelengths); a longer list
        // the limits allow is integrated the same way, already checked above.
        SpectralSet set = wavelengths.size() > max_explicit_wavelengths
                              ? SpectralSet::integrating(wavelengths)
                              : SpectralSet::from_wavelengths(wavelengths, wpath);
        resolved = json{{"wavelengths_nm", wavelengths}};
        return set;
    } catch (const Error& e) {
        c.fail_raw(e.what());
        return std::nullopt;
    }
}

std::optional<AccuracySpec> MaterialParser::parse_accuracy(const json& v, const std::string& path,
                                                           json& resolved) {
    static const std::pair<std::string_view, double> levels[] = {
        {"draft", 1e-2}, {"default", 1e-4}, {"reference", 1e-6}};
    if (v.is_string()) {
        const auto which =
            c.one_of(v.get<std::string>(), v, path, {"draft", "default", "reference"},
                     "\"draft\", \"default\", \"reference\" or {\"tolerance\": t}");
        if (!which) return std::nullopt;
        const auto& [level, tolerance] = levels[*which];
        resolved = level;
        return AccuracySpec{std::string(level), tolerance};
    }
    if (!v.is_object()) {
        c.fail(path, cat("expected \"draft\", \"default\", \"reference\" or {\"tolerance\": t}, "
                         "got ",
                         type_name(v), " (got ", show(v), ")"));
        return std::nullopt;
    }
    c.check_keys(v, path, {"tolerance"});
    const std::string tpath = key_path(path, "tolerance");
    if (!v.contains("tolerance")) {
        c.fail(tpath, "missing (the relative BRDF error, 1e-8 to 0.5)");
        return std::nullopt;
    }
    const auto t = c.number(v["tolerance"], tpath);
    if (!t) return std::nullopt;
    if (*t > 0.0 && *t < m_limits.min_tolerance) {
        c.fail_limit(tpath, cat(show(v["tolerance"]), " is below the limit of ",
                                shortest(m_limits.min_tolerance),
                                " (the solver's double-precision floor; streams and time grow as "
                                "the tolerance falls); to override, set \"limits\": "
                                "{\"min_tolerance\": ",
                                show(v["tolerance"]), "}"));
        return std::nullopt;
    }
    if (!(*t > 0.0 && *t <= 0.5)) {
        c.fail(tpath, cat("must be in [1e-8, 0.5] (a relative error; 1e-8 is near the solver's "
                          "double-precision floor) (got ",
                          show(v["tolerance"]), ")"));
        return std::nullopt;
    }
    resolved = json{{"tolerance", *t}};
    return AccuracySpec{"custom", *t};
}

std::optional<std::vector<std::string>>
MaterialParser::parse_outputs(const json& v, const std::string& path, json& resolved) {
    if (!c.array(v, path, "of output formats (e.g. [\"merl\", \"exr\"])")) return std::nullopt;
    std::vector<bool> listed(output_names.size(), false);
    bool ok = true;
    for (std::size_t i = 0; i < v.size(); ++i) {
        const std::string epath = elem_path(path, i);
        const auto which = c.one_of(v[i], epath, output_names);
        if (!which) {
            ok = false;
        } else if (listed[*which]) {
            c.fail(epath, cat("\"", output_names[*which], "\" is listed twice"));
            ok = false;
        } else {
            listed[*which] = true;
        }
    }
    if (!ok) return std::nullopt;
    // Canonical order, so that the order written does not change the hash.
    std::vector<std::string> out;
    for (std::size_t k = 0; k < output_names.size(); ++k)
        if (listed[k]) out.emplace_back(output_names[k]);
    resolved = out;
    return out;
}

void MaterialParser::parse_limits(const json& v, const std::string& path, json& resolved) {
    if (!c.object(v, path, "of resource limits (e.g. {\"max_size_parameter\": 1e6})")) return;
    c.check_keys(v, path, limit_keys);
    // Counts: whole numbers in [1, 1e9] (beyond that a size_t conversion means nothing here).
    const auto count = [&](const char* key, std::size_t& out) {
        if (!v.contains(key)) return;
        const std::string kpath = key_path(path, key);
        const auto x = c.number(v[key], kpath);
        if (!x) return;
        if (!(*x >= 1.0 && *x <= 1e9 && std::floor(*x) == *x)) {
            c.fail(kpath, cat("must be a whole number in [1, 1e9] (got ", show(v[key]), ")"));
            return;
        }
        out = static_cast<std::size_t>(*x);
        resolved[key] = *x;
    };
    count("max_wavelengths", m_limits.max_wavelengths);
    count("max_legendre_terms", m_limits.max_legendre_terms);
    if (v.contains("max_size_parameter")) {
        const std::string kpath = key_path(path, "max_size_parameter");
        if (const auto x = c.number(v["max_size_parameter"], kpath)) {
            if (!(*x > 0.0))
                c.fail(kpath, cat("must be > 0 (got ", show(v["max_size_parameter"]), ")"));
            else
                m_limits.max_size_parameter = *x, resolved["max_size_parameter"] = *x;
        }
    }
    if (v.contains("min_tolerance")) {
        const std::string kpath = key_path(path, "min_tolerance");
        if (const auto x = c.number(v["min_tolerance"], kpath)) {
            if (!(*x > 0.0 && *x <= 0.5))
                c.fail(kpath, cat("must be in (0, 0.5] (got ", show(v["min_tolerance"]), ")"));
            else
                m_limits.min_tolerance = *x, resolved["min_tolerance"] = *x;
        }
    }
}

} // namespace brdf::material::spec_detail
