#include <formats/exr/spectral_exr.h>

#include <formats/exr/exr.h>
#include <formats/exr/exr_detail.h>
#include <formats/exr/zip_writer.h>
#include <formats/table.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/std_regex.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

namespace brdf::formats {

namespace {

using detail::CoreHeader;
using detail::display;

// The paper's channel grammar (section 3; the regular expression of the authors' reference code):
// a type (S0..S3 emissive Stokes components, T reflective), '.', a number with ',' as the decimal
// separator and an optional exponent, an optional SI prefix, and the unit m or Hz.
const std::regex& channel_grammar() {
    static const std::regex grammar(
        R"(^(S[0-3]|T)\.(\d*,?\d*([Ee][+-]?\d+)?)(Y|Z|E|P|T|G|M|k|h|da|d|c|m|u|n|p)?(m|Hz)$)");
    return grammar;
}

// SI prefixes as powers of ten.
int prefix_exponent(const std::string& prefix) {
    static const std::map<std::string, int> exponents{
        {"Y", 24}, {"Z", 21}, {"E", 18}, {"P", 15},  {"T", 12}, {"G", 9},
        {"M", 6},  {"k", 3},  {"h", 2},  {"da", 1},  {"d", -1}, {"c", -2},
        {"m", -3}, {"u", -6}, {"n", -9}, {"p", -12}, {"", 0}};
    return exponents.at(prefix);
}

// value * 10^e, exactly rounded for the exponents of SI prefixes (powers of ten up to 10^22 are
// exact doubles, and one multiplication or division rounds once): "T.550nm" is 550 nm, not
// 550.00000000000006.
double times_power_of_ten(double value, int e) {
    double p = 1.0;
    for (int k = 0; k < std::abs(e); ++k) p *= 10.0;
    return e >= 0 ? value * p : value / p;
}

// Wavelength in nm of a matched channel name, or -1 when its number is not a positive finite one.
double wavelength_of(const std::smatch& m) {
    std::string number = m[2].str();
    std::replace(number.begin(), number.end(), ',', '.');
    if (number.empty() || number == ".") return -1.0;
    char* end = nullptr;
    const double value = std::strtod(number.c_str(), &end);
    if (end != number.c_str() + number.size() || !std::isfinite(value) || !(value > 0)) return -1.0;
    const int e = prefix_exponent(m[4].str());
    // Metres: nm = value 10^(e + 9). Hertz: wavelength = c / frequency, nm = c 10^(9 - e) / value.
    const double nm = m[5].str() == "Hz" ? times_power_of_ten(299792458.0, 9 - e) / value
                                         : times_power_of_ten(value, e + 9);
    return std::isfinite(nm) && nm > 0 ? nm : -1.0;
}

struct SpectralChannel {
    double wavelength_nm = 0.0;
    std::string name;
};

std::vector<SpectralChannel> spectral_channels(const CoreHeader& header,
                                               const std::filesystem::path& path) {
    std::vector<SpectralChannel> found;
    std::string emissive;
    for (const std::string& name : detail::channel_names(header)) {
        std::smatch m;
        if (!std::regex_match(name, m, channel_grammar())) continue;
        if (m[1].str() != "T") {
            if (emissive.empty()) emissive = name;
            continue;
        }
        const double nm = wavelength_of(m);
        if (!(nm > 0))
            throw FormatError(
                cat(display(path), ": channel ", name, " names no positive wavelength"));
        found.push_back({nm, name});
    }
    if (!emissive.empty())
        throw FormatError(cat(display(path), ": emissive spectral channel ", emissive,
                              " (a radiance image, not a BRDF table; reflective channels are "
                              "T.<wavelength>nm)"));
    if (found.empty())
        throw FormatError(cat(display(path),
                              ": no reflective spectral channel (T.<wavelength>nm, JCGT 2021 "
                              "spectral layout)"));
    if (found.size() > max_spectral_wavelengths)
        throw FormatError(cat(display(path), ": ", found.size(), " wavelengths (at most ",
                              max_spectral_wavelengths, ")"));
    std::sort(found.begin(), found.end(), [](const SpectralChannel& a, const SpectralChannel& b) {
        return a.wavelength_nm < b.wavelength_nm;
    });
    for (std::size_t k = 1; k < found.size(); ++k)
        if (found[k].wavelength_nm == found[k - 1].wavelength_nm)
            throw FormatError(cat(display(path), ": channels ", found[k - 1].name, " and ",
                                  found[k].name, " are the same wavelength (",
                                  found[k].wavelength_nm, " nm)"));
    const exr_attr_chlist_t* list = nullptr;
    exr_get_channels(header.context(), 0, &list);
    for (int i = 0; list && i < list->num_channels; ++i) {
        const exr_attr_chlist_entry_t& e = list->entries[i];
        const std::string name = e.name.str ? e.name.str : "";
        const bool spectral = std::any_of(found.begin(), found.end(),
                                          [&](const SpectralChannel& c) { return c.name == name; });
        if (spectral && (e.x_sampling != 1 || e.y_sampling != 1))
            throw FormatError(cat(display(path), ": channel ", name, " is subsampled (",
                                  e.x_sampling, " x ", e.y_sampling, ")"));
    }
    return found;
}

std::string format_wavelength(double nm, const char* format) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, format, nm);
    std::string s = buffer;
    std::replace(s.begin(), s.end(), '.', ',');
    return "T." + s + "nm";
}

} // namespace

