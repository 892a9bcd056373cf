#include "entry_points.h"

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/material/spec.h>
#include <formats/exr/exr.h>
#include <formats/exr/spectral_exr.h>
#include <formats/fourier/fourier.h>
#include <formats/merl/merl.h>
#include <formats/rgl/rgl_bsdf.h>
#include <formats/rgl/rgl_eval.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <unistd.h>

namespace brdf::fuzz {
namespace {

// One scratch file per process and extension, rewritten for each input and removed at exit: the
// readers take paths, and a fuzzer runs millions of inputs, so no per-input file is created.
class ScratchFile {
  public:
    explicit ScratchFile(const char* extension)
        : m_path(std::filesystem::temp_directory_path() /
                 ("brdf-fuzz-" + std::to_string(::getpid()) + extension)) {}
    ~ScratchFile() {
        std::error_code ec;
        std::filesystem::remove(m_path, ec);
    }
    ScratchFile(const ScratchFile&) = delete;
    ScratchFile& operator=(const ScratchFile&) = delete;

    const std::filesystem::path& write(const std::uint8_t* data, std::size_t size) {
        std::ofstream out(m_path, std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
        out.close();
        if (!out) throw std::runtime_error("fuzz: cannot write " + m_path.string());
        return m_path;
    }

  private:
    std::filesystem::path m_path;
};

} // namespace

void merl(const std::uint8_t* data, std::size_t size) {
    static ScratchFile file(".binary");
    formats::read_merl(file.write(data, size));
}

void exr(const std::uint8_t* data, std::size_t size) {
    static ScratchFile file(".exr");
    formats::read_exr(file.write(data, size));
}

void rgl(const std::uint8_t* data, std::size_t size) {
    static ScratchFile file(".rgl.bsdf");
    const formats::RglEvaluator evaluator(formats::read_rgl_bsdf(file.write(data, size)));
    const formats::Vec3 directions[] = {{0.0, 0.0, 1.0}, {0.6, 0.0, 0.8}, {-0.3, 0.4, 0.866},
                                        {0.999, 0.0, 0.0447}, {0.0, -0.6, 0.8}};
    for (const auto& wi : directions)
        for (const auto& wo : directions) {
            for (double v : evaluator.eval_cosine(wi, wo))
                if (std::isnan(v)) throw std::runtime_error("fuzz: the evaluator returned NaN");
        }
}

void fourier(const std::uint8_t* data, std::size_t size) {
    static ScratchFile file(".bsdf");
    const formats::FourierBsdf bsdf = formats::read_fourier_bsdf(file.write(data, size));
    // Directions on and between nodes, at the poles and below the horizon.
    for (double ti : {0.0, 0.3, 1.2, 1.5707963267948966, 2.0})
        for (double to : {0.0, 0.7, 1.4, 3.0})
            for (double phi : {0.0, 1.0, 3.14159})
                for (double v : formats::evaluate(bsdf, ti, to, phi))
                    if (!(v >= 0.0)) throw std::logic_error("fuzz: evaluate gave a negative or NaN value");
}

void spectral_exr(const std::uint8_t* data, std::size_t size) {
    static ScratchFile file(".spectral.exr");
    formats::read_spectral_exr(file.write(data, size));
}

void spec(const std::uint8_t* data, std::size_t size) {
    material::parse_specs_text(std::string_view(reinterpret_cast<const char*>(data), size),
                               "fuzz.json");
}

int run_expecting_error_or_success(void (*target)(const std::uint8_t*, std::size_t),
                                   const std::uint8_t* data, std::size_t size) {
    // Warnings about odd but valid input would flood the fuzzer's output.
    static const bool quiet = (log::set_level(log::Level::Error), true);
    (void)quiet;
    try {
        target(data, size);
    } catch (const brdf::Error&) {
        // Malformed input, refused with a message: what the readers are for.
    }
    return 0;
}

} // namespace brdf::fuzz
