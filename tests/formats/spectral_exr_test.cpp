// Spectral OpenEXR tables (formats/exr/spectral_exr): the JCGT 2021 layout for reflective spectra,
// read back by OpenImageIO and OpenEXR's exrheader, round trips, and refusals.

#include <formats/exr/spectral_exr.h>

#include <formats/exr/exr.h>
#include <formats/table_io.h>

#include <brdf/core/error.h>

#include "format_test_util.h"
#include "test_support.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <OpenImageIO/imageio.h>

#include <cmath>

namespace brdf::formats {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

// Three wavelengths of the analytic table, scaled per wavelength.
SpectralTable analytic_spectral(std::vector<double> nm = {450.0, 550.0, 650.0}) {
    SpectralTable t(nm);
    const BrdfTable& rgb = test::analytic_table();
    for (std::size_t j = 0; j < nm.size(); ++j)
        for (std::size_t cell = 0; cell < cells; ++cell)
            if (rgb.has_data(cell))
                t.planes[j][cell] = float(rgb.channels[j % 3][cell] * (1.0 + 0.1 * j));
    t.spec = rgb.spec;
    t.generator = "formats tests";
    return t;
}

TEST(SpectralExr, ChannelNamesFollowThePaper) {
    EXPECT_EQ(spectral_channel_name(550.0), "T.550,000000nm");
    EXPECT_EQ(spectral_channel_name(611.46), "T.611,460000nm");
    EXPECT_EQ(spectral_channel_name(1000.125), "T.1000,125000nm");
    EXPECT_EQ(parse_spectral_channel("T.550,000000nm"), 550.0);
    EXPECT_EQ(parse_spectral_channel("T.550nm"), 550.0);
    EXPECT_DOUBLE_EQ(parse_spectral_channel("T.0,55um"), 550.0);
    EXPECT_DOUBLE_EQ(parse_spectral_channel("T.5,5E+2nm"), 550.0);
    EXPECT_NEAR(parse_spectral_channel("T.545,077196THz"), 550.0, 1e-6); // c / 545.08 THz
    for (const char* not_spectral :
         {"R", "T", "T.nm", "S0.550nm", "T.550", "T.550,0nmx", "T.-5nm", "T.0nm"})
        EXPECT_LT(parse_spectral_channel(not_spectral), 0.0) << not_spectral;
    // A wavelength six decimals cannot hold is written with more.
    const double odd = 550.0 + 1.0 / 3.0;
    EXPECT_EQ(parse_spectral_channel(spectral_channel_name(odd)), odd);
}

TEST(SpectralExr, OpenImageIOSeesTheLayout) {
    TempDir dir;
    const fs::path p = dir / "a.spectral.exr";
    const SpectralTable t = analytic_spectral();
    write_spectral_exr(p, t);
    auto in = OIIO::ImageInput::open(p.string());
    ASSERT_TRUE(in) << OIIO::geterror();
    const OIIO::ImageSpec& spec = in->spec();
    EXPECT_EQ(spec.width, 180);
    EXPECT_EQ(spec.height, 8100);
    EXPECT_EQ(spec.channelnames,
              (std::vector<std::string>{"T.450,000000nm", "T.550,000000nm", "T.650,000000nm"}));
    EXPECT_EQ(spec.format, OIIO::TypeDesc::FLOAT);
    EXPECT_EQ(spec.get_string_attribute("compression"), "zip");
    EXPECT_EQ(spec.get_string_attribute("spectralLayoutVersion"), "1.0");
    EXPECT_EQ(spec.get_string_attribute("brdf.layout"), "merl-halfdiff-90x90x180");
    EXPECT_EQ(spec.get_string_attribute("brdf.units"), "1/sr");
    EXPECT_EQ(spec.get_string_attribute("brdf.generator"), "formats tests");
    std::vector<float> pixels(cells * 3);
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, pixels.data()));
    for (std::size_t cell : {cell_index(0, 0, 0), cell_index(40, 20, 100), cell_index(89, 89, 0)})
        for (int j = 0; j < 3; ++j)
            EXPECT_EQ(pixels[cell * 3 + j], cell_below_horizon(cell) ? 0.0f : t.planes[j][cell])
                << describe_cell(cell) << " plane " << j;
}

TEST(SpectralExr, ExrheaderReadsIt) {
    if (!fs::exists("/usr/bin/exrheader"))
        GTEST_SKIP() << "exrheader (Debian package openexr) not installed";
    TempDir dir;
    write_spectral_exr(dir / "a.spectral.exr", analytic_spectral());
    const test::ProcessResult r =
        test::run_process({"/usr/bin/exrheader", (dir / "a.spectral.exr").string()});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("spectralLayoutVersion (type string): \"1.0\""), std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("T.550,000000nm, 32-bit floating-point"), std::string::npos) << r.out;
}

