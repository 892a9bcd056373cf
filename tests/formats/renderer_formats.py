#!/usr/bin/env python3
"""Renderers read what `brdftool compute` writes: the seed material's NAME.fourier.bsdf and
NAME.rgl.bsdf against `brdftool eval` on the spec (the exact model), and a Mitsuba 3 rendering.

  renderer_formats.py setup --brdftool BIN --spec SPEC --work-dir DIR [--directions 600]
      brdftool compute SPEC --formats fourier,rgl into DIR/out; DIR/model.csv: the model's BRDF
      (`brdftool eval SPEC`) at random directions, cosine-uniform below 85 degrees in both zenith
      angles, uniform in azimuth (seeded: the same every run), as "theta_i theta_o phi r g b"
      (radians, 1/sr) for tests/formats/fourier_reader.py --model; DIR/rgl_case.json: the same
      directions as unit vectors with the model's albedo at 0, 30, 60 degrees, for
      tests/reference/formats/mitsuba_measured_check.py (accuracy and Mitsuba's sampling) on the
      RGB companion NAME.rgb.rgl.bsdf in scalar_rgb; DIR/rgl_spectral_case.json: the first
      --spectral-directions (300) of them with `brdftool eval --spectral` at every solved wavelength,
      for the same check on the spectral NAME.rgl.bsdf in scalar_spectral, after checking that
      `brdftool info --json` lists the wavelengths eval solves.
  renderer_formats.py render --brdftool BIN --spec SPEC --work-dir DIR [--gallery DIR]
      a sphere under a directional light: Mitsuba 3 (scalar_rgb, `measured` with DIR/out's
      .rgb.rgl.bsdf, the `direct` integrator) and `brdftool render SPEC` (light size 0, so the smooth
      interface's mirror image of the light, which no table holds, is not in the picture either).
      Metric: per pixel the relative difference |M - B| / B of the luminance over the pixels whose
      whole footprint lies on the sphere and whose reference radiance is >= 2 % of the brightest
      (the terminator's last pixels are the file's grazing values, where the format is weakest);
      median <= --median and 95th percentile <= --p95. --gallery writes both as PNG (the same
      sRGB encoding, clamped at 1) and the metric as JSON.

Exit status 0 when the checks pass, 1 when they fail, 77 (skipped) without mitsuba and pip.
"""
import argparse
import importlib.util
import json
import math
import os
import random
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
CHECK = os.path.join(HERE, "..", "reference", "formats", "mitsuba_measured_check.py")
MAX_THETA_DEG = 85.0
LUMA = (0.2126, 0.7152, 0.0722)


def spec_name(spec):
    with open(spec) as f:
        return json.load(f)["name"]


def run(command, **kwargs):
    result = subprocess.run(command, text=True, capture_output=True, **kwargs)
    if result.returncode != 0:
        sys.exit(f"FAIL: {' '.join(command)} exited with {result.returncode}: {result.stderr.strip()}")
    return result.stdout


