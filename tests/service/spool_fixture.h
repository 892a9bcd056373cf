#pragma once
// Helpers shared by the spool, daemon and brdfd tests: dropping specs into a spool the way users are
// told to (write elsewhere, rename in), waiting for a condition, listing a spool folder.

#include <brdf/service/spool.h>

#include "test_support.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace brdf::test {

/// Writes incoming/NAME through a hidden temporary and a rename; `age_seconds` sets its mtime that far
/// in the past (the daemon takes the oldest first).
inline void submit(const std::filesystem::path& spool, const std::string& name,
                   const std::string& content = "{}", double age_seconds = 0.0) {
    namespace fs = std::filesystem;
    fs::create_directories(spool / "incoming");
    const fs::path tmp = spool / "incoming" / ("." + name + ".tmp");
    write_file(tmp, content);
    if (age_seconds != 0.0) {
        const auto t = fs::file_time_type::clock::now() -
                       std::chrono::duration_cast<fs::file_time_type::duration>(
                           std::chrono::duration<double>(age_seconds));
        fs::last_write_time(tmp, t);
    }
    fs::rename(tmp, spool / "incoming" / name);
}

/// Names of the regular, non-hidden files in a folder, sorted.
inline std::vector<std::string> list_files(const std::filesystem::path& dir) {
    std::vector<std::string> names;
    std::error_code ec;
    for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.front() != '.' && it->is_regular_file()) names.push_back(name);
    }
    std::sort(names.begin(), names.end());
    return names;
}

/// Polls `condition` every 10 ms for up to `seconds`; returns its last value.
inline bool wait_until(const std::function<bool()>& condition, double seconds = 10.0) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < deadline) {
        if (condition()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return condition();
}

} // namespace brdf::test
