// `lights_pass::SHADOW_CUTOFF`: a shadow march stops once σt·τ passes it (e^−20 ≈ 2e-9
// of the light left). A module (`#import shadow_cutoff`) of the marches that stop there:
// `grid_march.wgsl` (lights and environment passes) and the view pass's ground shadow.
const SHADOW_CUTOFF: f32 = 20.0;
