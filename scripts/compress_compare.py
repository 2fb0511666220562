#!/usr/bin/env python3
"""Bytes per frame of a haze asset against established volume compressors, at the same
max-error bound, on the same frames, in one run on one machine (BENCHMARKS
"Compression against established compressors").

For each frame of each input (a directory of numbered VDB/raw/npy frames, as `haze bake`
takes), the script:

- gets the frame's exact density through haze itself (`haze pack` the frame, then
  `haze export` it: the packed frame comes back bit for bit);
- bakes that one frame with `haze bake --residual-error E` (E relative to the frame's
  peak; the bound is a max error) and takes the asset's size, and that file through
  zstd level 19;
- compresses the same density with SZ3 (`pysz`, absolute bound E·peak), zfp
  (`zfpy`, fixed accuracy E·peak), and 8-bit quantization (steps of 2·E·peak, so the
  error is at most E·peak) followed by Blosc2 with zstd;
- checks every decoded volume's max error against the bound and prints a Markdown
  table with encode/decode times (the haze column's encode time is the whole bake,
  fitting included).

With `--sequence A..B` it bakes each input's frames A..B into one asset instead (the
bake's defaults, as a user stores a sequence: temporal coherence, hash volumes of up to
27 frames) and prints the asset's bytes per frame against the other compressors' mean
bytes per frame over the same frames, every frame checked within its bound.

Not part of the test suite. Needs `pip install numpy pysz zfpy blosc2 zstandard` and a
built `haze` (`cargo build --release`, or pass --haze).

    python3 scripts/compress_compare.py --haze target/release/haze \\
        --frames 30,60 DIR [DIR ...] [--error 0.00392]
    python3 scripts/compress_compare.py --haze target/release/haze --sequence 20..45 DIR
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: {r.stderr.strip().splitlines()[-1] if r.stderr else r.returncode}")
    return r


def exact_frame(haze, src, frame, tmp):
    """The frame's density as haze reads it: packed, then exported."""
    packed = os.path.join(tmp, f"packed_{frame}.haze")
    dense = os.path.join(tmp, f"dense_{frame}.f32")
    run([haze, "pack", src, "--frames", f"{frame}..{frame}", "--out", packed])
    run([haze, "export", packed, "--frame", str(frame), "--out", dense])
    meta = json.load(open(os.path.splitext(dense)[0] + ".json"))
    nx, ny, nz = meta["dims"]
    return np.fromfile(dense, dtype="<f4").reshape(nz, ny, nx)


def timed(f, repeat=3):
    best, out = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return out, best


def haze_row(haze, src, frame, error, tmp, truth):
    import zstandard

    asset = os.path.join(tmp, f"baked_{frame}.haze")
    t = time.perf_counter()
    run([haze, "bake", src, "--frames", f"{frame}..{frame}", "--residual-error", str(error),
         "--out", asset, "-q"])
    encode = time.perf_counter() - t
    back = os.path.join(tmp, f"back_{frame}.f32")
    t = time.perf_counter()
    run([haze, "export", asset, "--frame", str(frame), "--out", back])
    decode = time.perf_counter() - t
    got = np.fromfile(back, dtype="<f4").reshape(truth.shape)
    raw = open(asset, "rb").read()
    z = zstandard.ZstdCompressor(level=19).compress(raw)
    return len(raw), len(z), encode, decode, float(np.abs(got - truth).max())


def sz3_row(truth, bound):
    from pysz import sz, szConfig, szErrorBoundMode

    def enc():
        c = szConfig()
        c.errorBoundMode = szErrorBoundMode.ABS
        c.absErrorBound = bound
        return sz.compress(truth, c)[0]

    packed, te = timed(enc)
    back, td = timed(lambda: sz.decompress(packed, np.float32, truth.shape)[0])
    return packed.nbytes, te, td, float(np.abs(back - truth).max())


def zfp_row(truth, bound):
    import zfpy

    packed, te = timed(lambda: zfpy.compress_numpy(truth, tolerance=bound))
    back, td = timed(lambda: zfpy.decompress_numpy(packed))
    return len(packed), te, td, float(np.abs(back - truth).max())


def quant_row(truth, bound):
    import blosc2

    step = 2.0 * bound

    def enc():
        q = np.rint(truth / step).astype(np.uint8 if truth.max() / step < 255.5 else np.uint16)
        cparams = blosc2.CParams(codec=blosc2.Codec.ZSTD, clevel=9, typesize=q.dtype.itemsize)
        return q.dtype, blosc2.compress2(q.tobytes(), cparams=cparams)

    (dtype, packed), te = timed(enc)

    def dec():
        q = np.frombuffer(blosc2.decompress2(packed), dtype=dtype).reshape(truth.shape)
        return q.astype(np.float32) * np.float32(step)

    back, td = timed(dec)
    return len(packed), te, td, float(np.abs(back - truth).max())


