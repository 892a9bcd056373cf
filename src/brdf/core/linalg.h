#pragma once
// Small dense linear algebra for the per-order solvers (N up to a few hundred): row-major matrices,
// products, and LU with partial pivoting. The OpenCL kernels implement the same operations in
// work-group form (kernels/ambartsumian.cl); these are the plain C++ references.

#include <cstddef>
#include <span>
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

/// A^-1 B.
Matrix solve(const Matrix& a, Matrix b);

} // namespace brdf
