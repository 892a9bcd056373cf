#include <brdf/model/model.h>

#include <brdf/cl/context.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/threads.h>
#include <brdf/rte/cl_solver.h>

#include <chrono>
#include <numbers>
#include <optional>
#include <cmath>

namespace brdf::model {
namespace {

// What the pipeline computes so far: one semi-infinite layer under no or a smooth interface, in
// Rec.709, into MERL and EXR tables. The spec format already describes more (docs/spec.md); until
// that physics lands, such a spec is refused here, naming what is missing, instead of being
// computed as something else.
void check_supported(const material::MaterialSpec& spec) {
    const std::string who = spec.source.empty() ? spec.name : spec.source;
    const auto refuse = [&](const std::string& what) {
        throw InputError(cat(who, ": ", what, " not supported yet"));
    };
    if (spec.layers.empty()) refuse("a material without layers is");
    if (spec.layers.size() > 1) refuse("stacks of several layers (\"layers\") are");
    if (!spec.layers[0].semi_infinite())
        refuse("finite layers (\"thickness_um\", \"optical_depth\", \"substrate\") are");
    if (spec.surface.kind == material::Surface::Rough)
        refuse("rough surfaces (\"roughness\", \"gloss\", \"satin\", \"matte\") are");
    if (spec.colorspace != material::ColorSpace::Rec709)
        refuse("colour spaces other than \"rec709\" are");
    for (const std::string& f : spec.outputs)
        if (f != "merl" && f != "exr" && f != "fourier" && f != "rgl") refuse(cat("the output \"", f, "\" is"));
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

// Largest relative difference of the BRDF between two solves, over a spread of directions; values
// below 1e-2 of the largest are compared on that absolute scale (their relative error is noise).
double disagreement(const rte::Reflection& a, const rte::Reflection& b) {
    // 0, 45, 75, 85 and 89.5 degrees: the last is about the most grazing bin centre of a MERL table.
    const double mus[] = {1.0, 0.7071, 0.2588, 0.0872, 0.0087};
    const double phis[] = {0.0, 0.5 * std::numbers::pi, std::numbers::pi};
    std::vector<std::pair<double, double>> values;
    double largest = 0.0;
    for (double mi : mus)
        for (double mo : mus)
            for (double phi : phis) {
                values.emplace_back(a.brdf(mi, mo, phi), b.brdf(mi, mo, phi));
                largest = std::max(largest, std::abs(values.back().second));
            }
    double worst = 0.0;
    for (const auto& [x, y] : values) worst = std::max(worst, std::abs(x - y) / std::max(std::abs(y), 1e-2 * largest));
    return worst;
}

rte::Reflection solve_one(const SpectralOptics& o, rte::ReflectionSettings rs, int streams) {
    rs.streams = streams;
    rte::StackSetup setup = rte::setup_reflection(o.medium, rte::Interface{o.binder_index}, rs);
    const auto problems = rte::order_problems(setup);
    auto solutions = rte::solve_orders_cpu(problems, rs.method, rs.control, available_cpus());
    return rte::Reflection(std::move(setup), std::move(solutions));
}

int choose_streams(const std::vector<SpectralOptics>& optics, const rte::ReflectionSettings& rs, const NumericalSettings& st,
                   double& estimate) {
    // The hardest samples: the most forward-peaked phase function and the highest albedo.
    std::vector<std::size_t> probes;
    std::size_t peaked = 0, bright = 0;
    for (std::size_t k = 0; k < optics.size(); ++k) {
        if (std::abs(optics[k].g) > std::abs(optics[peaked].g)) peaked = k;
        if (optics[k].medium.omega > optics[bright].medium.omega) bright = k;
    }
    probes.push_back(peaked);
    if (bright != peaked) probes.push_back(bright);
    int n = st.streams;
    // The larger solve of one round is the smaller one of the next: kept, not solved again.
    std::vector<std::optional<rte::Reflection>> at_n(probes.size());
    for (;;) {
        const int next = std::min(st.max_streams, (3 * n + 1) / 2);
        if (next <= n) return n; // at the cap: keep the last estimate
        estimate = 0.0;
        std::vector<std::optional<rte::Reflection>> at_next(probes.size());
        for (std::size_t p = 0; p < probes.size(); ++p) {
            if (!at_n[p]) at_n[p] = solve_one(optics[probes[p]], rs, n);
            at_next[p] = solve_one(optics[probes[p]], rs, next);
            estimate = std::max(estimate, disagreement(*at_n[p], *at_next[p]));
        }
        if (estimate <= st.tolerance) return n;
        log::info("streams ", n, " -> ", next, ": solutions differ by ", estimate, " (tolerance ", st.tolerance, ")");
        n = next;
        at_n = std::move(at_next);
    }
}

} // namespace

SpectralSelection select_wavelengths(const std::vector<SpectralOptics>& optics, const std::vector<Rgb>& weights,
                                    double tolerance) {
    const std::size_t n = optics.size();
    SpectralSelection out;
    if (n == 0) return out;
    // What the BRDF is made of, per wavelength: the similarity parameter sqrt((1 - omega) /
    // (1 - omega g)) sets the multiply scattered level (van de Hulst 1980), omega p(Theta) at a
    // spread of scattering angles the single scattering, and the binder index the Fresnel factors.
    // Each must be reproduced by the interpolation to within a third of the tolerance (relative for
    // the phase function values); measured against solving every wavelength by the
    // PipelineSpectral test.
    constexpr int angles = 7;
    const auto feature = [&](std::size_t k) {
        const double om = optics[k].medium.omega, g = optics[k].g;
        std::array<double, 2 + angles> f{std::sqrt(std::max(0.0, (1.0 - om) / (1.0 - om * g))), optics[k].binder_index};
        for (int a = 0; a < angles; ++a)
            f[2 + a] = om * rte::phase_value(optics[k].medium.beta, std::cos(std::numbers::pi * a / (angles - 1)));
        return f;
    };
    const auto allowed = [&](const auto& fa, const auto& fb, int q) {
        return q < 2 ? tolerance / 3.0 : tolerance / 3.0 * std::min(std::abs(fa[q]), std::abs(fb[q]));
    };
    const auto lambda = [&](std::size_t k) { return optics[k].wavelength_nm; };
    // Quadratic Lagrange weights of nodes a, c, b at wavelength x.
    const auto lagrange = [&](std::size_t a, std::size_t c, std::size_t b, double x) {
        const double la = lambda(a), lc = lambda(c), lb = lambda(b);
        return std::array<double, 3>{(x - lc) * (x - lb) / ((la - lc) * (la - lb)),
                                     (x - la) * (x - lb) / ((lc - la) * (lc - lb)),
                                     (x - la) * (x - lc) / ((lb - la) * (lb - lc))};
    };
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
                if (std::abs(fj[q] - (l[0] * fa[q] + l[1] * fc[q] + l[2] * fb[q])) > allowed(fa, fb, static_cast<int>(q)))
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

SolvedMaterial solve_material(const material::MaterialSpec& spec, Device device) {
    return solve_material(spec, device, settings_for(spec.accuracy.tolerance));
}

SolvedMaterial solve_material(const material::MaterialSpec& spec, Device device, const NumericalSettings& settings) {
    check_supported(spec);
    SolvedMaterial out;
    out.spec = spec;
    out.settings = settings;
    const NumericalSettings& st = out.settings;
    rte::ReflectionSettings rs;
    rs.streams = st.streams;
    rs.order_tolerance = st.order_tolerance;
    rs.method = st.method;
    rs.control.tolerance = st.solver_tolerance;

    // 1. Optics per wavelength (or per channel of an analytic medium).
    auto t0 = std::chrono::steady_clock::now();
    std::vector<SpectralOptics> optics;
    std::vector<Rgb> weights;
    if (spec.layers[0].medium) {
        const material::MediumSpec& m = *spec.layers[0].medium;
        const std::vector<double> beta = analytic_phase(m, 1e-3 * st.order_tolerance);
        const int channels = m.grey ? 1 : 3;
        for (int c = 0; c < channels; ++c) {
            SpectralOptics o;
            o.binder_index = (spec.surface.kind == material::Surface::Smooth && m.index) ? *m.index : 1.0;
            o.medium = {m.albedo[c], beta};
            o.g = m.g;
            optics.push_back(std::move(o));
            weights.push_back(m.grey ? Rgb{1.0, 1.0, 1.0} : Rgb{c == 0 ? 1.0 : 0.0, c == 1 ? 1.0 : 0.0, c == 2 ? 1.0 : 0.0});
        }
    } else {
        const auto wavelengths = spec.spectrum.wavelengths_nm();
        const auto rgb = spec.spectrum.rgb_weights();
        optics.resize(wavelengths.size());
        // Wavelengths are independent: split them over the cores.
        parallel_for(static_cast<int>(wavelengths.size()), available_cpus(),
                     [&](int k) { optics[k] = particulate_optics(spec, wavelengths[k], st.mie_tolerance); });
        if (spec.surface.kind == material::Surface::None)
            for (auto& o : optics) o.binder_index = 1.0;
        std::vector<Rgb> all(rgb.begin(), rgb.end());
        const SpectralSelection pick =
            select_wavelengths(optics, all, st.select_wavelengths ? st.tolerance : 0.0);
        std::vector<SpectralOptics> kept;
        for (std::size_t k : pick.solved) kept.push_back(std::move(optics[k]));
        optics = std::move(kept);
        weights = pick.weights;
        out.wavelengths_interpolated = all.size() - pick.solved.size();
    }
    // The spec's limit on the phase function's Legendre series (material::SpecLimits): the order
    // matrices and the table's Fourier sums grow with it. Known only now, from the optics.
    for (const SpectralOptics& o : optics)
        if (o.medium.beta.size() > spec.limits.max_legendre_terms)
            throw LimitError(cat(spec.source.empty() ? spec.name : spec.source,
                                 ": the phase function's Legendre series has ", o.medium.beta.size(),
                                 " terms", o.wavelength_nm > 0.0 ? cat(" at ", o.wavelength_nm, " nm") : "",
                                 ", more than the limit of ", spec.limits.max_legendre_terms,
                                 "; to override, set \"limits\": {\"max_legendre_terms\": ",
                                 o.medium.beta.size(), "} in the spec"));
    out.seconds.optics = seconds_since(t0);

    // 2. Streams: the table in settings_for is calibrated on isotropic scattering without an
    // interface. Forward-peaked phase functions (delta-M truncates more of them) and the split rule
    // under an interface need more: check convergence on the hardest samples and grow N until two
    // stream counts agree within the tolerance, or the cap is reached; the last difference is the
    // reported error estimate.
    t0 = std::chrono::steady_clock::now();
    rs.streams = choose_streams(optics, rs, st, out.error_estimate);
    out.settings.streams = rs.streams;
    if (out.error_estimate > st.tolerance)
        log::warn(spec.name, ": accuracy not reached at the stream cap (", st.max_streams, "): estimated error ",
                  out.error_estimate, " > tolerance ", st.tolerance,
                  " (a phase function too peaked for delta-M at this cost; see the report)");

    // 3. Every order of every sample in one batch.
    std::vector<rte::StackSetup> setups;
    std::vector<rte::OrderProblem> problems;
    for (const SpectralOptics& o : optics) {
        setups.push_back(rte::setup_reflection(o.medium, rte::Interface{o.binder_index}, rs));
        for (auto& p : rte::order_problems(setups.back())) problems.push_back(std::move(p));
    }
    std::vector<rte::OrderSolution> solutions;
    if (device == Device::OpenCL) {
        auto ctx = cl::Context::shared(); // throws DeviceError naming the fault
        out.device = "opencl: " + ctx->info().name;
        solutions = rte::solve_orders_opencl(problems, rs.method, rs.control);
    } else {
        out.device = "cpu";
        solutions = rte::solve_orders_cpu(problems, rs.method, rs.control, available_cpus());
    }
    std::size_t next = 0;
    for (std::size_t k = 0; k < setups.size(); ++k) {
        std::vector<rte::OrderSolution> mine(solutions.begin() + next, solutions.begin() + next + setups[k].orders);
        next += setups[k].orders;
        for (const auto& s : mine)
            if (!s.converged)
                log::warn(spec.name, ": order solve did not converge (residual ", s.residual, ")");
        out.samples.push_back(WavelengthSolution{optics[k].wavelength_nm, weights[k], optics[k],
                                     rte::Reflection(std::move(setups[k]), std::move(mine)), std::nullopt});
        if (spec.model == material::Model::Dipole) {
            const SpectralOptics& o = optics[k];
            out.samples.back().dipole.emplace(o.medium.omega, o.g, o.binder_index, o.medium.beta);
        }
    }
    out.seconds.solve = seconds_since(t0);
    if (!spec.layers[0].medium) fit_into_gamut(out);
    return out;
}

void fit_into_gamut(SolvedMaterial& m) {
    // A saturated pigment (CdS yellow, vermilion) reflects a colour outside the Rec.709 gamut: one
    // channel's albedo goes negative, another above 1. Renderers cannot use either, and clamping
    // per cell would break reciprocity and smoothness. Instead every colour weight is moved towards
    // its luminance by the same factor s (w' = Y + s (w - Y)): a linear map, so the table stays
    // exact in luminance and keeps its angular shape, with s as large as keeps the total
    // reflectance (diffuse + mirror) in [0, 1] at the report's incidence angles.
    const Rgb luma{0.2126, 0.7152, 0.0722};
    std::vector<std::array<double, 4>> reflectance; // per sample: at 0, 30, 60, 80 degrees
    for (const WavelengthSolution& s : m.samples) {
        std::array<double, 4> r{};
        const double angles[4] = {0.0, 30.0, 60.0, 80.0};
        for (int a = 0; a < 4; ++a) {
            const double mu = std::cos(angles[a] * std::numbers::pi / 180.0);
            r[a] = s.reflection.albedo(mu) + s.reflection.mirror(mu);
        }
        reflectance.push_back(r);
    }
    const auto channel = [&](double scale, int a, int c) {
        double v = 0.0;
        for (std::size_t k = 0; k < m.samples.size(); ++k) {
            const Rgb& w = m.samples[k].weight;
            const double y = luma[0] * w[0] + luma[1] * w[1] + luma[2] * w[2];
            v += (y + scale * (w[c] - y)) * reflectance[k][a];
        }
        return v;
    };
    const auto fits = [&](double scale) {
        for (int a = 0; a < 4; ++a)
            for (int c = 0; c < 3; ++c) {
                const double v = channel(scale, a, c);
                if (v < -1e-9 || v > 1.0 + 1e-9) return false; // energy is conserved to ~1e-12, not exactly
            }
        return true;
    };
    if (fits(1.0)) return;
    double lo = 0.0, hi = 1.0; // s = 0 is grey: in gamut whenever the luminance is
    for (int it = 0; it < 50; ++it) {
        const double mid = 0.5 * (lo + hi);
        (fits(mid) ? lo : hi) = mid;
    }
    for (WavelengthSolution& s : m.samples) {
        const double y = luma[0] * s.weight[0] + luma[1] * s.weight[1] + luma[2] * s.weight[2];
        for (double& w : s.weight) w = y + lo * (w - y);
    }
    m.gamut_scale = lo;
    log::info(m.spec.name, ": colour outside the Rec.709 gamut; chroma scaled by ", lo, " (luminance kept)");
}

Rgb SolvedMaterial::brdf(double theta_i, double theta_o, double phi) const {
    const double mi = std::cos(theta_i), mo = std::cos(theta_o);
    if (mi <= 0.0 || mo <= 0.0) return {0.0, 0.0, 0.0};
    return weighted(samples, [&](const WavelengthSolution& s) {
        return s.dipole ? s.dipole->brdf(mi, mo, phi) : s.reflection.brdf(mi, mo, phi);
    });
}

Rgb SolvedMaterial::albedo(double theta_i) const {
    const double mi = std::cos(theta_i);
    return weighted(samples, [&](const WavelengthSolution& s) { return s.dipole ? s.dipole->albedo(mi) : s.reflection.albedo(mi); });
}

Rgb SolvedMaterial::mirror(double theta_i) const {
    const double mi = std::cos(theta_i);
    return weighted(samples, [&](const WavelengthSolution& s) { return s.dipole ? s.dipole->mirror(mi) : s.reflection.mirror(mi); });
}

} // namespace brdf::model
