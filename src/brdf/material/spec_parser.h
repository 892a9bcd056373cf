#pragma once
// Internal to the spec parser: MaterialParser turns one material object (catalogue defaults
// already merged) into a MaterialSpec and its resolved JSON, reporting every problem to a Checker.
// Its parts live by what they parse: spec.cpp (the material as a whole, documents), spec_index.cpp
// (refractive indices), spec_size.cpp (size distributions), spec_medium.cpp (analytic media, phase
// functions, albedos), spec_layers.cpp (binder, pigments, layers, substrate), spec_options.cpp
// (surface, spectrum, accuracy, outputs, limits, colorspace, model).

#include "spec_json.h"

#include <brdf/core/log.h>
#include <brdf/material/spec.h>

#include <array>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace brdf::material::spec_detail {

/// The keys of a material object; of one entry of "layers".
extern const std::vector<std::string_view> material_keys;
extern const std::vector<std::string_view> layer_keys;

/// A material after merging catalogue defaults: each top-level key knows where it was written.
struct MaterialInput {
    json object;
    std::string base;                            ///< "materials[1]" or "" for a single material
    std::map<std::string, std::string> key_base; ///< key -> "defaults" for inherited keys
    std::string path(std::string_view key) const {
        const auto it = key_base.find(std::string(key));
        return key_path(it == key_base.end() ? base : it->second, key);
    }
};

/// An index whose data must cover the spectrum (checked once the spectrum is known).
struct IndexCheck {
    std::string path; ///< of the key that gave the index
    IndexSpec index;
};

/// Where one layer's keys were written: "pigments" or "defaults.pigments" for the top-level form,
/// "layers[1].pigments" in a stack.
struct LayerPaths {
    std::string base; ///< the layer itself: the material's base, or "layers[i]"
    std::string binder, pigments, medium, thickness;
};

class MaterialParser {
  public:
    MaterialParser(Checker& checker, const MaterialInput& input)
        : c(checker), in(input), obj(input.object) {}

    std::optional<MaterialSpec> parse();

  private:
    // spec_index.cpp
    std::optional<IndexSpec> parse_index(const json& holder, const std::string& holder_path,
                                         bool binder, json& resolved_material);
    std::optional<IndexSpec> parse_constant(const json& v, const std::string& path, bool binder,
                                            json& resolved);
    std::optional<IndexSpec> parse_nk(const json& v, const std::string& path, json& resolved);
    /// Queues the index given in `holder` (a binder or pigment object) for check_ranges.
    void queue_range_check(const json& holder, const std::string& holder_path,
                           const IndexSpec& index);
    void check_ranges(const SpectralSet& spectrum);

    // spec_size.cpp
    std::optional<mie::SizeDistribution> parse_size(const json& v, const std::string& path,
                                                    json& resolved);
    void check_size_parameters(const SpectralSet& spectrum);

    // spec_medium.cpp
    std::optional<MediumSpec> parse_medium(const json& v, const std::string& path, json& resolved);
    bool parse_phase(const json& p, const std::string& path, MediumSpec& m, json& resolved);
    /// An albedo: a number in [0, 1] (grey) or [r, g, b], each in [0, 1].
    std::optional<std::array<double, 3>> parse_albedo(const json& a, const std::string& path,
                                                      bool& grey, json& resolved);

    // spec_layers.cpp
    /// The material's layers (the top-level single layer or "layers") and its substrate.
    void parse_layers(MaterialSpec& spec, json& resolved);
    /// One layer written in `holder`, its keys' paths in `paths`; `in_stack` for an entry of
    /// "layers" (false: the top-level keys of a material).
    std::optional<LayerSpec> parse_layer(const json& holder, const LayerPaths& paths, bool in_stack,
                                         json& resolved);
    std::optional<BinderSpec> parse_binder(const json& v, const std::string& path, json& resolved);
    std::optional<std::vector<PigmentSpec>> parse_pigments(const json& v, const std::string& path,
                                                           bool clear_allowed, json& resolved);
    std::optional<SubstrateSpec> parse_substrate(const json& v, const std::string& path,
                                                 json& resolved);

    // spec_options.cpp
    void parse_surface(MaterialSpec& spec, json& resolved);
    std::optional<SurfaceSpec> parse_surface_value(const json& v, const std::string& path,
                                                   json& resolved);
    void parse_model(MaterialSpec& spec, json& resolved);
    std::optional<SpectralSet> parse_spectrum(const json& v, const std::string& path,
                                              json& resolved);
    std::optional<AccuracySpec> parse_accuracy(const json& v, const std::string& path,
                                               json& resolved);
    std::optional<std::vector<std::string>> parse_outputs(const json& v, const std::string& path,
                                                          json& resolved);
    void parse_colorspace(MaterialSpec& spec, json& resolved);
    void parse_limits(const json& v, const std::string& path, json& resolved);

    void warn(const std::string& path, const std::string& message) {
        m_warnings.push_back(path.empty() ? cat(c.source(), ": ", message)
                                          : cat(c.source(), ": ", path, ": ", message));
    }

    Checker& c;
    const MaterialInput& in;
    const json& obj;
    std::vector<std::string> m_warnings;
    SpecLimits m_limits; // parsed before the spectrum and accuracy, which they bound
    std::vector<IndexCheck> m_index_checks;
    // Every layer as parsed (nullopt where it had problems) with its paths, top first; also the
    // layers a failed stack still has, so that their limits are checked with the other faults.
    std::vector<std::optional<LayerSpec>> m_layers;
    std::vector<LayerPaths> m_layer_paths;
};

} // namespace brdf::material::spec_detail