def sequence_rows(a, tmp):
    first, last = (int(v) for v in a.sequence.split(".."))
    print("| sequence | frames | haze asset a frame | SZ3 (abs) | 8-bit + Blosc2/zstd "
          "| zfp (accuracy) | haze / SZ3 | haze bake s |")
    print("|---|---|---|---|---|---|---|---|")
    for src in a.inputs:
        asset = os.path.join(tmp, "sequence.haze")
        t = time.perf_counter()
        run([a.haze, "bake", src, "--frames", f"{first}..{last}", "--residual-error",
             str(a.error), "--out", asset, "-q"])
        bake = time.perf_counter() - t
        n = last - first + 1
        others = {"SZ3": 0, "8-bit": 0, "zfp": 0}
        for frame in range(first, last + 1):
            truth = exact_frame(a.haze, src, frame, tmp)
            bound = a.error * float(truth.max())
            back = os.path.join(tmp, "back.f32")
            run([a.haze, "export", asset, "--frame", str(frame), "--out", back])
            got = np.fromfile(back, dtype="<f4").reshape(truth.shape)
            errs = {"haze": float(np.abs(got - truth).max())}
            s, _, _, errs["SZ3"] = sz3_row(truth, bound)
            q, _, _, errs["8-bit"] = quant_row(truth, bound)
            z, _, _, errs["zfp"] = zfp_row(truth, bound)
            others["SZ3"] += s
            others["8-bit"] += q
            others["zfp"] += z
            for name, err in errs.items():
                if err > bound * (1 + 1e-4) + 1e-6 * float(truth.max()):
                    print(f"warning: {name} exceeds the bound on {src} frame {frame}: "
                          f"{err:.3g} > {bound:.3g}", file=sys.stderr)
        h = os.path.getsize(asset) / n
        kb = lambda v: f"{v / 1000:.1f} kB"
        print(f"| {os.path.basename(os.path.normpath(src))} | {first}..{last} | {kb(h)} | "
              f"{kb(others['SZ3'] / n)} | {kb(others['8-bit'] / n)} | {kb(others['zfp'] / n)} | "
              f"{h / (others['SZ3'] / n):.2f} | {bake:.1f} |", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("inputs", nargs="+", help="directories of numbered frames")
    ap.add_argument("--frames", default="30", help="frame numbers, comma separated")
    ap.add_argument("--error", type=float, default=1 / 255, help="max error relative to the peak")
    ap.add_argument("--haze", default="target/release/haze")
    ap.add_argument("--sequence", help="A..B: bake these frames as one asset (bytes a frame)")
    a = ap.parse_args()
    if a.sequence:
        with tempfile.TemporaryDirectory() as tmp:
            sequence_rows(a, tmp)
        return
    print(f"| frame | dims | haze asset | haze through zstd -19 | SZ3 (abs) | 8-bit + Blosc2/zstd "
          f"| zfp (accuracy) | haze encode / decode s | SZ3 | 8-bit | zfp |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for src in a.inputs:
            for frame in [int(f) for f in a.frames.split(",")]:
                truth = exact_frame(a.haze, src, frame, tmp)
                bound = a.error * float(truth.max())
                h, hz, he, hd, herr = haze_row(a.haze, src, frame, a.error, tmp, truth)
                s, se, sd, serr = sz3_row(truth, bound)
                q, qe, qd, qerr = quant_row(truth, bound)
                z, ze, zd, zerr = zfp_row(truth, bound)
                for name, err in [("haze", herr), ("SZ3", serr), ("8-bit", qerr), ("zfp", zerr)]:
                    # haze's bound holds on D̃ + R̂ in f64 before the f32 store: 1e-6 of the peak.
                    if err > bound * (1 + 1e-4) + 1e-6 * float(truth.max()):
                        print(f"warning: {name} exceeds the bound on {src} frame {frame}: "
                              f"{err:.3g} > {bound:.3g}", file=sys.stderr)
                dims = " × ".join(str(d) for d in truth.shape[::-1])
                kb = lambda n: f"{n / 1000:.1f} kB"
                print(f"| {os.path.basename(os.path.normpath(src))} {frame} | {dims} | {kb(h)} | "
                      f"{kb(hz)} | {kb(s)} | {kb(q)} | {kb(z)} | {he:.2f} / {hd:.2f} | "
                      f"{se * 1e3:.1f} / {sd * 1e3:.1f} ms | {qe * 1e3:.1f} / {qd * 1e3:.1f} ms | "
                      f"{ze * 1e3:.1f} / {zd * 1e3:.1f} ms |", flush=True)


if __name__ == "__main__":
    main()
