#include <formats/table_io.h>

#include <brdf/core/error.h>

#include "format_test_util.h"
#include "test_support.h"

#include <cmath>

namespace brdf::formats {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

TEST(TableIo, FormatFollowsTheExtension) {
    EXPECT_EQ(table_format("a/b/paint.binary"), TableFormat::Merl);
    EXPECT_EQ(table_format("paint.BINARY"), TableFormat::Merl);
    EXPECT_EQ(table_format("paint.exr"), TableFormat::Exr);
    EXPECT_EQ(table_format("paint.Exr"), TableFormat::Exr);
    EXPECT_STREQ(to_string(TableFormat::Merl), "MERL .binary");
    EXPECT_STREQ(to_string(TableFormat::Exr), "OpenEXR");
    EXPECT_EQ(table_format("paint.spectral.exr"), TableFormat::SpectralExr);
    EXPECT_EQ(table_format("paint.fourier.bsdf"), TableFormat::Fourier);
    EXPECT_EQ(table_format("paint.RGL.bsdf"), TableFormat::RglTensor);
    EXPECT_THROW_MESSAGE(
        table_format("paint.png"), InputError,
        "paint.png: unsupported table format '.png' (supported: .binary (MERL), .exr (OpenEXR), "
        ".spectral.exr (spectral OpenEXR), .bsdf (pbrt-v3 Fourier BSDF), .rgl.bsdf (RGL tensor))");
    EXPECT_THROW(read_table("no-such-paint"), IoError);
    TempDir dir;
    EXPECT_THROW(write_table(dir / "x.json", test::analytic_table()), InputError);
    EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(TableIo, ReadsAndWritesBothFormats) {
    TempDir dir;
    const BrdfTable& t = test::analytic_table();
    write_table(dir / "a.binary", t);
    write_table(dir / "a.exr", t);
    EXPECT_EQ(fs::file_size(dir / "a.binary"), 34992012u);
    const BrdfTable merl = read_table(dir / "a.binary");
    const BrdfTable exr = read_table(dir / "a.exr");
    EXPECT_EQ(exr.spec, t.spec);
    const TableDiff d = diff(exr, merl);
    EXPECT_EQ(d.compared_cells, cells - 361784);
    for (const ChannelDiff& c : d.channels) EXPECT_LE(c.max, std::ldexp(1.0, -24) * 1.0001);
}

TEST(TableStatistics, CountsAndMomentsOverCellsWithData) {
    BrdfTable t;
    for (std::size_t cell = 0; cell < cells; ++cell)
        if (t.has_data(cell)) t.set(cell, {0.5, 0.25, 0.125});
    const std::size_t big = cell_index(0, 0, 0);
    t.set(big, {10.0, 0.25, 0.0});
    t.set_no_data(cell_index(0, 0, 1));
    const TableStats s = table_stats(t);
    const std::size_t n = cells - 361784 - 1;
    EXPECT_EQ(s.data_cells, n);
    EXPECT_EQ(s.below_horizon_cells, 361784u);
    EXPECT_EQ(s.channels[0].min, 0.5);
    EXPECT_EQ(s.channels[0].max, 10.0);
    EXPECT_REL_NEAR(s.channels[0].mean, (0.5 * (n - 1) + 10.0) / n, 1e-12);
    EXPECT_EQ(s.channels[1].min, 0.25);
    EXPECT_EQ(s.channels[1].max, 0.25);
    EXPECT_REL_NEAR(s.channels[1].mean, 0.25, 1e-12);
    EXPECT_EQ(s.channels[2].min, 0.0);
    EXPECT_EQ(s.channels[2].max, 0.125);

    BrdfTable empty;
    for (std::size_t cell = 0; cell < cells; ++cell) empty.set_no_data(cell);
    const TableStats e = table_stats(empty);
    EXPECT_EQ(e.data_cells, 0u);
    EXPECT_EQ(e.channels[0].min, 0.0);
    EXPECT_EQ(e.channels[0].max, 0.0);
    EXPECT_EQ(e.channels[0].mean, 0.0);
}

TEST(TableDifference, IdenticalTablesDifferByNothing) {
    const TableDiff d = diff(test::analytic_table(), test::analytic_table());
    EXPECT_EQ(d.compared_cells, cells - 361784);
    EXPECT_EQ(d.only_in_a, 0u);
    EXPECT_EQ(d.only_in_b, 0u);
    for (const ChannelDiff& c : d.channels) {
        EXPECT_EQ(c.max, 0.0);
        EXPECT_EQ(c.mean, 0.0);
        EXPECT_EQ(c.rms, 0.0);
    }
}

TEST(TableDifference, RelativeToTheReferenceWithAFloor) {
    BrdfTable b;
    for (std::size_t cell = 0; cell < cells; ++cell)
        if (b.has_data(cell)) b.set(cell, {0.2, 0.2, 0.0});
    BrdfTable a = b;
    const std::size_t worst = cell_index(10, 20, 30);
    for (std::size_t cell = 0; cell < cells; ++cell)
        if (a.has_data(cell)) a.set(cell, {0.2 * 1.001, 0.2, 1e-4});
    a.channels[0][worst] = 0.2 * 1.05;
    // A cell only A has, one only B has.
    const std::size_t a_only = cell_index(89, 89, 0), b_only = cell_index(0, 0, 5);
    a.set(a_only, {1, 1, 1});
    a.set_no_data(b_only);
    const TableDiff d = diff(a, b);
    const std::size_t n = cells - 361784 - 1;
    EXPECT_EQ(d.compared_cells, n);
    EXPECT_EQ(d.only_in_a, 1u);
    EXPECT_EQ(d.only_in_b, 1u);
    EXPECT_EQ(d.floor, 3e-4);
    EXPECT_REL_NEAR(d.channels[0].max, 0.05, 1e-12);
    EXPECT_EQ(d.channels[0].max_cell, worst);
    EXPECT_REL_NEAR(d.channels[0].mean, (0.001 * (n - 1) + 0.05) / n, 1e-9);
    EXPECT_REL_NEAR(d.channels[0].rms, std::sqrt((1e-6 * (n - 1) + 0.0025) / n), 1e-9);
    EXPECT_EQ(d.channels[1].max, 0.0);
    // Reference 0: the floor (3e-4 1/sr) stands in for it.
    EXPECT_REL_NEAR(d.channels[2].max, 1e-4 / 3e-4, 1e-12);
    EXPECT_REL_NEAR(diff(a, b, 1e-3).channels[2].max, 0.1, 1e-12);
    EXPECT_THROW_MESSAGE(diff(a, b, 0.0), InputError,
                         "diff: the relative-difference floor must be > 0 (got 0)");
    EXPECT_THROW(diff(a, b, std::nan("")), InputError);
}

} // namespace
} // namespace brdf::formats
