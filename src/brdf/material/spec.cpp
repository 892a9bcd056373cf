#include <brdf/material/spec.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/text.h>
#include <brdf/core/parse.h>
#include <brdf/material/catalogue.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <system_error>

namespace brdf::material {

using nlohmann::json;

std::string_view to_string(Surface surface) {
    switch (surface) {
    case Surface::None: return "none";
    case Surface::Smooth: return "smooth";
    }
    return "unknown";
}

std::string_view to_string(PhaseType type) {
    switch (type) {
    case PhaseType::Isotropic: return "isotropic";
    case PhaseType::Rayleigh: return "rayleigh";
    case PhaseType::HenyeyGreenstein: return "henyey_greenstein";
    case PhaseType::Legendre: return "legendre";
    }
    return "unknown";
}

std::string_view to_string(Model model) {
    switch (model) {
    case Model::Exact: return "exact";
    case Model::Dipole: return "dipole";
    }
    return "unknown";
}

namespace {

// Shortest text that reads back as the same double ("0.1", "2.7", "1e-05").
std::string shortest(double x) {
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, x);
    return std::string(buffer, result.ptr);
}

std::string complex_text(std::complex<double> m) {
    return m.imag() == 0.0 ? shortest(m.real())
                           : cat(shortest(m.real()), "+", shortest(m.imag()), "i");
}

} // namespace

std::string IndexSpec::describe() const {
    if (!id.empty()) return id;
    if (constant) return complex_text(*constant);
    if (!nk.empty()) return cat("nk table (", nk.size(), " rows)");
    return model.name();
}

double MaterialSpec::pigment_volume_fraction() const {
    double sum = 0.0;
    for (const PigmentSpec& p : pigments) sum += p.volume_fraction;
    return sum;
}

namespace {

// ---------------------------------------------------------------------------------------------
// Paths, values, suggestions

bool is_identifier(std::string_view key) {
    if (key.empty()) return false;
    return std::all_of(key.begin(), key.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
               c == '_';
    });
}

std::string key_path(const std::string& base, std::string_view key) {
    if (!is_identifier(key)) return cat(base, "[", json(std::string(key)).dump(), "]");
    return base.empty() ? std::string(key) : cat(base, ".", key);
}

std::string elem_path(const std::string& base, std::size_t i) { return cat(base, "[", i, "]"); }

// A JSON value for "(got VALUE)": compact, truncated, non-finite numbers spelled out (dump() would
// print them as null).
std::string show(const json& v) {
    if (v.is_number_float() && !std::isfinite(v.get<double>())) {
        const double x = v.get<double>();
        return std::isnan(x) ? "NaN" : (x > 0 ? "Infinity" : "-Infinity");
    }
    std::string s = v.dump(-1, ' ', false, json::error_handler_t::replace);
    if (s.size() > 60) s = s.substr(0, 56) + " ...";
    return s;
}

const char* type_name(const json& v) {
    switch (v.type()) {
    case json::value_t::null: return "null";
    case json::value_t::object: return "an object";
    case json::value_t::array: return "an array";
    case json::value_t::string: return "a string";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "a number";
    default: return "an unsupported value";
    }
}



// The closest of `known` to `key` when close enough to be a typo, else "".
std::string closest(std::string_view key, const std::vector<std::string_view>& known) {
    const std::string query = ascii_lower(key);
    std::string best;
    std::size_t best_distance = std::string::npos;
    for (std::string_view k : known) {
        const std::string candidate = ascii_lower(k);
        // A prefix of at least 3 characters ("r_eff" for "r_eff_um", "absorption" for
        // "absorption_per_mm") is the likeliest intent, ahead of any edit distance.
        const bool prefix = std::min(query.size(), candidate.size()) >= 3 &&
                            (candidate.starts_with(query) || query.starts_with(candidate));
        const std::size_t d = prefix ? 0 : edit_distance(query, candidate);
        if (d < best_distance) best_distance = d, best = std::string(k);
    }
    const std::size_t allowed = std::max<std::size_t>(2, query.size() / 3);
    return best_distance <= allowed && best_distance < query.size() ? best : std::string();
}

std::string list(const std::vector<std::string_view>& items) {
    std::string out;
    for (std::string_view s : items) out += (out.empty() ? "" : ", ") + std::string(s);
    return out;
}

// ---------------------------------------------------------------------------------------------
// Problem collection

class Checker {
  public:
    explicit Checker(std::string source) : m_source(std::move(source)) {}

    const std::string& source() const { return m_source; }
    std::size_t failures() const { return m_failures; }
    const std::vector<std::string>& problems() const { return m_problems; }

    /// "SOURCE: PATH: message" (or "SOURCE: message" for an empty path); identical lines (a fault
    /// in catalogue defaults seen by every material) are kept once.
    void fail(const std::string& path, const std::string& message) {
        // A required key reported as a likely typo ("volume_fracton: unknown key (did you mean
        // ...)") is not reported missing as well: one mistake, one line.
        if (message.starts_with("missing") && m_suggested.count(path)) {
            ++m_failures;
            return;
        }
        add_line(path.empty() ? cat(m_source, ": ", message)
                              : cat(m_source, ": ", path, ": ", message));
    }
    /// A message that already starts with its path (the index and spectrum helpers' format).
    void fail_raw(const std::string& message) { add_line(cat(m_source, ": ", message)); }
    /// A resource limit (SpecLimits) exceeded: reported like any problem, but a document whose only
    /// problems are limits is refused with a LimitError (only_limits()).
    void fail_limit(const std::string& path, const std::string& message) {
        const std::size_t before = m_problems.size();
        fail(path, message);
        m_limit_problems += m_problems.size() - before;
    }
    bool only_limits() const { return !m_problems.empty() && m_limit_problems == m_problems.size(); }

    /// An unknown key, with a suggestion when it is a likely typo.
    void unknown_key(const std::string& path, std::string_view key,
                     const std::vector<std::string_view>& known, std::string_view note = {}) {
        std::string message = "unknown key";
        const std::string guess = closest(key, known);
        if (!guess.empty()) {
            message += cat(" (did you mean \"", guess, "\"?)");
            // The path the suggested key would have: this path with its last component replaced.
            std::string parent = path.substr(0, path.size() - key_path("", key).size());
            if (is_identifier(key) && !parent.empty()) parent.pop_back(); // the '.'
            m_suggested.insert(key_path(parent, guess));
        }
        message += cat("; expected one of: ", list(known));
        if (!note.empty()) message += cat(" (", note, ")");
        fail(path, message);
    }

