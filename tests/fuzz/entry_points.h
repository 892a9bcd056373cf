#pragma once
// The fuzzed entry points, shared by the libFuzzer targets (tests/fuzz, -DBRDF_FUZZ=ON) and the
// regression test that replays tests/data/fuzz/regressions in the normal build
// (tests/fuzz_regressions). Each runs the bytes through one reader and lets every exception escape:
// a brdf::Error is the expected outcome for malformed input; anything else (another exception, a
// crash, a sanitizer report) is a bug.

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace brdf::fuzz {

/// The bytes as a MERL .binary file (written to a temporary file: read_merl takes a path) -> read_merl.
void merl(const std::uint8_t* data, std::size_t size);
/// The bytes as an OpenEXR file (temporary file) -> read_exr.
void exr(const std::uint8_t* data, std::size_t size);
/// The bytes as an RGL BSDF file (temporary file) -> read_rgl_bsdf; a file that reads is then
/// evaluated (RglEvaluator) at a few direction pairs, so that valid but odd files reach the
/// evaluator's interpolation too.
void rgl(const std::uint8_t* data, std::size_t size);
/// The bytes as a pbrt-v3 Fourier BSDF file (temporary file) -> read_fourier_bsdf, and on success
/// evaluate at a few directions (the reader's checks must make every file it accepts safe to
/// evaluate).
void fourier(const std::uint8_t* data, std::size_t size);
/// The bytes as a spectral OpenEXR table (temporary file) -> read_spectral_exr.
void spectral_exr(const std::uint8_t* data, std::size_t size);
/// The bytes as spec JSON text -> parse_specs_text.
void spec(const std::uint8_t* data, std::size_t size);

/// Runs `target` on the bytes and swallows a brdf::Error; returns 0 (libFuzzer's convention).
int run_expecting_error_or_success(void (*target)(const std::uint8_t*, std::size_t),
                                   const std::uint8_t* data, std::size_t size);

} // namespace brdf::fuzz
