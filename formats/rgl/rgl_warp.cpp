#include <formats/rgl/rgl_warp.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace brdf::formats::rgl {

namespace {

// Linear interpolation written as Dr.Jit's lerp (b t + (a - a t)), so that rounding matches.
float lerp(float a, float b, float t) {
    return b * t + (a - a * t);
}

// Clamps to [0, 1]; NaN becomes 0, so that no later float-to-index conversion sees it.
float clamp01(float v) {
    return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;
}

// First index k in [first, last] with !below(k), or `last` when below() holds throughout: Dr.Jit's
// binary_search for a monotone predicate.
template <typename Below> std::uint32_t first_not_below(std::uint32_t first, std::uint32_t last,
                                                        const Below& below) {
    while (first < last) {
        const std::uint32_t middle = (first + last) / 2;
        if (below(middle))
            first = middle + 1;
        else
            last = middle;
    }
    return first;
}

} // namespace

PiecewiseLinearWarp::PiecewiseLinearWarp(const std::vector<float>& data, std::uint32_t width,
                                         std::uint32_t height,
                                         std::vector<std::vector<float>> params, bool normalize,
                                         bool sampling)
    : m_width(width), m_height(height), m_params(std::move(params)), m_normalized(normalize) {
    if (width < 2 || height < 2)
        throw InputError(cat("warp: grid ", width, " x ", height, " (at least 2 x 2 needed)"));
    if (m_params.size() > max_params)
        throw InputError(cat("warp: ", m_params.size(), " parameters (at most 3)"));
    m_patch = {1.0f / static_cast<float>(width - 1), 1.0f / static_cast<float>(height - 1)};
    m_inv_patch = {static_cast<float>(width - 1), static_cast<float>(height - 1)};
    // The last parameter varies fastest between slices; one with a single node does not vary.
    m_strides.assign(m_params.size(), 0);
    for (std::size_t d = m_params.size(); d-- > 0;) {
        if (m_params[d].empty()) throw InputError("warp: a parameter has no nodes");
        m_strides[d] = m_params[d].size() > 1 ? m_slices : 0;
        m_slices *= static_cast<std::uint32_t>(m_params[d].size());
    }
    const std::uint32_t n_data = width * height;
    if (data.size() != std::size_t{m_slices} * n_data)
        throw InputError(cat("warp: ", data.size(), " values for ", m_slices, " grids of ", width,
                             " x ", height));

    // CDFs accumulate in double and are stored in float (as Mitsuba does): trapezoids of the
    // bilinear interpolant along x per row (conditional), then of the row integrals along y
    // (marginal).
    const double scale_x = 0.5 / (width - 1), scale_y = 0.5 / (height - 1);
    m_data.resize(data.size());
    if (sampling) {
        m_marginal.resize(std::size_t{m_slices} * (height - 1));
        m_conditional.resize(std::size_t{m_slices} * height * (width - 1));
    }
    std::vector<double> row_total(height);
    for (std::uint32_t s = 0; s < m_slices; ++s) {
        const float* in = data.data() + std::size_t{s} * n_data;
        float norm = 1.0f;
        if (sampling) {
            float* cond = m_conditional.data() + std::size_t{s} * height * (width - 1);
            float* marg = m_marginal.data() + std::size_t{s} * (height - 1);
            for (std::uint32_t y = 0; y < height; ++y) {
                double accum = 0.0;
                for (std::uint32_t x = 0; x + 1 < width; ++x) {
                    const std::uint32_t i = y * width + x;
                    accum += scale_x * (double{in[i]} + double{in[i + 1]});
                    cond[y * (width - 1) + x] = static_cast<float>(accum);
                }
                row_total[y] = accum;
            }
            double accum = 0.0;
            for (std::uint32_t y = 0; y + 1 < height; ++y) {
                accum += scale_y * (row_total[y] + row_total[y + 1]);
                marg[y] = static_cast<float>(accum);
            }
            if (normalize) norm = static_cast<float>(1.0 / accum);
            for (std::uint32_t k = 0; k < height * (width - 1); ++k) cond[k] *= norm;
            for (std::uint32_t k = 0; k + 1 < height; ++k) marg[k] *= norm;
        } else if (normalize) {
            double sum = 0.0;
            for (std::uint32_t y = 0; y + 1 < height; ++y)
                for (std::uint32_t x = 0; x + 1 < width; ++x) {
                    const std::uint32_t i = y * width + x;
                    sum += double{in[i]} + double{in[i + 1]} + double{in[i + width]} +
                           double{in[i + width + 1]};
                }
            norm = static_cast<float>(1.0 / (scale_x * scale_y * sum));
        }
        float* out = m_data.data() + std::size_t{s} * n_data;
        for (std::uint32_t k = 0; k < n_data; ++k) out[k] = in[k] * norm;
    }
}

