#include <formats/table.h>

#include <brdf/core/error.h>

#include "format_test_util.h"
#include "test_support.h"

#include <cmath>
#include <random>

namespace brdf::formats {
namespace {

constexpr std::size_t below_horizon_cells = 361784;

TEST(BrdfTable, NewTableMarksCellsBelowTheHorizonAsNoData) {
    const BrdfTable t;
    for (const auto& plane : t.channels) ASSERT_EQ(plane.size(), cells);
    EXPECT_EQ(t.data_cells(), cells - below_horizon_cells);
    for (std::size_t cell = 0; cell < cells; ++cell) {
        ASSERT_EQ(t.has_data(cell), !cell_below_horizon(cell));
        for (int c = 0; c < 3; ++c)
            ASSERT_EQ(t.channels[c][cell], cell_below_horizon(cell) ? -1.0 : 0.0);
    }
    EXPECT_EQ(t.colorspace, "rec709");
    EXPECT_EQ(canonical_colorspace("ACEScg"), "acescg");
    EXPECT_EQ(canonical_colorspace("Rec2020"), "rec2020");
    EXPECT_EQ(canonical_colorspace("linear Rec.709 (sRGB primaries), D65"), "rec709");
    EXPECT_EQ(canonical_colorspace("sRGB"), "");
    EXPECT_EQ(t.spec, "");
    EXPECT_EQ(t.generator, "");
}

TEST(BrdfTable, HasDataNeedsAllThreeChannels) {
    BrdfTable t;
    const std::size_t cell = cell_index(10, 10, 10);
    t.set(cell, {0.1, -1.0, 0.2});
    EXPECT_FALSE(t.has_data(cell));
    t.set(cell, {0.1, 0.0, 0.2});
    EXPECT_TRUE(t.has_data(cell));
    t.set_no_data(cell);
    EXPECT_FALSE(t.has_data(cell));
    EXPECT_EQ(t.at(cell), (Rgb{-1.0, -1.0, -1.0}));
}

// A grey table (a grey medium's fill) holds the red plane alone, which stands for all three.
BrdfTable grey_analytic_table() {
    BrdfTable grey(BrdfTable::Unwritten{}, true);
    grey.channels[0] = test::analytic_table().channels[0];
    return grey;
}

TEST(BrdfTable, AGreyTableReadsItsOnePlaneInEveryChannel) {
    BrdfTable grey = grey_analytic_table();
    EXPECT_TRUE(grey.grey);
    EXPECT_EQ(grey.channels[0].size(), cells);
    EXPECT_TRUE(grey.channels[1].empty() && grey.channels[2].empty());
    const TablePlane& red = test::analytic_table().channels[0];
    const std::size_t cell = cell_index(12, 34, 56), below = cell_index(89, 89, 0);
    EXPECT_EQ(grey.at(cell), (Rgb{red[cell], red[cell], red[cell]}));
    for (int c = 0; c < 3; ++c) EXPECT_EQ(&grey.plane(c), &grey.channels[0]);
    EXPECT_TRUE(grey.has_data(cell));
    EXPECT_FALSE(grey.has_data(below));
    EXPECT_EQ(grey.data_cells(), cells - below_horizon_cells);
    EXPECT_NO_THROW(check_table(grey, "grey"));
    // Setting a cell keeps the red value alone; made full, the table holds three equal planes.
    grey.set(cell, {0.5, 0.5, 0.5});
    EXPECT_EQ(grey.at(cell), (Rgb{0.5, 0.5, 0.5}));
    grey.make_full();
    EXPECT_FALSE(grey.grey);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(grey.channels[c], grey.channels[0]) << c;
    EXPECT_EQ(grey.at(cell), (Rgb{0.5, 0.5, 0.5}));
    grey.set(cell, {0.5, 0.25, 0.125});
    EXPECT_EQ(grey.at(cell), (Rgb{0.5, 0.25, 0.125}));
}

TEST(CheckTable, AGreyTableHoldsOnePlaneOfEveryCell) {
    BrdfTable grey = grey_analytic_table();
    grey.channels[0][cell_index(3, 4, 5)] = -0.5;
    EXPECT_THROW_MESSAGE(
        check_table(grey, "g"), NumericalError,
        "g: red value -0.5 at cell theta_h 3, theta_d 4, phi_d 5 (a BRDF must be finite and >= 0, "
        "or -1 in all three channels for no data)");
    grey = grey_analytic_table();
    grey.channels[2].resize(cells);
    EXPECT_THROW_MESSAGE(check_table(grey, "g"), NumericalError,
                         "g: the blue channel holds 1458000 values (0 expected in a grey table)");
    grey = grey_analytic_table();
    grey.channels[0].resize(cells - 1);
    EXPECT_THROW_MESSAGE(check_table(grey, "g"), NumericalError,
                         "g: the red channel holds 1457999 values (1458000 expected in a grey table)");
}

TEST(Tabulate, EvaluatesEveryCellAboveTheHorizonAtItsBinCentre) {
    std::size_t calls = 0;
    const BrdfTable t = tabulate([&](const CellCentre& c) {
        ++calls;
        EXPECT_EQ(c.cell, cell_index(c.index.theta_h, c.index.theta_d, c.index.phi_d));
        EXPECT_GT(c.dirs.wi.z, 0.0);
        EXPECT_GT(c.dirs.wo.z, 0.0);
        return Rgb{c.angles.theta_h, c.angles.theta_d, c.angles.phi_d};
    });
    EXPECT_EQ(calls, cells - below_horizon_cells);
    const std::size_t cell = cell_index(12, 34, 56);
    EXPECT_EQ(t.channels[0][cell], theta_h_centre(12));
    EXPECT_EQ(t.channels[1][cell], theta_d_centre(34));
    EXPECT_EQ(t.channels[2][cell], phi_d_centre(56));
    EXPECT_EQ(t.channels[0][cell_index(89, 89, 0)], BrdfTable::no_data);
}

TEST(CheckTable, NamesTheFirstBadCell) {
    BrdfTable t;
    EXPECT_NO_THROW(check_table(t, "t"));
    t.channels[1][cell_index(3, 4, 5)] = std::nan("");
    EXPECT_THROW_MESSAGE(
        check_table(t, "out.binary"), NumericalError,
        "out.binary: green value NaN at cell theta_h 3, theta_d 4, phi_d 5 (a BRDF "
        "must be finite and >= 0, or -1 in all three channels for no data)");
    t = BrdfTable();
    t.set(cell_index(0, 1, 2), {0.5, -0.25, 0.5});
    EXPECT_THROW_MESSAGE(
        check_table(t, "t"), NumericalError,
        "t: green value -0.25 at cell theta_h 0, theta_d 1, phi_d 2 (a BRDF must be "
        "finite and >= 0, or -1 in all three channels for no data)");
    t = BrdfTable();
    t.channels[2][cell_index(0, 0, 7)] = -std::numeric_limits<double>::infinity();
    EXPECT_THROW(check_table(t, "t"), NumericalError);
    // The first bad cell in cell order is named, however far apart the bad cells lie (the check
    // runs over blocks of cells); a cell with -1 in one channel alone is not "no data".
    t = BrdfTable();
    t.channels[1][cell_index(80, 2, 3)] = std::nan("");
    t.channels[0][cell_index(40, 5, 6)] = BrdfTable::no_data;
    EXPECT_THROW_MESSAGE(check_table(t, "t"), NumericalError,
                         "t: red value -1 at cell theta_h 40, theta_d 5, phi_d 6 (a BRDF must be "
                         "finite and >= 0, or -1 in all three channels for no data)");
    t.channels[0][cell_index(40, 5, 6)] = 0.0;
    EXPECT_THROW_MESSAGE(check_table(t, "t"), NumericalError,
                         "t: green value NaN at cell theta_h 80, theta_d 2, phi_d 3 (a BRDF must be "
                         "finite and >= 0, or -1 in all three channels for no data)");
    // Below the horizon anything goes: writers ignore those cells.
    t = BrdfTable();
    t.channels[0][cell_index(89, 89, 0)] = std::nan("");
    EXPECT_NO_THROW(check_table(t, "t"));
    t.channels[2].resize(10);
    EXPECT_THROW_MESSAGE(check_table(t, "t"), NumericalError,
                         "t: the blue channel holds 10 values (1458000 expected)");
}

TEST(TableLookup, FindsTheNearestCellOfTheReferenceReader) {
    // Each cell holds its own index, so a lookup tells which cell it read.
    BrdfTable t;
    for (std::size_t cell = 0; cell < cells; ++cell)
        if (t.has_data(cell)) t.set(cell, {double(cell), 2.0 * double(cell), 0.5});
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int n = 0; n < 20000; ++n) {
        const double ti = u(rng) * pi / 2, to = u(rng) * pi / 2, phi = 2 * pi * (u(rng) - 0.5);
        const TableSample s = sample(t, ti, to, phi);
        ASSERT_EQ(s.cell, nearest_cell(ti, to, phi));
        ASSERT_EQ(s.has_data, t.has_data(s.cell));
        if (s.has_data) {
            ASSERT_EQ(s.rgb[0], double(s.cell));
        } else {
            ASSERT_EQ(s.rgb, (Rgb{0, 0, 0}));
        }
        ASSERT_EQ(lookup(t, ti, to, phi), s.rgb);
    }
    // The bin centre of a cell, given as (theta_i, theta_o, phi), is found in that cell.
    for (std::size_t cell = 0; cell < cells; cell += 97) {
        if (!t.has_data(cell)) continue;
        const CellIndices c = cell_indices(cell);
        const DirectionPair p = to_directions(theta_h_centre(c.theta_h), theta_d_centre(c.theta_d),
                                              phi_d_centre(c.phi_d));
        const double ti = std::acos(p.wi.z), to = std::acos(p.wo.z);
        const double phi = std::atan2(p.wo.y, p.wo.x) - std::atan2(p.wi.y, p.wi.x);
        ASSERT_EQ(sample(t, ti, to, phi).cell, cell) << describe_cell(cell);
    }
}

TEST(TableLookup, BelowTheHorizonAndNoDataGiveZero) {
    BrdfTable t;
    for (std::size_t cell = 0; cell < cells; ++cell)
        if (t.has_data(cell)) t.set(cell, {1, 1, 1});
    const double deg = pi / 180;
    EXPECT_TRUE(sample(t, 30 * deg, 40 * deg, 1.0).has_data);
    const TableSample under = sample(t, 30 * deg, 100 * deg, 1.0);
    EXPECT_FALSE(under.has_data);
    EXPECT_EQ(under.rgb, (Rgb{0, 0, 0}));
    EXPECT_FALSE(sample(t, 91 * deg, 40 * deg, 1.0).has_data);
    t.set_no_data(nearest_cell(30 * deg, 40 * deg, 1.0));
    const TableSample hole = sample(t, 30 * deg, 40 * deg, 1.0);
    EXPECT_FALSE(hole.has_data);
    EXPECT_EQ(hole.rgb, (Rgb{0, 0, 0}));
}

// A white Lambertian surface (1/pi) reflects everything. The table loses a little near grazing
// outgoing angles, where nearest-bin lookups of directions above the horizon fall into cells whose
// bin centre lies below it (no data, 0): measured 4.3e-5 at theta_i = 10..80 degrees, 1.2e-2 at 89.
TEST(TableAlbedo, WhiteLambertianTableReflectsNearlyEverything) {
    const BrdfTable t = tabulate([](const CellCentre&) {
        return Rgb{1 / pi, 0.5 / pi, 0.25 / pi};
    });
    for (double deg : {0.0, 10.0, 30.0, 60.0, 80.0, 85.0}) {
        const Rgb rho = directional_albedo(t, deg * pi / 180);
        EXPECT_NEAR(rho[0], 1.0, 1e-4) << deg;
        EXPECT_LE(rho[0], 1.0 + 1e-12) << deg;
        EXPECT_REL_NEAR(rho[1], 0.5 * rho[0], 1e-14);
        EXPECT_REL_NEAR(rho[2], 0.25 * rho[0], 1e-14);
    }
    EXPECT_NEAR(directional_albedo(t, 89 * pi / 180)[0], 1.0, 0.02);
    EXPECT_EQ(directional_albedo(t, pi / 2 + 0.01), (Rgb{0, 0, 0}));
    EXPECT_THROW(directional_albedo(t, 0.1, {0, 10}), InputError);
}

TEST(TableAlbedo, AnalyticBrdfTableIsCloseToTheAnalyticAlbedo) {
    const BrdfTable& t = test::analytic_table();
    // Reference: the analytic BRDF integrated with the same rule but evaluated exactly.
    const double theta_i = 0.5;
    Rgb exact{0, 0, 0};
    const int nm = 400, np = 800;
    for (int m = 0; m < nm; ++m) {
        const double mu = (m + 0.5) / nm;
        for (int n = 0; n < np; ++n) {
            const Rgb f = test::analytic_brdf(direction(theta_i, 0),
                                              direction(std::acos(mu), (n + 0.5) * 2 * pi / np));
            for (int c = 0; c < 3; ++c) exact[c] += f[c] * mu * (1.0 / nm) * (2 * pi / np);
        }
    }
    const Rgb rho = directional_albedo(t, theta_i);
    // Nearest-bin error of the table for this lobe (n = 50): measured 1e-4 .. 4.4e-4 per channel.
    for (int c = 0; c < 3; ++c) EXPECT_REL_NEAR(rho[c], exact[c], 2e-3) << c;
}

} // namespace
} // namespace brdf::formats
