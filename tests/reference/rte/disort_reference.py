#!/usr/bin/env python3
"""Independent DISORT references for the reflection of a semi-infinite medium.

Runs cdisort 2.1.3 through pydisort (pip install pydisort) and writes disort_hg_rayleigh.json beside
this script: BRDF values (1/sr) of a bare semi-infinite medium (no interface) for Henyey-Greenstein
phase functions g in {-0.5, 0.5, 0.9, 0.99} and Rayleigh, single-scattering albedo
omega in {0.5, 0.9, 0.999999}, at theta_i, theta_o in {0, 30, 60, 80} degrees and
phi in {0, 90, 180} degrees. Run: python3 disort_reference.py  (about a minute). Its set-up
(solve_disort, node_distance) is shared by disort_films.py and bench/speed_vs_error.py.

Settings (docs/physics.md section 6):
- omega = 1 is not used: DISORT replaces an albedo of exactly 1 by 1 - dither and is ill-conditioned
  near it, so the "conservative" case is omega = 0.999999 here, and the C++ test solves at that same
  albedo (not at 1).
- Semi-infinite: one layer of optical thickness 1e10 over a black Lambertian floor.
- BRDF = I / (mu0 FBEAM) (R = pi I / (mu0 FBEAM), BRDF = R / pi), FBEAM = 1.
- Azimuth: DISORT's phi = 0 is the forward side; the graphics azimuth of docs/design.md is
  phi_g = phi_DISORT - 180 degrees, so DISORT is run at phi_g + 180.
- Phase moments PMOM_l = beta_l / (2l + 1): g^l for Henyey-Greenstein, (0, 0.1) for Rayleigh.
- Azimuth-series tolerance ACCUR = 0 (pydisort's default 1e-6 stops the Fourier sum early).
- Intensity correction on, the original Nakajima-Tanaka routine (phase moments; the new one needs an
  explicit phase-function table that pydisort does not pass). For reflected radiance it is the TMS
  correction only (the IMS part applies to the downward aureole).
- Stream counts avoid mu0 within 2e-3 (relative) of a Gauss node: cdisort silently moves mu0 by
  1e-4 relative when it lands within 1e-4 of one.
- Convergence: each case is also run at a second stream count ("nstr_check": about half for the smooth phase functions, 120 for g = 0.9, or for
  g = 0.99 the largest affordable one) and "max_rel_change" records the largest relative difference;
  "converged" is true when it is below 1e-6.

g = 0.99 cannot be converged here: DISORT always applies delta-M (the truncated fraction is
f = g^NSTR = 0.28 at NSTR = 128) and its delta-M error falls only like f, while the run time grows
like NSTR^4 (about 4 s at 128 streams, minutes at 256). Its values are stored at NSTR = 128 with
f and converged = false; the C++ test compares them with our solver at the same truncation
(64 streams per hemisphere, L = 128) instead of as converged values.
"""
import datetime
import json
import os
import time

try:
    import numpy as np
    import torch
    import pydisort
except ImportError:  # test-only dependency: pydisort (brings torch and numpy)
    import subprocess
    import sys
    subprocess.check_call([sys.executable, "-m", "pip", "install", "--quiet", "pydisort"])
    import numpy as np
    import torch
    import pydisort
from pydisort import Disort, DisortOptions

ANGLES_DEG = [0.0, 30.0, 60.0, 80.0]
PHIS_DEG = [0.0, 90.0, 180.0]
OMEGAS = [0.5, 0.9, 0.999999]
TAU = 1e10

# (label, type, g, nstr, nstr_check, number of moments)
CASES = [
    ("rayleigh", "rayleigh", 0.0, 60, 28, 2),
    ("hg-0.5", "henyey_greenstein", -0.5, 60, 28, 200),
    ("hg0.5", "henyey_greenstein", 0.5, 60, 28, 200),
    ("hg0.9", "henyey_greenstein", 0.9, 144, 120, 600),
    ("hg0.99", "henyey_greenstein", 0.99, 128, 144, 4000),
]


def moments(kind, g, count):
    if kind == "rayleigh":
        return [0.0, 0.1]
    return [g**l for l in range(1, count + 1)]


