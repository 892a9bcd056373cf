#include <brdf/model/optics.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/mie/ensemble.h>

#include <algorithm>
#include <cmath>

namespace brdf::model {

SpectralOptics particulate_optics(const material::MaterialSpec& spec, double wavelength_nm, double mie_tolerance) {
    if (spec.layers.empty() || !spec.layers[0].binder || spec.layers[0].pigments.empty())
        throw InputError(cat(spec.source, ": particulate optics need a binder and pigments"));
    const material::LayerSpec& layer = spec.layers[0]; // the one layer the pipeline computes so far
    SpectralOptics out;
    out.wavelength_nm = wavelength_nm;
    out.binder_index = layer.binder->index.model.at(wavelength_nm).n;
    mie::EnsembleOptions options;
    options.tolerance = std::clamp(mie_tolerance, 1e-8, 0.1);

    // sigma_s = sum_i N_i Csca_i, sigma_e = sum_i N_i Cext_i + (1 - f) kappa_binder, and the mixed
    // phase function weights each pigment's by its scattering N_i Csca_i.
    std::vector<double> beta;
    double sigma_s = 0.0, sigma_e = 0.0, sigma_a = 0.0;
    for (const material::PigmentSpec& pigment : layer.pigments) {
        const material::IndexSample index = pigment.index.model.at(wavelength_nm);
        const mie::Ensemble e = mie::ensemble({index.n, index.k}, out.binder_index, wavelength_nm, pigment.size, options);
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
    if (!(sigma_s > 0.0))
        throw NumericalError(cat(spec.source, ": pigments do not scatter at ", wavelength_nm, " nm"));
    for (double& b : beta) b /= sigma_s;
    beta[0] = 1.0;
    out.scattering_per_um = sigma_s;
    out.extinction_per_um = sigma_e;
    // 1 - absorption / extinction, with the absorption cross sections computed directly (not as
    // Cext - Csca): exactly 1 for non-absorbing pigments in a clear binder, where the ratio of two
    // separately rounded sums would give 1 - 1e-15, a near-critical case no solver needs to meet.
    out.medium.omega = std::clamp(1.0 - sigma_a / sigma_e, 0.0, 1.0);
    out.medium.beta = std::move(beta);
    out.g = out.medium.beta.size() > 1 ? out.medium.beta[1] / 3.0 : 0.0;
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

} // namespace brdf::model
