// The compute pipeline end to end: spec -> solve -> table -> files, and the table's agreement with
// the exactly evaluated model (eval on a spec).

#include <brdf/material/spec.h>
#include <brdf/service/compute.h>
#include <brdf/model/model.h>
#include <brdf/model/optics.h>
#include <brdf/model/table_fill.h>
#include <brdf/preview/preview.h>
#include <formats/halfdiff.h>
#include <formats/table_io.h>
#include <test_support.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <limits>
#include <random>
#include <span>
#include <vector>

namespace brdf::test {
namespace {

material::MaterialSpec spec_from(const std::string& text) {
    return material::parse_specs_text(text, "test.json").at(0);
}

const char* hg_medium = R"({"name": "hg", "medium": {"albedo": [0.99, 0.8, 0.4],
    "phase": {"type": "henyey_greenstein", "g": 0.6}}, "accuracy": "draft"})";

// The seed white (rutile, power law r_eff 0.4 um, v_eff 0.3, 10 % in PMMA) with the spec keys
// `keys` added (e.g. "spectrum": "visible"), solved by the C++ reference.
model::SolvedMaterial solve_seed_white(const std::string& keys) {
    return model::solve_material(spec_from(R"({"name": "w", "binder": {"material": "pmma"},
        "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.1,
                      "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}], )" +
                                           keys + "}"),
                                 model::Device::Cpu);
}

// Bin-centre directions of a cell (theta_i, theta_o, phi).
struct CellDirections {
    double ti, to, phi;
};
CellDirections cell_directions(std::size_t cell) {
    const auto ix = formats::cell_indices(cell);
    const auto d = formats::to_directions(formats::theta_h_centre(ix.theta_h), formats::theta_d_centre(ix.theta_d),
                                          formats::phi_d_centre(ix.phi_d));
    return {std::acos(std::clamp(d.wi.z, -1.0, 1.0)), std::acos(std::clamp(d.wo.z, -1.0, 1.0)),
            std::atan2(d.wo.y, d.wo.x) - std::atan2(d.wi.y, d.wi.x)};
}

// Largest relative difference between the fill and the model over 300 random cells above the
// horizon (`seed` picks them) with a direction at least `zenith` radians from the normal, relative
// to max(value, floor).
double worst_cells_against_model(const model::SolvedMaterial& m, const model::FillInputs& in, unsigned seed,
                                 double zenith = 0.0, double floor = 0.0) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::size_t> pick(0, formats::cells - 1);
    double worst = 0.0;
    for (int checked = 0; checked < 300;) {
        const std::size_t cell = pick(rng);
        if (formats::cell_below_horizon(cell)) continue;
        const CellDirections c = cell_directions(cell);
        if (std::max(c.ti, c.to) < zenith) continue;
        const auto table = model::fill_value(in, c.ti, c.to, c.phi);
        const auto exact = m.brdf(c.ti, c.to, c.phi);
        for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(table[k] - exact[k]) / std::max(exact[k], floor));
        ++checked;
    }
    return worst;
}

TEST(Pipeline, TableCellsMatchTheModelAtTheirBinCentres) {
    const model::SolvedMaterial m = model::solve_material(spec_from(hg_medium), model::Device::Cpu);
    // Catmull-Rom on the draft's 46 zenith nodes (2 degrees apart in acos(sqrt(mu))), every cell up
    // to the horizon: well below a percent.
    EXPECT_LT(worst_cells_against_model(m, model::prepare_fill(m), 7), 5e-3);
}

// Under a rough surface the table holds the whole BRDF: the body interpolated as for a smooth one,
// the first-surface lobe exact per cell. So the cells agree with eval to the body's interpolation
// accuracy everywhere, and the lobe alone (the fill without its Fourier part) is the closed form
// (Reflection::surface_lobe, weighted like eval) to the Fresnel table's ~1e-10, also at the
// peak cells, where theta_h is a few hundredths of a degree and the lobe dominates.
void expect_rough_table_matches_model(const char* spec) {
    const model::SolvedMaterial m = model::solve_material(spec_from(spec), model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    ASSERT_NE(in.lobe, model::FillInputs::Lobe::None);
    const double worst = worst_cells_against_model(m, in, 7);
    std::printf("rough table vs eval at 300 bin centres: worst relative %.2e\n", worst);
    EXPECT_LT(worst, 5e-3);

    model::FillInputs lobe_only = in;
    lobe_only.orders = 0;
    lobe_only.fourier.clear();
    double worst_lobe = 0.0, peak = 0.0;
    for (int h = 0; h < 4; ++h)
        for (int d = 0; d < formats::theta_d_bins; d += 3)
            for (int p = 0; p < formats::phi_d_bins; p += 15) {
                const std::size_t cell = (static_cast<std::size_t>(h) * formats::theta_d_bins + d) * formats::phi_d_bins + p;
                if (formats::cell_below_horizon(cell)) continue;
                const CellDirections c = cell_directions(cell);
                const auto table = model::fill_value(lobe_only, c.ti, c.to, c.phi);
                model::Rgb exact{0.0, 0.0, 0.0};
                for (const model::WavelengthSolution& s : m.samples)
                    for (int k = 0; k < 3; ++k)
                        exact[k] += s.weight[k] * s.reflection.surface_lobe(std::cos(c.ti), std::cos(c.to), c.phi);
                for (int k = 0; k < 3; ++k) {
                    ASSERT_GT(exact[k], 0.0);
                    worst_lobe = std::max(worst_lobe, std::abs(table[k] - exact[k]) / exact[k]);
                    peak = std::max(peak, exact[k]);
                }
            }
    std::printf("lobe at the peak cells: worst relative %.2e (largest value %.4g 1/sr)\n", worst_lobe, peak);
    EXPECT_LT(worst_lobe, 1e-6);
}

// The cells within 4 degrees of the horizon on their own: one per cent of a table's cells have a
// direction beyond 89.5 degrees, down to 89.9998. Under a smooth top the body
// falls linearly in mu there, and without an interface Chandrasekhar's H functions go as mu log mu:
// on a grid uniform in the zenith angle such a function has a corner at the horizon, and the cells
// beside it erred by up to half their value (the seed white at "default": 50 % at 89.98 degrees,
// 5 % at 89.3; an HG half-space 6e-3). On the grid uniform in acos(sqrt(mu)) (model::
// zenith_grid_cosine) they are even about the horizon and the cubic follows them.
double worst_near_the_horizon(const model::SolvedMaterial& m) {
    return worst_cells_against_model(m, model::prepare_fill(m), 11, 86.0 * std::numbers::pi / 180.0,
                                     1e-3 / std::numbers::pi);
}

TEST(PipelineTable, CellsNearTheHorizonMatchTheModel) {
    const double seed = worst_near_the_horizon(solve_seed_white(R"("spectrum": "rgb")"));
    const double hg = worst_near_the_horizon(model::solve_material(spec_from(hg_medium), model::Device::Cpu));
    std::printf("cells beyond 86 degrees against the model: seed white %.2e, HG half-space (draft) %.2e\n", seed, hg);
    EXPECT_LT(seed, 5e-3);
    EXPECT_LT(hg, 1e-3);
}

// Near the normal Fourier order m goes as sin^m of the zenith angle: the tap before the first node
// is node 1 mirrored, times (-1)^m. With the first node standing in for it, as before, the odd
// orders erred between the first nodes: an HG half-space at "reference" 7e-5 within a degree of
// the normal where its tolerance is 1e-6 (2.7e-7 now); this draft medium 1.1e-3 (5.3e-6 now).
TEST(PipelineTable, OrdersNearTheNormalKeepTheirParity) {
    const model::SolvedMaterial m = model::solve_material(spec_from(hg_medium), model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    constexpr double deg = std::numbers::pi / 180.0;
    double worst = 0.0;
    for (double ti : {0.2, 0.7, 1.5, 2.5})
        for (double to : {30.0, 60.0, 85.0})
            for (double phi : {0.0, 90.0, 180.0}) {
                const auto table = model::fill_value(in, ti * deg, to * deg, phi * deg);
                const auto exact = m.brdf(ti * deg, to * deg, phi * deg);
                for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(table[k] - exact[k]) / exact[k]);
            }
    std::printf("within 2.5 degrees of the normal: worst relative %.2e\n", worst);
    EXPECT_LT(worst, 1e-4);
}

TEST(PipelineRough, GlossPaintTableCellsMatchTheModel) {
    expect_rough_table_matches_model(R"({"name": "w", "binder": {"material": "pmma"},
        "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.1,
                      "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}],
        "surface": "gloss", "spectrum": "rgb", "accuracy": "draft"})");
}

