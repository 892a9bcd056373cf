#!/usr/bin/env python3
"""Monte Carlo reference (Mitsuba 3) for a semi-infinite medium under a rough dielectric boundary.

Writes mitsuba_rough_slab.json beside this script: the BRDF f_r(theta_i, theta_o, phi) (1/sr) of a
homogeneous half-space z < 0 (sigma_t = 1, lengths in mean free paths; single-scattering albedo
omega; Henyey-Greenstein phase function, g > 0 forward) below Mitsuba's `roughdielectric`
(distribution "ggx", int_ior 1.5, ext_ior 1.0) at z = 0, lit by a directional light of irradiance 1
from theta_i. f_r = L_o / cos(theta_i), split into the surface part (first-surface reflection, no
volume event) and the body part (light that entered the medium). Azimuth in the graphics convention
of docs/design.md: phi = 0 the viewer is on the light's side, phi = 180 the mirror side.

Mitsuba's microfacet model uses the SEPARABLE Smith shadowing-masking G = G1(wi, m) G1(wo, m)
(Walter et al. 2007, eq. 23, with the GGX G1 of their eq. 34), not the height-correlated form.

Method (tests/reference/README.md has the full description):
- Built on Mitsuba's own parts, called directly: the `roughdielectric` BSDF (mi.load_dict; its
  sample() and eval() on SurfaceInteraction3f values built here, in the local frame of the plane
  z = 0, normal +z pointing out of the medium) and the `hg` phase function. The half-space is
  analytic: exponential free paths, the boundary is the plane z = 0 (no scene, no ray tracing).
  Vectorised with the llvm_ad_rgb variant (one symbolic loop traces a whole batch of paths).
- Surface part: the BSDF evaluated at (viewer, light), no sampling (float32 rounding only).
- Body part: paths start from the viewer, refract into the medium by sampling the BSDF's
  transmission lobe, and scatter until Russian roulette ends them; a path that reaches the boundary
  from below continues by sampling the BSDF's reflection lobe (its transmission lobe cannot hit the
  delta light). At each volume vertex, next-event estimation toward the light: the light's
  refraction into the medium is sampled with the BSDF's own sampling (importance mode, wi = the
  light direction); the half-space is invariant under horizontal translation, so that refracted
  ray reaches the vertex from wherever it entered. Contribution: throughput * phase * transmittance
  exp(-|z| / |v_z|) * (sample weight) / |v_z|.
- Error bars: B >= 32 independent batches with their own seeds; the standard error is that of the
  batch means; the spread is checked against the per-path standard deviation.

Checks (printed and stored under "checks"; the JSON is written only if all pass):
- null (index-matched) boundary, isotropic omega 0.9 against Chandrasekhar's exact H-function
  result (chandrasekhar_h.py), and g = 0.5, omega 0.9 against DISORT (disort_hg_rayleigh.json);
- single scattering under the rough boundary against a direct integral of the BSDF's eval();
- the roughdielectric's own directional albedo (reflection + transmission, energy) at alpha 0.1 and
  0.3 from outside and inside at 0, 45, 80 degrees, by its sampling weights and independently by
  integrating eval() over the sphere;
- the BSDF reciprocity the next-event estimate relies on (radiance-mode eval(v, l) |cos v| ==
  importance-mode eval(l, v) |cos l|) and the vectorised surface part against scalar_rgb;
- on the same paths, the estimator of Mitsuba's stock volpath (next-event estimation at the
  boundary) agrees; reciprocity of the body part; two independent runs of one case agree; the
  batch-mean error bars agree with the per-path spread.

Run (about 40 minutes of CPU; resumes from mitsuba_rough_slab.json.partial after a crash):
    nice -n 15 python3 tests/reference/rte/mitsuba_rough_slab.py
Quick validation (minutes; writes /tmp/mitsuba_rough_slab_quick.json): add --quick
Needs: PyPI mitsuba 3.9.x (installed here with pip if missing) and Debian's libllvm19
(llvm_ad_* variants abort with Debian 12's LLVM 14/15; docs/monte-carlo.md).
"""
import argparse
import datetime
import glob
import hashlib
import importlib.util
import json
import math
import os
import re
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = "tests/reference/rte/mitsuba_rough_slab.py"
MITSUBA_REQUIREMENT = "mitsuba==3.9.1"

INT_IOR, EXT_IOR = 1.5, 1.0
ALPHAS = [0.1, 0.3]
OMEGAS = [0.9, 0.99]
GS = [0.0, 0.5]
THETA_I = [0.0, 30.0, 60.0]
THETA_O = [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0]
PHI_MAIN = [0.0, 180.0]
PHI_90_AT = [40.0, 80.0]  # theta_o where phi = 90 is added

TARGET_REL_SE = 0.005  # per body value; the total's relative error is smaller
NULL_TARGET_REL_SE = 0.0025  # the null-boundary checks are made tighter than the product values
MIN_BATCHES = 32
PILOT_LANES = 1 << 16
MAX_LANES = 1 << 20  # per launch: 1M paths keep the loop state near 100 MB
SAFETY = 1.3  # the pilot's per-path variance is itself uncertain
# Russian roulette only once the throughput is below 1e-3 (docs/monte-carlo.md: Mitsuba's
# q = min(throughput, 0.95) from depth 5 biases high-albedo media); a survivor carries RR_LEVEL.
RR_LEVEL = 1e-3
MAX_DEPTH = 100000  # guard only: lanes still alive there are counted and must be none
REPEAT_CASE = (0.3, 0.99, 0.5)  # run twice with other seeds: the two must agree


def fail(message):
    """One-line error naming the fault; no output file is written."""
    print(f"mitsuba_rough_slab.py: {message}", file=sys.stderr)
    sys.exit(1)


