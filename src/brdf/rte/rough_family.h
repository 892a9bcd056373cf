#pragma once
// A rough top's interface kernels (rough_interface.h) for every wavelength of one material at once.
//
// The interface depends on the wavelength only through the binder's index n, and smoothly: the
// kernels of one surface and stream count are analytic in n (Fresnel factors, refracted directions
// and the critical-angle split of the streams all are). Across the visible a binder's index moves
// by 1-4 % (PMMA 1.49-1.51), so the kernels at a few Chebyshev-Lobatto indices of the material's
// range, interpolated in n (Lagrange, entry by entry), replace one quadrature per wavelength.
// Entry by entry is the right thing to interpolate: stream k of index n is the continuous
// deformation of stream k at every node index (the same Gauss rule on pieces whose edge, the
// critical cosine, moves with n), and what the body does with a kernel is a sum over the streams
// against a smooth field, so the result is the interpolant of a smooth function of n.
//
// Each set of air cosines (the table's grid, a probe set, an albedo rule) is computed at the node
// indices the first time any sample asks for it; the samples' threads share that work (each takes
// a node nobody has started) and every later sample only interpolates.

#include <brdf/rte/rough_interface.h>

#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

namespace brdf::rte {

/// The kernels at `tolerance`, or, where the quadrature cannot reach it (a few grazing air cosines
/// at small alpha reach 2.7e-6 at the finest level for 1e-6), at the nearest tenfold looser
/// tolerance it reaches, with a warning; NumericalError beyond 1e-3.
InterfaceKernels converged_interface_kernels(const RoughInterface& rough, const StreamPieces& pieces,
                                             std::span<const double> air, int orders, double tolerance,
                                             bool internal_reflection);

/// Chebyshev-Lobatto indices for a range of binder indices: one index where the range is a point,
/// else nodes >= 2 indices from n_lo to n_hi (both ends included).
std::vector<double> family_indices(double n_lo, double n_hi, int nodes);

/// How many indices (family_indices) interpolate the kernels over [n_lo, n_hi] to 1 % of the
/// kernels' quadrature tolerance (see rough_family.cpp for the measured error model); 1 for a point.
int family_nodes(double n_lo, double n_hi, double tolerance);

class RoughKernelFamily {
public:
    /// Kernels of `surface` for stream pieces split_gauss_pieces(n_below, n_above, mu_c(n)) (the top
    /// layer's streams of a single binder, mu_c = sqrt(1 - 1/n^2)), binder index in [n_lo, n_hi],
    /// at most `orders` Fourier orders, quadrature tolerance `tolerance`, from kernels at `nodes`
    /// indices (family_indices). Throws InputError for an empty or invalid range.
    RoughKernelFamily(RoughSurface surface, int n_below, int n_above, double n_lo, double n_hi, int nodes,
                      int orders, double tolerance);

    /// The top layer's stream pieces at index n, which a stack must have for this family to apply.
    StreamPieces pieces(double n) const;
    /// Whether the family serves a top layer of index n with these stream pieces, Fourier orders
    /// and kernel tolerance: n in the range, `pieces` are pieces(n) (same structure, nodes and
    /// weights within 1e-12), the same surface, orders at most the family's, the same tolerance.
    bool applies(double n, const RoughSurface& surface, const StreamPieces& pieces, int orders,
                 double tolerance) const;

    /// interface_kernels(RoughInterface(n, surface), pieces(n), air, orders, tolerance, internal)
    /// by interpolation in n (n within the range; orders at most the family's). Thread-safe.
    InterfaceKernels kernels(double n, std::span<const double> air, int orders, bool internal_reflection) const;

    const std::vector<double>& indices() const { return m_indices; }
    double tolerance() const { return m_tolerance; }

private:
    // The kernels of one set of air cosines at every node index, computed once.
    struct Entry {
        std::vector<double> air;
        int orders = 0;
        bool internal = false;
        std::vector<InterfaceKernels> at; // per node index
        std::vector<int> state;           // per node: 0 not started, 1 being computed, 2 done
        std::exception_ptr error;
        std::mutex mutex;
        std::condition_variable done;
    };
    std::shared_ptr<Entry> entry(std::span<const double> air, int orders, bool internal) const;
    void complete(Entry& e) const;

    RoughSurface m_surface;
    int m_below = 0, m_above = 0, m_orders = 0;
    double m_lo = 0.0, m_hi = 0.0, m_tolerance = 0.0;
    std::vector<double> m_indices;
    mutable std::mutex m_mutex;
    mutable std::vector<std::shared_ptr<Entry>> m_entries; // most recently used last
};

} // namespace brdf::rte
