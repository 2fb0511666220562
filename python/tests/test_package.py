"""The `haze` Python package end to end: inspect, bake (progress, interruption, resume,
nothing lost), assets as arrays (checked against NumPy's own evaluation and the source
volume), renders (checked against the command line's image) and errors."""

import _thread
import io
import json
import os
import signal
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import numpy as np
import pytest

import haze

ROOT = Path(__file__).resolve().parents[2]
DENSE = ROOT / "data" / "plume-a" / "dense"
SCENES = ROOT / "data" / "scenes"


def haze_bin() -> str:
    """The command-line tool of the same build (CI builds it before the wheel)."""
    return os.environ.get("HAZE_BIN", str(ROOT / "target" / "debug" / "haze"))


def source_frame() -> np.ndarray:
    """Bundled plume-a frame 24, (z, y, x), from its raw file."""
    meta = json.loads((DENSE / "density_0024.json").read_text())
    nx, ny, nz = meta["dims"]
    return np.fromfile(DENSE / "density_0024.f32", dtype="<f4").reshape(nz, ny, nx)


def write_sequence(folder: Path, count: int) -> np.ndarray:
    """`count` raw frames (plume-a 24, shifted one voxel up per frame) with their
    sidecars; returns them stacked (frame, z, y, x)."""
    meta = json.loads((DENSE / "density_0024.json").read_text())
    base = source_frame()
    frames = []
    for k in range(count):
        v = np.roll(base, k, axis=0)
        v[:k] = 0.0
        stem = folder / f"density_{k + 1:04d}"
        v.astype("<f4").tofile(stem.with_suffix(".f32"))
        stem.with_suffix(".json").write_text(
            json.dumps(
                {
                    "dims": meta["dims"],
                    "world_bbox_min": meta["world_bbox_min"],
                    "world_bbox_max": meta["world_bbox_max"],
                }
            )
        )
        frames.append(v)
    return np.stack(frames)


