// Single-sphere Lorenz-Mie: published reference values, an independent 40-digit reference, limits
// and invariants.

#include <brdf/core/error.h>
#include <brdf/mie/mie.h>
#include <brdf/mie/phase_function.h>

#include "mie_test_support.h"
#include "test_support.h"

#include <cmath>
#include <complex>
#include <random>

namespace brdf::mie {
namespace {

using Complex = std::complex<double>;
using test::mie_reference;

// --- Published values -------------------------------------------------------------------------

// Wiscombe, W. J. (1979, revised 1996), "Mie scattering calculations: advances in technique and fast,
// vector-speed computer codes", NCAR/TN-140+STR: the MIEV0 test cases 5-19, with the digits and
// absolute tolerances that miepython's tests use for them (S. Prahl, tests/test_nojit.py; a value of
// 0 means the case gives no such number). MIEV0 writes m = n - ik; we write m = n + ik: the real
// results are the same.
struct Published {
    Complex m;
    double x;
    double qext;
    double qsca;
    double g;
    double tol; ///< absolute
};

TEST(MieReference, Miev0TestCases) {
    const Published cases[] = {
        {{0.75, 0.0}, 0.099, 0.000007, 0.000007, 0.001448, 1e-6},  // case 5
        {{0.75, 0.0}, 0.101, 0.000008, 0.000008, 0.001507, 1e-6},  // case 6
        {{0.75, 0.0}, 10.0, 0.0, 2.232265, 0.896473, 1e-6},        // case 7
        {{0.75, 0.0}, 1000.0, 0.0, 1.997908, 0.844944, 1e-6},      // case 8
        {{1.33, 1e-5}, 1.0, 0.0, 0.093923, 0.184517, 1e-6},        // case 9
        {{1.33, 1e-5}, 100.0, 0.0, 2.096594, 0.868959, 1e-6},      // case 10
        {{1.33, 1e-5}, 10000.0, 0.0, 1.723857, 0.907840, 1e-6},    // case 11
        {{1.5, 1.0}, 0.055, 0.101491, 0.000011, 0.000491, 1e-6},   // case 12
        {{1.5, 1.0}, 0.056, 0.103347, 0.000012, 0.000509, 1e-6},   // case 13
        {{1.5, 1.0}, 1.0, 0.0, 0.6634538, 0.192136, 1e-6},         // case 14
        {{1.5, 1.0}, 100.0, 2.097502, 1.283697, 0.850252, 1e-6},   // case 15
        {{1.5, 1.0}, 10000.0, 2.004368, 1.236575, 0.846309, 1e-6}, // case 16
        {{10.0, 10.0}, 1.0, 0.0, 2.049405, -0.110664, 1e-6},       // case 17
        {{10.0, 10.0}, 100.0, 0.0, 1.836785, 0.556215, 1e-6},      // case 18
        {{10.0, 10.0}, 10000.0, 0.0, 1.795393, 0.548194, 1e-6},    // case 19
    };
    for (const Published& c : cases) {
        const Efficiencies q = efficiencies(coefficients(c.m, c.x));
        SCOPED_TRACE(testing::Message() << "m = " << c.m << ", x = " << c.x);
        if (c.qext != 0.0) {
            EXPECT_NEAR(q.qext, c.qext, c.tol);
        }
        EXPECT_NEAR(q.qsca, c.qsca, c.tol);
        EXPECT_NEAR(q.g, c.g, c.tol);
    }
}

// Bohren and Huffman's own BHMIE example (B&H appendix A: m = 1.55, radius 0.525 um, wavelength
// 0.6328 um), as checked by miepython's tests: Qext = Qsca = 3.10543, Qback = 2.92534, g = 0.63314.
TEST(MieReference, BohrenHuffmanAppendixExample) {
    const double x = 2.0 * M_PI * 0.525 / 0.6328;
    const Efficiencies q = efficiencies(coefficients({1.55, 0.0}, x));
    EXPECT_NEAR(q.qext, 3.10543, 1e-5);
    EXPECT_NEAR(q.qsca, 3.10543, 1e-5);
    EXPECT_NEAR(q.qback, 2.92534, 1e-5);
    EXPECT_NEAR(q.g, 0.63314, 1e-5);
}

// MIEV0's older test cases for a non-absorbing m = 1.5 (Wiscombe 1979 as above; miepython
// tests/test_nojit.py "OLD MIEV0 Test Case 1-4"): Qsca to 5 digits.
TEST(MieReference, Miev0NonAbsorbing) {
    const std::pair<double, double> cases[] = {{10.0, 2.8820}, {100.0, 2.0944}, {1000.0, 2.0139},
                                               {5000.0, 2.0086}};
    for (const auto& [x, qsca] : cases) {
        const Efficiencies q = efficiencies(coefficients({1.5, 0.0}, x));
        EXPECT_REL_NEAR(q.qsca, qsca, 3e-5) << "x = " << x;
        EXPECT_EQ(q.qext, q.qsca) << "x = " << x;
    }
}

// docs/physics.md section 1 (values from MIEV0 as reproduced by miepython): m = 1.5 - 0.1i in MIEV0's
// convention is m = 1.5 + 0.1i in ours.
TEST(MieReference, PhysicsNotesValues) {
    const Efficiencies q = efficiencies(coefficients({1.5, 0.1}, 10.0));
    EXPECT_REL_NEAR(q.qext, 2.4597905, 1e-7);
    EXPECT_REL_NEAR(q.qsca, 1.2351442, 1e-7);
    EXPECT_REL_NEAR(q.g, 0.9223496, 1e-7);
    EXPECT_REL_NEAR(efficiencies(coefficients({1.5, 0.0}, 10.0)).qsca, 2.8820, 2e-5);
}

// MIEV0 test case 14 amplitudes (m = 1.5 - 1i in MIEV0's convention, x = 1) at 0, 30, ..., 180
// degrees, as tabulated in miepython tests/test_nojit.py. Our S are their complex conjugates.
TEST(MieReference, Miev0Amplitudes) {
    const Coefficients c = coefficients({1.5, 1.0}, 1.0);
    const double s1[7][2] = {{0.584080, 0.190515}, {0.565702, 0.187200}, {0.517525, 0.178443},
                             {0.456340, 0.167167}, {0.400212, 0.156643}, {0.362157, 0.149391},
                             {0.348844, 0.146829}};
    const double s2[7][2] = {{0.584080, 0.190515},   {0.500161, 0.145611},
                             {0.287964, 0.041054},   {0.0362285, -0.0618265},
                             {-0.174875, -0.122959}, {-0.305682, -0.143846},
                             {-0.348844, -0.146829}};
    for (int k = 0; k < 7; ++k) {
        const double mu = std::cos(k * 30.0 * M_PI / 180.0);
        const Amplitudes s = amplitudes(c, k == 6 ? -1.0 : mu);
        EXPECT_NEAR(s.s1.real(), s1[k][0], 1e-6) << k * 30 << " degrees";
        EXPECT_NEAR(s.s1.imag(), -s1[k][1], 1e-6) << k * 30 << " degrees";
        EXPECT_NEAR(s.s2.real(), s2[k][0], 1e-6) << k * 30 << " degrees";
        EXPECT_NEAR(s.s2.imag(), -s2[k][1], 1e-6) << k * 30 << " degrees";
    }
}

// --- Independent 40-digit reference (tests/reference/mie/mie_reference.py) ----------------------

// What limits the agreement is the truncation at Wiscombe's N, not rounding: the reference sums 40
// more terms. For real m the dropped terms enter Qext = Qsca only as |a_n|^2 (1e-14 agreement); for
// absorbing m, Re(a_n) - |a_n|^2 of the first dropped term is first order in a_n and leaves ~3e-10 in
// Qabs and Qext at x = 100-1000. The amplitudes see Im a_n ~ |a_n| of the dropped terms (7e-10 of
// |S(0)|), the backscattering efficiency, a squared alternating sum, up to 1.2e-7.
TEST(MieReference, MatchesFortyDigitSeries) {
    int checked = 0;
    for (const auto& c : mie_reference()["cases"]) {
        if (c["source"] != "mpmath") continue;
        const Complex m(c["m"][0].get<double>(), c["m"][1].get<double>());
        const double x = c["x"].get<double>();
        SCOPED_TRACE(testing::Message() << "m = " << m << ", x = " << x);
        const Coefficients coef = coefficients(m, x);
        const Efficiencies q = efficiencies(coef);
        EXPECT_REL_NEAR(q.qsca, c["qsca"].get<double>(), 1e-13);
        EXPECT_REL_NEAR(q.g, c["g"].get<double>(), 1e-13);
        EXPECT_REL_NEAR(q.qback, c["qback"].get<double>(), 3e-7);
        if (m.imag() == 0.0) {
            EXPECT_EQ(q.qabs, 0.0);
            EXPECT_REL_NEAR(q.qext, c["qext"].get<double>(), 1e-13);
        } else {
            // Relative to Qext: for weak absorption (k = 1e-5) Qabs itself is small and the
            // truncation error is absolute.
            EXPECT_NEAR(q.qabs, c["qabs"].get<double>(), 1e-9 * q.qext);
            EXPECT_REL_NEAR(q.qext, c["qext"].get<double>(), 1e-9);
        }
        const double scale = std::abs(amplitudes(coef, 1.0).s1); // |S(0)|, the largest amplitude
        for (const auto& a : c["amplitudes"]) {
            const double mu = a[0].get<double>();
            const Amplitudes s = amplitudes(coef, mu);
            const Complex s1(a[1].get<double>(), a[2].get<double>());
            const Complex s2(a[3].get<double>(), a[4].get<double>());
            EXPECT_LE(std::abs(s.s1 - s1), 2e-9 * scale) << "S1 at mu = " << mu;
            EXPECT_LE(std::abs(s.s2 - s2), 2e-9 * scale) << "S2 at mu = " << mu;
        }
        if (c.contains("legendre")) {
            const std::vector<double> beta = legendre_coefficients(coef);
            const auto& ref = c["legendre"];
            // Same truncation rule (drop trailing |beta_l| <= 1e-12): lengths agree up to the
            // moments hovering at the threshold.
            EXPECT_NEAR(static_cast<double>(beta.size()), static_cast<double>(ref.size()), 2.0);
            for (std::size_t l = 0; l < std::min(beta.size(), ref.size()); ++l)
                EXPECT_NEAR(beta[l], ref[l].get<double>(), 2e-10 * (2.0 * l + 1.0)) << "l = " << l;
        }
        ++checked;
    }
    EXPECT_GE(checked, 30);
}

// x = 1e4 against miepython (double precision, independent code): both accumulate ~1e4 terms
// (3e-12 agreement; Qback 9e-9).
TEST(MieReference, MatchesMiepythonAtLargeSize) {
    int checked = 0;
    for (const auto& c : mie_reference()["cases"]) {
        if (c["source"] == "mpmath") continue;
        const Complex m(c["m"][0].get<double>(), c["m"][1].get<double>());
        const double x = c["x"].get<double>();
        SCOPED_TRACE(testing::Message() << "m = " << m << ", x = " << x);
        const Efficiencies q = efficiencies(coefficients(m, x));
        EXPECT_REL_NEAR(q.qext, c["qext"].get<double>(), 1e-11);
        EXPECT_REL_NEAR(q.qsca, c["qsca"].get<double>(), 1e-11);
        EXPECT_REL_NEAR(q.g, c["g"].get<double>(), 1e-11);
        EXPECT_REL_NEAR(q.qback, c["qback"].get<double>(), 3e-8);
        if (m.imag() > 0.0) {
            EXPECT_REL_NEAR(q.qabs, c["qabs"].get<double>(), 1e-10);
        }
        ++checked;
    }
    EXPECT_EQ(checked, 6);
}

// --- Limits ------------------------------------------------------------------------------------

// Rayleigh limit (B&H section 5.2): Qsca = (8/3) x^4 |K|^2, Qabs = 4 x Im K, K = (m^2-1)/(m^2+2).
// The next terms are O(|m|^2 x^2) relative, so 10 |m|^2 x^2 is the honest tolerance.
TEST(MieLimits, RayleighSmallSphere) {
    const Complex indices[] = {{1.5, 0.0}, {1.5, 0.1}, {0.75, 0.0}, {1.33, 1e-5},
                               {2.7, 0.01}, {0.2, 3.4}, {10.0, 10.0}, {1.5, 1e-10}};
    for (const Complex m : indices) {
        const Complex k = (m * m - 1.0) / (m * m + 2.0);
        for (const double x : {1e-3, 1e-6}) {
            SCOPED_TRACE(testing::Message() << "m = " << m << ", x = " << x);
            const double tol = 10.0 * std::max(1.0, std::norm(m)) * x * x + 1e-14;
            const Efficiencies q = efficiencies(coefficients(m, x));
            EXPECT_REL_NEAR(q.qsca, 8.0 / 3.0 * std::pow(x, 4) * std::norm(k), tol);
            if (m.imag() > 0.0) {
                EXPECT_REL_NEAR(q.qabs, 4.0 * x * k.imag(), tol);
            } else {
                EXPECT_EQ(q.qabs, 0.0);
                EXPECT_EQ(q.qext, q.qsca);
            }
            EXPECT_REL_NEAR(q.qext, q.qsca + q.qabs, 1e-15);
        }
    }
}

// Far below the Rayleigh range nothing overflows or turns negative.
TEST(MieLimits, TinySizesStayFinite) {
    for (const Complex m : {Complex(1.5, 0.0), Complex(1.5, 0.1), Complex(10.0, 10.0),
                            Complex(0.2, 3.4)})
        for (const double x : {1e-8, 1e-10, min_size_parameter}) {
            const Sphere s = sphere(m, x);
            EXPECT_TRUE(std::isfinite(s.q.qext) && std::isfinite(s.q.g)) << m << " " << x;
            EXPECT_GT(s.q.qsca, 0.0) << m << " " << x;
            EXPECT_GE(s.q.qabs, 0.0) << m << " " << x;
            // Rayleigh phase function 3/4 (1 + mu^2): beta_2 = 1/2.
            ASSERT_GE(s.legendre.size(), 3u) << m << " " << x;
            EXPECT_NEAR(s.legendre[2], 0.5, 1e-6) << m << " " << x;
        }
}

// Extinction paradox: Qext -> 2 as x -> infinity (van de Hulst 1957, "Light Scattering by Small
// Particles"); at x = 1e4 the remaining edge term ~ x^(-2/3) is below 1e-2.
TEST(MieLimits, LargeSphereExtinctionTendsToTwo) {
    for (const Complex m : {Complex(1.5, 0.0), Complex(1.5, 0.1), Complex(0.75, 0.0),
                            Complex(1.33, 1e-5), Complex(10.0, 10.0), Complex(0.2, 3.4)})
        EXPECT_NEAR(efficiencies(coefficients(m, 1e4)).qext, 2.0, 1e-2) << m;
}

// --- Invariants ------------------------------------------------------------------------------

class MieInvariants : public testing::TestWithParam<Complex> {};

TEST_P(MieInvariants, HoldOverSizes) {
    const Complex m = GetParam();
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    for (const double x : {1e-3, 0.05, 0.5, 1.0, 3.3, 10.0, 31.4, 100.0, 400.0}) {
        SCOPED_TRACE(testing::Message() << "m = " << m << ", x = " << x);
        const Coefficients c = coefficients(m, x);
        const Efficiencies q = efficiencies(c);
        EXPECT_GE(q.qabs, 0.0);
        for (double a : c.absorption) EXPECT_GE(a, 0.0);
        EXPECT_LE(q.qsca, q.qext);
        if (m.imag() == 0.0) {
            EXPECT_REL_NEAR(q.qext, q.qsca, 1e-12);
        }
        EXPECT_LE(std::abs(q.g), 1.0);
        EXPECT_GE(q.qback, 0.0);
        // |a_n - 1/2| <= 1/2 for a passive sphere: Re a - |a|^2 >= 0 term by term.
        for (int n = 0; n < c.size(); ++n) {
            EXPECT_LE(std::abs(c.a[n] - 0.5), 0.5 + 1e-14);
            EXPECT_LE(std::abs(c.b[n] - 0.5), 0.5 + 1e-14);
        }

        PhaseFunctionAccumulator acc(c.size());
        acc.add(c, 1.0);
        // int (|S1|^2 + |S2|^2) dmu = x^2 Qsca (B&H chapter 4): the angular rule is exact; what
        // remains is the rounding of sums over ~2N terms.
        EXPECT_REL_NEAR(acc.integral(), x * x * q.qsca, 1e-11);
        const std::vector<double> beta = acc.legendre();
        ASSERT_GE(beta.size(), 2u);
        EXPECT_EQ(beta[0], 1.0);
        EXPECT_NEAR(beta[1], 3.0 * q.g, 1e-10);
        // The Legendre series reproduces the phase function p = 2 (|S1|^2 + |S2|^2) / (x^2 Qsca),
        // whose half-integral is 1, at angles that are not quadrature nodes.
        for (int k = 0; k < 5; ++k) {
            const double mu = k == 0 ? 1.0 : uniform(rng);
            const Amplitudes s = amplitudes(c, mu);
            const double p = 2.0 * (std::norm(s.s1) + std::norm(s.s2)) / (x * x * q.qsca);
            double series = 0.0, p_prev = 1.0, p_l = mu;
            for (std::size_t l = 0; l < beta.size(); ++l) {
                const double pl = l == 0 ? 1.0 : p_l;
                series += beta[l] * pl;
                if (l >= 1) {
                    const double next = ((2.0 * l + 1.0) * mu * p_l - l * p_prev) / (l + 1.0);
                    p_prev = p_l;
                    p_l = next;
                }
            }
            // The dropped moments are each <= 1e-12; the forward peak p(1) ~ x^2 sets the scale of
            // the rounding.
            EXPECT_NEAR(series, p, 1e-11 * std::max(1.0, x * x) + 1e-12 * beta.size()) << "mu = " << mu;
        }
    }
}

INSTANTIATE_TEST_SUITE_P(
    Indices, MieInvariants,
    testing::Values(Complex(1.5, 0.0), Complex(0.75, 0.0), Complex(1.0 / 1.5, 0.0),
                    Complex(1.33, 1e-5), Complex(1.5, 0.1), Complex(1.5, 1e-10),
                    Complex(2.7, 0.01), Complex(2.0, 0.0), Complex(1.0001, 0.0),
                    Complex(0.2, 3.4), Complex(0.05, 4.0), Complex(10.0, 10.0), Complex(1.5, 1.0)));

// --- API behaviour ---------------------------------------------------------------------------

TEST(MieSeries, SeriesLengthIsWiscombes) {
    EXPECT_EQ(series_length(10.0), 20);     // 10 + 4.05 * 2.154 + 2 = 20.7
    EXPECT_EQ(series_length(1e4), 10089);   // 1e4 + 87.3 + 2
    EXPECT_EQ(series_length(1e-3), 2);
    EXPECT_EQ(coefficients({1.5, 0.0}, 100.0).size(), series_length(100.0));
}

TEST(MieSeries, SphereBundlesTheParts) {
    const Sphere s = sphere({1.5, 0.1}, 10.0);
    const Coefficients c = coefficients({1.5, 0.1}, 10.0);
    const Efficiencies q = efficiencies(c);
    EXPECT_EQ(s.q.qext, q.qext);
    EXPECT_EQ(s.q.g, q.g);
    EXPECT_EQ(s.albedo, q.qsca / q.qext);
    EXPECT_EQ(s.terms, c.size());
    EXPECT_EQ(s.legendre, legendre_coefficients(c));
}

TEST(MieSeries, LegendreTruncationFollowsOptions) {
    const Coefficients c = coefficients({1.5, 0.0}, 10.0);
    const std::vector<double> all = legendre_coefficients(c, {0.0, 0});
    EXPECT_EQ(all.size(), 2u * c.size() + 1u); // the intensity has degree 2N
    const std::vector<double> beta = legendre_coefficients(c);
    ASSERT_LT(beta.size(), all.size());
    EXPECT_GT(std::abs(beta.back()), 1e-12);
    for (std::size_t l = beta.size(); l < all.size(); ++l) EXPECT_LE(std::abs(all[l]), 1e-12);
    const std::vector<double> capped = legendre_coefficients(c, {1e-12, 5});
    ASSERT_EQ(capped.size(), 5u);
    for (std::size_t l = 0; l < 5; ++l) EXPECT_EQ(capped[l], beta[l]);
    const std::vector<double> loose = legendre_coefficients(c, {1e-3, 0});
    EXPECT_LT(loose.size(), beta.size());
    EXPECT_GT(std::abs(loose.back()), 1e-3);
}

TEST(MieSeries, ReusedStorageGivesTheSameResult) {
    Coefficients c;
    coefficients({1.5, 0.1}, 100.0, c);
    coefficients({2.0, 0.0}, 3.0, c); // shrinks
    const Coefficients fresh = coefficients({2.0, 0.0}, 3.0);
    EXPECT_EQ(c.a, fresh.a);
    EXPECT_EQ(c.b, fresh.b);
    EXPECT_EQ(c.absorption, fresh.absorption);
}

TEST(MieInputs, RejectsInvalidValuesNamingThem) {
    const double nan = std::nan("");
    test::expect_error_mentions<InputError>([&] { coefficients({nan, 0.0}, 1.0); }, "nan");
    test::expect_error_mentions<InputError>([&] { coefficients({0.0, 0.0}, 1.0); }, "real part");
    test::expect_error_mentions<InputError>([&] { coefficients({-1.5, 0.0}, 1.0); }, "-1.5");
    test::expect_error_mentions<InputError>([&] { coefficients({1.5, -0.1}, 1.0); }, "k >= 0");
    test::expect_error_mentions<InputError>([&] { coefficients({1.5, 0.0}, 0.0); }, "x");
    test::expect_error_mentions<InputError>([&] { coefficients({1.5, 0.0}, -2.0); }, "-2");
    test::expect_error_mentions<InputError>([&] { coefficients({1.5, 0.0}, nan); }, "nan");
    test::expect_error_mentions<InputError>(
        [&] { coefficients({1.5, 0.0}, std::numeric_limits<double>::infinity()); }, "inf");
    test::expect_error_mentions<InputError>([&] { coefficients({1.5, 0.0}, 1e-13); }, "minimum");
    test::expect_error_mentions<LimitError>([&] { coefficients({1.5, 0.0}, 2e5); }, "200000");
    const Coefficients big = coefficients({1.5, 0.0}, 6e4);
    test::expect_error_mentions<LimitError>([&] { legendre_coefficients(big); }, "60000");
    const Coefficients small = coefficients({1.5, 0.0}, 1.0);
    test::expect_error_mentions<InputError>([&] { amplitudes(small, 1.5); }, "1.5");
    test::expect_error_mentions<InputError>([&] { legendre_coefficients(small, {-1.0, 0}); },
                                            "tolerance");
}

// Spheres in a batch (coefficients over a span: a real index runs eight to a vector) get the bits
// each gets alone: every term of a, b and the absorption, for indices above and below 1, sizes from
// the Rayleigh range to thousands of terms mixed in one batch (each lane its own term count and
// recurrence start), a batch that is not a multiple of eight, and an absorbing index (one by one).
// So do the efficiencies a batch sums as it makes the terms (the lanes add nothing past their own
// terms): every one of them is efficiencies() of the sphere alone.
TEST(MieCoefficients, BatchEqualsOneByOne) {
    std::mt19937 rng(12);
    std::uniform_real_distribution<double> decades(-6.0, 3.5);
    for (std::complex<double> m : {std::complex<double>(1.8), std::complex<double>(0.75), std::complex<double>(1.001),
                                   std::complex<double>(2.9 / 1.49), std::complex<double>(1.5, 0.01)}) {
        std::vector<double> x;
        for (int i = 0; i < 29; ++i) x.push_back(std::pow(10.0, decades(rng)));
        x.push_back(x.front()); // the same sphere twice in one batch
        std::vector<Coefficients> batch(x.size()), with_efficiencies(x.size());
        std::vector<Efficiencies> q(x.size());
        SeriesWork work;
        coefficients(m, x, batch, work);
        coefficients(m, x, with_efficiencies, q, work);
        for (std::size_t i = 0; i < x.size(); ++i) {
            const Coefficients one = coefficients(m, x[i]);
            ASSERT_EQ(batch[i].size(), one.size()) << "m " << m << " x " << x[i];
            EXPECT_EQ(batch[i].x, one.x);
            const Efficiencies alone = efficiencies(one);
            EXPECT_EQ(q[i].qext, alone.qext) << "m " << m << " x " << x[i];
            EXPECT_EQ(q[i].qsca, alone.qsca) << "m " << m << " x " << x[i];
            EXPECT_EQ(q[i].qabs, alone.qabs) << "m " << m << " x " << x[i];
            EXPECT_EQ(q[i].qback, alone.qback) << "m " << m << " x " << x[i];
            EXPECT_EQ(q[i].g, alone.g) << "m " << m << " x " << x[i];
            ASSERT_EQ(with_efficiencies[i].a, one.a) << "m " << m << " x " << x[i];
            ASSERT_EQ(with_efficiencies[i].b, one.b) << "m " << m << " x " << x[i];
            for (int n = 0; n < one.size(); ++n) {
                ASSERT_EQ(batch[i].a[n], one.a[n]) << "m " << m << " x " << x[i] << " a_" << n + 1;
                ASSERT_EQ(batch[i].b[n], one.b[n]) << "m " << m << " x " << x[i] << " b_" << n + 1;
                ASSERT_EQ(batch[i].absorption[n], one.absorption[n]) << "m " << m << " x " << x[i];
            }
        }
    }
    // Invalid input is refused as one by one; mismatched spans are an internal error.
    std::vector<Coefficients> two(2);
    SeriesWork work;
    EXPECT_THROW(coefficients(std::complex<double>(1.5), std::vector<double>{1.0, -1.0}, two, work), InputError);
    EXPECT_THROW(coefficients(std::complex<double>(1.5), std::vector<double>{1.0, 1e300}, two, work), LimitError);
    EXPECT_THROW(coefficients(std::complex<double>(1.5), std::vector<double>{std::nan(""), 1.0}, two, work),
                 InputError);
    EXPECT_THROW(coefficients(std::complex<double>(1.5), std::vector<double>{1.0}, two, work), InternalError);
    std::vector<Efficiencies> one_efficiency(1);
    EXPECT_THROW(coefficients(std::complex<double>(1.5), std::vector<double>{1.0, 2.0}, two, one_efficiency, work),
                 InternalError);
}

} // namespace
} // namespace brdf::mie
