#include <formats/exr/exr.h>
#include <formats/merl/merl.h>

#include <brdf/core/error.h>

#include "format_test_util.h"
#include "test_support.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <OpenImageIO/imageio.h>
#include <half.h>

#include <cmath>
#include <csignal>
#include <cstring>
#include <sys/resource.h>

namespace brdf::formats {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

float as_float(double v) {
    return static_cast<float>(v);
}

// The next value of a xorshift32 sequence (Marsaglia 2003): reproducible test values.
std::uint32_t xorshift32(std::uint32_t& state) {
    state ^= state << 13;
    state ^= state >> 17;
    state ^= state << 5;
    return state;
}

// Other tools must read our files: OpenImageIO reports the layout of docs/design.md.
TEST(ExrFormat, OpenImageIOSeesTheDocumentedLayoutAndAttributes) {
    TempDir dir;
    const fs::path p = dir / "a.exr";
    write_exr(p, test::analytic_table());
    auto in = OIIO::ImageInput::open(p.string());
    ASSERT_TRUE(in) << OIIO::geterror();
    const OIIO::ImageSpec& spec = in->spec();
    EXPECT_EQ(std::string(in->format_name()), "openexr");
    EXPECT_EQ(spec.width, 180);
    EXPECT_EQ(spec.height, 8100);
    EXPECT_EQ(spec.x, 0);
    EXPECT_EQ(spec.y, 0);
    EXPECT_EQ(spec.nchannels, 3);
    EXPECT_EQ(spec.channelnames, (std::vector<std::string>{"R", "G", "B"}));
    EXPECT_EQ(spec.format, OIIO::TypeDesc::FLOAT);
    EXPECT_EQ(spec.tile_width, 0); // scanlines
    EXPECT_EQ(spec.get_string_attribute("compression"), "zip");
    EXPECT_EQ(spec.get_string_attribute("brdf.layout"), "merl-halfdiff-90x90x180");
    EXPECT_EQ(spec.get_string_attribute("brdf.units"), "1/sr");
    EXPECT_EQ(spec.get_string_attribute("brdf.colorspace"), "rec709");
    // OpenEXR's standard chromaticities: Rec.709 primaries, D65.
    const OIIO::ParamValue* chroma = spec.find_attribute("chromaticities");
    ASSERT_TRUE(chroma);
    ASSERT_EQ(chroma->type().size(), 8 * sizeof(float));
    const float* xy = static_cast<const float*>(chroma->data());
    const float rec709[8] = {0.64f, 0.33f, 0.30f, 0.60f, 0.15f, 0.06f, 0.3127f, 0.3290f};
    for (int k = 0; k < 8; ++k) EXPECT_EQ(xy[k], rec709[k]) << k;
    EXPECT_EQ(spec.get_string_attribute("brdf.spec"), test::analytic_table().spec);
    EXPECT_EQ(spec.get_string_attribute("brdf.generator"), "formats tests");
    EXPECT_FALSE(in->seek_subimage(1, 0)); // one part
}

TEST(ExrFormat, PixelsAreTheCellsInMerlOrderWithZeroBelowTheHorizon) {
    TempDir dir;
    const fs::path p = dir / "a.exr";
    BrdfTable t = test::analytic_table();
    // Data below the horizon is not written; a no-data cell above it is written as 0.
    t.set(cell_index(89, 89, 0), {5, 5, 5});
    const std::size_t hole = cell_index(30, 30, 30);
    t.set_no_data(hole);
    write_exr(p, t);
    auto in = OIIO::ImageInput::open(p.string());
    ASSERT_TRUE(in);
    std::vector<float> pixels(std::size_t{180} * 8100 * 3);
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, pixels.data()));
    for (int y = 0; y < 8100; ++y)
        for (int x = 0; x < 180; ++x) {
            const std::size_t cell = std::size_t(y) * 180 + x;
            const CellIndices c = cell_indices(cell);
            ASSERT_EQ(y, 90 * c.theta_h + c.theta_d);
            ASSERT_EQ(x, c.phi_d);
            for (int ch = 0; ch < 3; ++ch) {
                const float expected = cell_below_horizon(cell) || cell == hole
                                           ? 0.0f
                                           : as_float(t.channels[ch][cell]);
                ASSERT_EQ(pixels[cell * 3 + ch], expected) << describe_cell(cell);
            }
        }
}

