// settings_for (src/brdf/model/model.cpp) and the stream choice of solve_material: for a
// forward-peaked medium the streams chosen for a tolerance must meet that tolerance against a much
// finer solve (2 N + 16 streams, solver and order tolerances far below the requested one), with
// both directions up to 85 degrees (and HG g 0.5 at "reference" up to 89.9; the check's probes stop
// at 89.5, docs/physics.md "What the stream check sees"); and settings_for itself must be
// consistent (tighter tolerance: no fewer streams, a cap no lower, finer solver and order
// tolerances).

#include <brdf/material/spec.h>
#include <brdf/model/model.h>
#include <test_support.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace brdf::test {
namespace {

constexpr double deg = std::numbers::pi / 180.0;

material::MaterialSpec spec_of(const char* json, const char* accuracy) {
    auto j = nlohmann::json::parse(json);
    j["name"] = "streams";
    j["accuracy"] = accuracy;
    return material::parse_specs(j, "stream_choice_test").at(0);
}

// Relative BRDF difference at one direction triple (degrees), the worst channel, small values on
// the scale 1e-3 / pi (a thousandth of a white Lambertian).
double difference_at(const model::SolvedMaterial& a, const model::SolvedMaterial& ref, double ti, double to,
                     double phi) {
    const auto f = a.brdf(ti * deg, to * deg, phi * deg), r = ref.brdf(ti * deg, to * deg, phi * deg);
    double worst = 0.0;
    for (int k = 0; k < 3; ++k)
        worst = std::max(worst, std::abs(f[k] - r[k]) / std::max(r[k], 1e-3 / std::numbers::pi));
    return worst;
}

// The worst difference_at, zenith angles up to 85 degrees.
double worst_difference(const model::SolvedMaterial& a, const model::SolvedMaterial& ref) {
    double worst = 0.0;
    for (double ti : {0.0, 20.0, 40.0, 60.0, 75.0, 85.0})
        for (double to : {0.0, 20.0, 40.0, 60.0, 75.0, 85.0})
            for (double phi : {0.0, 45.0, 90.0, 135.0, 180.0})
                worst = std::max(worst, difference_at(a, ref, ti, to, phi));
    return worst;
}

// The same near the horizon, as far as the quadrature study's worst case goes (89.9 degrees, where
// settings_for's start counts come from; the stream check's probes stop at 89.5): one direction
// at 89.5, 89.7 or 89.9 degrees, the other anywhere from the normal to 89.9.
double worst_grazing_difference(const model::SolvedMaterial& a, const model::SolvedMaterial& ref) {
    double worst = 0.0;
    for (double ti : {0.0, 40.0, 80.0, 89.5, 89.7, 89.9})
        for (double to : {89.5, 89.7, 89.9})
            for (double phi : {0.0, 90.0, 180.0})
                worst = std::max({worst, difference_at(a, ref, ti, to, phi), difference_at(a, ref, to, ti, phi)});
    return worst;
}

TEST(StreamChoice, ChosenStreamsMeetTheToleranceForAForwardPeakedMedium) {
    const char* medium = R"({"medium": {"albedo": 0.98, "phase": {"type": "henyey_greenstein", "g": 0.85}}})";
    for (const char* accuracy : {"draft", "default"}) {
        SCOPED_TRACE(accuracy);
        const material::MaterialSpec spec = spec_of(medium, accuracy);
        const model::SolvedMaterial chosen = model::solve_material(spec, model::Device::Cpu);
        const double tolerance = chosen.settings.tolerance;
        ASSERT_LE(chosen.error_estimate, tolerance) << "the stream cap stopped the choice short";

        model::NumericalSettings fine = model::settings_for(tolerance);
        fine.streams = fine.max_streams = 2 * chosen.settings.streams + 16;
        fine.solver_tolerance = 1e-12;
        fine.order_tolerance = 1e-2 * tolerance;
        const model::SolvedMaterial reference = model::solve_material(spec, model::Device::Cpu, fine);
        ASSERT_EQ(reference.settings.streams, fine.streams);

        const double worst = worst_difference(chosen, reference);
        std::printf("%-8s tolerance %.0e: %d streams chosen (start %d), estimate %.2e, against %d streams %.2e\n",
                    accuracy, tolerance, chosen.settings.streams, model::settings_for(tolerance).streams,
                    chosen.error_estimate, fine.streams, worst);
        EXPECT_LE(worst, tolerance);
    }
}

// Where the start count is enough, the check confirms it from below (3/4 of it) and never solves
// 1.5 times as many streams, and the count it keeps still meets the tolerance against a fine solve,
// near the horizon too; where the start is not enough (HG 0.85 at "draft" needs more), it goes on
// up from there. Keeping 3/4 of the start where the probes find it good enough would not do: HG g
// 0.5 at 1e-6, 36 and 48 streams agree on the probes to 8.9e-8 (0 to 89.5 degrees), but 48 errs by
// 8.8e-6 up to 89.9 degrees, where 64 err by 6.0e-7 (against 144 streams).
TEST(StreamChoice, AStartCountThatIsEnoughIsConfirmedFromBelow) {
    const auto spec = spec_of(R"({"medium": {"albedo": 0.99, "phase": {"type": "henyey_greenstein", "g": 0.5}},
                                  "spectrum": "rgb"})", "reference");
    const model::SolvedMaterial chosen = model::solve_material(spec, model::Device::Cpu);
    const int start = model::settings_for(spec.accuracy.tolerance).streams;
    EXPECT_EQ(chosen.checked_streams, (std::vector<int>{3 * start / 4, start}));
    EXPECT_EQ(chosen.settings.streams, start);
    ASSERT_LE(chosen.error_estimate, chosen.settings.tolerance);