    /// Reports every key of `object` that is not in `known` (paths from `path_of`).
    void check_keys(const json& object, const std::function<std::string(std::string_view)>& path_of,
                    const std::vector<std::string_view>& known, std::string_view note = {}) {
        for (const auto& item : object.items()) {
            const std::string& key = item.key();
            if (std::find(known.begin(), known.end(), key) == known.end())
                unknown_key(path_of(key), key, known, note);
        }
    }
    void check_keys(const json& object, const std::string& base,
                    const std::vector<std::string_view>& known, std::string_view note = {}) {
        check_keys(object, [&](std::string_view k) { return key_path(base, k); }, known, note);
    }

    std::optional<double> number(const json& v, const std::string& path) {
        if (!v.is_number()) {
            fail(path, cat("expected a number, got ", type_name(v), " (got ", show(v), ")"));
            return std::nullopt;
        }
        const double x = v.get<double>();
        if (!std::isfinite(x)) {
            fail(path, cat("must be a finite number (got ", show(v), ")"));
            return std::nullopt;
        }
        return x;
    }

    std::optional<std::string> string(const json& v, const std::string& path) {
        if (!v.is_string()) {
            fail(path, cat("expected a string, got ", type_name(v), " (got ", show(v), ")"));
            return std::nullopt;
        }
        return v.get<std::string>();
    }

    bool object(const json& v, const std::string& path, std::string_view what) {
        if (v.is_object()) return true;
        fail(path, cat("expected an object ", what, ", got ", type_name(v), " (got ", show(v), ")"));
        return false;
    }

    bool array(const json& v, const std::string& path, std::string_view what) {
        if (v.is_array()) return true;
        fail(path, cat("expected an array ", what, ", got ", type_name(v), " (got ", show(v), ")"));
        return false;
    }

  private:
    void add_line(std::string line) {
        ++m_failures;
        if (std::find(m_problems.begin(), m_problems.end(), line) == m_problems.end())
            m_problems.push_back(std::move(line));
    }

    std::string m_source;
    std::vector<std::string> m_problems;
    std::set<std::string> m_suggested;
    std::size_t m_failures = 0;
    std::size_t m_limit_problems = 0;
};

// ---------------------------------------------------------------------------------------------
// One material

const std::vector<std::string_view> material_keys = {
    "name", "description", "binder", "pigments", "medium", "surface", "spectrum", "accuracy",
    "outputs", "limits", "model"};
const std::vector<std::string_view> limit_keys = {"max_wavelengths", "max_size_parameter",
                                                  "min_tolerance", "max_legendre_terms"};
const std::vector<std::string_view> pigment_keys = {"material", "index", "nk",
                                                                  "volume_fraction", "size"};
const std::vector<std::string_view> binder_keys = {"material", "index", "nk",
                                                                 "absorption_per_mm"};
const std::vector<std::string_view> index_object_keys = {"index", "nk"};
const std::vector<std::string_view> size_keys_all = {
    "distribution", "radius_um", "r_eff_um", "v_eff", "r_g_um", "sigma_g"};
const std::vector<std::string_view> medium_keys = {"albedo", "phase", "index"};
const std::vector<std::string_view> phase_keys_all = {"type", "g", "coefficients"};

struct IndexCheck {
    std::string path; // of the key that gave the index
    const IndexSpec* index = nullptr;
};

// A material after merging catalogue defaults: each top-level key knows where it was written.
struct MaterialInput {
    json object;
    std::string base;                              // "materials[1]" or "" for a single material
    std::map<std::string, std::string> key_base;   // key -> "defaults" for inherited keys
    std::string path(std::string_view key) const {
        const auto it = key_base.find(std::string(key));
        return key_path(it == key_base.end() ? base : it->second, key);
    }
};

class MaterialParser {
  public:
    MaterialParser(Checker& checker, const MaterialInput& input)
        : c(checker), in(input), obj(input.object) {}

    std::optional<MaterialSpec> parse();

  private:
    std::optional<IndexSpec> parse_index(const json& holder, const std::string& holder_path,
                                         bool binder, json& resolved_material);
    std::optional<IndexSpec> parse_constant(const json& v, const std::string& path, bool binder,
                                            json& resolved);
    std::optional<IndexSpec> parse_nk(const json& v, const std::string& path, json& resolved);
    std::optional<mie::SizeDistribution> parse_size(const json& v, const std::string& path,
                                                    json& resolved);
    std::optional<BinderSpec> parse_binder(const json& v, const std::string& path, json& resolved);
    std::optional<std::vector<PigmentSpec>> parse_pigments(const json& v, const std::string& path,
                                                           json& resolved);
    std::optional<MediumSpec> parse_medium(const json& v, const std::string& path, json& resolved);
    std::optional<SpectralSet> parse_spectrum(const json& v, const std::string& path,
                                              json& resolved);
    std::optional<AccuracySpec> parse_accuracy(const json& v, const std::string& path,
                                               json& resolved);
    std::optional<std::vector<std::string>> parse_outputs(const json& v, const std::string& path,
                                                          json& resolved);
    void check_ranges(const SpectralSet& spectrum, const std::vector<IndexCheck>& checks);
    void parse_limits(const json& v, const std::string& path, json& resolved);
    void check_size_parameters(const SpectralSet& spectrum, const MaterialSpec& spec);

    void warn(const std::string& path, const std::string& message) {
        m_warnings.push_back(path.empty() ? cat(c.source(), ": ", message)
                                          : cat(c.source(), ": ", path, ": ", message));
    }

    Checker& c;
    const MaterialInput& in;
    const json& obj;
    std::vector<std::string> m_warnings;
    SpecLimits m_limits; // parsed before the spectrum and accuracy, which they bound
};

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

