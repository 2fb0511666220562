// The logarithms of the view pass's J̃ (a module, `#import ln_radiance`): written per
// voxel by `view_grid.wgsl`, read by `view_pass.wgsl`'s geometric mean (decision 0049).

// The smallest normal f32: a lit channel below it is taken at it.
const MIN_NORMAL: f32 = 1.17549435e-38;
// ln MIN_NORMAL: the floor of a cell whose brightest corner is subnormal.
const LN_MIN_NORMAL: f32 = -87.336544750553;
// The logarithm of an unlit channel (J̃ = 0).
const UNLIT: f32 = -3.0e38;
