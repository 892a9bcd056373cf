#!/usr/bin/env python3
"""What a user waits for, measured side by side in one run: writes docs/benchmarks.md.

    python3 bench/interactive.py [--brdftool build/bin/brdftool] [--repeat 3] [--doc docs/benchmarks.md]

Each row runs the real command line (`brdftool compute`, `eval`, `render`, `lobes`) as a user would,
on the default device, `--repeat` times (medians; the slow rows once), and prints the wall time,
the peak resident memory of the process and the accuracy next to it:

- the seed material (rutile in acrylic, visible spectrum, MERL + EXR) at "default" and
  "reference", and the same paint under the gloss, satin and matte finishes (each alternating
  with the smooth paint: the ratio of their medians);
  at "default" also with its Mie ensembles on disk from the run before (a re-run after an edit);
- the full 90 x 90 x 180 table of an analytic HG g = 0.5, omega = 0.99 half-space at tolerance
  1e-6, against DISORT (cdisort via pydisort, 32 streams) computing the same grid, alternating;
- eval throughput (200,000 random directions from stdin; the interpolant's error against
  `eval --exact`), render 512 x 512, lobes of two specs;
- matting agents: silica spheres r_eff 5 um and 40 um (v_eff 0.1) in acrylic (40 um also with its
  Mie ensembles on disk).

Each run starts with the disk flushed (os.sync): a run's own fsync of its tables is timed, the
write-back of the runs before it is not. Each `compute` writes into an empty folder, as a new
material's first run does: the run before's tables are deleted untimed (deleting a 35 MB table
waits for the disk to discard its blocks where the file system is mounted with `discard`, ~9 ms
here). One row times the seed replacing its own tables (`--force` into the same folder).

Needs numpy; pydisort for the DISORT row (skipped, and said so, without it).
"""
import argparse
import atexit
import datetime
import json
import math
import os
import platform
import random
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

SEED = {
    "binder": {"material": "pmma"},
    "pigments": [{"material": "tio2-rutile", "volume_fraction": 0.10,
                  "size": {"distribution": "power_law", "r_eff_um": 0.4, "v_eff": 0.3}}],
    "surface": "smooth", "spectrum": "visible", "accuracy": "default", "outputs": ["merl", "exr"],
}
HG = {"medium": {"albedo": 0.99, "phase": {"type": "henyey_greenstein", "g": 0.5}},
      "accuracy": {"tolerance": 1e-6}, "spectrum": "rgb", "outputs": ["merl"]}


