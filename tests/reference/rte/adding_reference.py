#!/usr/bin/env python3
"""Adding-doubling reference for smooth interfaces, films and stacks (numpy only).

Writes adding_interface.json and adding_stacks.json beside this script. Run:
    python3 tests/reference/rte/adding_reference.py      (about 2.5 min of CPU on one core)
It is written from the physics, independently of the project's C++ (which solves half-spaces with
Ambartsumian's equation and finite layers with a discrete-ordinates eigen solution):

- Per Fourier order m every element of a stack (homogeneous layer, smooth Fresnel interface,
  Lambertian floor) is a pair of reflection and transmission operators; layers are built by doubling
  from a layer of optical depth ~1e-15 given by exact single scattering, stacks by adding (van de
  Hulst 1980, Multiple Light Scattering vol. 1; Hansen and Travis 1974, Space Sci. Rev. 16, 527;
  Plass, Kattawar and Catchings 1973, Appl. Opt. 12, 314).
- Directions are labelled by the Snell invariant s = n sin(theta), which refraction conserves, so one
  node is one direction in every medium and a smooth interface is diagonal: exact Fresnel, no
  interpolation. A medium of index n owns the nodes with s < n; the others (beyond its horizon) are
  zero rows and columns of its operators, and total internal reflection is F = 1 on the nodes a
  denser medium has and the lighter one lacks.
- Radiance is carried as basic radiance L / n^2 (it crosses a smooth interface times T = 1 - F) and
  operators contract with the measure 2 s ds = 2 n^2 mu dmu, the same in every medium. A medium's
  reflection function R (BRDF = R / pi) is then the kernel R / n^2.
- Quadrature: s is split at every refractive index of the stack; on each piece the variable is
  mu of the medium whose horizon ends the piece, mu = c t^2 with Gauss-Legendre in t (the field
  behaves like mu ln mu at a horizon and like sqrt(mu) beyond a critical angle: both smooth in t).
- The requested directions are extra nodes of zero weight. Operators are stored as
  (delta part, kernel) so that a zero-weight node keeps its kernel row and column: single
  scattering, and every interface, is exact at those directions; only multiple scattering uses the
  quadrature.
- No delta-M truncation anywhere: the phase function is the full Legendre series (HG moments are
  dropped only once (2l+1) g^l < 1e-15).
- Azimuth: the radiative-transfer phi = 0 is the forward side; the graphics phi_g = phi - 180 deg,
  so BRDF = (R^0 + 2 sum_m (-1)^m R^m cos(m phi_g)) / pi (docs/physics.md sections 3 and 6).

Checks printed on each run: the published semi-infinite external albedos of docs/physics.md section 4,
energy conservation at omega = 1 (mirror + diffuse albedo + transmittance = 1 for a film under an
interface), reciprocity, agreement with disort_films.json (cdisort) for layers without an interface,
that an index-matched clear layer changes nothing, and the change between two node counts (the
convergence estimate stored with every case).
"""
import datetime
import json
import math
import os
import sys
import time

# One BLAS thread: the reference runs on one core (threaded BLAS on small matrices of a busy machine is
# ten times slower, not faster). Must be set before numpy loads.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

try:
    import numpy as np
except ImportError:  # test-only dependency (tools/dev/install-deps.sh installs Debian packages only)
    import subprocess
    subprocess.check_call([sys.executable, "-m", "pip", "install", "--quiet", "numpy"])
    import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))

THIN_DEPTH = 1e-15       # starting layer of the doubling (2^-50 on the shared chain); starting at 2^-40
                         # instead moves BRDFs by up to 1.4e-9 (neglected double scattering in that layer)
SEMI_INFINITE_MIN = 1e3  # a half-space is doubled at least this deep, then until R stops changing
FOURIER_TOL = 1e-11      # stop the azimuth series when two orders in a row add less than this (relative)
HG_DROP = 1e-15          # HG moments (2l+1) g^l below this are dropped


# --- Phase functions ------------------------------------------------------------------------------

def phase_moments(phase):
    """Legendre coefficients beta_l (beta_0 = 1) of {"type": "isotropic" | "henyey_greenstein", "g"}."""
    if phase["type"] == "isotropic":
        return np.array([1.0])
    g = float(phase["g"])
    if g == 0.0:
        return np.array([1.0])
    beta = [1.0]
    l = 1
    while (2 * l + 1) * abs(g) ** l >= HG_DROP:
        beta.append((2 * l + 1) * g**l)
        l += 1
    return np.array(beta)


def normalized_legendre(m, lmax, mu, sin):
    """Pbar_l^m(mu) = sqrt((l-m)!/(l+m)!) P_l^m(mu) for l = 0..lmax (rows; zero for l < m).

    Upward recurrence in l at fixed m (as DISORT's LEPOLY); sin = sqrt(1 - mu^2) is passed in because
    it is known exactly from the Snell invariant where 1 - mu^2 would cancel.
    """
    out = np.zeros((lmax + 1, mu.size))
    if m > lmax:
        return out
    pmm = np.ones(mu.size)
    for k in range(1, m + 1):
        pmm = pmm * math.sqrt((2 * k - 1) / (2 * k)) * sin
    out[m] = pmm
    if m + 1 <= lmax:
        out[m + 1] = math.sqrt(2 * m + 1) * mu * pmm
    for l in range(m + 2, lmax + 1):
        out[l] = ((2 * l - 1) * mu * out[l - 1] - math.sqrt((l - 1) ** 2 - m * m) * out[l - 2]) / math.sqrt(
            l * l - m * m)
    return out


