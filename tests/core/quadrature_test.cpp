#include <brdf/core/error.h>
#include <brdf/core/quadrature.h>

#include "test_support.h"

#include <cmath>

namespace brdf {
namespace {

// An n-point rule integrates x^k exactly for k <= 2n - 1: int_{-1}^{1} x^k = 2/(k+1) for even k.
TEST(GaussLegendre, IntegratesPolynomialsUpToDegree2nMinus1) {
    for (int n : {1, 2, 3, 7, 16, 64, 257}) {
        const auto q = gauss_legendre(n);
        for (int k = 0; k <= 2 * n - 1 && k <= 60; ++k) {
            double sum = 0.0;
            for (std::size_t i = 0; i < q->size(); ++i) sum += q->w[i] * std::pow(q->x[i], k);
            const double exact = k % 2 ? 0.0 : 2.0 / (k + 1);
            EXPECT_NEAR(sum, exact, 1e-14) << "n = " << n << ", k = " << k;
        }
    }
}

TEST(GaussLegendre, NodesAscendSymmetricWeightsSumToTwo) {
    for (int n : {2, 5, 100, 1001, 20000}) {
        const auto q = gauss_legendre(n);
        double total = 0.0;
        for (std::size_t i = 0; i < q->size(); ++i) {
            total += q->w[i];
            EXPECT_GT(q->w[i], 0.0);
            if (i > 0) {
                EXPECT_LT(q->x[i - 1], q->x[i]);
            }
            EXPECT_EQ(q->x[i], -q->x[q->size() - 1 - i]);
        }
        EXPECT_REL_NEAR(total, 2.0, 1e-13) << "n = " << n;
    }
}

// A smooth non-polynomial integrand converges to machine precision: int_0^pi sin = 2.
TEST(GaussLegendre, MappedIntervalIntegratesSine) {
    const Quadrature q = gauss_legendre(20, 0.0, M_PI);
    double sum = 0.0;
    for (std::size_t i = 0; i < q.size(); ++i) sum += q.w[i] * std::sin(q.x[i]);
    EXPECT_REL_NEAR(sum, 2.0, 1e-15);
}

TEST(GaussLegendre, RejectsAbsurdSizes) {
    EXPECT_THROW(gauss_legendre(0), LimitError);
    EXPECT_THROW(gauss_legendre(10000000), LimitError);
}

} // namespace
} // namespace brdf