SpectralTable::SpectralTable(std::vector<double> wavelengths)
    : wavelengths_nm(std::move(wavelengths)) {
    planes.assign(wavelengths_nm.size(), std::vector<float>(cells, 0.0f));
    for (std::size_t cell = 0; cell < cells; ++cell)
        if (cell_below_horizon(cell))
            for (auto& plane : planes) plane[cell] = no_data;
}

bool SpectralTable::has_data(std::size_t cell) const {
    return std::all_of(planes.begin(), planes.end(),
                       [cell](const std::vector<float>& p) { return p[cell] >= 0.0f; });
}

std::string spectral_channel_name(double nm) {
    // Six decimals, as the reference code writes them; more when six do not give the wavelength
    // back exactly.
    const std::string six = format_wavelength(nm, "%f");
    if (parse_spectral_channel(six) == nm) return six;
    return format_wavelength(nm, "%.17g");
}

double parse_spectral_channel(const std::string& name) {
    std::smatch m;
    if (!std::regex_match(name, m, channel_grammar()) || m[1].str() != "T") return -1.0;
    return wavelength_of(m);
}

SpectralTable read_spectral_exr(const std::filesystem::path& path) {
    const detail::InputFile file(path);
    detail::check_exr_magic(file);
    std::vector<SpectralChannel> channels;
    std::optional<std::string> spec, generator;
    {
        const CoreHeader header(file);
        detail::check_table_header(header, path);
        channels = spectral_channels(header, path);
        const std::optional<std::string> version = header.string_attribute("spectralLayoutVersion");
        if (!version)
            log::warn(display(path), ": no spectralLayoutVersion attribute (expected \"",
                      spectral_layout_version, "\"); reading it as that layout");
        else if (*version != spectral_layout_version)
            throw FormatError(cat(display(path), ": spectralLayoutVersion is \"", *version,
                                  "\" (this reader knows \"", spectral_layout_version, "\")"));
        spec = header.string_attribute("brdf.spec");
        generator = header.string_attribute("brdf.generator");
    }

    std::vector<double> wavelengths;
    for (const SpectralChannel& c : channels) wavelengths.push_back(c.wavelength_nm);
    SpectralTable table(wavelengths);
    table.spec = spec.value_or("");
    table.generator = generator.value_or("");
    // The header describes exactly one table of at most max_spectral_wavelengths planes.
    std::vector<detail::PlaneTarget> targets;
    for (std::size_t j = 0; j < channels.size(); ++j) targets.push_back({channels[j].name, table.planes[j].data()});
    detail::read_planes(file, targets);
    for (std::size_t j = 0; j < channels.size(); ++j) {
        std::vector<float>& plane = table.planes[j];
        for (std::size_t cell = 0; cell < cells; ++cell) {
            if (cell_below_horizon(cell)) {
                plane[cell] = SpectralTable::no_data; // whatever the file holds there
                continue;
            }
            const float v = plane[cell];
            if (!std::isfinite(v) || v < 0.0f)
                throw FormatError(cat(
                    display(path), std::isfinite(v) ? ": negative value " : ": non-finite value ",
                    detail::value_text(v), " in channel ", channels[j].name, " at ",
                    describe_cell(cell)));
        }
    }
    return table;
}