TEST(ExrFormat, RoundTripRoundsToFloatAndRestoresNoDataFromGeometry) {
    TempDir dir;
    const fs::path p = dir / "a.exr";
    BrdfTable t = test::analytic_table();
    t.colorspace = "ACEScg";
    const std::size_t hole = cell_index(30, 30, 30);
    t.set_no_data(hole);
    write_exr(p, t);
    const BrdfTable back = read_exr(p);
    EXPECT_EQ(back.spec, t.spec);
    EXPECT_EQ(back.generator, t.generator);
    EXPECT_EQ(back.colorspace, "ACEScg");
    for (std::size_t cell = 0; cell < cells; ++cell) {
        ASSERT_EQ(back.has_data(cell), !cell_below_horizon(cell));
        if (cell_below_horizon(cell)) {
            ASSERT_EQ(back.at(cell), (Rgb{-1, -1, -1}));
            continue;
        }
        for (int c = 0; c < 3; ++c)
            ASSERT_EQ(back.channels[c][cell],
                      cell == hole ? 0.0 : double(as_float(t.channels[c][cell])));
    }
}

// `convert` must not change any valid value beyond float32 rounding.
TEST(ExrFormat, MerlToExrToMerlChangesValuesOnlyByFloatRounding) {
    TempDir dir;
    write_merl(dir / "a.binary", test::analytic_table());
    const BrdfTable merl = read_merl(dir / "a.binary");
    write_exr(dir / "a.exr", merl);
    const BrdfTable exr = read_exr(dir / "a.exr");
    write_merl(dir / "b.binary", exr);
    const BrdfTable again = read_merl(dir / "b.binary");
    for (std::size_t cell = 0; cell < cells; ++cell) {
        ASSERT_EQ(again.has_data(cell), merl.has_data(cell));
        if (!merl.has_data(cell)) continue;
        for (int c = 0; c < 3; ++c) {
            // EXR holds float(value) exactly; MERL stores it to within one double ulp.
            ASSERT_EQ(exr.channels[c][cell], double(as_float(merl.channels[c][cell])));
            ASSERT_NEAR(again.channels[c][cell], merl.channels[c][cell],
                        std::ldexp(std::abs(merl.channels[c][cell]), -24) * 1.0001);
        }
    }
    // EXR -> MERL -> EXR is exact: float values survive the double round trip.
    write_exr(dir / "b.exr", again);
    const BrdfTable exr2 = read_exr(dir / "b.exr");
    for (int c = 0; c < 3; ++c)
        for (std::size_t cell = 0; cell < cells; ++cell)
            if (exr.has_data(cell)) {
                ASSERT_EQ(as_float(exr2.channels[c][cell]), as_float(exr.channels[c][cell]));
            }
}

TEST(ExrFormat, OpenExrsOwnToolReadsTheFile) {
    if (!fs::exists("/usr/bin/exrheader"))
        GTEST_SKIP() << "exrheader (Debian package openexr) not installed";
    TempDir dir;
    write_exr(dir / "a.exr", test::analytic_table());
    const test::ProcessResult r =
        test::run_process({"/usr/bin/exrheader", (dir / "a.exr").string()});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("zip"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("brdf.layout (type string): \"merl-halfdiff-90x90x180\""),
              std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("(0 0) - (179 8099)"), std::string::npos) << r.out;
}

