// The rough air/binder interface (rte/rough_interface.h) against independent numbers: the
// microfacet closed forms against a physical Monte Carlo of facet reflection and refraction (own
// sampling, own Smith G1), the distributions' normalisation, the smooth limit (Fresnel), the
// directional albedos against Mitsuba 3's roughdielectric (tests/reference/rte/mitsuba_rough_slab.json,
// checks.bsdf_albedo), and the per-order kernels against brute-force adaptive quadrature over the
// microfacet normals.

#include <brdf/core/error.h>
#include <brdf/core/quadrature.h>
#include <brdf/core/threads.h>
#include <brdf/rte/adding.h>
#include <brdf/rte/rough_interface.h>
#include <test_support.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <functional>
#include <numbers>
#include <random>
#include <sched.h>
#include <sstream>

namespace brdf::test {
namespace {

using rte::Masking;
using rte::Microfacet;
using rte::RoughInterface;
using rte::RoughSurface;

constexpr double pi = std::numbers::pi;
constexpr double n_binder = 1.5;

RoughInterface ggx(double alpha, Masking masking = Masking::Separable) {
    return RoughInterface(n_binder, RoughSurface{alpha, Microfacet::Ggx, masking});
}

struct Vec {
    double x, y, z;
};
Vec operator+(Vec a, Vec b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec operator*(double s, Vec a) { return {s * a.x, s * a.y, s * a.z}; }
double dot(Vec a, Vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec direction(double mu, double phi) {
    const double s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
    return {s * std::cos(phi), s * std::sin(phi), mu};
}
Vec facet(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// Light arriving along -i (i points away from the surface, into the incident medium of index eta_i)
// refracted by facet h into the medium of index eta_o; nullopt-like: valid = false under TIR.
struct Refracted {
    bool valid;
    Vec o;
};
Refracted refract(Vec i, Vec h, double eta_i, double eta_o) {
    const double c = dot(i, h), eta = eta_i / eta_o;
    const double k = 1.0 - eta * eta * (1.0 - c * c);
    if (!(c > 0.0) || k < 0.0) return {false, {}};
    return {true, (-eta) * i + (eta * c - std::sqrt(k)) * h};
}

// Own Smith G1 for GGX (Walter et al. 2007 eq. 34) and own Fresnel (Born and Wolf 1.5.2).
double g1_ggx(double alpha, double mu) {
    const double t2 = (1.0 - mu * mu) / (mu * mu);
    return 2.0 / (1.0 + std::sqrt(1.0 + alpha * alpha * t2));
}
double fresnel_facet(double c, double eta_i, double eta_o) { return rte::fresnel(c, eta_i, eta_o); }

// Adaptive Gauss-Legendre (8 points, bisection until the two halves agree), vector valued.
using VecFn = std::function<void(double, double*)>;
void adaptive(const VecFn& f, double a, double b, int count, double tol, double* out, int depth = 0) {
    static const auto g = gauss_legendre(8);
    std::vector<double> whole(count, 0.0), left(count, 0.0), right(count, 0.0), v(count);
    auto rule = [&](double lo, double hi, std::vector<double>& acc) {
        const double h = 0.5 * (hi - lo), c = 0.5 * (hi + lo);
        for (std::size_t k = 0; k < g->size(); ++k) {
            f(c + h * g->x[k], v.data());
            for (int j = 0; j < count; ++j) acc[j] += h * g->w[k] * v[j];
        }
    };
    const double mid = 0.5 * (a + b);
    rule(a, b, whole);
    rule(a, mid, left);
    rule(mid, b, right);
    double diff = 0.0;
    for (int j = 0; j < count; ++j) diff = std::max(diff, std::abs(left[j] + right[j] - whole[j]));
    if (diff <= tol || depth > 24) {
        for (int j = 0; j < count; ++j) out[j] += left[j] + right[j];
        return;
    }
    adaptive(f, a, mid, count, 0.5 * tol, out, depth + 1);
    adaptive(f, mid, b, count, 0.5 * tol, out, depth + 1);
}

// Integral over the microfacet normals of GGX roughness alpha: tan theta_h = alpha tan u (the GGX
// measure D cos dw_h is then 2 sin u cos u du dphi / 2 pi, smooth), u in [0, pi/2) adaptively,
// phi_h in [0, pi] (mirror symmetry of an incident direction in the xz plane) by a fixed composite
// Gauss rule. The integrand gets the facet and dw_h (both halves of the azimuth).
void over_facets(double alpha, int count, double tol, const std::function<void(Vec, double, double*)>& f, double* out,
                 int phi_panels = 32) {
    const Quadrature qp = [&] {
        Quadrature q;
        const auto g = gauss_legendre(8);
        for (int p = 0; p < phi_panels; ++p)
            for (std::size_t k = 0; k < g->size(); ++k) {
                const double h = 0.5 * pi / phi_panels;
                q.x.push_back((2 * p + 1) * h + h * g->x[k]);
                q.w.push_back(h * g->w[k]);
            }
        return q;
    }();
    std::vector<double> v(count);
    adaptive(
        [&](double u, double* vu) {
            const double t = alpha * std::tan(u);
            const double theta = std::atan(t);
            const double dtheta = alpha / (std::cos(u) * std::cos(u) * (1.0 + t * t));
            for (int j = 0; j < count; ++j) vu[j] = 0.0;
            for (std::size_t k = 0; k < qp.size(); ++k) {
                std::fill(v.begin(), v.end(), 0.0);
                f(facet(theta, qp.x[k]), 2.0 * std::sin(theta) * dtheta * qp.w[k], v.data());
                for (int j = 0; j < count; ++j) vu[j] += v[j];
            }
        },
        0.0, 0.5 * pi, count, tol, out);
}

// ---------------------------------------------------------------------------------------------
// Closed forms.

TEST(RoughInterface, DistributionsAreNormalised) {
    for (Microfacet d : {Microfacet::Ggx, Microfacet::Beckmann})
        for (double alpha : {0.001, 0.01, 0.1, 0.5, 1.0}) {
            const RoughInterface s(n_binder, RoughSurface{alpha, d, Masking::HeightCorrelated});
            // int D cos dw with tan(theta_h) = alpha tan(u): dw = 2 pi sin dtheta.
            double sum = 0.0;
            adaptive(
                [&](double u, double* v) {
                    const double t = alpha * std::tan(u), th = std::atan(t);
                    const double dth = alpha / (std::cos(u) * std::cos(u) * (1.0 + t * t));
                    v[0] = s.distribution(std::cos(th)) * std::cos(th) * 2.0 * pi * std::sin(th) * dth;
                },
                0.0, 0.5 * pi, 1, 1e-11, &sum);
            EXPECT_NEAR(sum, 1.0, 1e-8) << "alpha " << alpha << (d == Microfacet::Ggx ? " GGX" : " Beckmann");
        }
}

TEST(RoughInterface, NearlySmoothSurfaceReflectsFresnelAndConservesEnergy) {
    const RoughInterface s = ggx(0.001);
    for (double mu : {1.0, 0.7, 0.3}) {
        const Vec i = direction(mu, 0.0);
        double sums[2] = {0.0, 0.0}; // reflected, transmitted (energy)
        over_facets(0.001, 2, 1e-9, [&](Vec h, double dwh, double* v) {
            const double c = dot(i, h);
            if (!(c > 0.0)) return;
            const Vec o = (2.0 * c) * h + (-1.0) * i;
            if (o.z > 0.0) // dw_o = 4 (i.h) dw_h (Walter eq. 14)
                v[0] = s.f_reflect_air(mu, o.z, std::atan2(o.y, o.x)) * o.z * 4.0 * c * dwh;
            const Refracted t = refract(i, h, 1.0, n_binder);
            if (t.valid && t.o.z < 0.0) { // dw_o = (i.h + n o.h)^2 / (n^2 |o.h|) dw_h (eq. 17)
                const double oh = dot(t.o, h), den = c + n_binder * oh;
                const double f = s.f_transmit_down(mu, -t.o.z, std::atan2(t.o.y, t.o.x));
                v[1] = f * -t.o.z * den * den / (n_binder * n_binder * std::abs(oh)) * dwh;
            }
        }, sums);
        const double fresnel = rte::fresnel(mu, 1.0, n_binder);
        EXPECT_NEAR(sums[0], fresnel, 2e-5) << "mu " << mu;
        EXPECT_NEAR(sums[0] + sums[1], 1.0, 2e-5) << "mu " << mu;
    }
}

// Physical Monte Carlo of Walter's construction: the flux falling on facets with normal in dw_h is
// D(h) (i.h) / mu_i dw_h; a facet reflects F and transmits 1 - F into the mirror or the Snell
// direction, and G1 G1 of it escapes (separable Smith). The flux into a cone C around a direction
// must equal the closed form's int_C f |cos| dw (radiance form: its n^2 and the solid-angle
// compression of the refraction cancel in the flux).
TEST(RoughInterface, ClosedFormsMatchMicrofacetMonteCarlo) {
    constexpr int samples = 1000000;
    const double alpha = 0.3;
    const RoughInterface s = ggx(alpha);
    struct Case {
        bool transmit;
        double mu_i, theta_c, phi_c; // cone centre (outgoing, pointing away from the surface)
    };
    const Case cases[] = {{false, 0.8, 0.7, pi}, {false, 0.4, 1.0, pi}, {true, 0.8, 0.45, pi}, {true, 0.5, 0.5, 2.6}};
    const double radius = 0.12; // cone half angle (rad)
    std::mt19937_64 rng(20071);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (const Case& c : cases) {
        const Vec i = direction(c.mu_i, 0.0);
        const Vec centre = facet(c.theta_c, c.phi_c);
        const Vec axis = c.transmit ? Vec{centre.x, centre.y, -centre.z} : centre;
        double sum = 0.0, sum2 = 0.0;
        for (int k = 0; k < samples; ++k) {
            // h with pdf D(h) cos(theta_h): tan^2 theta_h = alpha^2 xi / (1 - xi).
            const double xi = uni(rng), th = std::atan(alpha * std::sqrt(xi / (1.0 - xi))), ph = 2.0 * pi * uni(rng);
            const Vec h = facet(th, ph);
            const double ih = dot(i, h);
            if (!(ih > 0.0)) continue;
            double w = ih / (c.mu_i * h.z) * g1_ggx(alpha, c.mu_i);
            Vec o;
            if (c.transmit) {
                const Refracted t = refract(i, h, 1.0, n_binder);
                if (!t.valid || !(t.o.z < 0.0)) continue;
                o = t.o;
                w *= (1.0 - fresnel_facet(ih, 1.0, n_binder)) * g1_ggx(alpha, -o.z);
            } else {
                o = (2.0 * ih) * h + (-1.0) * i;
                if (!(o.z > 0.0)) continue;
                w *= fresnel_facet(ih, 1.0, n_binder) * g1_ggx(alpha, o.z);
            }
            if (dot(o, axis) < std::cos(radius)) continue;
            sum += w;
            sum2 += w * w;
        }
        const double mean = sum / samples, se = std::sqrt((sum2 / samples - mean * mean) / samples);
        // The closed form over the cone: polar coordinates (r, psi) around its axis.
        const Vec e1 = facet(c.theta_c + 0.5 * pi, c.phi_c);
        const Vec e2{-std::sin(c.phi_c), std::cos(c.phi_c), 0.0};
        const Quadrature qr = gauss_legendre(48, 0.0, radius), qp = gauss_legendre(96, 0.0, 2.0 * pi);
        double exact = 0.0;
        for (std::size_t a = 0; a < qr.size(); ++a)
            for (std::size_t b = 0; b < qp.size(); ++b) {
                const double r = qr.x[a], p = qp.x[b];
                const Vec o = std::cos(r) * centre + (std::sin(r) * std::cos(p)) * e1 + (std::sin(r) * std::sin(p)) * e2;
                const double phi = std::atan2(o.y, o.x);
                const double f = c.transmit ? s.f_transmit_down(c.mu_i, o.z, phi)
                                            : s.f_reflect_air(c.mu_i, o.z, phi);
                exact += qr.w[a] * qp.w[b] * std::sin(r) * f * o.z;
            }
        EXPECT_NEAR(mean, exact, 4.0 * se + 1e-6)
            << c.theta_c << " " << (c.transmit ? "transmission" : "reflection") << " mu_i " << c.mu_i << " se " << se;
        EXPECT_LT(se, 0.01 * exact);
    }
}

TEST(RoughInterface, ClosedFormsAreReciprocal) {
    for (double alpha : {0.01, 0.1, 0.5})
        for (Masking mk : {Masking::Separable, Masking::HeightCorrelated}) {
            const RoughInterface s = ggx(alpha, mk);
            for (double a : {0.95, 0.6, 0.2})
                for (double b : {0.9, 0.75, 0.4})
                    for (double phi : {pi, 2.8, 2.0}) {
                        EXPECT_REL_NEAR(s.f_reflect_air(a, b, phi), s.f_reflect_air(b, a, phi), 1e-12);
                        EXPECT_REL_NEAR(s.f_reflect_inside(a, b, phi), s.f_reflect_inside(b, a, phi), 1e-12);
                        // Radiance BSDFs across an interface: f_t(wi -> wo) / n_o^2 = f_t(wo -> wi) / n_i^2.
                        const double down = s.f_transmit_down(a, b, phi), up = s.f_transmit_up(b, a, phi);
                        EXPECT_NEAR(down / (n_binder * n_binder), up, 1e-12 * std::max(1.0, up));
                    }
        }
}

TEST(RoughInterface, MaskingFormsOrderAndAgreeAtNormalIncidence) {
    const RoughInterface hc = ggx(0.3, Masking::HeightCorrelated), sep = ggx(0.3, Masking::Separable);
    for (double a : {0.9, 0.5, 0.1})
        for (double b : {0.8, 0.3, 0.05}) {
            // Reflection: 1 / (1 + L + L) >= 1 / ((1 + L)(1 + L)); transmission: the Beta function is
            // below the product (Chebyshev's integral inequality).
            EXPECT_GE(hc.masking_reflect(a, b), sep.masking_reflect(a, b));
            EXPECT_LE(hc.masking_transmit(a, b), sep.masking_transmit(a, b));
        }
    for (double b : {0.9, 0.3})
        EXPECT_NEAR(hc.masking_transmit(1.0, b), sep.masking_transmit(1.0, b), 1e-14);
    EXPECT_NEAR(hc.albedo_from_air(1.0).total(), sep.albedo_from_air(1.0).total(), 1e-9);
    // At grazing incidence from inside the forms differ by a few 1e-3 (0.8832 vs 0.8798 at alpha 0.1).
    const double graze = std::cos(80.0 * pi / 180.0);
    const double d = ggx(0.1, Masking::HeightCorrelated).albedo_from_inside(graze).total() -
                     ggx(0.1, Masking::Separable).albedo_from_inside(graze).total();
    EXPECT_GT(d, 1e-3);
    EXPECT_LT(d, 1e-2);
}

// Mitsuba 3 roughdielectric's energy albedos (importance mode, 8.4e6 samples a value).
TEST(RoughInterface, AlbedosMatchMitsuba) {
    std::ifstream in(source_dir() / "tests/reference/rte/mitsuba_rough_slab.json");
    ASSERT_TRUE(in) << "reference missing";
    const auto j = nlohmann::json::parse(in);
    int rows = 0;
    for (const auto& row : j.at("checks").at("bsdf_albedo").at("rows")) {
        const double alpha = row.at("alpha"), mu = std::cos(double(row.at("theta_deg")) * pi / 180.0);
        const bool inside = row.at("side") == "inside";
        const auto& e = row.at("energy");
        const RoughInterface s = ggx(alpha, Masking::Separable);
        const RoughInterface::Albedo a = inside ? s.albedo_from_inside(mu) : s.albedo_from_air(mu);
        EXPECT_NEAR(a.reflected, double(e.at("r")), 3.0 * double(e.at("r_se")) + 2e-5) << row.dump();
        EXPECT_NEAR(a.transmitted, double(e.at("t")), 3.0 * double(e.at("t_se")) + 2e-5) << row.dump();
        ++rows;
    }
    EXPECT_EQ(rows, 12);
}

// ---------------------------------------------------------------------------------------------
// Per-order kernels.

rte::StreamPieces pieces_16(const RoughInterface& s) { return rte::split_gauss_pieces(16, 16, s.critical()); }

TEST(RoughInterface, AirReflectionOrdersSumToTheClosedForm) {
    for (double alpha : {0.3, 0.5}) {
        const RoughInterface s = ggx(alpha, Masking::HeightCorrelated);
        const std::vector<double> mu{0.93, 0.61, 0.27};
        const int orders = 96;
        const auto k = rte::air_reflection_orders(s, mu, orders, 1e-7);
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
                for (double phi : {pi, 2.5, 1.0, 0.0}) {
                    double sum = 0.0;
                    for (int m = 0; m < orders; ++m)
                        sum += (m == 0 ? 1.0 : 2.0) * k[m](a, b) * std::cos(m * (phi + pi));
                    const double f = s.f_reflect_air(mu[b], mu[a], phi);
                    EXPECT_NEAR(sum / pi, f, 1e-6 * std::max(1.0, f)) << alpha << " " << mu[a] << " " << mu[b] << " " << phi;
                }
    }
}

// The kernels are computed on every core (for_each_on_cores: directions one per core, the internal
// reflection's incident nodes in a fixed number of runs summed in order): on one CPU they are the
// same, bit for bit, so tables do not depend on the machine's core count.
TEST(RoughInterface, KernelsDoNotDependOnTheCoreCount) {
    if (available_cpus() < 2) GTEST_SKIP() << "needs at least 2 CPUs to compare with 1";
    const RoughInterface s = ggx(0.1, Masking::HeightCorrelated);
    const rte::StreamPieces sp = pieces_16(s);
    const std::vector<double> air{0.95, 0.7, 0.3, 0.05};
    const auto all = rte::interface_kernels(s, sp, air, 12, 1e-7);
    cpu_set_t mask, one;
    ASSERT_EQ(sched_getaffinity(0, sizeof mask, &mask), 0);
    CPU_ZERO(&one);
    for (int c = 0; c < CPU_SETSIZE; ++c)
        if (CPU_ISSET(c, &mask)) {
            CPU_SET(c, &one);
            break;
        }
    ASSERT_EQ(sched_setaffinity(0, sizeof one, &one), 0);
    const int cpus = available_cpus();
    const auto single = rte::interface_kernels(s, sp, air, 12, 1e-7);
    ASSERT_EQ(sched_setaffinity(0, sizeof mask, &mask), 0);
    ASSERT_EQ(cpus, 1);
    const auto same = [](const std::vector<Matrix>& a, const std::vector<Matrix>& b) {
        if (a.size() != b.size()) return false;
        for (std::size_t m = 0; m < a.size(); ++m)
            if (!std::ranges::equal(a[m].data(), b[m].data())) return false;
        return true;
    };
    EXPECT_TRUE(same(all.t_down, single.t_down));
    EXPECT_TRUE(same(all.t_up, single.t_up));
    EXPECT_TRUE(same(all.r_inside, single.r_inside));
    EXPECT_EQ(all.quadrature.nodes, single.quadrature.nodes);
    EXPECT_GT(all.quadrature.nodes, 0);
}

TEST(RoughInterface, WideTransmissionOrdersSumToTheClosedForm) {
    // For a wide lobe the product-integrated column is the kernel at the node to Gauss accuracy.
    const RoughInterface s = ggx(0.5, Masking::HeightCorrelated);
    const rte::StreamPieces sp = pieces_16(s);
    const std::vector<double> air{0.9, 0.55};
    const int orders = 48;
    const auto k = rte::interface_kernels(s, sp, air, orders, 1e-8);
    double worst = 0.0;
    for (int e = 0; e < 2; ++e)
        for (int i = 16; i < sp.streams.size(); i += 3) // above the critical cosine: smooth in mu
            for (double phi : {pi, 2.0, 0.5}) {
                double sum = 0.0;
                for (int m = 0; m < orders; ++m)
                    sum += (m == 0 ? 1.0 : 2.0) * k.t_up[m](e, i) * std::cos(m * (phi + pi));
                const double f = s.f_transmit_up(sp.streams.mu[i], air[e], phi);
                worst = std::max(worst, std::abs(sum / pi - f) / std::max(f, 0.05));
            }
    // Point value against the Lagrange projection: Gauss error of a kernel that is not a polynomial
    // (measured 4.0e-2 at 16 nodes a piece); the sum over orders itself is what is tested.
    EXPECT_LT(worst, 6e-2);
}

// sum_k X(k, e) q_k g(mu_k) = int K^m(mu, u_e) g(mu) 2 mu dmu, brute force over the facets:
// int f(i -> o) g(mu_o) cos(m phi_rt) mu_o dw_o.
TEST(RoughInterface, ProductIntegrationIsExactForSmoothFunctions) {
    const std::array<int, 4> ms{0, 1, 4, 12};
    const std::vector<std::function<double(double)>> gs{[](double) { return 1.0; },
                                                        [](double x) { return std::pow(x, 7); },
                                                        [](double x) { return std::exp(x); }};
    const int count = static_cast<int>(ms.size() * gs.size());
    for (double alpha : {0.001, 0.01, 0.1, 0.5}) {
        const RoughInterface s = ggx(alpha, Masking::HeightCorrelated);
        const rte::StreamPieces sp = pieces_16(s);
        const std::vector<double> air{0.92, 0.5, 0.15};
        const auto k = rte::interface_kernels(s, sp, air, 13, 1e-10);
        for (std::size_t e = 0; e < air.size(); ++e) {
            const Vec i = direction(air[e], 0.0);
            std::vector<double> brute(count, 0.0);
            over_facets(alpha, count, 1e-12, [&](Vec h, double dwh, double* v) {
                const Refracted t = refract(i, h, 1.0, n_binder);
                if (!t.valid || !(t.o.z < 0.0)) return;
                const double ih = dot(i, h), oh = dot(t.o, h), den = ih + n_binder * oh;
                const double phi = std::atan2(t.o.y, t.o.x), mu_o = -t.o.z;
                const double w = s.f_transmit_down(air[e], mu_o, phi) * mu_o * den * den /
                                 (n_binder * n_binder * std::abs(oh)) * dwh;
                for (std::size_t a = 0; a < ms.size(); ++a)
                    for (std::size_t b = 0; b < gs.size(); ++b)
                        v[a * gs.size() + b] = w * std::cos(ms[a] * (phi + pi)) * gs[b](mu_o);
            }, brute.data());
            for (std::size_t a = 0; a < ms.size(); ++a)
                for (std::size_t b = 0; b < gs.size(); ++b) {
                    double sum = 0.0, up = 0.0;
                    for (int j = 0; j < sp.streams.size(); ++j) {
                        const double q = 2.0 * sp.streams.w[j] * sp.streams.mu[j];
                        sum += k.t_down[ms[a]](j, e) * q * gs[b](sp.streams.mu[j]);
                        up += k.t_up[ms[a]](e, j) * q * gs[b](sp.streams.mu[j]);
                    }
                    const double ref = brute[a * gs.size() + b];
                    EXPECT_NEAR(sum, ref, 1e-8) << "alpha " << alpha << " u " << air[e] << " m " << ms[a] << " g " << b;
                    EXPECT_NEAR(up, ref / (n_binder * n_binder), 1e-8);
                }
        }
    }
}

TEST(RoughInterface, KernelsAreReciprocal) {
    for (double alpha : {0.001, 0.1, 0.5}) {
        const RoughInterface s = ggx(alpha);
        const rte::StreamPieces sp = pieces_16(s);
        const std::vector<double> air{1.0, 0.7, 0.3, 0.05};
        const auto k = rte::interface_kernels(s, sp, air, 8, 1e-6);
        for (int m = 0; m < 8; ++m) {
            double scale = max_abs(k.t_down[m]);
            for (int e = 0; e < 4; ++e)
                for (int j = 0; j < sp.streams.size(); ++j)
                    EXPECT_NEAR(k.t_up[m](e, j) * n_binder * n_binder, k.t_down[m](j, e), 1e-10 * scale);
            EXPECT_LE(max_abs_diff(k.r_inside[m], transpose(k.r_inside[m])), 1e-10 * max_abs(k.r_inside[m]));
        }
    }
}

// Order 0 contracted with 1: the directional albedos (reflected and transmitted) of item 2.
TEST(RoughInterface, OrderZeroAlbedosMatchDirectIntegration) {
    for (double alpha : {0.001, 0.1, 0.5}) {
        const RoughInterface s = ggx(alpha, Masking::HeightCorrelated);
        const rte::StreamPieces sp = pieces_16(s);
        const std::vector<double> air{0.95, 0.6, 0.2};
        const auto k = rte::interface_kernels(s, sp, air, 1, 1e-9);
        for (std::size_t e = 0; e < air.size(); ++e) {
            double t = 0.0;
            for (int j = 0; j < sp.streams.size(); ++j) t += k.t_down[0](j, e) * 2.0 * sp.streams.w[j] * sp.streams.mu[j];
            EXPECT_NEAR(t, s.albedo_from_air(air[e]).transmitted, 1e-6) << alpha << " " << air[e];
        }
    }
}

TEST(RoughInterface, RejectsBadArguments) {
    EXPECT_THROW(RoughInterface(1.0, RoughSurface{}), InputError);
    EXPECT_THROW(RoughInterface(1.5, RoughSurface{0.0005}), InputError);
    EXPECT_THROW(RoughInterface(1.5, RoughSurface{std::nan("")}), InputError);
    const RoughInterface s = ggx(0.1);
    EXPECT_THROW(s.albedo_from_air(0.0), InputError);
    EXPECT_THROW(s.albedo_from_air(0.5, 1.0), InputError);
    const rte::StreamPieces sp = pieces_16(s);
    const double bad[] = {1.5};
    EXPECT_THROW(rte::interface_kernels(s, sp, bad, 4), InputError);
    EXPECT_THROW(rte::interface_kernels(s, sp, {}, 0), InputError);
}

} // namespace
} // namespace brdf::test
