#pragma once
// The one logger: timestamped lines on stderr, thread-safe, level set by --log-level or $BRDF_LOG.
//   log::info("job ", name, " done in ", seconds, " s");

#include <functional>
#include <sstream>
#include <string>
#include <string_view>

namespace brdf {

/// Concatenates anything streamable into a string (libstdc++ 12 has no <format>).
template <typename... Args>
std::string cat(const Args&... args) {
    std::ostringstream os;
    os.precision(10);
    (os << ... << args);
    return os.str();
}

namespace log {

enum class Level { Error = 0, Warn = 1, Info = 2, Debug = 3 };

void set_level(Level level);
Level level();
/// Parses "error", "warn", "info", "debug"; throws InputError otherwise.
Level parse_level(std::string_view name);
void write(Level level, std::string_view message);

/// A status line drawn on stderr (core/progress.h's ProgressLine): every log line first calls
/// `clear` (under the log's lock), so that messages start at the left margin and the status line is
/// redrawn below them. An empty function removes it.
void set_status_line_clearer(std::function<void()> clear);

template <typename... Args> void error(const Args&... a) { write(Level::Error, cat(a...)); }
template <typename... Args> void warn(const Args&... a) { if (level() >= Level::Warn) write(Level::Warn, cat(a...)); }
template <typename... Args> void info(const Args&... a) { if (level() >= Level::Info) write(Level::Info, cat(a...)); }
template <typename... Args> void debug(const Args&... a) { if (level() >= Level::Debug) write(Level::Debug, cat(a...)); }

} // namespace log
} // namespace brdf
