#pragma once
// Parameters of the table-fill kernel (kernels/table_fill.cl), shared with the host
// (src/brdf/model/cl_table_fill.cpp static_asserts every size and offset). FillInputs::fourier
// (grid * grid * padded orders * channels) has a buffer of its own, the host's vector itself on a
// CPU device; the other arrays of brdf::model::FillInputs travel in one buffer of doubles, and the
// offsets below count doubles from its start. The three channel planes of formats::BrdfTable are
// one buffer each.

#include "shared/types.h"

/// Cells in one channel plane of the MERL table (formats::cells): 90 * 90 * 180.
#define TF_THETA_H_BINS 90
#define TF_THETA_D_BINS 90
#define TF_PHI_D_BINS 180
#define TF_CELLS 1458000
/// formats::BrdfTable::no_data
#define TF_NO_DATA (-1.0)
/// brdf::model::fill_order_block: the Fourier orders of one grid node are stored in blocks of this
/// many (the last padded with zeros), each order's channels (FillParams::channels) together.
#define TF_ORDER_BLOCK 8
/// Cells per work item of the table-fill kernel, one in each lane of its double8 values: the
/// first phi_d half's 729000 cells are 91125 work items.
#define TF_LANES 8

typedef struct FillParams {
    brdf_i64 phase_offset;        ///< FillInputs::phase, samples * phase_points * channels
    brdf_i64 refractive_index_offset; ///< FillInputs::refractive_index, samples
    brdf_i64 transmission_offset; ///< FillInputs::transmission, samples * fresnel_points
    brdf_i64 geometry_offset;     ///< sin and cos of the bin centres: theta_h (90 pairs), theta_d (90), phi_d (180)
    brdf_i64 tau_offset;          ///< FillInputs::tau, samples
    brdf_i64 cell_count;          ///< cells (global ids past it do nothing)
    brdf_i32 grid;                ///< E
    brdf_i32 orders;              ///< M
    brdf_i32 samples;             ///< S
    brdf_i32 phase_points;        ///< K
    brdf_i32 fresnel_points;      ///< F
    brdf_i32 channels;            ///< FillInputs::channels: 3, or 1 for a grey table (every channel the same)
    brdf_i64 lobe_fresnel_offset; ///< FillInputs::lobe_fresnel, 3 * lobe_points
    brdf_f64 lobe_alpha;          ///< FillInputs::lobe_alpha
    brdf_i32 lobe;                ///< FillInputs::Lobe: 0 none, 1 GGX, 2 Beckmann
    brdf_i32 lobe_separable;      ///< 1: separable masking, 0: height-correlated
    brdf_i32 lobe_points;         ///< P
    brdf_i32 pad2;
    brdf_i64 node_blocks_offset;  ///< FillInputs::node_blocks (grid * grid, as doubles); -1: every block everywhere
} FillParams;
