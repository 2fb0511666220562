#!/usr/bin/env python3
"""One scene lit by a sky map, by Mitsuba 3 and by haze's renderers, compared.

    pip install mitsuba numpy
    cargo build --release
    scripts/mitsuba_check.py [--haze target/release/haze] [--spp 1024] [--mitsuba-spp 8192]
                             [--size 64x48] [--variant scalar_rgb] [--keep DIR]
                             [--multiple] [--sigma-t S] [--albedo A] [--g G]

The scene (written to a temporary folder): a density grid of three Gaussians (40³ over
[−1, 1]³, a raw float32 file with its JSON sidecar), σt 4, albedo 0.8, HG g 0.5, under a
512 × 256 lat-long map — a sky graded from the horizon to the zenith over a dark ground,
with a sun disk 8° wide at 2000× the zenith's radiance kept in the map — and seen by a
pinhole camera at (0.4, −4, 1) looking at the origin, 40° vertical field of view. haze
renders it with `render --reference --no-multiple --no-sun-extraction` (the map whole,
importance-sampled); Mitsuba with `volpath` at `max_depth` 2 (one scattering event),
the grid as a `gridvolume` (trilinear, clamped past the outer voxel centers, as haze's
field), the map as an `envmap` turned from Mitsuba's Y-up frame into haze's Z-up one.

`--ground` compares the ground under the smoke instead: a diffuse plane (albedo 0.16,
0.15, 0.13, haze's default ground) at the box's floor, z = −1, under the map without its
sun, the smoke absorbing only (albedo 0), over the pixels that see the ground not
through the smoke: the sky's shadow the smoke casts on it (decision 0071), by haze's
fast renderer and its reference against Mitsuba's `volpath` with the plane as a
`rectangle` 2000 units wide (the smoke's cube lifted 0.004 off it: coplanar faces lose
the plane for some of Mitsuba's rays).

`--multiple` compares every scattering order instead: haze's `--reference` with
multiple scattering, Mitsuba's `volpath` without a depth limit, and haze's fast renderer
as a user runs it (`haze render --env MAP`: the sun found in the map and lit exactly,
the rest in SH, multiple scattering by explicit orders). `--sigma-t`, `--albedo` and
`--g` change the medium.

Prints `rel_rms` (docs/conventions.md: RMS of the difference over the RMS of the reference, here
Mitsuba's image) over the pixels where the smoke changes the background by more than 1 %,
and each renderer's own noise: haze's from its two half-runs, Mitsuba's from two seeds.
The pixel footprints differ (haze: one ray through each pixel center; Mitsuba: a box
filter over the pixel), which only matters at the smoke's edge. Not part of the test
suite: it needs Mitsuba and minutes of CPU.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

try:
    import mitsuba as mi
except ImportError:
    sys.exit("needs Mitsuba 3: pip install mitsuba")

DIMS = 40
SIGMA_T, ALBEDO, G = 4.0, 0.8, 0.5
EYE, TARGET, FOV = (0.4, -4.0, 1.0), (0.0, 0.0, 0.0), 40.0
SUN_ELEV, SUN_AZIM, SUN_ANGLE, SUN_RATIO = 40.0, 60.0, 8.0, 2000.0
ZENITH = np.array([0.25, 0.45, 0.9])
HORIZON = np.array([0.8, 0.85, 0.9])
GROUND = np.array([0.05, 0.045, 0.04])


def density():
    """Three Gaussians sampled at the voxel centers of [−1, 1]³, indexed [z, y, x]."""
    c = (np.arange(DIMS) + 0.5) / DIMS * 2.0 - 1.0
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    d = np.zeros_like(x)
    for (cx, cy, cz), r, w in [
        ((0.0, 0.0, 0.0), 0.45, 1.0),
        ((0.35, 0.2, 0.3), 0.3, 0.6),
        ((-0.4, -0.1, -0.2), 0.25, 0.8),
    ]:
        d += w * np.exp(-((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / r**2)
    return d.astype(np.float32)


def sun_direction():
    t, p = math.radians(90.0 - SUN_ELEV), math.radians(SUN_AZIM)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


GROUND_ALBEDO = (0.16, 0.15, 0.13)


def env_map(w=512, h=256, sub=4, sun_ratio=SUN_RATIO):
    """Lat-long map (docs/conventions.md: row 0 the zenith, column u → φ = 2πu from +X to +Y),
    each texel the sin θ-weighted mean of sub × sub subsamples."""
    s = sun_direction()
    cos_half = math.cos(math.radians(SUN_ANGLE) / 2.0)
    sun = ZENITH * sun_ratio
    img = np.zeros((h, w, 3))
    fy = (np.arange(h * sub) + 0.5) / (h * sub)
    fx = (np.arange(w * sub) + 0.5) / (w * sub)
    theta = (math.pi * fy)[:, None]
    phi = (2.0 * math.pi * fx)[None, :]
    dx, dy = np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi)
    dz = np.cos(theta) * np.ones_like(phi)
    up = np.clip(dz, 0.0, 1.0)[..., None]
    sky = np.where(dz[..., None] >= 0.0, HORIZON * (1 - up) + ZENITH * up, GROUND)
    disk = (dx * s[0] + dy * s[1] + dz * s[2]) >= cos_half
    sky = sky + disk[..., None] * sun
    wgt = np.sin(theta) * np.ones_like(phi)
    num = (sky * wgt[..., None]).reshape(h, sub, w, sub, 3).sum(axis=(1, 3))
    den = wgt.reshape(h, sub, w, sub).sum(axis=(1, 3))
    img[:] = num / den[..., None]
    return img.astype(np.float32)


def read_exr(path):
    bmp = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
    return np.array(bmp)


def mitsuba_render(vol, env_path, size, spp, seed, medium, max_depth, ground=False):
    w, h = size
    grid_to_world = mi.ScalarTransform4f().translate([-1.0, -1.0, -1.0]).scale(2.0)
    # Mitsuba's envmap: θ from local +Y, u = atan2(x, −z)/2π. Local (y_w, z_w, −x_w) puts
    # θ from world +Z and u = atan2(y_w, x_w)/2π, haze's convention.
    env_to_world = mi.ScalarTransform4f(
        [[0, 0, -1, 0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]]
    )
    extra = {}
    if ground:
        extra["ground"] = {
            "type": "rectangle",
            "to_world": mi.ScalarTransform4f().translate([0.0, 0.0, -1.0]).scale(1000.0),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": GROUND_ALBEDO}},
        }
    scene = mi.load_dict(
        {
            **extra,
            "type": "scene",
            "integrator": {"type": "volpath", "max_depth": max_depth},
            "sensor": {
                "type": "perspective",
                "fov": FOV,
                "fov_axis": "y",
                "to_world": mi.ScalarTransform4f().look_at(
                    origin=EYE, target=TARGET, up=[0, 0, 1]
                ),
                "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
                "film": {
                    "type": "hdrfilm",
                    "width": w,
                    "height": h,
                    "rfilter": {"type": "box"},
                    "pixel_format": "rgb",
                },
            },
            "env": {"type": "envmap", "filename": env_path, "to_world": env_to_world},
            "smoke": {
                "type": "cube",
                # Over a ground, the cube's floor lifted off the plane (coplanar faces
                # make Mitsuba lose the plane for some rays); the density there is ~0.
                "to_world": (
                    mi.ScalarTransform4f().translate([0.0, 0.0, 0.002]).scale([1.0, 1.0, 0.998])
                    if ground
                    else mi.ScalarTransform4f()
                ),
                "bsdf": {"type": "null"},
                "interior": {
                    "type": "heterogeneous",
                    "albedo": medium[1],
                    "scale": medium[0],
                    "sigma_t": {
                        "type": "gridvolume",
                        "grid": mi.VolumeGrid(vol[..., None]),
                        "to_world": grid_to_world,
                        "filter_type": "trilinear",
                        "wrap_mode": "clamp",
                    },
                    "phase": {"type": "hg", "g": medium[2]},
                },
            },
        }
    )
    return np.array(mi.render(scene), dtype=np.float64)[..., :3]


def masked_rel_rms(img, ref, mask):
    d = (img - ref)[mask]
    return math.sqrt((d**2).sum() / max((ref[mask] ** 2).sum(), 1e-300))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--haze", default="target/release/haze")
    ap.add_argument("--spp", type=int, default=1024, help="haze's samples per pixel")
    ap.add_argument("--mitsuba-spp", type=int, default=8192)
    ap.add_argument("--size", default="64x48")
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--keep", help="write the scene and images to this folder")
    ap.add_argument("--multiple", action="store_true",
                    help="every scattering order, and haze's fast renderer too")
    ap.add_argument("--ground", action="store_true",
                    help="the ground under absorbing smoke, its sky's shadow")
    ap.add_argument("--sigma-t", type=float, default=SIGMA_T)
    ap.add_argument("--albedo", type=float, default=ALBEDO)
    ap.add_argument("--g", type=float, default=G)
    a = ap.parse_args()
    w, h = (int(v) for v in a.size.split("x"))
    mi.set_variant(a.variant)
    with tempfile.TemporaryDirectory(prefix="haze_mitsuba_") as tmp:
        folder = a.keep or tmp
        os.makedirs(folder, exist_ok=True)
        if a.ground:
            compare_ground(a, folder, w, h)
        else:
            compare(a, folder, w, h)


def write_volume(folder):
    """The density (`density()`) as a raw file with its JSON sidecar in `folder`: the
    array and the file's path."""
    vol = density()
    vol_path = os.path.join(folder, "blob.f32")
    vol.tofile(vol_path)
    with open(os.path.join(folder, "blob.json"), "w") as f:
        json.dump(
            {"dims": [DIMS] * 3, "world_bbox_min": [-1.0] * 3, "world_bbox_max": [1.0] * 3},
            f,
        )
    return vol, vol_path


