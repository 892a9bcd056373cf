#include <brdf/core/linalg.h>

#include <brdf/core/error.h>
#include <brdf/core/lane_set.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <utility>

#include <cblas.h>
#include <lapacke.h>

namespace brdf {
namespace {

// OpenBLAS would otherwise start a thread pool of its own under every caller's parallel_for. The
// programs set one thread before main (core/serial_blas.cpp); setting it again would restart the
// pool that stopped there.
void single_threaded_blas() {
    static std::once_flag once;
    std::call_once(once, [] {
        if (openblas_get_num_threads() != 1) openblas_set_num_threads(1);
    });
}

void require_same_shape(const Matrix& a, const Matrix& b, const char* op) {
    if (a.rows() != b.rows() || a.cols() != b.cols())
        throw InputError(cat("matrix ", op, ": shapes differ (", a.rows(), "x", a.cols(), " vs ",
                             b.rows(), "x", b.cols(), ")"));
}

} // namespace

Matrix Matrix::identity(int n) {
    Matrix m(n, n);
    for (int i = 0; i < n; ++i) m(i, i) = 1.0;
    return m;
}

Matrix& Matrix::operator+=(const Matrix& b) {
    require_same_shape(*this, b, "+");
    for (std::size_t k = 0; k < m_data.size(); ++k) m_data[k] += b.m_data[k];
    return *this;
}

Matrix& Matrix::operator-=(const Matrix& b) {
    require_same_shape(*this, b, "-");
    for (std::size_t k = 0; k < m_data.size(); ++k) m_data[k] -= b.m_data[k];
    return *this;
}

Matrix& Matrix::operator*=(double s) {
    for (double& v : m_data) v *= s;
    return *this;
}

Matrix operator*(const Matrix& a, const Matrix& b) {
    if (a.cols() != b.rows())
        throw InputError(cat("matrix *: inner sizes differ (", a.cols(), " vs ", b.rows(), ")"));
    Matrix c(a.rows(), b.cols());
    gemm(a, false, b, false, c);
    return c;
}

Matrix operator+(Matrix a, const Matrix& b) { return a += b; }
Matrix operator-(Matrix a, const Matrix& b) { return a -= b; }
Matrix operator*(double s, Matrix a) { return a *= s; }

Matrix transpose(const Matrix& a) {
    Matrix t(a.cols(), a.rows());
    for (int i = 0; i < a.rows(); ++i)
        for (int j = 0; j < a.cols(); ++j) t(j, i) = a(i, j);
    return t;
}

namespace {

// The largest |value(k)| over k < count, 0 for none; a NaN is passed over, as std::max(m, NaN)
// keeps m. Eight running maxima side by side, then the largest of them: the same answer as one
// running maximum (max is exact and order-free), without its chain of dependent comparisons,
// which had been 8 % of the stream check's host solves (the order solvers' convergence tests).
template <typename Value> double largest_magnitude(std::size_t count, Value value) {
    constexpr std::size_t lanes = 8;
    double m[lanes] = {};
    std::size_t k = 0;
    for (; k + lanes <= count; k += lanes)
        for (std::size_t l = 0; l < lanes; ++l) {
            const double v = std::abs(value(k + l));
            m[l] = m[l] < v ? v : m[l];
        }
    for (; k < count; ++k) m[0] = std::max(m[0], std::abs(value(k)));
    double out = 0.0;
    for (double v : m) out = std::max(out, v);
    return out;
}

} // namespace

double max_abs(const Matrix& a) {
    const double* x = a.data().data();
    return largest_magnitude(a.data().size(), [x](std::size_t k) { return x[k]; });
}

double max_abs_diff(const Matrix& a, const Matrix& b) {
    require_same_shape(a, b, "diff");
    const double *x = a.data().data(), *y = b.data().data();
    return largest_magnitude(a.data().size(), [x, y](std::size_t k) { return x[k] - y[k]; });
}

namespace {

// LU with partial pivoting in place (rows), and the triangular solves for many right-hand sides:
// row operations over contiguous rows, compiled for AVX-512, AVX2 and the baseline and picked at run
// time. Element-wise, in the same order in every clone and without contraction
// (cmake/BrdfWarnings.cmake): the same bits in each. A rough top's adding factors one n x n matrix
// per order and sample (setup_rough): with the baseline's two doubles to a register this was a
// twentieth of a gloss finish's compute. Nothing is thrown inside a clone: GCC 12 takes a
// target_clones function for one that does not throw, and the caller's cleanups were skipped (the
// ASan build found the pivots of a singular matrix leaked). Returns the column whose pivot is zero
// or not finite, or -1.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
int lu_factor_rows(Matrix& lu, std::vector<int>& pivots) {
    const int n = lu.rows();
    for (int k = 0; k < n; ++k) {
        int p = k;
        for (int i = k + 1; i < n; ++i)
            if (std::abs(lu(i, k)) > std::abs(lu(p, k))) p = i;
        const double pivot = lu(p, k);
        if (pivot == 0.0 || !std::isfinite(pivot)) return k;
        pivots[k] = p;
        if (p != k) std::swap_ranges(lu.row(k).begin(), lu.row(k).end(), lu.row(p).begin());
        const auto rk = lu.row(k);
        for (int i = k + 1; i < n; ++i) {
            const auto ri = lu.row(i);
            const double f = (ri[k] /= pivot);
            if (f == 0.0) continue;
            for (int j = k + 1; j < n; ++j) ri[j] -= f * rk[j];
        }
    }
    return -1;
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void lu_solve_rows(const Matrix& lu, const std::vector<int>& pivots, Matrix& b) {
    const int n = lu.rows();
    for (int k = 0; k < n; ++k)
        if (pivots[k] != k) std::swap_ranges(b.row(k).begin(), b.row(k).end(), b.row(pivots[k]).begin());
    const int m = b.cols();
    for (int i = 0; i < n; ++i) { // forward: L has a unit diagonal
        auto bi = b.row(i);
        for (int k = 0; k < i; ++k) {
            const double l = lu(i, k);
            if (l == 0.0) continue;
            const auto bk = b.row(k);
            for (int j = 0; j < m; ++j) bi[j] -= l * bk[j];
        }
    }
    for (int i = n - 1; i >= 0; --i) { // backward
        auto bi = b.row(i);
        for (int k = i + 1; k < n; ++k) {
            const double u = lu(i, k);
            if (u == 0.0) continue;
            const auto bk = b.row(k);
            for (int j = 0; j < m; ++j) bi[j] -= u * bk[j];
        }
        const double d = lu(i, i);
        for (int j = 0; j < m; ++j) bi[j] /= d;
    }
}

} // namespace

LuFactor::LuFactor(Matrix a) : m_lu(std::move(a)), m_pivot(static_cast<std::size_t>(m_lu.rows())) {
    const int n = m_lu.rows();
    if (m_lu.cols() != n) throw InputError(cat("LU: matrix is not square (", n, "x", m_lu.cols(), ")"));
    if (const int k = lu_factor_rows(m_lu, m_pivot); k >= 0)
        throw NumericalError(cat("LU: matrix is singular or not finite at column ", k, " of ", n));
}

void LuFactor::solve(Matrix& b) const {
    const int n = m_lu.rows();
    if (b.rows() != n) throw InputError(cat("LU solve: right-hand side has ", b.rows(), " rows, not ", n));
    lu_solve_rows(m_lu, m_pivot, b);
}

void LuFactor::solve(std::span<double> b) const {
    Matrix m(static_cast<int>(b.size()), 1);
    std::copy(b.begin(), b.end(), m.data().begin());
    solve(m);
    std::copy(m.data().begin(), m.data().end(), b.begin());
}

namespace {

// Matrices (reduce_hessenberg_lanes) or shifts (solve_hessenberg_lanes) side by side in vector lanes,
// W of them: as wide as the target's registers (8 doubles under AVX-512, 4 under AVX2, 2 on SSE2).
// A vector wider than the registers GCC lowers through the stack piece by piece (scalar compares and
// selects, stores that cannot be forwarded to the whole's loads): with eight lanes under AVX2 these
// two took 10 % of the seed's CPU time, against 3 % under AVX-512 (perf).
constexpr int max_hessenberg_lanes = 8;
template <int W> struct HessenbergLanes { // (an alias template would drop the attributes)
    typedef double vec __attribute__((vector_size(8 * W)));
    typedef long long mask __attribute__((vector_size(8 * W)));
    // Unaligned (std::vector's doubles); no vector crosses a call.
    typedef double unaligned_vec __attribute__((vector_size(8 * W), aligned(8)));
    typedef long long unaligned_mask __attribute__((vector_size(8 * W), aligned(8)));
};

// M(r, c) -= tau v_r (v^T M)(c) for rows r >= k + 1 and columns c >= c0 of the n x n lanes matrix m:
// the reflector from the left. v^T M is summed four columns at a time in registers (each column's
// sum over the rows in order), where a sum kept in memory and updated row by row had made every
// step a load, an add and a store.
template <typename LaneVec>
[[gnu::always_inline]] inline void reflect_rows(int n, int k, int c0, LaneVec* m, const LaneVec* v, const LaneVec& tau,
                                                LaneVec* w) {
    int j = c0;
    for (; j + 4 <= n; j += 4) {
        LaneVec s0 = {}, s1 = {}, s2 = {}, s3 = {};
        for (int i = k + 1; i < n; ++i) {
            const LaneVec* row = m + i * n + j;
            s0 += v[i] * row[0];
            s1 += v[i] * row[1];
            s2 += v[i] * row[2];
            s3 += v[i] * row[3];
        }
        w[j] = s0, w[j + 1] = s1, w[j + 2] = s2, w[j + 3] = s3;
    }
    for (; j < n; ++j) {
        LaneVec s = {};
        for (int i = k + 1; i < n; ++i) s += v[i] * m[i * n + j];
        w[j] = s;
    }
    for (int i = k + 1; i < n; ++i) {
        const LaneVec f = tau * v[i];
        for (int c = c0; c < n; ++c) m[i * n + c] -= f * w[c];
    }
}

// The Householder reduction of W matrices side by side to upper Hessenberg form, A = Z H Z^T (Golub
// and Van Loan 2013, algorithm 7.4.2; LAPACK's dgehd2 and dorg2r, unblocked): a[(i * n + j) W + l]
// holds element (i, j) of lane l's matrix and receives H (zeros below the subdiagonal), z receives
// Z; both 8 W-byte aligned. LAPACK (dgehrd, dorghr) does the same one matrix at a time, at the
// Nystrom pencils' sizes (a material's orders times its wavelengths: 750 of 32 x 32 for the seed,
// 1,250 of 64 x 64 at "reference") 3.6 times as slowly at 32 streams, 1.7 at 64, its small level-2
// calls mostly overhead (largest_lane_pencil has the numbers). Each lane sees the operations of a
// scalar reduction in the same order, so its H and Z do not depend on its neighbours or on the
// instruction set (no contraction; the sets give identical results). A column already zero below
// the subdiagonal gets no reflector (tau 0), as in LAPACK's dlarfg.
// `scratch` holds 3 n W doubles, aligned alike.
template <int W>
[[gnu::always_inline]] inline void reduce_hessenberg_lanes(int n, double* a_lanes, double* z_lanes,
                                                           double* scratch_lanes) {
    using LaneVec = typename HessenbergLanes<W>::vec;
    using LaneMask = typename HessenbergLanes<W>::mask;
    LaneVec* const a = reinterpret_cast<LaneVec*>(a_lanes);
    LaneVec* const z = reinterpret_cast<LaneVec*>(z_lanes);
    LaneVec* const tau = reinterpret_cast<LaneVec*>(scratch_lanes);
    LaneVec* const w = tau + n; // v^T A
    LaneVec* const v = w + n;   // the reflector, v[k + 1] = 1
    const LaneVec zero = {}, one = zero + 1.0;
    for (int k = 0; k + 2 < n; ++k) {
        // The reflector I - tau v v^T that zeroes column k below row k + 1: v_{k+1} = 1, the rest
        // kept where the column's zeros go (a[i * n + k], i > k + 1), as LAPACK keeps them.
        const LaneVec alpha = a[(k + 1) * n + k];
        LaneVec tail = zero; // sum of squares below the subdiagonal
        for (int i = k + 2; i < n; ++i) tail += a[i * n + k] * a[i * n + k];
        const LaneMask none = tail == 0.0;
        LaneVec norm;
        for (int l = 0; l < W; ++l) norm[l] = std::sqrt(alpha[l] * alpha[l] + tail[l]);
        const LaneVec beta = alpha >= 0.0 ? -norm : norm;
        const LaneVec t = none ? zero : (beta - alpha) / beta;
        const LaneVec scale = none ? zero : one / (alpha - beta);
        tau[k] = t;
        a[(k + 1) * n + k] = none ? alpha : beta;
        v[k + 1] = one;
        for (int i = k + 2; i < n; ++i) v[i] = a[i * n + k] *= scale;
        // From the right, every row: A(i, k+1:) -= tau (A(i, k+1:) v) v^T; each row's product in four
        // partial sums (j = k + 1 + 4 q + p in sum p), added in order.
        for (int i = 0; i < n; ++i) {
            LaneVec* row = a + i * n;
            LaneVec p0 = zero, p1 = zero, p2 = zero, p3 = zero;
            int j = k + 1;
            for (; j + 4 <= n; j += 4) {
                p0 += row[j] * v[j];
                p1 += row[j + 1] * v[j + 1];
                p2 += row[j + 2] * v[j + 2];
                p3 += row[j + 3] * v[j + 3];
            }
            for (; j < n; ++j) p0 += row[j] * v[j];
            const LaneVec f = t * ((p0 + p1) + (p2 + p3));
            for (int c = k + 1; c < n; ++c) row[c] -= f * v[c];
        }
        // From the left, rows and columns k + 1 on.
        reflect_rows(n, k, k + 1, a, v, t, w);
    }
    // Z = H_0 H_1 ... H_{n-3}, accumulated backwards from the identity: reflector k touches rows and
    // columns k + 1 on only, where the product of the later ones is all there is yet.
    for (int i = 0; i < n * n; ++i) z[i] = zero;
    for (int i = 0; i < n; ++i) z[i * n + i] = one;
    for (int k = n - 3; k >= 0; --k) {
        v[k + 1] = one;
        for (int i = k + 2; i < n; ++i) v[i] = a[i * n + k];
        reflect_rows(n, k, k + 1, z, v, tau[k], w);
    }
    for (int i = 2; i < n; ++i)
        for (int j = 0; j + 1 < i; ++j) a[i * n + j] = zero;
}

// x = (I + u H)^-1 b for the upper Hessenberg H and W shifts side by side, in place: y[i W + l] is
// row i of shift l's right-hand side, u[l] its shift.
// Gaussian elimination with a pivot chosen per shift from two adjacent rows, then back substitution
// by columns: every shift sees the operations of a scalar solve in the same order, so its answer
// does not depend on its neighbours or on the instruction set (no contraction anywhere,
// cmake/BrdfWarnings.cmake: the sets give identical results). One vector of GCC's per matrix
// entry holds it for every shift: the pivots' row swaps are blends (plain loops over the lanes
// compiled to a branch per lane, a third of the time); each row of I + u H is made as the
// elimination reaches it, in the slot where the factor's row will be, so a step reads what the last
// one wrote instead of the whole matrix made first; and the back substitution subtracts each
// solved unknown from the rows above it, independent updates, where each row's sum of products had
// waited on every subtraction in turn. A table grid's 181 shifts at 64 streams: 0.72 -> 0.56 ms
// (bench_solver BM_PencilShifts, with the products around it); the HG half-space's solve, its
// stream check evaluating the probes, 31.6 -> 24.8 ms (bench_pipeline BM_SolveHg). `bad` receives
// the shifts singular to working precision (1) or not (0). `work` holds n x (n + 1) x W
// scratch, written before it is read.
template <int W>
[[gnu::always_inline]] inline void solve_hessenberg_lanes(const Matrix& h, const double* u, double* y, double* work,
                                                          int* bad) {
    using Vec = typename HessenbergLanes<W>::unaligned_vec;
    using Mask = typename HessenbergLanes<W>::unaligned_mask;
    const int n = h.rows();
    // Row k of the triangular factor U at a[k * stride + j], j >= k. The rows of I + u H are made as
    // the elimination reaches them: at step k, row k + 1's slot receives what row k's pivot leaves of
    // the other row (the next step's candidate), so every step reads the row the last one wrote.
    // Rows one vector longer than n: at 64 streams rows of n vectors lie 4 KiB apart, and each
    // load from row k then waited on the store to the same column of row k + 1 (the CPU compares
    // only an address's low 12 bits at first: 4K aliasing). BM_PencilShifts at 64 streams 410-623
    // -> 441 us, at 128 1015-2006 -> 1050 us (the unpadded rows' time varied from run to run), HG's
    // grids (BM_PrepareFillHg) 9.5 -> 7.2 ms; the same answers.
    const int stride = n + 1;
    Vec* const a = reinterpret_cast<Vec*>(work);
    Vec* const x = reinterpret_cast<Vec*>(y);
    const Vec shift = *reinterpret_cast<const Vec*>(u);
    Mask singular = {};
    for (int j = 0; j < n; ++j) a[j] = (j == 0 ? 1.0 : 0.0) + shift * h(0, j);
    for (int k = 0; k + 1 < n; ++k) {
        Vec* const top = a + k * stride;         // the candidate from above (row 0 at k = 0)
        Vec* const below = a + (k + 1) * stride; // row k + 1 of I + u H (H: from column k on)
        const double* const next = h.data().data() + static_cast<std::size_t>(k + 1) * n; // row k + 1 of H
        const Vec t = top[k], b = shift * next[k]; // (k + 1, k): off the diagonal
        const Mask swap = (b < 0.0 ? -b : b) > (t < 0.0 ? -t : t); // |b| > |t|, false for NaN
        const Vec pivot = swap ? b : t, other = swap ? t : b;
        top[k] = pivot;
        const Vec p = x[k], q = x[k + 1];
        x[k] = swap ? q : p;
        x[k + 1] = swap ? p : q;
        // a zero below the pivot leaves the row as it is (factor 0), as the scalar solve skips it
        const Mask skip = other == 0.0;
        singular |= ~skip & (pivot == 0.0);
        const Vec factor = skip ? Vec{} : other / pivot;
        for (int j = k + 1; j < n; ++j) {
            const Vec tj = top[j], bj = (j == k + 1 ? 1.0 : 0.0) + shift * next[j];
            const Vec uj = swap ? bj : tj;
            top[j] = uj;
            below[j] = (swap ? tj : bj) - factor * uj;
        }
        x[k + 1] -= factor * x[k];
    }
    for (int i = n - 1; i >= 0; --i) {
        const Vec pivot = a[i * stride + i];
        const Vec xi = x[i] / pivot;
        singular |= ~(pivot != 0.0) | ~(xi - xi == 0.0); // a zero pivot, or an infinite or NaN answer
        x[i] = xi;
        for (int k = 0; k < i; ++k) x[k] -= a[k * stride + i] * xi;
    }
    for (int l = 0; l < W; ++l) bad[l] = singular[l] != 0;
}

// One pair of kernels per instruction set, picked once at run time (lane_set()): every lane sees a
// scalar reduction's or solve's operations in the same order and nothing is contracted
// (cmake/BrdfWarnings.cmake), so each set gives the same bits (Linalg.ShiftedPencil*, run under
// each set: tests/core/CMakeLists.txt).
struct HessenbergKernels {
    int lanes;
    void (*reduce)(int n, double* a, double* z, double* scratch);
    void (*solve)(const Matrix& h, const double* u, double* y, double* work, int* bad);
};
void reduce_baseline(int n, double* a, double* z, double* scratch) { reduce_hessenberg_lanes<2>(n, a, z, scratch); }
void solve_baseline(const Matrix& h, const double* u, double* y, double* work, int* bad) {
    solve_hessenberg_lanes<2>(h, u, y, work, bad);
}
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target("avx2"))) void reduce_avx2(int n, double* a, double* z, double* scratch) {
    reduce_hessenberg_lanes<4>(n, a, z, scratch);
}
__attribute__((target("avx2"))) void solve_avx2(const Matrix& h, const double* u, double* y, double* work, int* bad) {
    solve_hessenberg_lanes<4>(h, u, y, work, bad);
}
__attribute__((target("avx512f"))) void reduce_avx512(int n, double* a, double* z, double* scratch) {
    reduce_hessenberg_lanes<8>(n, a, z, scratch);
}
__attribute__((target("avx512f"))) void solve_avx512(const Matrix& h, const double* u, double* y, double* work,
                                                     int* bad) {
    solve_hessenberg_lanes<8>(h, u, y, work, bad);
}
#endif
const HessenbergKernels& hessenberg_kernels() {
    static const HessenbergKernels kernels = []() -> HessenbergKernels {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
        switch (lane_set()) {
        case LaneSet::avx512: return {8, reduce_avx512, solve_avx512};
        case LaneSet::avx2: return {4, reduce_avx2, solve_avx2};
        case LaneSet::baseline: break;
        }
#endif
        return {2, reduce_baseline, solve_baseline};
    }();
    return kernels;
}

/// Doubles aligned for any lane vector, uninitialised.
struct alignas(8 * max_hessenberg_lanes) LaneBlock {
    double v[max_hessenberg_lanes];
};
struct AlignedDoubles {
    explicit AlignedDoubles(std::size_t count)
        : blocks(std::make_unique_for_overwrite<LaneBlock[]>((count + max_hessenberg_lanes - 1) /
                                                             max_hessenberg_lanes)) {}
    double* get() { return blocks[0].v; }
    std::unique_ptr<LaneBlock[]> blocks;
};

// The checks common to both reductions: a square G of D's size, D invertible.
void check_pencil(const Matrix& g, std::span<const double> d) {
    const int n = static_cast<int>(d.size());
    if (g.rows() != n || g.cols() != n)
        throw InternalError(cat("ShiftedPencil: shapes ", g.rows(), "x", g.cols(), " and ", d.size(), " differ"));
    for (int i = 0; i < n; ++i) {
        const double di = d[static_cast<std::size_t>(i)];
        if (!(std::isfinite(di) && di != 0.0))
            throw InternalError(cat("ShiftedPencil: D(", i, ", ", i, ") = ", di, " (D must be invertible)"));
    }
}

// Up to this size a batch's pencils are reduced in vector lanes; above it by LAPACK one at a time.
// One thread, bench_solver BM_PencilBatch against BM_PencilSetup (LAPACK), per pencil (medians of
// 5): 14 against 51 us at 32 streams, 136 against 234 at 64, 350 against 523 at 96; at 128 both
// take ~1 ms (eight lane matrices of 128 x 128, 2 MB, no longer fit the caches).
constexpr int largest_lane_pencil = 96;

} // namespace