def rbf_density(asset: "haze.Asset", number: int) -> np.ndarray:
    """The RBFs of a frame summed by NumPy at the voxel centers (cut off at 3 radii),
    independently of the library's own evaluation."""
    centers, radii, weights = asset.rbfs(number)
    (x0, y0, z0), (x1, y1, z1) = asset.bbox
    nx, ny, nz = asset.dims
    axes = [
        lo + (np.arange(n) + 0.5) * (hi - lo) / n
        for lo, hi, n in ((z0, z1, nz), (y0, y1, ny), (x0, x1, nx))
    ]
    z, y, x = np.meshgrid(*axes, indexing="ij")
    total = np.zeros_like(x)
    for (cx, cy, cz), r, w in zip(centers, radii, weights):
        q2 = ((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / (r * r)
        total += np.where(q2 < 9.0, w * np.exp(-q2), 0.0)
    return total


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    """Three frames baked with 60 RBFs, the progress records kept."""
    folder = tmp_path_factory.mktemp("seq")
    source = write_sequence(folder, 3)
    out = folder.parent / "seq.haze"
    seen = []
    report = haze.bake(folder, out, rbfs=60, progress=seen.append)
    return source, out, report, seen


def test_inspect_describes_volumes_and_names_a_missing_file(tmp_path):
    info = haze.inspect(DENSE / "density_0024.f32")
    assert json.dumps(info)  # plain JSON types
    text = json.dumps(info)
    assert "48" in text and "64" in text
    missing = tmp_path / "nothing.vdb"
    with pytest.raises(haze.HazeError, match="nothing.vdb"):
        haze.inspect(missing)
    vdbs = ROOT / "data" / "plume-a" / "vdb"
    assert haze.inspect(vdbs, frames=21, grid="density")["dims"] == [48, 48, 64]
    with pytest.raises(haze.HazeError, match="no grid named 'smoke'.*density"):
        haze.inspect(vdbs, frames=21, grid="smoke")


def test_inspect_describes_an_environment_map(tmp_path):
    # A 16 x 8 Radiance map (flat RGBE scanlines): a sky of 0.3125 with one bright texel
    # of 500 (250 * 2^(137 - 136)) that carries most of the power.
    sky, sun = bytes([80, 80, 80, 128]), bytes([250, 250, 250, 137])
    texels = [sun if (x, y) == (5, 2) else sky for y in range(8) for x in range(16)]
    path = tmp_path / "sky.hdr"
    path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n" + b"".join(texels))
    info = haze.inspect(path)
    assert info["kind"] == "environment-map" and info["format"] == "Radiance HDR"
    assert (info["width"], info["height"], info["max_radiance"]) == (16, 8, 500.0)
    assert len(info["suns"]) == 1 and info["sun_share"] > 0.5
    # A picture that is not lat-long (3 x 1) is described as an image, not refused.
    wide = tmp_path / "wide.hdr"
    wide.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 3\n" + sky * 3)
    info = haze.inspect(wide)
    assert info["kind"] == "image" and (info["width"], info["height"]) == (3, 1)
    assert info["mean_rgb"] == [0.3125] * 3 and "suns" not in info


def test_a_bake_reports_every_frame_and_keeps_its_error(baked):
    source, out, report, seen = baked
    assert [r["frame"] for r in seen] == [1, 2, 3]
    assert report["totals"]["frames"] == 3
    assert report["totals"]["bytes"] == out.stat().st_size
    assert all(r["rbfs"] > 0 for r in report["frames"])
    asset = haze.Asset(out)
    assert asset.frames == [1, 2, 3] and len(asset) == 3
    assert asset.dims == (48, 48, 64)
    for k, number in enumerate(asset.frames):
        density = asset.frame(number)
        assert density.dtype == np.float32 and density.shape == (64, 48, 48)
        # The bake's bound: every voxel within the residual error (1/255 of the peak)
        # of the source, plus float32 rounding.
        peak = float(source[k].max())
        assert np.abs(density - source[k]).max() <= peak / 255.0 + 1e-5


def test_a_frame_written_as_openvdb_reads_back_as_the_frame(baked, tmp_path):
    _, out, _, _ = baked
    asset = haze.Asset(out)
    vdb = asset.write_vdb(2, tmp_path / "f2.vdb")
    assert vdb == tmp_path / "f2.vdb"
    info = haze.inspect(vdb)
    density = asset.frame(2)
    assert info["dims"] == list(asset.dims)
    assert (tuple(info["bbox_min"]), tuple(info["bbox_max"])) == tuple(map(tuple, asset.bbox))
    assert info["active_voxels"] == int(np.count_nonzero(density))
    assert np.float32(info["value_max"]) == density.max()
    assert abs(info["value_sum"] - float(density.sum(dtype=np.float64))) <= 1e-9 * info["value_sum"]
    grid = info["vdb"]["grids"][0]
    assert (grid["name"], grid["class"], grid["half_float"]) == ("density", "fog volume", False)
    # Only .vdb, written whole or not at all.
    with pytest.raises(haze.HazeError, match=r"f2.npy: write_vdb writes OpenVDB"):
        asset.write_vdb(2, tmp_path / "f2.npy")
    with pytest.raises(haze.HazeError, match="frame 9 is not in the asset"):
        asset.write_vdb(9, tmp_path / "f9.vdb")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f2.vdb"]


def test_rbfs_are_what_the_asset_reconstructs(tmp_path):
    # With a residual error of the whole peak nothing is stored beyond the RBFs: the
    # frame is exactly their sum (clamped at 0), as NumPy evaluates it.
    folder = tmp_path / "one"
    folder.mkdir()
    write_sequence(folder, 1)
    out = tmp_path / "rbfs.haze"
    haze.bake(folder, out, rbfs=40, residual_error=1.0)
    asset = haze.Asset(out)
    centers, radii, weights = asset.rbfs(1)
    assert centers.shape == (len(radii), 3) and len(radii) == len(weights) >= 40
    want = np.maximum(rbf_density(asset, 1), 0.0)
    got = asset.frame(1)
    assert np.abs(got - want).max() <= 1e-5 * max(1.0, want.max())


def test_an_output_naming_an_input_is_refused_untouched(tmp_path):
    src = tmp_path / "density_0001.f32"
    write_sequence(tmp_path, 1)
    before = src.read_bytes()
    with pytest.raises(haze.HazeError, match="density_0001"):
        haze.bake(src, src)
    assert src.read_bytes() == before
    with pytest.raises(haze.HazeError, match="rbfs=0"):
        haze.bake(src, tmp_path / "x.haze", rbfs=0)
    with pytest.raises(haze.HazeError, match=r"x.bin: out must end in \.haze"):
        haze.bake(src, tmp_path / "x.bin")
    with pytest.raises(haze.HazeError, match="no chunks to merge"):
        haze.merge([], tmp_path / "m.haze")
    assert not (tmp_path / "m.haze").exists()
    with pytest.raises(haze.HazeError, match="gone.haze: no such file or directory"):
        haze.Asset(tmp_path / "gone.haze")


def test_a_progress_exception_stops_and_resume_finishes(tmp_path):
    folder = tmp_path / "seq"
    folder.mkdir()
    write_sequence(folder, 3)
    out = tmp_path / "stop.haze"

    def stop(record):
        if record["frame"] == 2:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        haze.bake(folder, out, rbfs=30, progress=stop)
    assert not out.exists()
    journal = Path(str(out) + ".partial")
    assert journal.exists()
    seen = []
    haze.bake(folder, out, rbfs=30, resume=True, progress=seen.append)
    # The two finished frames are not fitted again.
    assert [r["frame"] for r in seen] == [3]
    assert haze.Asset(out).frames == [1, 2, 3] and not journal.exists()


def test_ctrl_c_stops_after_the_frame_and_keeps_it(tmp_path):
    folder = tmp_path / "seq"
    folder.mkdir()
    write_sequence(folder, 8)
    out = tmp_path / "int.haze"
    # Ctrl-C arrives while a frame is being fitted (the GIL released): 10 ms after the
    # first frame is reported, while the seven frames after it still have to be fitted
    # (without the delay it could fire in the callback itself).
    timers = []

    def ctrl_c_soon(report):
        if report["frame"] == 1:
            timers.append(threading.Timer(0.01, _thread.interrupt_main))
            timers[-1].start()

    # Python's own Ctrl-C handler, as an interactive session has it: a process started in
    # the background inherits SIGINT ignored, and then `interrupt_main` does nothing.
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt, match="for --resume"):
            haze.bake(folder, out, rbfs=30, progress=ctrl_c_soon)
    finally:
        signal.signal(signal.SIGINT, inherited)
        for t in timers:
            t.join()
    assert not out.exists() and Path(str(out) + ".partial").exists()
    haze.bake(folder, out, rbfs=30, resume=True)
    assert haze.Asset(out).frames == list(range(1, 9))


def read_exr(path):
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        channels = f.channels()
        if "RGB" in channels:
            return np.asarray(channels["RGB"].pixels, dtype=np.float32)
        return np.stack([np.asarray(channels[c].pixels) for c in "RGB"], axis=-1)


def test_render_is_the_command_lines_image(tmp_path):
    asset = SCENES / "plume.haze"
    image = haze.render(asset, width=40, height=30, suns=[(0.3, 1, 0.6, 30, 28, 26, 2)])
    assert image.dtype == np.float32 and image.shape == (30, 40, 3)
    assert np.isfinite(image).all() and image.min() >= 0.0
    out = tmp_path / "cli.exr"
    subprocess.run(
        [haze_bin(), "render", str(asset), "--out", str(out), "--width", "40",
         "--height", "30", "--sun", "0.3,1,0.6,30,28,26,2", "-q"],
        check=True,
    )
    np.testing.assert_array_equal(image, read_exr(out))
    # The ground: on by default under the built-in sky, the same as the command line's.
    bare = haze.render(asset, width=40, height=30, suns=[(0.3, 1, 0.6, 30, 28, 26, 2)],
                       ground="off")
    assert not np.array_equal(bare, image)
    subprocess.run(
        [haze_bin(), "render", str(asset), "--out", str(out), "--width", "40",
         "--height", "30", "--sun", "0.3,1,0.6,30,28,26,2", "--ground", "off", "-q"],
        check=True,
    )
    np.testing.assert_array_equal(bare, read_exr(out))


def test_render_errors_are_haze_errors(tmp_path):
    with pytest.raises(haze.HazeError, match="missing.haze"):
        haze.render(tmp_path / "missing.haze")
    with pytest.raises(haze.HazeError, match="supersample"):
        haze.render(SCENES / "plume.haze", width=8, height=6, supersample=9)
    with pytest.raises(haze.HazeError, match="ground"):
        haze.render(SCENES / "plume.haze", width=8, height=6, ground="maybe")
    with pytest.raises(haze.HazeError, match="suns"):
        haze.render(SCENES / "plume.haze", suns=[(0, 0, 1)])
    with pytest.raises(haze.HazeError, match="env_layout"):
        haze.render(SCENES / "plume.haze", width=8, height=6, env_layout="maya")
    with pytest.raises(haze.HazeError, match="env_rotate"):
        haze.render(SCENES / "plume.haze", width=8, height=6, env_rotate=float("nan"))
    with pytest.raises(haze.HazeError, match="env_strength"):
        haze.render(SCENES / "plume.haze", width=8, height=6, env_strength=-1.0)


def test_a_map_in_blenders_layout_is_the_command_lines(tmp_path):
    import OpenEXR

    # A dim sky and a sun at column 5 of 64, 20° up.
    w, h = 64, 32
    texels = np.full((h, w, 3), 0.25, np.float32)
    texels[12, 5] = 512.0
    path = tmp_path / "sun.exr"
    OpenEXR.File({"type": OpenEXR.scanlineimage}, {"RGB": texels}).write(str(path))
    asset = SCENES / "plume.haze"
    kw = dict(width=24, height=18, env=path)
    blender = haze.render(asset, env_layout="blender", env_rotate=15, env_strength=1.5, **kw)
    assert not np.array_equal(blender, haze.render(asset, **kw))
    out = tmp_path / "cli.exr"
    subprocess.run(
        [haze_bin(), "render", str(asset), "--out", str(out), "--width", "24",
         "--height", "18", "--env", str(path), "--env-layout", "blender",
         "--env-rotate", "15", "--env-strength", "1.5", "-q"],
        check=True,
    )
    np.testing.assert_array_equal(blender, read_exr(out))
    # haze.inspect places the map as haze.render does, as `haze inspect` does.
    placed = dict(env_layout="blender", env_rotate=22.5)
    said = haze.inspect(path, **placed)
    cli = subprocess.run(
        [haze_bin(), "inspect", "--json", str(path), "--env-layout", "blender",
         "--env-rotate", "22.5"],
        check=True, capture_output=True, text=True,
    )
    assert said == json.loads(cli.stdout)
    # Column 5's centre in Blender's layout, 180° − 360°·5.5/64, then four texels on.
    assert abs(said["suns"][0]["azimuth_degrees"] - (180.0 - 30.9375 + 22.5)) < 1e-9
    with pytest.raises(haze.HazeError, match="not an environment map"):
        haze.inspect(asset, **placed)
    with pytest.raises(haze.HazeError, match="env_layout: 'maya'"):
        haze.inspect(path, env_layout="maya")


def test_a_scene_renders_from_its_file_and_from_a_dict():
    path = SCENES / "room.json"
    from_file = haze.render_scene(path, width=32, height=24)
    assert from_file.shape == (24, 32, 3) and np.isfinite(from_file).all()
    scene = json.loads(path.read_text())
    from_dict = haze.render_scene(scene, width=32, height=24, base=SCENES)
    np.testing.assert_array_equal(from_file, from_dict)
    assert not list(SCENES.glob(".haze-scene-*"))
    # NumPy numbers and arrays are the numbers and lists they hold.
    camera = scene["camera"]
    camera["eye"] = np.asarray(camera["eye"])
    camera["fov"] = np.int64(camera["fov"])
    from_numpy = haze.render_scene(scene, width=32, height=24, base=SCENES)
    np.testing.assert_array_equal(from_file, from_numpy)


def test_warnings_are_python_warnings_and_nothing_is_printed(tmp_path, capfd):
    # A model outside where it holds: the bundled sky scene with every Gaussian ten times
    # as dense is rendered, with the command line's warning as a HazeWarning.
    scene = json.loads((SCENES / "gaussians_sky.json").read_text())
    for g in scene["media"][0]["gaussians"]:
        g["weight"] *= 10.0
    with pytest.warns(haze.HazeWarning, match="dense for the environment's light") as caught:
        image = haze.render_scene(scene, width=8, height=6, base=SCENES)
    assert np.isfinite(image).all()
    assert caught[0].filename == __file__, "attributed to the caller's line"
    # Frames missing from a sequence (an Adaptive Domain's frames 1 and 6).
    adaptive = ROOT / "data" / "blender-adaptive" / "adaptive" / "data"
    with pytest.warns(haze.HazeWarning, match=r"missing frames \[\(2, 5\)\]"):
        report = haze.bake(adaptive, tmp_path / "a.haze", rbfs=10)
    assert [f["frame"] for f in report["frames"]] == [1, 6]
    assert haze.Asset(tmp_path / "a.haze").dims == (21, 21, 32)
    # Python's filters apply: "error" turns the warning into the call's exception.
    with warnings.catch_warnings():
        warnings.simplefilter("error", haze.HazeWarning)
        with pytest.raises(haze.HazeWarning, match="dense"):
            haze.render_scene(scene, width=8, height=6, base=SCENES)
    # No summary lines: a call returns its result and prints nothing.
    haze.render_scene(SCENES / "room.json", width=8, height=6)
    assert capfd.readouterr().err == ""


def test_a_gpu_render_is_the_cpu_render_and_quiet_without_a_session():
    # A fresh interpreter without a desktop session (XDG_RUNTIME_DIR unset, as in a
    # container or on a cluster worker): the GPU adapter is found without libwayland's
    # complaint (Mesa's device-select layer would have it printed twice), and the
    # picture is the CPU's within the GPU tolerance of the command line's test
    # (5e-4 relative plus 1e-5 of the mean, at most 1 % of the pixels outside).
    code = (
        "import sys, numpy as np, haze\n"
        f"room = {str(SCENES / 'room.json')!r}\n"
        "c = haze.render_scene(room, width=32, height=24)\n"
        "g = haze.render_scene(room, width=32, height=24, gpu=True)\n"
        "np.save(sys.stdout.buffer, np.stack([c, g]))\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_RUNTIME_DIR", "NODEVICE_SELECT")}
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True)
    assert run.returncode == 0, run.stderr.decode()
    assert b"XDG_RUNTIME_DIR" not in run.stderr, run.stderr.decode()
    c, g = np.load(io.BytesIO(run.stdout))
    assert np.isfinite(g).all() and c.mean() > 0
    outside = (np.abs(g - c) > 5e-4 * np.abs(c) + 1e-5 * c.mean()).any(axis=-1).sum()
    assert outside * 100 <= c.shape[0] * c.shape[1], f"{outside} pixels differ"


