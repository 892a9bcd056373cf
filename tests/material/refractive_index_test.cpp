// The refractiveindex.info reader, the dispersion formulas and IndexModel.

#include <brdf/core/error.h>
#include <brdf/material/refractive_index.h>

#include "test_support.h"

#include <cmath>
#include <complex>
#include <limits>
#include <string>
#include <vector>

namespace brdf::material {
namespace {

// The message of the Error that `f` throws, checked to be of type E.
template <typename E, typename F> std::string message_of(F&& f) {
    try {
        f();
    } catch (const E& e) {
        return e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << "threw another exception type: " << e.what();
        return {};
    }
    ADD_FAILURE() << "did not throw";
    return {};
}

std::string format_error(std::string_view text, ReadOptions options = {}) {
    return message_of<FormatError>([&] { parse_index_file(text, "test.yml", options); });
}

// ---------------------------------------------------------------------------------------------
// Reader

TEST(IndexFile, ReadsTheSubset) {
    const std::string text = R"(# comment
REFERENCES: |
    A. Author.
    <a href="x">A paper</a> (2000)
COMMENTS: plain one-line comment
SPECS:
    temperature: 293
    thermal_dispersion:
        - type: "formula 1"
          coefficients: 1 2 3
DATA:
  - type: formula 2
    wavelength_range: 0.4 1.0
    coefficients: 0 1.1819 0.011313

  - type: tabulated k
    data: |
        0.30 0.010

        0.50 0.002
        1.20 0.0
CONDITIONS:
    temperature: 293
    direction: o
)";
    const IndexFile f = parse_index_file(text, "test.yml");
    EXPECT_EQ(f.name, "test.yml");
    EXPECT_EQ(f.references, "A. Author.\n<a href=\"x\">A paper</a> (2000)");
    EXPECT_EQ(f.comments, "plain one-line comment");
    ASSERT_EQ(f.data.size(), 2u);
    EXPECT_EQ(f.data[0].type, DataType::Formula2);
    EXPECT_EQ(f.data[0].line, 12);
    EXPECT_EQ(f.data[0].coefficients, (std::vector<double>{0, 1.1819, 0.011313}));
    EXPECT_DOUBLE_EQ(f.data[0].range.min_nm, 400.0);
    EXPECT_DOUBLE_EQ(f.data[0].range.max_nm, 1000.0);
    EXPECT_EQ(f.data[1].type, DataType::TabulatedK);
    EXPECT_EQ(f.data[1].line, 16);
    EXPECT_EQ(f.data[1].wavelength_nm.size(), 3u);
    EXPECT_DOUBLE_EQ(f.data[1].wavelength_nm[1], 500.0);
    EXPECT_TRUE(f.data[1].n.empty());
    EXPECT_EQ(f.data[1].k, (std::vector<double>{0.010, 0.002, 0.0}));
    EXPECT_TRUE(f.repairs.empty());

