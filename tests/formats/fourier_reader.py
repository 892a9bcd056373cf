#!/usr/bin/env python3
"""An independent reader of pbrt-v3 Fourier BSDF files (layerlab / Mitsuba "SCATFUN" version 1).

Written from the format description in docs/formats.md ("Fourier BSDF") and pbrt-v3's
FourierBSDF::f as the PBR book, 3rd edition, section 8.6 states it, not from our C++ code: numpy
only, so that a mistake in formats/fourier/ is not repeated here.

File (little-endian): a 64-byte header
    char[7] "SCATFUN", uint8 version (1), int32 flags (1: a BSDF), nMu, nCoeffs, mMax,
    nChannels (1: Y; 3: Y, R, B), nBases (1), nMetadataBytes, nParameters (0),
    nParameterValues (0), float32 eta, float32 alpha[2], float32 unused[2];
then float32 mu[nMu], float32 cdf[nMu * nMu], int32 (offset, length)[nMu * nMu],
float32 coefficients[nCoeffs], nMetadataBytes bytes of metadata. Pair (o, i) (o: outgoing node,
i: incident node) is entry o * nMu + i; its channel c holds coefficients[offset + c * length + k],
k < length.

Evaluation (pbrt-v3, both directions pointing away from the surface, wi towards the light):
    mu_i = cos(-wi), mu_o = cos(wo), cos_phi = cos of the azimuth between -wi and wo;
    a_k = sum of Catmull-Rom weights(mu_i) x weights(mu_o) x coefficients of the 16 pairs;
    f = sum_k a_k cos(k phi) / |mu_i|, Y clamped at 0, G = 1.39829 Y - 0.100913 B - 0.297375 R.
In our conventions (docs/design.md: theta_i of the light, theta_o of the viewer, phi = phi_o -
phi_i, phi = 0 with the viewer on the light's side) mu_i = -cos(theta_i), mu_o = cos(theta_o) and
the azimuth between -wi and wo is pi - phi.

Usage:
    fourier_reader.py FILE --check CSV [--tolerance 1e-6]
        CSV: lines "theta_i theta_o phi r g b" (radians; BRDF in 1/sr) that another evaluator
        produced; every value must agree to the tolerance (relative, with an absolute floor of
        the tolerance times the largest value). Exit status 0 when all agree, 1 otherwise.
    fourier_reader.py FILE --model CSV [--max-theta-deg 85] [--median 0.002] [--worst 0.02]
        CSV: the same lines holding the model's exact BRDF; reports the median and worst
        relative difference of the file's BRDF below --max-theta-deg and fails beyond the limits.
    fourier_reader.py FILE --info
        the header and metadata.
"""

import argparse
import math
import struct
import sys

import numpy as np

HEADER = struct.Struct("<7sB9i5f")  # 64 bytes
assert HEADER.size == 64


class FormatFault(Exception):
    pass


