#!/usr/bin/env python3
"""Reference refractive indices for tests/material/catalogue_test.cpp.

Writes index_reference.csv: for every built-in material ID and a set of wavelengths, either the
expected index (n, k, extrapolated) or "error" where the documented range policy (docs/materials.md)
says the wavelength is outside the usable range.

This is deliberately independent of the C++ code:
  * Dispersion formulas are written in the form the original papers publish (not the database's
    generic formula 1/2/4), with the coefficients transcribed from the papers as quoted in the data
    files' references; the C++ reads the database's generic forms from the .yml files.
  * Tables are read with a plain regular expression and interpolated with numpy.interp, after the
    same documented repairs (rows whose wavelength does not exceed the previous row's dropped,
    negative k set to 0).
  * The usable ranges are typed in from docs/materials.md.
Uniaxial crystals: m = (2 m_o + m_e) / 3 for n and k.

Run from anywhere: python3 tests/reference/material/index_reference.py
"""
import csv
import math
import os
import re

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "..", "data", "refractiveindex")


# --- formulas as published (lambda in micrometres) -----------------------------------------------
def devore_rutile(l, axis):
    # J. R. DeVore, JOSA 41, 416 (1951): n^2 = A + B / (lambda^2 - C)
    a, b, c = (5.913, 0.2441, 0.0803) if axis == "o" else (7.197, 0.3322, 0.0843)
    return math.sqrt(a + b / (l * l - c))


def bond_zno(l, axis):
    # Handbook of Optics (3rd ed., vol. 4) fit to Bond (1965): n^2 = A + B l^2/(l^2 - C^2) - D l^2
    a, b, c, d = (2.81418, 0.87968, 0.3042, 0.00711) if axis == "o" else (2.80333, 0.94470, 0.3004, 0.00714)
    return math.sqrt(a + b * l * l / (l * l - c * c) - d * l * l)


def ghosh_calcite(l, axis):
    # G. Ghosh, Opt. Commun. 163, 95 (1999): n^2 = A + B l^2/(l^2 - C) + D l^2/(l^2 - E)
    a, b, c, d, e = ((1.73358749, 0.96464345, 1.94325203e-2, 1.82831454, 120.0) if axis == "o"
                     else (1.35859695, 0.82427830, 1.06689543e-2, 0.14429128, 120.0))
    return math.sqrt(a + b * l * l / (l * l - c) + d * l * l / (l * l - e))


def bhar_hgs(l, axis):
    # G. C. Bhar, Appl. Opt. 15, 305 (1976), same form as Ghosh's
    a, b, c, d, e = ((4.1506, 2.7896, 0.1328, 1.1378, 705.0) if axis == "o"
                     else (4.0101, 4.3736, 0.1284, 1.5604, 705.0))
    return math.sqrt(a + b * l * l / (l * l - c) + d * l * l / (l * l - e))


def sellmeier(l, terms):
    # n^2 - 1 = sum B l^2 / (l^2 - L^2), resonance wavelengths L in um
    return math.sqrt(1.0 + sum(b * l * l / (l * l - c * c) for b, c in terms))


def malitson_silica(l):
    return sellmeier(l, [(0.6961663, 0.0684043), (0.4079426, 0.1162414), (0.8974794, 9.896161)])


def malitson_sapphire_o(l):
    return sellmeier(l, [(1.4313493, 0.0726631), (0.65054713, 0.1193242), (5.3414021, 18.028251)])


def stephens_mgo(l):
    # Stephens and Malitson, J. Res. NBS 49, 249 (1952): n^2 = A + B/(l^2 - C) + D l^2
    return math.sqrt(2.957019 + 0.0216485 / (l * l - 0.0158650) - 0.0101373 * l * l)


def sultanova(b, c):
    # n^2 - 1 = B l^2 / (l^2 - C), C in um^2
    return lambda l: math.sqrt(1.0 + b * l * l / (l * l - c))


# --- tables --------------------------------------------------------------------------------------
def table(name):
    rows = []
    with open(os.path.join(DATA, name), encoding="utf-8") as f:
        inside = False
        for line in f:
            if re.match(r"^\s+data:\s*\|", line):
                inside = True
                continue
            if inside:
                parts = line.split()
                if len(parts) == 3 and all(re.match(r"^[-+0-9.eE]+$", p) for p in parts):
                    rows.append([float(p) for p in parts])
                elif line.strip():
                    inside = False
    kept = []
    for w, n, k in rows:
        if kept and not (w * 1000.0 > kept[-1][0]):
            continue  # documented repair: out-of-order or repeated row dropped
        kept.append([w * 1000.0, n, max(k, 0.0)])  # documented repair: k < 0 set to 0
    a = np.array(kept)
    return a[:, 0], a[:, 1], a[:, 2]


