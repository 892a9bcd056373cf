// Writes the small malformed tables checked in under tests/data/bad (see the README there), and with
// a second folder the Fourier and spectral OpenEXR fuzz seeds (tests/data/fuzz):
//   make_format_specimens <bad folder> [<fuzz seed folder>]
// The MERL and Fourier specimens are compared byte for byte with these definitions by the tests.

#include "format_test_util.h"

#include "test_support.h"

#include <cstdio>
#include <filesystem>

int main(int argc, char** argv) {
    if (argc != 2 && argc != 3) {
        std::fprintf(stderr, "usage: make_format_specimens BAD_FOLDER [FUZZ_SEED_FOLDER]\n");
        return 2;
    }
    const std::filesystem::path folder = argv[1];
    for (const brdf::test::MerlSpecimen& s : brdf::test::merl_specimens())
        brdf::test::write_file(folder / s.name, s.bytes);
    brdf::test::write_exr_specimens(folder);
    for (const brdf::test::MerlSpecimen& s : brdf::test::fourier_specimens())
        brdf::test::write_file(folder / s.name, s.bytes);
    if (argc == 3) brdf::test::write_fuzz_seeds(argv[2]);
    return 0;
}
