#include <formats/rgl/rgl_build.h>

#include <formats/rgl/rgl_eval.h>
#include <formats/rgl/rgl_warp.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>
#include <brdf/core/version.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace brdf::formats {

namespace {

constexpr double pi_d = std::numbers::pi;

// Zenith angle of grid node k of n on the renderers' u_theta = sqrt(theta / (pi/2)) scale.
double node_theta(int k, int n) {
    const double u = static_cast<double>(k) / (n - 1);
    return u * u * (pi_d / 2);
}

std::string vec_text(const Vec3& v) {
    return cat("(", v.x, ", ", v.y, ", ", v.z, ")");
}

// CIE 1931 y-bar, the two-lobe piecewise-Gaussian fit of Wyman, Sloan and Shirley, "Simple Analytic
// Approximations to the CIE XYZ Color Matching Functions", JCGT 2(2) 2013, eq. 2 (nm). Used only
// to weight channels for sampling and for the NDF, where a 1 % error does not matter.
double cie_y_bar(double nm) {
    const auto lobe = [nm](double mu, double s_below, double s_above) {
        const double t = (nm - mu) / (nm < mu ? s_below : s_above);
        return std::exp(-0.5 * t * t);
    };
    return 0.821 * lobe(568.8, 46.9, 40.5) + 0.286 * lobe(530.9, 16.3, 31.1);
}

std::vector<double> luminance_weights(const RglOptions& options, std::size_t channels) {
    if (!options.luminance_weights.empty()) {
        if (options.luminance_weights.size() != channels)
            throw InputError(cat("RGL options: ", options.luminance_weights.size(),
                                 " luminance weights for ", channels, " channels"));
        double sum = 0.0;
        for (double w : options.luminance_weights) {
            if (!(w >= 0.0) || !std::isfinite(w))
                throw InputError(cat("RGL options: luminance weight ", w, " is not >= 0"));
            sum += w;
        }
        if (!(sum > 0.0)) throw InputError("RGL options: the luminance weights are all 0");
        return options.luminance_weights;
    }
    if (options.wavelengths_nm.empty()) return {0.2126, 0.7152, 0.0722}; // Rec.709 Y
    const std::vector<double>& nm = options.wavelengths_nm;
    std::vector<double> w(channels);
    double sum = 0.0;
    for (std::size_t c = 0; c < channels; ++c) {
        const double width = channels == 1 ? 1.0
                                           : 0.5 * (nm[std::min(c + 1, channels - 1)] -
                                                    nm[c == 0 ? 0 : c - 1]);
        w[c] = cie_y_bar(nm[c]) * width;
        sum += w[c];
    }
    // Outside the visible range y-bar vanishes: weigh the channels equally instead.
    if (!(sum > 1e-6 * static_cast<double>(channels))) std::fill(w.begin(), w.end(), 1.0);
    return w;
}

// Integral over the azimuth of max(0, w.m) for zenith angles theta_w, theta_m in [0, pi/2]:
// int_0^2pi max(0, a cos(phi) + b) dphi with a = sin sin, b = cos cos >= 0.
double azimuthal_cosine_integral(double theta_w, double theta_m) {
    const double a = std::sin(theta_w) * std::sin(theta_m);
    const double b = std::max(std::cos(theta_w) * std::cos(theta_m), 0.0);
    if (a <= b) return 2.0 * pi_d * b;
    const double ratio = b / a, phi0 = std::acos(-ratio);
    return 2.0 * (b * phi0 + a * std::sqrt(std::max(1.0 - ratio * ratio, 0.0)));
}

// K[e][k]: sigma(theta_e) = sum_k K[e][k] D_k for D piecewise linear in u_theta between the n nodes
// D_k (isotropic), sigma(w) = int D(m) <w.m> dm with dm = sin(theta) dtheta dphi and dtheta =
// pi u du. Gauss-Legendre per patch; the integrand has a kink (theta_m = pi/2 - theta_w), so each
// patch gets more points than smoothness alone would need.
std::vector<std::vector<double>> projected_area_kernel(const std::vector<double>& thetas, int n) {
    const auto rule = gauss_legendre(24, 0.0, 1.0);
    std::vector<std::vector<double>> kernel(thetas.size(), std::vector<double>(n, 0.0));
    for (std::size_t e = 0; e < thetas.size(); ++e)
        for (int k = 0; k + 1 < n; ++k)
            for (std::size_t q = 0; q < rule.size(); ++q) {
                const double t = rule.x[q];
                const double u = (k + t) / (n - 1);
                const double theta_m = u * u * (pi_d / 2);
                const double g = azimuthal_cosine_integral(thetas[e], theta_m) *
                                 std::sin(theta_m) * pi_d * u * rule.w[q] / (n - 1);
                kernel[e][k] += (1.0 - t) * g;
                kernel[e][k + 1] += t * g;
            }
    return kernel;
}

std::vector<double> project(const std::vector<std::vector<double>>& kernel,
                          const std::vector<double>& d) {
    std::vector<double> out(kernel.size(), 0.0);
    for (std::size_t e = 0; e < kernel.size(); ++e)
        for (std::size_t k = 0; k < d.size(); ++k) out[e] += kernel[e][k] * d[k];
    return out;
}

// Linear interpolation in u_theta of values at the n nodes of the u grid.
double interpolate_u(const std::vector<double>& nodes, double theta) {
    const int n = static_cast<int>(nodes.size());
    const double x = std::sqrt(std::max(theta, 0.0) / (pi_d / 2)) * (n - 1);
    const int k = std::min(static_cast<int>(x), n - 2);
    const double t = std::min(x - k, 1.0);
    return nodes[k] * (1.0 - t) + nodes[k + 1] * t;
}

class CheckedCallback {
  public:
    CheckedCallback(const RglBrdfCallback& f, std::size_t channels)
        : m_f(f), m_values(channels) {}

