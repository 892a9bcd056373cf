#pragma once
// Legendre moments of Mie phase functions, for one sphere or a weighted sum of spheres.
//
// The unpolarised intensity I(mu) = |S1(mu)|^2 + |S2(mu)|^2 of a series truncated at N terms is a
// polynomial of degree 2N in mu (pi_n has degree n-1, tau_n degree n; B&H 4.46-4.47), so its
// Legendre moments beta_l vanish for l > 2N and (2l+1)/2 int I P_l dmu has degree <= 4N. A
// Gauss-Legendre rule with 2N + 2 nodes (exact to degree 4N + 3) therefore gives every beta_l exactly
// up to rounding: no truncation error, no aliasing (the classical alternative, the Dave 1970 /
// Mishchenko 1991 closed-form sums over products a_n a_k*, costs O(N^3)). The nodes come in pairs
// +-mu_j; pi_n(-mu) = (-1)^(n-1) pi_n(mu) and tau_n(-mu) = (-1)^n tau_n(mu) (B&H section 4.3), so the series
// is summed once per pair, split by the parity of n, which halves the work.
//
// A size distribution adds many spheres with weights (number density x quadrature weight in radius)
// and projects once at the end: the averaged phase function is sum_k w_k I_k / sum_k w_k int I_k
// (docs/physics.md section 2), which is what the accumulated intensities give.

#include <brdf/core/quadrature.h>
#include <brdf/mie/mie.h>

#include <memory>
#include <vector>

namespace brdf::mie {

/// Which compiled set of the series and projection kernels this CPU runs ("avx512-fma", "avx2-fma"
/// or "baseline"; the environment variable BRDF_MIE_KERNELS may name a narrower one): the sets
/// round differently (FMA or not), so whatever stores results across runs keys them by it. The
/// real-index coefficients' lanes (mie.cpp) follow the same choice, with the same bits in each.
const char* series_kernels();

class PhaseFunctionAccumulator {
public:
    /// Prepares the angular rule for series of up to `max_terms` terms (2 max_terms + 2 nodes).
    /// max_terms >= 1; LimitError when the rule would exceed the quadrature module's limit.
    explicit PhaseFunctionAccumulator(int max_terms);

    int max_terms() const { return m_max_terms; }

    /// Adds weight * (|S1|^2 + |S2|^2) at every node. c.size() <= max_terms(), weight >= 0.
    void add(const Coefficients& c, double weight);

    /// Number of node pairs +-mu_j (max_terms() + 1): the size of partial sums.
    std::size_t pairs() const { return m_mu.size(); }
    /// Like add(), into caller-owned partial sums of I(+mu_j) and I(-mu_j) (each pairs() long), for
    /// integrations that decide later which evaluations to keep. Thread-safe. `work` is the
    /// caller's working storage, reused from call to call (mie.h, SeriesWork, says why not
    /// thread_local); the overload without it allocates its own.
    void accumulate(const Coefficients& c, double weight, double* plus, double* minus, std::vector<double>& work) const;
    void accumulate(const Coefficients& c, double weight, double* plus, double* minus) const;
    /// The Gauss weights of the positive nodes (those of -mu_j are the same), pairs() long.
    const std::vector<double>& weights() const { return m_weight; }
    /// Adds partial sums made by accumulate().
    void add_sums(const std::vector<double>& plus, const std::vector<double>& minus);

    /// int_{-1}^{1} of the accumulated intensity (exact). For one sphere with weight 1 it equals
    /// x^2 Qsca (from C_sca = (pi / k^2) int (|S1|^2 + |S2|^2) dmu, B&H chapter 4).
    double integral() const;

    /// Moments beta_l of the normalised accumulated phase function, beta_0 = 1, truncated as
    /// LegendreOptions says. Throws NumericalError if nothing (or only zeros) was accumulated.
    std::vector<double> legendre(const LegendreOptions& options = {}) const;

    /// Forgets the accumulated intensity (the rule is kept).
    void clear();

private:
    /// beta_0 .. beta_{l_last} of the accumulated intensity (integral `total`), untruncated.
    std::vector<double> project(std::size_t half, int l_last, double total) const;

    int m_max_terms;
    std::shared_ptr<const Quadrature> m_rule;
    std::vector<double> m_mu;     ///< the positive nodes mu_j, j = 0 .. max_terms
    std::vector<double> m_weight; ///< their Gauss weights
    std::vector<double> m_plus;   ///< accumulated I(+mu_j)
    std::vector<double> m_minus;  ///< accumulated I(-mu_j)
    static constexpr std::size_t recurrence_stride = 5;
    std::vector<double> m_recurrence; ///< per order: c_n, n c_n, (n+2) c_{n+1}, (2n+1)/n, (n+1)/n
    std::vector<double> m_work;       ///< add()'s working storage for accumulate()
};

} // namespace brdf::mie
