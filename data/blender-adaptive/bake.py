"""Bakes this folder's two caches with Blender as a Python module (bpy 5.0.1 from PyPI,
CPython 3.11): the same smoke in a 2 x 2 x 3 domain centred at (1, -2, 1.5), resolution
32, frames 1..6, once with Adaptive Domain on and once off.

    python data/blender-adaptive/bake.py OUT_FOLDER

writes OUT_FOLDER/adaptive and OUT_FOLDER/fixed (each a whole Mantaflow cache: config,
data, ...); frames 1 and 6 of their data (and the adaptive cache's configurations) are
what this folder keeps.
"""

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "blender" / "tests"))


def bake(cache: Path, adaptive: bool) -> None:
    import manta_fix

    manta_fix.apply()
    import bpy
    from mathutils import Matrix

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(1.0, -2.0, 1.5))
    domain = bpy.context.active_object
    domain.data.transform(Matrix.Diagonal((2.0, 2.0, 3.0, 1.0)))
    domain.data.update()
    mod = domain.modifiers.new("Fluid", "FLUID")
    mod.fluid_type = "DOMAIN"
    ds = mod.domain_settings
    ds.domain_type = "GAS"
    ds.resolution_max = 32
    ds.use_adaptive_domain = adaptive
    ds.cache_directory = str(cache)
    ds.cache_type = "ALL"
    ds.cache_data_format = "OPENVDB"
    ds.cache_frame_start, ds.cache_frame_end = 1, 6
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.25, location=(1.6, -1.45, 0.5))
    flow = bpy.context.active_object.modifiers.new("Fluid", "FLUID")
    flow.fluid_type = "FLOW"
    fs = flow.flow_settings
    fs.flow_type, fs.flow_behavior, fs.flow_source = "SMOKE", "INFLOW", "MESH"
    fs.surface_distance = 1.5
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 6
    scene.frame_set(1)
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    domain.select_set(True)
    bpy.context.view_layer.objects.active = domain
    with bpy.context.temp_override(object=domain, active_object=domain, selected_objects=[domain]):
        bpy.ops.fluid.bake_all()


if __name__ == "__main__":
    if len(sys.argv) == 3:
        bake(Path(sys.argv[1]), sys.argv[2] == "adaptive")
        sys.stdout.flush()
        # Mantaflow aborts while Python shuts down; the cache is complete by then.
        import os

        os._exit(0)
    out = Path(sys.argv[1])
    for kind in ("adaptive", "fixed"):
        subprocess.run([sys.executable, __file__, str(out / kind), kind], check=True)
