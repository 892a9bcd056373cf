// End-to-end checks of `brdftool convert`, `info` and `diff` on real table files: synthetic tables
// are made with formats' own API (tabulate, write_table), the real brdftool is run on them, and its
// output files, text, JSON and exit statuses are checked. Each table file is 35 MB, so the tests
// are few and each writes into its own TempDir (removed afterwards).

#include <formats/halfdiff.h>
#include <formats/table.h>
#include <formats/table_io.h>

#include <nlohmann/json.hpp>

#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iterator>
#include <string>
#include <vector>

namespace brdf::test {
namespace {

namespace fs = std::filesystem;
using formats::BrdfTable;
using formats::CellCentre;
using formats::Rgb;

constexpr double pi = formats::pi;
constexpr std::size_t below_horizon_cells = 361784; // formats/halfdiff.h
constexpr std::size_t data_cells = formats::cells - below_horizon_cells;

/// A smooth, colourful, everywhere-positive function of the bin-centre angles (1/sr), with values
/// whose float32 rounding is visible (no short binary fractions), all far above diff's floor.
BrdfTable analytic_table() {
    return formats::tabulate([](const CellCentre& c) {
        const double h = c.angles.theta_h, d = c.angles.theta_d, p = c.angles.phi_d;
        const double base = (0.3 + 0.2 * std::cos(h) * std::cos(h)) / pi;
        return Rgb{base * (1.0 + 0.1 * std::sin(3.0 * p)), base * (0.7 + 0.05 * std::cos(d)),
                   base * (0.4 + 0.3 * std::exp(-h))};
    });
}

/// White-ish Lambertian: f = rho / pi with albedo rho per channel.
BrdfTable lambertian_table(const Rgb& rho) {
    return formats::tabulate([&](const CellCentre&) {
        return Rgb{rho[0] / pi, rho[1] / pi, rho[2] / pi};
    });
}

/// The first 1,200 bytes of a MERL file: a valid header (dims 90 90 180, little-endian), then
/// zeros.
std::string truncated_merl() {
    std::string bytes(1200, '\0');
    const unsigned char header[12] = {90, 0, 0, 0, 90, 0, 0, 0, 180, 0, 0, 0};
    std::copy(std::begin(header), std::end(header), bytes.begin());
    return bytes;
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

nlohmann::json parse_json(const ProcessResult& r) {
    EXPECT_EQ(r.status, 0) << r.err;
    return nlohmann::json::parse(r.out);
}

double to_degrees(double radians) {
    return radians * 180.0 / pi;
}

// MERL -> EXR -> MERL keeps every valid value up to float32 rounding (docs/design.md, "OpenEXR table"):
// the result is the float32 rounding of the original, give or take one double ulp from the MERL
// scale (stored = BRDF / scale), and no cell gains or loses data.
TEST(TableTools, ConvertMerlExrMerlRoundTripKeepsValuesToFloat32) {
    TempDir dir;
    const BrdfTable original = analytic_table();
    formats::write_table(dir / "a.binary", original);

    const ProcessResult to_exr =
        run_tool("brdftool", {"--log-level", "info", "convert", (dir / "a.binary").string(),
                              (dir / "b.exr").string()});
    ASSERT_EQ(to_exr.status, 0) << to_exr.err;
    EXPECT_TRUE(to_exr.out.empty()) << to_exr.out;
    EXPECT_TRUE(contains(to_exr.err, "no provenance")) << to_exr.err;
    const ProcessResult back =
        run_tool("brdftool", {"convert", (dir / "b.exr").string(), (dir / "c.binary").string()});
    ASSERT_EQ(back.status, 0) << back.err;

    const BrdfTable a = formats::read_table(dir / "a.binary");
    const BrdfTable c = formats::read_table(dir / "c.binary");
    std::size_t checked = 0, bad = 0;
    for (std::size_t cell = 0; cell < formats::cells; ++cell) {
        ASSERT_EQ(a.has_data(cell), c.has_data(cell)) << formats::describe_cell(cell);
        if (!a.has_data(cell)) continue;
        for (int ch = 0; ch < 3; ++ch) {
            const double va = a.channels[ch][cell], vc = c.channels[ch][cell];
            const double rounded = static_cast<float>(va);
            // float32 rounding: at most half an ulp of float, 2^-24 relative.
            if (std::abs(vc - va) > 0x1p-24 * va || std::abs(vc - rounded) > 0x1p-51 * rounded) {
                if (++bad <= 5)
                    ADD_FAILURE() << formats::describe_cell(cell) << " channel " << ch
                                  << ": original " << va << ", after MERL -> EXR -> MERL " << vc;
            }
            ++checked;
        }
    }
    EXPECT_EQ(bad, 0u);
    EXPECT_EQ(checked, 3 * data_cells);
}

// EXR -> EXR keeps brdf.spec, brdf.generator and brdf.colorspace exactly (values too); EXR -> MERL
// says on an info line that the attributes are not kept.
TEST(TableTools, ConvertKeepsExrProvenance) {
    TempDir dir;
    BrdfTable t = analytic_table();
    t.spec = "{\"name\": \"test paint\",\n \"note\": \"quotes \\\" and newlines\"}";
    t.generator = "table_tools_test 1.0";
    t.colorspace = "ACEScg";
    formats::write_table(dir / "p.exr", t);

    const ProcessResult same_format =
        run_tool("brdftool", {"convert", (dir / "p.exr").string(), (dir / "q.EXR").string()});
    ASSERT_EQ(same_format.status, 0) << same_format.err;
    const BrdfTable p = formats::read_table(dir / "p.exr");
    const BrdfTable q = formats::read_table(dir / "q.EXR");
    EXPECT_EQ(q.spec, t.spec);
    EXPECT_EQ(q.generator, t.generator);
    EXPECT_EQ(q.colorspace, t.colorspace);
    EXPECT_EQ(q.channels, p.channels);

    const ProcessResult to_merl =
        run_tool("brdftool", {"--log-level", "info", "convert", (dir / "p.exr").string(),
                              (dir / "r.binary").string()});
    ASSERT_EQ(to_merl.status, 0) << to_merl.err;
    EXPECT_TRUE(contains(to_merl.err, "brdf.spec and brdf.generator")) << to_merl.err;
    EXPECT_TRUE(contains(to_merl.err, "ACEScg")) << to_merl.err; // the colour-space warning
    EXPECT_TRUE(fs::exists(dir / "r.binary"));
}

// Refusals come before the input is read, name the file, and leave nothing behind.
TEST(TableTools, ConvertRefusesSameFileUnknownExtensionAndBadInput) {
    TempDir dir;
    formats::write_table(dir / "a.binary", lambertian_table({0.5, 0.5, 0.5}));
    const std::string a = (dir / "a.binary").string();

    const ProcessResult same =
        run_tool("brdftool", {"convert", a, (dir.path() / "." / "a.binary").string()});
    EXPECT_EQ(same.status, 3) << same.err;
    EXPECT_TRUE(contains(same.err, "a.binary")) << same.err;
    EXPECT_TRUE(contains(same.err, "the output is the input file")) << same.err;
    EXPECT_EQ(fs::file_size(dir / "a.binary"), 34992012u);

    const ProcessResult png = run_tool("brdftool", {"convert", a, (dir / "a.png").string()});
    EXPECT_EQ(png.status, 3) << png.err;
    EXPECT_TRUE(contains(png.err, "a.png: unsupported table format '.png'")) << png.err;
    EXPECT_FALSE(fs::exists(dir / "a.png"));

    const ProcessResult missing = run_tool(
        "brdftool", {"convert", (dir / "missing.exr").string(), (dir / "out.binary").string()});
    EXPECT_EQ(missing.status, 7) << missing.err;
    EXPECT_TRUE(contains(missing.err, "missing.exr: cannot open")) << missing.err;

    write_file(dir / "short.binary", truncated_merl());
    const ProcessResult truncated = run_tool(
        "brdftool", {"convert", (dir / "short.binary").string(), (dir / "out.exr").string()});
    EXPECT_EQ(truncated.status, 4) << truncated.err;
    EXPECT_TRUE(contains(truncated.err, "short.binary: truncated (34992012 bytes expected, 1200 "
                                        "found)"))
        << truncated.err;
    EXPECT_EQ(std::count(truncated.err.begin(), truncated.err.end(), '\n'), 1) << truncated.err;

    // Nothing but the two inputs is left in the folder (no output, no temporary file).
    std::size_t entries = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir.path())) ++entries;
    EXPECT_EQ(entries, 2u);
}

TEST(TableTools, InfoReportsLayoutProvenanceStatisticsAndAlbedo) {
    TempDir dir;
    const Rgb rho{0.8, 0.5, 0.2};
    BrdfTable t = lambertian_table(rho);
    t.spec = R"({"name": "grey"})";
    t.generator = "table_tools_test 1.0";
    formats::write_table(dir / "lambert.exr", t);
    formats::write_table(dir / "lambert.binary", t);

    const ProcessResult text = run_tool("brdftool", {"info", (dir / "lambert.exr").string()});
    ASSERT_EQ(text.status, 0) << text.err;
    for (const char* part : {"lambert.exr", "OpenEXR", "merl-halfdiff-90x90x180", "1458000 cells",
                             "table_tools_test 1.0", R"({"name": "grey"})", "1096216 with data",
                             "361784 below the horizon", "directional albedo", "80 deg"})
        EXPECT_TRUE(contains(text.out, part)) << "missing '" << part << "' in\n" << text.out;

    const nlohmann::json exr =
        parse_json(run_tool("brdftool", {"info", (dir / "lambert.exr").string(), "--json"}));
    EXPECT_EQ(exr["format"], "OpenEXR");
    EXPECT_EQ(exr["file_size_bytes"].get<std::uintmax_t>(), fs::file_size(dir / "lambert.exr"));
    EXPECT_EQ(exr["layout"], "merl-halfdiff-90x90x180");
    EXPECT_EQ(exr["dims"]["phi_d"], 180);
    EXPECT_EQ(exr["provenance"]["brdf.generator"], "table_tools_test 1.0");
    EXPECT_EQ(exr["provenance"]["brdf.spec"], t.spec);
    EXPECT_EQ(exr["data_cells"].get<std::size_t>(), data_cells);
    EXPECT_EQ(exr["below_horizon_cells"].get<std::size_t>(), below_horizon_cells);
    EXPECT_EQ(exr["no_data_above_horizon_cells"].get<std::size_t>(), 0u);
    int c = 0;
    for (const char* name : {"red", "green", "blue"}) {
        // The .exr holds float32: 2^-24 relative.
        EXPECT_REL_NEAR(exr["channels"][name]["min"].get<double>(), rho[c] / pi, 1e-7);
        EXPECT_REL_NEAR(exr["channels"][name]["max"].get<double>(), rho[c] / pi, 1e-7);
        EXPECT_REL_NEAR(exr["channels"][name]["mean"].get<double>(), rho[c] / pi, 1e-7);
        ++c;
    }
    ASSERT_EQ(exr["directional_albedo"].size(), 4u);
    for (const nlohmann::json& row : exr["directional_albedo"])
        for (int ch = 0; ch < 3; ++ch) // the quadrature loses < 4e-5 up to 85 degrees (table.h)
            EXPECT_REL_NEAR(row["rgb"][ch].get<double>(), rho[ch], 1e-4) << row.dump();
    EXPECT_EQ(exr["directional_albedo"][3]["theta_i_deg"], 80.0);

    const nlohmann::json merl =
        parse_json(run_tool("brdftool", {"info", (dir / "lambert.binary").string(), "--json"}));
    EXPECT_EQ(merl["format"], "MERL .binary");
    EXPECT_EQ(merl["file_size_bytes"].get<std::uintmax_t>(), 34992012u);
    EXPECT_TRUE(merl["provenance"].empty()) << merl["provenance"].dump();
    // A sum of a million equal doubles: rounding of order 1e-10 relative.
    EXPECT_REL_NEAR(merl["channels"]["green"]["mean"].get<double>(), 0.5 / pi, 1e-9);
}

TEST(TableTools, DiffReportsRelativeDifferenceAndWhereItPeaks) {
    TempDir dir;
    const BrdfTable a = analytic_table();
    formats::write_table(dir / "a.binary", a);
    BrdfTable scaled = a, one_cell = a;
    for (std::size_t cell = 0; cell < formats::cells; ++cell)
        if (a.has_data(cell))
            for (int ch = 0; ch < 3; ++ch) scaled.channels[ch][cell] *= 1.01;
    formats::write_table(dir / "scaled.binary", scaled);
    const std::size_t peak = formats::cell_index(10, 20, 30);
    ASSERT_TRUE(a.has_data(peak));
    one_cell.channels[0][peak] *= 1.05;
    formats::write_table(dir / "one_cell.exr", one_cell);
    const std::string pa = (dir / "a.binary").string();

    const nlohmann::json same = parse_json(run_tool("brdftool", {"diff", pa, pa, "--json"}));
    EXPECT_EQ(same["compared_cells"].get<std::size_t>(), data_cells);
    for (const char* name : {"red", "green", "blue"}) {
        EXPECT_EQ(same["channels"][name]["max"].get<double>(), 0.0);
        EXPECT_EQ(same["channels"][name]["rms"].get<double>(), 0.0);
        EXPECT_TRUE(same["channels"][name]["max_at"].is_null()); // no difference, no "where"
    }

    const nlohmann::json s =
        parse_json(run_tool("brdftool", {"diff", (dir / "scaled.binary").string(), pa, "--json"}));
    for (const char* name : {"red", "green", "blue"})
        for (const char* stat : {"max", "mean", "rms"}) // MERL round trip: one double ulp
            EXPECT_REL_NEAR(s["channels"][name][stat].get<double>(), 0.01, 1e-9)
                << name << ' ' << stat;

    // A .exr against a .binary: float32 rounding everywhere (< 6e-8), 5% in one red cell.
    const ProcessResult text = run_tool("brdftool", {"diff", (dir / "one_cell.exr").string(), pa});
    ASSERT_EQ(text.status, 0) << text.err;
    EXPECT_TRUE(contains(text.out, "theta_h, theta_d, phi_d")) << text.out;
    const nlohmann::json o =
        parse_json(run_tool("brdftool", {"diff", (dir / "one_cell.exr").string(), pa, "--json"}));
    const nlohmann::json& red = o["channels"]["red"];
    EXPECT_REL_NEAR(red["max"].get<double>(), 0.05, 1e-6);
    EXPECT_EQ(red["max_at"]["cell"].get<std::size_t>(), peak);
    EXPECT_REL_NEAR(red["max_at"]["theta_h_deg"].get<double>(),
                    to_degrees(formats::theta_h_centre(10)), 1e-12);
    EXPECT_REL_NEAR(red["max_at"]["theta_d_deg"].get<double>(), 20.5, 1e-12); // (20 + 0.5) * 1 deg
    EXPECT_REL_NEAR(red["max_at"]["phi_d_deg"].get<double>(), 30.5, 1e-12);   // (30 + 0.5) * 1 deg
    EXPECT_LT(o["channels"]["green"]["max"].get<double>(), 6e-8);

    // The floor: far above every value, the difference is measured in units of the floor.
    const nlohmann::json f = parse_json(run_tool(
        "brdftool", {"diff", (dir / "scaled.binary").string(), pa, "--floor", "100", "--json"}));
    EXPECT_EQ(f["floor"].get<double>(), 100.0);
    EXPECT_LT(f["channels"]["red"]["max"].get<double>(), 1e-4);
    for (const char* bad : {"0", "-1", "abc"}) {
        const ProcessResult r = run_tool("brdftool", {"diff", pa, pa, "--floor", bad});
        EXPECT_EQ(r.status, 3) << bad << ": " << r.err;
        EXPECT_TRUE(contains(r.err, "--floor")) << r.err;
    }
}

// Bad operands: the documented exit statuses (3 input, 4 malformed table, 7 file I/O) and one line
// on stderr naming the file.
TEST(TableTools, BadOperandsGiveDocumentedStatusAndNameTheFile) {
    TempDir dir;
    write_file(dir / "short.binary", truncated_merl());
    write_file(dir / "text.exr", "this is not an OpenEXR file\n");
    write_file(dir / "paint.json", R"({"name": "paint"})");
    write_file(dir / "table.txt", "");
    fs::create_directory(dir / "folder.exr");
    struct Case {
        std::vector<std::string> args;
        int status;
        std::string message;
    };
    const auto p = [&](const char* name) { return (dir / name).string(); };
    const std::vector<Case> cases{
        {{"info", p("short.binary")}, 4, "short.binary: truncated"},
        {{"info", p("text.exr")}, 4, "text.exr: "},
        {{"info", p("table.txt")}, 3, "table.txt: unsupported table format '.txt'"},
        {{"info", p("missing.binary")}, 7, "missing.binary: cannot open"},
        {{"info", p("folder.exr")}, 7, "folder.exr: is a directory"},
        {{"diff", p("short.binary"), p("short.binary")}, 4, "short.binary: truncated"},
        {{"diff", p("paint.json"), p("short.binary"), "--device", "cpu"}, 3, "paint.json: "},
        {{"diff", p("missing.exr"), p("short.binary")}, 7, "missing.exr: cannot open"},
        {{"convert", p("text.exr"), p("out.binary")}, 4, "text.exr: "},
    };
    for (const Case& c : cases) {
        const ProcessResult r = run_tool("brdftool", c.args);
        EXPECT_EQ(r.status, c.status) << c.args[0] << ' ' << c.args[1] << ": " << r.err;
        EXPECT_TRUE(contains(r.err, c.message)) << "expected '" << c.message << "' in " << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
        EXPECT_TRUE(r.out.empty()) << r.out;
    }
    EXPECT_FALSE(fs::exists(dir / "out.binary"));
}

TEST(TableTools, DiffOfATableAgainstItsSpecIsZero) {
    TempDir dir;
    write_file(dir / "spec.json", R"({"name": "m", "medium": {"albedo": 0.7, "phase": "rayleigh"},
                                      "accuracy": "draft", "outputs": ["merl"]})");
    const ProcessResult c = run_tool("brdftool", {"compute", (dir / "spec.json").string(), "-o",
                                                  (dir / "out").string(), "--device", "cpu"});
    ASSERT_EQ(c.status, 0) << c.err;
    const ProcessResult d = run_tool("brdftool", {"diff", (dir / "out/m.binary").string(),
                                                  (dir / "spec.json").string(), "--device", "cpu", "--json"});
    ASSERT_EQ(d.status, 0) << d.err;
    const auto j = nlohmann::json::parse(d.out);
    for (const auto& ch : j["channels"]) EXPECT_LT(ch["max"].get<double>(), 1e-12) << d.out;
}

