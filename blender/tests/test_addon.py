"""The Blender add-on, headless, with bpy from PyPI: bakes a small Mantaflow smoke domain,
runs "Bake to .haze", "Preview" and "Load as Volume" on it, and checks the asset and the
image; then the same on a Volume object that plays another tool's OpenVDB sequence.

    python blender/tests/test_addon.py        # a Python with bpy, numpy and haze installed

A plain script, not pytest: bpy as a module aborts while freeing a fluid domain at exit,
so it ends with os._exit (0 when every check passed). Prints one line per check and a
closing "N passed, 0 failed in T s".
"""

import math
import os
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import manta_fix  # noqa: E402

manta_fix.apply()

import bpy  # noqa: E402
import numpy as np  # noqa: E402
from mathutils import Vector  # noqa: E402

import haze  # noqa: E402
import haze_bake  # noqa: E402
from smoke_domain import smoke_domain  # noqa: E402

passed = 0
START = time.monotonic()


def check(what, ok, detail=""):
    global passed
    if not ok:
        print(f"FAILED: {what} {detail}", flush=True)
        print(f"{passed} passed, 1 failed in {time.monotonic() - START:.2f}s", flush=True)
        os._exit(1)
    passed += 1
    print(f"ok: {what}", flush=True)


def attempt(op):
    """What the operator returned, or the text of the error report bpy raised."""
    try:
        return op()
    except RuntimeError as e:
        return str(e)


def blender_openvdb():
    """Blender's own OpenVDB Python module (pyopenvdb, bundled in bpy's Python tree)."""
    site = sorted(Path(bpy.__file__).parents[3].glob("python/lib/python3*/site-packages"))
    sys.path.append(str(site[0]))
    import openvdb

    return openvdb


