#!/usr/bin/env python3
"""Reference size-distribution averages for tests/mie/ensemble_test.cpp, independent of the C++ code.

Run from the repository root (a few seconds):
    python3 tests/reference/mie/ensemble_reference.py > tests/reference/mie/ensemble_reference.json

Mie efficiencies from miepython 3.3.0 (S. Prahl; it takes |Im m| whatever the sign). The size
distributions are written out here from Hansen and Travis (1974) as the C++ code states them:
  power law  n ~ r^-3 on [r1, r2], r_eff = (r2 - r1) / ln(r2 / r1), r1 + r2 = 2 r_eff (1 + v_eff)
             (r1 by scipy.optimize.brentq);
  gamma      n ~ r^((1-3b)/b) exp(-r / (a b)), a = r_eff, b = v_eff;
  lognormal  n ~ (1/r) exp(-(ln r - ln r_g)^2 / (2 ln^2 sigma_g)).
Each is normalised over (0, inf) (the power law over its support), so the averages are per particle:
<C> = int n(r) pi r^2 Q(x) dr, x = 2 pi r n_h / lambda. The integral runs over [1e-4 r_eff, 20 r_eff]
(gamma, lognormal: the neglected tails are below 1e-12 of <Csca> for these parameters) with 2000
panels of 16-point Gauss-Legendre, uniform in ln r: the particles absorb (k = 0.05), so there are no
sharp resonances and this converges to ~1e-12 (checked by halving the panels).
g = <Csca g> / <Csca>, albedo = <Csca> / <Cext>.
"""

import json
import math
import sys

import miepython
import numpy as np
from scipy.optimize import brentq
from scipy.special import gammaln

PARTICLE = complex(2.0, 0.05)
MEDIUM = 1.5
WAVELENGTH_NM = 550.0


def power_law(r_eff, v_eff):
    s = 2.0 * r_eff * (1.0 + v_eff)
    r1 = brentq(lambda r: (s - 2 * r) / math.log1p((s - 2 * r) / r) - r_eff, 1e-12 * s, 0.5 * s * (1 - 1e-12), xtol=1e-16, rtol=1e-15)
    r2 = s - r1
    c = 2.0 * r1 * r1 * r2 * r2 / ((r2 - r1) * (r2 + r1))
    return (lambda r: np.where((r >= r1) & (r <= r2), c / r**3, 0.0)), r1, r2


def gamma(r_eff, v_eff):
    b = v_eff
    alpha = (1 - 3 * b) / b
    scale = r_eff * b
    log_c = -gammaln(alpha + 1) - (alpha + 1) * math.log(scale)
    return (lambda r: np.exp(log_c + alpha * np.log(r) - r / scale)), 1e-4 * r_eff, 20 * r_eff


def lognormal(r_g, sigma_g):
    s = math.log(sigma_g)
    r_eff = r_g * math.exp(2.5 * s * s)
    return (lambda r: np.exp(-0.5 * ((np.log(r) - math.log(r_g)) / s) ** 2) / (math.sqrt(2 * math.pi) * s * r)), \
        1e-4 * r_eff, 20 * r_eff


def average(density, a, b, panels=2000):
    t, w = np.polynomial.legendre.leggauss(16)
    edges = np.exp(np.linspace(math.log(a), math.log(b), panels + 1))
    lo, hi = edges[:-1, None], edges[1:, None]
    r = (0.5 * (lo + hi) + 0.5 * (hi - lo) * t[None, :]).ravel()
    wr = (0.5 * (hi - lo) * w[None, :]).ravel()
    k = 2 * math.pi * MEDIUM / (WAVELENGTH_NM * 1e-3)
    x = k * r
    qext, qsca, qback, g = miepython.efficiencies_mx(PARTICLE / MEDIUM, x)
    weight = wr * density(r) * math.pi * r * r
    cext = float(np.sum(weight * qext))
    csca = float(np.sum(weight * qsca))
    gsca = float(np.sum(weight * qsca * g))
    return {"cext_um2": cext, "csca_um2": csca, "cabs_um2": cext - csca, "g": gsca / csca,
            "albedo": csca / cext}


def main():
    cases = []
    for name, (density, a, b), params in [
        ("power_law", power_law(0.4, 0.3), [0.4, 0.3]),
        ("gamma", gamma(0.5, 0.1), [0.5, 0.1]),
        ("lognormal", lognormal(0.2, 1.6), [0.2, 1.6]),
    ]:
        case = {"distribution": name, "parameters": params}
        case.update(average(density, a, b))
        coarse = average(density, a, b, panels=1000)
        case["convergence"] = max(abs(coarse[q] / case[q] - 1) for q in ("cext_um2", "csca_um2"))
        cases.append(case)
    json.dump({"generator": "tests/reference/mie/ensemble_reference.py",
               "miepython": miepython.__version__,
               "particle_index": [PARTICLE.real, PARTICLE.imag], "medium_index": MEDIUM,
               "wavelength_nm": WAVELENGTH_NM, "cases": cases}, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
