"""Bakes spread over a Dask cluster: chunks of frames baked as tasks, then merged.

A sequence is cut into chunks of consecutive frames. Each chunk is one Dask task that
runs :func:`haze.bake` on its frames. It first fits the ``overlap`` frames before its
first and drops them, so its first kept frame is fitted warm, as in one bake of the
whole sequence. Every chunk starts with the sequence's first frame's RBFs per voxel of
smoke and holds its frames to that frame's error (its baseline, fitted once before the
chunks), as one bake of the whole sequence does: without it a chunk's RBF count restarts
from its own cold start, and the error jumps at its boundary.
The chunks are written next to the output (shared storage) and joined by
:func:`haze.merge` into one asset; then they are removed.

Why Dask (``distributed``) rather than Ray: it is plain Python with no daemon to
install. The same code runs on a laptop (``LocalCluster``), on an HPC batch system
(``dask-jobqueue``: SLURM, PBS, SGE), on Kubernetes (``dask-kubernetes``) or on a
cluster started by hand (``dask scheduler`` / ``dask worker``). Its scheduler retries
failed tasks and reschedules those of lost workers. Our tasks are coarse (minutes of
native code that releases the GIL) and exchange only file paths, so Ray's fine-grained
actors and shared object store would bring nothing here.

Real cluster recipe::

    # on the scheduler machine
    dask scheduler                       # listens on tcp://HOST:8786
    # on every worker machine, with the smoke cache and the output on shared storage
    # (NFS, Lustre, ...) at the same path, and haze installed (pip install ./python)
    RAYON_NUM_THREADS=8 dask worker tcp://HOST:8786 --nworkers 1 --nthreads 1

    # anywhere
    from distributed import Client
    import haze.cluster
    haze.cluster.bake("/shared/cache", "/shared/smoke.haze", Client("tcp://HOST:8786"))
"""

from __future__ import annotations

import math
import os
import shutil
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

from . import _haze

__all__ = ["bake", "plan"]

PathLike = Union[str, "os.PathLike[str]"]