ShiftedPencil::ShiftedPencil(const Matrix& g, std::span<const double> d) : m_h(g), m_q(g.rows(), g.cols()) {
    check_pencil(g, d);
    const int n = g.rows();
    // D + u G = D (I + u A), A = D^-1 G = Z H Z^T (Householder, LAPACK dgehrd and dorghr: blocked,
    // a third of the flops of dgghrd's Givens rotations on the pencil (D, G), which were 8 % of a
    // matting agent's compute). So Q = D^-1 Z: (D + u G)^-1 b = Z (I + u H)^-1 Z^T D^-1 b.
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) m_h(i, j) /= d[static_cast<std::size_t>(i)];
    std::vector<double> tau(static_cast<std::size_t>(std::max(1, n - 1)));
    lapack_int info = LAPACKE_dgehrd(LAPACK_ROW_MAJOR, n, 1, n, m_h.data().data(), n, tau.data());
    if (info != 0) throw NumericalError(cat("ShiftedPencil: LAPACK dgehrd failed (info ", info, ", size ", n, ")"));
    m_z = m_h;
    info = LAPACKE_dorghr(LAPACK_ROW_MAJOR, n, 1, n, m_z.data().data(), n, tau.data());
    if (info != 0) throw NumericalError(cat("ShiftedPencil: LAPACK dorghr failed (info ", info, ", size ", n, ")"));
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < i - 1; ++j) m_h(i, j) = 0.0; // dgehrd keeps its reflectors there
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) m_q(i, j) = m_z(i, j) / d[static_cast<std::size_t>(i)];
}

