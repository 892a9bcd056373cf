#include <brdf/core/blob_cache.h>

#include <test_support.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace brdf {
namespace {
namespace fs = std::filesystem;

// What is stored under a key comes back under that key, byte for byte (zeros included), and under
// no other; a store replaces.
TEST(BlobCache, ABlobComesBackUnderItsKeyOnly) {
    test::TempDir dir;
    const BlobCache cache(dir.path() / "sub" / "folder", "TESTMAG1");
    const std::string blob("a\0b\xff\n blob", 11);
    EXPECT_FALSE(cache.load("key one").has_value());
    ASSERT_TRUE(cache.store("key one", blob)); // creates the folders
    ASSERT_TRUE(cache.load("key one").has_value());
    EXPECT_EQ(*cache.load("key one"), blob);
    EXPECT_FALSE(cache.load("key two").has_value());
    ASSERT_TRUE(cache.store("key one", "replaced"));
    EXPECT_EQ(*cache.load("key one"), "replaced");
    // Another magic reads nothing of it.
    EXPECT_FALSE(BlobCache(cache.dir(), "OTHERMG1").load("key one").has_value());
}

// A file that holds another key (a hash collision), is truncated anywhere, or has any byte of its
// blob changed is a miss, never a wrong blob.
TEST(BlobCache, ADamagedOrForeignFileIsAMiss) {
    test::TempDir dir;
    const BlobCache cache(dir.path(), "TESTMAG1");
    ASSERT_TRUE(cache.store("the key", "the blob of the key"));
    const std::string good = test::read_file(cache.file("the key"));
    // Another key's file put where this key's would be.
    ASSERT_TRUE(cache.store("another key", "another blob"));
    fs::copy_file(cache.file("another key"), cache.file("the key"), fs::copy_options::overwrite_existing);
    EXPECT_FALSE(cache.load("the key").has_value());
    for (std::size_t size = 0; size < good.size(); ++size) {
        test::write_file(cache.file("the key"), good.substr(0, size));
        EXPECT_FALSE(cache.load("the key").has_value()) << "truncated to " << size << " bytes";
    }
    // Each byte of the blob flipped (it lies before the final 8-byte checksum).
    const std::size_t blob_end = good.size() - 8, blob_start = blob_end - std::string("the blob of the key").size();
    for (std::size_t at = blob_start; at < blob_end; ++at) {
        std::string bad = good;
        bad[at] = static_cast<char>(bad[at] ^ 0x20);
        test::write_file(cache.file("the key"), bad);
        EXPECT_FALSE(cache.load("the key").has_value()) << "byte " << at << " changed";
    }
    test::write_file(cache.file("the key"), good);
    EXPECT_EQ(*cache.load("the key"), "the blob of the key");
}

// A folder that cannot be made keeps nothing, and says so by returning false, never by throwing.
TEST(BlobCache, AFolderThatCannotBeMadeKeepsNothing) {
    test::TempDir dir;
    test::write_file(dir.path() / "a-file", "x");
    const BlobCache cache(dir.path() / "a-file" / "cache", "TESTMAG1");
    EXPECT_FALSE(cache.store("key", "blob"));
    EXPECT_FALSE(cache.load("key").has_value());
}

// $BRDF_CACHE_DIR, else $XDG_CACHE_HOME/brdf-service, else $HOME/.cache/brdf-service; "off": none.
TEST(BlobCache, TheCacheRootFollowsTheEnvironment) {
    const test::ScopedEnv brdf("BRDF_CACHE_DIR", "/some/where");
    const test::ScopedEnv xdg("XDG_CACHE_HOME", "/xdg");
    const test::ScopedEnv home("HOME", "/home/user");
    EXPECT_EQ(cache_root(), fs::path("/some/where"));
    {
        const test::ScopedEnv off("BRDF_CACHE_DIR", "off");
        EXPECT_TRUE(cache_root().empty());
    }
    {
        const test::ScopedEnv unset("BRDF_CACHE_DIR", nullptr);
        EXPECT_EQ(cache_root(), fs::path("/xdg/brdf-service"));
        const test::ScopedEnv no_xdg("XDG_CACHE_HOME", nullptr);
        EXPECT_EQ(cache_root(), fs::path("/home/user/.cache/brdf-service"));
        const test::ScopedEnv no_home("HOME", nullptr);
        EXPECT_TRUE(cache_root().empty());
    }
}

} // namespace
} // namespace brdf
