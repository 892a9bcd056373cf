// The half/difference layout against an independent evaluation: directions are built here from
// spherical angles with explicit 3x3 rotation matrices (Rusinkiewicz 1998, section 3: the
// difference vector is wi expressed in the frame Ry(-theta_h) Rz(-phi_h) that takes h to the pole),
// and the bin formulas are restated from docs/design.md ("Table formats").

#include <formats/halfdiff.h>

#include "test_support.h"

#include <array>
#include <cmath>
#include <random>

namespace brdf::formats {
namespace {

using Mat3 = std::array<std::array<double, 3>, 3>;

Mat3 rot_z(double a) {
    return {{{std::cos(a), -std::sin(a), 0.0}, {std::sin(a), std::cos(a), 0.0}, {0.0, 0.0, 1.0}}};
}
Mat3 rot_y(double a) {
    return {{{std::cos(a), 0.0, std::sin(a)}, {0.0, 1.0, 0.0}, {-std::sin(a), 0.0, std::cos(a)}}};
}
Mat3 mul(const Mat3& a, const Mat3& b) {
    Mat3 m{};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) m[r][c] += a[r][k] * b[k][c];
    return m;
}
Vec3 transform(const Mat3& m, const Vec3& v) {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
}
Vec3 spherical(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}
double dot(const Vec3& a, const Vec3& b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
double max_abs_diff(const Vec3& a, const Vec3& b) {
    return std::max({std::abs(a.x - b.x), std::abs(a.y - b.y), std::abs(a.z - b.z)});
}
// Distance of two phi_d values on the circle of period pi (phi_d and phi_d + pi are one).
double phi_distance(double a, double b) {
    const double d = std::fmod(std::abs(a - b), pi);
    return std::min(d, pi - d);
}

// Independent inverse: h, then d = Ry(-theta_h) Rz(-phi_h) wi as matrices; angles by atan2.
HalfDiff reference_half_diff(const Vec3& wi, const Vec3& wo) {
    Vec3 h{wi.x + wo.x, wi.y + wo.y, wi.z + wo.z};
    const double len = std::sqrt(dot(h, h));
    h = {h.x / len, h.y / len, h.z / len};
    const double theta_h = std::atan2(std::hypot(h.x, h.y), h.z);
    const double phi_h = std::atan2(h.y, h.x);
    const Vec3 d = transform(mul(rot_y(-theta_h), rot_z(-phi_h)), wi);
    double phi_d = std::atan2(d.y, d.x);
    if (phi_d < 0) phi_d += pi;
    return {theta_h, std::atan2(std::hypot(d.x, d.y), d.z), phi_d};
}

TEST(HalfDiffLayout, CellIndexIsMerlOrderAndInverts) {
    EXPECT_EQ(cells, 1458000u);
    EXPECT_EQ(cell_index(0, 0, 0), 0u);
    EXPECT_EQ(cell_index(0, 0, 1), 1u);
    EXPECT_EQ(cell_index(0, 1, 0), 180u);
    EXPECT_EQ(cell_index(1, 0, 0), 16200u);
    EXPECT_EQ(cell_index(89, 89, 179), cells - 1);
    std::size_t expected = 0;
    for (int i = 0; i < 90; ++i)
        for (int j = 0; j < 90; ++j)
            for (int k = 0; k < 180; ++k, ++expected) {
                ASSERT_EQ(cell_index(i, j, k), std::size_t(k + 180 * j + 180 * 90 * i));
                const CellIndices c = cell_indices(expected);
                ASSERT_EQ(c.theta_h, i);
                ASSERT_EQ(c.theta_d, j);
                ASSERT_EQ(c.phi_d, k);
            }
}

TEST(HalfDiffLayout, BinCentresFollowTheDesignFormulas) {
    for (int i = 0; i < 90; ++i) {
        const double lo = std::pow(i / 90.0, 2) * pi / 2, hi = std::pow((i + 1) / 90.0, 2) * pi / 2;
        EXPECT_REL_NEAR(theta_h_centre(i), std::pow((i + 0.5) / 90.0, 2) * pi / 2, 1e-15);
        EXPECT_GT(theta_h_centre(i), lo);
        EXPECT_LT(theta_h_centre(i), hi);
        // The centre is the midpoint in index space, not in angle: sqrt maps it to i + 0.5.
        EXPECT_NEAR(std::sqrt(theta_h_centre(i) / (pi / 2)) * 90, i + 0.5, 1e-12);
        EXPECT_EQ(theta_h_index(theta_h_centre(i)), i);
        EXPECT_REL_NEAR(theta_d_centre(i), (i + 0.5) / 90.0 * pi / 2, 1e-15);
        EXPECT_EQ(theta_d_index(theta_d_centre(i)), i);
        // Just inside each edge of the bin.
        EXPECT_EQ(theta_h_index(lo * (1 + 1e-12) + 1e-300), i);
        EXPECT_EQ(theta_h_index(hi * (1 - 1e-12)), i);
    }
    for (int k = 0; k < 180; ++k) {
        EXPECT_REL_NEAR(phi_d_centre(k), (k + 0.5) / 180.0 * pi, 1e-15);
        EXPECT_EQ(phi_d_index(phi_d_centre(k)), k);
        // Negative azimuths fold by reciprocity: phi_d - pi is the same bin.
        EXPECT_EQ(phi_d_index(phi_d_centre(k) - pi), k);
    }
}

// The clamping of the MERL reference reader (BRDFRead.cpp): out-of-range angles land in the end
// bins.
TEST(HalfDiffLayout, IndexFunctionsClampLikeTheReferenceReader) {
    EXPECT_EQ(theta_h_index(-0.1), 0);
    EXPECT_EQ(theta_h_index(0.0), 0);
    EXPECT_EQ(theta_h_index(pi / 2), 89);
    EXPECT_EQ(theta_h_index(pi), 89);
    EXPECT_EQ(theta_h_index(std::nan("")), 0);
    EXPECT_EQ(theta_d_index(-0.1), 0);
    EXPECT_EQ(theta_d_index(pi / 2), 89);
    EXPECT_EQ(theta_d_index(10.0), 89);
    EXPECT_EQ(phi_d_index(0.0), 0);
    EXPECT_EQ(phi_d_index(pi), 179);
    EXPECT_EQ(phi_d_index(-pi), 0);
    EXPECT_EQ(phi_d_index(2 * pi), 179);
    EXPECT_EQ(phi_d_index(std::nan("")), 0);
    EXPECT_EQ(theta_h_index(1e300), 89);
}

TEST(HalfDiffConversion, ToDirectionsMatchesRotationMatrices) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int n = 0; n < 20000; ++n) {
        const double th = u(rng) * pi / 2, td = u(rng) * pi / 2, pd = u(rng) * pi;
        const DirectionPair p = to_directions(th, td, pd);
        // h = Rz(phi_h = 0) Ry(theta_h) e_z; wi = the same rotation of d; wo of d turned by pi
        // about the pole.
        const Mat3 frame = mul(rot_z(0.0), rot_y(th));
        const Vec3 d = spherical(td, pd);
        const Vec3 wi = transform(frame, d), wo = transform(frame, transform(rot_z(pi), d));
        ASSERT_LT(max_abs_diff(p.wi, wi), 1e-14) << th << " " << td << " " << pd;
        ASSERT_LT(max_abs_diff(p.wo, wo), 1e-14);
        EXPECT_NEAR(dot(p.wi, p.wi), 1.0, 1e-15);
        // Defining properties: h bisects wi and wo, and wi makes the angle theta_d with h.
        const Vec3 h = spherical(th, 0.0);
        EXPECT_NEAR(dot(p.wi, h), std::cos(td), 1e-14);
        EXPECT_NEAR(dot(p.wo, h), std::cos(td), 1e-14);
        const Vec3 sum{p.wi.x + p.wo.x, p.wi.y + p.wo.y, p.wi.z + p.wo.z};
        EXPECT_NEAR(std::abs(dot(sum, h)), std::sqrt(dot(sum, sum)), 1e-13);
    }
}

