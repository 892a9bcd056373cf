#pragma once
// The OpenCL sources, embedded into the binary at build time from kernels/
// (src/brdf/cl/CMakeLists.txt: brdf_embed_files(... FUNCTION kernel_sources BASE kernels ...)).
// Paths are relative to kernels/: "selftest.cl", "shared/selftest_layout.h".

#include <brdf/core/embedded.h>

#include <span>

namespace brdf::embedded {

/// Every embedded kernels/*.cl and kernels/shared/*.h file.
std::span<const EmbeddedFile> kernel_sources();

} // namespace brdf::embedded
