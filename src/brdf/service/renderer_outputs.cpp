#include <brdf/service/renderer_outputs.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/threads.h>
#include <brdf/core/version.h>
#include <formats/fourier/fourier.h>
#include <formats/rgl/rgl_build.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>

namespace brdf::service {
namespace {

// A series longer than this is cut (its tail is below the truncation rule for every material we
// know; the single scattering of the largest particles would need more, and the report's accuracy
// no longer holds for it).
constexpr int max_fourier_orders = 1024;

double zenith(double mu) { return std::acos(std::clamp(mu, -1.0, 1.0)); }

} // namespace

RendererResolution renderer_resolution(double tolerance) {
    // Measured on the seed material against the exact model (docs/formats.md, "What compute
    // writes"): the Fourier file's error is the Catmull-Rom interpolation in mu between nodes, the
    // RGL file's the bilinear interpolation of its samples between warped nodes (the retro lobe
    // needs 64 x 64 samples).
    RendererResolution r;
    if (tolerance >= 3e-3) { // draft
        r.fourier_nodes = 16;
        r.rgl_theta_i = 16;
        r.rgl_samples = 32;
    } else if (tolerance >= 5e-6) { // default
        r.fourier_nodes = 32;
        r.rgl_theta_i = 32;
        r.rgl_samples = 64;
    } else { // reference
        r.fourier_nodes = 64;
        r.rgl_theta_i = 48;
        r.rgl_samples = 96;
    }
    r.fourier_truncation = std::clamp(0.1 * tolerance, 1e-7, 1e-3);
    return r;
}

std::vector<double> fourier_nodes(int n) {
    if (n < 2) throw InputError(cat("fourier_nodes: need at least 2 nodes (got ", n, ")"));
    // Chebyshev-Lobatto in mu: dense towards grazing, where the Fresnel transmission and the
    // H-function's mu log mu behaviour bend the BRDF most, and towards the normal.
    std::vector<double> mu;
    for (int k = 1; k <= n; ++k)
        mu.push_back(static_cast<float>(0.5 * (1.0 - std::cos(std::numbers::pi * k / n))));
    return mu;
}

void write_fourier_output(const std::filesystem::path& path, const model::SolvedMaterial& solved,
                          const model::FillInputs& fill, const RendererResolution& resolution) {
    const std::vector<double> positive = fourier_nodes(resolution.fourier_nodes);
    // The rows and columns: mu = 0 (the column with the viewer at the horizon), then the nodes.
    std::vector<double> mu{0.0};
    mu.insert(mu.end(), positive.begin(), positive.end());
    const int e = static_cast<int>(mu.size());

    // Multiply scattered part: exact (Nystrom) per order on the nodes, one sample per core.
    std::vector<rte::OrderGrid> grids(solved.samples.size());
    parallel_for(static_cast<int>(solved.samples.size()), available_cpus(),
                 [&](int k) { grids[k] = solved.samples[k].reflection.order_grid(mu); });
    int orders = 1;
    for (const rte::OrderGrid& g : grids) orders = std::max(orders, static_cast<int>(g.orders.size()));
    // Single scattering at fixed (mu_i, mu_o) is p(cos Theta) with cos Theta linear in cos(phi): a
    // polynomial of degree L - 1 in cos(phi) for L Legendre terms, i.e. exactly L Fourier orders.
    int ss_orders = 0;
    for (const model::SingleScatteringSource& t : solved.single_scattering_sources())
        if (t.setup->stack.top != rte::Top::Rough)
            for (int layer = 0; layer < static_cast<int>(t.setup->layers.size()); ++layer)
                ss_orders = std::max(ss_orders, static_cast<int>(rte::scattering_layer(*t.setup, layer).beta->size()));
    if (fill.samples == 0) ss_orders = 0;
    // A rough top's first-surface lobe (in `fill`, evaluated exactly per direction) is expanded
    // the same way. In azimuth it is about alpha wide at grazing and wider towards the normal, so
    // its coefficients fall like exp(-(m alpha)^2 / 2): 12 / alpha orders keep it to ~1e-8 of its
    // peak before the file's truncation.
    if (fill.lobe != model::FillInputs::Lobe::None)
        ss_orders = std::max(ss_orders, static_cast<int>(std::ceil(12.0 / fill.lobe_alpha)));
    orders = std::min(std::max(orders, ss_orders), max_fourier_orders);

    // b[((o * e + i) * 3 + c) * orders + m]: f = sum_m b_m cos(m phi), 1/sr, our conventions.
    const std::size_t per_pair = 3 * static_cast<std::size_t>(orders);
    std::vector<double> b(static_cast<std::size_t>(e) * e * per_pair, 0.0);
    for (std::size_t k = 0; k < solved.samples.size(); ++k) {
        const model::Rgb& w = solved.samples[k].weight;
        const rte::OrderGrid& g = grids[k];
        for (int m = 0; m < static_cast<int>(g.orders.size()) && m < orders; ++m) {
            // OrderGrid: BRDF = sum_m (2 - delta_m0) (-1)^m orders[m](o, i) cos(m phi) / pi.
            const double factor = (m == 0 ? 1.0 : 2.0) * (m % 2 == 0 ? 1.0 : -1.0) * std::numbers::inv_pi;
            for (int o = 0; o < e; ++o)
                for (int i = 1; i < e; ++i)
                    for (int c = 0; c < 3; ++c)
                        b[((static_cast<std::size_t>(o) * e + i) * 3 + c) * orders + m] += w[c] * factor * g.orders[m](o, i);
        }
    }
    if (ss_orders > 0) {
        // The single scattering of every sample, as the table fill evaluates it (its phase and
        // Fresnel tables, each sample's own refraction), expanded by the midpoint rule on [0, pi]
        // with P = orders points: exact for cos(j phi) cos(m phi) with j + m < 2P, so for every
        // order of a series of `orders` terms.
        model::FillInputs single = fill;
        single.orders = 0;
        single.fourier.clear();
        const int p = orders;
        std::vector<double> cos_table(static_cast<std::size_t>(p) * orders);
        for (int j = 0; j < p; ++j)
            for (int m = 0; m < orders; ++m)
                cos_table[static_cast<std::size_t>(j) * orders + m] = std::cos(m * std::numbers::pi * (j + 0.5) / p);
        parallel_for(e * (e - 1), available_cpus(), [&](int pair) {
            const int o = pair / (e - 1), i = 1 + pair % (e - 1);
            const double theta_o = zenith(mu[o]), theta_i = zenith(mu[i]);
            double* dst = &b[(static_cast<std::size_t>(o) * e + i) * per_pair];
            for (int j = 0; j < p; ++j) {
                const model::Rgb v = model::fill_value(single, theta_i, theta_o, std::numbers::pi * (j + 0.5) / p);
                const double* cj = &cos_table[static_cast<std::size_t>(j) * orders];
                for (int m = 0; m < orders; ++m) {
                    const double weight = (m == 0 ? 1.0 : 2.0) / p * cj[m];
                    for (int c = 0; c < 3; ++c) dst[c * orders + m] += weight * v[c];
                }
            }
        });
    }

    const auto index_of = [&](double x) {
        const auto it = std::lower_bound(mu.begin(), mu.end(), x);
        if (it == mu.end() || *it != x)
            throw InternalError(cat("write_fourier_output: ", x, " is not one of the nodes"));
        return static_cast<std::size_t>(it - mu.begin());
    };
    formats::FourierBuildOptions options;
    options.channels = 3;
    options.truncation = resolution.fourier_truncation;
    options.spec = solved.spec.resolved.dump();
    options.generator = std::string(generator_string);
    const formats::FourierBsdf bsdf = formats::make_fourier_bsdf(
        positive, orders,
        [&](double mu_i, double mu_o, std::span<double> out) {
            const double* src = &b[(index_of(mu_o) * e + index_of(mu_i)) * per_pair];
            std::copy(src, src + per_pair, out.begin());
        },
        options);
    formats::write_fourier_bsdf(path, bsdf);
}

bool rgl_output_spectral(const model::SolvedMaterial& solved) {
    return !solved.samples.empty() &&
           std::all_of(solved.samples.begin(), solved.samples.end(),
                       [](const model::WavelengthSolution& s) { return s.wavelength_nm > 0.0; });
}

std::filesystem::path rgl_rgb_companion_path(const std::filesystem::path& rgl_path) {
    const std::string name = rgl_path.filename().string();
    const std::string suffix = ".rgl.bsdf";
    const std::string stem = name.size() > suffix.size() && name.ends_with(suffix)
                                 ? name.substr(0, name.size() - suffix.size())
                                 : rgl_path.stem().string();
    return rgl_path.parent_path() / (stem + ".rgb.rgl.bsdf");
}

void write_rgl_output(const std::filesystem::path& path, const model::SolvedMaterial& solved,
                      const model::FillInputs& fill, const RendererResolution& resolution) {
    formats::RglOptions options;
    options.theta_i_count = resolution.rgl_theta_i;
    options.sample_resolution = resolution.rgl_samples;
    options.description = formats::rgl_description(std::string(generator_string), solved.spec.resolved.dump());
    const std::filesystem::path companion = rgl_rgb_companion_path(path);
    if (!rgl_output_spectral(solved)) {
        // An analytic medium is given per RGB channel: an RGB file only. The table fill's interpolant
        // (Catmull-Rom on the order grid's zenith nodes, exact Fourier sum in phi, the single
        // scattering per direction): microseconds per direction, where SolvedMaterial::brdf would
        // solve a Nystrom system per direction and wavelength.
        const formats::RglBrdfCallback brdf = [&](const formats::Vec3& wi, const formats::Vec3& wo,
                                                   std::vector<double>& values) {
            const double phi = std::atan2(wo.y, wo.x) - std::atan2(wi.y, wi.x);
            const model::Rgb v = model::fill_value(fill, zenith(wi.z), zenith(wo.z), phi);
            values.assign(v.begin(), v.end());
        };
        formats::write_rgl_bsdf(path, formats::make_rgl_bsdf(brdf, options));
        std::error_code ec; // a companion left by an earlier, spectral version of the material
        std::filesystem::remove(companion, ec);
        return;
    }

    // Solved per wavelength: "spectra" at the solved wavelengths (those of NAME.spectral.exr), each
    // the fill with a one-hot colour weight, three wavelengths per fill_value
    // (model::for_each_spectral_fill), so a direction costs ceil(L / 3) RGB evaluations.
    const std::size_t count = solved.samples.size();
    std::vector<std::size_t> order(count); // channel -> sample, by increasing wavelength
    for (std::size_t k = 0; k < count; ++k) order[k] = k;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return solved.samples[a].wavelength_nm < solved.samples[b].wavelength_nm;
    });
    std::vector<std::size_t> channel_of(count);
    for (std::size_t c = 0; c < count; ++c) {
        channel_of[order[c]] = c;
        options.wavelengths_nm.push_back(solved.samples[order[c]].wavelength_nm);
        if (c > 0 && !(options.wavelengths_nm[c] > options.wavelengths_nm[c - 1]))
            throw InternalError(cat("write_rgl_output: wavelength ", options.wavelengths_nm[c],
                                    " nm is solved twice"));
    }
    std::vector<model::SpectralFill> groups;
    model::for_each_spectral_fill(solved, [&](const model::SpectralFill& g) { groups.push_back(g); });
    const formats::RglBrdfCallback brdf = [&](const formats::Vec3& wi, const formats::Vec3& wo,
                                               std::vector<double>& values) {
        const double phi = std::atan2(wo.y, wo.x) - std::atan2(wi.y, wi.x);
        const double theta_i = zenith(wi.z), theta_o = zenith(wo.z);
        values.assign(count, 0.0);
        for (const model::SpectralFill& g : groups) {
            const model::Rgb v = model::fill_value(g.inputs, theta_i, theta_o, phi);
            for (int c = 0; c < 3; ++c)
                if (g.sample[c] >= 0) values[channel_of[static_cast<std::size_t>(g.sample[c])]] = v[c];
        }
    };
    const auto t0 = std::chrono::steady_clock::now();
    const formats::RglBsdf spectral = formats::make_rgl_bsdf(brdf, options);
    const auto t1 = std::chrono::steady_clock::now();
    // The RGB file for Mitsuba's RGB variants from the same samples and the samples' colour weights
    // (the RGB fill is sum_k weight_k f_k, clamped at 0, as the companion is).
    std::vector<std::array<double, 3>> weights(count);
    for (std::size_t c = 0; c < count; ++c) {
        const model::Rgb& w = solved.samples[order[c]].weight;
        weights[c] = {w[0], w[1], w[2]};
    }
    formats::write_rgl_bsdf(path, spectral);
    formats::write_rgl_bsdf(companion, formats::rgl_rgb_from_spectral(spectral, weights));
    log::info(solved.spec.name, ": RGL file of ", count, " wavelengths built in ",
              std::chrono::duration<double>(t1 - t0).count(), " s (", groups.size(),
              " evaluations per direction), written with its RGB companion in ",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count(), " s");
}

} // namespace brdf::service
