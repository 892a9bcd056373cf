#pragma once
// A material solved: per wavelength (or per RGB channel of an analytic medium) the optics and the
// reflection function, with the colour weights that turn spectra into RGB of the spec's colour space. Evaluation
// at exact angles (brdftool eval / albedo on a spec) and the table fill both start here.

#include <brdf/material/spec.h>
#include <brdf/rte/dipole.h>
#include <brdf/rte/reflection.h>
#include <brdf/model/optics.h>

#include <array>
#include <functional>
#include <future>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace brdf {
class Progress; // core/progress.h
}

namespace brdf::model {

using Rgb = std::array<double, 3>;

enum class Device { OpenCL, Cpu };

/// Numerical settings chosen for a requested relative BRDF error (the spec's accuracy).
struct NumericalSettings {
    double tolerance = 1e-4;
    int streams = 32;               ///< starting point; grown by the convergence check up to max_streams
    int max_streams = 64;
    double order_tolerance = 1e-5;
    double solver_tolerance = 1e-10;
    double mie_tolerance = 1e-5;
    int table_grid = 91; ///< zenith angles of the table's Fourier grid, 0..90 degrees
    rte::Method method = rte::Method::Fast;
    bool select_wavelengths = true; ///< solve only the wavelengths select_wavelengths() keeps
    /// Solve only the Fourier orders the stream check's probes reflect (reflection_orders), not
    /// every order their phase functions carry.
    bool fit_orders = true;
    int max_orders = 0; ///< at most this many Fourier orders (0: no cap; rte::ReflectionSettings)
    double note_after_seconds = 10.0; ///< solve_material's `note` for an expected time above this
};
NumericalSettings settings_for(double tolerance);

struct WavelengthSolution {
    double wavelength_nm = 0.0; ///< 0 for a channel of an analytic medium
    Rgb weight{};               ///< contribution to r, g, b
    /// The colour weight of this wavelength's direct single scattering: `weight`, but where the
    /// spectrum's single scattering is exact per wavelength (SolvedMaterial::single_only) its own,
    /// and `weight` (which also carries skipped neighbours' share) weights the rest of the BRDF.
    Rgb single_weight{};
    SpectralOptics optics;
    rte::Reflection reflection;
    /// Set when the spec asks for "model": "dipole": SolvedMaterial::brdf/albedo/mirror then evaluate
    /// this comparison model (rte/dipole.h) instead of `reflection` (which is still solved, for the
    /// report and tables).
    std::optional<rte::Dipole> dipole;
    /// The diffuse albedo and mirror at the cosines of reflectance_angles_deg, as the gamut fit
    /// found them (empty before it ran): the report asks for the same, which under a rough top costs
    /// as much again (the interface's kernels at those directions, the lobe's albedo).
    std::vector<double> known_albedo, known_mirror;
};

/// The incidence angles, in degrees, of the report's directional albedo and mirror; the gamut fit
/// probes the same ones.
inline constexpr double reflectance_angles_deg[] = {0.0, 30.0, 60.0, 80.0};

struct StageSeconds {
    double optics = 0.0, solve = 0.0, table = 0.0, write = 0.0;
};

/// A wavelength of the spectrum that is not solved (select_wavelengths) but whose direct single
/// scattering is added exactly: its multiply scattered light, smooth in wavelength, is interpolated
/// (its colour weight folded onto the solved samples' `weight`), while its single scattering
/// follows its own phase function, which Mie's ripple makes anything but smooth in wavelength.
struct SingleScatteringSample {
    double wavelength_nm = 0.0;
    Rgb weight{};
    rte::StackSetup setup; ///< set up at the material's streams (the delta-M fraction of TMS)
};

/// One wavelength's direct single scattering: its set-up stack and the colour weight it takes.
struct SingleScatteringSource {
    const rte::StackSetup* setup = nullptr;
    Rgb weight{};
};

struct SolvedMaterial {
    material::MaterialSpec spec;
    NumericalSettings settings;
    std::vector<WavelengthSolution> samples;
    /// The wavelengths whose single scattering alone is evaluated (empty unless select_wavelengths
    /// interpolated only the multiply scattered light: under no or a smooth top, a half-space or
    /// layers of one index over a grey substrate).
    std::vector<SingleScatteringSample> single_only;
    std::string device; ///< device_label of the batch's device; empty when the batch had nothing for it
    /// Where the caller makes sure of the device (DeviceCheck::Caller): the OpenCL device's opening,
    /// which may still be under way on a thread of its own (its end is waited for when the last
    /// copy goes; cl::Context::shared() waits for it too). Invalid otherwise.
    std::shared_future<void> device_opening;
    std::size_t wavelengths_interpolated = 0; ///< of the spectrum, not solved (select_wavelengths)
    /// Relative BRDF difference between the chosen stream count and the last one checked against
    /// it on the hardest wavelengths (3/4 of it, or 1.5 times as many): the error estimate of the
    /// solve (0 when not checked).
    double error_estimate = 0.0;
    /// The stream counts the convergence check solved its probes at, in order.
    std::vector<int> checked_streams;
    double gamut_scale = 1.0; ///< chroma factor applied by fit_into_gamut (1: colour already in gamut)
    /// True when the chroma scaling alone could not bring the colour into the space and the
    /// outputs clamp what is left (material::GamutFit::clipped).
    bool gamut_clipped = false;
    /// What the solve did to the colour, one line each (the gamut fit's warning: material, colour
    /// space, factor, what keeps the colour); logged with log::warn and kept for the report.
    std::vector<std::string> warnings;
    StageSeconds seconds;

