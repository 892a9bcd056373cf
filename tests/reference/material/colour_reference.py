#!/usr/bin/env python3
"""Independent reference for tests/material/colour_test.cpp: colour-science (PyPI colour-science).

Writes colour_reference.json beside this script:
  table_white_xyz      XYZ of a perfect white (R = 1) under D65, Y = 1: what the 5 nm tables give
  spaces.NAME          primaries and white (the space's definition), the normalised primary matrix
                       from colour.normalised_primary_matrix (SMPTE RP 177), and the matrix from the
                       pipeline's XYZ to the space (adaptation and white balance included)
  spectra[]            a few reflectance spectra at the service's "visible" wavelengths (380..780 nm
                       step 10) with their XYZ, CIE 1976 chroma C*ab (white: the tables' white) and
                       their RGB in every space

What is computed, and how it matches the C++ (docs/colour.md):
- Integration: the reflectance given at 10 nm is spread onto the CIE 5 nm grid by numpy.interp
  (piecewise linear, the C++ rule), then colour.sd_to_XYZ(method="Integration") sums
  xbar S R over 380..780 nm on the repository's own 5 nm tables (data/cie), normalised so that Y of
  white is 100 (divided by 100 here). Same tables, same grid, same rule: the comparison measures the
  colour conversions, not two integration rules.
- rec709: colour.XYZ_to_RGB(..., "sRGB", no adaptation), i.e. the IEC 61966-2-1 matrix that
  colour-science also uses for sRGB, then the per-channel white balance of the C++ (each channel
  divided by that of the tables' white), so that R = 1 gives (1, 1, 1).
- acescg / rec2020: colour.XYZ_to_RGB with illuminant = the tables' white and
  chromatic_adaptation_transform="Bradford": the von Kries transform in the Bradford cone space from
  the tables' white to the space's white (ACES: x = 0.32168, y = 0.33767; BT.2020: D65), then the
  inverse normalised primary matrix. Bradford, not colour-science's default CAT02, because Bradford
  is the ACES convention (calculate_cat_matrix in the ACES CTL library defaults to
  CONE_RESP_MAT_BRADFORD; the OCIO ACES configs use it): docs/colour.md.

Run from anywhere: python3 tests/reference/material/colour_reference.py
(installs colour-science with pip when it is missing; the JSON is checked in, the C++ tests never
run Python).
"""
import json
import os
import subprocess
import sys

try:
    import colour
except ImportError:
    subprocess.check_call([sys.executable, "-m", "pip", "install", "--quiet", "colour-science"])
    import colour

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "..", "data", "cie")

cmf_table = np.loadtxt(os.path.join(DATA, "cie1931_2deg_5nm.csv"), delimiter=",", comments="#", skiprows=2)
d65_table = np.loadtxt(os.path.join(DATA, "cie_d65_5nm.csv"), delimiter=",", comments="#", skiprows=2)
keep = (cmf_table[:, 0] >= 380) & (cmf_table[:, 0] <= 780)
GRID = cmf_table[keep, 0]
CMFS = colour.MultiSpectralDistributions(
    dict(zip(GRID, cmf_table[keep, 1:4])), name="CIE 1931 2 degree (data/cie)")
D65 = colour.SpectralDistribution(
    {l: float(d65_table[d65_table[:, 0] == l, 1][0]) for l in GRID}, name="D65 (data/cie)")

VISIBLE = np.arange(380.0, 781.0, 10.0)

SPACES = {  # our name: colour-science's colourspace
    "rec709": colour.RGB_COLOURSPACES["sRGB"],
    "acescg": colour.RGB_COLOURSPACES["ACEScg"],
    "rec2020": colour.RGB_COLOURSPACES["ITU-R BT.2020"],
}


def xyz_of(reflectance_visible):
    r = np.interp(GRID, VISIBLE, reflectance_visible)
    sd = colour.SpectralDistribution(dict(zip(GRID, r)))
    return colour.sd_to_XYZ(sd, CMFS, D65, method="Integration") / 100.0


WHITE = xyz_of(np.ones(len(VISIBLE)))
WHITE_XY = colour.XYZ_to_xy(WHITE)


def to_space(xyz, name):
    cs = SPACES[name]
    if name == "rec709":
        raw = colour.XYZ_to_RGB(xyz, cs, illuminant=cs.whitepoint, chromatic_adaptation_transform=None)
        white = colour.XYZ_to_RGB(WHITE, cs, illuminant=cs.whitepoint, chromatic_adaptation_transform=None)
        return raw / white
    return colour.XYZ_to_RGB(xyz, cs, illuminant=WHITE_XY, chromatic_adaptation_transform="Bradford")


def spectra():
    l = VISIBLE
    return {
        # a flat grey: must come out (0.5, 0.5, 0.5) in every space
        "grey": np.full(len(l), 0.5),
        # cadmium-yellow-like: absorbing below the CdS band edge (~2.4 eV), a smooth step to 0.85
        "cds_yellow_step": 0.04 + 0.81 / (1.0 + np.exp(-(l - 505.0) / 8.0)),
        # a saturated green: a 18 nm Gaussian on a dark base
        "saturated_green": 0.03 + 0.6 * np.exp(-0.5 * ((l - 530.0) / 18.0) ** 2),
        # a narrow band: 1 at 600 nm only (a 20 nm wide hat on the 10 nm grid)
        "narrow_band_600": np.where(l == 600.0, 1.0, 0.0),
    }


def matrix_list(m):
    return [[float(v) for v in row] for row in np.asarray(m)]


def main():
    out = {
        "generator": "tests/reference/material/colour_reference.py",
        "colour_science_version": colour.__version__,
        "table_white_xyz": [float(v) for v in WHITE],
        "spaces": {},
        "spectra": [],
    }
    eye = np.eye(3)
    for name, cs in SPACES.items():
        # The matrix from the pipeline's XYZ to the space: its columns are the images of X, Y, Z.
        effective = np.stack([to_space(eye[i], name) for i in range(3)], axis=1)
        out["spaces"][name] = {
            "colour_science_name": cs.name,
            "primaries": matrix_list(cs.primaries),
            "white": [float(v) for v in cs.whitepoint],
            "normalised_primary_matrix": matrix_list(
                colour.normalised_primary_matrix(cs.primaries, cs.whitepoint)),
            "xyz_to_rgb": matrix_list(effective),
        }
    for name, r in spectra().items():
        xyz = xyz_of(r)
        out["spectra"].append({
            "name": name,
            "wavelengths_nm": [float(v) for v in VISIBLE],
            "reflectance": [float(v) for v in r],
            "xyz": [float(v) for v in xyz],
            # CIE 1976 chroma C*ab relative to the tables' white
            "chroma_ab": float(np.hypot(*colour.XYZ_to_Lab(xyz, illuminant=WHITE_XY)[1:])),
            "rgb": {space: [float(v) for v in to_space(xyz, space)] for space in SPACES},
        })
    with open(os.path.join(HERE, "colour_reference.json"), "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    for s in out["spectra"]:
        print(s["name"], {k: np.round(v, 4).tolist() for k, v in s["rgb"].items()})


if __name__ == "__main__":
    main()
