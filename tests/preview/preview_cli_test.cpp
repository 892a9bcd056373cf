// brdftool render and lobes as a user runs them (--device cpu: the C++ reference solver).

#include "preview_test_support.h"
#include "test_support.h"

namespace brdf::test {
namespace {

const char* orange_spec = R"({"name": "orange", "medium": {"albedo": [0.9, 0.6, 0.3], "phase": "isotropic"},
                              "surface": "none", "accuracy": "draft"})";
const char* forward_spec = R"({"name": "forward", "medium": {"albedo": 0.9,
                               "phase": {"type": "henyey_greenstein", "g": 0.9}}, "surface": "none", "accuracy": "draft"})";

TEST(RenderCli, WritesPngAndExrOfTheRequestedSize) {
    TempDir dir;
    write_file(dir / "orange.json", orange_spec);
    const ProcessResult png = run_tool("brdftool", {"render", (dir / "orange.json").string(), "-o",
                                                    (dir / "orange.png").string(), "--size", "72", "--device", "cpu",
                                                    "--environment", "sky"});
    ASSERT_EQ(png.status, 0) << png.err;
    const ReadImage a = read_image(dir / "orange.png");
    EXPECT_EQ(a.width, 72);
    EXPECT_EQ(a.height, 72);
    EXPECT_EQ(a.channels, 3);
    EXPECT_EQ(a.format, OIIO::TypeDesc::UINT8);
    const ProcessResult exr = run_tool("brdftool", {"render", (dir / "orange.json").string(), "-o",
                                                    (dir / "orange.exr").string(), "--size", "40", "--device", "cpu"});
    ASSERT_EQ(exr.status, 0) << exr.err;
    const ReadImage b = read_image(dir / "orange.exr");
    EXPECT_EQ(b.width, 40);
    EXPECT_EQ(b.format, OIIO::TypeDesc::FLOAT);
}

TEST(RenderCli, LightFromTheLeftMakesTheLeftThirdBrighter) {
    TempDir dir;
    write_file(dir / "orange.json", orange_spec);
    const ProcessResult r = run_tool("brdftool", {"render", (dir / "orange.json").string(), "-o",
                                                  (dir / "left.png").string(), "--size", "90", "--device", "cpu",
                                                  "--light-theta", "90", "--light-phi", "180"});
    ASSERT_EQ(r.status, 0) << r.err;
    const ReadImage image = read_image(dir / "left.png");
    const double left = column_mean(image, 0, 30), right = column_mean(image, 60, 90);
    EXPECT_GT(left, right + 0.1) << "left third " << left << ", right third " << right;
}

TEST(RenderCli, BadOutputExtensionIsInputError) {
    TempDir dir;
    write_file(dir / "orange.json", orange_spec);
    const ProcessResult r = run_tool("brdftool", {"render", (dir / "orange.json").string(), "-o",
                                                  (dir / "orange.jpg").string(), "--device", "cpu"});
    EXPECT_EQ(r.status, 3) << r.err;
    EXPECT_NE(r.err.find(".jpg"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "orange.jpg"));
    const ProcessResult l = run_tool("brdftool", {"lobes", (dir / "orange.json").string(), "-o",
                                                  (dir / "lobes.tiff").string(), "--device", "cpu"});
    EXPECT_EQ(l.status, 3) << l.err;
}

TEST(RenderCli, HelpNamesTheFlags) {
    const ProcessResult r = run_tool("brdftool", {"help", "render"});
    EXPECT_EQ(r.status, 0);
    for (const char* flag : {"--size", "--light-theta", "--light-phi", "--light-size", "--environment", "--exposure",
                             "--material", "--device"})
        EXPECT_NE(r.out.find(flag), std::string::npos) << flag << " missing from\n" << r.out;
    const ProcessResult l = run_tool("brdftool", {"lobes", "--help"});
    EXPECT_EQ(l.status, 0);
    for (const char* flag : {"--theta-i", "--log", "-o"}) EXPECT_NE(l.out.find(flag), std::string::npos) << flag;
}

TEST(LobesCli, OverlaysSeveralInputs) {
    TempDir dir;
    write_file(dir / "orange.json", orange_spec);
    write_file(dir / "forward.json", forward_spec);
    const ProcessResult r = run_tool("brdftool", {"lobes", (dir / "orange.json").string(),
                                                  (dir / "forward.json").string(), "-o", (dir / "lobes.png").string(),
                                                  "--theta-i", "30,60", "--log", "--device", "cpu", "--width", "640"});
    ASSERT_EQ(r.status, 0) << r.err;
    const ReadImage image = read_image(dir / "lobes.png");
    EXPECT_EQ(image.width, 640);
    EXPECT_GT(image.height, 300);
    const ProcessResult bad = run_tool("brdftool", {"lobes", (dir / "orange.json").string(), "-o",
                                                    (dir / "x.png").string(), "--theta-i", "95", "--device", "cpu"});
    EXPECT_EQ(bad.status, 3) << bad.err;
}

} // namespace
} // namespace brdf::test
