// The tensor_file container: round trips, the byte layout Mitsuba's tensor_io writes, and one clear
// line for every malformed file (truncated, wrong magic or version, counts and offsets out of range,
// huge shapes that must not be allocated).

#include "format_test_util.h"
#include "rgl_test_files.h"
#include "test_support.h"

#include <formats/rgl/tensor_file.h>

#include <brdf/core/error.h>

#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <filesystem>

namespace brdf::formats {
namespace {

using test::le64;
using test::RawField;
using test::raw_tensor_header;
using test::TempDir;

TensorFile sample_file() {
    TensorFile f;
    f.fields.push_back(
        TensorField::float32("floats", {2, 3}, {0.5f, -1.0f, 2.0f, 3.5f, 1e-30f, 7.0f}));
    f.fields.push_back(TensorField::uint8("text", {5}, {'h', 'e', 'l', 'l', 'o'}));
    f.fields.push_back(TensorField::uint8("empty", {0}, {}));
    TensorField scalar;
    scalar.name = "scalar64";
    scalar.dtype = TensorDType::Float64;
    const auto bits = std::bit_cast<std::uint64_t>(3.141592653589793);
    for (int b = 0; b < 8; ++b) scalar.bytes.push_back(static_cast<unsigned char>(bits >> (8 * b)));
    f.fields.push_back(scalar);
    return f;
}

TEST(TensorFile, RoundTripKeepsNamesOrderShapesAndBytes) {
    const TempDir dir;
    const TensorFile written = sample_file();
    write_tensor_file(dir / "a.tensor", written);
    const TensorFile read = read_tensor_file(dir / "a.tensor");
    ASSERT_EQ(read.fields.size(), written.fields.size());
    for (std::size_t k = 0; k < read.fields.size(); ++k) {
        EXPECT_EQ(read.fields[k].name, written.fields[k].name);
        EXPECT_EQ(read.fields[k].dtype, written.fields[k].dtype);
        EXPECT_EQ(read.fields[k].shape, written.fields[k].shape);
        EXPECT_EQ(read.fields[k].bytes, written.fields[k].bytes);
    }
    EXPECT_EQ(read.find("scalar64")->element_count(), 1u);
    EXPECT_EQ(read.find("floats")->to_float32(),
              (std::vector<float>{0.5f, -1.0f, 2.0f, 3.5f, 1e-30f, 7.0f}));
    EXPECT_EQ(read.find("nope"), nullptr);
    write_tensor_file(dir / "b.tensor", read);
    EXPECT_EQ(test::read_file(dir / "a.tensor"), test::read_file(dir / "b.tensor"));
}

// The layout of Mitsuba's tensor_io.write: magic, version 1 0, uint32 count, per field uint16 name
// length, name, uint16 rank, uint8 dtype, uint64 offset, shape; data 8-byte aligned in field order.
TEST(TensorFile, ByteLayoutIsTheOneTensorIoWrites) {
    const TempDir dir;
    TensorFile f;
    f.fields.push_back(TensorField::float32("ab", {3}, {1.0f, 2.0f, 3.0f}));
    f.fields.push_back(TensorField::uint8("c", {1}, {9}));
    write_tensor_file(dir / "x.tensor", f);
    const std::string bytes = test::read_file(dir / "x.tensor");
    // Preamble 18 bytes; header of ab 2 + 2 + 2 + 1 + 8 + 8 = 23 (to 41); of c 22 (to 63). Data
    // of ab at 64 (aligned) to 76, of c at 80: 81 bytes.
    const std::string expected_header =
        raw_tensor_header({{"ab", 10, 64, {3}}, {"c", 1, 80, {1}}});
    ASSERT_EQ(bytes.size(), 81u);
    EXPECT_EQ(bytes.substr(0, 63), expected_header);
    EXPECT_EQ(bytes.substr(63, 1), std::string(1, '\0')); // padding is zero
    float v[3];
    std::memcpy(v, bytes.data() + 64, 12);
    EXPECT_EQ(v[2], 3.0f);
    EXPECT_EQ(bytes[80], 9);
    EXPECT_TRUE(has_tensor_file_magic(bytes));
    EXPECT_TRUE(has_tensor_file_magic(bytes.substr(0, 12)));
    EXPECT_FALSE(has_tensor_file_magic(bytes.substr(0, 11)));
    EXPECT_FALSE(has_tensor_file_magic("tensor_filX\0 and more"));
}

// A file written by Mitsuba's tensor_io.write can lay its fields out in any order with gaps; the
// reader only needs them inside the file, after the header, and disjoint.
TEST(TensorFile, ReadsFieldsInAnyOrderWithGaps) {
    const TempDir dir;
    std::string bytes = raw_tensor_header({{"late", 1, 200, {2}}, {"early", 1, 100, {3}}});
    bytes.resize(202, '\0');
    bytes[100] = 'x';
    bytes[201] = 'z';
    test::write_file(dir / "g.tensor", bytes);
    const TensorFile f = read_tensor_file(dir / "g.tensor");
    ASSERT_EQ(f.fields.size(), 2u);
    EXPECT_EQ(f.fields[0].name, "late");
    EXPECT_EQ(f.fields[0].bytes, (std::vector<unsigned char>{0, 'z'}));
    EXPECT_EQ(f.fields[1].bytes, (std::vector<unsigned char>{'x', 0, 0}));
}

class TensorFileFault : public ::testing::Test {
  protected:
    std::filesystem::path write(const std::string& bytes) {
        const auto p = m_dir / "bad.rgl.bsdf";
        test::write_file(p, bytes);
        return p;
    }
    std::string expect_format_error(const std::string& bytes, const std::string& fault) {
        const auto p = write(bytes);
        EXPECT_THROW_MESSAGE(read_tensor_file(p), FormatError, p.string() + ": " + fault);
        return p.string();
    }
    TempDir m_dir;
};

TEST_F(TensorFileFault, EmptyFile) {
    expect_format_error("", "empty file (not a tensor file)");
}

TEST_F(TensorFileFault, ShortFileThatStartsRight) {
    expect_format_error(std::string("tensor_fil", 10),
                        "truncated (the tensor file preamble needs 18 bytes, 10 found)");
}

TEST_F(TensorFileFault, ShortFileThatStartsWrong) {
    expect_format_error("hello", "not a tensor file (no \"tensor_file\" magic)");
}

TEST_F(TensorFileFault, WrongMagic) {
    std::string bytes = raw_tensor_header({});
    bytes[0] = 'T';
    expect_format_error(bytes, "not a tensor file (no \"tensor_file\" magic)");
}

TEST_F(TensorFileFault, WrongMajorVersion) {
    expect_format_error(raw_tensor_header({}, 2, 0),
                        "unsupported tensor file version 2.0 (1.0 expected)");
}

// Mitsuba 3.9 tests the minor byte twice; both bytes count here.
TEST_F(TensorFileFault, WrongMinorVersion) {
    expect_format_error(raw_tensor_header({}, 1, 1),
                        "unsupported tensor file version 1.1 (1.0 expected)");
}

TEST_F(TensorFileFault, FieldCountBeyondTheFile) {
    std::string bytes = raw_tensor_header({});
    bytes.replace(14, 4, test::le32(4000000000u));
    bytes += std::string(26, '\0');
    expect_format_error(bytes, "truncated: 4000000000 fields announced, but the 26 bytes after the "
                               "preamble hold at most 2 field headers");
}

TEST_F(TensorFileFault, TruncatedFieldHeader) {
    // Two headers announced; the second one's shape runs past the end.
    std::string bytes = raw_tensor_header({{"a", 1, 0, {}}, {"vndf", 10, 0, {4, 4, 4}}});
    bytes.resize(bytes.size() - 5);
    expect_format_error(bytes, "truncated in the header of field 2 of 2 ('vndf') (24 more bytes "
                               "needed at byte 49, the file has 68)");
}

TEST_F(TensorFileFault, UnknownDtype) {
    std::string bytes = raw_tensor_header({{"ndf", 12, 0, {}}});
    expect_format_error(bytes, "field 'ndf': unknown dtype 12 (1..11: uint8 .. float64)");
    bytes = raw_tensor_header({{"ndf", 0, 0, {}}});
    expect_format_error(bytes, "field 'ndf': unknown dtype 0 (1..11: uint8 .. float64)");
}

TEST_F(TensorFileFault, DuplicateName) {
    expect_format_error(raw_tensor_header({{"a", 1, 0, {0}}, {"a", 1, 0, {0}}}),
                        "field 'a': the name appears twice");
}

TEST_F(TensorFileFault, HugeShapeIsRefusedBeforeAllocating) {
    const test::AllocationProbe probe;
    // 2^62 float32 elements would be 2^64 bytes (overflow); 2^40 elements are merely too large.
    expect_format_error(raw_tensor_header({{"spectra", 10, 64, {std::uint64_t{1} << 31,
                                                                  std::uint64_t{1} << 31}}}),
                        "field 'spectra': shape [2147483648, 2147483648] of float32 needs more "
                        "bytes than the file holds (54)");
    expect_format_error(raw_tensor_header({{"spectra", 10, 64, {std::uint64_t{1} << 40}}}),
                        "field 'spectra': shape [1099511627776] of float32 needs more bytes than "
                        "the file holds (46)");
    expect_format_error(
        raw_tensor_header({{"x", 11, 0, {~std::uint64_t{0}, ~std::uint64_t{0}, 3}}}),
        "field 'x': shape [18446744073709551615, 18446744073709551615, 3] of float64 needs more "
        "bytes than the file holds (56)");
    EXPECT_LT(probe.largest(), std::size_t{1} << 16);
}

TEST_F(TensorFileFault, DataPastTheEnd) {
    std::string bytes = raw_tensor_header({{"ndf", 10, 40, {4}}});
    bytes.resize(50, '\0');
    expect_format_error(bytes, "field 'ndf': data [40, 56) lies past the end of the file (50 bytes)");
    bytes = raw_tensor_header({{"ndf", 10, ~std::uint64_t{0} - 2, {1}}});
    expect_format_error(bytes, "field 'ndf': data [18446744073709551613, ...) lies past the end of "
                               "the file (42 bytes)");
}

TEST_F(TensorFileFault, DataInsideTheHeader) {
    std::string bytes = raw_tensor_header({{"ndf", 10, 8, {2}}});
    bytes.resize(64, '\0');
    expect_format_error(bytes, "field 'ndf': data at offset 8 overlaps the header (which ends at "
                               "byte 42)");
}

TEST_F(TensorFileFault, OverlappingFields) {
    // Two fields reading the same bytes would let a small file claim much data.
    std::string bytes = raw_tensor_header({{"a", 10, 64, {4}}, {"b", 10, 72, {4}}});
    bytes.resize(96, '\0');
    expect_format_error(bytes, "fields 'a' and 'b' overlap (data [64, 80) and [72, 88))");
}

TEST_F(TensorFileFault, DataAboveTheLimitIsALimitError) {
    std::string bytes = raw_tensor_header({{"a", 1, 64, {100}}});
    bytes.resize(164, '\0');
    const auto p = write(bytes);
    TensorFileLimits limits;
    limits.max_data_bytes = 99;
    EXPECT_THROW_MESSAGE(read_tensor_file(p, limits), LimitError,
                         p.string() + ": the fields hold 100 bytes of data, above the limit of 99 "
                                      "bytes");
    limits.max_data_bytes = 100;
    EXPECT_EQ(read_tensor_file(p, limits).fields.at(0).bytes.size(), 100u);
}

TEST_F(TensorFileFault, MissingFileAndFolderAreIoErrors) {
    EXPECT_THROW(read_tensor_file(m_dir / "missing.rgl.bsdf"), IoError);
    EXPECT_THROW_MESSAGE(read_tensor_file(m_dir.path()), IoError,
                         m_dir.path().string() + ": is a directory, not a table file");
}

TEST(TensorFileWrite, RefusesWhatTheFormatCannotHoldBeforeCreatingAFile) {
    const TempDir dir;
    const auto p = dir / "w.tensor";
    TensorFile f;
    f.fields.push_back(TensorField::uint8("a", {1}, {1}));
    f.fields.push_back(TensorField::uint8("a", {1}, {2}));
    EXPECT_THROW_MESSAGE(write_tensor_file(p, f), InputError,
                         p.string() + ": tensor field 'a': name used twice");
    f.fields.pop_back();
    f.fields[0].bytes.push_back(3);
    EXPECT_THROW_MESSAGE(write_tensor_file(p, f), InputError,
                         p.string() + ": tensor field 'a': 2 bytes do not match shape [1] of uint8");
    f.fields[0] = TensorField::uint8("", {0}, {});
    EXPECT_THROW_MESSAGE(write_tensor_file(p, f), InputError,
                         p.string() + ": a tensor field has an empty name");
    EXPECT_FALSE(std::filesystem::exists(p));
    EXPECT_TRUE(std::filesystem::is_empty(dir.path())); // no temporary file left behind
    EXPECT_THROW_MESSAGE(TensorField::float32("v", {2, 2}, {1.0f}), InputError,
                         "tensor field 'v': shape [2, 2] does not hold 1 values");
}

TEST(TensorFileWrite, FailureLeavesNoFile) {
    const TempDir dir;
    const auto p = dir / "no-such-folder" / "w.tensor";
    EXPECT_THROW(write_tensor_file(p, sample_file()), IoError);
    EXPECT_FALSE(std::filesystem::exists(p));
}

} // namespace
} // namespace brdf::formats
