// Analytic media: single-scattering albedo, phase function (isotropic, Rayleigh, Henyey-Greenstein,
// Legendre series), refractive index and optical depth; the albedo helper is shared with the
// substrate.

#include "spec_parser.h"

#include <cmath>

namespace brdf::material::spec_detail {
namespace {

const std::vector<std::string_view> medium_keys = {"albedo", "phase", "index", "optical_depth"};
const std::vector<std::string_view> phase_keys_all = {"type", "g", "coefficients"};
const std::vector<std::string_view> phase_names = {"isotropic", "rayleigh", "henyey_greenstein",
                                                   "legendre"};
const PhaseType phase_types[] = {PhaseType::Isotropic, PhaseType::Rayleigh,
                                 PhaseType::HenyeyGreenstein, PhaseType::Legendre};

} // namespace

std::optional<std::array<double, 3>> MaterialParser::parse_albedo(const json& a,
                                                                  const std::string& path,
                                                                  bool& grey, json& resolved) {
    if (a.is_number()) {
        const auto x = c.number(a, path);
        if (!x) return std::nullopt;
        if (!(*x >= 0.0 && *x <= 1.0)) {
            c.fail(path, cat("must be in [0, 1] (got ", show(a), ")"));
            return std::nullopt;
        }
        grey = true;
        resolved = *x;
        return std::array<double, 3>{*x, *x, *x};
    }
    if (!a.is_array()) {
        c.fail(path, cat("expected a number in [0, 1] or [r, g, b], got ", type_name(a), " (got ",
                         show(a), ")"));
        return std::nullopt;
    }
    if (a.size() != 3) {
        c.fail(path, cat("expected one number or three [r, g, b] (got ", show(a), ")"));
        return std::nullopt;
    }
    std::array<double, 3> out{};
    bool ok = true;
    for (std::size_t i = 0; i < 3; ++i) {
        const auto x = c.number(a[i], elem_path(path, i));
        if (x && !(*x >= 0.0 && *x <= 1.0))
            c.fail(elem_path(path, i), cat("must be in [0, 1] (got ", show(a[i]), ")"));
        if (x && *x >= 0.0 && *x <= 1.0)
            out[i] = *x;
        else
            ok = false;
    }
    if (!ok) return std::nullopt;
    grey = false;
    resolved = json::array({out[0], out[1], out[2]});
    return out;
}

bool MaterialParser::parse_phase(const json& p, const std::string& ppath, MediumSpec& m,
                                 json& phase) {
    bool ok = true;
    std::optional<std::size_t> which;
    if (p.is_string()) {
        which = c.one_of(p.get<std::string>(), p, ppath, phase_names);
    } else if (p.is_object()) {
        const std::string tpath = key_path(ppath, "type");
        if (!p.contains("type"))
            c.fail(tpath, cat("missing (one of ", list(phase_names), ")"));
        else
            which = c.one_of(p["type"], tpath, phase_names);
    } else {
        c.fail(ppath, cat("expected an object {\"type\": ...} or a type name, got ", type_name(p),
                          " (got ", show(p), ")"));
    }
    if (!which) {
        if (p.is_object()) c.check_keys(p, ppath, phase_keys_all);
        return false;
    }
    const PhaseType kind = phase_types[*which];
    const std::string_view type = phase_names[*which];
    m.phase = kind;
    phase = json{{"type", to_string(kind)}};
    const bool wants_g = kind == PhaseType::HenyeyGreenstein;
    const bool wants_coefficients = kind == PhaseType::Legendre;
    if (p.is_string() && (wants_g || wants_coefficients)) {
        c.fail(ppath, cat("the ", type, " phase function needs ",
                          wants_g ? "\"g\": {\"type\": \"henyey_greenstein\", \"g\": 0.5}"
                                  : "\"coefficients\": {\"type\": \"legendre\", "
                                    "\"coefficients\": [1, ...]}",
                          " (got ", show(p), ")"));
        return false;
    }
    if (!p.is_object()) return ok;
    for (const auto& item : p.items()) {
        const std::string& key = item.key();
        if (key == "type" || (key == "g" && wants_g) ||
            (key == "coefficients" && wants_coefficients))
            continue;
        if (key == "g" || key == "coefficients")
            c.fail(key_path(ppath, key), cat("not used by the ", type, " phase function"));
        else
            c.unknown_key(key_path(ppath, key), key, phase_keys_all);
    }
    if (wants_g) {
        const std::string gpath = key_path(ppath, "g");
        std::optional<double> g;
        if (!p.contains("g"))
            c.fail(gpath, "missing (the asymmetry parameter, -1 < g < 1)");
        else if ((g = c.number(p["g"], gpath)) && !(std::abs(*g) < 1.0)) {
            c.fail(gpath, cat("must satisfy |g| < 1 (got ", show(p["g"]), ")"));
            g.reset();
        }
        if (g) {
            m.g = *g;
            phase["g"] = *g;
        } else {
            ok = false;
        }
    }
    if (wants_coefficients) {
        const std::string cpath = key_path(ppath, "coefficients");
        bool cok = true;
        if (!p.contains("coefficients")) {
            c.fail(cpath, "missing (the Legendre coefficients beta_l, beta_0 = 1)");
            cok = false;
        } else if (!c.array(p["coefficients"], cpath,
                            "of Legendre coefficients [1, beta_1, ...]")) {
            cok = false;
        } else {
            const json& cs = p["coefficients"];
            if (cs.empty()) {
                c.fail(cpath, "must list at least beta_0 = 1 (got [])");
                cok = false;
            } else if (cs.size() > max_phase_coefficients) {
                c.fail(cpath, cat("has ", cs.size(), " coefficients, more than the limit of ",
                                  max_phase_coefficients));
                cok = false;
            }
            for (std::size_t l = 0; cok && l < cs.size(); ++l) {
                const std::string lpath = elem_path(cpath, l);
                const auto b = c.number(cs[l], lpath);
                if (!b) {
                    cok = false;
                    continue;
                }
                if (l == 0 && !(std::abs(*b - 1.0) <= 1e-9)) {
                    c.fail(lpath, cat("beta_0 must be 1 (the phase function is normalised) (got ",
                                      show(cs[l]), ")"));
                    cok = false;
                } else if (!(std::abs(*b) <= 2.0 * static_cast<double>(l) + 1.0)) {
                    c.fail(lpath, cat("must satisfy |beta_", l, "| <= ", 2 * l + 1,
                                      " (2l + 1, for a non-negative phase function) (got ",
                                      show(cs[l]), ")"));
                    cok = false;
                }
                if (cok) m.coefficients.push_back(l == 0 ? 1.0 : *b);
            }
        }
        if (cok) {
            m.g = m.coefficients.size() > 1 ? m.coefficients[1] / 3.0 : 0.0;
            phase["coefficients"] = m.coefficients;
        } else {
            ok = false;
        }
    }
    return ok;
}

std::optional<MediumSpec> MaterialParser::parse_medium(const json& v, const std::string& path,
                                                       json& resolved) {
    if (!c.object(v, path, "(e.g. {\"albedo\": 0.9, \"phase\": {\"type\": \"isotropic\"}})"))
        return std::nullopt;
    c.check_keys(v, path, medium_keys);
    MediumSpec m;
    resolved = json::object();
    bool ok = true;
    const std::string apath = key_path(path, "albedo");
    if (!v.contains("albedo")) {
        c.fail(apath, "missing (the single-scattering albedo: a number in [0, 1] or [r, g, b])");
        ok = false;
    } else {
        json r;
        if (const auto a = parse_albedo(v["albedo"], apath, m.grey, r)) {
            m.albedo = *a;
            resolved["albedo"] = r;
        } else {
            ok = false;
        }
    }

    json phase = json{{"type", "isotropic"}};
    if (v.contains("phase") && !parse_phase(v["phase"], key_path(path, "phase"), m, phase))
        ok = false;
    resolved["phase"] = phase;

    // A positive real number: the medium's index, its optical depth.
    const auto positive = [&](const char* key) -> std::optional<double> {
        const std::string kpath = key_path(path, key);
        const auto x = c.number(v[key], kpath);
        if (x && !(*x > 0.0)) {
            c.fail(kpath, cat("must be > 0 (got ", show(v[key]), ")"));
            return std::nullopt;
        }
        return x;
    };
    if (v.contains("index")) {
        if (const auto n = positive("index")) {
            m.index = *n;
            resolved["index"] = *n;
        } else {
            ok = false;
        }
    }
    // Resolved only when given: a medium without it is semi-infinite, as before.
    if (v.contains("optical_depth")) {
        if (const auto tau = positive("optical_depth")) {
            m.optical_depth = *tau;
            resolved["optical_depth"] = *tau;
        } else {
            ok = false;
        }
    }
    if (!ok) return std::nullopt;
    return m;
}

} // namespace brdf::material::spec_detail