std::vector<ShiftedPencil> ShiftedPencil::batch(std::span<const Matrix> g, std::span<const double> d) {
    for (const Matrix& m : g) check_pencil(m, d);
    const int n = static_cast<int>(d.size());
    std::vector<ShiftedPencil> out;
    out.reserve(g.size());
    if (n > largest_lane_pencil) {
        for (const Matrix& m : g) out.emplace_back(m, d);
        return out;
    }
    const HessenbergKernels& kernels = hessenberg_kernels();
    const int lanes = kernels.lanes;
    const std::size_t nn = static_cast<std::size_t>(n) * n;
    // Aligned for the lane vectors: unaligned, each load of a lane vector spanned two cache lines
    // and the reduction took 6 times as long.
    AlignedDoubles a(nn * lanes), z(nn * lanes), scratch(3 * static_cast<std::size_t>(n) * lanes);
    for (std::size_t first = 0; first < g.size(); first += lanes) {
        const int count = static_cast<int>(std::min<std::size_t>(lanes, g.size() - first));
        // Lanes beyond the last matrix hold zeros (no reflectors; not kept).
        if (count < lanes) std::fill_n(a.get(), nn * lanes, 0.0);
        for (int l = 0; l < count; ++l) {
            const Matrix& m = g[first + l];
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j)
                    a.get()[(static_cast<std::size_t>(i) * n + j) * lanes + l] =
                        m(i, j) / d[static_cast<std::size_t>(i)];
        }
        kernels.reduce(n, a.get(), z.get(), scratch.get());
        for (int l = 0; l < count; ++l) {
            Matrix h(n, n), q(n, n), zl(n, n);
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    const std::size_t at = (static_cast<std::size_t>(i) * n + j) * lanes + l;
                    h(i, j) = a.get()[at];
                    zl(i, j) = z.get()[at];
                    q(i, j) = z.get()[at] / d[static_cast<std::size_t>(i)];
                }
            out.push_back(ShiftedPencil(std::move(h), std::move(q), std::move(zl)));
        }
    }
    return out;
}


