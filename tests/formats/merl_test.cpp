#include <formats/merl/merl.h>

#include <brdf/core/error.h>

#include "format_test_util.h"
#include "test_support.h"

#include <bit>
#include <cmath>
#include <csignal>
#include <cstring>
#include <random>
#include <sys/resource.h>

namespace brdf::formats {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

// Files in a folder other than `keep`: a failed or finished write must leave no temporary behind.
std::vector<std::string> files_in(const fs::path& folder) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(folder))
        names.push_back(entry.path().filename());
    std::sort(names.begin(), names.end());
    return names;
}

double next_up(double x) {
    return std::nextafter(x, INFINITY);
}

TEST(MerlFormat, FileHasTheExactSizeHeaderAndScaledPlanes) {
    TempDir dir;
    const BrdfTable& t = test::analytic_table();
    write_merl(dir / "a.binary", t);
    EXPECT_EQ(fs::file_size(dir / "a.binary"), 34992012u);
    const std::string bytes = test::read_file(dir / "a.binary");
    ASSERT_EQ(bytes.size(), 34992012u);
    // int32 90, 90, 180, little-endian.
    const unsigned char header[12] = {90, 0, 0, 0, 90, 0, 0, 0, 180, 0, 0, 0};
    EXPECT_EQ(std::memcmp(bytes.data(), header, 12), 0);
    // Planes red, green, blue, each in MERL index order, BRDF / scale.
    const double scales[3] = {1.0 / 1500, 1.15 / 1500, 1.66 / 1500};
    for (std::size_t cell : {cell_index(0, 0, 0), cell_index(5, 6, 7), cell_index(40, 30, 179),
                             cell_index(89, 0, 90)}) {
        ASSERT_TRUE(t.has_data(cell));
        for (int c = 0; c < 3; ++c)
            EXPECT_EQ(test::load_f64_le(bytes, test::merl_offset(c, cell)),
                      t.channels[c][cell] / scales[c])
                << channel_name(c) << " " << describe_cell(cell);
    }
}

TEST(MerlFormat, CellsBelowTheHorizonHoldMinusOneInAllPlanes) {
    TempDir dir;
    // Data where the geometry says there can be none: the writer still writes -1 there.
    BrdfTable t;
    for (auto& plane : t.channels) std::fill(plane.begin(), plane.end(), 0.125);
    write_merl(dir / "a.binary", t);
    const std::string bytes = test::read_file(dir / "a.binary");
    std::size_t minus_one = 0;
    for (std::size_t cell = 0; cell < cells; ++cell)
        for (int c = 0; c < 3; ++c) {
            const double v = test::load_f64_le(bytes, test::merl_offset(c, cell));
            ASSERT_EQ(v, cell_below_horizon(cell) ? -1.0 : 0.125 / merl_scales[c])
                << describe_cell(cell);
            minus_one += v == -1.0;
        }
    EXPECT_EQ(minus_one, 3u * 361784u);
    // Read back: exactly those cells have no data.
    const BrdfTable back = read_merl(dir / "a.binary");
    for (std::size_t cell = 0; cell < cells; ++cell)
        ASSERT_EQ(back.has_data(cell), !cell_below_horizon(cell));
}