TEST(HalfDiffConversion, ToHalfDiffMatchesRotationMatrices) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int n = 0; n < 20000; ++n) {
        const double ti = std::acos(u(rng)), to = std::acos(u(rng));
        const double pi_ = 2 * pi * u(rng), po = 2 * pi * u(rng);
        const Vec3 wi = spherical(ti, pi_), wo = spherical(to, po);
        const HalfDiff ref = reference_half_diff(wi, wo);
        const HalfDiff got = to_half_diff(wi, wo);
        // acos near 1 (the implementation follows the reference reader) costs ~1e-16 / theta.
        EXPECT_NEAR(got.theta_h, ref.theta_h, 1e-9) << ti << " " << pi_ << " " << to << " " << po;
        EXPECT_NEAR(got.theta_d, ref.theta_d, 1e-9);
        EXPECT_GE(got.phi_d, 0.0);
        EXPECT_LT(got.phi_d, pi);
        if (std::sin(ref.theta_d) > 1e-6) {
            EXPECT_LT(phi_distance(got.phi_d, ref.phi_d), 1e-9);
        }
    }
}

TEST(HalfDiffConversion, RoundTripsThroughDirections) {
    std::mt19937_64 rng(13);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int n = 0; n < 20000; ++n) {
        // Away from the poles of both frames, where azimuths are undefined.
        const double th = 0.01 + u(rng) * 1.5, td = 0.01 + u(rng) * 1.5, pd = u(rng) * pi;
        const HalfDiff back =
            to_half_diff(to_directions(th, td, pd).wi, to_directions(th, td, pd).wo);
        EXPECT_NEAR(back.theta_h, th, 1e-12);
        EXPECT_NEAR(back.theta_d, td, 1e-12);
        EXPECT_LT(phi_distance(back.phi_d, pd), 1e-11);
        const DirectionPair again = to_directions(back);
        EXPECT_LT(max_abs_diff(again.wi, to_directions(th, td, pd).wi), 1e-12);
    }
}

