#!/usr/bin/env python3
"""Held-out sky cases for the fast renderer's single scattering and final image: skies
written here as lat-long maps (Gaussian sun lobes on a sky gradient, not the classes of
`crm_accuracy --sky`), over held-out frames not used by `sky_speed.py` (BENCHMARKS "Skies
of every shape", the shell and the forward peak).

For each case the script writes the sky (1024 x 512 EXR), the smoke's mask (the
reference's transmittance under a white map below 0.98), the reference at `--spp-low` and
`--spp` samples per pixel (kept in `--out`, made once), renders `haze render --env SKY`
and prints its relative RMS over the smoke with the reference's noise taken out
(`sqrt(e^2 - n^2)`, the noise from the two references: `n = e_low / sqrt(spp/spp_low + 1)`)
and its mean over the reference's.

Not part of the test suite. Needs `pip install numpy OpenEXR`, a release build of haze and
the held-out frames (`scripts/bake_heldout.py`'s OUT_DIR):

    python3 scripts/lobe_skies.py --heldout HELDOUT [--haze target/release/haze] [--out DIR]
"""

import argparse
import math
import os
import subprocess

import numpy as np
import OpenEXR
from sky_speed import load, rel_rms

# name, plume, frame, lobes (elevation, azimuth, sigma in degrees, peak, colour), sky
# (horizon, zenith, ground), sigma_t, albedo, g
CASES = [
    ("h1", "plume-g", 45, [(15, 75, 4.0, 900, (1.0, 0.9, 0.75)), (20, 60, 20, 8, (1.0, 0.95, 0.9))],
     ((0.7, 0.75, 0.8), (0.25, 0.4, 0.8), (0.15, 0.13, 0.1)), 6, 0.9, 0.5),
    ("h2", "plume-b", 45, [(40, 200, 0.6, 60000, (1.0, 0.95, 0.9))],
     ((0.8, 0.8, 0.8), (0.5, 0.55, 0.65), (0.2, 0.2, 0.2)), 5, 0.85, 0.4),
    ("h3", "plume-g", 20, [(8, 100, 2.0, 3000, (1.0, 0.8, 0.6))],
     ((0.9, 0.7, 0.5), (0.2, 0.3, 0.6), (0.1, 0.1, 0.1)), 8, 0.9, 0.6),
]


def write_exr(path, pixels):
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION}, {"RGB": pixels.astype(np.float32)}) as f:
        f.write(path)


def sky(path, lobes, base):
    """Z up, row 0 the zenith, column u at azimuth 2*pi*u from +X towards +Y."""
    w, h = 1024, 512
    theta = (np.arange(h) + 0.5) / h * math.pi
    phi = (np.arange(w) + 0.5) / w * 2 * math.pi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    up = np.clip(d[..., 2], 0, 1)[..., None]
    horizon, zenith, ground = (np.array(c) for c in base)
    img = np.where(d[..., 2:3] >= 0, horizon * (1 - up) + zenith * up, ground)
    for elev, azim, sigma, peak, colour in lobes:
        e, a = math.radians(elev), math.radians(azim)
        s = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
        angle = np.arccos(np.clip(d @ s, -1, 1))
        img = img + peak * np.exp(-0.5 * (angle / math.radians(sigma)) ** 2)[..., None] * np.array(colour)
    write_exr(path, img)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--heldout", required=True, help="scripts/bake_heldout.py's OUT_DIR")
    p.add_argument("--haze", default="target/release/haze")
    p.add_argument("--out", default="lobe-skies")
    p.add_argument("--size", default="48x36")
    p.add_argument("--spp", type=int, default=1024)
    p.add_argument("--spp-low", type=int, default=128)
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    w, h = a.size.split("x")
    white = os.path.join(a.out, "white.exr")
    write_exr(white, np.ones((2, 4, 3)))
    for name, plume, frame, lobes, base, st, alb, g in CASES:
        vol = os.path.join(a.heldout, plume, f"fluid_data_{frame:04d}.vdb")
        sky_path = os.path.join(a.out, f"sky-{name}.exr")
        sky(sky_path, lobes, base)
        common = [a.haze, "render", vol, "--width", w, "--height", h, "--sigma-t", str(st)]
        mask_path = os.path.join(a.out, f"mask-{name}.exr")
        if not os.path.exists(mask_path):
            subprocess.run(common + ["--albedo", "0", "--env", white, "--reference", "--no-multiple",
                                     "--spp", "2", "--out", mask_path], check=True, capture_output=True)
        mask = load(mask_path)[..., 0] < 0.98
        med = ["--albedo", str(alb), "--g", str(g), "--env", sky_path]
        for image, extra in (("single", ["--no-multiple"]), ("final", [])):
            refs = {}
            for spp in (a.spp_low, a.spp):
                path = os.path.join(a.out, f"{name}-{image}-ref{spp}.exr")
                if not os.path.exists(path):
                    subprocess.run(common + med + ["--reference", "--spp", str(spp), "--out", path] + extra,
                                   check=True, capture_output=True)
                refs[spp] = load(path)
            r = refs[a.spp]
            n = rel_rms(refs[a.spp_low], r, mask) / math.sqrt(a.spp / a.spp_low + 1)
            fast_path = os.path.join(a.out, f"{name}-{image}-fast.exr")
            subprocess.run(common + med + ["--out", fast_path] + extra, check=True, capture_output=True)
            f = load(fast_path)
            e = rel_rms(f, r, mask)
            print(f"{name} ({plume} {frame}, sigma_t {st}, albedo {alb}, g {g}) {image:6s}: "
                  f"{math.sqrt(max(e * e - n * n, 0.0)):4.1f} % (noise {n:.1f} %), "
                  f"mean {f[mask].mean() / r[mask].mean():.3f}", flush=True)


if __name__ == "__main__":
    main()
