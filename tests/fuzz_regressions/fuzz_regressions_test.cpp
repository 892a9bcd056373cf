// Inputs that once crashed, hung or leaked in a fuzzer (tests/data/fuzz/regressions, see its
// README), replayed through the fuzzers' own entry points (tests/fuzz/entry_points.h). The file name
// says which: "merl-*", "exr-*", "fourier-*", "spectral-*", "rgl-*", "spec-*". Each must be refused
// with a brdf::Error or accepted; another exception fails the test, a crash or sanitizer report kills
// it. The seed corpora (tests/data/fuzz/{merl,exr,fourier,spectral_exr,rgl}, tests/data/specs/good
// for the spec parser, tests/data/bad for every reader) are replayed too, so the entry points
// themselves stay tested.

#include "entry_points.h"

#include <brdf/core/error.h>

#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace brdf::fuzz {
namespace {

namespace fs = std::filesystem;

using Target = void (*)(const std::uint8_t*, std::size_t);

// The files of `folder` whose names start with `prefix`, sorted (so failures are reproducible).
std::vector<fs::path> files(const fs::path& folder, const std::string& prefix = "") {
    std::vector<fs::path> out;
    for (const auto& entry : fs::directory_iterator(folder))
        if (entry.is_regular_file() && entry.path().filename().string().starts_with(prefix) &&
            entry.path().extension() != ".md")
            out.push_back(entry.path());
    std::sort(out.begin(), out.end());
    return out;
}

// Runs one file; a brdf::Error or success passes, any other exception fails naming the file.
void replay(Target target, const fs::path& file) {
    const std::string bytes = test::read_file(file);
    try {
        target(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    } catch (const Error&) {
        // refused with a message: fine
    } catch (const std::exception& e) {
        ADD_FAILURE() << file.filename() << ": escaped as a non-brdf exception: " << e.what();
    } catch (...) {
        ADD_FAILURE() << file.filename() << ": escaped as an unknown exception";
    }
}

const fs::path regressions = test::source_dir() / "tests/data/fuzz/regressions";

TEST(FuzzRegressions, EveryFileIsNamedAfterItsTarget) {
    for (const fs::path& f : files(regressions)) {
        const std::string name = f.filename().string();
        EXPECT_TRUE(name.starts_with("merl-") || name.starts_with("exr-") ||
                    name.starts_with("fourier-") || name.starts_with("spectral-") ||
                    name.starts_with("rgl-") || name.starts_with("spec-"))
            << name << ": name must start with merl-, exr-, fourier-, spectral-, rgl- or spec-";
    }
}

TEST(FuzzRegressions, MerlInputs) {
    for (const fs::path& f : files(regressions, "merl-")) replay(&merl, f);
}

TEST(FuzzRegressions, ExrInputs) {
    for (const fs::path& f : files(regressions, "exr-")) replay(&exr, f);
}

TEST(FuzzRegressions, RglInputs) {
    for (const fs::path& f : files(regressions, "rgl-")) replay(&rgl, f);
}

TEST(FuzzRegressions, FourierInputs) {
    for (const fs::path& f : files(regressions, "fourier-")) replay(&fourier, f);
}

TEST(FuzzRegressions, SpectralExrInputs) {
    for (const fs::path& f : files(regressions, "spectral-")) replay(&spectral_exr, f);
}

TEST(FuzzRegressions, SpecInputs) {
    for (const fs::path& f : files(regressions, "spec-")) replay(&spec, f);
}

TEST(FuzzSeeds, EverySeedRunsThroughItsEntryPoint) {
    const fs::path seeds = test::source_dir() / "tests/data/fuzz";
    for (const fs::path& f : files(seeds / "merl")) replay(&merl, f);
    for (const fs::path& f : files(seeds / "exr")) replay(&exr, f);
    for (const fs::path& f : files(seeds / "rgl")) replay(&rgl, f);
    for (const fs::path& f : files(seeds / "fourier")) replay(&fourier, f);
    for (const fs::path& f : files(seeds / "spectral_exr")) replay(&spectral_exr, f);
    // The spec parser's seeds are the good specs of the parser tests, not a copy of them.
    for (const fs::path& f : files(test::source_dir() / "tests/data/specs/good")) replay(&spec, f);
    // tools/dev/fuzz.sh seeds every target with the malformed files of tests/data/bad too.
    const fs::path bad = test::source_dir() / "tests/data/bad";
    for (const fs::path& f : files(bad, "merl_")) replay(&merl, f);
    for (const fs::path& f : files(bad, "exr_")) replay(&exr, f);
    for (const fs::path& f : files(bad, "fourier_")) replay(&fourier, f);
    for (const fs::path& f : files(bad, "spec_")) replay(&spec, f);
}

// Each seed lives in one place: no two seed files (nor a seed and a test's good or bad file) are
// byte for byte the same.
TEST(FuzzSeeds, NoSeedIsACopyOfAnother) {
    std::map<std::string, fs::path> seen;
    for (const char* folder : {"tests/data/fuzz", "tests/data/specs/good", "tests/data/bad"})
        for (const auto& entry : fs::recursive_directory_iterator(test::source_dir() / folder)) {
            if (!entry.is_regular_file() || entry.path().extension() == ".md") continue;
            const auto [it, fresh] = seen.emplace(test::read_file(entry.path()), entry.path());
            EXPECT_TRUE(fresh) << entry.path() << " is a copy of " << it->second;
        }
}

// The entry points swallow nothing themselves: a malformed input reaches the test as a brdf::Error.
TEST(FuzzSeeds, EntryPointsLetTheReadersErrorsThrough) {
    const std::string junk = "not a table";
    const auto* p = reinterpret_cast<const std::uint8_t*>(junk.data());
    EXPECT_THROW(merl(p, junk.size()), FormatError);
    EXPECT_THROW(exr(p, junk.size()), FormatError);
    EXPECT_THROW(rgl(p, junk.size()), FormatError);
    EXPECT_THROW(fourier(p, junk.size()), FormatError);
    EXPECT_THROW(spectral_exr(p, junk.size()), FormatError);
    EXPECT_THROW(spec(p, junk.size()), InputError);
}

} // namespace
} // namespace brdf::fuzz