def node_distance(nstr, mu0s):
    x, _ = np.polynomial.legendre.leggauss(nstr // 2)
    nodes = 0.5 * (x + 1.0)
    return min(float(np.min(np.abs(m - nodes)) / m) for m in mu0s if m < 1.0)


def run_disort(nstr, omega, pmom, mu0s, mus, phis_g):
    """BRDF[col = mu0 index][phi index][mu index] for ascending mus."""
    rad, _, seconds = solve_disort(nstr, omega, pmom, mu0s, mus, phis_g)
    return rad[:, :, 0, :], seconds


def solve_disort(nstr, omega, pmom, mu0s, mus, phis_g, tau=TAU, floor_albedo=0.0, user_taus=(0.0,),
                 only_fluxes=False):
    """One homogeneous layer over a Lambertian floor, a unit beam (FBEAM = 1) from each mu0.

    Returns (radiance / mu0 [col][phi][user tau][mu], fluxes [col][user tau][8], seconds); the flux
    columns are cdisort's RFLDIR, RFLDN, FLUP, DFDT, UAVG, UAVGDN, UAVGUP, UAVGSO (RFLDIR and RFLDN
    are delta-M scaled; their sum is not).
    """
    nmom = max(len(pmom), nstr)
    flags = "usrtau,lamber,quiet" + (",onlyfl" if only_fluxes else
                                     ",usrang,intensity_correction,old_intensity_correction")
    op = DisortOptions().flags(flags)
    op.ds().nlyr = 1
    op.ds().nstr = nstr
    op.ds().nmom = nmom
    op.ds().nphase = nstr
    op.accur(0.0)
    op.user_tau(np.array(user_taus, dtype=float))
    if not only_fluxes:
        op.user_mu(np.array(mus))
        op.user_phi(np.array([p + 180.0 for p in phis_g]))
    op.nwave(1)
    op.ncol(len(mu0s))
    t0 = time.perf_counter()  # set-up and solve: what a user of DISORT waits for
    ds = Disort(op)
    prop = torch.zeros((1, len(mu0s), 1, 2 + nmom), dtype=torch.float64)
    prop[..., 0] = tau
    prop[..., 1] = omega
    pm = np.zeros(nmom)
    pm[: len(pmom)] = pmom
    prop[..., 2:] = torch.tensor(pm, dtype=torch.float64)
    ncol = len(mu0s)
    zeros = torch.zeros((1, ncol), dtype=torch.float64)
    bc = {"umu0": torch.tensor(mu0s, dtype=torch.float64), "phi0": torch.zeros(ncol, dtype=torch.float64),
          "fbeam": torch.ones((1, ncol), dtype=torch.float64),
          "albedo": torch.full((1, ncol), float(floor_albedo), dtype=torch.float64), "fluor": zeros,
          "fisot": zeros}
    ds.forward(prop, **bc)
    flux = ds.gather_flx().numpy()[0]  # (ncol, ntau, 8)
    rad = None if only_fluxes else ds.gather_rad().numpy()[0] / np.array(mu0s)[:, None, None, None]
    seconds = time.perf_counter() - t0
    return rad, flux, seconds


def main():
    mu_of = {a: (1.0 if a == 0.0 else float(np.cos(np.radians(a)))) for a in ANGLES_DEG}
    mu0s = [mu_of[a] for a in ANGLES_DEG]
    order = sorted(range(len(ANGLES_DEG)), key=lambda i: mu0s[i])  # DISORT wants ascending umu
    mus = [mu0s[i] for i in order]
    out_cases = []
    for label, kind, g, nstr, nstr_check, nmom in CASES:
        for n in (nstr, nstr_check):
            assert node_distance(n, mu0s) > 2e-3, (label, n)
        pmom = moments(kind, g, nmom)
        for omega in OMEGAS:
            ref, seconds = run_disort(nstr, omega, pmom, mu0s, mus, PHIS_DEG)
            chk, _ = run_disort(nstr_check, omega, pmom, mu0s, mus, PHIS_DEG)
            change = float(np.max(np.abs(chk / ref - 1.0)))
            values = []
            for ii, ti in enumerate(ANGLES_DEG):
                for jo, to in enumerate(ANGLES_DEG):
                    col = order.index(jo)
                    for kp, ph in enumerate(PHIS_DEG):
                        values.append([ti, to, ph, float(ref[ii, kp, col])])
            case = {"label": label, "phase": kind, "g": g, "omega": omega, "nstr": nstr,
                    "nstr_check": nstr_check, "max_rel_change": change, "converged": change < 1e-6,
                    "seconds": round(seconds, 3), "values": values}
            if kind == "henyey_greenstein":
                case["delta_m_f"] = g**nstr
            print(f"{label:9s} omega {omega:<9g} nstr {nstr:4d} vs {nstr_check:4d}: max rel change {change:.2e}"
                  f"  ({seconds:.2f} s)")
            out_cases.append(case)
    doc = {
        "source": "tests/reference/rte/disort_reference.py: cdisort 2.1.3 via pydisort "
                  + getattr(pydisort, "__version__", "?"),
        "generated": datetime.date.today().isoformat(),
        "units": "BRDF in 1/sr; angles in degrees; phi in the graphics convention of docs/design.md "
                 "(0 = the light's side, 180 = the mirror side)",
        "medium": "semi-infinite (tau = 1e10 over a black floor), no interface",
        "omega_note": "omega = 1 is represented by 0.999999 (DISORT dithers unit albedo); compare at 0.999999",
        "tms_note": "DISORT's TMS adds omega p / ((1 - f omega) 4 pi (mu + mu0)) with the full phase function",
        "values_layout": "[theta_i, theta_o, phi, brdf]",
        "cases": out_cases,
    }
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "disort_hg_rayleigh.json")
    with open(path, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print("wrote", path)


if __name__ == "__main__":
    main()