// docs/design.md: phi = 0 puts the viewer on the light's side (retro-reflection when
// theta_o = theta_i); phi = 180 degrees is the mirror side.
TEST(HalfDiffConversion, AngleConventionsOfTheDesign) {
    const double deg = pi / 180;
    const HalfDiff retro = to_half_diff(30 * deg, 30 * deg, 0.0);
    EXPECT_NEAR(retro.theta_h, 30 * deg, 1e-12);
    EXPECT_NEAR(retro.theta_d, 0.0, 1e-7);
    const HalfDiff mirror = to_half_diff(30 * deg, 30 * deg, 180 * deg);
    EXPECT_NEAR(mirror.theta_h, 0.0, 1e-7);
    EXPECT_NEAR(mirror.theta_d, 30 * deg, 1e-12);
    // In the plane of incidence on the light's side, light farther from the normal: phi_d = 0.
    const HalfDiff in_plane = to_half_diff(60 * deg, 20 * deg, 0.0);
    EXPECT_NEAR(in_plane.theta_h, 40 * deg, 1e-12);
    EXPECT_NEAR(in_plane.theta_d, 20 * deg, 1e-12);
    EXPECT_EQ(in_plane.phi_d, 0.0);
    // Out of the plane by 90 degrees: symmetric about the h plane, phi_d = 90 degrees.
    const DirectionPair p = to_directions(40 * deg, 20 * deg, 90 * deg);
    EXPECT_NEAR(p.wi.y, -p.wo.y, 1e-15);
    EXPECT_NEAR(p.wi.z, p.wo.z, 1e-15);
    // The convenience overload is the vector form with phi_i = 0.
    const HalfDiff a = to_half_diff(0.3, 0.7, 1.1);
    const HalfDiff b = to_half_diff(direction(0.3, 0.0), direction(0.7, 1.1));
    EXPECT_EQ(a.theta_h, b.theta_h);
    EXPECT_EQ(a.theta_d, b.theta_d);
    EXPECT_EQ(a.phi_d, b.phi_d);
}

