// The rough air/binder interface: closed forms, albedos and the per-order kernels (see the header).
//
// Formulas (Walter, Marschner, Li and Torrance 2007, EGSR; "Walter" below):
//   D_GGX(h)      = alpha^2 / (pi cos^4 (alpha^2 + tan^2)^2)                       (eq. 33)
//   D_Beckmann(h) = exp(-tan^2 / alpha^2) / (pi alpha^2 cos^4)                       (eq. 25)
//   Lambda_GGX(mu)      = (sqrt(1 + alpha^2 tan^2) - 1) / 2                          (G1 of eq. 34)
//   Lambda_Beckmann(mu) = (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)),
//                         a = 1 / (alpha tan)                                        (G1 of eq. 27, exact)
//   f_r = F(i.h) G D / (4 |i.n| |o.n|),  h = (i + o) / |i + o|                       (eqs. 13, 20)
//   f_t = |i.h| |o.h| / (|i.n| |o.n|) n_o^2 (1 - F(i.h)) G D / (n_i i.h + n_o o.h)^2,
//         h = -(n_i i + n_o o) / |...|, i.h > 0 > o.h, h.n > 0                      (eqs. 16, 21)
// Masking (Heitz 2014, JCGT 3(2)): separable G = G1(i) G1(o) (eq. 98); height-correlated for
// reflection G = 1 / (1 + Lambda(i) + Lambda(o)) (eq. 99). For transmission the height-correlated
// form (section 6.2) follows from the same Smith construction: at a height with cumulative height
// distribution C the incident ray from above is unshadowed with probability C^Lambda(i) and the
// transmitted ray below is unmasked with probability (1 - C)^Lambda(o), so
//   G = int_0^1 C^Lambda(i) (1 - C)^Lambda(o) dC = B(1 + Lambda(i), 1 + Lambda(o)),
// the Beta function (the form Heitz, Hanika, d'Eon and Dachsbacher 2016 use for their dielectric).
// It is below the separable product for transmission (Chebyshev's integral inequality: one factor
// rises with C, the other falls) and above it for reflection.
//
// Geometry of one pair of directions. For reflection (both directions on one side, cosines mu_i,
// mu_o, sines s_i, s_o) and omc = 1 - cos(phi_rt) = 2 sin^2(phi_rt / 2):
//   wi.wo = cos(theta_i + theta_o) + s_i s_o omc,   cos(i.h) = sqrt((1 + wi.wo) / 2),
//   tan^2(theta_h) = ((s_i - s_o)^2 + 2 s_i s_o omc) / (mu_i + mu_o)^2.
// For transmission (air cosine mu_a, binder cosine mu_b), with H = wa + n wb:
//   wa.wb = -cos(theta_a - theta_b) + s_a s_b omc,  |H|^2 = 1 + n^2 + 2 n wa.wb,
//   a.h = -(1 + n wa.wb) / |H| (> 0 required),     |b.h| = (n + wa.wb) / |H|,
//   tan^2(theta_h) = ((s_a - n s_b)^2 + 2 n s_a s_b omc) / (n mu_b - mu_a)^2  (n mu_b > mu_a required).
// So every factor is a simple function of omc, the facet tilt is known in closed form along the
// azimuth, and so are the azimuths where the integrand stops being smooth: the end of the valid
// refraction pairs (a.h = 0) and the onset of facet total internal reflection (cos(i.h) = mu_c).
//
// Quadrature of one kernel column (fixed incident direction), all orders at once:
//   X^m(k) = int K^m(mu_o, mu_i) ell_k(mu_o) 2 mu_o dmu_o,   K^m = int_0^pi f cos(m phi_rt) dphi_rt.
// Outer: the outgoing zenith angle theta_o (smooth at the pole, where K^m ~ sin^m theta_o, unlike
// mu_o), broken at the pieces' edges, at the specular angle, where the cuts above enter or leave
// [0, pi] (square-root-type points, node clustering there), and geometrically (ratio 4) away from
// the specular angle, with theta - theta_s = sigma sinh(t) inside each interval (sigma: the lobe's
// angular width, ~alpha) so that the power-law tail of GGX becomes a decaying exponential. Inner:
// phi_rt from 0, where every lobe peaks, with the core mapped by tan(phi/2) = w tan(s/2) (w: the
// core's half width in tan(phi/2), from the formula for tan^2(theta_h); it makes the GGX core a
// trigonometric polynomial of degree one in s), then intervals doubling in length up to pi, broken
// at the cuts. Node counts grow with the number of orders (cos(m phi) over an interval) and with the
// pieces' node counts (ell_k over an interval). Then X^m(k) is one matrix product per piece.

#include <brdf/rte/rough_interface.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>
#include <brdf/core/threads.h>
#include <brdf/core/trig_lanes.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <span>

namespace brdf::rte {
namespace {

constexpr double pi = std::numbers::pi;
constexpr double half_pi = 0.5 * std::numbers::pi;
constexpr double infinity = std::numeric_limits<double>::infinity();

// Gauss nodes per unit of (orders - 1) * length / pi: n-point Gauss integrates cos(k x) over
// [-1, 1] once n exceeds about k / 2 (pi / 2 nodes per wavelength), and cos(m phi) over an interval
// of length L is cos(k x) with k = m L / 2.
constexpr double nodes_per_order = 0.8;
// Gauss nodes per unit of (piece nodes - 1) * (interval length / piece length) in mu: ell_k has
// degree N - 1 on its piece.
constexpr double nodes_per_degree = 0.55;
// Beckmann: facets with tan^2 / alpha^2 beyond this carry exp(-50) of the peak density.
constexpr double beckmann_cutoff = 50.0;

// ------------------------------------------------------------------------------------------------
// Fresnel reflectance of one facet (Born and Wolf 1.5.2; as rte/interface.cpp), cos in [0, 1].

double fresnel_from_air(double c, double n) {
    const double ct = std::sqrt(std::max(0.0, 1.0 - (1.0 - c * c) / (n * n)));
    const double rs = (c - n * ct) / (c + n * ct);
    const double rp = (n * c - ct) / (n * c + ct);
    return 0.5 * (rs * rs + rp * rp);
}

// Written without branches (a select at the end) so that the inner quadrature's loop vectorises.
double fresnel_from_inside(double c, double n) {
    const double st2 = n * n * (1.0 - c * c);
    const double ct = std::sqrt(std::max(0.0, 1.0 - st2));
    const double rs = (n * c - ct) / (n * c + ct);
    const double rp = (c - n * ct) / (c + n * ct);
    return st2 >= 1.0 ? 1.0 : 0.5 * (rs * rs + rp * rp); // total internal reflection on the facet
}

double sine_of(double mu) { return std::sqrt(std::max(0.0, (1.0 - mu) * (1.0 + mu))); }

enum class Kind { ReflectAir, ReflectInside, TransmitDown, TransmitUp };

// The model's constants, copied out of RoughInterface so that the hot loops see plain members.
struct Facets {
    double n, alpha, alpha2, mu_c;
    Microfacet distribution;
    Masking masking;

    explicit Facets(const RoughInterface& s)
        : n(s.index()), alpha(s.surface().alpha), alpha2(alpha * alpha), mu_c(s.critical()),
          distribution(s.surface().distribution), masking(s.surface().masking) {}

    // D from t2 = tan^2(theta_h); 1 / cos^4 = (1 + t2)^2.
    template <Microfacet D>
    double density(double t2) const {
        const double sec2 = 1.0 + t2;
        if constexpr (D == Microfacet::Ggx) {
            const double q = alpha2 + t2;
            return alpha2 * sec2 * sec2 / (pi * q * q);
        } else {
            return std::exp(-t2 / alpha2) * sec2 * sec2 / (pi * alpha2);
        }
    }
    double d_of_tan2(double t2) const {
        return distribution == Microfacet::Ggx ? density<Microfacet::Ggx>(t2) : density<Microfacet::Beckmann>(t2);
    }

    // s: the sine of the direction (passed separately: 1 - mu^2 loses digits near the pole).
    double lambda(double mu, double s) const {
        if (!(s > 0.0)) return 0.0;
        if (!(mu > 0.0)) return infinity;
        const double s2 = s * s;
        if (distribution == Microfacet::Ggx) {
            const double x = alpha2 * s2 / (mu * mu); // alpha^2 tan^2
            return x / (2.0 * (1.0 + std::sqrt(1.0 + x)));
        }
        const double a = mu / (alpha * std::sqrt(s2));
        return 0.5 * (std::exp(-a * a) / (a * std::sqrt(pi)) - std::erfc(a));
    }

    double g_reflect(double li, double lo) const {
        if (masking == Masking::HeightCorrelated) return 1.0 / (1.0 + li + lo);
        return 1.0 / ((1.0 + li) * (1.0 + lo));
    }

