#!/usr/bin/env python3
"""DISORT references for finite layers (films) without an interface, over a black or Lambertian floor.

Runs cdisort 2.1.3 through pydisort (installed with pip if missing) with the set-up of
disort_reference.py (imported: its solve_disort, node_distance; the pitfalls of docs/physics.md
section 6 are handled there) and writes disort_films.json beside this script. Run:
    python3 tests/reference/rte/disort_films.py      (about 70 s of CPU on one core)

Cases: one homogeneous layer of optical depth 0.1, 1, 10; Henyey-Greenstein g = 0.5, 0.9;
omega = 0.9, 1; over a black floor and a Lambertian floor of albedo 0.5 (BRDF 0.5/pi). Outputs:
- BRDF (1/sr) at theta_i in {0, 30, 60, 85}, theta_o in {0, 15, 30, 45, 60, 75, 85},
  phi in {0, 90, 180} (graphics azimuth: DISORT is run at phi + 180);
- per theta_i: hemispherical reflectance ("albedo" = FLUP(0) / mu0), the total transmittance to the
  floor level (down-flux there / mu0, direct + diffuse; over a Lambertian floor it includes the light
  the floor sends back up and the layer returns), its direct part exp(-tau/mu0) (computed, because
  DISORT's RFLDIR is delta-M scaled) and the diffuse rest, and the layer's absorptance, integrated
  from DISORT's flux divergence DFDT over the depth (composite Gauss on a grid graded geometrically
  toward both faces). Energy balance: albedo + absorptance + (1 - floor albedo) transmittance = 1;
  over black, R + T + A = 1. Both are checked here.

Stream counts (no node within 1e-3 relative of a mu0: cdisort moves mu0 within 1e-4 of a node):
- g = 0.5: 84 streams, check 92. Delta-M truncates f = 0.5^84: nothing; the streams are for the thin
  layer (tau = 0.1, omega = 1 the hardest), where DISORT's Gauss nodes in mu converge slowly and not
  monotonically. Largest relative BRDF difference from the adding reference (adding_reference.py,
  converged to 1e-12 there) over the 12 g = 0.5 films, by stream count: 52: 4.7e-7, 68: 6.9e-8,
  76: 3.5e-8, 84: 1.6e-8, 92: 1.8e-8, 100: 1.4e-7, 108: 1.7e-8, 116: 1.5e-7, 124: 1.5e-8.
  64 streams would put a node within 8e-5 of cos 30 deg.
- g = 0.9: 144 streams, check 128 (f = 0.9^144 = 2.6e-7 and 1.4e-6; the Nakajima-Tanaka TMS
  correction removes most of the truncation error from the reflected radiance). Measured while
  choosing: 144 streams differs from 224 by at most 1.3e-8 (tau = 1, omega 0.9, black), 128 from
  224 by 1.7e-7; DISORT's own noise at this level is not monotone in NSTR (176 streams differ
  from 224 by 2.2e-7), so more streams buy nothing at 1e-7. Run time grows like NSTR^4: 144 streams
  take about 4 s per case, 224 about 30 s.
"max_rel_change" is the largest relative BRDF difference between the two stream counts, and
"flux_max_abs_change" the largest absolute change of albedo and transmittance.

omega = 1: cdisort replaces a single-scattering albedo of exactly 1 by 1 - 100 DBL_EPSILON
(= 1 - 2.2e-14, disort.h) before solving. Its direct effect, an absorptance of about 2.2e-14 x the
path length, is below 1e-12 even at tau = 10. What it costs is accuracy near the critical case:
the energy-balance residual is 1e-9 at omega = 1 against 3e-12 at omega = 0.9, and the BRDF is
off from the exact adding solution at omega = 1 by 1.6e-8 (g 0.5) and 8.3e-8 (g 0.9, tau 1),
against 2.6e-9 and 1.9e-8 at omega = 0.9 (tests/reference/README.md).
"""
import datetime
import json
import math
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from disort_reference import node_distance, solve_disort, pydisort  # noqa: E402 (installs pydisort if missing)

import numpy as np  # noqa: E402