# --- Fresnel ---------------------------------------------------------------------------------------

def fresnel_unpolarised(n1, mu1, n2, mu2):
    """Mean of the s and p power reflectances between media n1, n2 at cosines mu1, mu2 (Snell pair)."""
    rs = (n1 * mu1 - n2 * mu2) / (n1 * mu1 + n2 * mu2)
    rp = (n2 * mu1 - n1 * mu2) / (n2 * mu1 + n1 * mu2)
    return 0.5 * (rs * rs + rp * rp)


def fresnel_from_air(n, theta_deg):
    mu_a = math.cos(math.radians(theta_deg))
    sin_a = math.sin(math.radians(theta_deg))
    mu_b = math.sqrt(1.0 - (sin_a / n) ** 2)
    return float(fresnel_unpolarised(1.0, mu_a, n, mu_b))


# --- Directions ------------------------------------------------------------------------------------

class Grid:
    """Quadrature over the Snell invariant s in [0, max index], plus zero-weight output directions.

    Node i lies on the piece of s ending at index top[i] and is given there by its cosine
    mu_top[i] in the medium of that index; every other medium's cosine follows from s.
    """

    def __init__(self, indices, nodes_per_piece, outputs_deg, output_index=1.0):
        breaks = sorted(set(float(n) for n in indices) | {float(output_index)})
        tops, mus, weights = [], [], []
        t, wt = np.polynomial.legendre.leggauss(nodes_per_piece)
        t, wt = 0.5 * (t + 1.0), 0.5 * wt
        lo = 0.0
        for top in breaks:
            c = math.sqrt(1.0 - (lo / top) ** 2)  # cosine, in the medium `top`, where the piece begins
            mu = c * t * t
            # 2 s ds = 2 top^2 mu dmu, dmu = 2 c t dt
            weights.append(2.0 * top * top * mu * 2.0 * c * t * wt)
            tops.append(np.full(t.size, top))
            mus.append(mu)
            lo = top
        for theta in outputs_deg:
            tops.append(np.array([float(output_index)]))
            mus.append(np.array([1.0 if theta == 0 else math.cos(math.radians(theta))]))
            weights.append(np.zeros(1))
        self.top = np.concatenate(tops)
        self.mu_top = np.concatenate(mus)
        self.w = np.concatenate(weights)
        self.size = self.w.size
        self.first_output = self.size - len(outputs_deg)
        self.output_index = float(output_index)
        # s = top sin(theta_top) with 1 - mu^2 factored to keep digits near normal incidence
        self.s = self.top * np.sqrt((1.0 - self.mu_top) * (1.0 + self.mu_top))
        self.pieces = breaks
        self.nodes_per_piece = nodes_per_piece

    def medium(self, n):
        """(active mask, mu, sin) of the directions that exist in a medium of index n."""
        n = float(n)
        # Pieces end at every index, so a node exists in medium n exactly when its piece ends at or
        # below n (comparing s with n would drop the most grazing node, where s rounds to n).
        active = self.top <= n
        same = self.top == n
        mu = np.ones(self.size)
        sin = np.zeros(self.size)
        other = active & ~same
        mu[other] = np.sqrt((n - self.s[other]) * (n + self.s[other])) / n
        mu[same] = self.mu_top[same]
        sin[active] = self.s[active] / n
        mu[~active] = 1.0  # placeholder, never used: rows and columns there are zero
        return active, mu, sin


# --- Operators: delta part plus kernel ------------------------------------------------------------

class Op:
    """Linear map on basic radiance over the grid: (Op L)_i = e_i L_i + sum_k K_ik w_k L_k.

    e is the unscattered (specular or direct) part, K the kernel, which stays meaningful for
    zero-weight nodes as inputs too (the response to a collimated beam from that direction).
    """

    def __init__(self, e, K):
        self.e = e
        self.K = K


def compose(a, b, w):
    """a after b."""
    return Op(a.e * b.e, a.e[:, None] * b.K + a.K * b.e[None, :] + a.K @ (w[:, None] * b.K))


def plus(a, b):
    return Op(a.e + b.e, a.K + b.K)


def resolvent(a, b, w):
    """(I - a)^-1 b: the series of interreflections between two elements, summed exactly."""
    xe = b.e / (1.0 - a.e)
    m = np.diag(1.0 - a.e) - a.K * w[None, :]
    return Op(xe, np.linalg.solve(m, b.K + a.K * xe[None, :]))


class Element:
    """Reflection from above r, transmission downward t, reflection from below rb, upward tb."""

    def __init__(self, r, t, rb, tb):
        self.r, self.t, self.rb, self.tb = r, t, rb, tb


def add(top, bottom, w):
    """Adding equations: the element `top` lying on `bottom`.

    R = Ra + Ta* (I - Rb Ra*)^-1 Rb Ta, T = Tb (I - Ra* Rb)^-1 Ta, and the same from below.
    """
    down = resolvent(compose(top.rb, bottom.r, w), top.t, w)      # (I - Ra* Rb)^-1 Ta
    up = resolvent(compose(bottom.r, top.rb, w), bottom.tb, w)    # (I - Rb Ra*)^-1 Tb*
    r = plus(top.r, compose(top.tb, compose(bottom.r, down, w), w))
    t = compose(bottom.t, down, w)
    rb = plus(bottom.rb, compose(bottom.t, compose(top.rb, up, w), w))
    tb = compose(top.tb, up, w)
    return Element(r, t, rb, tb)


