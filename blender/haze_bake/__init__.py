"""haze for Blender: bake smoke to a .haze asset, and preview it.

The "haze" panel sits in Properties > Physics of a fluid domain of type Gas (its
Mantaflow cache is the source) and in Properties > Data of a Volume object (the OpenVDB
file or sequence it plays: smoke from another tool, imported with Add > Volume > Import
OpenVDB). On a domain:
- **Bake to .haze** bakes the domain's OpenVDB cache (Cache > Directory, its ``data``
  folder; with Noise on, the high-resolution density of its ``noise`` folder; Cache >
  Format Volumes, or Format Noise, must be OpenVDB; an Adaptive Domain's frames are placed
  in the whole domain by the cache's ``config`` folder) into the
  asset named in the panel, frame by frame. Progress shows in the
  status bar; Esc (or "Cancel" in the panel) stops after the frame being fitted and keeps
  the finished frames, which the next bake of the same asset resumes.
- **Preview** renders the current frame of the asset through the scene camera (or the
  default camera that frames the smoke) into the image "haze preview", shown in any open
  Image Editor, lit by the World's equirectangular Environment Texture as Blender shows
  it (``world_lighting``), or else by haze's built-in sky and sun.
- **Load as Volume** writes the asset's frames, as every renderer reconstructs them, to
  an OpenVDB sequence beside it (``<asset>_vdb/density_NNNN.vdb``) and loads that into the
  scene as the Volume object "<asset> (haze)", frame for frame with the cache: the bake
  next to the simulation, in the viewport and in Cycles or EEVEE. Loading again rewrites
  the files and reuses the object.

The asset sits where the domain is: the cache's grids are local to the domain, so the
bake adds the domain's lower corner in world space (``haze bake --domain-offset``). An
asset sits axis-aligned and still, so a rotated domain, and a domain that moves over its
cache's frames, are refused.

On a Volume object the same three buttons work on the files it plays: its grid
``density`` (or its first float grid), the files of its sequence that it plays (the
file's name with its last run of digits as ``*``; numbers ``frame_offset + 1`` to
``frame_offset + frame_duration``, the span its Frames and Offset select). The asset keeps the files' own coordinates, which are
the object's local space, so nothing about the object's placement is refused: Preview
looks through the scene camera carried into that space, and "Load as Volume" parents the
result to the object (it follows the object wherever it is placed or animated) with the
object's own frame mapping (start, offset, duration, mode).

Needs the ``haze`` Python package in Blender's Python
(``<blender>/python/bin/python3 -m pip install ./python``).
"""

import glob
import math
import os
import re
import sys
import threading

import bpy

bl_info = {
    "name": "haze: bake smoke to .haze",
    "author": "haze",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "Properties > Physics > haze (a Gas fluid domain); Properties > Data > haze (a Volume object)",
    "description": "Bake a smoke domain's cache or a Volume object's OpenVDB files into a compact .haze asset and preview it",
    "category": "Physics",
}


def haze_module():
    """The ``haze`` Python package, or a RuntimeError that says how to install it in
    Blender's own Python (where the add-on runs)."""
    try:
        import haze
    except ImportError:
        raise RuntimeError(
            "the haze Python package is not installed in Blender's Python: run "
            f"{sys.executable} -m pip install haze-*.whl (or ./python from the haze sources)"
        ) from None
    return haze


def fluid_domain(obj):
    """The domain settings of ``obj``'s Gas fluid domain, or None."""
    if obj is None:
        return None
    for mod in obj.modifiers:
        if mod.type == "FLUID" and mod.fluid_type == "DOMAIN":
            ds = mod.domain_settings
            if ds.domain_type == "GAS":
                return ds
    return None


def density_cache(ds):
    """Where Mantaflow writes the domain's density and the grid's name: with Noise on, the
    high-resolution ``density_noise`` of ``CACHE/noise``; else ``density`` of
    ``CACHE/data``."""
    root = bpy.path.abspath(ds.cache_directory)
    if ds.use_noise:
        return os.path.join(root, "noise"), "density_noise"
    return os.path.join(root, "data"), "density"


