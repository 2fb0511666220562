#!/usr/bin/env python3
"""Accuracy and speed of `haze render` against the reference path tracer on skies of every
class, at equal error, in one run on one machine (BENCHMARKS "Skies of every shape").

For each case (a held-out frame, a sky class with its main light's elevation and
azimuth, a medium) the script:

- writes the sky as a 1024 x 512 lat-long EXR (`crm_accuracy --sky CLASS,ELEV,AZIM
  --save-sky`, the example that defines the classes);
- renders the smoke's transmittance (the reference with albedo 0 under a white map) to
  mask the smoke's pixels (transmittance below 0.98);
- renders the frame with `haze render --env SKY` (the fast renderer, which splits the
  map's light into suns), final image and single scattering (`--no-multiple`), timing
  the median of `--repeat` runs (process start included);
- renders the same with `haze render --reference` at `--spp` samples per pixel (two
  seeds: the command prints their noise `n`) and at `--spp-low`, timing both;
- prints the fast render's error against the reference (relative RMS over the smoke,
  linear RGB), with the reference's noise taken out (`sqrt(e^2 - n^2)`), and the speed
  at equal error: the path tracer is unbiased, so its error falls as `1/sqrt(spp)`; it
  matches the fast render's error `e'` at `spp_eq = spp * (n / e')^2` samples, whose time
  follows the two timed runs' line `t(spp) = a + b * spp`. The ratio is
  `t(spp_eq) / t_fast`. The noise at `--spp-low` checks the `1/sqrt(spp)` law; the
  same line gives the path tracer's time to a 2 % noise, `t(spp * (n / 2)^2)`, to compare
  its importance sampling across sky classes.

Not part of the test suite. Needs `pip install numpy OpenEXR`, a release build of haze
and of the example (`cargo build --release --bin haze --example crm_accuracy`) and the
held-out frames (`scripts/bake_heldout.py`'s OUT_DIR):

    python3 scripts/sky_speed.py --plume-b HELDOUT/plume-b/fluid_data_0030.vdb \\
        --plume-g HELDOUT/plume-g/fluid_data_0030.vdb [--spp 2048] [--out DIR]
"""

import argparse
import math
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np
import OpenEXR

# name, plume, sky class, elevation, azimuth, sigma_t, albedo, g
CASES = [
    ("b-soft8-back", "b", "soft8", 25, 90, 6, 0.9, 0.5),
    ("b-soft8-front", "b", "soft8", 25, 270, 6, 0.9, 0.5),
    ("b-sharp-back", "b", "sharp", 20, 90, 4, 0.8, 0.5),
    ("b-two-side", "b", "two", 40, 0, 6, 0.9, 0.2),
    ("b-cloud-back", "b", "cloud", 30, 110, 4, 0.8, 0.5),
    ("b-overcast-front", "b", "overcast", 30, 270, 4, 0.9, 0.2),
    ("b-low-side", "b", "low", 3, 10, 6, 0.8, 0.2),
    ("g-soft6-back", "g", "soft6", 30, 90, 4, 0.8, 0.2),
    ("g-low-side", "g", "low", 3, 0, 6, 0.9, 0.5),
    # The ends of the goal's range: thick smoke with a strongly forward phase function,
    # and thin smoke under a key and fill.
    ("g-sharp-front-thick", "g", "sharp", 35, 270, 10, 0.9, 0.8),
    ("b-soft6-back-thick", "b", "soft6", 20, 90, 10, 0.9, 0.8),
    ("g-two-side-thin", "g", "two", 45, 0, 2, 0.8, 0.0),
]


def run(cmd):
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t
    if r.returncode != 0:
        last = r.stderr.strip().splitlines()[-1] if r.stderr.strip() else str(r.returncode)
        sys.exit(f"{' '.join(cmd)}: {last}")
    return r, seconds


def load(path):
    with OpenEXR.File(path) as f:
        ch = f.channels()
        if "RGB" in ch:
            return np.array(ch["RGB"].pixels, dtype=np.float64)
        return np.stack([np.array(ch[c].pixels, dtype=np.float64) for c in "RGB"], -1)


def white_map(path):
    pixels = np.ones((2, 4, 3), dtype=np.float32)
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION}, {"RGB": pixels}) as f:
        f.write(path)