TEST(SpectralExr, RoundTripIsExactAndRestoresNoData) {
    TempDir dir;
    SpectralTable t = analytic_spectral({380.0, 1000.0, 555.5, 700.0});
    // Not ascending as given: refused. Sorted, it round-trips exactly.
    EXPECT_THROW(write_spectral_exr(dir / "a.exr", t), InputError);
    t = analytic_spectral({380.0, 555.5, 700.0, 1000.0});
    t.planes[2][cell_index(89, 89, 0)] = 7.0f; // below the horizon: not written
    write_spectral_exr(dir / "a.exr", t);
    const SpectralTable r = read_spectral_exr(dir / "a.exr");
    EXPECT_EQ(r.wavelengths_nm, t.wavelengths_nm); // 1000 sorts before 380 in the file
    EXPECT_EQ(r.spec, t.spec);
    EXPECT_EQ(r.generator, t.generator);
    for (std::size_t j = 0; j < 4; ++j)
        for (std::size_t cell = 0; cell < cells; ++cell)
            ASSERT_EQ(r.planes[j][cell],
                      cell_below_horizon(cell) ? SpectralTable::no_data : t.planes[j][cell])
                << describe_cell(cell);
}

TEST(SpectralExr, ToRgbWithWeights) {
    SpectralTable t = analytic_spectral();
    // Weights per wavelength: R = plane 0, G = plane 1 - plane 2 (clamped at 0), B = plane 2.
    const std::vector<Rgb> weights{{1, 0, 0}, {0, 1, 0}, {0, -1, 1}};
    const BrdfTable rgb = spectral_to_rgb(t, weights);
    const std::size_t cell = cell_index(30, 20, 10);
    EXPECT_EQ(rgb.channels[0][cell], double(t.planes[0][cell]));
    EXPECT_EQ(rgb.channels[1][cell],
              std::max(0.0, double(t.planes[1][cell]) - double(t.planes[2][cell])));
    EXPECT_EQ(rgb.channels[2][cell], double(t.planes[2][cell]));
    EXPECT_EQ(rgb.spec, t.spec);
    EXPECT_EQ(rgb.data_cells(), cells - 361784);
    EXPECT_THROW(spectral_to_rgb(t, std::vector<Rgb>(2)), InputError);
}

void write_raw(const fs::path& p, const std::vector<std::string>& channels,
               const std::vector<std::pair<std::string, std::string>>& attributes,
               float value = 0.0f) {
    Imf::Header header(exr_width, exr_height);
    for (const auto& [k, v] : attributes) header.insert(k, Imf::StringAttribute(v));
    std::vector<float> plane(cells, value);
    Imf::FrameBuffer frame;
    for (const std::string& c : channels) {
        header.channels().insert(c, Imf::Channel(Imf::FLOAT));
        frame.insert(c, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(plane.data()), sizeof(float),
                                   sizeof(float) * exr_width));
    }
    Imf::OutputFile out(p.c_str(), header);
    out.setFrameBuffer(frame);
    out.writePixels(exr_height);
}

TEST(SpectralExr, RefusalsNameTheFault) {
    TempDir dir;
    const std::vector<std::pair<std::string, std::string>> ok{{"brdf.layout", exr_layout},
                                                              {"spectralLayoutVersion", "1.0"}};
    const auto message = [&](const std::vector<std::string>& channels,
                             const std::vector<std::pair<std::string, std::string>>& attributes,
                             float value = 0.0f) {
        const fs::path p = dir / "s.exr";
        write_raw(p, channels, attributes, value);
        try {
            read_spectral_exr(p);
        } catch (const FormatError& e) {
            return std::string(e.what()).substr(p.string().size() + 2);
        }
        return std::string("accepted");
    };
    EXPECT_EQ(message({"T.500nm", "R"}, ok), "accepted"); // an RGB preview is ignored
    EXPECT_EQ(message({"R", "G", "B"}, ok),
              "no reflective spectral channel (T.<wavelength>nm, JCGT 2021 spectral layout)");
    EXPECT_EQ(message({"S0.500nm", "T.500nm"}, ok),
              "emissive spectral channel S0.500nm (a radiance image, not a BRDF table; reflective "
              "channels are T.<wavelength>nm)");
    EXPECT_EQ(message({"T.500nm", "T.500,000000nm"}, ok),
              "channels T.500,000000nm and T.500nm are the same wavelength (500 nm)");
    EXPECT_EQ(message({"T.500nm"}, {{"brdf.layout", exr_layout}, {"spectralLayoutVersion", "2.0"}}),
              "spectralLayoutVersion is \"2.0\" (this reader knows \"1.0\")");
    EXPECT_EQ(message({"T.500nm"}, {{"brdf.layout", exr_layout}}), "accepted"); // a warning
    EXPECT_EQ(message({"T.500nm"}, {{"spectralLayoutVersion", "1.0"}}),
              "missing attribute brdf.layout (expected \"merl-halfdiff-90x90x180\")");
    EXPECT_EQ(message({"T.500nm"}, ok, std::nanf("")),
              "non-finite value NaN in channel T.500nm at cell theta_h 0, theta_d 0, phi_d 0");
    EXPECT_EQ(message({"T.500nm"}, ok, -1.0f),
              "negative value -1 in channel T.500nm at cell theta_h 0, theta_d 0, phi_d 0");
}