    // Formula n with tabulated k: k interpolated, range = intersection 400-1000 nm.
    const IndexModel m = IndexModel::from_file(f, "test");
    EXPECT_DOUBLE_EQ(m.data_range().min_nm, 400.0);
    EXPECT_DOUBLE_EQ(m.data_range().max_nm, 1000.0);
    EXPECT_TRUE(m.has_table());
    const IndexSample s = m.at(450.0);
    EXPECT_REL_NEAR(s.k, 0.010 + (0.002 - 0.010) * (450.0 - 300.0) / 200.0, 1e-14);
    const double l2 = 0.45 * 0.45;
    EXPECT_REL_NEAR(s.n, std::sqrt(1.0 + 1.1819 * l2 / (l2 - 0.011313)), 1e-14);
    EXPECT_FALSE(s.extrapolated);
}

// As in YAML, a '#' line inside a block scalar is content, not a comment: here a bad row.
TEST(IndexFile, CommentInsideADataBlockIsABadRow) {
    EXPECT_EQ(format_error("DATA:\n  - type: tabulated k\n    data: |\n        0.30 0.010\n"
                           "        # a comment\n        0.50 0.002\n"),
              "test.yml:5: tabulated k row has 3 fields, expected 2: '# a comment'");
}

TEST(IndexFile, FormatErrorsNameFileAndLine) {
    EXPECT_EQ(format_error("DATA:\n\t- type: formula 1\n"),
              "test.yml:2: tab character in indentation (use spaces)");
    EXPECT_EQ(format_error("REFERENCE: x\nDATA:\n"),
              "test.yml:1: unknown key 'REFERENCE' (expected REFERENCES, COMMENTS, DATA, "
              "CONDITIONS, SPECS or PROPERTIES)");
    EXPECT_EQ(format_error("DATA:\n  - type: formula 3\n    wavelength_range: 1 2\n"),
              "test.yml:2: unsupported data type 'formula 3' (this reader knows formula 1, 2 and 4 "
              "and tabulated nk, n and k)");
    EXPECT_EQ(format_error("DATA:\n  - type: tabulated nk\n    data: |\n        0.5 1.5\n"
                           "        0.6 1.5 0\n"),
              "test.yml:4: tabulated nk row has 2 fields, expected 3: '0.5 1.5'");
    EXPECT_EQ(format_error("DATA:\n  - type: tabulated n\n    data: |\n        0.5 1.5\n"
                           "        0.6 1.5x\n"),
              "test.yml:5: n: '1.5x' is not a number");
    EXPECT_EQ(format_error("DATA:\n  - type: formula 1\n    coefficients: 0 1 0.1\n"),
              "test.yml:2: formula 1 without 'wavelength_range'");
    EXPECT_EQ(format_error("DATA:\n  - type: formula 4\n    wavelength_range: 0.4 0.8\n"
                           "    coefficients: 1 2 3 4 5 6 7\n"),
              "test.yml:4: formula 4 needs 1, 5, 9, 11, 13, 15 or 17 coefficients (got 7)");
    EXPECT_EQ(format_error("DATA:\n  - type: formula 2\n    wavelength_range: 0.4 0.8\n"
                           "    coefficients: 0 1\n"),
              "test.yml:4: formula 2 needs C1 and pairs of coefficients, an odd count (got 2)");
    EXPECT_EQ(format_error("DATA:\n  - type: formula 2\n    wavelength_range: 0.8 0.4\n"
                           "    coefficients: 0 1 0.1\n"),
              "test.yml:3: wavelength_range: expected 0 < min < max, got '0.8 0.4'");
    EXPECT_EQ(format_error("DATA:\n  - type: formula 2\n    type: formula 1\n"),
              "test.yml:3: duplicate key type in a DATA entry");
    EXPECT_EQ(format_error("DATA:\n  - type: formula 2\n    range: 0.4 0.8\n"),
              "test.yml:3: unknown key 'range' in a DATA entry (expected type, wavelength_range, "
              "coefficients or data)");
    EXPECT_EQ(format_error("DATA:\n  - type: tabulated nk\n    data: |\n        0.5 1.5 0\n"),
              "test.yml:2: tabulated nk needs at least 2 rows (got 1)");
    EXPECT_EQ(format_error("DATA:\n  - type: tabulated nk\n    data: |\n        0.5 0 0\n"),
              "test.yml:4: n must be > 0 (got 0)");
    EXPECT_EQ(format_error("DATA:\n  - type: tabulated nk\n    data: |\n        0.5 1 nan\n"),
              "test.yml:4: k: 'nan' is not finite");
    EXPECT_EQ(format_error("REFERENCES: x\n"), "test.yml:2: no DATA in the file");
    EXPECT_EQ(format_error("DATA:\n"), "test.yml:1: DATA has no entries");
    EXPECT_EQ(format_error("DATA:\n  - type: formula 2\n      coefficients: 0 1 0.1\n"),
              "test.yml:3: unexpected indentation in a DATA entry");
    EXPECT_EQ(format_error("  DATA:\n"),
              "test.yml:1: unexpected indentation (expected a top-level key such as DATA:)");
    EXPECT_EQ(format_error("DATA:\n  - type: tabulated nk\n    wavelength_range: 0.4 0.8\n"
                           "    data: |\n        0.5 1 0\n        0.6 1 0\n"),
              "test.yml:3: 'wavelength_range' is not used with tabulated nk (the rows give the "
              "range)");
}

const std::string unsorted_table = "DATA:\n"
                                   "  - type: tabulated nk\n"
                                   "    data: |\n"
                                   "        0.50 1.50 0.10\n"
                                   "        0.60 1.60 0.20\n"
                                   "        0.60 1.70 0.30\n"
                                   "        0.55 1.80 -0.40\n"
                                   "        0.70 1.90 -1e-17\n";

TEST(IndexFile, StrictModeRejectsUnsortedRowsAndNegativeK) {
    EXPECT_EQ(format_error(unsorted_table),
              "test.yml:6: wavelength 0.60 um does not exceed the previous row's 0.60 um (rows "
              "must be sorted by increasing wavelength)");
    EXPECT_EQ(format_error("DATA:\n  - type: tabulated nk\n    data: |\n        0.5 1 0\n"
                           "        0.6 1 -1e-17\n"),
              "test.yml:5: k must be >= 0 (got -1e-17)");
}

TEST(IndexFile, RepairModeDropsUnsortedRowsAndClampsNegativeK) {
    ReadOptions repair;
    repair.repair_tables = true;
    const IndexFile f = parse_index_file(unsorted_table, "test.yml", repair);
    ASSERT_EQ(f.data.size(), 1u);
    EXPECT_EQ(f.data[0].wavelength_nm.size(), 3u); // rows 6 and 7 dropped
    EXPECT_DOUBLE_EQ(f.data[0].wavelength_nm[2], 700.0);
    EXPECT_EQ(f.data[0].n, (std::vector<double>{1.5, 1.6, 1.9}));
    EXPECT_EQ(f.data[0].k, (std::vector<double>{0.1, 0.2, 0.0}));
    EXPECT_EQ(f.repairs,
              (std::vector<std::string>{
                  "test.yml:6: wavelength 0.60 um does not exceed the previous row's 0.60 um: "
                  "row dropped",
                  "test.yml:7: wavelength 0.55 um does not exceed the previous row's 0.60 um: "
                  "row dropped",
                  "test.yml:2: 1 row with k < 0 (smallest -1e-17 at line 8): set to 0"}));
}

TEST(IndexFile, AcceptsCrlfLineEnds) {
    const IndexFile f =
        parse_index_file("DATA:\r\n  - type: formula 1\r\n    wavelength_range: 0.2 2\r\n"
                         "    coefficients: 0 0.6961663 0.0684043\r\n",
                         "crlf.yml");
    ASSERT_EQ(f.data.size(), 1u);
    EXPECT_EQ(f.data[0].coefficients.size(), 3u);
}

// YAML allows a list at its key's indentation; the database indents by 2, but both must read alike.
TEST(IndexFile, AcceptsAListAtTheKeysIndentation) {
    const IndexFile f = parse_index_file("DATA:\n- type: formula 1\n  wavelength_range: 0.2 2\n"
                                         "  coefficients: 0 0.6961663 0.0684043\n"
                                         "- type: tabulated k\n  data: |\n    0.3 0.1\n"
                                         "    0.9 0.2\nCONDITIONS:\n  temperature: 293\n",
                                         "flat.yml");
    ASSERT_EQ(f.data.size(), 2u);
    EXPECT_EQ(f.data[0].type, DataType::Formula1);
    EXPECT_EQ(f.data[1].k, (std::vector<double>{0.1, 0.2}));
    const IndexSample s = IndexModel::from_file(f, "flat").at(600.0);
    EXPECT_REL_NEAR(s.k, 0.15, 1e-15);
    EXPECT_EQ(s.complex(), std::complex<double>(s.n, s.k));
}

TEST(IndexFile, RejectsHugeInput) {
    const std::string big(max_index_file_bytes + 1, ' ');
    EXPECT_THROW(parse_index_file(big, "big.yml"), LimitError);
}

// ---------------------------------------------------------------------------------------------
// Formulas. The references are the published equations written out here independently of
// formula_n's generic loops.

TEST(IndexFormula, Formula1IsSellmeierWithSquaredResonances) {
    // Malitson (1965) fused silica: n^2 - 1 = sum B_i l^2 / (l^2 - L_i^2)
    const std::vector<double> c{0, 0.6961663, 0.0684043, 0.4079426, 0.1162414, 0.8974794, 9.896161};
    for (double l : {0.25, 0.5875618, 1.0, 3.0}) {
        const double l2 = l * l;
        const double ref = std::sqrt(1.0 + 0.6961663 * l2 / (l2 - 0.0684043 * 0.0684043) +
                                     0.4079426 * l2 / (l2 - 0.1162414 * 0.1162414) +
                                     0.8974794 * l2 / (l2 - 9.896161 * 9.896161));
        EXPECT_REL_NEAR(formula_n(DataType::Formula1, c, l), ref, 1e-15) << l;
    }
    // The textbook value n_d = 1.4585 at the helium d line (Malitson 1965, table).
    EXPECT_NEAR(formula_n(DataType::Formula1, c, 0.5875618), 1.4585, 5e-5);
}

TEST(IndexFormula, Formula2IsSellmeierWithUnsquaredResonances) {
    // Ghosh (1999) calcite, ordinary ray: n^2 = A + B l^2/(l^2 - C) + D l^2/(l^2 - E), A = 1 + C1.
    const std::vector<double> c{0.73358749, 0.96464345, 1.94325203e-2, 1.82831454, 120};
    for (double l : {0.25, 0.5893, 1.5}) {
        const double l2 = l * l;
        const double ref = std::sqrt(1.73358749 + 0.96464345 * l2 / (l2 - 1.94325203e-2) +
                                     1.82831454 * l2 / (l2 - 120.0));
        EXPECT_REL_NEAR(formula_n(DataType::Formula2, c, l), ref, 1e-15) << l;
    }
    // Handbook value of calcite n_o at the sodium D line: 1.6584.
    EXPECT_NEAR(formula_n(DataType::Formula2, c, 0.5893), 1.6584, 1e-4);
}

TEST(IndexFormula, Formula4ExponentConventions) {
    // DeVore (1951) rutile, ordinary ray: n^2 = 5.913 + 0.2441 / (l^2 - 0.0803); the file writes
    // it as C1 C2 C3=0 C4=0.0803 C5=1 (pole C4^C5), then a zero second term.
    const std::vector<double> rutile{5.913, 0.2441, 0, 0.0803, 1, 0, 0, 0, 1};
    // Bond (1965) ZnO, ordinary ray: n^2 = 2.81418 + 0.87968 l^2/(l^2 - 0.3042^2) - 0.00711 l^2,
    // with a pole C4^C5 = 0.3042^2 and a power term C10 l^C11.
    const std::vector<double> zno{2.81418, 0.87968, 2, 0.3042, 2, 0, 0, 0, 1, -0.00711, 2};
    for (double l : {0.45, 0.55, 1.2}) {
        const double l2 = l * l;
        EXPECT_REL_NEAR(formula_n(DataType::Formula4, rutile, l),
                        std::sqrt(5.913 + 0.2441 / (l2 - 0.0803)), 1e-15);
        EXPECT_REL_NEAR(formula_n(DataType::Formula4, zno, l),
                        std::sqrt(2.81418 + 0.87968 * l2 / (l2 - 0.3042 * 0.3042) - 0.00711 * l2),
                        1e-15);
    }
    // Every term with non-trivial exponents, 17 coefficients:
    // n^2 = 2 + 0.3 l^1.5/(l^2 - 0.2^3) + 0.1 l^0.5/(l^2 - 0.3^2) + 0.01 l^1 + 0.02 l^-2
    //         + 0.003 l^3 - 0.004 l^2.5
    const std::vector<double> all{2,    0.3, 1.5,  0.2, 3,     0.1, 0.5,    0.3, 2,
                                  0.01, 1,   0.02, -2,  0.003, 3,   -0.004, 2.5};
    for (double l : {0.4, 0.7, 1.1}) {
        const double l2 = l * l;
        const double ref =
            std::sqrt(2 + 0.3 * std::pow(l, 1.5) / (l2 - 0.008) + 0.1 * std::sqrt(l) / (l2 - 0.09) +
                      0.01 * l + 0.02 / l2 + 0.003 * l * l * l - 0.004 * std::pow(l, 2.5));
        EXPECT_REL_NEAR(formula_n(DataType::Formula4, all, l), ref, 1e-14) << l;
    }
}

TEST(IndexFormula, NonPhysicalResultIsANumericalError) {
    // Below the pole of the Sultanova PMMA fit (sqrt(0.011313) um = 106 nm), n^2 < 0.
    const std::vector<double> pmma{0, 1.1819, 0.011313};
    EXPECT_THROW(formula_n(DataType::Formula2, pmma, 0.105), NumericalError);
    EXPECT_THROW(formula_n(DataType::TabulatedNK, pmma, 0.5), FormatError);
}

// ---------------------------------------------------------------------------------------------
// Tables and models

const std::vector<NkRow> small_table{{400.0, 1.5, 0.0}, {500.0, 1.7, 0.2}, {700.0, 1.3, 0.1}};

TEST(IndexTable, InterpolatesNAndKLinearlyInWavelength) {
    const IndexModel m = IndexModel::from_nk_table(small_table, "pigments[0].material.nk");
    // At the nodes exactly the table.
    for (const NkRow& r : small_table) {
        const IndexSample s = m.at(r.wavelength_nm);
        EXPECT_EQ(s.n, r.n);
        EXPECT_EQ(s.k, r.k);
        EXPECT_FALSE(s.extrapolated);
    }
    // 450 nm: half way from 400 to 500; 650 nm: three quarters from 500 to 700.
    EXPECT_REL_NEAR(m.at(450.0).n, 1.6, 1e-15);
    EXPECT_REL_NEAR(m.at(450.0).k, 0.1, 1e-15);
    EXPECT_REL_NEAR(m.at(650.0).n, 1.7 + 0.75 * (1.3 - 1.7), 1e-15);
    EXPECT_REL_NEAR(m.at(650.0).k, 0.2 + 0.75 * (0.1 - 0.2), 1e-15);
    EXPECT_TRUE(m.has_table());
    EXPECT_FALSE(m.is_extended());
}

TEST(IndexTable, IsNeverExtrapolated) {
    const IndexModel m = IndexModel::from_nk_table(small_table, "pigments[0].material.nk");
    EXPECT_EQ(message_of<InputError>([&] { m.at(300.0); }),
              "wavelength 300 nm is outside the data of pigments[0].material.nk (400-700 nm)");
    EXPECT_EQ(message_of<InputError>([&] { m.at(700.5); }),
              "wavelength 700.5 nm is outside the data of pigments[0].material.nk (400-700 nm)");
    EXPECT_EQ(message_of<InputError>([&] {
                  m.extended({380.0, 780.0});
              }),
              "cannot extend pigments[0].material.nk to 380-780 nm: tabulated data are never "
              "extrapolated");
    EXPECT_EQ(message_of<InputError>([&] { m.at(std::nan("")); }),
              "wavelength nan nm for pigments[0].material.nk: must be finite and > 0");
    EXPECT_THROW(m.at(-500.0), InputError);
}

TEST(IndexUserData, NkTableProblemsSayWhatAndWhichRow) {
    const double inf = std::numeric_limits<double>::infinity();
    const std::vector<NkRow> bad{{500.0, 1.5, 0.0},
                                 {450.0, -1.0, 0.0},
                                 {600.0, 1.5, -0.1},
                                 {inf, 1.5, 0.0},
                                 {700.0, 1.5, std::nan("")}};
    // Adjacent literals below are deliberate concatenations of long messages.
    // NOLINTNEXTLINE(bugprone-suspicious-missing-comma)
    EXPECT_EQ(nk_table_problems(bad, "pigments[1].material.nk"),
              (std::vector<std::string>{
                  "pigments[1].material.nk[1][1]: n must be finite and > 0 (got -1)",
                  "pigments[1].material.nk[1][0]: wavelength 450 nm is not greater than the "
                  "previous row's 500 nm (rows must be sorted by strictly increasing wavelength)",
                  "pigments[1].material.nk[2][2]: k must be finite and >= 0 (got -0.1; k is the "
                  "absorption, a non-negative number)",
                  "pigments[1].material.nk[3][0]: wavelength must be finite and > 0 nm (got inf)",
                  "pigments[1].material.nk[4][2]: k must be finite and >= 0 (got nan; k is the "
                  "absorption, a non-negative number)",
              }));
    const std::vector<NkRow> one{{500.0, 1.5, 0.0}};
    EXPECT_EQ(
        nk_table_problems(one),
        (std::vector<std::string>{"nk: needs at least 2 rows [wavelength_nm, n, k] (got 1)"}));
    EXPECT_EQ(message_of<InputError>([&] { IndexModel::from_nk_table(one); }),
              "nk: needs at least 2 rows [wavelength_nm, n, k] (got 1)");
    // All problems in one message.
    const std::string all = message_of<InputError>([&] { IndexModel::from_nk_table(bad, "t"); });
    EXPECT_NE(all.find("t[1][1]: n must be"), std::string::npos) << all;
    EXPECT_NE(all.find("; t[4][2]: k must be"), std::string::npos) << all;

    std::vector<NkRow> huge(max_nk_rows + 1);
    for (std::size_t i = 0; i < huge.size(); ++i) huge[i] = {200.0 + 0.01 * i, 1.5, 0.0};
    EXPECT_THROW(IndexModel::from_nk_table(huge), LimitError);
}

TEST(IndexUserData, ConstantIndex) {
    const IndexModel m = IndexModel::constant(2.7, 0.01, "pigments[0].material.index");
    for (double l : {1.0, 380.0, 1e6}) {
        const IndexSample s = m.at(l);
        EXPECT_EQ(s.n, 2.7);
        EXPECT_EQ(s.k, 0.01);
        EXPECT_FALSE(s.extrapolated);
    }
    EXPECT_TRUE(m.is_constant());
    EXPECT_FALSE(m.has_table());
    EXPECT_EQ(message_of<InputError>([] { IndexModel::constant(-1.5, -0.1, "binder.index"); }),
              "binder.index: real part n must be finite and > 0 (got -1.5); binder.index: "
              "imaginary part k must be finite and >= 0 (got -0.1; k is the absorption, a "
              "non-negative number)");
    EXPECT_TRUE(constant_index_problems(1.0, 0.0).empty());
    EXPECT_EQ(constant_index_problems(std::nan(""), 0.0),
              (std::vector<std::string>{"index: real part n must be finite and > 0 (got nan)"}));
}

TEST(IndexModel, AverageWeighsNAndKAndIntersectsRanges) {
    const std::vector<NkRow> o_rows{{300.0, 2.0, 0.3}, {800.0, 2.5, 0.0}};
    const std::vector<NkRow> e_rows{{400.0, 3.0, 0.6}, {900.0, 3.5, 0.1}};
    const IndexModel o = IndexModel::from_nk_table(o_rows, "o");
    const IndexModel e = IndexModel::from_nk_table(e_rows, "e");
    // Weights need not be normalised: 2 and 1 mean (2 o + e) / 3.
    const std::pair<double, IndexModel> parts[] = {{2.0, o}, {1.0, e}};
    const IndexModel avg = IndexModel::average(parts, "crystal");
    EXPECT_DOUBLE_EQ(avg.data_range().min_nm, 400.0);
    EXPECT_DOUBLE_EQ(avg.data_range().max_nm, 800.0);
    for (double l : {400.0, 555.0, 800.0}) {
        const IndexSample so = o.at(l), se = e.at(l), s = avg.at(l);
        EXPECT_REL_NEAR(s.n, (2.0 * so.n + se.n) / 3.0, 1e-15) << l;
        EXPECT_REL_NEAR(s.k, (2.0 * so.k + se.k) / 3.0, 1e-15) << l;
    }
    EXPECT_EQ(message_of<InputError>([&] { avg.at(350.0); }),
              "wavelength 350 nm is outside the data of crystal (400-800 nm)");
}

// A formula file extended beyond its data: extrapolated samples, and the messages.
TEST(IndexModel, ExtendedFormulaFlagsExtrapolatedSamples) {
    const IndexFile f = parse_index_file("DATA:\n  - type: formula 2\n"
                                         "    wavelength_range: 0.4368 1.052\n"
                                         "    coefficients: 0 1.1819 0.011313\n",
                                         "pmma.yml");
    const IndexModel base = IndexModel::from_file(f, "pmma");
    EXPECT_FALSE(base.has_table());
    EXPECT_EQ(message_of<InputError>([&] { base.at(400.0); }),
              "wavelength 400 nm is outside the data of pmma (436.8-1052 nm)");
    const IndexModel m = base.extended({380.0, 1052.0}, "see the docs");
    EXPECT_TRUE(m.is_extended());
    EXPECT_TRUE(m.at(400.0).extrapolated);
    EXPECT_FALSE(m.at(436.8).extrapolated); // the data's own end point
    EXPECT_FALSE(m.at(500.0).extrapolated);
    const double l2 = 0.4 * 0.4;
    EXPECT_REL_NEAR(m.at(400.0).n, std::sqrt(1.0 + 1.1819 * l2 / (l2 - 0.011313)), 1e-15);
    EXPECT_EQ(m.at(400.0).k, 0.0);
    EXPECT_EQ(message_of<InputError>([&] { m.at(379.0); }),
              "wavelength 379 nm is outside the usable range of pmma (380-1052 nm; its data "
              "cover 436.8-1052 nm): see the docs");
    EXPECT_THROW(base.extended({500.0, 1052.0}), InputError); // must contain the data
    // A pole inside an (unwise) extension surfaces as a NumericalError naming the model.
    const IndexModel wild = base.extended({50.0, 1052.0});
    EXPECT_EQ(message_of<NumericalError>([&] { wild.at(100.0); }).rfind("pmma: formula 2 gives", 0),
              0u);
}

TEST(IndexModel, FileWithoutNOrWithTwoNEntriesIsAFormatError) {
    EXPECT_EQ(message_of<FormatError>([] {
                  IndexModel::from_file(
                      parse_index_file("DATA:\n  - type: tabulated k\n    data: |\n"
                                       "        0.5 0.1\n        0.6 0.1\n",
                                       "k.yml"),
                      "k");
              }),
              "k.yml: no DATA entry gives n (only tabulated k)");
    EXPECT_EQ(message_of<FormatError>([] {
                  IndexModel::from_file(
                      parse_index_file("DATA:\n  - type: tabulated n\n    data: |\n"
                                       "        0.5 1.5\n        0.6 1.5\n"
                                       "  - type: formula 1\n    wavelength_range: 0.2 2\n"
                                       "    coefficients: 0 1 0.1\n",
                                       "two.yml"),
                      "two");
              }),
              "two.yml:6: a second entry that gives n (the first is at line 2)");
    EXPECT_EQ(message_of<FormatError>([] {
                  IndexModel::from_file(
                      parse_index_file("DATA:\n  - type: tabulated n\n    data: |\n"
                                       "        0.5 1.5\n        0.6 1.5\n"
                                       "  - type: tabulated k\n    data: |\n"
                                       "        0.7 0.1\n        0.8 0.1\n",
                                       "apart.yml"),
                      "apart");
              }),
              "apart.yml: the n data (500-600 nm) and the k data (700-800 nm) do not overlap");
}

TEST(IndexModel, TabulatedNAloneGivesZeroK) {
    const IndexModel m = IndexModel::from_file(
        parse_index_file("DATA:\n  - type: tabulated n\n    data: |\n        0.5 1.5\n"
                         "        0.6 1.7\n",
                         "n.yml"),
        "n");
    EXPECT_REL_NEAR(m.at(525.0).n, 1.55, 1e-15);
    EXPECT_EQ(m.at(525.0).k, 0.0);
}

} // namespace
} // namespace brdf::material