    const std::vector<double>& operator()(const Vec3& wi, const Vec3& wo) {
        const std::size_t channels = m_values.size();
        m_f(wi, wo, m_values);
        if (m_values.size() != channels)
            throw NumericalError(cat("RGL: the BRDF returned ", m_values.size(), " values (",
                                     channels, " channels expected) at wi ", vec_text(wi),
                                     ", wo ", vec_text(wo)));
        for (std::size_t c = 0; c < channels; ++c)
            if (!std::isfinite(m_values[c]) || m_values[c] < 0.0)
                throw NumericalError(cat("RGL: the BRDF returned ", m_values[c], " for channel ",
                                         c, " at wi ", vec_text(wi), ", wo ", vec_text(wo),
                                         " (a finite value >= 0 expected)"));
        return m_values;
    }

  private:
    const RglBrdfCallback& m_f;
    std::vector<double> m_values;
};

void check_options(const RglOptions& o) {
    const auto at_least_2 = [](int v, const char* name) {
        if (v < 2 || v > 4096)
            throw InputError(cat("RGL options: ", name, " = ", v, " (2 .. 4096 expected)"));
    };
    at_least_2(o.theta_i_count, "theta_i_count");
    at_least_2(o.sample_resolution, "sample_resolution");
    at_least_2(o.vndf_theta_resolution, "vndf_theta_resolution");
    at_least_2(o.vndf_phi_resolution, "vndf_phi_resolution");
    at_least_2(o.ndf_resolution, "ndf_resolution");
    at_least_2(o.sigma_resolution, "sigma_resolution");
    if (!(o.max_theta_i_deg > 0.0 && o.max_theta_i_deg <= 90.0))
        throw InputError(cat("RGL options: max_theta_i_deg = ", o.max_theta_i_deg,
                             " ((0, 90] expected)"));
    for (std::size_t c = 0; c < o.wavelengths_nm.size(); ++c)
        if (!(o.wavelengths_nm[c] > 0.0) || !std::isfinite(o.wavelengths_nm[c]) ||
            (c > 0 && !(o.wavelengths_nm[c] > o.wavelengths_nm[c - 1])))
            throw InputError(cat("RGL options: wavelengths_nm[", c, "] = ", o.wavelengths_nm[c],
                                 " (positive and increasing expected)"));
}

} // namespace

