#!/usr/bin/env python3
"""Reference values for tests/mie/mie_test.cpp, independent of the C++ code.

Run from the repository root (takes a few minutes, mostly the complex Bessel functions at x = 1000):
    python3 tests/reference/mie/mie_reference.py > tests/reference/mie/mie_reference.json
and, for the size-distribution averages of large spheres (matting agents; about 15 minutes, see
the comment above matting_main):
    python3 tests/reference/mie/mie_reference.py matting > tests/reference/mie/matting_reference.json
miepython (and numpy) are installed with pip when missing.

Sources:
  "mpmath"    The Mie series written directly from Bohren and Huffman (1983) eq. 4.53,
              a_n = (m psi_n(mx) psi_n'(x) - psi_n(x) psi_n'(mx)) / (m psi_n(mx) xi_n'(x) - xi_n(x) psi_n'(mx)),
              b_n = (psi_n(mx) psi_n'(x) - m psi_n(x) psi_n'(mx)) / (psi_n(mx) xi_n'(x) - m xi_n(x) psi_n'(mx)),
              with psi_n(z) = sqrt(pi z / 2) J_{n+1/2}(z), xi_n(x) = sqrt(pi x / 2) (J + iY)_{n+1/2}(x) and
              f_n' = f_{n-1} - n f_n / z, all evaluated by mpmath's Bessel functions at 40 significant
              digits (no recurrences, no logarithmic derivatives), summed to N + 40 terms (N = Wiscombe's
              x + 4.05 x^(1/3) + 2). Efficiencies from B&H 4.61, 4.62 and pp. 120-122; Qabs = Qext - Qsca
              is safe at 40 digits. Convention m = n + ik, k >= 0 (B&H).
  "miepython" miepython 3.3.0 (S. Prahl), an independent double-precision implementation, for x = 1e4
              where 40-digit Bessel functions would take hours. miepython takes |Im m| whatever its sign.
Legendre moments beta_l (beta_0 = 1, beta_1 = 3g) for some cases: S1, S2 (B&H 4.74) from the mpmath
coefficients on a (2N' + 2)-point Gauss-Legendre rule (N' = N + 40 terms), computed at 40 digits, which
is exact for the degree-4N' integrand; truncated after the last |beta_l| > 1e-12.
"""

import importlib
import json
import subprocess
import sys


def ensure(module, requirement):
    """Imports `module`, installing `requirement` with pip first when it is missing."""
    try:
        return importlib.import_module(module)
    except ImportError:
        subprocess.check_call([sys.executable, "-m", "pip", "install", "--quiet", requirement],
                              stdout=sys.stderr)
        return importlib.import_module(module)


mp = ensure("mpmath", "mpmath")

mp.mp.dps = 40


def wiscombe_terms(x):
    return int(x + 4.05 * x ** (1.0 / 3.0) + 2.0)


def riccati_psi(n, z):
    return mp.sqrt(mp.pi * z / 2) * mp.besselj(n + mp.mpf(1) / 2, z)


def riccati_xi(n, x):
    h = mp.besselj(n + mp.mpf(1) / 2, x) + 1j * mp.bessely(n + mp.mpf(1) / 2, x)
    return mp.sqrt(mp.pi * x / 2) * h


def coefficients(m, x, n_terms):
    m = mp.mpc(m)
    x = mp.mpf(x)
    mx = m * x
    a, b = [], []
    psi_x_prev = riccati_psi(0, x)
    xi_x_prev = riccati_xi(0, x)
    psi_mx_prev = riccati_psi(0, mx)
    for n in range(1, n_terms + 1):
        psi_x = riccati_psi(n, x)
        xi_x = riccati_xi(n, x)
        psi_mx = riccati_psi(n, mx)
        dpsi_x = psi_x_prev - n * psi_x / x
        dxi_x = xi_x_prev - n * xi_x / x
        dpsi_mx = psi_mx_prev - n * psi_mx / mx
        a.append((m * psi_mx * dpsi_x - psi_x * dpsi_mx) / (m * psi_mx * dxi_x - xi_x * dpsi_mx))
        b.append((psi_mx * dpsi_x - m * psi_x * dpsi_mx) / (psi_mx * dxi_x - m * xi_x * dpsi_mx))
        psi_x_prev, xi_x_prev, psi_mx_prev = psi_x, xi_x, psi_mx
    return a, b


