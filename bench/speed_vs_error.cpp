// Speed against error (docs/speed-vs-error.md): wall time and BRDF relative error of every way we can
// compute a BRDF, on analytic media and on the example catalogue.
//
// Cases: analytic media (isotropic and Henyey-Greenstein g = 0.5, 0.9, 0.99; omega = 0.9, 0.999, 1;
// surface none) and the particulate materials of examples/catalogue.json with spectrum "rgb".
// Methods:
//   ours-draft / ours-default / ours-reference  model::solve_material at that accuracy
//                                                (Method::Fast; the whole pipeline, optics included)
//   fixed-point   the seed paper's plain fixed-point iteration (Method::FixedPoint) at the default
//                 accuracy's streams, capped at --max-iterations per order; "converged" says if every
//                 order converged within the cap
//   doubling      structure-preserving doubling (Method::Doubling) at the default accuracy's streams
//   dipole        Jensen et al. 2001 dipole diffusion + single scattering (rte/dipole.h)
// fixed-point, doubling and dipole run on the optics of the default solve and add its optics time.
// Error: the largest relative difference over theta_i, theta_o in {0, 30, 60, 80} degrees,
// phi in {0, 90, 180} and the three colour channels, against a reference solve at tolerance 1e-7 with 96 streams
// (for isotropic scattering the reference itself is checked against Chandrasekhar's exact H-function
// solution where tests/reference/rte/chandrasekhar_h.json has the angles, printed to stderr).
// Output: CSV on stdout or to --csv FILE; --reference-json FILE writes the reference values (for the
// DISORT rows that bench/speed_vs_error.py adds). Run via tools/dev/speed-vs-error.sh.

#include <brdf/material/spec.h>
#include <brdf/rte/dipole.h>
#include <brdf/rte/reflection.h>
#include <brdf/model/model.h>
#include <brdf/model/optics.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <numbers>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace brdf;
using model::Rgb;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
const double kThetas[] = {0.0, 30.0, 60.0, 80.0};
const double kPhis[] = {0.0, 90.0, 180.0};

using Values = std::vector<Rgb>; // 48 angle triples

template <class F> Values at_angles(F&& brdf) {
    Values out;
    for (double ti : kThetas)
        for (double to : kThetas)
            for (double ph : kPhis) out.push_back(brdf(ti * kDeg, to * kDeg, ph * kDeg));
    return out;
}

double max_rel_error(const Values& got, const Values& ref) {
    double worst = 0.0;
    for (std::size_t k = 0; k < ref.size(); ++k)
        for (int c = 0; c < 3; ++c) {
            const double r = ref[k][c];
            if (std::abs(r) < 1e-300) continue;
            worst = std::max(worst, std::abs(got[k][c] - r) / std::abs(r));
        }
    return worst;
}

double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

int threads() { return std::max(1u, std::thread::hardware_concurrency()); }

struct Row {
    std::string kase, kind, method;
    int streams = 0;
    double seconds = 0.0, error = 0.0;
    bool converged = true;
    std::string note;
};

std::string csv_line(const Row& r) {
    char buf[512];
    std::snprintf(buf, sizeof buf, "%s,%s,%s,%d,%.6g,%.3e,%s,%s", r.kase.c_str(), r.kind.c_str(), r.method.c_str(),
                  r.streams, r.seconds, r.error, r.converged ? "yes" : "no", r.note.c_str());
    return buf;
}

material::MaterialSpec with_accuracy(nlohmann::json doc, const nlohmann::json& accuracy) {
    doc["accuracy"] = accuracy;
    return material::parse_specs(doc, "bench")[0];
}

// Solves every sample's reflection with `method` on the default solve's optics (the same streams
// and order truncation) and evaluates the colour BRDF.
Row rte_method(const model::SolvedMaterial& base, rte::Method method, int max_iterations, const Values& ref) {
    Row row;
    row.method = method == rte::Method::FixedPoint ? "fixed-point" : "doubling";
    row.streams = base.settings.streams;
    const double t0 = now();
    rte::ReflectionSettings rs;
    rs.streams = base.settings.streams;
    rs.order_tolerance = base.settings.order_tolerance;
    rs.method = method;
    rs.control.tolerance = base.settings.solver_tolerance;
    rs.control.max_iterations = max_iterations;
    std::vector<rte::Reflection> refl;
    int unconverged = 0, orders = 0;
    for (const model::WavelengthSolution& s : base.samples) {
        rte::StackSetup setup = rte::setup_reflection(model::make_stack(s.optics, base.spec.surface), rs);
        const auto problems = rte::order_problems(setup);
        auto sol = rte::solve_orders_cpu(problems, method, rs.control, threads());
        for (const auto& o : sol) unconverged += o.converged ? 0 : 1;
        orders += static_cast<int>(sol.size());
        refl.emplace_back(std::move(setup), std::move(sol));
    }
    const Values v = at_angles([&](double ti, double to, double ph) {
        Rgb out{0, 0, 0};
        for (std::size_t k = 0; k < refl.size(); ++k) {
            const double b = refl[k].brdf(std::cos(ti), std::cos(to), ph);
            for (int c = 0; c < 3; ++c) out[c] += base.samples[k].weight[c] * b;
        }
        return out;
    });
    row.seconds = now() - t0 + base.seconds.optics;
    row.error = max_rel_error(v, ref);
    row.converged = unconverged == 0;
    if (unconverged) row.note = std::to_string(unconverged) + " of " + std::to_string(orders) + " orders hit the cap";
    return row;
}

