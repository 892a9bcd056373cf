// The OpenCL table fill (kernels/table_fill.cl through model/cl_table_fill.h) against its C++
// reference fill_table_reference, every one of the 1,458,000 cells: an analytic medium, a small
// particulate material (in RGB, and across the visible, where the wavelengths share
// single-scattering terms), the same paint under rough surfaces (gloss and matte GGX, separable
// masking, Beckmann on a stack: the first-surface lobe per cell), and empty inputs (geometry only).
// Below-horizon cells must be no_data exactly where formats::cell_below_horizon says so. The CPU
// device's fill in lanes (fill_table_cpu) against the same reference, bit for bit, on those inputs.

#include <brdf/cl/context.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/material/spec.h>
#include <brdf/model/cl_table_fill.h>
#include <brdf/model/model.h>
#include <brdf/model/table_fill.h>
#include <formats/halfdiff.h>
#include <formats/table.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace brdf::test {
namespace {

material::MaterialSpec spec_from(const std::string& text) {
    return material::parse_specs_text(text, "test.json").at(0);
}

const char* hg_medium = R"({"name": "hg", "medium": {"albedo": [0.99, 0.8, 0.4],
    "phase": {"type": "henyey_greenstein", "g": 0.6}}, "accuracy": "draft"})";

const char* white_paint = R"({"name": "w", "binder": {"material": "pmma"},
    "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.1,
                  "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}],
    "spectrum": "rgb", "accuracy": "draft"})";

// Every cell: no_data exactly at the below-horizon cells (in both tables), elsewhere data that agrees
// to `relative` (1e-12 by default) or 1e-15 absolute.
void compare_tables(const formats::BrdfTable& device, const formats::BrdfTable& reference, double relative = 1e-12) {
    ASSERT_EQ(device.channels[0].size(), formats::cells);
    std::size_t horizon_mismatch = 0, value_mismatch = 0, below = 0;
    double worst_rel = 0.0;
    std::size_t worst_cell = 0;
    double worst_value = 0.0;
    for (std::size_t cell = 0; cell < formats::cells; ++cell) {
        const bool no_data = formats::cell_below_horizon(cell);
        below += no_data;
        for (int c = 0; c < 3; ++c) {
            const double d = device.plane(c)[cell], r = reference.plane(c)[cell];
            if (no_data) {
                if (d != formats::BrdfTable::no_data || r != formats::BrdfTable::no_data) ++horizon_mismatch;
                continue;
            }
            if (!(d >= 0.0) || !(r >= 0.0)) {
                ++horizon_mismatch;
                continue;
            }
            const double diff = std::abs(d - r);
            const double rel = r > 0.0 ? diff / r : diff;
            if (rel > worst_rel) worst_rel = rel, worst_cell = cell, worst_value = r;
            if (diff > std::max(relative * std::abs(r), 1e-15)) {
                if (value_mismatch < 5)
                    ADD_FAILURE() << "cell " << cell << " channel " << c << ": device " << d << ", reference " << r;
                ++value_mismatch;
            }
        }
    }
    EXPECT_EQ(below, 361784u);
    EXPECT_EQ(horizon_mismatch, 0u);
    EXPECT_EQ(value_mismatch, 0u);
    const auto ix = formats::cell_indices(worst_cell);
    std::printf("worst relative difference %.3g at cell %zu (%d, %d, %d), reference value %.6g\n", worst_rel,
                worst_cell, ix.theta_h, ix.theta_d, ix.phi_d, worst_value);
}

std::string rough(const char* spec, const char* surface) {
    std::string text(spec);
    return text.insert(text.rfind('}'), cat(", \"surface\": ", surface));
}

class ClTableFill : public ::testing::Test {
protected:
    void SetUp() override {
        if (!brdf::cl::available()) GTEST_SKIP() << "no OpenCL device with fp64";
    }
};

