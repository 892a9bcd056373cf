#include <brdf/model/film.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>
#include <brdf/core/threads.h>
#include <brdf/material/colour.h>

#include <cmath>
#include <limits>

namespace brdf::model {
namespace {

// Fourier order 0 of the stack of one sample over a substrate of albedo a, the single layer's
// thickness replaced when asked: everything a hemispherical quantity needs.
rte::Reflection order_zero(const material::MaterialSpec& spec, SpectralOptics o, int streams, double a,
                           std::optional<double> thickness_um) {
    o.substrate_albedo = a;
    if (thickness_um) {
        LayerOptics& l = o.layers.front();
        l.optical_depth = l.extinction_per_um * *thickness_um;
    }
    rte::ReflectionSettings rs;
    rs.streams = streams;
    rs.order_tolerance = std::numeric_limits<double>::infinity(); // m = 0 only
    const rte::Stack stack = make_stack(o, spec.surface);
    // A film has no semi-infinite layer: nothing for a device, the host solves it.
    return std::move(solve_stacks({&stack, 1}, rs, Device::Cpu).front());
}

void require_film(const material::MaterialSpec& spec, std::optional<double> thickness_um) {
    const std::string who = spec.source.empty() ? spec.name : spec.source;
    if (thickness_um) {
        if (!has_hiding_thickness(spec))
            throw InputError(cat(who, ": a film thickness applies to one pigmented binder layer; this material is ",
                                 spec.layers.size() > 1 ? "a stack" : "an analytic medium or a clear film"));
        if (!(*thickness_um > 0.0) || !std::isfinite(*thickness_um))
            throw InputError(cat(who, ": film thickness must be a positive number of micrometres (got ", *thickness_um, ")"));
    } else if (spec.layers.back().semi_infinite()) {
        throw InputError(cat(who, ": a contrast ratio needs a film (a finite last layer: \"thickness_um\" or "
                                  "\"optical_depth\"); this material is semi-infinite"));
    }
}

} // namespace

double normal_luminance(const material::MaterialSpec& spec, const MaterialOptics& optics, int streams,
                        double substrate_albedo, std::optional<double> thickness_um) {
    require_film(spec, thickness_um);
    std::vector<double> y(optics.optics.size(), 0.0);
    parallel_for(static_cast<int>(y.size()), available_cpus(), [&](int k) {
        const rte::Reflection r = order_zero(spec, optics.optics[k], streams, substrate_albedo, thickness_um);
        y[k] = material::luminance(optics.weights[k], spec.colorspace) * r.albedo(1.0);
    });
    double sum = 0.0;
    for (double v : y) sum += v;
    return sum;
}

double contrast_ratio(const material::MaterialSpec& spec, const MaterialOptics& optics, int streams,
                      std::optional<double> thickness_um) {
    const double white = normal_luminance(spec, optics, streams, contrast_white_albedo, thickness_um);
    const double black = normal_luminance(spec, optics, streams, 0.0, thickness_um);
    return white > 0.0 ? black / white : 0.0;
}

bool has_hiding_thickness(const material::MaterialSpec& spec) {
    return spec.layers.size() == 1 && spec.layers[0].binder && !spec.layers[0].pigments.empty();
}

std::optional<double> hiding_thickness_um(const material::MaterialSpec& spec, const MaterialOptics& optics, int streams,
                                          double target) {
    if (!has_hiding_thickness(spec)) return std::nullopt;
    const auto cr = [&](double t) { return contrast_ratio(spec, optics, streams, t); };
    // The contrast ratio rises monotonically with thickness (each added sublayer only adds
    // reflection over black and hides more of the white): bracket by doubling, then bisect in log t.
    double lo = 1.0, hi = 1.0;
    if (cr(1.0) >= target) {
        do {
            hi = lo;
            lo *= 0.5;
            if (lo < 1e-6) return lo;
        } while (cr(lo) >= target);
    } else {
        do {
            lo = hi;
            hi *= 2.0;
            if (hi > 1e4) return std::nullopt;
        } while (cr(hi) < target);
    }
    while (hi / lo > 1.0 + 1e-4) {
        const double mid = std::sqrt(lo * hi);
        (cr(mid) < target ? lo : hi) = mid;
    }
    return std::sqrt(lo * hi);
}

std::vector<double> diffuse_transmittance(const material::MaterialSpec& spec, const MaterialOptics& optics, int streams) {
    require_film(spec, std::nullopt);
    // Hemispherical average of the directional reflectance (diffuse + specular) over a Lambertian sky.
    const Quadrature rule = gauss_legendre(32, 0.0, 1.0);
    std::vector<double> out(optics.optics.size(), 0.0);
    parallel_for(static_cast<int>(out.size()), available_cpus(), [&](int k) {
        double n = 1.0; // index of the medium the substrate lies in
        const auto hemispherical = [&](double a) {
            const rte::Reflection r = order_zero(spec, optics.optics[k], streams, a, std::nullopt);
            n = r.setup().layers.back().index;
            const std::vector<double> diffuse = r.albedo(rule.x);
            double sum = 0.0;
            for (std::size_t q = 0; q < rule.x.size(); ++q)
                sum += 2.0 * rule.w[q] * rule.x[q] * (diffuse[q] + r.mirror(rule.x[q]));
            return sum;
        };
        const double r0 = hemispherical(0.0), d_half = hemispherical(0.5) - r0, d_one = hemispherical(1.0) - r0;
        // R(a) - R0 = a X / (1 - a r): 1 / (R(a) - R0) is linear in 1 / a, with slope 1 / X.
        if (!(d_half > 0.0) || !(d_one > 0.0)) return; // nothing reaches the substrate
        const double x = 1.0 / (1.0 / d_half - 1.0 / d_one);
        out[k] = n * std::sqrt(std::max(0.0, x));
    });
    return out;
}

std::optional<FilmReport> film_report(const SolvedMaterial& material) {
    const material::MaterialSpec& spec = material.spec;
    if (spec.layers.empty() || spec.layers.back().semi_infinite()) return std::nullopt;
    MaterialOptics optics;
    for (const WavelengthSolution& s : material.samples) {
        optics.optics.push_back(s.optics);
        optics.weights.push_back(s.weight);
    }
    const int streams = material.settings.streams;
    FilmReport out;
    for (const SpectralOptics& o : optics.optics) {
        std::vector<double> depth;
        for (const LayerOptics& l : o.layers) depth.push_back(l.finite() ? l.optical_depth : -1.0);
        out.optical_depth.push_back(std::move(depth));
    }
    out.diffuse_transmittance = diffuse_transmittance(spec, optics, streams);
    out.contrast_ratio = contrast_ratio(spec, optics, streams);
    out.hiding_thickness_um = hiding_thickness_um(spec, optics, streams);
    return out;
}

} // namespace brdf::model
