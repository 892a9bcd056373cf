#pragma once
// Filling the 1.46 million cells of the MERL half/difference table from a solved material.
//
// The BRDF splits into the multiply scattered part, smooth in every angle, and the single
// scattering with the full phase function, which carries any sharp forward peak (TMS, Nakajima and
// Tanaka 1988). The smooth part is evaluated exactly (Nystrom) on a grid of zenith angles per
// Fourier order, combined into RGB there, and interpolated per cell (Catmull-Rom in
// v = acos(sqrt(mu)) of both directions, zenith_grid_cosine) before the Fourier sum in phi. The
// single scattering is evaluated per cell and per wavelength from a fine table of the phase
// function, with each wavelength's own refraction.
// Under a rough top the first-surface reflection lobe (Reflection::surface_lobe) is added per cell
// in closed form, never Fourier expanded: in air it is D(h) G(wi, wo) F(wi.h; n) / (4 mu_i mu_o)
// (Walter et al. 2007, eq. 20), and only the facet Fresnel factor depends on the wavelength, so it
// is tabulated per colour channel in cos(theta_d) = wi.h while D and G are computed per cell.
// FillInputs is everything a cell needs; the OpenCL kernel and the C++ reference read the same.

#include <brdf/model/model.h>
#include <formats/table.h>

#include <array>
#include <functional>
#include <vector>

namespace brdf::model {

/// Orders per block of FillInputs::fourier (kernels/table_fill.cl uses the same).
constexpr int fill_order_block = 8;
/// M rounded up to whole blocks.
constexpr int padded_orders(int orders) {
    return (orders + fill_order_block - 1) / fill_order_block * fill_order_block;
}

/// The cosine of zenith node a of a fill's grid of `grid` nodes, a = 0 (the normal) .. grid - 1 (the
/// horizon): the nodes are uniform in the angle v = acos(sqrt(mu)), mu = cos^2 v (docs/physics.md,
/// "The tables' zenith grid"). Near the horizon the BRDFs here are smooth in mu (the Fresnel
/// transmission is linear in it, Chandrasekhar's H functions go as mu log mu), so even in v about
/// 90 degrees, which the cubic follows with a ghost node reflected there; in the zenith angle
/// itself they have a corner at the horizon (cells within 0.5 degrees of it erred by up to 50 %).
/// Near the normal v is theta / sqrt(2), and order m goes as sin^m: the tap before the first node is
/// node 1 mirrored, times (-1)^m.
double zenith_grid_cosine(int a, int grid);

struct FillInputs {
    int grid = 0;   ///< E: zenith nodes of cosine zenith_grid_cosine(a, E), a = 0 .. E - 1
    int orders = 0; ///< M
    /// C: 3 (red, green, blue), or 1 when every sample's colour weight is grey (an analytic grey
    /// medium): then fourier and phase hold one value where they hold three, and the table's three
    /// channels are equal (the fill computes one and copies it: a third of the work).
    int channels = 3;
    /// fourier[((o * E + i) * padded_orders(M) + m) * C + c]: (2 - delta_m0) (-1)^m R^m_c(theta_o,
    /// theta_i) / pi in 1/sr, interface factors included, single scattering on the direct paths
    /// removed; orders M .. padded_orders(M) - 1 are 0. Every order and channel of one grid node lie
    /// together, in blocks of fill_order_block orders: a cell's interpolation is then 16 taps of
    /// contiguous blocks, which the compilers vectorise (C++ and OpenCL alike).
    std::vector<double> fourier;
    /// node_blocks[o * E + i]: how many blocks of fill_order_block orders grid node (o, i) needs,
    /// 0 .. padded_orders(M) / fill_order_block. A cell sums the blocks the most demanding of its
    /// 16 taps needs; the orders beyond add 0 (node_order_blocks says what a node leaves out).
    /// Empty: every block at every node. Unused (not read, not checked) where M is 0.
    std::vector<int> node_blocks;
    /// S: single-scattering terms, each with its own refraction: one per wavelength (or channel)
    /// and layer (Reflection::single_scattering), or, for a half-space whose wavelengths differ only
    /// in their binder index, one per node of an interpolation in that index (table_fill.cpp:
    /// share_single_scattering), which is exact to 1 % of the tolerance on a probe set.
    int samples = 0;
    /// K: phase[(s * K + k) * C + c] = w_s,c (albedo_s / 4) p_s at u = sin(Theta/2) - cos(Theta/2) =
    /// 2 (k - 1) / (K - 3) - 1:
    /// the term's phase table, colour weights included, interpolated by Catmull-Rom (one ghost point
    /// beyond each end).
    int phase_points = 0;
    std::vector<double> phase;
    std::vector<double> refractive_index; ///< [s]: the layer's index (1: no interface)
    /// F: transmission[s * F + k] = A(mu_k) / (n sqrt(pi)), mu_k = (k - 1) / (F - 3): the layer's
    /// path factor (Reflection::path_factor) as a table (Catmull-Rom, one ghost point beyond each
    /// end), so the term's factor is t(mu_o) t(mu_i).
    int fresnel_points = 0;
    std::vector<double> transmission;
    /// [s]: the layer's (delta-M scaled) optical thickness, infinite for a half-space and for a
    /// layer whose slab factor is 1 to within 1 % of the tolerance (exp(-2 tau) below it)
    std::vector<double> tau;

