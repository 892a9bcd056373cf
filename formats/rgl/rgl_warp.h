#pragma once
// The piecewise-bilinear 2D warp behind the RGL parameterisation (Dupuy and Jakob, "An Adaptive
// Parameterization for Efficient Material Acquisition and Rendering", SIGGRAPH Asia 2018: sampling
// a bilinear interpolant by its marginal and conditional CDFs, and the inverse of that map), as
// Mitsuba 3's `measured` BSDF builds it (Marginal2D with continuous marginal and conditional, in
// include/mitsuba/core/distr_2d.h) and pbrt-v4's PiecewiseLinear2D. We reproduce that arithmetic in
// single precision, in the same order, so that our evaluator and the grids our writer makes match
// what those renderers compute to float rounding.
//
// A density on [0, 1]^2 is given at width x height nodes (x varies fastest), optionally one such grid
// per combination of up to three conditioning parameters (each with its own increasing list of
// node values; the grids are stored with the first parameter varying slowest). Between parameter
// nodes the grids are blended linearly; outside they are clamped to the end nodes.

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace brdf::formats::rgl {

struct Point2f {
    float x = 0.0f;
    float y = 0.0f;
};

class PiecewiseLinearWarp {
  public:
    static constexpr std::size_t max_params = 3;

    PiecewiseLinearWarp() = default;
    /// `data`: params[0].size() * ... * width * height values (>= 0), width and height >= 2, each
    /// parameter list non-empty and increasing. `normalize`: scale every grid to integrate to 1
    /// over the unit square (the warps of the file are normalised; ndf, sigma and the BRDF values
    /// are not). `sampling`: build the CDFs that sample() and invert() need. Throws InputError when
    /// the sizes do not fit.
    PiecewiseLinearWarp(const std::vector<float>& data, std::uint32_t width, std::uint32_t height,
                        std::vector<std::vector<float>> params, bool normalize, bool sampling);

    /// The (blended) bilinear interpolant at `pos` (clamped to the unit square). `param` holds one
    /// value per parameter.
    float eval(Point2f pos, const float* param = nullptr) const;

    /// Maps a uniform point of the unit square to a point distributed like the density; returns it
    /// with the density there.
    std::pair<Point2f, float> sample(Point2f u, const float* param = nullptr) const;

    /// The inverse of sample(): the uniform point that sample() maps to `p`, with the density at p.
    std::pair<Point2f, float> invert(Point2f p, const float* param = nullptr) const;

    std::uint32_t width() const { return m_width; }
    std::uint32_t height() const { return m_height; }

  private:
    struct Weights {
        std::uint32_t slice = 0;               ///< first slice of the blend
        std::array<float, 2 * max_params> w{}; ///< (w0, w1) per parameter
    };
    Weights weights(const float* param) const;
    // Blends `table` over the parameter slices: entry `i0 + offset` of the first slice and the
    // corresponding entries (stride `slice_size`) of the others.
    float lookup(const std::vector<float>& table, std::uint32_t offset, std::uint32_t i0,
                 std::uint32_t slice_size, const Weights& w, std::size_t dims) const;
    float lookup(const std::vector<float>& table, std::uint32_t offset, std::uint32_t i0,
                 std::uint32_t slice_size, const Weights& w) const {
        return lookup(table, offset, i0, slice_size, w, m_params.size());
    }
    float sample_segment(float u, float inv_width, float v0, float v1) const;
    float invert_segment(float u, float width, float v0, float v1) const;

    std::uint32_t m_width = 0, m_height = 0;
    Point2f m_patch{}, m_inv_patch{};
    std::vector<std::vector<float>> m_params;
    std::vector<std::uint32_t> m_strides; ///< in slices; 0 for a parameter with one node
    std::uint32_t m_slices = 1;
    bool m_normalized = false;
    std::vector<float> m_data;     ///< the grids, scaled when normalised
    std::vector<float> m_marginal; ///< per slice: height - 1 entries
    std::vector<float> m_conditional; ///< per slice: height rows of width - 1 entries
};

} // namespace brdf::formats::rgl