def spec(work, name, base, **changes):
    s = dict(base, name=name, **changes)
    path = os.path.join(work, name + ".json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


def measure(cmd, stdin_text=None, timeout=900, mie_on_disk=False, empty_folder=None):
    """Runs cmd in a fresh Python child so ru_maxrss is this command's alone. The disk is flushed
    first: every `compute` fsyncs its tables (35 MB of MERL), and with the runs before still being
    written back that fsync waited for them too (the HG row took 0.20-0.43 s within one run).
    The Mie ensembles kept on disk (docs/mie.md) are dropped first unless mie_on_disk: a row is a
    new material unless it says otherwise. `empty_folder` (a compute's output folder) is deleted
    first, untimed."""
    if not mie_on_disk:
        shutil.rmtree(os.path.join(os.environ["BRDF_CACHE_DIR"], "mie"), ignore_errors=True)
    if empty_folder:
        shutil.rmtree(empty_folder, ignore_errors=True)
    os.sync()
    helper = ("import json,resource,subprocess,sys,time;"
              "a=json.loads(sys.argv[1]);i=open(a['stdin']).read() if a['stdin'] else None;"
              "t=time.perf_counter();"
              "p=subprocess.run(a['cmd'],input=i,capture_output=True,text=True);"
              "w=time.perf_counter()-t;"
              "print(json.dumps({'rc':p.returncode,'wall':w,'rss':resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss,"
              "'out':p.stdout,'err':p.stderr[-600:]}))")
    stdin_file = None
    if stdin_text is not None:
        with tempfile.NamedTemporaryFile("w", suffix=".txt", delete=False) as f:
            f.write(stdin_text)
            stdin_file = f.name
    try:
        res = subprocess.run([sys.executable, "-c", helper, json.dumps({"cmd": cmd, "stdin": stdin_file})],
                             capture_output=True, text=True, timeout=timeout)
    finally:
        if stdin_file:
            os.unlink(stdin_file)
    r = json.loads(res.stdout)
    if r["rc"] != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({r['rc']}): {r['err'].strip()}")
    return r["wall"], r["rss"] / 1024.0, r["out"]


def compute(tool, spec_file, out, replace=False, **kw):
    """`brdftool compute SPEC -o OUT --force`: into an empty folder unless `replace`."""
    return measure([tool, "compute", spec_file, "-o", out, "--force"], empty_folder=None if replace else out, **kw)


def median_of(n, fn):
    walls, rss, last = [], [], None
    for _ in range(n):
        w, m, last = fn()
        walls.append(w)
        rss.append(m)
    return statistics.median(walls), max(rss), last


def report(out_dir, name):
    with open(os.path.join(out_dir, name + ".report.json")) as f:
        return json.load(f)


def estimate(r):
    e = r["error_estimate"]
    return f"estimate {e['solver_estimate']:.1e} (tolerance {e['requested_tolerance']:.0e}" + \
        ("" if e["tolerance_met"] else ", NOT met") + ")"


def wavelengths_solved(r):
    """How many of the spectrum's wavelengths were solved (docs/physics.md, "Every wavelength's
    single scattering")."""
    n = len(r["wavelengths"]) + r["wavelengths_interpolated"]
    only = r.get("wavelengths_single_scattering_only", 0)
    return f"{len(r['wavelengths'])} of {n} wavelengths solved" + \
        (f", the other {only} with their single scattering exact" if only else "")


def disort_grid(streams=32):
    """DISORT on the table's 90 x 90 x 180 grid of bin centres, and its wall time."""
    sys.path.insert(0, os.path.join(ROOT, "tests", "reference", "rte"))
    from disort_reference import run_disort  # noqa: E402 (needs pydisort and torch)
    g = 0.5
    count = 1
    while g ** count > 1e-16:
        count += 1
    pmom = [g ** l for l in range(1, count + 1)]
    thetas = [(k + 0.5) for k in range(90)]  # degrees, bin centres
    mus = sorted(math.cos(math.radians(t)) for t in thetas)
    phis = [(k + 0.5) * 1.0 for k in range(180)]
    rad, seconds = run_disort(streams, 0.99, pmom, [math.cos(math.radians(t)) for t in thetas], mus, phis)
    return rad, seconds, thetas, mus, phis


def blas_cores(tool):
    """The kernels OpenBLAS picked for this CPU, one per start of the program (OPENBLAS_VERBOSE=2):
    two where it fell back to Prescott's and the program executed itself again with better ones
    (src/brdf/core/serial_blas.cpp)."""
    env = dict(os.environ, OPENBLAS_VERBOSE="2")
    out = subprocess.run([tool, "--version"], capture_output=True, text=True, env=env)
    return re.findall(r"Core: (\S+)", out.stdout + out.stderr)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--brdftool", default=os.path.join(ROOT, "build", "bin", "brdftool"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--doc", default=os.path.join(ROOT, "docs", "benchmarks.md"))
    ap.add_argument("--skip-slow", action="store_true", help="leave out the reference and 40 um rows")
    a = ap.parse_args()
    tool = a.brdftool
    work = tempfile.mkdtemp(prefix="brdf-bench-")
    atexit.register(shutil.rmtree, work, True)  # its 45 MB of tables and caches, also after a failure
    out = os.path.join(work, "out")
    # The run's own cache folder: the user's is left alone, and every row starts from a known state
    # (OpenCL programs built once by the warm-up below; Mie ensembles as each row says).
    os.environ["BRDF_CACHE_DIR"] = os.path.join(work, "cache")
    rows = []

    def row(what, target, result, accuracy):
        rows.append((what, target, result, accuracy))
        print(f"{what}: {result} | {accuracy}", flush=True)

    # 1. The seed material, smooth and in each finish. Debian 12's OpenBLAS (0.3.21) falls back to
    # its generic Prescott kernels on CPUs newer than it knows (an Intel Xeon of model 207), and our
    # programs then pick the kernels of the CPU's features themselves: there the seed also runs with
    # OpenBLAS's own fallback (OPENBLAS_CORETYPE=Prescott), alternating with the default.
    seed = spec(work, "seed", SEED)
    cores = blas_cores(tool)
    core = cores[-1] if cores else None
    picked_here = len(cores) > 1
    plain_runs, forced_runs = [], []
    compute(tool, seed, out)  # warm-up: the OpenCL programs' binaries
    for _ in range(a.repeat):
        plain_runs.append(compute(tool, seed, out))
        if picked_here:
            os.environ["OPENBLAS_CORETYPE"] = "Prescott"
            try:
                forced_runs.append(compute(tool, seed, out))
            finally:
                del os.environ["OPENBLAS_CORETYPE"]
    t_seed = statistics.median(w for w, _, _ in plain_runs)
    m_seed = max(m for _, m, _ in plain_runs)
    r = report(out, "seed")
    row("seed material, `compute` at \"default\" (MERL + EXR)", "<= 0.3 s",
        f"{t_seed:.2f} s, {m_seed:.0f} MiB", estimate(r) + f", {r['solver']['streams']} streams")
    t, m, _ = median_of(a.repeat, lambda: compute(tool, seed, out, mie_on_disk=True))
    row("the same, its particles' Mie ensembles on disk from the run before (a re-run after changing the "
        "pigment amount, film, substrate or finish)", "", f"{t:.2f} s, {m:.0f} MiB", "the same tables, byte for byte")
    if picked_here:
        t = statistics.median(w for w, _, _ in forced_runs)
        row(f"the same with OpenBLAS's own fallback kernels (`OPENBLAS_CORETYPE=Prescott`; the programs pick "
            f"{core} on this CPU), a new material, alternating with the first seed row", "",
            f"{t:.2f} s (the first seed row is {t_seed / t:.2f}x this)", "tables within rounding")
    t, m, _ = median_of(a.repeat, lambda: compute(tool, seed, out, mie_on_disk=True, replace=True))
    row("the seed with its Mie ensembles on disk, replacing its own tables from the run before (`--force` "
        "into the same folder)", "", f"{t:.2f} s, {m:.0f} MiB", "the same tables, byte for byte")
    # Each finish alternates with the smooth paint, so that the ratio compares runs of one stretch of
    # time (this machine's speed drifts by 5-15 % over a minute).
    for finish in ("gloss", "satin", "matte"):
        p = spec(work, "seed-" + finish, SEED, surface=finish)
        smooth_runs, finish_runs = [], []
        for _ in range(a.repeat):
            smooth_runs.append(compute(tool, seed, out)[0])
            finish_runs.append(compute(tool, p, out))  # last: its report is read below
        t = statistics.median(w for w, _, _ in finish_runs)
        t_smooth = statistics.median(smooth_runs)
        m = max(mem for _, mem, _ in finish_runs)
        r = report(out, "seed-" + finish)
        row(f"the same, {finish} finish (alternating with the smooth paint)", "<= 2x smooth",
            f"{t:.2f} s ({t / t_smooth:.2f}x the smooth paint's {t_smooth:.2f} s in the same runs), {m:.0f} MiB",
            estimate(r) + f", {r['solver']['streams']} streams")

    # 2. A full table against DISORT, alternating.
    hg = spec(work, "hg", HG)
    try:
        ours, computed, theirs = [], [], []
        rad = None
        for _ in range(a.repeat):
            ours.append(compute(tool, hg, out)[0])
            # The computation alone, as DISORT's time is its set-up and solve: the report's optics,
            # solve (the OpenCL device's start included) and table seconds, without the process's
            # start and the 35 MB write of the table.
            sec = report(out, "hg")["seconds"]
            computed.append(sec["optics"] + sec["solve"] + sec["table"])
            rad, s, thetas, mus, phis = disort_grid()
            theirs.append(s)
        t_ours, t_disort = statistics.median(ours), statistics.median(theirs)
        t_computed = statistics.median(computed)
        # Our table's interpolant and DISORT 32 at 400 of the grid's points, both against DISORT
        # at 64 streams (untimed): DISORT 32's own error is largest at grazing incidence.
        fine = disort_grid(64)[0]
        rng = random.Random(5)
        picks = [(rng.randrange(90), rng.randrange(90), rng.randrange(180)) for _ in range(400)]
        text = "".join(f"{thetas[i]} {thetas[o]} {phis[p]}\n" for i, o, p in picks)
        _, _, ev = measure([tool, "eval", hg], text)
        vals = [float(line.split()[0]) for line in ev.split("\n") if line.strip()]
        ours_err = disort_err = 0.0
        for (i, o, p), v in zip(picks, vals):
            k = mus.index(math.cos(math.radians(thetas[o])))
            ref = fine[i, p, k]  # BRDF (run_disort: I / (mu0 FBEAM))
            ours_err = max(ours_err, abs(v - ref) / ref)
            disort_err = max(disort_err, abs(rad[i, p, k] - ref) / ref)
        row("full 90 x 90 x 180 table, HG g 0.5, omega 0.99, tolerance 1e-6: ours vs DISORT 32 streams",
            ">= 20x faster", f"{t_ours:.2f} s vs {t_disort:.2f} s: {t_disort / t_ours:.1f}x (the command; "
            f"its computation alone {t_computed:.3f} s: {t_disort / t_computed:.1f}x)",
            f"largest error at 400 grid points against DISORT 64 streams: ours {ours_err:.1e}, "
            f"DISORT 32 {disort_err:.1e}")
    except ImportError as e:
        row("full table vs DISORT", ">= 20x faster", "not run", f"pydisort missing ({e})")

    # 3. eval, render, lobes.
    rng = random.Random(1)
    lines = "".join(f"{rng.uniform(0, 89):.6f} {rng.uniform(0, 89):.6f} {rng.uniform(0, 180):.6f}\n"
                    for _ in range(200000))
    t_one, _, _ = median_of(a.repeat, lambda: measure([tool, "eval", seed, "--theta-i", "10", "--theta-o", "20"]))
    t_all, m_all, ev = median_of(a.repeat, lambda: measure([tool, "eval", seed], lines))
    few = "".join(lines.splitlines(keepends=True)[:300])
    _, _, exact = measure([tool, "eval", seed, "--exact"], few)
    errs = []
    for x, y in zip(ev.splitlines()[:300], exact.splitlines()):
        for u, v in zip(map(float, x.split()), map(float, y.split())):
            errs.append(abs(u - v) / max(v, 1e-3 / math.pi))
    errs.sort()
    rate = 200000 / max(t_all - t_one, 1e-9)
    row("`eval` of the seed spec, 200,000 directions from stdin", ">= 100,000 directions/s",
        f"{rate:,.0f} directions/s ({t_all:.2f} s in all, {t_one:.2f} s of it the solve), {m_all:.0f} MiB",
        f"interpolant vs `--exact`, 300 directions: median {errs[len(errs) // 2]:.1e}, max {errs[-1]:.1e}")
    png = os.path.join(work, "r.png")
    t, m, _ = median_of(a.repeat, lambda: measure([tool, "render", seed, "-o", png, "--size", "512"]))
    row("`render` of the seed spec, 512 x 512", "<= 1 s", f"{t:.2f} s, {m:.0f} MiB",
        "the body's interpolant on the draft tables' grid "
        "(within 8.6e-5 of the table's below 88 deg, 4.2e-4 at the horizon)")
    gloss = os.path.join(work, "seed-gloss.json")
    t, m, _ = median_of(a.repeat, lambda: measure([tool, "lobes", seed, gloss, "-o", png]))
    row("`lobes` of two specs (seed smooth and gloss)", "<= 1 s", f"{t:.2f} s, {m:.0f} MiB",
        "the previews' 46-node Fourier grid: within 5.4e-5 of each curve's peak")

    # 4. The slow rows, once each.
    if not a.skip_slow:
        p = spec(work, "seed-reference", SEED, accuracy="reference")
        t, m, _ = compute(tool, p, out, timeout=3600)
        r = report(out, "seed-reference")
        row("seed material at \"reference\"", "<= 10 s, <= 1 GB", f"{t:.1f} s, {m:.0f} MiB",
            estimate(r) + f", {r['solver']['streams']} streams")
    for r_um in (5, 40):
        if a.skip_slow and r_um == 40:
            continue
        p = spec(work, f"silica-{r_um}um", dict(SEED, pigments=[{
            "material": "silica", "volume_fraction": 0.05,
            "size": {"distribution": "gamma", "r_eff_um": r_um, "v_eff": 0.1}}]))
        try:
            t, m, _ = compute(tool, p, out, timeout=900)
            r = report(out, f"silica-{r_um}um")
            row(f"matting agent: silica r_eff {r_um} um, v_eff 0.1, in acrylic, \"default\"",
                "<= 2 s" if r_um == 5 else "<= 5 s", f"{t:.1f} s, {m:.0f} MiB",
                estimate(r) + "; " + wavelengths_solved(r))
            if r_um == 40:
                t, m, _ = compute(tool, p, out, timeout=900, mie_on_disk=True)
                row("the same, its Mie ensembles on disk from the run before", "", f"{t:.1f} s, {m:.0f} MiB",
                    "the same tables, byte for byte")
        except (RuntimeError, subprocess.TimeoutExpired) as e:
            row(f"matting agent: silica r_eff {r_um} um", "<= 2 s" if r_um == 5 else "<= 5 s", "failed",
                str(e)[:200])

    cpu = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
    model = next((l.split(":", 1)[1].strip() for l in cpu.splitlines() if l.startswith("Model name")),
                 platform.processor())
    doc = ["# Benchmarks: what a user waits for", "",
           f"Produced by `python3 bench/interactive.py` on {datetime.date.today().isoformat()}: {model}, "
           f"{os.cpu_count()} logical CPUs, OpenBLAS kernels {core or 'unknown'}, "
           "the default device (OpenCL through PoCL on these CPUs), "
           f"Release build. Wall times are medians of {a.repeat} runs of the real command line (the "
           "reference and matting-agent rows: one run); memory is the process's peak resident set. "
           "The DISORT row alternates ours and DISORT within one run. Every run starts without the Mie "
           "ensembles of the runs before (docs/mie.md, \"And on disk, across runs\"), as a new material "
           "does, except the two rows that say they have them, and every `compute` writes into an empty "
           "folder, untimed deletion of the run before's tables included (deleting a 35 MB table waits for "
           "the disk to discard its blocks on this machine's file system, mounted with `discard`: ~9 ms), "
           "except the row that replaces its own tables.", "",
           "| what | target (issues 14, 16) | measured | accuracy |", "|---|---|---|---|"]
    for what, target, result, accuracy in rows:
        doc.append(f"| {what} | {target} | {result} | {accuracy} |")
    doc += ["", "Speed against error of every solver method (ours at each accuracy, the plain fixed "
            "point, doubling, the dipole, DISORT at 16-68 streams): [speed-vs-error.md](speed-vs-error.md).", ""]
    with open(a.doc, "w") as f:
        f.write("\n".join(doc))
    print(f"wrote {a.doc}")


if __name__ == "__main__":
    main()
