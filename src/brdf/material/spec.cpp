// Material specs (spec.h): the entry points, the material as a whole and documents (single
// materials, catalogues with defaults, duplicate keys). The parts of a material are parsed in
// spec_index.cpp, spec_size.cpp, spec_medium.cpp, spec_layers.cpp and spec_options.cpp; paths,
// values and the problem list are spec_json.h's.

#include <brdf/material/spec.h>

#include "spec_parser.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/text.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace brdf::material {

using nlohmann::json;

std::string_view to_string(Surface surface) {
    switch (surface) {
    case Surface::None: return "none";
    case Surface::Smooth: return "smooth";
    case Surface::Rough: return "rough";
    }
    return "unknown";
}

std::string_view to_string(Microfacet distribution) {
    switch (distribution) {
    case Microfacet::Ggx: return "ggx";
    case Microfacet::Beckmann: return "beckmann";
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

std::string IndexSpec::describe() const {
    if (!id.empty()) return id;
    if (constant) return spec_detail::complex_text(*constant);
    if (!nk.empty()) return cat("nk table (", nk.size(), " rows)");
    return model.name();
}

bool LayerSpec::semi_infinite() const {
    return !thickness_um && !(medium && medium->optical_depth);
}

double LayerSpec::pigment_volume_fraction() const {
    double sum = 0.0;
    for (const PigmentSpec& p : pigments) sum += p.volume_fraction;
    return sum;
}

namespace spec_detail {

const std::vector<std::string_view> material_keys = {
    "name",    "description", "binder",   "pigments", "medium",     "thickness_um",
    "layers",  "substrate",   "surface",  "spectrum", "accuracy",   "colorspace",
    "outputs", "limits",      "model"};

// ---------------------------------------------------------------------------------------------
// One material

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

    // The layers (one written with the material's own keys, or "layers") and the substrate, then
    // the surface on top of them.
    parse_layers(spec, resolved);
    parse_surface(spec, resolved);
    parse_model(spec, resolved);

    // limits: before the spectrum and accuracy, which they bound; resolved only when given, so
    // that specs without them keep their hashes
    if (obj.contains("limits")) {
        json r = json::object();
        parse_limits(obj["limits"], in.path("limits"), r);
        resolved["limits"] = r;
    }

    // spectrum, accuracy, outputs, colour space
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
    parse_colorspace(spec, resolved);

    // The index data must cover every wavelength to solve; the pigments' size parameters must
    // stay within the limit.
    if (spectrum) {
        check_ranges(*spectrum);
        check_size_parameters(*spectrum);
        spec.spectrum = std::move(*spectrum);
    }

    if (c.failures() != failures_before) return std::nullopt;
    for (std::optional<LayerSpec>& layer : m_layers) {
        // Every part that fails reports a problem, so here every layer parsed.
        if (!layer) throw std::logic_error("spec parser: a layer failed without a problem");
        spec.layers.push_back(std::move(*layer));
    }
    spec.limits = m_limits;
    spec.resolved = std::move(resolved);
    spec.hash = fnv1a64_hex(spec.resolved.dump());
    spec.warnings = std::move(m_warnings);
    return spec;
}

namespace {

// ---------------------------------------------------------------------------------------------
// Documents

// The groups of model keys that catalogue defaults merge as a whole (spec.h): 1 a particulate
// layer, 2 an analytic medium, 3 a stack; 0 for every other key.
int model_group(std::string_view key) {
    if (key == "binder" || key == "pigments" || key == "thickness_um") return 1;
    if (key == "medium") return 2;
    if (key == "layers") return 3;
    return 0;
}

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
                std::set<int> own_groups;
                for (const auto& item : m.items())
                    if (const int g = model_group(item.key())) own_groups.insert(g);
                for (const auto& item : defaults.items()) {
                    const std::string& key = item.key();
                    if (m.contains(key)) continue;
                    // A material that gives one way of writing its model inherits no other.
                    const int g = model_group(key);
                    if (g && !own_groups.empty() && !own_groups.count(g)) continue;
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
                                         std::vector<std::string> early_problems, const json& overlay) {
    if (!overlay.is_object() || overlay.empty()) return parse_document(document, source_name, std::move(early_problems));
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
} // namespace spec_detail

std::vector<MaterialSpec> parse_specs(const nlohmann::json& document, std::string_view source,
                                      const nlohmann::json& overlay) {
    return spec_detail::parse_document(document, source, {}, overlay);
}

std::vector<MaterialSpec> parse_specs_text(std::string_view text, std::string_view source,
                                           const nlohmann::json& overlay) {
    spec_detail::DuplicateKeyFinder finder;
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
    return spec_detail::parse_document(document, source, std::move(finder.problems), overlay);
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
