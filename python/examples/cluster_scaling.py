"""A cluster bake against a sequential one: wall time with 1 and 2 workers (one thread
each), and the quality at the chunk boundaries.

    RAYON_NUM_THREADS=1 python python/examples/cluster_scaling.py SEQUENCE --frames 20..44 \\
        --chunk 13 --overlap 3 [--rbfs 300] [--json out.json]

Prints, for the sequential bake (in this process, one thread) and the cluster bakes
(LocalCluster of N worker processes, one thread each):
- wall time;
- each frame's rel_l2 against the sequential bake's: median and worst ratio, and the
  boundary frames (first kept frame of each chunk) against the sequence's worst;
- the RBF centres' motion into each boundary frame (mean distance from each centre to the
  nearest centre of the frame before, in voxels), cluster against sequential;
- bytes per frame a worker reads (input, with the warm-up) and writes (its chunk).
"""

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

import haze
import haze.cluster


def rel_l2(report):
    if "chunks" in report:
        return {f["frame"]: f["rel_l2"] for c in report["chunks"] for f in c["report"]["frames"]}
    return {f["frame"]: f["rel_l2"] for f in report["frames"]}


def centre_motion(asset, a, b):
    """Mean distance from each RBF centre of frame b to the nearest of frame a, in voxels."""
    ca, _, _ = asset.rbfs(a)
    cb, _, _ = asset.rbfs(b)
    d = np.sqrt(((cb[:, None, :] - ca[None, :, :]) ** 2).sum(-1)).min(1)
    (x0, _, _), (x1, _, _) = asset.bbox
    voxel = (x1 - x0) / asset.dims[0]
    return float(d.mean() / voxel)


def input_bytes(src, numbers):
    files = sorted(p for p in Path(src).iterdir() if p.is_file())
    sizes = [p.stat().st_size for p in files]
    return statistics.mean(sizes) if sizes else 0.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("src")
    ap.add_argument("--frames", default=None)
    ap.add_argument("--chunk", type=int, default=13)
    ap.add_argument("--overlap", type=int, default=3)
    ap.add_argument("--rbfs", type=int, default=None)
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    from distributed import Client, LocalCluster

    tmp = Path(tempfile.mkdtemp(prefix="haze-cluster-"))
    t = time.monotonic()
    seq = haze.bake(args.src, tmp / "seq.haze", frames=args.frames, rbfs=args.rbfs)
    seq_s = time.monotonic() - t
    seq_err = rel_l2(seq)
    numbers = sorted(seq_err)
    whole = haze.Asset(tmp / "seq.haze")
    out = {"sequential": {"seconds": seq_s, "frames": len(numbers)}, "cluster": {}}
    print(f"sequential: {len(numbers)} frames, {seq_s:.1f} s")
    for n in [int(w) for w in args.workers.split(",")]:
        cluster = LocalCluster(
            n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
            env={"RAYON_NUM_THREADS": "1"},
        )
        with Client(cluster) as client:
            r = haze.cluster.bake(
                args.src, tmp / f"c{n}.haze", client, frames=args.frames,
                chunk=args.chunk, overlap=args.overlap, rbfs=args.rbfs,
            )
        cluster.close()
        err = rel_l2(r)
        ratios = [err[k] / seq_err[k] for k in numbers]
        spread = haze.Asset(tmp / f"c{n}.haze")
        boundaries = [c["first"] for c in r["chunks"] if c["warm_up"] > 0]
        worst_seq = max(seq_err.values())
        b = []
        for k in boundaries:
            prev = numbers[numbers.index(k) - 1]
            b.append({
                "frame": k,
                "rel_l2": err[k],
                "sequential_rel_l2": seq_err[k],
                "over_sequence_worst": err[k] > worst_seq,
                "centre_motion_voxels": centre_motion(spread, prev, k),
                "sequential_centre_motion_voxels": centre_motion(whole, prev, k),
            })
        row = {
            "seconds": r["seconds"],
            "chunks": len(r["chunks"]),
            "median_ratio": statistics.median(ratios),
            "worst_ratio": max(ratios),
            "boundaries": b,
        }
        out["cluster"][n] = row
        print(
            f"{n} worker(s): {r['seconds']:.1f} s ({len(r['chunks'])} chunks); rel_l2 against "
            f"sequential: median ×{row['median_ratio']:.4f}, worst ×{row['worst_ratio']:.4f}"
        )
        for x in b:
            print(
                f"  boundary {x['frame']}: rel_l2 {x['rel_l2']:.4f} (sequential "
                f"{x['sequential_rel_l2']:.4f}, sequence's worst {worst_seq:.4f}); centres "
                f"moved {x['centre_motion_voxels']:.3f} voxels (sequential "
                f"{x['sequential_centre_motion_voxels']:.3f})"
            )
    per_in = input_bytes(args.src, numbers)
    per_out = (tmp / "seq.haze").stat().st_size / len(numbers)
    warm = 1 + args.overlap / args.chunk
    out["per_frame_bytes"] = {"input": per_in, "read_with_warm_up": per_in * warm, "asset": per_out}
    print(
        f"per frame: a worker reads {per_in * warm / 1e6:.2f} MB of input (warm-up included), "
        f"writes {per_out / 1e3:.1f} kB; the driver reads it back to merge"
    )
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
