#pragma once
// What eval, albedo and diff read: a material spec (solved on the spot, evaluated exactly at the
// requested angles, or through the tables' interpolant: Source::use_interpolant), a pbrt-v3
// Fourier BSDF (.bsdf; evaluated as pbrt-v3 does, formats::evaluate), an RGL tensor BSDF
// (.rgl.bsdf; evaluated as Mitsuba 3's `measured` does, formats::RglEvaluator, a spectral one
// weighted to RGB by the CIE 1931 / D65 weights of its wavelengths) or a table file (.binary, .exr,
// spectral .exr as RGB; evaluated by nearest-bin lookup). Files are recognised by content
// (formats::detect_format).

#include <brdf/material/colour_space.h>
#include <brdf/model/model.h>
#include <brdf/model/table_fill.h>
#include <formats/fourier/fourier.h>
#include <formats/rgl/rgl_eval.h>
#include <formats/table.h>
#include <formats/table_io.h>

#include <CLI/CLI.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace brdf::tool {

/// --device opencl|cpu, shared by the commands that solve.
struct DeviceFlag {
    std::string value = "opencl";
    void add_to(CLI::App& app);
    model::Device device() const;
};

struct Source {
    std::optional<model::SolvedMaterial> model;
    std::optional<formats::FourierBsdf> fourier;
    std::optional<formats::RglEvaluator> rgl;
    /// For a spectral RGL file: the RGB weight of each of its wavelengths.
    std::vector<model::Rgb> rgl_weights;
    std::optional<formats::BrdfTable> table;
    /// Set by use_interpolant(): brdf() of a spec then evaluates the tables' interpolant
    /// (model::fill_value: each Fourier order solved on the table's zenith grid, Catmull-Rom in
    /// acos(sqrt(mu)) of both directions; the single scattering and a rough top's lobe exact per
    /// direction) at about a microsecond per direction instead of a solve per direction off the
    /// nodes.
    std::optional<model::FillInputs> interpolant;

    /// For commands that evaluate many directions (eval, lobes): a spec's brdf() through the
    /// interpolant, whose values are the tables' at the cell centres. `zenith_grid`: the Fourier
    /// grid's zenith angles, 0 for the tables' own (model::prepare_fill). A dipole model keeps its
    /// exact evaluation (its tables come from the same interpolant of the transport solution).
    void use_interpolant(int zenith_grid = 0);
    /// BRDF (1/sr) at angles in radians.
    model::Rgb brdf(double theta_i, double theta_o, double phi) const;
    /// The colour space of brdf() and albedo(): the spec's, the table's (brdf.colorspace, or the
    /// spectral table's recorded spec), Rec.709 for a Fourier BSDF and a MERL file.
    material::ColorSpace colorspace() const;
    /// Directional-hemispherical reflectance at theta_i (radians): the model's, the Fourier or RGL
    /// BSDF's by formats::directional_albedo's quadrature of their evaluation, or the table's by
    /// lookup.
    model::Rgb albedo(double theta_i) const;
};

/// RGB of a spectral table: the CIE 1931 / D65 weights of material::SpectralSet::integrating for
/// its wavelengths (piecewise-linear between them), in the colour space of the spec the table
/// records (its "colorspace"; linear Rec.709 without one): formats::read_table's converter.
/// Where the service solved only some of a spectrum's wavelengths this differs from the RGB
/// table by the interpolation (within the spec's tolerance); with every wavelength solved it is
/// the RGB table's colour.
formats::SpectralToRgb spectral_to_rgb();

/// A spec file (.json: the material named `material`, or its only one) or a table file. `recorded`
/// (diff TABLE CATALOGUE: the material the table says it was computed from) picks the material of
/// a spec holding several when `material` is empty. A name that is not there is an InputError
/// listing the names there are. `feedback` goes to a spec's solve (model::feedback_on: a command's
/// progress line).
Source load_source(const std::filesystem::path& path, const std::string& material, model::Device device,
                   const std::string& recorded = {}, const model::SolveFeedback& feedback = {});

/// The name of the material a table file was computed from: the "name" of the spec in its EXR
/// brdf.spec attribute, else of the report written beside it (DIR/NAME.report.json for
/// DIR/NAME.binary or DIR/NAME.exr); empty when neither says.
std::string recorded_material(const std::filesystem::path& table_path, const formats::BrdfTable& table);

bool is_spec_file(const std::filesystem::path& path);

/// The material of a spec file: the one named `material`, or `recorded` when the file holds several
/// and `material` is empty, or its only one. A name that is not there is an InputError listing the
/// names there are.
material::MaterialSpec choose_spec(const std::filesystem::path& path, const std::string& material,
                                   const std::string& recorded = {});

} // namespace brdf::tool
