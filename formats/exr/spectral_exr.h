#pragma once
// Spectral BRDF tables in OpenEXR, in the layout of Fichet, Pacanowski and Wilkie, "An OpenEXR
// Layout for Spectral Images", JCGT 10(3), 2021, for REFLECTIVE spectra: one 32-bit float channel
// per wavelength named "T.<wavelength>nm" with a comma as the decimal separator (the channel of
// 550 nm is "T.550,000000nm", as the authors' reference code spells it), and the string attribute
// spectralLayoutVersion = "1.0". The image is the OpenEXR table's (formats/exr/exr.h): width 180
// (phi_d bins), height 8100 (row = 90 theta_h index + theta_d index), ZIP compression, BRDF values
// in 1/sr, cells below the horizon 0, with the attributes brdf.layout, brdf.units = "1/sr",
// brdf.spec, brdf.generator. docs/formats.md, "Spectral OpenEXR", has the details.

#include <formats/halfdiff.h>

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace brdf::formats {

inline constexpr const char* spectral_layout_version = "1.0";
/// At most this many wavelengths: the spec's limit for explicit lists (material::
/// max_explicit_wavelengths). A table of that many takes 5.8 GB in memory.
inline constexpr std::size_t max_spectral_wavelengths = 1000;

/// A BRDF table with one plane per wavelength, in the MERL cells (formats/halfdiff.h).
struct SpectralTable {
    /// The marker of a cell without data, in every plane.
    static constexpr float no_data = -1.0f;

    SpectralTable() = default;
    /// Planes for these wavelengths with every cell below the horizon no_data and the rest 0.
    explicit SpectralTable(std::vector<double> wavelengths);

    /// Vacuum wavelengths in nm, strictly increasing, > 0.
    std::vector<double> wavelengths_nm;
    /// planes[j][cell]: BRDF in 1/sr at wavelengths_nm[j] (>= 0), or no_data. float: what the file
    /// holds, and half the memory of double for 41 planes of 1,458,000 cells.
    std::vector<std::vector<float>> planes;
    std::string spec;      ///< the material spec JSON; empty when unknown
    std::string generator; ///< name and version of the program; empty when unknown

    bool has_data(std::size_t cell) const;
};

/// "T.550,000000nm": the reflective channel of a wavelength in nm (6 decimals, comma).
std::string spectral_channel_name(double wavelength_nm);
/// The wavelength in nm a reflective channel name gives, or a negative value when the name is
/// not one ("T." + a number with an optional comma and exponent + an SI prefix + "m" or "Hz"; Hz
/// converted with c = 299792458 m/s), as the paper's layout allows.
double parse_spectral_channel(const std::string& name);

/// Reads a spectral table. Checks as read_exr does (magic, one flat part, brdf.layout, brdf.units,
/// 180 x 8100, subsampling, every value above the horizon finite and >= 0), and: at least one
/// reflective channel; no emissive channels ("S0.*": a radiance image, not a BRDF); no repeated
/// wavelength; at most max_spectral_wavelengths; spectralLayoutVersion "1.0" (absent: accepted
/// with a warning; another version: refused). Wavelengths are returned ascending, whatever the
/// channel order. Other channels (an RGB preview) are ignored. FormatError naming the path.
SpectralTable read_spectral_exr(const std::filesystem::path& path);

/// Writes atomically. Checks first (InputError for wavelengths or plane sizes, NumericalError for
/// a non-finite or negative value, naming wavelength and cell); cells below the horizon and
/// without data are written as 0.
void write_spectral_exr(const std::filesystem::path& path, const SpectralTable& table);

} // namespace brdf::formats