// Each colour space gets OpenEXR's standard chromaticities attribute (read back with OpenEXR's own
// API, not ours) and keeps brdf.colorspace; files of the old default string read as rec709.
TEST(ExrFormat, ChromaticitiesFollowTheColourSpace) {
    TempDir dir;
    struct Case {
        const char* colorspace;
        std::array<float, 8> xy;
    };
    const Case cases[] = {
        {"rec709", {0.64f, 0.33f, 0.30f, 0.60f, 0.15f, 0.06f, 0.3127f, 0.3290f}},
        {"acescg", {0.713f, 0.293f, 0.165f, 0.830f, 0.128f, 0.044f, 0.32168f, 0.33767f}},
        {"rec2020", {0.708f, 0.292f, 0.170f, 0.797f, 0.131f, 0.046f, 0.3127f, 0.3290f}},
    };
    BrdfTable t; // zeros: small and fast
    for (const Case& c : cases) {
        t.colorspace = c.colorspace;
        const fs::path p = dir / (std::string(c.colorspace) + ".exr");
        write_exr(p, t);
        Imf::InputFile file(p.c_str());
        ASSERT_TRUE(Imf::hasChromaticities(file.header())) << c.colorspace;
        const Imf::Chromaticities& got = Imf::chromaticities(file.header());
        const float xy[8] = {got.red.x,  got.red.y,  got.green.x, got.green.y,
                             got.blue.x, got.blue.y, got.white.x, got.white.y};
        for (int k = 0; k < 8; ++k) EXPECT_EQ(xy[k], c.xy[k]) << c.colorspace << " " << k;
        EXPECT_EQ(read_exr(p).colorspace, c.colorspace);
    }
    // The old default string: read as rec709, written as rec709 with its chromaticities.
    test::ExrSpecimen old;
    old.value = 0.0f;
    old.attributes.push_back({"brdf.colorspace", "linear Rec.709 (sRGB primaries), D65"});
    test::write_exr_specimen(dir / "old.exr", old);
    EXPECT_EQ(read_exr(dir / "old.exr").colorspace, "rec709");
    t.colorspace = legacy_rec709_colorspace;
    write_exr(dir / "legacy.exr", t);
    EXPECT_EQ(read_exr(dir / "legacy.exr").colorspace, "rec709");
    // No brdf.colorspace but standard chromaticities of one of ours (another tool's file).
    {
        Imf::Header header(exr_width, exr_height);
        header.channels().insert("R", Imf::Channel(Imf::FLOAT));
        header.channels().insert("G", Imf::Channel(Imf::FLOAT));
        header.channels().insert("B", Imf::Channel(Imf::FLOAT));
        header.insert("brdf.layout", Imf::StringAttribute(exr_layout));
        Imf::addChromaticities(header, Imf::Chromaticities({0.708f, 0.292f}, {0.170f, 0.797f},
                                                           {0.131f, 0.046f}, {0.3127f, 0.3290f}));
        std::vector<float> zero(cells, 0.0f);
        Imf::FrameBuffer frame;
        for (const char* ch : {"R", "G", "B"})
            frame.insert(ch, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(zero.data()),
                                        sizeof(float), sizeof(float) * exr_width));
        Imf::OutputFile out((dir / "other.exr").c_str(), header);
        out.setFrameBuffer(frame);
        out.writePixels(exr_height);
    }
    EXPECT_EQ(read_exr(dir / "other.exr").colorspace, "rec2020");
    // An unknown colour space is kept, without chromaticities.
    t.colorspace = "my-space";
    write_exr(dir / "mine.exr", t);
    EXPECT_FALSE(Imf::hasChromaticities(Imf::InputFile((dir / "mine.exr").c_str()).header()));
    EXPECT_EQ(read_exr(dir / "mine.exr").colorspace, "my-space");
}

