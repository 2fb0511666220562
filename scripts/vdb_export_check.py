"""`haze export --out VOL.vdb` against OpenVDB itself, side by side in one run.

    python scripts/vdb_export_check.py ASSET.haze [--haze target/release/haze]

Needs a Python with `bpy` (whose Blender bundles OpenVDB's Python module), `numpy` and
the `haze` package. For every frame of the asset: `haze export` writes it as OpenVDB
(timed per frame); OpenVDB reads the file back and its dense copy is compared with
`haze.Asset.frame` voxel for voxel, and its index→world map with the asset's box; then
OpenVDB's own writer stores the same array (full floats, its default compression) so
that sizes and times sit beside haze's. Prints one table; exits 1 when a frame differs.
"""

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

import haze


def openvdb_module():
    site = sorted(Path(bpy.__file__).parents[3].glob("python/lib/python3*/site-packages"))
    sys.path.append(str(site[0]))
    import openvdb

    return openvdb


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("asset")
    ap.add_argument("--haze", default="target/release/haze")
    args = ap.parse_args()
    vdb = openvdb_module()
    asset = haze.Asset(args.asset)
    nx, ny, nz = asset.dims
    lo, hi = asset.bbox
    voxel = [(hi[a] - lo[a]) / asset.dims[a] for a in range(3)]
    work = Path(tempfile.mkdtemp(prefix="vdb-check-"))
    print(f"{args.asset}: {len(asset)} frames of {nx} × {ny} × {nz}, OpenVDB {vdb.LIBRARY_VERSION}")
    print("| frame | active voxels | `haze export` s | haze KiB | OpenVDB write s | OpenVDB KiB | read back by OpenVDB |")
    print("|---|---|---|---|---|---|---|")
    bad = 0
    for n in asset.frames:
        ours = work / f"haze_{n:04d}.vdb"
        t = time.perf_counter()
        subprocess.run([args.haze, "export", args.asset, "--frame", str(n), "--out", str(ours), "-q"], check=True)
        t_haze = time.perf_counter() - t
        want = asset.frame(n)  # (z, y, x)
        grid = vdb.read(str(ours), "density")
        dense = np.zeros((nx, ny, nz), dtype=np.float32)
        grid.copyToArray(dense, ijk=(0, 0, 0))
        same = np.array_equal(dense.transpose(2, 1, 0), want)
        placed = np.allclose(grid.transform.indexToWorld((0, 0, 0)), lo, atol=1e-9) and np.allclose(
            grid.transform.indexToWorld((nx, ny, nz)), hi, atol=1e-9
        )
        bad += not (same and placed)
        theirs = vdb.FloatGrid()
        theirs.name = "density"
        theirs.copyFromArray(np.ascontiguousarray(want.transpose(2, 1, 0)), ijk=(0, 0, 0), tolerance=0.0)
        theirs.transform = vdb.createLinearTransform(voxelSize=voxel[0])
        theirs_path = work / f"openvdb_{n:04d}.vdb"
        t = time.perf_counter()
        vdb.write(str(theirs_path), grids=[theirs])
        t_theirs = time.perf_counter() - t
        print(
            f"| {n} | {grid.activeVoxelCount()} | {t_haze:.3f} | {ours.stat().st_size / 1024:.1f} | "
            f"{t_theirs:.3f} | {theirs_path.stat().st_size / 1024:.1f} | "
            f"{'equal' if same else 'DIFFERS'}{'' if placed else ', MISPLACED'} |"
        )
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
