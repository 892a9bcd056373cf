#pragma once
// Filling the 1.46 million cells of the MERL half/difference table from a solved material.
//
// The BRDF splits into the multiply scattered part, smooth in every angle, and the single
// scattering with the full phase function, which carries any sharp forward peak (TMS, Nakajima and
// Tanaka 1988). The smooth part is evaluated exactly (Nystrom) on a grid of zenith angles per
// Fourier order, combined into RGB there, and interpolated per cell (Catmull-Rom in theta_i and
// theta_o) before the Fourier sum in phi. The single scattering is evaluated per cell and per
// wavelength from a fine table of the phase function, with each wavelength's own refraction.
// FillInputs is everything a cell needs; the OpenCL kernel and the C++ reference read the same.

#include <brdf/service/model.h>
#include <formats/table.h>

#include <vector>

namespace brdf::service {

struct FillInputs {
    int grid = 0;   ///< E: zenith angles theta_a = a / (E - 1) * 90 degrees, a = 0 .. E - 1
    int orders = 0; ///< M
    /// fourier[((m * 3 + c) * E + o) * E + i]: (2 - delta_m0) (-1)^m R^m_c(theta_o, theta_i) in 1/sr,
    /// interface factors included, single scattering of the truncated phase function removed.
    std::vector<double> fourier;
    int samples = 0;      ///< S: wavelengths (or channels) with their own single scattering
    int phase_points = 0; ///< K: phase[s * K + k] = (w_s / 4) p_s at sin(Theta/2) = k / (K - 1)
    std::vector<double> phase;
    std::vector<double> index;  ///< [s]: binder index (1: no interface)
    /// F: transmission[s * F + k] = T_s(1) T_s(mu_k) / (n_s^2 pi), mu_k = k / (F - 1): the interface
    /// factor of Reflection::transmission_factor as a table (1/pi without an interface).
    int fresnel_points = 0;
    std::vector<double> transmission;
    std::vector<double> weight; ///< [s * 3 + c]
};

FillInputs prepare_fill(const SolvedMaterial& material);

/// BRDF of one direction triple (radians) from the fill inputs: the per-cell computation.
Rgb fill_value(const FillInputs& in, double theta_i, double theta_o, double phi);

/// Every cell, on `threads` CPU threads (the C++ reference of the table-fill kernel).
formats::BrdfTable fill_table_cpu(const FillInputs& in, int threads);

} // namespace brdf::service