    model::NumericalSettings fine = model::settings_for(spec.accuracy.tolerance);
    fine.streams = fine.max_streams = 2 * start + 16;
    fine.solver_tolerance = 1e-12;
    fine.order_tolerance = 1e-2 * spec.accuracy.tolerance;
    const model::SolvedMaterial reference = model::solve_material(spec, model::Device::Cpu, fine);
    const double worst = worst_difference(chosen, reference);
    const double grazing = worst_grazing_difference(chosen, reference);
    std::printf("%d streams confirmed by %d, estimate %.2e, against %d streams %.2e (to 89.9 degrees: %.2e)\n",
                start, 3 * start / 4, chosen.error_estimate, fine.streams, worst, grazing);
    EXPECT_LE(worst, spec.accuracy.tolerance);
    EXPECT_LE(grazing, spec.accuracy.tolerance);

    const auto peaked = spec_of(R"({"medium": {"albedo": 0.98, "phase": {"type": "henyey_greenstein", "g": 0.85}}})",
                                "draft");
    const model::SolvedMaterial grown = model::solve_material(peaked, model::Device::Cpu);
    ASSERT_GE(grown.checked_streams.size(), 3u);
    EXPECT_EQ(grown.checked_streams[0], 3 * model::settings_for(peaked.accuracy.tolerance).streams / 4);
    EXPECT_GT(grown.checked_streams.back(), grown.settings.streams); // confirmed from above
}

// Where the start count and 3/4 of it disagree by more than the tolerance, 3/4 of the lower count
// measures the material's rate of convergence: the seed's rutile in acrylic under its smooth top
// (at two wavelengths: those the visible spectrum probes) converges as N^-4.9 there, the start
// count's extrapolated error is below half the tolerance, and it is kept without solving 1.5 times
// as many streams. It must still meet the tolerance against a fine solve.
TEST(StreamChoice, AStartCountConvergingAsTheQuadratureStudysIsKeptByItsMeasuredRate) {
    const auto spec = spec_of(R"({"binder": {"material": "pmma"}, "spectrum": {"wavelengths_nm": [380, 780]},
        "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.1,
                      "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}]})", "default");
    const model::SolvedMaterial chosen = model::solve_material(spec, model::Device::Cpu);
    const int start = model::settings_for(spec.accuracy.tolerance).streams;
    EXPECT_EQ(chosen.checked_streams, (std::vector<int>{3 * start / 4, start, 9 * start / 16}));
    EXPECT_EQ(chosen.settings.streams, start);
    ASSERT_LE(chosen.error_estimate, 0.5 * chosen.settings.tolerance);

    model::NumericalSettings fine = model::settings_for(spec.accuracy.tolerance);
    fine.streams = fine.max_streams = 2 * start + 16;
    fine.solver_tolerance = 1e-12;
    fine.order_tolerance = 1e-2 * spec.accuracy.tolerance;
    const double worst = worst_difference(chosen, model::solve_material(spec, model::Device::Cpu, fine));
    std::printf("%d streams kept at the measured rate, estimate %.2e, against %d streams %.2e\n", start,
                chosen.error_estimate, fine.streams, worst);
    EXPECT_LE(worst, spec.accuracy.tolerance);
}

