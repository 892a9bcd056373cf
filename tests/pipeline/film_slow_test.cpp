// The slow part of the film tests (label "slow"): DISORT's forward-peaked films (HG 0.9: about 60
// streams and 100 Fourier orders each) at the default accuracy, and films at the reference accuracy.

#include "film_support.h"

namespace brdf::test {
namespace {

class DisortPeakedFilm : public ::testing::TestWithParam<std::string> {};

TEST_P(DisortPeakedFilm, MatchesDisortAtDefaultAccuracy) {
    const json c = disort_case(GetParam());
    const model::SolvedMaterial m = model::solve_material(spec_from(disort_spec(c, "default")), model::Device::Cpu);
    EXPECT_LT(worst_relative(m, c.at("values")), 1e-4) << GetParam();
}

INSTANTIATE_TEST_SUITE_P(Cases, DisortPeakedFilm, ::testing::ValuesIn(disort_labels("hg0.9")), label_name);

TEST(DisortFilmReference, MatchesDisortAtReferenceAccuracy) {
    // g = 0.5: the reference accuracy (1e-6) within a test's budget; g = 0.9 runs in the slow suite.
    for (const std::string label : {"hg0.5-omega0.9-tau1-floor0", "hg0.5-omega1-tau10-floor0.5",
                                    "hg0.5-omega0.9-tau0.1-floor0.5"}) {
        const json c = disort_case(label);
        const model::SolvedMaterial m = model::solve_material(spec_from(disort_spec(c, "reference")), model::Device::Cpu);
        EXPECT_LT(worst_relative(m, c.at("values")), 1e-6) << label;
    }
}

} // namespace
} // namespace brdf::test
