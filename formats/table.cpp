#include <formats/table.h>

#include <formats/file_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/quadrature.h>

#include <cctype>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace brdf::formats {

const char* channel_name(int channel) {
    static const char* const names[3] = {"red", "green", "blue"};
    return channel >= 0 && channel < 3 ? names[channel] : "?";
}

std::string canonical_colorspace(std::string_view name) {
    if (name == legacy_rec709_colorspace) return default_colorspace;
    std::string lower(name);
    for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    for (const char* known : {"rec709", "acescg", "rec2020"})
        if (lower == known) return known;
    return {};
}

BrdfTable::BrdfTable() {
    for (auto& plane : channels) plane.assign(cells, 0.0);
    for (std::size_t cell = 0; cell < cells; ++cell)
        if (cell_below_horizon(cell)) set_no_data(cell);
}

BrdfTable::BrdfTable(Unwritten, bool grey_table) : grey(grey_table) {
    for (int c = 0; c < (grey ? 1 : 3); ++c) channels[c].resize(cells);
}

void BrdfTable::make_full() {
    if (!grey) return;
    channels[1] = channels[2] = channels[0];
    grey = false;
}

std::size_t BrdfTable::data_cells() const {
    std::size_t n = 0;
    for (std::size_t cell = 0; cell < cells; ++cell) n += has_data(cell);
    return n;
}

BrdfTable tabulate(const std::function<Rgb(const CellCentre&)>& brdf) {
    BrdfTable table;
    CellCentre centre;
    for (int i = 0; i < theta_h_bins; ++i)
        for (int j = 0; j < theta_d_bins; ++j)
            for (int k = 0; k < phi_d_bins; ++k) {
                const std::size_t cell = cell_index(i, j, k);
                if (cell_below_horizon(cell)) continue; // already no_data
                centre.cell = cell;
                centre.index = {i, j, k};
                centre.angles = {theta_h_centre(i), theta_d_centre(j), phi_d_centre(k)};
                centre.dirs = to_directions(centre.angles);
                table.set(cell, brdf(centre));
            }
    return table;
}

std::string describe_cell(std::size_t cell) {
    const CellIndices c = cell_indices(cell);
    return cat("cell theta_h ", c.theta_h, ", theta_d ", c.theta_d, ", phi_d ", c.phi_d);
}

namespace {

// Whether a cell keeps check_table's invariants: below the horizon, or finite and >= 0 in all three
// channels, or no data in all three. Without branches, so that a loop over cells vectorises.
struct CellCheck {
    const std::uint8_t* below;
    const double *r, *g, *b;
    bool operator()(std::size_t cell) const {
        constexpr double big = std::numeric_limits<double>::max();
        const double x = r[cell], y = g[cell], z = b[cell];
        const bool data = (x >= 0.0) & (x <= big) & (y >= 0.0) & (y <= big) & (z >= 0.0) & (z <= big);
        const bool none = (x == BrdfTable::no_data) & (y == BrdfTable::no_data) & (z == BrdfTable::no_data);
        return (below[cell] != 0) | data | none;
    }
};

CellCheck cell_check(const BrdfTable& table) {
    return {below_horizon_mask().data(), table.plane(0).data(), table.plane(1).data(),
            table.plane(2).data()};
}

// The first cell that breaks the invariants, or `cells`: blocks of cells counted (a vectorised
// loop), then the first block with a bad cell cell by cell.
std::size_t first_bad_cell(const BrdfTable& table) {
    const CellCheck ok = cell_check(table);
    constexpr std::size_t block = 4096;
    for (std::size_t start = 0; start < cells; start += block) {
        const std::size_t end = std::min(cells, start + block);
        if (cells_pass_check(table, start, end)) continue;
        for (std::size_t cell = start; cell < end; ++cell)
            if (!ok(cell)) return cell;
    }
    return cells;
}

} // namespace

void check_channel_sizes(const BrdfTable& table, std::string_view what) {
    for (int c = 0; c < 3; ++c) {
        const std::size_t expected = table.grey && c > 0 ? 0 : cells;
        if (table.channels[c].size() != expected)
            throw NumericalError(cat(what, ": the ", channel_name(c), " channel holds ",
                                     table.channels[c].size(), " values (", expected, " expected",
                                     table.grey ? " in a grey table" : "", ")"));
    }
}

bool cells_pass_check(const BrdfTable& table, std::size_t first, std::size_t end) {
    const CellCheck ok = cell_check(table);
    std::size_t bad = 0;
    for (std::size_t cell = first; cell < end; ++cell) bad += !ok(cell);
    return bad == 0;
}

void check_table(const BrdfTable& table, std::string_view what) {
    check_channel_sizes(table, what);
    const std::size_t cell = first_bad_cell(table);
    if (cell == cells) return;
    // Not all three no data, so some channel is negative or not finite: the first is named.
    const Rgb v = table.at(cell);
    for (int c = 0; c < 3; ++c)
        if (!std::isfinite(v[c]) || v[c] < 0.0)
            throw NumericalError(cat(what, ": ", channel_name(c), " value ", detail::value_text(v[c]), " at ",
                                     describe_cell(cell),
                                     " (a BRDF must be finite and >= 0, or -1 in all three "
                                     "channels for no data)"));
    throw InternalError(cat(what, ": check_table found ", describe_cell(cell), " bad but no bad value"));
}

TableSample sample(const BrdfTable& table, double theta_i, double theta_o, double phi) {
    TableSample s;
    const DirectionPair p = directions_from_angles(theta_i, theta_o, phi);
    s.cell = nearest_cell(p.wi, p.wo);
    if (!(p.wi.z > 0.0 && p.wo.z > 0.0) || !table.has_data(s.cell)) return s;
    s.rgb = table.at(s.cell);
    s.has_data = true;
    return s;
}

Rgb lookup(const BrdfTable& table, double theta_i, double theta_o, double phi) {
    return sample(table, theta_i, theta_o, phi).rgb;
}

Rgb directional_albedo(const BrdfTable& table, double theta_i, AlbedoQuadrature quadrature) {
    return directional_albedo(
        [&](double theta_o, double phi) { return lookup(table, theta_i, theta_o, phi); }, theta_i,
        quadrature);
}

Rgb directional_albedo(const std::function<Rgb(double theta_o, double phi)>& brdf, double theta_i,
                       AlbedoQuadrature quadrature) {
    if (quadrature.mu_points < 1 || quadrature.phi_points < 1 || quadrature.mu_points > 100000 ||
        quadrature.phi_points > 100000)
        throw InputError(cat("directional_albedo: quadrature of ", quadrature.mu_points, " x ",
                             quadrature.phi_points, " points (each must be in [1, 100000])"));
    Rgb rho{0.0, 0.0, 0.0};
    if (!(std::cos(theta_i) > 0.0)) return rho;
    // rho = int_0^1 mu dmu int_0^{2 pi} f dphi.
    const Quadrature mu = gauss_legendre(quadrature.mu_points, 0.0, 1.0);
    const double dphi = 2.0 * pi / quadrature.phi_points;
    for (std::size_t m = 0; m < mu.size(); ++m) {
        const double theta_o = std::acos(mu.x[m]);
        Rgb ring{0.0, 0.0, 0.0};
        for (int n = 0; n < quadrature.phi_points; ++n) {
            const Rgb f = brdf(theta_o, (n + 0.5) * dphi);
            for (int c = 0; c < 3; ++c) ring[c] += f[c];
        }
        for (int c = 0; c < 3; ++c) rho[c] += mu.w[m] * mu.x[m] * ring[c] * dphi;
    }
    return rho;
}

} // namespace brdf::formats
