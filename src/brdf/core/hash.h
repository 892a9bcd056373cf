#pragma once
// The one non-cryptographic hash of the project: FNV-1a 64 (Fowler, Noll, Vo). It keys the spec hash
// in every report (material::MaterialSpec::hash, so its values must never change: tests/core pins
// them) and the OpenCL program-binary cache (cl/context.cpp). Neither needs resistance to an
// attacker: the cache checks the full key on load, and a spec hash only decides "up to date".

#include <cstdint>
#include <string>
#include <string_view>

namespace brdf {

/// FNV-1a 64, fed in pieces: update("foo"); update("bar") gives the hash of "foobar".
class Fnv1a64 {
public:
    void update(std::string_view data) {
        for (unsigned char c : data) {
            m_state ^= c;
            m_state *= prime;
        }
    }
    std::uint64_t value() const { return m_state; }

private:
    static constexpr std::uint64_t offset_basis = 14695981039346656037ull;
    static constexpr std::uint64_t prime = 1099511628211ull;
    std::uint64_t m_state = offset_basis;
};

/// FNV-1a 64 of `data`.
std::uint64_t fnv1a64(std::string_view data);

/// `value` as 16 lowercase hex digits, most significant first.
std::string hex64(std::uint64_t value);

/// hex64(fnv1a64(data)): the spec hash and the cache file names.
std::string fnv1a64_hex(std::string_view data);

} // namespace brdf
