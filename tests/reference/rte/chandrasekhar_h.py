#!/usr/bin/env python3
"""Reference values of Chandrasekhar's H-function for isotropic scattering.

ln H(mu) = -(mu/pi) int_0^inf ln(1 - omega arctan(x)/x) dx / (1 + mu^2 x^2)
(Chandrasekhar 1960, Radiative Transfer, eq. V.(39); docs/physics.md section 3), evaluated with mpmath at
30 digits. The exact reflection function is then R = (omega/4) H(mu) H(mu0) / (mu + mu0).
Writes chandrasekhar_h.json beside this script. Run: python3 chandrasekhar_h.py
"""
import json
import os

import mpmath as mp

mp.mp.dps = 30


def h_function(mu, omega):
    mu = mp.mpf(mu)
    omega = mp.mpf(omega)
    if mu == 0:
        return mp.mpf(1)

    def integrand(x):
        if x < mp.mpf("1e-4"):
            # 1 - arctan(x)/x = x^2/3 - x^4/5 + x^6/7 - ...: avoids cancellation (log of 0 at omega = 1).
            one_minus = x**2 / 3 - x**4 / 5 + x**6 / 7
            arg = (1 - omega) + omega * one_minus
        else:
            arg = 1 - omega * mp.atan(x) / x
        return mp.log(arg) / (1 + mu * mu * x * x)

    # Break points where the integrand changes scale: the singularity at 0 for omega = 1 and the
    # Lorentzian width 1/mu.
    pts = [0, mp.mpf(1) / 1000, mp.mpf(1) / 10, 1, 1 / mu, 10 / mu, 100 / mu, mp.inf]
    pts = sorted(set(pts))
    val = mp.quad(integrand, pts, maxdegree=10)
    return mp.exp(-mu / mp.pi * val)


def main():
    omegas = ["0.5", "0.9", "0.99", "0.999999", "1"]
    angles_deg = [0, 30, 60, 75, 85, 89, 89.9]
    mus = sorted({float(mp.cos(mp.radians(a))) for a in angles_deg} | {0.5, 0.1, 1.0})
    out = {"source": "tests/reference/rte/chandrasekhar_h.py (mpmath, 30 digits)", "cases": []}
    for om in omegas:
        out["cases"].append({"omega": float(om), "mu": mus,
                             "h": [float(h_function(m, om)) for m in mus]})
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "chandrasekhar_h.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    # Published check values at omega = 1 (docs/physics.md): H(1) = 2.9078105291, H(0.5) = 2.0127787700.
    print("H(1), H(0.5), H(0.1) at omega 1:", [float(h_function(m, 1)) for m in (1, 0.5, 0.1)])


if __name__ == "__main__":
    main()