def volume_format_problem(ds):
    """Why haze cannot read the domain's density cache, or None: it reads OpenVDB, and a
    domain may cache its grids (or, with Noise on, its noise) as Uni Cache or Raw Cache."""
    prop, menu = ("cache_noise_format", "Noise") if ds.use_noise else ("cache_data_format", "Volumes")
    fmt = getattr(ds, prop)
    if fmt == "OPENVDB":
        return None
    name = ds.bl_rna.properties[prop].enum_items[fmt].name
    return f"the domain caches its {menu.lower()} as {name}; haze reads OpenVDB (Cache > Format {menu}: OpenVDB, then bake the domain again)"


def asset_path(settings):
    """The asset's path on disk. ``//`` is the saved .blend file's folder; before the file
    is saved it has none (Blender would read it as the process's working directory)."""
    if settings.output.startswith("//") and not bpy.data.filepath:
        raise RuntimeError(
            f"{settings.output}: the .blend file is not saved, so // names no folder: "
            "save it first, or give the asset a full path"
        )
    return bpy.path.abspath(settings.output)


def rotation_problem(obj):
    """Why the domain cannot be placed, or None: a baked asset sits axis-aligned in the
    world (shifted by the domain's lower corner), so a rotated domain's smoke would be
    placed unrotated."""
    rotation = obj.matrix_world.to_quaternion()
    if rotation.angle > 1e-6:
        return (
            f"the domain is rotated ({math.degrees(rotation.angle):.1f}°) and an asset sits "
            "axis-aligned: clear its rotation (or apply it: Object > Apply > Rotation), "
            "then bake the domain again"
        )
    return None


def may_move(obj):
    """Whether anything could move the object over time: an action or drivers, a
    constraint, on it or on a parent."""
    while obj is not None:
        ad = obj.animation_data
        if (ad and (ad.action or len(ad.drivers))) or len(obj.constraints):
            return True
        obj = obj.parent
    return False


def motion_problem(scene, obj, ds, samples=8):
    """Why the domain cannot be placed, or None: an asset sits still at one offset, so a
    domain that moves over its cache's frames (its smoke carried with it, or left behind
    by Blender's shift) would be placed wrong in every frame but one. Only a domain that
    may move is sampled: its world matrix at `samples` frames of the cache (the scene's
    frame is restored)."""
    if not may_move(obj):
        return None
    first, last = ds.cache_frame_start, ds.cache_frame_end
    frames = sorted({round(first + (last - first) * k / (samples - 1)) for k in range(samples)})
    now = scene.frame_current
    try:
        matrices = []
        for f in frames:
            scene.frame_set(f)
            matrices.append((f, obj.matrix_world.copy()))
    finally:
        scene.frame_set(now)
    (f0, m0) = matrices[0]
    for f, m in matrices[1:]:
        moved = max(abs(m[i][j] - m0[i][j]) for i in range(4) for j in range(4))
        if moved > 1e-6:
            return (
                f"the domain moves during the simulation (its transform changes between "
                f"frames {f0} and {f}) and an asset sits still: keep the domain still (clear "
                "its animation, constraints and parent's motion), then bake the domain again"
            )
    return None


def domain_offset(obj):
    """The domain's lower corner in world space: what the cache's local grids are shifted
    by (the domain's transform is a translation and a scale: `rotation_problem`)."""
    corners = [obj.matrix_world @ v.co for v in obj.data.vertices] if obj.data else []
    if not corners:
        return (0.0, 0.0, 0.0)
    return tuple(min(c[i] for c in corners) for i in range(3))


def volume_data(obj):
    """``obj``'s Volume data when ``obj`` is a Volume object that plays a file, or None."""
    if obj is None or obj.type != "VOLUME" or obj.data is None or not obj.data.filepath:
        return None
    return obj.data


def smoke_source(obj):
    """Whether the panel's operators apply to ``obj``: a Gas fluid domain, or a Volume
    object that plays a file."""
    return fluid_domain(obj) is not None or volume_data(obj) is not None