TEST_F(ClTableFill, AnalyticMediumMatchesReference) {
    const model::SolvedMaterial m = model::solve_material(spec_from(hg_medium), model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    compare_tables(model::fill_table_opencl(in), model::fill_table_reference(in, 2));
}

// A grey medium is filled in one channel (FillInputs::channels 1) into a grey table (one plane,
// formats/table.h): the same values, bit for bit, as the three-channel fill of the same inputs, on
// the device, in the C++ lanes and in the C++ reference, with orders, single scattering and a rough
// top's lobe.
model::FillInputs three_channels(const model::FillInputs& grey) {
    model::FillInputs in = grey;
    in.channels = 3;
    const auto triple = [](const std::vector<double>& one) {
        std::vector<double> three;
        for (double v : one) three.insert(three.end(), {v, v, v});
        return three;
    };
    in.fourier = triple(grey.fourier);
    in.phase = triple(grey.phase);
    return in;
}

// The same planes, bit for bit (a grey table's one plane).
void expect_identical(const formats::BrdfTable& a, const formats::BrdfTable& b) {
    EXPECT_EQ(a.grey, b.grey);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(a.channels[c], b.channels[c]) << "channel " << c;
}

void expect_grey_and_identical(const formats::BrdfTable& grey, const formats::BrdfTable& wide) {
    EXPECT_TRUE(grey.grey);
    EXPECT_TRUE(grey.channels[1].empty() && grey.channels[2].empty()) << "a grey table holds one plane";
    EXPECT_FALSE(wide.grey);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(grey.plane(c), wide.channels[c]) << "channel " << c;
    EXPECT_NO_THROW(formats::check_table(grey, "the grey table"));
}

TEST_F(ClTableFill, GreyMediumIsFilledInOneChannel) {
    for (const char* surface : {"\"none\"", "\"smooth\"", "\"satin\""}) {
        SCOPED_TRACE(surface);
        const std::string text = rough(R"({"name": "grey", "medium": {"albedo": 0.95, "index": 1.5,
            "phase": {"type": "henyey_greenstein", "g": 0.6}}, "accuracy": "draft"})", surface);
        const model::SolvedMaterial m = model::solve_material(spec_from(text), model::Device::Cpu);
        const model::FillInputs in = model::prepare_fill(m);
        ASSERT_EQ(in.channels, 1);
        const model::FillInputs wide = three_channels(in);
        const formats::BrdfTable grey_device = model::fill_table_opencl(in);
        expect_grey_and_identical(grey_device, model::fill_table_opencl(wide));
        const formats::BrdfTable grey_reference = model::fill_table_reference(in, 2);
        expect_grey_and_identical(grey_reference, model::fill_table_reference(wide, 2));
        const formats::BrdfTable grey_lanes = model::fill_table_cpu(in, 2);
        expect_grey_and_identical(grey_lanes, model::fill_table_cpu(wide, 2));
        EXPECT_EQ(grey_lanes.channels[0], grey_reference.channels[0]);
        compare_tables(grey_device, grey_reference, 1e-11);
    }
    // A coloured medium keeps its three channels.
    EXPECT_EQ(model::prepare_fill(model::solve_material(spec_from(hg_medium), model::Device::Cpu)).channels, 3);
}

