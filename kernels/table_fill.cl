// The MERL table fill: one work-item per TF_LANES (8) cells of the 90 x 90 x 180 half/difference
// table, one cell in each lane of its double8 values. The C++ reference is
// brdf::model::fill_table_cpu and cell_value (src/brdf/model/table_fill.cpp) with the bin-centre
// geometry of formats/halfdiff.cpp (cell_indices, theta_h/theta_d/phi_d_centre, to_directions) and
// the below-horizon test of formats::cell_below_horizon; this is the same computation, formula for
// formula and in the same order of summation, in double precision without contraction. Cells whose
// incident or outgoing bin-centre direction has z <= 0 get TF_NO_DATA in all three channels.
//
// Why lanes: one cell per work item left PoCL's code scalar (a cell's loops over orders, taps and
// single-scattering terms keep its work-item loop from vectorising), and a cell is a few hundred
// dependent scalar operations: the geometry, the stencils' acos, the Chebyshev recurrence, the
// single scattering's square roots and divisions. In lanes each of those is one vector operation
// for eight cells. Only the orders' taps stay per cell (each cell reads its own grid nodes): there
// the vector runs along the orders of a node (contiguous), as before, and the block's sums are
// handed to the lanes for the Fourier sum in phi. A GPU runs the same code, each work item eight
// cells in turn.

#pragma OPENCL FP_CONTRACT OFF

#include "shared/table_fill_layout.h"

#if TF_ORDER_BLOCK != 8
#error "table_fill sums a block of orders as three double8 (3 channels x 8 orders)"
#endif
#if TF_LANES != 8
#error "table_fill holds a work item's cells in double8 lanes"
#endif

#define TF_PI 3.14159265358979323846

// std::clamp(v, lo, hi) per lane (also for NaN: v < lo and hi < v are both false, v comes back).
static double8 clamp_ref(double8 v, double lo, double hi) {
    return select(select(v, (double8)(hi), hi < v), (double8)(lo), v < lo);
}

// std::max(0.0, v) per lane: 0 for NaN too.
static double8 max0_ref(double8 v) { return select((double8)(0.0), v, 0.0 < v); }

// base[index] of each lane.
static double8 gather(__global const double* base, int8 i) {
    return (double8)(base[i.s0], base[i.s1], base[i.s2], base[i.s3], base[i.s4], base[i.s5], base[i.s6], base[i.s7]);
}

// out[k] = element k of every row: out[k][l] = rows[l][k] (an 8 x 8 transpose in three rounds of
// shuffles, which the compilers keep in vector registers).
static void transpose(const double8 rows[8], double8 out[8]) {
    double8 t[8], u[8];
    for (int r = 0; r < 8; r += 2) { // t: rows r and r + 1 interleaved, even elements then odd
        t[r] = shuffle2(rows[r], rows[r + 1], (ulong8)(0, 8, 2, 10, 4, 12, 6, 14));
        t[r + 1] = shuffle2(rows[r], rows[r + 1], (ulong8)(1, 9, 3, 11, 5, 13, 7, 15));
    }
    for (int r = 0; r < 8; r += 4) // u[r + i], u[r + 2 + i]: elements i, i + 4 and i + 2, i + 6 of rows r .. r + 3
        for (int i = 0; i < 2; ++i) {
            u[r + i] = shuffle2(t[r + i], t[r + 2 + i], (ulong8)(0, 1, 8, 9, 4, 5, 12, 13));
            u[r + 2 + i] = shuffle2(t[r + i], t[r + 2 + i], (ulong8)(2, 3, 10, 11, 6, 7, 14, 15));
        }
    for (int i = 0; i < 4; ++i) {
        out[i] = shuffle2(u[i], u[4 + i], (ulong8)(0, 1, 2, 3, 8, 9, 10, 11));
        out[4 + i] = shuffle2(u[i], u[4 + i], (ulong8)(4, 5, 6, 7, 12, 13, 14, 15));
    }
}

