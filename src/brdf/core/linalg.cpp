#include <brdf/core/linalg.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace brdf {
namespace {

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
    // i-k-j order: the inner loop runs along rows of b and c, which the compiler vectorises.
    for (int i = 0; i < a.rows(); ++i) {
        auto ci = c.row(i);
        for (int k = 0; k < a.cols(); ++k) {
            const double aik = a(i, k);
            if (aik == 0.0) continue;
            const auto bk = b.row(k);
            for (int j = 0; j < b.cols(); ++j) ci[j] += aik * bk[j];
        }
    }
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

double max_abs(const Matrix& a) {
    double m = 0.0;
    for (double v : a.data()) m = std::max(m, std::abs(v));
    return m;
}

double max_abs_diff(const Matrix& a, const Matrix& b) {
    require_same_shape(a, b, "diff");
    double m = 0.0;
    for (std::size_t k = 0; k < a.data().size(); ++k) m = std::max(m, std::abs(a.data()[k] - b.data()[k]));
    return m;
}

LuFactor::LuFactor(Matrix a) : m_lu(std::move(a)), m_pivot(static_cast<std::size_t>(m_lu.rows())) {
    const int n = m_lu.rows();
    if (m_lu.cols() != n) throw InputError(cat("LU: matrix is not square (", n, "x", m_lu.cols(), ")"));
    for (int k = 0; k < n; ++k) {
        int p = k;
        for (int i = k + 1; i < n; ++i)
            if (std::abs(m_lu(i, k)) > std::abs(m_lu(p, k))) p = i;
        const double pivot = m_lu(p, k);
        if (pivot == 0.0 || !std::isfinite(pivot))
            throw NumericalError(cat("LU: matrix is singular or not finite at column ", k, " of ", n));
        m_pivot[k] = p;
        if (p != k) std::swap_ranges(m_lu.row(k).begin(), m_lu.row(k).end(), m_lu.row(p).begin());
        const auto rk = m_lu.row(k);
        for (int i = k + 1; i < n; ++i) {
            const auto ri = m_lu.row(i);
            const double f = (ri[k] /= pivot);
            if (f == 0.0) continue;
            for (int j = k + 1; j < n; ++j) ri[j] -= f * rk[j];
        }
    }
}

void LuFactor::solve(Matrix& b) const {
    const int n = m_lu.rows();
    if (b.rows() != n) throw InputError(cat("LU solve: right-hand side has ", b.rows(), " rows, not ", n));
    for (int k = 0; k < n; ++k)
        if (m_pivot[k] != k) std::swap_ranges(b.row(k).begin(), b.row(k).end(), b.row(m_pivot[k]).begin());
    const int m = b.cols();
    for (int i = 0; i < n; ++i) { // forward: L has a unit diagonal
        auto bi = b.row(i);
        for (int k = 0; k < i; ++k) {
            const double l = m_lu(i, k);
            if (l == 0.0) continue;
            const auto bk = b.row(k);
            for (int j = 0; j < m; ++j) bi[j] -= l * bk[j];
        }
    }
    for (int i = n - 1; i >= 0; --i) { // backward
        auto bi = b.row(i);
        for (int k = i + 1; k < n; ++k) {
            const double u = m_lu(i, k);
            if (u == 0.0) continue;
            const auto bk = b.row(k);
            for (int j = 0; j < m; ++j) bi[j] -= u * bk[j];
        }
        const double d = m_lu(i, i);
        for (int j = 0; j < m; ++j) bi[j] /= d;
    }
}

void LuFactor::solve(std::span<double> b) const {
    Matrix m(static_cast<int>(b.size()), 1);
    std::copy(b.begin(), b.end(), m.data().begin());
    solve(m);
    std::copy(m.data().begin(), m.data().end(), b.begin());
}

Matrix solve(const Matrix& a, Matrix b) {
    LuFactor(a).solve(b);
    return b;
}

} // namespace brdf
