#!/usr/bin/env python3
"""Mitsuba 3 loads our RGL BSDF files (`NAME.rgl.bsdf`) and evaluates them as we do.

For each case (a JSON file beside its .rgl.bsdf, written by tests/formats/rgl_mitsuba_cases.cpp or
by anything else that writes the same keys) this loads the file with Mitsuba's `measured` plugin in
a CPU variant (`scalar_rgb` for RGB files, `scalar_spectral` for spectral ones) and calls BSDF.eval at
every direction pair of the case. Mitsuba's eval is f(wi, wo) cos(theta_o) (its BSDFs include the
cosine), so:

- accuracy: eval / cos(theta_o) against the model's BRDF ("reference_brdf", 1/sr), relative
  difference |a - b| / max(|b|, 1e-4 1/sr); cases with "enforce": true must reach a median <= 1 % and
  a 95th percentile <= 5 % (--median, --p95);
- agreement: eval against our evaluator's value ("ours_eval_cosine", formats/rgl/rgl_eval.h), relative
  difference with a floor of 1e-6 of the case's largest value; every case must agree within 1e-4
  (--agreement): float rounding, which pins our reading of the format;
- sampling (enforced cases with "albedo"): BSDF.sample at a fixed incidence, 4000 stratified
  samples; the mean weight estimates the directional albedo and must match the model's within
  4 standard errors + 2 % (the file's own interpolation error), every weight must be finite and
  >= 0, and BSDF.pdf at the sampled direction must equal the sample's pdf (1e-3): Mitsuba's
  luminance and visible-normal warps of our files are consistent and unbiased.

Case keys: name, bsdf (path relative to the JSON), variant, enforce, pairs ([wi x y z, wo x y z],
unit vectors, z up, pointing away from the surface), reference_brdf and ours_eval_cosine (one list of
channel values per pair), wavelengths_nm (spectral). "ours_eval_cosine" may be omitted (then only the
accuracy is checked), which is how the same script checks tables made elsewhere.

Mitsuba: PyPI `mitsuba` 3.9.x (docs/monte-carlo.md: the scalar variants work as installed; the llvm
ones need a newer LLVM than Debian 12's). When `import mitsuba` fails or finds another version, 3.9.x
is installed with pip into WORK_DIR/pydeps (not into the system). When that fails too (no network),
the script prints why and exits 77, which CTest reports as skipped.

Usage:
  mitsuba_measured_check.py --generator BUILD/bin/rgl_mitsuba_cases --work-dir DIR
  mitsuba_measured_check.py CASE.json ...
  mitsuba_measured_check.py --generator BIN --work-dir DIR --write-reference FILE
    (writes Mitsuba's values for two small cases; tests/formats/rgl_test.cpp compares our evaluator
    with them without Mitsuba: tests/reference/formats/mitsuba_measured_reference.json)
"""
import argparse
import glob
import importlib
import json
import math
import os
import subprocess
import sys
import time

SKIP = 77
MITSUBA_REQUIREMENT = "mitsuba>=3.9,<3.10"


def skip(reason):
    print(f"SKIP: {reason}")
    sys.exit(SKIP)


def import_mitsuba(work_dir):
    """Mitsuba 3.9.x, installed into work_dir/pydeps when missing or of another version."""
    try:
        import mitsuba
        if mitsuba.__version__.startswith("3.9."):
            return mitsuba
        print(f"found mitsuba {mitsuba.__version__}; installing 3.9.x beside the test")
    except ImportError:
        print("mitsuba is not installed; installing 3.9.x beside the test")
    target = os.path.join(work_dir, "pydeps")
    os.makedirs(target, exist_ok=True)
    command = [sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
               "--target", target, MITSUBA_REQUIREMENT]
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    except (OSError, subprocess.TimeoutExpired) as e:
        skip(f"cannot run pip: {e}")
    if result.returncode != 0:
        tail = (result.stderr or result.stdout).strip().splitlines()[-1:] or ["(no output)"]
        skip(f"pip could not install {MITSUBA_REQUIREMENT}: {tail[0]}")
    sys.path.insert(0, target)
    for name in [m for m in sys.modules if m == "mitsuba" or m.startswith(("mitsuba.", "drjit"))]:
        del sys.modules[name]
    try:
        mitsuba = importlib.import_module("mitsuba")
    except ImportError as e:
        skip(f"mitsuba installed but cannot be imported: {e}")
    if not mitsuba.__version__.startswith("3.9."):
        skip(f"pip installed mitsuba {mitsuba.__version__}, not 3.9.x")
    return mitsuba


def quantile(sorted_values, q):
    if not sorted_values:
        return 0.0
    index = min(len(sorted_values) - 1, int(q * (len(sorted_values) - 1) + 0.5))
    return sorted_values[index]


