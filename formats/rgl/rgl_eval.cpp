#include <formats/rgl/rgl_eval.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <numbers>

namespace brdf::formats {

namespace {

using rgl::PiecewiseLinearWarp;
using rgl::Point2f;

constexpr float pi_f = std::numbers::pi_v<float>;

struct Vec3f {
    float x, y, z;
};

// Zenith angle from the chord length to the pole: accurate near the pole, unlike acos(z) (the
// `elevation` of Mitsuba's measured.cpp).
float elevation(const Vec3f& d) {
    const float dist = std::sqrt(d.x * d.x + d.y * d.y + (d.z - 1.0f) * (d.z - 1.0f));
    return 2.0f * std::asin(std::min(std::max(0.5f * dist, -1.0f), 1.0f));
}

// The renderers' unit coordinates of an angle (sqrt spacing in theta crowds nodes at the pole).
float theta_to_u(float theta) {
    return std::sqrt(theta * (2.0f / pi_f));
}
float phi_to_u(float phi) {
    return (phi + pi_f) * (1.0f / (2.0f * pi_f));
}

// Dr.Jit's mulsign_neg: x with its sign flipped unless `s` has its sign bit set.
float mulsign_neg(float x, float s) {
    return std::signbit(s) ? x : -x;
}

std::uint32_t u32(std::size_t v) {
    return static_cast<std::uint32_t>(v);
}

} // namespace

RglEvaluator::RglEvaluator(RglBsdf bsdf) : m_bsdf(std::move(bsdf)) {
    if (const std::string fault = rgl_bsdf_fault(m_bsdf); !fault.empty())
        throw NumericalError(cat("RGL BSDF: ", fault));
    const RglBsdf& b = m_bsdf;
    if (!b.isotropic())
        m_reduction = static_cast<int>(
            std::rint((2.0f * pi_f) / (b.phi_i.back() - b.phi_i.front())));
    // Width is the last (fastest) index: theta for the ndf, sigma and vndf grids.
    m_ndf = PiecewiseLinearWarp(b.ndf.values, u32(b.ndf.shape[1]), u32(b.ndf.shape[0]), {}, false,
                                false);
    m_sigma = PiecewiseLinearWarp(b.sigma.values, u32(b.sigma.shape[1]), u32(b.sigma.shape[0]), {},
                                  false, false);
    m_vndf = PiecewiseLinearWarp(b.vndf.values, u32(b.vndf.shape[3]), u32(b.vndf.shape[2]),
                                 {b.phi_i, b.theta_i}, true, true);
    if (b.spectral())
        m_channel_params = b.wavelengths;
    else
        m_channel_params = {0.0f, 1.0f, 2.0f};
    m_values = PiecewiseLinearWarp(b.values.values, u32(b.values.shape[4]), u32(b.values.shape[3]),
                                   {b.phi_i, b.theta_i, m_channel_params}, false, false);
}

RglEvaluator::Query RglEvaluator::prepare(const Vec3& wi_d, const Vec3& wo_d) const {
    Query q;
    Vec3f wi{static_cast<float>(wi_d.x), static_cast<float>(wi_d.y), static_cast<float>(wi_d.z)};
    Vec3f wo{static_cast<float>(wo_d.x), static_cast<float>(wo_d.y), static_cast<float>(wo_d.z)};
    if (!(wi.z > 0.0f && wo.z > 0.0f)) return q;
    if (m_reduction >= 2) {
        const float sy = wi.y, sx = m_reduction == 4 ? wi.x : sy;
        wi.x = mulsign_neg(wi.x, sx);
        wi.y = mulsign_neg(wi.y, sy);
        wo.x = mulsign_neg(wo.x, sx);
        wo.y = mulsign_neg(wo.y, sy);
    }
    Vec3f m{wi.x + wo.x, wi.y + wo.y, wi.z + wo.z};
    const float inv_norm = 1.0f / std::sqrt(m.x * m.x + m.y * m.y + m.z * m.z);
    m = {m.x * inv_norm, m.y * inv_norm, m.z * inv_norm};

    q.theta_i = elevation(wi);
    q.phi_i = std::atan2(wi.y, wi.x);
    const float theta_m = elevation(m), phi_m = std::atan2(m.y, m.x);
    const Point2f u_wi{theta_to_u(q.theta_i), phi_to_u(q.phi_i)};
    Point2f u_m{theta_to_u(theta_m), phi_to_u(m_bsdf.isotropic() ? phi_m - q.phi_i : phi_m)};
    u_m.y = u_m.y - std::floor(u_m.y);

    const float params[2] = {q.phi_i, q.theta_i};
    q.sample = m_vndf.invert(u_m, params).first;
    if (m_bsdf.jacobian) q.factor = m_ndf.eval(u_m) / (4.0f * m_sigma.eval(u_wi));
    q.valid = true;
    return q;
}

float RglEvaluator::value(const Query& q, float channel_param) const {
    const float params[3] = {q.phi_i, q.theta_i, channel_param};
    return m_values.eval(q.sample, params) * q.factor;
}

std::vector<double> RglEvaluator::eval_cosine(const Vec3& wi, const Vec3& wo) const {
    std::vector<double> out(channels(), 0.0);
    const Query q = prepare(wi, wo);
    if (!q.valid) return out;
    for (std::size_t c = 0; c < out.size(); ++c) out[c] = value(q, m_channel_params[c]);
    return out;
}

double RglEvaluator::eval_cosine(const Vec3& wi, const Vec3& wo, double wavelength_nm) const {
    const Query q = prepare(wi, wo);
    return q.valid ? value(q, static_cast<float>(wavelength_nm)) : 0.0;
}

std::vector<double> RglEvaluator::brdf(const Vec3& wi, const Vec3& wo) const {
    std::vector<double> out = eval_cosine(wi, wo);
    const double cos_o = static_cast<float>(wo.z);
    for (double& v : out) v = cos_o > 0.0 ? v / cos_o : 0.0;
    return out;
}

double RglEvaluator::sample_factor(const Vec3& wi, const Vec3& wo) const {
    const Query q = prepare(wi, wo);
    return q.valid ? q.factor : 0.0;
}

rgl::Point2f RglEvaluator::sample_point(const Vec3& wi, const Vec3& wo) const {
    const Query q = prepare(wi, wo);
    return q.valid ? q.sample : rgl::Point2f{-1.0f, -1.0f};
}

RglProvenance rgl_provenance(const RglBsdf& bsdf) {
    RglProvenance p;
    const nlohmann::json j = nlohmann::json::parse(bsdf.description, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("generator") || !j["generator"].is_string())
        return p;
    p.ours = true;
    p.generator = j["generator"].get<std::string>();
    if (j.contains("spec")) p.spec = j["spec"].is_string() ? j["spec"].get<std::string>() : j["spec"].dump();
    return p;
}

} // namespace brdf::formats