def main():
    work = Path(tempfile.mkdtemp(prefix="haze-blender-"))
    # Mantaflow's noise writes its tile (waveletNoiseTile.bin, 24 MiB) into the working
    # directory; an empty one of the test's own keeps it out of the repository and
    # gives the "nothing written for //" check a folder of its own.
    (work / "cwd").mkdir()
    os.chdir(work / "cwd")
    domain = smoke_domain(work / "cache")
    vdbs = sorted((work / "cache" / "data").glob("*.vdb"))
    check("Mantaflow baked the domain's cache", len(vdbs) >= 5, f"{vdbs}")

    haze_bake.register()
    scene = bpy.context.scene
    scene.haze.output = str(work / "smoke.haze")
    scene.haze.rbfs = 30
    check("the operators show on a smoke domain", bpy.ops.haze.bake.poll())

    result = bpy.ops.haze.bake()
    out = work / "smoke.haze"
    check("Bake to .haze finished", result == {"FINISHED"} and out.exists(), f"{result}")
    asset = haze.Asset(out)
    numbers = [n for n, _ in haze._haze.frame_sizes(str(work / "cache" / "data"))]
    check("the asset holds every cached frame", asset.frames == numbers, f"{asset.frames} vs {numbers}")
    # The domain spans (0, -3, 0)..(2, -1, 3) in the world; the cache's grids are local
    # to it, so the asset is shifted there (within a cell: the grid covers the domain's
    # cells).
    (lo, hi) = asset.bbox
    cell = 3.0 / 16
    check(
        "the asset sits where the domain is",
        all(abs(a - b) <= cell for a, b in zip(lo, (0.0, -3.0, 0.0)))
        and all(abs(a - b) <= cell for a, b in zip(hi, (2.0, -1.0, 3.0))),
        f"{asset.bbox}",
    )
    last = asset.frame(asset.frames[-1])
    check("the smoke is in the asset", last.max() > 0.1, f"peak {last.max()}")

    # Preview through a camera looking at the domain from the side.
    bpy.ops.object.camera_add(location=(1.0, -12.0, 1.5))
    cam = bpy.context.active_object
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.camera = cam
    bpy.context.view_layer.objects.active = domain
    scene.haze.preview_width, scene.haze.preview_height = 64, 48
    scene.frame_set(asset.frames[-1])
    result = bpy.ops.haze.preview()
    img = bpy.data.images.get("haze preview")
    check("Preview made the image", result == {"FINISHED"} and img is not None, f"{result}")
    check("the preview has the panel's size", tuple(img.size) == (64, 48), f"{tuple(img.size)}")
    pixels = np.empty(64 * 48 * 4, dtype=np.float32)
    img.pixels.foreach_get(pixels)
    shown = pixels.reshape(48, 64, 4)[::-1, :, :3]
    m = cam.matrix_world.to_3x3()
    eye = tuple(cam.matrix_world.translation)
    forward = tuple(-m.col[2])
    want = haze.render(
        out, asset.frames[-1], width=64, height=48, eye=eye,
        target=tuple(e + f for e, f in zip(eye, forward)), up=tuple(m.col[1]),
        fov=haze_bake._vertical_fov(cam.data, 64, 48),
    )
    check(
        "the preview is the frame rendered through the scene camera, top row on top",
        # The add-on sums eye + forward in Blender's float32 vectors, this test in
        # Python floats: the cameras differ in the last bits of f32, which a sharp
        # shadow edge on the ground turns into a few 1e-6 of a pixel.
        np.allclose(shown, want, rtol=1e-5, atol=1e-6),
        f"max diff {np.abs(shown - want).max()}",
    )
    check("the smoke shows in the preview", np.ptp(want.mean(-1)) > 1e-3)
    world_preview_checks(work, scene, out, asset.frames[-1], cam)

    # Load as Volume: the frames as an OpenVDB sequence beside the asset, played by a
    # Volume object frame for frame.
    result = bpy.ops.haze.volume()
    seq = sorted((work / "smoke_vdb").glob("density_*.vdb"))
    check(
        "Load as Volume wrote one OpenVDB file per frame",
        result == {"FINISHED"} and [int(p.stem[-4:]) for p in seq] == asset.frames,
        f"{result} {[p.name for p in seq]}",
    )
    n = asset.frames[-1]
    g = blender_openvdb().read(str(seq[-1]), "density")
    nx, ny, nz = asset.dims
    dense = np.zeros((nx, ny, nz), dtype=np.float32)
    g.copyToArray(dense, ijk=(0, 0, 0))
    check(
        "OpenVDB reads the file back as the asset's frame, voxel for voxel",
        np.array_equal(dense.transpose(2, 1, 0), asset.frame(n)),
        f"max diff {np.abs(dense.transpose(2, 1, 0) - asset.frame(n)).max()}",
    )
    check(
        "the file's index 0 is the centre of the asset's first voxel, index dims - 1 of its last",
        np.allclose(g.transform.indexToWorld((-0.5, -0.5, -0.5)), lo, atol=1e-9)
        and np.allclose(g.transform.indexToWorld((nx - 0.5, ny - 0.5, nz - 0.5)), hi, atol=1e-9),
        f"{g.transform.indexToWorld((0, 0, 0))} {g.transform.indexToWorld((nx, ny, nz))} vs {asset.bbox}",
    )
    bpy.ops.haze.volume()
    loaded = [o for o in bpy.data.objects if o.name.startswith("smoke (haze)")]
    check("loading again reuses the one Volume object", len(loaded) == 1, f"{[o.name for o in loaded]}")
    obj = loaded[0]
    scene.frame_set(asset.frames[1])
    vol = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    vol.grids.load()
    check(
        "the object shows the scene frame's file",
        Path(vol.grids.frame_filepath).name == f"density_{asset.frames[1]:04d}.vdb"
        and vol.grids.frame == asset.frames[1],
        f"{vol.grids.frame_filepath} {vol.grids.frame}",
    )
    # Blender draws a voxel centred on its index, as the file places it: with the object
    # untransformed, voxel (i, j, k) is centred on the asset's cell (i, j, k).
    to_world = obj.matrix_world @ vol.grids["density"].matrix_object
    cell_size = [(hi[a] - lo[a]) / asset.dims[a] for a in range(3)]
    corners = [(0, 0, 0), (nx - 1, ny - 1, nz - 1)]
    centres = [tuple(to_world @ Vector(c)) for c in corners]
    want = [tuple(lo[a] + (c[a] + 0.5) * cell_size[a] for a in range(3)) for c in corners]
    check(
        "the object's voxels are centred on the asset's cells",
        all(np.allclose(c, w, atol=1e-5) for c, w in zip(centres, want)),
        f"{centres} vs {want}",
    )
    # Blender's own bounds of the object (whole leaves of 8 voxels, each voxel ±½ about its
    # index) then fall on the asset's cell faces, not half a cell off them.
    shown_obj = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    low = [min((shown_obj.matrix_world @ Vector(c))[a] for c in shown_obj.bound_box) for a in range(3)]
    steps = [(low[a] - lo[a]) / cell_size[a] for a in range(3)]
    check(
        "Blender's bounds of the object lie on the asset's cell faces",
        all(abs(t - round(t)) < 1e-4 for t in steps),
        f"{steps}",
    )

    # A missing cache is an error in Blender's report, not a crash.
    domain.modifiers["Fluid"].domain_settings.cache_directory = str(work / "nothing")
    result = attempt(bpy.ops.haze.bake)
    check("a domain without a cache is refused", "no cache here" in str(result), f"{result}")
    # Without the haze package in Blender's Python, the operators say how to install it.
    saved = sys.modules["haze"]
    sys.modules["haze"] = None  # `import haze` now raises ImportError
    try:
        for op in (bpy.ops.haze.bake, bpy.ops.haze.preview, bpy.ops.haze.volume):
            result = attempt(op)
            check(
                f"{op.idname_py()} says how to install the haze package",
                "haze Python package is not installed in Blender's Python" in str(result)
                and "-m pip install" in str(result),
                f"{result}",
            )
    finally:
        sys.modules["haze"] = saved
    # An unsaved .blend has no folder for //: the asset is not written wherever the
    # process happens to run.
    scene.haze.output = "//smoke.haze"
    for op in (bpy.ops.haze.bake, bpy.ops.haze.preview, bpy.ops.haze.volume):
        result = attempt(op)
        check(f"{op.idname_py()} refuses // before the .blend is saved", "not saved" in str(result), f"{result}")
    check("nothing written for //", not Path("smoke.haze").exists())
    scene.haze.output = str(out)
    # A rotated domain's smoke cannot be placed axis-aligned: refused, naming the fix.
    domain.rotation_euler = (0.0, 0.0, math.radians(30.0))
    bpy.context.view_layer.update()
    result = attempt(bpy.ops.haze.bake)
    check("a rotated domain is refused", "the domain is rotated (30.0°)" in str(result), f"{result}")
    domain.rotation_euler = (0.0, 0.0, 0.0)
    bpy.context.view_layer.update()
    # A domain that moves over the cache's frames cannot sit at one offset: refused too,
    # and the scene's frame is left where it was.
    was = scene.frame_current
    scene.frame_set(2)
    domain.keyframe_insert("location", frame=1)
    domain.location.x += 0.5
    domain.keyframe_insert("location", frame=6)
    result = attempt(bpy.ops.haze.bake)
    check(
        "a moving domain is refused",
        "the domain moves during the simulation" in str(result) and scene.frame_current == 2,
        f"{result}",
    )
    domain.animation_data_clear()
    domain.location = (1.0, -2.0, 1.5)
    scene.frame_set(was)
    bpy.context.view_layer.update()
    # A cache haze cannot read is named with the setting to change.
    domain.modifiers["Fluid"].domain_settings.cache_data_format = "UNI"
    result = attempt(bpy.ops.haze.bake)
    check(
        "a Uni Cache is refused with the setting to change",
        "caches its volumes as Uni Cache" in str(result) and "Format Volumes: OpenVDB" in str(result),
        f"{result}",
    )

    haze_bake.unregister()

    # With Noise on, the asset is the noise cache's high-resolution density.
    domain = smoke_domain(work / "noisy", noise=True)
    haze_bake.register()
    scene = bpy.context.scene
    scene.haze.output = str(work / "noisy.haze")
    scene.haze.rbfs = 30
    result = bpy.ops.haze.bake()
    noise = haze.inspect(work / "noisy" / "noise", grid="density_noise")
    asset = haze.Asset(work / "noisy.haze")
    check(
        "with Noise on, the noise cache's density is baked",
        result == {"FINISHED"} and list(asset.dims) == noise["dims"] and asset.dims[2] == 32,
        f"{result} {asset.dims} vs {noise['dims']}",
    )
    (lo, hi) = asset.bbox
    check(
        "the noise's asset sits where the domain is",
        all(abs(a - b) <= cell for a, b in zip(lo, (0.0, -3.0, 0.0))),
        f"{asset.bbox}",
    )
    haze_bake.unregister()

    # An Adaptive Domain with Noise on: each frame's files hold a block of the domain that
    # grows with the smoke; haze places it by the cache's configuration, so the asset is
    # the whole domain's at the noise's resolution, where the domain is.
    whole = list(asset.dims)
    smoke_domain(work / "adaptive", noise=True, adaptive=True)
    blocks = {
        tuple(g["base_resolution"])
        for v in sorted((work / "adaptive" / "noise").glob("*.vdb"))
        for g in haze.inspect(v, grid="density_noise")["vdb"]["grids"]
        if g["name"] == "density_noise"
    }
    haze_bake.register()
    bpy.context.scene.haze.output = str(work / "adaptive.haze")
    bpy.context.scene.haze.rbfs = 30
    result = bpy.ops.haze.bake()
    asset = haze.Asset(work / "adaptive.haze")
    check(
        "an Adaptive Domain's noise is baked over the whole domain",
        result == {"FINISHED"} and list(asset.dims) == whole and len(asset.frames) >= 5,
        f"{result} {asset.dims} vs {whole}, {len(asset.frames)} frames",
    )
    (lo, hi) = asset.bbox
    check(
        "the adaptive asset sits where the domain is",
        all(abs(a - b) <= cell for a, b in zip(lo, (0.0, -3.0, 0.0)))
        and all(abs(a - b) <= cell for a, b in zip(hi, (2.0, -1.0, 3.0))),
        f"{asset.bbox}",
    )
    check("its frames were blocks of the domain", len(blocks) > 1, f"{blocks}")
    haze_bake.unregister()

    volume_source_checks(work)
    print(f"{passed} passed, 0 failed in {time.monotonic() - START:.2f}s", flush=True)
    os._exit(0)