std::optional<mie::SizeDistribution> MaterialParser::parse_size(const json& v,
                                                                const std::string& path,
                                                                json& resolved) {
    if (!c.object(v, path, "(e.g. {\"distribution\": \"gamma\", \"r_eff_um\": 0.4, \"v_eff\": "
                           "0.1})"))
        return std::nullopt;
    struct Kind {
        std::string_view name;
        mie::DistributionKind kind;
        std::string_view p1, p2; // p2 empty for monodisperse
    };
    static const Kind kinds[] = {
        {"monodisperse", mie::DistributionKind::Monodisperse, "radius_um", ""},
        {"power_law", mie::DistributionKind::PowerLaw, "r_eff_um", "v_eff"},
        {"gamma", mie::DistributionKind::Gamma, "r_eff_um", "v_eff"},
        {"lognormal", mie::DistributionKind::Lognormal, "r_g_um", "sigma_g"},
    };
    const Kind* kind = nullptr;
    const std::string dpath = key_path(path, "distribution");
    if (!v.contains("distribution")) {
        c.fail(dpath, "missing (one of monodisperse, power_law, gamma, lognormal)");
    } else if (const auto name = c.string(v["distribution"], dpath)) {
        for (const Kind& k : kinds)
            if (k.name == *name) kind = &k;
        if (!kind) {
            std::string message = "must be one of monodisperse, power_law, gamma, lognormal";
            const std::string guess =
                closest(*name, {"monodisperse", "power_law", "gamma", "lognormal"});
            if (!guess.empty()) message += cat(" (did you mean \"", guess, "\"?)");
            c.fail(dpath, cat(message, " (got ", show(v["distribution"]), ")"));
        }
    }
    if (!kind) {
        c.check_keys(v, path, size_keys_all);
        return std::nullopt;
    }
    const std::string takes = kind->p2.empty() ? cat(kind->p1) : cat(kind->p1, " and ", kind->p2);
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        if (key == "distribution" || key == kind->p1 || key == kind->p2) continue;
        if (std::find(size_keys_all.begin(), size_keys_all.end(), key) != size_keys_all.end())
            c.fail(key_path(path, key),
                   cat("not used by the ", kind->name, " distribution (it takes ", takes, ")"));
        else
            c.unknown_key(key_path(path, key), key,
                          kind->p2.empty()
                              ? std::vector<std::string_view>{"distribution", kind->p1}
                              : std::vector<std::string_view>{"distribution", kind->p1, kind->p2},
                          cat("the ", kind->name, " distribution takes ", takes));
    }
    const auto get = [&](std::string_view key) -> std::optional<double> {
        const std::string kpath = key_path(path, key);
        if (!v.contains(key)) {
            c.fail(kpath, cat("missing (the ", kind->name, " distribution takes ", takes, ")"));
            return std::nullopt;
        }
        return c.number(v[std::string(key)], kpath);
    };
    const auto p1 = get(kind->p1);
    const auto p2 = kind->p2.empty() ? std::optional<double>(0.0) : get(kind->p2);
    bool ok = p1 && p2;
    if (p1 && !(*p1 > 0.0)) {
        c.fail(key_path(path, kind->p1), cat("must be > 0 (got ", show(v[std::string(kind->p1)]), ")"));
        ok = false;
    }
    if (p2 && kind->kind == mie::DistributionKind::Gamma && !(*p2 > 0.0 && *p2 < 0.5)) {
        c.fail(key_path(path, "v_eff"),
               cat("must be in (0, 0.5) for the gamma distribution (it is not normalisable at "
                   "0.5) (got ", show(v["v_eff"]), ")"));
        ok = false;
    }
    if (p2 && kind->kind == mie::DistributionKind::PowerLaw && !(*p2 > 0.0)) {
        c.fail(key_path(path, "v_eff"), cat("must be > 0 (got ", show(v["v_eff"]), ")"));
        ok = false;
    }
    if (p2 && kind->kind == mie::DistributionKind::Lognormal && !(*p2 > 1.0)) {
        c.fail(key_path(path, "sigma_g"), cat("must be > 1 (got ", show(v["sigma_g"]), ")"));
        ok = false;
    }
    if (!ok) return std::nullopt;
    // The distribution's own checks are the final word on the ranges it supports (e.g. power-law
    // v_eff <= 2, log-normal sigma_g <= 3): its message is put under the parameter it names.
    try {
        std::optional<mie::SizeDistribution> d;
        switch (kind->kind) {
        case mie::DistributionKind::Monodisperse: d = mie::monodisperse(*p1); break;
        case mie::DistributionKind::PowerLaw: d = mie::power_law(*p1, *p2); break;
        case mie::DistributionKind::Gamma: d = mie::gamma(*p1, *p2); break;
        case mie::DistributionKind::Lognormal: d = mie::lognormal(*p1, *p2); break;
        }
        resolved = json::object();
        resolved["distribution"] = kind->name;
        resolved[std::string(kind->p1)] = *p1;
        if (!kind->p2.empty()) resolved[std::string(kind->p2)] = *p2;
        return d;
    } catch (const InputError& e) {
        const std::string message = e.what();
        std::string_view key = kind->p1;
        std::size_t first = message.find(kind->p1);
        if (!kind->p2.empty()) {
            const std::size_t second = message.find(kind->p2);
            if (second != std::string::npos && (first == std::string::npos || second < first))
                key = kind->p2;
        }
        c.fail(key_path(path, key), message);
        return std::nullopt;
    }
}

std::optional<BinderSpec> MaterialParser::parse_binder(const json& v, const std::string& path,
                                                       json& resolved) {
    if (!c.object(v, path, "(e.g. {\"material\": \"pmma\"} or {\"index\": 1.5})"))
        return std::nullopt;
    c.check_keys(v, path, binder_keys);
    json material;
    auto index = parse_index(v, path, true, material);
    double absorption = 0.0;
    bool ok = index.has_value();
    if (v.contains("absorption_per_mm")) {
        const std::string apath = key_path(path, "absorption_per_mm");
        const auto a = c.number(v["absorption_per_mm"], apath);
        if (!a) {
            ok = false;
        } else if (!(*a >= 0.0)) {
            c.fail(apath, cat("must be >= 0 (got ", show(v["absorption_per_mm"]), ")"));
            ok = false;
        } else {
            absorption = *a;
        }
    }
    if (!ok) return std::nullopt;
    resolved = json{{"material", material}, {"absorption_per_mm", absorption}};
    return BinderSpec{std::move(*index), absorption};
}

