#include "spec_json.h"

#include <brdf/core/log.h>
#include <brdf/core/text.h>

#include <algorithm>
#include <charconv>
#include <cmath>

namespace brdf::material::spec_detail {

std::string shortest(double x) {
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, x);
    return std::string(buffer, result.ptr);
}

std::string complex_text(std::complex<double> m) {
    return m.imag() == 0.0 ? shortest(m.real())
                           : cat(shortest(m.real()), "+", shortest(m.imag()), "i");
}

bool is_identifier(std::string_view key) {
    if (key.empty()) return false;
    return std::all_of(key.begin(), key.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
               c == '_';
    });
}

std::string key_path(const std::string& base, std::string_view key) {
    if (!is_identifier(key)) return cat(base, "[", json(std::string(key)).dump(), "]");
    return base.empty() ? std::string(key) : cat(base, ".", key);
}

std::string elem_path(const std::string& base, std::size_t i) { return cat(base, "[", i, "]"); }

std::string show(const json& v) {
    if (v.is_number_float() && !std::isfinite(v.get<double>())) {
        const double x = v.get<double>();
        return std::isnan(x) ? "NaN" : (x > 0 ? "Infinity" : "-Infinity");
    }
    std::string s = v.dump(-1, ' ', false, json::error_handler_t::replace);
    if (s.size() > 60) s = s.substr(0, 56) + " ...";
    return s;
}

const char* type_name(const json& v) {
    switch (v.type()) {
    case json::value_t::null: return "null";
    case json::value_t::object: return "an object";
    case json::value_t::array: return "an array";
    case json::value_t::string: return "a string";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "a number";
    default: return "an unsupported value";
    }
}

std::string closest(std::string_view key, const std::vector<std::string_view>& known) {
    const std::string query = ascii_lower(key);
    std::string best;
    std::size_t best_distance = std::string::npos;
    for (std::string_view k : known) {
        const std::string candidate = ascii_lower(k);
        // A prefix of at least 3 characters ("r_eff" for "r_eff_um", "absorption" for
        // "absorption_per_mm") is the likeliest intent, ahead of any edit distance.
        const bool prefix = std::min(query.size(), candidate.size()) >= 3 &&
                            (candidate.starts_with(query) || query.starts_with(candidate));
        const std::size_t d = prefix ? 0 : edit_distance(query, candidate);
        if (d < best_distance) best_distance = d, best = std::string(k);
    }
    const std::size_t allowed = std::max<std::size_t>(2, query.size() / 3);
    return best_distance <= allowed && best_distance < query.size() ? best : std::string();
}

std::string list(const std::vector<std::string_view>& items) {
    std::string out;
    for (std::string_view s : items) out += (out.empty() ? "" : ", ") + std::string(s);
    return out;
}

void Checker::fail(const std::string& path, const std::string& message) {
    // A required key reported as a likely typo ("volume_fracton: unknown key (did you mean ...)")
    // is not reported missing as well: one mistake, one line.
    if (message.starts_with("missing") && m_suggested.count(path)) {
        ++m_failures;
        return;
    }
    add_line(path.empty() ? cat(m_source, ": ", message) : cat(m_source, ": ", path, ": ", message));
}

void Checker::fail_raw(const std::string& message) { add_line(cat(m_source, ": ", message)); }

void Checker::fail_limit(const std::string& path, const std::string& message) {
    const std::size_t before = m_problems.size();
    fail(path, message);
    m_limit_problems += m_problems.size() - before;
}

void Checker::unknown_key(const std::string& path, std::string_view key,
                          const std::vector<std::string_view>& known, std::string_view note) {
    std::string message = "unknown key";
    const std::string guess = closest(key, known);
    if (!guess.empty()) {
        message += cat(" (did you mean \"", guess, "\"?)");
        // The path the suggested key would have: this path with its last component replaced.
        std::string parent = path.substr(0, path.size() - key_path("", key).size());
        if (is_identifier(key) && !parent.empty()) parent.pop_back(); // the '.'
        m_suggested.insert(key_path(parent, guess));
    }
    message += cat("; expected one of: ", list(known));
    if (!note.empty()) message += cat(" (", note, ")");
    fail(path, message);
}

void Checker::check_keys(const json& object,
                         const std::function<std::string(std::string_view)>& path_of,
                         const std::vector<std::string_view>& known, std::string_view note) {
    for (const auto& item : object.items()) {
        const std::string& key = item.key();
        if (std::find(known.begin(), known.end(), key) == known.end())
            unknown_key(path_of(key), key, known, note);
    }
}

void Checker::check_keys(const json& object, const std::string& base,
                         const std::vector<std::string_view>& known, std::string_view note) {
    check_keys(object, [&](std::string_view k) { return key_path(base, k); }, known, note);
}

std::optional<double> Checker::number(const json& v, const std::string& path) {
    if (!v.is_number()) {
        fail(path, cat("expected a number, got ", type_name(v), " (got ", show(v), ")"));
        return std::nullopt;
    }
    const double x = v.get<double>();
    if (!std::isfinite(x)) {
        fail(path, cat("must be a finite number (got ", show(v), ")"));
        return std::nullopt;
    }
    return x;
}

std::optional<std::string> Checker::string(const json& v, const std::string& path) {
    if (!v.is_string()) {
        fail(path, cat("expected a string, got ", type_name(v), " (got ", show(v), ")"));
        return std::nullopt;
    }
    return v.get<std::string>();
}

bool Checker::object(const json& v, const std::string& path, std::string_view what) {
    if (v.is_object()) return true;
    fail(path, cat("expected an object ", what, ", got ", type_name(v), " (got ", show(v), ")"));
    return false;
}

bool Checker::array(const json& v, const std::string& path, std::string_view what) {
    if (v.is_array()) return true;
    fail(path, cat("expected an array ", what, ", got ", type_name(v), " (got ", show(v), ")"));
    return false;
}

std::optional<std::size_t> Checker::one_of(std::string_view name, const json& shown,
                                           const std::string& path,
                                           const std::vector<std::string_view>& choices,
                                           std::string_view expected) {
    for (std::size_t i = 0; i < choices.size(); ++i)
        if (choices[i] == name) return i;
    std::string message =
        expected.empty() ? cat("must be one of ", list(choices)) : cat("must be ", expected);
    if (const std::string guess = closest(name, choices); !guess.empty())
        message += cat(" (did you mean \"", guess, "\"?)");
    fail(path, cat(message, " (got ", show(shown), ")"));
    return std::nullopt;
}

std::optional<std::size_t> Checker::one_of(const json& v, const std::string& path,
                                           const std::vector<std::string_view>& choices,
                                           std::string_view expected) {
    const auto name = string(v, path);
    if (!name) return std::nullopt;
    return one_of(*name, v, path, choices, expected);
}

void Checker::add_line(std::string line) {
    ++m_failures;
    if (std::find(m_problems.begin(), m_problems.end(), line) == m_problems.end())
        m_problems.push_back(std::move(line));
}

} // namespace brdf::material::spec_detail
