// Writes the seed corpus of fuzz_rgl into a folder (tests/data/fuzz/rgl):
//   cmake --build BUILD --target rgl_make_fuzz_seeds && BUILD/bin/rgl_make_fuzz_seeds tests/data/fuzz/rgl
// Small valid files (RGB, spectral, built by make_rgl_bsdf, anisotropic with a symmetry reduction)
// and two broken ones (cut short, an empty field list), so that the fuzzer starts from every part
// of the reader and the evaluator.

#include "rgl_test_brdfs.h"
#include "rgl_test_files.h"

#include <formats/rgl/rgl_bsdf.h>
#include <formats/rgl/rgl_build.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>

namespace {

using namespace brdf;

std::string read(const std::filesystem::path& p) {
    std::string bytes(std::filesystem::file_size(p), '\0');
    std::ifstream(p, std::ios::binary).read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return bytes;
}

void write(const std::filesystem::path& p, const std::string& bytes) {
    std::ofstream(p, std::ios::binary) << bytes;
}

} // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::cerr << "usage: rgl_make_fuzz_seeds FOLDER\n";
        return 2;
    }
    const std::filesystem::path dir = argv[1];
    try {
        std::filesystem::create_directories(dir);
        formats::write_rgl_bsdf(dir / "small-rgb.rgl.bsdf", test::small_rgl_bsdf(false));
        formats::write_rgl_bsdf(dir / "small-spectral.rgl.bsdf", test::small_rgl_bsdf(true));

        formats::RglOptions o;
        o.theta_i_count = 2;
        o.sample_resolution = 4;
        o.vndf_theta_resolution = 6;
        o.vndf_phi_resolution = 6;
        o.ndf_resolution = 8;
        o.sigma_resolution = 8;
        o.description = "fuzz seed";
        formats::write_rgl_bsdf(dir / "glossy-built.rgl.bsdf",
                                formats::make_rgl_bsdf(
                                    test::rgl_test_brdf(test::RglTestModel::Glossy, {}), o));

        // Three incidence azimuths over half a turn: anisotropic with a 2-fold reduction.
        formats::RglBsdf a = test::small_rgl_bsdf(false);
        constexpr float pi = std::numbers::pi_v<float>;
        a.phi_i = {-pi, -pi / 2, 0.0f};
        for (formats::RglArray* f : {&a.vndf, &a.luminance, &a.values}) {
            f->shape[0] = 3;
            std::vector<float> v;
            for (int k = 0; k < 3; ++k) v.insert(v.end(), f->values.begin(), f->values.end());
            f->values = v;
        }
        formats::write_rgl_bsdf(dir / "anisotropic.rgl.bsdf", a);

        const std::string whole = read(dir / "small-rgb.rgl.bsdf");
        write(dir / "truncated.rgl.bsdf", whole.substr(0, whole.size() / 2));
        write(dir / "no-fields.rgl.bsdf", test::raw_tensor_header({}));
    } catch (const std::exception& e) {
        std::cerr << "rgl_make_fuzz_seeds: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
