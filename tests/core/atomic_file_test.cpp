// core's AtomicFile, the one writer of files others read: whole file or none, unique temporaries per
// call (threads writing one target at once), no temporary left behind on success or failure, and
// files written by a library that opens the temporary by name itself.

#include <brdf/core/atomic_file.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <test_support.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <fcntl.h>
#include <set>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

namespace brdf::test {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> names_in(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

TEST(AtomicFile, WritesTheWholeFileAndLeavesNoTemporary) {
    TempDir tmp;
    write_file_atomically(tmp / "a.json", "{\"x\": 1}\n");
    EXPECT_EQ(read_file(tmp / "a.json"), "{\"x\": 1}\n");
    write_file_atomically(tmp / "a.json", "replaced");
    EXPECT_EQ(read_file(tmp / "a.json"), "replaced");
    EXPECT_EQ(names_in(tmp.path()), std::vector<std::string>{"a.json"});
}

TEST(AtomicFile, NothingChangesBeforeCommitAndAnAbandonedFileVanishes) {
    TempDir tmp;
    write_file(tmp / "t.binary", "old");
    {
        AtomicFile f(tmp / "t.binary");
        f.write("new, ");
        f.write_at(5, "whole", 5);
        EXPECT_EQ(read_file(tmp / "t.binary"), "old");
        // Hidden, named after its target and its writer: what brdfd's clean-up recognises.
        const std::string name = f.temporary().filename().string();
        EXPECT_EQ(name.rfind(cat(".t.binary.tmp.", ::getpid(), "."), 0), 0u) << name;
        EXPECT_EQ(f.temporary().parent_path(), tmp.path());
    } // destroyed without commit(): a writer that failed
    EXPECT_EQ(read_file(tmp / "t.binary"), "old");
    EXPECT_EQ(names_in(tmp.path()), std::vector<std::string>{"t.binary"});
}

TEST(AtomicFile, WriteAtFillsAnyOffset) {
    TempDir tmp;
    AtomicFile f(tmp / "t");
    f.write_at(4, "EFGH", 4);
    f.write_at(0, "ABCD", 4);
    f.write("IJ"); // appends after the furthest byte written
    f.commit();
    EXPECT_EQ(read_file(tmp / "t"), "ABCDEFGHIJ");
    EXPECT_THROW(f.write("more"), IoError);
    EXPECT_THROW(f.commit(), IoError);
}

TEST(AtomicFile, ConcurrentWritersOfOneTargetNeverShowAPartialFile) {
    TempDir tmp;
    const fs::path target = tmp / "status.json";
    // Distinct, long contents: any mix or cut of two would not be one of them.
    std::set<std::string> contents;
    for (int t = 0; t < 4; ++t) contents.insert(std::string(200000, static_cast<char>('a' + t)));
    write_file_atomically(target, *contents.begin());
    std::atomic<bool> stop{false};
    std::atomic<int> bad_reads{0}, reads{0};
    std::thread reader([&] {
        while (!stop) {
            if (!contents.count(read_file(target))) ++bad_reads;
            ++reads;
        }
    });
    std::vector<std::thread> writers;
    for (int t = 0; t < 4; ++t)
        writers.emplace_back([&, t] {
            const std::string mine(200000, static_cast<char>('a' + t));
            for (int i = 0; i < 25; ++i) write_file_atomically(target, mine);
        });
    for (std::thread& w : writers) w.join();
    stop = true;
    reader.join();
    EXPECT_GT(reads, 0);
    EXPECT_EQ(bad_reads, 0);
    EXPECT_EQ(names_in(tmp.path()), std::vector<std::string>{"status.json"});
}

TEST(AtomicFile, FolderThatIsNotThereIsAnIoErrorNamingTheTarget) {
    TempDir tmp;
    try {
        write_file_atomically(tmp / "missing" / "r.report.json", "x");
        FAIL() << "no error";
    } catch (const IoError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find((tmp / "missing" / "r.report.json").string()), std::string::npos) << what;
        EXPECT_NE(what.find("No such file or directory"), std::string::npos) << what;
    }
    EXPECT_FALSE(fs::exists(tmp / "missing"));
}

TEST(AtomicFile, RenameOntoAFolderFailsAndRemovesTheTemporary) {
    TempDir tmp;
    fs::create_directory(tmp / "taken");
    write_file(tmp / "taken" / "inside", "x"); // a non-empty folder cannot be replaced by a file
    EXPECT_THROW(write_file_atomically(tmp / "taken", "x"), IoError);
    EXPECT_EQ(names_in(tmp.path()), std::vector<std::string>{"taken"});
}

TEST(AtomicFile, ALibraryMayWriteTheTemporaryByNameItself) {
    // OpenImageIO opens the file by name (and may replace it): commit() publishes whatever is
    // there. The suffix keeps the extension libraries pick the format by.
    TempDir tmp;
    AtomicFile f(tmp / "preview.png", ".png");
    EXPECT_EQ(f.temporary().extension(), ".png");
    fs::remove(f.temporary());
    write_file(f.temporary(), "written by someone else");
    f.commit();
    EXPECT_EQ(read_file(tmp / "preview.png"), "written by someone else");
    EXPECT_EQ(names_in(tmp.path()), std::vector<std::string>{"preview.png"});
}

TEST(AtomicFile, TemporariesAreUniquePerCall) {
    TempDir tmp;
    std::set<std::string> names;
    std::vector<std::unique_ptr<AtomicFile>> open;
    for (int i = 0; i < 50; ++i) {
        open.push_back(std::make_unique<AtomicFile>(tmp / "same"));
        names.insert(open.back()->temporary().string());
    }
    EXPECT_EQ(names.size(), 50u);
    open.clear();
    EXPECT_EQ(names_in(tmp.path()), std::vector<std::string>{});
}

} // namespace
} // namespace brdf::test