// BRDF / scale then * scale is not the identity in floating point (about 14% of doubles move by one
// ulp), so a computed table comes back within one ulp; but the MERL values themselves are fixed
// points: a table that was read from a file survives write + read bit for bit, and a file this
// writer made survives read + write byte for byte.
TEST(MerlFormat, RoundTripsAreExactWhereFloatingPointAllowsAndOneUlpOtherwise) {
    TempDir dir;
    const BrdfTable& t = test::analytic_table();
    write_merl(dir / "a.binary", t);
    const BrdfTable once = read_merl(dir / "a.binary");
    std::size_t moved = 0;
    for (std::size_t cell = 0; cell < cells; ++cell) {
        ASSERT_EQ(once.has_data(cell), t.has_data(cell));
        for (int c = 0; c < 3; ++c) {
            const double a = t.channels[c][cell], b = once.channels[c][cell];
            if (!t.has_data(cell)) {
                ASSERT_EQ(b, -1.0);
                continue;
            }
            ASSERT_TRUE(b == a || b == next_up(a) || a == next_up(b)) << a << " " << b;
            moved += a != b;
        }
    }
    EXPECT_GT(moved, 0u); // the one-ulp moves do happen: this test would notice a lossless scale
    write_merl(dir / "b.binary", once);
    EXPECT_EQ(test::read_file(dir / "a.binary"), test::read_file(dir / "b.binary"));
    const BrdfTable twice = read_merl(dir / "b.binary");
    for (int c = 0; c < 3; ++c)
        for (std::size_t cell = 0; cell < cells; ++cell)
            ASSERT_EQ(std::bit_cast<std::uint64_t>(twice.channels[c][cell]),
                      std::bit_cast<std::uint64_t>(once.channels[c][cell]));
}

TEST(MerlFormat, NegativeStoredValuesMarkTheirCellAsNoData) {
    TempDir dir;
    write_merl(dir / "a.binary", test::analytic_table());
    std::string bytes = test::read_file(dir / "a.binary");
    const std::size_t hole = cell_index(20, 20, 20), neighbour = cell_index(20, 20, 21);
    test::store_f64_le(bytes, test::merl_offset(1, hole), -0.5); // green only
    test::write_file(dir / "b.binary", bytes);
    const BrdfTable t = read_merl(dir / "b.binary");
    EXPECT_FALSE(t.has_data(hole));
    EXPECT_EQ(t.at(hole), (Rgb{-1, -1, -1}));
    EXPECT_TRUE(t.has_data(neighbour));
    EXPECT_EQ(t.data_cells(), cells - 361784 - 1);
    // Metadata: none in this format.
    EXPECT_EQ(t.spec, "");
    EXPECT_EQ(t.generator, "");
}

// What the MERL reference reader does with our file, restated: read three int32, check their
// product, read the doubles, and look up value * scale; a negative value means "below horizon".
TEST(MerlFormat, TheReferenceReadersLookupSeesTheTable) {
    TempDir dir;
    const BrdfTable& t = test::analytic_table();
    write_merl(dir / "a.binary", t);
    const std::string bytes = test::read_file(dir / "a.binary");
    std::int32_t dims[3];
    std::memcpy(dims, bytes.data(), 12);
    ASSERT_EQ(std::int64_t{dims[0]} * dims[1] * dims[2], 90 * 90 * 180);
    std::mt19937_64 rng(29);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    int below = 0;
    for (int n = 0; n < 20000; ++n) {
        const double ti = u(rng) * pi / 2, to = u(rng) * pi / 2, phi = 2 * pi * u(rng);
        const std::size_t ind = nearest_cell(ti, to, phi);
        const double red = test::load_f64_le(bytes, 12 + 8 * ind) * (1.0 / 1500.0);
        const double green =
            test::load_f64_le(bytes, 12 + 8 * (ind + std::size_t{90} * 90 * 180)) * (1.15 / 1500.0);
        const double blue =
            test::load_f64_le(bytes, 12 + 8 * (ind + std::size_t{90} * 90 * 360)) * (1.66 / 1500.0);
        if (red < 0 || green < 0 || blue < 0) {
            ++below;
            ASSERT_FALSE(t.has_data(ind));
            continue;
        }
        const Rgb expected = lookup(t, ti, to, phi);
        EXPECT_REL_NEAR(red, expected[0], 3e-16);
        EXPECT_REL_NEAR(green, expected[1], 3e-16);
        EXPECT_REL_NEAR(blue, expected[2], 3e-16);
        // And the table holds the analytic BRDF at the bin centre, not at the looked-up angles.
        const CellIndices c = cell_indices(ind);
        const DirectionPair centre = to_directions(
            theta_h_centre(c.theta_h), theta_d_centre(c.theta_d), phi_d_centre(c.phi_d));
        EXPECT_REL_NEAR(red, test::analytic_brdf(centre.wi, centre.wo)[0], 3e-16);
    }
    EXPECT_GT(below, 0); // some grazing lookups land in below-horizon cells
}