void ShiftedPencil::solve(double u, std::span<double> b) const {
    Matrix column(size(), 1);
    for (int i = 0; i < size(); ++i) column(i, 0) = b[static_cast<std::size_t>(i)];
    const double shift[1] = {u};
    solve(shift, column);
    for (int i = 0; i < size(); ++i) b[static_cast<std::size_t>(i)] = column(i, 0);
}

void ShiftedPencil::solve(std::span<const double> u, Matrix& b) const {
    if (b.rows() != size() || b.cols() != static_cast<int>(u.size()))
        throw InternalError(cat("ShiftedPencil: right-hand sides ", b.rows(), "x", b.cols(), " for size ", size(),
                                " and ", u.size(), " shifts"));
    const int k = b.cols(), n = size();
    // Y = Q^T B for every column at once, then the Hessenberg solves a group of shifts at a time,
    // then X = Z Y.
    Matrix y;
    gemm(m_q, true, b, false, y);
    Matrix yt = transpose(y); // one shift per row (the product with Z below as before)
    const HessenbergKernels& kernels = hessenberg_kernels();
    const int lanes = kernels.lanes;
    // Scratch every solve writes before it reads (n x (n + 1) x lanes: 266 KB at 64 streams and
    // eight lanes), not zeroed first.
    const auto work = std::make_unique_for_overwrite<double[]>(static_cast<std::size_t>(n) * (n + 1) * lanes);
    std::vector<double> group(static_cast<std::size_t>(n) * lanes);
    for (int e0 = 0; e0 < k; e0 += lanes) {
        const int count = std::min(lanes, k - e0);
        double shift[max_hessenberg_lanes];
        for (int l = 0; l < lanes; ++l) shift[l] = u[static_cast<std::size_t>(e0 + std::min(l, count - 1))];
        for (int i = 0; i < n; ++i)
            for (int l = 0; l < lanes; ++l)
                group[static_cast<std::size_t>(i) * lanes + l] = yt(e0 + std::min(l, count - 1), i);
        int bad[max_hessenberg_lanes];
        kernels.solve(m_h, shift, group.data(), work.get(), bad);
        for (int l = 0; l < count; ++l)
            if (bad[l]) throw NumericalError(cat("ShiftedPencil: singular at u = ", shift[l], " (size ", n, ")"));
        for (int i = 0; i < n; ++i)
            for (int l = 0; l < count; ++l) yt(e0 + l, i) = group[static_cast<std::size_t>(i) * lanes + l];
    }
    gemm(m_z, false, yt, true, b);
}