def find_libllvm():
    """drjit's LLVM backend needs LLVM >= 16 (Debian 12's 14/15 abort: docs/monte-carlo.md)."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    for version in range(22, 15, -1):
        for pattern in (f"/usr/lib/x86_64-linux-gnu/libLLVM-{version}.so*",
                        f"/usr/lib/llvm-{version}/lib/libLLVM*.so*",
                        f"/usr/lib/*/libLLVM.so.{version}*"):
            hits = sorted(glob.glob(pattern))
            if hits:
                return hits[0]
    fail("the llvm_ad_rgb variant needs libLLVM >= 16: apt-get install -y libllvm19 "
         "(or set DRJIT_LIBLLVM_PATH)")


def import_mitsuba():
    if importlib.util.find_spec("mitsuba") is None:
        subprocess.run([sys.executable, "-m", "pip", "install", "-q", MITSUBA_REQUIREMENT], check=True)
    os.environ["DRJIT_LIBLLVM_PATH"] = find_libllvm()
    import drjit
    import mitsuba
    if not mitsuba.__version__.startswith("3.9."):
        fail(f"needs mitsuba 3.9.x (found {mitsuba.__version__}): "
             f"python3 -m pip install {MITSUBA_REQUIREMENT}")
    return mitsuba, drjit


mi, dr = import_mitsuba()
mi.set_variant("llvm_ad_rgb")
sys.path.insert(0, HERE)
from chandrasekhar_h import h_function  # noqa: E402  (exact isotropic oracle, same directory)


# ---------------------------------------------------------------------------------------------
# Geometry and Mitsuba objects

def direction(theta_deg, phi_deg=0.0):
    """Unit vector above the plane (z > 0) at polar angle theta, azimuth phi (degrees)."""
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))


def light_direction(theta_i, phi):
    """Direction toward the light for a viewer at azimuth 0: phi = phi_o - phi_i, so phi_i = -phi."""
    return direction(theta_i, -phi)


def rough_bsdf(alpha):
    return mi.load_dict({"type": "roughdielectric", "distribution": "ggx", "alpha": alpha,
                         "int_ior": INT_IOR, "ext_ior": EXT_IOR})


def hg_phase(g):
    return mi.load_dict({"type": "hg", "g": g})


RADIANCE_T = mi.BSDFContext(mi.TransportMode.Radiance, mi.BSDFFlags.All, 1)   # transmission lobe
RADIANCE_R = mi.BSDFContext(mi.TransportMode.Radiance, mi.BSDFFlags.All, 0)   # reflection lobe
RADIANCE_ALL = mi.BSDFContext(mi.TransportMode.Radiance)
IMPORTANCE_T = mi.BSDFContext(mi.TransportMode.Importance, mi.BSDFFlags.All, 1)
PHASE_CTX = mi.PhaseFunctionContext()


def surface_interaction(wi):
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = wi
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.n = mi.Vector3f(0, 0, 1)
    return si


def medium_interaction(wi):
    it = dr.zeros(mi.MediumInteraction3f)
    it.wi = wi
    it.sh_frame = mi.Frame3f(wi)
    return it


def opaque_vector(v):
    return mi.Vector3f(*(dr.opaque(mi.Float, c) for c in v))


def seed_pair(*key):
    """Two 64-bit seeds from a text key: every batch of every task has its own PCG32 streams."""
    digest = hashlib.sha256(":".join(str(k) for k in key).encode()).digest()
    return int.from_bytes(digest[:8], "little"), int.from_bytes(digest[8:16], "little")


def splitmix64(x):
    """SplitMix64 finaliser (Steele, Lea and Flood 2014) on numpy uint64 arrays, modulo 2^64."""
    with np.errstate(over="ignore"):
        x = x + np.uint64(0x9E3779B97F4A7C15)
        x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return x ^ (x >> np.uint64(31))


def make_rng(lanes_per_key, keys):
    """PCG32 for len(keys) consecutive blocks of lanes, block b seeded from keys[b]. Every lane's
    state and stream come through SplitMix64: with plain consecutive seeds (PCG32's own
    arange offsets) the lanes' states form a lattice at every step, the paths of one batch are
    correlated and the per-path variance no longer predicts the batch means' (measured: 0.5-0.9)."""
    local = np.tile(np.arange(lanes_per_key, dtype=np.uint64), len(keys))
    pairs = np.array([seed_pair(*k) for k in keys], dtype=np.uint64)
    with np.errstate(over="ignore"):
        states = splitmix64(np.repeat(pairs[:, 0], lanes_per_key) + local)
        seqs = splitmix64(np.repeat(pairs[:, 1], lanes_per_key) + local)
    rng = mi.PCG32(len(local))
    rng.seed(mi.UInt64(states), mi.UInt64(seqs))
    return rng


# ---------------------------------------------------------------------------------------------
# The tracer

def trace(boundary, omega, g, theta_o, lights, lanes_per_batch, batch_keys, single=False):
    """Per-path body estimates of len(batch_keys) batches traced in one launch.

    Returns two numpy float64 arrays (len(lights), batches, lanes_per_batch): the product estimator
    (next-event estimation at volume vertices) and, as a check on the same paths, the estimator of
    Mitsuba's stock volpath (next-event estimation through eval() where a path meets the boundary
    from below; zero for the null boundary), then the number of paths cut by MAX_DEPTH and the mean
    number of events per path. boundary: a roughdielectric BSDF, or None for an index-matched one.
    lights: directions toward the light (the viewer is at azimuth 0, polar angle theta_o).
    single: stop every path after its first volume vertex (single scattering only, for a check)."""
    phase = hg_phase(g)
    omega_v = dr.opaque(mi.Float, omega)
    rr_level = dr.opaque(mi.Float, RR_LEVEL)
    light_vs = [opaque_vector(l) for l in lights]
    cos_lights = [dr.opaque(mi.Float, l[2]) for l in lights]
    rng = make_rng(lanes_per_batch, batch_keys)
    lanes = lanes_per_batch * len(batch_keys)
    viewer = opaque_vector(direction(theta_o))

    if boundary is None:
        d = -mi.Vector3f(viewer.x, viewer.y, viewer.z) + mi.Vector3f(dr.zeros(mi.Float, lanes))
        beta = dr.full(mi.Float, 1.0, lanes)
    else:
        # Refraction of the viewer's ray into the medium: radiance-mode weight (1 - F) G1 / eta^2.
        s1, s2 = rng.next_float32(), mi.Point2f(rng.next_float32(), rng.next_float32())
        bs, weight = boundary.sample(RADIANCE_T, surface_interaction(viewer), s1, s2)
        d = mi.Vector3f(bs.wo)
        beta = dr.select(d.z < 0, weight[0], 0.0)
    z = dr.zeros(mi.Float, lanes)
    active = beta > 0
    depth = dr.zeros(mi.UInt32, lanes)
    accs = [dr.zeros(mi.Float, lanes) for _ in range(2 * len(lights))]

    def cond(z, d, beta, active, depth, rng, accs):
        return active

    def body(z, d, beta, active, depth, rng, accs):
        free_path = -dr.log(1.0 - rng.next_float32())
        z_next = z + free_path * d.z
        at_boundary = active & (z_next >= 0)  # only when travelling up (d.z > 0)
        in_volume = active & ~at_boundary

        # Volume vertex: absorption as a weight, then next-event estimation toward each light.
        z = dr.select(in_volume, z_next, z)
        beta = dr.select(in_volume, beta * omega_v, beta)
        back = medium_interaction(-d)
        new_accs = []
        for acc, wl, cos_l in zip(accs[:len(lights)], light_vs, cos_lights):
            u1, u2, u3 = rng.next_float32(), rng.next_float32(), rng.next_float32()
            if boundary is None:
                v = -wl
                w_over_cos = dr.rcp(cos_l)
            else:
                # The light's refraction into the medium, sampled by the BSDF itself: importance-mode
                # weight f(l, v) |cos v| / pdf(v); radiance-mode f(v, l) equals importance-mode f(l, v).
                bl, wt = boundary.sample(IMPORTANCE_T, surface_interaction(wl), u1,
                                         mi.Point2f(u2, u3), in_volume)
                v = mi.Vector3f(bl.wo)
                w_over_cos = wt[0] / dr.maximum(-v.z, 1e-30)
            ok = in_volume & (v.z < 0)
            transmittance = dr.exp(-z / dr.select(ok, v.z, -1.0))  # z <= 0, v.z < 0
            p, _ = phase.eval_pdf(PHASE_CTX, back, -v, ok)
            contribution = beta * p[0] * transmittance * w_over_cos
            new_accs.append(acc + dr.select(ok, contribution, 0.0))
        # The check estimator at boundary vertices: throughput * f(-d, l) = eval(-d, l) / cos(l).
        for acc, wl, cos_l in zip(accs[len(lights):], light_vs, cos_lights):
            if boundary is not None:
                f_cos = boundary.eval(RADIANCE_ALL, surface_interaction(-d), wl, at_boundary)[0]
                acc = acc + dr.select(at_boundary, beta * f_cos / cos_l, 0.0)
            new_accs.append(acc)
        accs = new_accs

        # New direction: HG sample at a volume vertex; reflection lobe at the boundary (the
        # transmitted part leaves toward the sky and cannot hit a delta light).
        p1, p2, p3 = rng.next_float32(), rng.next_float32(), rng.next_float32()
        wo_phase, _, _ = phase.sample(PHASE_CTX, back, p1, mi.Point2f(p2, p3), in_volume)
        if boundary is None:
            d_boundary, w_boundary = d, dr.zeros(mi.Float)
        else:
            bs, wb = boundary.sample(RADIANCE_R, surface_interaction(-d), p1, mi.Point2f(p2, p3),
                                     at_boundary)
            d_boundary = mi.Vector3f(bs.wo)
            w_boundary = dr.select(d_boundary.z < 0, wb[0], 0.0)
        d = dr.select(at_boundary, d_boundary, dr.select(in_volume, wo_phase, d))
        z = dr.select(at_boundary, 0.0, z)
        beta = dr.select(at_boundary, beta * w_boundary, beta)

        # Russian roulette below RR_LEVEL; survivors carry exactly RR_LEVEL (unbiased).
        u = rng.next_float32()
        low = active & (beta < rr_level)
        survive = u * rr_level < beta
        beta = dr.select(low, dr.select(survive, rr_level, 0.0), beta)
        depth = depth + 1
        active = active & (beta > 0) & (depth < MAX_DEPTH)
        if single:
            active = active & ~in_volume
        return z, d, beta, active, depth, rng, accs

    z, d, beta, active, depth, rng, accs = dr.while_loop(
        (z, d, beta, active, depth, rng, accs), cond, body, mode="symbolic")
    depths = depth.numpy()
    cut = int(np.count_nonzero(depths >= MAX_DEPTH))
    values = np.stack([np.asarray(a.numpy(), dtype=np.float64) for a in accs])
    values = values.reshape(2, len(lights), len(batch_keys), lanes_per_batch)
    return values[0], values[1], cut, float(np.mean(depths))