def compare(a, folder, w, h):
    vol, vol_path = write_volume(folder)
    env_path = os.path.join(folder, "env.exr")
    mi.Bitmap(env_map()).write(env_path)

    def haze(out, spp, sigma_t, fast=False):
        cmd = [
            a.haze, "render", vol_path, "--out", out, "--env", env_path,
            "--width", str(w), "--height", str(h),
            "--eye", ",".join(map(str, EYE)), "--target", ",".join(map(str, TARGET)),
            "--fov", str(FOV), "--sigma-t", str(sigma_t), "--albedo", str(a.albedo),
            "--g", str(a.g), "-v",
        ]
        if not fast:
            cmd += ["--reference", "--spp", str(spp), "--no-sun-extraction"]
        if not a.multiple:
            cmd += ["--no-multiple"]
        run = subprocess.run(cmd, capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"haze failed:\n{run.stderr}")
        return read_exr(out).astype(np.float64), (run.stdout + run.stderr).strip()

    haze_img, said = haze(os.path.join(folder, "haze.exr"), a.spp, a.sigma_t)
    print("haze:", said.splitlines()[-1] if said else "")
    fast_img = None
    if a.multiple:
        fast_img, said = haze(os.path.join(folder, "haze-fast.exr"), 1, a.sigma_t, fast=True)
        print("haze fast:", said.splitlines()[-1] if said else "")
    # The background each pixel would show without smoke: σt = 0, exact.
    bg, _ = haze(os.path.join(folder, "background.exr"), 1, 0.0)
    mask = np.abs(haze_img - bg).sum(axis=2) > 0.01 * np.abs(bg).sum(axis=2)

    half = max(a.mitsuba_spp // 2, 1)
    medium = (a.sigma_t, a.albedo, a.g)
    depth = -1 if a.multiple else 2
    m1 = mitsuba_render(vol, env_path, (w, h), half, 1, medium, depth)
    m2 = mitsuba_render(vol, env_path, (w, h), half, 2, medium, depth)
    mits = 0.5 * (m1 + m2)
    if a.keep:
        mi.Bitmap(mits.astype(np.float32)).write(os.path.join(folder, "mitsuba.exr"))

    # The mean of two independent halves: its noise is rel_rms(A, B)/2.
    noise_m = 0.5 * masked_rel_rms(m1, m2, mask)
    err = masked_rel_rms(haze_img, mits, mask)
    flipped = masked_rel_rms(haze_img[:, ::-1], mits, mask[:, ::-1])
    ratio = haze_img[mask].sum() / mits[mask].sum()
    print(f"{mask.sum()} smoke pixels of {w * h}")
    print(f"Mitsuba ({a.variant}, {a.mitsuba_spp} spp) noise {100 * noise_m:.2f} %")
    what = "every order" if a.multiple else "single scattering"
    print(f"medium σt {a.sigma_t}, albedo {a.albedo}, g {a.g}; {what}")
    print(f"haze reference vs Mitsuba: rel_rms {100 * err:.2f} %, mean ratio {ratio:.4f}"
          f" (mirrored: {100 * flipped:.1f} %, a check of the orientation)")
    if fast_img is not None:
        err = masked_rel_rms(fast_img, mits, mask)
        ratio = fast_img[mask].sum() / mits[mask].sum()
        print(f"haze fast vs Mitsuba: rel_rms {100 * err:.2f} %, mean ratio {ratio:.4f}")


def compare_ground(a, folder, w, h):
    """The ground under absorbing smoke (module docs, `--ground`)."""
    vol, vol_path = write_volume(folder)
    env_path = os.path.join(folder, "sky.exr")
    mi.Bitmap(env_map(sun_ratio=0.0)).write(env_path)

    def haze(name, sigma_t, *extra):
        out = os.path.join(folder, name)
        cmd = [
            a.haze, "render", vol_path, "--out", out, "--env", env_path,
            "--width", str(w), "--height", str(h),
            "--eye", ",".join(map(str, EYE)), "--target", ",".join(map(str, TARGET)),
            "--fov", str(FOV), "--sigma-t", str(sigma_t), "--albedo", "0", "-q", *extra,
        ]
        run = subprocess.run(cmd, capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"haze failed:\n{run.stderr}")
        return read_exr(out).astype(np.float64)

    fast = haze("fast.exr", a.sigma_t, "--ground", "on")
    ref = haze("reference.exr", a.sigma_t, "--ground", "on", "--reference", "--spp", "256")
    off = haze("off.exr", a.sigma_t, "--ground", "off")
    clear = haze("clear.exr", 0.0, "--ground", "on")
    bare = haze("bare.exr", 0.0, "--ground", "off")
    # The pixels that see the ground, not through the smoke (where the pixels' footprints,
    # a box filter in Mitsuba and one ray in haze, differ across the smoke's edges).
    behind = np.abs(off - bare).sum(axis=2) > 1e-3 * np.abs(bare).sum(axis=2)
    mask = (np.abs(fast - off).sum(axis=2) > 1e-6) & ~behind
    half = max(a.mitsuba_spp // 2, 1)
    medium = (a.sigma_t, 0.0, a.g)
    m1 = mitsuba_render(vol, env_path, (w, h), half, 1, medium, 3, ground=True)
    m2 = mitsuba_render(vol, env_path, (w, h), half, 2, medium, 3, ground=True)
    mits = 0.5 * (m1 + m2)
    if a.keep:
        mi.Bitmap(mits.astype(np.float32)).write(os.path.join(folder, "mitsuba.exr"))
    # The ground where the smoke takes a tenth of its sky or more (by Mitsuba): its shadow.
    shade = mask & (mits.sum(axis=2) < 0.9 * clear.sum(axis=2))
    print(f"{mask.sum()} ground pixels of {w * h} not behind the smoke,"
          f" {shade.sum()} of them in the smoke's shadow")
    print(f"Mitsuba ({a.variant}, {a.mitsuba_spp} spp) noise"
          f" {100 * 0.5 * masked_rel_rms(m1, m2, mask):.2f} %")
    for name, img in [("haze fast", fast), ("haze reference", ref),
                      ("the open sky (no smoke)", clear)]:
        print(f"{name} vs Mitsuba: ground rel_rms {100 * masked_rel_rms(img, mits, mask):.2f} %"
              f" (mean {img[mask].sum() / mits[mask].sum():.4f}); in the shadow"
              f" {100 * masked_rel_rms(img, mits, shade):.2f} %"
              f" (mean {img[shade].sum() / mits[shade].sum():.4f})")


if __name__ == "__main__":
    main()
