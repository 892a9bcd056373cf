#pragma once
// An isotropic BRDF table in the MERL half/difference layout (formats/halfdiff.h), the in-memory
// form of both the .binary and the .exr files.
//
// Values are BRDF in 1/sr (not the MERL file's scaled units), one plane per channel (R, G, B in
// linear Rec.709 primaries unless `colorspace` says otherwise), in MERL index order.
//
// A grey table (an analytic grey medium's fill: every channel the same) holds its values once, in
// the red plane; the green and blue planes are then empty and read as the red one (plane(), at(),
// has_data()). Its fill writes 12 MB of new memory instead of 35 (HG g 0.5's fill on PoCL: 33 ->
// 20 ms), and its files hold the same bytes as those of the same table with three equal planes.
//
// "No data": a cell either holds a BRDF >= 0 in all three channels, or BrdfTable::no_data (-1) in
// all three. -1 is what the MERL files hold there, so a table read from a .binary file carries
// exactly the file's cells; it is also a value no BRDF can take, so code that forgets to test
// has_data() sees an obviously wrong number rather than a plausible one. Cells whose bin centre
// lies below the horizon (cell_below_horizon) are always written as no data, whatever the table
// holds there.

#include <formats/halfdiff.h>

#include <brdf/core/unwritten_allocator.h>

#include <array>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace brdf::formats {

/// Red, green, blue; BRDF in 1/sr unless said otherwise.
using Rgb = std::array<double, 3>;

/// BrdfTable::colorspace is one of "rec709" (linear Rec.709 / sRGB primaries, D65: the default),
/// "acescg" (ACES AP1 primaries, ACES white point) or "rec2020" (ITU-R BT.2020 primaries, D65), the
/// spec's "colorspace" values.
inline constexpr const char* default_colorspace = "rec709";
/// What tables said before the identifiers above (OpenEXR files written then hold it): rec709.
inline constexpr const char* legacy_rec709_colorspace = "linear Rec.709 (sRGB primaries), D65";

/// "rec709", "acescg" or "rec2020" for those names in any case and for the legacy string; empty
/// for anything else.
std::string canonical_colorspace(std::string_view name);

/// "red", "green", "blue" for channel 0, 1, 2.
const char* channel_name(int channel);

/// One channel of a table: `cells` values, unwritten when made (brdf::UnwrittenAllocator: first
/// touched by what fills them, the fill's threads or a file read).
using TablePlane = std::vector<double, UnwrittenAllocator<double>>;

struct BrdfTable {
    /// The marker of a cell without data, in all three channels.
    static constexpr double no_data = -1.0;

    /// A table with every cell below the horizon marked no_data and every other cell 0.
    BrdfTable();
    /// A table of `cells` unwritten values per channel, for a caller that writes every cell,
    /// below the horizon too (a fill, a file read); a grey one holds only the red plane.
    struct Unwritten {};
    explicit BrdfTable(Unwritten, bool grey = false);

    /// channels[c][cell_index(i, j, k)]: BRDF in 1/sr (>= 0), or no_data. Each holds `cells`
    /// values, but for a grey table's green and blue planes, which are empty: read the channels
    /// through plane(c).
    std::array<TablePlane, 3> channels;
    /// True when only channels[0] holds values and it stands for all three.
    bool grey = false;
    /// The material spec (JSON text) the table was computed from; empty when unknown.
    std::string spec;
    /// Name and version of the program that made the table; empty when unknown.
    std::string generator;
    /// The RGB colour space of the values.
    std::string colorspace = default_colorspace;

    /// Channel c's values (the red plane for every channel of a grey table).
    const TablePlane& plane(int c) const { return channels[grey ? 0 : c]; }
    /// True when the cell holds data (all three channels >= 0). `cell` < cells.
    bool has_data(std::size_t cell) const {
        return plane(0)[cell] >= 0.0 && plane(1)[cell] >= 0.0 && plane(2)[cell] >= 0.0;
    }
    Rgb at(std::size_t cell) const { return {plane(0)[cell], plane(1)[cell], plane(2)[cell]}; }
    /// Sets a cell; a grey table keeps the red value alone (its writers set grey values).
    void set(std::size_t cell, const Rgb& rgb) {
        for (int c = 0; c < (grey ? 1 : 3); ++c) channels[c][cell] = rgb[c];
    }
    /// A grey table made into one of three planes (copies of the red one); others are left as
    /// they are.
    void make_full();
    void set_no_data(std::size_t cell) { set(cell, {no_data, no_data, no_data}); }
    /// Number of cells with data.
    std::size_t data_cells() const;
};