def tabulated(name):
    w, n, k = table(name)

    def f(nm):
        return float(np.interp(nm, w, n)), float(np.interp(nm, w, k))

    return f, (w[0], w[-1])


def formula(fn):
    return lambda nm: (fn(nm / 1000.0), 0.0)


def uniaxial(fo, fe):
    def f(nm):
        no, ko = fo(nm)
        ne, ke = fe(nm)
        return (2.0 * no + ne) / 3.0, (2.0 * ko + ke) / 3.0

    return f


def axis(fn, a):
    return lambda l: fn(l, a)


# id -> (function of nm -> (n, k), data range nm, usable range nm)
MATERIALS = {}


def add(mid, f, data, usable=None):
    MATERIALS[mid] = (f, data, usable or data)


add("tio2-rutile", uniaxial(formula(axis(devore_rutile, "o")), formula(axis(devore_rutile, "e"))),
    (430.0, 1530.0), (380.0, 1530.0))
f, r = tabulated("main_TiO2__Jolivet-anatase.yml")
add("tio2-anatase", f, r)
add("zno", uniaxial(formula(axis(bond_zno, "o")), formula(axis(bond_zno, "e"))), (450.0, 4000.0),
    (380.0, 4000.0))
add("calcite", uniaxial(formula(axis(ghosh_calcite, "o")), formula(axis(ghosh_calcite, "e"))),
    (204.0, 2172.0))
fo, ro = tabulated("main_Fe2O3__Querry-o.yml")
fe, re_ = tabulated("main_Fe2O3__Querry-e.yml")
add("hematite", uniaxial(fo, fe), (max(ro[0], re_[0]), min(ro[1], re_[1])))
f, r = tabulated("main_Fe3O4__Querry.yml")
add("magnetite", f, r)
f, r = tabulated("main_CdS__Treharne.yml")
add("cds", f, r)
add("vermilion", uniaxial(formula(axis(bhar_hgs, "o")), formula(axis(bhar_hgs, "e"))), (620.0, 11000.0))
f, r = tabulated("main_Cu2O__Querry.yml")
add("cu2o", f, r)
add("silica", formula(malitson_silica), (210.0, 6700.0))
add("alumina", formula(malitson_sapphire_o), (200.0, 5000.0))
f, r = tabulated("main_ZnS__Querry.yml")
add("zns", f, r)
add("mgo", formula(stephens_mgo), (404.7, 767.9), (380.0, 780.0))
for mid, name in [("gold", "main_Au__Johnson.yml"), ("silver", "main_Ag__Johnson.yml"),
                  ("copper", "main_Cu__Johnson.yml"), ("carbon", "main_C__Arakawa.yml"),
                  ("soot", "other_soots_acetylene_soot__Dalzell.yml")]:
    f, r = tabulated(name)
    add(mid, f, r)
add("pmma", formula(sultanova(1.1819, 0.011313)), (436.8, 1052.0), (380.0, 1052.0))
add("polystyrene", formula(sultanova(1.4435, 0.020216)), (436.8, 1052.0), (380.0, 1052.0))
add("polycarbonate", formula(sultanova(1.4182, 0.021304)), (436.8, 1052.0), (380.0, 1052.0))
add("air", lambda nm: (1.0, 0.0), (0.0, math.inf))

WAVELENGTHS = [380.0 + 5.0 * i for i in range(81)] + [432.1, 587.56, 632.8, 1000.0]


def inside(nm, r):
    lo, hi = r
    slack = 1e-9 * max(abs(lo), abs(hi)) if math.isfinite(hi) else 0.0
    return lo - slack <= nm <= hi + slack


def main():
    out = os.path.join(HERE, "index_reference.csv")
    with open(out, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["# written by index_reference.py; do not edit"])
        w.writerow(["id", "wavelength_nm", "n", "k", "extrapolated"])
        for mid, (fn, data, usable) in MATERIALS.items():
            for nm in WAVELENGTHS:
                if not inside(nm, usable):
                    w.writerow([mid, repr(nm), "error", "error", "error"])
                    continue
                n, k = fn(nm)
                w.writerow([mid, repr(nm), repr(n), repr(k), int(not inside(nm, data))])
    print("wrote", out)


if __name__ == "__main__":
    main()