def efficiencies(a, b, x):
    x = mp.mpf(x)
    n_terms = len(a)
    ext = sca = asym = mp.mpf(0)
    back = mp.mpc(0)
    for i in range(n_terms):
        n = i + 1
        f = 2 * n + 1
        ext += f * (a[i] + b[i]).real
        sca += f * (abs(a[i]) ** 2 + abs(b[i]) ** 2)
        back += f * (-1) ** n * (a[i] - b[i])
        asym += mp.mpf(f) / (n * (n + 1)) * (a[i] * mp.conj(b[i])).real
        if i + 1 < n_terms:
            asym += mp.mpf(n * (n + 2)) / (n + 1) * (a[i] * mp.conj(a[i + 1]) + b[i] * mp.conj(b[i + 1])).real
    qext = 2 * ext / x**2
    qsca = 2 * sca / x**2
    return {
        "qext": float(qext),
        "qsca": float(qsca),
        "qabs": float(qext - qsca),
        "qback": float(abs(back) ** 2 / x**2),
        "g": float(2 * asym / sca),
    }


def amplitudes(a, b, mu):
    """S1, S2 (B&H 4.74) with pi_n, tau_n from B&H 4.47, in mpmath."""
    mu = mp.mpf(mu)
    s1 = s2 = mp.mpc(0)
    pi_prev, pi = mp.mpf(0), mp.mpf(1)
    for i in range(len(a)):
        n = i + 1
        if n > 1:
            pi_prev, pi = pi, ((2 * n - 1) * mu * pi - n * pi_prev) / (n - 1)
        tau = n * mu * pi - (n + 1) * pi_prev
        f = mp.mpf(2 * n + 1) / (n * (n + 1))
        s1 += f * (a[i] * pi + b[i] * tau)
        s2 += f * (a[i] * tau + b[i] * pi)
    return s1, s2


def gauss_legendre(n):
    """n-point Gauss-Legendre nodes and weights at mpmath precision (Newton on P_n from the
    Tricomi initial guess; weights 2 / ((1 - x^2) P_n'(x)^2))."""
    nodes, weights = [], []
    for k in range(n):
        x = mp.cos(mp.pi * (k + mp.mpf(3) / 4) / (n + mp.mpf(1) / 2))
        for _ in range(100):
            p0, p1 = mp.mpf(1), x
            for l in range(2, n + 1):
                p0, p1 = p1, ((2 * l - 1) * x * p1 - (l - 1) * p0) / l
            dp = n * (x * p1 - p0) / (x * x - 1)
            dx = p1 / dp
            x -= dx
            if abs(dx) < mp.mpf(10) ** (-mp.mp.dps + 5):
                break
        p0, p1 = mp.mpf(1), x
        for l in range(2, n + 1):
            p0, p1 = p1, ((2 * l - 1) * x * p1 - (l - 1) * p0) / l
        dp = n * (x * p1 - p0) / (x * x - 1)
        nodes.append(x)
        weights.append(2 / ((1 - x * x) * dp * dp))
    return nodes, weights


def legendre_moments(a, b, tolerance=1e-12):
    """beta_l = (2l+1)/2 int p P_l dmu with p = 2 I / int I, I = |S1|^2 + |S2|^2, by a Gauss rule
    exact for the degree-4N integrand, all in mpmath; cut after the last |beta_l| > tolerance."""
    n_terms = len(a)
    nodes, weights = gauss_legendre(2 * n_terms + 2)
    intensity = []
    for mu in nodes:
        s1, s2 = amplitudes(a, b, mu)
        intensity.append(abs(s1) ** 2 + abs(s2) ** 2)
    total = mp.fsum(w * i for w, i in zip(weights, intensity))
    beta = []
    p_prev = [mp.mpf(0)] * len(nodes)
    p = [mp.mpf(1)] * len(nodes)
    for l in range(2 * n_terms + 1):
        if l > 0:
            p_prev, p = p, [((2 * l - 1) * mu * pl - (l - 1) * pp) / l for mu, pl, pp in zip(nodes, p, p_prev)]
        beta.append((2 * l + 1) * mp.fsum(w * i * pl for w, i, pl in zip(weights, intensity, p)) / total)
    keep = len(beta)
    while keep > 1 and abs(beta[keep - 1]) <= tolerance:
        keep -= 1
    return [float(v) for v in beta[:keep]]