def world_preview_checks(work, scene, out, frame, cam):
    """Preview lit by the World: an Environment Texture turned by a Mapping node and a
    Background Strength reach haze as Blender shows them; a World haze cannot read
    leaves its built-in sky, said."""
    w, h = 64, 32
    img = bpy.data.images.new("sky", w, h, float_buffer=True)
    px = np.full((h, w, 4), 0.3, np.float32)
    px[20, 10] = (400.0, 380.0, 350.0, 1.0)  # a sun, 20° up (Blender's rows from the bottom)
    px[..., 3] = 1.0
    img.pixels.foreach_set(px.ravel())
    img.filepath_raw = str(work / "sky.exr")
    img.file_format = "OPEN_EXR"
    img.save()
    world = bpy.data.worlds.new("haze test world")
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    nt = world.node_tree
    bg = nt.nodes["Background"]
    bg.inputs["Strength"].default_value = 2.5
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(work / "sky.exr"))
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(30.0))
    nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    scene.world = world
    lighting, said = haze_bake.world_lighting(world)
    check(
        "the World's map is read in Blender's layout, turned back by its Mapping, scaled",
        lighting.get("env_layout") == "blender"
        and abs(lighting.get("env_rotate", 0.0) + 30.0) < 1e-4
        and lighting.get("env_strength") == 2.5
        and os.path.samefile(lighting.get("env", "/"), work / "sky.exr"),
        f"{lighting} {said}",
    )
    result = bpy.ops.haze.preview()
    shown = np.empty(64 * 48 * 4, dtype=np.float32)
    bpy.data.images["haze preview"].pixels.foreach_get(shown)
    shown = shown.reshape(48, 64, 4)[::-1, :, :3]
    camera = haze_bake.preview_camera(cam, None, 64, 48)
    want = haze.render(out, frame, width=64, height=48, **camera, **lighting)
    check(
        "the preview is lit by the World's map",
        result == {"FINISHED"} and np.allclose(shown, want, rtol=1e-5, atol=1e-6),
        f"{result} max diff {np.abs(shown - want).max()}",
    )
    sky = bpy.data.worlds.new("haze test sky")
    if bpy.app.version < (5, 0, 0):
        sky.use_nodes = True
    texture = sky.node_tree.nodes.new("ShaderNodeTexSky")
    sky.node_tree.links.new(texture.outputs["Color"], sky.node_tree.nodes["Background"].inputs["Color"])
    lighting, said = haze_bake.world_lighting(sky)
    check(
        "a World haze cannot read leaves the built-in sky, and says why",
        lighting == {} and "takes no Environment Texture" in said,
        f"{lighting} {said}",
    )
    scene.world = None


