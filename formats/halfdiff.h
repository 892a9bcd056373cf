#pragma once
// The MERL half/difference table layout shared by the .binary and .exr tables (Matusik et al., "A
// Data-Driven Reflectance Model", SIGGRAPH 2003; the angles are those of Rusinkiewicz, "A New
// Change of Variables for Efficient BRDF Representation", EGWR 1998, section 3).
//
// Conventions (docs/design.md, "Angle and unit conventions"): the normal is +z, directions point
// away from the surface, all angles are in radians. An isotropic BRDF is a function of
//   theta_h  zenith angle of the half vector h = normalize(wi + wo), [0, pi/2]
//   theta_d  angle between wi and h, [0, pi/2]
//   phi_d    azimuth of wi about h in the frame where h is the pole and phi_h = 0, [0, pi)
// phi_d and phi_d + pi swap wi and wo, so by reciprocity the table stores [0, pi) only.
//
// Cell (i, j, k) = (theta_h, theta_d, phi_d index) sits at cell_index(i, j, k) in a plane of
// 90 x 90 x 180 cells. theta_h is binned on the square-root scale: bin i covers
// theta_h in [(i/90)^2, ((i+1)/90)^2] * pi/2, which puts half the bins within 21 degrees of the
// specular peak. theta_d and phi_d bins are uniform.

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace brdf::formats {

inline constexpr double pi = 3.14159265358979323846;

inline constexpr int theta_h_bins = 90;
inline constexpr int theta_d_bins = 90;
inline constexpr int phi_d_bins = 180;
/// Cells in one channel plane: 90 * 90 * 180 = 1,458,000.
inline constexpr std::size_t cells = std::size_t{theta_h_bins} * theta_d_bins * phi_d_bins;

/// Index of cell (theta_h, theta_d, phi_d) in a plane: phi_d + 180*theta_d + 180*90*theta_h.
/// Arguments must be in range (checked only in debug builds).
std::size_t cell_index(int theta_h, int theta_d, int phi_d);

/// The bin indices of a cell; the inverse of cell_index. `cell` < cells.
struct CellIndices {
    int theta_h = 0; ///< [0, 90)
    int theta_d = 0; ///< [0, 90)
    int phi_d = 0;   ///< [0, 180)
};
CellIndices cell_indices(std::size_t cell);

/// Bin centres in index space, radians: theta_h ((i + 0.5)/90)^2 * pi/2, theta_d (j + 0.5)/90 *
/// pi/2, phi_d (k + 0.5)/180 * pi.
double theta_h_centre(int i);
double theta_d_centre(int j);
double phi_d_centre(int k);

struct Vec3 {
    double x = 0.0, y = 0.0, z = 0.0;
};

/// Half/difference angles of a pair of directions, radians.
struct HalfDiff {
    double theta_h = 0.0; ///< [0, pi]
    double theta_d = 0.0; ///< [0, pi]
    double phi_d = 0.0;   ///< [0, pi) (reduced by reciprocity)
};

/// An incident and an outgoing unit vector, both pointing away from the surface.
struct DirectionPair {
    Vec3 wi; ///< towards the light
    Vec3 wo; ///< towards the viewer
};

/// Unit vector from spherical angles (radians): (sin theta cos phi, sin theta sin phi, cos theta),
/// not renormalised (as the reference reader builds it).
Vec3 direction(double theta, double phi);

/// Directions of a half/difference configuration with phi_h = 0 (Rusinkiewicz 1998, eq. 2
/// inverted): wi = Rz(phi_h) Ry(theta_h) d with d = (sin theta_d cos phi_d, sin theta_d sin phi_d,
/// cos theta_d), and wo is d rotated by pi about h. Angles in radians.
DirectionPair to_directions(double theta_h, double theta_d, double phi_d);
DirectionPair to_directions(const HalfDiff& angles);

/// Half/difference angles of two unit vectors (not opposite). phi_d is reduced to [0, pi).
/// Computed in the reference reader's order of operations (half vector from the vectors as given).
HalfDiff to_half_diff(const Vec3& wi, const Vec3& wo);

/// Directions for (theta_i, theta_o, phi = phi_o - phi_i) with the light at phi_i = 0:
/// wi = direction(theta_i, 0), wo = direction(theta_o, phi). Radians. phi = 0 puts the viewer on
/// the light's side, phi = pi on the mirror side.
DirectionPair directions_from_angles(double theta_i, double theta_o, double phi);
/// to_half_diff(directions_from_angles(theta_i, theta_o, phi)).
HalfDiff to_half_diff(double theta_i, double theta_o, double phi);

/// Continuous angle -> bin, exactly as the MERL reference reader (BRDFRead.cpp) does it:
///   theta_h: floor(sqrt(theta_h / (pi/2) * 90 * 90)), 0 for theta_h <= 0
///   theta_d: floor(theta_d / (pi/2) * 90)
///   phi_d:   phi_d + pi if phi_d < 0, then floor(phi_d / pi * 180)
/// each clamped to the valid range. Arguments in radians; NaN maps to bin 0.
int theta_h_index(double theta_h);
int theta_d_index(double theta_d);
int phi_d_index(double phi_d);

/// The cell the MERL reference reader uses for this pair of directions. It works from the raw
/// atan2 azimuth in (-pi, pi], as the reference reader does, so phi_d = pi exactly (an in-plane
/// configuration with the light nearer the normal than the viewer, e.g. normal incidence) lands in
/// bin 179 as it does there, while to_half_diff reports it as phi_d = 0 (bin 0). Both bins adjoin
/// phi_d = 0 == pi, and the values of a reciprocal isotropic BRDF agree there.
std::size_t nearest_cell(const Vec3& wi, const Vec3& wo);
/// nearest_cell(directions_from_angles(theta_i, theta_o, phi)); radians.
std::size_t nearest_cell(double theta_i, double theta_o, double phi);

/// True when the incident or the outgoing direction of the bin centre of cell (i, j, k) lies on or
/// below the horizon (z <= 0); 361,784 of the 1,458,000 cells are. No bin centre has |z| below
/// 8.3e-7 (tested), far above rounding error, so whether z = 0 counts as below (it does: a grazing
/// direction receives or sends no light) never decides a cell.
bool cell_below_horizon(int theta_h, int theta_d, int phi_d);
bool cell_below_horizon(std::size_t cell);
/// below_horizon_mask()[cell] != 0 where cell_below_horizon(cell): one byte per cell, computed once,
/// for loops over every cell (a call per cell cost more than the loops' own work).
const std::vector<std::uint8_t>& below_horizon_mask();

} // namespace brdf::formats