// Half-float channels from another tool are accepted (converted by OpenEXR), attributes other than
// brdf.layout are optional.
TEST(ExrRead, HalfChannelsAndMinimalAttributesAreAccepted) {
    TempDir dir;
    const fs::path p = dir / "half.exr";
    test::ExrSpecimen s;
    s.half = true;
    s.attributes = {{"brdf.layout", "merl-halfdiff-90x90x180"}};
    s.value = 0.3f;
    test::write_exr_specimen(p, s);
    const BrdfTable t = read_exr(p);
    EXPECT_EQ(t.colorspace, default_colorspace);
    EXPECT_EQ(t.spec, "");
    EXPECT_EQ(t.channels[1][cell_index(0, 0, 0)], double(float(half(0.3f))));
    EXPECT_EQ(t.data_cells(), cells - 361784);
}

// Other tools' variations that still hold a table: tiles instead of scanlines, an extra channel.
TEST(ExrRead, TiledFileWithAnExtraChannelIsAccepted) {
    TempDir dir;
    write_exr(dir / "a.exr", test::analytic_table());
    auto in = OIIO::ImageInput::open((dir / "a.exr").string());
    ASSERT_TRUE(in);
    OIIO::ImageSpec spec = in->spec();
    std::vector<float> rgb(std::size_t{180} * 8100 * 3);
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, rgb.data()));
    in->close();
    std::vector<float> rgba(std::size_t{180} * 8100 * 4, 1.0f);
    for (std::size_t p = 0; p < cells; ++p)
        for (int c = 0; c < 3; ++c) rgba[p * 4 + c] = rgb[p * 3 + c];
    spec.nchannels = 4;
    spec.channelnames.push_back("A");
    spec.alpha_channel = 3;
    spec.tile_width = spec.tile_height = 64;
    auto out = OIIO::ImageOutput::create("exr");
    ASSERT_TRUE(out);
    ASSERT_TRUE(out->open((dir / "tiled.exr").string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, rgba.data()));
    out->close();
    auto check = OIIO::ImageInput::open((dir / "tiled.exr").string());
    ASSERT_TRUE(check);
    ASSERT_EQ(check->spec().tile_width, 64);
    check->close();
    const BrdfTable t = read_exr(dir / "tiled.exr");
    const BrdfTable ours = read_exr(dir / "a.exr");
    for (int c = 0; c < 3; ++c) EXPECT_EQ(t.channels[c], ours.channels[c]);
}

TEST(ExrRead, WrongSize) {
    TempDir dir;
    const fs::path p = dir / "small.exr";
    test::ExrSpecimen s;
    s.height = 100;
    test::write_exr_specimen(p, s);
    EXPECT_THROW_MESSAGE(read_exr(p), FormatError,
                         p.string() + ": wrong size 180 x 100 (a BRDF table is 180 x 8100)");
    s.height = 8100;
    s.width = 360;
    test::write_exr_specimen(p, s);
    EXPECT_THROW_MESSAGE(read_exr(p), FormatError,
                         p.string() + ": wrong size 360 x 8100 (a BRDF table is 180 x 8100)");
}

TEST(ExrRead, MissingChannel) {
    TempDir dir;
    const fs::path p = dir / "rb.exr";
    test::ExrSpecimen s;
    s.channels = {"R", "B"};
    test::write_exr_specimen(p, s);
    EXPECT_THROW_MESSAGE(read_exr(p), FormatError, p.string() + ": missing channel G (found B, R)");
    s.channels = {"Y"};
    test::write_exr_specimen(p, s);
    EXPECT_THROW_MESSAGE(read_exr(p), FormatError, p.string() + ": missing channel R (found Y)");
}