Matrix solve(const Matrix& a, Matrix b) {
    LuFactor(a).solve(b);
    return b;
}

Matrix inverse(Matrix a) {
    const int n = a.rows();
    if (a.cols() != n) throw InputError(cat("inverse: matrix is not square (", n, "x", a.cols(), ")"));
    if (n == 0) return a;
    // LAPACK's blocked LU and inverse (dgetrf, dgetri): the adding method's (I - B g)^-1 per order
    // and sample, where LuFactor's unblocked loops took 7 % of a matting agent's compute. LuFactor
    // stays the kernels' reference (the same operations in the same order as theirs).
    for (double v : a.data())
        if (!std::isfinite(v))
            throw NumericalError(cat("inverse: a matrix element is not finite (", n, "x", n, ")"));
    // Row-major A is column-major A^T, and (A^T)^-1 = (A^-1)^T is A^-1 read back row-major: LAPACK
    // works on the data in place, without the row-major interface's two transposes and its NaN scan
    // (the loop above has checked the values).
    std::vector<lapack_int> pivot(static_cast<std::size_t>(n));
    lapack_int info = LAPACKE_dgetrf_work(LAPACK_COL_MAJOR, n, n, a.data().data(), n, pivot.data());
    if (info > 0)
        throw NumericalError(cat("inverse: matrix is singular at column ", info - 1, " of ", n));
    if (info == 0) {
        std::vector<double> work(static_cast<std::size_t>(64) * n); // dgetri's blocked workspace
        info = LAPACKE_dgetri_work(LAPACK_COL_MAJOR, n, a.data().data(), n, pivot.data(),
                                   work.data(), static_cast<lapack_int>(work.size()));
    }
    if (info != 0)
        throw NumericalError(cat("inverse: LAPACK failed (info ", info, ", size ", n, ")"));
    return a;
}

