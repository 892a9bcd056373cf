#include <brdf/core/hash.h>

namespace brdf {

std::uint64_t fnv1a64(std::string_view data) {
    Fnv1a64 h;
    h.update(data);
    return h.value();
}

std::string hex64(std::uint64_t value) {
    static constexpr char digits[] = "0123456789abcdef";
    std::string out(16, '0');
    for (int i = 15; i >= 0; --i, value >>= 4) out[static_cast<std::size_t>(i)] = digits[value & 0xf];
    return out;
}

std::string fnv1a64_hex(std::string_view data) { return hex64(fnv1a64(data)); }

} // namespace brdf