def estimate(name, boundary, omega, g, theta_o, lights, settings, single=False):
    """Body estimates for one viewer direction and several lights, from B independent batches.

    A pilot batch (its own seeds, then discarded) measures the per-path spread and fixes the batch
    size so that the mean reaches settings["target"] (relative); the estimate is the mean of the
    batch means, its standard error their standard deviation / sqrt(B) and "cov" their covariance
    / B. "spread" = that error / the per-path one (sd / sqrt(paths)): the two estimate the same
    number when the per-path variance is finite."""
    start, cpu_start = time.time(), time.process_time()
    pilot, _, cut, _ = trace(boundary, omega, g, theta_o, lights, settings["pilot_lanes"],
                             [(name, "pilot")], single)
    pilot = pilot[:, 0, :]
    rel_sd = float(np.max(pilot.std(axis=1) / np.maximum(pilot.mean(axis=1), 1e-30)))
    needed = SAFETY * (rel_sd / settings["target"]) ** 2
    batches = max(settings["batches"], math.ceil(needed / MAX_LANES))
    lanes = int(min(MAX_LANES, max(settings["min_lanes"], math.ceil(needed / batches / 256) * 256)))
    per_launch = max(1, MAX_LANES // lanes)
    means = np.zeros((batches, len(lights)))
    means_check = np.zeros((batches, len(lights)))
    sums2 = np.zeros(len(lights))
    events = 0.0
    for first in range(0, batches, per_launch):
        keys = [(name, b) for b in range(first, min(batches, first + per_launch))]
        values, check, c, mean_events = trace(boundary, omega, g, theta_o, lights, lanes, keys,
                                              single)
        cut += c
        events += mean_events * len(keys)
        batch_means = values.mean(axis=2)  # (lights, batches in this launch)
        means[first:first + len(keys)] = batch_means.T
        means_check[first:first + len(keys)] = check.mean(axis=2).T
        sums2 += ((values - batch_means[:, :, None]) ** 2).sum(axis=(1, 2))
    if cut:
        fail(f"{name}: {cut} paths still alive after {MAX_DEPTH} events (roulette broken?)")
    mean = means.mean(axis=0)
    cov = np.atleast_2d(np.cov(means.T, ddof=1)) / batches
    se = np.sqrt(np.diag(cov))
    se_path = np.sqrt(sums2 / (batches * (lanes - 1))) / math.sqrt(batches * lanes)
    # The volpath-style estimator on the same paths: its difference from ours, with the covariance
    # of that difference from the same batches.
    diff = means - means_check
    check = {"name": name + " volume-vs-boundary NEE", "mean": diff.mean(axis=0).tolist(),
             "cov": (np.atleast_2d(np.cov(diff.T, ddof=1)) / batches).tolist(),
             "boundary_nee_mean": means_check.mean(axis=0).tolist(),
             "boundary_nee_se": (means_check.std(axis=0, ddof=1) / math.sqrt(batches)).tolist()}
    return {"name": name, "mean": mean.tolist(), "se": se.tolist(), "cov": cov.tolist(),
            "boundary_nee_check": check,
            "spread": (se / se_path).tolist(), "batches": batches, "lanes_per_batch": lanes,
            "pilot_rel_sd": rel_sd, "mean_events": events / batches,
            "seconds": round(time.time() - start, 1),
            "cpu_seconds": round(time.process_time() - cpu_start, 1)}


def light_set(theta_o, theta_is, phis_for):
    """Unique light directions for one viewer and the (theta_i, phi) -> light index map (at
    theta_i = 0 every phi is the same light)."""
    lights, index = [], {}
    for ti in theta_is:
        for ph in phis_for(theta_o):
            l = light_direction(ti, ph)
            for k, other in enumerate(lights):
                if max(abs(a - b) for a, b in zip(l, other)) < 1e-12:
                    index[(ti, ph)] = k
                    break
            else:
                index[(ti, ph)] = len(lights)
                lights.append(l)
    return lights, index


def product_phis(theta_o):
    return PHI_MAIN + ([90.0] if theta_o in PHI_90_AT else [])


def surface_values(bsdf, pairs):
    """Surface part f_s = eval(viewer, light) / cos(theta_i) (Mitsuba's eval includes |cos wo|)."""
    viewers = np.array([direction(to) for _, to, _ in pairs])
    lights = np.array([light_direction(ti, ph) for ti, _, ph in pairs])
    si = surface_interaction(mi.Vector3f(*(mi.Float(viewers[:, k]) for k in range(3))))
    wo = mi.Vector3f(*(mi.Float(lights[:, k]) for k in range(3)))
    value = bsdf.eval(mi.BSDFContext(mi.TransportMode.Radiance), si, wo)[0].numpy()
    return (np.asarray(value, dtype=np.float64) / lights[:, 2]).tolist()


# ---------------------------------------------------------------------------------------------
# Statistics of the checks

MAX_ABS_Z = 4.5  # with B = 32 batches z is Student-t with 31 dof: P(|t| > 4.5) ~ 1e-4 per value


def z_check(items, what):
    """Each item: (terms, reference, reference_se) with terms [(estimate, light index, coefficient)];
    z = (sum of terms - reference) / se. Values from one estimate are correlated (several lights per
    path), so the chi^2 / n bound uses the effective count n_eff = n^2 / sum(rho_ij^2) from the batch
    covariances: chi^2 / n must stay below 1 + 4 sqrt(2 / n_eff), and every |z| below MAX_ABS_Z."""
    n = len(items)
    if n == 0:
        fail(f"{what}: no values to compare")
    cov = np.zeros((n, n))
    for i, (ti, _, ri) in enumerate(items):
        for j, (tj, _, rj) in enumerate(items):
            for est_a, ka, ca in ti:
                for est_b, kb, cb in tj:
                    if est_a["name"] == est_b["name"]:
                        cov[i, j] += ca * cb * est_a["cov"][ka][kb]
        cov[i, i] += ri ** 2
    diff = np.array([sum(c * e["mean"][k] for e, k, c in t) - ref for t, ref, _ in items])
    sd = np.sqrt(np.diag(cov))
    z = diff / sd
    rho = cov / np.outer(sd, sd)
    n_eff = n * n / float(np.sum(rho ** 2))
    chi2 = float(np.mean(z * z))
    bound = 1.0 + 4.0 * math.sqrt(2.0 / n_eff)
    ok = bool(np.max(np.abs(z)) < MAX_ABS_Z and chi2 < bound)
    print(f"  {what}: {n} values (effectively {n_eff:.1f} independent), max |z| "
          f"{np.max(np.abs(z)):.2f}, chi2/n {chi2:.2f} (bound {bound:.2f}), within 2 sigma "
          f"{np.mean(np.abs(z) < 2):.0%} -> {'ok' if ok else 'FAILED'}", flush=True)
    return {"count": n, "effective_count": n_eff, "max_abs_z": float(np.max(np.abs(z))),
            "max_abs_z_bound": MAX_ABS_Z, "chi2_per_value": chi2, "chi2_bound": bound,
            "fraction_within_2_sigma": float(np.mean(np.abs(z) < 2)), "pass": ok}, z


# ---------------------------------------------------------------------------------------------
# Checks of the parts

def albedo_by_sampling(bsdf, mode, wi, samples, key):
    """(reflected, transmitted) albedo and their se from the BSDF's own sampling weights."""
    rng = make_rng(samples, [key])
    bs, weight = bsdf.sample(mi.BSDFContext(mode), surface_interaction(opaque_vector(wi)),
                             rng.next_float32(), mi.Point2f(rng.next_float32(), rng.next_float32()))
    w = np.asarray(weight[0].numpy(), dtype=np.float64)
    reflected = np.asarray(bs.wo.z.numpy()) * wi[2] > 0
    return [(float(x.mean()), float(x.std() / math.sqrt(len(x))))
            for x in (np.where(reflected, w, 0.0), np.where(reflected, 0.0, w))]


def lobe_axes(wi):
    """Mirror and smooth-interface refraction directions of wi (unit, either side of z = 0). Where the
    mean surface reflects totally, rough facets still transmit near grazing: an axis there."""
    eta = INT_IOR / EXT_IOR if wi[2] > 0 else EXT_IOR / INT_IOR
    sin_t2 = (1.0 - wi[2] ** 2) / eta ** 2
    side = -1.0 if wi[2] > 0 else 1.0
    if sin_t2 < 1.0:
        refracted = (-wi[0] / eta, -wi[1] / eta, side * math.sqrt(1.0 - sin_t2))
    else:
        s = math.hypot(wi[0], wi[1])
        refracted = (-0.99 * wi[0] / s, -0.99 * wi[1] / s, side * math.sqrt(1.0 - 0.99 ** 2))
    return (-wi[0], -wi[1], wi[2]), refracted


def mixture_directions(rng, axes, alpha):
    """Directions and their density from a mixture independent of the BSDF's sampling code: uniform
    on the sphere (10 %) and von Mises-Fisher lobes (Mitsuba's warp) of three widths around each
    axis (a refracted lobe is narrower or wider than alpha by a factor ~ eta)."""
    lobes = [(axis, kappa / (4.0 * alpha ** 2)) for axis in axes for kappa in (0.3, 3.0, 30.0)]
    weights = [0.1] + [0.9 / len(lobes)] * len(lobes)
    pick = rng.next_float32()
    u = mi.Point2f(rng.next_float32(), rng.next_float32())
    wo = mi.warp.square_to_uniform_sphere(u)
    bound = weights[0]
    frames = [mi.Frame3f(opaque_vector(axis)) for axis, _ in lobes]
    for frame, (_, kappa), wgt in zip(frames, lobes, weights[1:]):
        lobe = frame.to_world(mi.warp.square_to_von_mises_fisher(u, kappa))
        wo = dr.select((pick >= bound) & (pick < bound + wgt), lobe, wo)
        bound += wgt
    pdf = weights[0] * mi.warp.square_to_uniform_sphere_pdf(wo)
    for frame, (_, kappa), wgt in zip(frames, lobes, weights[1:]):
        pdf += wgt * mi.warp.square_to_von_mises_fisher_pdf(frame.to_local(wo), kappa)
    return wo, pdf


def albedo_by_eval(bsdf, mode, wi, alpha, samples, key):
    """(reflected, transmitted) albedo and their se from eval() integrated over the sphere, with
    directions drawn independently of the BSDF's sampling code."""
    rng = make_rng(samples, [key])
    wo, pdf = mixture_directions(rng, lobe_axes(wi), alpha)
    value = bsdf.eval(mi.BSDFContext(mode), surface_interaction(opaque_vector(wi)), wo)[0] / pdf
    value = np.asarray(value.numpy(), dtype=np.float64)
    reflected = np.asarray(wo.z.numpy()) * wi[2] > 0
    return [(float(x.mean()), float(x.std() / math.sqrt(len(x))))
            for x in (np.where(reflected, value, 0.0), np.where(reflected, 0.0, value))]


def single_scattering_by_eval(bsdf, alpha, omega, g, viewer, light, samples, key):
    """Single-scattering body part by direct integration over both refracted directions, with the
    BSDF's eval() only (no BSDF sampling, the HG formula in numpy):
      f_ss = (1 / cos theta_i) int int eval(viewer, u) omega p(-u . v) |v_z| / (|u_z| + |v_z|)
             eval(v, light) du dv
    (u: the viewer's path inside, v: the light's, both downward; the depth integral of
    exp(-s) exp(-s |u_z| / |v_z|) gives the |v_z| / (|u_z| + |v_z|))."""
    rng = make_rng(samples, [key])
    u, pdf_u = mixture_directions(rng, lobe_axes(viewer)[1:], alpha)
    v, pdf_v = mixture_directions(rng, lobe_axes(light)[1:], alpha)
    into = bsdf.eval(RADIANCE_ALL, surface_interaction(opaque_vector(viewer)), u)[0]
    out_of = bsdf.eval(RADIANCE_ALL, surface_interaction(v), opaque_vector(light))[0]
    uz, vz = (np.asarray(c.numpy(), dtype=np.float64) for c in (u.z, v.z))
    cos_scatter = -np.asarray(dr.dot(u, v).numpy(), dtype=np.float64)  # light travels v, then -u
    phase = (1.0 - g * g) / (4.0 * math.pi * (1.0 + g * g - 2.0 * g * cos_scatter) ** 1.5)
    value = (np.asarray(into.numpy(), dtype=np.float64) * np.asarray(out_of.numpy(), dtype=np.float64)
             * omega * phase * np.abs(vz) / (np.abs(uz) + np.abs(vz))
             / (np.asarray(pdf_u.numpy(), dtype=np.float64) * np.asarray(pdf_v.numpy(), dtype=np.float64)
                * light[2]))
    value = np.where((uz < 0) & (vz < 0), value, 0.0)
    return float(value.mean()), float(value.std() / math.sqrt(len(value)))


def check_albedo(settings):
    print("roughdielectric directional albedo (energy, importance mode):")
    rows, items = [], []
    fake = {"name": "albedo", "mean": [], "cov": []}  # albedo comparisons are independent scalars
    for alpha in ALPHAS:
        bsdf = rough_bsdf(alpha)
        for side in ("outside", "inside"):
            for theta in (0.0, 45.0, 80.0):
                wi = direction(theta)
                if side == "inside":
                    wi = (wi[0], wi[1], -wi[2])
                row = {"alpha": alpha, "side": side, "theta_deg": theta}
                for mode_name, mode in (("energy", mi.TransportMode.Importance),
                                        ("radiance", mi.TransportMode.Radiance)):
                    key = ("albedo", alpha, side, theta, mode_name)
                    (r, r_se), (t, t_se) = albedo_by_sampling(bsdf, mode, wi, settings["albedo_samples"], key)
                    (er, er_se), (et, et_se) = albedo_by_eval(bsdf, mode, wi, alpha,
                                                              settings["albedo_samples"], key + ("eval",))
                    row[mode_name] = {"r": r, "t": t, "r_plus_t": r + t, "r_se": r_se, "t_se": t_se,
                                      "eval_r": er, "eval_t": et, "eval_r_se": er_se, "eval_t_se": et_se}
                    for a, sa, b, sb in ((r, r_se, er, er_se), (t, t_se, et, et_se)):
                        k = len(fake["mean"])
                        fake["mean"].append(a)
                        items.append(([(fake, k, 1.0)], b, math.hypot(sa, sb)))
                e = row["energy"]
                print(f"  alpha {alpha} {side:7s} {theta:3.0f} deg: R {e['r']:.4f} T {e['t']:.4f} "
                      f"R+T {e['r_plus_t']:.4f} (eval over the sphere: R {e['eval_r']:.4f} +- "
                      f"{e['eval_r_se']:.4f}, T {e['eval_t']:.4f} +- {e['eval_t_se']:.4f})")
                rows.append(row)
    fake["cov"] = np.zeros((len(fake["mean"]),) * 2).tolist()
    summary, _ = z_check(items, "albedo: sampling weights vs eval() over the sphere, per lobe and mode")
    return {"description": "Directional albedo of roughdielectric alone (no medium). 'energy': "
                           "importance mode, the fractions of incident power reflected (r) and "
                           "transmitted (t); 'radiance': radiance mode (transmission scaled by "
                           "1/eta^2 of the side it enters). r, t from the BSDF's own sampling weights; "
                           "eval_r, eval_t from eval() integrated over the sphere with directions "
                           "drawn independently of the BSDF's sampling code. 'inside': incidence "
                           "from the medium (n = 1.5). The shortfall 1 - r_plus_t is the energy the "
                           "single-scattering microfacet model loses.",
            "docs_monte_carlo_md_quotes": "energy r_plus_t at normal incidence ~0.999 outside / ~0.99 "
                                          "inside at alpha 0.1; ~0.99 / ~0.90 at alpha 0.3; ~0.75 "
                                          "inside at grazing at alpha 0.3",
            "samples": settings["albedo_samples"], "rows": rows, "sampled_vs_eval": summary,
            "pass": summary["pass"]}


def check_bsdf_reciprocity(settings):
    """The next-event estimate samples the light's refraction in importance mode inside a radiance
    estimate: valid when radiance-mode f(v, l) equals importance-mode f(l, v), i.e.
    eval_rad(v, l) |cos v| == eval_imp(l, v) |cos l| (Mitsuba's eval includes |cos wo|). Float32
    cancellation in the generalised half vector (Walter et al. eq. 16) makes single small values
    differ, so the bound is on the cosine-weighted integral of |difference|."""
    n = settings["reciprocity_samples"]
    out = {"pairs_per_alpha": n, "bound_integrated": 1e-5}
    for alpha in ALPHAS:
        bsdf = rough_bsdf(alpha)
        rng = make_rng(n, [("bsdf reciprocity", alpha)])
        l = mi.warp.square_to_cosine_hemisphere(mi.Point2f(rng.next_float32(), rng.next_float32()))
        v = -mi.warp.square_to_cosine_hemisphere(mi.Point2f(rng.next_float32(), rng.next_float32()))
        rad = bsdf.eval(mi.BSDFContext(mi.TransportMode.Radiance), surface_interaction(v), l)[0] * -v.z
        imp = bsdf.eval(mi.BSDFContext(mi.TransportMode.Importance), surface_interaction(l), v)[0] * l.z
        rad = np.asarray(rad.numpy(), dtype=np.float64)
        imp = np.asarray(imp.numpy(), dtype=np.float64)
        rel = np.abs(rad - imp) / np.maximum(np.maximum(rad, imp), 1e-300)
        out[f"alpha_{alpha}"] = {"integrated_rel_diff": float(np.sum(np.abs(rad - imp)) / np.sum(imp)),
                                 "median_rel_diff": float(np.median(rel[imp > 0])),
                                 "max_rel_diff": float(np.max(rel[imp > 0]))}
    worst = max(out[f"alpha_{a}"]["integrated_rel_diff"] for a in ALPHAS)
    out["pass"] = bool(worst < out["bound_integrated"])
    print(f"  BSDF reciprocity radiance f(v,l) vs importance f(l,v): integrated rel diff "
          f"{worst:.1e}, largest single {max(out[f'alpha_{a}']['max_rel_diff'] for a in ALPHAS):.1e} "
          f"({n} pairs per alpha, float32) -> {'ok' if out['pass'] else 'FAILED'}")
    return out


def check_surface_scalar(pairs):
    """The vectorised surface part against the scalar_rgb variant, one direction at a time."""
    vector = {a: surface_values(rough_bsdf(a), pairs) for a in ALPHAS}
    mi.set_variant("scalar_rgb")
    try:
        worst = 0.0
        for a in ALPHAS:
            bsdf = mi.load_dict({"type": "roughdielectric", "distribution": "ggx", "alpha": a,
                                 "int_ior": INT_IOR, "ext_ior": EXT_IOR})
            for (ti, to, ph), fv in zip(pairs, vector[a]):
                si = mi.SurfaceInteraction3f()
                si.wi = mi.Vector3f(*direction(to))
                si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
                l = light_direction(ti, ph)
                fs = float(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*l))[0]) / l[2]
                worst = max(worst, abs(fs - fv) / max(abs(fs), 1e-30))
    finally:
        mi.set_variant("llvm_ad_rgb")
    ok = worst < 1e-5
    print(f"  surface part llvm_ad_rgb vs scalar_rgb: max rel diff {worst:.1e} -> "
          f"{'ok' if ok else 'FAILED'}")
    return {"max_rel_diff": worst, "bound": 1e-5, "pass": ok}