def reflection_on(top, below_r, w):
    """Reflection from above of `top` lying on a reflector below_r (only the first adding equation)."""
    return plus(top.r, compose(top.tb, compose(below_r, resolvent(compose(top.rb, below_r, w), top.t, w), w), w))


# --- Elements --------------------------------------------------------------------------------------

def thin_layer(grid, n, beta, omega, depth, m):
    """Exact single scattering of a layer of optical depth `depth` (~1e-15), Fourier order m.

    R(mu, mu0) = (omega/4) p^m(-mu, mu0) (1 - exp(-depth (1/mu + 1/mu0))) / (mu + mu0),
    T(mu, mu0) = (omega/4) p^m(mu, mu0) (exp(-depth/mu) - exp(-depth/mu0)) / (mu - mu0),
    direct part exp(-depth/mu); divided by n^2 for basic radiance. Neglected: double scattering,
    of relative order depth ln(1/depth).
    """
    active, mu, sin = grid.medium(n)
    lmax = beta.size - 1
    pbar = normalized_legendre(m, lmax, mu, sin) * active[None, :]
    parity = np.array([(-1.0) ** (l + m) for l in range(lmax + 1)])
    p_same = pbar.T @ (beta[:, None] * pbar)              # p^m(mu, mu')
    p_flip = pbar.T @ ((beta * parity)[:, None] * pbar)   # p^m(-mu, mu')
    inv = 1.0 / mu
    y_r = depth * (inv[:, None] + inv[None, :])
    y_t = depth * (inv[None, :] - inv[:, None])
    scale = omega / 4.0 * depth * (inv[:, None] * inv[None, :]) / (n * n)
    r = scale * p_flip * relative_expm1(y_r)
    t = scale * p_same * relative_expm1(y_t) * np.exp(-depth * inv)[:, None]
    return Op(np.zeros(grid.size), r), Op(direct_part(grid, n, depth), t)


def relative_expm1(x):
    """(1 - exp(-x)) / x, 1 at x = 0."""
    out = np.ones_like(x)
    big = np.abs(x) > 1e-8
    out[big] = -np.expm1(-x[big]) / x[big]
    out[~big] = 1.0 - 0.5 * x[~big]
    return out


def double(r, t, w, direct):
    """A homogeneous layer on itself (R = R*, T = T* by symmetry).

    `direct` is the exact exp(-depth/mu) of the doubled layer: squaring the rounded direct part 40
    times would turn its rounding (1e-16 of 1 - 1e-15) into a large error of the extinction.
    """
    y = resolvent(compose(r, r, w), t, w)
    t2 = compose(t, y, w)
    t2.e = direct
    return plus(r, compose(t, compose(r, y, w), w)), t2


def direct_part(grid, n, depth):
    active, mu, _ = grid.medium(n)
    return np.where(active, np.exp(-depth / mu), 0.0)


def layer_chain(grid, n, beta, omega, depths, m):
    """Elements of a homogeneous layer at each requested optical depth; math.inf gives the half-space.

    Dyadic depths (d 2^50 an integer) and the half-space share one doubling chain from 2^-50: a depth
    is the sum of the powers 2^k 2^-50 of its binary digits, put together by adding. Other depths
    (0.1) are doubled from d / 2^k <= THIN_DEPTH on their own. The half-space is doubled until R stops
    changing (relative change < 1e-15) and at least to SEMI_INFINITE_MIN.
    Returns {depth: Element}, and for math.inf an Element whose t is zero.
    """
    out = {}
    w = grid.w
    unit = 2.0**-50
    dyadic = [d for d in depths if d != math.inf and float(d / unit).is_integer()]
    if dyadic or math.inf in depths:
        r, t = thin_layer(grid, n, beta, omega, unit, m)
        powers = [(r, t)]
        top = max([int(d / unit).bit_length() for d in dyadic] + [1])
        depth = unit
        while True:
            need_more = len(powers) < top
            change = 1.0
            if not need_more and math.inf not in depths:
                break
            depth *= 2.0
            r_new, t = double(r, t, w, direct_part(grid, n, depth))
            change = np.max(np.abs(r_new.K - r.K)) / max(np.max(np.abs(r_new.K)), 1e-300)
            r = r_new
            powers.append((r, t))
            if not need_more and depth >= SEMI_INFINITE_MIN and change < 1e-15:
                break
            if depth > 1e13:
                raise RuntimeError(f"half-space did not converge (change {change:.1e} at depth {depth:.1e})")
        if math.inf in depths:
            zero = np.zeros((grid.size, grid.size))
            out[math.inf] = Element(r, Op(np.zeros(grid.size), zero), r, Op(np.zeros(grid.size), zero))
        for d in dyadic:
            bits = int(d / unit)
            total = None
            for k in range(bits.bit_length()):
                if bits >> k & 1:
                    part = Element(powers[k][0], powers[k][1], powers[k][0], powers[k][1])
                    total = part if total is None else add(part, total, w)
            out[d] = total
    for d in depths:
        if d in out:
            continue
        k = math.ceil(math.log2(d / THIN_DEPTH))
        r, t = thin_layer(grid, n, beta, omega, d / 2.0**k, m)
        for j in range(k):
            r, t = double(r, t, w, direct_part(grid, n, d / 2.0**(k - j - 1)))
        out[d] = Element(r, t, r, t)
    return out