TEST(ExrRead, LayoutAndUnitsAttributes) {
    TempDir dir;
    const fs::path p = dir / "attr.exr";
    test::ExrSpecimen s;
    s.height = 100; // the attribute is checked first: it says what the file is meant to be
    s.attributes = {};
    test::write_exr_specimen(p, s);
    EXPECT_THROW_MESSAGE(
        read_exr(p), FormatError,
        p.string() + ": missing attribute brdf.layout (expected \"merl-halfdiff-90x90x180\")");
    s.attributes = {{"brdf.layout", "merl-halfdiff-90x90x360"}};
    test::write_exr_specimen(p, s);
    EXPECT_THROW_MESSAGE(read_exr(p), FormatError,
                         p.string() +
                             ": attribute brdf.layout is \"merl-halfdiff-90x90x360\" (expected "
                             "\"merl-halfdiff-90x90x180\")");
    s.height = 8100;
    s.attributes = {{"brdf.layout", "merl-halfdiff-90x90x180"}, {"brdf.units", "W/(m2 sr)"}};
    test::write_exr_specimen(p, s);
    EXPECT_THROW_MESSAGE(read_exr(p), FormatError,
                         p.string() +
                             ": attribute brdf.units is \"W/(m2 sr)\" (expected \"1/sr\")");
}

TEST(ExrRead, NonFiniteOrNegativeValueInACellAboveTheHorizon) {
    TempDir dir;
    const fs::path p = dir / "nan.exr";
    test::ExrSpecimen s;
    s.value = std::nanf("");
    test::write_exr_specimen(p, s);
    EXPECT_THROW_MESSAGE(
        read_exr(p), FormatError,
        p.string() + ": non-finite value NaN in channel R at cell theta_h 0, theta_d 0, phi_d 0");
    s.value = -0.5f;
    test::write_exr_specimen(p, s);
    EXPECT_THROW_MESSAGE(
        read_exr(p), FormatError,
        p.string() + ": negative value -0.5 in channel R at cell theta_h 0, theta_d 0, phi_d 0");
}

TEST(ExrRead, ValuesBelowTheHorizonAreIgnored) {
    // Another tool may store anything there (MERL's -1, NaN): the cells hold no data either way.
    TempDir dir;
    const fs::path p = dir / "a.exr";
    write_exr(p, test::analytic_table());
    auto in = OIIO::ImageInput::open(p.string());
    ASSERT_TRUE(in);
    OIIO::ImageSpec spec = in->spec();
    std::vector<float> pixels(std::size_t{180} * 8100 * 3);
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, pixels.data()));
    in->close();
    for (std::size_t cell = 0; cell < cells; ++cell)
        if (cell_below_horizon(cell)) pixels[cell * 3] = cell % 2 ? -1.0f : std::nanf("");
    auto out = OIIO::ImageOutput::create(p.string());
    ASSERT_TRUE(out);
    ASSERT_TRUE(out->open((dir / "b.exr").string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()));
    out->close();
    const BrdfTable back = read_exr(dir / "b.exr");
    EXPECT_EQ(back.data_cells(), cells - 361784);
    EXPECT_EQ(back.spec, test::analytic_table().spec); // OpenImageIO kept our attributes
}

TEST(ExrRead, NotAnExrEmptyTruncatedDirectoryMissing) {
    TempDir dir;
    const fs::path text = dir / "text.exr";
    test::write_file(text, "this is not an image\n");
    EXPECT_THROW_MESSAGE(read_exr(text), FormatError, text.string() + ": not an OpenEXR file");
    const fs::path empty = dir / "empty.exr";
    test::write_file(empty, "");
    EXPECT_THROW_MESSAGE(read_exr(empty), FormatError, empty.string() + ": empty file");

    const fs::path cut = dir / "cut.exr";
    write_exr(dir / "whole.exr", test::analytic_table());
    const std::string whole = test::read_file(dir / "whole.exr");
    for (std::size_t keep :
         {std::size_t{20}, std::size_t{400}, whole.size() / 2, whole.size() - 10}) {
        test::write_file(cut, whole.substr(0, keep));
        try {
            read_exr(cut);
            ADD_FAILURE() << "a file cut to " << keep << " bytes was read";
        } catch (const FormatError& e) {
            const std::string m = e.what();
            EXPECT_EQ(m.rfind(cut.string() + ": ", 0), 0u) << m;
        }
    }
    fs::create_directory(dir / "folder.exr");
    EXPECT_THROW_MESSAGE(read_exr(dir / "folder.exr"), IoError,
                         (dir / "folder.exr").string() + ": is a directory, not a table file");
    EXPECT_THROW_MESSAGE(read_exr(dir / "missing.exr"), IoError,
                         (dir / "missing.exr").string() +
                             ": cannot open: No such file or directory");
}

