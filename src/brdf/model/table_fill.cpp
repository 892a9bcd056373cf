#include <brdf/model/table_fill.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/threads.h>
#include <brdf/rte/interface.h>
#include <brdf/rte/phase.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace brdf::model {
namespace {

constexpr int phase_table_points = 8192;
// A(mu) / (n sqrt(pi)) is smooth (linear near grazing for a half-space): 2049 points interpolate it to
// ~1e-7.
constexpr int fresnel_table_points = 2049;
// The facet Fresnel factor F(cos theta_d; n) is analytic on [0, 1] (n > 1): Catmull-Rom on 2048
// intervals interpolates it to ~1e-10 (O(h^3)), well inside the lobe's 1e-6. One ghost point beyond
// each end keeps the end intervals cubic too.
constexpr int lobe_fresnel_intervals = 2048;

// Catmull-Rom weights for fractional position f in [0, 1) between taps 0 and 1 of (-1, 0, 1, 2).
void catmull_rom(double f, double w[4]) {
    const double f2 = f * f, f3 = f2 * f;
    w[0] = 0.5 * (-f3 + 2.0 * f2 - f);
    w[1] = 0.5 * (3.0 * f3 - 5.0 * f2 + 2.0);
    w[2] = 0.5 * (-3.0 * f3 + 4.0 * f2 + f);
    w[3] = 0.5 * (f3 - f2);
}

// Taps and weights along one zenith axis of the grid.
struct Stencil {
    int idx[4];
    double w[4];
};

Stencil stencil(double theta, int grid) {
    const double t = std::clamp(theta / (0.5 * std::numbers::pi), 0.0, 1.0) * (grid - 1);
    const int i0 = std::min(static_cast<int>(t), grid - 2);
    Stencil s;
    catmull_rom(t - i0, s.w);
    for (int k = 0; k < 4; ++k) s.idx[k] = std::clamp(i0 - 1 + k, 0, grid - 1);
    return s;
}

double lerp_table(const double* table, int points, double x) { // x in [0, 1]
    const double t = std::clamp(x, 0.0, 1.0) * (points - 1);
    const int k = std::min(static_cast<int>(t), points - 2);
    const double f = t - k;
    return (1.0 - f) * table[k] + f * table[k + 1];
}

// Catmull-Rom through a table with one ghost point beyond each end: table[k] holds the value at
// x_k = (k - 1) / (points - 3), k = 0 .. points - 1; x in [0, 1].
double cubic_table(const double* table, int points, double x) {
    const int intervals = points - 3;
    const double t = std::clamp(x, 0.0, 1.0) * intervals;
    const int k = std::min(static_cast<int>(t), intervals - 1);
    double w[4];
    catmull_rom(t - k, w);
    const double* v = table + k; // taps x_{k-1} .. x_{k+2} are table[k] .. table[k + 3]
    return w[0] * v[0] + w[1] * v[1] + w[2] * v[2] + w[3] * v[3];
}

// Smith Lambda from a direction's cosine and sine (rte/rough_interface.cpp, Facets::lambda: Walter
// et al. 2007, G1 of eqs. 34 (GGX) and 27 (Beckmann, exact)).
double smith_lambda(FillInputs::Lobe lobe, double alpha, double mu, double s) {
    if (!(s > 0.0)) return 0.0;
    if (!(mu > 0.0)) return std::numeric_limits<double>::infinity();
    if (lobe == FillInputs::Lobe::Ggx) {
        const double x = alpha * alpha * s * s / (mu * mu); // alpha^2 tan^2
        return x / (2.0 * (1.0 + std::sqrt(1.0 + x)));
    }
    const double a = mu / (alpha * s);
    return 0.5 * (std::exp(-a * a) / (a * std::sqrt(std::numbers::pi)) - std::erfc(a));
}

// The first-surface lobe without its Fresnel factor, D(h) G(wi, wo) / (4 mu_i mu_o), and the cosine
// wi.h it needs, for the graphics azimuth phi (the geometry of rte/rough_interface.cpp: with
// omc = 1 + cos(phi), tan^2(theta_h) = ((s_i - s_o)^2 + 2 s_i s_o omc) / (mu_i + mu_o)^2 and
// wi.wo = mu_i mu_o - s_i s_o + s_i s_o omc).
struct LobeGeometry {
    double cos_d = 0.0;
    double value = 0.0;
};

LobeGeometry lobe_geometry(const FillInputs& in, double mu_i, double mu_o, double phi) {
    const double s_i = std::sqrt(std::max(0.0, (1.0 - mu_i) * (1.0 + mu_i)));
    const double s_o = std::sqrt(std::max(0.0, (1.0 - mu_o) * (1.0 + mu_o)));
    const double cos_half = std::cos(0.5 * phi), omc = 2.0 * cos_half * cos_half;
    const double sum = mu_i + mu_o;
    const double t2 = ((s_i - s_o) * (s_i - s_o) + 2.0 * s_i * s_o * omc) / (sum * sum);
    const double a2 = in.lobe_alpha * in.lobe_alpha, sec2 = 1.0 + t2;
    double d = 0.0;
    if (in.lobe == FillInputs::Lobe::Ggx) { // Walter eq. 33
        const double q = a2 + t2;
        d = a2 * sec2 * sec2 / (std::numbers::pi * q * q);
    } else { // Walter eq. 25
        d = std::exp(-t2 / a2) * sec2 * sec2 / (std::numbers::pi * a2);
    }
    const double li = smith_lambda(in.lobe, in.lobe_alpha, mu_i, s_i);
    const double lo = smith_lambda(in.lobe, in.lobe_alpha, mu_o, s_o);
    // Heitz 2014 eqs. 99 (height-correlated) and 98 (separable).
    const double g = in.lobe_separable ? 1.0 / ((1.0 + li) * (1.0 + lo)) : 1.0 / (1.0 + li + lo);
    LobeGeometry out;
    out.cos_d = std::sqrt(std::max(0.0, 0.5 * (1.0 + mu_i * mu_o - s_i * s_o + s_i * s_o * omc)));
    out.value = d * g / (4.0 * mu_i * mu_o);
    return out;
}

// The rough top's lobe constants, the same for every sample (the spec's surface), and the facet
// Fresnel factor per channel of the samples `which` with colour weights `weights` (the RGB fill:
// all samples with theirs; a spectral group: its own with one-hot weights).
void prepare_lobe(const SolvedMaterial& material, const std::vector<std::size_t>& which,
                  const std::vector<Rgb>& weights, FillInputs& in) {
    const rte::RoughInterface* first = nullptr;
    for (const WavelengthSolution& s : material.samples) {
        const rte::RoughInterface* r = s.reflection.rough_interface();
        if (!r) continue;
        if (!first) first = r;
        if (r->surface() != first->surface())
            throw InternalError("table fill: the samples' rough surfaces differ (one lobe per table expected)");
    }
    if (!first) return;
    const rte::RoughSurface& surface = first->surface();
    in.lobe = surface.distribution == rte::Microfacet::Ggx ? FillInputs::Lobe::Ggx : FillInputs::Lobe::Beckmann;
    in.lobe_separable = surface.masking == rte::Masking::Separable;
    in.lobe_alpha = surface.alpha;
    const int p = lobe_fresnel_intervals + 3;
    in.lobe_points = p;
    in.lobe_fresnel.assign(3 * static_cast<std::size_t>(p), 0.0);
    for (std::size_t j = 0; j < which.size(); ++j) {
        const rte::RoughInterface* r = material.samples[which[j]].reflection.rough_interface();
        if (!r) continue;
        const rte::Interface facet{r->index()};
        for (int k = 0; k < p; ++k) {
            // The ghost points lie just outside [0, 1], where the formula continues analytically.
            const double c = static_cast<double>(k - 1) / lobe_fresnel_intervals;
            const double f = facet.reflectance_from_air(c);
            for (int ch = 0; ch < 3; ++ch) in.lobe_fresnel[static_cast<std::size_t>(ch) * p + k] += weights[j][ch] * f;
        }
    }
}

} // namespace