/// Geometry of one cell's bin centre, handed to tabulate().
struct CellCentre {
    std::size_t cell = 0;
    CellIndices index;
    HalfDiff angles;    ///< bin-centre angles, radians
    DirectionPair dirs; ///< unit vectors of the bin centre, both above the horizon
};

/// Fills a table by evaluating `brdf` (1/sr) at the bin centre of every cell above the horizon;
/// cells below it get no_data. Calls are made in cell order from the calling thread.
BrdfTable tabulate(const std::function<Rgb(const CellCentre&)>& brdf);

/// Checks the invariants writers rely on: every channel holds `cells` values (a grey table: the
/// red one, the others none), each finite, and each cell is either >= 0 in all three channels or
/// no_data in all three. Cells below the horizon are not checked (writers ignore them). Throws
/// NumericalError naming `what`, the first bad cell (channel, theta_h/theta_d/phi_d indices) and
/// the value.
void check_table(const BrdfTable& table, std::string_view what);

/// check_table in parts, for a writer that checks each block of cells as it converts it: the
/// channels' sizes (throws as check_table does), then whether cells [first, end) keep the
/// invariants (a vectorised count); where a block does not, check_table names the first bad cell.
void check_channel_sizes(const BrdfTable& table, std::string_view what);
bool cells_pass_check(const BrdfTable& table, std::size_t first, std::size_t end);

/// "cell theta_h 3, theta_d 4, phi_d 5" for error messages.
std::string describe_cell(std::size_t cell);

/// The table's value for one direction triple, as the MERL reference reader finds it.
struct TableSample {
    Rgb rgb{};             ///< BRDF in 1/sr; 0 where has_data is false
    std::size_t cell = 0;  ///< nearest_cell() of the configuration
    bool has_data = false; ///< false below the horizon and in no-data cells
};

/// Nearest-bin lookup (no interpolation, as the MERL reference reader and pbrt-v2 do): the cell of
/// nearest_cell(theta_i, theta_o, phi). theta_i, theta_o: zenith angles of light and viewer,
/// radians; phi = phi_o - phi_i, radians (0: viewer on the light's side; pi: mirror side). A
/// direction at or below the horizon (cos theta <= 0), and a cell without data, give has_data =
/// false and rgb = 0.
TableSample sample(const BrdfTable& table, double theta_i, double theta_o, double phi);
/// sample(...).rgb.
Rgb lookup(const BrdfTable& table, double theta_i, double theta_o, double phi);

/// Quadrature of directional_albedo: Gauss-Legendre in mu_o = cos theta_o over (0, 1) with
/// `mu_points` nodes times the midpoint rule in phi over [0, 2 pi) with `phi_points` nodes. The
/// table is piecewise constant, so neither rule is exact; with the defaults a white Lambertian
/// table gives 1 - 4e-5 for theta_i up to 85 degrees (tested; the loss is lookups near grazing that
/// land in cells whose bin centre is below the horizon), and doubling both counts changes it by <
/// 1e-6.
struct AlbedoQuadrature {
    int mu_points = 128;
    int phi_points = 256;
};

/// Directional-hemispherical reflectance rho(theta_i) = int f(theta_i, theta_o, phi) cos theta_o
/// d omega_o of the table (dimensionless, per channel), by table lookup (sample) at the nodes of
/// `quadrature`; no-data cells count as 0. theta_i in radians, [0, pi/2).
Rgb directional_albedo(const BrdfTable& table, double theta_i, AlbedoQuadrature quadrature = {});
/// The same rule for any BRDF at this theta_i: brdf(theta_o, phi) in 1/sr (a Fourier BSDF's
/// evaluate, say).
Rgb directional_albedo(const std::function<Rgb(double theta_o, double phi)>& brdf, double theta_i,
                       AlbedoQuadrature quadrature = {});

} // namespace brdf::formats