def check_single_scattering(settings, run):
    """The tracer stopped after one volume vertex against the single-scattering integral computed
    with the BSDF's eval() only: checks the parts the null boundary cannot (the sampled entry with
    its 1/eta^2, the importance-mode next-event weight, exp(-|z|/|v_z|) and 1/|v_z|)."""
    omega, g = 0.9, 0.5
    rows, items = [], []
    for alpha in ALPHAS:
        bsdf = rough_bsdf(alpha)
        for to in settings["single_theta_o"]:
            lights, index = light_set(to, THETA_I, product_phis)
            est = run(("single", alpha, omega, g, to),
                      lambda name: estimate(name, bsdf, omega, g, to, lights, settings["single"],
                                            single=True))
            for k, l in enumerate(lights):
                ref, ref_se = single_scattering_by_eval(bsdf, alpha, omega, g, direction(to), l,
                                                        settings["quadrature_samples"],
                                                        ("single quadrature", alpha, to, k))
                ti, ph = next(key for key, kk in sorted(index.items()) if kk == k)
                rows.append([alpha, ti, to, ph, est["mean"][k], est["se"][k], ref, ref_se])
                items.append(([(est, k, 1.0)], ref, ref_se))
    s, _ = z_check(items, f"single scattering (omega {omega}, g {g}): tracer vs eval() integral")
    return {"values_layout": ["alpha", "theta_i_deg", "theta_o_deg", "phi_deg", "f", "f_se",
                              "integral", "integral_se"], "values": rows, **s}