# (Re m, Im m, x, with Legendre moments)
MPMATH_CASES = [
    # Rayleigh regime and the smallest sizes
    (1.5, 0.0, 1e-6, False), (1.5, 0.0, 1e-3, True), (1.5, 0.1, 1e-3, False), (1.5, 1e-8, 1e-3, False),
    (0.2, 3.4, 1e-3, False), (10.0, 10.0, 1e-3, False),
    # Wiscombe's MIEV0 test cases (m in his sign convention m = n - ik; ours is the conjugate)
    (0.75, 0.0, 0.099, False), (0.75, 0.0, 0.101, False), (0.75, 0.0, 10.0, True), (0.75, 0.0, 1000.0, False),
    (1.33, 1e-5, 1.0, False), (1.33, 1e-5, 100.0, False),
    (1.5, 1.0, 0.055, False), (1.5, 1.0, 0.056, False), (1.5, 1.0, 1.0, False), (1.5, 1.0, 100.0, False),
    (10.0, 10.0, 1.0, False), (10.0, 10.0, 100.0, False),
    (1.5, 0.0, 10.0, True), (1.5, 0.0, 100.0, False), (1.5, 0.0, 1000.0, False),
    (1.5, 0.1, 10.0, True), (1.5, 0.1, 100.0, False), (1.5, 0.1, 1000.0, False),
    # metal-like (k > 3), an air void in a binder (m < 1), a rutile pigment in a binder
    (0.2, 3.4, 0.5, False), (0.2, 3.4, 5.0, True), (0.2, 3.4, 50.0, False),
    (1.0 / 1.5, 0.0, 5.0, True), (1.0 / 1.5, 0.0, 50.0, False),
    (2.2, 0.0, 20.0, True), (2.2, 0.01, 20.0, False),
]
MIEPYTHON_CASES = [(1.5, 0.0), (1.5, 0.1), (0.75, 0.0), (1.33, 1e-5), (1.5, 1.0), (10.0, 10.0)]
ANGLES = [1.0, 0.5, 0.0, -0.5, -1.0]


def main():
    cases = []
    for re_m, im_m, x, with_legendre in MPMATH_CASES:
        n_terms = wiscombe_terms(x) + 40
        a, b = coefficients(mp.mpc(re_m, im_m), x, n_terms)
        case = {"m": [re_m, im_m], "x": x, "source": "mpmath", "terms": n_terms}
        case.update(efficiencies(a, b, x))
        s = [amplitudes(a, b, mu) for mu in ANGLES]
        case["amplitudes"] = [[mu, float(s1.real), float(s1.imag), float(s2.real), float(s2.imag)]
                              for mu, (s1, s2) in zip(ANGLES, s)]
        if with_legendre:
            case["legendre"] = legendre_moments(a, b)
        cases.append(case)
        print(f"done m = {re_m}+{im_m}i x = {x}", file=sys.stderr)
    miepython = ensure("miepython", "miepython==3.3.0")
    for re_m, im_m in MIEPYTHON_CASES:
        x = 1e4
        qext, qsca, qback, g = miepython.efficiencies_mx(complex(re_m, -im_m), x)
        cases.append({"m": [re_m, im_m], "x": x, "source": "miepython " + miepython.__version__,
                      "qext": float(qext), "qsca": float(qsca), "qabs": float(qext - qsca),
                      "qback": float(qback), "g": float(g)})
    json.dump({"generator": "tests/reference/mie/mie_reference.py", "mpmath_digits": mp.mp.dps,
               "angles_mu": ANGLES, "cases": cases}, sys.stdout, indent=1)
    print()