// A header that claims a billion scanlines must not make anyone allocate for them.
TEST(ExrRead, HugeDataWindowIsRefusedWithoutAHugeAllocation) {
    TempDir dir;
    write_exr(dir / "a.exr", test::analytic_table());
    std::string bytes = test::read_file(dir / "a.exr");
    for (const std::string name : {"dataWindow", "displayWindow"}) {
        const std::string key = name + std::string("\0box2i\0", 7);
        const std::size_t at = bytes.find(key);
        ASSERT_NE(at, std::string::npos);
        const std::int32_t max_y = 1000000000; // box2i: size int32, then xmin ymin xmax ymax
        std::memcpy(&bytes[at + key.size() + 4 + 12], &max_y, 4);
    }
    const fs::path p = dir / "bomb.exr";
    test::write_file(p, bytes);
    const test::AllocationProbe probe;
    EXPECT_THROW_MESSAGE(read_exr(p), FormatError,
                         p.string() + ": wrong size 180 x 1000000001 (a BRDF table is 180 x 8100)");
    EXPECT_LT(probe.largest(), std::size_t{64} << 20);
}

// An attribute that claims 2 GiB in a 1 MB file: OpenEXR 3.1's C++ API would allocate it; the Core
// header check in front of it refuses the file first.
TEST(ExrRead, HugeAttributeIsRefusedWithoutAHugeAllocation) {
    TempDir dir;
    write_exr(dir / "a.exr", test::analytic_table());
    std::string bytes = test::read_file(dir / "a.exr");
    std::string attribute("zz\0blob\0", 8);
    const std::int32_t size = 0x7ffffff0;
    attribute.append(reinterpret_cast<const char*>(&size), 4);
    attribute += "abc";
    bytes.insert(8, attribute); // right after the magic number and version
    const fs::path p = dir / "bomb.exr";
    test::write_file(p, bytes);
    const test::AllocationProbe probe;
    try {
        read_exr(p);
        ADD_FAILURE() << "read";
    } catch (const FormatError& e) {
        const std::string m = e.what();
        EXPECT_EQ(m.rfind(p.string() + ": OpenEXR: ", 0), 0u) << m;
        EXPECT_NE(m.find("Invalid size 2147483632"), std::string::npos) << m;
    }
    EXPECT_LT(probe.largest(), std::size_t{64} << 20);
}

TEST(ExrRead, CheckedInSpecimens) {
    const fs::path bad = test::source_dir() / "tests/data/bad";
    EXPECT_THROW_MESSAGE(read_exr(bad / "exr_missing_channel.exr"), FormatError,
                         (bad / "exr_missing_channel.exr").string() +
                             ": missing channel G (found B, R)");
    EXPECT_THROW_MESSAGE(read_exr(bad / "exr_wrong_size.exr"), FormatError,
                         (bad / "exr_wrong_size.exr").string() +
                             ": wrong size 180 x 100 (a BRDF table is 180 x 8100)");
    EXPECT_THROW_MESSAGE(read_exr(bad / "exr_nan.exr"), FormatError,
                         (bad / "exr_nan.exr").string() +
                             ": non-finite value NaN in channel R at cell theta_h 0, theta_d 0, "
                             "phi_d 0");
    EXPECT_THROW_MESSAGE(read_exr(bad / "exr_wrong_endian.exr"), FormatError,
                         (bad / "exr_wrong_endian.exr").string() + ": not an OpenEXR file");
    const std::string truncated = (bad / "exr_truncated.exr").string();
    EXPECT_THROW_MESSAGE(read_exr(bad / "exr_truncated.exr"), FormatError,
                         truncated + ": OpenEXR: Error reading pixel data from image file \"" +
                             truncated +
                             "\". unexpected end of file (4 bytes wanted at offset 18179, 0 "
                             "there)");
}

