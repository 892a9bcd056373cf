#include <brdf/material/spectrum.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/material/colour.h>
#include <brdf/material/embedded_data.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <optional>

namespace brdf::material {
namespace {

std::string join(const std::vector<std::string>& parts, std::string_view separator) {
    std::string out;
    for (std::size_t i = 0; i < parts.size(); ++i) {
        if (i) out += separator;
        out += parts[i];
    }
    return out;
}

// A CSV table of numbers: '#' comment lines, one header line, then rows of `columns` numbers.
std::vector<std::vector<double>> read_csv(std::string_view path, std::size_t columns) {
    const std::optional<std::string_view> text = find_embedded(embedded::material_data(), path);
    if (!text) throw FormatError(cat("data/", path, ": not embedded in this binary"));
    std::vector<std::vector<double>> rows;
    bool header = false;
    int number = 0;
    std::size_t start = 0;
    while (start < text->size()) {
        std::size_t end = text->find('\n', start);
        if (end == std::string_view::npos) end = text->size();
        std::string_view line = text->substr(start, end - start);
        start = end + 1;
        ++number;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (line.empty() || line.front() == '#') continue;
        if (!header) { // column names
            header = true;
            continue;
        }
        std::vector<double> row;
        std::size_t pos = 0;
        while (pos <= line.size()) {
            std::size_t comma = line.find(',', pos);
            if (comma == std::string_view::npos) comma = line.size();
            const std::string_view field = line.substr(pos, comma - pos);
            double value = 0.0;
            const auto [ptr, ec] =
                std::from_chars(field.data(), field.data() + field.size(), value);
            if (field.empty() || ec != std::errc() || ptr != field.data() + field.size() ||
                !std::isfinite(value))
                throw FormatError(
                    cat("data/", path, ":", number, ": '", field, "' is not a finite number"));
            row.push_back(value);
            pos = comma + 1;
        }
        if (row.size() != columns)
            throw FormatError(
                cat("data/", path, ":", number, ": ", row.size(), " columns, expected ", columns));
        rows.push_back(std::move(row));
    }
    if (rows.empty()) throw FormatError(cat("data/", path, ": no data rows"));
    return rows;
}

CieTables load_cie() {
    CieTables t;
    const auto observer = read_csv("cie/cie1931_2deg_5nm.csv", 4);
    const auto d65 = read_csv("cie/cie_d65_5nm.csv", 2);
    std::map<double, double> d65_at;
    for (const auto& r : d65) d65_at[r[0]] = r[1];
    for (const auto& r : observer) {
        if (!t.wavelength_nm.empty() && r[0] != t.wavelength_nm.back() + 5.0)
            throw FormatError(cat("data/cie/cie1931_2deg_5nm.csv: wavelength ", r[0],
                                  " nm breaks the 5 nm grid"));
        const auto it = d65_at.find(r[0]);
        if (it == d65_at.end())
            throw FormatError(cat("data/cie/cie_d65_5nm.csv: no value at ", r[0], " nm"));
        t.wavelength_nm.push_back(r[0]);
        t.xbar.push_back(r[1]);
        t.ybar.push_back(r[2]);
        t.zbar.push_back(r[3]);
        t.d65.push_back(it->second);
    }
    if (t.wavelength_nm.front() > visible_min_nm || t.wavelength_nm.back() < visible_max_nm)
        throw FormatError("data/cie/cie1931_2deg_5nm.csv: does not cover 380-780 nm");
    return t;
}

// The inverse of the IEC matrix (adjugate over determinant).
std::array<std::array<double, 3>, 3> rec709_to_xyz_matrix() {
    const auto& m = xyz_to_rec709_matrix;
    std::array<std::array<double, 3>, 3> inv{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
            inv[i][j] = m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1];
        }
    const double det = m[0][0] * inv[0][0] + m[0][1] * inv[1][0] + m[0][2] * inv[2][0];
    for (auto& row : inv)
        for (double& v : row) v /= det;
    return inv;
}

// Problems of a wavelength list, in list order; `limits`: also check the explicit-list range.
std::vector<std::string> list_problems(std::span<const double> wl, std::string_view path,
                                       bool limits) {
    std::vector<std::string> problems;
    if (wl.empty()) problems.push_back(cat(path, ": needs at least one wavelength"));
    for (std::size_t i = 0; i < wl.size(); ++i) {
        if (!(std::isfinite(wl[i]) && wl[i] > 0.0)) {
            problems.push_back(
                cat(path, "[", i, "]: must be a finite wavelength > 0 nm (got ", wl[i], ")"));
            continue;
        }
        if (limits && (wl[i] < explicit_min_nm || wl[i] > explicit_max_nm))
            problems.push_back(cat(path, "[", i, "]: must be within ", explicit_min_nm, "-",
                                   explicit_max_nm, " nm (got ", wl[i], ")"));
        if (i > 0 && std::isfinite(wl[i - 1]) && !(wl[i] > wl[i - 1]))
            problems.push_back(cat(path, "[", i, "]: ", wl[i], " nm is not greater than ", path,
                                   "[", i - 1, "] = ", wl[i - 1],
                                   " nm (list the wavelengths in increasing order, without "
                                   "repeats)"));
    }
    return problems;
}

} // namespace