def noise_of(stderr):
    m = re.search(r"noise ≈ ([0-9.]+) %", stderr)
    if not m:
        sys.exit(f"no noise figure in: {stderr.strip()}")
    return float(m.group(1))


def rel_rms(a, b, mask):
    d = a[mask] - b[mask]
    return 100.0 * math.sqrt((d**2).sum() / max((b[mask] ** 2).sum(), 1e-300))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--plume-b", required=True)
    p.add_argument("--plume-g", required=True)
    p.add_argument("--haze", default="target/release/haze")
    p.add_argument("--crm", default="target/release/examples/crm_accuracy")
    p.add_argument("--spp", type=int, default=2048)
    p.add_argument("--spp-low", type=int, default=128)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--size", default="48x36")
    p.add_argument("--cases", default="", help="comma-separated names (default: all)")
    p.add_argument("--out", default="", help="keep the images here")
    a = p.parse_args()
    out = a.out or tempfile.mkdtemp(prefix="sky_speed_")
    os.makedirs(out, exist_ok=True)
    w, h = a.size.split("x")
    frames = {"b": a.plume_b, "g": a.plume_g}
    white = os.path.join(out, "white.exr")
    white_map(white)
    wanted = set(filter(None, a.cases.split(",")))
    print(f"# {a.size}, reference {a.spp} / {a.spp_low} spp, fast renders median of {a.repeat}")
    print(
        "| case | image | fast s | error (noise out) | ref. noise | spp at equal error | "
        "path tracer s at equal error | speed-up | noise law | path tracer s to 2 % noise |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, plume, sky, elev, azim, st, alb, g in CASES:
        if wanted and name not in wanted:
            continue
        vol = frames[plume]
        sky_path = os.path.join(out, f"sky-{name}.exr")
        run([a.crm, vol, "--size", "8x6", "--spp", "1", "--sky", f"{sky},{elev},{azim}",
             "--table", "reference", "--save-sky", sky_path])
        med = ["--sigma-t", str(st), "--albedo", str(alb), "--g", str(g)]
        common = [a.haze, "render", vol, "--width", w, "--height", h] + med
        mask_path = os.path.join(out, f"mask-{name}.exr")
        run(common[:2] + [vol, "--width", w, "--height", h, "--sigma-t", str(st), "--albedo",
                          "0", "--env", white, "--reference", "--no-multiple", "--spp", "2",
                          "--out", mask_path])
        mask = load(mask_path)[..., 0] < 0.98
        for image, extra in (("final", []), ("single", ["--no-multiple"])):
            fast_path = os.path.join(out, f"{name}-{image}-fast.exr")
            times = []
            for _ in range(a.repeat):
                _, s = run(common + ["--env", sky_path, "--out", fast_path] + extra)
                times.append(s)
            t_fast = sorted(times)[len(times) // 2]
            ref = {}
            for spp in (a.spp_low, a.spp):
                ref_path = os.path.join(out, f"{name}-{image}-ref{spp}.exr")
                r, s = run(common + ["--env", sky_path, "--reference", "--spp", str(spp),
                                     "--out", ref_path] + extra)
                ref[spp] = (ref_path, s, noise_of(r.stderr))
            ref_path, t_ref, n = ref[a.spp]
            e = rel_rms(load(fast_path), load(ref_path), mask)
            e_true = math.sqrt(max(e * e - n * n, 0.0))
            # t(spp) = a + b spp through the two timed reference runs.
            b = (t_ref - ref[a.spp_low][1]) / (a.spp - a.spp_low)
            a0 = t_ref - b * a.spp
            if e_true > 0:
                spp_eq = a.spp * (n / e_true) ** 2
                t_eq = a0 + b * spp_eq
                eq = f"{spp_eq:.0f} | {t_eq:.1f} | {t_eq / t_fast:.1f}×"
            else:
                eq = "below the reference's noise | | "
            law = ref[a.spp_low][2] / n / math.sqrt(a.spp / a.spp_low)
            t_two = a0 + b * a.spp * (n / 2.0) ** 2
            print(
                f"| {name} | {image} | {t_fast:.2f} | {e:.1f} % ({e_true:.1f} %) | {n:.1f} % | "
                f"{eq} | {law:.2f} | {t_two:.1f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
