// The voxels the fast renderer lights (a module, `#import lit`; the importer also imports
// `grid_march`, whose `density` and `p.dims` it reads): `render::shell::lit_voxels`, the
// smoke and its one-voxel shell.

// True where D > 0 at voxel i or at one of its 26 neighbours.
fn lit(i: vec3<u32>) -> bool {
    let lo = max(vec3<i32>(i) - 1, vec3<i32>(0));
    let hi = min(vec3<i32>(i) + 1, vec3<i32>(p.dims) - 1);
    for (var z = lo.z; z <= hi.z; z++) {
        for (var y = lo.y; y <= hi.y; y++) {
            for (var x = lo.x; x <= hi.x; x++) {
                if density(vec3<u32>(u32(x), u32(y), u32(z))) > 0.0 {
                    return true;
                }
            }
        }
    }
    return false;
}
