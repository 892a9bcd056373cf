// Normalised associated Legendre functions and Legendre series: closed forms, the addition theorem
// and stability at high degree.

#include <brdf/core/error.h>
#include <brdf/core/legendre.h>
#include <brdf/core/linalg.h>
#include <test_support.h>

#include <cmath>

namespace brdf::test {
namespace {

TEST(Legendre, LowOrdersMatchClosedForms) {
    for (double x : {-0.9, -0.3, 0.0, 0.45, 0.99}) {
        const double s = std::sqrt(1 - x * x);
        const auto p0 = normalized_legendre(0, 3, x);
        EXPECT_NEAR(p0[2], 0.5 * (3 * x * x - 1), 1e-15);
        EXPECT_NEAR(p0[3], 0.5 * (5 * x * x * x - 3 * x), 1e-15);
        // Pbar_2^1 = sqrt(1/6) * 3 x s, Pbar_2^2 = sqrt(1/24) * 3 s^2 (no Condon-Shortley phase).
        EXPECT_NEAR(normalized_legendre(1, 2, x)[1], std::sqrt(1.0 / 6.0) * 3 * x * s, 1e-15);
        EXPECT_NEAR(normalized_legendre(2, 2, x)[0], std::sqrt(1.0 / 24.0) * 3 * s * s, 1e-15);
    }
}

TEST(Legendre, AdditionTheoremHoldsAtHighDegree) {
    // sum_m (2 - delta_m0) Pbar_l^m(x)^2 = P_l(1) = 1 for every l: a sharp test of the normalisation.
    const int lmax = 3000;
    for (double x : {0.0, 0.31, 0.77, 0.999}) {
        std::vector<double> sum(lmax + 1, 0.0);
        for (int m = 0; m <= lmax; ++m) {
            const auto p = normalized_legendre(m, lmax, x);
            for (int l = m; l <= lmax; ++l) sum[l] += (m == 0 ? 1.0 : 2.0) * p[l - m] * p[l - m];
        }
        for (int l : {0, 1, 10, 500, 3000}) EXPECT_NEAR(sum[l], 1.0, 1e-10) << "l " << l << " x " << x;
    }
}

TEST(Legendre, SeriesMatchesDirectSum) {
    const std::vector<double> beta = {1.0, 1.5, 0.8, -0.2, 0.05};
    for (double x : {-1.0, -0.2, 0.6, 1.0}) {
        std::vector<double> p(beta.size());
        legendre_polynomials(static_cast<int>(beta.size()) - 1, x, p);
        double direct = 0;
        for (std::size_t l = 0; l < beta.size(); ++l) direct += beta[l] * p[l];
        EXPECT_NEAR(legendre_series(beta, x), direct, 1e-14);
    }
}

// The batched functions (a row per point) give each point what it gets alone, whatever its place
// in a block and whatever else the block holds (the single-point function is a block of one; the
// values themselves are checked above): orders 0 to 600 (the rescaled start of high orders near
// the poles, whose values underflow to true zeros), degrees from m alone to 700, point counts
// around the block size (64), both poles (zero rows for m > 0) and points a hair from them.
TEST(Legendre, BatchedFunctionsEqualTheScalarOnesBitForBit) {
    for (std::size_t count : {1u, 63u, 64u, 65u, 200u}) {
        std::vector<double> x(count);
        for (std::size_t k = 0; k < count; ++k) x[k] = count == 1 ? 0.3 : -1.0 + 2.0 * k / (count - 1);
        if (count > 3) x[1] = -1.0 + 1e-13, x[count - 2] = 1.0 - 1e-9, x[count / 2] = 0.0;
        for (int m : {0, 1, 5, 40, 300, 600})
            for (int lmax : {m, m + 1, m + 60, 700}) {
                if (lmax < m) continue;
                const std::size_t degrees = static_cast<std::size_t>(lmax - m + 1);
                std::vector<double> out(count * degrees, -7.0);
                normalized_legendre(m, lmax, x, out);
                for (std::size_t k = 0; k < count; ++k) {
                    const std::vector<double> one = normalized_legendre(m, lmax, x[k]);
                    for (std::size_t d = 0; d < degrees; ++d)
                        ASSERT_EQ(out[k * degrees + d], one[d]) << "m " << m << " lmax " << lmax << " x " << x[k] << " l " << m + d;
                }
            }
    }
    std::vector<double> too_few(3);
    const std::vector<double> two = {0.0, 0.5};
    EXPECT_THROW(normalized_legendre(0, 1, two, too_few), InternalError);
}

// Without a power of the sine (normalized_legendre_over_sine): times sin^power, the functions
// themselves, for powers 0 to m; at the poles the reduced functions of power m are finite and
// nonzero (Pbar_l^m / sin^m -> sqrt((l + m)! / (l - m)!) / (2^m m!) at x = 1: Pbar_m^m / sin^m is
// prod_k sqrt((2k - 1) / 2k)), those of a smaller power 0; a power above m is refused.
TEST(Legendre, OverASineTimesThatSineIsTheFunction) {
    const std::vector<double> x{-0.999, -0.6, -0.1, 0.0, 0.3, 0.8, 0.9999};
    for (int m : {0, 1, 2, 7, 40})
        for (int power : {0, m % 2, m}) {
            const int lmax = m + 50;
            const std::size_t degrees = static_cast<std::size_t>(lmax - m + 1);
            std::vector<double> plain(x.size() * degrees), reduced(x.size() * degrees);
            normalized_legendre(m, lmax, x, plain);
            normalized_legendre_over_sine(m, lmax, x, reduced, power);
            for (std::size_t k = 0; k < x.size(); ++k) {
                const double sine = std::sqrt((1.0 - x[k]) * (1.0 + x[k]));
                for (std::size_t d = 0; d < degrees; ++d) {
                    const double a = plain[k * degrees + d],
                                 b = reduced[k * degrees + d] * std::pow(sine, power);
                    ASSERT_NEAR(b, a, 1e-12 * std::max(1.0, std::abs(a)))
                        << "m " << m << " power " << power << " x " << x[k];
                }
            }
        }
    const std::vector<double> poles{-1.0, 1.0};
    for (int m : {1, 2, 5}) {
        std::vector<double> full(2 * 4), part(2 * 4);
        normalized_legendre_over_sine(m, m + 3, poles, full, m);
        normalized_legendre_over_sine(m, m + 3, poles, part, m - 1);
        double start = 1.0;
        for (int k = 1; k <= m; ++k) start *= std::sqrt((2.0 * k - 1.0) / (2.0 * k));
        EXPECT_NEAR(full[4], start, 1e-14) << "m " << m; // x = 1, l = m
        for (double v : full) EXPECT_NE(v, 0.0) << "m " << m;
        for (double v : part) EXPECT_EQ(v, 0.0) << "m " << m;
    }
    std::vector<double> out(2 * 3);
    EXPECT_THROW(normalized_legendre_over_sine(2, 4, poles, out, 3), InputError);
}

// The batched series (blocks of points) is the scalar Clenshaw sum bit for bit, at a Mie-like
// degree (3000 terms, beta_l = (2l + 1) g^l of HG g = 0.999), at point counts around the block
// size, including both ends of [-1, 1].
TEST(Legendre, BatchedSeriesEqualsTheScalarSumBitForBit) {
    std::vector<double> beta(3000);
    for (std::size_t l = 0; l < beta.size(); ++l) beta[l] = (2.0 * l + 1.0) * std::pow(0.999, static_cast<double>(l));
    for (std::size_t count : {1u, 255u, 256u, 257u, 1000u}) {
        std::vector<double> x(count), out(count, -7.0);
        for (std::size_t k = 0; k < count; ++k) x[k] = count == 1 ? 1.0 : -1.0 + 2.0 * k / (count - 1);
        legendre_series(beta, x, out);
        for (std::size_t k = 0; k < count; ++k) ASSERT_EQ(out[k], legendre_series(beta, x[k])) << count << " " << k;
    }
    std::vector<double> too_few(1);
    const std::vector<double> two = {0.0, 0.5};
    EXPECT_THROW(legendre_series(beta, two, too_few), InternalError);
}

// max_abs and max_abs_diff keep eight running maxima: the largest magnitude is found wherever it
// sits (every position of sizes around the eight lanes, the tail past the last eight included),
// and a NaN is passed over as one running maximum passes it.
TEST(Linalg, MaxAbsFindsTheLargestMagnitudeAnywhere) {
    for (int n : {1, 7, 8, 9, 16, 17, 64, 67})
        for (int at = 0; at < n; ++at) {
            Matrix a(1, n), zero(1, n);
            for (int k = 0; k < n; ++k) a(0, k) = 0.5 * std::sin(1.0 + k);
            a(0, at) = -3.0;
            EXPECT_EQ(max_abs(a), 3.0) << "size " << n << " at " << at;
            EXPECT_EQ(max_abs_diff(zero, a), 3.0) << "size " << n << " at " << at;
        }
    Matrix b(3, 5, -2.0);
    b(1, 2) = std::nan("");
    EXPECT_EQ(max_abs(b), 2.0);
    EXPECT_EQ(max_abs(Matrix(2, 2, 0.0)), 0.0);
}

TEST(Linalg, LuSolvesAndRejectsSingular) {
    Matrix a(3, 3);
    const double v[9] = {0, 2, 1, 1, 1, 1, 4, 0, 3}; // needs pivoting (a_00 = 0)
    std::copy(v, v + 9, a.data().begin());
    Matrix b(3, 1);
    b(0, 0) = 1, b(1, 0) = 2, b(2, 0) = 3;
    const Matrix x = solve(a, b);
    const Matrix back = a * x;
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(back(i, 0), b(i, 0), 1e-14);
    Matrix s(2, 2, 1.0);
    EXPECT_THROW(LuFactor{s}, NumericalError);
}

class ShiftedPencilSizes : public ::testing::TestWithParam<std::pair<int, double>> {};

TEST_P(ShiftedPencilSizes, MatchesLuForEveryShift) {
    // (D + u G) x = b for the shifts of a Nystrom evaluation (u in (0, 1], D the stream cosines,
    // down to 1e-3 at 24 streams and 1e-4 at 128, whose smallest Gauss node is 8.8e-5): the
    // Hessenberg solve of D^-1 G's reduction against an LU of each assembled matrix.
    const auto [n, smallest] = GetParam();
    Matrix g(n, n);
    std::vector<double> d(static_cast<std::size_t>(n)), b(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        d[i] = std::pow(smallest, i / (n - 1.0));
        b[i] = std::sin(1.0 + i);
        for (int j = 0; j < n; ++j) g(i, j) = (i == j ? 1.0 : 0.0) - 0.4 * std::cos(0.3 * i * j + 0.1 * j) / n;
    }
    const ShiftedPencil pencil(g, d);
    Matrix columns(n, 3);
    const std::vector<double> shifts = {1e-4, 0.37, 1.0};
    for (int i = 0; i < n; ++i)
        for (int e = 0; e < 3; ++e) columns(i, e) = b[i];
    pencil.solve(shifts, columns);
    for (int e = 0; e < 3; ++e) {
        Matrix k = g;
        k *= shifts[e];
        for (int i = 0; i < n; ++i) k(i, i) += d[i];
        std::vector<double> x = b;
        LuFactor(std::move(k)).solve(x);
        std::vector<double> y = b;
        pencil.solve(shifts[e], y);
        for (int i = 0; i < n; ++i) {
            EXPECT_NEAR(y[i], x[i], 1e-11 * (1.0 + std::abs(x[i]))) << "u " << shifts[e] << " row " << i;
            EXPECT_NEAR(columns(i, e), y[i], 1e-14 * (1.0 + std::abs(y[i])));
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Linalg, ShiftedPencilSizes,
                         ::testing::Values(std::pair{24, 1e-3}, std::pair{64, 3e-4}, std::pair{128, 1e-4}));

TEST(Linalg, ShiftedPencilRefusesSingularShiftsAndDiagonals) {
    // A singular shift is refused, not answered with garbage: D + u G = 0 at u = 1 for G = -D.
    Matrix minus_d(2, 2);
    minus_d(0, 0) = -0.5, minus_d(1, 1) = -0.25;
    std::vector<double> r = {1.0, 1.0};
    EXPECT_THROW(ShiftedPencil(minus_d, std::vector<double>{0.5, 0.25}).solve(1.0, r), NumericalError);
    // D must be invertible (the reduction is of D^-1 G).
    EXPECT_THROW(ShiftedPencil(minus_d, std::vector<double>{0.5, 0.0}), InternalError);
}

// The shifts are solved eight side by side (vector lanes): each one's answer is the one it gets
// alone (to rounding: BLAS multiplies one column and many in different orders), for a count that
// is no multiple of eight, different right-hand sides and shifts that pivot differently; a
// singular shift among others is named.
TEST(Linalg, ShiftedPencilSolvesEachShiftAsItWouldAlone) {
    const int n = 17, k = 19;
    Matrix g(n, n);
    std::vector<double> d(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        d[i] = std::pow(10.0, -2.0 * i / (n - 1.0));
        for (int j = 0; j < n; ++j) g(i, j) = (i == j ? 1.0 : 0.0) - 0.9 * std::cos(0.7 * i * j + 0.3 * j) / n;
    }
    const ShiftedPencil pencil(g, d);
    std::vector<double> shifts(static_cast<std::size_t>(k));
    Matrix columns(n, k);
    for (int e = 0; e < k; ++e) {
        shifts[e] = e % 3 == 0 ? 1e-3 * (e + 1) : 0.05 * (e + 1);
        for (int i = 0; i < n; ++i) columns(i, e) = std::sin(1.0 + i + 0.37 * e);
    }
    const Matrix rhs = columns;
    pencil.solve(shifts, columns);
    for (int e = 0; e < k; ++e) {
        std::vector<double> alone(static_cast<std::size_t>(n));
        for (int i = 0; i < n; ++i) alone[i] = rhs(i, e);
        pencil.solve(shifts[e], alone);
        Matrix a = g;
        a *= shifts[e];
        for (int i = 0; i < n; ++i) a(i, i) += d[i];
        std::vector<double> lu(static_cast<std::size_t>(n));
        for (int i = 0; i < n; ++i) lu[i] = rhs(i, e);
        LuFactor(std::move(a)).solve(lu);
        for (int i = 0; i < n; ++i) {
            EXPECT_NEAR(columns(i, e), alone[i], 1e-14 * (1.0 + std::abs(alone[i]))) << "shift " << e << " row " << i;
            EXPECT_NEAR(columns(i, e), lu[i], 1e-11 * (1.0 + std::abs(lu[i]))) << "shift " << e << " row " << i;
        }
    }
    // D + u G singular at u = 2 for G = -D / 2: the fifth of six shifts.
    Matrix half(2, 2);
    half(0, 0) = -0.25, half(1, 1) = -0.125;
    const std::vector<double> bad_shifts = {0.1, 0.5, 1.0, 1.5, 2.0, 3.0};
    Matrix ones(2, 6, 1.0);
    try {
        ShiftedPencil(half, std::vector<double>{0.5, 0.25}).solve(bad_shifts, ones);
        ADD_FAILURE() << "no error for a singular shift";
    } catch (const NumericalError& e) {
        EXPECT_EQ(std::string(e.what()), "ShiftedPencil: singular at u = 2 (size 2)");
    }
}

// A batch of pencils of one D is reduced eight at a time in vector lanes: each pencil solves as it
// does reduced alone by LAPACK (to rounding) and exactly as in a batch of its own (the same
// operations in its lane, whatever its neighbours), for a count that is no multiple of eight, and
// one pencil whose G is diagonal (no reflector at all: D^-1 G is already Hessenberg) solves as the
// diagonal system it is. Above the lanes' largest size the batch is LAPACK's, pencil by pencil.
TEST(Linalg, ShiftedPencilBatchSolvesEachAsItWouldAlone) {
    for (const int n : {20, 97}) {
        SCOPED_TRACE(n);
        const int count = 11;
        std::vector<double> d(static_cast<std::size_t>(n));
        for (int i = 0; i < n; ++i) d[i] = std::pow(10.0, -2.0 * i / (n - 1.0));
        std::vector<Matrix> g;
        for (int p = 0; p < count; ++p) {
            Matrix m(n, n);
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j)
                    m(i, j) = (i == j ? 1.0 + 0.1 * p : 0.0) -
                              (p == 4 ? 0.0 : 0.6 * std::cos(0.7 * i * j + 0.3 * j + p) / n);
            g.push_back(std::move(m));
        }
        const std::vector<ShiftedPencil> batch = ShiftedPencil::batch(g, d);
        ASSERT_EQ(batch.size(), g.size());
        const std::vector<double> shifts = {1e-3, 0.3, 1.0};
        Matrix rhs(n, 3);
        for (int i = 0; i < n; ++i)
            for (int e = 0; e < 3; ++e) rhs(i, e) = std::sin(1.0 + i + 0.5 * e);
        for (int p = 0; p < count; ++p) {
            Matrix together = rhs, own = rhs, alone = rhs;
            batch[p].solve(shifts, together);
            ShiftedPencil::batch(std::span(&g[p], 1), d).front().solve(shifts, own);
            ShiftedPencil(g[p], d).solve(shifts, alone);
            for (int i = 0; i < n; ++i)
                for (int e = 0; e < 3; ++e) {
                    EXPECT_EQ(together(i, e), own(i, e)) << "pencil " << p << " row " << i << " shift " << e;
                    EXPECT_NEAR(together(i, e), alone(i, e), 1e-12 * (1.0 + std::abs(alone(i, e))))
                        << "pencil " << p << " row " << i << " shift " << e;
                    if (p == 4) { // diagonal: x_i = b_i / (d_i + u g_ii)
                        EXPECT_NEAR(together(i, e), rhs(i, e) / (d[i] + shifts[e] * g[p](i, i)),
                                    1e-14 * std::abs(together(i, e)));
                    }
                }
        }
    }
    EXPECT_TRUE(ShiftedPencil::batch({}, std::vector<double>{1.0}).empty());
}

} // namespace
} // namespace brdf::test