THETA_I = [0.0, 30.0, 60.0, 85.0]
THETA_O = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0]
PHIS = [0.0, 90.0, 180.0]
DEPTHS = [0.1, 1.0, 10.0]
FLOORS = [0.0, 0.5]
OMEGAS = [0.9, 1.0]
# g: (nstr, nstr_check)
STREAMS = {0.5: (84, 92), 0.9: (144, 128)}
HG_DROP = 1e-15


def cosine(theta_deg):
    return 1.0 if theta_deg == 0.0 else math.cos(math.radians(theta_deg))


def hg_pmom(g):
    """DISORT phase moments PMOM_l = beta_l / (2l + 1) = g^l, l >= 1, until (2l+1) g^l < HG_DROP."""
    out = []
    l = 1
    while (2 * l + 1) * g**l >= HG_DROP:
        out.append(g**l)
        l += 1
    return out


def depth_grid(tau, per_piece=20, decades=8):
    """Gauss nodes and weights on [0, tau], graded toward both faces (boundary layers of grazing light)."""
    half = 0.5 * tau
    breaks = [0.0] + [half * 10.0 ** (-k) for k in range(decades - 1, -1, -1)]
    x, w = np.polynomial.legendre.leggauss(per_piece)
    nodes, weights = [], []
    for a, b in zip(breaks[:-1], breaks[1:]):
        nodes.append(a + (b - a) * 0.5 * (x + 1.0))
        weights.append((b - a) * 0.5 * w)
    top = np.concatenate(nodes)
    wt = np.concatenate(weights)
    return np.concatenate([top, tau - top[::-1]]), np.concatenate([wt, wt[::-1]])


def run_case(g, omega, tau, floor, nstr):
    mu0s = [cosine(a) for a in THETA_I]
    order = sorted(range(len(THETA_O)), key=lambda i: cosine(THETA_O[i]))  # DISORT wants ascending umu
    mus = [cosine(THETA_O[i]) for i in order]
    rad, flux, seconds = solve_disort(nstr, omega, hg_pmom(g), mu0s, mus, PHIS, tau=tau, floor_albedo=floor,
                                      user_taus=(0.0, tau))
    brdf = np.empty((len(THETA_I), len(THETA_O), len(PHIS)))
    for jo in range(len(THETA_O)):
        brdf[:, jo, :] = rad[:, :, 0, order.index(jo)]
    mu0 = np.array(mu0s)
    albedo = flux[:, 0, 2] / mu0
    transmittance = (flux[:, 1, 0] + flux[:, 1, 1]) / mu0
    return brdf, albedo, transmittance, seconds


def absorptance(g, omega, tau, floor, nstr):
    """int_0^tau DFDT dtau / mu0: the power the layer absorbs per unit incident power.

    cdisort's DFDT is d(net flux)/d(tau) with the net flux counted upward (down-flux minus up-flux
    decreases with depth by the absorption), so the absorbed power is its integral with a plus sign.
    """
    mu0s = [cosine(a) for a in THETA_I]
    taus, weights = depth_grid(tau)
    _, flux, _ = solve_disort(nstr, omega, hg_pmom(g), mu0s, [], PHIS, tau=tau, floor_albedo=floor,
                              user_taus=tuple(taus), only_fluxes=True)
    return (flux[:, :, 3] @ weights) / np.array(mu0s)


