#include <brdf/preview/render.h>

#include <brdf/material/colour.h>

#include <brdf/core/threads.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>

#include <cmath>
#include <memory>
#include <numbers>

namespace brdf::preview {
namespace {

constexpr double pi = std::numbers::pi;

struct Vec {
    double x = 0.0, y = 0.0, z = 0.0;
};
Vec operator+(Vec a, Vec b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec operator-(Vec a, Vec b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec operator*(double s, Vec a) { return {s * a.x, s * a.y, s * a.z}; }
double dot(Vec a, Vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec cross(Vec a, Vec b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
Vec normalize(Vec a) { return (1.0 / std::sqrt(dot(a, a))) * a; }

double radians(double degrees) { return degrees * pi / 180.0; }
double safe_acos(double c) { return std::acos(std::clamp(c, -1.0, 1.0)); }

/// Any unit vector perpendicular to the unit vector n.
Vec perpendicular(Vec n) {
    const Vec a = std::abs(n.x) < 0.9 ? Vec{1.0, 0.0, 0.0} : Vec{0.0, 1.0, 0.0};
    return normalize(cross(n, a));
}

/// phi folded into [0, pi] (the BRDF is isotropic and reciprocal in azimuth).
double fold_phi(double phi) {
    phi = std::fmod(std::abs(phi), 2.0 * pi);
    return phi > pi ? 2.0 * pi - phi : phi;
}

/// The tangent frame of a surface point: t1 towards the viewer's azimuth (so phi_o = 0), t2 = n x t1.
struct Frame {
    Vec n, t1, t2;
    Frame(Vec normal, Vec view) : n(normal) {
        const Vec t = view - dot(view, normal) * normal;
        t1 = dot(t, t) > 1e-18 ? normalize(t) : perpendicular(normal);
        t2 = cross(n, t1);
    }
    /// phi = phi_o - phi_i of direction d (docs/design.md), folded into [0, pi].
    double phi(Vec d) const { return fold_phi(std::atan2(dot(d, t2), dot(d, t1))); }
    /// cos(phi(d)) without the angle (1 for d along the normal, where atan2 gives phi = 0).
    double cos_phi(Vec d) const {
        const double x = dot(d, t1), y = dot(d, t2), h = std::sqrt(x * x + y * y);
        return h > 0.0 ? std::clamp(x / h, -1.0, 1.0) : 1.0;
    }
};

Rgb sky(Vec d, double scale) {
    // A simple overcast-to-blue gradient: white at the horizon, blue overhead, a brownish ground with a
    // short blend below the horizon so the mirror image has no hard line.
    const Rgb zenith{0.35, 0.5, 0.9}, horizon{1.0, 1.0, 1.0}, ground{0.25, 0.22, 0.18};
    Rgb out;
    if (d.y >= 0.0)
        for (int c = 0; c < 3; ++c) out[c] = scale * (horizon[c] + (zenith[c] - horizon[c]) * d.y);
    else {
        const double t = std::min(1.0, -d.y * 10.0);
        for (int c = 0; c < 3; ++c) out[c] = scale * (horizon[c] + (ground[c] - horizon[c]) * t);
    }
    return out;
}

struct Light {
    std::vector<Vec> directions; ///< fixed samples over the disc (one for a point light)
    Vec centre;
    double cos_radius = 1.0;     ///< cosine of the disc's angular radius
    Rgb irradiance{};            ///< per sample
    Rgb radiance{};              ///< of the disc, for its mirror image (0 for a point light)
};

Light make_light(const RenderOptions& o) {
    Light l;
    const double th = radians(o.light_theta_deg), ph = radians(o.light_phi_deg);
    l.centre = {std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
    if (o.light_irradiance <= 0.0) return l;
    const double alpha = radians(0.5 * o.light_size_deg);
    if (alpha <= 0.0) {
        l.directions.push_back(l.centre);
    } else {
        // Vogel's spiral: uniform in solid angle over the cone, deterministic.
        const int count = 32;
        const Vec a1 = perpendicular(l.centre), a2 = cross(l.centre, a1);
        l.cos_radius = std::cos(alpha);
        const double golden = pi * (3.0 - std::sqrt(5.0));
        for (int k = 0; k < count; ++k) {
            const double cb = 1.0 - (k + 0.5) / count * (1.0 - l.cos_radius);
            const double sb = std::sqrt(std::max(0.0, 1.0 - cb * cb)), psi = golden * k;
            l.directions.push_back(sb * std::cos(psi) * a1 + sb * std::sin(psi) * a2 + cb * l.centre);
        }
        const double solid_angle = 2.0 * pi * (1.0 - l.cos_radius);
        for (int c = 0; c < 3; ++c) l.radiance[c] = o.light_irradiance * o.light_colour[c] / solid_angle;
    }
    for (int c = 0; c < 3; ++c)
        l.irradiance[c] = o.light_irradiance * o.light_colour[c] / static_cast<double>(l.directions.size());
    return l;
}

class Tabulated {
public:
    Tabulated(const BrdfFunction& f, int nt, int np, int threads) : m_nt(nt), m_np(np) {
        m_values.resize(static_cast<std::size_t>(nt) * nt * np);
        m_step = 0.5 * pi / nt;
        // Reciprocity: f(ti, to, phi) = f(to, ti, phi); fill i <= o and copy.
        parallel_for(nt, threads, [&](int i) {
            for (int o = i; o < nt; ++o)
                for (int p = 0; p < np; ++p) {
                    const double phi = np > 1 ? pi * p / (np - 1) : 0.0;
                    const Rgb v = f((i + 0.5) * m_step, (o + 0.5) * m_step, phi);
                    for (int c = 0; c < 3; ++c)
                        if (!std::isfinite(v[c]))
                            throw NumericalError(cat("preview: BRDF is not finite at theta_i ", (i + 0.5) * m_step,
                                                     ", theta_o ", (o + 0.5) * m_step, ", phi ", phi, " (radians)"));
                    m_values[index(i, o, p)] = v;
                    m_values[index(o, i, p)] = v;
                }
        });
    }
    Rgb operator()(double ti, double to, double phi) const {
        if (ti >= 0.5 * pi || to >= 0.5 * pi) return {0.0, 0.0, 0.0};
        int i0, o0, p0;
        double fi, fo, fp;
        locate(ti / m_step - 0.5, m_nt, i0, fi);
        locate(to / m_step - 0.5, m_nt, o0, fo);
        locate(m_np > 1 ? fold_phi(phi) / pi * (m_np - 1) : 0.0, m_np, p0, fp);
        Rgb out{0.0, 0.0, 0.0};
        for (int a = 0; a < 2; ++a)
            for (int b = 0; b < 2; ++b)
                for (int d = 0; d < 2; ++d) {
                    const double w = (a ? fi : 1.0 - fi) * (b ? fo : 1.0 - fo) * (d ? fp : 1.0 - fp);
                    if (w == 0.0) continue;
                    const Rgb& v = m_values[index(std::min(i0 + a, m_nt - 1), std::min(o0 + b, m_nt - 1),
                                                  std::min(p0 + d, m_np - 1))];
                    for (int c = 0; c < 3; ++c) out[c] += w * v[c];
                }
        return out;
    }

private:
    std::size_t index(int i, int o, int p) const {
        return (static_cast<std::size_t>(i) * m_nt + o) * m_np + p;
    }
    static void locate(double u, int n, int& k, double& frac) {
        u = std::clamp(u, 0.0, static_cast<double>(n - 1));
        k = std::min(static_cast<int>(u), n - 1);
        frac = u - k;
    }
    int m_nt, m_np;
    double m_step = 0.0;
    std::vector<Rgb> m_values;
};

} // namespace

Environment parse_environment(const std::string& name) {
    if (name == "none") return Environment::None;
    if (name == "constant") return Environment::Constant;
    if (name == "sky") return Environment::Sky;
    throw InputError(cat("environment: expected none, constant or sky (got '", name, "')"));
}

void check_options(const RenderOptions& o) {
    const auto require = [](bool ok, const std::string& what) {
        if (!ok) throw InputError(cat("render: ", what));
    };
    require(o.size >= 8 && o.size <= 8192, cat("size must be in [8, 8192] pixels (got ", o.size, ")"));
    require(o.supersample >= 1 && o.supersample <= 8, cat("supersample must be in [1, 8] (got ", o.supersample, ")"));
    require(o.margin >= 0.0 && o.margin < 0.45, cat("margin must be in [0, 0.45) (got ", o.margin, ")"));
    require(o.light_theta_deg >= 0.0 && o.light_theta_deg <= 180.0,
            cat("light theta must be in [0, 180] degrees (got ", o.light_theta_deg, ")"));
    require(std::isfinite(o.light_phi_deg), "light phi must be a finite number of degrees");
    require(o.light_size_deg >= 0.0 && o.light_size_deg <= 90.0,
            cat("light size must be in [0, 90] degrees (got ", o.light_size_deg, ")"));
    require(o.light_irradiance >= 0.0 && std::isfinite(o.light_irradiance),
            cat("light irradiance must be >= 0 (got ", o.light_irradiance, ")"));
    require(o.environment_radiance >= 0.0 && std::isfinite(o.environment_radiance),
            cat("environment radiance must be >= 0 (got ", o.environment_radiance, ")"));
    require(o.environment_mu >= 1 && o.environment_mu <= 64 && o.environment_phi >= 1 && o.environment_phi <= 256,
            "environment rule must have 1..64 cos theta nodes and 1..256 azimuths");
    require((o.theta_nodes == 0 && o.phi_nodes == 0) ||
                (o.theta_nodes >= 2 && o.theta_nodes <= 512 && o.phi_nodes >= 2 && o.phi_nodes <= 721),
            "BRDF grid must be 0 x 0 (direct) or 2..512 zenith x 2..721 azimuth nodes");
    for (int c = 0; c < 3; ++c)
        require(std::isfinite(o.background[c]) && std::isfinite(o.light_colour[c]) && o.light_colour[c] >= 0.0,
                "background and light colour must be finite (light colour >= 0)");
}

BrdfFunction tabulate_brdf(const BrdfFunction& brdf, int theta_nodes, int phi_nodes, int threads) {
    auto table = std::make_shared<const Tabulated>(brdf, theta_nodes, phi_nodes, threads);
    return [table](double ti, double to, double phi) { return (*table)(ti, to, phi); };
}

Image render_sphere(const BrdfFunction& brdf_in, const RenderOptions& o) {
    check_options(o);
    const bool tabulated = o.theta_nodes > 0;
    const BrdfFunction brdf = tabulated ? tabulate_brdf(brdf_in, o.theta_nodes, o.phi_nodes, o.threads) : brdf_in;
    const Light light = make_light(o);
    const Vec view{0.0, 0.0, 1.0};

    // The environment's local rule: Gauss-Legendre in mu = cos theta_i on (0, 1) times the midpoint
    // rule in azimuth (exact for the azimuthal Fourier orders below environment_phi / 2).
    struct Node {
        double mu, sin, theta, weight;
    };
    std::vector<Node> mu_nodes;
    if (o.environment != Environment::None && o.environment_radiance > 0.0) {
        const Quadrature q = gauss_legendre(o.environment_mu, 0.0, 1.0);
        for (std::size_t a = 0; a < q.size(); ++a)
            mu_nodes.push_back({q.x[a], std::sqrt(1.0 - q.x[a] * q.x[a]), std::acos(q.x[a]),
                                q.w[a] * 2.0 * pi / o.environment_phi});
    }
    const auto environment = [&](Vec d) -> Rgb {
        if (o.environment == Environment::Constant)
            return {o.environment_radiance, o.environment_radiance, o.environment_radiance};
        if (o.environment == Environment::Sky) return sky(d, o.environment_radiance);
        return {0.0, 0.0, 0.0};
    };

    Image image(o.size, o.size, o.background);
    const double centre = 0.5 * o.size, radius = 0.5 * o.size * (1.0 - 2.0 * o.margin);
    const int ss = o.supersample;
    const double sub_weight = 1.0 / (ss * ss);

    parallel_for(o.size, o.threads, [&](int py) {
        for (int px = 0; px < o.size; ++px) {
            Rgb sum{0.0, 0.0, 0.0};
            double covered = 0.0, cx = 0.0, cy = 0.0;
            for (int sy = 0; sy < ss; ++sy)
                for (int sx = 0; sx < ss; ++sx) {
                    const double x = (px + (sx + 0.5) / ss - centre) / radius;
                    const double y = (centre - (py + (sy + 0.5) / ss)) / radius;
                    const double r2 = x * x + y * y;
                    if (r2 >= 1.0) continue;
                    covered += sub_weight;
                    cx += x;
                    cy += y;
                    const Vec n{x, y, std::sqrt(1.0 - r2)};
                    const Frame frame(n, view);
                    const double mu_o = n.z, theta_o = safe_acos(mu_o);
                    // Direct light over the disc. The cosine and the horizon sample by sample (the
                    // soft terminator); a rough lobe too (as narrow as the disc). The tabulated body is
                    // trilinear on a grid of several degrees: over a disc of a few degrees its
                    // cosine-weighted mean is nearly its value at the disc's cosine-weighted
                    // centroid (within one 8-bit step: RenderSphere.DiscCentroidLookupMatchesSampleBySample),
                    // one lookup instead of one per sample (32 per sub-pixel: most of the render).
                    double disc_cosine = 0.0;
                    Vec centroid{0.0, 0.0, 0.0};
                    for (const Vec& d : light.directions) {
                        const double mu_i = dot(n, d);
                        if (mu_i <= 0.0) continue;
                        if (tabulated) {
                            disc_cosine += mu_i;
                            centroid = centroid + mu_i * d;
                            if (!o.lobe) continue;
                        }
                        Rgb f = tabulated ? Rgb{0.0, 0.0, 0.0} : brdf(safe_acos(mu_i), theta_o, frame.phi(d));
                        if (o.lobe) {
                            const Rgb l = o.lobe(mu_i, mu_o, frame.cos_phi(d));
                            for (int c = 0; c < 3; ++c) f[c] += l[c];
                        }
                        for (int c = 0; c < 3; ++c) sum[c] += sub_weight * f[c] * light.irradiance[c] * mu_i;
                    }
                    if (disc_cosine > 0.0) {
                        const Vec d = (1.0 / std::sqrt(dot(centroid, centroid))) * centroid;
                        const Rgb f = brdf(safe_acos(dot(n, d)), theta_o, frame.phi(d));
                        for (int c = 0; c < 3; ++c) sum[c] += sub_weight * f[c] * light.irradiance[c] * disc_cosine;
                    }
                    // The rough lobe sees the environment around the mirror direction.
                    if (o.lobe_albedo && !mu_nodes.empty()) {
                        const Rgb a = o.lobe_albedo(theta_o);
                        const Rgb env = environment(2.0 * mu_o * n - view);
                        for (int c = 0; c < 3; ++c) sum[c] += sub_weight * a[c] * env[c];
                    }
                    // The interface mirrors the environment and the light's disc.
                    if (o.mirror) {
                        const Rgb fr = o.mirror(theta_o);
                        const Vec r = 2.0 * mu_o * n - view;
                        const Rgb env = environment(r);
                        const bool in_disc = !light.directions.empty() && light.cos_radius < 1.0 &&
                                             dot(r, light.centre) >= light.cos_radius;
                        for (int c = 0; c < 3; ++c)
                            sum[c] += sub_weight * fr[c] * (env[c] + (in_disc ? light.radiance[c] : 0.0));
                    }
                }
            if (covered == 0.0) continue;
            // The environment varies slowly over a pixel: integrate it once, at the mean covered normal.
            if (!mu_nodes.empty()) {
                const double k = sub_weight / covered;
                double x = cx * k, y = cy * k;
                const double r2 = x * x + y * y;
                if (r2 > 1.0 - 1e-12) {
                    const double s = std::sqrt((1.0 - 1e-12) / r2);
                    x *= s;
                    y *= s;
                }
                const Vec n{x, y, std::sqrt(std::max(0.0, 1.0 - x * x - y * y))};
                const Frame frame(n, view);
                const double theta_o = safe_acos(n.z);
                Rgb env_sum{0.0, 0.0, 0.0};
                for (const Node& a : mu_nodes)
                    for (int b = 0; b < o.environment_phi; ++b) {
                        const double psi = (b + 0.5) * 2.0 * pi / o.environment_phi;
                        const Vec d = a.sin * std::cos(psi) * frame.t1 + a.sin * std::sin(psi) * frame.t2 + a.mu * n;
                        const Rgb f = brdf(a.theta, theta_o, fold_phi(psi));
                        const Rgb le = environment(d);
                        for (int c = 0; c < 3; ++c) env_sum[c] += f[c] * le[c] * a.mu * a.weight;
                    }
                for (int c = 0; c < 3; ++c) sum[c] += covered * env_sum[c];
            }
            float* p = image.at(px, py);
            for (int c = 0; c < 3; ++c)
                p[c] = static_cast<float>(sum[c] + (1.0 - covered) * o.background[c]);
        }
    });
    return image;
}

BrdfFunction in_rec709(BrdfFunction brdf, material::ColorSpace space) {
    if (space == material::ColorSpace::Rec709 || !brdf) return brdf;
    return [brdf = std::move(brdf), m = material::rgb_to_rec709_matrix(space)](double ti, double to, double phi) {
        return material::clip_negative(material::apply_matrix(m, brdf(ti, to, phi)));
    };
}

MirrorFunction in_rec709(MirrorFunction mirror, material::ColorSpace space) {
    if (space == material::ColorSpace::Rec709 || !mirror) return mirror;
    return [mirror = std::move(mirror), m = material::rgb_to_rec709_matrix(space)](double theta) {
        return material::clip_negative(material::apply_matrix(m, mirror(theta)));
    };
}

} // namespace brdf::preview