// table_fill.cpp: catmull_rom, the weights of taps (-1, 0, 1, 2) at fraction f in [0, 1).
static void catmull_rom(double8 f, double8 w[4]) {
    const double8 f2 = f * f, f3 = f2 * f;
    w[0] = 0.5 * (-f3 + 2.0 * f2 - f);
    w[1] = 0.5 * (3.0 * f3 - 5.0 * f2 + 2.0);
    w[2] = 0.5 * (-3.0 * f3 + 4.0 * f2 + f);
    w[3] = 0.5 * (f3 - f2);
}

// Catmull-Rom taps and weights along one zenith axis of the grid (table_fill.cpp: stencil).
static void stencil(double8 mu, int grid, int8 idx[4], double8 w[4], int8 ghost[4]) {
    const double8 t = acos(clamp_ref(2.0 * mu - 1.0, -1.0, 1.0)) / TF_PI * (double)(grid - 1);
    const int8 i0 = min(convert_int8(t), grid - 2); // t >= 0: truncation, as (int) t
    catmull_rom(t - convert_double8(i0), w);
    for (int k = 0; k < 4; ++k) {
        const int8 j = i0 - 1 + k;
        idx[k] = select(select(j, -j, j < 0), 2 * (grid - 1) - j, j > grid - 1);
        ghost[k] = j < 0;
    }
}

// table_fill.cpp: cubic_taps (one ghost point beyond each end: x_k = (k - 1) / (points - 3)); returns k.
static int8 cubic_taps(int points, double8 x, double8 w[4]) {
    const int intervals = points - 3;
    const double8 t = clamp_ref(x, 0.0, 1.0) * (double)intervals;
    const int8 k = min(convert_int8(t), intervals - 1);
    catmull_rom(t - convert_double8(k), w);
    return k;
}

// table_fill.cpp: cubic_table, at taps k and weights w from cubic_taps. The taps depend on the
// table's size and x alone: a cell's loops over tables of one size (the samples' transmissions,
// the lobe's three channels) find them once (the transmission taps were 9 % of the silica matting
// agent's samples, a call each with its double8 arguments in memory under AVX2).
static double8 cubic_at(__global const double* table, int8 k, const double8 w[4]) {
    return w[0] * gather(table, k) + w[1] * gather(table, k + 1) + w[2] * gather(table, k + 2) +
           w[3] * gather(table, k + 3);
}

// table_fill.cpp: cubic_rgb_table, cubic_table for a table of RGB triples or (channels 1) of single
// values, then in all three.
static void cubic_rgb_table(__global const double* table, int points, int channels, double8 x, double8 out[3]) {
    double8 w[4];
    const int8 k = channels * cubic_taps(points, x, w);
    for (int c = 0; c < channels; ++c)
        out[c] = w[0] * gather(table, k + c) + w[1] * gather(table, k + channels + c) +
                 w[2] * gather(table, k + 2 * channels + c) + w[3] * gather(table, k + 3 * channels + c);
    if (channels == 1) out[1] = out[2] = out[0];
}

// table_fill.cpp: smith_lambda (Walter et al. 2007, G1 of eqs. 34 and 27).
static double8 smith_lambda(int lobe, double alpha, double8 mu, double8 s) {
    double8 lambda;
    if (lobe == 1) {
        const double8 x = alpha * alpha * s * s / (mu * mu);
        lambda = x / (2.0 * (1.0 + sqrt(1.0 + x)));
    } else {
        const double8 a = mu / (alpha * s);
        lambda = 0.5 * (exp(-a * a) / (a * sqrt(TF_PI)) - erfc(a));
    }
    lambda = select(lambda, (double8)(INFINITY), !(mu > 0.0));
    return select(lambda, (double8)(0.0), !(s > 0.0));
}

