#pragma once
// Internal to the spec parser (spec*.cpp): JSON paths as messages write them, values as "(got
// VALUE)" shows them, "did you mean" suggestions, and the Checker that collects every problem of a
// document (spec.h describes the message format).

#include <nlohmann/json.hpp>

#include <complex>
#include <cstddef>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace brdf::material::spec_detail {

using nlohmann::json;

/// Shortest text that reads back as the same double ("0.1", "2.7", "1e-05").
std::string shortest(double x);
/// "2.7+0.01i", or "1.5" for a real index.
std::string complex_text(std::complex<double> m);

/// A key that can follow a '.' in a path: [A-Za-z0-9_]+.
bool is_identifier(std::string_view key);
/// "base.key", "key" at the top, or base["odd key"] for keys that are not identifiers.
std::string key_path(const std::string& base, std::string_view key);
/// "base[i]".
std::string elem_path(const std::string& base, std::size_t i);

/// A JSON value for "(got VALUE)": compact, truncated, non-finite numbers spelled out (dump() would
/// print them as null).
std::string show(const json& v);
/// "a number", "a string", "an object", ... for "expected X, got Y".
const char* type_name(const json& v);

/// The closest of `known` to `key` when close enough to be a typo, else "": a shared prefix of at
/// least 3 characters first, then the edit distance (core/text.h) within max(2, |key| / 3).
std::string closest(std::string_view key, const std::vector<std::string_view>& known);
/// "a, b, c".
std::string list(const std::vector<std::string_view>& items);

/// Collects the problems of one document: every line "SOURCE: PATH: fault", each kept once.
class Checker {
  public:
    explicit Checker(std::string source) : m_source(std::move(source)) {}

    const std::string& source() const { return m_source; }
    /// Problems reported so far, repeats included (a parser compares it before and after a part).
    std::size_t failures() const { return m_failures; }
    const std::vector<std::string>& problems() const { return m_problems; }

    /// "SOURCE: PATH: message" (or "SOURCE: message" for an empty path); identical lines (a fault
    /// in catalogue defaults seen by every material) are kept once.
    void fail(const std::string& path, const std::string& message);
    /// A message that already starts with its path (the index and spectrum helpers' format).
    void fail_raw(const std::string& message);
    /// A resource limit (SpecLimits) exceeded: reported like any problem, but a document whose only
    /// problems are limits is refused with a LimitError (only_limits()).
    void fail_limit(const std::string& path, const std::string& message);
    bool only_limits() const { return !m_problems.empty() && m_limit_problems == m_problems.size(); }

    /// Whether an unknown key was reported as a likely typo of the key at `path` (that key is then
    /// not reported missing, nor faults that only follow from its absence).
    bool suggested(const std::string& path) const { return m_suggested.count(path) != 0; }

    /// An unknown key, with a suggestion when it is a likely typo.
    void unknown_key(const std::string& path, std::string_view key,
                     const std::vector<std::string_view>& known, std::string_view note = {});
    /// Reports every key of `object` that is not in `known` (paths from `path_of`).
    void check_keys(const json& object, const std::function<std::string(std::string_view)>& path_of,
                    const std::vector<std::string_view>& known, std::string_view note = {});
    void check_keys(const json& object, const std::string& base,
                    const std::vector<std::string_view>& known, std::string_view note = {});

    /// The value as a finite number, or a problem ("expected a number", "must be a finite number").
    std::optional<double> number(const json& v, const std::string& path);
    /// The value as a string, or a problem.
    std::optional<std::string> string(const json& v, const std::string& path);
    /// True for an object; else a problem "expected an object WHAT, got ...".
    bool object(const json& v, const std::string& path, std::string_view what);
    /// True for an array; else a problem "expected an array WHAT, got ...".
    bool array(const json& v, const std::string& path, std::string_view what);

    /// "One of": the position of `name` in `choices`, or a problem
    ///   PATH: must be EXPECTED (did you mean "x"?) (got SHOWN)
    /// where EXPECTED defaults to "one of a, b, c" and the suggestion is closest(name, choices).
    /// `shown` is the value as written (for the "got" part).
    std::optional<std::size_t> one_of(std::string_view name, const json& shown,
                                      const std::string& path,
                                      const std::vector<std::string_view>& choices,
                                      std::string_view expected = {});
    /// The same for a JSON value that must be a string (a problem "expected a string" otherwise).
    std::optional<std::size_t> one_of(const json& v, const std::string& path,
                                      const std::vector<std::string_view>& choices,
                                      std::string_view expected = {});

  private:
    void add_line(std::string line);

    std::string m_source;
    std::vector<std::string> m_problems;
    std::set<std::string> m_suggested; // paths a "did you mean" named: not reported missing too
    std::size_t m_failures = 0;
    std::size_t m_limit_problems = 0;
};

} // namespace brdf::material::spec_detail