// The writer compresses OpenEXR's ZIP blocks itself (formats/exr/zip_writer.h); a block that does
// not shrink is stored as it is, as OpenEXR stores it. Values of random bits (every exponent, every
// mantissa) in the first half of the rows defeat the compressor, smooth values in the second half
// do not: OpenEXR's own reader (OpenImageIO) must read both kinds, exactly, and the file must be
// larger than a table of smooth values alone.
TEST(ExrWrite, BlocksThatDoNotShrinkAreStoredAsTheyAre) {
    TempDir dir;
    BrdfTable t = test::analytic_table();
    std::uint32_t state = 12345;
    for (std::size_t cell = 0; cell < cells / 2; ++cell) {
        if (cell_below_horizon(cell)) continue;
        for (int c = 0; c < 3; ++c) {
            const std::uint32_t bits = xorshift32(state) & 0x7f7fffffu; // positive, finite
            float v;
            std::memcpy(&v, &bits, sizeof v);
            t.channels[c][cell] = v;
        }
    }
    write_exr(dir / "noise.exr", t);
    write_exr(dir / "smooth.exr", test::analytic_table());
    EXPECT_GT(fs::file_size(dir / "noise.exr"), fs::file_size(dir / "smooth.exr") + cells / 2 * 3 * 3);
    auto in = OIIO::ImageInput::open((dir / "noise.exr").string());
    ASSERT_TRUE(in) << OIIO::geterror();
    std::vector<float> pixels(std::size_t{180} * 8100 * 3);
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, pixels.data()));
    for (std::size_t cell = 0; cell < cells; ++cell)
        for (int c = 0; c < 3; ++c)
            ASSERT_EQ(pixels[cell * 3 + c], cell_below_horizon(cell) ? 0.0f : as_float(t.channels[c][cell]))
                << describe_cell(cell);
    const BrdfTable back = read_exr(dir / "noise.exr");
    for (std::size_t cell = 0; cell < cells; ++cell)
        for (int c = 0; c < 3; ++c)
            if (!cell_below_horizon(cell)) {
                ASSERT_EQ(back.channels[c][cell], double(as_float(t.channels[c][cell])));
            }
}

// Every core compresses blocks as it claims them (formats/exr/zip_writer.cpp), so which thread
// compresses a block, and what it compressed before, changes from run to run: the file must not
// (docs/formats.md says why ISA-L's igzip is not used). Tables of smooth and of random values
// written in turn leave each thread's compressor in another state every time; each table comes
// back as the same bytes.
TEST(ExrWrite, TheSameTableIsWrittenAsTheSameBytesEveryTime) {
    TempDir dir;
    const BrdfTable smooth = test::analytic_table();
    BrdfTable noise = smooth;
    std::uint32_t state = 777;
    for (std::size_t cell = 0; cell < cells; cell += 3)
        for (int c = 0; c < 3; ++c)
            noise.channels[c][cell] = static_cast<double>(xorshift32(state) % 1000003u) * 1e-6;
    write_exr(dir / "smooth.exr", smooth);
    write_exr(dir / "noise.exr", noise);
    const std::string first_smooth = test::read_file(dir / "smooth.exr");
    const std::string first_noise = test::read_file(dir / "noise.exr");
    for (int round = 0; round < 4; ++round) {
        write_exr(dir / "smooth.exr", smooth);
        ASSERT_TRUE(test::read_file(dir / "smooth.exr") == first_smooth) << "round " << round;
        write_exr(dir / "noise.exr", noise);
        ASSERT_TRUE(test::read_file(dir / "noise.exr") == first_noise) << "round " << round;
    }
}