class FourierFile:
    def __init__(self, path):
        with open(path, "rb") as f:
            data = f.read()
        if len(data) < HEADER.size:
            raise FormatFault(f"{path}: truncated header ({len(data)} bytes)")
        (magic, version, flags, n_mu, n_coeffs, m_max, n_channels, n_bases, n_meta, n_par,
         n_par_values, eta, alpha0, alpha1, _u0, _u1) = HEADER.unpack_from(data, 0)
        if magic != b"SCATFUN" or version != 1:
            raise FormatFault(f"{path}: not a SCATFUN version 1 file")
        if flags != 1 or n_channels not in (1, 3) or n_bases != 1 or n_par != 0 or n_par_values != 0:
            raise FormatFault(f"{path}: unsupported variant (flags {flags}, channels {n_channels}, "
                              f"bases {n_bases}, parameters {n_par})")
        expected = 64 + 4 * n_mu + 4 * n_mu * n_mu + 8 * n_mu * n_mu + 4 * n_coeffs + n_meta
        if len(data) != expected:
            raise FormatFault(f"{path}: {len(data)} bytes, header implies {expected}")
        pos = 64
        self.mu = np.frombuffer(data, "<f4", n_mu, pos).astype(np.float64)
        pos += 4 * n_mu
        self.cdf = np.frombuffer(data, "<f4", n_mu * n_mu, pos).astype(np.float64).reshape(n_mu, n_mu)
        pos += 4 * n_mu * n_mu
        table = np.frombuffer(data, "<i4", 2 * n_mu * n_mu, pos).reshape(n_mu, n_mu, 2)
        pos += 8 * n_mu * n_mu
        self.coeffs = np.frombuffer(data, "<f4", n_coeffs, pos).astype(np.float64)
        pos += 4 * n_coeffs
        self.metadata = data[pos:pos + n_meta].decode("utf-8", errors="replace")
        self.offset = table[:, :, 0].astype(np.int64)  # [o, i]
        self.length = table[:, :, 1].astype(np.int64)
        if np.any(self.length < 0) or np.any(self.offset < 0) or \
                np.any(self.offset + self.length * n_channels > n_coeffs):
            raise FormatFault(f"{path}: a series lies outside the coefficients")
        if self.length.max(initial=0) > m_max:
            raise FormatFault(f"{path}: a series is longer than mMax")
        self.n_mu, self.m_max, self.channels, self.eta = n_mu, m_max, n_channels, eta
        self.alpha = (alpha0, alpha1)
        self.n_coeffs = n_coeffs

    def series(self, o, i, channel):
        n = self.length[o, i]
        start = self.offset[o, i] + channel * n
        return self.coeffs[start:start + n]


def catmull_rom_weights(nodes, x):
    """(offset, [w0, w1, w2, w3]) of the PBR book's CatmullRomWeights (section 8.6.1), or None
    outside the nodes. The weights belong to nodes offset .. offset + 3."""
    n = len(nodes)
    if not (nodes[0] <= x <= nodes[-1]):
        return None
    # The interval: the last node <= x, kept within [0, n - 2].
    idx = int(np.searchsorted(nodes, x, side="right")) - 1
    idx = min(max(idx, 0), n - 2)
    x0, x1 = nodes[idx], nodes[idx + 1]
    t = (x - x0) / (x1 - x0)
    t2, t3 = t * t, t * t * t
    w = [0.0, 2 * t3 - 3 * t2 + 1, -2 * t3 + 3 * t2, 0.0]
    # Hermite tangents estimated by finite differences over the neighbouring nodes; at the ends
    # the one-sided difference over the interval itself.
    if idx > 0:
        w0 = (t3 - 2 * t2 + t) * (x1 - x0) / (x1 - nodes[idx - 1])
        w[0] = -w0
        w[2] += w0
    else:
        w0 = t3 - 2 * t2 + t
        w[0] = 0.0
        w[1] -= w0
        w[2] += w0
    if idx + 2 < n:
        w3 = (t3 - t2) * (x1 - x0) / (nodes[idx + 2] - x0)
        w[1] -= w3
        w[3] = w3
    else:
        w3 = t3 - t2
        w[1] -= w3
        w[2] += w3
        w[3] = 0.0
    return idx - 1, w


def fourier_sum(a, cos_phi):
    phi = math.acos(max(-1.0, min(1.0, cos_phi)))
    k = np.arange(len(a))
    return float(np.sum(a * np.cos(k * phi)))


def evaluate_pbrt(bsdf, mu_i, mu_o, cos_phi, radiance=True):
    """pbrt-v3's FourierBSDF::f in its own variables: RGB (1/sr)."""
    wi = catmull_rom_weights(bsdf.mu, mu_i)
    wo = catmull_rom_weights(bsdf.mu, mu_o)
    if wi is None or wo is None:
        return np.zeros(3)
    (oi, weights_i), (oo, weights_o) = wi, wo
    ak = np.zeros((bsdf.channels, max(bsdf.m_max, 1)))
    for b in range(4):
        for a in range(4):
            weight = weights_i[a] * weights_o[b]
            if weight == 0.0:
                continue
            o, i = oo + b, oi + a
            n = bsdf.length[o, i]
            for c in range(bsdf.channels):
                ak[c, :n] += weight * bsdf.series(o, i, c)
    y = max(0.0, fourier_sum(ak[0], cos_phi))
    # Below a cosine of 1e-12 the light grazes the surface and 1/|mu_i| amplifies rounding
    # noise; like pbrt-v3 at mu_i == 0, return 0 there (docs/formats.md).
    scale = 1.0 / abs(mu_i) if abs(mu_i) > 1e-12 else 0.0
    if radiance and mu_i * mu_o > 0:  # transmission, radiance transport
        eta = 1.0 / bsdf.eta if mu_i > 0 else bsdf.eta
        scale *= eta * eta
    if bsdf.channels == 1:
        return np.array([y, y, y]) * scale
    r = fourier_sum(ak[1], cos_phi)
    bl = fourier_sum(ak[2], cos_phi)
    g = 1.39829 * y - 0.100913 * bl - 0.297375 * r
    return np.maximum(np.array([r, g, bl]) * scale, 0.0)