const CieTables& cie_tables() {
    static const CieTables tables = load_cie();
    return tables;
}

Chromaticity chromaticity(const Tristimulus& xyz) {
    const double sum = xyz[0] + xyz[1] + xyz[2];
    return {xyz[0] / sum, xyz[1] / sum};
}

Rgb xyz_to_linear_rec709(const Tristimulus& xyz) {
    Rgb rgb{};
    for (int c = 0; c < 3; ++c)
        for (int i = 0; i < 3; ++i) rgb[c] += xyz_to_rec709_matrix[c][i] * xyz[i];
    return rgb;
}

std::vector<std::string> wavelength_list_problems(std::span<const double> wavelengths_nm,
                                                  std::string_view path) {
    return list_problems(wavelengths_nm, path, true);
}

std::string_view SpectralSet::name() const {
    switch (m_kind) {
    case Kind::Visible:
        return "visible";
    case Kind::RgbWavelengths:
        return "rgb";
    case Kind::Explicit:
        return "wavelengths";
    }
    return "unknown";
}

SpectralSet SpectralSet::integrate(std::vector<double> wl, Kind kind) {
    const CieTables& cie = cie_tables();
    SpectralSet set;
    set.m_kind = kind;
    set.m_xyz.assign(wl.size(), Tristimulus{0.0, 0.0, 0.0});
    double white_y = 0.0;
    for (std::size_t i = 0; i < cie.wavelength_nm.size(); ++i) {
        const double l = cie.wavelength_nm[i];
        if (l < visible_min_nm || l > visible_max_nm) continue;
        const Tristimulus cmf{cie.xbar[i] * cie.d65[i], cie.ybar[i] * cie.d65[i],
                              cie.zbar[i] * cie.d65[i]};
        white_y += cmf[1];
        // Hat functions of the piecewise-linear interpolant, constant beyond the ends.
        auto add = [&](std::size_t j, double h) {
            for (int c = 0; c < 3; ++c) set.m_xyz[j][c] += h * cmf[c];
        };
        if (l <= wl.front()) {
            add(0, 1.0);
        } else if (l >= wl.back()) {
            add(wl.size() - 1, 1.0);
        } else {
            const std::size_t j = static_cast<std::size_t>(
                std::upper_bound(wl.begin(), wl.end(), l) - wl.begin()); // wl[j-1] <= l < wl[j]
            const double t = (l - wl[j - 1]) / (wl[j] - wl[j - 1]);
            add(j - 1, 1.0 - t);
            add(j, t);
        }
    }
    for (Tristimulus& w : set.m_xyz)
        for (double& v : w) v /= white_y;
    set.m_rgb.resize(wl.size());
    Rgb white{0.0, 0.0, 0.0};
    for (std::size_t j = 0; j < wl.size(); ++j) {
        set.m_rgb[j] = xyz_to_linear_rec709(set.m_xyz[j]);
        for (int c = 0; c < 3; ++c) white[c] += set.m_rgb[j][c];
    }
    for (int c = 0; c < 3; ++c) set.m_balance[c] = 1.0 / white[c];
    for (Rgb& w : set.m_rgb)
        for (int c = 0; c < 3; ++c) w[c] *= set.m_balance[c];
    set.m_wavelengths = std::move(wl);
    set.add_other_spaces();
    return set;
}

void SpectralSet::add_other_spaces() {
    for (ColorSpace space : {ColorSpace::AcesCg, ColorSpace::Rec2020}) {
        std::vector<Rgb>& out = space == ColorSpace::AcesCg ? m_acescg : m_rec2020;
        out.clear();
        if (m_kind == Kind::RgbWavelengths) {
            // Not colorimetric: the Rec.709 identity weights, converted as a Rec.709 colour is.
            const Matrix3 from_rec709 = inverse(rgb_to_rec709_matrix(space));
            for (const Rgb& w : m_rgb) out.push_back(apply_matrix(from_rec709, w));
        } else {
            for (const Tristimulus& w : m_xyz) out.push_back(xyz_to_rgb(w, space));
        }
    }
}

