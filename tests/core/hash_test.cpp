// The one hash (FNV-1a 64): published test vectors, and the spec hashes it produces pinned, because
// reports on disk carry them (a rerun skips a material whose report has the same spec hash: a changed
// hash would recompute every catalogue, a colliding one would skip a changed material).

#include <brdf/core/hash.h>
#include <brdf/material/spec.h>
#include <test_support.h>

#include <map>
#include <string>

namespace brdf::test {
namespace {

// Test vectors of the FNV reference (Fowler, Noll, Vo; draft-eastlake-fnv, "FNV-1a 64").
TEST(Hash, Fnv1a64MatchesPublishedVectors) {
    EXPECT_EQ(fnv1a64(""), 0xcbf29ce484222325ull);
    EXPECT_EQ(fnv1a64("a"), 0xaf63dc4c8601ec8cull);
    EXPECT_EQ(fnv1a64("foobar"), 0x85944171f73967e8ull);
}

TEST(Hash, HexIsSixteenLowercaseDigits) {
    EXPECT_EQ(hex64(0), "0000000000000000");
    EXPECT_EQ(hex64(0xcbf29ce484222325ull), "cbf29ce484222325");
    EXPECT_EQ(fnv1a64_hex("foobar"), "85944171f73967e8");
}

TEST(Hash, Fnv1a64StreamsLikeOneCall) {
    // Feeding the data in pieces gives the hash of the whole (the OpenCL cache key is built so).
    Fnv1a64 h;
    h.update("foo");
    h.update("bar");
    EXPECT_EQ(h.value(), fnv1a64("foobar"));
}

// The spec hashes of the example catalogue and of a small analytic spec, as they were before the
// hash moved into core: they must never change.
TEST(Hash, SpecHashesArePinned) {
    const std::map<std::string, std::string> pinned = {
        {"seed-tio2-white", "7d8e9b2438246122"},    {"hematite-red", "9bfe6a1413f737d1"},
        {"zno-white", "43426795aa9f24f7"},          {"carbon-black-grey", "b555a77bc3bf00b5"},
        {"cds-yellow", "7c4fd50514e982d7"},         {"gold-ruby-glass", "9dc46c52f3f748d8"},
        {"tio2-hematite-pink", "d15500fe100fcd15"}, {"analytic-hg-orange", "0f2f0e92551f26b2"},
        {"cds-copper-mixture", "693df724ffb7adc2"}, // added with issue 18
        {"tio2-white-gloss", "39c32e71af656fa5"},   {"tio2-white-satin", "49ad2ab72950d810"}, // issue 16
        {"tio2-white-matte", "da8fde8975d6d0b0"},
    };
    const auto specs = material::load_specs(source_dir() / "examples" / "catalogue.json");
    ASSERT_EQ(specs.size(), pinned.size());
    for (const auto& s : specs) EXPECT_EQ(s.hash, pinned.at(s.name)) << s.name;
    const auto tiny = material::parse_specs_text(
        R"({"name": "k", "medium": {"albedo": 0.9}, "accuracy": "draft", "spectrum": "rgb"})", "x");
    EXPECT_EQ(tiny.at(0).hash, "0d2cd5afde2e7fa9");
    EXPECT_EQ(material::fnv1a64_hex("foobar"), "85944171f73967e8");
}

} // namespace
} // namespace brdf::test
