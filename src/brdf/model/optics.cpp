#include <brdf/model/optics.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/mie/ensemble_cache.h>

#include <algorithm>
#include <cmath>

namespace brdf::model {
namespace {

LayerOptics analytic_layer_optics(const material::MediumSpec& m, int channel, double phase_tolerance) {
    LayerOptics out;
    out.index = m.index.value_or(1.0);
    out.index_from_above = !m.index;
    out.medium = {m.albedo[static_cast<std::size_t>(channel)], analytic_phase(m, phase_tolerance)};
    out.g = m.g;
    if (m.optical_depth) out.optical_depth = *m.optical_depth;
    return out;
}

} // namespace

LayerOptics particulate_layer_optics(const material::LayerSpec& layer, double wavelength_nm,
                                     const mie::EnsembleOptions& mie, const std::string& who,
                                     const std::function<void()>& heartbeat) {
    if (!layer.binder) throw InputError(cat(who, ": particulate optics need a binder"));
    LayerOptics out;
    out.index = layer.binder->index.model.at(wavelength_nm).n;
    mie::EnsembleOptions options = mie;
    options.tolerance = std::clamp(mie.tolerance, 1e-8, 0.1);
    options.progress = heartbeat ? std::function<void(double)>([&heartbeat](double) { heartbeat(); }) : nullptr;

    // sigma_s = sum_i N_i Csca_i, sigma_e = sum_i N_i Cext_i + (1 - f) kappa_binder, and the mixed
    // phase function weights each pigment's by its scattering N_i Csca_i.
    std::vector<double> beta;
    double sigma_s = 0.0, sigma_e = 0.0, sigma_a = 0.0;
    for (const material::PigmentSpec& pigment : layer.pigments) {
        const material::IndexSample index = pigment.index.model.at(wavelength_nm);
        // From the process's cache: a pigment recurs across the materials of a catalogue or a job.
        const std::shared_ptr<const mie::Ensemble> shared =
            mie::EnsembleCache::shared().get({index.n, index.k}, out.index, wavelength_nm, pigment.size, options);
        const mie::Ensemble& e = *shared;
        PigmentOptics p;
        p.albedo = e.albedo;
        p.g = e.g;
        p.csca_um2 = e.csca_um2;
        p.cext_um2 = e.cext_um2;
        p.number_density_um3 = pigment.volume_fraction / e.mean_volume_um3;
        p.legendre = static_cast<int>(e.legendre.size());
        p.radius_nodes = e.radius_nodes;
        p.mie_error = e.error_estimate;
        const double s = p.number_density_um3 * e.csca_um2;
        if (beta.size() < e.legendre.size()) beta.resize(e.legendre.size(), 0.0);
        for (std::size_t l = 0; l < e.legendre.size(); ++l) beta[l] += s * e.legendre[l];
        sigma_s += s;
        sigma_e += p.number_density_um3 * e.cext_um2;
        sigma_a += p.number_density_um3 * e.cabs_um2;
        out.pigments.push_back(p);
    }
    const double binder_fraction = std::max(0.0, 1.0 - layer.pigment_volume_fraction());
    const double binder_absorption = binder_fraction * layer.binder->absorption_per_mm * 1e-3;
    sigma_e += binder_absorption;
    sigma_a += binder_absorption;
    out.scattering_per_um = sigma_s;
    out.extinction_per_um = sigma_e;
    if (layer.thickness_um) out.optical_depth = sigma_e * *layer.thickness_um;
    if (layer.pigments.empty()) {
        // A clear film: it only absorbs (omega 0; tau from the binder, possibly 0).
        out.medium = {0.0, {1.0}};
        return out;
    }
    if (!(sigma_s > 0.0))
        throw NumericalError(cat(who, ": pigments do not scatter at ", wavelength_nm, " nm"));
    for (double& b : beta) b /= sigma_s;
    beta[0] = 1.0;
    // 1 - absorption / extinction, with the absorption cross sections computed directly (not as
    // Cext - Csca): exactly 1 for non-absorbing pigments in a clear binder, where the ratio of two
    // separately rounded sums would give 1 - 1e-15, a near-critical case no solver needs to meet.
    out.medium.omega = std::clamp(1.0 - sigma_a / sigma_e, 0.0, 1.0);
    out.medium.beta = std::move(beta);
    out.g = out.medium.beta.size() > 1 ? out.medium.beta[1] / 3.0 : 0.0;
    return out;
}

SpectralOptics spectral_optics(const material::MaterialSpec& spec, double wavelength_nm,
                               const mie::EnsembleOptions& mie, int substrate_channel,
                               const std::function<void()>& heartbeat) {
    const std::string who = spec.source.empty() ? spec.name : spec.source;
    SpectralOptics out;
    out.wavelength_nm = wavelength_nm;
    for (const material::LayerSpec& layer : spec.layers)
        out.layers.push_back(layer.medium ? analytic_layer_optics(*layer.medium, 0, 1e-3 * mie.tolerance)
                                          : particulate_layer_optics(layer, wavelength_nm, mie, who, heartbeat));
    if (spec.substrate) out.substrate_albedo = spec.substrate->albedo[static_cast<std::size_t>(substrate_channel)];
    return out;
}

SpectralOptics analytic_optics(const material::MaterialSpec& spec, int channel, double order_tolerance) {
    SpectralOptics out;
    for (const material::LayerSpec& layer : spec.layers) {
        if (!layer.medium)
            throw InputError(cat(spec.source.empty() ? spec.name : spec.source,
                                 ": analytic optics need every layer to be a \"medium\""));
        out.layers.push_back(analytic_layer_optics(*layer.medium, channel, 1e-3 * order_tolerance));
    }
    if (spec.substrate) out.substrate_albedo = spec.substrate->albedo[static_cast<std::size_t>(channel)];
    return out;
}

std::vector<double> analytic_phase(const material::MediumSpec& medium, double tolerance) {
    switch (medium.phase) {
    case material::PhaseType::Isotropic: return {1.0};
    case material::PhaseType::Rayleigh: return {1.0, 0.0, 0.5};
    case material::PhaseType::Legendre: return medium.coefficients;
    case material::PhaseType::HenyeyGreenstein: {
        std::vector<double> beta{1.0};
        const double g = medium.g;
        for (int l = 1; l < 20000; ++l) {
            const double b = (2.0 * l + 1.0) * std::pow(g, l);
            if (std::abs(b) < tolerance) break;
            beta.push_back(b);
        }
        return beta;
    }
    }
    throw InputError("unknown phase function type");
}

rte::Stack make_stack(const SpectralOptics& optics, const material::SurfaceSpec& surface) {
    rte::Stack stack;
    switch (surface.kind) {
    case material::Surface::None: stack.top = rte::Top::None; break;
    case material::Surface::Smooth: stack.top = rte::Top::Smooth; break;
    case material::Surface::Rough:
        stack.top = rte::Top::Rough;
        stack.rough.alpha = surface.roughness;
        stack.rough.distribution =
            surface.distribution == material::Microfacet::Beckmann ? rte::Microfacet::Beckmann : rte::Microfacet::Ggx;
        break;
    }
    double above = 1.0;
    for (std::size_t k = 0; k < optics.layers.size(); ++k) {
        const LayerOptics& l = optics.layers[k];
        rte::Layer layer;
        layer.medium = l.medium;
        layer.tau = l.optical_depth;
        // An analytic medium without an index below the top is index-matched to the layer above
        // (on top, to air); with surface "none" the stack ignores every index.
        layer.index = l.index_from_above ? above : l.index;
        above = layer.index;
        stack.layers.push_back(std::move(layer));
    }
    // "none": no air/top interface, i.e. the ambient is index-matched to the top layer. Only the
    // relative indices matter (Snell and Fresnel see ratios), so the interfaces between layers keep
    // theirs with every index divided by the top one: a smooth top of index 1.
    if (stack.top == rte::Top::None) {
        const double top = stack.layers.front().index;
        for (rte::Layer& l : stack.layers) l.index /= top;
        stack.top = rte::Top::Smooth;
    }
    // Index 1 throughout: no interface anywhere (the results of every half-space spec as before).
    if (std::all_of(stack.layers.begin(), stack.layers.end(), [](const rte::Layer& l) { return l.index == 1.0; }))
        stack.top = rte::Top::None;
    stack.substrate_albedo = optics.layers.back().finite() ? optics.substrate_albedo : 0.0;
    return stack;
}

} // namespace brdf::model