    /// The rough top's first-surface lobe (every sample shares alpha, distribution and masking).
    enum class Lobe { None = 0, Ggx = 1, Beckmann = 2 };
    Lobe lobe = Lobe::None;
    bool lobe_separable = false; ///< masking G1(wi) G1(wo); otherwise height-correlated (Heitz 2014)
    double lobe_alpha = 0.0;     ///< roughness, in [0.001, 1]
    /// P: lobe_fresnel[c * P + k] = sum_s w_s,c F(c_k; n_s) at c_k = cos(theta_d) = k / (P - 1): the
    /// facet Fresnel reflectance from air (rte::Interface::reflectance_from_air) weighted per channel.
    int lobe_points = 0;
    std::vector<double> lobe_fresnel;
};

/// The blocks of orders each node of `in.fourier` needs (FillInputs::node_blocks): the fewest whose
/// orders leave out at most `cut` times the node's R^0 in every channel, summed over the orders
/// left out (R^0 no smaller than 1e-2 of the grid's largest in that channel, as the solve's order
/// cut takes it: model::reflection_orders). The Fourier coefficients fall fast in m wherever the
/// directions are not grazing and the phase function is not sharply peaked, so most nodes need
/// far fewer orders than the few near grazing that set M.
std::vector<int> node_order_blocks(const FillInputs& in, double cut);

/// The fill inputs of every sample with its colour weight, on the material's table grid, or on
/// `zenith_grid` zenith angles (0..90 degrees) when that is positive and coarser (a preview's);
/// the single scattering of every wavelength, the skipped ones' too (SolvedMaterial::single_only),
/// each with the weight of its own (WavelengthSolution::single_weight).
FillInputs prepare_fill(const SolvedMaterial& material, int zenith_grid = 0);

/// The fill of up to three solved samples (wavelengths) at once, one in each channel: channel c of
/// the table filled from `inputs` is the BRDF of material.samples[sample[c]] alone (weight 1, the
/// others 0), or unused where sample[c] < 0. The same cells, interpolation and single scattering
/// as the RGB fill, so a spectral table is filled by the RGB code paths (CPU and OpenCL) in
/// ceil(S / 3) passes over the cells, each with only its own samples' orders and phase tables.
struct SpectralFill {
    FillInputs inputs;
    std::array<int, 3> sample{-1, -1, -1};
};
/// Calls `fill` with the groups of every solved sample, in order, one at a time: each group's
/// inputs, its samples' Nystrom grids included, are computed when its turn comes (each sample's
/// once), so no more than one group's grids are held.
void for_each_spectral_fill(const SolvedMaterial& material, const std::function<void(const SpectralFill&)>& fill);

/// BRDF of one direction triple (radians) from the fill inputs: the per-cell computation.
Rgb fill_value(const FillInputs& in, double theta_i, double theta_o, double phi);
/// The same from the cosines of the zenith angles and of the azimuth between the directions: what
/// the orders' zenith grid, the single scattering and a lobe take.
Rgb fill_value_from_cosines(const FillInputs& in, double mu_i, double mu_o, double cos_phi);

/// Every cell, on `threads` CPU threads: cell_value cell by cell (fill_value), the C++ reference of
/// the table-fill kernel.
formats::BrdfTable fill_table_reference(const FillInputs& in, int threads);
/// The same table from cells in vector lanes, as many at a time as the instruction set's registers
/// hold (the CPU device's fill): the same formulas and library calls in the same order, so the
/// same values bit for bit, at a third of the time.
formats::BrdfTable fill_table_cpu(const FillInputs& in, int threads);

} // namespace brdf::model