TEST(PipelineRough, BeckmannMediumTableCellsMatchTheModel) {
    expect_rough_table_matches_model(R"({"name": "b", "medium": {"albedo": [0.99, 0.8, 0.4], "index": 1.5,
        "phase": {"type": "henyey_greenstein", "g": 0.6}},
        "surface": {"roughness": 0.2, "distribution": "beckmann"}, "accuracy": "draft"})");
}

// A material's wavelengths under one rough top share the interface's kernels, interpolated in the
// binder's index (rte/rough_family.h): the batch's BRDFs agree with each stack solved alone (no
// family: a batch of one) well within the kernels' tolerance, over PMMA's range across the visible
// (measured 1.9e-6 at tolerance 1e-4: mostly the quadratures' own differences from one index to
// the next at that tolerance; the interpolation alone is below 1e-8, tests/rte/rough_family_test);
// stacks of one index (an analytic material's channels) share them exactly.
TEST(PipelineRough, SharedKernelsMatchEachWavelengthSolvedAlone) {
    rte::ReflectionSettings rs;
    rs.streams = 32;
    rs.order_tolerance = 1e-5; // "default"
    rs.control.tolerance = 1e-10;
    std::vector<double> beta(200);
    for (int l = 0; l < 200; ++l) beta[static_cast<std::size_t>(l)] = (2.0 * l + 1.0) * std::pow(0.6, l);
    const auto stacks_of = [&](std::initializer_list<double> indices) {
        std::vector<rte::Stack> out;
        for (double n : indices) {
            rte::Stack s;
            s.top = rte::Top::Rough;
            s.rough = rte::RoughSurface{0.03, rte::Microfacet::Ggx, rte::Masking::HeightCorrelated};
            s.layers.push_back(rte::Layer{rte::Medium{0.99, beta}, std::numeric_limits<double>::infinity(), n});
            out.push_back(s);
        }
        return out;
    };
    const double mus[] = {1.0, 0.7071, 0.2588, 0.0872, 0.0087};
    const double phis[] = {0.0, 0.5 * std::numbers::pi, std::numbers::pi};
    const auto worst_difference = [&](const std::vector<rte::Stack>& stacks) {
        const std::vector<rte::Reflection> batch = model::solve_stacks(stacks, rs, model::Device::Cpu);
        double worst = 0.0;
        for (std::size_t k = 0; k < stacks.size(); ++k) {
            const std::vector<rte::Reflection> alone =
                model::solve_stacks(std::span<const rte::Stack>(&stacks[k], 1), rs, model::Device::Cpu);
            const std::vector<double> x = batch[k].brdf_grid(mus, phis, false);
            const std::vector<double> y = alone[0].brdf_grid(mus, phis, false);
            double largest = 0.0;
            for (double v : y) largest = std::max(largest, v);
            for (std::size_t j = 0; j < x.size(); ++j) worst = std::max(worst, std::abs(x[j] - y[j]) / largest);
        }
        return worst;
    };
    const double dispersing = worst_difference(stacks_of({1.4847, 1.4861, 1.4880, 1.4903, 1.4931, 1.4966, 1.5009,
                                                          1.5061, 1.5108}));
    const double one_index = worst_difference(stacks_of({1.5, 1.5, 1.5}));
    std::printf("batch against alone: dispersing %.2e, one index %.2e\n", dispersing, one_index);
    EXPECT_LT(dispersing, 0.05 * rte::rough_kernel_tolerance(rs.order_tolerance));
    EXPECT_LT(one_index, 1e-12);
}