def foreign_sequence(folder):
    """Three frames of a drifting blob as another tool writes them (OpenVDB's own writer):
    grids ``density`` and ``temperature``, indices around 0, voxels of 0.1 shifted by
    (0.3, −0.2, 0.5). Returns the densities as (z, y, x) arrays over file indices
    (−9, −8, −10) + index, and the index→world transform's scale and translation."""
    vdb = blender_openvdb()
    folder.mkdir()
    voxel, shift, first = 0.1, (0.3, -0.2, 0.5), (-9, -8, -10)
    z, y, x = np.meshgrid(*(np.arange(k, dtype=np.float64) for k in (20, 16, 18)), indexing="ij")
    frames = {}
    for n in (1, 2, 3):
        d = np.exp(-(((x - 7 - n) / 3.0) ** 2 + ((y - 7) / 3.0) ** 2 + ((z - 9) / 4.0) ** 2))
        d[d < 0.01] = 0.0
        frames[n] = d.astype(np.float32)
        grids = []
        for name, scale in (("density", 1.0), ("temperature", 300.0)):
            g = vdb.FloatGrid()
            g.copyFromArray(np.ascontiguousarray(frames[n].transpose(2, 1, 0)) * scale, ijk=first, tolerance=0)
            g.name = name
            g.gridClass = vdb.GridClass.FOG_VOLUME
            m = [[voxel, 0, 0, 0], [0, voxel, 0, 0], [0, 0, voxel, 0], [*shift, 1]]
            g.transform = vdb.createLinearTransform(m)
            grids.append(g)
        vdb.write(str(folder / f"ember.{n:04d}.vdb"), grids=grids)
    return frames, first, voxel, shift


