// The MERL table fill: one work-item per cell of the 90 x 90 x 180 half/difference table. The C++
// reference is brdf::model::fill_table_cpu and cell_value (src/brdf/model/table_fill.cpp) with
// the bin-centre geometry of formats/halfdiff.cpp (cell_indices, theta_h/theta_d/phi_d_centre,
// to_directions) and the below-horizon test of formats::cell_below_horizon; this is the same
// computation, formula for formula and in the same order of summation, in double precision without
// contraction. Cells whose incident or outgoing bin-centre direction has z <= 0 get TF_NO_DATA in
// all three channels.

#pragma OPENCL FP_CONTRACT OFF

#include "shared/table_fill_layout.h"

#if TF_ORDER_BLOCK != 8
#error "table_fill sums a block of orders as three double8 (3 channels x 8 orders)"
#endif

#define TF_PI 3.14159265358979323846

// std::clamp(v, lo, hi) (also for NaN: v < lo and hi < v are both false, v comes back).
static double clamp_ref(double v, double lo, double hi) { return v < lo ? lo : (hi < v ? hi : v); }

// std::max(0.0, v): 0 for NaN too.
static double max0_ref(double v) { return 0.0 < v ? v : 0.0; }

// table_fill.cpp: catmull_rom, the weights of taps (-1, 0, 1, 2) at fraction f in [0, 1).
static void catmull_rom(double f, double w[4]) {
    const double f2 = f * f, f3 = f2 * f;
    w[0] = 0.5 * (-f3 + 2.0 * f2 - f);
    w[1] = 0.5 * (3.0 * f3 - 5.0 * f2 + 2.0);
    w[2] = 0.5 * (-3.0 * f3 + 4.0 * f2 + f);
    w[3] = 0.5 * (f3 - f2);
}

// Catmull-Rom taps and weights along one zenith axis of the grid (table_fill.cpp: stencil).
static void stencil(double mu, int grid, int idx[4], double w[4], int ghost[4]) {
    const double t = acos(clamp_ref(2.0 * mu - 1.0, -1.0, 1.0)) / TF_PI * (grid - 1);
    const int i0 = min((int)t, grid - 2);
    catmull_rom(t - i0, w);
    for (int k = 0; k < 4; ++k) {
        const int j = i0 - 1 + k;
        idx[k] = j > grid - 1 ? 2 * (grid - 1) - j : (j < 0 ? -j : j);
        ghost[k] = j < 0;
    }
}

// table_fill.cpp: cubic_taps (one ghost point beyond each end: x_k = (k - 1) / (points - 3)); returns k.
static int cubic_taps(int points, double x, double w[4]) {
    const int intervals = points - 3;
    const double t = clamp_ref(x, 0.0, 1.0) * intervals;
    const int k = min((int)t, intervals - 1);
    catmull_rom(t - k, w);
    return k;
}

// table_fill.cpp: cubic_table.
static double cubic_table(__global const double* table, int points, double x) {
    double w[4];
    __global const double* v = table + cubic_taps(points, x, w);
    return w[0] * v[0] + w[1] * v[1] + w[2] * v[2] + w[3] * v[3];
}

// table_fill.cpp: cubic_rgb_table, cubic_table for a table of RGB triples or (channels 1) of single
// values, then in all three.
static void cubic_rgb_table(__global const double* table, int points, int channels, double x, double out[3]) {
    double w[4];
    __global const double* v = table + channels * (long)cubic_taps(points, x, w);
    for (int c = 0; c < channels; ++c)
        out[c] = w[0] * v[c] + w[1] * v[channels + c] + w[2] * v[2 * channels + c] + w[3] * v[3 * channels + c];
    if (channels == 1) out[1] = out[2] = out[0];
}

// table_fill.cpp: smith_lambda (Walter et al. 2007, G1 of eqs. 34 and 27).
static double smith_lambda(int lobe, double alpha, double mu, double s) {
    if (!(s > 0.0)) return 0.0;
    if (!(mu > 0.0)) return INFINITY;
    if (lobe == 1) {
        const double x = alpha * alpha * s * s / (mu * mu);
        return x / (2.0 * (1.0 + sqrt(1.0 + x)));
    }
    const double a = mu / (alpha * s);
    return 0.5 * (exp(-a * a) / (a * sqrt(TF_PI)) - erfc(a));
}