// --- refusals: every message names the file and the fault --------------------------------------

TEST(MerlRead, TruncatedFile) {
    TempDir dir;
    const fs::path p = dir / "paint.binary";
    test::write_file(p, test::merl_truncated(1200));
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() + ": truncated (34992012 bytes expected, 1200 found)");
    // One byte short of a table.
    test::write_file(p, test::merl_truncated(34992011));
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() + ": truncated (34992012 bytes expected, 34992011 found)");
    // Shorter than the header.
    test::write_file(p, "abcde");
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() + ": truncated (34992012 bytes expected, 5 found)");
}

TEST(MerlRead, FileLongerThanATable) {
    TempDir dir;
    const fs::path p = dir / "long.binary";
    test::write_file(p, test::merl_truncated(34992020));
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() + ": wrong size (34992012 bytes expected, 34992020 found)");
}

TEST(MerlRead, EmptyFile) {
    TempDir dir;
    const fs::path p = dir / "empty.binary";
    test::write_file(p, "");
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() + ": empty file (34992012 bytes expected)");
}

TEST(MerlRead, BigEndianHeaderIsRecognised) {
    TempDir dir;
    const fs::path p = dir / "swapped.binary";
    // A whole table written big-endian: the header says so before the size is even considered.
    std::string bytes = test::merl_header_big_endian(90, 90, 180);
    bytes.resize(34992012, '\0');
    test::write_file(p, bytes);
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() + ": big-endian header (dims 90 90 180 after byte swapping); "
                                      "MERL tables are little-endian");
}

TEST(MerlRead, HugeDimsAreRefusedBeforeAllocating) {
    TempDir dir;
    const fs::path p = dir / "huge.binary";
    test::write_file(p, test::merl_header(90, 90, 2147483647));
    {
        const test::AllocationProbe probe;
        EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                             p.string() +
                                 ": unsupported dims 90 x 90 x 2147483647 (a MERL table has "
                                 "90 x 90 x 180)");
        EXPECT_LT(probe.largest(), std::size_t{1} << 16);
    }
    test::write_file(p, test::merl_header(-90, 90, 180));
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() +
                             ": unsupported dims -90 x 90 x 180 (a MERL table has 90 x 90 x 180)");
    // The reference reader only checks the product; we want the layout itself.
    test::write_file(p, test::merl_header(180, 90, 90));
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() +
                             ": unsupported dims 180 x 90 x 90 (a MERL table has 90 x 90 x 180)");
}

TEST(MerlRead, TruncatedAndOversizedFilesAreRefusedBeforeAllocating) {
    TempDir dir;
    const fs::path p = dir / "short.binary";
    test::write_file(p, test::merl_truncated(34992004));
    const test::AllocationProbe probe;
    EXPECT_THROW(read_merl(p), FormatError);
    EXPECT_LT(probe.largest(), std::size_t{1} << 16);
}

TEST(MerlRead, NanFilledTableNamesTheFirstBadCell) {
    TempDir dir;
    const fs::path p = dir / "nan.binary";
    std::string bytes = test::merl_header(90, 90, 180);
    bytes.resize(34992012, '\0');
    for (std::size_t off = 12; off < bytes.size(); off += 8)
        test::store_f64_le(bytes, off, std::nan(""));
    test::write_file(p, bytes);
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() + ": non-finite value NaN in the red plane at cell theta_h 0, "
                                      "theta_d 0, phi_d 0");
}

