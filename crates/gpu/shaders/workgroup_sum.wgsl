// A workgroup's sum of one vec2 per invocation (a module, `#import workgroup_sum`; the
// importer defines `const WG: u32`, its workgroup size, a power of two, and calls
// `workgroup_sum` from every invocation in uniform control flow).

var<workgroup> reduce_buf: array<vec2<f32>, WG>;

// The sum of `v` over the workgroup (a tree of WG/2, WG/4, … pairs), the same in every
// invocation; `lid` is the invocation's local index.
fn workgroup_sum(lid: u32, v: vec2<f32>) -> vec2<f32> {
    reduce_buf[lid] = v;
    workgroupBarrier();
    for (var stride = WG / 2u; stride > 0u; stride = stride / 2u) {
        if lid < stride {
            reduce_buf[lid] = reduce_buf[lid] + reduce_buf[lid + stride];
        }
        workgroupBarrier();
    }
    let total = workgroupUniformLoad(&reduce_buf[0]);
    // No invocation may write the next sum's partial before every one has read this one.
    workgroupBarrier();
    return total;
}