def setup(args):
    os.makedirs(args.work_dir, exist_ok=True)
    out = os.path.join(args.work_dir, "out")
    run([args.brdftool, "compute", args.spec, "-o", out, "--formats", "fourier,rgl", "--force"])
    rng = random.Random(17)
    c_max = math.cos(math.radians(MAX_THETA_DEG))
    angles = []
    for _ in range(args.directions):
        ti = math.degrees(math.acos(rng.uniform(c_max, 1.0)))
        to = math.degrees(math.acos(rng.uniform(c_max, 1.0)))
        angles.append((ti, to, rng.uniform(0.0, 360.0)))
    text = "".join(f"{ti:.9f} {to:.9f} {phi:.9f}\n" for ti, to, phi in angles)
    values = [[float(v) for v in line.split()] for line in
              run([args.brdftool, "eval", args.spec], input=text).strip().splitlines()]
    if len(values) != len(angles):
        sys.exit(f"FAIL: brdftool eval gave {len(values)} lines for {len(angles)} directions")
    with open(os.path.join(args.work_dir, "model.csv"), "w") as f:
        f.write("# theta_i theta_o phi (radians) r g b (1/sr): brdftool eval on the spec\n")
        for (ti, to, phi), v in zip(angles, values):
            f.write(f"{math.radians(ti):.12f} {math.radians(to):.12f} {math.radians(phi):.12f} "
                    f"{v[0]:.9g} {v[1]:.9g} {v[2]:.9g}\n")
    pairs = []
    for ti, to, phi in angles:
        ti, to, phi = math.radians(ti), math.radians(to), math.radians(phi)
        pairs.append([math.sin(ti), 0.0, math.cos(ti),
                      math.sin(to) * math.cos(phi), math.sin(to) * math.sin(phi), math.cos(to)])
    albedo = []
    for line in run([args.brdftool, "albedo", args.spec, "--theta-i", "0,30,60"]).splitlines():
        if line.startswith("mirror") or not line.strip():
            continue
        albedo.append([float(v) for v in line.split()[-3:]])
    name = spec_name(args.spec)
    # The seed material is solved per wavelength: NAME.rgl.bsdf is spectral (pbrt-v4, Mitsuba's
    # spectral variants), NAME.rgb.rgl.bsdf its RGB companion (Mitsuba's RGB variants).
    case = {"name": name, "bsdf": f"out/{name}.rgb.rgl.bsdf", "variant": "scalar_rgb", "enforce": True,
            "pairs": pairs, "reference_brdf": values,
            "albedo": [{"theta_i_deg": t, "albedo": a} for t, a in zip([0, 30, 60], albedo)]}
    with open(os.path.join(args.work_dir, "rgl_case.json"), "w") as f:
        json.dump(case, f)

    # The spectral file: `brdftool info` must list the wavelengths `brdftool eval --spectral` solves,
    # and the model's BRDF at every one of them at the first --spectral-directions directions.
    spectral_angles = angles[:args.spectral_directions]
    lines = run([args.brdftool, "eval", args.spec, "--spectral"],
                input="".join(f"{ti:.9f} {to:.9f} {phi:.9f}\n" for ti, to, phi in spectral_angles)).splitlines()
    header = lines[0].split()
    if header[:2] != ["#", "wavelength_nm"]:
        sys.exit(f"FAIL: brdftool eval --spectral: first line {lines[0]!r}, '# wavelength_nm ...' expected")
    eval_nm = [float(v) for v in header[2:]]
    spectral_values = [[float(v) for v in line.split()] for line in lines[1:] if line.strip()]
    if len(spectral_values) != len(spectral_angles) or any(len(v) != len(eval_nm) for v in spectral_values):
        sys.exit(f"FAIL: brdftool eval --spectral gave {len(spectral_values)} lines for {len(spectral_angles)} "
                 f"directions of {len(eval_nm)} wavelengths")
    rgl = os.path.join(out, f"{name}.rgl.bsdf")
    info = json.loads(run([args.brdftool, "info", rgl, "--json"]))
    file_nm = info.get("wavelengths_nm")
    if not file_nm:
        sys.exit(f"FAIL: brdftool info {rgl}: no wavelengths_nm (the file should be spectral)")
    if len(file_nm) != len(eval_nm) or any(abs(a - b) > 1e-3 for a, b in zip(file_nm, eval_nm)):
        sys.exit(f"FAIL: {rgl} holds the wavelengths {file_nm}, brdftool eval --spectral solves {eval_nm}")
    spectral_case = {"name": f"{name}-spectral", "bsdf": f"out/{name}.rgl.bsdf", "variant": "scalar_spectral",
                     "enforce": True, "pairs": pairs[:len(spectral_angles)], "reference_brdf": spectral_values,
                     "wavelengths_nm": file_nm}
    with open(os.path.join(args.work_dir, "rgl_spectral_case.json"), "w") as f:
        json.dump(spectral_case, f)
    print(f"wrote {out}, model.csv, rgl_case.json ({len(angles)} directions) and rgl_spectral_case.json "
          f"({len(spectral_angles)} directions x {len(file_nm)} wavelengths, {file_nm[0]:g} to {file_nm[-1]:g} nm)")
    return 0


def quantile(values, q):
    values = sorted(values)
    return values[min(len(values) - 1, int(q * (len(values) - 1) + 0.5))]