def main():
    t_start = time.perf_counter()
    mu0s = [cosine(a) for a in THETA_I]
    cases = []
    worst = {"brdf": 0.0, "flux": 0.0, "balance": 0.0, "balance_omega1": 0.0}
    for g, (nstr, nstr_check) in STREAMS.items():
        for n in (nstr, nstr_check):
            assert node_distance(n, mu0s) > 1e-3, (g, n)
        for omega in OMEGAS:
            for tau in DEPTHS:
                for floor in FLOORS:
                    brdf, alb, trans, seconds = run_case(g, omega, tau, floor, nstr)
                    brdf_c, alb_c, trans_c, _ = run_case(g, omega, tau, floor, nstr_check)
                    absorbed = absorptance(g, omega, tau, floor, nstr)
                    change = float(np.max(np.abs(brdf_c / brdf - 1.0)))
                    flux_change = float(max(np.max(np.abs(alb_c - alb)), np.max(np.abs(trans_c - trans))))
                    balance = alb + absorbed + (1.0 - floor) * trans - 1.0
                    worst["brdf"] = max(worst["brdf"], change)
                    worst["flux"] = max(worst["flux"], flux_change)
                    key = "balance_omega1" if omega == 1.0 else "balance"
                    worst[key] = max(worst[key], float(np.max(np.abs(balance))))
                    direct = np.exp(-tau / np.array(mu0s))
                    values = [[ti, to, ph, float(brdf[ii, jo, kp])]
                              for ii, ti in enumerate(THETA_I) for jo, to in enumerate(THETA_O)
                              for kp, ph in enumerate(PHIS)]
                    per_incidence = [{"theta_i": ti, "albedo": float(alb[ii]), "transmittance": float(trans[ii]),
                                      "direct_transmittance": float(direct[ii]),
                                      "diffuse_transmittance": float(trans[ii] - direct[ii]),
                                      "absorptance": float(absorbed[ii])}
                                     for ii, ti in enumerate(THETA_I)]
                    label = f"hg{g}-omega{omega:g}-tau{tau:g}-floor{floor:g}"
                    print(f"{label:32s} nstr {nstr} vs {nstr_check}: BRDF change {change:.1e}, "
                          f"flux change {flux_change:.1e}, energy balance {np.max(np.abs(balance)):.1e}"
                          f"  ({seconds:.1f} s)", flush=True)
                    cases.append({
                        "label": label,
                        "phase": {"type": "henyey_greenstein", "g": g},
                        "omega": omega,
                        "omega_solved": 1.0 - 100 * np.finfo(float).eps if omega == 1.0 else omega,
                        "optical_depth": tau,
                        "floor_albedo": floor,
                        "interface": "none (index 1 everywhere)",
                        "nstr": nstr, "nstr_check": nstr_check,
                        "delta_m_f": g**nstr,
                        "max_rel_change": change, "flux_max_abs_change": flux_change,
                        "energy_balance_residual": float(np.max(np.abs(balance))),
                        "seconds": round(seconds, 3),
                        "values": values,
                        "per_incidence": per_incidence,
                    })
    doc = {
        "source": "tests/reference/rte/disort_films.py: cdisort 2.1.3 via pydisort "
                  + getattr(pydisort, "__version__", "?"),
        "generated": datetime.date.today().isoformat(),
        "units": "BRDF in 1/sr; angles in degrees; phi in the graphics convention of docs/design.md "
                 "(0 = the light's side, 180 = the mirror side); fluxes per unit incident flux (mu0 FBEAM)",
        "medium": "one homogeneous layer, refractive index 1 (no interface), over a Lambertian floor "
                  "(albedo 0 = black; BRDF albedo/pi)",
        "values_layout": "[theta_i, theta_o, phi, brdf]",
        "per_incidence_note": "albedo = FLUP(0)/mu0; transmittance = total down-flux at the floor level / mu0 "
                              "(direct + diffuse; over a Lambertian floor it includes interreflection with the floor); "
                              "direct_transmittance = exp(-tau/mu0); absorptance = layer absorption from "
                              "int DFDT dtau / mu0; albedo + absorptance + (1 - floor_albedo) transmittance = 1",
        "omega_note": "omega = 1 is solved by cdisort at 1 - 100 DBL_EPSILON (omega_solved)",
        "convergence_note": "max_rel_change: largest relative BRDF difference nstr vs nstr_check; "
                            "flux_max_abs_change: same for albedo and transmittance (absolute)",
        "cases": cases,
    }
    path = os.path.join(HERE, "disort_films.json")
    with open(path, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print(f"largest BRDF change between stream counts {worst['brdf']:.1e}, flux change {worst['flux']:.1e}")
    print(f"energy balance residual: omega 0.9 {worst['balance']:.1e}, omega 1 (dithered) {worst['balance_omega1']:.1e}")
    print(f"wrote {path} ({time.perf_counter() - t_start:.0f} s)")


if __name__ == "__main__":
    main()