// The three channels' planes are separate buffers: the host's table planes themselves on a CPU
// device (cl_table_fill.cpp maps them with CL_MEM_USE_HOST_PTR); so is `orders`, the grid of
// Fourier orders (FillInputs::fourier), there. A grey fill (channels 1) writes `red` alone, the
// grey table's one plane (formats/table.h).
__kernel void table_fill(__global const FillParams* params_in, __global const double* data,
                         __global const double* orders, __global double* red, __global double* green,
                         __global double* blue) {
    const FillParams p = *params_in;
    // Cells of the first half of phi_d, each lane writing its cell and the mirror phi_d -> pi -
    // phi_d (table_fill.cpp: fill_table_cpu says why they are equal).
    const int half_cells = (int)(p.cell_count / 2);
    const int first = (int)get_global_id(0) * TF_LANES;
    if (first >= half_cells) return;
    const int8 id = first + (int8)(0, 1, 2, 3, 4, 5, 6, 7);
    const int8 valid = id < half_cells;
    const int8 phi_k = id % (TF_PHI_D_BINS / 2);
    const int8 rest = id / (TF_PHI_D_BINS / 2);
    int cell[TF_LANES], mirror[TF_LANES], lane_valid[TF_LANES];
    vstore8(rest * TF_PHI_D_BINS + phi_k, 0, cell);
    vstore8(rest * TF_PHI_D_BINS + (TF_PHI_D_BINS - 1 - phi_k), 0, mirror);
    vstore8(valid, 0, lane_valid);

    // formats::cell_indices; the bin centres' sin and cos from the host's table.
    const int8 theta_dj = rest % TF_THETA_D_BINS;
    const int8 theta_hi = rest / TF_THETA_D_BINS;
    __global const double* trig = data + p.geometry_offset;
    const double8 sh = gather(trig, 2 * theta_hi), ch = gather(trig, 2 * theta_hi + 1);
    const int8 d_at = 2 * (TF_THETA_H_BINS + theta_dj), p_at = 2 * (TF_THETA_H_BINS + TF_THETA_D_BINS + phi_k);
    const double8 sd = gather(trig, d_at), cd = gather(trig, d_at + 1);
    const double8 sp = gather(trig, p_at), cp = gather(trig, p_at + 1);

    // formats::to_directions: wi = Ry(theta_h) d, wo = Ry(theta_h) (-d.x, -d.y, d.z).
    const double8 dx = sd * cp, dy = sd * sp, dz = cd;
    const double8 wix = dx * ch + dz * sh, wiy = dy, wiz = -dx * sh + dz * ch;
    const double8 mdx = -dx, mdy = -dy;
    const double8 wox = mdx * ch + dz * sh, woy = mdy, woz = -mdx * sh + dz * ch;

    const long8 below = (wiz <= 0.0) | (woz <= 0.0); // formats::cell_below_horizon
    double8 out0 = (double8)(0.0), out1 = (double8)(0.0), out2 = (double8)(0.0);
    if (!all(below)) {
        // table_fill.cpp: cell_directions. Every lane is computed; those below the horizon are
        // replaced by TF_NO_DATA at the end (their values stay finite or are discarded).
        const double8 mu_i = clamp_ref(wiz, -1.0, 1.0), mu_o = clamp_ref(woz, -1.0, 1.0);
        const double8 horizontal = sqrt((wix * wix + wiy * wiy) * (wox * wox + woy * woy));
        const double8 c1 =
            select((double8)(1.0), clamp_ref((wix * wox + wiy * woy) / horizontal, -1.0, 1.0), horizontal > 0.0);
        int lane_below[TF_LANES];
        vstore8(convert_int8(below), 0, lane_below);

        // table_fill.cpp: cell_value. The multiply scattered part: per cell, each block of orders
        // interpolated from its 16 taps (contiguous double8 along the orders), the cells' sums
        // turned into lanes (transpose), then the Fourier sum over the block's orders in all lanes
        // at once, cos(m phi) by the Chebyshev recurrence.
        //
        // The 16 taps of every lane: tap t = 4 a + b is grid node (so_idx[a], si_idx[b]), whose
        // orders start at fourier[tap_at[t * TF_LANES + lane]], weight so_w[a] si_w[b]; a ghost tap
        // (node 1 mirrored through the normal) is only ever tap a = 0 or b = 0, so a lane without
        // one (all but those within a grid step of the normal) skips the mirrored sums. A lane sums
        // only the blocks of orders its cell needs (table_fill.cpp: cell_blocks, the most any of
        // its taps' nodes needs); the others' sums are 0.
        const int e = p.grid;
        const int mp = (p.orders + TF_ORDER_BLOCK - 1) / TF_ORDER_BLOCK * TF_ORDER_BLOCK;
        int tap_at[16 * TF_LANES], tap_mirrored[16 * TF_LANES], lane_ghost[TF_LANES], lane_orders[TF_LANES];
        double tap_w[16 * TF_LANES];
        if (p.orders > 0) {
            int8 so_idx[4], si_idx[4], so_g[4], si_g[4];
            double8 so_w[4], si_w[4];
            stencil(mu_o, e, so_idx, so_w, so_g);
            stencil(mu_i, e, si_idx, si_w, si_g);
            int8 blocks = (int8)(mp / TF_ORDER_BLOCK);
            __global const double* node_blocks = data + max(p.node_blocks_offset, (long)0);
            if (p.node_blocks_offset >= 0) blocks = (int8)(0);
            for (int a = 0; a < 4; ++a)
                for (int b = 0; b < 4; ++b) {
                    const int8 node = so_idx[a] * e + si_idx[b];
                    vstore8(node * (mp * p.channels), 4 * a + b, tap_at);
                    vstore8(so_w[a] * si_w[b], 4 * a + b, tap_w);
                    vstore8(so_g[a] != si_g[b], 4 * a + b, tap_mirrored);
                    if (p.node_blocks_offset >= 0) blocks = max(blocks, convert_int8(gather(node_blocks, node)));
                }
            vstore8(so_g[0] | si_g[0], 0, lane_ghost);
            vstore8(blocks * TF_ORDER_BLOCK, 0, lane_orders);
        }
        double8 cm_prev = c1, cm = (double8)(1.0); // cos(-phi) = cos(phi), cos(0)
        // cells[q][l]: element k = 8 q + i of lane l's sums of the pass's orders, i = 0..7;
        // terms[k]: element k of every lane. RGB: one block of orders per pass, element k = 3 j + c
        // is order m0 + j, channel c. Grey: two blocks per pass where the orders reach that far,
        // element j is order m0 + j (j < 16): each tap's weight and address, loaded once, serve
        // both blocks (each sum is the one a pass of its own makes, in the same order), where they
        // had been a third of a grey block's work (HG g 0.5: 34 -> 30 ms; an RGB pair's twelve sums
        // ran slower than one block's six). A block's odd orders (its first is even) count their
        // taps mirrored through the normal with the opposite sign, acc - 2 mirrored (table_fill.cpp:
        // cell_value): j is odd for elements 1, 3, 5, 7 of each grey double8, or 3-5 (q = 0), 9-11,
        // 15 (q = 1), 16-17 and 21-23 (q = 2).
        double8 cells[3][TF_LANES], terms[3 * TF_ORDER_BLOCK];
        const long8 odd_grey = (long8)(0, -1, 0, -1, 0, -1, 0, -1);
        const int pass = p.channels == 1 ? 2 * TF_ORDER_BLOCK : TF_ORDER_BLOCK; // orders per pass
        for (int m0 = 0; m0 < p.orders; m0 += pass) {
            const int pair = p.channels == 1 && m0 + TF_ORDER_BLOCK < p.orders;
            // double8 per lane this pass: RGB's last block only as many as its orders fill (the seed's
            // 20 orders: two of three; the gloss's 34: one)
            const int rgb_vectors = min(3, (3 * (p.orders - m0) + 7) / 8);
            const int vectors = p.channels == 1 ? 1 + pair : rgb_vectors;
            for (int l = 0; l < TF_LANES; ++l) {
                // Zeros for a lane below the horizon (its value is replaced; they keep its sums
                // defined) and for one whose cell needs no orders from m0 on.
                if (lane_below[l] || m0 >= lane_orders[l]) {
                    for (int q = 0; q < vectors; ++q) cells[q][l] = (double8)(0.0);
                    continue;
                }
                __global const double* fourier = orders + m0 * p.channels;
                if (p.channels == 1) { // a grey table: one channel, one double8 per block
                    double8 v0 = (double8)(0.0), v1 = (double8)(0.0), g0 = (double8)(0.0), g1 = (double8)(0.0);
                    const int both = pair && m0 + TF_ORDER_BLOCK < lane_orders[l];
                    if (both) {
                        for (int t = 0; t < 16; ++t) {
                            const double w = tap_w[t * TF_LANES + l];
                            __global const double* f = fourier + tap_at[t * TF_LANES + l];
                            v0 += w * vload8(0, f);
                            v1 += w * vload8(1, f);
                        }
                    } else {
                        for (int t = 0; t < 16; ++t)
                            v0 += tap_w[t * TF_LANES + l] * vload8(0, fourier + tap_at[t * TF_LANES + l]);
                    }
                    for (int t = 0; lane_ghost[l] && t < 16; ++t)
                        if (tap_mirrored[t * TF_LANES + l]) {
                            const double w = tap_w[t * TF_LANES + l];
                            __global const double* f = fourier + tap_at[t * TF_LANES + l];
                            g0 += w * vload8(0, f);
                            if (both) g1 += w * vload8(1, f);
                        }
                    cells[0][l] = select(v0, v0 - 2.0 * g0, odd_grey);
                    cells[1][l] = select(v1, v1 - 2.0 * g1, odd_grey);
                } else {
                    // A block's 3 x 8 sums as three double8, element for element the reference's
                    // loop over k.
                    double8 v0 = (double8)(0.0), v1 = (double8)(0.0), v2 = (double8)(0.0);
                    double8 g0 = (double8)(0.0), g1 = (double8)(0.0), g2 = (double8)(0.0);
                    for (int t = 0; t < 16; ++t) {
                        const double w = tap_w[t * TF_LANES + l];
                        __global const double* f = fourier + tap_at[t * TF_LANES + l];
                        v0 += w * vload8(0, f);
                        if (rgb_vectors > 1) v1 += w * vload8(1, f);
                        if (rgb_vectors > 2) v2 += w * vload8(2, f);
                    }
                    for (int t = 0; lane_ghost[l] && t < 16; ++t)
                        if (tap_mirrored[t * TF_LANES + l]) {
                            const double w = tap_w[t * TF_LANES + l];
                            __global const double* f = fourier + tap_at[t * TF_LANES + l];
                            g0 += w * vload8(0, f);
                            if (rgb_vectors > 1) g1 += w * vload8(1, f);
                            if (rgb_vectors > 2) g2 += w * vload8(2, f);
                        }
                    cells[0][l] = select(v0, v0 - 2.0 * g0, (long8)(0, 0, 0, -1, -1, -1, 0, 0));
                    cells[1][l] = select(v1, v1 - 2.0 * g1, (long8)(0, -1, -1, -1, 0, 0, 0, -1));
                    cells[2][l] = select(v2, v2 - 2.0 * g2, (long8)(-1, -1, 0, 0, 0, -1, -1, -1));
                }
            }
            for (int q = 0; q < vectors; ++q) transpose(cells[q], terms + TF_LANES * q);
            for (int j = 0; j < vectors * TF_LANES / p.channels; ++j) {
                if (p.channels == 1) {
                    out0 += terms[j] * cm;
                } else {
                    out0 += terms[3 * j] * cm;
                    out1 += terms[3 * j + 1] * cm;
                    out2 += terms[3 * j + 2] * cm;
                }
                const double8 next = 2.0 * c1 * cm - cm_prev;
                cm_prev = cm;
                cm = next;
            }
        }
        if (p.channels == 1) out1 = out2 = out0;
        // Single scattering with the full phase function, per term (its own refraction; table_fill.cpp:
        // add_single_scattering), each term's phase table RGB.
        const double8 sin_i = sqrt(max0_ref(1.0 - mu_i * mu_i)), sin_o = sqrt(max0_ref(1.0 - mu_o * mu_o));
        const int kp = p.phase_points, kf = p.fresnel_points;
        double8 wo[4], wi[4];
        const int8 ko = cubic_taps(kf, mu_o, wo), ki = cubic_taps(kf, mu_i, wi);
        __global const double* refractive_index = data + p.refractive_index_offset;
        __global const double* tau = data + p.tau_offset;
        for (int s = 0; s < p.samples; ++s) {
            const double n = refractive_index[s], inv_n2 = 1.0 / (n * n);
            const double8 ui = sqrt(1.0 - sin_i * sin_i * inv_n2), uo = sqrt(1.0 - sin_o * sin_o * inv_n2);
            const double8 cos_scatter = clamp_ref(-uo * ui - sin_o * sin_i * inv_n2 * c1, -1.0, 1.0);
            __global const double* t = data + p.transmission_offset + (long)s * kf;
            const double8 factor = cubic_at(t, ko, wo) * cubic_at(t, ki, wi);
            const double8 slab = isinf(tau[s]) ? (double8)(1.0) : -expm1(-tau[s] * (1.0 / uo + 1.0 / ui));
            const double8 v = factor / (uo + ui) * slab;
            double8 phase[3];
            const double8 u = sqrt(0.5 * (1.0 - cos_scatter)) - sqrt(0.5 * (1.0 + cos_scatter));
            cubic_rgb_table(data + p.phase_offset + (long)s * kp * p.channels, kp, p.channels, 0.5 * (u + 1.0), phase);
            out0 += v * phase[0];
            out1 += v * phase[1];
            out2 += v * phase[2];
        }
        out0 = max0_ref(out0);
        out1 = max0_ref(out1);
        out2 = max0_ref(out2);
        // The rough top's first-surface lobe (table_fill.cpp: lobe_geometry), D G / (4 mu_i mu_o)
        // times the channel's facet Fresnel factor at wi.h.
        if (p.lobe != 0) {
            const double8 s_i = sqrt(max0_ref((1.0 - mu_i) * (1.0 + mu_i)));
            const double8 s_o = sqrt(max0_ref((1.0 - mu_o) * (1.0 + mu_o)));
            const double8 omc = 1.0 + c1;
            const double8 sum = mu_i + mu_o;
            const double8 t2 = ((s_i - s_o) * (s_i - s_o) + 2.0 * s_i * s_o * omc) / (sum * sum);
            const double alpha = p.lobe_alpha;
            const double a2 = alpha * alpha;
            const double8 sec2 = 1.0 + t2;
            double8 d;
            if (p.lobe == 1) {
                const double8 q = a2 + t2;
                d = a2 * sec2 * sec2 / (TF_PI * q * q);
            } else {
                d = exp(-t2 / a2) * sec2 * sec2 / (TF_PI * a2);
            }
            const double8 li = smith_lambda(p.lobe, alpha, mu_i, s_i);
            const double8 lo = smith_lambda(p.lobe, alpha, mu_o, s_o);
            const double8 g = p.lobe_separable ? 1.0 / ((1.0 + li) * (1.0 + lo)) : 1.0 / (1.0 + li + lo);
            const double8 cos_d = sqrt(max0_ref(0.5 * (1.0 + mu_i * mu_o - s_i * s_o + s_i * s_o * omc)));
            const double8 value = d * g / (4.0 * mu_i * mu_o);
            __global const double* fresnel = data + p.lobe_fresnel_offset;
            const int lp = p.lobe_points;
            double8 wd[4];
            const int8 kd = cubic_taps(lp, cos_d, wd);
            out0 = max0_ref(out0 + value * cubic_at(fresnel, kd, wd));
            out1 = max0_ref(out1 + value * cubic_at(fresnel + lp, kd, wd));
            out2 = max0_ref(out2 + value * cubic_at(fresnel + 2 * (long)lp, kd, wd));
        }
    }
    double r[TF_LANES], g[TF_LANES], b[TF_LANES];
    vstore8(select(out0, (double8)(TF_NO_DATA), below), 0, r);
    vstore8(select(out1, (double8)(TF_NO_DATA), below), 0, g);
    vstore8(select(out2, (double8)(TF_NO_DATA), below), 0, b);
    for (int l = 0; l < TF_LANES; ++l) {
        if (!lane_valid[l]) continue;
        red[cell[l]] = red[mirror[l]] = r[l];
        if (p.channels == 1) continue; // a grey table: red stands for all three (green, blue are red)
        green[cell[l]] = green[mirror[l]] = g[l];
        blue[cell[l]] = blue[mirror[l]] = b[l];
    }
}
