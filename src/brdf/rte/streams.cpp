#include <brdf/rte/streams.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>

#include <algorithm>

namespace brdf::rte {

Streams gauss_streams(int n) {
    if (n < 1) throw InputError(cat("streams: need at least one node (got ", n, ")"));
    const Quadrature q = gauss_legendre(n, 0.0, 1.0);
    return Streams{q.x, q.w, 2 * n - 1};
}

Streams split_gauss_streams(int n_below, int n_above, double split) {
    if (n_below < 1 || n_above < 1 || !(split > 0.0 && split < 1.0))
        throw InputError(cat("streams: bad split rule (", n_below, " + ", n_above, " nodes at ", split, ")"));
    const Quadrature lo = gauss_legendre(n_below, 0.0, split);
    const Quadrature hi = gauss_legendre(n_above, split, 1.0);
    Streams s;
    s.mu = lo.x;
    s.mu.insert(s.mu.end(), hi.x.begin(), hi.x.end());
    s.w = lo.w;
    s.w.insert(s.w.end(), hi.w.begin(), hi.w.end());
    s.exact_degree = 2 * std::min(n_below, n_above) - 1;
    return s;
}

} // namespace brdf::rte