void gemm(const Matrix& a, bool transpose_a, const Matrix& b, bool transpose_b, Matrix& c, double alpha, double beta) {
    single_threaded_blas();
    const int m = transpose_a ? a.cols() : a.rows();
    const int k = transpose_a ? a.rows() : a.cols();
    const int kb = transpose_b ? b.cols() : b.rows();
    const int n = transpose_b ? b.rows() : b.cols();
    if (k != kb) throw InputError(cat("gemm: inner sizes differ (", k, " vs ", kb, ")"));
    if (beta != 0.0 && (c.rows() != m || c.cols() != n))
        throw InputError(cat("gemm: C is ", c.rows(), "x", c.cols(), ", expected ", m, "x", n));
    if (c.rows() != m || c.cols() != n) c = Matrix(m, n);
    if (m == 0 || n == 0) return;
    if (k == 0) {
        c *= beta;
        return;
    }
    cblas_dgemm(CblasRowMajor, transpose_a ? CblasTrans : CblasNoTrans, transpose_b ? CblasTrans : CblasNoTrans, m,
                n, k, alpha, a.data().data(), std::max(1, a.cols()), b.data().data(), std::max(1, b.cols()), beta,
                c.data().data(), std::max(1, n));
}

Matrix multiply_transposed(const Matrix& a, const Matrix& b) {
    Matrix c;
    gemm(a, false, b, true, c);
    return c;
}