# ---- Size-distribution averages of large spheres: matting agents --------------------------------
#
# Silica spheres (fused silica, Malitson 1965: n^2 - 1 = sum B_i l^2 / (l^2 - C_i^2), l in um) in
# acrylic (PMMA, Sultanova et al. 2009: n^2 - 1 = 1.1819 l^2 / (l^2 - 0.011313)), the formulas of the
# catalogue's data files written out here, at 450, 550 and 700 nm (both formulas valid there); relative
# index m = n_silica / n_pmma ~ 0.98 (n ~ 1.46 in n ~ 1.49). Gamma distributions of Hansen and Travis
# (1974), n(r) ~ r^((1-3b)/b) exp(-r / (a b)), a = r_eff in {5, 40} um, b = v_eff = 0.1, normalised over
# (0, inf) with the gamma function, integrated over [0.02 a, 4.5 a] (the neglected tails: below 3e-14 of
# the cross-section-weighted mass at the low end and 3e-10 of the volume-weighted mass at the top).
# Efficiencies and series coefficients a_n, b_n from miepython 3.3.0 (S. Prahl; independent of the
# C++ code); S1, S2 from B&H 4.74 with pi_n, tau_n from B&H 4.47 on one Gauss-Legendre rule in mu for
# all radii, with N_max + 20 nodes (N_max: miepython's series length at the largest radius), exact for
# the moments beta_0 .. beta_16 of every sphere's intensity (a polynomial of degree 2N; times P_l,
# degree <= 2 N_max + 16 <= 2 (N_max + 20) - 1). The radius integral: composite Gauss-Legendre, 8 nodes
# per panel, panels 0.04 wide in ln r (135 panels, 1080 radii); convergence: the same with panels 0.08
# wide (the largest change, relative for the cross sections, absolute for g and chi_l = beta_l/(2l+1),
# is written as "convergence"). Averages per particle; efficiencies
# <C> / <pi r^2> with <pi r^2> = pi a^2 (1 - b)(1 - 2b) (exact for the untruncated gamma); g =
# <Csca g> / <Csca>; legendre: beta_l of the averaged phase function sum C_sca p / sum C_sca, beta_0 = 1.

def silica_index(nm):
    l2 = (nm * 1e-3) ** 2
    b = [(0.6961663, 0.0684043), (0.4079426, 0.1162414), (0.8974794, 9.896161)]
    return (1.0 + sum(bi * l2 / (l2 - ci * ci) for bi, ci in b)) ** 0.5


def pmma_index(nm):
    l2 = (nm * 1e-3) ** 2
    return (1.0 + 1.1819 * l2 / (l2 - 0.011313)) ** 0.5