// A grey table (one plane standing for three, a grey medium's fill) is written as the same bytes,
// MERL and OpenEXR, as the table of three equal planes, and read back as that table.
TEST(TableWrite, AGreyTableIsWrittenAsItsThreeEqualPlanes) {
    TempDir dir;
    BrdfTable grey(BrdfTable::Unwritten{}, true);
    grey.channels[0] = test::analytic_table().channels[0];
    grey.channels[0][cell_index(20, 30, 40)] = BrdfTable::no_data; // a no-data cell above the horizon
    BrdfTable full = grey;
    full.make_full();
    ASSERT_TRUE(grey.grey);
    ASSERT_FALSE(full.grey);
    write_merl(dir / "grey.binary", grey);
    write_merl(dir / "full.binary", full);
    EXPECT_TRUE(test::read_file(dir / "grey.binary") == test::read_file(dir / "full.binary"));
    write_exr(dir / "grey.exr", grey);
    write_exr(dir / "full.exr", full);
    EXPECT_TRUE(test::read_file(dir / "grey.exr") == test::read_file(dir / "full.exr"));
    const BrdfTable back = read_merl(dir / "grey.binary");
    EXPECT_FALSE(back.grey);
    EXPECT_FALSE(back.has_data(cell_index(20, 30, 40)));
    for (int c = 0; c < 3; ++c) EXPECT_EQ(back.channels[c].size(), cells);
}

TEST(ExrWrite, BadTableIsRefusedAndNothingIsLeftBehind) {
    TempDir dir;
    BrdfTable t;
    t.channels[2][cell_index(0, 0, 1)] = INFINITY;
    EXPECT_THROW_MESSAGE(write_exr(dir / "a.exr", t), NumericalError,
                         (dir / "a.exr").string() +
                             ": blue value inf at cell theta_h 0, theta_d 0, phi_d 1 "
                             "(a BRDF must be finite and >= 0, or -1 in all three "
                             "channels for no data)");
    EXPECT_TRUE(fs::is_empty(dir.path()));
    write_exr(dir / "a.exr", test::analytic_table());
    EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
}

// Checked block by block as they are compressed: of two bad cells far apart, the first is named.
TEST(ExrWrite, OfTwoBadCellsTheFirstIsNamed) {
    TempDir dir;
    BrdfTable t = test::analytic_table();
    t.channels[0][cell_index(85, 3, 170)] = INFINITY;
    t.channels[1][cell_index(9, 60, 2)] = -2.0;
    EXPECT_THROW_MESSAGE(write_exr(dir / "a.exr", t), NumericalError,
                         (dir / "a.exr").string() +
                             ": green value -2 at cell theta_h 9, theta_d 60, phi_d 2 "
                             "(a BRDF must be finite and >= 0, or -1 in all three "
                             "channels for no data)");
    EXPECT_TRUE(fs::is_empty(dir.path()));
}

// An I/O error inside OpenEXR's writer comes out as our IoError, and nothing is left behind.
TEST(ExrWrite, FailedWriteKeepsTheOldFileAndRemovesTheTemporary) {
    TempDir dir;
    const fs::path p = dir / "a.exr";
    test::write_file(p, "old");
    std::signal(SIGXFSZ, SIG_IGN);
    rlimit old_limit{};
    ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
    rlimit small = old_limit;
    small.rlim_cur = 16 << 10; // the analytic table compresses to far more than 16 kB
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
    bool threw = false;
    try {
        write_exr(p, test::analytic_table());
    } catch (const IoError& e) {
        threw = true;
        EXPECT_EQ(std::string(e.what()), p.string() + ": write failed: File too large");
    }
    setrlimit(RLIMIT_FSIZE, &old_limit);
    EXPECT_TRUE(threw);
    EXPECT_EQ(test::read_file(p), "old");
    EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
}

} // namespace
} // namespace brdf::formats