std::span<const Rgb> SpectralSet::rgb_weights(ColorSpace space) const {
    switch (space) {
    case ColorSpace::Rec709:
        return m_rgb;
    case ColorSpace::AcesCg:
        return m_acescg;
    case ColorSpace::Rec2020:
        return m_rec2020;
    }
    return m_rgb;
}

SpectralSet SpectralSet::visible() {
    std::vector<double> wl;
    for (int l = 380; l <= 780; l += 10) wl.push_back(l);
    return integrate(std::move(wl), Kind::Visible);
}

SpectralSet SpectralSet::rgb() {
    SpectralSet set;
    set.m_kind = Kind::RgbWavelengths;
    set.m_wavelengths.assign(rgb_wavelengths_nm.begin(), rgb_wavelengths_nm.end());
    // Ascending wavelengths are blue, green, red.
    set.m_rgb = {Rgb{0.0, 0.0, 1.0}, Rgb{0.0, 1.0, 0.0}, Rgb{1.0, 0.0, 0.0}};
    const auto inv = rec709_to_xyz_matrix();
    for (const Rgb& w : set.m_rgb) {
        Tristimulus xyz{};
        for (int i = 0; i < 3; ++i)
            for (int c = 0; c < 3; ++c) xyz[i] += inv[i][c] * w[c];
        set.m_xyz.push_back(xyz);
    }
    set.add_other_spaces();
    return set;
}

SpectralSet SpectralSet::from_wavelengths(std::span<const double> wavelengths_nm,
                                          std::string_view path) {
    if (wavelengths_nm.size() > max_explicit_wavelengths)
        throw LimitError(cat(path, ": ", wavelengths_nm.size(), " wavelengths exceed the limit of ",
                             max_explicit_wavelengths));
    const auto problems = wavelength_list_problems(wavelengths_nm, path);
    if (!problems.empty()) throw InputError(join(problems, "; "));
    return integrate({wavelengths_nm.begin(), wavelengths_nm.end()}, Kind::Explicit);
}

SpectralSet SpectralSet::integrating(std::span<const double> wavelengths_nm) {
    const auto problems = list_problems(wavelengths_nm, "wavelengths_nm", false);
    if (!problems.empty()) throw InputError(join(problems, "; "));
    return integrate({wavelengths_nm.begin(), wavelengths_nm.end()}, Kind::Explicit);
}

Rgb SpectralSet::to_rgb(std::span<const double> values) const {
    if (values.size() != size())
        throw InputError(cat("SpectralSet ", name(), ": ", values.size(), " values for ", size(),
                             " wavelengths"));
    Rgb rgb{0.0, 0.0, 0.0};
    for (std::size_t j = 0; j < size(); ++j)
        for (int c = 0; c < 3; ++c) rgb[c] += m_rgb[j][c] * values[j];
    return rgb;
}

Rgb SpectralSet::to_rgb(std::span<const double> values, ColorSpace space) const {
    if (values.size() != size())
        throw InputError(cat("SpectralSet ", name(), ": ", values.size(), " values for ", size(),
                             " wavelengths"));
    const std::span<const Rgb> w = rgb_weights(space);
    Rgb rgb{0.0, 0.0, 0.0};
    for (std::size_t j = 0; j < size(); ++j)
        for (int c = 0; c < 3; ++c) rgb[c] += w[j][c] * values[j];
    return rgb;
}

Tristimulus SpectralSet::to_xyz(std::span<const double> values) const {
    if (values.size() != size())
        throw InputError(cat("SpectralSet ", name(), ": ", values.size(), " values for ", size(),
                             " wavelengths"));
    Tristimulus xyz{0.0, 0.0, 0.0};
    for (std::size_t j = 0; j < size(); ++j)
        for (int c = 0; c < 3; ++c) xyz[c] += m_xyz[j][c] * values[j];
    return xyz;
}

Tristimulus reflectance_to_xyz(std::span<const double> wavelengths_nm,
                               std::span<const double> reflectance) {
    return SpectralSet::integrating(wavelengths_nm).to_xyz(reflectance);
}

Rgb reflectance_to_rgb(std::span<const double> wavelengths_nm,
                       std::span<const double> reflectance) {
    return SpectralSet::integrating(wavelengths_nm).to_rgb(reflectance);
}

Rgb reflectance_to_rgb(std::span<const double> wavelengths_nm, std::span<const double> reflectance,
                       ColorSpace space) {
    return SpectralSet::integrating(wavelengths_nm).to_rgb(reflectance, space);
}

} // namespace brdf::material