    double g_transmit(double li, double lo) const {
        if (masking == Masking::Separable) return 1.0 / ((1.0 + li) * (1.0 + lo));
        if (!std::isfinite(li) || !std::isfinite(lo)) return 0.0;
        return std::exp(std::lgamma(1.0 + li) + std::lgamma(1.0 + lo) - std::lgamma(2.0 + li + lo));
    }
};

bool is_transmission(Kind k) { return k == Kind::TransmitDown || k == Kind::TransmitUp; }

// One pair of cosines, everything that does not depend on the azimuth (see the file comment).
struct Pair {
    bool valid = false;
    double a = 0.0, b = 0.0, c = 1.0; // tan^2(theta_h) = (a + b omc) / c
    double w0 = 0.0, w1 = 0.0;         // wi.wo (reflection) or wa.wb (transmission) = w0 + w1 omc
    double scale = 0.0;                // masking over the cosines
    double omc_end = 2.0;              // the integrand vanishes for omc >= omc_end
    double omc_tir = -1.0;             // ReflectInside: facet total internal reflection for omc < omc_tir
};

// Cosines and sines of the incident and outgoing directions.
Pair make_pair(const Facets& fc, Kind kind, double mu_i, double s_i, double mu_o, double s_o) {
    Pair p;
    if (!(mu_i > 0.0) || !(mu_o > 0.0)) return p;
    const double li = fc.lambda(mu_i, s_i), lo = fc.lambda(mu_o, s_o);
    if (!is_transmission(kind)) {
        p.a = (s_i - s_o) * (s_i - s_o);
        p.b = 2.0 * s_i * s_o;
        p.c = (mu_i + mu_o) * (mu_i + mu_o);
        p.w0 = mu_i * mu_o - s_i * s_o;
        p.w1 = s_i * s_o;
        p.scale = fc.g_reflect(li, lo) / (4.0 * mu_i * mu_o);
        if (kind == Kind::ReflectInside) {
            const double target = 2.0 * fc.mu_c * fc.mu_c - 1.0; // wi.wo at cos(i.h) = mu_c
            if (p.w1 > 0.0) p.omc_tir = (target - p.w0) / p.w1;
            else p.omc_tir = p.w0 < target ? infinity : -infinity;
        }
        p.valid = p.scale > 0.0;
        return p;
    }
    const double n = fc.n;
    const double mu_a = kind == Kind::TransmitDown ? mu_i : mu_o;
    const double mu_b = kind == Kind::TransmitDown ? mu_o : mu_i;
    const double s_a = kind == Kind::TransmitDown ? s_i : s_o;
    const double s_b = kind == Kind::TransmitDown ? s_o : s_i;
    const double hz = n * mu_b - mu_a; // the facet normal must point into air
    if (!(hz > 0.0)) return p;
    p.a = (s_a - n * s_b) * (s_a - n * s_b);
    p.b = 2.0 * n * s_a * s_b;
    p.c = hz * hz;
    p.w0 = -(mu_a * mu_b + s_a * s_b);
    p.w1 = s_a * s_b;
    // a.h > 0 <=> 1 + n wa.wb < 0.
    const double lead = 1.0 + n * p.w0;
    if (p.w1 > 0.0) p.omc_end = std::min(2.0, -lead / (n * p.w1));
    else p.omc_end = lead < 0.0 ? 2.0 : 0.0;
    if (!(p.omc_end > 0.0)) return p;
    p.scale = fc.g_transmit(li, lo) / (mu_a * mu_b);
    p.valid = p.scale > 0.0;
    return p;
}

struct Value {
    double f = 0.0;       // the BSDF of the kind (incident -> outgoing)
    double reverse = 0.0; // transmission only: the BSDF of the reverse path (outgoing -> incident)
};

// Both transmission values come from their own Fresnel (air side for down, binder side for up), so
// that reciprocity f_down = n^2 f_up is computed, not assumed. No branch depends on omc (selects
// only), so that the loop over the inner nodes vectorises (inner_sums).
template <Kind K, Microfacet D>
inline Value evaluate_at(const Facets& fc, const Pair& p, double omc) {
    const double d = fc.density<D>((p.a + p.b * omc) / p.c);
    const double n = fc.n;
    if constexpr (K == Kind::ReflectAir || K == Kind::ReflectInside) {
        const double ci = std::sqrt(std::max(0.0, 0.5 * (1.0 + p.w0 + p.w1 * omc)));
        const double fresnel = K == Kind::ReflectAir ? fresnel_from_air(ci, n) : fresnel_from_inside(ci, n);
        const double f = fresnel * d * p.scale;
        return {f, f};
    } else {
        const double wawb = p.w0 + p.w1 * omc;
        const double h2 = 1.0 + n * n + 2.0 * n * wawb;
        const double inv = 1.0 / std::sqrt(h2);
        const double ca = -(1.0 + n * wawb) * inv;
        const double cb = (wawb + n) * inv;
        const double common = ca * cb * d * p.scale / h2;
        const bool valid = ca > 0.0; // the facet faces the air direction
        const double down = valid ? n * n * (1.0 - fresnel_from_air(ca, n)) * common : 0.0;
        const double up = valid ? (1.0 - fresnel_from_inside(cb, n)) * common : 0.0;
        return K == Kind::TransmitDown ? Value{down, up} : Value{up, down};
    }
}

template <Kind K>
Value evaluate_kind(const Facets& fc, const Pair& p, double omc) {
    return fc.distribution == Microfacet::Ggx ? evaluate_at<K, Microfacet::Ggx>(fc, p, omc)
                                              : evaluate_at<K, Microfacet::Beckmann>(fc, p, omc);
}

Value evaluate(const Facets& fc, Kind kind, const Pair& p, double omc) {
    switch (kind) {
    case Kind::ReflectAir: return evaluate_kind<Kind::ReflectAir>(fc, p, omc);
    case Kind::ReflectInside: return evaluate_kind<Kind::ReflectInside>(fc, p, omc);
    case Kind::TransmitDown: return evaluate_kind<Kind::TransmitDown>(fc, p, omc);
    case Kind::TransmitUp: return evaluate_kind<Kind::TransmitUp>(fc, p, omc);
    }
    return {};
}

// The inner quadrature's sums (azimuth_orders): the integrand f (and its reverse) at the nodes omc
// times their weights into f0 and f1, then sum_j f_j T_m(cos phi_j) for m < orders by the Chebyshev
// recurrence, four nodes side by side with per-lane partial sums in acc0 and acc1 (4 per order; no
// reassociated reductions: numerics are IEEE, docs/style.md). `count` nodes, padded to a multiple
// of four with zero weights. Compiled for AVX-512, AVX2 and the baseline, picked at run time: the
// same operations in the same order in each (no contraction, cmake/BrdfWarnings.cmake), so every
// clone gives the same bits; wider vectors take the integrand's divisions and square roots and the
// recurrence's lanes at once (docs/physics.md, "Rough interface").
template <Kind K, Microfacet D>
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void inner_sums(const Facets& fc, const Pair& p, std::size_t count, std::size_t padded, const double* omc,
                const double* cosine, const double* weight, int orders, int channels, double* f0, double* f1,
                double* acc0, double* acc1) {
    for (std::size_t i = 0; i < count; ++i) {
        const Value v = evaluate_at<K, D>(fc, p, omc[i]);
        f0[i] = v.f * weight[i];
        f1[i] = v.reverse * weight[i];
    }
    for (std::size_t i = count; i < padded; ++i) f0[i] = f1[i] = 0.0;
    // Four lanes to a vector (GCC vector extensions, lowered to the clone's registers), element-wise
    // in the scalar recurrence's order; the channel test out of the loop over the orders (GCC kept
    // it inside, and the loop scalar).
    typedef double Vec4 __attribute__((vector_size(32)));
    const auto load = [](const double* x) {
        Vec4 v;
        std::memcpy(&v, x, sizeof v);
        return v;
    };
    const auto add_to = [](double* x, Vec4 v) {
        Vec4 sum;
        std::memcpy(&sum, x, sizeof sum);
        sum += v;
        std::memcpy(x, &sum, sizeof sum);
    };
    for (std::size_t b0 = 0; b0 < padded; b0 += 4) {
        Vec4 tp = {1.0, 1.0, 1.0, 1.0}, tc = load(cosine + b0);
        const Vec4 c2 = 2.0 * tc, fa = load(f0 + b0), fb = load(f1 + b0);
        add_to(acc0, fa);
        if (channels > 1) {
            add_to(acc1, fb);
            for (int m = 1; m < orders; ++m) {
                add_to(acc0 + 4 * m, fa * tc);
                add_to(acc1 + 4 * m, fb * tc);
                const Vec4 tn = c2 * tc - tp;
                tp = tc;
                tc = tn;
            }
        } else {
            for (int m = 1; m < orders; ++m) {
                add_to(acc0 + 4 * m, fa * tc);
                const Vec4 tn = c2 * tc - tp;
                tp = tc;
                tc = tn;
            }
        }
    }
}

using InnerSums = void (*)(const Facets&, const Pair&, std::size_t, std::size_t, const double*, const double*,
                           const double*, int, int, double*, double*, double*, double*);

template <Kind K>
InnerSums inner_sums_for(Microfacet d) {
    return d == Microfacet::Ggx ? &inner_sums<K, Microfacet::Ggx> : &inner_sums<K, Microfacet::Beckmann>;
}

InnerSums inner_sums_for(Kind kind, Microfacet d) {
    switch (kind) {
    case Kind::ReflectAir: return inner_sums_for<Kind::ReflectAir>(d);
    case Kind::ReflectInside: return inner_sums_for<Kind::ReflectInside>(d);
    case Kind::TransmitDown: return inner_sums_for<Kind::TransmitDown>(d);
    case Kind::TransmitUp: return inner_sums_for<Kind::TransmitUp>(d);
    }
    return nullptr;
}

// ------------------------------------------------------------------------------------------------
// Quadrature levels. Level L aims at a relative precision eps = 10^-(L+1) of each integral; an
// interval carrying a share r of it gets nodes for a relative error eps / r: three, plus
// nodes_per_decade per decade of r / eps (Gauss on an interval whose nearest singularity is at
// least a third of its length away gains about a decade per node and a half), plus what the
// oscillation of cos(m phi) or the degree of the basis over the interval needs. An interval below
// eps gets two. The convergence check compares a level with the next.

constexpr double nodes_per_decade = 2.0;

struct Level {
    double eps;
    static Level at(int l) { return {std::pow(10.0, -(l + 1))}; }
    int nodes(double share, double resolution) const {
        if (!(share > eps)) return 2;
        return 3 + static_cast<int>(std::ceil(nodes_per_decade * std::log10(share / eps) + resolution));
    }
    // The precision an integral needs when it enters a larger one with this share.
    Level within(double share) const { return {std::min(0.1, eps / std::max(share, 1e-300))}; }
};
constexpr int max_level = 13;

int start_level(double tolerance) {
    const int digits = static_cast<int>(std::floor(-std::log10(tolerance)));
    return std::clamp(digits - 2, 0, max_level - 1);
}

// Gauss-Legendre rules by size, looked up once per computation (the global cache takes a lock).
class GaussRules {
public:
    const Quadrature& operator()(int n) {
        if (n >= static_cast<int>(m_rules.size())) m_rules.resize(static_cast<std::size_t>(n) + 1);
        auto& r = m_rules[static_cast<std::size_t>(n)];
        if (!r) r = gauss_legendre(n);
        return *r;
    }

private:
    std::vector<std::shared_ptr<const Quadrature>> m_rules;
};

// Gauss node v in [-1, 1] -> u in [a, b] and du/dv, optionally clustered at either end. Power 2
// (u - a ~ v^2, the 1 - cos map) turns sqrt(d) at that end into a smooth function; power 4 (Sidi's
// sin^3 transformation, A. Sidi 1993, Int. Ser. Numer. Math. 112, 359: psi(t) = sin^4(pi t / 2)
// (2 + cos(pi t)), psi' = (3 pi / 4) sin^3(pi t)) also tames d log d, which the outer integral shows
// where facet TIR starts to cover phi = 0. Clustering costs interior resolution, so it is used only
// where needed. Different powers at the two ends use the larger one at both.
enum Cluster { None = 0, Square = 2, Quartic = 4 };

inline double sidi(double t) {
    const double s = std::sin(0.5 * pi * t);
    return s * s * s * s * (2.0 + std::cos(pi * t));
}
inline double sidi_slope(double t) {
    const double s = std::sin(pi * t);
    return 0.75 * pi * s * s * s;
}
// The power 2 map from the sine and cosine of pi t.
inline void square_map(double sine, double cosine, double& u, double& du) {
    u = 0.5 * (1.0 - cosine);
    du = 0.5 * pi * sine;
}
// The two-sided map psi on [0, 1] for the power.
inline void two_sided(int power, double t, double& u, double& du) {
    if (power == Quartic) {
        u = sidi(t);
        du = sidi_slope(t);
    } else {
        square_map(std::sin(pi * t), std::cos(pi * t), u, du);
    }
}
// The left half of the two-sided map stretched to [a, b] (cluster_map with ca only), from x, dx.
inline void left_half(double a, double b, double x, double dx, double& u, double& du) {
    u = a + 2.0 * (b - a) * x;
    du = 0.5 * (b - a) * dx;
}

inline void cluster_map(double v, double a, double b, int ca, int cb, double& u, double& du) {
    const double len = b - a, t = 0.5 * (v + 1.0);
    double x, dx;
    if (ca && cb) {
        two_sided(std::max(ca, cb), t, x, dx);
        u = a + len * x;
        du = 0.5 * len * dx;
    } else if (ca) {
        two_sided(ca, 0.5 * t, x, dx);
        left_half(a, b, x, dx, u, du);
    } else if (cb) {
        two_sided(cb, 0.5 * (1.0 - t), x, dx);
        u = b - 2.0 * len * x;
        du = 0.5 * len * dx;
    } else {
        u = a + len * t;
        du = 0.5 * len;
    }
}

struct Workspace {
    GaussRules gauss;
    std::vector<double> phi_w, omc, cosine, f0, f1; // inner nodes
    std::vector<double> cheb;                       // Chebyshev blocks
    long long evaluations = 0;
};

// body(k, workspace) for k < count over the cores, each thread with a workspace of its own (the
// first is `ws`): a workspace holds scratch and Gauss rules only, so what body(k) computes does not
// depend on the thread that runs it. The evaluations are counted into `ws`. A probe's stream check
// solves one or two stacks, whose kernels were computed on one core while the other waited.
template <class Body>
void for_each_on_cores(int count, Workspace& ws, const Body& body) {
    const int threads = std::max(1, std::min(available_cpus(), count));
    std::vector<Workspace> others(static_cast<std::size_t>(threads - 1));
    std::atomic<int> next{0};
    parallel_for(threads, threads, [&](int t) {
        Workspace& own = t == 0 ? ws : others[static_cast<std::size_t>(t - 1)];
        for (int k = next++; k < count; k = next++) body(k, own);
    });
    for (const Workspace& w : others) ws.evaluations += w.evaluations;
}

// ------------------------------------------------------------------------------------------------
// Inner: K^m = int_0^pi f cos(m phi) dphi for m < orders, channels 1 or 2 (f, reverse), added to
// out[ch * orders + m].

struct Segment {
    double a, b;   // in phi, or in s for the Moebius core
    bool moebius;  // tan(phi/2) = w tan(s/2)
    int cluster_a; // Square at a facet-TIR onset (F = 1 - k sqrt(phi - phi_tir))
    int n;
};

double phi_of_omc(double omc) { return 2.0 * std::asin(std::sqrt(std::clamp(0.5 * omc, 0.0, 1.0))); }

void azimuth_orders(const Facets& fc, Kind kind, const Pair& p, const Level& level, int orders, int channels,
                    double weight, double* out, Workspace& ws) {
    if (!p.valid) return;
    if (fc.distribution == Microfacet::Beckmann && p.a / (p.c * fc.alpha2) > beckmann_cutoff) return;
    const double phi_end = p.omc_end >= 2.0 ? pi : phi_of_omc(p.omc_end);
    if (!(phi_end > 0.0)) return;
    const double phi_tir = (p.omc_tir > 0.0 && p.omc_tir < p.omc_end) ? phi_of_omc(p.omc_tir) : -1.0;

    double w = 1.0; // core half width in tan(phi/2)
    if (p.b > 0.0) {
        if (fc.distribution == Microfacet::Ggx) {
            const double q = fc.alpha2 * p.c + p.a;
            w = std::sqrt(q / (q + 2.0 * p.b));
        } else {
            w = std::min(1.0, fc.alpha * std::sqrt(p.c / (2.0 * p.b)));
        }
    }
    const double order_nodes = nodes_per_order * (orders - 1) / pi;

    // Breaks: the core out to three half widths (Moebius-mapped; its stretch of phi there is below
    // 1.7), then intervals doubling in length (a core wider than a third reaches past pi/2 and the
    // tail is one interval). Facet TIR (ReflectInside) adds its onset phi_tir, where
    // F = 1 - k sqrt(phi - phi_tir) (nodes clustered there), and a geometric grading on the scale of
    // the onset's distance from phi = 0: there F ~ 1 - k sqrt(delta + kappa phi^2) is nearly
    // singular within sqrt(delta / kappa), also when the onset itself lies just below phi = 0.
    const double phi_core = std::min(phi_end, 2.0 * std::atan(3.0 * w));
    double breaks[96];
    int nb = 0;
    breaks[nb++] = 0.0;
    for (double x = phi_core; x < phi_end && nb < 60; x *= 2.0) {
        if (fc.distribution == Microfacet::Beckmann) {
            const double omc = 2.0 * std::sin(0.5 * x) * std::sin(0.5 * x);
            if ((p.a + p.b * omc) / (p.c * fc.alpha2) > beckmann_cutoff) break;
        }
        if (phi_end - 2.0 * x < 0.5 * x) break; // the last interval takes the rest
        breaks[nb++] = x;
    }
    double phi_last = phi_end; // Beckmann: nothing beyond the cut-off
    if (fc.distribution == Microfacet::Beckmann && nb > 1) {
        const double x = std::min(phi_end, 2.0 * breaks[nb - 1]);
        const double omc = 2.0 * std::sin(0.5 * x) * std::sin(0.5 * x);
        if ((p.a + p.b * omc) / (p.c * fc.alpha2) > beckmann_cutoff) phi_last = x;
    }
    breaks[nb++] = phi_last;
    if (kind == Kind::ReflectInside && p.omc_tir < 2.0 && std::isfinite(p.omc_tir)) {
        const double start = std::max(0.0, phi_tir);
        const double scale = phi_of_omc(std::abs(p.omc_tir)); // onset distance from phi = 0
        if (phi_tir > 0.0 && phi_tir < phi_last) breaks[nb++] = phi_tir;
        for (double d = scale; start + d < std::min(phi_last, 0.5) && nb < 94; d *= 2.0) breaks[nb++] = start + d;
    }
    std::sort(breaks, breaks + nb);
    // A break just right of the onset would leave the next interval with a square root at a small
    // fraction of its length: merge it into the clustered interval that starts at the onset.
    if (phi_tir > 0.0) {
        int t = 0;
        while (t < nb && breaks[t] != phi_tir) ++t;
        while (t + 2 < nb && breaks[t + 1] - phi_tir < 0.5 * (breaks[t + 2] - breaks[t + 1])) {
            std::copy(breaks + t + 2, breaks + nb, breaks + t + 1);
            --nb;
        }
    }

    // Share of each interval: D at its start (the largest on it: tan^2 grows with phi) times its
    // length, against the core's.
    const double d_core = fc.d_of_tan2(p.a / p.c) * phi_core;
    Segment segs[96];
    int count = 0;
    for (int i = 0; i + 1 < nb; ++i) {
        const double a = breaks[i], b = breaks[i + 1];
        if (!(b - a > 1e-15)) continue;
        const bool in_core = b <= phi_core * (1.0 + 1e-12);
        const int cluster = phi_tir > 0.0 && a == phi_tir ? Square : None;
        const double sh = std::sin(0.5 * a);
        const double share = std::min(1.0, fc.d_of_tan2((p.a + 2.0 * p.b * sh * sh) / p.c) * (b - a) / d_core);
        const int n = level.nodes(share, order_nodes * (b - a));
        if (in_core) // Moebius variable s: tan(phi/2) = w tan(s/2)
            segs[count++] = {2.0 * std::atan(std::tan(0.5 * a) / w), 2.0 * std::atan(std::tan(0.5 * b) / w), true,
                             cluster, n};
        else
            segs[count++] = {a, b, false, cluster, n};
    }

    // Nodes: each Gauss node's u (phi, or s in the Moebius core) and du/dv, then sin and cos of u/2
    // (in [0, pi/2]) for all of them at once, then omc and the weights. The sines and cosines are
    // made in f0 and f1, which the integrand overwrites (inner_sums), from the half angles in omc
    // and du in phi_w; one call per node to libm's sin had been a sixth of the kernels' time.
    std::size_t total = 0;
    for (int s = 0; s < count; ++s) total += static_cast<std::size_t>(segs[s].n);
    const std::size_t padded = (total + 3) / 4 * 4;
    for (std::vector<double>* v : {&ws.phi_w, &ws.omc, &ws.cosine, &ws.f0, &ws.f1}) v->resize(padded);
    double *half = ws.omc.data(), *du = ws.phi_w.data(), *sines = ws.f0.data(), *cosines = ws.f1.data();
    std::size_t j = 0;
    for (int s = 0; s < count; ++s) {
        const Segment& sg = segs[s];
        const Quadrature& g = ws.gauss(sg.n);
        if (sg.cluster_a == Square) { // cluster_map's sines and cosines of pi t / 2 at once too
            double* angle = ws.cosine.data() + j; // free until the weights are made
            for (int k = 0; k < sg.n; ++k) angle[k] = pi * (0.5 * (0.5 * (g.x[k] + 1.0)));
            quarter_turn_sincos({angle, static_cast<std::size_t>(sg.n)}, sines + j, cosines + j);
            for (int k = 0; k < sg.n; ++k, ++j) {
                double x, dx, u;
                square_map(sines[j], cosines[j], x, dx);
                left_half(sg.a, sg.b, x, dx, u, du[j]);
                half[j] = 0.5 * u;
            }
            continue;
        }
        for (int k = 0; k < sg.n; ++k, ++j) {
            double u;
            cluster_map(g.x[k], sg.a, sg.b, sg.cluster_a, None, u, du[j]);
            half[j] = 0.5 * u;
        }
    }
    quarter_turn_sincos({half, total}, sines, cosines);
    j = 0;
    for (int s = 0; s < count; ++s) {
        const Segment& sg = segs[s];
        const Quadrature& g = ws.gauss(sg.n);
        for (int k = 0; k < sg.n; ++k, ++j) {
            double omc, dphi;
            if (sg.moebius) {
                const double t = sines[j] / cosines[j], x = w * t; // x = tan(phi/2)
                omc = 2.0 * x * x / (1.0 + x * x);
                dphi = w / (cosines[j] * cosines[j] + w * w * sines[j] * sines[j]) * du[j];
            } else {
                omc = 2.0 * sines[j] * sines[j];
                dphi = du[j];
            }
            ws.phi_w[j] = g.w[k] * dphi * weight;
            ws.omc[j] = omc;
            ws.cosine[j] = 1.0 - omc;
        }
    }
    for (; j < padded; ++j) { // zero weights
        ws.phi_w[j] = 0.0;
        ws.omc[j] = 0.0;
        ws.cosine[j] = 1.0;
    }
    ws.evaluations += static_cast<long long>(total);
    const int m_count = orders;
    ws.cheb.assign(static_cast<std::size_t>(2 * m_count * 4), 0.0);
    double* acc0 = ws.cheb.data();
    double* acc1 = acc0 + m_count * 4;
    inner_sums_for(kind, fc.distribution)(fc, p, total, padded, ws.omc.data(), ws.cosine.data(), ws.phi_w.data(),
                                          m_count, channels, ws.f0.data(), ws.f1.data(), acc0, acc1);
    for (int ch = 0; ch < channels; ++ch) {
        const double* acc = ch == 0 ? acc0 : acc1;
        for (int m = 0; m < m_count; ++m)
            out[ch * orders + m] += (acc[4 * m] + acc[4 * m + 1]) + (acc[4 * m + 2] + acc[4 * m + 3]);
    }
}

// ------------------------------------------------------------------------------------------------
// The outgoing side: pieces in mu with the Lagrange basis of each piece's nodes (barycentric form,
// Berrut and Trefethen 2004, SIAM Review 46, 501).

struct OutputSide {
    std::vector<double> edges; // ascending, 0 .. 1
    std::vector<int> first;
    std::vector<double> nodes;
    std::vector<double> bary;