TEST_F(ClTableFill, ParticulateMaterialMatchesReference) {
    const model::SolvedMaterial m = model::solve_material(spec_from(white_paint), model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    ASSERT_GT(in.samples, 0);
    compare_tables(model::fill_table_opencl(in), model::fill_table_reference(in, 2));
}

// Across the visible the wavelengths share a few single-scattering terms (interpolated in the
// binder index): the kernel reads them as the C++ fill does.
TEST_F(ClTableFill, SpectralPaintWithSharedSingleScatteringMatchesReference) {
    std::string text(white_paint);
    text.replace(text.find("\"rgb\""), 5, "\"visible\"");
    const model::SolvedMaterial m = model::solve_material(spec_from(text), model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    ASSERT_GT(in.samples, 0);
    ASSERT_LT(static_cast<std::size_t>(in.samples), m.samples.size());
    compare_tables(model::fill_table_opencl(in), model::fill_table_reference(in, 2));
}


TEST_F(ClTableFill, GlossPaintMatchesReference) {
    const model::SolvedMaterial m =
        model::solve_material(spec_from(rough(white_paint, "\"gloss\"")), model::Device::Cpu);
    model::FillInputs in = model::prepare_fill(m);
    ASSERT_EQ(in.lobe, model::FillInputs::Lobe::Ggx);
    EXPECT_EQ(in.lobe_alpha, 0.03);
    // A narrow lobe near grazing is ill-conditioned in the azimuth: there tan^2(theta_h) carries
    // 1 + cos(phi) over (mu_i + mu_o)^2 ~ 1e-4 and D changes by 2 / alpha^2 ~ 2e3 per unit of
    // tan^2, so a last-bit difference between the device's and glibc's atan2 or cos (~1e-16) comes
    // out as ~3e-12 relative at the grazing peak cells of alpha 0.03.
    constexpr double narrow_lobe = 1e-11;
    compare_tables(model::fill_table_opencl(in), model::fill_table_reference(in, 2), narrow_lobe);
    in.lobe_separable = true; // the masking form Mitsuba's roughdielectric uses
    compare_tables(model::fill_table_opencl(in), model::fill_table_reference(in, 2), narrow_lobe);
}

TEST_F(ClTableFill, MattePaintMatchesReference) {
    const model::SolvedMaterial m =
        model::solve_material(spec_from(rough(white_paint, "\"matte\"")), model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    ASSERT_EQ(in.lobe, model::FillInputs::Lobe::Ggx);
    EXPECT_EQ(in.lobe_alpha, 0.4);
    compare_tables(model::fill_table_opencl(in), model::fill_table_reference(in, 2));
}

TEST_F(ClTableFill, BeckmannStackMatchesReference) {
    // A clear coat over a scattering layer, solved per wavelength (three): Beckmann's Lambda needs erfc.
    const model::SolvedMaterial m = model::solve_material(spec_from(R"({"name": "coat",
        "surface": {"roughness": 0.2, "distribution": "beckmann"},
        "layers": [{"binder": {"material": "pmma"}, "thickness_um": 20},
                   {"medium": {"albedo": 0.95, "optical_depth": 3, "index": 1.5}}],
        "substrate": {"albedo": 0.5}, "spectrum": "rgb", "accuracy": "draft"})"),
                                                          model::Device::Cpu);
    const model::FillInputs in = model::prepare_fill(m);
    ASSERT_EQ(in.lobe, model::FillInputs::Lobe::Beckmann);
    compare_tables(model::fill_table_opencl(in), model::fill_table_reference(in, 2));
}

// The CPU device's fill computes cells in vector lanes (eight, four or two at once: the
// instruction set's, and each narrower set's in Pipeline.TableFillLanes.*) with the reference's
// formulas, order of summation and library calls: every value is the reference's, bit for bit, for
// every kind of input (grey and RGB orders, shared and per-sample single scattering, a finite
// layer's slab factor, GGX in both maskings, Beckmann, nothing but the geometry). Runs without
// OpenCL.
TEST(TableFillLanes, EqualTheReferenceBitForBit) {
    const auto solved = [](const std::string& text) {
        return model::prepare_fill(model::solve_material(spec_from(text), model::Device::Cpu));
    };
    std::string visible(white_paint);
    visible.replace(visible.find("\"rgb\""), 5, "\"visible\"");
    std::vector<std::pair<std::string, model::FillInputs>> cases = {
        {"hg", solved(hg_medium)},
        {"grey satin", solved(rough(R"({"name": "grey", "medium": {"albedo": 0.95, "index": 1.5,
            "phase": {"type": "henyey_greenstein", "g": 0.6}}, "accuracy": "draft"})", "\"satin\""))},
        {"paint", solved(white_paint)},
        {"visible paint", solved(visible)},
        {"gloss paint", solved(rough(white_paint, "\"gloss\""))},
        {"coat", solved(R"({"name": "coat", "surface": {"roughness": 0.2, "distribution": "beckmann"},
            "layers": [{"binder": {"material": "pmma"}, "thickness_um": 20},
                       {"medium": {"albedo": 0.95, "optical_depth": 3, "index": 1.5}}],
            "substrate": {"albedo": 0.5}, "spectrum": "rgb", "accuracy": "draft"})")},
    };
    // A thin film: its single scattering carries the slab factor 1 - exp(-tau (1/u_o + 1/u_i)).
    cases.emplace_back("film", solved(R"({"name": "film", "layers": [{"binder": {"material": "pmma"},
        "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.1,
                      "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}],
        "thickness_um": 2}], "substrate": {"albedo": 0.5}, "spectrum": "rgb", "accuracy": "draft"})"));
    model::FillInputs separable = cases[4].second;
    separable.lobe_separable = true;
    cases.emplace_back("gloss paint, separable masking", separable);
    model::FillInputs empty;
    empty.grid = 2;
    cases.emplace_back("empty", empty);
    ASSERT_EQ(cases[1].second.channels, 1);
    ASSERT_EQ(cases[5].second.lobe, model::FillInputs::Lobe::Beckmann);
    ASSERT_TRUE(std::any_of(cases[6].second.tau.begin(), cases[6].second.tau.end(),
                            [](double t) { return std::isfinite(t); }));
    for (const auto& [name, in] : cases) {
        SCOPED_TRACE(name);
        expect_identical(model::fill_table_cpu(in, 2), model::fill_table_reference(in, 2));
    }
}