void write_spectral_exr(const std::filesystem::path& path, const SpectralTable& table) {
    const std::string where = display(path);
    const std::size_t n = table.wavelengths_nm.size();
    if (n == 0) throw InputError(cat(where, ": a spectral table needs at least one wavelength"));
    if (n > max_spectral_wavelengths)
        throw InputError(
            cat(where, ": ", n, " wavelengths (at most ", max_spectral_wavelengths, ")"));
    if (table.planes.size() != n)
        throw InputError(cat(where, ": ", table.planes.size(), " planes for ", n, " wavelengths"));
    for (std::size_t j = 0; j < n; ++j) {
        const double nm = table.wavelengths_nm[j];
        if (!std::isfinite(nm) || !(nm > 0))
            throw InputError(cat(where, ": wavelength ", detail::value_text(nm), " nm is not > 0"));
        if (j > 0 && !(nm > table.wavelengths_nm[j - 1]))
            throw InputError(cat(where, ": wavelengths not increasing (",
                                 table.wavelengths_nm[j - 1], " nm, then ", nm, " nm)"));
        if (table.planes[j].size() != cells)
            throw InputError(cat(where, ": the plane of ", nm, " nm holds ", table.planes[j].size(),
                                 " values (", cells, " expected)"));
    }
    std::size_t no_data_above_horizon = 0;
    for (std::size_t cell = 0; cell < cells; ++cell) {
        if (cell_below_horizon(cell)) continue;
        bool any_no_data = false, any_data = false;
        for (std::size_t j = 0; j < n; ++j) {
            const float v = table.planes[j][cell];
            if (v == SpectralTable::no_data) {
                any_no_data = true;
                continue;
            }
            if (!std::isfinite(v) || v < 0.0f)
                throw NumericalError(cat(where, ": ", std::isfinite(v) ? "negative" : "non-finite",
                                         " value ", detail::value_text(v), " at ",
                                         table.wavelengths_nm[j], " nm, ", describe_cell(cell)));
            any_data = true;
        }
        if (any_no_data && any_data)
            throw NumericalError(
                cat(where, ": ", describe_cell(cell), " is no data at some wavelengths only"));
        no_data_above_horizon += any_no_data;
    }
    if (no_data_above_horizon > 0)
        log::warn(where, ": ", no_data_above_horizon,
                  " cells above the horizon hold no data; OpenEXR tables store them as 0");

    std::vector<detail::PlaneSource> sources;
    for (std::size_t j = 0; j < n; ++j)
        sources.push_back({spectral_channel_name(table.wavelengths_nm[j]), table.planes[j].data()});
    detail::write_zip_table(path, sources,
                            {{"spectralLayoutVersion", spectral_layout_version},
                             {"brdf.layout", exr_layout},
                             {"brdf.units", exr_units},
                             {"brdf.spec", table.spec},
                             {"brdf.generator", table.generator}},
                            std::nullopt);
}

} // namespace brdf::formats