def sequence_pattern(path):
    """The glob of a volume sequence's files from one of them: the last run of digits in
    the file's name before its extension as ``*`` (the frame number, as Blender reads it);
    a name without such digits is the file alone."""
    folder, name = os.path.split(path)
    stem, ext = os.path.splitext(name)
    digits = list(re.finditer(r"[0-9]+", stem))
    if not digits:
        return path
    last = digits[-1]
    return os.path.join(glob.escape(folder), glob.escape(stem[: last.start()]) + "*" + glob.escape(stem[last.end() :] + ext))


def volume_grid(vol):
    """The grid haze bakes from Volume data ``vol``: ``density``, else its first float grid
    (32- or 64-bit), as Blender lists the grids of the frame it shows; ``density`` when it
    shows none (haze then names the file's grids if it has no such grid). A RuntimeError
    when the listed grids hold no float grid."""
    vol.grids.load()
    grids = [(g.name, g.data_type) for g in vol.grids]
    scalar = ("FLOAT", "DOUBLE")
    if not grids or any(("density", k) in grids for k in scalar):
        return "density"
    for name, kind in grids:
        if kind in scalar:
            return name
    listed = ", ".join(f"{n} ({k.lower()})" for n, k in grids)
    raise RuntimeError(f"no float grid to bake as density (the grids: {listed})")


def volume_files(vol):
    """What haze reads for Volume data ``vol``: its file, or the glob of its sequence."""
    path = bpy.path.abspath(vol.filepath)
    return sequence_pattern(path) if vol.is_sequence else path


def played_frames(vol):
    """The file numbers Volume data ``vol`` plays, as haze's frame range ``"a..b"``, or None
    for a single file. Blender shows the sequence's file number ``frame_offset + k`` for
    ``k`` in ``1..=frame_duration`` (each sequence mode maps the scene's frame into that
    span), so a sequence imported from 50 files and set to play 8 bakes those 8. A
    RuntimeError when it plays none (Frames is 0)."""
    if not vol.is_sequence or sequence_pattern(bpy.path.abspath(vol.filepath)) == bpy.path.abspath(vol.filepath):
        return None
    if vol.frame_duration < 1:
        raise RuntimeError("the Volume object plays no file (its Frames is 0)")
    first = vol.frame_offset + 1
    return f"{first}..{first + vol.frame_duration - 1}"


def source_arguments(context):
    """``haze.bake``'s source arguments for the active object: ``src``, ``grid``,
    ``domain_offset`` (a domain's cache is local to the domain; a Volume object's files
    keep their own coordinates, the object's local space) and, for a Volume object's
    sequence, the ``frames`` it plays."""
    obj = context.object
    vol = volume_data(obj)
    if vol is not None:
        src = volume_files(vol)
        if not vol.is_sequence and not os.path.isfile(src):
            raise RuntimeError(f"{src}: no such file (the Volume object's file)")
        try:
            grid = volume_grid(vol)
            frames = played_frames(vol)
        except RuntimeError as e:
            raise RuntimeError(f"{src}: {e}") from None
        # Blender draws a Volume object's voxel centred on its index, as OpenVDB places
        # it: the bake takes the files as Blender shows them (a Blender cache imported
        # as a Volume object included).
        return dict(src=src, grid=grid, domain_offset=(0.0, 0.0, 0.0), frames=frames, vdb_index="centre")
    ds = fluid_domain(obj)
    src, grid = density_cache(ds)
    problem = volume_format_problem(ds) or rotation_problem(obj) or motion_problem(context.scene, obj, ds)
    if problem:
        raise RuntimeError(f"{src}: {problem}")
    if not os.path.isdir(src):
        what = "Bake Noise" if ds.use_noise else "Bake All"
        raise RuntimeError(f"{src}: no cache here: bake the domain first (Cache > {what})")
    return dict(src=src, grid=grid, domain_offset=domain_offset(obj))