Row dipole_method(const model::SolvedMaterial& base, const Values& ref) {
    Row row;
    row.method = "dipole";
    const double t0 = now();
    std::vector<rte::Dipole> d;
    for (const model::WavelengthSolution& s : base.samples)
        d.emplace_back(s.optics.top().medium.omega, s.optics.top().g, s.reflection.setup().layers[0].index, s.optics.top().medium.beta);
    const Values v = at_angles([&](double ti, double to, double ph) {
        Rgb out{0, 0, 0};
        for (std::size_t k = 0; k < d.size(); ++k) {
            const double b = d[k].brdf(std::cos(ti), std::cos(to), ph);
            for (int c = 0; c < 3; ++c) out[c] += base.samples[k].weight[c] * b;
        }
        return out;
    });
    row.seconds = now() - t0 + base.seconds.optics;
    row.error = max_rel_error(v, ref);
    return row;
}

// Chandrasekhar's exact isotropic solution at the reference angles it tabulates (0, 30, 60 degrees).
void check_isotropic_reference(double omega, const model::SolvedMaterial& ref) {
    std::ifstream in(std::string(BRDF_SOURCE_DIR) + "/tests/reference/rte/chandrasekhar_h.json");
    if (!in) return;
    const auto j = nlohmann::json::parse(in);
    for (const auto& c : j["cases"]) {
        if (c["omega"].get<double>() != omega) continue;
        const std::vector<double> mu = c["mu"], h = c["h"];
        double worst = 0.0;
        for (std::size_t a = 0; a < mu.size(); ++a)
            for (std::size_t b = 0; b < mu.size(); ++b) {
                if (mu[a] < 0.4 || mu[b] < 0.4) continue; // 0, 30, 60 degrees
                const double exact = 0.25 * omega * h[a] * h[b] / (mu[a] + mu[b]) / std::numbers::pi;
                const double got = ref.brdf(std::acos(mu[a]), std::acos(mu[b]), 1.0)[0];
                worst = std::max(worst, std::abs(got - exact) / exact);
            }
        std::fprintf(stderr, "  reference vs Chandrasekhar (omega %g): max rel error %.2e\n", omega, worst);
    }
}

nlohmann::json g_reference = nlohmann::json::object(); // case -> [[theta_i, theta_o, phi, r, g, b], ...]

void run_case(const std::string& name, const std::string& kind, const nlohmann::json& doc, int max_iterations,
              std::vector<Row>& rows) {
    std::fprintf(stderr, "%s\n", name.c_str());
    const auto solve = [&](const nlohmann::json& accuracy, double& seconds) {
        const material::MaterialSpec spec = with_accuracy(doc, accuracy);
        const double t0 = now();
        model::SolvedMaterial m = model::solve_material(spec, model::Device::Cpu);
        seconds = now() - t0;
        return m;
    };
    // The reference: 96 streams, fixed (the convergence check would grow forward-peaked cases to
    // 128 streams and hundreds of orders, minutes each); tight order and iteration tolerances.
    double tref = 0.0;
    const model::SolvedMaterial ref = [&] {
        const material::MaterialSpec spec = with_accuracy(doc, nlohmann::json{{"tolerance", 1e-7}});
        model::NumericalSettings st = model::settings_for(1e-7);
        st.streams = st.max_streams = 96;
        const double t0 = now();
        model::SolvedMaterial m = model::solve_material(spec, model::Device::Cpu, st);
        tref = now() - t0;
        return m;
    }();
    const Values vref = at_angles([&](double ti, double to, double ph) { return ref.brdf(ti, to, ph); });
    {
        nlohmann::json values = nlohmann::json::array();
        std::size_t k = 0;
        for (double ti : kThetas)
            for (double to : kThetas)
                for (double ph : kPhis) {
                    values.push_back({ti, to, ph, vref[k][0], vref[k][1], vref[k][2]});
                    ++k;
                }
        g_reference[name] = {{"spec", doc}, {"values", values}};
    }
    if (doc.contains("medium") && doc["medium"]["phase"]["type"] == "isotropic")
        check_isotropic_reference(doc["medium"]["albedo"].get<double>(), ref);
    const auto add = [&](Row r) {
        r.kase = name;
        r.kind = kind;
        std::fprintf(stderr, "  %-15s %8.4f s  error %.2e%s\n", r.method.c_str(), r.seconds, r.error,
                     r.converged ? "" : "  (NOT CONVERGED)");
        rows.push_back(std::move(r));
    };
    Row rr;
    rr.method = "reference-1e-7";
    rr.streams = ref.settings.streams;
    rr.seconds = tref;
    add(rr);
    model::SolvedMaterial base;
    for (const char* level : {"draft", "default", "reference"}) {
        double t = 0.0;
        model::SolvedMaterial m = solve(level, t);
        const Values v = at_angles([&](double ti, double to, double ph) { return m.brdf(ti, to, ph); });
        Row r;
        r.method = std::string("ours-") + level;
        r.streams = m.settings.streams;
        r.seconds = t;
        r.error = max_rel_error(v, vref);
        add(r);
        if (std::string(level) == "default") base = std::move(m);
    }
    add(rte_method(base, rte::Method::FixedPoint, max_iterations, vref));
    add(rte_method(base, rte::Method::Doubling, max_iterations, vref));
    add(dipole_method(base, vref));
}

