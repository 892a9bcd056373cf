#pragma once
// Small text helpers shared by the validators: case folding and the edit distance behind their
// "did you mean" suggestions.

#include <cstddef>
#include <string>
#include <string_view>

namespace brdf {

/// ASCII lower case (locale-independent: spec keys and material IDs are ASCII).
std::string ascii_lower(std::string_view s);

/// Levenshtein distance (insertions, deletions, substitutions of single bytes).
std::size_t edit_distance(std::string_view a, std::string_view b);

} // namespace brdf
