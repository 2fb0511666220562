"""haze: bake smoke simulations into compact assets, and light them.

A first bake, from Python::

    import haze
    report = haze.bake("cache/", "smoke.haze", progress=print)
    density = haze.Asset("smoke.haze").frame(report["frames"][0]["frame"])

Every function runs the same code as the ``haze`` command line (its defaults, its
checks, its one-line errors, raised as :class:`HazeError`; its warnings, issued as
:class:`HazeWarning` through :mod:`warnings` when the call returns), with the GIL released
while it works; it prints nothing (no summary lines or progress bars: ``bake`` reports
progress to its callback). Volumes come back as float32 arrays shaped ``(nz, ny, nx)``, images as
float32 ``(height, width, 3)`` linear radiance. World units are the volume's; Z is up.
"""

from __future__ import annotations

import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

# Mesa's Vulkan device-select layer asks Wayland for the display's GPU while an adapter is
# sought; without a desktop session (XDG_RUNTIME_DIR unset or not absolute: a container,
# ssh, a cluster worker) libwayland prints two "XDG_RUNTIME_DIR is invalid" lines on
# stderr at the first GPU render. There is no display to pick a GPU for then, so the
# layer is turned off with its own switch, unless it was set (as the command line does).
if not os.path.isabs(os.environ.get("XDG_RUNTIME_DIR", "")):
    os.environ.setdefault("NODEVICE_SELECT", "1")

from . import _haze
from ._haze import Asset, HazeError, HazeWarning

__all__ = [
    "Asset",
    "HazeError",
    "HazeWarning",
    "bake",
    "inspect",
    "merge",
    "render",
    "render_scene",
    "__version__",
]

__version__: str = _haze.version()

PathLike = Union[str, "os.PathLike[str]"]
Frames = Union[None, int, str, Tuple[int, int]]


def _frames(frames: Frames) -> Optional[str]:
    """``frames`` in the command line's ``A..B`` syntax."""
    if frames is None:
        return None
    if isinstance(frames, str):
        return frames
    if isinstance(frames, int):
        return str(frames)
    first, last = frames
    return f"{'' if first is None else first}..{'' if last is None else last}"


def inspect(
    path: PathLike,
    frames: Frames = None,
    grid: str = "density",
    env_layout: str = "haze",
    env_rotate: float = 0.0,
    env_strength: float = 1.0,
) -> Dict[str, Any]:
    """What is in a volume file, a frame sequence, a ``.haze`` asset or an environment map.

    Returns what ``haze inspect --json PATH`` prints, as a dict: for an asset its
    frames, grid, blocks and per-frame figures; for volumes their dims, world box,
    value range and active voxels; for a lat-long map (``.exr`` or ``.hdr``) its size,
    brightest texel, power and the suns a render splits off it (``kind`` is
    ``"environment-map"``); any other ``.exr`` or ``.hdr`` picture (a render) gives its
    size, brightest value and mean colour (``kind`` is ``"image"``).

    Args:
        path: a volume file (OpenVDB ``.vdb``, NumPy ``.npy``, raw ``.f32`` with its
            ``.json`` sidecar), a directory or glob of numbered frames, an asset, or an
            environment map.
        frames: for a sequence, which frames to read: an int, ``(first, last)``
            (inclusive; ``None`` for open ends) or ``"A..B"``; all by default.
        grid: the OpenVDB grid to read (``haze inspect --grid``).
        env_layout, env_rotate, env_strength: for a map, place it as :func:`render`
            does before splitting it into suns, so the suns reported are the render's
            (``haze inspect --env-layout/--env-rotate/--env-strength``).

    Raises:
        HazeError: the path is missing or unreadable (the message names it), or a
            placement is given for a path that is not a lat-long map.
    """
    return _haze.inspect(
        os.fspath(path), _frames(frames), grid, env_layout, float(env_rotate), float(env_strength)
    )