TEST(MerlRead, OneInfiniteValueIsNamedByChannelAndCell) {
    TempDir dir;
    const fs::path p = dir / "inf.binary";
    write_merl(p, test::analytic_table());
    std::string bytes = test::read_file(p);
    test::store_f64_le(bytes, test::merl_offset(2, cell_index(7, 8, 9)), -INFINITY);
    test::write_file(p, bytes);
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() +
                             ": non-finite value -inf in the blue plane at cell theta_h 7, "
                             "theta_d 8, phi_d 9");
    // Even in a cell below the horizon: a NaN there is still a broken file.
    write_merl(p, test::analytic_table());
    bytes = test::read_file(p);
    test::store_f64_le(bytes, test::merl_offset(0, cell_index(89, 89, 0)), std::nan(""));
    test::write_file(p, bytes);
    EXPECT_THROW_MESSAGE(read_merl(p), FormatError,
                         p.string() + ": non-finite value NaN in the red plane at cell theta_h 89, "
                                      "theta_d 89, phi_d 0");
}

TEST(MerlRead, DirectoryAndMissingFile) {
    TempDir dir;
    fs::create_directory(dir / "folder.binary");
    EXPECT_THROW_MESSAGE(read_merl(dir / "folder.binary"), IoError,
                         (dir / "folder.binary").string() + ": is a directory, not a table file");
    EXPECT_THROW_MESSAGE(read_merl(dir / "missing.binary"), IoError,
                         (dir / "missing.binary").string() +
                             ": cannot open: No such file or directory");
    EXPECT_THROW_MESSAGE(read_merl("/dev/null"), IoError, "/dev/null: not a regular file");
}

// The small specimens checked in under tests/data/bad (written by make_specimens) give the same
// messages, and still hold the bytes they are documented to hold.
TEST(MerlRead, CheckedInSpecimens) {
    const fs::path bad = test::source_dir() / "tests/data/bad";
    for (const test::MerlSpecimen& s : test::merl_specimens())
        EXPECT_EQ(test::read_file(bad / s.name), s.bytes)
            << s.name << " differs from make_specimens";
    const auto path = [&](const char* name) { return (bad / name).string(); };
    EXPECT_THROW_MESSAGE(read_merl(bad / "merl_empty.binary"), FormatError,
                         path("merl_empty.binary") + ": empty file (34992012 bytes expected)");
    EXPECT_THROW_MESSAGE(read_merl(bad / "merl_truncated.binary"), FormatError,
                         path("merl_truncated.binary") +
                             ": truncated (34992012 bytes expected, 1200 found)");
    EXPECT_THROW_MESSAGE(
        read_merl(bad / "merl_big_endian.binary"), FormatError,
        path("merl_big_endian.binary") +
            ": big-endian header (dims 90 90 180 after byte swapping); MERL tables "
            "are little-endian");
    EXPECT_THROW_MESSAGE(
        read_merl(bad / "merl_huge_dims.binary"), FormatError,
        path("merl_huge_dims.binary") +
            ": unsupported dims 90 x 90 x 2147483647 (a MERL table has 90 x 90 x 180)");
    EXPECT_THROW_MESSAGE(read_merl(bad / "merl_short_header.binary"), FormatError,
                         path("merl_short_header.binary") +
                             ": truncated (34992012 bytes expected, 8 found)");
    EXPECT_THROW_MESSAGE(
        read_merl(bad / "merl_wrong_dims.binary"), FormatError,
        path("merl_wrong_dims.binary") +
            ": unsupported dims 90 x 90 x 360 (a MERL table has 90 x 90 x 180)");
}

// --- the writer: all or nothing
// ---------------------------------------------------------------------

TEST(MerlWrite, ReplacesAnExistingFileAndLeavesNoTemporary) {
    TempDir dir;
    const fs::path p = dir / "a.binary";
    test::write_file(p, "old");
    write_merl(p, test::analytic_table());
    EXPECT_EQ(fs::file_size(p), 34992012u);
    EXPECT_EQ(files_in(dir.path()), std::vector<std::string>{"a.binary"});
}