def render(args):
    spec = importlib.util.spec_from_file_location("mitsuba_measured_check", CHECK)
    check = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(check)
    mi = check.import_mitsuba(args.work_dir)  # exits 77 when it cannot
    mi.set_variant("scalar_rgb")
    import numpy as np

    name = spec_name(args.spec)
    rgl = os.path.join(args.work_dir, "out", f"{name}.rgb.rgl.bsdf")  # the RGB companion (scalar_rgb)
    size, margin = args.size, 0.06
    light_theta, light_phi = 45.0, 135.0  # brdftool render's defaults
    ours = os.path.join(args.work_dir, "brdftool_sphere.exr")
    run([args.brdftool, "render", args.spec, "-o", ours, "--size", str(size), "--light-size", "0",
         "--light-theta", str(light_theta), "--light-phi", str(light_phi), "--supersample", "4"])
    # brdftool render: orthographic view of the unit sphere along -z, x right, y up, the sphere's
    # radius (1 - 2 margin) of half the image, the light towards (sin t cos p, sin t sin p, cos t).
    th, ph = math.radians(light_theta), math.radians(light_phi)
    towards_light = [math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)]
    half = 1.0 / (1.0 - 2.0 * margin)
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        # Mitsuba's camera space has +x to the left: a mirrored x scale puts it to the right.
        "sensor": {"type": "orthographic",
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0])
                   @ mi.ScalarTransform4f().scale([half, half, 1.0]),
                   "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"},
                            "pixel_format": "rgb"},
                   "sampler": {"type": "stratified", "sample_count": 16}},
        "sphere": {"type": "sphere", "bsdf": {"type": "measured", "filename": rgl}},
        "light": {"type": "directional", "direction": [-v for v in towards_light],
                  "irradiance": {"type": "rgb", "value": math.pi}},
    })
    mitsuba_image = np.array(mi.render(scene), dtype=np.float64)[:, :, :3]
    reference = np.array(mi.Bitmap(ours), dtype=np.float64)[:, :, :3]
    # Pixels whose whole footprint is on the sphere (pixel centre within radius - 1 pixel).
    radius = 0.5 * size * (1.0 - 2.0 * margin)
    y, x = np.mgrid[0:size, 0:size]
    inside = np.hypot(x + 0.5 - 0.5 * size, y + 0.5 - 0.5 * size) < radius - 1.0
    lum_m = np.tensordot(mitsuba_image, LUMA, axes=([2], [0]))
    lum_b = np.tensordot(reference, LUMA, axes=([2], [0]))
    lit = inside & (lum_b >= 0.02 * lum_b[inside].max())
    rel = np.abs(lum_m[lit] - lum_b[lit]) / lum_b[lit]
    result = {"pixels": int(lit.sum()), "median": float(np.median(rel)), "p95": quantile(rel.tolist(), 0.95),
              "max": float(rel.max()), "mean_ratio": float(lum_m[lit].sum() / lum_b[lit].sum()),
              "metric": "per-pixel |L_mitsuba - L_brdftool| / L_brdftool of the luminance, pixels fully on "
                        "the sphere with L >= 2 % of the brightest",
              "mitsuba": mi.__version__, "size": size, "spp": 16}
    print(json.dumps(result, indent=1))
    if args.gallery:
        os.makedirs(args.gallery, exist_ok=True)
        for image, file in ((mitsuba_image, "measured-mitsuba.png"), (reference, "measured-brdftool.png")):
            rgb = np.clip(image, 0.0, 1.0)
            srgb = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * np.power(rgb, 1.0 / 2.4) - 0.055)
            bitmap = mi.Bitmap(np.ascontiguousarray((srgb * 255.0 + 0.5).astype(np.uint8)),
                               mi.Bitmap.PixelFormat.RGB)
            bitmap.write(os.path.join(args.gallery, file))
        with open(os.path.join(args.gallery, "measured-comparison.json"), "w") as f:
            json.dump(result, f, indent=1)
            f.write("\n")
    faults = []
    if result["median"] > args.median:
        faults.append(f"median {result['median']:.3g} > {args.median}")
    if result["p95"] > args.p95:
        faults.append(f"95th percentile {result['p95']:.3g} > {args.p95}")
    for fault in faults:
        print(f"FAIL: {fault}")
    return 1 if faults else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=["setup", "render"])
    parser.add_argument("--brdftool", required=True)
    parser.add_argument("--spec", required=True)
    parser.add_argument("--work-dir", required=True)
    parser.add_argument("--directions", type=int, default=600)
    parser.add_argument("--spectral-directions", type=int, default=300)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--median", type=float, default=0.01)
    parser.add_argument("--p95", type=float, default=0.03)
    parser.add_argument("--gallery", help="write the two images and the metric here")
    args = parser.parse_args()
    return setup(args) if args.mode == "setup" else render(args)


if __name__ == "__main__":
    sys.exit(main())
