#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <mutex>

namespace brdf::log {
namespace {

Level initial_level() {
    if (const char* env = std::getenv("BRDF_LOG")) {
        try {
            return parse_level(env);
        } catch (const Error&) {
        }
    }
    return Level::Warn;
}

std::atomic<Level>& current() {
    static std::atomic<Level> value{initial_level()};
    return value;
}

const char* tag(Level level) {
    switch (level) {
    case Level::Error: return "error";
    case Level::Warn: return "warn";
    case Level::Info: return "info";
    case Level::Debug: return "debug";
    }
    return "?";
}

} // namespace

void set_level(Level level) { current() = level; }
Level level() { return current(); }

Level parse_level(std::string_view name) {
    if (name == "error") return Level::Error;
    if (name == "warn") return Level::Warn;
    if (name == "info") return Level::Info;
    if (name == "debug") return Level::Debug;
    throw InputError(cat("log level: expected error, warn, info or debug (got '", name, "')"));
}

namespace {

std::mutex& write_mutex() {
    static std::mutex mutex;
    return mutex;
}

std::function<void()>& status_line_clearer() {
    static std::function<void()> clear;
    return clear;
}

} // namespace

void set_status_line_clearer(std::function<void()> clear) {
    std::lock_guard lock(write_mutex());
    status_line_clearer() = std::move(clear);
}

void write(Level level, std::string_view message) {
    const auto now = std::chrono::system_clock::now();
    const std::time_t t = std::chrono::system_clock::to_time_t(now);
    const auto ms =
        std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
    std::tm tm{};
    gmtime_r(&t, &tm);
    char stamp[32];
    std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%S", &tm);
    std::lock_guard lock(write_mutex());
    if (status_line_clearer()) status_line_clearer()();
    std::fprintf(stderr, "%s.%03dZ %s %.*s\n", stamp, static_cast<int>(ms), tag(level),
                 static_cast<int>(message.size()), message.data());
    std::fflush(stderr);
}

} // namespace brdf::log