std::string rgl_description(const std::string& generator, const std::string& spec_json) {
    const auto quoted = [](const std::string& s) {
        std::string out = "\"";
        for (char ch : s) {
            if (ch == '"' || ch == '\\')
                out += cat('\\', ch);
            else if (static_cast<unsigned char>(ch) < 0x20) {
                static const char* hex = "0123456789abcdef";
                out += cat("\\u00", hex[(ch >> 4) & 0xf], hex[ch & 0xf]);
            } else
                out += ch;
        }
        return out + "\"";
    };
    std::string out = cat("{\"generator\": ", quoted(generator));
    if (!spec_json.empty()) {
        const auto first = spec_json.find_first_not_of(" \t\r\n");
        const auto last = spec_json.find_last_not_of(" \t\r\n");
        const bool object = first != std::string::npos && spec_json[first] == '{' &&
                            spec_json[last] == '}';
        out += cat(", \"spec\": ", object ? spec_json.substr(first, last - first + 1)
                                          : quoted(spec_json));
    }
    return out + "}";
}

RglBsdf make_rgl_bsdf(const RglBrdfCallback& brdf, const RglOptions& options) {
    check_options(options);
    const bool spectral = !options.wavelengths_nm.empty();
    const std::size_t channels = spectral ? options.wavelengths_nm.size() : 3;
    const std::vector<double> weights = luminance_weights(options, channels);
    CheckedCallback f(brdf, channels);
    const auto luminance = [&](const std::vector<double>& v) {
        double y = 0.0;
        for (std::size_t c = 0; c < channels; ++c) y += weights[c] * v[c];
        return y;
    };

    RglBsdf out;
    out.jacobian = true;
    out.description =
        options.description.empty() ? rgl_description(generator_string, "") : options.description;
    for (double nm : options.wavelengths_nm) out.wavelengths.push_back(static_cast<float>(nm));
    const int T = options.theta_i_count;
    for (int k = 0; k < T; ++k)
        out.theta_i.push_back(static_cast<float>(
            static_cast<double>(k) / (T - 1) * options.max_theta_i_deg * pi_d / 180.0));
    out.phi_i = {0.0f};

    // 1. The NDF: power iteration on D = f(w, w) cos(theta) sigma_D(w) (see the header).
    const int n_ndf = options.ndf_resolution;
    std::vector<double> ndf_theta(n_ndf), retro_cos(n_ndf);
    for (int k = 0; k + 1 < n_ndf; ++k) {
        ndf_theta[k] = node_theta(k, n_ndf);
        const Vec3 w{std::sin(ndf_theta[k]), 0.0, std::cos(ndf_theta[k])};
        retro_cos[k] = luminance(f(w, w)) * w.z;
    }
    // f(w, w) cos(theta) has a finite limit at the horizon (a microfacet f(w, w) grows like
    // 1 / cos(theta)), where the model cannot be asked: extrapolate linearly in u.
    ndf_theta[n_ndf - 1] = pi_d / 2;
    retro_cos[n_ndf - 1] =
        n_ndf > 2 ? std::max(2.0 * retro_cos[n_ndf - 2] - retro_cos[n_ndf - 3], 0.0)
                  : retro_cos[0];
    const double retro_max = *std::max_element(retro_cos.begin(), retro_cos.end());
    for (double& r : retro_cos) r = retro_max > 0.0 ? std::max(r, 1e-6 * retro_max) : 1.0;
    const auto ndf_kernel = projected_area_kernel(ndf_theta, n_ndf);
    std::vector<double> D(n_ndf, 1.0 / pi_d);
    int iterations = 0;
    for (double change = 1.0; change > 1e-10 && iterations < 1000; ++iterations) {
        const std::vector<double> sigma = project(ndf_kernel, D);
        std::vector<double> next(n_ndf);
        for (int k = 0; k < n_ndf; ++k) next[k] = retro_cos[k] * sigma[k];
        const double norm = project(ndf_kernel, next)[0]; // sigma(normal) = int D cos = 1
        change = 0.0;
        double peak = 0.0;
        for (int k = 0; k < n_ndf; ++k) {
            next[k] /= norm;
            change = std::max(change, std::abs(next[k] - D[k]));
            peak = std::max(peak, next[k]);
        }
        change /= peak;
        D = std::move(next);
    }
    log::debug("RGL: NDF power iteration: ", iterations, " iterations");
    const double d_peak = *std::max_element(D.begin(), D.end());
    for (double& d : D) d = std::max(d, 1e-4 * d_peak);
    const double d_norm = project(ndf_kernel, D)[0];
    for (double& d : D) d /= d_norm;
    out.ndf.shape = {2, static_cast<std::size_t>(n_ndf)};
    for (int row = 0; row < 2; ++row)
        for (double d : D) out.ndf.values.push_back(static_cast<float>(d));

    // 2. sigma on its own grid.
    const int n_sigma = options.sigma_resolution;
    std::vector<double> sigma_theta(n_sigma);
    for (int k = 0; k < n_sigma; ++k) sigma_theta[k] = node_theta(k, n_sigma);
    const std::vector<double> sigma = project(projected_area_kernel(sigma_theta, n_ndf), D);
    out.sigma.shape = {2, static_cast<std::size_t>(n_sigma)};
    for (int row = 0; row < 2; ++row)
        for (double s : sigma) out.sigma.values.push_back(static_cast<float>(s));

    // 3. The visible-normal warp per incidence. Relative azimuths pi (2 r - (np - 1)) / (np - 1)
    //    are exactly antisymmetric in r, so the grid is exactly symmetric about the plane of
    //    incidence.
    const int nvt = options.vndf_theta_resolution, nvp = options.vndf_phi_resolution;
    out.vndf.shape = {1, static_cast<std::size_t>(T), static_cast<std::size_t>(nvp),
                      static_cast<std::size_t>(nvt)};
    out.vndf.values.reserve(out.vndf.size());
    for (int t = 0; t < T; ++t) {
        const double theta_i = out.theta_i[t];
        const Vec3 wi{std::sin(theta_i), 0.0, std::cos(theta_i)};
        const double sigma_i = interpolate_u(sigma, theta_i);
        for (int r = 0; r < nvp; ++r) {
            const double phi = pi_d * (2 * r - (nvp - 1)) / (nvp - 1);
            for (int c = 0; c < nvt; ++c) {
                const double u = static_cast<double>(c) / (nvt - 1);
                const double theta_m = u * u * (pi_d / 2);
                const double cos_im = wi.x * std::sin(theta_m) * std::cos(phi) +
                                      wi.z * std::cos(theta_m);
                const double jacobian = 2.0 * pi_d * pi_d * u * std::sin(theta_m);
                out.vndf.values.push_back(static_cast<float>(
                    interpolate_u(D, theta_m) * std::max(cos_im, 0.0) * jacobian / sigma_i));
            }
        }
    }

    // 4. BRDF samples on the warped grid, divided by the factor the renderer multiplies back.
    const int n = options.sample_resolution;
    const std::size_t nn = static_cast<std::size_t>(n) * n;
    out.values.shape = {1, static_cast<std::size_t>(T), channels, static_cast<std::size_t>(n),
                        static_cast<std::size_t>(n)};
    out.luminance.shape = {1, static_cast<std::size_t>(T), static_cast<std::size_t>(n),
                           static_cast<std::size_t>(n)};
    out.values.values.assign(out.values.size(), 1.0f);
    out.luminance.values.assign(out.luminance.size(), 1.0f);
    // An evaluator on the finished ndf, sigma and vndf (the samples are still placeholders) gives
    // the renderer's warp and factor.
    const RglEvaluator geometry(out);
    const rgl::PiecewiseLinearWarp warp(out.vndf.values, static_cast<std::uint32_t>(nvt),
                                        static_cast<std::uint32_t>(nvp), {out.phi_i, out.theta_i},
                                        true, true);
    std::size_t below_horizon = 0;
    for (int t = 0; t < T; ++t) {
        const double theta_i = out.theta_i[t];
        const Vec3 wi{std::sin(theta_i), 0.0, std::cos(theta_i)};
        const float params[2] = {out.phi_i[0], out.theta_i[t]};
        // Nodes whose wo is at or below the horizon keep 0: the limit of f cos(theta_o) there.
        std::vector<std::vector<double>> grids(channels, std::vector<double>(nn, 0.0));
        std::vector<double> lum(nn, 0.0);
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                const rgl::Point2f s{static_cast<float>(x) / static_cast<float>(n - 1),
                                     static_cast<float>(y) / static_cast<float>(n - 1)};
                const auto [u_m, warp_density] = warp.sample(s, params);
                const double u_theta = u_m.x;
                const double theta_m = u_theta * u_theta * (pi_d / 2);
                const double phi_m = (2.0 * u_m.y - 1.0) * pi_d; // relative to phi_i = 0
                const Vec3 m{std::sin(theta_m) * std::cos(phi_m),
                             std::sin(theta_m) * std::sin(phi_m), std::cos(theta_m)};
                const double cos_im = wi.x * m.x + wi.y * m.y + wi.z * m.z;
                const Vec3 wo{2 * cos_im * m.x - wi.x, 2 * cos_im * m.y - wi.y,
                              2 * cos_im * m.z - wi.z};
                const double factor = cos_im > 0.0 && wo.z > 0.0
                                          ? geometry.sample_factor(wi, wo)
                                          : 0.0;
                if (!(factor > 0.0) || !std::isfinite(factor)) {
                    ++below_horizon;
                    continue;
                }
                const std::vector<double>& value = f(wi, wo);
                const std::size_t i = static_cast<std::size_t>(y) * n + x;
                for (std::size_t c = 0; c < channels; ++c)
                    grids[c][i] = value[c] * wo.z / factor;
                // The renderers sample s by the luminance, then wo by the warp: for a pdf of wo
                // proportional to f cos(theta_o), the luminance at s is that over the warp's pdf
                // of wo, density / (2 pi^2 u sin(theta_m) 4 wi.m). For the visible-normal warp
                // that pdf is close to D / (4 sigma) and this is the luminance of the samples.
                const double grid_jacobian = 2.0 * pi_d * pi_d * u_theta * std::sin(theta_m);
                const double warp_pdf = warp_density / (grid_jacobian * 4.0 * cos_im);
                lum[i] = warp_pdf > 0.0 && std::isfinite(warp_pdf)
                             ? luminance(value) * wo.z / warp_pdf
                             : 0.0;
            }
        // 5. A small floor keeps every luminance grid normalisable.
        double lum_max = 0.0;
        for (double l : lum) lum_max = std::max(lum_max, l);
        for (std::size_t i = 0; i < nn; ++i) {
            const std::size_t base = static_cast<std::size_t>(t) * nn;
            out.luminance.values[base + i] =
                static_cast<float>(lum_max > 0.0 ? lum[i] + 1e-6 * lum_max : 1.0);
            for (std::size_t c = 0; c < channels; ++c)
                out.values.values[(static_cast<std::size_t>(t) * channels + c) * nn + i] =
                    static_cast<float>(grids[c][i]);
        }
    }
    log::debug("RGL: ", below_horizon, " of ", T * nn,
               " sample nodes map to or below the horizon (0 there)");
    if (const std::string fault = rgl_bsdf_fault(out); !fault.empty())
        throw NumericalError(cat("RGL: the parameterisation is invalid: ", fault));
    return out;
}