def check_null_boundary(settings, run):
    """Index-matched boundary: the tracer must reproduce exact semi-infinite results."""
    out = {}
    # Chandrasekhar: f = omega H(mu) H(mu0) / (4 pi (mu + mu0)) (BRDF = R / pi, docs/physics.md).
    omega = 0.9
    theta_is = [0.0, 30.0, 60.0, 80.0]
    h = {t: float(h_function(math.cos(math.radians(t)), omega))
         for t in set(settings["null_theta_o"]) | set(theta_is)}
    rows, items = [], []
    for to in settings["null_theta_o"]:
        lights, index = light_set(to, theta_is, lambda _: [0.0, 180.0])
        est = run(("null-chandrasekhar", omega, 0.0, to),
                  lambda name: estimate(name, None, omega, 0.0, to, lights, settings["null"]))
        for (ti, ph), k in sorted(index.items()):
            mu, mu0 = math.cos(math.radians(to)), math.cos(math.radians(ti))
            exact = omega * h[to] * h[ti] / (4.0 * math.pi * (mu + mu0))
            rows.append([ti, to, ph, est["mean"][k], est["se"][k], exact])
            items.append(([(est, k, 1.0)], exact, 0.0))
    s, _ = z_check(items, "null boundary, isotropic omega 0.9 vs Chandrasekhar's H")
    out["chandrasekhar_isotropic_omega0.9"] = {
        "values_layout": ["theta_i_deg", "theta_o_deg", "phi_deg", "f", "f_se", "exact"],
        "values": rows, **s}
    # DISORT (disort_hg_rayleigh.json): HG g = 0.5, omega 0.9, converged to 1e-6; checks the
    # direction convention of the phase function, which the isotropic case cannot.
    with open(os.path.join(HERE, "disort_hg_rayleigh.json")) as f:
        disort = json.load(f)
    case = next(c for c in disort["cases"] if c["label"] == "hg0.5" and abs(c["omega"] - 0.9) < 1e-12)
    if not case["converged"]:
        fail("disort_hg_rayleigh.json: hg0.5 omega 0.9 is not marked converged")
    table = {(v[0], v[1], v[2]): v[3] for v in case["values"]}
    theta_is = sorted({k[0] for k in table})
    phis = sorted({k[2] for k in table})
    rows, items = [], []
    for to in sorted({k[1] for k in table}):
        if to not in settings["null_disort_theta_o"]:
            continue
        lights, index = light_set(to, theta_is, lambda _: phis)
        est = run(("null-disort", 0.9, 0.5, to),
                  lambda name: estimate(name, None, 0.9, 0.5, to, lights, settings["null"]))
        for (ti, ph), k in sorted(index.items()):
            ref = table[(ti, to, ph)]
            rows.append([ti, to, ph, est["mean"][k], est["se"][k], ref])
            items.append(([(est, k, 1.0)], ref, 0.0))
    s, _ = z_check(items, "null boundary, HG g 0.5 omega 0.9 vs DISORT")
    out["disort_hg0.5_omega0.9"] = {
        "values_layout": ["theta_i_deg", "theta_o_deg", "phi_deg", "f", "f_se", "disort"],
        "values": rows, **s}
    out["pass"] = all(v["pass"] for v in out.values())
    return out