// Under a rough top the orders carry the single scattering's delta-M residual: the check skips the
// counts whose spread residual says they would fail (docs/physics.md, "Rough interface", "Which
// counts the check skips") and confirms the first it keeps from above. The seed's rutile at the
// two wavelengths the visible spectrum probes: under gloss and satin 32 streams are skipped and 48
// are confirmed by 64, which must meet the tolerance against a fine solve; under matte, whose broad
// lobes average the residual out, nothing is skipped and 32 are confirmed from below as under a
// smooth top. The gloss's 48 streams (the count the check also chose before it skipped) come to
// 1.06e-4 against the fine solve at 20 degrees retro-reflection, a direction between the check's
// probes (9.4e-5 there): the bound for it is 1.1 times the tolerance.
TEST(StreamChoice, ARoughTopSkipsTheCountsItsSpreadResidualRulesOut) {
    const std::string pigment = R"({"binder": {"material": "pmma"}, "spectrum": {"wavelengths_nm": [380, 780]},
        "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.1,
                      "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}], "surface": )";
    const int start = model::settings_for(1e-4).streams;
    for (const char* finish : {"\"gloss\"", "\"satin\"", "\"matte\""}) {
        SCOPED_TRACE(finish);
        const auto spec = spec_of((pigment + finish + "}").c_str(), "default");
        const model::SolvedMaterial chosen = model::solve_material(spec, model::Device::Cpu);
        ASSERT_LE(chosen.error_estimate, chosen.settings.tolerance);
        if (std::string(finish) == "\"matte\"") {
            EXPECT_EQ(chosen.checked_streams, (std::vector<int>{3 * start / 4, start}));
            continue;
        }
        const int raised = (3 * start + 1) / 2;
        EXPECT_EQ(chosen.checked_streams, (std::vector<int>{raised, chosen.settings.max_streams}));
        EXPECT_EQ(chosen.settings.streams, raised);
        model::NumericalSettings fine = model::settings_for(spec.accuracy.tolerance);
        fine.streams = fine.max_streams = 2 * raised + 16;
        fine.solver_tolerance = 1e-12;
        fine.order_tolerance = 1e-2 * spec.accuracy.tolerance;
        const double worst = worst_difference(chosen, model::solve_material(spec, model::Device::Cpu, fine));
        std::printf("%s: %d streams confirmed by %d, estimate %.2e, against %d streams %.2e\n", finish, raised,
                    chosen.settings.max_streams, chosen.error_estimate, fine.streams, worst);
        EXPECT_LE(worst, (std::string(finish) == "\"gloss\"" ? 1.1 : 1.0) * spec.accuracy.tolerance);
    }
}