def sampling_faults(mi, evaluator, case, samples=4000):
    """Mean sample weight against the model's albedo, at each incidence of case["albedo"]."""
    faults, report = [], []
    bsdf, ctx = evaluator.bsdf, evaluator.ctx
    side = int(round(samples ** 0.5))
    for entry in case["albedo"]:
        theta = math.radians(entry["theta_i_deg"])
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(math.sin(theta), 0.0, math.cos(theta))
        channels = len(entry["albedo"])
        sums = [0.0] * channels
        squares = [0.0] * channels
        worst_pdf = 0.0
        bad_weights = 0
        for a in range(side):
            for b in range(side):
                u = mi.Point2f((a + 0.5) / side, (b + 0.37) / side)
                if evaluator.spectral:
                    group_weights = []
                    for start in range(0, channels, 4):
                        group = evaluator.wavelengths[start:start + 4]
                        si.wavelengths = mi.Spectrum(group + [group[-1]] * (4 - len(group)))
                        bs, w = bsdf.sample(ctx, si, 0.5, u)
                        group_weights.extend(float(w[k]) for k in range(len(group)))
                    weights = group_weights
                else:
                    bs, w = bsdf.sample(ctx, si, 0.5, u)
                    weights = [float(w[0]), float(w[1]), float(w[2])]
                # sample() keeps the pdf of directions it then rejects below the horizon.
                if bs.pdf > 0 and bs.wo.z > 0:
                    pdf = float(bsdf.pdf(ctx, si, bs.wo))
                    worst_pdf = max(worst_pdf, abs(pdf - float(bs.pdf)) / float(bs.pdf))
                for c, w in enumerate(weights):
                    if not (w >= 0.0 and math.isfinite(w)):
                        bad_weights += 1
                        continue
                    sums[c] += w
                    squares[c] += w * w
        n = side * side
        worst = 0.0
        for c in range(channels):
            mean = sums[c] / n
            stderr = math.sqrt(max(squares[c] / n - mean * mean, 0.0) / n)
            ref = entry["albedo"][c]
            excess = abs(mean - ref) / (4.0 * stderr + 0.02 * ref)
            worst = max(worst, excess)
            if excess > 1.0:
                faults.append(f"theta_i {entry['theta_i_deg']}: mean weight {mean:.4g} in channel "
                              f"{c}, model albedo {ref:.4g} (4 standard errors {4 * stderr:.2g})")
                break
        if bad_weights:
            faults.append(f"theta_i {entry['theta_i_deg']}: {bad_weights} weights NaN, inf or < 0")
        if worst_pdf > 1e-3:
            faults.append(f"theta_i {entry['theta_i_deg']}: pdf() differs from the sample's pdf "
                          f"by {worst_pdf:.2g}")
        report.append(f"{entry['theta_i_deg']:.0f} deg: {worst:.2f}")
    return faults, ", ".join(report)


class MitsubaEvaluator:
    """BSDF.eval of one file, per pair and channel (every wavelength of a spectral file)."""

    def __init__(self, mi, case, path):
        self.mi = mi
        self.spectral = case["variant"] == "scalar_spectral"
        mi.set_variant(case["variant"])
        self.bsdf = mi.load_dict({"type": "measured", "filename": path})
        self.ctx = mi.BSDFContext()
        self.wavelengths = case.get("wavelengths_nm", [])

    def eval(self, pair):
        mi = self.mi
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(pair[0], pair[1], pair[2])
        wo = mi.Vector3f(pair[3], pair[4], pair[5])
        if not self.spectral:
            v = self.bsdf.eval(self.ctx, si, wo)
            return [float(v[0]), float(v[1]), float(v[2])]
        # Spectral variants carry four wavelengths per evaluation.
        out = []
        wl = self.wavelengths
        for start in range(0, len(wl), 4):
            group = wl[start:start + 4]
            si.wavelengths = mi.Spectrum(group + [group[-1]] * (4 - len(group)))
            v = self.bsdf.eval(self.ctx, si, wo)
            out.extend(float(v[k]) for k in range(len(group)))
        return out


def check_case(mi, case_path, args):
    with open(case_path) as f:
        case = json.load(f)
    bsdf_path = os.path.join(os.path.dirname(os.path.abspath(case_path)), case["bsdf"])
    evaluator = MitsubaEvaluator(mi, case, bsdf_path)
    accuracy, agreement = [], []
    ours = case.get("ours_eval_cosine")
    scale = max((abs(v) for values in ours for v in values), default=0.0) if ours else 0.0
    for k, pair in enumerate(case["pairs"]):
        values = evaluator.eval(pair)
        cos_o = pair[5]
        for c, v in enumerate(values):
            ref = case["reference_brdf"][k][c]
            accuracy.append(abs(v / cos_o - ref) / max(abs(ref), 1e-4))
            if ours:
                o = ours[k][c]
                agreement.append(abs(v - o) / max(abs(o), 1e-6 * scale))
    accuracy.sort()
    result = {
        "name": case["name"],
        "enforce": bool(case.get("enforce", False)),
        "theta_i_count": case.get("theta_i_count"),
        "sample_resolution": case.get("sample_resolution"),
        "values": len(accuracy),
        "median": quantile(accuracy, 0.5),
        "p95": quantile(accuracy, 0.95),
        "max": accuracy[-1] if accuracy else 0.0,
        "agreement_max": max(agreement) if agreement else None,
    }
    faults = []
    if result["enforce"] and result["median"] > args.median:
        faults.append(f"median {result['median']:.3g} > {args.median}")
    if result["enforce"] and result["p95"] > args.p95:
        faults.append(f"95th percentile {result['p95']:.3g} > {args.p95}")
    if agreement and result["agreement_max"] > args.agreement:
        faults.append(f"our evaluator differs by {result['agreement_max']:.3g} > {args.agreement}")
    if result["enforce"] and "albedo" in case:
        sample_faults, result["sampling"] = sampling_faults(mi, evaluator, case)
        faults += sample_faults
    result["faults"] = faults
    return result