# ---------------------------------------------------------------------------------------------
# The product values

def run_case(alpha, omega, g, settings, run, tag="main", theta_os=None):
    """All values of one case; also returns {(theta_i, theta_o, phi): (estimate, light index)}."""
    bsdf = rough_bsdf(alpha)
    rows, tasks, where = [], [], {}
    for to in (theta_os or settings["theta_o"]):
        lights, index = light_set(to, THETA_I, product_phis)
        est = run((tag, alpha, omega, g, to),
                  lambda name: estimate(name, bsdf, omega, g, to, lights, settings["main"]))
        keys = sorted(index)
        surface = surface_values(bsdf, [(ti, to, ph) for ti, ph in keys])
        for (ti, ph), fs in zip(keys, surface):
            k = index[(ti, ph)]
            body, body_se = est["mean"][k], est["se"][k]
            rows.append([ti, to, ph, sig(fs + body), sig(body_se), sig(fs), sig(body), sig(body_se),
                         sig(est["spread"][k], 4)])
            where[(ti, to, ph)] = (est, k)
        tasks.append({"theta_o_deg": to, "lights": len(lights), "batches": est["batches"],
                      "paths_per_batch": est["lanes_per_batch"],
                      "mean_events_per_path": round(est["mean_events"], 1),
                      "cpu_seconds": est["cpu_seconds"]})
    rows.sort(key=lambda r: (r[0], r[1], r[2]))
    return {"alpha": alpha, "omega": omega, "g": g, "values": rows, "tasks": tasks}, where