// A table against a catalogue: the material is the one the table records (EXR: its brdf.spec;
// MERL: the report beside it), and a name that is not there lists those that are.
TEST(TableTools, DiffOfATableAgainstACataloguePicksTheRecordedMaterial) {
    TempDir dir;
    write_file(dir / "cat.json", R"({"defaults": {"accuracy": "draft", "spectrum": "rgb"}, "materials": [
        {"name": "m1", "medium": {"albedo": 0.7, "phase": "rayleigh"}, "outputs": ["exr"]},
        {"name": "m2", "medium": {"albedo": 0.4}, "outputs": ["merl"]}]})");
    const ProcessResult c = run_tool("brdftool", {"compute", (dir / "cat.json").string(), "-o",
                                                  (dir / "out").string(), "--device", "cpu"});
    ASSERT_EQ(c.status, 0) << c.err;
    for (const char* table : {"out/m1.exr", "out/m2.binary"}) {
        const ProcessResult d = run_tool("brdftool", {"diff", (dir / table).string(), (dir / "cat.json").string(),
                                                      "--device", "cpu", "--json"});
        ASSERT_EQ(d.status, 0) << table << ": " << d.err;
        const nlohmann::json result = nlohmann::json::parse(d.out);
        for (const auto& ch : result["channels"])
            EXPECT_LT(ch["max"].get<double>(), 1e-12) << table << ": " << d.out;
    }
    // A MERL table with no report beside it records nothing: --material is needed, and says so.
    fs::copy_file(dir / "out/m2.binary", dir / "bare.binary");
    const ProcessResult bare = run_tool("brdftool", {"diff", (dir / "bare.binary").string(),
                                                     (dir / "cat.json").string(), "--device", "cpu"});
    EXPECT_EQ(bare.status, 3) << bare.err;
    EXPECT_TRUE(contains(bare.err, "holds 2 materials (m1, m2); choose one with --material NAME")) << bare.err;
    const ProcessResult wrong = run_tool("brdftool", {"diff", (dir / "bare.binary").string(), (dir / "cat.json").string(),
                                                      "--device", "cpu", "--material", "m3"});
    EXPECT_EQ(wrong.status, 3) << wrong.err;
    EXPECT_TRUE(contains(wrong.err, "no material named 'm3'; it holds m1, m2")) << wrong.err;
    EXPECT_EQ(std::count(wrong.err.begin(), wrong.err.end(), '\n'), 1) << wrong.err;
}

TEST(TableTools, HelpDescribesTheCommands) {
    for (const char* cmd : {"convert", "info", "diff"}) {
        const ProcessResult r = run_tool("brdftool", {"help", cmd});
        EXPECT_EQ(r.status, 0) << cmd;
        EXPECT_TRUE(contains(r.out, cmd)) << r.out;
    }
    const ProcessResult usage = run_tool("brdftool", {"convert", "only-one.binary"});
    EXPECT_EQ(usage.status, 2) << usage.err;
}

} // namespace
} // namespace brdf::test
