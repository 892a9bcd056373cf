// The layers of a material: a binder with its pigments (or a clear binder film), or an analytic
// medium; written either as the material's own top-level keys (one layer) or as "layers": [...],
// top first; and the Lambertian substrate under a finite last layer.

#include "spec_parser.h"

#include <algorithm>

namespace brdf::material::spec_detail {

const std::vector<std::string_view> layer_keys = {"binder", "pigments", "medium", "thickness_um"};

namespace {

const std::vector<std::string_view> pigment_keys = {"material", "index", "nk", "volume_fraction",
                                                    "size"};
const std::vector<std::string_view> binder_keys = {"material", "index", "nk", "absorption_per_mm"};
const std::vector<std::string_view> substrate_keys = {"albedo"};

// Whether a layer as written is finite (a thickness_um, or an optical_depth in its medium), read
// from the JSON so that the order rules are checked even where the layer itself has faults;
// nullopt where that cannot be told (not an object, no model, or a medium that is not an object).
std::optional<bool> written_finite(const json& layer) {
    if (!layer.is_object()) return std::nullopt;
    const bool particulate = layer.contains("binder") || layer.contains("pigments");
    if (layer.contains("medium")) {
        if (particulate || !layer["medium"].is_object()) return std::nullopt;
        return layer["medium"].contains("optical_depth");
    }
    if (!particulate) return std::nullopt;
    return layer.contains("thickness_um");
}

} // namespace

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
MaterialParser::parse_pigments(const json& v, const std::string& path, bool clear_allowed,
                               json& resolved) {
    if (!c.array(v, path, "of pigments")) return std::nullopt;
    resolved = json::array();
    if (v.empty()) {
        if (clear_allowed) return std::vector<PigmentSpec>{}; // a clear film, resolved without it
        c.fail(path, "must list at least one pigment (got [])");
        return std::nullopt;
    }
    std::vector<PigmentSpec> out;
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
        resolved.push_back(
            json{{"material", material}, {"volume_fraction", fraction}, {"size", size_json}});
    }
    // The volumes of one layer's pigments share that layer.
    if (sum_known && sum > 1.0 + 1e-12) {
        std::string terms;
        for (const json& p : v) terms += (terms.empty() ? "" : " + ") + show(p["volume_fraction"]);
        c.fail(path,
               cat("volume fractions sum to ", shortest(sum), ", more than 1 (got ", terms, ")"));
        ok = false;
    } else if (sum_known && sum > 0.6) {
        warn(path, cat("volume fractions sum to ", shortest(sum),
                       ": beyond about 0.6 the particles are no longer independent scatterers "
                       "(dependent scattering), so the computed BRDF is only indicative"));
    }
    if (!ok) return std::nullopt;
    return out;
}

std::optional<SubstrateSpec> MaterialParser::parse_substrate(const json& v,
                                                             const std::string& path,
                                                             json& resolved) {
    if (!c.object(v, path, "(e.g. {\"albedo\": 0.8} or {\"albedo\": [0.8, 0.7, 0.6]})"))
        return std::nullopt;
    c.check_keys(v, path, substrate_keys);
    const std::string apath = key_path(path, "albedo");
    if (!v.contains("albedo")) {
        c.fail(apath, "missing (the substrate's Lambertian albedo: a number in [0, 1] or [r, g, "
                      "b]; 0 is black)");
        return std::nullopt;
    }
    SubstrateSpec s;
    json r;
    const auto a = parse_albedo(v["albedo"], apath, s.grey, r);
    if (!a) return std::nullopt;
    s.albedo = *a;
    resolved = json{{"albedo", r}};
    return s;
}