def bake(
    src: PathLike,
    out: PathLike,
    frames: Frames = None,
    rbfs: Optional[int] = None,
    residual_error: Optional[float] = None,
    resume: bool = False,
    progress: Optional[Callable[[Dict[str, Any]], None]] = None,
    warm_up: int = 0,
    domain_offset: Optional[Sequence[float]] = None,
    baseline: Optional[Tuple[float, float, float, int, int]] = None,
    grid: str = "density",
    vdb_index: Optional[str] = None,
) -> Dict[str, Any]:
    """Bake a sequence of density volumes into one ``.haze`` asset (``haze bake``).

    Every frame is fitted with Gaussian RBFs, warm-started from the frame before; the
    residual is quantized to ``residual_error`` and hashed; the asset is written to a
    temporary file and renamed into place when complete. Frames are journaled in
    ``OUT.partial`` as they finish.

    Args:
        src: a volume file, a directory or a glob of numbered frames (OpenVDB, NumPy,
            raw), or a packed asset.
        out: the asset to write, named ``*.haze``. It must not be one of the inputs
            (refused, nothing touched).
        frames: which frames: an int, ``(first, last)`` inclusive, or ``"A..B"``;
            every frame by default.
        rbfs: RBFs fitted to the first frame (later frames insert and delete as the
            smoke changes); 300 by default, at most 65 536.
        residual_error: the residual's error bound, a fraction of each frame's peak
            density (1/255 by default; 0 stores the residual losslessly).
        resume: continue the interrupted bake of ``out`` from its journal.
        progress: called after every finished frame with its report line (a dict:
            ``frame``, ``rbfs``, ``rel_l2``, ``rms_over_max``, the residual's figures
            and times). An exception it raises stops the bake, keeping the finished
            frames for ``resume=True``.
        warm_up: with ``frames`` starting at A, first fit the ``warm_up`` frames before
            A and drop them, so that A is fitted warm as in one bake of the whole
            sequence (a chunk of a bake spread over machines: see ``haze.cluster``).
        domain_offset: ``(x, y, z)`` added to OpenVDB grids' world coordinates, whose
            transforms are often local to the simulation domain (Blender's: the
            domain object's lower corner); none by default.
        baseline: ``(rel_l2, radius, gain, rbfs, support)`` of the whole sequence's
            first frame (``haze._haze.baseline``), which later frames are held to
            instead of the range's own first frame's: a chunk then starts with the
            sequence's RBFs per voxel of smoke and inserts towards the error one bake of
            the whole sequence reaches (see ``haze.cluster``).
        grid: the OpenVDB grid to read (``haze bake --grid``): ``"density"``, or e.g.
            ``"density_noise"`` for Blender's high-resolution noise cache.
        vdb_index: where an OpenVDB grid's transform puts a voxel's index
            (``haze bake --vdb-index``): ``"centre"`` (OpenVDB's convention: Houdini,
            EmberGen, haze's exports) or ``"corner"`` (Blender's fluid caches); by
            default the file's own word, else ``"corner"`` for a grid that records its
            Blender domain, else ``"centre"``.

    Returns:
        The report (``haze bake --report``): ``settings``, ``frames`` (one dict per
        frame), ``temporal`` (flicker measures), ``totals`` (seconds, bytes, frames).

    Raises:
        HazeError: bad input or options, with the command line's one-line message.
        KeyboardInterrupt: Ctrl-C stops after the frame being fitted; the finished
            frames stay in the journal and ``resume=True`` continues from them.
    """
    return _haze.bake(
        os.fspath(src),
        os.fspath(out),
        _frames(frames),
        rbfs,
        residual_error,
        resume,
        progress,
        warm_up,
        None if domain_offset is None else [float(v) for v in domain_offset],
        None if baseline is None else tuple(baseline),
        grid,
        vdb_index,
    )


def merge(chunks: Sequence[PathLike], out: PathLike) -> List[int]:
    """Join chunks of one sequence baked separately (``haze merge``).

    Args:
        chunks: the chunks' assets, in any order; together they must hold consecutive
            frames, each once, baked with the same settings.
        out: the asset to write, named ``*.haze`` (not one of the chunks).

    Returns:
        The merged asset's frame numbers, in order.

    Raises:
        HazeError: a gap, an overlap, other settings or a damaged chunk, named.
    """
    return _haze.merge([os.fspath(c) for c in chunks], os.fspath(out))


