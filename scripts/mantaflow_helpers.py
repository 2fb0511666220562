"""Scene helpers for `bake_heldout.py`: a Mantaflow smoke domain, emitters, obstacles and
effectors built with bpy (Blender as a Python module), baked to OpenVDB.

Import after `manta_fix.apply()` (blender/tests/manta_fix.py), which lets bpy from PyPI
bake Mantaflow domains.
"""
import json
import os
import shutil
import sys
import time

import bpy
from mathutils import Matrix, Vector


def reset_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def add_box(name, size, location):
    """Axis-aligned box mesh with the given full size, object transform = translation only."""
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=location)
    ob = bpy.context.active_object
    ob.name = name
    ob.data.transform(Matrix.Diagonal((size[0], size[1], size[2], 1.0)))
    ob.data.update()
    return ob


def add_sphere(name, radius, location):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=location, segments=24, ring_count=12)
    ob = bpy.context.active_object
    ob.name = name
    return ob


def make_domain(ob, *, res_max, cache_dir, frame_start, frame_end, vorticity,
                compress="ZIP", depth="32", set_compress=True, alpha=1.0, beta=1.0):
    mod = ob.modifiers.new("Fluid", "FLUID")
    mod.fluid_type = "DOMAIN"
    ds = mod.domain_settings
    ds.domain_type = "GAS"
    ds.resolution_max = res_max
    ds.use_adaptive_domain = False
    ds.use_noise = False
    ds.vorticity = vorticity
    ds.alpha = alpha
    ds.beta = beta
    ds.use_dissolve_smoke = False
    ds.cache_directory = cache_dir
    ds.cache_type = "ALL"
    ds.cache_data_format = "OPENVDB"
    if set_compress:
        ds.openvdb_cache_compress_type = compress
    ds.openvdb_data_depth = depth  # '32' = full float, '16' = half float
    ds.cache_frame_start = frame_start
    ds.cache_frame_end = frame_end
    return mod


def make_smoke_flow(ob, *, density=1.0, temperature=1.0, init_vel=None):
    mod = ob.modifiers.new("Fluid", "FLUID")
    mod.fluid_type = "FLOW"
    fs = mod.flow_settings
    fs.flow_type = "SMOKE"
    fs.flow_behavior = "INFLOW"
    fs.flow_source = "MESH"
    fs.density = density
    fs.temperature = temperature
    fs.volume_density = 1.0
    fs.surface_distance = 1.5
    fs.subframes = 1
    if init_vel is not None:
        fs.use_initial_velocity = True
        fs.velocity_coord = init_vel
    return mod


def make_obstacle(ob):
    mod = ob.modifiers.new("Fluid", "FLUID")
    mod.fluid_type = "EFFECTOR"
    mod.effector_settings.effector_type = "COLLISION"
    return mod


def bake(domain, *, frame_start, frame_end, blend_path=None):
    scene = bpy.context.scene
    scene.frame_start = frame_start
    scene.frame_end = frame_end
    scene.frame_set(frame_start)
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    domain.select_set(True)
    bpy.context.view_layer.objects.active = domain
    if blend_path:
        bpy.ops.wm.save_as_mainfile(filepath=blend_path, relative_remap=False)
    t0 = time.time()
    with bpy.context.temp_override(object=domain, active_object=domain,
                                   selected_objects=[domain]):
        res = bpy.ops.fluid.bake_all()
    dt = time.time() - t0
    print(f"[bake] bpy.ops.fluid.bake_all() -> {res} in {dt:.1f} s", flush=True)
    return res, dt


def domain_meta(domain):
    """Geometry of the (non-adaptive) domain in world space, as seen by Blender."""
    ds = domain.modifiers["Fluid"].domain_settings
    dg = bpy.context.evaluated_depsgraph_get()
    dse = domain.evaluated_get(dg).modifiers["Fluid"].domain_settings  # RNA grid info lives here
    mw = domain.matrix_world
    corners = [mw @ Vector(c) for c in domain.bound_box]
    bmin = [min(c[i] for c in corners) for i in range(3)]
    bmax = [max(c[i] for c in corners) for i in range(3)]
    return {
        "domain_object": domain.name,
        "world_bbox_min": bmin,
        "world_bbox_max": bmax,
        "domain_resolution_rna": list(dse.domain_resolution),
        "cell_size_rna": list(dse.cell_size),
        "start_point_rna_object_space": list(dse.start_point),
        "resolution_max": ds.resolution_max,
        "vorticity": ds.vorticity,
        "openvdb_cache_compress_type": ds.openvdb_cache_compress_type,
        "openvdb_data_depth": ds.openvdb_data_depth,
        "cache_type": ds.cache_type,
        "cache_data_format": ds.cache_data_format,
        "cache_directory": ds.cache_directory,
        "frame_start": ds.cache_frame_start,
        "frame_end": ds.cache_frame_end,
        "blender_version": bpy.app.version_string,
    }


def dump_bpy_density(domain, frames, out_dir):
    """Read density via the Blender fluid RNA (domain_settings.density_grid) for some frames.

    Must use the *evaluated* object (the original's density_grid is empty and reading it
    segfaulted in bpy 5.0.1). Used as a cross-check of the VDB reader. Writes raw float32 in
    Mantaflow order (x fastest, then y, then z).
    """
    import numpy as np
    os.makedirs(out_dir, exist_ok=True)
    scene = bpy.context.scene
    out = {}
    for f in frames:
        scene.frame_set(f)
        dg = bpy.context.evaluated_depsgraph_get()
        ds = domain.evaluated_get(dg).modifiers["Fluid"].domain_settings
        n = len(ds.density_grid)
        arr = np.empty(n, dtype=np.float32)
        if n:
            ds.density_grid.foreach_get(arr)
            arr.astype("<f4").tofile(os.path.join(out_dir, f"bpy_density_{f:04d}.f32"))
        out[str(f)] = {"n": int(n), "res": list(ds.domain_resolution),
                       "min": float(arr.min()) if n else None,
                       "max": float(arr.max()) if n else None,
                       "sum": float(arr.sum()) if n else None}
    with open(os.path.join(out_dir, "bpy_density_summary.json"), "w") as fh:
        json.dump(out, fh, indent=1)
    print("[bpy density_grid]", json.dumps(out), flush=True)
    return out


def hard_exit(code=0):
    """Skip interpreter/Blender teardown: in bpy 5.0.1 module mode freeing the fluid modifier at
    exit aborts with "Manta::Error: can't clean grid cache, some grids are still in use"
    (after all outputs were written). os._exit avoids that noise."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