RglBsdf rgl_rgb_from_spectral(const RglBsdf& spectral, const std::vector<std::array<double, 3>>& weights) {
    if (!spectral.spectral())
        throw InputError("rgl_rgb_from_spectral: the file is not spectral (no wavelengths)");
    const std::size_t channels = spectral.channels();
    if (weights.size() != channels)
        throw InputError(cat("rgl_rgb_from_spectral: ", weights.size(), " colour weights for ", channels,
                             " wavelengths"));
    for (const auto& w : weights)
        for (double v : w)
            if (!std::isfinite(v)) throw InputError(cat("rgl_rgb_from_spectral: colour weight ", v, " is not finite"));
    const std::vector<std::size_t>& shape = spectral.values.shape;
    if (shape.size() != 5 || shape[2] != channels || spectral.values.values.size() != spectral.values.size())
        throw InputError("rgl_rgb_from_spectral: the spectral samples do not match the wavelengths");

    RglBsdf out = spectral;
    out.wavelengths.clear();
    out.values.shape[2] = 3;
    const std::size_t grids = shape[0] * shape[1], nn = shape[3] * shape[4];
    out.values.values.assign(grids * 3 * nn, 0.0f);
    for (std::size_t g = 0; g < grids; ++g)
        for (std::size_t i = 0; i < nn; ++i)
            for (std::size_t c = 0; c < 3; ++c) {
                double sum = 0.0;
                for (std::size_t l = 0; l < channels; ++l)
                    sum += weights[l][c] * spectral.values.values[(g * channels + l) * nn + i];
                out.values.values[(g * 3 + c) * nn + i] = static_cast<float>(std::max(sum, 0.0));
            }
    return out;
}

} // namespace brdf::formats