def check_boundary_nee(wheres, cases):
    """Our estimator (next-event estimation at volume vertices, the light's refraction sampled in
    importance mode) against the one of Mitsuba's stock volpath (next-event estimation through the
    BSDF's radiance-mode eval() where a path meets the boundary from below), on the same paths. The
    second shares none of the first one's next-event code (importance-mode sampling, transmittance
    exp(-|z|/|v_z|), the 1/|v_z|) but is heavy-tailed (per-path kurtosis ~2000 at alpha 0.1: the
    peaked eval()), so its per-value error bars are unreliable (docs/monte-carlo.md). The test is
    therefore on the mean relative difference over each case's values, an average of hundreds of
    batch means, with its se from the batch covariances of the differences."""
    rel, rel_se, per_value = [], [], []
    for where, case in zip(wheres, cases):
        tasks = {}
        for est, k in where.values():
            tasks.setdefault(est["name"], (est, set()))[1].add(k)
        means, variances = [], []
        for est, ks in tasks.values():
            ks = sorted(ks)
            w = np.zeros(len(est["mean"]))
            w[ks] = 1.0 / (len(ks) * np.asarray(est["mean"])[ks])
            check = est["boundary_nee_check"]
            means.append(float(w @ np.asarray(check["mean"])))
            variances.append(float(w @ np.asarray(check["cov"]) @ w))
            per_value += [check["mean"][k] / math.sqrt(check["cov"][k][k]) for k in ks]
        rel.append(float(np.mean(means)))
        rel_se.append(math.sqrt(sum(variances)) / len(variances))
        print(f"  alpha {case['alpha']} omega {case['omega']} g {case['g']}: (ours - volpath-style) / "
              f"ours = {rel[-1]:+.2%} +- {rel_se[-1]:.2%}")
    z = np.array(rel) / np.array(rel_se)
    chi2 = float(np.mean(z * z))
    bound = 1.0 + 4.0 * math.sqrt(2.0 / len(z))
    ok = bool(np.max(np.abs(z)) < MAX_ABS_Z and chi2 < bound)
    print(f"  body: volume-vertex NEE vs volpath-style boundary-vertex NEE, mean relative difference "
          f"per case: max |z| {np.max(np.abs(z)):.2f}, chi2/n {chi2:.2f} (bound {bound:.2f}) -> "
          f"{'ok' if ok else 'FAILED'}; per value (not a criterion) max |z| "
          f"{np.max(np.abs(per_value)):.2f}, chi2/n {np.mean(np.square(per_value)):.2f}", flush=True)
    return {"cases": [{"alpha": c["alpha"], "omega": c["omega"], "g": c["g"], "rel_diff": r,
                       "rel_diff_se": s} for c, r, s in zip(cases, rel, rel_se)],
            "max_abs_z": float(np.max(np.abs(z))), "max_abs_z_bound": MAX_ABS_Z,
            "chi2_per_case": chi2, "chi2_bound": bound,
            "per_value_max_abs_z": float(np.max(np.abs(per_value))),
            "per_value_chi2": float(np.mean(np.square(per_value))), "pass": ok}


def check_system_reciprocity(wheres):
    """f(theta_i, theta_o, phi) = f(theta_o, theta_i, phi) for the body part: the two values come from
    different viewers, i.e. different paths and a different use of the BSDF (sampled entry vs
    next-event exit)."""
    items = []
    for where in wheres:
        for (ti, to, ph), (est, k) in where.items():
            if ti < to and (to, ti, ph) in where:
                other, ko = where[(to, ti, ph)]
                items.append(([(est, k, 1.0), (other, ko, -1.0)], 0.0, 0.0))
    s, _ = z_check(items, "reciprocity of the body part, f(i, o, phi) vs f(o, i, phi)")
    return s


def check_repeat(settings, run, first_where):
    alpha, omega, g = REPEAT_CASE
    theta_os = settings["theta_o"]
    second, where = run_case(alpha, omega, g, settings, run, tag="repeat", theta_os=theta_os)
    items = [([(est, k, 1.0), (first_where[key][0], first_where[key][1], -1.0)], 0.0, 0.0)
             for key, (est, k) in where.items()]
    s, _ = z_check(items, f"two independent runs of alpha {alpha} omega {omega} g {g}")
    return {"case": {"alpha": alpha, "omega": omega, "g": g, "theta_o_deg": theta_os},
            "second_run_values_layout": ["theta_i_deg", "theta_o_deg", "phi_deg", "body", "body_se"],
            "second_run_values": [[r[0], r[1], r[2], r[6], r[7]] for r in second["values"]], **s}


def check_spread(cases, batches):
    """Error bars from batch means vs from the per-path spread: with B independent batches of
    independent paths their ratio scatters by about 1 / sqrt(2 (B - 1)) around 1. The values of one
    estimate share paths, so the mean ratio is tested with one average per estimate."""
    ratios = np.array([r[8] for c in cases for r in c["values"]])
    per_task = [np.mean([r[8] for r in c["values"] if r[1] == t["theta_o_deg"]])
                for c in cases for t in c["tasks"]]
    rel = np.array([r[7] / r[6] for c in cases for r in c["values"]])
    width = 1.0 / math.sqrt(2.0 * (batches - 1))
    mean_bound = 4.0 * width / math.sqrt(len(per_task))
    ok = bool(abs(np.mean(per_task) - 1.0) < mean_bound and ratios.min() > 1 - 4.5 * width
              and ratios.max() < 1 + 5 * width)
    print(f"  error bars: batch-mean se / per-path se mean {np.mean(per_task):.3f} (1 +- "
          f"{mean_bound:.3f} allowed), range [{ratios.min():.2f}, {ratios.max():.2f}] over "
          f"{len(ratios)} values (expected scatter {width:.2f}) -> {'ok' if ok else 'FAILED'}; body "
          f"relative se max {rel.max():.2%}, median {np.median(rel):.2%}")
    return {"ratio_mean": float(np.mean(per_task)), "ratio_mean_bound": mean_bound,
            "ratio_min": float(ratios.min()), "ratio_max": float(ratios.max()),
            "expected_scatter": width, "body_rel_se_max": float(rel.max()),
            "body_rel_se_median": float(np.median(rel)), "pass": ok}


# ---------------------------------------------------------------------------------------------

def settings_for(quick):
    if quick:
        return {"quick": True, "theta_o": [0.0, 30.0, 80.0], "null_theta_o": [0.0, 60.0],
                "null_disort_theta_o": [0.0, 60.0], "cases": [(0.1, 0.9, 0.0), (0.3, 0.99, 0.5)],
                "main": {"target": 0.02, "batches": 16, "min_lanes": 1024, "pilot_lanes": 1 << 13},
                "null": {"target": 0.01, "batches": 16, "min_lanes": 1024, "pilot_lanes": 1 << 13},
                "single_theta_o": [0.0, 80.0], "quadrature_samples": 1 << 20,
                "single": {"target": 0.01, "batches": 16, "min_lanes": 1024, "pilot_lanes": 1 << 13},
                "albedo_samples": 1 << 20, "reciprocity_samples": 1 << 18}
    return {"quick": False, "theta_o": THETA_O, "null_theta_o": [0.0, 20.0, 40.0, 60.0, 80.0],
            "null_disort_theta_o": [0.0, 30.0, 60.0, 80.0],
            "cases": [(a, o, g) for a in ALPHAS for o in OMEGAS for g in GS],
            "main": {"target": TARGET_REL_SE, "batches": MIN_BATCHES, "min_lanes": 4096,
                     "pilot_lanes": PILOT_LANES},
            "null": {"target": NULL_TARGET_REL_SE, "batches": MIN_BATCHES, "min_lanes": 4096,
                     "pilot_lanes": PILOT_LANES},
            "single_theta_o": [0.0, 40.0, 80.0], "quadrature_samples": 1 << 22,
            "single": {"target": 0.002, "batches": MIN_BATCHES, "min_lanes": 4096,
                       "pilot_lanes": PILOT_LANES},
            "albedo_samples": 1 << 23, "reciprocity_samples": 1 << 20}


def write_json_atomic(path, data, indent=1):
    """Writes through a temporary and a rename: a crash never leaves a truncated file. Lists of
    plain numbers and strings (the value rows) stay on one line."""
    text = json.dumps(data, indent=indent)
    if indent is not None:
        text = re.sub(r"\[\n\s*([^\[\]{}]*?)\n\s*\]",
                      lambda m: "[" + re.sub(r",\n\s*", ", ", m.group(1)) + "]", text)
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text + "\n")
    os.replace(tmp, path)