// The stream check's probes, solved at the count it settles on, are kept for the material instead
// of being solved again in the batch: every sample must be exactly what the batch makes of its
// stack (each order problem is solved on its own, whatever else is in a batch).
TEST(PipelineSpectral, SamplesKeptFromTheStreamCheckEqualTheBatchSolve) {
    const model::SolvedMaterial m = solve_seed_white(R"("spectrum": "visible")");
    rte::ReflectionSettings rs;
    rs.streams = m.settings.streams;
    rs.order_tolerance = m.settings.order_tolerance;
    rs.max_orders = m.samples.front().reflection.orders(); // fitted to the probes (reflection_orders)
    rs.method = m.settings.method;
    rs.control.tolerance = m.settings.solver_tolerance;
    std::vector<rte::Stack> stacks;
    for (const model::WavelengthSolution& s : m.samples) stacks.push_back(model::make_stack(s.optics, m.spec.surface));
    const std::vector<rte::Reflection> batch = model::solve_stacks(stacks, rs, model::Device::Cpu);
    const double mus[] = {1.0, 0.6, 0.1};
    const double phis[] = {0.0, 2.0};
    for (std::size_t k = 0; k < stacks.size(); ++k) {
        EXPECT_EQ(m.samples[k].reflection.setup().layers.front().streams.size(), batch[k].setup().layers.front().streams.size());
        EXPECT_EQ(m.samples[k].reflection.brdf_grid(mus, phis, false), batch[k].brdf_grid(mus, phis, false))
            << "sample " << k << " (" << m.samples[k].wavelength_nm << " nm)";
    }
}

// The table fill's single scattering, shared by a dispersing material's wavelengths (a few index
// nodes instead of one term per wavelength), against each wavelength's exact term
// (rte::single_scattering, no tables) summed with its colour weights, in directions off the
// fill's probe set; relative to the sum with absolute weights, as the fill judges it. Every
// wavelength of the spectrum: the solved samples with their single_weight and the ones whose
// single scattering alone is exact (single_only). The largest difference found is returned.
double shared_single_scattering_error(const model::SolvedMaterial& m) {
    model::FillInputs in = model::prepare_fill(m);
    std::vector<std::pair<const rte::StackSetup*, model::Rgb>> wavelengths;
    for (const model::WavelengthSolution& s : m.samples) wavelengths.emplace_back(&s.reflection.setup(), s.single_weight);
    for (const model::SingleScatteringSample& u : m.single_only) wavelengths.emplace_back(&u.setup, u.weight);
    std::printf("%zu wavelengths (%zu solved), %d single-scattering terms\n", wavelengths.size(), m.samples.size(),
                in.samples);
    EXPECT_GE(in.samples, 3);
    EXPECT_LE(2 * static_cast<std::size_t>(in.samples), wavelengths.size());
    in.orders = 0; // the single scattering alone
    in.fourier.clear();
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> zenith(0.0, 89.9), azimuth(0.0, 180.0);
    double worst = 0.0;
    for (int k = 0; k < 400; ++k) {
        const double ti = zenith(rng) * std::numbers::pi / 180.0, to = zenith(rng) * std::numbers::pi / 180.0;
        const double phi = azimuth(rng) * std::numbers::pi / 180.0;
        model::Rgb exact{}, scale{};
        for (const auto& [setup, weight] : wavelengths) {
            const double v = rte::single_scattering(*setup, std::cos(to), std::cos(ti), phi) * std::numbers::inv_pi;
            for (int c = 0; c < 3; ++c) exact[c] += weight[c] * v, scale[c] += std::abs(weight[c]) * v;
        }
        const model::Rgb table = model::fill_value(in, ti, to, phi);
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(table[c] - std::max(0.0, exact[c])) / scale[c]);
    }
    std::printf("shared single scattering against each wavelength's exact term: %.2e\n", worst);
    return worst;
}

TEST(PipelineTable, SingleScatteringSharedByTheWavelengthsMatchesEachExactly) {
    // The fill keeps the sharing within 1 % of the tolerance (1e-4) on its probe set (measured:
    // 3.1e-7 here with 4 index nodes, 1.4e-8 with 5; the tables' own interpolation 1e-9).
    EXPECT_LT(shared_single_scattering_error(solve_seed_white(R"("spectrum": "visible")")), 1e-6);
}

// A matting agent's spheres scatter through ripples in angle that move with the binder's index:
// its 41 wavelengths need ten index nodes, more than the sharing found before two
// Chebyshev-Lobatto points could share a sample (it kept 41 terms then). The single scattering
// does not depend on the stream count: solved at 16 streams, the check off. Only 11 of its
// wavelengths are solved; the single scattering of all 41 is in the fill.
TEST(PipelineTable, MattingAgentsWavelengthsShareTheirSingleScattering) {
    const auto spec = spec_from(R"({"name": "silica", "binder": {"material": "pmma"}, "spectrum": "visible",
        "pigments": [{"material": "silica", "volume_fraction": 0.05,
                      "size": {"distribution": "gamma", "r_eff_um": 5, "v_eff": 0.1}}]})");
    model::NumericalSettings st = model::settings_for(spec.accuracy.tolerance);
    st.streams = st.max_streams = 16;
    EXPECT_LT(shared_single_scattering_error(model::solve_material(spec, model::Device::Cpu, st)), 1e-6);
}

// The Mie integration checks what the tables read (model.cpp, mie_accuracy; docs/mie.md): a smooth
// paint's 40 um matting agent stops at half the radius nodes of the same paint under a rough top,
// whose wavelength selection compares the phase functions at every angle and so checks every
// moment; the moments the smooth paint's solver reads agree within the Mie tolerance.
TEST(Pipeline, MieChecksWhatTheTablesRead) {
    const auto spec = [](const std::string& surface) {
        return spec_from(R"({"name": "silica", "binder": {"material": "pmma"}, "spectrum": {"wavelengths_nm": [550]},
            "surface": ")" + surface + R"(", "pigments": [{"material": "silica", "volume_fraction": 0.05,
            "size": {"distribution": "gamma", "r_eff_um": 40, "v_eff": 0.1}}]})");
    };
    const material::MaterialSpec smooth = spec("smooth"), rough = spec("gloss");
    const model::NumericalSettings st = model::settings_for(smooth.accuracy.tolerance);
    const model::LayerOptics a = model::material_optics(smooth, st).optics.at(0).top();
    const model::LayerOptics b = model::material_optics(rough, st).optics.at(0).top();
    EXPECT_LE(2 * a.pigments.at(0).radius_nodes - 1, b.pigments.at(0).radius_nodes);
    for (int l = 0; l <= 2 * st.max_streams; ++l)
        EXPECT_NEAR(a.medium.beta.at(l) / (2 * l + 1), b.medium.beta.at(l) / (2 * l + 1), st.mie_tolerance)
            << "l = " << l;
}