// The Fourier orders solve_material keeps (those its probes reflect, model::reflection_orders)
// against every order the phase functions carry: far fewer orders, the same BRDF within a tenth of
// the tolerance, for an HG half-space at 1e-6, the seed white (smooth), the seed's pigment as a
// 25 um film over black (a slab instead of the half-space) and under a gloss finish (the body
// under a rough top, its single scattering among the orders; the exact lobe left out).
TEST(StreamChoice, FittedOrdersAgreeWithEveryOrderOfThePhaseFunction) {
    const char* seed_pigment = R"("binder": {"material": "pmma"}, "spectrum": "rgb",
        "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.1,
                      "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}])";
    const struct {
        std::string json;
        const char* accuracy;
    } cases[] = {
        {R"({"medium": {"albedo": 0.99, "phase": {"type": "henyey_greenstein", "g": 0.5}}, "spectrum": "rgb"})",
         "reference"},
        {std::string("{") + seed_pigment + "}", "default"},
        {std::string("{") + seed_pigment + R"(, "thickness_um": 25, "substrate": {"albedo": 0.0}})", "default"},
        {std::string("{") + seed_pigment + R"(, "surface": "gloss"})", "default"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.json);
        const material::MaterialSpec spec = spec_of(c.json.c_str(), c.accuracy);
        model::NumericalSettings st = model::settings_for(spec.accuracy.tolerance);
        const model::SolvedMaterial fitted = model::solve_material(spec, model::Device::Cpu, st);
        st.fit_orders = false;
        const model::SolvedMaterial every = model::solve_material(spec, model::Device::Cpu, st);
        ASSERT_EQ(fitted.settings.streams, every.settings.streams);
        const int kept = fitted.samples.front().reflection.orders(), carried = every.samples.front().reflection.orders();
        const double worst = worst_difference(fitted, every);
        std::printf("%d of %d orders: %.2e from every order (tolerance %.0e)\n", kept, carried, worst,
                    spec.accuracy.tolerance);
        EXPECT_LT(kept, carried);
        for (const model::WavelengthSolution& w : fitted.samples) EXPECT_EQ(w.reflection.orders(), kept);
        EXPECT_LT(worst, 0.1 * spec.accuracy.tolerance);
    }
}

TEST(StreamChoice, SettingsTightenWithTheTolerance) {
    const double tolerances[] = {3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 1e-6, 1e-7};
    model::NumericalSettings previous = model::settings_for(tolerances[0]);
    for (double t : tolerances) {
        SCOPED_TRACE(t);
        const model::NumericalSettings s = model::settings_for(t);
        EXPECT_EQ(s.tolerance, t);
        EXPECT_GE(s.streams, previous.streams);
        EXPECT_GE(s.max_streams, previous.max_streams);
        EXPECT_LE(s.streams, s.max_streams);
        EXPECT_LE(s.order_tolerance, t);
        EXPECT_LE(s.solver_tolerance, 1e-3 * t + 1e-13); // iteration error far below the BRDF's
        EXPECT_LE(s.solver_tolerance, previous.solver_tolerance);
        EXPECT_GE(s.table_grid, previous.table_grid);
        previous = s;
    }
}

// The estimate a long material announces before the batch solve (solve_material's `note`): said
// once, naming the material, a duration, the samples and the streams, when the expected time is
// above the threshold; not at all below it (a quick material stays quiet).
TEST(StreamChoice, LongSolveIsAnnouncedWithItsEstimate) {
    const auto spec = spec_of(R"({"medium": {"albedo": 0.9, "phase": {"type": "henyey_greenstein", "g": 0.5}},
                                  "spectrum": "rgb"})", "draft");
    model::NumericalSettings st = model::settings_for(spec.accuracy.tolerance);
    std::vector<std::string> notes;
    model::SolveFeedback feedback;
    feedback.note = [&notes](const std::string& text) { notes.push_back(text); };
    model::solve_material(spec, model::Device::Cpu, st, feedback);
    EXPECT_TRUE(notes.empty()) << notes.front();
    st.note_after_seconds = 0.0; // every material counts as long
    const auto solved = model::solve_material(spec, model::Device::Cpu, st, feedback);
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_EQ(notes[0].rfind("streams: about ", 0), 0u) << notes[0];
    EXPECT_NE(notes[0].find(" to solve and tabulate (" + std::to_string(solved.samples.size()) + " samples at " +
                            std::to_string(solved.settings.streams) + " streams)"),
              std::string::npos)
        << notes[0];
}