// A line-by-line restatement of the reference reader's lookup (BRDFRead.cpp:
// std_coords_to_half_diff_coords and the three *_index functions), to pin bin compatibility.
std::size_t reference_reader_cell(double theta_in, double fi_in, double theta_out, double fi_out) {
    auto rotate = [](const double* v, const double* axis, double angle, double* out) {
        const double c = std::cos(angle), s = std::sin(angle);
        for (int i = 0; i < 3; ++i) out[i] = v[i] * c;
        double t = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2];
        t = t * (1.0 - c);
        for (int i = 0; i < 3; ++i) out[i] += axis[i] * t;
        const double cr[3] = {axis[1] * v[2] - axis[2] * v[1], axis[2] * v[0] - axis[0] * v[2],
                              axis[0] * v[1] - axis[1] * v[0]};
        for (int i = 0; i < 3; ++i) out[i] += cr[i] * s;
    };
    auto normalize = [](double* v) {
        const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        for (int i = 0; i < 3; ++i) v[i] /= len;
    };
    double in[3] = {std::sin(theta_in) * std::cos(fi_in), std::sin(theta_in) * std::sin(fi_in),
                    std::cos(theta_in)};
    double out[3] = {std::sin(theta_out) * std::cos(fi_out), std::sin(theta_out) * std::sin(fi_out),
                     std::cos(theta_out)};
    // The half vector is formed from the components before normalisation.
    double half[3] = {(in[0] + out[0]) / 2, (in[1] + out[1]) / 2, (in[2] + out[2]) / 2};
    normalize(in);
    normalize(out);
    normalize(half);
    const double theta_half = std::acos(half[2]), fi_half = std::atan2(half[1], half[0]);
    const double normal[3] = {0, 0, 1}, bi_normal[3] = {0, 1, 0};
    double temp[3], diff[3];
    rotate(in, normal, -fi_half, temp);
    rotate(temp, bi_normal, -theta_half, diff);
    const double theta_diff = std::acos(diff[2]);
    double fi_diff = std::atan2(diff[1], diff[0]);

    int ih = 0;
    if (theta_half > 0)
        ih = std::min(89, static_cast<int>(std::sqrt(theta_half / (pi / 2) * 90 * 90)));
    const int id = std::clamp(static_cast<int>(theta_diff / (pi * 0.5) * 90), 0, 89);
    if (fi_diff < 0) fi_diff += pi;
    const int ip = std::clamp(static_cast<int>(fi_diff / pi * 360 / 2), 0, 179);
    return std::size_t(ip) + std::size_t(id) * 180 + std::size_t(ih) * 180 * 90;
}

TEST(HalfDiffLookup, NearestCellMatchesTheReferenceReader) {
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int n = 0; n < 100000; ++n) {
        const double ti = u(rng) * pi / 2, to = u(rng) * pi / 2;
        const double fi = 2 * pi * u(rng), fo = 2 * pi * u(rng);
        ASSERT_EQ(nearest_cell(direction(ti, fi), direction(to, fo)),
                  reference_reader_cell(ti, fi, to, fo))
            << ti << " " << fi << " " << to << " " << fo;
        ASSERT_EQ(nearest_cell(ti, to, fo - fi), reference_reader_cell(ti, 0.0, to, fo - fi));
    }
    // Special configurations where the reference reader's signed zeros decide phi_d = 0 or pi:
    // normal incidence, in-plane and exactly mirrored directions.
    const double deg = pi / 180;
    for (int ti = 0; ti <= 90; ti += 5)
        for (int to = 0; to <= 90; to += 5)
            for (int phi : {0, 30, 90, 180, 270, 360})
                ASSERT_EQ(nearest_cell(ti * deg, to * deg, phi * deg),
                          reference_reader_cell(ti * deg, 0.0, to * deg, phi * deg))
                    << ti << " " << to << " " << phi;
    // Normal incidence lands in phi_d bin 179, as in the reference reader.
    // (theta_o = 40 degrees would put theta_h = theta_d = 20 degrees exactly on bin edges.)
    const CellIndices normal = cell_indices(nearest_cell(0.0, 41 * deg, 1.0));
    EXPECT_EQ(normal.phi_d, 179);
    EXPECT_EQ(normal.theta_d, 20); // 20.5 degrees
    EXPECT_EQ(normal.theta_h, 42); // sqrt(20.5/90) * 90 = 42.95
}