TEST(SpectralExr, WriterRefusesBadTables) {
    TempDir dir;
    SpectralTable t = analytic_spectral();
    t.planes[1][cell_index(0, 0, 0)] = -0.5f;
    EXPECT_THROW_MESSAGE(write_spectral_exr(dir / "a.exr", t), NumericalError,
                         (dir / "a.exr").string() +
                             ": negative value -0.5 at 550 nm, cell theta_h 0, theta_d 0, phi_d 0");
    t = analytic_spectral();
    t.planes[1][cell_index(0, 0, 0)] = SpectralTable::no_data;
    EXPECT_THROW(write_spectral_exr(dir / "a.exr", t), NumericalError);
    EXPECT_THROW(write_spectral_exr(dir / "a.exr", SpectralTable{}), InputError);
    EXPECT_TRUE(fs::is_empty(dir.path()));
}

// --- Detection by content
// ----------------------------------------------------------------------------

TEST(TableDetection, MagicBytesDecideAndTheExtensionOnlyWarns) {
    TempDir dir;
    write_spectral_exr(dir / "s.exr", analytic_spectral());
    write_exr(dir / "rgb.exr", BrdfTable{});
    write_table(dir / "m.binary", BrdfTable{});
    test::write_file(dir / "f.bsdf", test::fourier_specimen_bytes());
    test::write_file(dir / "t.rgl.bsdf", std::string("tensor_file\0\1\0", 14));
    EXPECT_EQ(detect_format(dir / "s.exr"), TableFormat::SpectralExr);
    EXPECT_EQ(detect_format(dir / "rgb.exr"), TableFormat::Exr);
    EXPECT_EQ(detect_format(dir / "m.binary"), TableFormat::Merl);
    EXPECT_EQ(detect_format(dir / "f.bsdf"), TableFormat::Fourier);
    EXPECT_EQ(detect_format(dir / "t.rgl.bsdf"), TableFormat::RglTensor);
    // Misnamed: content wins.
    fs::copy_file(dir / "m.binary", dir / "m.exr");
    fs::copy_file(dir / "f.bsdf", dir / "f.binary");
    fs::copy_file(dir / "rgb.exr", dir / "rgb.dat");
    EXPECT_EQ(detect_format(dir / "m.exr"), TableFormat::Merl);
    EXPECT_EQ(detect_format(dir / "f.binary"), TableFormat::Fourier);
    EXPECT_EQ(detect_format(dir / "rgb.dat"), TableFormat::Exr);
    EXPECT_EQ(read_table(dir / "m.exr").data_cells(), cells - 361784);
    // Unrecognised content: the extension's reader names the fault, an unknown one is refused.
    test::write_file(dir / "short.binary", test::merl_truncated(1200));
    EXPECT_EQ(detect_format(dir / "short.binary"), TableFormat::Merl);
    EXPECT_THROW_MESSAGE(read_table(dir / "short.binary"), FormatError,
                         (dir / "short.binary").string() +
                             ": truncated (34992012 bytes expected, 1200 found)");
    test::write_file(dir / "x.txt", "");
    EXPECT_THROW(detect_format(dir / "x.txt"), InputError);
    EXPECT_THROW(detect_format(dir / "missing.binary"), IoError);
    // Spectral needs colour weights; an RGL file is read (this one is only its magic: a format fault).
    EXPECT_THROW(read_table(dir / "s.exr"), InputError);
    const BrdfTable via = read_table(dir / "s.exr", [](const SpectralTable& s) {
        return spectral_to_rgb(s, std::vector<Rgb>{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
    });
    EXPECT_EQ(via.generator, "formats tests");
    EXPECT_THROW(read_table(dir / "t.rgl.bsdf"), FormatError);
    // A Fourier BSDF reads as its table at the cell centres.
    EXPECT_EQ(read_table(dir / "f.bsdf").generator, "formats tests");
    // Writing goes by extension, RGB formats only.
    EXPECT_THROW(write_table(dir / "o.bsdf", BrdfTable{}), InputError);
    EXPECT_THROW(write_table(dir / "o.spectral.exr", BrdfTable{}), InputError);
    EXPECT_FALSE(fs::exists(dir / "o.bsdf"));
}

} // namespace
} // namespace brdf::formats