std::optional<std::vector<PigmentSpec>>
MaterialParser::parse_pigments(const json& v, const std::string& path, json& resolved) {
    if (!c.array(v, path, "of pigments")) return std::nullopt;
    if (v.empty()) {
        c.fail(path, "must list at least one pigment (got [])");
        return std::nullopt;
    }
    std::vector<PigmentSpec> out;
    resolved = json::array();
    bool ok = true;
    double sum = 0.0;
    bool sum_known = true;
    for (std::size_t i = 0; i < v.size(); ++i) {
        const json& p = v[i];
        const std::string ppath = elem_path(path, i);
        if (!c.object(p, ppath, "(a pigment: material, volume_fraction, size)")) {
            ok = false;
            sum_known = false;
            continue;
        }
        c.check_keys(p, ppath, pigment_keys);
        json material, size_json;
        auto index = parse_index(p, ppath, false, material);
        double fraction = 0.0;
        bool fraction_ok = false;
        const std::string fpath = key_path(ppath, "volume_fraction");
        if (!p.contains("volume_fraction")) {
            c.fail(fpath, "missing (the pigment's volume fraction, in (0, 1])");
        } else if (const auto f = c.number(p["volume_fraction"], fpath)) {
            if (*f > 0.0 && *f <= 1.0) {
                fraction = *f;
                fraction_ok = true;
            } else {
                c.fail(fpath, cat("must be in (0, 1] (got ", show(p["volume_fraction"]), ")"));
            }
        }
        if (fraction_ok)
            sum += fraction;
        else
            sum_known = false;
        std::optional<mie::SizeDistribution> size;
        const std::string spath = key_path(ppath, "size");
        if (!p.contains("size"))
            c.fail(spath, "missing (e.g. {\"distribution\": \"gamma\", \"r_eff_um\": 0.4, "
                          "\"v_eff\": 0.1})");
        else
            size = parse_size(p["size"], spath, size_json);
        if (!index || !fraction_ok || !size) {
            ok = false;
            continue;
        }
        out.push_back(PigmentSpec{std::move(*index), fraction, *size});
        resolved.push_back(json{{"material", material}, {"volume_fraction", fraction},
                                {"size", size_json}});
    }
    if (sum_known && sum > 1.0 + 1e-12) {
        std::string terms;
        for (const json& p : v) terms += (terms.empty() ? "" : " + ") + show(p["volume_fraction"]);
        c.fail(path, cat("volume fractions sum to ", shortest(sum), ", more than 1 (got ", terms,
                         ")"));
        ok = false;
    } else if (sum_known && sum > 0.6) {
        warn(path, cat("volume fractions sum to ", shortest(sum),
                       ": beyond about 0.6 the particles are no longer independent scatterers "
                       "(dependent scattering), so the computed BRDF is only indicative"));
    }
    if (!ok) return std::nullopt;
    return out;
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
    } else if (const json& a = v["albedo"]; a.is_number()) {
        const auto x = c.number(a, apath);
        if (x && !(*x >= 0.0 && *x <= 1.0))
            c.fail(apath, cat("must be in [0, 1] (got ", show(a), ")"));
        if (x && *x >= 0.0 && *x <= 1.0) {
            m.albedo = {*x, *x, *x};
            m.grey = true;
            resolved["albedo"] = *x;
        } else {
            ok = false;
        }
    } else if (a.is_array()) {
        if (a.size() != 3) {
            c.fail(apath, cat("expected one number or three [r, g, b] (got ", show(a), ")"));
            ok = false;
        } else {
            for (std::size_t i = 0; i < 3; ++i) {
                const auto x = c.number(a[i], elem_path(apath, i));
                if (x && !(*x >= 0.0 && *x <= 1.0))
                    c.fail(elem_path(apath, i), cat("must be in [0, 1] (got ", show(a[i]), ")"));
                if (x && *x >= 0.0 && *x <= 1.0)
                    m.albedo[i] = *x;
                else
                    ok = false;
            }
            m.grey = false;
            resolved["albedo"] = json::array({m.albedo[0], m.albedo[1], m.albedo[2]});
        }
    } else {
        c.fail(apath, cat("expected a number in [0, 1] or [r, g, b], got ", type_name(a), " (got ",
                          show(a), ")"));
        ok = false;
    }

    const std::string ppath = key_path(path, "phase");
    json phase = json{{"type", "isotropic"}};
    if (v.contains("phase")) {
        const json& p = v["phase"];
        std::optional<std::string> type;
        const std::string tpath = p.is_object() ? key_path(ppath, "type") : ppath;
        if (p.is_string()) {
            type = p.get<std::string>();
        } else if (p.is_object()) {
            if (!p.contains("type"))
                c.fail(tpath, "missing (one of isotropic, rayleigh, henyey_greenstein, legendre)");
            else
                type = c.string(p["type"], tpath);
        } else {
            c.fail(ppath, cat("expected an object {\"type\": ...} or a type name, got ",
                              type_name(p), " (got ", show(p), ")"));
        }
        static const std::pair<std::string_view, PhaseType> types[] = {
            {"isotropic", PhaseType::Isotropic},
            {"rayleigh", PhaseType::Rayleigh},
            {"henyey_greenstein", PhaseType::HenyeyGreenstein},
            {"legendre", PhaseType::Legendre}};
        std::optional<PhaseType> kind;
        if (type) {
            for (const auto& [name, t] : types)
                if (name == *type) kind = t;
            if (!kind) {
                std::string message =
                    "must be one of isotropic, rayleigh, henyey_greenstein, legendre";
                const std::string guess =
                    closest(*type, {"isotropic", "rayleigh", "henyey_greenstein", "legendre"});
                if (!guess.empty()) message += cat(" (did you mean \"", guess, "\"?)");
                c.fail(tpath, cat(message, " (got \"", *type, "\")"));
            }
        }
        if (!kind) {
            ok = false;
            if (p.is_object()) c.check_keys(p, ppath, phase_keys_all);
        } else {
            m.phase = *kind;
            phase = json{{"type", to_string(*kind)}};
            const bool wants_g = *kind == PhaseType::HenyeyGreenstein;
            const bool wants_coefficients = *kind == PhaseType::Legendre;
            if (p.is_string() && (wants_g || wants_coefficients)) {
                c.fail(ppath, cat("the ", *type, " phase function needs ",
                                  wants_g ? "\"g\": {\"type\": \"henyey_greenstein\", \"g\": 0.5}"
                                          : "\"coefficients\": {\"type\": \"legendre\", "
                                            "\"coefficients\": [1, ...]}",
                                  " (got ", show(p), ")"));
                ok = false;
            }
            if (p.is_object()) {
                for (const auto& item : p.items()) {
                    const std::string& key = item.key();
                    if (key == "type" || (key == "g" && wants_g) ||
                        (key == "coefficients" && wants_coefficients))
                        continue;
                    if (key == "g" || key == "coefficients")
                        c.fail(key_path(ppath, key),
                               cat("not used by the ", *type, " phase function"));
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
                                c.fail(lpath, cat("beta_0 must be 1 (the phase function is "
                                                  "normalised) (got ",
                                                  show(cs[l]), ")"));
                                cok = false;
                            } else if (!(std::abs(*b) <= 2.0 * static_cast<double>(l) + 1.0)) {
                                c.fail(lpath, cat("must satisfy |beta_", l, "| <= ", 2 * l + 1,
                                                  " (2l + 1, for a non-negative phase function) "
                                                  "(got ",
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
            }
        }
    }
    resolved["phase"] = phase;

    if (v.contains("index")) {
        const std::string ipath = key_path(path, "index");
        const auto n = c.number(v["index"], ipath);
        if (n && !(*n > 0.0)) {
            c.fail(ipath, cat("must be > 0 (got ", show(v["index"]), ")"));
            ok = false;
        } else if (n) {
            m.index = *n;
            resolved["index"] = *n;
        } else {
            ok = false;
        }
    }
    if (!ok) return std::nullopt;
    return m;
}

std::optional<SpectralSet> MaterialParser::parse_spectrum(const json& v, const std::string& path,
                                                          json& resolved) {
    if (v.is_string()) {
        const std::string name = v.get<std::string>();
        if (name == "visible") {
            resolved = "visible";
            return SpectralSet::visible();
        }
        if (name == "rgb") {
            resolved = "rgb";
            return SpectralSet::rgb();
        }
        std::string message = "must be \"visible\", \"rgb\" or {\"wavelengths_nm\": [...]}";
        const std::string guess = closest(name, {"visible", "rgb"});
        if (!guess.empty()) message += cat(" (did you mean \"", guess, "\"?)");
        c.fail(path, cat(message, " (got ", show(v), ")"));
        return std::nullopt;
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
        const std::string name = v.get<std::string>();
        for (const auto& [level, tolerance] : levels)
            if (level == name) {
                resolved = name;
                return AccuracySpec{name, tolerance};
            }
        std::string message = "must be \"draft\", \"default\", \"reference\" or {\"tolerance\": t}";
        const std::string guess = closest(name, {"draft", "default", "reference"});
        if (!guess.empty()) message += cat(" (did you mean \"", guess, "\"?)");
        c.fail(path, cat(message, " (got ", show(v), ")"));
        return std::nullopt;
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
    if (!c.array(v, path, "of output formats (\"merl\", \"exr\")")) return std::nullopt;
    bool merl = false, exr = false, ok = true;
    for (std::size_t i = 0; i < v.size(); ++i) {
        const std::string epath = elem_path(path, i);
        const auto name = c.string(v[i], epath);
        if (!name) {
            ok = false;
            continue;
        }
        bool* flag = *name == "merl" ? &merl : *name == "exr" ? &exr : nullptr;
        if (!flag) {
            std::string message = "must be \"merl\" or \"exr\"";
            const std::string guess = closest(*name, {"merl", "exr"});
            if (!guess.empty()) message += cat(" (did you mean \"", guess, "\"?)");
            c.fail(epath, cat(message, " (got ", show(v[i]), ")"));
            ok = false;
        } else if (*flag) {
            c.fail(epath, cat("\"", *name, "\" is listed twice"));
            ok = false;
        } else {
            *flag = true;
        }
    }
    if (!ok) return std::nullopt;
    std::vector<std::string> out;
    if (merl) out.emplace_back("merl");
    if (exr) out.emplace_back("exr");
    resolved = out;
    return out;
}

void MaterialParser::check_ranges(const SpectralSet& spectrum,
                                  const std::vector<IndexCheck>& checks) {
    const auto wavelengths = spectrum.wavelengths_nm();
    for (const IndexCheck& check : checks) {
        std::vector<double> bad, extrapolated;
        std::string first_message;
        for (double l : wavelengths) {
            try {
                if (check.index->model.at(l).extrapolated) extrapolated.push_back(l);
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
            if (!check.index->nk.empty())
                message += "; tables are never extrapolated: extend the table or choose a spectrum "
                           "within it";
            c.fail(check.path, message);
        }
        if (!extrapolated.empty()) {
            const WavelengthRange data = check.index->model.data_range();
            warn(check.path,
                 cat(check.index->describe(), ": ", extrapolated.size(), " wavelength",
                     extrapolated.size() > 1 ? "s" : "", " (", extrapolated.front(), "-",
                     extrapolated.back(), " nm) lie outside its data (", data.min_nm, "-",
                     data.max_nm, " nm) and use the documented extension of its dispersion "
                     "formula"));
        }
    }
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

// The largest Mie size parameter of each pigment, x = 2 pi r_max n_binder / lambda (the wavenumber
// in the binder times the distribution's upper integration radius), over the spectrum. Mie series
// need about x + 4 x^(1/3) terms per radius (Wiscombe 1980) and the ensemble integral more radius
// nodes as x grows, so the cost rises at least as x^2.
void MaterialParser::check_size_parameters(const SpectralSet& spectrum, const MaterialSpec& spec) {
    if (!spec.binder || spec.pigments.empty()) return;
    const auto digits4 = [](double x) {
        char buffer[32];
        std::snprintf(buffer, sizeof buffer, "%.4g", x);
        return std::string(buffer);
    };
    for (std::size_t i = 0; i < spec.pigments.size(); ++i) {
        const double r_max = spec.pigments[i].size.r_max_um();
        double x_max = 0.0, n_at = 0.0, lambda_at = 0.0;
        for (double lambda : spectrum.wavelengths_nm()) {
            double n = 0.0;
            try {
                n = spec.binder->index.model.at(lambda).n;
            } catch (const Error&) {
                continue; // outside the binder's data: check_ranges reported it
            }
            const double x = 2.0 * std::numbers::pi * r_max * n / (1e-3 * lambda);
            if (x > x_max) x_max = x, n_at = n, lambda_at = lambda;
        }
        if (x_max > m_limits.max_size_parameter)
            c.fail_limit(
                key_path(elem_path(in.path("pigments"), i), "size"),
                cat("size parameter x = 2 pi r_max n_binder / lambda reaches ", std::round(x_max),
                    " (r_max ", digits4(r_max), " um, n_binder ", digits4(n_at), " at ", lambda_at,
                    " nm), above the limit of ",
                    shortest(m_limits.max_size_parameter),
                    " (Mie series need about x terms per radius); to override, set \"limits\": "
                    "{\"max_size_parameter\": ",
                    std::ceil(x_max), "}"));
    }
}

std::optional<MaterialSpec> MaterialParser::parse() {
    const std::size_t failures_before = c.failures();
    c.check_keys(obj, [&](std::string_view k) { return in.path(k); }, material_keys);
    MaterialSpec spec;
    json resolved = json::object();

    // name
    const std::string npath = in.path("name");
    if (!obj.contains("name")) {
        c.fail(npath, "missing (the material's name, [A-Za-z0-9._-]{1,100}; it names the output "
                      "files)");
    } else if (const auto name = c.string(obj["name"], npath)) {
        const bool chars_ok = std::all_of(name->begin(), name->end(), [](char ch) {
            return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') ||
                   (ch >= '0' && ch <= '9') || ch == '.' || ch == '_' || ch == '-';
        });
        if (name->empty() || name->size() > 100 || !chars_ok)
            c.fail(npath, cat("must be 1 to 100 characters from A-Z a-z 0-9 . _ - (it names the "
                              "output files) (got ",
                              show(obj["name"]), ")"));
        else
            spec.name = *name;
        resolved["name"] = *name;
    }
    if (obj.contains("description")) {
        if (const auto d = c.string(obj["description"], in.path("description"))) {
            spec.description = *d;
            resolved["description"] = *d;
        }
    }

    // The model: binder + pigments, or medium.
    const bool has_binder = obj.contains("binder"), has_pigments = obj.contains("pigments");
    const bool has_medium = obj.contains("medium");
    std::vector<IndexCheck> index_checks;
    if ((has_binder || has_pigments) && has_medium) {
        c.fail(in.path("medium"),
               cat("cannot be combined with ", has_binder ? "\"binder\"" : "\"pigments\"",
                   ": a material is either particulate (binder + pigments) or an analytic "
                   "medium"));
    } else if (!has_binder && !has_pigments && !has_medium) {
        c.fail(in.base, "needs either \"binder\" + \"pigments\" (a particulate material) or "
                        "\"medium\" (an analytic medium)");
    } else if (has_medium) {
        json r;
        spec.medium = parse_medium(obj["medium"], in.path("medium"), r);
        resolved["medium"] = r;
    } else {
        if (!has_binder)
            c.fail(in.path("binder"),
                   "missing (pigments need a binder, e.g. {\"material\": \"pmma\"}, "
                   "{\"index\": 1.5}, or {\"material\": \"air\"} for a bare powder)");
        if (!has_pigments)
            c.fail(in.path("pigments"), "missing (a particulate material needs at least one "
                                        "pigment)");
        json rb, rp;
        if (has_binder) {
            spec.binder = parse_binder(obj["binder"], in.path("binder"), rb);
            resolved["binder"] = rb;
        }
        if (has_pigments) {
            if (auto pigments = parse_pigments(obj["pigments"], in.path("pigments"), rp))
                spec.pigments = std::move(*pigments);
            resolved["pigments"] = rp;
        }
    }

    // surface
    const std::string spath = in.path("surface");
    std::optional<Surface> surface = has_medium ? Surface::None : Surface::Smooth;
    if (obj.contains("surface")) {
        surface.reset();
        if (const auto s = c.string(obj["surface"], spath)) {
            if (*s == "none")
                surface = Surface::None;
            else if (*s == "smooth")
                surface = Surface::Smooth;
            else {
                std::string message = "must be \"none\" or \"smooth\"";
                const std::string guess = closest(*s, {"none", "smooth"});
                if (!guess.empty()) message += cat(" (did you mean \"", guess, "\"?)");
                c.fail(spath, cat(message, " (got ", show(obj["surface"]), ")"));
            }
        }
    }
    if (surface) {
        spec.surface = *surface;
        resolved["surface"] = to_string(*surface);
        if (*surface == Surface::Smooth && has_medium && spec.medium && !spec.medium->index)
            c.fail(key_path(in.path("medium"), "index"),
                   "missing (\"surface\": \"smooth\" on an analytic medium needs the medium's real "
                   "refractive index, e.g. \"index\": 1.5)");
        if (*surface == Surface::None && spec.medium && spec.medium->index)
            warn(key_path(in.path("medium"), "index"),
                 "unused with \"surface\": \"none\" (the index only matters for a smooth surface)");
    }

    // model: "exact" (default) or "dipole"; resolved only when not the default, so that specs
    // without it keep their hashes
    if (obj.contains("model")) {
        const std::string mpath = in.path("model");
        if (const auto m = c.string(obj["model"], mpath)) {
            if (*m == "exact") {
                spec.model = Model::Exact;
            } else if (*m == "dipole") {
                spec.model = Model::Dipole;
                resolved["model"] = "dipole";
            } else {
                std::string message = "must be \"exact\" or \"dipole\"";
                const std::string guess = closest(*m, {"exact", "dipole"});
                if (!guess.empty()) message += cat(" (did you mean \"", guess, "\"?)");
                c.fail(mpath, cat(message, " (got ", show(obj["model"]), ")"));
            }
        }
    }

    // limits: before the spectrum and accuracy, which they bound; resolved only when given, so
    // that specs without them keep their hashes
    if (obj.contains("limits")) {
        json r = json::object();
        parse_limits(obj["limits"], in.path("limits"), r);
        resolved["limits"] = r;
    }

    // spectrum, accuracy, outputs
    std::optional<SpectralSet> spectrum = SpectralSet::visible();
    resolved["spectrum"] = "visible";
    if (obj.contains("spectrum")) {
        json r;
        spectrum = parse_spectrum(obj["spectrum"], in.path("spectrum"), r);
        resolved["spectrum"] = r;
    }
    if (obj.contains("accuracy")) {
        json r;
        if (auto a = parse_accuracy(obj["accuracy"], in.path("accuracy"), r)) spec.accuracy = *a;
        resolved["accuracy"] = r;
    } else {
        resolved["accuracy"] = "default";
    }
    if (obj.contains("outputs")) {
        json r;
        if (auto o = parse_outputs(obj["outputs"], in.path("outputs"), r)) spec.outputs = *o;
        resolved["outputs"] = r;
    } else {
        resolved["outputs"] = spec.outputs;
    }

    // The index data must cover every wavelength to solve.
    if (spectrum) {
        const auto source_key = [](const json& holder, const std::string& holder_path) {
            if (holder.contains("material")) {
                const json& m = holder["material"];
                if (m.is_object())
                    return key_path(key_path(holder_path, "material"),
                                    m.contains("nk") ? "nk" : "index");
                return key_path(holder_path, "material");
            }
            return key_path(holder_path, holder.contains("nk") ? "nk" : "index");
        };
        if (spec.binder)
            index_checks.push_back({source_key(obj["binder"], in.path("binder")), &spec.binder->index});
        if (!spec.pigments.empty())
            for (std::size_t i = 0; i < spec.pigments.size(); ++i)
                index_checks.push_back(
                    {source_key(obj["pigments"][i], elem_path(in.path("pigments"), i)),
                     &spec.pigments[i].index});
        check_ranges(*spectrum, index_checks);
        check_size_parameters(*spectrum, spec);
        spec.spectrum = std::move(*spectrum);
    }

    if (c.failures() != failures_before) return std::nullopt;
    spec.limits = m_limits;
    spec.resolved = std::move(resolved);
    spec.hash = fnv1a64_hex(spec.resolved.dump());
    spec.warnings = std::move(m_warnings);
    return spec;
}

// ---------------------------------------------------------------------------------------------
// Documents

// The document with `overlay`'s keys set on every material (over its own keys and the defaults).
json overlaid(const json& document, const json& overlay) {
    json out = document;
    const auto apply = [&](json& material) {
        if (!material.is_object()) return;
        for (const auto& item : overlay.items()) material[item.key()] = item.value();
    };
    if (!out.is_object()) return out;
    if (!out.contains("materials")) {
        apply(out);
    } else if (out["materials"].is_array()) {
        for (json& m : out["materials"]) apply(m);
    }
    return out;
}

// Logs each finding once per document: the same fault at several JSON paths (rutile's
// extrapolation in every material of a catalogue that uses it) is one line naming every path,
// "SOURCE: TEXT (at PATH, PATH, ...)". Each spec keeps its own warnings for its report.
void log_warnings_once(const std::vector<MaterialSpec>& specs, std::string_view source) {
    const std::string prefix = cat(source, ": ");
    const auto is_path_char = [](char ch) {
        return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '.' || ch == '[' ||
               ch == ']' || ch == '-';
    };
    std::vector<std::pair<std::string, std::vector<std::string>>> groups; // text -> paths
    for (const MaterialSpec& spec : specs)
        for (const std::string& w : spec.warnings) {
            std::string text = w, path;
            if (w.rfind(prefix, 0) == 0) {
                const std::string rest = w.substr(prefix.size());
                const std::size_t colon = rest.find(": ");
                if (colon != std::string::npos && colon > 0 &&
                    std::all_of(rest.begin(), rest.begin() + static_cast<std::ptrdiff_t>(colon), is_path_char)) {
                    path = rest.substr(0, colon);
                    text = rest.substr(colon + 2);
                }
            }
            auto group = std::find_if(groups.begin(), groups.end(),
                                      [&](const auto& g) { return g.first == text; });
            if (group == groups.end()) group = groups.insert(groups.end(), {text, {}});
            if (std::find(group->second.begin(), group->second.end(), path) == group->second.end())
                group->second.push_back(path);
        }
    for (const auto& [text, paths] : groups) {
        if (paths.size() == 1 && paths.front().empty()) {
            log::warn(text);
        } else if (paths.size() == 1) {
            log::warn(prefix, paths.front(), ": ", text);
        } else {
            std::string where;
            for (const std::string& p : paths) where += cat(where.empty() ? "" : ", ", p.empty() ? "(document)" : p);
            log::warn(prefix, text, " (at ", where, ")");
        }
    }
}

std::vector<MaterialSpec> parse_document(const json& document, std::string_view source_name,
                                         std::vector<std::string> early_problems) {
    Checker c{std::string(source_name)};
    for (std::string& p : early_problems) c.fail_raw(p);
    std::vector<MaterialSpec> specs;
    std::vector<std::string> sources;

    if (!document.is_object()) {
        c.fail("", cat("expected a JSON object: one material {\"name\": ...} or a catalogue "
                       "{\"materials\": [...]}, got ",
                       type_name(document), " (got ", show(document), ")"));
    } else if (!document.contains("materials")) {
        MaterialInput input{document, "", {}};
        if (auto spec = MaterialParser(c, input).parse()) {
            spec->source = std::string(source_name);
            specs.push_back(std::move(*spec));
        }
    } else {
        c.check_keys(document, "", {"materials", "defaults"},
                     "a catalogue has \"materials\" and optional \"defaults\"; material keys go "
                     "inside each material or in \"defaults\"");
        json defaults = json::object();
        if (document.contains("defaults")) {
            const json& d = document["defaults"];
            if (c.object(d, "defaults", "(keys merged into every material)")) {
                defaults = d;
                if (defaults.contains("name")) {
                    c.fail("defaults.name", "not allowed (every material needs its own name)");
                    defaults.erase("name");
                }
                c.check_keys(defaults, "defaults", material_keys);
            }
        }
        const json& materials = document["materials"];
        if (c.array(materials, "materials", "of material specs")) {
            if (materials.empty()) c.fail("materials", "must list at least one material (got [])");
            std::map<std::string, std::string> names; // lower-case name -> path of first use
            for (std::size_t i = 0; i < materials.size(); ++i) {
                const json& m = materials[i];
                const std::string base = elem_path("materials", i);
                if (!c.object(m, base, "(a material spec)")) continue;
                MaterialInput input{m, base, {}};
                const bool own_particulate = m.contains("binder") || m.contains("pigments");
                const bool own_medium = m.contains("medium");
                for (const auto& item : defaults.items()) {
                    const std::string& key = item.key();
                    if (m.contains(key)) continue;
                    if ((key == "binder" || key == "pigments") && own_medium) continue;
                    if (key == "medium" && own_particulate) continue;
                    input.object[key] = item.value();
                    input.key_base[key] = "defaults";
                }
                // Names must be unique (they name the output files), also ignoring case: on a
                // case-insensitive file system "Paint" and "paint" would overwrite each other.
                if (m.contains("name") && m["name"].is_string()) {
                    const std::string name = m["name"].get<std::string>();
                    const std::string npath = key_path(base, "name");
                    const auto [it, inserted] = names.emplace(ascii_lower(name), npath);
                    if (!inserted)
                        c.fail(npath, cat("duplicate name (also at ", it->second,
                                          "; names must be unique, ignoring case, because they "
                                          "name the output files) (got ",
                                          show(m["name"]), ")"));
                }
                if (auto spec = MaterialParser(c, input).parse()) {
                    spec->source = cat(source_name, ": ", base);
                    specs.push_back(std::move(*spec));
                }
            }
        }
    }

    if (!c.problems().empty()) {
        std::string message;
        for (const std::string& p : c.problems()) message += (message.empty() ? "" : "\n") + p;
        if (c.only_limits()) throw LimitError(message);
        throw InputError(message);
    }
    log_warnings_once(specs, source_name);
    return specs;
}

std::vector<MaterialSpec> parse_document(const json& document, std::string_view source_name,
                                         std::vector<std::string> early_problems,
                                         const json& overlay) {
    if (!overlay.is_object() || overlay.empty())
        return parse_document(document, source_name, std::move(early_problems));
    return parse_document(overlaid(document, overlay), source_name, std::move(early_problems));
}

// Tracks the path of each value while nlohmann parses, to report duplicate keys (which the library
// silently resolves by keeping one value).
class DuplicateKeyFinder {
  public:
    bool operator()(int /*depth*/, json::parse_event_t event, json& parsed) {
        switch (event) {
        case json::parse_event_t::object_start:
        case json::parse_event_t::array_start:
            m_frames.push_back({event == json::parse_event_t::object_start, child_path(), {}, {}, 0});
            break;
        case json::parse_event_t::key: {
            Frame& f = m_frames.back();
            f.key = parsed.get<std::string>();
            if (!f.keys.insert(f.key).second)
                problems.push_back(cat(key_path(f.path, f.key),
                                       ": duplicate key (JSON objects keep only one value per key; "
                                       "remove one of them)"));
            break;
        }
        case json::parse_event_t::object_end:
        case json::parse_event_t::array_end:
            m_frames.pop_back();
            advance();
            break;
        case json::parse_event_t::value: advance(); break;
        }
        return true;
    }

    std::vector<std::string> problems;

  private:
    struct Frame {
        bool object = true;
        std::string path;
        std::set<std::string> keys;
        std::string key;
        std::size_t index = 0;
    };
    std::string child_path() const {
        if (m_frames.empty()) return "";
        const Frame& f = m_frames.back();
        return f.object ? key_path(f.path, f.key) : elem_path(f.path, f.index);
    }
    void advance() {
        if (!m_frames.empty() && !m_frames.back().object) ++m_frames.back().index;
    }
    std::vector<Frame> m_frames;
};

} // namespace

std::vector<MaterialSpec> parse_specs(const nlohmann::json& document, std::string_view source,
                                      const nlohmann::json& overlay) {
    return parse_document(document, source, {}, overlay);
}

std::vector<MaterialSpec> parse_specs_text(std::string_view text, std::string_view source,
                                           const nlohmann::json& overlay) {
    DuplicateKeyFinder finder;
    json document;
    try {
        document = json::parse(text.begin(), text.end(), std::ref(finder));
    } catch (const json::parse_error& e) {
        // Line and column of the byte where parsing failed (e.byte counts from 1).
        const std::size_t at = std::min<std::size_t>(e.byte == 0 ? 0 : e.byte - 1, text.size());
        std::size_t line = 1, column = 1;
        for (std::size_t i = 0; i < at; ++i) {
            if (text[i] == '\n')
                ++line, column = 1;
            else
                ++column;
        }
        std::string what = e.what();
        if (const std::size_t p = what.find("column "); p != std::string::npos) {
            if (const std::size_t q = what.find(": ", p); q != std::string::npos)
                what = what.substr(q + 2);
        }
        std::string message = cat(source, ":", line, ":", column, ": invalid JSON: ", what);
        const std::string_view around = text.substr(at >= 8 ? at - 8 : 0, 20);
        for (std::string_view word : {"NaN", "nan", "Infinity", "inf"})
            if (around.find(word) != std::string_view::npos) {
                message += " (JSON has no NaN or Infinity: every number in a spec must be finite)";
                break;
            }
        throw InputError(message);
    } catch (const json::exception& e) {
        // Not a syntax error but a value the parser cannot hold: a number beyond the range of a
        // double ("1e400") is json::out_of_range 406, and carries no position. Found by fuzz_spec.
        std::string what = e.what();
        if (const std::size_t p = what.find("] "); what.starts_with("[json.exception.") &&
                                                   p != std::string::npos)
            what = what.substr(p + 2);
        throw InputError(cat(source, ": invalid JSON: ", what,
                             " (every number in a spec must fit in a double)"));
    }
    return parse_document(document, source, std::move(finder.problems), overlay);
}

std::vector<MaterialSpec> load_specs(const std::filesystem::path& file, const nlohmann::json& overlay) {
    const std::string name = file.string();
    std::error_code ec;
    if (std::filesystem::is_directory(file, ec))
        throw IoError(cat(name, ": cannot read: is a directory"));
    std::ifstream in(file, std::ios::binary);
    if (!in) {
        const bool exists = std::filesystem::exists(file, ec);
        throw IoError(cat(name, ": cannot read: ", exists ? "permission denied or not a regular file"
                                                           : "no such file"));
    }
    const auto size = std::filesystem::file_size(file, ec);
    if (!ec && size > max_spec_file_bytes)
        throw LimitError(cat(name, ": ", size, " bytes is more than the spec size limit of ",
                             max_spec_file_bytes, " bytes"));
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw IoError(cat(name, ": read error"));
    return parse_specs_text(text.str(), name, overlay);
}

} // namespace brdf::material