def write_reference(mi, work_dir, path):
    """Mitsuba's eval at 64 pairs of the two coarse glossy cases, for tests/formats/rgl_test.cpp."""
    out = {"mitsuba_version": mi.__version__,
           "made_by": "tests/reference/formats/mitsuba_measured_check.py --write-reference",
           "cases": []}
    for name in ["glossy-rgb-coarse", "glossy-spectral-coarse"]:
        with open(os.path.join(work_dir, name + ".json")) as f:
            case = json.load(f)
        evaluator = MitsubaEvaluator(mi, case, os.path.join(work_dir, case["bsdf"]))
        pairs = case["pairs"][:64]
        out["cases"].append({"name": name, "pairs": pairs,
                             "mitsuba_eval": [evaluator.eval(p) for p in pairs]})
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    print(f"wrote {path}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases", nargs="*", help="case JSON files")
    parser.add_argument("--generator", help="rgl_mitsuba_cases: writes the cases into --work-dir")
    parser.add_argument("--work-dir", default=".", help="where cases are written and pip installs")
    parser.add_argument("--median", type=float, default=0.01)
    parser.add_argument("--p95", type=float, default=0.05)
    parser.add_argument("--agreement", type=float, default=1e-4)
    parser.add_argument("--write-reference", metavar="FILE")
    args = parser.parse_args()

    start = time.time()
    os.makedirs(args.work_dir, exist_ok=True)
    mi = import_mitsuba(args.work_dir)
    for variant in ("scalar_rgb", "scalar_spectral"):
        if variant not in mi.variants():
            skip(f"mitsuba {mi.__version__} lacks the {variant} variant")
    cases = list(args.cases)
    if args.generator:
        # Cases are the .rgl.bsdf files with a JSON beside them; old ones are removed first.
        for old in glob.glob(os.path.join(args.work_dir, "*.rgl.bsdf")):
            for stale in (old, old[:-len(".rgl.bsdf")] + ".json"):
                if os.path.exists(stale):
                    os.remove(stale)
        generated = subprocess.run([args.generator, args.work_dir], text=True, capture_output=True)
        if generated.returncode != 0:
            print(generated.stdout + generated.stderr)
            print(f"FAIL: {args.generator} exited with {generated.returncode}")
            return 1
        print("our evaluator against the model (rgl_mitsuba_cases):")
        print(generated.stdout, end="")
        cases += sorted(f[:-len(".rgl.bsdf")] + ".json"
                        for f in glob.glob(os.path.join(args.work_dir, "*.rgl.bsdf")))
    if args.write_reference:
        write_reference(mi, args.work_dir, args.write_reference)
        return 0
    if not cases:
        parser.error("no cases: give case files or --generator")

    print(f"\nMitsuba {mi.__version__} `measured` against the model, and against our evaluator:")
    print(f"{'case':28s} {'nodes':>7s} {'median':>9s} {'p95':>9s} {'max':>9s} {'vs ours':>9s}")
    failed = []
    results = []
    for path in cases:
        r = check_case(mi, path, args)
        results.append(r)
        nodes = f"{r['theta_i_count']}x{r['sample_resolution']}"
        agreement = "-" if r["agreement_max"] is None else f"{r['agreement_max']:.2e}"
        mark = " (enforced)" if r["enforce"] else ""
        if "sampling" in r:
            mark += f" sampling |mean - albedo| / tolerance: {r['sampling']}"
        print(f"{r['name']:28s} {nodes:>7s} {r['median']:9.2e} {r['p95']:9.2e} {r['max']:9.2e} "
              f"{agreement:>9s}{mark}")
        if r["faults"]:
            failed.append(f"{r['name']}: " + "; ".join(r["faults"]))
    with open(os.path.join(args.work_dir, "mitsuba_measured_results.json"), "w") as f:
        json.dump({"mitsuba_version": mi.__version__, "results": results}, f, indent=1)
    print(f"\n{len(cases)} cases in {time.time() - start:.1f} s")
    for line in failed:
        print(f"FAIL: {line}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
