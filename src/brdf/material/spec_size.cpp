// Size distributions of pigments (mie/size_distribution.h: monodisperse, power law, gamma,
// log-normal) and the size-parameter limit they are held to.

#include "spec_parser.h"

#include <brdf/core/error.h>
#include <brdf/mie/mie.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

namespace brdf::material::spec_detail {
namespace {

const std::vector<std::string_view> size_keys_all = {"distribution", "radius_um", "r_eff_um",
                                                     "v_eff",        "r_g_um",    "sigma_g"};
const std::vector<mie::DistributionKind> kinds = {
    mie::DistributionKind::Monodisperse, mie::DistributionKind::PowerLaw,
    mie::DistributionKind::Gamma, mie::DistributionKind::Lognormal};
const std::vector<std::string_view> kind_names = {"monodisperse", "power_law", "gamma",
                                                  "lognormal"};

} // namespace

std::optional<mie::SizeDistribution> MaterialParser::parse_size(const json& v,
                                                                const std::string& path,
                                                                json& resolved) {
    if (!c.object(v, path, "(e.g. {\"distribution\": \"gamma\", \"r_eff_um\": 0.4, \"v_eff\": "
                           "0.1})"))
        return std::nullopt;
    std::optional<std::size_t> which;
    const std::string dpath = key_path(path, "distribution");
    if (!v.contains("distribution"))
        c.fail(dpath, cat("missing (one of ", list(kind_names), ")"));
    else
        which = c.one_of(v["distribution"], dpath, kind_names);
    if (!which) {
        c.check_keys(v, path, size_keys_all);
        return std::nullopt;
    }
    const mie::DistributionKind kind = kinds[*which];
    const std::string_view name = kind_names[*which];
    const std::string_view p1_key = mie::parameter1_key(kind), p2_key = mie::parameter2_key(kind);
    const std::string takes = p2_key.empty() ? cat(p1_key) : cat(p1_key, " and ", p2_key);
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        if (key == "distribution" || key == p1_key || key == p2_key) continue;
        if (std::find(size_keys_all.begin(), size_keys_all.end(), key) != size_keys_all.end())
            c.fail(key_path(path, key),
                   cat("not used by the ", name, " distribution (it takes ", takes, ")"));
        else
            c.unknown_key(key_path(path, key), key,
                          p2_key.empty()
                              ? std::vector<std::string_view>{"distribution", p1_key}
                              : std::vector<std::string_view>{"distribution", p1_key, p2_key},
                          cat("the ", name, " distribution takes ", takes));
    }
    const auto get = [&](std::string_view key) -> std::optional<double> {
        const std::string kpath = key_path(path, key);
        if (!v.contains(key)) {
            c.fail(kpath, cat("missing (the ", name, " distribution takes ", takes, ")"));
            return std::nullopt;
        }
        return c.number(v[std::string(key)], kpath);
    };
    const auto p1 = get(p1_key);
    const auto p2 = p2_key.empty() ? std::optional<double>(0.0) : get(p2_key);
    if (!p1 || !p2) return std::nullopt;
    // The distribution states its own ranges (one source for the parser and the constructors);
    // each problem goes under the parameter it names.
    const std::vector<mie::ParameterProblem> problems = mie::parameter_problems(kind, *p1, *p2);
    for (const mie::ParameterProblem& p : problems) c.fail(key_path(path, p.key), p.fault);
    if (!problems.empty()) return std::nullopt;
    std::optional<mie::SizeDistribution> d;
    switch (kind) {
    case mie::DistributionKind::Monodisperse: d = mie::monodisperse(*p1); break;
    case mie::DistributionKind::PowerLaw: d = mie::power_law(*p1, *p2); break;
    case mie::DistributionKind::Gamma: d = mie::gamma(*p1, *p2); break;
    case mie::DistributionKind::Lognormal: d = mie::lognormal(*p1, *p2); break;
    }
    resolved = json::object();
    resolved["distribution"] = name;
    resolved[std::string(p1_key)] = *p1;
    if (!p2_key.empty()) resolved[std::string(p2_key)] = *p2;
    return d;
}

// The largest Mie size parameter of each pigment, x = 2 pi r_max n_binder / lambda (the wavenumber
// in the binder times the distribution's upper integration radius), over the spectrum, in every
// layer. Mie series need about x + 4 x^(1/3) terms per radius (Wiscombe 1980) and the ensemble
// integral more radius nodes as x grows, so the cost rises at least as x^2.
void MaterialParser::check_size_parameters(const SpectralSet& spectrum) {
    const auto digits4 = [](double x) {
        char buffer[32];
        std::snprintf(buffer, sizeof buffer, "%.4g", x);
        return std::string(buffer);
    };
    for (std::size_t k = 0; k < m_layers.size(); ++k) {
        if (!m_layers[k] || !m_layers[k]->binder) continue;
        const LayerSpec& layer = *m_layers[k];
        for (std::size_t i = 0; i < layer.pigments.size(); ++i) {
            const double r_max = layer.pigments[i].size.r_max_um();
            double x_max = 0.0, n_at = 0.0, lambda_at = 0.0;
            for (double lambda : spectrum.wavelengths_nm()) {
                double n = 0.0;
                try {
                    n = layer.binder->index.model.at(lambda).n;
                } catch (const Error&) {
                    continue; // outside the binder's data: check_ranges reported it
                }
                const double x = 2.0 * std::numbers::pi * r_max * n / (1e-3 * lambda);
                if (x > x_max) x_max = x, n_at = n, lambda_at = lambda;
            }
            const std::string reaches =
                cat("size parameter x = 2 pi r_max n_binder / lambda reaches ", std::round(x_max),
                    " (r_max ", digits4(r_max), " um, n_binder ", digits4(n_at), " at ", lambda_at,
                    " nm), above ");
            const std::string size_path = key_path(elem_path(m_layer_paths[k].pigments, i), "size");
            // Beyond what the Mie module computes no limit helps: said here, before any optics, and
            // without an override that would only move the refusal to the Mie stage.
            if (x_max > mie::max_legendre_size_parameter)
                c.fail_limit(
                    size_path,
                    cat(reaches, shortest(mie::max_legendre_size_parameter),
                        ", the largest this service computes (a phase function's Legendre series "
                        "needs about 2x terms per radius; a fixed limit)"));
            else if (x_max > m_limits.max_size_parameter)
                c.fail_limit(size_path,
                             cat(reaches, "the limit of ", shortest(m_limits.max_size_parameter),
                                 " (Mie series need about x terms per radius); to override, set "
                                 "\"limits\": {\"max_size_parameter\": ",
                                 std::ceil(x_max), "}"));
        }
    }
}

} // namespace brdf::material::spec_detail
