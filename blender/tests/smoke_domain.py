"""A small Mantaflow smoke domain baked headless (bpy as a module): what the add-on's
test and the bundled `data/blender-adaptive/` caches are made from."""

import bpy
from mathutils import Matrix


def smoke_domain(cache, noise=False, adaptive=False, resolution=16,
                 emitter=(1.0, -2.0, 0.5), radius=0.35):
    """A 2 × 2 × 3 domain centred at (1, -2, 1.5) (so its cache's local grids need the
    offset), `resolution` cells along its longest side, with a smoke emitter of `radius`
    at `emitter` near its floor, baked for frames 1..6; with `noise`, Mantaflow's noise at
    twice the resolution too; `adaptive`, an Adaptive Domain (its grid follows the smoke,
    so it grows from frame to frame)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(1.0, -2.0, 1.5))
    domain = bpy.context.active_object
    domain.name = "Domain"
    domain.data.transform(Matrix.Diagonal((2.0, 2.0, 3.0, 1.0)))
    domain.data.update()
    mod = domain.modifiers.new("Fluid", "FLUID")
    mod.fluid_type = "DOMAIN"
    ds = mod.domain_settings
    ds.domain_type = "GAS"
    ds.resolution_max = resolution
    ds.use_adaptive_domain = adaptive
    ds.use_noise = noise
    ds.noise_scale = 2
    ds.cache_noise_format = "OPENVDB"
    ds.cache_directory = str(cache)
    ds.cache_type = "ALL"
    ds.cache_data_format = "OPENVDB"
    ds.cache_frame_start = 1
    ds.cache_frame_end = 6
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=emitter)
    flow = bpy.context.active_object.modifiers.new("Fluid", "FLUID")
    flow.fluid_type = "FLOW"
    fs = flow.flow_settings
    fs.flow_type = "SMOKE"
    fs.flow_behavior = "INFLOW"
    fs.flow_source = "MESH"
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
    return domain
