// Strict number and refractive-index parsing (src/brdf/core/parse.h). The tests live here because
// the Mie work introduced the parser (tests/core belongs to the core owners).

#include <brdf/core/error.h>
#include <brdf/core/parse.h>

#include "mie_test_support.h"
#include "test_support.h"

#include <cmath>

namespace brdf {
namespace {

using test::expect_error_mentions;

TEST(Parse, DoubleAcceptsPlainNumbers) {
    EXPECT_EQ(parse_double("1.5", "--x"), 1.5);
    EXPECT_EQ(parse_double("-3e-4", "--x"), -3e-4);
    EXPECT_EQ(parse_double("+2", "--x"), 2.0);
    EXPECT_EQ(parse_double(".5", "--x"), 0.5);
    EXPECT_EQ(parse_double("1E3", "--x"), 1000.0);
}

TEST(Parse, DoubleRejectsAnythingElseNamingTheFlag) {
    expect_error_mentions<InputError>([] { parse_double("", "--x"); }, "--x: expected a number, got an empty string");
    expect_error_mentions<InputError>([] { parse_double("0.3x", "--v-eff"); }, "--v-eff: expected a finite number, got '0.3x'");
    expect_error_mentions<InputError>([] { parse_double(" 1", "--x"); }, "' 1'");
    expect_error_mentions<InputError>([] { parse_double("1 ", "--x"); }, "'1 '");
    expect_error_mentions<InputError>([] { parse_double("nan", "--x"); }, "'nan'");
    expect_error_mentions<InputError>([] { parse_double("NaN", "--x"); }, "'NaN'");
    expect_error_mentions<InputError>([] { parse_double("inf", "--x"); }, "'inf'");
    expect_error_mentions<InputError>([] { parse_double("-infinity", "--x"); }, "'-infinity'");
    expect_error_mentions<InputError>([] { parse_double("1e999", "--x"); }, "'1e999'");
    expect_error_mentions<InputError>([] { parse_double("+-1", "--x"); }, "'+-1'");
    expect_error_mentions<InputError>([] { parse_double("0x10", "--x"); }, "'0x10'");
    expect_error_mentions<InputError>([] { parse_double("1,5", "--x"); }, "'1,5'");
}

TEST(Parse, ComplexIndexAcceptsTheDocumentedForms) {
    EXPECT_EQ(parse_complex_index("1.5", "--m"), std::complex<double>(1.5, 0.0));
    EXPECT_EQ(parse_complex_index("2.7+0.01i", "--m"), std::complex<double>(2.7, 0.01));
    EXPECT_EQ(parse_complex_index("2.7+1e-3i", "--m"), std::complex<double>(2.7, 1e-3));
    EXPECT_EQ(parse_complex_index("0.2+3.4i", "--m"), std::complex<double>(0.2, 3.4));
    EXPECT_EQ(parse_complex_index("1.5e0+2E-2j", "--m"), std::complex<double>(1.5, 0.02));
    EXPECT_EQ(parse_complex_index("1.33+0i", "--m"), std::complex<double>(1.33, 0.0));
    const std::complex<double> minus_zero = parse_complex_index("1.33-0i", "--m");
    EXPECT_EQ(minus_zero, std::complex<double>(1.33, 0.0));
    EXPECT_FALSE(std::signbit(minus_zero.imag()));
}

TEST(Parse, ComplexIndexExplainsTheSignConvention) {
    expect_error_mentions<InputError>([] { parse_complex_index("1.5-0.1i", "--m"); },
                                      "--m: imaginary part of '1.5-0.1i' is negative; the convention is m = n + ik with absorption k >= 0 (write 1.5+0.1i)");
}

TEST(Parse, ComplexIndexRejectsMalformedText) {
    for (const char* text : {"", "i", "1.5+i", "+0.1i", "3.4i", "1.5+0.1", "1.5+0.1ii", "1.5 + 0.1i",
                             "1.5+nani", "1.5+0.1i ", "abc", "1.5+-0.1i", "2.7+1e-3"}) {
        SCOPED_TRACE(text);
        EXPECT_THROW(parse_complex_index(text, "--m"), InputError);
    }
    expect_error_mentions<InputError>([] { parse_complex_index("1.5+0.1", "--index"); },
                                      "--index: expected a refractive index like 1.5 or 2.7+0.01i, got '1.5+0.1'");
    expect_error_mentions<InputError>([] { parse_complex_index("0", "--m"); }, "real part of '0' must be > 0");
    expect_error_mentions<InputError>([] { parse_complex_index("-1.5", "--m"); }, "real part");
}

} // namespace
} // namespace brdf