def evaluate(bsdf, theta_i, theta_o, phi):
    """Our conventions: theta_i (light) and theta_o (viewer) zenith angles, phi = phi_o - phi_i
    (0: viewer on the light's side), radians; RGB BRDF in 1/sr."""
    mu_i = -math.cos(theta_i)
    mu_o = math.cos(theta_o)
    # pbrt-v3 takes cos phi = 1 when either direction is vertical (no azimuth).
    if math.sin(theta_i) == 0.0 or math.sin(theta_o) == 0.0:
        cos_phi = 1.0
    else:
        cos_phi = math.cos(math.pi - phi)
    return evaluate_pbrt(bsdf, mu_i, mu_o, cos_phi)


def read_rows(path):
    rows = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            values = [float(v) for v in line.split()]
            if len(values) != 6:
                raise SystemExit(f"{path}:{number}: expected 'theta_i theta_o phi r g b'")
            rows.append(values)
    return np.array(rows)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("file")
    parser.add_argument("--check", help="values of another evaluator to agree with")
    parser.add_argument("--tolerance", type=float, default=1e-6)
    parser.add_argument("--model", help="exact model values to compare with")
    parser.add_argument("--max-theta-deg", type=float, default=85.0)
    parser.add_argument("--median", type=float, default=0.002)
    parser.add_argument("--worst", type=float, default=0.02)
    parser.add_argument("--info", action="store_true")
    args = parser.parse_args(argv)
    try:
        bsdf = FourierFile(args.file)
    except FormatFault as e:
        print(e, file=sys.stderr)
        return 1
    if args.info:
        print(f"nodes {bsdf.n_mu}, mMax {bsdf.m_max}, channels {bsdf.channels}, eta {bsdf.eta}, "
              f"coefficients {bsdf.n_coeffs}\nmetadata: {bsdf.metadata}")
    if args.check:
        rows = read_rows(args.check)
        mine = np.array([evaluate(bsdf, *r[:3]) for r in rows])
        theirs = rows[:, 3:]
        scale = max(float(np.max(np.abs(theirs))), 1e-30)
        err = np.abs(mine - theirs) / np.maximum(np.abs(theirs), scale * args.tolerance)
        worst = int(np.argmax(np.max(err, axis=1)))
        print(f"{len(rows)} directions, largest relative difference {err.max():.3g} at "
              f"theta_i {rows[worst, 0]:.6g}, theta_o {rows[worst, 1]:.6g}, phi {rows[worst, 2]:.6g}: "
              f"reader {mine[worst]}, other {theirs[worst]}")
        if not err.max() <= args.tolerance:
            print(f"FAIL: above the tolerance {args.tolerance}", file=sys.stderr)
            return 1
    if args.model:
        rows = read_rows(args.model)
        limit = math.radians(args.max_theta_deg)
        keep = (rows[:, 0] <= limit) & (rows[:, 1] <= limit)
        rows = rows[keep]
        mine = np.array([evaluate(bsdf, *r[:3]) for r in rows])
        model = rows[:, 3:]
        floor = 1e-3 * max(float(np.max(model)), 1e-30)
        rel = np.abs(mine - model) / np.maximum(model, floor)
        print(f"{len(rows)} directions below {args.max_theta_deg:g} degrees: median relative "
              f"difference {np.median(rel):.3g}, worst {rel.max():.3g}")
        if not (np.median(rel) <= args.median and rel.max() <= args.worst):
            print(f"FAIL: limits median {args.median}, worst {args.worst}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