TEST_F(ClTableFill, EmptyInputsGiveTheHorizonMaskAndZeros) {
    model::FillInputs in; // no orders, no samples: only the geometry
    in.grid = 2;
    compare_tables(model::fill_table_opencl(in), model::fill_table_reference(in, 2));
    const formats::BrdfTable t = model::fill_table_opencl(in);
    EXPECT_EQ(t.data_cells(), formats::cells - 361784u);
}

TEST(ClTableFillInputs, InconsistentInputsAreRefused) {
    model::FillInputs in;
    in.grid = 3;
    in.orders = 2;
    in.fourier.assign(static_cast<std::size_t>(model::padded_orders(2)) * 3 * 3 * 3 - 1, 0.0);
    EXPECT_THROW(model::fill_table_opencl(in), InputError);
    in.fourier.push_back(0.0);
    in.samples = 1;
    in.phase_points = 5;
    in.phase.assign(5 * 3 - 1, 0.0); // RGB: 15 expected
    in.fresnel_points = 5;
    in.transmission.assign(5, 1.0);
    in.refractive_index.assign(1, 1.0);
    EXPECT_THROW(model::fill_table_opencl(in), InputError);
    in.phase.push_back(0.0);
    in.tau.assign(1, 1.0);
    in.lobe = model::FillInputs::Lobe::Ggx;
    in.lobe_alpha = 0.1;
    in.lobe_points = 8;
    in.lobe_fresnel.assign(3 * 8 - 1, 0.04); // 24 expected
    EXPECT_THROW(model::fill_table_opencl(in), InputError);
    in.lobe_fresnel.push_back(0.04);
    in.lobe_alpha = 0.0; // below the range
    EXPECT_THROW(model::fill_table_opencl(in), InputError);
    in.lobe_alpha = 0.1;
    in.node_blocks.assign(3 * 3 - 1, 1); // one per node: 9 expected
    EXPECT_THROW(model::fill_table_opencl(in), InputError);
    in.node_blocks.assign(3 * 3, 2); // 2 orders are one block
    EXPECT_THROW(model::fill_table_opencl(in), InputError);
    // Without orders the nodes' blocks are not read (a fill of the single scattering alone).
    in.node_blocks.assign(3 * 3, 1);
    in.orders = 0;
    in.fourier.clear();
    if (brdf::cl::available()) {
        EXPECT_NO_THROW(model::fill_table_opencl(in));
    }
}

} // namespace
} // namespace brdf::test