def interface(grid, n_above, n_below):
    """Smooth Fresnel interface as an Element (diagonal in s: Snell pairs share a node)."""
    act_a, mu_a, _ = grid.medium(n_above)
    act_b, mu_b, _ = grid.medium(n_below)
    both = act_a & act_b
    f = np.zeros(grid.size)
    f[both] = fresnel_unpolarised(n_above, mu_a[both], n_below, mu_b[both])
    zero = np.zeros((grid.size, grid.size))
    r_above = np.where(both, f, np.where(act_a, 1.0, 0.0))  # total internal reflection: F = 1
    r_below = np.where(both, f, np.where(act_b, 1.0, 0.0))
    t = np.where(both, 1.0 - f, 0.0)
    return Element(Op(r_above, zero), Op(t, zero.copy()), Op(r_below, zero.copy()), Op(t.copy(), zero.copy()))


def lambertian(grid, n, albedo, m):
    """Lambertian floor in a medium of index n: BRDF albedo/pi, i.e. R = albedo, kernel albedo/n^2."""
    active, _, _ = grid.medium(n)
    k = np.zeros((grid.size, grid.size))
    if m == 0:
        k[np.ix_(active, active)] = albedo / (n * n)
    return Op(np.zeros(grid.size), k)


def transparent(grid, n):
    """A layer that neither scatters nor absorbs (a clear binder): identity on the medium's nodes."""
    active, _, _ = grid.medium(n)
    zero = np.zeros((grid.size, grid.size))
    e = np.where(active, 1.0, 0.0)
    return Element(Op(np.zeros(grid.size), zero), Op(e, zero.copy()), Op(np.zeros(grid.size), zero.copy()),
                   Op(e.copy(), zero.copy()))


# --- Cases -----------------------------------------------------------------------------------------

def case_indices(case):
    return [layer["index"] for layer in case["layers"]]


def depth_of(layer):
    d = layer["optical_depth"]
    return math.inf if d == "semi-infinite" else float(d)


def medium_key(layer):
    ph = layer["phase"]
    return (float(layer["index"]), ph["type"], float(ph.get("g", 0.0)), float(layer.get("omega", 0.0)),
            bool(layer.get("clear", False)))


def stack_elements(grid, case, m, chains):
    """Elements top first (air interface, layers, inner interfaces) and the floor's reflection."""
    layers = case["layers"]
    elements = []
    if case["surface"] == "smooth":
        elements.append(interface(grid, 1.0, layers[0]["index"]))
    elif layers[0]["index"] != 1.0:
        raise ValueError("surface none needs a top layer of index 1 (no refraction at the top)")
    floor = None
    for j, layer in enumerate(layers):
        d = depth_of(layer)
        if layer.get("clear"):
            elements.append(transparent(grid, layer["index"]))
        else:
            el = chains[medium_key(layer)][d]
            if d == math.inf:
                floor = el.r
                if j != len(layers) - 1:
                    raise ValueError("only the last layer may be semi-infinite")
                break
            elements.append(el)
        if j + 1 < len(layers) and layers[j + 1]["index"] != layer["index"]:
            elements.append(interface(grid, layer["index"], layers[j + 1]["index"]))
    if floor is None:
        floor = lambertian(grid, layers[-1]["index"], case.get("substrate_albedo", 0.0) or 0.0, m)
    return elements, floor


def stack_reflection(grid, case, m, chains):
    elements, floor = stack_elements(grid, case, m, chains)
    r = floor
    for el in reversed(elements):
        r = reflection_on(el, r, grid.w)
    return r


def stack_element(grid, case, m, chains):
    """The whole stack as one Element (with its transmission into the floor's medium): for checks."""
    elements, floor = stack_elements(grid, case, m, chains)
    total = elements[-1]
    for el in reversed(elements[:-1]):
        total = add(el, total, grid.w)
    return total, floor


def build_chains(grid, cases, m):
    """Layer operators of order m for every distinct medium of the cases (shared between cases)."""
    wanted = {}
    for case in cases:
        for layer in case["layers"]:
            if not layer.get("clear"):
                wanted.setdefault(medium_key(layer), (layer, set()))[1].add(depth_of(layer))
    chains = {}
    for key, (layer, depths) in wanted.items():
        beta = phase_moments(layer["phase"])
        if m > beta.size - 1:
            # p^m = 0: the layer only attenuates (its direct part); its diffuse operators vanish.
            beta = np.zeros(1)
        chains[key] = layer_chain(grid, layer["index"], beta, layer["omega"], sorted(depths), m)
    return chains


def max_order(case):
    orders = [0]
    for layer in case["layers"]:
        if not layer.get("clear"):
            orders.append(phase_moments(layer["phase"]).size - 1)
    return max(orders)