    int size() const { return static_cast<int>(nodes.size()); }
    int pieces() const { return static_cast<int>(edges.size()) - 1; }
    int piece_size(int p) const { return first[p + 1] - first[p]; }

    static OutputSide from(const StreamPieces& s) {
        OutputSide o{s.edges, s.first, s.streams.mu, std::vector<double>(s.streams.mu.size(), 1.0)};
        // Differences scaled by the piece's half length keep the products in range.
        for (int p = 0; p < o.pieces(); ++p) {
            const double half = 0.5 * (o.edges[p + 1] - o.edges[p]);
            for (int k = o.first[p]; k < o.first[p + 1]; ++k) {
                double prod = 1.0;
                for (int j = o.first[p]; j < o.first[p + 1]; ++j)
                    if (j != k) prod *= (o.nodes[k] - o.nodes[j]) / half;
                o.bary[k] = 1.0 / prod;
            }
        }
        return o;
    }
    // One piece [0, 1] and the constant basis (albedos).
    static OutputSide whole() { return OutputSide{{0.0, 1.0}, {0, 1}, {0.5}, {1.0}}; }

    int piece_of(double mu) const {
        int p = 0;
        while (p + 1 < pieces() && mu >= edges[p + 1]) ++p;
        return p;
    }
    // ell_k(mu) for the nodes of piece p into out[0 .. piece_size).
    void basis(int p, double mu, double* out) const {
        const int f = first[p], count = piece_size(p);
        double sum = 0.0;
        for (int k = 0; k < count; ++k) {
            const double d = mu - nodes[f + k];
            if (d == 0.0) {
                for (int j = 0; j < count; ++j) out[j] = j == k ? 1.0 : 0.0;
                return;
            }
            out[k] = bary[f + k] / d;
            sum += out[k];
        }
        for (int k = 0; k < count; ++k) out[k] /= sum;
    }
};

// ------------------------------------------------------------------------------------------------
// Outer: nodes in theta for an interval graded around a centre.

struct OuterNode {
    double theta, weight;
    int piece;
    double share; // of its interval in the whole integral (estimated)
};

struct Break {
    double theta;
    int cluster; // Cluster power of the nodes on both sides
};

// Gauss nodes on [ta, tb] with theta - centre = sigma sinh(t), clustered at flagged ends.
void add_graded(double a, double b, int ca, int cb, double centre, double sigma, int n, int piece, double share,
                GaussRules& gauss, std::vector<OuterNode>& out) {
    const double ta = std::asinh((a - centre) / sigma), tb = std::asinh((b - centre) / sigma);
    const Quadrature& g = gauss(n);
    for (int k = 0; k < n; ++k) {
        double t, dt;
        cluster_map(g.x[k], ta, tb, ca, cb, t, dt);
        const double theta = centre + sigma * std::sinh(t);
        out.push_back({theta, g.w[k] * sigma * std::cosh(t) * dt, piece, share});
    }
}

// Breaks of [lo, hi] graded around `centre`: the centre and centre +- sigma 4^j.
void graded_breaks(double lo, double hi, double centre, double sigma, std::vector<Break>& out) {
    if (centre > lo && centre < hi) out.push_back({centre, None});
    for (double d = 4.0 * sigma; d < hi - lo; d *= 4.0) {
        if (centre + d > lo && centre + d < hi) out.push_back({centre + d, None});
        if (centre - d > lo && centre - d < hi) out.push_back({centre - d, None});
    }
}

// Sorted breaks within [lo, hi], coincident ones merged (keeping clustering).
std::vector<Break> merged_breaks(double lo, double hi, std::vector<Break> breaks) {
    std::sort(breaks.begin(), breaks.end(), [](const Break& x, const Break& y) { return x.theta < y.theta; });
    std::vector<Break> b;
    for (const Break& x : breaks) {
        if (x.theta < lo - 1e-15 || x.theta > hi + 1e-15) continue;
        const double t = std::clamp(x.theta, lo, hi);
        if (!b.empty() && t - b.back().theta < 1e-13) {
            b.back().cluster = std::max(b.back().cluster, x.cluster);
            continue;
        }
        b.push_back({t, x.cluster});
    }
    return b;
}

// A point the nodes are graded toward, with its scale: the specular angle (lobe width) or the
// horizon, where Smith masking G1 falls from 1 to 0 within about alpha.
struct Centre {
    double theta, sigma;
};

// Nodes on [lo, hi] in theta split by `breaks`, each interval graded around the nearest centre (in
// units of its scale); node counts from the level and from the degree of the basis over the interval.
// `density(theta)` estimates the integrand (it sets each interval's share, from the largest of the
// values at its ends and middle times its length); `sweep(a, b)` is the extra node count the
// integrand's own oscillation over [a, b] needs.
template <class Density, class Sweep>
void outer_rule(double lo, double hi, std::vector<Break> breaks, std::span<const Centre> centres, const Level& level,
                const OutputSide& side, const Density& density, const Sweep& sweep, GaussRules& gauss,
                std::vector<OuterNode>& out) {
    if (!(hi > lo)) return;
    for (int p = 1; p < side.pieces(); ++p) breaks.push_back({std::acos(side.edges[p]), None});
    for (const Centre& c : centres) graded_breaks(lo, hi, c.theta, c.sigma, breaks);
    breaks.push_back({lo, None});
    breaks.push_back({hi, None});
    std::vector<Break> b = merged_breaks(lo, hi, breaks);
    // Around each clustered break: the clustered interval a quarter of the gap to the next break
    // (clustering costs interior resolution), and geometric grading outward, so that no interval has
    // the singular point closer than a third of its own length (an interval that merely comes near
    // one converges only algebraically).
    const std::size_t count = b.size();
    for (std::size_t i = 0; i < count; ++i) {
        if (b[i].cluster == None) continue;
        const double t = b[i].theta;
        if (i > 0) {
            const double gap = t - b[i - 1].theta;
            b.push_back({t - 0.25 * gap, None});
            for (double g = 2.0 * gap; t - g > lo; g *= 2.0) b.push_back({t - g, None});
        }
        if (i + 1 < count) {
            const double gap = b[i + 1].theta - t;
            b.push_back({t + 0.25 * gap, None});
            for (double g = 2.0 * gap; t + g < hi; g *= 2.0) b.push_back({t + g, None});
        }
    }
    b = merged_breaks(lo, hi, b);
    std::vector<double> share(b.size(), 0.0);
    double total = 0.0;
    for (std::size_t i = 0; i + 1 < b.size(); ++i) {
        const double a = b[i].theta, c = b[i + 1].theta;
        share[i] = std::max({density(a), density(0.5 * (a + c)), density(c)}) * (c - a);
        total += share[i];
    }
    for (std::size_t i = 0; i + 1 < b.size(); ++i) {
        const double a = b[i].theta, c = b[i + 1].theta, mid = 0.5 * (a + c);
        const double r = total > 0.0 ? std::min(1.0, share[i] / total) : 1.0;
        const Centre* near = &centres[0];
        for (const Centre& x : centres)
            if (std::abs(mid - x.theta) / x.sigma < std::abs(mid - near->theta) / near->sigma) near = &x;
        const double mu_a = std::cos(a), mu_c = std::cos(c);
        const int piece = side.piece_of(0.5 * (mu_a + mu_c));
        const double len = side.edges[piece + 1] - side.edges[piece];
        const int degree = side.piece_size(piece) - 1;
        const int n = level.nodes(r, nodes_per_degree * degree * (mu_a - mu_c) / len + sweep(a, c));
        add_graded(a, c, b[i].cluster, b[i + 1].cluster, near->theta, near->sigma, n, piece, r, gauss, out);
    }
}

// The lobe of a fixed incident direction: specular angle, angular width, valid outgoing range and
// the square-root-type points (where an azimuthal cut enters or leaves [0, pi]).
struct Lobe {
    double centre, sigma, lo, hi;
    std::vector<Break> breaks;
};

Lobe lobe_of(const Facets& fc, Kind kind, double mu_i, double s_i) {
    const double theta_i = std::atan2(s_i, mu_i);
    const double n = fc.n, beta = std::acos(1.0 / n); // beta: where cos(theta_a -+ theta_b) = 1/n
    Lobe l{theta_i, 2.0 * fc.alpha, 0.0, half_pi, {}};
    auto feature = [&](double t, int power) {
        if (t > 0.0 && t < half_pi) l.breaks.push_back({t, power});
    };
    switch (kind) {
    case Kind::ReflectAir:
        break;
    case Kind::ReflectInside: {
        // Facet TIR starts (omc_tir = 0) or covers the circle (omc_tir = 2): cos(theta_i + theta_o) or
        // cos(theta_i - theta_o) equals cos(2 theta_c). The inner integral behaves like d log d there.
        const double two_c = 2.0 * std::acos(fc.mu_c);
        feature(two_c - theta_i, Quartic);
        feature(theta_i - two_c, Quartic);
        feature(theta_i + two_c, Quartic);
        break;
    }
    case Kind::TransmitDown: {
        l.centre = std::asin(s_i / n);
        l.sigma = fc.alpha * std::max(0.05, 1.0 - mu_i / (n * std::cos(l.centre)));
        l.lo = std::max(0.0, theta_i - beta);
        l.hi = std::min({half_pi, theta_i + beta, std::acos(std::min(1.0, mu_i / n))});
        // Where the valid pairs start to fill the azimuth or the circle: the integrand vanishes like
        // (a.h)^2 at the cut, so the inner integral goes like d^(5/2) there.
        feature(l.lo, Square);
        feature(beta - theta_i, Square);
        break;
    }
    case Kind::TransmitUp: {
        const double ns = n * s_i;
        if (ns < 1.0) {
            l.centre = std::asin(ns);
            l.sigma = fc.alpha * std::clamp(n * mu_i / std::cos(l.centre) - 1.0, 0.05, 20.0);
        } else {
            l.centre = half_pi;
            l.sigma = 2.0 * fc.alpha;
        }
        l.lo = std::max({0.0, theta_i - beta, std::acos(std::min(1.0, n * mu_i))});
        l.hi = std::min(half_pi, theta_i + beta);
        feature(l.lo, Square);
        feature(l.hi, Square);
        feature(beta - theta_i, Square);
        // Height-correlated masking of a transmission into a grazing air direction:
        // B(1 + L_i, 1 + L_o) ~ L_o^-(1 + L_i) ~ mu_o^(1 + L_i), a fractional power at the horizon.
        if (fc.masking == Masking::HeightCorrelated && l.hi == half_pi) l.breaks.push_back({half_pi, Quartic});
        break;
    }
    }
    l.sigma = std::clamp(l.sigma, 1e-7, 0.5);
    return l;
}

// X[ch](m, k) += int K^m(mu_o, mu_i) ell_k(mu_o) 2 mu_o dmu_o over outgoing theta_o <= theta_max.
void direction_orders(const Facets& fc, Kind kind, double mu_i, double s_i, const OutputSide& side,
                      double theta_max, const Level& level, int orders, int channels, std::vector<Matrix>& x,
                      Workspace& ws) {
    Lobe lobe = lobe_of(fc, kind, mu_i, s_i);
    const Centre centres[] = {{lobe.centre, lobe.sigma}, {half_pi, fc.alpha}};
    // The inner integral's size at phi = 0 times its core width, with the outer measure.
    auto density = [&](double theta) {
        const double mu_o = std::cos(theta), s_o = std::sin(theta);
        const Pair p = make_pair(fc, kind, mu_i, s_i, mu_o, s_o);
        if (!p.valid) return 0.0;
        const double q = fc.alpha2 * p.c + p.a;
        const double w = p.b > 0.0 ? std::sqrt(q / (q + 2.0 * p.b)) : 1.0;
        return p.scale * fc.d_of_tan2(p.a / p.c) * std::min(pi, 4.0 * w) * 2.0 * mu_o * s_o;
    };
    // Facet TIR: the onset phi_tir is a square-root point of the azimuthal integrand, so K^m carries
    // a term ~ cos(m phi_tir) / m^1.5 that oscillates in theta_o as the onset sweeps the azimuth.
    auto onset = [&](double theta) {
        const Pair p = make_pair(fc, kind, mu_i, s_i, std::cos(theta), std::sin(theta));
        return phi_of_omc(std::clamp(p.omc_tir, 0.0, 2.0));
    };
    auto sweep = [&](double a, double b) {
        if (kind != Kind::ReflectInside || orders == 1) return 0.0;
        const double pa = onset(a), pm = onset(0.5 * (a + b)), pb = onset(b);
        const double span = std::abs(pm - pa) + std::abs(pb - pm);
        return nodes_per_order * (orders - 1) * span / pi;
    };
    std::vector<OuterNode> nodes;
    outer_rule(lobe.lo, std::min(lobe.hi, theta_max), lobe.breaks, centres, level, side, density, sweep, ws.gauss,
               nodes);
    std::vector<int> per_piece(static_cast<std::size_t>(side.pieces()), 0);
    for (const OuterNode& o : nodes) ++per_piece[static_cast<std::size_t>(o.piece)];
    std::vector<double> k_orders(static_cast<std::size_t>(channels * orders));
    std::vector<double> ell(static_cast<std::size_t>(side.size()));
    for (int p = 0; p < side.pieces(); ++p) {
        const int count = per_piece[static_cast<std::size_t>(p)];
        if (count == 0) continue;
        const int np = side.piece_size(p);
        std::vector<Matrix> kmat(static_cast<std::size_t>(channels), Matrix(orders, count));
        Matrix basis(count, np);
        int j = 0;
        for (const OuterNode& o : nodes) {
            if (o.piece != p) continue;
            const double mu_o = std::cos(o.theta), s_o = std::sin(o.theta);
            std::fill(k_orders.begin(), k_orders.end(), 0.0);
            const Pair pair = make_pair(fc, kind, mu_i, s_i, mu_o, s_o);
            azimuth_orders(fc, kind, pair, level.within(o.share), orders, channels, o.weight * 2.0 * mu_o * s_o,
                           k_orders.data(), ws);
            for (int ch = 0; ch < channels; ++ch)
                for (int m = 0; m < orders; ++m)
                    kmat[static_cast<std::size_t>(ch)](m, j) = k_orders[static_cast<std::size_t>(ch * orders + m)];
            side.basis(p, mu_o, ell.data());
            for (int k = 0; k < np; ++k) basis(j, k) = ell[static_cast<std::size_t>(k)];
            ++j;
        }
        for (int ch = 0; ch < channels; ++ch) {
            Matrix prod;
            gemm(kmat[static_cast<std::size_t>(ch)], false, basis, false, prod);
            Matrix& dst = x[static_cast<std::size_t>(ch)];
            for (int m = 0; m < orders; ++m)
                for (int k = 0; k < np; ++k) dst(m, side.first[p] + k) += prod(m, k);
        }
    }
}

// The incident direction as an angle (its cosine and sine both to full precision).
std::vector<Matrix> direction_result(const Facets& fc, Kind kind, double theta_i, const OutputSide& side,
                                     double theta_max, const Level& level, int orders, int channels, Workspace& ws) {
    std::vector<Matrix> x(static_cast<std::size_t>(channels), Matrix(orders, side.size()));
    direction_orders(fc, kind, std::cos(theta_i), std::sin(theta_i), side, theta_max, level, orders, channels, x, ws);
    return x;
}

// Largest difference of two results relative to the order-0 size of the finer one.
double relative_change(const std::vector<Matrix>& fine, const std::vector<Matrix>& coarse) {
    double scale = 0.0;
    for (int k = 0; k < fine[0].cols(); ++k) scale += std::abs(fine[0](0, k));
    if (!(scale > 0.0)) return 0.0;
    double diff = 0.0;
    for (std::size_t ch = 0; ch < fine.size(); ++ch) diff = std::max(diff, max_abs_diff(fine[ch], coarse[ch]));
    return diff / scale;
}

void check_tolerance(double tolerance, const char* what) {
    if (!(tolerance >= 1e-13 && tolerance <= 1e-2))
        throw InputError(cat(what, ": tolerance must be in [1e-13, 1e-2] (got ", tolerance, ")"));
}

void check_cosine(double mu, const char* what) {
    if (!(mu > 0.0 && mu <= 1.0)) throw InputError(cat(what, ": cosine must be in (0, 1] (got ", mu, ")"));
}

// A direction whose result the quadrature level is chosen on.
struct Probe {
    Kind kind;
    double theta; // incident direction
    double theta_max;
};

struct LevelChoice {
    int level;
    double error;
};

// The probes of one level search, and the channels their results carry.
struct ProbeGroup {
    const std::vector<Probe>* probes;
    int channels;
};

// For each group, the smallest level whose result agrees with the next one to `tolerance` on every
// probe direction. The groups are searched at once (the air side's three probes and the inside's
// six): each round evaluates the next level of every group still searching, all of their probes
// spread over the cores together. One group alone left a core idle for a probe's evaluation in every
// round (three probes on two cores). Each group's choice is what it would be alone; a search that
// fails throws as it would alone, in the round it fails (the groups in order within a round).
std::vector<LevelChoice> choose_levels(const Facets& fc, std::span<const ProbeGroup> groups, const OutputSide& side,
                                       int orders, double tolerance, const char* what, Workspace& ws) {
    const std::size_t g_count = groups.size();
    std::vector<int> level(g_count, start_level(tolerance));
    std::vector<std::optional<LevelChoice>> chosen(g_count);
    // Every probe of the groups still searching, at level[g] + shift, one probe per core.
    const auto evaluate = [&](int shift) {
        std::vector<std::pair<std::size_t, std::size_t>> items; // (group, probe)
        for (std::size_t g = 0; g < g_count; ++g)
            if (!chosen[g])
                for (std::size_t i = 0; i < groups[g].probes->size(); ++i) items.emplace_back(g, i);
        std::vector<std::vector<std::vector<Matrix>>> out(g_count);
        for (std::size_t g = 0; g < g_count; ++g) out[g].resize(groups[g].probes->size());
        for_each_on_cores(static_cast<int>(items.size()), ws, [&](int k, Workspace& w) {
            const auto [g, i] = items[static_cast<std::size_t>(k)];
            const Probe& p = (*groups[g].probes)[i];
            out[g][i] = direction_result(fc, p.kind, p.theta, side, p.theta_max, Level::at(level[g] + shift), orders,
                                         groups[g].channels, w);
        });
        return out;
    };
    std::vector<std::vector<std::vector<Matrix>>> coarse = evaluate(0);
    for (;;) {
        bool searching = false;
        for (std::size_t g = 0; g < g_count; ++g) searching = searching || !chosen[g];
        if (!searching) break;
        for (std::size_t g = 0; g < g_count; ++g)
            if (!chosen[g] && level[g] >= max_level)
                throw NumericalError(cat(what, ": quadrature did not converge to ", tolerance));
        std::vector<std::vector<std::vector<Matrix>>> fine = evaluate(1);
        for (std::size_t g = 0; g < g_count; ++g) {
            if (chosen[g]) continue;
            double worst = 0.0;
            for (std::size_t i = 0; i < fine[g].size(); ++i)
                worst = std::max(worst, relative_change(fine[g][i], coarse[g][i]));
            if (worst <= tolerance) {
                chosen[g] = LevelChoice{level[g] + 1, worst};
            } else if (level[g] + 1 == max_level) {
                throw NumericalError(cat(what, ": quadrature did not converge to ", tolerance, " (", worst,
                                         " at the finest level)"));
            } else {
                coarse[g] = std::move(fine[g]);
                ++level[g];
            }
        }
    }
    std::vector<LevelChoice> out;
    for (const std::optional<LevelChoice>& c : chosen) out.push_back(*c);
    return out;
}

double albedo_part(const Facets& fc, Kind kind, double mu, double tolerance) {
    const OutputSide side = OutputSide::whole();
    Workspace ws;
    const double theta = std::acos(mu);
    const std::vector<Probe> probes{{kind, theta, half_pi}};
    const ProbeGroup group{&probes, 1};
    const LevelChoice c = choose_levels(fc, {&group, 1}, side, 1, tolerance, "rough interface albedo", ws).front();
    return direction_result(fc, kind, theta, side, half_pi, Level::at(c.level), 1, 1, ws)[0](0, 0);
}

} // namespace

// ------------------------------------------------------------------------------------------------

RoughInterface::RoughInterface(double n, RoughSurface surface) : m_n(n), m_surface(surface) {
    if (!(n > 1.0 && n <= 4.0))
        throw InputError(cat("rough interface: binder index must be in (1, 4] (got ", n, ")"));
    if (!(surface.alpha >= 0.001 && surface.alpha <= 1.0))
        throw InputError(cat("rough interface: roughness alpha must be in [0.001, 1] (got ", surface.alpha, ")"));
    m_critical = std::sqrt(1.0 - 1.0 / (n * n));
}

double RoughInterface::distribution(double cos_h) const {
    if (!(cos_h > 0.0)) return 0.0;
    const double c = std::min(cos_h, 1.0);
    return Facets(*this).d_of_tan2((1.0 - c) * (1.0 + c) / (c * c));
}

double RoughInterface::smith_lambda(double mu) const { return Facets(*this).lambda(mu, sine_of(mu)); }

double RoughInterface::masking_reflect(double mu_i, double mu_o) const {
    const Facets fc(*this);
    return fc.g_reflect(fc.lambda(mu_i, sine_of(mu_i)), fc.lambda(mu_o, sine_of(mu_o)));
}

double RoughInterface::masking_transmit(double mu_i, double mu_o) const {
    const Facets fc(*this);
    return fc.g_transmit(fc.lambda(mu_i, sine_of(mu_i)), fc.lambda(mu_o, sine_of(mu_o)));
}

namespace {
// omc = 1 - cos(phi_rt) = 1 + cos(phi) = 2 cos^2(phi / 2) for the graphics azimuth phi.
double omc_of_graphics(double phi) {
    const double c = std::cos(0.5 * phi);
    return 2.0 * c * c;
}

double closed_form(const RoughInterface& s, Kind kind, double mu_i, double mu_o, double phi) {
    const Facets fc(s);
    mu_i = std::min(mu_i, 1.0);
    mu_o = std::min(mu_o, 1.0);
    const Pair p = make_pair(fc, kind, mu_i, sine_of(mu_i), mu_o, sine_of(mu_o));
    if (!p.valid) return 0.0;
    const double omc = omc_of_graphics(phi);
    if (is_transmission(kind) && omc >= p.omc_end) return 0.0;
    return evaluate(fc, kind, p, omc).f;
}
} // namespace

double RoughInterface::f_reflect_air(double mu_i, double mu_o, double phi) const {
    return closed_form(*this, Kind::ReflectAir, mu_i, mu_o, phi);
}
double RoughInterface::f_reflect_inside(double mu_i, double mu_o, double phi) const {
    return closed_form(*this, Kind::ReflectInside, mu_i, mu_o, phi);
}
double RoughInterface::f_transmit_down(double mu_air, double mu_binder, double phi) const {
    return closed_form(*this, Kind::TransmitDown, mu_air, mu_binder, phi);
}
double RoughInterface::f_transmit_up(double mu_binder, double mu_air, double phi) const {
    return closed_form(*this, Kind::TransmitUp, mu_binder, mu_air, phi);
}

RoughInterface::Albedo RoughInterface::albedo_from_air(double mu, double tolerance) const {
    check_cosine(mu, "rough interface albedo");
    check_tolerance(tolerance, "rough interface albedo");
    const Facets fc(*this);
    return {albedo_part(fc, Kind::ReflectAir, mu, tolerance), albedo_part(fc, Kind::TransmitDown, mu, tolerance)};
}

double RoughInterface::lobe_albedo(double mu, double tolerance) const {
    check_cosine(mu, "rough interface albedo");
    check_tolerance(tolerance, "rough interface albedo");
    return albedo_part(Facets(*this), Kind::ReflectAir, mu, tolerance);
}

RoughInterface::Albedo RoughInterface::albedo_from_inside(double mu, double tolerance) const {
    check_cosine(mu, "rough interface albedo");
    check_tolerance(tolerance, "rough interface albedo");
    const Facets fc(*this);
    return {albedo_part(fc, Kind::ReflectInside, mu, tolerance), albedo_part(fc, Kind::TransmitUp, mu, tolerance)};
}

// ------------------------------------------------------------------------------------------------

StreamPieces split_gauss_pieces(int n_below, int n_above, double split) {
    StreamPieces s{split_gauss_streams(n_below, n_above, split), {0.0, split, 1.0}, {0, n_below, n_below + n_above}};
    return s;
}

StreamPieces stream_pieces(const Streams& streams, std::span<const double> edges) {
    const std::size_t count = edges.size();
    if (count < 2 || edges.front() != 0.0 || edges.back() != 1.0)
        throw InputError("stream pieces: edges must run from 0 to 1");
    for (std::size_t p = 0; p + 1 < count; ++p)
        if (!(edges[p + 1] > edges[p])) throw InputError(cat("stream pieces: edges not ascending at ", edges[p + 1]));
    if (streams.mu.size() != streams.w.size()) throw InputError("stream pieces: nodes and weights differ in number");
    StreamPieces s{streams, {edges.begin(), edges.end()}, {0}};
    std::size_t k = 0;
    for (std::size_t p = 0; p + 1 < count; ++p) {
        const std::size_t start = k;
        while (k < streams.mu.size() && streams.mu[k] < edges[p + 1]) {
            if (!(streams.mu[k] > edges[p]) || (k > 0 && !(streams.mu[k] > streams.mu[k - 1])))
                throw InputError(cat("stream pieces: node ", streams.mu[k], " is not inside its piece in ascending order"));
            ++k;
        }
        if (k == start) throw InputError(cat("stream pieces: no node in (", edges[p], ", ", edges[p + 1], ")"));
        s.first.push_back(static_cast<int>(k));
    }
    if (k != streams.mu.size()) throw InputError(cat("stream pieces: node ", streams.mu[k], " outside (0, 1)"));
    return s;
}

InterfaceKernels interface_kernels(const RoughInterface& surface, const StreamPieces& streams,
                                   std::span<const double> air_mu, int orders, double tolerance,
                                   bool internal_reflection) {
    const char* what = "rough interface kernels";
    check_tolerance(tolerance, what);
    if (orders < 1 || orders > 512) throw InputError(cat(what, ": orders must be in [1, 512] (got ", orders, ")"));
    for (double u : air_mu) check_cosine(u, what);
    const StreamPieces checked = stream_pieces(streams.streams, streams.edges); // validates
    const Facets fc(surface);
    const OutputSide side = OutputSide::from(checked);
    const int n = side.size(), e_count = static_cast<int>(air_mu.size());
    const double sigma = 2.0 * fc.alpha;

    // Probes: the extreme and middle air cosines; inside, either side of each edge and the horizon.
    std::vector<Probe> air_probes, inside_probes;
    if (e_count > 0) {
        std::vector<double> sorted(air_mu.begin(), air_mu.end());
        std::sort(sorted.begin(), sorted.end());
        for (double u : {sorted.front(), sorted[sorted.size() / 2], sorted.back()})
            if (air_probes.empty() || air_probes.back().theta != std::acos(u))
                air_probes.push_back({Kind::TransmitDown, std::acos(u), half_pi});
    }
    for (int p = 1; p < side.pieces(); ++p) {
        const double te = std::acos(side.edges[p]);
        for (double d : {-4.0, -0.5, 0.5, 4.0}) {
            const double t = te + d * sigma;
            if (t > 0.0 && t < half_pi) inside_probes.push_back({Kind::ReflectInside, t, t});
        }
    }
    for (double t : {0.3, half_pi - 0.5 * sigma})
        if (t > 0.0 && t < half_pi) inside_probes.push_back({Kind::ReflectInside, t, t});

    if (!internal_reflection) inside_probes.clear();
    // Both searches at once (choose_levels); a side without probes keeps the start level.
    Workspace ws;
    std::vector<ProbeGroup> groups;
    if (!air_probes.empty()) groups.push_back({&air_probes, 2});
    if (!inside_probes.empty()) groups.push_back({&inside_probes, 1});
    const std::vector<LevelChoice> levels = choose_levels(fc, groups, side, orders, tolerance, what, ws);
    const LevelChoice start{start_level(tolerance), 0.0};
    const LevelChoice air_level = air_probes.empty() ? start : levels.front();
    const LevelChoice inside_level = inside_probes.empty() ? start : levels.back();
    ws.evaluations = 0;

    InterfaceKernels out;
    out.t_down.assign(static_cast<std::size_t>(orders), Matrix(n, e_count));
    out.t_up.assign(static_cast<std::size_t>(orders), Matrix(e_count, n));
    if (internal_reflection) out.r_inside.assign(static_cast<std::size_t>(orders), Matrix(n, n));
    std::vector<double> q(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) q[k] = 2.0 * checked.streams.w[k] * checked.streams.mu[k];

    for_each_on_cores(e_count, ws, [&](int e, Workspace& w) {
        const auto x =
            direction_result(fc, Kind::TransmitDown, std::acos(air_mu[e]), side, half_pi, Level::at(air_level.level),
                             orders, 2, w);
        for (int m = 0; m < orders; ++m)
            for (int k = 0; k < n; ++k) {
                out.t_down[m](k, e) = x[0](m, k) / q[k];
                out.t_up[m](e, k) = x[1](m, k) / q[k];
            }
    });

    if (!internal_reflection) {
        out.quadrature.level = air_level.level;
        out.quadrature.estimated_error = air_level.error;
        out.quadrature.nodes = ws.evaluations;
        out.quadrature.directions = e_count;
        out.quadrature.probe_directions = static_cast<int>(air_probes.size());
        return out;
    }

    // Internal reflection: each pair of inside directions once (outgoing mu >= incident mu'), then
    // R = (Y + Y^T) / (q_i q_k), which is the full double integral because K^m is symmetric. The
    // incident rule runs over theta' of each piece, graded toward the piece's ends where the
    // reflected lobe meets an edge or the horizon, or switches to facet TIR (width ~ 2 alpha).
    std::vector<OuterNode> incident;
    const Level lv = Level::at(inside_level.level);
    for (int p = 0; p < side.pieces(); ++p) {
        const double t_hi = std::acos(side.edges[p]), t_lo = std::acos(side.edges[p + 1]); // theta range
        const bool layer_hi_mu = side.edges[p + 1] < 1.0; // mu = edges[p+1] < 1 is an edge
        GaussRules& gauss = ws.gauss;
        const double len = side.edges[p + 1] - side.edges[p];
        auto graded = [&](double a, double b, double centre) {
            std::vector<Break> br;
            graded_breaks(a, b, centre, sigma, br);
            br.push_back({a, None});
            br.push_back({b, None});
            std::sort(br.begin(), br.end(), [](const Break& x, const Break& y) { return x.theta < y.theta; });
            for (std::size_t i = 0; i + 1 < br.size(); ++i) {
                if (!(br[i + 1].theta - br[i].theta > 1e-13)) continue;
                const double ma = std::cos(br[i].theta), mb = std::cos(br[i + 1].theta);
                const double share = (ma - mb) * (ma + mb); // of int 2 mu dmu = 1
                const int cnt = lv.nodes(share, nodes_per_degree * (side.piece_size(p) - 1) * (ma - mb) / len);
                add_graded(br[i].theta, br[i + 1].theta, None, None, centre, sigma, cnt, p, share, gauss, incident);
            }
        };
        if (layer_hi_mu) {
            const double mid = 0.5 * (t_lo + t_hi);
            graded(t_lo, mid, t_lo);
            graded(mid, t_hi, t_hi);
        } else {
            graded(t_lo, t_hi, t_hi);
        }
    }
    // The incident nodes in a fixed number of runs, each summed on its own and the runs then in
    // order: the same sums whatever the number of cores.
    constexpr std::size_t runs_max = 8;
    const std::size_t runs = std::min(runs_max, incident.size());
    std::vector<std::vector<Matrix>> y(runs, std::vector<Matrix>(static_cast<std::size_t>(orders), Matrix(n, n)));
    for_each_on_cores(static_cast<int>(runs), ws, [&](int r, Workspace& w) {
        std::vector<double> ell(static_cast<std::size_t>(n));
        const std::size_t first = incident.size() * r / runs, last = incident.size() * (r + 1) / runs;
        for (std::size_t j = first; j < last; ++j) {
            const OuterNode& in = incident[j];
            const double mu_in = std::cos(in.theta);
            const auto x =
                direction_result(fc, Kind::ReflectInside, in.theta, side, in.theta, lv.within(in.share), orders, 1, w);
            const int p = in.piece, f = side.first[p], np = side.piece_size(p);
            side.basis(p, mu_in, ell.data());
            const double wt = in.weight * 2.0 * mu_in * std::sin(in.theta);
            for (int m = 0; m < orders; ++m) {
                Matrix& ym = y[static_cast<std::size_t>(r)][static_cast<std::size_t>(m)];
                for (int i = 0; i < n; ++i) {
                    const double xi = x[0](m, i) * wt;
                    if (xi == 0.0) continue;
                    for (int k = 0; k < np; ++k) ym(i, f + k) += xi * ell[static_cast<std::size_t>(k)];
                }
            }
        }
    });
    for (std::size_t r = 1; r < runs; ++r)
        for (int m = 0; m < orders; ++m) y[0][static_cast<std::size_t>(m)] += y[r][static_cast<std::size_t>(m)];
    const Matrix none(n, n); // no incident node
    for (int m = 0; m < orders; ++m) {
        const Matrix& ym = runs > 0 ? y[0][static_cast<std::size_t>(m)] : none;
        for (int i = 0; i < n; ++i)
            for (int k = 0; k < n; ++k) out.r_inside[m](i, k) = (ym(i, k) + ym(k, i)) / (q[i] * q[k]);
    }

    out.quadrature.level = std::max(air_level.level, inside_level.level);
    out.quadrature.estimated_error = std::max(air_level.error, inside_level.error);
    out.quadrature.nodes = ws.evaluations;
    out.quadrature.directions = e_count + static_cast<int>(incident.size());
    out.quadrature.probe_directions = static_cast<int>(air_probes.size() + inside_probes.size());
    return out;
}

std::vector<Matrix> air_reflection_orders(const RoughInterface& surface, std::span<const double> air_mu, int orders,
                                          double tolerance, QuadratureReport* report) {
    const char* what = "rough interface air reflection";
    check_tolerance(tolerance, what);
    if (orders < 1 || orders > 512) throw InputError(cat(what, ": orders must be in [1, 512] (got ", orders, ")"));
    for (double u : air_mu) check_cosine(u, what);
    const Facets fc(surface);
    const int e_count = static_cast<int>(air_mu.size());
    Workspace ws;
    std::vector<double> k(static_cast<std::size_t>(orders));
    auto pair_orders = [&](double mu_o, double mu_i, int level) {
        std::fill(k.begin(), k.end(), 0.0);
        const Pair p = make_pair(fc, Kind::ReflectAir, mu_i, sine_of(mu_i), mu_o, sine_of(mu_o));
        azimuth_orders(fc, Kind::ReflectAir, p, Level::at(level), orders, 1, 1.0, k.data(), ws);
        return k;
    };
    // Probes: diagonal pairs (the narrowest lobes) and neighbours at the extreme and middle cosines.
    std::vector<std::pair<double, double>> probes;
    if (e_count > 0) {
        std::vector<double> sorted(air_mu.begin(), air_mu.end());
        std::sort(sorted.begin(), sorted.end());
        for (std::size_t i : {std::size_t{0}, sorted.size() / 2, sorted.size() - 1}) {
            probes.push_back({sorted[i], sorted[i]});
            if (i + 1 < sorted.size()) probes.push_back({sorted[i], sorted[i + 1]});
        }
    }
    int level = start_level(tolerance);
    double error = 0.0;
    for (;; ++level) {
        if (level + 1 >= max_level)
            throw NumericalError(cat(what, ": quadrature did not converge to ", tolerance, " (", error, ")"));
        error = 0.0;
        for (const auto& [a, b] : probes) {
            const std::vector<double> coarse = pair_orders(a, b, level);
            const std::vector<double> fine = pair_orders(a, b, level + 1);
            if (!(fine[0] > 0.0)) continue;
            for (int m = 0; m < orders; ++m) error = std::max(error, std::abs(fine[m] - coarse[m]) / fine[0]);
        }
        if (error <= tolerance) break;
    }
    ++level;
    ws.evaluations = 0;
    std::vector<Matrix> out(static_cast<std::size_t>(orders), Matrix(e_count, e_count));
    for (int e = 0; e < e_count; ++e)
        for (int f = e; f < e_count; ++f) {
            const std::vector<double> v = pair_orders(air_mu[e], air_mu[f], level);
            for (int m = 0; m < orders; ++m) out[m](e, f) = out[m](f, e) = v[m];
        }
    if (report) {
        report->level = level;
        report->estimated_error = error;
        report->nodes = ws.evaluations;
        report->directions = e_count * (e_count + 1) / 2;
        report->probe_directions = static_cast<int>(probes.size());
    }
    return out;
}

} // namespace brdf::rte