TEST(MerlWrite, BadTableIsRefusedBeforeTouchingTheFile) {
    TempDir dir;
    const fs::path p = dir / "a.binary";
    test::write_file(p, "old");
    BrdfTable t;
    t.channels[0][cell_index(1, 2, 3)] = std::nan("");
    EXPECT_THROW_MESSAGE(write_merl(p, t), NumericalError,
                         p.string() +
                             ": red value NaN at cell theta_h 1, theta_d 2, phi_d 3 (a BRDF "
                             "must be finite and >= 0, or -1 in all three channels for no data)");
    EXPECT_EQ(test::read_file(p), "old");
    EXPECT_EQ(files_in(dir.path()), std::vector<std::string>{"a.binary"});
}

// The cells are checked block by block as they are converted, on every core: of two bad cells in
// blocks far apart, the first in cell order is named, whichever thread meets a bad block first.
TEST(MerlWrite, OfTwoBadCellsTheFirstIsNamed) {
    TempDir dir;
    const fs::path p = dir / "a.binary";
    BrdfTable t = test::analytic_table();
    t.channels[1][cell_index(80, 40, 10)] = -0.5;
    t.channels[2][cell_index(5, 6, 7)] = std::nan("");
    EXPECT_THROW_MESSAGE(write_merl(p, t), NumericalError,
                         p.string() +
                             ": blue value NaN at cell theta_h 5, theta_d 6, phi_d 7 (a BRDF "
                             "must be finite and >= 0, or -1 in all three channels for no data)");
    EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(MerlWrite, FailedWriteKeepsTheOldFileAndRemovesTheTemporary) {
    TempDir dir;
    const fs::path p = dir / "a.binary";
    test::write_file(p, "old");
    // A file-size limit of 1 MB makes the write fail half way (EFBIG instead of SIGXFSZ).
    std::signal(SIGXFSZ, SIG_IGN);
    rlimit old_limit{};
    ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
    rlimit small = old_limit;
    small.rlim_cur = 1 << 20;
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
    bool threw = false;
    try {
        write_merl(p, test::analytic_table());
    } catch (const IoError& e) {
        threw = true;
        EXPECT_EQ(std::string(e.what()), p.string() + ": write failed: File too large");
    }
    setrlimit(RLIMIT_FSIZE, &old_limit);
    EXPECT_TRUE(threw);
    EXPECT_EQ(test::read_file(p), "old");
    EXPECT_EQ(files_in(dir.path()), std::vector<std::string>{"a.binary"});
}

TEST(MerlWrite, MissingFolderAndFolderInTheWay) {
    TempDir dir;
    const fs::path p = dir / "no-such-folder" / "a.binary";
    try {
        write_merl(p, test::analytic_table());
        FAIL() << "no error";
    } catch (const IoError& e) {
        const std::string m = e.what();
        EXPECT_EQ(m.rfind(p.string() + ": cannot create temporary file " +
                              (dir / "no-such-folder").string() + "/.a.binary.tmp.",
                          0),
                  0u)
            << m;
        EXPECT_NE(m.find(": No such file or directory"), std::string::npos) << m;
    }
    fs::create_directory(dir / "folder.binary");
    try {
        write_merl(dir / "folder.binary", test::analytic_table());
        FAIL() << "no error";
    } catch (const IoError& e) {
        const std::string m = e.what();
        EXPECT_EQ(m.rfind((dir / "folder.binary").string() + ": cannot rename ", 0), 0u) << m;
        EXPECT_NE(m.find(" into place: Is a directory"), std::string::npos) << m;
    }
    EXPECT_EQ(files_in(dir.path()), std::vector<std::string>{"folder.binary"});
}

} // namespace
} // namespace brdf::formats