std::string fmt(double x) {
    std::ostringstream s;
    s << x;
    return s.str();
}

} // namespace

int main(int argc, char** argv) {
    std::string csv_path, reference_path, catalogue = std::string(BRDF_SOURCE_DIR) + "/examples/catalogue.json";
    int max_iterations = 20000;
    bool analytic = true, particulate = true;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--csv" && i + 1 < argc) csv_path = argv[++i];
        else if (a == "--reference-json" && i + 1 < argc) reference_path = argv[++i];
        else if (a == "--catalogue" && i + 1 < argc) catalogue = argv[++i];
        else if (a == "--max-iterations" && i + 1 < argc) max_iterations = std::stoi(argv[++i]);
        else if (a == "--analytic-only") particulate = false;
        else if (a == "--catalogue-only") analytic = false;
        else {
            std::fprintf(stderr,
                         "usage: speed_vs_error [--csv FILE] [--reference-json FILE] [--catalogue FILE] [--max-iterations N] "
                         "[--analytic-only | --catalogue-only]\n");
            return 2;
        }
    }
    std::vector<Row> rows;
    try {
        if (analytic) {
            struct Phase {
                std::string label;
                nlohmann::json json;
            };
            const std::vector<Phase> phases = {
                {"iso", {{"type", "isotropic"}}},
                {"hg0.5", {{"type", "henyey_greenstein"}, {"g", 0.5}}},
                {"hg0.9", {{"type", "henyey_greenstein"}, {"g", 0.9}}},
                {"hg0.99", {{"type", "henyey_greenstein"}, {"g", 0.99}}},
            };
            for (const Phase& p : phases)
                for (double omega : {0.9, 0.999, 1.0}) {
                    const std::string name = p.label + "-w" + fmt(omega);
                    const nlohmann::json doc = {{"name", name},
                                                {"medium", {{"albedo", omega}, {"phase", p.json}}},
                                                {"surface", "none"}};
                    run_case(name, "analytic", doc, max_iterations, rows);
                }
        }
        if (particulate) {
            std::ifstream in(catalogue);
            if (!in) throw std::runtime_error("cannot read " + catalogue);
            const auto cat = nlohmann::json::parse(in);
            const nlohmann::json defaults = cat.value("defaults", nlohmann::json::object());
            for (const auto& m : cat["materials"]) {
                if (m.contains("medium")) continue; // analytic: covered above
                nlohmann::json doc = defaults;
                for (auto it = m.begin(); it != m.end(); ++it) doc[it.key()] = it.value();
                doc["spectrum"] = "rgb";
                doc.erase("outputs");
                run_case(doc["name"].get<std::string>(), "catalogue", doc, max_iterations, rows);
            }
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "speed_vs_error: %s\n", e.what());
        return 1;
    }
    std::ofstream file;
    if (!csv_path.empty()) file.open(csv_path);
    std::ostream& out = csv_path.empty() ? std::cout : file;
    out << "case,kind,method,streams,seconds,max_rel_error,converged,note\n";
    for (const Row& r : rows) out << csv_line(r) << "\n";
    if (!reference_path.empty()) std::ofstream(reference_path) << g_reference.dump(1) << "\n";
    return 0;
}
