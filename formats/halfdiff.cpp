#include <formats/halfdiff.h>

#include <cassert>
#include <cmath>
#include <cstdint>
#include <vector>

namespace brdf::formats {

std::size_t cell_index(int theta_h, int theta_d, int phi_d) {
    assert(theta_h >= 0 && theta_h < theta_h_bins);
    assert(theta_d >= 0 && theta_d < theta_d_bins);
    assert(phi_d >= 0 && phi_d < phi_d_bins);
    return static_cast<std::size_t>(phi_d) +
           std::size_t{phi_d_bins} *
               (static_cast<std::size_t>(theta_d) +
                std::size_t{theta_d_bins} * static_cast<std::size_t>(theta_h));
}

CellIndices cell_indices(std::size_t cell) {
    assert(cell < cells);
    CellIndices c;
    c.phi_d = static_cast<int>(cell % phi_d_bins);
    cell /= phi_d_bins;
    c.theta_d = static_cast<int>(cell % theta_d_bins);
    c.theta_h = static_cast<int>(cell / theta_d_bins);
    return c;
}

double theta_h_centre(int i) {
    const double u = (i + 0.5) / theta_h_bins;
    return u * u * (pi / 2);
}
double theta_d_centre(int j) {
    return (j + 0.5) / theta_d_bins * (pi / 2);
}
double phi_d_centre(int k) {
    return (k + 0.5) / phi_d_bins * pi;
}

namespace {

Vec3 normalized(const Vec3& v) {
    const double len = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    return {v.x / len, v.y / len, v.z / len};
}

// Rotation by `angle` about the unit axis k by Rodrigues' formula, evaluated as
// (v cos a + k (k . v)(1 - cos a)) + (k x v) sin a with the full dot and cross products: the order
// of operations of the MERL reference reader, so that bins, and the signed zeros that pick phi_d =
// 0 or pi on in-plane configurations, come out as they do there.
Vec3 rotate(const Vec3& v, const Vec3& k, double angle) {
    const double c = std::cos(angle), s = std::sin(angle);
    const double t = (k.x * v.x + k.y * v.y + k.z * v.z) * (1.0 - c);
    const Vec3 k_cross_v{k.y * v.z - k.z * v.y, k.z * v.x - k.x * v.z, k.x * v.y - k.y * v.x};
    return {v.x * c + k.x * t + k_cross_v.x * s, v.y * c + k.y * t + k_cross_v.y * s,
            v.z * c + k.z * t + k_cross_v.z * s};
}

// Half/difference angles with phi_d straight from atan2, in (-pi, pi]. As in the reference reader,
// the half vector comes from the vectors as given and the rotation from wi normalised.
HalfDiff raw_half_diff(const Vec3& wi, const Vec3& wo) {
    const Vec3 h = normalized({(wi.x + wo.x) / 2.0, (wi.y + wo.y) / 2.0, (wi.z + wo.z) / 2.0});
    const double theta_h = std::acos(h.z);
    const double phi_h = std::atan2(h.y, h.x);
    // d: wi in the frame where h is the pole (Rusinkiewicz 1998, section 3.1).
    const Vec3 d =
        rotate(rotate(normalized(wi), {0.0, 0.0, 1.0}, -phi_h), {0.0, 1.0, 0.0}, -theta_h);
    return {theta_h, std::acos(d.z), std::atan2(d.y, d.x)};
}

} // namespace

Vec3 direction(double theta, double phi) {
    const double s = std::sin(theta);
    return {s * std::cos(phi), s * std::sin(phi), std::cos(theta)};
}

DirectionPair to_directions(double theta_h, double theta_d, double phi_d) {
    const double sd = std::sin(theta_d), cd = std::cos(theta_d);
    const Vec3 d{sd * std::cos(phi_d), sd * std::sin(phi_d), cd};
    const double sh = std::sin(theta_h), ch = std::cos(theta_h);
    // Ry(theta_h) takes the pole to h = (sin theta_h, 0, cos theta_h); wo is d turned by pi about
    // h.
    auto to_world = [&](const Vec3& v) {
        return Vec3{v.x * ch + v.z * sh, v.y, -v.x * sh + v.z * ch};
    };
    return {to_world(d), to_world({-d.x, -d.y, d.z})};
}

DirectionPair to_directions(const HalfDiff& angles) {
    return to_directions(angles.theta_h, angles.theta_d, angles.phi_d);
}

HalfDiff to_half_diff(const Vec3& wi, const Vec3& wo) {
    HalfDiff a = raw_half_diff(wi, wo);
    if (a.phi_d < 0.0) a.phi_d += pi;
    if (a.phi_d >= pi) a.phi_d -= pi;
    return a;
}

DirectionPair directions_from_angles(double theta_i, double theta_o, double phi) {
    return {direction(theta_i, 0.0), direction(theta_o, phi)};
}

HalfDiff to_half_diff(double theta_i, double theta_o, double phi) {
    const DirectionPair p = directions_from_angles(theta_i, theta_o, phi);
    return to_half_diff(p.wi, p.wo);
}

int theta_h_index(double theta_h) {
    if (!(theta_h > 0.0)) return 0; // also NaN
    // sqrt(theta_h / (pi/2) * 90 * 90) rather than sqrt(theta_h / (pi/2)) * 90: the reference
    // reader's rounding, which decides bin edges such as theta_h = 40 degrees exactly.
    const double x = theta_h / (pi / 2) * theta_h_bins * theta_h_bins;
    const int i = static_cast<int>(std::min(std::sqrt(x), 1e9));
    return std::min(i, theta_h_bins - 1);
}

int theta_d_index(double theta_d) {
    if (!(theta_d > 0.0)) return 0;
    const int j = static_cast<int>(std::min(theta_d / (pi / 2) * theta_d_bins, 1e9));
    return std::min(j, theta_d_bins - 1);
}

int phi_d_index(double phi_d) {
    if (phi_d < 0.0) phi_d += pi;
    if (!(phi_d > 0.0)) return 0;
    const int k = static_cast<int>(std::min(phi_d / pi * phi_d_bins, 1e9));
    return std::min(k, phi_d_bins - 1);
}

std::size_t nearest_cell(const Vec3& wi, const Vec3& wo) {
    const HalfDiff a = raw_half_diff(wi, wo);
    return cell_index(theta_h_index(a.theta_h), theta_d_index(a.theta_d), phi_d_index(a.phi_d));
}

std::size_t nearest_cell(double theta_i, double theta_o, double phi) {
    const DirectionPair p = directions_from_angles(theta_i, theta_o, phi);
    return nearest_cell(p.wi, p.wo);
}

// One byte per cell, computed once: the writers ask for every cell of every table. The heights of
// to_directions' wi and wo from each bin centre's sine and cosine, taken once per angle rather than
// once per cell (six calls for each of the 1.46 M cells were 30 ms of every table): the same
// products of the same values, so the same horizon.
const std::vector<std::uint8_t>& below_horizon_mask() {
    static const std::vector<std::uint8_t> mask = [] {
        std::vector<double> sin_h(theta_h_bins), cos_h(theta_h_bins), sin_d(theta_d_bins),
            cos_d(theta_d_bins), cos_p(phi_d_bins);
        for (int i = 0; i < theta_h_bins; ++i)
            sin_h[i] = std::sin(theta_h_centre(i)), cos_h[i] = std::cos(theta_h_centre(i));
        for (int j = 0; j < theta_d_bins; ++j)
            sin_d[j] = std::sin(theta_d_centre(j)), cos_d[j] = std::cos(theta_d_centre(j));
        for (int k = 0; k < phi_d_bins; ++k) cos_p[k] = std::cos(phi_d_centre(k));
        std::vector<std::uint8_t> m(cells);
        for (int i = 0; i < theta_h_bins; ++i)
            for (int j = 0; j < theta_d_bins; ++j)
                for (int k = 0; k < phi_d_bins; ++k) {
                    const double dx = sin_d[j] * cos_p[k], dz = cos_d[j];
                    const double wi_z = -dx * sin_h[i] + dz * cos_h[i];
                    const double wo_z = dx * sin_h[i] + dz * cos_h[i]; // -(-d.x), exactly
                    m[cell_index(i, j, k)] = wi_z <= 0.0 || wo_z <= 0.0;
                }
        return m;
    }();
    return mask;
}

bool cell_below_horizon(std::size_t cell) {
    return below_horizon_mask()[cell] != 0;
}

bool cell_below_horizon(int theta_h, int theta_d, int phi_d) {
    return cell_below_horizon(cell_index(theta_h, theta_d, phi_d));
}

} // namespace brdf::formats
