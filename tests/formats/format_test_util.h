#pragma once
// Helpers shared by the formats tests: exact-message exception assertions, an analytic reciprocal
// isotropic BRDF to fill tables with, byte-level file helpers, the malformed specimens (also
// checked in under tests/data/bad, see make_specimens.cpp), and an allocation probe.

#include <formats/halfdiff.h>
#include <formats/table.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

namespace brdf::test {

/// Succeeds when f() throws exactly type E (or a subclass) whose what() equals `expected`.
template <typename E, typename F>
::testing::AssertionResult throws_with_message(F&& f, const std::string& expected) {
    try {
        f();
    } catch (const E& e) {
        if (expected == e.what()) return ::testing::AssertionSuccess();
        return ::testing::AssertionFailure()
               << "message\n  \"" << e.what() << "\"\nexpected\n  \"" << expected << "\"";
    } catch (const std::exception& e) {
        return ::testing::AssertionFailure() << "threw another type: " << e.what();
    }
    return ::testing::AssertionFailure() << "did not throw";
}

#define EXPECT_THROW_MESSAGE(statement, Type, message)                                             \
    EXPECT_TRUE((::brdf::test::throws_with_message<Type>([&] { statement; }, message)))

/// A reciprocal, isotropic analytic BRDF (1/sr): Lambertian kd/pi plus a normalised Blinn-Phong
/// lobe ks (n + 2)/(2 pi) (n . h)^n with n = 50, per channel. Symmetric under wi <-> wo and
/// rotations about the normal, positive everywhere above the horizon.
formats::Rgb analytic_brdf(const formats::Vec3& wi, const formats::Vec3& wo);

/// tabulate(analytic_brdf), computed once per process and copied.
const formats::BrdfTable& analytic_table();

/// Raw little-endian header of a MERL file.
std::string merl_header(std::int32_t d0, std::int32_t d1, std::int32_t d2);
/// Header with each int32 byte-swapped (what a big-endian writer produces).
std::string merl_header_big_endian(std::int32_t d0, std::int32_t d1, std::int32_t d2);
/// A MERL file of `n` bytes: a valid header and zeros (n >= 12).
std::string merl_truncated(std::size_t n);

/// Little-endian float64 at byte offset `offset` of `bytes`.
double load_f64_le(const std::string& bytes, std::size_t offset);
void store_f64_le(std::string& bytes, std::size_t offset, double value);

/// Byte offset of cell `cell` of channel `channel` in a MERL file.
std::size_t merl_offset(int channel, std::size_t cell);

/// Options for a hand-made OpenEXR file (written with OpenEXR directly, not write_exr).
struct ExrSpecimen {
    int width = 180;
    int height = 8100;
    std::vector<std::string> channels{"R", "G", "B"};
    bool half = false; ///< HALF instead of FLOAT channels
    /// String attributes; brdf.layout is the right one unless replaced or removed.
    std::vector<std::pair<std::string, std::string>> attributes{
        {"brdf.layout", "merl-halfdiff-90x90x180"}, {"brdf.units", "1/sr"}};
    float value = 0.25f; ///< every pixel of every channel
};
void write_exr_specimen(const std::filesystem::path& path, const ExrSpecimen& specimen);

/// Names of the checked-in specimens in tests/data/bad and the bytes each must hold (MERL ones) or
/// how to make it (OpenEXR ones); make_specimens writes them.
struct MerlSpecimen {
    const char* name;
    std::string bytes;
};
std::vector<MerlSpecimen> merl_specimens();
void write_exr_specimens(const std::filesystem::path& folder);

/// A small valid Fourier BSDF file (make_fourier_bsdf of a Lambertian + azimuthal lobe on the
/// nodes 0.5, 1: 6 nodes, 3 orders, 3 channels), as bytes; deterministic.
std::string fourier_specimen_bytes();
/// The checked-in malformed Fourier BSDF files (name, bytes); make_specimens writes them.
std::vector<MerlSpecimen> fourier_specimens();

/// The fuzz seeds of fuzz_fourier and fuzz_spectral_exr: FOLDER/fourier/*.bsdf,
/// FOLDER/spectral_exr/*.exr.
void write_fuzz_seeds(const std::filesystem::path& folder);

/// Records the largest single operator new request made between construction and destruction
/// (this test binary replaces the global operator new).
class AllocationProbe {
  public:
    AllocationProbe();
    ~AllocationProbe();
    AllocationProbe(const AllocationProbe&) = delete;
    AllocationProbe& operator=(const AllocationProbe&) = delete;
    std::size_t largest() const;
};

} // namespace brdf::test
