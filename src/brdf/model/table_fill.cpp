#include <brdf/model/table_fill.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/threads.h>
#include <brdf/rte/phase.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace brdf::model {
namespace {

constexpr int phase_table_points = 8192;
// A(mu) / (n sqrt(pi)) is smooth (linear near grazing for a half-space): 2049 points interpolate it to
// ~1e-7.
constexpr int fresnel_table_points = 2049;

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
    in.fourier.assign(static_cast<std::size_t>(in.orders) * 3 * e * e, 0.0);
    in.phase_points = phase_table_points;
    in.fresnel_points = fresnel_table_points;
    const double inv_sqrt_pi = 1.0 / std::sqrt(std::numbers::pi);
    for (std::size_t j = 0; j < which.size(); ++j) {
        const rte::Reflection& r = material.samples[which[j]].reflection;
        const rte::OrderGrid& g = grids[which[j]];
        const Rgb& weight = weights[j];
        for (int m = 0; m < static_cast<int>(g.orders.size()); ++m) {
            const double factor = (m == 0 ? 1.0 : 2.0) * (m % 2 == 0 ? 1.0 : -1.0) * std::numbers::inv_pi;
            for (int c = 0; c < 3; ++c) {
                if (weight[c] == 0.0) continue;
                double* dst = &in.fourier[((static_cast<std::size_t>(m) * 3 + c) * e) * e];
                for (int o = 0; o < e; ++o)
                    for (int i = 0; i < e; ++i) dst[o * e + i] += weight[c] * factor * g.orders[m](o, i);
            }
        }
        if (r.setup().stack.top == rte::Top::Rough) continue; // no TMS under a rough surface
        for (int layer = 0; layer < static_cast<int>(r.setup().layers.size()); ++layer) {
            const rte::Reflection::ScatteringLayer l = r.scattering_layer(layer);
            for (int p = 0; p < in.phase_points; ++p) {
                const double x = static_cast<double>(p) / (in.phase_points - 1); // sin(Theta / 2)
                in.phase.push_back(0.25 * l.albedo * rte::phase_value(*l.beta, 1.0 - 2.0 * x * x));
            }
            in.index.push_back(l.index);
            in.tau.push_back(l.tau);
            for (int p = 0; p < fresnel_table_points; ++p)
                in.transmission.push_back(r.path_factor(layer, static_cast<double>(p) / (fresnel_table_points - 1)) *
                                          inv_sqrt_pi);
            for (int c = 0; c < 3; ++c) in.weight.push_back(weight[c]);
            ++in.samples;
        }
    }
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
    for (int m = 0; m < in.orders; ++m) {
        for (int c = 0; c < 3; ++c) {
            const double* f = &in.fourier[((static_cast<std::size_t>(m) * 3 + c) * e) * e];
            double v = 0.0;
            for (int a = 0; a < 4; ++a) {
                const double* row = f + static_cast<std::size_t>(so.idx[a]) * e;
                v += so.w[a] * (si.w[0] * row[si.idx[0]] + si.w[1] * row[si.idx[1]] + si.w[2] * row[si.idx[2]] +
                                si.w[3] * row[si.idx[3]]);
            }
            out[c] += v * cm;
        }
        const double next = 2.0 * c1 * cm - cm_prev;
        cm_prev = cm;
        cm = next;
    }
    // Single scattering with the full phase function, per sample (its own refraction). Snell:
    // sin(theta inside) = sin(theta in air) / n, so only the cosines inside need a square root.
    const double sin_i = std::sqrt(std::max(0.0, 1.0 - mu_i * mu_i)), sin_o = std::sqrt(std::max(0.0, 1.0 - mu_o * mu_o));
    const int kp = in.phase_points, kf = in.fresnel_points;
    for (int s = 0; s < in.samples; ++s) {
        const double n = in.index[s], inv_n2 = 1.0 / (n * n);
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
