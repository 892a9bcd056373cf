#include "rgl_test_files.h"

namespace brdf::test {

namespace {

std::string le(std::uint64_t v, int bytes) {
    std::string out;
    for (int b = 0; b < bytes; ++b) out.push_back(static_cast<char>((v >> (8 * b)) & 0xff));
    return out;
}

formats::RglArray array(std::vector<std::size_t> shape, float base) {
    formats::RglArray a;
    a.shape = std::move(shape);
    a.values.resize(a.size());
    for (std::size_t k = 0; k < a.values.size(); ++k)
        a.values[k] = base + 0.01f * static_cast<float>(k % 7);
    return a;
}

} // namespace

std::string le16(std::uint16_t v) {
    return le(v, 2);
}
std::string le32(std::uint32_t v) {
    return le(v, 4);
}
std::string le64(std::uint64_t v) {
    return le(v, 8);
}

std::uint64_t load_u64_le(const std::string& bytes, std::size_t offset) {
    std::uint64_t v = 0;
    for (int b = 0; b < 8; ++b)
        v |= std::uint64_t{static_cast<unsigned char>(bytes.at(offset + b))} << (8 * b);
    return v;
}

std::string raw_tensor_header(const std::vector<RawField>& fields, std::uint8_t major,
                              std::uint8_t minor) {
    std::string out("tensor_file\0", 12);
    out.push_back(static_cast<char>(major));
    out.push_back(static_cast<char>(minor));
    out += le32(static_cast<std::uint32_t>(fields.size()));
    for (const RawField& f : fields) {
        out += le16(static_cast<std::uint16_t>(f.name.size())) + f.name;
        out += le16(static_cast<std::uint16_t>(f.shape.size()));
        out.push_back(static_cast<char>(f.dtype));
        out += le64(f.offset);
        for (std::uint64_t d : f.shape) out += le64(d);
    }
    return out;
}

formats::RglBsdf small_rgl_bsdf(bool spectral) {
    formats::RglBsdf b;
    b.theta_i = {0.0f, 0.7f};
    b.phi_i = {0.0f};
    b.ndf = array({2, 3}, 0.3f);
    b.sigma = array({2, 3}, 0.9f);
    b.vndf = array({1, 2, 3, 3}, 0.5f);
    b.luminance = array({1, 2, 4, 4}, 0.2f);
    if (spectral) b.wavelengths = {400.0f, 500.0f, 600.0f, 700.0f};
    b.values = array({1, 2, b.channels(), 4, 4}, 0.1f);
    b.description = "small test file";
    return b;
}

} // namespace brdf::test
