#!/usr/bin/env python3
"""Reference colour weights for tests/material/spectrum_test.cpp, and the choice of the "rgb" set.

Writes
  spectral_weights_visible.csv   weights of the "visible" set (380..780 nm step 10)
  spectral_weights_explicit.csv  weights of the explicit list 450, 500.5, 610, 700 nm
  spectral_summary.txt           D65 white chromaticity of the 5 nm tables, white-balance scales,
                                 dominant wavelengths of the Rec.709 primaries, RGB of test spectra

Independent of the C++: the solved values are spread onto the CIE 5 nm grid with numpy.interp
(piecewise linear, constant beyond the ends), i.e. the weight of wavelength j is the colour of the
basis reflectance e_j; CIE 15 sums from 380 to 780 nm, Y of white = 1; XYZ -> linear Rec.709 by the
IEC 61966-2-1 matrix; each channel scaled so that R = 1 gives (1, 1, 1).

Run from anywhere: python3 tests/reference/material/spectral_weights.py
"""
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "..", "data", "cie")

cmf = np.loadtxt(os.path.join(DATA, "cie1931_2deg_5nm.csv"), delimiter=",", comments="#", skiprows=2)
d65 = np.loadtxt(os.path.join(DATA, "cie_d65_5nm.csv"), delimiter=",", comments="#", skiprows=2)
grid = cmf[:, 0]
S = np.array([d65[d65[:, 0] == l, 1][0] for l in grid])
keep = (grid >= 380) & (grid <= 780)
grid, S, xyz_bar = grid[keep], S[keep], cmf[keep, 1:4]
M = np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]])
K = 1.0 / np.sum(xyz_bar[:, 1] * S)


def xyz_of(wl, values):
    r = np.interp(grid, wl, values)  # constant beyond the ends
    return K * (xyz_bar * (S * r)[:, None]).sum(axis=0)


def weights(wl):
    wl = np.asarray(wl, dtype=float)
    xyz = np.array([xyz_of(wl, np.eye(len(wl))[j]) for j in range(len(wl))])
    rgb = xyz @ M.T
    balance = 1.0 / rgb.sum(axis=0)
    return xyz, rgb * balance, balance


def write(name, wl, xyz, rgb):
    with open(os.path.join(HERE, name), "w") as f:
        f.write("# written by spectral_weights.py; do not edit\n")
        f.write("wavelength_nm,wx,wy,wz,wr,wg,wb\n")
        for j, l in enumerate(wl):
            f.write(",".join(repr(float(v)) for v in [l, *xyz[j], *rgb[j]]) + "\n")


def dominant_wavelength(primary, white=(0.3127, 0.3290)):
    """Where the ray from the white point through the primary meets the spectral locus: the CIE 1931
    colour-matching functions interpolated linearly to a 0.01 nm grid (360-830 nm), their
    chromaticities joined by straight segments."""
    fine = np.arange(360.0, 830.0 + 1e-9, 0.01)
    bars = np.stack([np.interp(fine, cmf[:, 0], cmf[:, c]) for c in (1, 2, 3)], axis=1)
    lx = bars[:, 0] / bars.sum(axis=1)
    ly = bars[:, 1] / bars.sum(axis=1)
    w = np.array(white)
    d = np.array(primary) - w
    # signed side of each locus point with respect to the ray; a sign change brackets the crossing
    side = (lx - w[0]) * d[1] - (ly - w[1]) * d[0]
    ahead = (lx - w[0]) * d[0] + (ly - w[1]) * d[1] > 0
    for i in range(len(fine) - 1):
        if ahead[i] and side[i] * side[i + 1] <= 0 and side[i] != side[i + 1]:
            t = side[i] / (side[i] - side[i + 1])
            return float(fine[i] + 0.01 * t)
    return None


def main():
    wl = np.arange(380.0, 781.0, 10.0)
    xyz, rgb, balance = weights(wl)
    write("spectral_weights_visible.csv", wl, xyz, rgb)
    ex = [450.0, 500.5, 610.0, 700.0]
    xyz_e, rgb_e, _ = weights(ex)
    write("spectral_weights_explicit.csv", ex, xyz_e, rgb_e)

    white = xyz.sum(axis=0)
    x, y = white[0] / white.sum(), white[1] / white.sum()
    fine = np.arange(380.0, 780.01, 1.0)
    ramp = 0.2 + 0.6 * (fine - 380.0) / 400.0  # a smooth test spectrum
    bump = 0.1 + 0.8 * np.exp(-0.5 * ((fine - 530.0) / 40.0) ** 2)
    with open(os.path.join(HERE, "spectral_summary.txt"), "w") as f:
        f.write("# written by spectral_weights.py; do not edit\n")
        f.write(f"white_xy {float(x)!r} {float(y)!r}\n")
        f.write("white_balance " + " ".join(repr(float(v)) for v in balance) + "\n")
        for name, p in [("red", (0.64, 0.33)), ("green", (0.30, 0.60)), ("blue", (0.15, 0.06))]:
            f.write(f"dominant_wavelength_{name} {dominant_wavelength(p)!r}\n")
        for name, spec in [("ramp_1nm", ramp), ("bump_1nm", bump)]:
            xyz_s = xyz_of(fine, spec)
            rgb_s = (M @ xyz_s) * balance
            f.write(f"{name}_rgb " + " ".join(repr(float(v)) for v in rgb_s) + "\n")
    print("white xy", x, y, "balance", balance)


if __name__ == "__main__":
    main()