def solve_cases(cases, nodes, theta_i, theta_o):
    """Fourier-summed reflection of each case at the output directions, for one node count.

    All cases must share their set of refractive indices (one grid). Returns per case a dict with
    "k" (Fourier orders of the air kernel at outputs: list of arrays [o, i]), "mirror", "albedo",
    "orders" and "seconds".
    """
    outputs = sorted(set(theta_i) | set(theta_o))
    grid = Grid(set().union(*[set(case_indices(c)) for c in cases]), nodes, outputs)
    at = {a: grid.first_output + outputs.index(a) for a in outputs}
    rows = [at[a] for a in theta_o]
    cols = [at[a] for a in theta_i]
    air = grid.medium(1.0)[0]
    results = [{"k": [], "orders": 0, "seconds": 0.0} for _ in cases]
    live = list(range(len(cases)))
    small = [0] * len(cases)
    m = 0
    while live:
        t0 = time.perf_counter()
        chains = build_chains(grid, [cases[c] for c in live], m)
        t_chain = time.perf_counter() - t0
        for c in list(live):
            t1 = time.perf_counter()
            r = stack_reflection(grid, cases[c], m, chains)
            res = results[c]
            res["seconds"] += time.perf_counter() - t1 + t_chain / len(live)
            block = r.K[np.ix_(rows, cols)]
            res["k"].append(block)
            res["orders"] = m + 1
            if m == 0:
                res["mirror"] = r.e[cols].copy()
                res["albedo"] = (grid.w[air][:, None] * r.K[np.ix_(np.flatnonzero(air), cols)]).sum(axis=0)
                res["reciprocity"] = float(np.max(np.abs(r.K[np.ix_(cols, cols)] - r.K[np.ix_(cols, cols)].T))
                                           / np.max(np.abs(r.K[np.ix_(cols, cols)])))
                res["grid"] = {"pieces": grid.pieces, "nodes_per_piece": nodes, "size": grid.size}
            else:
                ratio = np.max(2.0 * np.abs(block) / np.abs(res["k"][0]))
                small[c] = small[c] + 1 if ratio < FOURIER_TOL else 0
            if m >= max_order(cases[c]) or small[c] >= 2:
                live.remove(c)
        m += 1
    return results


def brdf_values(res, theta_i, theta_o, phis):
    """[[theta_i, theta_o, phi, brdf], ...] from the Fourier orders (graphics azimuth)."""
    k = np.array(res["k"])  # [m, o, i]
    m = np.arange(k.shape[0])
    out = []
    for ii, ti in enumerate(theta_i):
        for jo, to in enumerate(theta_o):
            for ph in phis:
                c = np.where(m == 0, 1.0, 2.0) * (-1.0) ** m * np.cos(m * math.radians(ph))
                out.append([ti, to, ph, float(np.dot(c, k[:, jo, ii]) / math.pi)])
    return out


# --- The reference sets ----------------------------------------------------------------------------

NODES, NODES_CHECK = 48, 32  # Gauss nodes per piece of s: reference and convergence check
INTERFACE_THETA_I = [0.0, 30.0, 60.0, 80.0]
INTERFACE_THETA_O = [0.0, 30.0, 60.0, 80.0, 89.0]
PHIS = [0.0, 90.0, 180.0]
ISO = {"type": "isotropic"}


def hg(g):
    return {"type": "henyey_greenstein", "g": g}


def layer(index, phase, omega, depth):
    return {"index": index, "phase": phase, "omega": omega, "optical_depth": depth}


def clear_layer(index):
    """A clear binder layer: no scattering, no absorption, so any thickness (optical depth 0)."""
    return {"index": index, "clear": True, "optical_depth": 0.0}


def interface_cases():
    cases = []
    for n in (1.5, 1.33):
        for label, phase in (("iso", ISO), ("hg0.5", hg(0.5)), ("hg0.8", hg(0.8))):
            for omega in (0.999, 0.99, 0.9):
                cases.append({"label": f"n{n}-{label}-omega{omega}", "surface": "smooth",
                              "layers": [layer(n, phase, omega, "semi-infinite")], "substrate_albedo": None})
    return cases


def stack_cases():
    cases = []
    # (a) films under a smooth air interface
    for omega in (0.9, 0.99):
        for tau in (1.0, 5.0):
            for floor in (0.0, 0.5, 0.8):
                cases.append({"label": f"film-omega{omega}-tau{tau:g}-floor{floor:g}", "group": "a",
                              "surface": "smooth", "layers": [layer(1.5, hg(0.5), omega, tau)],
                              "substrate_albedo": floor})
    # (b) two layers with a smooth index change, with and without the air interface
    top = layer(1.5, hg(0.3), 0.95, 1.0)
    top_bare = layer(1.0, hg(0.3), 0.95, 1.0)  # "surface none": the top layer has index 1
    for surface, first, second_indices in (("smooth", top, (1.8, 1.3)), ("none", top_bare, (1.5, 1.3))):
        for n2 in second_indices:
            cases.append({"label": f"two-layer-{surface}-n{first['index']:g}-over-n{n2:g}", "group": "b",
                          "surface": surface, "layers": [first, layer(n2, ISO, 0.99, 3.0)],
                          "substrate_albedo": 0.5})
        n2 = second_indices[0]
        cases.append({"label": f"two-layer-{surface}-n{first['index']:g}-over-n{n2:g}-semi-infinite", "group": "b",
                      "surface": surface, "layers": [first, layer(n2, ISO, 0.99, "semi-infinite")],
                      "substrate_albedo": None})
    # (c) a clear layer index-matched to the layer below changes nothing
    cases.append({"label": "clear-n1.5-over-film-omega0.9-tau1-floor0.5", "group": "c", "surface": "smooth",
                  "layers": [clear_layer(1.5), layer(1.5, hg(0.5), 0.9, 1.0)], "substrate_albedo": 0.5,
                  "same_as": "film-omega0.9-tau1-floor0.5"})
    cases.append({"label": "clear-n1.8-between-two-layer-smooth-n1.5-over-n1.8", "group": "c", "surface": "smooth",
                  "layers": [top, clear_layer(1.8), layer(1.8, ISO, 0.99, 3.0)], "substrate_albedo": 0.5,
                  "same_as": "two-layer-smooth-n1.5-over-n1.8"})
    return cases