namespace {

// The Nystrom grids of every sample at the table's zenith angles: the expensive part of
// prepare_fill, and independent of the colour weights.
std::vector<rte::OrderGrid> order_grids(const SolvedMaterial& material) {
    const int e = material.settings.table_grid;
    std::vector<double> mu(static_cast<std::size_t>(e));
    for (int a = 0; a < e; ++a) mu[a] = std::cos(0.5 * std::numbers::pi * a / (e - 1));
    // Independent per sample: one thread per core.
    std::vector<rte::OrderGrid> grids(material.samples.size());
    parallel_for(static_cast<int>(material.samples.size()), available_cpus(),
                 [&](int k) { grids[k] = material.samples[k].reflection.order_grid(mu); });
    return grids;
}

// The fill inputs of the samples `which` with colour weights `weights` (one per entry of `which`).
FillInputs assemble_fill(const SolvedMaterial& material, const std::vector<rte::OrderGrid>& grids,
                         const std::vector<std::size_t>& which, const std::vector<Rgb>& weights) {
    FillInputs in;
    const int e = material.settings.table_grid;
    in.grid = e;
    for (std::size_t k : which) in.orders = std::max(in.orders, material.samples[k].reflection.orders());
    const int mp = padded_orders(in.orders);
    in.fourier.assign(static_cast<std::size_t>(mp) * 3 * e * e, 0.0);
    in.phase_points = phase_table_points;
    in.fresnel_points = fresnel_table_points;
    const double inv_sqrt_pi = 1.0 / std::sqrt(std::numbers::pi);
    for (std::size_t j = 0; j < which.size(); ++j) {
        const rte::Reflection& r = material.samples[which[j]].reflection;
        const rte::OrderGrid& g = grids[which[j]];
        const Rgb& weight = weights[j];
        for (int m = 0; m < static_cast<int>(g.orders.size()); ++m) {
            const double factor = (m == 0 ? 1.0 : 2.0) * (m % 2 == 0 ? 1.0 : -1.0) * std::numbers::inv_pi;
            for (int o = 0; o < e; ++o)
                for (int i = 0; i < e; ++i) {
                    double* dst = &in.fourier[((static_cast<std::size_t>(o) * e + i) * mp + m) * 3];
                    const double v = factor * g.orders[m](o, i);
                    for (int c = 0; c < 3; ++c) dst[c] += weight[c] * v;
                }
        }
        if (r.setup().stack.top == rte::Top::Rough) continue; // no TMS under a rough surface
        for (int layer = 0; layer < static_cast<int>(r.setup().layers.size()); ++layer) {
            const rte::Reflection::ScatteringLayer l = r.scattering_layer(layer);
            for (int p = 0; p < in.phase_points; ++p) {
                const double x = static_cast<double>(p) / (in.phase_points - 1); // sin(Theta / 2)
                in.phase.push_back(0.25 * l.albedo * rte::phase_value(*l.beta, 1.0 - 2.0 * x * x));
            }
            in.refractive_index.push_back(l.index);
            in.tau.push_back(l.tau);
            for (int p = 0; p < fresnel_table_points; ++p)
                in.transmission.push_back(r.path_factor(layer, static_cast<double>(p) / (fresnel_table_points - 1)) *
                                          inv_sqrt_pi);
            for (int c = 0; c < 3; ++c) in.weight.push_back(weight[c]);
            ++in.samples;
        }
    }
    prepare_lobe(material, which, weights, in);
    return in;
}

} // namespace

