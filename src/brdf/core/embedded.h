#pragma once
// Files embedded into the binary at build time (cmake/BrdfEmbed.cmake): OpenCL kernels, refractive-
// index data, CIE tables. Each module declares the registry functions it generates.

#include <optional>
#include <span>
#include <string_view>

namespace brdf {

struct EmbeddedFile {
    std::string_view path; ///< relative to the embedding base folder, '/'-separated
    std::string_view data;
};

/// The file with exactly this relative path, if embedded.
std::optional<std::string_view> find_embedded(std::span<const EmbeddedFile> files,
                                              std::string_view path);

} // namespace brdf