def volume_source_checks(work):
    """The panel's three operators on a Volume object (placed, rotated and scaled) that
    plays an OpenVDB sequence written by another tool."""
    frames, first, voxel, shift = foreign_sequence(work / "ember")
    haze_bake.register()
    scene = bpy.context.scene
    # As a user brings it in: File > Import > OpenVDB of the three files (Blender makes
    # them one sequence).
    names = [f"ember.{n:04d}.vdb" for n in (1, 2, 3)]
    bpy.ops.object.volume_import(
        filepath=str(work / "ember" / names[0]),
        directory=str(work / "ember"),
        files=[{"name": n} for n in names],
        use_sequence_detection=True,
    )
    src = bpy.context.active_object
    vol = src.data
    check(
        "Blender imported the files as one sequence",
        src.type == "VOLUME" and vol.is_sequence and vol.frame_duration == 3,
        f"{src.type} {vol.is_sequence} {vol.frame_duration}",
    )
    src.location = (2.0, 1.0, 0.5)
    src.rotation_euler = (0.0, 0.0, math.radians(30.0))
    src.scale = (0.5, 0.5, 0.5)
    bpy.context.view_layer.objects.active = src
    bpy.context.view_layer.update()
    check(
        "the operators and the Data panel show on a Volume object that plays a file",
        bpy.ops.haze.bake.poll()
        and haze_bake.HAZE_PT_volume.poll(bpy.context)
        and not haze_bake.HAZE_PT_domain.poll(bpy.context),
    )

    out = work / "ember.haze"
    scene.haze.output = str(out)
    scene.haze.rbfs = 20
    result = bpy.ops.haze.bake()
    asset = haze.Asset(out)
    check(
        "a rotated, scaled Volume object's sequence is baked, frame for file",
        result == {"FINISHED"} and asset.frames == [1, 2, 3],
        f"{result} {asset.frames if out.exists() else None}",
    )
    # The asset keeps the files' coordinates: its box starts half a voxel before the first
    # active index (OpenVDB centres a voxel on its index), and each frame is the file's density (not its temperature) within the
    # residual's bound, 1/255 of the frame's peak.
    (lo, hi) = asset.bbox
    i0 = [round((lo[a] - shift[a]) / voxel + 0.5) for a in range(3)]
    nx, ny, nz = asset.dims
    worst = 0.0
    for n, d in frames.items():
        z0, y0, x0 = (i0[2] - first[2], i0[1] - first[1], i0[0] - first[0])
        want = d[z0 : z0 + nz, y0 : y0 + ny, x0 : x0 + nx]
        got = asset.frame(n)
        worst = max(worst, float(np.abs(got - want).max()) / float(d.max()))
    check(
        "the asset is the files' density grid where the files put it (index at the voxel's centre)",
        all(abs(lo[a] - (shift[a] + voxel * (i0[a] - 0.5))) < 1e-9 for a in range(3)) and worst <= 1.0 / 255 + 1e-6,
        f"{asset.bbox} {i0} worst {worst}",
    )
    # Where Blender draws the file's voxel i0 (its grid's index→object matrix, at the
    # index) is the centre of the asset's voxel 0.
    vol.grids.load()
    drawn = vol.grids["density"].matrix_object @ Vector([float(i) for i in i0])
    check(
        "the asset's first voxel is centred where Blender draws the file's voxel",
        np.allclose(tuple(drawn), [lo[a] + voxel / 2 for a in range(3)], atol=1e-6),
        f"{tuple(drawn)} vs {lo}",
    )

    # Preview through a camera in the world: the asset is in the object's local space, so
    # the camera is carried there by the object's inverse transform.
    bpy.ops.object.camera_add(location=(2.5, -4.0, 1.2))
    cam = bpy.context.active_object
    cam.rotation_euler = (math.radians(80.0), 0.0, math.radians(5.0))
    scene.camera = cam
    bpy.context.view_layer.objects.active = src
    bpy.context.view_layer.update()
    scene.haze.preview_width, scene.haze.preview_height = 48, 36
    scene.frame_set(2)
    result = bpy.ops.haze.preview()
    img = bpy.data.images.get("haze preview")
    pixels = np.empty(48 * 36 * 4, dtype=np.float32)
    img.pixels.foreach_get(pixels)
    shown = pixels.reshape(36, 48, 4)[::-1, :, :3]
    inv = np.linalg.inv(np.array(src.matrix_world, dtype=np.float64))
    cm = np.array(cam.matrix_world, dtype=np.float64)
    eye, forward, up = cm[:3, 3], -cm[:3, 2], cm[:3, 1]

    def local(p):
        return tuple(inv[:3, :3] @ p + inv[:3, 3])

    up_local = inv[:3, :3] @ up
    fov = haze_bake._vertical_fov(cam.data, 48, 36)
    want = haze.render(
        out, 2, width=48, height=36, eye=local(eye), target=local(eye + forward),
        up=tuple(up_local / np.linalg.norm(up_local)), fov=fov,
    )
    check(
        "the preview is frame 2 seen by the scene camera in the object's space",
        result == {"FINISHED"} and np.allclose(shown, want, rtol=1e-4, atol=1e-5),
        f"{result} max diff {np.abs(shown - want).max()}",
    )
    unmoved = haze.render(
        out, 2, width=48, height=36, eye=tuple(eye), target=tuple(eye + forward), up=tuple(up), fov=fov,
    )
    check(
        "the smoke shows in the preview, where the world camera alone would not put it",
        np.ptp(want.mean(-1)) > 1e-3 and np.abs(unmoved - want).max() > 1e-2,
        f"ptp {np.ptp(want.mean(-1))}, unmoved diff {np.abs(unmoved - want).max()}",
    )
    src.scale = (0.5, 0.5, 1.0)
    bpy.context.view_layer.update()
    result = attempt(bpy.ops.haze.preview)
    check("an unevenly scaled object's preview is refused", "scaled unevenly" in str(result), f"{result}")
    src.scale = (0.5, 0.5, 0.5)
    bpy.context.view_layer.update()

    # Load as Volume: the result drawn exactly over the source, wherever it goes.
    result = bpy.ops.haze.volume()
    obj = bpy.data.objects.get("ember (haze)")
    check(
        "Load as Volume parents the result to the object, with its frame mapping",
        result == {"FINISHED"}
        and obj.parent == src
        and np.allclose(np.array(obj.matrix_world), np.array(src.matrix_world), atol=1e-6)
        and all(
            getattr(obj.data, k) == getattr(vol, k)
            for k in ("is_sequence", "sequence_mode", "frame_start", "frame_duration", "frame_offset")
        ),
        f"{result} {obj and obj.parent}",
    )
    scene.frame_set(3)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    shown_vol = obj.evaluated_get(depsgraph).data
    source_vol = src.evaluated_get(depsgraph).data
    shown_vol.grids.load()
    source_vol.grids.load()
    g = blender_openvdb().read(str(work / "ember_vdb" / "density_0003.vdb"), "density")
    check(
        "it shows the file of the source's frame, its voxels on the source's voxels",
        shown_vol.grids.frame == source_vol.grids.frame == 3
        and np.allclose(g.transform.indexToWorld((0, 0, 0)), [shift[a] + voxel * i0[a] for a in range(3)], atol=1e-9)
        and np.allclose(g.transform.indexToWorld((1, 1, 1)), [shift[a] + voxel * (i0[a] + 1) for a in range(3)], atol=1e-9),
        f"{shown_vol.grids.frame} {source_vol.grids.frame} {g.transform.indexToWorld((0, 0, 0))}",
    )

    # The object set to play a part of its sequence (Offset 1, Frames 2: files 2 and 3)
    # bakes that part; playing nothing (Frames 0) is refused.
    vol.frame_offset, vol.frame_duration = 1, 2
    part = work / "ember_part.haze"
    scene.haze.output = str(part)
    result = bpy.ops.haze.bake()
    baked = haze.Asset(part).frames if part.exists() else None
    check("a Volume object bakes the files its frame span plays", result == {"FINISHED"} and baked == [2, 3], f"{result} {baked}")
    vol.frame_duration = 0
    result = attempt(bpy.ops.haze.bake)
    check("a Volume object that plays no file is refused", "plays no file" in str(result), f"{result}")
    vol.frame_offset, vol.frame_duration = 0, 3
    scene.haze.output = str(out)

    # A sequence without a float grid is refused, naming its grids.
    vdb = blender_openvdb()
    (work / "wind").mkdir()
    for n in (1, 2):
        v = vdb.Vec3SGrid()
        v.copyFromArray(np.ones((4, 4, 4, 3), dtype=np.float32))
        v.name = "velocity"
        vdb.write(str(work / "wind" / f"wind_{n:03d}.vdb"), grids=[v])
    vol.filepath = str(work / "wind" / "wind_001.vdb")
    vol.frame_duration = 2
    scene.frame_set(1)
    result = attempt(bpy.ops.haze.bake)
    check(
        "a sequence without a float grid is refused, naming its grids",
        "wind_*.vdb: no float grid" in str(result) and "velocity (vector_float)" in str(result),
        f"{result}",
    )
    # A 64-bit grid (as Houdini writes at 64-bit precision), not named density: baked.
    (work / "dbl").mkdir()
    d = vdb.DoubleGrid()
    d.copyFromArray(np.full((4, 4, 4), 0.5))
    d.name = "smoke"
    d.gridClass = vdb.GridClass.FOG_VOLUME
    vdb.write(str(work / "dbl" / "dbl.vdb"), grids=[d])
    vol.is_sequence = False
    vol.filepath = str(work / "dbl" / "dbl.vdb")
    scene.haze.output = str(work / "dbl.haze")
    result = bpy.ops.haze.bake()
    baked = haze.Asset(work / "dbl.haze").frame(0) if (work / "dbl.haze").exists() else None
    check(
        "a Volume object's 64-bit grid is baked",
        result == {"FINISHED"} and haze_bake.volume_grid(vol) == "smoke" and np.allclose(baked, 0.5, atol=0.5 / 255),
        f"{result} {None if baked is None else (baked.min(), baked.max())}",
    )
    vol.filepath = str(work / "gone.vdb")
    result = attempt(bpy.ops.haze.bake)
    check("a missing file is refused, named", "gone.vdb: no such file" in str(result), f"{result}")
    haze_bake.unregister()


if __name__ == "__main__":
    main()
