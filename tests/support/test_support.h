#pragma once
// Shared test helpers: relative-error assertions that print value, reference and difference; paths of
// the source and build trees; temporary folders; running the tools as real processes.

#include <gtest/gtest.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace brdf::test {

/// |value - reference| <= tol * |reference| (or <= tol when the reference is 0).
::testing::AssertionResult rel_near(const char* value_expr, const char* ref_expr,
                                    const char* tol_expr, double value, double reference,
                                    double tol);

#define EXPECT_REL_NEAR(value, reference, tol) \
    EXPECT_PRED_FORMAT3(::brdf::test::rel_near, value, reference, tol)
#define ASSERT_REL_NEAR(value, reference, tol) \
    ASSERT_PRED_FORMAT3(::brdf::test::rel_near, value, reference, tol)

/// The project's source tree.
std::filesystem::path source_dir();
/// Folder of the built executables.
std::filesystem::path bin_dir();

/// A fresh folder under the system temporary directory, removed with its contents on destruction.
class TempDir {
public:
    TempDir();
    ~TempDir();
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    const std::filesystem::path& path() const { return m_path; }
    std::filesystem::path operator/(const std::string& name) const { return m_path / name; }

private:
    std::filesystem::path m_path;
};

struct ProcessResult {
    int status = -1; ///< exit status, or 128 + signal number when killed by a signal
    std::string out;
    std::string err;
};

/// Runs an executable (argv[0] is a path) with the given stdin, capturing stdout and stderr.
ProcessResult run_process(const std::vector<std::string>& argv, const std::string& input = {});

/// Runs bin_dir()/tool with arguments.
ProcessResult run_tool(const std::string& tool, const std::vector<std::string>& args,
                       const std::string& input = {});

std::string read_file(const std::filesystem::path& path);
void write_file(const std::filesystem::path& path, const std::string& content);

/// Sets (value nullptr: unsets) an environment variable for its lifetime, then restores it.
class ScopedEnv {
public:
    ScopedEnv(const char* name, const char* value);
    ~ScopedEnv();
    ScopedEnv(const ScopedEnv&) = delete;
    ScopedEnv& operator=(const ScopedEnv&) = delete;

private:
    std::string m_name;
    std::optional<std::string> m_old;
};

} // namespace brdf::test