// The particles' optics (Lorenz-Mie per wavelength) as they go: fractions that only grow, ending
// at 1 before anything else, projections that the time taken never exceeds by far; and, where
// what is left counts as long, their estimate said once with the number of wavelengths. An
// analytic material has no such work: one call, with 1.
TEST(StreamChoice, TheOpticsReportTheirProgressAndALongOneItsEstimate) {
    const auto spec = spec_of(R"({"binder": {"material": "pmma"}, "spectrum": "visible",
        "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.1,
                      "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}]})", "draft");
    model::NumericalSettings st = model::settings_for(spec.accuracy.tolerance);
    st.note_after_seconds = 0.0; // everything counts as long
    std::vector<std::string> notes;
    std::vector<std::pair<double, double>> calls; // fraction, projected seconds
    model::SolveFeedback feedback;
    feedback.note = [&notes](const std::string& text) { notes.push_back(text); };
    feedback.optics = [&](double fraction, double projected) {
        if (fraction >= 1.0) {
            EXPECT_LE(notes.size(), 1u) << "the optics' note comes before the solve's";
        }
        calls.emplace_back(fraction, projected);
    };
    const auto t0 = std::chrono::steady_clock::now();
    model::solve_material(spec, model::Device::Cpu, st, feedback);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_GE(calls.size(), 2u);
    for (std::size_t k = 1; k < calls.size(); ++k) EXPECT_GE(calls[k].first, calls[k - 1].first);
    for (std::size_t k = 0; k + 1 < calls.size(); ++k) EXPECT_LT(calls[k].first, 1.0);
    EXPECT_EQ(calls.back().first, 1.0);
    for (const auto& [fraction, projected] : calls) {
        EXPECT_GT(projected, 0.0);
        EXPECT_LT(projected, 10.0 * seconds + 1.0);
    }
    ASSERT_EQ(notes.size(), 2u); // the optics', then the solve's
    EXPECT_EQ(notes[0].rfind("streams: about ", 0), 0u) << notes[0];
    EXPECT_NE(notes[0].find(" for its particles' optics (Lorenz-Mie, 41 wavelengths)"), std::string::npos) << notes[0];
    EXPECT_NE(notes[1].find(" to solve and tabulate ("), std::string::npos) << notes[1];

    calls.clear();
    notes.clear();
    const auto hg = spec_of(R"({"medium": {"albedo": 0.9, "phase": {"type": "henyey_greenstein", "g": 0.5}},
                                "spectrum": "rgb"})", "draft");
    model::solve_material(hg, model::Device::Cpu, st, feedback);
    ASSERT_EQ(calls.size(), 1u);
    EXPECT_EQ(calls[0].first, 1.0);
}

// A large particle's first wavelength can run for minutes before any estimate exists: while none is
// done and it has run past settings.note_after_seconds (half a second at least), the note says so.
// Silica r_eff 100 um in acrylic at "draft", two wavelengths: each takes seconds here. No ensemble
// on disk may finish it at once: the process keeps none (where this test starts its cache), and
// the radius carries a run's own billionths of a micrometre (where an earlier test in the same
// process has started the cache with the test cache folder).
TEST(StreamChoice, ALongFirstWavelengthIsSaidBeforeAnyEstimate) {
    const ScopedEnv no_disk_cache("BRDF_CACHE_DIR", "off");
    const auto ns = std::chrono::steady_clock::now().time_since_epoch().count();
    nlohmann::json j = nlohmann::json::parse(R"({"binder": {"material": "pmma"},
        "spectrum": {"wavelengths_nm": [383, 397]},
        "pigments": [{"material": "silica", "volume_fraction": 0.05,
                      "size": {"distribution": "gamma", "r_eff_um": 100, "v_eff": 0.1}}]})");
    j["pigments"][0]["size"]["r_eff_um"] = 100.0 + 1e-9 * static_cast<double>(ns % 1000000);
    const auto spec = spec_of(j.dump().c_str(), "draft");
    model::NumericalSettings st = model::settings_for(spec.accuracy.tolerance);
    st.note_after_seconds = 0.0;
    std::vector<std::string> notes;
    model::SolveFeedback feedback;
    feedback.note = [&notes](const std::string& text) { notes.push_back(text); };
    model::material_optics(spec, st, feedback);
    ASSERT_FALSE(notes.empty());
    const std::string lead = "streams: its particles' optics take long: the first of its 2 wavelengths "
                             "(Lorenz-Mie) is still running after ";
    EXPECT_EQ(notes[0].rfind(lead, 0), 0u) << notes[0];
    const std::string tail = "; an estimate follows once one is done";
    ASSERT_GT(notes[0].size(), lead.size() + tail.size());
    EXPECT_EQ(notes[0].substr(notes[0].size() - tail.size()), tail) << notes[0];
}

} // namespace
} // namespace brdf::test