TEST(HalfDiffHorizon, BelowHorizonCellsAreThoseWithACentreDirectionAtOrBelowZ0) {
    std::size_t below = 0;
    double margin = 1.0;
    for (int i = 0; i < 90; ++i)
        for (int j = 0; j < 90; ++j)
            for (int k = 0; k < 180; ++k) {
                // z of wi and wo from the closed form of Ry(theta_h) d and Ry(theta_h) d'.
                const double th = std::pow((i + 0.5) / 90, 2) * pi / 2;
                const double td = (j + 0.5) / 90 * pi / 2, pd = (k + 0.5) / 180 * pi;
                const double a = std::cos(td) * std::cos(th);
                const double b = std::sin(td) * std::sin(th) * std::cos(pd);
                const bool expected = a - b <= 0 || a + b <= 0;
                ASSERT_EQ(cell_below_horizon(i, j, k), expected) << i << " " << j << " " << k;
                ASSERT_EQ(cell_below_horizon(cell_index(i, j, k)), expected);
                // The mask (built from each angle's sine and cosine once) is to_directions' horizon.
                const DirectionPair p = to_directions(theta_h_centre(i), theta_d_centre(j), phi_d_centre(k));
                ASSERT_EQ(cell_below_horizon(i, j, k), p.wi.z <= 0.0 || p.wo.z <= 0.0) << i << " " << j << " " << k;
                below += expected;
                margin = std::min({margin, std::abs(a - b), std::abs(a + b)});
            }
    EXPECT_EQ(below, 361784u);
    // The documented margin: no bin centre is near grazing, so rounding cannot flip a cell.
    EXPECT_GT(margin, 8e-7);
    EXPECT_FALSE(cell_below_horizon(0, 0, 0));
    EXPECT_FALSE(cell_below_horizon(89, 0, 0)); // theta_h ~ 89 deg, theta_d ~ 0.5 deg: both up
    EXPECT_TRUE(cell_below_horizon(89, 89, 0)); // grazing half vector, wide difference
    EXPECT_TRUE(cell_below_horizon(45, 89, 90) == cell_below_horizon(45, 89, 89));
}

// Reciprocity: swapping wi and wo turns phi_d into phi_d + pi, the same cell. Isotropy: rotating
// both about the normal changes nothing.
TEST(HalfDiffSymmetry, ReciprocityAndIsotropyKeepTheCell) {
    std::mt19937_64 rng(19);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int n = 0; n < 20000; ++n) {
        const double ti = u(rng) * pi / 2, to = u(rng) * pi / 2, fi = 2 * pi * u(rng),
                     fo = 2 * pi * u(rng), spin = 2 * pi * u(rng);
        const Vec3 wi = spherical(ti, fi), wo = spherical(to, fo);
        EXPECT_EQ(nearest_cell(wi, wo), nearest_cell(wo, wi));
        EXPECT_EQ(nearest_cell(wi, wo),
                  nearest_cell(spherical(ti, fi + spin), spherical(to, fo + spin)));
        const HalfDiff a = to_half_diff(wi, wo), b = to_half_diff(wo, wi);
        EXPECT_NEAR(a.theta_h, b.theta_h, 1e-12);
        EXPECT_NEAR(a.theta_d, b.theta_d, 1e-12);
        EXPECT_LT(phi_distance(a.phi_d, b.phi_d), 1e-9);
    }
}

// Mirroring a configuration in the plane of h and the normal (y -> -y) maps phi_d to -phi_d, which
// reciprocity folds to pi - phi_d: cell (i, j, k) and cell (i, j, 179 - k) are mirror images, so an
// isotropic BRDF has equal values there and both are below the horizon or neither is.
TEST(HalfDiffSymmetry, PhiDBinsMirrorAboutNinetyDegrees) {
    for (int i = 0; i < 90; i += 7)
        for (int j = 0; j < 90; j += 5)
            for (int k = 0; k < 180; ++k) {
                const DirectionPair p =
                    to_directions(theta_h_centre(i), theta_d_centre(j), phi_d_centre(k));
                const DirectionPair q =
                    to_directions(theta_h_centre(i), theta_d_centre(j), phi_d_centre(179 - k));
                ASSERT_LT(max_abs_diff(q.wi, {p.wo.x, -p.wo.y, p.wo.z}), 1e-14);
                ASSERT_LT(max_abs_diff(q.wo, {p.wi.x, -p.wi.y, p.wi.z}), 1e-14);
            }
    for (std::size_t cell = 0; cell < cells; ++cell) {
        const CellIndices c = cell_indices(cell);
        ASSERT_EQ(cell_below_horizon(cell),
                  cell_below_horizon(c.theta_h, c.theta_d, 179 - c.phi_d));
    }
}

} // namespace
} // namespace brdf::formats