Matrix cholesky_lower(Matrix a) {
    single_threaded_blas();
    const int n = a.rows();
    if (a.cols() != n) throw InputError(cat("Cholesky: matrix is not square (", n, "x", a.cols(), ")"));
    if (n == 0) return a;
    const lapack_int info = LAPACKE_dpotrf(LAPACK_ROW_MAJOR, 'L', n, a.data().data(), n);
    if (info != 0)
        throw NumericalError(cat("Cholesky: matrix is not positive definite (LAPACK dpotrf info ", info, ", size ", n, ")"));
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) a(i, j) = 0.0;
    return a;
}

void solve_lower(const Matrix& l, Matrix& b, bool transpose) {
    single_threaded_blas();
    const int n = l.rows();
    if (l.cols() != n || b.rows() != n)
        throw InputError(cat("triangular solve: ", l.rows(), "x", l.cols(), " with ", b.rows(), " rows"));
    if (n == 0 || b.cols() == 0) return;
    cblas_dtrsm(CblasRowMajor, CblasLeft, CblasLower, transpose ? CblasTrans : CblasNoTrans, CblasNonUnit, n, b.cols(),
                1.0, l.data().data(), n, b.data().data(), b.cols());
}

SymmetricEigen symmetric_eigen(Matrix a) {
    single_threaded_blas();
    const int n = a.rows();
    if (a.cols() != n) throw InputError(cat("eigen: matrix is not square (", n, "x", a.cols(), ")"));
    SymmetricEigen out;
    out.values.resize(static_cast<std::size_t>(n));
    if (n > 0) {
        const lapack_int info = LAPACKE_dsyevd(LAPACK_ROW_MAJOR, 'V', 'L', n, a.data().data(), n, out.values.data());
        if (info != 0) throw NumericalError(cat("eigen: LAPACK dsyevd failed (info ", info, ", size ", n, ")"));
    }
    out.vectors = std::move(a);
    return out;
}

} // namespace brdf