def index_set(case):
    return tuple(sorted(set(case_indices(case)) | {1.0}))


def solve_reference(cases, theta_i, theta_o, nodes=NODES, nodes_check=NODES_CHECK):
    """Solve every case at two node counts (cases sharing a set of indices share a grid)."""
    groups = {}
    for j, case in enumerate(cases):
        groups.setdefault(index_set(case), []).append(j)
    out = [None] * len(cases)
    for key, members in groups.items():
        group = [cases[j] for j in members]
        ref = solve_cases(group, nodes, theta_i, theta_o)
        chk = solve_cases(group, nodes_check, theta_i, theta_o)
        for j, r, c in zip(members, ref, chk):
            v = np.array([x[3] for x in brdf_values(r, theta_i, theta_o, PHIS)])
            vc = np.array([x[3] for x in brdf_values(c, theta_i, theta_o, PHIS)])
            r["values"] = brdf_values(r, theta_i, theta_o, PHIS)
            r["max_rel_change"] = float(np.max(np.abs(vc / v - 1.0)))
            r["albedo_max_abs_change"] = float(np.max(np.abs(c["albedo"] - r["albedo"])))
            r["seconds"] += c["seconds"]
            out[j] = r
    return out


def case_record(case, res, theta_i):
    rec = {k: case[k] for k in ("label", "surface", "layers", "substrate_albedo") if k in case}
    if "same_as" in case:
        rec["same_as"] = case["same_as"]
    rec.update({
        "pieces_of_s": res["grid"]["pieces"],
        "nodes_per_piece": NODES, "nodes_per_piece_check": NODES_CHECK,
        "fourier_orders": res["orders"],
        "max_rel_change": res["max_rel_change"],
        "albedo_max_abs_change": res["albedo_max_abs_change"],
        "values": res["values"],
        "per_incidence": [{"theta_i": ti, "diffuse_albedo": float(res["albedo"][ii]), "mirror": float(res["mirror"][ii]),
                           "air_interface_fresnel": (fresnel_from_air(case["layers"][0]["index"], ti)
                                                     if case["surface"] == "smooth" else 0.0)}
                          for ii, ti in enumerate(theta_i)],
    })
    return rec