// The three channels' planes are separate buffers: the host's table planes themselves on a CPU
// device (cl_table_fill.cpp maps them with CL_MEM_USE_HOST_PTR).
__kernel void table_fill(__global const FillParams* params_in, __global const double* data,
                         __global double* red, __global double* green, __global double* blue) {
    const FillParams p = *params_in;
    // One work item per cell of the first half of phi_d, writing it and its mirror phi_d -> pi -
    // phi_d (table_fill.cpp: fill_table_cpu says why they are equal).
    const long id = (long)get_global_id(0);
    if (id >= p.cell_count / 2) return;
    const int phi_k = (int)(id % (TF_PHI_D_BINS / 2));
    const long rest = id / (TF_PHI_D_BINS / 2);
    const long cell = rest * TF_PHI_D_BINS + phi_k;
    const long mirror = rest * TF_PHI_D_BINS + (TF_PHI_D_BINS - 1 - phi_k);

    // formats::cell_indices; the bin centres' sin and cos from the host's table.
    const int theta_dj = (int)(rest % TF_THETA_D_BINS);
    const int theta_hi = (int)(rest / TF_THETA_D_BINS);
    __global const double* trig = data + p.geometry_offset;
    const double sh = trig[2 * theta_hi], ch = trig[2 * theta_hi + 1];
    const double sd = trig[2 * (TF_THETA_H_BINS + theta_dj)], cd = trig[2 * (TF_THETA_H_BINS + theta_dj) + 1];
    const double sp = trig[2 * (TF_THETA_H_BINS + TF_THETA_D_BINS + phi_k)];
    const double cp = trig[2 * (TF_THETA_H_BINS + TF_THETA_D_BINS + phi_k) + 1];

    // formats::to_directions: wi = Ry(theta_h) d, wo = Ry(theta_h) (-d.x, -d.y, d.z).
    const double dx = sd * cp, dy = sd * sp, dz = cd;
    const double wix = dx * ch + dz * sh, wiy = dy, wiz = -dx * sh + dz * ch;
    const double mdx = -dx, mdy = -dy;
    const double wox = mdx * ch + dz * sh, woy = mdy, woz = -mdx * sh + dz * ch;

    if (wiz <= 0.0 || woz <= 0.0) { // formats::cell_below_horizon
        red[cell] = red[mirror] = TF_NO_DATA;
        green[cell] = green[mirror] = TF_NO_DATA;
        blue[cell] = blue[mirror] = TF_NO_DATA;
        return;
    }
    // table_fill.cpp: cell_directions.
    const double mu_i = clamp_ref(wiz, -1.0, 1.0), mu_o = clamp_ref(woz, -1.0, 1.0);
    const double horizontal = sqrt((wix * wix + wiy * wiy) * (wox * wox + woy * woy));
    const double c1 = horizontal > 0.0 ? clamp_ref((wix * wox + wiy * woy) / horizontal, -1.0, 1.0) : 1.0;

    // table_fill.cpp: cell_value
    double out0 = 0.0, out1 = 0.0, out2 = 0.0;
    if (mu_i > 0.0 && mu_o > 0.0) {
        const int e = p.grid;
        int so_idx[4], si_idx[4], so_g[4], si_g[4];
        double so_w[4], si_w[4];
        stencil(mu_o, e, so_idx, so_w, so_g);
        stencil(mu_i, e, si_idx, si_w, si_g);
        double cm_prev = c1, cm = 1.0; // cos(-phi) = cos(phi), cos(0)
        __global const double* fourier = data + p.fourier_offset;
        const int mp = (p.orders + TF_ORDER_BLOCK - 1) / TF_ORDER_BLOCK * TF_ORDER_BLOCK;
        // A grey table: one channel, one double8 per block, copied to all three.
        for (int m0 = 0; p.channels == 1 && m0 < p.orders; m0 += TF_ORDER_BLOCK) {
            // table_fill.cpp: cell_value (acc and mirrored).
            double8 v0 = (double8)(0.0), g0 = (double8)(0.0);
            for (int a = 0; a < 4; ++a)
                for (int b = 0; b < 4; ++b) {
                    const double w = so_w[a] * si_w[b];
                    const double8 t0 = w * vload8(0, fourier + (((long)so_idx[a] * e + si_idx[b]) * mp + m0));
                    v0 += t0;
                    if (so_g[a] != si_g[b]) g0 += t0;
                }
            double acc[TF_ORDER_BLOCK], mirrored[TF_ORDER_BLOCK];
            vstore8(v0, 0, acc);
            vstore8(g0, 0, mirrored);
            for (int j = 0; j < TF_ORDER_BLOCK; ++j) {
                out0 += (j % 2 == 1 ? acc[j] - 2.0 * mirrored[j] : acc[j]) * cm;
                const double next = 2.0 * c1 * cm - cm_prev;
                cm_prev = cm;
                cm = next;
            }
        }
        if (p.channels == 1) out1 = out2 = out0;
        for (int m0 = 0; p.channels == 3 && m0 < p.orders; m0 += TF_ORDER_BLOCK) {
            // A block's 3 x 8 sums as three double8, element for element the reference's loop over
            // k: PoCL then vectorises within the work item (contiguous taps) instead of across work
            // items, whose taps lie apart (a third of the time of the scalar loop, same values).
            double8 v0 = (double8)(0.0), v1 = (double8)(0.0), v2 = (double8)(0.0);
            double8 g0 = (double8)(0.0), g1 = (double8)(0.0), g2 = (double8)(0.0);
            for (int a = 0; a < 4; ++a)
                for (int b = 0; b < 4; ++b) {
                    const double w = so_w[a] * si_w[b];
                    __global const double* f = fourier + (((long)so_idx[a] * e + si_idx[b]) * mp + m0) * 3;
                    const double8 t0 = w * vload8(0, f), t1 = w * vload8(1, f), t2 = w * vload8(2, f);
                    v0 += t0;
                    v1 += t1;
                    v2 += t2;
                    if (so_g[a] != si_g[b]) {
                        g0 += t0;
                        g1 += t1;
                        g2 += t2;
                    }
                }
            double acc[3 * TF_ORDER_BLOCK], mirrored[3 * TF_ORDER_BLOCK];
            vstore8(v0, 0, acc);
            vstore8(v1, 1, acc);
            vstore8(v2, 2, acc);
            vstore8(g0, 0, mirrored);
            vstore8(g1, 1, mirrored);
            vstore8(g2, 2, mirrored);
            for (int j = 0; j < TF_ORDER_BLOCK; ++j) {
                const int odd = j % 2 == 1;
                out0 += (odd ? acc[3 * j] - 2.0 * mirrored[3 * j] : acc[3 * j]) * cm;
                out1 += (odd ? acc[3 * j + 1] - 2.0 * mirrored[3 * j + 1] : acc[3 * j + 1]) * cm;
                out2 += (odd ? acc[3 * j + 2] - 2.0 * mirrored[3 * j + 2] : acc[3 * j + 2]) * cm;
                const double next = 2.0 * c1 * cm - cm_prev;
                cm_prev = cm;
                cm = next;
            }
        }
        // Single scattering with the full phase function, per term (its own refraction; table_fill.cpp:
        // add_single_scattering), each term's phase table RGB.
        const double sin_i = sqrt(max0_ref(1.0 - mu_i * mu_i)), sin_o = sqrt(max0_ref(1.0 - mu_o * mu_o));
        const int kp = p.phase_points, kf = p.fresnel_points;
        __global const double* refractive_index = data + p.refractive_index_offset;
        __global const double* tau = data + p.tau_offset;
        for (int s = 0; s < p.samples; ++s) {
            const double n = refractive_index[s], inv_n2 = 1.0 / (n * n);
            const double ui = sqrt(1.0 - sin_i * sin_i * inv_n2), uo = sqrt(1.0 - sin_o * sin_o * inv_n2);
            const double cos_scatter = clamp_ref(-uo * ui - sin_o * sin_i * inv_n2 * c1, -1.0, 1.0);
            __global const double* t = data + p.transmission_offset + (long)s * kf;
            const double factor = cubic_table(t, kf, mu_o) * cubic_table(t, kf, mu_i);
            const double slab = isinf(tau[s]) ? 1.0 : -expm1(-tau[s] * (1.0 / uo + 1.0 / ui));
            const double v = factor / (uo + ui) * slab;
            double phase[3];
            const double u = sqrt(0.5 * (1.0 - cos_scatter)) - sqrt(0.5 * (1.0 + cos_scatter));
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
            const double s_i = sqrt(max0_ref((1.0 - mu_i) * (1.0 + mu_i)));
            const double s_o = sqrt(max0_ref((1.0 - mu_o) * (1.0 + mu_o)));
            const double omc = 1.0 + c1;
            const double sum = mu_i + mu_o;
            const double t2 = ((s_i - s_o) * (s_i - s_o) + 2.0 * s_i * s_o * omc) / (sum * sum);
            const double alpha = p.lobe_alpha;
            const double a2 = alpha * alpha, sec2 = 1.0 + t2;
            double d = 0.0;
            if (p.lobe == 1) {
                const double q = a2 + t2;
                d = a2 * sec2 * sec2 / (TF_PI * q * q);
            } else {
                d = exp(-t2 / a2) * sec2 * sec2 / (TF_PI * a2);
            }
            const double li = smith_lambda(p.lobe, alpha, mu_i, s_i);
            const double lo = smith_lambda(p.lobe, alpha, mu_o, s_o);
            const double g = p.lobe_separable ? 1.0 / ((1.0 + li) * (1.0 + lo)) : 1.0 / (1.0 + li + lo);
            const double cos_d = sqrt(max0_ref(0.5 * (1.0 + mu_i * mu_o - s_i * s_o + s_i * s_o * omc)));
            const double value = d * g / (4.0 * mu_i * mu_o);
            __global const double* fresnel = data + p.lobe_fresnel_offset;
            const int lp = p.lobe_points;
            out0 = max0_ref(out0 + value * cubic_table(fresnel, lp, cos_d));
            out1 = max0_ref(out1 + value * cubic_table(fresnel + lp, lp, cos_d));
            out2 = max0_ref(out2 + value * cubic_table(fresnel + 2 * (long)lp, lp, cos_d));
        }
    }
    red[cell] = red[mirror] = out0;
    green[cell] = green[mirror] = out1;
    blue[cell] = blue[mirror] = out2;
}