// A film whose slab factor 1 - exp(-tau (1/u_o + 1/u_i)) is 1 to within 1 % of the tolerance
// (the seed's rutile, 25 um: tau 11-14, exp(-2 tau) <= 1.3e-10) scatters once as a half-space:
// its wavelengths share their terms on index nodes (it kept one per wavelength, 41, before), and
// the shared terms still match each wavelength's exact slab term.
TEST(PipelineTable, AnOpaqueFilmsWavelengthsShareTheirSingleScattering) {
    const auto spec = spec_from(R"({"name": "film", "binder": {"material": "pmma"}, "spectrum": "visible",
        "thickness_um": 25, "substrate": {"albedo": 0.0},
        "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.1,
                      "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}]})");
    model::NumericalSettings st = model::settings_for(spec.accuracy.tolerance);
    st.streams = st.max_streams = 16;
    EXPECT_LT(shared_single_scattering_error(model::solve_material(spec, model::Device::Cpu, st)), 1e-6);
}

// The same matting agent at "default" (64 streams, the count its stream check ends at): white and
// non-absorbing, its diffuse albedo + mirror is 1 to the solve's error (1e-11) at every wavelength.
// That is no colour for the gamut fit to scale: it did, by 0.47, and warned of a colour outside
// Rec.709.
TEST(PipelineTable, AWhiteMattingAgentIsNotOutOfGamut) {
    const auto spec =
        spec_from(R"({"name": "silica", "binder": {"material": "pmma"}, "spectrum": "visible",
        "pigments": [{"material": "silica", "volume_fraction": 0.05,
                      "size": {"distribution": "gamma", "r_eff_um": 5, "v_eff": 0.1}}]})");
    model::NumericalSettings st = model::settings_for(spec.accuracy.tolerance);
    st.streams = st.max_streams = 64;
    const model::SolvedMaterial m = model::solve_material(spec, model::Device::Cpu, st);
    EXPECT_EQ(m.gamut_scale, 1.0);
    EXPECT_FALSE(m.gamut_clipped);
    EXPECT_TRUE(m.warnings.empty()) << m.warnings.front();
}

// fill_value_from_cosines (the render's rough lobe, at every light sample) is fill_value without
// the angles: the same BRDF to rounding, with orders, single scattering and a lobe, and for a lobe
// alone (no orders: no angles at all).
TEST(PipelineTable, ValueFromCosinesEqualsValueFromAngles) {
    const model::SolvedMaterial m = solve_seed_white(R"("spectrum": "visible", "accuracy": "draft")");
    model::FillInputs body = model::prepare_fill(m);
    body.lobe = model::FillInputs::Lobe::Ggx;
    body.lobe_alpha = 0.1;
    body.lobe_points = 8;
    body.lobe_fresnel.assign(3 * 8, 0.04);
    model::FillInputs lobe = body;
    lobe.orders = 0;
    lobe.fourier.clear();
    lobe.samples = 0;
    ASSERT_GT(body.orders, 0);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> zenith(0.0, 89.9), azimuth(0.0, 180.0);
    for (const model::FillInputs* in : {&body, &lobe}) {
        double worst = 0.0, largest = 0.0;
        for (int k = 0; k < 2000; ++k) {
            const double ti = zenith(rng) * std::numbers::pi / 180.0, to = zenith(rng) * std::numbers::pi / 180.0;
            // Near the mirror direction half the time, where the lobe is large.
            const double phi = k % 2 ? std::numbers::pi - 0.05 * azimuth(rng) / 180.0 : azimuth(rng) * std::numbers::pi / 180.0;
            const model::Rgb a = model::fill_value(*in, ti, to, phi);
            const model::Rgb b = model::fill_value_from_cosines(*in, std::cos(ti), std::cos(to), std::cos(phi));
            for (int c = 0; c < 3; ++c) {
                worst = std::max(worst, std::abs(a[c] - b[c]) / std::max(a[c], 1e-3));
                largest = std::max(largest, a[c]);
            }
        }
        std::printf("%s: from cosines against from angles %.2e (largest value %.3g 1/sr)\n",
                    in == &body ? "body and lobe" : "lobe alone", worst, largest);
        EXPECT_GT(largest, 1.0); // the lobe was met
        EXPECT_LT(worst, 1e-12);
    }
}

// A tabulated render samples the body at cell-centred zenith angles 3.75 degrees apart and
// interpolates trilinearly; its interpolant is built on the draft tables' grid (46 zenith nodes,
// about 2 degrees apart, preview.cpp) instead of the table's 91. At the render's nodes the two
// agree to 8.6e-5 of the value below 88 degrees, 4.2e-4 where both directions are at the last node
// (88.1 degrees, 0.01 1/sr: the limb under a grazing light; 5.5e-3 on the grid uniform in the
// zenith angle, docs/physics.md "The tables' zenith grid").
TEST(PipelineTable, PreviewGridAgreesWithTheTableGridAtTheRenderNodes) {
    const model::SolvedMaterial m = solve_seed_white(R"("spectrum": "visible")");
    const model::FillInputs table = model::prepare_fill(m);
    const model::FillInputs coarse = model::prepare_fill(m, preview::preview_zenith_grid);
    ASSERT_EQ(table.grid, 91);
    ASSERT_EQ(coarse.grid, 46);
    constexpr int nt = 24, np = 13;
    const double step = 0.5 * std::numbers::pi / nt;
    double worst = 0.0, worst_inside = 0.0; // all nodes; all but the last zenith node, 88.1 degrees
    for (int i = 0; i < nt; ++i)
        for (int o = 0; o < nt; ++o)
            for (int p = 0; p < np; ++p) {
                const double ti = (i + 0.5) * step, to = (o + 0.5) * step, phi = std::numbers::pi * p / (np - 1);
                const model::Rgb a = model::fill_value(table, ti, to, phi), b = model::fill_value(coarse, ti, to, phi);
                for (int c = 0; c < 3; ++c) {
                    const double d = std::abs(a[c] - b[c]) / a[c];
                    worst = std::max(worst, d);
                    if (std::max(i, o) < nt - 1) worst_inside = std::max(worst_inside, d);
                }
            }
    std::printf("preview grid against the table grid at the render's nodes: %.2e relative (%.2e below 88 degrees)\n",
                worst, worst_inside);
    EXPECT_LT(worst, 2e-3);
    EXPECT_LT(worst_inside, 1e-3);
}