PiecewiseLinearWarp::Weights PiecewiseLinearWarp::weights(const float* param) const {
    Weights result;
    for (std::size_t d = 0; d < m_params.size(); ++d) {
        const std::vector<float>& nodes = m_params[d];
        if (nodes.size() == 1) {
            result.w[2 * d] = 1.0f;
            result.w[2 * d + 1] = 0.0f;
            continue;
        }
        const float p = param[d];
        // The interval [k, k + 1] with nodes[k] < p <= nodes[k + 1], clamped to the end intervals.
        const auto size = static_cast<std::uint32_t>(nodes.size());
        const std::uint32_t k =
            first_not_below(1, size - 1, [&](std::uint32_t i) { return nodes[i] < p; }) - 1;
        const float p0 = nodes[k], p1 = nodes[k + 1];
        const float w1 = std::min(std::max((p - p0) / (p1 - p0), 0.0f), 1.0f);
        result.w[2 * d + 1] = w1;
        result.w[2 * d] = 1.0f - w1;
        result.slice += m_strides[d] * k;
    }
    return result;
}

float PiecewiseLinearWarp::lookup(const std::vector<float>& table, std::uint32_t offset,
                                  std::uint32_t i0, std::uint32_t slice_size, const Weights& w,
                                  std::size_t dims) const {
    if (dims == 0) return table[i0 + offset];
    // The last parameter is blended outermost, as Mitsuba's recursion does.
    const std::uint32_t i1 = i0 + m_strides[dims - 1] * slice_size;
    const float v0 = lookup(table, offset, i0, slice_size, w, dims - 1);
    const float v1 = lookup(table, offset, i1, slice_size, w, dims - 1);
    return v0 * w.w[2 * dims - 2] + v1 * w.w[2 * dims - 1];
}

float PiecewiseLinearWarp::eval(Point2f pos, const float* param) const {
    const Weights w = weights(param);
    pos = {clamp01(pos.x) * m_inv_patch.x, clamp01(pos.y) * m_inv_patch.y};
    const std::uint32_t ox = std::min(static_cast<std::uint32_t>(pos.x), m_width - 2);
    const std::uint32_t oy = std::min(static_cast<std::uint32_t>(pos.y), m_height - 2);
    pos.x -= static_cast<float>(ox);
    pos.y -= static_cast<float>(oy);
    const std::uint32_t size = m_width * m_height;
    const std::uint32_t index = ox + oy * m_width + w.slice * size;
    const float v00 = lookup(m_data, 0, index, size, w), v10 = lookup(m_data, 1, index, size, w),
                v01 = lookup(m_data, m_width, index, size, w),
                v11 = lookup(m_data, m_width + 1, index, size, w);
    return lerp(lerp(v00, v10, pos.x), lerp(v01, v11, pos.x), pos.y);
}

float PiecewiseLinearWarp::sample_segment(float u, float inv_width, float v0, float v1) const {
    // Inverts the CDF of the linear density v0 .. v1 over one patch (a quadratic).
    const bool non_constant = std::abs(v0 - v1) > 1e-4f * (v0 + v1);
    const float divisor = non_constant ? v0 - v1 : v0 + v1;
    u *= 2.0f * inv_width;
    if (non_constant) u = v0 - std::sqrt(std::max(v0 * v0 + u * (v1 - v0), 0.0f));
    if (divisor != 0.0f) u /= divisor;
    return u;
}

float PiecewiseLinearWarp::invert_segment(float u, float width, float v0, float v1) const {
    return u * lerp(v0, v1, 0.5f * u) * width;
}