def render(
    input: PathLike,
    frame: Optional[int] = None,
    *,
    width: int = 400,
    height: int = 300,
    eye: Optional[Sequence[float]] = None,
    target: Optional[Sequence[float]] = None,
    up: Sequence[float] = (0.0, 0.0, 1.0),
    fov: float = 40.0,
    env: Union[str, PathLike] = "sky",
    suns: Sequence[Sequence[float]] = (),
    lights: Sequence[Sequence[float]] = (),
    sigma_t: float = 4.0,
    albedo: float = 0.8,
    g: float = 0.3,
    multiple: bool = True,
    residual: bool = True,
    sh_order: int = 4,
    gpu: bool = False,
    reference: bool = False,
    spp: int = 64,
    check: int = 0,
    supersample: Union[str, int] = "auto",
    ground: str = "auto",
    env_layout: str = "haze",
    env_rotate: float = 0.0,
    env_strength: float = 1.0,
) -> np.ndarray:
    """Render one frame of an asset or a volume (``haze render``).

    Args:
        input: a ``.haze`` asset, or a volume file / frame directory (fitted on the
            spot with 300 RBFs).
        frame: the source frame number (the first by default).
        width, height: the image size in pixels.
        eye, target: camera position and the point it looks at (world units), both or
            neither; without them the camera frames the smoke.
        up: the camera's up vector.
        fov: vertical field of view, degrees.
        env: ``"sky"`` (the built-in sky and its low sun, lit exactly; a sun given in
            ``suns`` replaces it), ``"glow"`` (the sky without its sun) or a lat-long
            OpenEXR or Radiance .hdr map (Z up, row 0 the zenith); a map's concentrated light is split
            off into suns lit exactly.
        suns: suns lit exactly, each ``(x, y, z, r, g, b[, angle])``: the direction
            towards it, its disk's radiance and apparent diameter in degrees (0.53).
        lights: point lights, each ``(x, y, z, r, g, b)``: position and intensity.
        sigma_t: extinction per unit density.
        albedo: single-scattering albedo, 0..1.
        g: Henyey–Greenstein asymmetry, -1..1.
        multiple: add multiple scattering.
        residual: put the baked residual back.
        sh_order: spherical-harmonic order, 1..6.
        gpu: render on the GPU (wgpu; Vulkan, Metal or DX12).
        reference: the slow path-traced reference instead.
        spp: samples per pixel of the reference.
        check: compare this many smoke pixels with the reference and log the
            estimated error (0: none).
        supersample: ``"auto"`` or 1..4: light the smoke on a grid this much finer
            than its voxels (``auto``: where voxels are optically thick).
        ground: ``"auto"``, ``"on"`` or ``"off"``: a ground under the smoke with its
            shadow, at the floor of the volume's box (``auto``: under the built-in
            skies, not under a map).
        env_layout: ``"haze"`` (a map's column u at azimuth 360°·u from +X towards +Y)
            or ``"blender"`` (as Blender's World reads an Environment Texture; read the
            other way, the same map lights the smoke mirrored).
        env_rotate: turn the map about +Z by this many degrees, counter-clockwise seen
            from above.
        env_strength: multiply the map's radiance (Blender's Background Strength).

    Returns:
        float32 array ``(height, width, 3)`` of linear radiance, row 0 at the top.

    Raises:
        HazeError: bad input or options, with the command line's one-line message.
    """
    return _haze.render(
        os.fspath(input),
        frame,
        width,
        height,
        None if eye is None else [float(v) for v in eye],
        None if target is None else [float(v) for v in target],
        [float(v) for v in up],
        float(fov),
        os.fspath(env),
        [[float(v) for v in s] for s in suns],
        [[float(v) for v in p] for p in lights],
        float(sigma_t),
        float(albedo),
        float(g),
        multiple,
        residual,
        sh_order,
        gpu,
        reference,
        spp,
        check,
        supersample,
        ground,
        env_layout,
        float(env_rotate),
        float(env_strength),
    )


def render_scene(
    scene: Union[PathLike, Dict[str, Any]],
    *,
    width: Optional[int] = None,
    height: Optional[int] = None,
    gpu: bool = False,
    reference: bool = False,
    time: float = 0.0,
    base: Optional[PathLike] = None,
) -> np.ndarray:
    """Render a scene (``haze render --scene``): camera, lights, fog, surfaces, media.

    Args:
        scene: a scene file's path, or the scene itself as a dict (the file's JSON).
        width, height: override the scene camera's image size.
        gpu: render on the GPU.
        reference: the same model integrated by quadrature (slow).
        time: seconds of wind carried by an analytic fog.
        base: for a dict, the folder its relative paths (models, maps, assets) are
            read from: the current directory by default.

    Returns:
        float32 array ``(height, width, 3)`` of linear radiance, row 0 at the top.

    Raises:
        HazeError: a bad scene, with the command line's one-line message.
    """
    if isinstance(scene, dict):
        return _render_scene_dict(scene, width, height, gpu, reference, time, base)
    return _haze.render_scene(os.fspath(scene), width, height, gpu, reference, float(time))


def _json_value(value: Any) -> Any:
    """NumPy scalars and arrays in a scene dict as the JSON numbers and lists they hold."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not a number, string, list or dict")


def _render_scene_dict(
    scene: Dict[str, Any],
    width: Optional[int],
    height: Optional[int],
    gpu: bool,
    reference: bool,
    time: float,
    base: Optional[PathLike],
) -> np.ndarray:
    """A scene given as a dict, written as JSON beside its relative paths (``base``)
    for the renderer; its errors name "the scene dict", not that file."""
    import json
    import re
    import tempfile

    try:
        text = json.dumps(scene, allow_nan=False, default=_json_value)
    except (TypeError, ValueError) as e:
        if "Out of range float" in str(e):
            e = "a NaN or infinite number (a scene holds finite numbers)"
        raise HazeError(f"the scene dict: {e}") from None
    folder = os.fspath(base) if base is not None else os.getcwd()
    with tempfile.NamedTemporaryFile(
        "w", suffix=".json", prefix=".haze-scene-", dir=folder, delete=False
    ) as f:
        f.write(text)
        path = f.name
    try:
        return _haze.render_scene(path, width, height, gpu, reference, float(time))
    except HazeError as e:
        # The line and column are the written file's, which the caller never sees.
        message = re.sub(r" at line \d+ column \d+", "", str(e).replace(path, "the scene dict"))
        raise HazeError(message) from None
    finally:
        os.unlink(path)