// `brdftool lobes` draws a spec's curves from the previews' grid (preview::preview_zenith_grid):
// in the plane of incidence at the plot's 0.5-degree steps, for a smooth and a gloss finish, the
// curves stay within 1e-3 of their peak of the table grid's (0.35 pixel of the default plot's
// 350-pixel radius), up to the horizon: 5.4e-5 at most. On the grid uniform in the zenith angle the
// last 2 degrees, where the body falls to 0 at the horizon, erred by up to 2e-2 of the peak.
TEST(PipelineTable, LobesFromThePreviewGridMatchTheTableGrid) {
    for (const char* keys : {R"("spectrum": "visible")", R"("surface": "gloss", "spectrum": "rgb")"}) {
        SCOPED_TRACE(keys);
        const model::SolvedMaterial m = solve_seed_white(keys);
        const model::FillInputs table = model::prepare_fill(m);
        const model::FillInputs coarse = model::prepare_fill(m, preview::preview_zenith_grid);
        ASSERT_EQ(table.grid, 91);
        for (double theta_i : {30.0, 60.0}) {
            double peak = 0.0, worst = 0.0, worst_below_88 = 0.0;
            for (int k = 1; k < 180; ++k)
                for (double phi : {0.0, std::numbers::pi}) {
                    const double ti = theta_i * std::numbers::pi / 180.0, to = 0.5 * k * std::numbers::pi / 180.0;
                    const model::Rgb a = model::fill_value(table, ti, to, phi), b = model::fill_value(coarse, ti, to, phi);
                    for (int c = 0; c < 3; ++c) {
                        peak = std::max(peak, a[c]);
                        worst = std::max(worst, std::abs(a[c] - b[c]));
                        if (k < 176) worst_below_88 = std::max(worst_below_88, std::abs(a[c] - b[c]));
                    }
                }
            std::printf("theta_i %.0f: lobe from the preview grid within %.2e of its peak %.3g 1/sr below 88 "
                        "degrees, %.2e up to 89.5\n",
                        theta_i, worst_below_88 / peak, peak, worst / peak);
            EXPECT_LT(worst_below_88 / peak, 1e-3);
            EXPECT_LT(worst / peak, 1e-3);
        }
    }
}

// The fill computes half the phi_d bins and copies each to its mirror phi_d -> pi - phi_d (bin k ->
// 179 - k), by the isotropy and reciprocity of the BRDF. Each copied cell against the fill's own
// value at that cell's directions, for a gloss finish (Fourier orders, single scattering and the
// microfacet lobe all in play); every cell has data exactly where it lies above the horizon.
TEST(PipelineTable, MirroredHalfEqualsTheDirectFill) {
    const model::SolvedMaterial m = solve_seed_white(R"("surface": "gloss", "spectrum": "rgb", "accuracy": "draft")");
    const model::FillInputs in = model::prepare_fill(m);
    ASSERT_NE(in.lobe, model::FillInputs::Lobe::None);
    const formats::BrdfTable table = model::fill_table_cpu(in, 2);
    double worst = 0.0;
    std::size_t compared = 0;
    for (std::size_t cell = 0; cell < formats::cells; ++cell) {
        ASSERT_EQ(table.has_data(cell), !formats::cell_below_horizon(cell)) << cell;
        const formats::CellIndices ix = formats::cell_indices(cell);
        if (ix.phi_d < formats::phi_d_bins / 2 || !table.has_data(cell) || (ix.theta_h * 7 + ix.theta_d) % 5 != 0)
            continue;
        const formats::DirectionPair d = formats::to_directions(
            formats::theta_h_centre(ix.theta_h), formats::theta_d_centre(ix.theta_d), formats::phi_d_centre(ix.phi_d));
        const double phi = std::abs(std::atan2(d.wo.y, d.wo.x) - std::atan2(d.wi.y, d.wi.x));
        const model::Rgb direct = model::fill_value(in, std::acos(d.wi.z), std::acos(d.wo.z), phi);
        const model::Rgb copied = table.at(cell);
        for (int c = 0; c < 3; ++c)
            worst = std::max(worst, std::abs(copied[c] - direct[c]) / std::max(std::abs(direct[c]), 1e-6));
        ++compared;
    }
    std::printf("%zu mirrored cells against the fill at their own directions: %.2e\n", compared, worst);
    EXPECT_GT(compared, 50000u);
    // Rounding alone (measured 3.2e-9, where the lobe reaches 3e5 1/sr at theta_d 89.5 degrees);
    // a fill that is not symmetric differs by the BRDF's whole azimuthal variation.
    EXPECT_LT(worst, 1e-8);
}

// node_order_blocks on a grid of 2 x 2 nodes with 20 orders in 3 blocks: each node keeps the
// fewest blocks whose left-out orders sum to at most the cut relative to its own R^0 (no smaller
// than 1e-2 of the grid's largest R^0, per channel).
TEST(PipelineTable, EachNodeKeepsTheBlocksOfOrdersItNeeds) {
    model::FillInputs in;
    in.grid = 2;
    in.orders = 20;
    in.channels = 3;
    const int mp = model::padded_orders(in.orders);
    ASSERT_EQ(mp, 24);
    in.fourier.assign(4u * mp * 3, 0.0);
    const auto at = [&](int node, int m, int c) -> double& {
        return in.fourier[(static_cast<std::size_t>(node) * mp + m) * 3 + c];
    };
    for (int node = 0; node < 4; ++node)
        for (int c = 0; c < 3; ++c) at(node, 0, c) = 1.0;
    // Node 0: orders falling as 10^-m: 1e-5 .. 1e-19 left out from order 5 on (sum 1.1e-5 > 1e-5,
    // 1.1e-6 from order 6): 6 orders, one block.
    for (int m = 1; m < 20; ++m) at(0, m, 1) = std::pow(10.0, -m);
    // Node 1: order 12 at 2e-6 in blue alone, order 19 at 5e-6 in red: with a cut of 1e-5 both may
    // go (7e-6); order 9 at 4e-6 too would make 1.1e-5, so it stays: 10 orders, two blocks.
    at(1, 9, 0) = 4e-6;
    at(1, 12, 2) = 2e-6;
    at(1, 19, 0) = 5e-6;
    // Node 2: its R^0 is 1e-3 of the others' in green, so green counts relative to 1e-2 of the
    // largest: 5e-8 at order 17 is 5e-6 of that, within the cut: one block; node 3: 2e-8 at
    // order 17 in red, where its R^0 is 1 (2e-8 relative, within) but also 2e-5 at order 16 in
    // green: the third block.
    at(2, 0, 1) = 1e-3;
    at(2, 17, 1) = 5e-8;
    at(3, 17, 0) = 2e-8;
    at(3, 16, 1) = 2e-5;
    const std::vector<int> blocks = model::node_order_blocks(in, 1e-5);
    ASSERT_EQ(blocks.size(), 4u);
    EXPECT_EQ(blocks[0], 1);
    EXPECT_EQ(blocks[1], 2);
    EXPECT_EQ(blocks[2], 1);
    EXPECT_EQ(blocks[3], 3);
    // A cut of 0 keeps every block with anything in it.
    EXPECT_EQ(model::node_order_blocks(in, 0.0), (std::vector<int>{3, 3, 3, 3}));
}

