#include <brdf/model/model.h>

#include <brdf/cl/context.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/progress.h>
#include <brdf/core/threads.h>
#include <brdf/material/colour.h>
#include <brdf/model/cl_table_fill.h>
#include <brdf/rte/cl_solver.h>

#include <chrono>
#include <exception>
#include <functional>
#include <future>
#include <iterator>
#include <tuple>
#include <numbers>
#include <optional>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>

namespace brdf::model {
namespace {

// What the pipeline computes so far: layer stacks under no, a smooth or a rough interface, in any
// of the colour spaces, into MERL, EXR and spectral EXR tables. The spec format already describes
// more (docs/spec.md); until that lands, such a spec is refused here, naming what is missing,
// instead of being computed as something else.
void check_supported(const material::MaterialSpec& spec) {
    const std::string who = spec.source.empty() ? spec.name : spec.source;
    const auto refuse = [&](const std::string& what) {
        throw InputError(cat(who, ": ", what, " not supported yet"));
    };
    if (spec.layers.empty()) refuse("a material without layers is");
    if (spec.model == material::Model::Dipole && (spec.layers.size() > 1 || !spec.layers[0].semi_infinite()))
        throw InputError(cat(who, ": \"model\": \"dipole\" is a semi-infinite comparison model; it has no films "
                                  "or stacks (remove \"model\" or the thickness)"));
}

// Whether the spec is solved per colour channel (every layer an analytic medium) rather than per
// wavelength of its spectrum.
bool analytic(const material::MaterialSpec& spec) {
    return std::all_of(spec.layers.begin(), spec.layers.end(), [](const material::LayerSpec& l) { return l.medium.has_value(); });
}

bool coloured(const std::array<double, 3>& a) { return a[0] != a[1] || a[1] != a[2]; }

// Whether each wavelength's direct single scattering is apart from its orders (Reflection::
// order_grid removes it there; table fills and SolvedMaterial::brdf add it from the optics): a
// spectral stack under no or a smooth top, evaluated by the exact model, whose layers share one
// index at every wavelength, as a half-space or over a grey (Lambertian) substrate. Every other
// once-scattered path then meets the substrate's diffuse reflection, which averages the phase
// function over angles as the multiple scattering does. Under a rough top the orders carry the
// single scattering (the rough refraction spreads it), and an index step between layers reflects
// a once-scattered ray specularly, keeping the phase function's ripple in what the orders hold.
// At one wavelength, from the spec alone (before its optics: what the Mie integration must check
// depends on it, mie_accuracy).
bool single_scattering_apart(const material::MaterialSpec& spec, double wavelength_nm) {
    if (analytic(spec) || spec.model != material::Model::Exact || spec.surface.kind == material::Surface::Rough)
        return false;
    if (spec.substrate && coloured(spec.substrate->albedo)) return false;
    double above = 1.0; // as make_stack: a layer given without an index takes the one above
    for (std::size_t k = 0; k < spec.layers.size(); ++k) {
        const material::LayerSpec& l = spec.layers[k];
        const double index = l.binder ? l.binder->index.model.at(wavelength_nm).n : l.medium->index.value_or(above);
        if (k > 0 && index != above) return false;
        above = index;
    }
    return true;
}

bool single_scattering_apart(const material::MaterialSpec& spec, const std::vector<SpectralOptics>& optics) {
    return !optics.empty() && std::all_of(optics.begin(), optics.end(), [&](const SpectralOptics& o) {
        return single_scattering_apart(spec, o.wavelength_nm);
    });
}

// What the tables read of a wavelength's Mie phase functions, so that the nested radius rule checks
// that and no more (mie::EnsembleOptions::checked_moments; docs/mie.md, "What the nested rule
// checks"). Where the single scattering is apart, the solver reads the moments up to twice its
// streams (delta-M: rte::delta_m at the split rule's exact degree + 1 <= 2 N), at most the cap, and
// the exact single scattering each layer's phase function at the scattering angles a smooth top
// lets in (both directions refracted into its cone, one index through the stack: Theta >= pi - 2
// theta_c, cos = 2 / n^2 - 1; every angle without an interface), to 0.3 tol absolute (p of mean
// 1). Those values are what the radius rule resolves worst (its step aliases each sphere's angular
// ripple: 20-50 % of the backward p, before as now) and the tables feel them least (the single
// scattering is ~2e-4 of a matting agent's BRDF there); measured against the tables of a four to
// eight times finer Mie integration, the matting agents' tables err by 2.3e-5 (5 um; 2.9e-5 with
// every moment checked) and 9e-6 (40 um; 2e-6), in half the radius nodes at 40 um. Elsewhere the
// wavelength selection compares the phase functions' values at all angles (select_wavelengths):
// every moment is checked, as before.
mie::EnsembleOptions mie_accuracy(const material::MaterialSpec& spec, const NumericalSettings& st,
                                  double wavelength_nm) {
    mie::EnsembleOptions out;
    out.tolerance = st.mie_tolerance;
    if (!single_scattering_apart(spec, wavelength_nm)) return out;
    out.checked_moments = 2 * st.max_streams + 1;
    out.value_tolerance = 0.3 * st.tolerance;
    const material::LayerSpec& top = spec.layers.front();
    const double n = top.binder ? top.binder->index.model.at(wavelength_nm).n : top.medium->index.value_or(1.0);
    out.checked_cosine = spec.surface.kind == material::Surface::Smooth && n > 1.0 ? 2.0 / (n * n) - 1.0 : 1.0;
    return out;
}

// The terms of SolvedMaterial::single_scattering_correction, in order: each solved sample's set-up
// with single_weight - weight, then each skipped wavelength's with its weight; f(setup, weight).
void for_each_single_correction(const SolvedMaterial& m, auto&& f) {
    for (const WavelengthSolution& s : m.samples) {
        const Rgb& a = s.single_weight;
        const Rgb& b = s.weight;
        f(s.reflection.setup(), Rgb{a[0] - b[0], a[1] - b[1], a[2] - b[2]});
    }
    for (const SingleScatteringSample& u : m.single_only) f(u.setup, u.weight);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Rgb weighted(const std::vector<WavelengthSolution>& samples, auto&& value) {
    Rgb out{0.0, 0.0, 0.0};
    for (const WavelengthSolution& s : samples) {
        const double v = value(s);
        for (int c = 0; c < 3; ++c) out[c] += s.weight[c] * v;
    }
    return out;
}

// The directions where the stream check and the gamut fit probe the BRDF: 0, 45, 75, 85 and 89.5
// degrees for both directions, on the light's side, across and on the mirror side. A MERL table's
// bin centres reach 89.9998 degrees; one per cent of its cells have a direction beyond 89.5
// (docs/physics.md, "The tables' zenith grid").
constexpr double probe_mus[] = {1.0, 0.7071, 0.2588, 0.0872, 0.0087};
constexpr double probe_phis[] = {0.0, 0.5 * std::numbers::pi, std::numbers::pi};

// Largest relative difference of the BRDF between two solves at the probes; values below 1e-2 of
// the largest are compared on that absolute scale (their relative error is noise). A rough top's
// first-surface lobe is left out: it is exact, the same in both, and its peak (10^4 1/sr for a
// gloss finish at grazing) would set a scale that hides every difference of the body.
// The orders on every core: the probes are compared one after the other, and their first
// evaluation sets up each order's Nystrom operator (HG g 0.5 at 64 streams: 12 ms on one core).
double disagreement(const rte::Reflection& a, const rte::Reflection& b) {
    const int cores = available_cpus();
    const std::vector<double> x = a.brdf_grid(probe_mus, probe_phis, false, cores);
    const std::vector<double> y = b.brdf_grid(probe_mus, probe_phis, false, cores);
    double largest = 0.0;
    for (double v : y) largest = std::max(largest, std::abs(v));
    double worst = 0.0;
    for (std::size_t k = 0; k < x.size(); ++k)
        worst = std::max(worst, std::abs(x[k] - y[k]) / std::max(std::abs(y[k]), 1e-2 * largest));
    return worst;
}

// The Fourier orders of the probes at the chosen count: those their phase functions carry, and
// those their reflection needs at `threshold` (reflection_orders; none when `threshold` is 0).
struct ProbeOrders {
    double threshold = 0.0;
    int carried = 0, needed = 0;
};

// `checked` receives the stream counts solved, in order. `probe_seconds`: the wall time of the
// batch that solved the probes at the chosen count. `kept` (one entry per stack) receives the
// probes' solutions at the chosen count, which are what the batch would make of them: each order
// problem is solved on its own, whatever else is in the batch, to the solver's tolerance on either
// device. Not under a rough top, where the batch shares one family of interface kernels over all
// its samples (solve_stacks), which the probes' own family only approximates.
//
// The probes are solved on the host whatever the device: batches of one or two stacks are latency,
// not throughput (an OpenCL launch, its buffers and transfers cost more than the solve), and the
// check then runs while the OpenCL device is still opening (solve_material, step 0). The seed
// material's check took 75 ms on PoCL, 34 ms of it after the device had opened, against 21 ms on
// the host.
int choose_streams(const std::vector<SpectralOptics>& optics, const std::vector<rte::Stack>& stacks,
                   const rte::ReflectionSettings& rs, const NumericalSettings& st, double& estimate,
                   double& probe_seconds, std::vector<std::optional<rte::Reflection>>& kept,
                   std::vector<int>& checked, ProbeOrders& orders) {
    // The probes of one stream count in one batch (one probe per core).
    const auto solve_probes = [&](const std::vector<std::size_t>& which, int streams) {
        rte::ReflectionSettings at = rs;
        at.streams = streams;
        std::vector<rte::Stack> batch;
        for (std::size_t k : which) batch.push_back(stacks[k]);
        const auto t0 = std::chrono::steady_clock::now();
        std::vector<rte::Reflection> out = solve_stacks(batch, at, Device::Cpu);
        return std::pair{std::move(out), seconds_since(t0)};
    };
    // The hardest samples: the most forward-peaked phase function and the highest albedo of any layer.
    const auto most = [](const SpectralOptics& o, auto&& value) {
        double v = 0.0;
        for (const LayerOptics& l : o.layers) v = std::max(v, value(l));
        return v;
    };
    const auto peak = [&](std::size_t k) { return most(optics[k], [](const LayerOptics& l) { return std::abs(l.g); }); };
    const auto brightness = [&](std::size_t k) { return most(optics[k], [](const LayerOptics& l) { return l.medium.omega; }); };
    std::vector<std::size_t> probes;
    std::size_t peaked = 0, bright = 0;
    for (std::size_t k = 0; k < optics.size(); ++k) {
        if (peak(k) > peak(peaked)) peaked = k;
        if (brightness(k) > brightness(bright)) bright = k;
    }
    probes.push_back(peaked);
    if (bright != peaked) probes.push_back(bright);
    int n = st.streams;
    // The count the check goes up to from n: 1.5 times as many, at most the cap.
    const auto next_count = [&](int count) { return std::min(st.max_streams, (3 * count + 1) / 2); };
    // Under a rough top the orders carry the single scattering with the delta-M phase function (TMS
    // corrects only a smooth top's direct paths), so what delta-M leaves out shows in the body as
    // far as the interface's lobes do not spread it out (docs/physics.md, "Rough interface": "Why a
    // rough top needs more streams", "Which counts the check skips"). Counts whose spread residual
    // (rte::spread_delta_m_residual, the lobes taken as a Gaussian of width 0.3 alpha) exceeds 30
    // times the tolerance are skipped: the body's error was measured at 0.06 to 0.5 of that residual
    // (the single scattering's share of the body; the seed in gloss, satin and matte, HG g 0.9 in
    // gloss), so such a count fails the check. The start stays below the cap, which checks it from
    // above.
    const auto rough_residual = [&](int streams) {
        double worst = 0.0;
        for (std::size_t k : probes) {
            if (stacks[k].top != rte::Top::Rough) continue;
            const double sigma = 0.3 * stacks[k].rough.alpha;
            // The split rule's exact degree + 1 under one interface (more pieces truncate sooner).
            for (const rte::Layer& l : stacks[k].layers)
                if (l.medium.omega > 0.0)
                    worst = std::max(worst, rte::spread_delta_m_residual(l.medium, 2 * (streams / 2), sigma));
        }
        return worst;
    };
    bool skipped = false;
    for (;;) {
        const int next = next_count(n);
        if (next >= st.max_streams) break;
        const double residual = rough_residual(n);
        if (!(residual > 30.0 * st.tolerance)) break;
        log::debug("streams ", n, " skipped: the rough top's spread delta-M residual ", residual, " > 30 x tolerance");
        n = next;
        skipped = true;
    }
    // The largest disagreement of two solves of the probes.
    const auto largest_disagreement = [&](const std::vector<rte::Reflection>& a,
                                          const std::vector<rte::Reflection>& b) {
        double d = 0.0;
        for (std::size_t p = 0; p < probes.size(); ++p) d = std::max(d, disagreement(a[p], b[p]));
        return d;
    };
    // The larger solve of one round is the smaller one of the next: kept, not solved again.
    std::vector<rte::Reflection> at_n;
    const auto t0 = std::chrono::steady_clock::now();
    const auto chosen = [&] {
        log::debug("streams: ", n, " (estimated error ", estimate, "; the check took ", seconds_since(t0), " s)");
        for (const rte::Reflection& r : at_n) {
            orders.carried = std::max(orders.carried, r.orders());
            if (orders.threshold > 0.0) orders.needed = std::max(orders.needed, reflection_orders(r, orders.threshold));
        }
        kept.assign(stacks.size(), std::nullopt);
        for (std::size_t p = 0; p < at_n.size(); ++p)
            if (stacks[probes[p]].top != rte::Top::Rough) kept[probes[p]].emplace(std::move(at_n[p]));
        return n;
    };
    // First from below: where the start count (settings_for's a-priori table) is enough, as for most
    // materials, three quarters of it must already agree with it within the tolerance. That solve
    // costs 0.42 of one at n, the solve above (1.5 n) 3.4 times as much: the order solves are cubic
    // in N. For an error falling as N^-p, d(3n/4, n) = ((4/3)^p - 1) err(n) and d(n, 1.5 n) =
    // (1 - 1.5^-p) err(n): equal for p = 1, and the check from below the more cautious for every
    // faster convergence. Otherwise the check goes up from n as before. Solved first, the smaller
    // batch also takes the device's one-off work (PoCL compiles a kernel on its first launch) out
    // of probe_seconds. A count pinned at the cap (streams = max_streams) is not checked.
    //
    // The check from below assumes the slowest convergence; the quadrature study measured the error
    // falling as N^-4.5 and faster (docs/quadrature-study.md: 1.4e-4, 3.9e-5, 2.8e-6 at 24, 32, 48).
    // Where the two counts disagree by more than the tolerance, a third, smaller count (3/4 of the
    // lower: its solve costs 0.18 of one at n, the solve above 3.4 times as much) measures this
    // material's own rate p: where it is the study's (p >= 4), the error at n extrapolates to
    // d(3n/4, n) / ((4/3)^p - 1) (Richardson, p taken at most 6), and n is kept where that is at most
    // half the tolerance. A rough top or a peaked phase function, which converge more slowly (p 2.6 to
    // 3.8 for the catalogue's finishes and the silica matting agent), go on up as before.
    // A skipped count's three quarters fail too: the check goes up from n.
    if (const int below = 3 * n / 4; !skipped && below >= 2 && n < st.max_streams) {
        const std::vector<rte::Reflection> at_below = solve_probes(probes, below).first;
        std::tie(at_n, probe_seconds) = solve_probes(probes, n);
        checked = {below, n};
        estimate = largest_disagreement(at_below, at_n);
        if (estimate <= st.tolerance) return chosen();
        if (const int lower = 3 * below / 4 / 2 * 2; lower >= 2) {
            const double d_lower = largest_disagreement(solve_probes(probes, lower).first, at_below);
            checked.push_back(lower);
            const double rate = std::log(d_lower / estimate) / std::log(static_cast<double>(below) / lower);
            if (rate >= 4.0) {
                const double step = std::pow(static_cast<double>(n) / below, std::min(rate, 6.0));
                const double extrapolated = estimate / (step - 1.0);
                log::debug("streams ", lower, ", ", below, " and ", n, " differ by ", d_lower, " and ", estimate,
                           ": error falling as N^-", rate, ", ", extrapolated, " at ", n);
                if (extrapolated <= 0.5 * st.tolerance) {
                    estimate = extrapolated;
                    return chosen();
                }
            }
        }
        log::debug("streams ", below, " and ", n, " differ by ", estimate, ": checking ", n, " from above");
    }
    for (;;) {
        const int next = next_count(n);
        if (next <= n) return chosen(); // at the cap: keep the last estimate
        if (at_n.empty()) {
            std::tie(at_n, probe_seconds) = solve_probes(probes, n);
            checked.push_back(n);
        }
        auto [at_next, next_seconds] = solve_probes(probes, next);
        checked.push_back(next);
        estimate = largest_disagreement(at_n, at_next);
        if (estimate <= st.tolerance) {
            // The first batch's time can hold the device's one-off work (PoCL compiles a kernel for
            // its launch on first use: ~2 s on a cold cache); the larger, later solve bounds it.
            probe_seconds = std::min(probe_seconds, next_seconds);
            return chosen();
        }
        log::info("streams ", n, " -> ", next, ": solutions differ by ", estimate, " (tolerance ", st.tolerance, ")");
        n = next;
        at_n = std::move(at_next);
        probe_seconds = next_seconds;
    }
}

} // namespace

SpectralSelection select_wavelengths(const std::vector<SpectralOptics>& optics, const std::vector<Rgb>& weights,
                                    double tolerance, bool single_exact) {
    const std::size_t n = optics.size();
    SpectralSelection out;
    if (n == 0) return out;
    // What the BRDF is made of, per wavelength and layer: the similarity parameter sqrt((1 - omega) /
    // (1 - omega g)) sets the multiply scattered level (van de Hulst 1980), omega p(Theta) at a
    // spread of scattering angles the single scattering, the index the Fresnel factors and a finite
    // layer's transmission exp(-tau) how much of what lies below shows through. Each must be
    // reproduced by the interpolation to within a third of the tolerance (relative for the phase
    // function values); measured against solving every wavelength by the PipelineSpectral test.
    // Where the single scattering is exact per wavelength (`single_exact`), the phase function
    // enters only through the multiple scattering, which averages it over angles: its first
    // moments chi_l = beta_l / (2 l + 1) stand for it. Its values at given angles carry Mie's
    // ripple in wavelength (0.1 % from one 10 nm step to the next for the seed's rutile at 30
    // degrees), which the colour integral of the solved BRDF would have to follow otherwise.
    constexpr int angles = 7;
    constexpr int moments = 4;
    struct Feature {
        double value;
        bool relative;
    };
    const auto feature = [&](std::size_t k) {
        std::vector<Feature> f;
        for (const LayerOptics& l : optics[k].layers) {
            const double om = l.medium.omega, g = l.g;
            f.push_back({std::sqrt(std::max(0.0, (1.0 - om) / (1.0 - om * g))), false});
            f.push_back({l.index, false});
            if (l.finite()) f.push_back({std::exp(-l.optical_depth), false});
            if (single_exact) {
                const std::vector<double>& beta = l.medium.beta;
                for (int m = 1; m <= moments; ++m)
                    f.push_back({m < static_cast<int>(beta.size()) ? beta[m] / (2 * m + 1) : 0.0, false});
                continue;
            }
            for (int a = 0; a < angles; ++a)
                f.push_back({om * rte::phase_value(l.medium.beta, std::cos(std::numbers::pi * a / (angles - 1))), true});
        }
        return f;
    };
    const auto allowed = [&](const std::vector<Feature>& fa, const std::vector<Feature>& fb, std::size_t q) {
        return fa[q].relative ? tolerance / 3.0 * std::min(std::abs(fa[q].value), std::abs(fb[q].value)) : tolerance / 3.0;
    };
    const auto lambda = [&](std::size_t k) { return optics[k].wavelength_nm; };
    // Quadratic Lagrange weights of nodes a, c, b at wavelength x.
    const auto lagrange = [&](std::size_t a, std::size_t c, std::size_t b, double x) {
        const double la = lambda(a), lc = lambda(c), lb = lambda(b);
        return std::array<double, 3>{(x - lc) * (x - lb) / ((la - lc) * (la - lb)),
                                     (x - la) * (x - lb) / ((lc - la) * (lc - lb)),
                                     (x - la) * (x - lc) / ((lb - la) * (lb - lc))};
    };
    // A skipped wavelength's error reaches the colour with its colour weight: one that carries a
    // fraction phi of a channel's weights (sum of |w|) may err by (tol / 3) / (n phi) where that is
    // looser, i.e. a wavelength of less than the average weight (the spectrum's ends) counts by
    // its weight. Each channel's colour-weighted error stays below sum_j max(phi_j, 1 / n) tol / 3
    // <= 2 tol / 3, and no wavelength is held tighter than before. share[j] = min(1, n max_c phi_jc).
    std::vector<double> share(n, 1.0);
    Rgb total{0.0, 0.0, 0.0};
    for (const Rgb& w : weights)
        for (int c = 0; c < 3; ++c) total[c] += std::abs(w[c]);
    for (std::size_t k = 0; k < n; ++k) {
        double most = 0.0;
        for (int c = 0; c < 3; ++c)
            if (total[c] > 0.0) most = std::max(most, static_cast<double>(n) * std::abs(weights[k][c]) / total[c]);
        share[k] = std::min(1.0, most);
    }
    std::vector<char> keep(n, 0);
    keep.front() = keep.back() = 1;
    // Intervals [a, b] with a kept midpoint c: accepted when the quadratic through a, c, b
    // reproduces every feature at every wavelength in between within `allowed`; else both halves
    // are refined. Every wavelength is solved below tolerance 1e-6 ("reference") or for short lists.
    struct Piece {
        std::size_t a, c, b;
    };
    std::vector<Piece> accepted;
    std::vector<std::pair<std::size_t, std::size_t>> stack;
    if (n <= 3 || tolerance < 1e-6) std::fill(keep.begin(), keep.end(), 1);
    else stack.push_back({0, n - 1});
    while (!stack.empty()) {
        const auto [a, b] = stack.back();
        stack.pop_back();
        if (b <= a + 1) continue;
        const std::size_t c = (a + b) / 2;
        keep[c] = 1;
        bool good = true;
        const auto fa = feature(a), fc = feature(c), fb = feature(b);
        for (std::size_t j = a + 1; j < b && good; ++j) {
            if (j == c) continue;
            const auto l = lagrange(a, c, b, lambda(j));
            const auto fj = feature(j);
            for (std::size_t q = 0; q < fj.size(); ++q)
                if (share[j] * std::abs(fj[q].value - (l[0] * fa[q].value + l[1] * fc[q].value + l[2] * fb[q].value)) >
                    allowed(fa, fb, q))
                    good = false;
        }
        if (good) {
            accepted.push_back({a, c, b});
        } else {
            stack.push_back({a, c});
            stack.push_back({c, b});
        }
    }
    std::vector<std::size_t> slot(n, 0);
    for (std::size_t k = 0; k < n; ++k)
        if (keep[k]) {
            slot[k] = out.solved.size();
            out.solved.push_back(k);
        }
    out.weights.assign(out.solved.size(), Rgb{0.0, 0.0, 0.0});
    for (std::size_t k = 0; k < n; ++k)
        if (keep[k])
            for (int c = 0; c < 3; ++c) out.weights[slot[k]][c] += weights[k][c];
    // Each skipped wavelength's colour weight goes to the three solved wavelengths of its piece, as
    // quadratic interpolation of the BRDF in wavelength would put it.
    for (const Piece& p : accepted)
        for (std::size_t j = p.a + 1; j < p.b; ++j) {
            if (keep[j]) continue;
            const auto l = lagrange(p.a, p.c, p.b, lambda(j));
            const std::size_t node[3] = {p.a, p.c, p.b};
            for (int q = 0; q < 3; ++q)
                for (int c = 0; c < 3; ++c) out.weights[slot[node[q]]][c] += l[q] * weights[j][c];
        }
    return out;
}

int reflection_orders(const rte::Reflection& reflection, double threshold) {
    const rte::OrderGrid g = reflection.order_grid(probe_mus);
    const Matrix& mean = g.orders.front();
    double largest = 0.0;
    for (double v : mean.data()) largest = std::max(largest, std::abs(v));
    int last = 0;
    for (int m = 1; m < static_cast<int>(g.orders.size()); ++m)
        for (int o = 0; o < mean.rows(); ++o)
            for (int i = 0; i < mean.cols(); ++i)
                if (2.0 * std::abs(g.orders[m](o, i)) > threshold * std::max(std::abs(mean(o, i)), 1e-2 * largest))
                    last = m;
    return last + 1;
}

NumericalSettings settings_for(double tolerance) {
    // Streams from the measured worst isotropic error of Gauss-in-mu Nystrom evaluation, angles 0 to
    // 89.9 degrees (docs/quadrature-study.md): 2.0e-3 at 8, 5.7e-4 at 16, 1.6e-4 at 24, 4.3e-5 at 32,
    // 3.1e-6 at 48, 2.2e-7 at 64.
    NumericalSettings s;
    s.tolerance = tolerance;
    s.streams = tolerance >= 3e-3   ? 8
                : tolerance >= 6e-4 ? 16
                : tolerance >= 2e-4 ? 24
                : tolerance >= 5e-5 ? 32
                : tolerance >= 5e-6 ? 48
                : tolerance >= 3e-7 ? 64
                                    : 96;
    s.order_tolerance = 0.1 * tolerance;
    s.solver_tolerance = std::clamp(1e-4 * tolerance, 1e-13, 1e-8);
    s.mie_tolerance = std::clamp(0.1 * tolerance, 1e-7, 1e-3);
    s.table_grid = tolerance >= 3e-3 ? 46 : tolerance >= 3e-5 ? 91 : 181;
    s.max_streams = tolerance >= 3e-3 ? 32 : tolerance >= 5e-5 ? 64 : 128;
    return s;
}

namespace {

// One rough kernel family (rte/rough_family.h) for a batch of stacks under the same rough top with
// a single binder's streams, when interpolating in the index costs less than a quadrature per
// stack; null otherwise.
std::shared_ptr<const rte::RoughKernelFamily> shared_rough_kernels(const std::vector<rte::StackSetup>& setups,
                                                                   const rte::ReflectionSettings& rs) {
    if (setups.empty()) return nullptr;
    const rte::Stack& first = setups.front().stack;
    double n_lo = std::numeric_limits<double>::infinity(), n_hi = 0.0;
    int orders = 1;
    for (const rte::StackSetup& s : setups) {
        if (s.stack.top != rte::Top::Rough || s.stack.rough != first.rough) return nullptr;
        n_lo = std::min(n_lo, s.layers.front().index);
        n_hi = std::max(n_hi, s.layers.front().index);
        orders = std::max(orders, s.orders);
    }
    const double tolerance = rte::rough_kernel_tolerance(rs.order_tolerance);
    const int nodes = rte::family_nodes(n_lo, n_hi, tolerance);
    if (setups.size() <= static_cast<std::size_t>(nodes)) return nullptr;
    log::debug("rough top: kernels of ", setups.size(), " stacks from ", nodes, " indices in [", n_lo, ", ", n_hi, "]");
    return std::make_shared<const rte::RoughKernelFamily>(first.rough, rs.streams / 2, rs.streams - rs.streams / 2,
                                                          n_lo, n_hi, nodes, orders, tolerance);
}

} // namespace

std::vector<rte::Reflection> solve_stacks(std::span<const rte::Stack> stacks, const rte::ReflectionSettings& rs,
                                          Device device, std::string* device_name) {
    // The semi-infinite layers' orders of every stack in one batch on the device; the finite layers
    // (slab eigen solutions, rte/slab.h) and the adding on the host, one stack per core, when each
    // Reflection is made.
    // The set-ups (delta-M, the phase matrices of every order) are independent per stack: one stack
    // per core (they ran on one core, 0.2 s of a gloss finish's 41 stacks at 48 streams). A failing
    // stack's error is the first in stack order, whatever the scheduling.
    const int count = static_cast<int>(stacks.size());
    std::vector<rte::StackSetup> setups(stacks.size());
    std::vector<std::vector<rte::OrderProblem>> own(stacks.size());
    std::vector<std::exception_ptr> failed(stacks.size());
    parallel_for(count, available_cpus(), [&](int k) {
        try {
            setups[k] = rte::setup_reflection(stacks[k], rs);
            own[k] = rte::order_problems(setups[k]);
        } catch (...) {
            failed[k] = std::current_exception();
        }
    });
    for (const std::exception_ptr& e : failed)
        if (e) std::rethrow_exception(e);
    std::vector<rte::OrderProblem> problems;
    std::vector<std::size_t> first_problem;
    for (auto& mine : own) {
        first_problem.push_back(problems.size());
        for (auto& p : mine) problems.push_back(std::move(p));
    }
    first_problem.push_back(problems.size());
    const std::shared_ptr<const rte::RoughKernelFamily> family = shared_rough_kernels(setups, rs);
    std::vector<rte::OrderSolution> solutions;
    if (device == Device::OpenCL) {
        // Nothing for the device (the HG half-space: its stream check's probe is its one sample):
        // no wait for PoCL, which may still be loading LLVM, so that compute makes the table's
        // grids meanwhile; the fill waits for it (HG's computation 89 -> 83-86 ms in 25
        // alternating runs). solve_material or its caller makes sure of it (DeviceCheck).
        if (!problems.empty()) {
            if (device_name) *device_name = device_label(device); // throws DeviceError naming the fault
            solutions = rte::solve_orders_opencl(problems, rs.method, rs.control);
        }
    } else {
        if (device_name) *device_name = device_label(device);
        solutions = rte::solve_orders_cpu(problems, rs.method, rs.control, available_cpus());
    }
    for (const auto& s : solutions)
        if (!s.converged) log::warn("order solve did not converge (residual ", s.residual, ")");
    std::vector<std::optional<rte::Reflection>> made(setups.size());
    parallel_for(static_cast<int>(setups.size()), available_cpus(), [&](int k) {
        std::vector<rte::OrderSolution> mine(
            std::make_move_iterator(solutions.begin() + static_cast<std::ptrdiff_t>(first_problem[k])),
            std::make_move_iterator(solutions.begin() + static_cast<std::ptrdiff_t>(first_problem[k + 1])));
        made[k].emplace(std::move(setups[k]), std::move(mine), family);
    });
    std::vector<rte::Reflection> out;
    out.reserve(made.size());
    for (auto& r : made) out.push_back(std::move(*r));
    return out;
}

std::string device_label(Device device) {
    return device == Device::OpenCL ? "opencl: " + cl::Context::shared()->info().name : "cpu";
}

MaterialOptics material_optics(const material::MaterialSpec& spec, const NumericalSettings& st,
                               const OpticsProgress& progress) {
    const std::string who = spec.source.empty() ? spec.name : spec.source;
    MaterialOptics out;
    std::vector<SpectralOptics>& optics = out.optics;
    std::vector<Rgb>& weights = out.weights;
    const bool rgb_substrate = spec.substrate && coloured(spec.substrate->albedo);
    if (analytic(spec)) {
        bool grey = !rgb_substrate;
        for (const material::LayerSpec& l : spec.layers) grey = grey && l.medium->grey;
        const int channels = grey ? 1 : 3;
        for (int c = 0; c < channels; ++c) {
            optics.push_back(analytic_optics(spec, c, st.order_tolerance));
            weights.push_back(grey ? Rgb{1.0, 1.0, 1.0} : Rgb{c == 0 ? 1.0 : 0.0, c == 1 ? 1.0 : 0.0, c == 2 ? 1.0 : 0.0});
        }
    } else {
        for (std::size_t k = 0; k < spec.layers.size(); ++k)
            if (spec.layers[k].medium && !spec.layers[k].medium->grey)
                throw InputError(cat(who, ": layers[", k, "]: an analytic medium in a stack with binder layers is "
                                          "solved per wavelength and needs one (grey) albedo, not [r, g, b]"));
        const auto wavelengths = spec.spectrum.wavelengths_nm();
        const auto rgb = spec.spectrum.rgb_weights(spec.colorspace);
        optics.resize(wavelengths.size());
        // Each wavelength's expected share of the work, for `progress`: a sphere's series has ~x
        // terms, its intensities as many angles per term, and x goes as 1 / lambda.
        std::vector<double> costs;
        for (double w : wavelengths) costs.push_back(1.0 / (w * w));
        const int threads = available_cpus();
        WorkProjection projection(std::move(costs), threads);
        std::mutex progress_mutex;
        const auto t0 = std::chrono::steady_clock::now();
        // Also while a wavelength's Lorenz-Mie integration runs (after each of its refinements): a
        // large particle's first wavelengths take minutes before any is done.
        const std::function<void()> heartbeat = [&] {
            const std::lock_guard lock(progress_mutex);
            const double now = seconds_since(t0);
            progress(now, projection.projected_total(now));
        };
        // Wavelengths are independent: split them over the cores.
        parallel_for(static_cast<int>(wavelengths.size()), threads, [&](int k) {
            if (progress) {
                const std::lock_guard lock(progress_mutex);
                projection.start(static_cast<std::size_t>(k), seconds_since(t0));
            }
            optics[k] = spectral_optics(spec, wavelengths[k], mie_accuracy(spec, st, wavelengths[k]), 0,
                                        progress ? heartbeat : std::function<void()>());
            if (!progress) return;
            const std::lock_guard lock(progress_mutex);
            const double now = seconds_since(t0);
            projection.finish(static_cast<std::size_t>(k), now);
            progress(now, projection.projected_total(now));
        });
        std::vector<Rgb> all(rgb.begin(), rgb.end());
        // Where the single scattering is apart, a skipped wavelength keeps its own exactly and
        // only its multiply scattered light is interpolated (SingleScatteringSample).
        const bool apart = single_scattering_apart(spec, optics);
        const SpectralSelection pick =
            select_wavelengths(optics, all, st.select_wavelengths ? st.tolerance : 0.0, apart);
        std::vector<char> solved(optics.size(), 0);
        for (std::size_t k : pick.solved) solved[k] = 1;
        for (std::size_t k = 0; apart && k < optics.size(); ++k)
            if (!solved[k]) {
                out.single_only.push_back(std::move(optics[k]));
                out.single_only_weights.push_back(all[k]);
            }
        std::vector<SpectralOptics> kept;
        for (std::size_t k : pick.solved) {
            kept.push_back(std::move(optics[k]));
            if (apart) out.single_weights.push_back(all[k]); // its own, not the folded one
        }
        optics = std::move(kept);
        weights = pick.weights;
        out.wavelengths_interpolated = all.size() - pick.solved.size();
        if (rgb_substrate) {
            // A coloured substrate under a spectral film: each output channel sees the substrate's
            // albedo of that channel (as an RGB renderer would), so each wavelength is solved once
            // per channel with that channel's weight only.
            std::vector<SpectralOptics> split;
            std::vector<Rgb> split_weights;
            for (std::size_t k = 0; k < optics.size(); ++k)
                for (int c = 0; c < 3; ++c) {
                    split.push_back(optics[k]);
                    split.back().substrate_albedo = spec.substrate->albedo[static_cast<std::size_t>(c)];
                    Rgb w{0.0, 0.0, 0.0};
                    w[c] = weights[k][c];
                    split_weights.push_back(w);
                }
            optics = std::move(split);
            weights = std::move(split_weights);
        }
    }
    if (out.single_weights.empty()) out.single_weights = weights; // single scattering not apart

    // The spec's limit on the phase function's Legendre series (material::SpecLimits): the order
    // matrices and the table's Fourier sums grow with it. Known only now, from the optics (the
    // skipped wavelengths' too where their single scattering is evaluated).
    const auto check_limit = [&](const SpectralOptics& o) {
        for (const LayerOptics& l : o.layers)
            if (l.medium.beta.size() > spec.limits.max_legendre_terms)
                throw LimitError(cat(who, ": the phase function's Legendre series has ", l.medium.beta.size(),
                                     " terms", o.wavelength_nm > 0.0 ? cat(" at ", o.wavelength_nm, " nm") : "",
                                     ", more than the limit of ", spec.limits.max_legendre_terms,
                                     "; to override, set \"limits\": {\"max_legendre_terms\": ",
                                     l.medium.beta.size(), "} in the spec"));
    };
    for (const SpectralOptics& o : optics) check_limit(o);
    for (const SpectralOptics& o : out.single_only) check_limit(o);
    return out;
}

MaterialOptics material_optics(const material::MaterialSpec& spec, const NumericalSettings& st,
                               const SolveFeedback& feedback) {
    // Large particles' optics take minutes (silica r_eff 200 um: ~3 min here) before anything else
    // is known: the bar follows them, and where what is left will take long, the estimate is said
    // once (after a second: the first wavelengths' times are what it goes by).
    const auto t0 = std::chrono::steady_clock::now();
    bool announced = false;
    double fraction = 0.0; // never back, and 1 only once they are all done
    bool running_noted = false;
    const auto progress = [&](double elapsed, double projected) {
        if (!(projected > 0.0)) {
            // None done yet: a first wavelength that runs this long makes them all long. Said with
            // what is known (the estimate follows once one is done); half a second at least, far
            // beyond any small particle's wavelength.
            if (feedback.note && !running_noted && elapsed >= std::max(0.5, st.note_after_seconds)) {
                running_noted = true;
                feedback.note(cat(spec.name, ": its particles' optics take long: the first of its ",
                                  spec.spectrum.wavelengths_nm().size(),
                                  " wavelengths (Lorenz-Mie) is still running after ", format_duration(elapsed),
                                  "; an estimate follows once one is done"));
            }
            return;
        }
        fraction = std::max(fraction, std::min(elapsed / projected, 0.999));
        if (feedback.optics) feedback.optics(fraction, projected);
        if (feedback.note && !announced && elapsed >= std::min(1.0, st.note_after_seconds) &&
            projected - elapsed > st.note_after_seconds) {
            announced = true;
            feedback.note(cat(spec.name, ": about ", format_duration(projected),
                              " for its particles' optics (Lorenz-Mie, ", spec.spectrum.wavelengths_nm().size(),
                              " wavelengths)"));
        }
    };
    // Without anyone to tell, no progress calls.
    MaterialOptics out =
        material_optics(spec, st, feedback.optics || feedback.note ? OpticsProgress(progress) : OpticsProgress());
    if (feedback.optics) feedback.optics(1.0, seconds_since(t0));
    return out;
}

SolveFeedback feedback_on(Progress& progress) {
    SolveFeedback f;
    f.note = [&progress](const std::string& text) { progress.note(text); };
    f.optics = [&progress](double fraction, double projected_seconds) {
        if (projected_seconds > 1.0) progress.set_weight("optics", projected_seconds);
        progress.advance(fraction);
        if (fraction >= 1.0) progress.stage("solve");
    };
    return f;
}

SolvedMaterial solve_material(const material::MaterialSpec& spec, Device device) {
    return solve_material(spec, device, settings_for(spec.accuracy.tolerance));
}

SolvedMaterial solve_material(const material::MaterialSpec& spec, Device device, const NumericalSettings& settings,
                              const SolveFeedback& feedback, DeviceCheck device_check) {
    const auto& note = feedback.note;
    check_supported(spec);
    SolvedMaterial out;
    out.spec = spec;
    out.settings = settings;
    const NumericalSettings& st = out.settings;
    rte::ReflectionSettings rs;
    rs.streams = st.streams;
    rs.order_tolerance = st.order_tolerance;
    rs.max_orders = st.max_orders;
    rs.method = st.method;
    rs.control.tolerance = st.solver_tolerance;

    // 0. The OpenCL device opens on one core (PoCL loads its compiler, LLVM: ~40 ms here) while the
    // optics run. glibc's dynamic loader holds its locks for the whole load: a thread started
    // meanwhile waits for it (pthread_create sets up the thread's TLS under the loader's lock), and
    // so does a thread's first use of a thread_local with a destructor (registered under it). So
    // the worker threads start first, and Mie keeps its scratch in the caller's hands (mie.h,
    // SeriesWork); with threads per loop, a new seed's first parallel loop had waited 45 ms
    // (strace -k). A failure is left to the first solve (solve_stacks), which opens it again and
    // raises the error as before.
    std::future<void> device_opening;
    if (device == Device::OpenCL) {
        start_worker_threads();
        device_opening = std::async(std::launch::async, [device_check] {
            try {
                cl::Context::shared();
                if (device_check == DeviceCheck::CallerFillsTable) load_fill_program();
            } catch (...) {
            }
        });
    }

    // 1. Optics per wavelength (or per channel of an analytic material), every layer; the bar and a
    // long one's estimate follow them.
    auto t0 = std::chrono::steady_clock::now();
    MaterialOptics mo = material_optics(spec, st, feedback);
    std::vector<SpectralOptics>& optics = mo.optics;
    std::vector<Rgb>& weights = mo.weights;
    out.wavelengths_interpolated = mo.wavelengths_interpolated;
    std::vector<rte::Stack> stacks;
    for (const SpectralOptics& o : optics) stacks.push_back(make_stack(o, spec.surface));
    out.seconds.optics = seconds_since(t0);

    // 2. Streams: the table in settings_for is calibrated on isotropic scattering without an
    // interface. Forward-peaked phase functions (delta-M truncates more of them) and the split rule
    // under an interface need more: check convergence on the hardest samples, first against 3/4 of
    // the start count, then growing N until two stream counts agree within the tolerance, or the
    // cap is reached; the last difference is the reported error estimate.
    t0 = std::chrono::steady_clock::now();
    double probe_seconds = 0.0;
    std::vector<std::optional<rte::Reflection>> kept;
    ProbeOrders orders;
    if (st.fit_orders) orders.threshold = 0.1 * st.order_tolerance;
    rs.streams = choose_streams(optics, stacks, rs, st, out.error_estimate, probe_seconds, kept,
                                out.checked_streams, orders);
    out.settings.streams = rs.streams;
    if (note) {
        // The probes (at most one per core) took about one sample's solve; the batch solves every
        // sample over the cores, and the gamut fit and the tables' grids add to it: 1.4 times that
        // matched the silica 5 um matting agent (18.3 s) and the seed at "reference" (8.5 s).
        const int cores = std::max(1, available_cpus());
        const double rounds = std::ceil(static_cast<double>(stacks.size()) / cores);
        const double expected = 1.4 * probe_seconds * rounds;
        if (expected > st.note_after_seconds)
            note(cat(spec.name, ": about ", format_duration(expected), " to solve and tabulate (", stacks.size(),
                     " samples at ", rs.streams, " streams)"));
    }
    // 2b. Fourier orders: what the probes (the most peaked and the brightest samples) reflect, at a
    // tenth of the order tolerance, rather than every order their phase functions carry (HG g 0.5:
    // 16 of 24 at 1e-6). The probes' own solutions are cut to that; the batch solves no more.
    int needed = orders.needed;
    if (st.max_orders > 0 && needed > 0) needed = std::min(needed, st.max_orders);
    if (needed > 0 && needed < orders.carried) {
        log::debug("Fourier orders: ", needed, " of the ", orders.carried, " the phase functions carry");
        rs.max_orders = needed;
        for (auto& r : kept)
            if (r && r->orders() > needed) r = r->with_orders(needed);
    }
    if (out.error_estimate > st.tolerance)
        log::warn(spec.name, ": accuracy not reached at the stream cap (", st.max_streams, "): estimated error ",
                  out.error_estimate, " > tolerance ", st.tolerance,
                  " (a phase function too peaked for delta-M at this cost; see the report)");

    // 3. Every sample the check has not solved at this count already, in one batch.
    std::vector<rte::Stack> unsolved;
    for (std::size_t k = 0; k < stacks.size(); ++k)
        if (!kept[k]) unsolved.push_back(stacks[k]);
    std::vector<rte::Reflection> reflections = solve_stacks(unsolved, rs, device, &out.device);
    if (out.device.empty() && device_check == DeviceCheck::BeforeReturn) out.device = device_label(device);
    // The caller's device check: returning does not wait for the device to open (HG g 0.5: its
    // solve is done 15 ms before PoCL has loaded LLVM, time the table's grids use now).
    if (device_check != DeviceCheck::BeforeReturn && device_opening.valid()) out.device_opening = device_opening.share();
    for (std::size_t k = 0, next = 0; k < stacks.size(); ++k) {
        rte::Reflection r = kept[k] ? std::move(*kept[k]) : std::move(reflections[next++]);
        out.samples.push_back(WavelengthSolution{optics[k].wavelength_nm, weights[k], mo.single_weights[k],
                                                 optics[k], std::move(r), std::nullopt, {}, {}});
        if (spec.model == material::Model::Dipole) {
            const LayerOptics& o = optics[k].top();
            const double n = out.samples.back().reflection.setup().layers[0].index;
            out.samples.back().dipole.emplace(o.medium.omega, o.g, n, o.medium.beta);
        }
    }
    // The skipped wavelengths' single scattering, at the chosen streams (TMS's delta-M fraction).
    out.single_only.resize(mo.single_only.size());
    parallel_for(static_cast<int>(mo.single_only.size()), available_cpus(), [&](int k) {
        const SpectralOptics& o = mo.single_only[k];
        out.single_only[k] = SingleScatteringSample{o.wavelength_nm, mo.single_only_weights[k],
                                                    rte::setup_reflection(make_stack(o, spec.surface), rs)};
    });
    if (!analytic(spec)) fit_into_gamut(out);
    // The gamut fit's share (the seed: ~27 ms, most of it the Nystrom set-ups the table's grids
    // then reuse) counts as solving: the report's stages add up to the material's time.
    out.seconds.solve = seconds_since(t0);
    return out;
}

namespace {

// The cosines of reflectance_angles_deg, as SolvedMaterial::albedo(theta) computes them from the
// report's angles in radians (so that they compare equal).
const std::vector<double>& reflectance_cosines() {
    static const std::vector<double> mus = [] {
        std::vector<double> out;
        for (double deg : reflectance_angles_deg) out.push_back(std::cos(deg * std::numbers::pi / 180.0));
        return out;
    }();
    return mus;
}

} // namespace

void fit_into_gamut(SolvedMaterial& m) {
    // A saturated pigment (CdS yellow, vermilion) reflects a colour outside a space's gamut: a
    // channel goes negative, or a reflectance above 1. material::fit_into_gamut (docs/colour.md,
    // "The gamut fit") scales every colour weight's chroma about its luminance by one factor: a
    // linear map, so the tables keep their angular shape, reciprocity and luminance. It must see
    // the values where the colour is hardest to hold: the diffuse BRDF at grazing incidence and
    // exitance on both azimuth sides (where the diffuse part is smallest relative to its colour),
    // the diffuse albedo alone and the mirror alone (a yellow-green mixture's blue diffuse albedo
    // went negative while diffuse + mirror stayed positive), and diffuse + mirror, which must stay
    // within [0, 1].
    material::GamutFitInput in;
    in.material = m.spec.name;
    in.space = m.spec.colorspace;
    in.value_error = m.settings.solver_tolerance; // the per-order iteration's: energy kept to it
    // The report's angles: the values are kept for it (WavelengthSolution::known_albedo).
    const std::vector<double>& reflectance_mus = reflectance_cosines();
    std::vector<std::vector<double>> probes(m.samples.size());
    // Independent per sample: one thread per core; every direction of a sample from one grid.
    parallel_for(static_cast<int>(m.samples.size()), available_cpus(), [&](int k) {
        WavelengthSolution& s = m.samples[k];
        std::vector<double>& p = probes[k];
        if (s.dipole) {
            for (double mi : probe_mus)
                for (double mo : probe_mus)
                    for (double phi : probe_phis) p.push_back(s.dipole->brdf(mi, mo, phi));
        } else {
            p = s.reflection.brdf_grid(probe_mus, probe_phis);
        }
        if (s.dipole) {
            s.known_albedo.clear();
            s.known_mirror.clear();
            for (double mu : reflectance_mus) {
                s.known_albedo.push_back(s.dipole->albedo(mu));
                s.known_mirror.push_back(s.dipole->mirror(mu));
            }
        } else {
            s.known_albedo = s.reflection.albedo(reflectance_mus);
            s.known_mirror = s.reflection.mirror(reflectance_mus);
        }
        for (std::size_t j = 0; j < reflectance_mus.size(); ++j) {
            p.push_back(s.known_albedo[j]);
            p.push_back(s.known_mirror[j]);
        }
    });
    // Per sample: the BRDF probes, then (diffuse albedo, mirror) per reflectance cosine.
    const std::size_t brdf_probes = std::size(probe_mus) * std::size(probe_mus) * std::size(probe_phis);
    for (std::size_t k = 0; k < m.samples.size(); ++k) {
        in.weights.push_back(m.samples[k].weight);
        in.brdf.insert(in.brdf.end(), probes[k].begin(), probes[k].end());
        for (std::size_t j = 0; j < reflectance_mus.size(); ++j)
            in.reflectance.push_back(probes[k][brdf_probes + 2 * j] + probes[k][brdf_probes + 2 * j + 1]);
    }
    // The exact single scattering of every wavelength (single_only) as more entries: each solved
    // sample's own with the weight single_weight - weight, then each skipped wavelength's, their
    // reflectances 0 (the albedo and mirror follow `weight`). The fit's map is linear, so the
    // difference's fitted weight is the difference of the fitted ones.
    if (!m.single_only.empty()) {
        const auto add_single = [&](const rte::StackSetup& setup, const Rgb& weight) {
            in.weights.push_back(weight);
            for (double v : rte::single_scattering_grid(setup, probe_mus, probe_phis)) // brdf_grid's order
                in.brdf.push_back(v * std::numbers::inv_pi);
            in.brdf.insert(in.brdf.end(), 2 * reflectance_mus.size(), 0.0); // (albedo, mirror) pairs
            in.reflectance.insert(in.reflectance.end(), reflectance_mus.size(), 0.0);
        };
        for_each_single_correction(m, add_single);
    }
    in.probe_count = brdf_probes + 2 * reflectance_mus.size();
    in.reflectance_count = reflectance_mus.size();
    const material::GamutFit fit = material::fit_into_gamut(in); // checks the luminance is kept
    const std::size_t n = m.samples.size();
    for (std::size_t k = 0; k < n; ++k) m.samples[k].weight = fit.weights[k];
    if (m.single_only.empty()) {
        for (WavelengthSolution& s : m.samples) s.single_weight = s.weight;
    } else {
        for (std::size_t k = 0; k < n; ++k)
            for (int c = 0; c < 3; ++c) m.samples[k].single_weight[c] = fit.weights[k][c] + fit.weights[n + k][c];
        for (std::size_t u = 0; u < m.single_only.size(); ++u) m.single_only[u].weight = fit.weights[2 * n + u];
    }
    m.gamut_scale = fit.scale;
    m.gamut_clipped = fit.clipped;
    if (!fit.warning.empty()) {
        log::warn(fit.warning);
        m.warnings.push_back(fit.warning);
    }
}

Rgb SolvedMaterial::brdf(double theta_i, double theta_o, double phi) const {
    const double mi = std::cos(theta_i), mo = std::cos(theta_o);
    if (mi <= 0.0 || mo <= 0.0) return {0.0, 0.0, 0.0};
    // No output holds a negative value (docs/colour.md): what the gamut fit leaves (its clipped
    // case, directions between its probes) and a series' rounding below 0 are clamped.
    Rgb sum = weighted(samples, [&](const WavelengthSolution& s) {
        return s.dipole ? s.dipole->brdf(mi, mo, phi) : s.reflection.brdf(mi, mo, phi);
    });
    const Rgb single = single_scattering_correction(mi, mo, phi);
    for (int c = 0; c < 3; ++c) sum[c] += single[c];
    return material::clip_negative(sum);
}

std::vector<SingleScatteringSource> SolvedMaterial::single_scattering_sources() const {
    std::vector<SingleScatteringSource> out;
    for (const WavelengthSolution& s : samples) out.push_back({&s.reflection.setup(), s.single_weight});
    for (const SingleScatteringSample& u : single_only) out.push_back({&u.setup, u.weight});
    return out;
}

Rgb SolvedMaterial::single_scattering_correction(double mu_i, double mu_o, double phi) const {
    Rgb out{0.0, 0.0, 0.0};
    if (single_only.empty()) return out;
    const auto add = [&](const rte::StackSetup& setup, const Rgb& weight) {
        const double v = rte::single_scattering(setup, mu_o, mu_i, phi) * std::numbers::inv_pi;
        for (int c = 0; c < 3; ++c) out[c] += weight[c] * v;
    };
    for_each_single_correction(*this, add);
    return out;
}

Rgb SolvedMaterial::albedo(double theta_i) const {
    const double mi = std::cos(theta_i);
    return material::clip_negative(weighted(
        samples, [&](const WavelengthSolution& s) { return s.dipole ? s.dipole->albedo(mi) : s.reflection.albedo(mi); }));
}

namespace {

// A per-sample quantity at many angles, weighted into colour: `of(sample, cosines)` gives one value
// per cosine; the samples are independent (one per core).
std::vector<Rgb> weighted_at(const std::vector<WavelengthSolution>& samples, std::span<const double> theta_i,
                             auto&& of) {
    std::vector<double> mus;
    for (double t : theta_i) mus.push_back(std::cos(t));
    std::vector<std::vector<double>> per_sample(samples.size());
    parallel_for(static_cast<int>(samples.size()), available_cpus(),
                 [&](int k) { per_sample[k] = of(samples[k], mus); });
    std::vector<Rgb> out(mus.size(), Rgb{0.0, 0.0, 0.0});
    for (std::size_t k = 0; k < samples.size(); ++k)
        for (std::size_t e = 0; e < mus.size(); ++e)
            for (int c = 0; c < 3; ++c) out[e][c] += samples[k].weight[c] * per_sample[k][e];
    for (Rgb& v : out) v = material::clip_negative(v);
    return out;
}

} // namespace

std::vector<Rgb> SolvedMaterial::albedo(std::span<const double> theta_i) const {
    return weighted_at(samples, theta_i, [](const WavelengthSolution& s, const std::vector<double>& mus) {
        if (!s.known_albedo.empty() && mus == reflectance_cosines()) return s.known_albedo;
        if (!s.dipole) return s.reflection.albedo(mus);
        std::vector<double> v;
        for (double mu : mus) v.push_back(s.dipole->albedo(mu));
        return v;
    });
}

std::vector<Rgb> SolvedMaterial::mirror(std::span<const double> theta_i) const {
    return weighted_at(samples, theta_i, [](const WavelengthSolution& s, const std::vector<double>& mus) {
        if (!s.known_mirror.empty() && mus == reflectance_cosines()) return s.known_mirror;
        if (!s.dipole) return s.reflection.mirror(mus);
        std::vector<double> v;
        for (double mu : mus) v.push_back(s.dipole->mirror(mu));
        return v;
    });
}

Rgb SolvedMaterial::mirror(double theta_i) const {
    const double mi = std::cos(theta_i);
    return material::clip_negative(weighted(
        samples, [&](const WavelengthSolution& s) { return s.dipole ? s.dipole->mirror(mi) : s.reflection.mirror(mi); }));
}

} // namespace brdf::model