def test_a_bad_scene_dict_is_named_as_the_dict(tmp_path):
    with pytest.raises(haze.HazeError, match="^the scene dict: missing field `camera`$"):
        haze.render_scene({}, base=tmp_path)
    with pytest.raises(haze.HazeError, match="the scene dict: a NaN or infinite number"):
        haze.render_scene({"camera": {"fov": float("nan")}}, base=tmp_path)
    with pytest.raises(haze.HazeError, match="the scene dict: set is not a number"):
        haze.render_scene({"camera": {"eye": {1, 2}}}, base=tmp_path)
    assert not list(tmp_path.iterdir())


def test_help_explains_every_argument():
    import inspect as pyinspect

    for fn in (haze.bake, haze.render, haze.render_scene, haze.inspect):
        doc = pyinspect.getdoc(fn)
        for name in pyinspect.signature(fn).parameters:
            assert name in doc, f"{fn.__name__}: {name} undocumented"
    assert haze.__version__


def test_a_bad_baseline_is_refused(tmp_path):
    write_sequence(tmp_path, 1)
    for bad in [(float("nan"), 1.0, 1.0, 10, 10), (0.1, 1.0, 1.0, 0, 10), (0.1, -1.0, 1.0, 5, 5)]:
        with pytest.raises(haze.HazeError, match="baseline="):
            haze.bake(tmp_path, tmp_path / "x.haze", baseline=bad)
        assert not (tmp_path / "x.haze").exists()


def test_vdb_index_places_another_tools_grid(tmp_path):
    # A grid written by OpenVDB's own writer, no Blender domain recorded: its index is the
    # voxel's centre (the box starts half a voxel, 0.05, below index 0's point); "corner"
    # reads it as Blender's caches are read. A bad word is refused, nothing written.
    src = ROOT / "data" / "synthetic" / "half_ball.vdb"
    lo = {}
    for at in (None, "corner"):
        out = tmp_path / f"{at}.haze"
        haze.bake(src, out, rbfs=10, vdb_index=at)
        lo[at] = np.array(haze.Asset(out).bbox[0])
    assert np.allclose(lo["corner"] - lo[None], 0.05, atol=1e-9), lo
    with pytest.raises(haze.HazeError, match="vdb_index="):
        haze.bake(src, tmp_path / "x.haze", vdb_index="middle")
    assert not (tmp_path / "x.haze").exists()