def plan(
    numbers: List[int], chunk: int, overlap: int, sizes: Optional[List[float]] = None
) -> List[Tuple[int, int, int]]:
    """The chunks of a bake of frames ``numbers`` (in order): ``(first, last, warm_up)``
    per chunk, each warmed up on the ``overlap`` frames before it (none for the first).

    There are ``ceil(len(numbers) / chunk)`` chunks. Without ``sizes`` each has
    ``chunk`` frames (the last may be shorter). With ``sizes`` (a frame's cost, e.g. its
    file's bytes) the cuts fall where the cumulative cost crosses equal shares. Growing
    smoke then gets shorter chunks late, where a frame holds more RBFs.
    """
    if chunk < 1:
        raise _haze.HazeError(f"chunk={chunk} must be at least 1 frame")
    if overlap < 0:
        raise _haze.HazeError(f"overlap={overlap} must be 0 or more frames")
    n = len(numbers)
    if sizes is not None:
        if len(sizes) != n:
            raise _haze.HazeError(f"sizes holds {len(sizes)} costs for {n} frames (one a frame)")
        bad = [w for w in sizes if not (math.isfinite(float(w)) and float(w) >= 0.0)]
        if bad:
            raise _haze.HazeError(f"sizes: {bad[0]} is not a cost (a finite number ≥ 0)")
    count = -(-n // chunk) if n else 0
    if sizes is None or count <= 1:
        starts = list(range(0, n, chunk))
    else:
        weights = [float(w) for w in sizes]
        total = sum(weights) or float(n)
        if not sum(weights):
            weights = [1.0] * n
        starts, acc, k = [0], 0.0, 1
        for i, w in enumerate(weights[:-1]):
            acc += w
            # A cut after frame i once the cost so far reaches the k-th share, keeping
            # at least one frame a chunk.
            if k < count and acc >= total * k / count and i + 1 > starts[-1]:
                starts.append(i + 1)
                k += 1
    out = []
    for c, start in enumerate(starts):
        end = starts[c + 1] if c + 1 < len(starts) else n
        out.append((numbers[start], numbers[end - 1], min(overlap, start)))
    return out


def _baseline(
    src: str, frames: Optional[str], rbfs: Optional[int], grid: str
) -> Tuple[str, Any]:
    """The sequence's first-frame figures, on a worker (bad input returned, as below)."""
    try:
        return ("ok", _haze.baseline(src, frames, rbfs, grid))
    except _haze.HazeError as e:
        return ("error", str(e))


def _bake_chunk(
    src: str,
    part: str,
    first: int,
    last: int,
    warm_up: int,
    rbfs: Optional[int],
    residual_error: Optional[float],
    baseline: Optional[Tuple[float, float, float, int, int]],
    grid: str,
) -> Tuple[str, Any]:
    """One chunk, on a worker. Bad input is returned, not raised: the engine retries a
    raised exception, and bad input fails the same way every time."""
    from . import bake as bake_frames

    try:
        report = bake_frames(
            src,
            part,
            frames=f"{first}..{last}",
            rbfs=rbfs,
            residual_error=residual_error,
            warm_up=warm_up,
            baseline=baseline,
            grid=grid,
        )
    except _haze.HazeError as e:
        return ("error", str(e))
    return ("ok", report)


def bake(
    src: PathLike,
    out: PathLike,
    client: Any = None,
    *,
    frames: Union[None, int, str, Tuple[int, int]] = None,
    chunk: int = 24,
    overlap: int = 3,
    rbfs: Optional[int] = None,
    residual_error: Optional[float] = None,
    workdir: Optional[PathLike] = None,
    retries: int = 2,
    progress: Optional[Callable[[Dict[str, Any]], None]] = None,
    grid: str = "density",
) -> Dict[str, Any]:
    """Bake ``src`` into ``out`` on a Dask cluster, chunk by chunk, then merge.

    Args:
        src: a frame directory or glob (or a packed asset), at a path every worker
            can read.
        out: the asset to write, on storage the driver can write (it must not be an
            input).
        client: a ``distributed.Client``; the current one by default.
        frames: which frames (as :func:`haze.bake` takes them); all by default.
        chunk: frames per task on average (24): the sequence is cut into
            ``ceil(frames / chunk)`` chunks of about equal cost (each frame's file
            size), and the dearest run first. Smaller chunks spread wider and cost
            more warm-up.
        overlap: frames fitted before each chunk and dropped (3). The first kept
            frame then starts warm. 0 starts every chunk cold: expect a jump in the
            error and in the RBFs at each boundary.
        rbfs, residual_error, grid: as :func:`haze.bake`.
        workdir: where the chunks are written, visible to every worker and to the
            driver. By default ``.OUT.chunks`` beside ``out``. The chunks are removed
            when done, and the folder too if the bake made it.
        retries: how often the engine reruns a chunk that raised (a worker lost or
            out of memory). A chunk that fails on bad input is not retried: the bake
            stops with that input's one-line error.
        progress: called as each chunk finishes, with ``{"first", "last",
            "warm_up", "report"}`` (the chunk's :func:`haze.bake` report).

    Returns:
        ``{"output", "frames", "chunks", "seconds"}``: the merged asset, its frame
        numbers, each chunk's ``(first, last, warm_up)`` and report, and the wall
        time.

    Raises:
        HazeError: bad input (the first failing chunk's message), or no client.
    """
    from distributed import as_completed, get_client

    start = time.monotonic()
    src, out = os.fspath(src), os.fspath(out)
    if client is None:
        try:
            client = get_client()
        except ValueError:
            raise _haze.HazeError(
                "haze.cluster.bake: no Dask client: pass client=, or create one "
                "(distributed.Client(...))"
            ) from None
    from . import _frames

    sized = _haze.frame_sizes(src, _frames(frames))
    numbers = [number for number, _ in sized]
    sizes = [size for _, size in sized]
    chunks = plan(numbers, chunk, overlap, sizes)
    # A chunk's cost: its frames' sizes, warm-up included. The dearest start first, so a
    # worker that finishes early is left the cheap ones.
    index = {number: i for i, number in enumerate(numbers)}

    def cost(first: int, last: int, warm: int) -> float:
        return float(sum(sizes[index[first] - warm : index[last] + 1]))
    # The whole sequence's first frame, fitted once: every chunk holds its frames to it.
    status, base = client.submit(
        _baseline, src, _frames(frames), rbfs, grid, retries=retries, pure=False
    ).result()
    if status == "error":
        raise _haze.HazeError(base)
    folder = Path(workdir) if workdir is not None else Path(out).parent / f".{Path(out).name}.chunks"
    created = not folder.exists()
    folder.mkdir(parents=True, exist_ok=True)
    parts = [str(folder / f"chunk_{first}_{last}.haze") for first, last, _ in chunks]
    futures = {
        client.submit(
            _bake_chunk,
            src,
            part,
            first,
            last,
            warm,
            rbfs,
            residual_error,
            # The first chunk starts where the sequence does: its own cold start is it.
            base if warm > 0 or first != numbers[0] else None,
            grid,
            key=f"haze-bake-{first}-{last}-{time.time_ns()}",
            retries=retries,
            pure=False,
            priority=cost(first, last, warm),
        ): (first, last, warm)
        for part, (first, last, warm) in zip(parts, chunks)
    }
    done: Dict[Tuple[int, int, int], Any] = {}
    try:
        for future in as_completed(list(futures)):
            status, value = future.result()
            if status == "error":
                raise _haze.HazeError(value)
            spec = futures[future]
            done[spec] = value
            if progress is not None:
                progress({"first": spec[0], "last": spec[1], "warm_up": spec[2], "report": value})
        merged = _haze.merge(parts, out)
    except BaseException:
        for f in futures:
            f.cancel()
        raise
    finally:
        # Only what this bake wrote: the chunks, their journals, the folder if it made it.
        for part in parts:
            for leftover in (Path(part), Path(part + ".partial")):
                leftover.unlink(missing_ok=True)
        if created:
            shutil.rmtree(folder, ignore_errors=True)
    return {
        "output": out,
        "frames": merged,
        "chunks": [
            {"first": c[0], "last": c[1], "warm_up": c[2], "report": done[c]} for c in chunks
        ],
        "seconds": time.monotonic() - start,
    }
