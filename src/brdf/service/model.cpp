#include <brdf/service/model.h>

#include <brdf/cl/context.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#if __has_include(<brdf/rte/cl_solver.h>) // TEMPORARY until the kernel lands
#include <brdf/rte/cl_solver.h>
#define BRDF_HAVE_CL_SOLVER 1
#endif

#include <chrono>
#include <cmath>
#include <thread>

namespace brdf::service {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int hardware_threads() { return std::max(1u, std::thread::hardware_concurrency()); }

Rgb weighted(const std::vector<Sample>& samples, auto&& value) {
    Rgb out{0.0, 0.0, 0.0};
    for (const Sample& s : samples) {
        const double v = value(s);
        for (int c = 0; c < 3; ++c) out[c] += s.weight[c] * v;
    }
    return out;
}

} // namespace

Settings settings_for(double tolerance) {
    // Streams from the measured isotropic error of Gauss-in-mu Nystrom evaluation
    // (docs/quadrature-study.md): 1e-3 at 8, 3e-4 at 16, 2e-5 at 32, 1.6e-6 at 48, 1e-7 at 64.
    Settings s;
    s.tolerance = tolerance;
    s.streams = tolerance >= 3e-3 ? 8 : tolerance >= 3e-4 ? 16 : tolerance >= 3e-5 ? 32 : tolerance >= 2e-6 ? 48 : 64;
    s.order_tolerance = 0.1 * tolerance;
    s.solver_tolerance = std::clamp(1e-4 * tolerance, 1e-13, 1e-8);
    s.mie_tolerance = std::clamp(0.1 * tolerance, 1e-7, 1e-3);
    s.table_grid = tolerance >= 3e-3 ? 46 : tolerance >= 3e-5 ? 91 : 181;
    return s;
}

SolvedMaterial solve_material(const material::MaterialSpec& spec, Device device) {
    SolvedMaterial out;
    out.spec = spec;
    out.settings = settings_for(spec.accuracy.tolerance);
    const Settings& st = out.settings;
    rte::ReflectionSettings rs;
    rs.streams = st.streams;
    rs.order_tolerance = st.order_tolerance;
    rs.method = st.method;
    rs.control.tolerance = st.solver_tolerance;

    // 1. Optics per wavelength (or per channel of an analytic medium).
    auto t0 = std::chrono::steady_clock::now();
    std::vector<SpectralOptics> optics;
    std::vector<Rgb> weights;
    if (spec.medium) {
        const material::MediumSpec& m = *spec.medium;
        const std::vector<double> beta = analytic_phase(m, 1e-3 * st.order_tolerance);
        const int channels = m.grey ? 1 : 3;
        for (int c = 0; c < channels; ++c) {
            SpectralOptics o;
            o.binder_index = (spec.surface == material::Surface::Smooth && m.index) ? *m.index : 1.0;
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
        const int threads = std::min<int>(hardware_threads(), static_cast<int>(wavelengths.size()));
        std::vector<std::exception_ptr> errors(static_cast<std::size_t>(threads));
        std::vector<std::thread> pool;
        for (int t = 0; t < threads; ++t)
            pool.emplace_back([&, t] {
                try {
                    for (std::size_t k = t; k < wavelengths.size(); k += threads)
                        optics[k] = particulate_optics(spec, wavelengths[k], st.mie_tolerance);
                } catch (...) {
                    errors[t] = std::current_exception();
                }
            });
        for (auto& th : pool) th.join();
        for (auto& e : errors)
            if (e) std::rethrow_exception(e);
        for (std::size_t k = 0; k < wavelengths.size(); ++k) weights.push_back(rgb[k]);
        if (spec.surface == material::Surface::None)
            for (auto& o : optics) o.binder_index = 1.0;
    }
    out.seconds.optics = seconds_since(t0);

    // 2. Every order of every sample in one batch.
    t0 = std::chrono::steady_clock::now();
    std::vector<rte::ReflectionSetup> setups;
    std::vector<rte::OrderProblem> problems;
    for (const SpectralOptics& o : optics) {
        setups.push_back(rte::setup_reflection(o.medium, rte::Interface{o.binder_index}, rs));
        for (auto& p : rte::order_problems(setups.back())) problems.push_back(std::move(p));
    }
    std::vector<rte::OrderSolution> solutions;
    if (device == Device::OpenCL) {
        auto ctx = cl::Context::shared(); // throws DeviceError naming the fault
        out.device = "opencl: " + ctx->info().name;
#ifdef BRDF_HAVE_CL_SOLVER
        solutions = rte::solve_orders_opencl(problems, rs.method, rs.control);
#else
        solutions = rte::solve_orders_cpu(problems, rs.method, rs.control, hardware_threads());
#endif
    } else {
        out.device = "cpu";
        solutions = rte::solve_orders_cpu(problems, rs.method, rs.control, hardware_threads());
    }
    std::size_t next = 0;
    for (std::size_t k = 0; k < setups.size(); ++k) {
        std::vector<rte::OrderSolution> mine(solutions.begin() + next, solutions.begin() + next + setups[k].orders);
        next += setups[k].orders;
        for (const auto& s : mine)
            if (!s.converged)
                log::warn(spec.name, ": order solve did not converge (residual ", s.residual, ")");
        out.samples.push_back(Sample{optics[k].wavelength_nm, weights[k], optics[k],
                                     rte::Reflection(std::move(setups[k]), std::move(mine))});
    }
    out.seconds.solve = seconds_since(t0);
    return out;
}

Rgb SolvedMaterial::brdf(double theta_i, double theta_o, double phi) const {
    const double mi = std::cos(theta_i), mo = std::cos(theta_o);
    if (mi <= 0.0 || mo <= 0.0) return {0.0, 0.0, 0.0};
    return weighted(samples, [&](const Sample& s) { return s.reflection.brdf(mi, mo, phi); });
}

Rgb SolvedMaterial::albedo(double theta_i) const {
    const double mi = std::cos(theta_i);
    return weighted(samples, [&](const Sample& s) { return s.reflection.albedo(mi); });
}

Rgb SolvedMaterial::mirror(double theta_i) const {
    const double mi = std::cos(theta_i);
    return weighted(samples, [&](const Sample& s) { return s.reflection.mirror(mi); });
}

} // namespace brdf::service
