"""`haze.cluster.bake` on a LocalCluster of two worker processes: the chunks, warmed up
on the frames before them, merge into an asset as accurate as one sequential bake's;
bad input stops the bake with its one-line error and leaves nothing behind."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import haze
import haze.cluster
from test_package import write_sequence

distributed = pytest.importorskip("distributed")

PLUME = Path(__file__).resolve().parents[2] / "data" / "plume-a" / "vdb"


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        env={"RAYON_NUM_THREADS": "1"},
    )
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def test_plan_cuts_chunks_and_warms_all_but_the_first():
    assert haze.cluster.plan([1, 2, 3, 4, 5, 6, 7], 3, 2) == [(1, 3, 0), (4, 6, 2), (7, 7, 2)]
    assert haze.cluster.plan([5, 6], 1, 4) == [(5, 5, 0), (6, 6, 1)]
    # By cost: two chunks of equal cost, the dear frames in a short one.
    assert haze.cluster.plan([1, 2, 3, 4, 5, 6], 3, 1, [1, 1, 1, 1, 4, 4]) == [
        (1, 5, 0), (6, 6, 1)
    ]
    # No cost at all: by count.
    assert haze.cluster.plan([1, 2, 3, 4], 2, 0, [0, 0, 0, 0]) == [(1, 2, 0), (3, 4, 0)]
    with pytest.raises(haze.HazeError, match="chunk=0"):
        haze.cluster.plan([1], 0, 0)
    # Costs that do not describe the frames are refused, not read as some other plan.
    with pytest.raises(haze.HazeError, match="2 costs for 5 frames"):
        haze.cluster.plan([1, 2, 3, 4, 5], 2, 1, [1, 2])
    for bad in (float("nan"), float("inf"), -1):
        with pytest.raises(haze.HazeError, match="is not a cost"):
            haze.cluster.plan([1, 2, 3], 1, 0, [1, bad, 1])


def rel_l2(report):
    """Each frame's rel_l2 of a bake report, or of a cluster bake's chunks."""
    if "chunks" in report:
        return {f["frame"]: f["rel_l2"] for c in report["chunks"] for f in c["report"]["frames"]}
    return {f["frame"]: f["rel_l2"] for f in report["frames"]}


def test_a_cluster_bake_keeps_the_sequential_bakes_error(client, tmp_path):
    seq = rel_l2(haze.bake(PLUME, tmp_path / "one.haze", rbfs=60))
    whole = haze.Asset(tmp_path / "one.haze")
    # Warmed up on every frame before it, each chunk is the sequential bake's, voxel for
    # voxel.
    seen = []
    full = haze.cluster.bake(
        PLUME, tmp_path / "full.haze", client, chunk=3, overlap=8, rbfs=60,
        progress=seen.append,
    )
    assert full["frames"] == list(range(21, 29))
    assert len(seen) == 3 and sorted(c["warm_up"] for c in seen)[0] == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["full.haze", "one.haze"]
    spread = haze.Asset(tmp_path / "full.haze")
    for n in whole.frames:
        np.testing.assert_array_equal(spread.frame(n), whole.frame(n), err_msg=f"frame {n}")
    # One frame of warm-up, the chunks held to the sequence's baseline: within 2 % of
    # the sequential error on every frame.
    short = rel_l2(haze.cluster.bake(PLUME, tmp_path / "short.haze", client, chunk=3,
                                     overlap=1, rbfs=60))
    assert all(short[n] <= 1.02 * seq[n] for n in seq), (short, seq)
    # What the baseline buys: a plain chunk of the same frames settles on its own cold
    # start's error.
    plain = rel_l2(haze.bake(PLUME, tmp_path / "plain.haze", frames="24..28", rbfs=60))
    assert max(plain[n] / seq[n] for n in plain) > 1.02, (plain, seq)


def test_bad_input_stops_the_bake_with_its_error(client, tmp_path):
    folder = tmp_path / "seq"
    folder.mkdir()
    write_sequence(folder, 4)
    broken = folder / "density_0003.f32"
    broken.write_bytes(broken.read_bytes()[:1000])
    out = tmp_path / "bad.haze"
    with pytest.raises(haze.HazeError, match="density_0003"):
        haze.cluster.bake(folder, out, client, chunk=2, overlap=1, rbfs=20)
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["seq"]
    # The grid reaches the workers: one the files do not hold is named.
    with pytest.raises(haze.HazeError, match="no grid named 'smoke'"):
        haze.cluster.bake(PLUME, out, client, frames=(21, 22), rbfs=20, grid="smoke")
    assert not out.exists()


def test_no_client_is_a_clear_error(tmp_path):
    # In a fresh interpreter: this module's cluster would be the current client here.
    code = (
        "import haze, haze.cluster, sys\n"
        "try:\n"
        f"    haze.cluster.bake({str(PLUME)!r}, {str(tmp_path / 'x.haze')!r})\n"
        "except haze.HazeError as e:\n"
        "    print(e)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert "no Dask client" in out.stdout, out.stderr
    assert not (tmp_path / "x.haze").exists()