FillInputs prepare_fill(const SolvedMaterial& material) {
    const std::vector<rte::OrderGrid> grids = order_grids(material);
    std::vector<std::size_t> all(material.samples.size());
    std::vector<Rgb> weights;
    for (std::size_t k = 0; k < all.size(); ++k) {
        all[k] = k;
        weights.push_back(material.samples[k].weight);
    }
    return assemble_fill(material, grids, all, weights);
}

void for_each_spectral_fill(const SolvedMaterial& material, const std::function<void(const SpectralFill&)>& fill) {
    const std::vector<rte::OrderGrid> grids = order_grids(material); // once for every group
    for (std::size_t first = 0; first < material.samples.size(); first += 3) {
        SpectralFill group;
        std::vector<std::size_t> which;
        std::vector<Rgb> weights;
        for (int c = 0; c < 3 && first + c < material.samples.size(); ++c) {
            which.push_back(first + c);
            Rgb one_hot{0.0, 0.0, 0.0};
            one_hot[c] = 1.0;
            weights.push_back(one_hot);
            group.sample[c] = static_cast<int>(first + c);
        }
        group.inputs = assemble_fill(material, grids, which, weights);
        fill(group);
    }
}

Rgb fill_value(const FillInputs& in, double theta_i, double theta_o, double phi) {
    Rgb out{0.0, 0.0, 0.0};
    const double mu_i = std::cos(theta_i), mu_o = std::cos(theta_o);
    if (mu_i <= 0.0 || mu_o <= 0.0) return out;
    const int e = in.grid;
    // Multiply scattered part: interpolate each order, then sum cos(m phi) by the Chebyshev recurrence.
    const Stencil so = stencil(theta_o, e), si = stencil(theta_i, e);
    const double c1 = std::cos(phi);
    double cm_prev = c1, cm = 1.0; // cos(-phi) = cos(phi), cos(0)
    const int mp = padded_orders(in.orders);
    constexpr int block = 3 * fill_order_block;
    for (int m0 = 0; m0 < in.orders; m0 += fill_order_block) {
        double acc[block] = {};
        for (int a = 0; a < 4; ++a)
            for (int b = 0; b < 4; ++b) {
                const double w = so.w[a] * si.w[b];
                const double* f =
                    &in.fourier[((static_cast<std::size_t>(so.idx[a]) * e + si.idx[b]) * mp + m0) * 3];
                for (int k = 0; k < block; ++k) acc[k] += w * f[k];
            }
        for (int j = 0; j < fill_order_block; ++j) {
            for (int c = 0; c < 3; ++c) out[c] += acc[3 * j + c] * cm;
            const double next = 2.0 * c1 * cm - cm_prev;
            cm_prev = cm;
            cm = next;
        }
    }
    // Single scattering with the full phase function, per sample (its own refraction). Snell:
    // sin(theta inside) = sin(theta in air) / n, so only the cosines inside need a square root.
    const double sin_i = std::sqrt(std::max(0.0, 1.0 - mu_i * mu_i)), sin_o = std::sqrt(std::max(0.0, 1.0 - mu_o * mu_o));
    const int kp = in.phase_points, kf = in.fresnel_points;
    for (int s = 0; s < in.samples; ++s) {
        const double n = in.refractive_index[s], inv_n2 = 1.0 / (n * n);
        const double ui = std::sqrt(1.0 - sin_i * sin_i * inv_n2), uo = std::sqrt(1.0 - sin_o * sin_o * inv_n2);
        const double cos_scatter = std::clamp(-uo * ui - sin_o * sin_i * inv_n2 * c1, -1.0, 1.0);
        const double phase = lerp_table(&in.phase[static_cast<std::size_t>(s) * kp], kp, std::sqrt(0.5 * (1.0 - cos_scatter)));
        // tab(mu) = A(mu) / (n sqrt(pi)): the term's factor A(mu_o) A(mu_i) / (n^2 pi).
        const double* t = &in.transmission[static_cast<std::size_t>(s) * kf];
        const double factor = lerp_table(t, kf, mu_o) * lerp_table(t, kf, mu_i);
        const double slab = std::isinf(in.tau[s]) ? 1.0 : -std::expm1(-in.tau[s] * (1.0 / uo + 1.0 / ui));
        const double v = factor * phase / (uo + ui) * slab;
        for (int c = 0; c < 3; ++c) out[c] += in.weight[s * 3 + c] * v;
    }
    for (double& v : out) v = std::max(0.0, v);
    if (in.lobe != FillInputs::Lobe::None) {
        const LobeGeometry g = lobe_geometry(in, mu_i, mu_o, phi);
        for (int c = 0; c < 3; ++c)
            out[c] = std::max(0.0, out[c] + g.value * cubic_table(&in.lobe_fresnel[static_cast<std::size_t>(c) * in.lobe_points],
                                                                  in.lobe_points, g.cos_d));
    }
    return out;
}

formats::BrdfTable fill_table_cpu(const FillInputs& in, int threads) {
    formats::BrdfTable table;
    // Rows of 180 cells (one theta_h, theta_d pair) per work item: the same split as the kernel's.
    const int rows = static_cast<int>(table.channels[0].size() / 180);
    parallel_for(rows, threads, [&](int row) {
        for (std::size_t cell = static_cast<std::size_t>(row) * 180; cell < static_cast<std::size_t>(row + 1) * 180; ++cell) {
            if (formats::cell_below_horizon(cell)) continue;
            const formats::CellIndices ix = formats::cell_indices(cell);
            const formats::DirectionPair d = formats::to_directions(
                formats::theta_h_centre(ix.theta_h), formats::theta_d_centre(ix.theta_d), formats::phi_d_centre(ix.phi_d));
            const double theta_i = std::acos(std::clamp(d.wi.z, -1.0, 1.0));
            const double theta_o = std::acos(std::clamp(d.wo.z, -1.0, 1.0));
            const double phi = std::atan2(d.wo.y, d.wo.x) - std::atan2(d.wi.y, d.wi.x);
            table.set(cell, fill_value(in, theta_i, theta_o, phi));
        }
    });
    return table;
}

} // namespace brdf::model