def sig(x, digits=7):
    """Rounds to float32-meaningful digits for the output."""
    return float(f"{x:.{digits}g}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="small configuration to validate the script (minutes)")
    parser.add_argument("--output", help="output JSON (default: mitsuba_rough_slab.json beside this "
                                         "script; /tmp/mitsuba_rough_slab_quick.json with --quick)")
    args = parser.parse_args()
    settings = settings_for(args.quick)
    output = args.output or (os.path.join(HERE, "mitsuba_rough_slab.json") if not args.quick
                             else "/tmp/mitsuba_rough_slab_quick.json")
    partial_path = output + ".partial"
    with open(os.path.abspath(__file__), "rb") as f:
        source_hash = hashlib.sha256(f.read()).hexdigest()
    # The partial file is reused only by the same script text, settings and Mitsuba.
    fingerprint = hashlib.sha256(json.dumps(
        [source_hash, settings, mi.__version__, dr.__version__], default=str).encode()).hexdigest()[:16]
    done = {}
    if os.path.exists(partial_path):
        try:
            with open(partial_path) as f:
                saved = json.load(f)
            if saved.get("fingerprint") == fingerprint:
                done = saved["tasks"]
                print(f"resuming from {partial_path}: {len(done)} tasks done")
            else:
                print(f"ignoring {partial_path}: made with other settings")
        except (OSError, ValueError, KeyError):
            print(f"ignoring {partial_path}: unreadable")

    def run(key, compute):
        """One estimate, unless the partial file has it; the partial file is saved after each."""
        name = json.dumps(key)
        if name not in done:
            done[name] = compute(name)
            write_json_atomic(partial_path, {"fingerprint": fingerprint, "tasks": done}, indent=None)
            r = done[name]
            print(f"  {name}: {r['batches']} x {r['lanes_per_batch']} paths, "
                  f"{r['mean_events']:.0f} events/path, max rel se "
                  f"{max(s / m for s, m in zip(r['se'], r['mean'])):.2%}, {r['seconds']} s "
                  f"({r['cpu_seconds']} s CPU)", flush=True)
        return done[name]

    start = time.time()
    checks = {}
    print("checks of the parts:")
    checks["bsdf_reciprocity"] = check_bsdf_reciprocity(settings)
    grid = [(ti, to, ph) for ti in THETA_I for to in settings["theta_o"] for ph in product_phis(to)]
    checks["surface_scalar_vs_llvm"] = check_surface_scalar(grid)
    checks["bsdf_albedo"] = check_albedo(settings)
    print("single scattering under the rough boundary:")
    checks["single_scattering"] = check_single_scattering(settings, run)
    print("null (index-matched) boundary:")
    checks["null_boundary"] = check_null_boundary(settings, run)
    print("rough boundary cases:")
    cases, wheres = [], []
    for alpha, omega, g in settings["cases"]:
        print(f" alpha {alpha} omega {omega} g {g}", flush=True)
        case, where = run_case(alpha, omega, g, settings, run)
        cases.append(case)
        wheres.append(where)
    print("checks of the estimates:")
    repeat_index = settings["cases"].index(REPEAT_CASE)
    checks["repeat_run"] = check_repeat(settings, run, wheres[repeat_index])
    checks["system_reciprocity"] = check_system_reciprocity(wheres)
    checks["volpath_style_estimator"] = check_boundary_nee(wheres, cases)
    checks["error_bar_spread"] = check_spread(cases, settings["main"]["batches"])
    failed = [name for name, c in checks.items() if not c["pass"]]
    out = {
        "source": f"{SCRIPT} (Mitsuba {mi.__version__}, drjit {dr.__version__}, variant "
                  f"{mi.variant()})",
        "generated": datetime.date.today().isoformat(),
        "command": "nice -n 15 python3 " + SCRIPT + (" --quick" if args.quick else ""),
        "quick": args.quick,
        "units": "BRDF in 1/sr: f_r = L_o / cos(theta_i) for a directional light of irradiance 1 "
                 "(on a plane perpendicular to its direction)",
        "conventions": "theta_i, theta_o: polar angles (degrees) from the surface normal; phi = "
                       "phi_o - phi_i (degrees), the graphics convention of docs/design.md: phi = 0 "
                       "the viewer is on the light's side (retro-reflection at theta_o = theta_i), "
                       "phi = 180 the mirror side. At theta_i = 0 phi is immaterial: the grid still "
                       "lists every phi, and those rows (one light, same paths) are identical.",
        "model": {
            "medium": "homogeneous half-space z < 0, sigma_t = 1 (lengths in mean free paths), "
                      "single-scattering albedo omega, Henyey-Greenstein phase function (Mitsuba "
                      "'hg', g > 0 forward scattering, normalised per steradian)",
            "boundary": {"bsdf": "roughdielectric", "distribution": "ggx",
                         "alpha": "per case (isotropic)", "int_ior": INT_IOR, "ext_ior": EXT_IOR,
                         "sample_visible": True, "plane": "z = 0, normal +z out of the medium"},
            "shadowing_masking": "separable Smith G = G1(wi, m) G1(wo, m) (Walter et al. 2007 eq. 23 "
                                 "with the GGX G1 of eq. 34), Mitsuba 3's MicrofacetDistribution::G; "
                                 "not the height-correlated form",
            "energy_loss": "single-scattering microfacet model: it loses energy (checks.bsdf_albedo); "
                           "the reference values include that loss",
            "precision": "float32 throughout (Mitsuba has no double variants); the surface is at "
                         "z = 0 and depths are in mean free paths",
        },
        "estimator": {
            "surface": "f_s = roughdielectric eval(viewer, light) / cos(theta_i) in radiance mode, "
                       "no sampling: only float32 rounding (its se is 0)",
            "body": "paths from the viewer: transmission lobe sampled into the medium (radiance "
                    "mode), exponential free paths, HG sampling at volume vertices, reflection lobe "
                    "sampled where a path meets the boundary from below; at each volume vertex "
                    "next-event estimation to the light through the rough boundary, its refraction "
                    "sampled by the BSDF in importance mode (the half-space is translation "
                    "invariant): throughput * phase * exp(-|z| / |v_z|) * weight / |v_z|",
            "absorption": "a weight omega per volume vertex",
            "russian_roulette": f"only once the throughput is below {RR_LEVEL}; survivors carry "
                                f"exactly {RR_LEVEL} (docs/monte-carlo.md: roulette from depth 5 "
                                "biases high albedos)",
            "error_bars": "se = standard error of the means of B >= "
                          f"{settings['main']['batches']} independent batches (PCG32 seeds from "
                          "SHA-256 of the estimate and batch index); a pilot batch (discarded) sets "
                          "the batch size for the target. The values at one theta_o come from the "
                          "same paths (one path serves every light), so they are correlated",
            "target_body_rel_se": settings["main"]["target"],
        },
        "values_layout": ["theta_i_deg", "theta_o_deg", "phi_deg", "f", "f_se", "surface", "body",
                          "body_se", "spread"],
        "values_note": "f = surface + body (1/sr); f_se = body_se (the surface part is exact); "
                       "spread = batch-mean se / per-path se (about 1 for honest error bars)",
        "cases": cases,
        "checks": checks,
        "pass": not failed,
        "run_seconds": {"wall": round(time.time() - start), "cpu": round(time.process_time())},
    }
    if failed:
        fail(f"check(s) failed: {', '.join(failed)}; {output} not written ({partial_path} kept)")
    write_json_atomic(output, out)
    os.remove(partial_path)
    print(f"wrote {output} ({round(time.time() - start)} s)")


if __name__ == "__main__":
    main()
