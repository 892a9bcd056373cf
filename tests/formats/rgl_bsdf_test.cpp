// RGL BSDF files: round trips, and one clear line for every file Mitsuba 3 or pbrt-v4 would refuse
// or turn into NaN (missing fields, wrong dtypes, inconsistent shapes, NaN, non-positive sigma).

#include "format_test_util.h"
#include "rgl_test_files.h"
#include "test_support.h"

#include <formats/rgl/rgl_bsdf.h>
#include <formats/rgl/tensor_file.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>

namespace brdf::formats {
namespace {

using test::TempDir;

void expect_same(const RglBsdf& a, const RglBsdf& b) {
    EXPECT_EQ(a.theta_i, b.theta_i);
    EXPECT_EQ(a.phi_i, b.phi_i);
    for (auto [x, y] : {std::pair{&a.ndf, &b.ndf}, {&a.sigma, &b.sigma}, {&a.vndf, &b.vndf},
                        {&a.luminance, &b.luminance}, {&a.values, &b.values}}) {
        EXPECT_EQ(x->shape, y->shape);
        EXPECT_EQ(x->values, y->values);
    }
    EXPECT_EQ(a.wavelengths, b.wavelengths);
    EXPECT_EQ(a.description, b.description);
    EXPECT_EQ(a.jacobian, b.jacobian);
}

TEST(RglBsdfFile, RoundTripRgbAndSpectral) {
    const TempDir dir;
    for (bool spectral : {false, true}) {
        const RglBsdf b = test::small_rgl_bsdf(spectral);
        ASSERT_EQ(rgl_bsdf_fault(b), "");
        const auto p = dir / (spectral ? "s.rgl.bsdf" : "c.rgl.bsdf");
        write_rgl_bsdf(p, b);
        const RglBsdf r = read_rgl_bsdf(p);
        expect_same(r, b);
        EXPECT_EQ(r.spectral(), spectral);
        EXPECT_TRUE(r.isotropic());
        EXPECT_EQ(r.channels(), spectral ? 4u : 3u);
        EXPECT_EQ(r.sample_resolution(), 4u);
        // The fields Mitsuba's loader asks for, under the names it uses.
        const TensorFile t = read_tensor_file(p);
        for (const char* name : {"theta_i", "phi_i", "ndf", "sigma", "vndf", "luminance",
                                 "description", "jacobian"})
            EXPECT_NE(t.find(name), nullptr) << name;
        EXPECT_NE(t.find(spectral ? "spectra" : "rgb"), nullptr);
        EXPECT_EQ(t.find("wavelengths") != nullptr, spectral);
        EXPECT_EQ(t.find("jacobian")->bytes, (std::vector<unsigned char>{1}));
    }
}

TEST(RglBsdfFile, ExtraFieldsAreIgnored) {
    const TempDir dir;
    TensorFile t = rgl_tensor_fields(test::small_rgl_bsdf());
    t.fields.push_back(TensorField::uint8("comment", {2}, {'h', 'i'}));
    write_tensor_file(dir / "x.rgl.bsdf", t);
    expect_same(read_rgl_bsdf(dir / "x.rgl.bsdf"), test::small_rgl_bsdf());
}

// Writes the tensor fields of a small valid file after `change`, and expects `fault` on reading.
class RglBsdfFault : public ::testing::Test {
  protected:
    void expect_fault(const std::function<void(TensorFile&)>& change, const std::string& fault,
                      bool spectral = false) {
        TensorFile t = rgl_tensor_fields(test::small_rgl_bsdf(spectral));
        change(t);
        const auto p = m_dir / "bad.rgl.bsdf";
        write_tensor_file(p, t);
        EXPECT_THROW_MESSAGE(read_rgl_bsdf(p), FormatError, p.string() + ": " + fault);
    }
    static TensorField& field(TensorFile& t, const char* name) {
        for (TensorField& f : t.fields)
            if (f.name == name) return f;
        throw std::logic_error(name);
    }
    static void set_float(TensorFile& t, const char* name, std::size_t k, float v) {
        std::vector<float> values = field(t, name).to_float32();
        values[k] = v;
        field(t, name) = TensorField::float32(name, field(t, name).shape, values);
    }
    static void remove(TensorFile& t, const char* name) {
        std::erase_if(t.fields, [&](const TensorField& f) { return f.name == name; });
    }
    TempDir m_dir;
};

TEST_F(RglBsdfFault, MissingField) {
    expect_fault([](TensorFile& t) { remove(t, "vndf"); },
                 "field 'vndf' is missing (not an RGL BSDF file)");
    expect_fault([](TensorFile& t) { remove(t, "rgb"); },
                 "field 'rgb' is missing (not an RGL BSDF file)");
    expect_fault([](TensorFile& t) { remove(t, "wavelengths"); },
                 "field 'wavelengths' is missing (a spectral file needs it beside 'spectra')", true);
    expect_fault([](TensorFile& t) { remove(t, "spectra"); },
                 "field 'spectra' is missing (not an RGL BSDF file)", true);
}

TEST_F(RglBsdfFault, WrongDtypeOrRank) {
    expect_fault(
        [](TensorFile& t) {
            TensorField& f = field(t, "ndf");
            f.dtype = TensorDType::Int32;
        },
        "field 'ndf': int32 of rank 2 (float32 of rank 2 expected)");
    expect_fault(
        [](TensorFile& t) {
            TensorField& f = field(t, "theta_i");
            f.shape = {1, 2};
        },
        "field 'theta_i': float32 of rank 2 (float32 of rank 1 expected)");
    expect_fault([](TensorFile& t) { field(t, "jacobian") = TensorField::uint8("jacobian", {2}, {1, 1}); },
                 "field 'jacobian': shape [2] ([1] expected)");
    expect_fault(
        [](TensorFile& t) {
            field(t, "description") = TensorField::float32("description", {1}, {1.0f});
        },
        "field 'description': float32 of rank 1 (uint8 of rank 1 expected)");
}

TEST_F(RglBsdfFault, ShapesThatDoNotMatch) {
    // vndf for 3 incidences, theta_i has 2.
    expect_fault(
        [](TensorFile& t) {
            field(t, "vndf") =
                TensorField::float32("vndf", {1, 3, 3, 3}, std::vector<float>(27, 1.0f));
        },
        "field 'vndf': shape [1, 3, 3, 3] does not match theta_i (2 values) in dimension 1");
    expect_fault(
        [](TensorFile& t) {
            field(t, "luminance") =
                TensorField::float32("luminance", {1, 2, 4, 5}, std::vector<float>(40, 1.0f));
        },
        "field 'luminance': shape [1, 2, 4, 5]: the sample grid is not square");
    // Five channels for four wavelengths.
    expect_fault(
        [](TensorFile& t) {
            field(t, "spectra") =
                TensorField::float32("spectra", {1, 2, 5, 4, 4}, std::vector<float>(160, 1.0f));
        },
        "field 'spectra': shape [1, 2, 5, 4, 4] does not match wavelengths (4 values) in dimension 2",
        true);
    // A sample grid other than the luminance grid.
    expect_fault(
        [](TensorFile& t) {
            field(t, "rgb") =
                TensorField::float32("rgb", {1, 2, 3, 3, 3}, std::vector<float>(54, 1.0f));
        },
        "field 'rgb': shape [1, 2, 3, 3, 3] does not match luminance (4 values) in dimension 3");
    // The renderers' interpolants need two nodes per dimension.
    expect_fault(
        [](TensorFile& t) {
            field(t, "ndf") = TensorField::float32("ndf", {1, 3}, std::vector<float>(3, 1.0f));
        },
        "field 'ndf': shape [1, 3]: dimension 0 needs at least 2 nodes");
}

TEST_F(RglBsdfFault, AxesMustBeFiniteAndIncreasing) {
    expect_fault([](TensorFile& t) { set_float(t, "theta_i", 1, 0.0f); },
                 "field 'theta_i': not increasing (0 then 0 at index [1])");
    expect_fault(
        [](TensorFile& t) {
            set_float(t, "theta_i", 0, std::numeric_limits<float>::quiet_NaN());
        },
        "field 'theta_i': non-finite value NaN at index [0]");
    expect_fault([](TensorFile& t) { set_float(t, "wavelengths", 0, -400.0f); },
                 "field 'wavelengths': value -400 at index [0] is not > 0", true);
    expect_fault(
        [](TensorFile& t) { field(t, "phi_i") = TensorField::float32("phi_i", {0}, {}); },
        "field 'phi_i': no values");
}

TEST_F(RglBsdfFault, ValuesThatWouldMakeNaN) {
    expect_fault(
        [](TensorFile& t) { set_float(t, "ndf", 5, std::numeric_limits<float>::quiet_NaN()); },
        "field 'ndf': non-finite value NaN at index [1, 2]");
    expect_fault(
        [](TensorFile& t) { set_float(t, "rgb", 17, std::numeric_limits<float>::infinity()); },
        "field 'rgb': non-finite value inf at index [0, 0, 1, 0, 1]");
    expect_fault([](TensorFile& t) { set_float(t, "sigma", 0, 0.0f); },
                 "field 'sigma': value 0 at index [0, 0] is not > 0");
    expect_fault([](TensorFile& t) { set_float(t, "vndf", 3, -0.5f); },
                 "field 'vndf': value -0.5 at index [0, 0, 1, 0] is negative");
}

// The renderers normalise each warp grid and divide by the integral of each of its rows.
TEST_F(RglBsdfFault, WarpsThatCannotBeNormalisedOrInverted) {
    expect_fault(
        [](TensorFile& t) {
            std::vector<float> v = field(t, "luminance").to_float32();
            std::fill(v.begin() + 16, v.end(), 0.0f);
            field(t, "luminance") = TensorField::float32("luminance", {1, 2, 4, 4}, v);
        },
        "field 'luminance': row 0 of the grid at index [0, 1, 0, 0] is zero (the renderers divide "
        "by each row's integral)");
    expect_fault(
        [](TensorFile& t) {
            std::vector<float> v = field(t, "vndf").to_float32();
            std::fill(v.begin() + 6, v.begin() + 9, 0.0f); // the last row of the first grid
            field(t, "vndf") = TensorField::float32("vndf", {1, 2, 3, 3}, v);
        },
        "field 'vndf': row 2 of the grid at index [0, 0, 0, 0] is zero (the renderers divide by "
        "each row's integral)");
    expect_fault(
        [](TensorFile& t) {
            field(t, "vndf") =
                TensorField::float32("vndf", {1, 2, 3, 3}, std::vector<float>(18, 1e-38f));
        },
        "field 'vndf': the grid at index [0, 0, 0, 0] integrates to 9.99999935e-39, too little to "
        "normalise in single precision");
}

// sample * ndf / (4 sigma) must not overflow (inf, then NaN where a factor is 0).
TEST_F(RglBsdfFault, ValuesWhoseProductOverflows) {
    // 3e38 * 0.35 (the largest ndf) / (4 * 0.01) = 2.6e39.
    const std::vector<float> ndf = test::small_rgl_bsdf().ndf.values;
    const double bound =
        double{3e38f} * *std::max_element(ndf.begin(), ndf.end()) / (4.0 * double{0.01f});
    expect_fault(
        [](TensorFile& t) {
            set_float(t, "rgb", 3, 3e38f);
            set_float(t, "sigma", 4, 0.01f);
        },
        cat("field 'rgb': the largest sample times the largest ndf over 4 times the smallest "
            "sigma is ",
            bound, ", beyond single precision"));
}

// Negative BRDF samples occur in measured files (noise); pbrt-v4 clamps them, Mitsuba reads them.
TEST_F(RglBsdfFault, NegativeSamplesAreReadButNotWritten) {
    const auto p = m_dir / "neg.rgl.bsdf";
    RglBsdf b = test::small_rgl_bsdf();
    b.values.values[7] = -0.25f;
    write_tensor_file(p, rgl_tensor_fields(b));
    EXPECT_EQ(read_rgl_bsdf(p).values.values[7], -0.25f);
    const auto q = m_dir / "neg2.rgl.bsdf";
    EXPECT_THROW_MESSAGE(write_rgl_bsdf(q, b), NumericalError,
                         q.string() + ": field 'rgb': value -0.25 at index [0, 0, 0, 1, 3] is "
                                      "negative");
    EXPECT_FALSE(std::filesystem::exists(q));
}

TEST_F(RglBsdfFault, WriterChecksTheStructureFirst) {
    const auto p = m_dir / "w.rgl.bsdf";
    RglBsdf b = test::small_rgl_bsdf();
    b.theta_i.push_back(1.0f);
    EXPECT_THROW_MESSAGE(write_rgl_bsdf(p, b), NumericalError,
                         p.string() + ": field 'vndf': shape [1, 2, 3, 3] does not match theta_i "
                                      "(3 values) in dimension 1");
    EXPECT_FALSE(std::filesystem::exists(p));
}

TEST_F(RglBsdfFault, TruncatedFileNamesTheField) {
    const auto p = m_dir / "t.rgl.bsdf";
    write_rgl_bsdf(p, test::small_rgl_bsdf());
    std::string bytes = test::read_file(p);
    const std::size_t size = bytes.size();
    bytes.resize(size - 1);
    test::write_file(p, bytes);
    // The last field is jacobian, one byte: cut it off.
    EXPECT_THROW_MESSAGE(read_rgl_bsdf(p), FormatError,
                         cat(p.string(), ": field 'jacobian': data [", size - 1, ", ", size,
                             ") lies past the end of the file (", size - 1, " bytes)"));
}

TEST_F(RglBsdfFault, NotATensorFile) {
    const auto p = m_dir / "merl.rgl.bsdf";
    test::write_file(p, test::merl_truncated(4096));
    EXPECT_THROW_MESSAGE(read_rgl_bsdf(p), FormatError,
                         p.string() + ": not a tensor file (no \"tensor_file\" magic)");
}

} // namespace
} // namespace brdf::formats
