#pragma once
// Small dense linear algebra for the per-order solvers (N up to a few hundred): row-major matrices,
// products, LU with partial pivoting, Cholesky and the symmetric eigenproblem. Products go to BLAS
// and factorisations to LAPACK (OpenBLAS, one thread per call: the callers run many independent
// problems in parallel), except batches of small Hessenberg reductions, eight side by side in
// vector lanes (ShiftedPencil::batch), where LAPACK's calls cost more than their arithmetic. The
// OpenCL kernels implement the same operations in work-group or serial form
// (kernels/ambartsumian*.cl); they agree with these to rounding.

#include <cstddef>
#include <span>
#include <utility>
#include <vector>

namespace brdf {

class Matrix {
public:
    Matrix() = default;
    Matrix(int rows, int cols, double fill = 0.0)
        : m_rows(rows), m_cols(cols), m_data(static_cast<std::size_t>(rows) * cols, fill) {}
    static Matrix identity(int n);

    int rows() const { return m_rows; }
    int cols() const { return m_cols; }
    double& operator()(int i, int j) { return m_data[static_cast<std::size_t>(i) * m_cols + j]; }
    double operator()(int i, int j) const { return m_data[static_cast<std::size_t>(i) * m_cols + j]; }
    std::span<double> data() { return m_data; }
    std::span<const double> data() const { return m_data; }
    std::span<double> row(int i) { return {m_data.data() + static_cast<std::size_t>(i) * m_cols, static_cast<std::size_t>(m_cols)}; }
    std::span<const double> row(int i) const { return {m_data.data() + static_cast<std::size_t>(i) * m_cols, static_cast<std::size_t>(m_cols)}; }

    Matrix& operator+=(const Matrix& b);
    Matrix& operator-=(const Matrix& b);
    Matrix& operator*=(double s);

private:
    int m_rows = 0, m_cols = 0;
    std::vector<double> m_data;
};

Matrix operator*(const Matrix& a, const Matrix& b);
Matrix operator+(Matrix a, const Matrix& b);
Matrix operator-(Matrix a, const Matrix& b);
Matrix operator*(double s, Matrix a);
Matrix transpose(const Matrix& a);
/// max_ij |a_ij|
double max_abs(const Matrix& a);
/// max_ij |a_ij - b_ij|
double max_abs_diff(const Matrix& a, const Matrix& b);

/// LU factorisation with partial pivoting of a square matrix. Throws NumericalError when a pivot is
/// zero or not finite (the matrix is singular to working precision).
class LuFactor {
public:
    explicit LuFactor(Matrix a);
    /// Solves A X = B for X (B: n x k), in place.
    void solve(Matrix& b) const;
    void solve(std::span<double> b) const;
    int size() const { return m_lu.rows(); }

private:
    Matrix m_lu;
    std::vector<int> m_pivot;
};

/// Solves (D + u G) x = b for many scalars u, D diagonal and invertible: one Hessenberg reduction
/// D^-1 G = Z H Z^T (Householder, orthogonal, so backward stable for D^-1 G) makes each solve the
/// O(n^2) Hessenberg system (I + u H) y = Q^T b, x = Z y, with Q = D^-1 Z, instead of an O(n^3)
/// LU per u (the frequency-response method of Laub 1981, IEEE TAC 26, 407). Throws
/// NumericalError when I + u H is singular to working precision, InternalError for a singular D.
class ShiftedPencil {
public:
    ShiftedPencil(const Matrix& g, std::span<const double> d);
    /// The pencils (D + u G_k) of one D: up to 96 x 96 reduced several at a time in vector lanes
    /// (each pencil's result the same whatever its neighbours; LAPACK, as the constructor, beyond).
    static std::vector<ShiftedPencil> batch(std::span<const Matrix> g, std::span<const double> d);
    /// x = (D + u G)^-1 b, in place.
    void solve(double u, std::span<double> b) const;
    /// Column e of B (n x k): (D + u_e G)^-1 B(., e), in place.
    void solve(std::span<const double> u, Matrix& b) const;
    int size() const { return m_h.rows(); }

private:
    ShiftedPencil(Matrix h, Matrix q, Matrix z) : m_h(std::move(h)), m_q(std::move(q)), m_z(std::move(z)) {}

    Matrix m_h, m_q, m_z;
};

/// A^-1 B.
Matrix solve(const Matrix& a, Matrix b);
/// A^-1 (LAPACK dgetrf and dgetri, blocked; NumericalError when singular or not finite).
Matrix inverse(Matrix a);

/// C = alpha op(A) op(B) + beta C, op = transpose when the flag is set; C must have the result's
/// shape when beta != 0 (it is resized otherwise).
void gemm(const Matrix& a, bool transpose_a, const Matrix& b, bool transpose_b, Matrix& c, double alpha = 1.0,
          double beta = 0.0);
/// A B^T.
Matrix multiply_transposed(const Matrix& a, const Matrix& b);

/// Lower triangular L with L L^T = A for a symmetric positive definite A (NumericalError otherwise).
Matrix cholesky_lower(Matrix a);
/// X = L^-1 B (transpose: L^-T B) for lower triangular L, in place.
void solve_lower(const Matrix& l, Matrix& b, bool transpose = false);

/// Eigenvalues (ascending) and orthonormal eigenvectors (columns) of a symmetric matrix.
struct SymmetricEigen {
    std::vector<double> values;
    Matrix vectors;
};
SymmetricEigen symmetric_eigen(Matrix a);

} // namespace brdf