// The seed white's table at "default" with each node's blocks against every block at every node:
// the cells differ by at most the orders left out, a tenth of the order tolerance (1e-6) of R^0
// times the Catmull-Rom weights' sum (at most 1.5625), and the fill sums fewer blocks.
TEST(PipelineTable, EachNodesOrdersChangeTheTableWithinTheCut) {
    const model::SolvedMaterial m = solve_seed_white(R"("spectrum": "rgb")");
    const model::FillInputs in = model::prepare_fill(m);
    ASSERT_EQ(in.node_blocks.size(), static_cast<std::size_t>(in.grid) * in.grid);
    const int all = model::padded_orders(in.orders) / model::fill_order_block;
    ASSERT_GE(all, 2);
    double blocks = 0.0;
    for (int b : in.node_blocks) blocks += b;
    blocks /= static_cast<double>(in.node_blocks.size());
    std::printf("%d orders: each node needs %.2f of %d blocks on average\n", in.orders, blocks, all);
    EXPECT_LT(blocks, 0.8 * all);
    model::FillInputs every = in;
    every.node_blocks.clear();
    const formats::BrdfTable a = model::fill_table_cpu(in, 2), b = model::fill_table_cpu(every, 2);
    double worst = 0.0;
    std::size_t changed = 0;
    for (std::size_t cell = 0; cell < formats::cells; ++cell) {
        if (!b.has_data(cell)) continue;
        for (int c = 0; c < 3; ++c) {
            const double x = a.plane(c)[cell], y = b.plane(c)[cell];
            changed += x != y;
            worst = std::max(worst, std::abs(x - y) / y);
        }
    }
    std::printf("%zu cell values changed, by %.2e relative at most\n", changed, worst);
    EXPECT_GT(changed, 0u);
    EXPECT_LT(worst, 1.5625 * 0.1 * m.settings.order_tolerance);
}

TEST(Pipeline, WhiteFurnaceTableConservesEnergy) {
    const model::SolvedMaterial m = model::solve_material(
        spec_from(R"({"name": "white", "medium": {"albedo": 1, "phase": {"type": "henyey_greenstein", "g": 0.3}},
                      "accuracy": "draft"})"),
        model::Device::Cpu);
    const formats::BrdfTable table = model::fill_table_cpu(model::prepare_fill(m), 2);
    for (double deg : {0.0, 20.0, 45.0, 70.0}) {
        const auto exact = m.albedo(deg * std::numbers::pi / 180.0);
        const auto tab = formats::directional_albedo(table, deg * std::numbers::pi / 180.0);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(exact[c], 1.0, 1e-9);
            // The table is piecewise constant in half/difference bins: a percent or two of binning
            // error, never a gain of energy beyond it.
            EXPECT_NEAR(tab[c], 1.0, 0.03) << "theta_i " << deg;
        }
    }
}

TEST(Pipeline, MirrorPlusDiffuseIsOneForARealWhitePaint) {
    // Rutile in acrylic absorbs nothing: all light comes back, split between the mirror and the body.
    const model::SolvedMaterial m = solve_seed_white(R"("spectrum": "rgb", "accuracy": "draft")");
    for (double deg : {0.0, 40.0, 75.0}) {
        const auto a = m.albedo(deg * std::numbers::pi / 180.0), r = m.mirror(deg * std::numbers::pi / 180.0);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c] + r[c], 1.0, 1e-9);
    }
}

TEST(Pipeline, ComputeWritesTablesAndReportAndSkipsWhatIsDone) {
    TempDir dir;
    write_file(dir / "spec.json", R"({"materials": [
        {"name": "a", "medium": {"albedo": 0.8}, "accuracy": "draft"},
        {"name": "b", "medium": {"albedo": 0.5, "phase": "rayleigh"}, "accuracy": "draft", "outputs": ["exr"]}]})");
    service::ComputeOptions options;
    options.output_dir = dir / "out";
    options.device = model::Device::Cpu;
    auto outcomes = service::compute_files({dir / "spec.json"}, options);
    ASSERT_EQ(outcomes.size(), 2u);
    for (const auto& o : outcomes) EXPECT_TRUE(o.ok && !o.skipped) << o.error;
    EXPECT_EQ(std::filesystem::file_size(dir / "out/a.binary"), 34992012u);
    EXPECT_TRUE(std::filesystem::exists(dir / "out/a.exr"));
    EXPECT_FALSE(std::filesystem::exists(dir / "out/b.binary"));
    const auto report = nlohmann::json::parse(read_file(dir / "out/a.report.json"));
    EXPECT_EQ(report["name"], "a");
    EXPECT_EQ(report["spec_hash"].get<std::string>().size(), 16u);
    EXPECT_GT(report["solver"]["streams"].get<int>(), 0);
    // The table read back agrees with the model's own albedo to the binning error.
    const auto table = formats::read_table(dir / "out/a.binary");
    const double model = report["directional_albedo"][0]["diffuse_rgb"][0];
    EXPECT_NEAR(formats::directional_albedo(table, 0.0)[0], model, 0.02);
    outcomes = service::compute_files({dir / "spec.json"}, options);
    for (const auto& o : outcomes) EXPECT_TRUE(o.ok && o.skipped) << o.name;
    // Sharding: 1/2 takes only the second material.
    options.shard_index = 1;
    options.shard_count = 2;
    options.output_dir = dir / "shard";
    outcomes = service::compute_files({dir / "spec.json"}, options);
    ASSERT_EQ(outcomes.size(), 1u);
    EXPECT_EQ(outcomes[0].name, "b");
}