def matting_average(np, miepython, r_eff, v_eff, nm, panel_width, moments=17):
    from math import lgamma, log, pi
    n_p, n_h = silica_index(nm), pmma_index(nm)
    m = n_p / n_h
    k = 2 * pi * n_h / (nm * 1e-3)
    alpha, scale = (1 - 3 * v_eff) / v_eff, r_eff * v_eff
    log_c = -lgamma(alpha + 1) - (alpha + 1) * log(scale)
    lo, hi = log(0.02 * r_eff), log(4.5 * r_eff)
    panels = int(round((hi - lo) / panel_width))
    t, w = np.polynomial.legendre.leggauss(8)
    edges = np.linspace(lo, hi, panels + 1)
    a, b = edges[:-1, None], edges[1:, None]
    ln_r = (0.5 * (a + b) + 0.5 * (b - a) * t[None, :]).ravel()
    r = np.exp(ln_r)
    weight = ((0.5 * (b - a) * w[None, :]).ravel() * r) * np.exp(log_c + alpha * ln_r - r / scale)  # n(r) dr
    x = k * r
    qext, qsca, qback, g = miepython.efficiencies_mx(complex(m, 0.0), x)
    area = pi * r * r
    cext = float(np.sum(weight * area * qext))
    csca = float(np.sum(weight * area * qsca))
    gsca = float(np.sum(weight * area * qsca * g))
    # Angular rule and pi_n, tau_n (B&H 4.47) for all orders up to the largest series.
    coefficients = [miepython.an_bn(complex(m, 0.0), float(xi)) for xi in x]
    n_max = max(len(c[0]) for c in coefficients)
    mu, mu_w = np.polynomial.legendre.leggauss(n_max + 20)
    pi_n = np.zeros((n_max, mu.size))
    tau_n = np.zeros((n_max, mu.size))
    p_prev, p = np.zeros_like(mu), np.ones_like(mu)
    for n in range(1, n_max + 1):
        if n > 1:
            p_prev, p = p, ((2 * n - 1) * mu * p - n * p_prev) / (n - 1)
        pi_n[n - 1] = p
        tau_n[n - 1] = n * mu * p - (n + 1) * p_prev
    intensity = np.zeros_like(mu)
    batch = 48
    orders = np.arange(1, n_max + 1)
    c_n = (2 * orders + 1) / (orders * (orders + 1.0))
    for start in range(0, x.size, batch):
        rows = range(start, min(start + batch, x.size))
        A = np.zeros((len(rows), n_max), complex)
        B = np.zeros((len(rows), n_max), complex)
        for i, row in enumerate(rows):
            an, bn = coefficients[row]
            A[i, :len(an)] = c_n[:len(an)] * an
            B[i, :len(bn)] = c_n[:len(bn)] * bn
        s1 = (A.real @ pi_n + B.real @ tau_n) + 1j * (A.imag @ pi_n + B.imag @ tau_n)
        s2 = (A.real @ tau_n + B.real @ pi_n) + 1j * (A.imag @ tau_n + B.imag @ pi_n)
        # number density weights: int (|S1|^2 + |S2|^2) dmu = x^2 Qsca = k^2 Csca / pi
        intensity += np.sum(weight[list(rows), None] * (np.abs(s1) ** 2 + np.abs(s2) ** 2), axis=0)
    total = float(np.sum(mu_w * intensity))
    legendre = []
    p_prev, p = np.zeros_like(mu), np.ones_like(mu)
    for l in range(moments):
        if l > 0:
            p_prev, p = p, ((2 * l - 1) * mu * p - (l - 1) * p_prev) / l
        legendre.append(float((2 * l + 1) * np.sum(mu_w * intensity * p) / total))
    mean_area = pi * r_eff * r_eff * (1 - v_eff) * (1 - 2 * v_eff)
    return {"wavelength_nm": nm, "particle_index": n_p, "medium_index": n_h, "m": m,
            "x_max": float(x[-1]), "radii": int(x.size), "n_max": n_max,
            "cext_um2": cext, "csca_um2": csca, "qext": cext / mean_area, "qsca": csca / mean_area,
            "g": gsca / csca, "legendre": legendre,
            # consistency of the two routes to Csca (efficiencies vs. the angular integral)
            "csca_from_intensity_relative": total * pi / (k * k) / csca - 1.0}


def matting_main():
    np = ensure("numpy", "numpy")
    miepython = ensure("miepython", "miepython==3.3.0")
    cases = []
    for r_eff in (5.0, 40.0):
        for nm in (450.0, 550.0, 700.0):
            fine = matting_average(np, miepython, r_eff, 0.1, nm, 0.04)
            coarse = matting_average(np, miepython, r_eff, 0.1, nm, 0.08)
            change = max(abs(coarse[q] / fine[q] - 1) for q in ("cext_um2", "csca_um2"))
            change = max(change, abs(coarse["g"] - fine["g"]))
            change = max(change, max(abs(a - b) / (2 * l + 1) for l, (a, b) in
                                     enumerate(zip(coarse["legendre"], fine["legendre"]))))
            case = {"distribution": "gamma", "r_eff_um": r_eff, "v_eff": 0.1}
            case.update(fine)
            case["convergence"] = change
            cases.append(case)
            print(f"done r_eff = {r_eff} um, {nm} nm: convergence {change:.2e}", file=sys.stderr)
    json.dump({"generator": "tests/reference/mie/mie_reference.py matting",
               "miepython": miepython.__version__, "cases": cases}, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "matting":
        matting_main()
    else:
        main()