std::pair<Point2f, float> PiecewiseLinearWarp::sample(Point2f u, const float* param) const {
    if (m_marginal.empty()) throw InputError("warp: sample() on a warp built without sampling");
    const std::uint32_t n_cond = m_height * (m_width - 1), n_marg = m_height - 1,
                        n_data = m_width * m_height;
    const Weights w = weights(param);
    constexpr float eps = std::numeric_limits<float>::epsilon() / 2; // Dr.Jit's Epsilon<float>
    u.x = std::min(std::max(u.x, eps), 1.0f - eps);
    u.y = std::min(std::max(u.y, eps), 1.0f - eps);

    const std::uint32_t offset_marg = w.slice * n_marg;
    const auto marginal = [&](std::uint32_t i) {
        return lookup(m_marginal, 0, offset_marg + i, n_marg, w);
    };
    if (!m_normalized) u.y *= marginal(n_marg - 1);
    const std::uint32_t row =
        first_not_below(0, n_marg - 1, [&](std::uint32_t i) { return marginal(i) < u.y; });
    if (row > 0) u.y -= marginal(row - 1);

    const std::uint32_t offset_cond = w.slice * n_cond + row * (m_width - 1);
    const float r0 = lookup(m_conditional, m_width - 2, offset_cond, n_cond, w),
                r1 = lookup(m_conditional, 2 * (m_width - 1) - 1, offset_cond, n_cond, w);
    u.y = sample_segment(u.y, m_inv_patch.y, r0, r1);
    u.x *= lerp(r0, r1, u.y);

    const auto conditional = [&](std::uint32_t i) {
        const float c0 = lookup(m_conditional, 0, offset_cond + i, n_cond, w);
        const float c1 = lookup(m_conditional, m_width - 1, offset_cond + i, n_cond, w);
        return lerp(c0, c1, u.y);
    };
    const std::uint32_t col =
        first_not_below(0, m_width - 1, [&](std::uint32_t i) { return conditional(i) < u.x; });
    if (col > 0) u.x -= conditional(col - 1);

    const std::uint32_t offset_data = w.slice * n_data + row * m_width + col;
    const float v00 = lookup(m_data, 0, offset_data, n_data, w),
                v10 = lookup(m_data, 1, offset_data, n_data, w),
                v01 = lookup(m_data, m_width, offset_data, n_data, w),
                v11 = lookup(m_data, m_width + 1, offset_data, n_data, w);
    const float c0 = lerp(v00, v01, u.y), c1 = lerp(v10, v11, u.y);
    u.x = sample_segment(u.x, m_inv_patch.x, c0, c1);
    return {{(static_cast<float>(col) + u.x) * m_patch.x,
             (static_cast<float>(row) + u.y) * m_patch.y},
            lerp(c0, c1, u.x)};
}

std::pair<Point2f, float> PiecewiseLinearWarp::invert(Point2f p, const float* param) const {
    if (m_marginal.empty()) throw InputError("warp: invert() on a warp built without sampling");
    const std::uint32_t n_cond = m_height * (m_width - 1), n_marg = m_height - 1,
                        n_data = m_width * m_height;
    const Weights w = weights(param);
    p = {clamp01(p.x) * m_inv_patch.x, clamp01(p.y) * m_inv_patch.y};
    const std::uint32_t px = std::min(static_cast<std::uint32_t>(p.x), m_width - 2);
    const std::uint32_t py = std::min(static_cast<std::uint32_t>(p.y), m_height - 2);
    p.x -= static_cast<float>(px);
    p.y -= static_cast<float>(py);

    const std::uint32_t offset_data = w.slice * n_data + py * m_width + px;
    const float v00 = lookup(m_data, 0, offset_data, n_data, w),
                v10 = lookup(m_data, 1, offset_data, n_data, w),
                v01 = lookup(m_data, m_width, offset_data, n_data, w),
                v11 = lookup(m_data, m_width + 1, offset_data, n_data, w);
    const float c0 = lerp(v00, v01, p.y), c1 = lerp(v10, v11, p.y);
    const float density = lerp(c0, c1, p.x);
    p.x = invert_segment(p.x, m_patch.x, c0, c1);

    const std::uint32_t offset_cond = w.slice * n_cond + py * (m_width - 1);
    if (px > 0) {
        const float a = lookup(m_conditional, 0, offset_cond + px - 1, n_cond, w);
        const float b = lookup(m_conditional, m_width - 1, offset_cond + px - 1, n_cond, w);
        p.x += lerp(a, b, p.y);
    }
    const float r0 = lookup(m_conditional, m_width - 2, offset_cond, n_cond, w),
                r1 = lookup(m_conditional, 2 * (m_width - 1) - 1, offset_cond, n_cond, w);
    p.x /= lerp(r0, r1, p.y);
    p.y = invert_segment(p.y, m_patch.y, r0, r1);
    const std::uint32_t offset_marg = w.slice * n_marg;
    if (py > 0) p.y += lookup(m_marginal, 0, offset_marg + py - 1, n_marg, w);
    if (!m_normalized) p.y /= lookup(m_marginal, 0, offset_marg + n_marg - 1, n_marg, w);
    return {p, density};
}

} // namespace brdf::formats::rgl