class HazeSettings(bpy.types.PropertyGroup):
    output: bpy.props.StringProperty(
        name="Asset",
        description="The .haze asset to write (// is the .blend file's folder: save the file first, or give a full path)",
        default="//smoke.haze",
        subtype="FILE_PATH",
    )
    rbfs: bpy.props.IntProperty(
        name="RBFs",
        description="RBFs fitted to the first frame; later frames insert and delete as the smoke changes",
        default=300,
        min=1,
        max=65536,
    )
    residual_error: bpy.props.FloatProperty(
        name="Residual error",
        description="Error bound of the stored residual, a fraction of each frame's peak density (0: lossless)",
        default=1.0 / 255.0,
        min=0.0,
        max=1.0,
        precision=4,
    )
    preview_width: bpy.props.IntProperty(name="Width", default=400, min=8, max=4096)
    preview_height: bpy.props.IntProperty(name="Height", default=300, min=8, max=4096)


class _Job:
    """A bake running in a thread: its progress and its end, read by the modal timer."""

    def __init__(self):
        self.done = 0
        self.total = 0
        self.last = ""
        self.error = None
        self.finished = False
        self.cancel = threading.Event()


class _OnSource:
    """What the panel's operators share: shown on a Gas fluid domain or a Volume object
    that plays a file, they need the haze package and the panel's asset path."""

    @classmethod
    def poll(cls, context):
        return smoke_source(context.object)

    def haze_and_asset(self, context):
        """The haze package and the asset's path, or None once the reason is reported."""
        try:
            return haze_module(), asset_path(context.scene.haze)
        except RuntimeError as e:
            self.report({"ERROR"}, str(e))
            return None


