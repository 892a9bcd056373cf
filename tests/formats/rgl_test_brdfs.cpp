#include "rgl_test_brdfs.h"

#include <brdf/core/quadrature.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <random>

namespace brdf::test {

namespace {

using formats::Vec3;
constexpr double pi = std::numbers::pi;

double dot(const Vec3& a, const Vec3& b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// Channel albedo: a warm RGB colour, or a smooth sigmoid spectrum rising through 560 nm.
double albedo(std::size_t channel, const std::vector<double>& nm) {
    if (nm.empty()) return std::array{0.8, 0.45, 0.15}[channel];
    return 0.15 + 0.7 / (1.0 + std::exp(-(nm[channel] - 560.0) / 25.0));
}

// GGX (Trowbridge-Reitz) NDF and the Smith Lambda (Walter et al. 2007, eqs. 33 and 34; Heitz 2014,
// eq. 72), alpha the roughness.
double ggx_d(double cos_h, double alpha) {
    const double c2 = cos_h * cos_h, a2 = alpha * alpha;
    const double t = c2 * (a2 - 1.0) + 1.0;
    return a2 / (pi * t * t);
}
double ggx_lambda(double cos_t, double alpha) {
    const double c2 = cos_t * cos_t;
    const double tan2 = std::max(1.0 - c2, 0.0) / c2;
    return 0.5 * (std::sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}

} // namespace

const char* to_string(RglTestModel model) {
    switch (model) {
    case RglTestModel::Lambertian: return "lambertian";
    case RglTestModel::Glossy: return "glossy";
    case RglTestModel::Retro: return "retro";
    }
    return "?";
}

formats::RglBrdfCallback rgl_test_brdf(RglTestModel model, const std::vector<double>& nm) {
    return [model, nm](const Vec3& wi, const Vec3& wo, std::vector<double>& out) {
        const std::size_t channels = nm.empty() ? 3 : nm.size();
        out.resize(channels);
        double shared = 0.0;    // added to every channel
        double diffuse = 1.0;   // scale of the channel albedo / pi
        double coloured = 0.0;  // times the channel albedo
        switch (model) {
        case RglTestModel::Lambertian:
            break;
        case RglTestModel::Glossy: {
            constexpr double alpha = 0.2, f0 = 0.04;
            Vec3 h{wi.x + wo.x, wi.y + wo.y, wi.z + wo.z};
            const double len = std::sqrt(dot(h, h));
            h = {h.x / len, h.y / len, h.z / len};
            const double c = std::clamp(dot(wi, h), 0.0, 1.0);
            const double fresnel = f0 + (1.0 - f0) * std::pow(1.0 - c, 5.0);
            const double g2 =
                1.0 / (1.0 + ggx_lambda(wi.z, alpha) + ggx_lambda(wo.z, alpha));
            shared = ggx_d(h.z, alpha) * g2 * fresnel / (4.0 * wi.z * wo.z);
            diffuse = 0.6;
            break;
        }
        case RglTestModel::Retro: {
            constexpr double n = 20.0;
            const double c = std::max(dot(wi, wo), 0.0);
            coloured = 0.8 * (n + 1.0) / (2.0 * pi) * std::pow(c, n);
            diffuse = 0.3;
            break;
        }
        }
        for (std::size_t ch = 0; ch < channels; ++ch) {
            const double rho = albedo(ch, nm);
            out[ch] = diffuse * rho / pi + coloured * rho + shared;
        }
    };
}

std::vector<double> visible_wavelengths() {
    std::vector<double> nm;
    for (int l = 380; l <= 780; l += 20) nm.push_back(l);
    return nm;
}

bool rgl_enforced(RglTestModel model, const RglResolution& resolution) {
    const int needed = model == RglTestModel::Retro ? 32 : 16;
    return resolution.theta_i >= needed;
}

formats::RglOptions rgl_case_options(const RglResolution& resolution, bool spectral) {
    formats::RglOptions options;
    if (spectral) options.wavelengths_nm = visible_wavelengths();
    options.theta_i_count = resolution.theta_i;
    options.sample_resolution = resolution.samples;
    return options;
}

std::vector<DirectionSample> random_direction_pairs(std::size_t count, std::uint64_t seed,
                                                    DirectionWeighting weighting) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    const auto direction = [&] {
        // Cosine-weighted (Malley): cos(theta) = sqrt(uniform); the solid-angle variant draws
        // cos(theta) itself uniformly.
        const double r = 1.0 - uniform(rng);
        const double z = weighting == DirectionWeighting::Cosine ? std::sqrt(r) : r;
        const double phi = 2.0 * pi * uniform(rng);
        const double s = std::sqrt(std::max(1.0 - z * z, 0.0));
        return Vec3{s * std::cos(phi), s * std::sin(phi), z};
    };
    std::vector<DirectionSample> pairs(count);
    for (auto& p : pairs) {
        p.wi = direction();
        p.wo = direction();
    }
    return pairs;
}

std::vector<double> model_albedo(const formats::RglBrdfCallback& brdf, double theta_i_deg) {
    const double ti = theta_i_deg * pi / 180.0;
    const Vec3 wi{std::sin(ti), 0.0, std::cos(ti)};
    const auto mu = gauss_legendre(128, 0.0, 1.0);
    constexpr int phis = 256;
    std::vector<double> albedo, values;
    for (std::size_t q = 0; q < mu.size(); ++q)
        for (int k = 0; k < phis; ++k) {
            const double z = mu.x[q], s = std::sqrt(1.0 - z * z);
            const double phi = 2.0 * pi * (k + 0.5) / phis;
            brdf(wi, {s * std::cos(phi), s * std::sin(phi), z}, values);
            albedo.resize(values.size(), 0.0);
            for (std::size_t c = 0; c < values.size(); ++c)
                albedo[c] += values[c] * z * mu.w[q] * 2.0 * pi / phis;
        }
    return albedo;
}

RelativeStats relative_stats(std::vector<double> d) {
    RelativeStats s;
    s.count = d.size();
    if (d.empty()) return s;
    std::sort(d.begin(), d.end());
    const auto at = [&](double q) {
        return d[std::min(d.size() - 1, static_cast<std::size_t>(q * (d.size() - 1) + 0.5))];
    };
    s.median = at(0.5);
    s.p95 = at(0.95);
    s.max = d.back();
    return s;
}

RelativeStats rgl_accuracy(const formats::RglEvaluator& evaluator,
                           const formats::RglBrdfCallback& brdf,
                           const std::vector<DirectionSample>& pairs) {
    std::vector<double> differences, reference;
    for (const DirectionSample& p : pairs) {
        const std::vector<double> ours = evaluator.brdf(p.wi, p.wo);
        brdf(p.wi, p.wo, reference);
        for (std::size_t c = 0; c < ours.size(); ++c)
            differences.push_back(std::abs(ours[c] - reference[c]) /
                                  std::max(std::abs(reference[c]), 1e-4));
    }
    return relative_stats(std::move(differences));
}

} // namespace brdf::test
