#pragma once
// The data files of the material module, embedded into the binary at build time from data/
// (src/brdf/material/CMakeLists.txt: brdf_embed_files(... FUNCTION material_data BASE data ...)).
// Paths are relative to data/: "refractiveindex/main_TiO2__Devore-o.yml", "cie/cie_d65_5nm.csv".

#include <brdf/core/embedded.h>

#include <span>

namespace brdf::embedded {

/// Every embedded file of data/refractiveindex/ (*.yml) and data/cie/ (*.csv).
std::span<const EmbeddedFile> material_data();

} // namespace brdf::embedded
