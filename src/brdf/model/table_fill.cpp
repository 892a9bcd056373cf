#include <brdf/model/table_fill.h>

#include <brdf/core/error.h>
#include <brdf/core/lane_set.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>
#include <brdf/core/threads.h>
#include <brdf/rte/interface.h>
#include <brdf/rte/phase.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>

namespace brdf::model {
namespace {

// The phase function against u = sin(Theta / 2) - cos(Theta / 2) = sqrt(2) sin(Theta / 2 - pi / 4),
// in [-1, 1]: two square roots of cos(Theta) per cell, and du / dTheta lies in [0.5, 0.71], so the
// table resolves the backward peak and the glory as well as the forward peak (reflection under a
// binder of index 1.5 sees only Theta > 96 degrees). A table uniform in sin(Theta / 2) left the
// last 2 degrees before backscattering to one interval and erred by ~1e-5 there for the seed's
// rutile (Legendre order ~100). Catmull-Rom on 8192 intervals, one ghost point beyond each end
// (exact: p is even about Theta = 0 and pi), errs by ~1e-9, and its C1 pieces keep the term smooth
// in the binder index, which share_single_scattering interpolates in.
constexpr int phase_table_intervals = 8192;
constexpr int phase_table_points = phase_table_intervals + 3;
// A(mu) / (n sqrt(pi)) is smooth (linear near grazing for a half-space): Catmull-Rom on 2048
// intervals (ghost points extrapolated) interpolates it to ~1e-9 down to 86 degrees, where the
// linear table of before erred by ~1e-6.
constexpr int fresnel_table_intervals = 2048;
constexpr int fresnel_table_points = fresnel_table_intervals + 3;
// The facet Fresnel factor F(cos theta_d; n) is analytic on [0, 1] (n > 1): Catmull-Rom on 2048
// intervals interpolates it to ~1e-10 (O(h^3)), well inside the lobe's 1e-6. One ghost point beyond
// each end keeps the end intervals cubic too.
constexpr int lobe_fresnel_intervals = 2048;

// Catmull-Rom weights for fractional position f in [0, 1) between taps 0 and 1 of (-1, 0, 1, 2); T
// is double, or a vector of lanes (the fill in lanes below).
template <typename T> [[gnu::always_inline]] inline void catmull_rom(T f, T w[4]) {
    const T f2 = f * f, f3 = f2 * f;
    w[0] = 0.5 * (-f3 + 2.0 * f2 - f);
    w[1] = 0.5 * (3.0 * f3 - 5.0 * f2 + 2.0);
    w[2] = 0.5 * (-3.0 * f3 + 4.0 * f2 + f);
    w[3] = 0.5 * (f3 - f2);
}

} // namespace

double zenith_grid_cosine(int a, int grid) {
    return 0.5 * (1.0 + std::cos(std::numbers::pi * a / (grid - 1))); // cos^2 v
}

namespace {

// Taps and weights along one zenith axis of the grid (nodes uniform in v = acos(sqrt(mu)), see
// zenith_grid_cosine). The taps beyond either end are the nodes mirrored there: at the horizon mu
// is even in v; at the normal order m goes as sin^m, so its mirror image is (-1)^m times the node
// (`ghost`: the tap is node 1 mirrored through the normal).
struct Stencil {
    int idx[4];
    double w[4];
    bool ghost[4];
};

Stencil stencil(double mu, int grid) {
    // v = acos(sqrt(mu)) = acos(2 mu - 1) / 2: one acos, as the zenith angle took.
    const double t = std::acos(std::clamp(2.0 * mu - 1.0, -1.0, 1.0)) / std::numbers::pi * (grid - 1);
    const int i0 = std::min(static_cast<int>(t), grid - 2);
    Stencil s;
    catmull_rom(t - i0, s.w);
    for (int k = 0; k < 4; ++k) {
        const int j = i0 - 1 + k;
        s.idx[k] = j > grid - 1 ? 2 * (grid - 1) - j : (j < 0 ? -j : j);
        s.ghost[k] = j < 0;
    }
    return s;
}

// The blocks of orders a cell sums: the most any of its 16 taps' nodes needs (FillInputs::node_blocks).
int cell_blocks(const FillInputs& in, const Stencil& so, const Stencil& si) {
    if (in.orders == 0 || in.node_blocks.empty()) return padded_orders(in.orders) / fill_order_block;
    int blocks = 0;
    for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b)
            blocks = std::max(blocks, in.node_blocks[static_cast<std::size_t>(so.idx[a]) * in.grid + si.idx[b]]);
    return blocks;
}

// Catmull-Rom through a table with one ghost point beyond each end: table[k] holds the value at
// x_k = (k - 1) / (points - 3), k = 0 .. points - 1; x in [0, 1]. The taps x_{k-1} .. x_{k+2} of
// x's interval are entries k .. k + 3.
struct CubicTaps {
    int k;
    double w[4];
};

CubicTaps cubic_taps(int points, double x) {
    const int intervals = points - 3;
    const double t = std::clamp(x, 0.0, 1.0) * intervals;
    CubicTaps taps;
    taps.k = std::min(static_cast<int>(t), intervals - 1);
    catmull_rom(t - taps.k, taps.w);
    return taps;
}

double cubic_table(const double* table, int points, double x) {
    const CubicTaps c = cubic_taps(points, x);
    const double* v = table + c.k;
    return c.w[0] * v[0] + c.w[1] * v[1] + c.w[2] * v[2] + c.w[3] * v[3];
}

// cubic_table for a table of RGB triples, or of single values (channels 1: the value in all three).
Rgb cubic_rgb_table(const double* table, int points, int channels, double x) {
    const CubicTaps c = cubic_taps(points, x);
    const double* v = table + channels * static_cast<std::size_t>(c.k);
    Rgb out{};
    for (int ch = 0; ch < channels; ++ch)
        out[ch] = c.w[0] * v[ch] + c.w[1] * v[channels + ch] + c.w[2] * v[2 * channels + ch] +
                  c.w[3] * v[3 * channels + ch];
    if (channels == 1) out[1] = out[2] = out[0];
    return out;
}

// One single-scattering term's path for a direction pair: what multiplies its phase table, the
// factor A(mu_o) A(mu_i) / (n^2 pi (u_o + u_i)) times the slab's (1 - exp(-tau (1/u_o + 1/u_i))),
// and where the table is read, x = (u + 1) / 2. Snell: sin(theta inside) = sin(theta in air) / n,
// so only the cosines inside need a square root.
struct TermPath {
    double value;
    double x;
};

TermPath term_path(double n, double tau, const double* transmission, int kf, double mu_i,
                   double sin_i, double mu_o, double sin_o, double cos_phi) {
    const double inv_n2 = 1.0 / (n * n);
    const double ui = std::sqrt(1.0 - sin_i * sin_i * inv_n2),
                 uo = std::sqrt(1.0 - sin_o * sin_o * inv_n2);
    const double cos_scatter = std::clamp(-uo * ui - sin_o * sin_i * inv_n2 * cos_phi, -1.0, 1.0);
    // tab(mu) = A(mu) / (n sqrt(pi)): the term's factor A(mu_o) A(mu_i) / (n^2 pi).
    const double factor = cubic_table(transmission, kf, mu_o) * cubic_table(transmission, kf, mu_i);
    const double slab = std::isinf(tau) ? 1.0 : -std::expm1(-tau * (1.0 / uo + 1.0 / ui));
    const double u = std::sqrt(0.5 * (1.0 - cos_scatter)) - std::sqrt(0.5 * (1.0 + cos_scatter));
    return {factor / (uo + ui) * slab, 0.5 * (u + 1.0)};
}

// Single scattering with the full phase function, per term (its own refraction), added to `out`.
void add_single_scattering(const FillInputs& in, double mu_i, double mu_o, double cos_phi, Rgb& out) {
    const double sin_i = std::sqrt(std::max(0.0, 1.0 - mu_i * mu_i));
    const double sin_o = std::sqrt(std::max(0.0, 1.0 - mu_o * mu_o));
    const int kp = in.phase_points, kf = in.fresnel_points;
    for (int s = 0; s < in.samples; ++s) {
        const TermPath path = term_path(in.refractive_index[s], in.tau[s],
                                        &in.transmission[static_cast<std::size_t>(s) * kf], kf,
                                        mu_i, sin_i, mu_o, sin_o, cos_phi);
        const double* table = &in.phase[static_cast<std::size_t>(s) * kp * in.channels];
        const Rgb phase = cubic_rgb_table(table, kp, in.channels, path.x);
        for (int c = 0; c < 3; ++c) out[c] += path.value * phase[c];
    }
}

// The ghost points of a table for cubic_table, extrapolated quadratically from the first and last
// three points inside [0, 1].
void extrapolate_ghosts(std::vector<double>& table) {
    const std::size_t n = table.size();
    table[0] = 3.0 * table[1] - 3.0 * table[2] + table[3];
    table[n - 1] = 3.0 * table[n - 2] - 3.0 * table[n - 3] + table[n - 4];
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
// wi.h it needs, for the graphics azimuth phi given by its cosine (the geometry of
// rte/rough_interface.cpp: with omc = 1 + cos(phi),
// tan^2(theta_h) = ((s_i - s_o)^2 + 2 s_i s_o omc) / (mu_i + mu_o)^2 and
// wi.wo = mu_i mu_o - s_i s_o + s_i s_o omc).
struct LobeGeometry {
    double cos_d = 0.0;
    double value = 0.0;
};

LobeGeometry lobe_geometry(const FillInputs& in, double mu_i, double mu_o, double cos_phi) {
    const double s_i = std::sqrt(std::max(0.0, (1.0 - mu_i) * (1.0 + mu_i)));
    const double s_o = std::sqrt(std::max(0.0, (1.0 - mu_o) * (1.0 + mu_o)));
    const double omc = 1.0 + cos_phi;
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

// One single-scattering term before the wavelengths share them: the layer's refraction, its path
// factor and its phase table without colour, and the colour weight.
struct SingleScatteringTerm {
    double index = 1.0;
    double tau = 0.0;
    bool top_layer = false;
    Rgb weight{};
    std::vector<double> phase;        // phase_table_points values
    std::vector<double> transmission; // fresnel_table_points values
};

// A term of the fill: the refraction and path factor of `geometry`, and the phase table
// sum_k weight_k phase_k over `sources` (RGB).
struct TermRecipe {
    const SingleScatteringTerm* geometry = nullptr;
    std::vector<std::pair<const SingleScatteringTerm*, Rgb>> sources;
};

// Sets the single-scattering terms of `in` to `recipes`, their phase tables one per core.
void set_terms(FillInputs& in, const std::vector<TermRecipe>& recipes) {
    const int channels = in.channels;
    const std::size_t block = channels * static_cast<std::size_t>(phase_table_points);
    in.samples = static_cast<int>(recipes.size());
    in.phase_points = phase_table_points;
    in.fresnel_points = fresnel_table_points;
    in.phase.assign(recipes.size() * block, 0.0);
    in.refractive_index.clear();
    in.tau.clear();
    in.transmission.clear();
    for (const TermRecipe& r : recipes) {
        in.refractive_index.push_back(r.geometry->index);
        in.tau.push_back(r.geometry->tau);
        in.transmission.insert(in.transmission.end(), r.geometry->transmission.begin(),
                               r.geometry->transmission.end());
    }
    parallel_for(static_cast<int>(recipes.size()), available_cpus(), [&](int j) {
        double* phase = &in.phase[static_cast<std::size_t>(j) * block];
        for (const auto& [source, weight] : recipes[static_cast<std::size_t>(j)].sources)
            for (int p = 0; p < phase_table_points; ++p)
                for (int c = 0; c < channels; ++c)
                    phase[channels * static_cast<std::size_t>(p) + c] +=
                        weight[c] * source->phase[p];
    });
}

// The probe set that decides whether shared terms may stand in for the per-sample ones: 0 to 89.7
// degrees in both zenith angles, 0 to 180 in azimuth, with the per-sample sum there and its scale,
// the same sum with absolute colour weights (the size of what the terms add up to, whatever their
// signs). Each term's path at each probe is kept: a node set is judged from the terms' own phase
// tables, without building its own.
struct Probe {
    double mu_i, sin_i, mu_o, sin_o, cos_phi;
    Rgb exact, scale;
    std::vector<TermPath> paths; // [term]
};

TermPath probe_path(const SingleScatteringTerm& t, const Probe& p) {
    return term_path(t.index, t.tau, t.transmission.data(), fresnel_table_points, p.mu_i, p.sin_i,
                     p.mu_o, p.sin_o, p.cos_phi);
}

std::vector<Probe> probe_set(const std::vector<SingleScatteringTerm>& terms) {
    constexpr double degrees[] = {0.0, 20.0, 40.0, 55.0, 65.0, 75.0, 82.0, 86.0, 88.5, 89.7};
    std::vector<Probe> out;
    for (double ti : degrees)
        for (double to : degrees)
            for (int k = 0; k <= 4; ++k) {
                const double mu_i = std::cos(ti * std::numbers::pi / 180.0),
                             mu_o = std::cos(to * std::numbers::pi / 180.0);
                Probe p{mu_i,
                        std::sqrt(std::max(0.0, 1.0 - mu_i * mu_i)),
                        mu_o,
                        std::sqrt(std::max(0.0, 1.0 - mu_o * mu_o)),
                        std::cos(k * std::numbers::pi / 4.0),
                        {},
                        {},
                        {}};
                for (const SingleScatteringTerm& t : terms) {
                    const TermPath path = probe_path(t, p);
                    const double v =
                        path.value * cubic_table(t.phase.data(), phase_table_points, path.x);
                    for (int c = 0; c < 3; ++c) {
                        p.exact[c] += t.weight[c] * v;
                        p.scale[c] += std::abs(t.weight[c]) * v;
                    }
                    p.paths.push_back(path);
                }
                out.push_back(std::move(p));
            }
    return out;
}

// Largest error on the probe set, per channel relative to its scale, of the shared terms at the
// terms `node` with phase tables sum_s weights[j][s] phase_s.
double probe_error(const std::vector<Probe>& probes, const std::vector<SingleScatteringTerm>& terms,
                   const std::vector<std::size_t>& node,
                   const std::vector<std::vector<Rgb>>& weights) {
    double worst = 0.0;
    for (const Probe& p : probes) {
        Rgb a{};
        for (std::size_t j = 0; j < node.size(); ++j) {
            const TermPath& path = p.paths[node[j]];
            for (std::size_t s = 0; s < terms.size(); ++s) {
                const double v =
                    path.value * cubic_table(terms[s].phase.data(), phase_table_points, path.x);
                for (int c = 0; c < 3; ++c) a[c] += weights[j][s][c] * v;
            }
        }
        for (int c = 0; c < 3; ++c)
            if (p.scale[c] > 0.0) worst = std::max(worst, std::abs(a[c] - p.exact[c]) / p.scale[c]);
    }
    return worst;
}

// The single-scattering terms of the fill, shared by the wavelengths where that is exact to 1 % of
// the tolerance. For a half-space each wavelength's term is f_s(n_s), f_s(n) = t(mu_o; n) t(mu_i; n)
// P_s(Theta(n)) / (u_o(n) + u_i(n)): it depends on the wavelength through the phase table and,
// smoothly, through the binder index n_s (the path factor of the top layer is the Fresnel
// transmission at n). Lagrange interpolation in n on nodes n_j of the material's index range, each
// a sample's own index, gives sum_s w_s f_s(n_s) ~= sum_j t t / (u_o + u_i) at n_j times
// Q_j(Theta(n_j)), Q_j = sum_s w_s L_j(n_s) P_s: J terms per cell instead of S (PMMA across the
// visible: 4 instead of 41). Nodes near the Chebyshev-Lobatto points, J = 3, 4, 5, ... until a
// probe set agrees (the odd counts alone gave PMMA 5; a term is ~7 % of the seed's fill); a
// material whose indices all agree gets one exact term; anything else (thin films, several
// layers) keeps one term per sample. An opaque film's top layer counts as a half-space
// (assemble_fill: its slab factor is 1 to within 1 % of the tolerance).
void share_single_scattering(const std::vector<SingleScatteringTerm>& terms, double tolerance, FillInputs& in) {
    const std::size_t count = terms.size();
    const bool half_space = std::all_of(terms.begin(), terms.end(),
                                        [](const SingleScatteringTerm& t) { return t.top_layer && std::isinf(t.tau); });
    const auto keep_per_sample = [&] {
        std::vector<TermRecipe> recipes;
        for (const SingleScatteringTerm& t : terms) recipes.push_back({&t, {{&t, t.weight}}});
        set_terms(in, recipes);
    };
    if (count < 2 || !half_space) return keep_per_sample();
    const auto [lo_it, hi_it] = std::minmax_element(terms.begin(), terms.end(), [](const auto& a, const auto& b) {
        return a.index < b.index;
    });
    const double lo = lo_it->index, hi = hi_it->index;
    if (hi - lo <= 1e-12 * hi) { // one refraction for all: one term, exact
        TermRecipe one{&*lo_it, {}};
        for (const SingleScatteringTerm& t : terms) one.sources.emplace_back(&t, t.weight);
        return set_terms(in, {one});
    }
    const std::vector<Probe> probes = probe_set(terms);
    std::size_t tried = 0; // the node count of the last set tried
    for (int nodes = 3; 2 * static_cast<std::size_t>(nodes) <= count; ++nodes) {
        // The sample nearest each Chebyshev-Lobatto point; a point whose nearest sample is already
        // a node adds none. Dispersion crowds the samples' indices at the red end, where several
        // points can share a sample once there are more than a few (silica's 41 visible samples
        // under PMMA needed 11 nodes and found 10): the probe set judges the nodes found.
        std::vector<std::size_t> node;
        std::vector<double> node_index;
        for (double x : chebyshev_lobatto(nodes, lo, hi)) {
            std::size_t best = 0;
            for (std::size_t s = 1; s < count; ++s)
                if (std::abs(terms[s].index - x) < std::abs(terms[best].index - x)) best = s;
            if (!node_index.empty() && !(terms[best].index > node_index.back())) continue; // not distinct
            node.push_back(best);
            node_index.push_back(terms[best].index);
        }
        if (node.size() <= tried) continue; // no more nodes than the set before
        tried = node.size();
        // weights[j][s]: sample s's colour weight times L_j(n_s).
        std::vector<std::vector<Rgb>> weights(node.size());
        for (const SingleScatteringTerm& t : terms) {
            const std::vector<double> l = lagrange_weights(node_index, t.index);
            for (std::size_t j = 0; j < node.size(); ++j)
                weights[j].push_back(Rgb{l[j] * t.weight[0], l[j] * t.weight[1], l[j] * t.weight[2]});
        }
        const double error = probe_error(probes, terms, node, weights);
        if (error <= 0.01 * tolerance) {
            log::debug("table fill: single scattering of ", count, " samples on ", node.size(), " index nodes (",
                      error, " relative on the probe set)");
            std::vector<TermRecipe> recipes(node.size());
            for (std::size_t j = 0; j < node.size(); ++j) {
                recipes[j].geometry = &terms[node[j]];
                for (std::size_t s = 0; s < count; ++s)
                    recipes[j].sources.emplace_back(&terms[s], weights[j][s]);
            }
            return set_terms(in, recipes);
        }
    }
    keep_per_sample();
}

// dst[i] += weight * (factor * src[i]) for i < n: a colour grid's row of one order and channel
// (assemble_fill), in the vector lanes of the clone picked at run time (each entry's own
// operations, the same bits in every clone).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void add_weighted_row(double* __restrict dst, const double* __restrict src, int n, double factor, double weight) {
    for (int i = 0; i < n; ++i) dst[i] += weight * (factor * src[i]);
}

// The fill inputs of the samples `which` with colour weights `weights` (one per entry of `which`)
// and the single scattering of `singles`.
FillInputs assemble_fill(const SolvedMaterial& material, const std::vector<std::size_t>& which,
                         const std::vector<Rgb>& weights, const std::vector<SingleScatteringSource>& singles,
                         int zenith_grid = 0) {
    FillInputs in;
    const int e = zenith_grid > 0 ? std::min(zenith_grid, material.settings.table_grid) : material.settings.table_grid;
    in.grid = e;
    for (std::size_t k : which) in.orders = std::max(in.orders, material.samples[k].reflection.orders());
    const int mp = padded_orders(in.orders);
    // A grey material (every colour weight the same in all channels) is filled in one channel.
    const auto is_grey = [](const Rgb& w) { return w[0] == w[1] && w[1] == w[2]; };
    const bool grey = std::all_of(weights.begin(), weights.end(), is_grey) &&
                      std::all_of(singles.begin(), singles.end(), [&](const SingleScatteringSource& t) { return is_grey(t.weight); });
    in.channels = grey ? 1 : 3;
    const int channels = in.channels;
    in.fourier.assign(static_cast<std::size_t>(mp) * channels * e * e, 0.0);
    // The orders in colour from each sample's Nystrom grid at the table's zenith angles (the
    // expensive part of the fill's preparation), a few samples at a time: a grid holds E^2 M
    // doubles, 14 MB at "reference", where keeping all 41 of the visible held 590 MB. The samples
    // are summed in order, whatever the thread count.
    std::vector<double> mu(static_cast<std::size_t>(e));
    for (int a = 0; a < e; ++a) mu[a] = zenith_grid_cosine(a, e);
    const int cpus = available_cpus();
    const std::size_t chunk = 2 * static_cast<std::size_t>(cpus);
    for (std::size_t first = 0; first < which.size(); first += chunk) {
        const std::size_t count = std::min(chunk, which.size() - first);
        std::vector<rte::OrderGrid> grids(count);
        const int inner = std::max(1, cpus / static_cast<int>(count)); // few samples: their orders in parallel
        parallel_for(static_cast<int>(count), cpus,
                     [&](int k) { grids[k] = material.samples[which[first + k]].reflection.order_grid(mu, inner); });
        // One zenith row o of the colour grid per task, summed as rows along the nodes i (a grid's
        // row of one order is contiguous along them): entry (o, m, c, i) of the colour grid
        // gathers sample k's order m at (o, i) times its weight in channel c, a whole row of i at
        // once in vector lanes (add_weighted_row). Each entry is summed over the samples in order,
        // as the fill's layout, node after node with its orders and channels side by side, was
        // summed in place before: the same bits, where that had been a third of the grids' time.
        parallel_for(e, cpus, [&](int o) {
            double* row = &in.fourier[static_cast<std::size_t>(o) * e * mp * channels];
            for (std::size_t k = 0; k < count; ++k) {
                const rte::OrderGrid& g = grids[k];
                const Rgb& weight = weights[first + k];
                for (int m = 0; m < static_cast<int>(g.orders.size()); ++m) {
                    const double factor = (m == 0 ? 1.0 : 2.0) * (m % 2 == 0 ? 1.0 : -1.0) * std::numbers::inv_pi;
                    const double* orders = g.orders[m].row(o).data();
                    for (int c = 0; c < channels; ++c)
                        add_weighted_row(row + (static_cast<std::size_t>(m) * channels + c) * e, orders, e, factor,
                                         weight[c]);
                }
            }
        });
    }
    // Each row (o) from (m, c, i) to the fill's (i, m, c): within its own stretch of the grid.
    parallel_for(e, cpus, [&](int o) {
        double* row = &in.fourier[static_cast<std::size_t>(o) * e * mp * channels];
        const std::vector<double> by_order(row, row + static_cast<std::size_t>(e) * mp * channels);
        for (int m = 0; m < mp; ++m)
            for (int c = 0; c < channels; ++c) {
                const double* from = &by_order[(static_cast<std::size_t>(m) * channels + c) * e];
                for (int i = 0; i < e; ++i) row[(static_cast<std::size_t>(i) * mp + m) * channels + c] = from[i];
            }
    });
    // Each node's orders: the solve's cut, a tenth of the order tolerance, taken node by node and
    // summed over the orders a node leaves out (where the solve keeps every order, so does the fill).
    if (material.settings.fit_orders) in.node_blocks = node_order_blocks(in, 0.1 * material.settings.order_tolerance);
    // The single-scattering terms of every sample and layer (none under a rough surface: no TMS).
    // A reflection seen from air scatters inside a layer of index n > 1 through cos Theta <= 2 / n^2
    // - 1 at most (both directions at the critical angle, opposite azimuths; add_single_scattering
    // and the kernel refract with the term's index): table points below u_min = (sqrt(n^2 - 1) - 1) /
    // n are never read, for the lowest index of any term (the shared terms' index nodes are terms'
    // indices). They stay 0 and are not summed: half the table under a binder of 1.5, where each
    // point sums thousands of Legendre terms for big spheres.
    double lowest_index = std::numeric_limits<double>::infinity();
    for (const SingleScatteringSource& t : singles)
        for (int layer = 0; layer < static_cast<int>(t.setup->layers.size()); ++layer)
            lowest_index = std::min(lowest_index, rte::scattering_layer(*t.setup, layer).index);
    int first_phase_point = 0; // the cubic's taps reach one point below the interval; one more for rounding
    if (lowest_index > 1.0 && std::isfinite(lowest_index)) {
        const double u_min = (std::sqrt(lowest_index * lowest_index - 1.0) - 1.0) / lowest_index;
        first_phase_point = std::max(0, static_cast<int>(std::floor(0.5 * (u_min + 1.0) * phase_table_intervals)) - 2);
    }
    std::vector<double> cos_theta; // the table's points from first_phase_point on, the same for every term
    for (int p = first_phase_point; p < phase_table_points; ++p) { // u_p = 2 (p - 1) / intervals - 1
        const double u = 2.0 * (p - 1) / phase_table_intervals - 1.0;
        cos_theta.push_back(-u * std::sqrt(2.0 - u * u));
    }
    // A layer's single scattering carries the slab factor 1 - exp(-tau (1/u_o + 1/u_i)), which
    // differs from 1 by exp(-2 tau) at most (u <= 1). Where that is below 1 % of the tolerance the
    // layer scatters once as a half-space does: its term takes tau infinite, so the fill skips the
    // exponential per cell and, for a film's top layer, the wavelengths share their terms on index
    // nodes (share_single_scattering) as a half-space's do. A 25 um rutile film (tau 11-14) at
    // "default": 1.3e-10 at most.
    const double opaque_tau = 0.5 * std::log(100.0 / material.settings.tolerance);
    std::vector<std::vector<SingleScatteringTerm>> per_sample(singles.size());
    parallel_for(static_cast<int>(singles.size()), available_cpus(), [&](int j) {
        const rte::StackSetup& setup = *singles[j].setup;
        if (setup.stack.top == rte::Top::Rough) return;
        const double inv_sqrt_pi = 1.0 / std::sqrt(std::numbers::pi);
        for (int layer = 0; layer < static_cast<int>(setup.layers.size()); ++layer) {
            const rte::ScatteringLayer l = rte::scattering_layer(setup, layer);
            const double tau = l.tau >= opaque_tau ? std::numeric_limits<double>::infinity() : l.tau;
            SingleScatteringTerm t{l.index, tau, layer == 0, singles[j].weight, {}, {}};
            t.phase.assign(phase_table_points, 0.0);
            // all points at once: thousands of degrees for big spheres
            rte::phase_values(*l.beta, cos_theta, std::span<double>(t.phase).subspan(first_phase_point));
            for (double& v : t.phase) v *= 0.25 * l.albedo;
            t.transmission.resize(fresnel_table_points);
            for (int p = 1; p + 1 < fresnel_table_points; ++p) // mu_p = (p - 1) / intervals
                t.transmission[p] =
                    rte::path_factor(setup, layer, static_cast<double>(p - 1) / fresnel_table_intervals) *
                    inv_sqrt_pi;
            extrapolate_ghosts(t.transmission);
            per_sample[j].push_back(std::move(t));
        }
    });
    std::vector<SingleScatteringTerm> terms;
    for (auto& sample_terms : per_sample)
        for (SingleScatteringTerm& t : sample_terms) terms.push_back(std::move(t));
    share_single_scattering(terms, material.settings.tolerance, in);
    prepare_lobe(material, which, weights, in);
    return in;
}

} // namespace

std::vector<int> node_order_blocks(const FillInputs& in, double cut) {
    const int e = in.grid, mp = padded_orders(in.orders), channels = in.channels;
    const std::size_t nodes = static_cast<std::size_t>(e) * e;
    std::vector<int> blocks(nodes, mp / fill_order_block);
    if (in.orders == 0 || in.fourier.size() != nodes * mp * channels) return blocks;
    double largest[3] = {0.0, 0.0, 0.0};
    for (std::size_t node = 0; node < nodes; ++node)
        for (int c = 0; c < channels; ++c)
            largest[c] = std::max(largest[c], std::abs(in.fourier[node * mp * channels + c]));
    parallel_for(e, available_cpus(), [&](int o) {
        for (int i = 0; i < e; ++i) {
            const std::size_t node = static_cast<std::size_t>(o) * e + i;
            const double* f = &in.fourier[node * mp * channels];
            double scale[3];
            for (int c = 0; c < channels; ++c) scale[c] = std::max(std::abs(f[c]), 1e-2 * largest[c]);
            // The orders from the top down while what they add up to stays within the cut.
            int needed = in.orders;
            double left_out = 0.0;
            for (int m = in.orders - 1; m >= 1; --m) {
                double term = 0.0; // relative to R^0, the largest of the channels
                for (int c = 0; c < channels; ++c) {
                    const double v = std::abs(f[m * channels + c]);
                    if (v > 0.0) term = std::max(term, v / scale[c]);
                }
                if (!(left_out + term <= cut)) break;
                left_out += term;
                needed = m;
            }
            blocks[node] = (needed + fill_order_block - 1) / fill_order_block;
        }
    });
    return blocks;
}

FillInputs prepare_fill(const SolvedMaterial& material, int zenith_grid) {
    std::vector<std::size_t> all(material.samples.size());
    std::vector<Rgb> weights;
    for (std::size_t k = 0; k < all.size(); ++k) {
        all[k] = k;
        weights.push_back(material.samples[k].weight);
    }
    return assemble_fill(material, all, weights, material.single_scattering_sources(), zenith_grid);
}

void for_each_spectral_fill(const SolvedMaterial& material, const std::function<void(const SpectralFill&)>& fill) {
    for (std::size_t first = 0; first < material.samples.size(); first += 3) {
        SpectralFill group;
        std::vector<std::size_t> which;
        std::vector<Rgb> weights;
        std::vector<SingleScatteringSource> singles;
        for (int c = 0; c < 3 && first + c < material.samples.size(); ++c) {
            which.push_back(first + c);
            Rgb one_hot{0.0, 0.0, 0.0};
            one_hot[c] = 1.0;
            weights.push_back(one_hot);
            singles.push_back({&material.samples[first + c].reflection.setup(), one_hot});
            group.sample[c] = static_cast<int>(first + c);
        }
        group.inputs = assemble_fill(material, which, weights, singles);
        fill(group);
    }
}

namespace {

// What a cell's value needs of its two directions: the cosines of the zenith angles (the grid's
// stencils, the single scattering, the lobe) and of the azimuth between them (cos(m phi) by
// recurrence; nothing else needs phi).
struct CellDirections {
    double mu_i, mu_o, cos_phi;
};

Rgb cell_value(const FillInputs& in, const CellDirections& d) {
    Rgb out{0.0, 0.0, 0.0};
    const double mu_i = d.mu_i, mu_o = d.mu_o;
    if (mu_i <= 0.0 || mu_o <= 0.0) return out;
    const int e = in.grid;
    // Multiply scattered part: interpolate each order, then sum cos(m phi) by the Chebyshev recurrence.
    const double c1 = d.cos_phi;
    double cm_prev = c1, cm = 1.0; // cos(-phi) = cos(phi), cos(0)
    const int mp = padded_orders(in.orders);
    Stencil so{}, si{};
    if (in.orders > 0) so = stencil(mu_o, e), si = stencil(mu_i, e);
    const int blocks = cell_blocks(in, so, si);
    const auto orders = [&]<int C> { // C channels per order
        constexpr int block = C * fill_order_block;
        for (int m0 = 0; m0 < in.orders; m0 += fill_order_block) {
            // acc: every tap as its node; mirrored: the taps mirrored through the normal in one
            // direction only, whose odd orders (j odd: m0 is even) count with the opposite sign.
            // A block the cell does not need adds 0.
            double acc[block] = {}, mirrored[block] = {};
            const bool needed = m0 < blocks * fill_order_block;
            for (int a = 0; needed && a < 4; ++a)
                for (int b = 0; b < 4; ++b) {
                    const double w = so.w[a] * si.w[b];
                    const double* f =
                        &in.fourier[((static_cast<std::size_t>(so.idx[a]) * e + si.idx[b]) * mp + m0) * C];
                    for (int k = 0; k < block; ++k) acc[k] += w * f[k];
                    if (so.ghost[a] != si.ghost[b])
                        for (int k = 0; k < block; ++k) mirrored[k] += w * f[k];
                }
            for (int j = 0; j < fill_order_block; ++j) {
                for (int c = 0; c < C; ++c) {
                    const double v = j % 2 == 1 ? acc[C * j + c] - 2.0 * mirrored[C * j + c] : acc[C * j + c];
                    out[c] += v * cm;
                }
                const double next = 2.0 * c1 * cm - cm_prev;
                cm_prev = cm;
                cm = next;
            }
        }
    };
    if (in.channels == 1) {
        orders.template operator()<1>();
        out[1] = out[2] = out[0];
    } else {
        orders.template operator()<3>();
    }
    add_single_scattering(in, mu_i, mu_o, c1, out);
    for (double& v : out) v = std::max(0.0, v);
    if (in.lobe != FillInputs::Lobe::None) {
        const LobeGeometry g = lobe_geometry(in, mu_i, mu_o, c1);
        for (int c = 0; c < 3; ++c)
            out[c] = std::max(0.0, out[c] + g.value * cubic_table(&in.lobe_fresnel[static_cast<std::size_t>(c) * in.lobe_points],
                                                                  in.lobe_points, g.cos_d));
    }
    return out;
}

// The cosines of a cell's bin-centre directions: of the zenith angles (clamped to [-1, 1]) and of
// the azimuth between them, from the directions' horizontal components (1 where one is vertical),
// instead of the angles' trigonometry (kernels/table_fill.cl computes the same).
CellDirections cell_directions(const formats::Vec3& wi, const formats::Vec3& wo) {
    const double mu_i = std::clamp(wi.z, -1.0, 1.0), mu_o = std::clamp(wo.z, -1.0, 1.0);
    const double horizontal = std::sqrt((wi.x * wi.x + wi.y * wi.y) * (wo.x * wo.x + wo.y * wo.y));
    const double cos_phi = horizontal > 0.0 ? std::clamp((wi.x * wo.x + wi.y * wo.y) / horizontal, -1.0, 1.0) : 1.0;
    return {mu_i, mu_o, cos_phi};
}

} // namespace

Rgb fill_value(const FillInputs& in, double theta_i, double theta_o, double phi) {
    return cell_value(in, {std::cos(theta_i), std::cos(theta_o), std::cos(phi)});
}

Rgb fill_value_from_cosines(const FillInputs& in, double mu_i, double mu_o, double cos_phi) {
    return cell_value(in, {mu_i, mu_o, cos_phi});
}

formats::BrdfTable fill_table_reference(const FillInputs& in, int threads) {
    // Every cell is written below; a grey fill (one channel) makes a grey table.
    formats::BrdfTable table(formats::BrdfTable::Unwritten{}, in.channels == 1);
    // Half the cells, each copied to its mirror phi_d -> pi - phi_d (bin k -> 179 - k): reflecting
    // both directions through the plane of the normal and the half vector maps phi_d to -phi_d, and
    // reciprocity (swapping them) adds pi; an isotropic, reciprocal BRDF is unchanged by both, and
    // so is whether a cell lies below the horizon. What the fill evaluates (the Fourier series in
    // cos m phi, the single scattering, the microfacet lobe) is exactly that; the values computed
    // at the mirrored directions differ by rounding alone, at most 3.2e-9 relative where a gloss
    // lobe peaks at grazing (PipelineTable.MirroredHalfEqualsTheDirectFill).
    // Rows of 180 cells (one theta_h, theta_d pair) per work item: the same split as the kernel's.
    constexpr std::size_t bins = formats::phi_d_bins;
    static_assert(bins % 2 == 0);
    const int rows = static_cast<int>(table.channels[0].size() / bins);
    parallel_for(rows, threads, [&](int row) {
        const std::size_t first = static_cast<std::size_t>(row) * bins;
        for (std::size_t k = 0; k < bins / 2; ++k) {
            const std::size_t cell = first + k;
            if (formats::cell_below_horizon(cell)) {
                table.set_no_data(cell);
                table.set_no_data(first + bins - 1 - k);
                continue;
            }
            const formats::CellIndices ix = formats::cell_indices(cell);
            const formats::DirectionPair d = formats::to_directions(
                formats::theta_h_centre(ix.theta_h), formats::theta_d_centre(ix.theta_d), formats::phi_d_centre(ix.phi_d));
            const Rgb v = cell_value(in, cell_directions(d.wi, d.wo));
            table.set(cell, v);
            table.set(first + bins - 1 - k, v);
        }
    });
    return table;
}

namespace {

// ---- The fill in lanes: fill_table_cpu -------------------------------------------------------------
//
// cell_value for W cells at once, one in each lane of GCC's vector types, as the OpenCL kernel
// (kernels/table_fill.cl) computes them: the per-cell loop left the processor a few hundred
// dependent scalar operations per cell (the Chebyshev recurrence, the single scattering's square
// roots and divisions). The same formulas in the same order, and the same library calls lane by
// lane (acos, expm1, exp, erfc), so every value equals cell_value's bit for bit
// (TableFillLanes.EqualTheReferenceBitForBit). W is the width of the registers of the instruction
// set picked at run time (core/lane_set.h: 8, 4, 2 doubles for AVX-512, AVX2, SSE2): a vector
// wider than the registers GCC lowers through the stack, piece by piece (eight cells under AVX2
// took three times as long as PoCL's kernel on the same cores).

template <int W> struct CellLanes { // (an alias template would drop the attribute)
    typedef double vec __attribute__((vector_size(8 * W)));
};
template <int W> using Lanes = typename CellLanes<W>::vec;
static_assert(fill_order_block % 8 == 0, "a block of orders of one channel is whole vectors of every width");

template <int W> [[gnu::always_inline]] inline Lanes<W> splat(double v) { return Lanes<W>{} + v; }
// std::clamp(v, lo, hi) and std::max(0.0, v) per lane (NaN: v, and 0).
template <int W> [[gnu::always_inline]] inline Lanes<W> clamp_lanes(Lanes<W> v, double lo, double hi) {
    return v < lo ? splat<W>(lo) : (hi < v ? splat<W>(hi) : v);
}
template <int W> [[gnu::always_inline]] inline Lanes<W> max0_lanes(Lanes<W> v) {
    return 0.0 < v ? v : splat<W>(0.0);
}
template <int W, typename F> [[gnu::always_inline]] inline Lanes<W> per_lane(Lanes<W> v, F f) {
    Lanes<W> out;
    for (int l = 0; l < W; ++l) out[l] = f(v[l]);
    return out;
}
template <int W> [[gnu::always_inline]] inline Lanes<W> sqrt_lanes(Lanes<W> v) {
    return per_lane<W>(v, [](double x) { return std::sqrt(x); });
}

// cubic_table in every lane: each lane's taps read from the table where its x falls.
template <int W> [[gnu::always_inline]] inline void cubic_taps_lanes(int points, Lanes<W> x, int k[W], Lanes<W> w[4]) {
    const int intervals = points - 3;
    const Lanes<W> t = clamp_lanes<W>(x, 0.0, 1.0) * intervals;
    Lanes<W> f;
    for (int l = 0; l < W; ++l) {
        k[l] = std::min(static_cast<int>(t[l]), intervals - 1);
        f[l] = t[l] - k[l];
    }
    catmull_rom(f, w);
}

template <int W>
[[gnu::always_inline]] inline Lanes<W> tap_lanes(const double* table, const int k[W], int offset, int stride) {
    Lanes<W> v;
    for (int l = 0; l < W; ++l) v[l] = table[static_cast<std::size_t>(stride) * k[l] + offset];
    return v;
}

template <int W> [[gnu::always_inline]] inline Lanes<W> cubic_table_lanes(const double* table, int points, Lanes<W> x) {
    int k[W];
    Lanes<W> w[4];
    cubic_taps_lanes<W>(points, x, k, w);
    return w[0] * tap_lanes<W>(table, k, 0, 1) + w[1] * tap_lanes<W>(table, k, 1, 1) +
           w[2] * tap_lanes<W>(table, k, 2, 1) + w[3] * tap_lanes<W>(table, k, 3, 1);
}

// The cells of one group: their directions' cosines, and which lanes hold a cell above the horizon.
template <int W> struct LaneCells {
    Lanes<W> mu_i, mu_o, cos_phi;
    bool live[W];
};

// cell_value's multiply scattered part for the live lanes: each lane's taps summed along the orders
// of its grid nodes (contiguous, as cell_value sums them; a block's C x 8 values as C x 8 / W
// vectors), then the Fourier sum over a block's orders in all lanes at once.
template <int W, int C>
[[gnu::always_inline]] inline void add_orders_lanes(const FillInputs& in, const LaneCells<W>& g, Lanes<W> out[3]) {
    constexpr int block = C * fill_order_block, vectors = block / W;
    const int e = in.grid, mp = padded_orders(in.orders);
    struct Taps {
        const double* node[16];
        double w[16];
        bool mirrored[16];
        bool any_mirrored;
        int blocks; // cell_blocks
    } taps[W];
    for (int l = 0; l < W; ++l) {
        if (!g.live[l]) continue;
        const Stencil so = stencil(g.mu_o[l], e), si = stencil(g.mu_i[l], e);
        Taps& t = taps[l];
        t.any_mirrored = false;
        for (int a = 0; a < 4; ++a)
            for (int b = 0; b < 4; ++b) {
                t.node[4 * a + b] = &in.fourier[(static_cast<std::size_t>(so.idx[a]) * e + si.idx[b]) * mp * C];
                t.w[4 * a + b] = so.w[a] * si.w[b];
                t.mirrored[4 * a + b] = so.ghost[a] != si.ghost[b];
                t.any_mirrored = t.any_mirrored || t.mirrored[4 * a + b];
            }
        t.blocks = cell_blocks(in, so, si);
    }
    Lanes<W> cm_prev = g.cos_phi, cm = splat<W>(1.0); // cos(-phi) = cos(phi), cos(0)
    alignas(64) double terms[block][W];
    for (int m0 = 0; m0 < in.orders; m0 += fill_order_block) {
        for (int l = 0; l < W; ++l) {
            if (!g.live[l] || m0 >= taps[l].blocks * fill_order_block) {
                for (int k = 0; k < block; ++k) terms[k][l] = 0.0;
                continue;
            }
            // Element k = C j + c of the block: order m0 + j, channel c.
            const Taps& t = taps[l];
            Lanes<W> acc[vectors] = {}, mirrored[vectors] = {};
            for (int tap = 0; tap < 16; ++tap) {
                const double* f = t.node[tap] + static_cast<std::size_t>(m0) * C;
                for (int q = 0; q < vectors; ++q) {
                    Lanes<W> v;
                    std::memcpy(&v, f + W * q, sizeof v);
                    acc[q] += t.w[tap] * v;
                }
            }
            for (int tap = 0; t.any_mirrored && tap < 16; ++tap) {
                if (!t.mirrored[tap]) continue;
                const double* f = t.node[tap] + static_cast<std::size_t>(m0) * C;
                for (int q = 0; q < vectors; ++q) {
                    Lanes<W> v;
                    std::memcpy(&v, f + W * q, sizeof v);
                    mirrored[q] += t.w[tap] * v;
                }
            }
            for (int q = 0; q < vectors; ++q)
                for (int i = 0; i < W; ++i) {
                    const int k = W * q + i;
                    terms[k][l] = (k / C) % 2 == 1 ? acc[q][i] - 2.0 * mirrored[q][i] : acc[q][i];
                }
        }
        for (int j = 0; j < fill_order_block; ++j) {
            for (int c = 0; c < C; ++c) {
                Lanes<W> v;
                std::memcpy(&v, terms[C * j + c], sizeof v);
                out[c] += v * cm;
            }
            const Lanes<W> next = 2.0 * g.cos_phi * cm - cm_prev;
            cm_prev = cm;
            cm = next;
        }
    }
}

// add_single_scattering in lanes (term_path and cubic_rgb_table per term).
template <int W>
[[gnu::always_inline]] inline void add_single_scattering_lanes(const FillInputs& in, const LaneCells<W>& g,
                                                               Lanes<W> out[3]) {
    const Lanes<W> sin_i = sqrt_lanes<W>(max0_lanes<W>(1.0 - g.mu_i * g.mu_i));
    const Lanes<W> sin_o = sqrt_lanes<W>(max0_lanes<W>(1.0 - g.mu_o * g.mu_o));
    const int kp = in.phase_points, kf = in.fresnel_points, channels = in.channels;
    for (int s = 0; s < in.samples; ++s) {
        const double n = in.refractive_index[s], tau = in.tau[s];
        const double inv_n2 = 1.0 / (n * n);
        const Lanes<W> ui = sqrt_lanes<W>(1.0 - sin_i * sin_i * inv_n2);
        const Lanes<W> uo = sqrt_lanes<W>(1.0 - sin_o * sin_o * inv_n2);
        const Lanes<W> cos_scatter = clamp_lanes<W>(-uo * ui - sin_o * sin_i * inv_n2 * g.cos_phi, -1.0, 1.0);
        const double* transmission = &in.transmission[static_cast<std::size_t>(s) * kf];
        const Lanes<W> factor =
            cubic_table_lanes<W>(transmission, kf, g.mu_o) * cubic_table_lanes<W>(transmission, kf, g.mu_i);
        const Lanes<W> slab = std::isinf(tau)
                                  ? splat<W>(1.0)
                                  : per_lane<W>(-tau * (1.0 / uo + 1.0 / ui), [](double x) { return -std::expm1(x); });
        const Lanes<W> u = sqrt_lanes<W>(0.5 * (1.0 - cos_scatter)) - sqrt_lanes<W>(0.5 * (1.0 + cos_scatter));
        const Lanes<W> value = factor / (uo + ui) * slab;
        const Lanes<W> x = 0.5 * (u + 1.0);
        const double* table = &in.phase[static_cast<std::size_t>(s) * kp * channels];
        int k[W];
        Lanes<W> w[4];
        cubic_taps_lanes<W>(kp, x, k, w);
        Lanes<W> phase[3];
        for (int c = 0; c < channels; ++c)
            phase[c] = w[0] * tap_lanes<W>(table, k, c, channels) +
                       w[1] * tap_lanes<W>(table, k, channels + c, channels) +
                       w[2] * tap_lanes<W>(table, k, 2 * channels + c, channels) +
                       w[3] * tap_lanes<W>(table, k, 3 * channels + c, channels);
        if (channels == 1) phase[1] = phase[2] = phase[0];
        for (int c = 0; c < 3; ++c) out[c] += value * phase[c];
    }
}

// lobe_geometry in lanes, D G / (4 mu_i mu_o) times each channel's facet Fresnel factor, added.
template <int W>
[[gnu::always_inline]] inline void add_lobe_lanes(const FillInputs& in, const LaneCells<W>& g, Lanes<W> out[3]) {
    const Lanes<W> s_i = sqrt_lanes<W>(max0_lanes<W>((1.0 - g.mu_i) * (1.0 + g.mu_i)));
    const Lanes<W> s_o = sqrt_lanes<W>(max0_lanes<W>((1.0 - g.mu_o) * (1.0 + g.mu_o)));
    const Lanes<W> omc = 1.0 + g.cos_phi;
    const Lanes<W> sum = g.mu_i + g.mu_o;
    const Lanes<W> t2 = ((s_i - s_o) * (s_i - s_o) + 2.0 * s_i * s_o * omc) / (sum * sum);
    const double a2 = in.lobe_alpha * in.lobe_alpha;
    const Lanes<W> sec2 = 1.0 + t2;
    Lanes<W> d;
    if (in.lobe == FillInputs::Lobe::Ggx) {
        const Lanes<W> q = a2 + t2;
        d = a2 * sec2 * sec2 / (std::numbers::pi * q * q);
    } else {
        d = per_lane<W>(-t2 / a2, [](double x) { return std::exp(x); }) * sec2 * sec2 / (std::numbers::pi * a2);
    }
    Lanes<W> li{}, lo{};
    for (int l = 0; l < W; ++l) {
        li[l] = smith_lambda(in.lobe, in.lobe_alpha, g.mu_i[l], s_i[l]);
        lo[l] = smith_lambda(in.lobe, in.lobe_alpha, g.mu_o[l], s_o[l]);
    }
    const Lanes<W> shadowing = in.lobe_separable ? 1.0 / ((1.0 + li) * (1.0 + lo)) : 1.0 / (1.0 + li + lo);
    const Lanes<W> cos_d = sqrt_lanes<W>(max0_lanes<W>(0.5 * (1.0 + g.mu_i * g.mu_o - s_i * s_o + s_i * s_o * omc)));
    const Lanes<W> value = d * shadowing / (4.0 * g.mu_i * g.mu_o);
    for (int c = 0; c < 3; ++c)
        out[c] = max0_lanes<W>(
            out[c] + value * cubic_table_lanes<W>(&in.lobe_fresnel[static_cast<std::size_t>(c) * in.lobe_points],
                                                  in.lobe_points, cos_d));
}

// One row of the table (theta_h i, theta_d j): its first phi_d half in groups of W, each cell also
// written to its mirror (fill_table_reference says why they are equal).
template <int W>
[[gnu::always_inline]] inline void fill_row_lanes(const FillInputs& in, int row, const double* sin_phi,
                                                  const double* cos_phi, formats::BrdfTable& table) {
    constexpr int bins = formats::phi_d_bins;
    const int i = row / formats::theta_d_bins, j = row % formats::theta_d_bins;
    const double theta_h = formats::theta_h_centre(i), theta_d = formats::theta_d_centre(j);
    const double sh = std::sin(theta_h), ch = std::cos(theta_h), sd = std::sin(theta_d), cd = std::cos(theta_d);
    const std::uint8_t* below = formats::below_horizon_mask().data();
    const std::size_t first = static_cast<std::size_t>(row) * bins;
    for (int k0 = 0; k0 < bins / 2; k0 += W) {
        // formats::to_directions and cell_directions, per lane; lanes past the half repeat its last cell.
        Lanes<W> sp, cp;
        LaneCells<W> g;
        bool any = false;
        for (int l = 0; l < W; ++l) {
            const int k = std::min(k0 + l, bins / 2 - 1);
            sp[l] = sin_phi[k];
            cp[l] = cos_phi[k];
            g.live[l] = k0 + l < bins / 2 && below[first + k] == 0;
            any = any || g.live[l];
        }
        if (!any) {
            for (int l = 0; l < W && k0 + l < bins / 2; ++l) {
                table.set_no_data(first + k0 + l);
                table.set_no_data(first + bins - 1 - (k0 + l));
            }
            continue;
        }
        const Lanes<W> dx = sd * cp, dy = sd * sp, dz = splat<W>(cd);
        const Lanes<W> wix = dx * ch + dz * sh, wiy = dy, wiz = -dx * sh + dz * ch;
        const Lanes<W> mdx = -dx, mdy = -dy;
        const Lanes<W> wox = mdx * ch + dz * sh, woy = mdy, woz = -mdx * sh + dz * ch;
        g.mu_i = clamp_lanes<W>(wiz, -1.0, 1.0);
        g.mu_o = clamp_lanes<W>(woz, -1.0, 1.0);
        const Lanes<W> horizontal = sqrt_lanes<W>((wix * wix + wiy * wiy) * (wox * wox + woy * woy));
        g.cos_phi =
            horizontal > 0.0 ? clamp_lanes<W>((wix * wox + wiy * woy) / horizontal, -1.0, 1.0) : splat<W>(1.0);
        // cell_value: every live lane has mu_i, mu_o > 0 (above the horizon).
        Lanes<W> out[3] = {splat<W>(0.0), splat<W>(0.0), splat<W>(0.0)};
        if (in.orders > 0) {
            if (in.channels == 1) {
                add_orders_lanes<W, 1>(in, g, out);
                out[1] = out[2] = out[0];
            } else {
                add_orders_lanes<W, 3>(in, g, out);
            }
        }
        add_single_scattering_lanes<W>(in, g, out);
        for (Lanes<W>& v : out) v = max0_lanes<W>(v);
        if (in.lobe != FillInputs::Lobe::None) add_lobe_lanes<W>(in, g, out);
        for (int l = 0; l < W && k0 + l < bins / 2; ++l) {
            const std::size_t cell = first + k0 + l, mirror = first + bins - 1 - (k0 + l);
            const Rgb v = g.live[l] ? Rgb{out[0][l], out[1][l], out[2][l]}
                                    : Rgb{formats::BrdfTable::no_data, formats::BrdfTable::no_data,
                                          formats::BrdfTable::no_data};
            table.set(cell, v);
            table.set(mirror, v);
        }
    }
}

using FillRow = void (*)(const FillInputs&, int, const double*, const double*, formats::BrdfTable&);
void fill_row_baseline(const FillInputs& in, int row, const double* sin_phi, const double* cos_phi,
                       formats::BrdfTable& table) {
    fill_row_lanes<2>(in, row, sin_phi, cos_phi, table);
}
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target("avx2"))) void fill_row_avx2(const FillInputs& in, int row, const double* sin_phi,
                                                   const double* cos_phi, formats::BrdfTable& table) {
    fill_row_lanes<4>(in, row, sin_phi, cos_phi, table);
}
__attribute__((target("avx512f"))) void fill_row_avx512(const FillInputs& in, int row, const double* sin_phi,
                                                        const double* cos_phi, formats::BrdfTable& table) {
    fill_row_lanes<8>(in, row, sin_phi, cos_phi, table);
}
#endif
FillRow fill_row() {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
    switch (lane_set()) {
    case LaneSet::avx512: return fill_row_avx512;
    case LaneSet::avx2: return fill_row_avx2;
    case LaneSet::baseline: break;
    }
#endif
    return fill_row_baseline;
}

} // namespace

formats::BrdfTable fill_table_cpu(const FillInputs& in, int threads) {
    // Every cell is written below; a grey fill (one channel) makes a grey table.
    formats::BrdfTable table(formats::BrdfTable::Unwritten{}, in.channels == 1);
    std::array<double, formats::phi_d_bins> sin_phi{}, cos_phi{};
    for (int k = 0; k < formats::phi_d_bins; ++k) {
        sin_phi[k] = std::sin(formats::phi_d_centre(k));
        cos_phi[k] = std::cos(formats::phi_d_centre(k));
    }
    const int rows = formats::theta_h_bins * formats::theta_d_bins;
    const FillRow fill = fill_row();
    parallel_for(rows, threads, [&](int row) { fill(in, row, sin_phi.data(), cos_phi.data(), table); });
    return table;
}

} // namespace brdf::model