TEST(Pipeline, TablesAreNotSolvedTighterThanTheyCanHold) {
    TempDir dir;
    write_file(dir / "spec.json", R"({"name": "tight", "medium": {"albedo": 0.9}, "accuracy": {"tolerance": 1e-8},
                                      "outputs": ["exr"]})");
    service::ComputeOptions options;
    options.output_dir = dir / "out";
    options.device = model::Device::Cpu;
    const auto outcomes = service::compute_files({dir / "spec.json"}, options);
    ASSERT_TRUE(outcomes.at(0).ok) << outcomes[0].error;
    const auto report = nlohmann::json::parse(read_file(dir / "out/tight.report.json"));
    EXPECT_EQ(report["error_estimate"]["requested_tolerance"].get<double>(), 1e-8);
    EXPECT_EQ(report["error_estimate"]["solved_tolerance"].get<double>(), 1e-6);
    EXPECT_LE(report["solver"]["streams"].get<int>(), 64); // 1e-8 alone would start at 96
}

TEST(Pipeline, InvalidSpecComputesNothing) {
    TempDir dir;
    write_file(dir / "spec.json", R"({"name": "x", "medium": {"albedo": 1.5}})");
    service::ComputeOptions options;
    options.output_dir = dir / "out";
    options.device = model::Device::Cpu;
    EXPECT_THROW(service::compute_files({dir / "spec.json"}, options), InputError);
    EXPECT_FALSE(std::filesystem::exists(dir / "out/x.binary"));
}

// The spec format describes films, stacks, rough surfaces and outputs (docs/
// spec.md) that the pipeline does not compute yet: each is refused with an InputError naming it,
// before any work, instead of being computed as something else.
TEST(Pipeline, RefusesWhatItCannotComputeYet) {
    const auto refusal = [](const std::string& text) {
        try {
            model::solve_material(spec_from(text), model::Device::Cpu);
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string("no InputError");
    };
    // The dipole is a semi-infinite comparison model: it has no film.
    EXPECT_EQ(refusal(R"({"name": "f", "medium": {"albedo": 0.9, "optical_depth": 2}, "model": "dipole"})"),
              "test.json: \"model\": \"dipole\" is a semi-infinite comparison model; it has no films or stacks "
              "(remove \"model\" or the thickness)");
    // Every colour space and the spectral output are computed (tests/pipeline/colour_pipeline_test.cpp).
    EXPECT_EQ(refusal(R"({"name": "c", "medium": {"albedo": 0.9}, "colorspace": "acescg", "accuracy": "draft"})"),
              "no InputError");
    // Every output is computed.
    EXPECT_EQ(refusal(R"({"name": "o", "binder": {"index": 1.5}, "pigments": [{"material": "tio2-rutile",
                          "volume_fraction": 0.1, "size": {"distribution": "monodisperse", "radius_um": 0.2}}], "spectrum": "rgb", "accuracy": "draft",
                          "outputs": ["merl", "exr", "fourier", "rgl", "spectral_exr"]})"),
              "no InputError");
    // The defaults written out are computed as before.
    EXPECT_EQ(refusal(R"({"name": "d", "medium": {"albedo": 0.9}, "colorspace": "rec709",
                          "accuracy": "draft", "spectrum": "rgb"})"),
              "no InputError");
}

// Interpolating the BRDF in wavelength between the solved ones stays within the requested
// tolerance of solving every wavelength, for the example catalogue's particulate materials.
// One case per particulate material of the example catalogue and a film of examples/films.json
// (whose optical depth the selection also follows), each its own test, and a matting agent whose
// single scattering alone is exact at the wavelengths not solved (SingleScatteringSample): 5 um
// silica spheres in acrylic, Mie's ripple in every phase-function value, 11 of 41 solved.
struct SpectralCase {
    std::string file, name;
    std::string text; ///< the spec itself, when not from `file`
};

std::vector<SpectralCase> spectral_cases() {
    std::vector<SpectralCase> out;
    for (const auto& spec : material::load_specs(source_dir() / "examples/catalogue.json"))
        if (!spec.layers[0].medium) out.push_back({"catalogue.json", spec.name, ""});
    out.push_back({"films.json", "white-25um-on-black", ""});
    out.push_back({"films.json", "clearcoat-over-red-basecoat", ""});
    out.push_back({"", "silica-matting-5um",
                   R"({"name": "silica-matting-5um", "binder": {"material": "pmma"}, "pigments": [{"material":
                       "silica", "volume_fraction": 0.05, "size": {"distribution": "gamma", "r_eff_um": 5,
                       "v_eff": 0.1}}]})"});
    out.push_back({"", "silica-matting-film",
                   R"({"name": "silica-matting-film", "binder": {"material": "pmma"}, "pigments": [{"material":
                       "silica", "volume_fraction": 0.05, "size": {"distribution": "gamma", "r_eff_um": 5,
                       "v_eff": 0.1}}], "thickness_um": 200, "substrate": {"albedo": 0.8}})"});
    return out;
}

class PipelineSpectral : public ::testing::TestWithParam<SpectralCase> {};

TEST_P(PipelineSpectral, SelectedWavelengthsMeetTheTolerance) {
    const SpectralCase& c = GetParam();
    material::MaterialSpec spec;
    const auto specs = c.text.empty() ? material::load_specs(source_dir() / "examples" / c.file)
                                      : material::parse_specs_text(c.text, c.name);
    for (const auto& s : specs)
        if (s.name == c.name) spec = s;
    ASSERT_EQ(spec.name, c.name);
    model::NumericalSettings all = model::settings_for(spec.accuracy.tolerance);
    all.select_wavelengths = false;
    const auto full = model::solve_material(spec, model::Device::Cpu, all);
    const auto fast = model::solve_material(spec, model::Device::Cpu);
    double worst = 0.0;
    for (double ti : {0.1, 0.6, 1.2})
        for (double to : {0.2, 0.9, 1.4})
            for (double phi : {0.0, 2.0, 3.1}) {
                const auto a = fast.brdf(ti, to, phi), b = full.brdf(ti, to, phi);
                for (int ch = 0; ch < 3; ++ch) worst = std::max(worst, std::abs(a[ch] - b[ch]) / b[ch]);
            }
    std::printf("%-22s solved %2zu of %2zu wavelengths, worst relative difference %.2e\n", spec.name.c_str(),
                fast.samples.size(), full.samples.size(), worst);
    EXPECT_LE(worst, spec.accuracy.tolerance) << spec.name;
    // Where the single scattering is exact per wavelength, every skipped wavelength keeps its own.
    if (!fast.single_only.empty()) {
        EXPECT_EQ(fast.single_only.size() + fast.samples.size(), full.samples.size());
    }
    if (!c.text.empty()) {
        EXPECT_LT(2 * fast.samples.size(), full.samples.size()) << "the matting agent's subset";
    }
}