std::optional<LayerSpec> MaterialParser::parse_layer(const json& holder, const LayerPaths& paths,
                                                     bool in_stack, json& resolved) {
    resolved = json::object();
    if (in_stack)
        c.check_keys(holder, paths.base, layer_keys,
                     "a layer is \"binder\" + \"pigments\" + \"thickness_um\", or \"medium\" with "
                     "its \"optical_depth\" inside");
    const bool has_binder = holder.contains("binder"), has_pigments = holder.contains("pigments");
    const bool has_medium = holder.contains("medium");
    const bool has_thickness = holder.contains("thickness_um");
    const char* what = in_stack ? "layer" : "material";
    if ((has_binder || has_pigments) && has_medium) {
        c.fail(paths.medium,
               cat("cannot be combined with ", has_binder ? "\"binder\"" : "\"pigments\"", ": a ",
                   what, " is either particulate (binder + pigments) or an analytic medium"));
        return std::nullopt;
    }
    if (!has_binder && !has_pigments && !has_medium) {
        c.fail(paths.base,
               in_stack ? "needs either \"binder\" + \"pigments\" (a particulate layer; a clear "
                          "film needs no pigments) or \"medium\" (an analytic medium)"
                        : "needs either \"binder\" + \"pigments\" (a particulate material) or "
                          "\"medium\" (an analytic medium), or \"layers\" (a stack of them)");
        return std::nullopt;
    }
    LayerSpec layer;
    bool ok = true;
    if (has_medium) {
        if (has_thickness) {
            c.fail(paths.thickness, "not used by an analytic medium (give its optical depth "
                                    "instead: \"medium\": {..., \"optical_depth\": tau})");
            ok = false;
        }
        json r;
        layer.medium = parse_medium(holder["medium"], paths.medium, r);
        resolved["medium"] = r;
        if (!layer.medium) ok = false;
        return ok ? std::optional<LayerSpec>(std::move(layer)) : std::nullopt;
    }

    // A binder layer: pigmented, or clear when it has a thickness.
    if (has_thickness) {
        const json& t = holder["thickness_um"];
        const auto x = c.number(t, paths.thickness);
        if (x && !(*x > 0.0)) {
            c.fail(paths.thickness, cat("must be > 0 (got ", show(t), ")"));
            ok = false;
        } else if (x) {
            layer.thickness_um = *x;
            resolved["thickness_um"] = *x;
        } else {
            ok = false;
        }
    }
    if (!has_binder) {
        c.fail(paths.binder, "missing (pigments need a binder, e.g. {\"material\": \"pmma\"}, "
                             "{\"index\": 1.5}, or {\"material\": \"air\"} for a bare powder)");
        ok = false;
    }
    if (!has_pigments && !has_thickness) {
        // A misspelt "thickness_um" is reported as an unknown key already: one mistake, one line.
        if (!c.suggested(paths.thickness))
            c.fail(paths.pigments, cat("missing (a particulate ", what, " needs at least one "
                                       "pigment; a clear binder layer needs \"thickness_um\")"));
        ok = false;
    }
    if (has_binder) {
        json r;
        layer.binder = parse_binder(holder["binder"], paths.binder, r);
        resolved["binder"] = r;
        if (layer.binder)
            queue_range_check(holder["binder"], paths.binder, layer.binder->index);
        else
            ok = false;
    }
    if (has_pigments) {
        json r;
        const json& pigments = holder["pigments"];
        if (auto p = parse_pigments(pigments, paths.pigments, has_thickness, r)) {
            layer.pigments = std::move(*p);
            for (std::size_t i = 0; i < layer.pigments.size(); ++i)
                queue_range_check(pigments[i], elem_path(paths.pigments, i),
                                  layer.pigments[i].index);
        } else {
            ok = false;
        }
        if (!r.empty()) resolved["pigments"] = r;
    }
    if (!ok) return std::nullopt;
    return layer;
}

void MaterialParser::parse_layers(MaterialSpec& spec, json& resolved) {
    std::optional<bool> last_finite;
    if (!obj.contains("layers")) {
        // One layer, written with the material's own keys.
        const LayerPaths paths{in.base, in.path("binder"), in.path("pigments"), in.path("medium"),
                               in.path("thickness_um")};
        json r;
        m_layers.push_back(parse_layer(obj, paths, false, r));
        m_layer_paths.push_back(paths);
        for (const auto& item : r.items()) resolved[item.key()] = item.value();
        last_finite = written_finite(obj);
    } else {
        for (std::string_view key : layer_keys)
            if (obj.contains(key))
                c.fail(in.path(key), "cannot be combined with \"layers\" (a material is one layer "
                                     "given by its own binder, pigments, medium, thickness_um, "
                                     "or a stack given by \"layers\"; move it into a layer)");
        const json& layers = obj["layers"];
        const std::string path = in.path("layers");
        if (c.array(layers, path, "of layers, top first")) {
            if (layers.empty()) c.fail(path, "must list at least one layer, top first (got [])");
            json rl = json::array();
            for (std::size_t i = 0; i < layers.size(); ++i) {
                const json& layer = layers[i];
                const std::string base = elem_path(path, i);
                const LayerPaths paths{base, key_path(base, "binder"), key_path(base, "pigments"),
                                       key_path(base, "medium"), key_path(base, "thickness_um")};
                m_layer_paths.push_back(paths);
                if (!c.object(layer, base,
                              "(a layer: {\"binder\": ..., \"pigments\": [...], \"thickness_um\": "
                              "T} or {\"medium\": {...}})")) {
                    m_layers.emplace_back();
                    continue;
                }
                json r;
                m_layers.push_back(parse_layer(layer, paths, true, r));
                rl.push_back(r);
                // Light must get through a layer to reach the next one.
                if (i + 1 < layers.size() && written_finite(layer) == false)
                    c.fail(layer.contains("medium") ? key_path(paths.medium, "optical_depth")
                                                    : paths.thickness,
                           "missing (only the last layer may be semi-infinite)");
            }
            if (!layers.empty()) last_finite = written_finite(layers.back());
            // A stack of one layer is that layer: resolved as the top-level form, so both
            // spellings of it hash alike.
            if (rl.size() == 1 && layers.size() == 1)
                for (const auto& item : rl[0].items()) resolved[item.key()] = item.value();
            else
                resolved["layers"] = rl;
        }
    }

    // The substrate: under a finite last layer only; black unless given.
    const std::string spath = in.path("substrate");
    const bool given = obj.contains("substrate");
    const bool inherited = given && in.key_base.count("substrate") != 0;
    if (last_finite == true) {
        json r = json{{"albedo", 0.0}};
        spec.substrate = given ? parse_substrate(obj["substrate"], spath, r) : SubstrateSpec{};
        resolved["substrate"] = r;
    } else if (given) {
        // A catalogue's default substrate is for its films: a semi-infinite material ignores it
        // (its own faults are still reported).
        json unused;
        if (last_finite == false && !inherited)
            c.fail(spath, "not allowed under a semi-infinite layer (nothing lies under it; give "
                          "the last layer \"thickness_um\", or \"optical_depth\" in its medium, "
                          "to make it a film)");
        else
            parse_substrate(obj["substrate"], spath, unused);
    }
}

} // namespace brdf::material::spec_detail