def write(name, doc):
    path = os.path.join(HERE, name)
    with open(path, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print("wrote", path)


COMMON = {
    "units": "BRDF in 1/sr; angles in degrees (in air); phi in the graphics convention of docs/design.md "
             "(0 = the light's side, 180 = the mirror side)",
    "values_layout": "[theta_i, theta_o, phi, brdf] with brdf the diffuse BRDF (the mirror delta excluded)",
    "per_incidence_note": "diffuse_albedo = directional-hemispherical reflectance of the diffuse part; "
                          "mirror = the whole specular (delta) reflectance: the air interface's unpolarised Fresnel "
                          "plus unscattered light mirrored back by inner interfaces (exp(-2 tau/mu) F T T); "
                          "air_interface_fresnel = the first term alone (0 without an air interface)",
    "layers_note": "top first; index = real refractive index of the layer's binder; phase Legendre series "
                   "beta_l = (2l+1) g^l for HG (beta_0 = 1); optical_depth 'semi-infinite' = half-space; "
                   "substrate_albedo = Lambertian floor (BRDF albedo/pi) under the last layer, null for a half-space; "
                   "every index change between layers is a smooth Fresnel interface; surface smooth = Fresnel "
                   "air/layer interface on top, none = no interface (top layer index 1)",
    "convergence_note": "max_rel_change: largest relative BRDF difference between nodes_per_piece and "
                        "nodes_per_piece_check Gauss nodes per piece of s; albedo_max_abs_change likewise",
}


# --- Checks ----------------------------------------------------------------------------------------

PUBLISHED_ALBEDO = {  # docs/physics.md section 4: n = 1.5, normal incidence, mirror + diffuse
    "iso": (0.841459, 0.601982, 0.259919),
    "hg0.5": (0.786373, 0.500607, 0.171065),
    "hg0.8": (0.691321, 0.360440, 0.095253),
}


def check_published(cases, results):
    worst = 0.0
    for case, res in zip(cases, results):
        if not case["label"].startswith("n1.5-"):
            continue
        _, phase, om = case["label"].split("-")
        omega = float(om[len("omega"):])
        ref = PUBLISHED_ALBEDO[phase][(0.999, 0.99, 0.9).index(omega)]
        got = res["albedo"][0] + res["mirror"][0]
        worst = max(worst, abs(got - ref))
    print(f"external albedo (n 1.5, normal incidence) vs docs/physics.md section 4: largest difference {worst:.1e} "
          "(the table has 6 decimals and is stated to ~1e-6)")
    return worst


def check_isotropic_exact(cases, results, theta_i, theta_o):
    """Isotropic half-space under an interface from Chandrasekhar's H-function (chandrasekhar_h.py).

    Independent of the doubling: X = (omega/4) H(mu) H(mu0)/(mu + mu0) exactly, then the interface
    by its own formula (docs/physics.md section 4) on a quadrature of the internal cosine split at
    the critical cosine. Compares BRDFs at all output directions and the albedo.
    """
    try:
        sys.path.insert(0, HERE)
        from chandrasekhar_h import h_function
        import mpmath
    except ImportError:
        print("isotropic H-function check skipped (mpmath missing)")
        return None
    mpmath.mp.dps = 15
    worst = 0.0
    for case, res in zip(cases, results):
        lay = case["layers"][0]
        if lay["phase"]["type"] != "isotropic":
            continue
        n, omega = lay["index"], lay["omega"]
        mu_c = math.sqrt(1.0 - 1.0 / n**2)
        t, wt = np.polynomial.legendre.leggauss(40)
        t, wt = 0.5 * (t + 1.0), 0.5 * wt
        mus = np.concatenate([mu_c * t * t, np.sqrt(1.0 - (1.0 - t**4) / n**2)])    # internal cosines
        mu_air = np.concatenate([np.zeros(t.size), t * t])
        dmu = np.concatenate([2.0 * mu_c * t * wt, (t * t) / (n * n * mus[t.size:]) * 2.0 * t * wt])
        f = np.array([1.0 if ma == 0.0 else fresnel_unpolarised(1.0, ma, n, mb) for ma, mb in zip(mu_air, mus)])
        h = np.array([float(h_function(m, omega)) for m in mus])
        outs = sorted(set(theta_i) | set(theta_o))
        mu_out_air = np.array([cosine(a) for a in outs])
        mu_out = np.sqrt(1.0 - (1.0 - mu_out_air**2) / n**2)
        h_out = np.array([float(h_function(m, omega)) for m in mu_out])
        x_qq = omega / 4.0 * np.outer(h, h) / (mus[:, None] + mus[None, :])
        x_oq = omega / 4.0 * np.outer(h_out, h) / (mu_out[:, None] + mus[None, :])
        x_qo = x_oq.T
        x_oo = omega / 4.0 * np.outer(h_out, h_out) / (mu_out[:, None] + mu_out[None, :])
        # Y = X + 2 X M F W Y  (internal reflection series), at quadrature and output rows
        a = np.eye(mus.size) - 2.0 * x_qq * (mus * f * dmu)[None, :]
        y_q = np.linalg.solve(a, x_qo)
        y_o = x_oo + 2.0 * x_oq @ ((mus * f * dmu)[:, None] * y_q)
        t_out = 1.0 - np.array([fresnel_unpolarised(1.0, ma, n, mb) for ma, mb in zip(mu_out_air, mu_out)])
        r_ext = t_out[:, None] * t_out[None, :] / n**2 * y_o
        for v in res["values"]:
            exact = r_ext[outs.index(v[1]), outs.index(v[0])] / math.pi
            worst = max(worst, abs(v[3] / exact - 1.0))
        # albedo = 2 int R_ext mu_a dmu_a = 2 int T(mu_a) R_ext n^2 mu_b dmu_b over the escaping cosines
        y_qo = y_q  # [quadrature, output]
        for ii, ti in enumerate(theta_i):
            col = outs.index(ti)
            alb = 2.0 * np.sum((1.0 - f) * t_out[col] * y_qo[:, col] * mus * dmu)
            worst = max(worst, abs(res["albedo"][ii] / alb - 1.0))
    print(f"isotropic half-spaces under an interface vs the exact H-function solution: largest relative "
          f"difference {worst:.1e} (BRDF and albedo)")
    return worst


def cosine(theta_deg):
    return 1.0 if theta_deg == 0.0 else math.cos(math.radians(theta_deg))


def check_conservation():
    """omega = 1: mirror + diffuse albedo + transmittance into a black floor = 1 (film and a TIR stack)."""
    worst = 0.0
    checks = [
        {"surface": "smooth", "layers": [layer(1.5, hg(0.5), 1.0, 1.0)]},
        {"surface": "smooth", "layers": [layer(1.5, hg(0.3), 1.0, 1.0), layer(1.3, ISO, 1.0, 3.0)]},
        {"surface": "smooth", "layers": [layer(1.5, hg(0.3), 1.0, 1.0), layer(1.8, hg(0.8), 1.0, 0.1)]},
    ]
    for case in checks:
        grid = Grid(index_set(case), 32, INTERFACE_THETA_I)
        chains = build_chains(grid, [case], 0)
        total, _ = stack_element(grid, case, 0, chains)
        cols = list(range(grid.first_output, grid.size))
        r = total.r.e[cols] + (grid.w[:, None] * total.r.K[:, cols]).sum(axis=0)
        t = total.t.e[cols] + (grid.w[:, None] * total.t.K[:, cols]).sum(axis=0)
        worst = max(worst, float(np.max(np.abs(r + t - 1.0))))
    print(f"omega = 1 energy conservation (films and stacks with total internal reflection): "
          f"|R + T - 1| <= {worst:.1e}")
    return worst


def check_disort():
    """Layers without an interface against cdisort (disort_films.json): BRDF, albedo, transmittance."""
    path = os.path.join(HERE, "disort_films.json")
    if not os.path.exists(path):
        print("DISORT check skipped (run disort_films.py first)")
        return None
    doc = json.load(open(path))
    # All g = 0.5 films; for g = 0.9 (128 nodes, ~100 Fourier orders) tau = 1 only.
    chosen = [c for c in doc["cases"] if c["phase"]["g"] == 0.5 or c["optical_depth"] == 1.0]
    theta_i = sorted({v[0] for v in chosen[0]["values"]})
    theta_o = sorted({v[1] for v in chosen[0]["values"]})
    cases = [{"surface": "none", "layers": [layer(1.0, c["phase"], c["omega"], c["optical_depth"])],
              "substrate_albedo": c["floor_albedo"]} for c in chosen]
    report = {}
    for g, nodes in ((0.5, 48), (0.9, 128)):
        sel = [j for j, c in enumerate(chosen) if c["phase"]["g"] == g]
        res = solve_cases([cases[j] for j in sel], nodes, theta_i, theta_o)
        for omega in sorted({chosen[j]["omega"] for j in sel}):
            worst = {"brdf": (0.0, ""), "albedo": (0.0, ""), "transmittance": (0.0, "")}

            def note(kind, diff, label):
                if diff > worst[kind][0]:
                    worst[kind] = (diff, label)

            count = 0
            for j, r in zip(sel, res):
                if chosen[j]["omega"] != omega:
                    continue
                count += 1
                label = chosen[j]["label"]
                theirs = {(v[0], v[1], v[2]): v[3] for v in chosen[j]["values"]}
                for v in brdf_values(r, theta_i, theta_o, [0.0, 90.0, 180.0]):
                    note("brdf", abs(v[3] / theirs[(v[0], v[1], v[2])] - 1.0), label)
                down = film_floor_flux(cases[j], nodes, theta_i)
                for p, a, t in zip(chosen[j]["per_incidence"], r["albedo"], down):
                    note("albedo", abs(p["albedo"] - a), label)
                    note("transmittance", abs(p["transmittance"] - t), label)
            report[f"g{g}-omega{omega:g}"] = {k: v[0] for k, v in worst.items()}
            print(f"films without interface, HG g = {g}, omega = {omega:g} ({count} cases, {nodes} nodes) vs "
                  f"cdisort: largest relative BRDF difference {worst['brdf'][0]:.1e} ({worst['brdf'][1]}), "
                  f"albedo {worst['albedo'][0]:.1e}, transmittance {worst['transmittance'][0]:.1e} (absolute)")
    return report


def film_floor_flux(case, nodes, theta_i):
    """Total down-flux at the floor of a one-layer film (direct + diffuse, floor interreflection included)."""
    grid = Grid(index_set(case), nodes, theta_i)
    chains = build_chains(grid, [case], 0)
    (film,), floor = stack_elements(grid, case, 0, chains)
    down = resolvent(compose(film.rb, floor, grid.w), film.t, grid.w)  # (I - R* R_floor)^-1 T
    cols = list(range(grid.first_output, grid.size))
    return down.e[cols] + (grid.w[:, None] * down.K[:, cols]).sum(axis=0)


def main():
    t0 = time.perf_counter()
    checks = {"conservation_omega1": check_conservation(), "disort": check_disort()}

    cases = interface_cases()
    results = solve_reference(cases, INTERFACE_THETA_I, INTERFACE_THETA_O)
    checks["published_albedo_max_abs_diff"] = check_published(cases, results)
    checks["isotropic_exact_max_rel_diff"] = check_isotropic_exact(cases, results, INTERFACE_THETA_I,
                                                                   INTERFACE_THETA_O)
    for case, res in zip(cases, results):
        print(f"  {case['label']:28s} orders {res['orders']:3d}  node change {res['max_rel_change']:.1e}"
              f"  reciprocity {res['reciprocity']:.1e}")
    write("adding_interface.json", dict(COMMON, **{
        "source": "tests/reference/rte/adding_reference.py (adding-doubling, numpy " + np.__version__ + ")",
        "generated": datetime.date.today().isoformat(),
        "medium": "semi-infinite homogeneous medium under a smooth air/binder interface",
        "cases": [case_record(c, r, INTERFACE_THETA_I) for c, r in zip(cases, results)],
    }))

    cases = stack_cases()
    results = solve_reference(cases, INTERFACE_THETA_I, INTERFACE_THETA_O)
    by_label = {c["label"]: r for c, r in zip(cases, results)}
    for case, res in zip(cases, results):
        same = ""
        if "same_as" in case:
            other = np.array([v[3] for v in by_label[case["same_as"]]["values"]])
            mine = np.array([v[3] for v in res["values"]])
            same = f"  vs {case['same_as']}: {np.max(np.abs(mine / other - 1.0)):.1e}"
        print(f"  {case['label']:52s} orders {res['orders']:3d}  node change {res['max_rel_change']:.1e}"
              f"  reciprocity {res['reciprocity']:.1e}{same}")
    write("adding_stacks.json", dict(COMMON, **{
        "source": "tests/reference/rte/adding_reference.py (adding-doubling, numpy " + np.__version__ + ")",
        "generated": datetime.date.today().isoformat(),
        "medium": "films and stacks: (a) film under a smooth interface, (b) two layers, (c) clear layers",
        "cases": [case_record(c, r, INTERFACE_THETA_I) for c, r in zip(cases, results)],
    }))
    print(f"done in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