class HAZE_OT_bake(_OnSource, bpy.types.Operator):
    """Bake the domain's smoke cache into a .haze asset (Esc cancels, keeping the finished frames)"""

    bl_idname = "haze.bake"
    bl_label = "Bake to .haze"

    _job = None
    _timer = None

    def arguments(self, context):
        settings = context.scene.haze
        out = asset_path(settings)
        args = source_arguments(context)
        return dict(
            args,
            out=out,
            rbfs=settings.rbfs,
            residual_error=settings.residual_error,
            resume=os.path.exists(out + ".partial"),
        )

    def execute(self, context):
        """Blocking bake (scripts, headless Blender)."""
        try:
            haze = haze_module()
        except RuntimeError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        try:
            args = self.arguments(context)
            report = haze.bake(**args)
        except (haze.HazeError, RuntimeError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, f"{args['out']}: {report['totals']['frames']} frames")
        return {"FINISHED"}

    def invoke(self, context, event):
        """Bake in a thread, with progress in the status bar and Esc to cancel."""
        try:
            haze = haze_module()
        except RuntimeError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        try:
            args = self.arguments(context)
            total = len(haze._haze.frame_sizes(args["src"]))
        except (haze.HazeError, RuntimeError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        job = _Job()
        job.total = total

        def progress(record):
            job.done += 1
            job.last = f"frame {record['frame']}: {record['rbfs']} RBFs, rel_l2 {record['rel_l2']:.4f}"
            if job.cancel.is_set():
                raise KeyboardInterrupt("cancelled")

        def run():
            try:
                haze.bake(progress=progress, **args)
            except BaseException as e:  # noqa: BLE001 — reported on the main thread
                job.error = e
            job.finished = True

        self._job = job
        threading.Thread(target=run, daemon=True).start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.progress_begin(0, max(total, 1))
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        job = self._job
        if event.type == "ESC":
            job.cancel.set()
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        wm = context.window_manager
        wm.progress_update(job.done)
        status = f"haze: baking {job.done}/{job.total} frames"
        if job.last:
            status += f" ({job.last})"
        if job.cancel.is_set():
            status += ", cancelling after this frame"
        context.workspace.status_text_set(status)
        if not job.finished:
            return {"RUNNING_MODAL"}
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        if job.error is not None:
            self.report({"WARNING" if job.cancel.is_set() else "ERROR"}, str(job.error))
            return {"CANCELLED"}
        self.report({"INFO"}, f"haze: {job.done} frames baked")
        return {"FINISHED"}


class HAZE_OT_preview(_OnSource, bpy.types.Operator):
    """Render the current frame of the .haze asset into the image "haze preview\""""

    bl_idname = "haze.preview"
    bl_label = "Preview"

    def execute(self, context):
        scene = context.scene
        settings = scene.haze
        found = self.haze_and_asset(context)
        if found is None:
            return {"CANCELLED"}
        haze, path = found
        w, h = settings.preview_width, settings.preview_height
        try:
            camera = preview_camera(scene.camera, context.object, w, h)
            lighting, lit_by = world_lighting(scene.world)
            frames = haze.Asset(path).frames
            frame = shown_frame(scene, context.object)
            frame = frame if frame in frames else frames[0]
            image = haze.render(path, frame, width=w, height=h, **camera, **lighting)
        except (haze.HazeError, RuntimeError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        show(image, "haze preview")
        self.report({"INFO"}, f"haze preview: {path} frame {frame}, lit by {lit_by}")
        return {"FINISHED"}


def world_lighting(world):
    """``haze.render``'s lighting arguments for the World ``world``, and what lights the
    preview in words. A World whose Background takes its colour from an Environment
    Texture (equirectangular, an image file), directly or through a Mapping node that
    only turns about Z, lights the preview with that map as Blender shows it: read in
    Blender's layout (``env_layout="blender"``), turned by the Mapping's Z rotation
    (Point, Vector and Normal mappings look the map up at the rotated direction, so the
    map turns the other way: ``env_rotate`` is minus the angle; Texture mappings turn it
    by the angle), times the Background's Strength. Anything else (no World, a plain
    colour, a sky texture, other nodes between) leaves haze's built-in sky and its sun,
    and says why."""
    builtin = {}, "haze's built-in sky and sun"
    # Before Blender 5 a World could keep a node tree it does not use.
    unused = bpy.app.version < (5, 0, 0) and not world.use_nodes if world is not None else False
    if world is None or unused or world.node_tree is None:
        return builtin[0], builtin[1] + " (the World has no shader nodes)"
    nodes = world.node_tree.nodes
    out = next((n for n in nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None)
    out = out or next((n for n in nodes if n.type == "OUTPUT_WORLD"), None)

    def source(socket):
        return socket.links[0].from_node if socket.is_linked else None

    bg = source(out.inputs["Surface"]) if out is not None else None
    if bg is None or bg.type != "BACKGROUND" or bg.inputs["Strength"].is_linked:
        return builtin[0], builtin[1] + " (the World is not a Background node of fixed strength)"
    env = source(bg.inputs["Color"])
    if env is None or env.type != "TEX_ENVIRONMENT":
        return builtin[0], builtin[1] + " (the World's Background takes no Environment Texture)"
    image = env.image
    if env.projection != "EQUIRECTANGULAR" or image is None or image.source != "FILE" or image.packed_file:
        return builtin[0], builtin[1] + " (the World's Environment Texture is not an equirectangular image file)"
    path = bpy.path.abspath(image.filepath, library=image.library)
    turn = 0.0
    mapping = source(env.inputs["Vector"])
    if mapping is not None:
        if mapping.type != "MAPPING":
            return builtin[0], builtin[1] + f" (the Environment Texture's vector comes from a {mapping.type} node)"
        inputs = mapping.inputs
        loose = [i for i in inputs[1:] if i.is_linked]
        rotation = inputs["Rotation"].default_value
        scale = inputs["Scale"].default_value
        offset = inputs["Location"].default_value if "Location" in inputs else (0.0, 0.0, 0.0)
        fed = source(inputs["Vector"])
        turns_only = (
            not loose
            and abs(rotation[0]) < 1e-9
            and abs(rotation[1]) < 1e-9
            and all(abs(c - 1.0) < 1e-9 for c in scale)
            and (mapping.vector_type != "POINT" or all(abs(c) < 1e-9 for c in offset))
            and (fed is None or (fed.type == "TEX_COORD" and inputs["Vector"].links[0].from_socket.name == "Generated"))
        )
        if not turns_only:
            return builtin[0], builtin[1] + " (the World's Mapping node does more than turn about Z)"
        turn = math.degrees(rotation[2]) * (1.0 if mapping.vector_type == "TEXTURE" else -1.0)
    strength = float(bg.inputs["Strength"].default_value)
    lighting = dict(env=path, env_layout="blender", env_rotate=turn, env_strength=strength)
    return lighting, f"the World's map {os.path.basename(path)} (turned {turn:.1f}°, strength {strength:g})"


def preview_camera(cam, obj, width, height):
    """``haze.render``'s camera arguments for the scene camera ``cam`` (none: haze's
    default camera framing the smoke). A domain's asset is in world space; a Volume
    object's is in the object's local space, so the camera is carried into it by the
    object's inverse transform (a rotation, a translation and a uniform scale keep the
    picture; a non-uniform scale would shear it and is refused)."""
    if cam is None or cam.type != "CAMERA":
        return {}
    m = cam.matrix_world
    eye = m.translation
    forward = -(m.to_3x3().col[2])
    target = eye + forward
    up = m.to_3x3().col[1]
    if volume_data(obj) is not None:
        scale = obj.matrix_world.to_scale()
        if max(abs(x) for x in scale) > (1.0 + 1e-6) * min(abs(x) for x in scale):
            raise RuntimeError(
                f"{obj.name} is scaled unevenly ({scale[0]:.3g}, {scale[1]:.3g}, {scale[2]:.3g}) "
                "and the preview would be sheared: give it one scale on every axis"
            )
        inv = obj.matrix_world.inverted()
        eye, target = inv @ eye, inv @ target
        up = (inv.to_3x3() @ up).normalized()
    return dict(eye=tuple(eye), target=tuple(target), up=tuple(up), fov=_vertical_fov(cam.data, width, height))


def shown_frame(scene, obj):
    """The asset frame that belongs to the scene's frame: a Volume object's sequence shows
    the file its frame mapping picks (its number is the asset's frame); a domain's cache
    is numbered by scene frames."""
    vol = volume_data(obj)
    if vol is None or not vol.is_sequence:
        return scene.frame_current
    shown = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    shown.grids.load()
    return shown.grids.frame


class HAZE_OT_volume(_OnSource, bpy.types.Operator):
    """Load the .haze asset into the scene as a Volume object (its frames written as an OpenVDB sequence beside it), to compare the bake with the simulation"""

    bl_idname = "haze.volume"
    bl_label = "Load as Volume"

    def execute(self, context):
        found = self.haze_and_asset(context)
        if found is None:
            return {"CANCELLED"}
        haze, path = found
        wm = context.window_manager
        try:
            asset = haze.Asset(path)
            folder = os.path.splitext(path)[0] + "_vdb"
            os.makedirs(folder, exist_ok=True)
            wm.progress_begin(0, len(asset))
            files = []
            for k, n in enumerate(asset.frames):
                files.append(asset.write_vdb(n, os.path.join(folder, f"density_{n:04d}.vdb")))
                wm.progress_update(k + 1)
        except (haze.HazeError, OSError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        source = context.object if volume_data(context.object) is not None else None
        obj = volume_object(context.scene, asset, files[0], source)
        self.report({"INFO"}, f"{obj.name}: {len(files)} frames from {folder}")
        return {"FINISHED"}


def volume_object(scene, asset, first, source=None):
    """The Volume object "<asset> (haze)" (made, or reused from an earlier load) playing the
    sequence that starts at file ``first``, numbered by the asset's frames.

    From a domain: scene frame ``n`` shows ``density_n`` (nothing outside the asset's
    frames). The files place index ``i`` at the centre of the asset's voxel ``i`` and
    Blender draws a voxel centred on its index, so the object has no transform of its own:
    its voxels cover the domain's cells.

    From a Volume object ``source``: the files keep the source files' transform and
    numbers, so the object is parented to ``source`` with no transform of its own (it is
    drawn exactly over it, wherever ``source`` goes) and takes ``source``'s frame mapping.
    """
    name = os.path.splitext(os.path.basename(str(asset.path)))[0] + " (haze)"
    obj = bpy.data.objects.get(name)
    if obj is None or obj.type != "VOLUME" or obj == source:
        vol = bpy.data.volumes.new(name)
        obj = bpy.data.objects.new(name, vol)
        scene.collection.objects.link(obj)
    vol = obj.data
    vol.filepath = bpy.path.relpath(str(first)) if bpy.data.filepath else str(first)
    vol.grids.unload()
    if source is not None:
        src = source.data
        for key in ("is_sequence", "sequence_mode", "frame_start", "frame_duration", "frame_offset"):
            setattr(vol, key, getattr(src, key))
        obj.parent = source
        obj.matrix_parent_inverse.identity()
        obj.matrix_basis.identity()
        return obj
    frames = asset.frames
    vol.is_sequence = True
    vol.sequence_mode = "CLIP"
    vol.frame_start = frames[0]
    vol.frame_duration = frames[-1] - frames[0] + 1
    vol.frame_offset = frames[0] - 1
    obj.parent = None
    obj.matrix_basis.identity()
    return obj


def _vertical_fov(cam, width, height):
    """The camera's vertical field of view in degrees for a ``width × height`` image."""
    sensor = cam.sensor_width if cam.sensor_fit != "VERTICAL" else cam.sensor_height
    fov = 2.0 * math.atan(sensor / (2.0 * cam.lens))
    if cam.sensor_fit == "VERTICAL" or (cam.sensor_fit == "AUTO" and height > width):
        return math.degrees(fov)
    return math.degrees(2.0 * math.atan(math.tan(fov / 2.0) * height / width))


def show(image, name):
    """``image`` (H, W, 3, linear, row 0 on top) as the Blender image ``name`` (float,
    bottom row first), shown in every open Image Editor."""
    import numpy as np

    h, w, _ = image.shape
    img = bpy.data.images.get(name)
    if img is None or tuple(img.size) != (w, h):
        if img is not None:
            bpy.data.images.remove(img)
        img = bpy.data.images.new(name, w, h, float_buffer=True, alpha=True)
    rgba = np.ones((h, w, 4), dtype=np.float32)
    rgba[:, :, :3] = image[::-1]
    img.pixels.foreach_set(rgba.ravel())
    img.update()
    for window in getattr(bpy.context.window_manager, "windows", []):
        for area in window.screen.areas:
            if area.type == "IMAGE_EDITOR":
                area.spaces.active.image = img
    return img


class _Panel:
    """What the two panels share: the "haze" panel of the Properties editor."""

    bl_label = "haze"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"


class HAZE_PT_domain(_Panel, bpy.types.Panel):
    """The panel on a Gas fluid domain (Properties > Physics)."""

    bl_context = "physics"

    @classmethod
    def poll(cls, context):
        return fluid_domain(context.object) is not None

    def draw(self, context):
        col = self.layout.column()
        ds = fluid_domain(context.object)
        if volume_format_problem(ds):
            menu = "Noise" if ds.use_noise else "Volumes"
            col.label(text=f"Cache > Format {menu} must be OpenVDB", icon="ERROR")
        draw_settings(col, context.scene.haze)


class HAZE_PT_volume(_Panel, bpy.types.Panel):
    """The panel on a Volume object that plays a file (Properties > Data)."""

    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return volume_data(context.object) is not None

    def draw(self, context):
        draw_settings(self.layout.column(), context.scene.haze)


def draw_settings(col, settings):
    """The panel's settings and buttons, the same on a domain and on a Volume object."""
    col.prop(settings, "output")
    col.prop(settings, "rbfs")
    col.prop(settings, "residual_error")
    col.operator(HAZE_OT_bake.bl_idname, icon="PHYSICS")
    row = col.row(align=True)
    row.prop(settings, "preview_width")
    row.prop(settings, "preview_height")
    col.operator(HAZE_OT_preview.bl_idname, icon="RENDER_STILL")
    col.operator(HAZE_OT_volume.bl_idname, icon="VOLUME_DATA")


classes = (HazeSettings, HAZE_OT_bake, HAZE_OT_preview, HAZE_OT_volume, HAZE_PT_domain, HAZE_PT_volume)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.haze = bpy.props.PointerProperty(type=HazeSettings)


def unregister():
    del bpy.types.Scene.haze
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
