#include <brdf/core/embedded.h>

namespace brdf {

std::optional<std::string_view> find_embedded(std::span<const EmbeddedFile> files,
                                              std::string_view path) {
    for (const EmbeddedFile& f : files)
        if (f.path == path) return f.data;
    return std::nullopt;
}

} // namespace brdf