    /// BRDF (1/sr) at zenith angles theta_i, theta_o and azimuth phi (radians, docs/design.md
    /// conventions), in the spec's colour space; these three never return a negative channel.
    Rgb brdf(double theta_i, double theta_o, double phi) const;
    /// Directional-hemispherical reflectance of the diffuse part.
    Rgb albedo(double theta_i) const;
    /// albedo() at each angle: every sample solved once for all of them, one sample per core.
    std::vector<Rgb> albedo(std::span<const double> theta_i) const;
    /// The interface's mirror reflectance (0 with surface "none").
    Rgb mirror(double theta_i) const;
    /// mirror() at each angle: every sample solved once for all of them, one sample per core.
    std::vector<Rgb> mirror(std::span<const double> theta_i) const;
    /// What the exact single scattering of every wavelength adds to the samples' `weight`ed BRDFs
    /// (1/sr, cosines and azimuth): sum_k (single_weight_k - weight_k) SS_k + sum_u weight_u SS_u
    /// over single_only; 0 unless single_only is in use.
    Rgb single_scattering_correction(double mu_i, double mu_o, double phi) const;
    /// Every wavelength's direct single scattering: each solved sample's with its single_weight,
    /// then each of single_only (pointing into this material).
    std::vector<SingleScatteringSource> single_scattering_sources() const;
};

/// Which wavelengths of a spectrum to solve: where the optics vary smoothly the BRDF is
/// interpolated (piecewise quadratic in wavelength) between solved ones, which folds each skipped wavelength's
/// colour weight onto its neighbours. All are solved for tolerance < 1e-6 ("reference"). A wavelength
/// of less than the average colour weight (the spectrum's ends) may err in proportion: its error
/// reaches the colour with its weight.
struct SpectralSelection {
    std::vector<std::size_t> solved; ///< indices into the spectrum, ascending, first and last included
    std::vector<Rgb> weights;        ///< colour weight of each solved wavelength
};
/// `single_exact`: the single scattering is added per wavelength from its own optics
/// (SolvedMaterial::single_only), so only what the multiply scattered light depends on must
/// interpolate: the similarity parameter, the index, the optical depth and the phase function's
/// first moments; otherwise the phase function's values at a spread of angles too.
SpectralSelection select_wavelengths(const std::vector<SpectralOptics>& optics, const std::vector<Rgb>& weights,
                                     double tolerance, bool single_exact = false);

/// The Fourier orders a reflection needs: one past the last order m whose term 2 |R^m| reaches
/// `threshold` of the azimuthal mean R^0 at some pair of the probe directions (the stream check's
/// zenith angles, 0 to 89.5 degrees). The orders carry only what is not single scattered on a direct
/// path (that is exact per direction: TMS), which is far smoother in azimuth than the phase
/// function: its terms fall off long before the phase function's components do. Under a rough top
/// they carry the body's single scattering too, spread in azimuth by the rough refraction.
int reflection_orders(const rte::Reflection& reflection, double threshold);

/// The optics of a spec ready to solve: per solved wavelength (or colour channel) every layer, with
/// the colour weights (wavelengths skipped by select_wavelengths folded onto their neighbours).
struct MaterialOptics {
    std::vector<SpectralOptics> optics;
    std::vector<Rgb> weights;
    std::size_t wavelengths_interpolated = 0;
    /// Per entry of `optics`, the weight of its direct single scattering (WavelengthSolution::
    /// single_weight), and the skipped wavelengths whose single scattering is still exact.
    std::vector<Rgb> single_weights;
    std::vector<SpectralOptics> single_only;
    std::vector<Rgb> single_only_weights;
};
/// material_optics' progress: the seconds its optics have taken, and the seconds they are projected
/// to take in all (WorkProjection: each wavelength's expected cost 1 / lambda^2, as the Lorenz-Mie
/// series' terms and its angles both grow with the size parameter); negative while no wavelength
/// is done.
using OpticsProgress = std::function<void(double elapsed_seconds, double projected_seconds)>;
/// `progress`, when given, is called as each wavelength's optics are done, and while a long
/// Lorenz-Mie integration runs (after each of its refinements), from the threads that compute them,
/// one call at a time. An analytic material has no such work and makes no call.
MaterialOptics material_optics(const material::MaterialSpec& spec, const NumericalSettings& settings,
                               const OpticsProgress& progress = {});

/// Brings an out-of-gamut colour into the spec's colour space by scaling every colour weight's chroma
/// about its luminance (material::fit_into_gamut: the same factor for all wavelengths, so the map
/// stays linear, and the luminance checked unchanged); sets gamut_scale and gamut_clipped, and adds
/// its warning to `warnings` and stderr when it changed anything.
void fit_into_gamut(SolvedMaterial& material);

/// The one entry that solves: every stack (one per sample) with the settings on the device. The
/// semi-infinite layers' Fourier orders of all stacks go to the device in one batch (OpenCL or the
/// C++ reference); the finite layers and the adding run on the host, one stack per core. Sets
/// *device_name (device_label) when given, and the device ran the batch: a batch with nothing for
/// the OpenCL device (the stream check's probes were every sample) does not wait for it to open.
std::vector<rte::Reflection> solve_stacks(std::span<const rte::Stack> stacks, const rte::ReflectionSettings& settings,
                                          Device device, std::string* device_name = nullptr);

/// "opencl: NAME" (opening the shared OpenCL context where it is not open yet: DeviceError without
/// a device) or "cpu": what a report's `device` says.
std::string device_label(Device device);

/// Who makes sure of the OpenCL device where the batch had nothing for it (solve_stacks did not
/// wait for it): solve_material before it returns (a device asked for must be there: DeviceError
/// otherwise, and SolvedMaterial::device names it), or its caller, which uses the device next and
/// names it itself (compute: the table fill, then device_label before anything is written). For
/// the caller, the device goes on opening beside its work (SolvedMaterial::device_opening); with
/// CallerFillsTable that thread then loads the table fill's program too (load_fill_program), so
/// that the caller starts no thread of its own while PoCL may still be loading its libraries.
enum class DeviceCheck { BeforeReturn, Caller, CallerFillsTable };

/// What solve_material tells a user waiting (compute shows both on its progress line).
struct SolveFeedback {
    /// What a user should know before a long part, once per part: for a material whose particles'
    /// optics (Lorenz-Mie) will take over settings.note_after_seconds, their estimate once the
    /// first wavelengths are done (their time scaled by the expected cost of the rest), e.g.
    /// "NAME: about 3 min 20 s for its particles' optics (Lorenz-Mie, 41 wavelengths)", and before
    /// that, where the first wavelength alone runs that long (at least half a second), "NAME: its
    /// particles' optics take long: the first of its 41 wavelengths (Lorenz-Mie) is still running
    /// after 10.0 s; an estimate follows once one is done"; for one
    /// whose solve and tables will, the estimate from the stream check's own solves of the hardest
    /// samples, scaled to all samples and cores, e.g. "NAME: about 2 min 10 s to solve and
    /// tabulate (41 samples at 64 streams)". compute shows them as lines of their own.
    std::function<void(const std::string&)> note;
    /// The optics as they go (material_optics' `progress`): the fraction of their projected time
    /// that has passed (never less than before, below 1), and that projection; called with 1 once
    /// they are done, before the stream check.
    std::function<void(double fraction, double projected_seconds)> optics;
};

/// Feedback shown on a command's progress line: notes as lines of their own, the optics as the task's
/// stage "optics" and then its stage "solve". Once the optics are projected to take over a second,
/// their stage weighs their projected seconds, the stages after it about 1 in all (a second's work
/// for most materials): the bar and its ETA then follow a large particle's minutes of Lorenz-Mie.
SolveFeedback feedback_on(Progress& progress);

/// material_optics with a user's feedback: the optics' fraction as they go, then 1 once done, and
/// for a material whose optics will take over settings.note_after_seconds, the note of their
/// estimate (SolveFeedback). solve_material's first step; `hiding` calls it alone.
MaterialOptics material_optics(const material::MaterialSpec& spec, const NumericalSettings& settings,
                               const SolveFeedback& feedback);

/// Mie + mixing per wavelength, then every Fourier order of every wavelength in one batch on the
/// device (or the CPU reference).
SolvedMaterial solve_material(const material::MaterialSpec& spec, Device device);
SolvedMaterial solve_material(const material::MaterialSpec& spec, Device device, const NumericalSettings& settings,
                              const SolveFeedback& feedback = {},
                              DeviceCheck device_check = DeviceCheck::BeforeReturn);

} // namespace brdf::model