INSTANTIATE_TEST_SUITE_P(Examples, PipelineSpectral, ::testing::ValuesIn(spectral_cases()),
                         [](const ::testing::TestParamInfo<SpectralCase>& param) {
                             std::string n = param.param.name;
                             for (char& ch : n)
                                 if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                             return n;
                         });

TEST(PipelineGamut, SaturatedYellowIsBroughtIntoGamutKeepingLuminance) {
    const char* text = R"({"name": "cds", "binder": {"material": "pmma"}, "accuracy": "draft",
        "pigments": [{"material": "cds", "volume_fraction": 0.1,
                      "size": {"distribution": "power_law", "r_eff_um": 0.2, "v_eff": 0.2}}]})";
    const auto spec = material::parse_specs_text(text, "cds.json").at(0);
    const model::SolvedMaterial m = model::solve_material(spec, model::Device::Cpu);
    EXPECT_LT(m.gamut_scale, 1.0); // CdS is more saturated than the Rec.709 yellow
    for (double deg : {0.0, 30.0, 60.0, 80.0}) {
        const double t = deg * std::numbers::pi / 180.0;
        const auto a = m.albedo(t), r = m.mirror(t);
        for (int c = 0; c < 3; ++c) {
            EXPECT_GE(a[c] + r[c], -1e-12) << deg;
            EXPECT_LE(a[c] + r[c], 1.0 + 1e-9) << deg;
        }
    }
}

// A table looked up at random directions (nearest bin, as renderers and the MERL reader do) agrees
// with eval on the spec at those exact directions within the binning error of 1-degree bins.
TEST(PipelineTable, RandomDirectionsAgreeWithTheModelWithinTheBinning) {
    const model::SolvedMaterial m = model::solve_material(spec_from(hg_medium), model::Device::Cpu);
    const formats::BrdfTable table = model::fill_table_cpu(model::prepare_fill(m), 2);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> zenith(0.0, 80.0 * std::numbers::pi / 180.0), azimuth(0.0, std::numbers::pi);
    std::vector<double> errors;
    for (int k = 0; k < 300; ++k) {
        const double ti = zenith(rng), to = zenith(rng), phi = azimuth(rng);
        const auto t = formats::lookup(table, ti, to, phi);
        const auto e = m.brdf(ti, to, phi);
        for (int c = 0; c < 3; ++c) errors.push_back(std::abs(t[c] - e[c]) / e[c]);
    }
    std::sort(errors.begin(), errors.end());
    const double median = errors[errors.size() / 2], worst = errors.back();
    std::printf("table vs model at random directions: median %.2e, worst %.2e\n", median, worst);
    EXPECT_LT(median, 0.02);
    EXPECT_LT(worst, 0.15);
}

// A skipped wavelength's interpolation error reaches the colour with its colour weight: a bump in
// the index at 410 nm that no quadratic follows (1e-3, thirty times a third of the tolerance) is
// skipped when 410 nm carries 1e-4 of the average weight (its error then counts as 1e-7), and
// solved when it weighs as much as the others.
TEST(SelectWavelengths, AWavelengthCountsByItsColourWeight) {
    std::vector<model::SpectralOptics> optics(17);
    for (std::size_t k = 0; k < optics.size(); ++k) {
        model::LayerOptics l;
        l.index = 1.5 + 1e-4 * static_cast<double>(k) + (k == 1 ? 1e-3 : 0.0);
        l.medium.omega = 1.0;
        l.medium.beta = {1.0, 1.5, 1.0};
        l.g = 0.5;
        optics[k].wavelength_nm = 400.0 + 10.0 * static_cast<double>(k);
        optics[k].layers.push_back(l);
    }
    const auto solved_410 = [&](double weight_410) {
        std::vector<model::Rgb> weights(optics.size(), model::Rgb{1.0, 1.0, 1.0});
        weights[1] = {weight_410, weight_410, weight_410};
        const model::SpectralSelection pick = model::select_wavelengths(optics, weights, 1e-4);
        model::Rgb folded{0.0, 0.0, 0.0}; // the quadratic's weights sum to 1: no colour is lost
        for (const model::Rgb& w : pick.weights)
            for (int c = 0; c < 3; ++c) folded[c] += w[c];
        EXPECT_NEAR(folded[0], 16.0 + weight_410, 1e-12);
        return std::find(pick.solved.begin(), pick.solved.end(), 1u) != pick.solved.end();
    };
    EXPECT_FALSE(solved_410(1e-4));
    EXPECT_TRUE(solved_410(1.0));
}

// The spec's limit on the phase function's Legendre series is a clear LimitError naming the terms,
// the wavelength and the key to raise (5 um silica spheres carry 500-960 terms in the visible).
TEST(PipelineLimits, ALegendreSeriesOverTheSpecsLimitIsRefused) {
    const auto spec = spec_from(R"({"name": "silica", "binder": {"material": "pmma"}, "spectrum": "visible",
        "limits": {"max_legendre_terms": 300},
        "pigments": [{"material": "silica", "volume_fraction": 0.05,
                      "size": {"distribution": "gamma", "r_eff_um": 5, "v_eff": 0.1}}]})");
    try {
        model::solve_material(spec, model::Device::Cpu);
        FAIL() << "no LimitError";
    } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::Limit) << e.what();
        EXPECT_NE(std::string(e.what()).find("max_legendre_terms"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(" nm"), std::string::npos) << e.what();
    }
}

} // namespace
} // namespace brdf::test
