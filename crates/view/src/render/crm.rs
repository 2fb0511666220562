//! Compensated ray marching (paper A §5.5, eqs. 14–16).
//!
//! **Volume pass**, at volume resolution: at every voxel center `u`,
//! `D̃(u) = Σ w_ℓ B_ℓ(u)`, the interpolated source radiance
//! `J̃(u, d) = y(d) · Σ_ℓ w_ℓ B_ℓ(u) J̃(c_ℓ) / D̃(u)` towards the camera (`d` is the
//! direction from the eye to `u`, so a pinhole view is exact at voxel centers), and the
//! density `D = D̃ + R` with the residual `R` from the hash. Where `D̃ < 10⁻¹⁰` the
//! interpolation is undefined: the residual is ignored there (paper) and `J̃ = 0`. Then
//! `J̃_D = D · J̃ = (1 + R/D̃) Σ w_ℓ B_ℓ (y·J̃(c_ℓ))`, eq. 15.
//!
//! **View pass**, per pixel: slices perpendicular to the camera axis, `Δu` apart (default
//! half the smallest voxel side), are crossed by the ray at `u_i`; along the ray a slice
//! is `Δs = Δu / cos γ` long (γ: angle to the axis) and has transmittance
//! `Δτ_i = exp(−σt D(u_i) Δs)` (eq. 16). Front to back,
//!
//! ```text
//! L = L_in(d) · Π Δτ_j  +  Σ_i J̃(u_i) (1 − Δτ_i) · Π_{j<i} Δτ_j
//! ```
//!
//! which is eq. 16's `Σ J̃_D σt Δs Π Δτ` with each slice's emission integrated exactly
//! for constant `D` and `J̃` across it (`∫₀^Δs σt D J̃ e^{−σt D s} ds = J̃ (1 − Δτ)`): the
//! same for thin slices, and bounded for opaque ones (huge σt gives `J̃`, never a blow-up).
//! `D` between voxel centers is trilinear, and so is `J̃_D = D·J̃` (eq. 15): the emission
//! of a thin slice is `J̃_D σt Δs`, so `J̃` at a sample is `J̃_D/D`.

use crate::Camera;
use crate::distant::Rgb;
use crate::env::Environment;
use crate::field;
use crate::ground::{GroundLight, marched_transmittance};
use crate::lighting::single::RgbSh;
use crate::medium::Medium;
use crate::sh;
use haze_volume::{Bbox, Rbf, Volume, rbf::voxel_span};
use rayon::prelude::*;

/// Below this `D̃` the interpolated source radiance (and the residual) is not used.
pub const MIN_DENSITY: f64 = 1e-10;

/// The output of the volume pass.
#[derive(Clone, Debug)]
pub struct VolumeGrids {
    /// `D = D̃ + R` (≥ 0) at voxel centers.
    pub density: Volume,
    /// `J̃(u, d)` towards the camera, RGB, at voxel centers (x fastest).
    pub radiance: Vec<[f32; 3]>,
    /// `Ωf`: the share of σt that the forward peak of the light towards the eye gives
    /// back on the eye's ray ([`crate::render::grid_diffusion::add_to_grids`], delta-M):
    /// the view pass carries `J̃`'s light to the eye through `σt(1 − Ωf)`, the background
    /// through `σt`. 0 (every light through `σt`) until multiple scattering is added.
    pub eye_peak: f64,
}

/// Volume pass: `D` and `J̃` at every voxel center of a `dims` grid over `bbox`, for
/// per-center source radiance `source[ℓ]` (RGB SH of `order`) and the camera at `eye`.
/// `residual`, when given, holds `R` at every voxel (x fastest).
pub fn volume_pass(
    rbfs: &[Rbf],
    source: &[RgbSh],
    order: usize,
    dims: [usize; 3],
    bbox: &Bbox,
    residual: Option<&[f32]>,
    eye: [f64; 3],
) -> VolumeGrids {
    let n2 = order * order;
    let plane = dims[0] * dims[1];
    let size = bbox.size();
    let vs = [0, 1, 2].map(|a| size[a] / dims[a].max(1) as f64);
    let slices: Vec<(Vec<f32>, Vec<[f32; 3]>)> = (0..dims[2])
        .into_par_iter()
        .map(|z| {
            let pz = bbox.min[2] + (z as f64 + 0.5) * vs[2];
            let mut dt = vec![0.0f64; plane];
            let mut acc = vec![0.0f64; plane * 3 * n2];
            for (rbf, j) in rbfs.iter().zip(source) {
                let s = rbf.support_radius();
                if s <= 0.0 || (pz - rbf.center[2]).abs() >= s {
                    continue;
                }
                let span = |a: usize| {
                    voxel_span(
                        rbf.center[a] - s,
                        rbf.center[a] + s,
                        bbox.min[a],
                        vs[a],
                        dims[a],
                    )
                };
                let (Some((x0, x1)), Some((y0, y1))) = (span(0), span(1)) else {
                    continue;
                };
                for y in y0..=y1 {
                    let py = bbox.min[1] + (y as f64 + 0.5) * vs[1];
                    for x in x0..=x1 {
                        let px = bbox.min[0] + (x as f64 + 0.5) * vs[0];
                        let b = rbf.eval([px, py, pz]);
                        if b == 0.0 {
                            continue;
                        }
                        let i = x + dims[0] * y;
                        dt[i] += b;
                        let a = &mut acc[i * 3 * n2..(i + 1) * 3 * n2];
                        for ch in 0..3 {
                            for (k, v) in j[ch].iter().enumerate() {
                                a[ch * n2 + k] += b * v;
                            }
                        }
                    }
                }
            }
            let mut y = vec![0.0; n2];
            let mut dens = vec![0.0f32; plane];
            let mut rad = vec![[0.0f32; 3]; plane];
            for i in 0..plane {
                let (x, yy) = (i % dims[0], i / dims[0]);
                let d_tilde = dt[i];
                let r = residual.map_or(0.0, |r| f64::from(r[z * plane + i]));
                if d_tilde < MIN_DENSITY {
                    dens[i] = d_tilde.max(0.0) as f32;
                    continue;
                }
                dens[i] = (d_tilde + r).max(0.0) as f32;
                let p = [
                    bbox.min[0] + (x as f64 + 0.5) * vs[0],
                    bbox.min[1] + (yy as f64 + 0.5) * vs[1],
                    pz,
                ];
                sh::eval_into(order, [p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]], &mut y);
                let a = &acc[i * 3 * n2..(i + 1) * 3 * n2];
                for ch in 0..3 {
                    let dot: f64 = a[ch * n2..(ch + 1) * n2]
                        .iter()
                        .zip(&y)
                        .map(|(s, b)| s * b)
                        .sum();
                    rad[i][ch] = (dot / d_tilde).max(0.0) as f32;
                }
            }
            (dens, rad)
        })
        .collect();
    let mut density = Vec::with_capacity(plane * dims[2]);
    let mut radiance = Vec::with_capacity(plane * dims[2]);
    for (d, r) in slices {
        density.extend(d);
        radiance.extend(r);
    }
    VolumeGrids {
        density: Volume::new(dims, *bbox, density).expect("dims match the data"),
        radiance,
        eye_peak: 0.0,
    }
}

/// `J̃` at world point `p` (0 outside the box), `dp` the density there
/// ([`field::sample`]): the mean of the 8 corners' `J̃` of [`field::sample`]'s stencil,
/// each weighed by its trilinear weight times `max(D_k, dp)`.
///
/// Between smoke voxels that is eq. 15's `D·J̃` over `D` (the denser corner counts for
/// more, as the RBFs' interpolated source does); a corner thinner than the sample counts
/// as if it held the sample's density. The empty corners of a cell with smoke are the
/// smoke's shell, lit at their own centers ([`super::shell`]), so the band beyond the
/// last smoke voxel takes the light that reaches it instead of its neighbour's: an
/// edge-on sun's light climbs towards 1 there, where the neighbour's center is shadowed.
/// With `dp ≤ 0` (no smoke at `p`) the result is 0.
pub fn sample_radiance(g: &VolumeGrids, p: [f64; 3], dp: f64) -> Rgb {
    let v = &g.density;
    let b = v.bbox();
    let d = v.dims();
    if d.contains(&0)
        || (0..3).any(|a| !(p[a] >= b.min[a] && p[a] <= b.max[a]))
        || dp.is_nan()
        || dp <= 0.0
    {
        return [0.0; 3];
    }
    let vs = v.voxel_size();
    let mut i0 = [0usize; 3];
    let mut t = [0.0f64; 3];
    for a in 0..3 {
        let f = ((p[a] - b.min[a]) / vs[a] - 0.5).clamp(0.0, (d[a] - 1) as f64);
        let i = (f as usize).min(d[a].saturating_sub(2));
        i0[a] = i;
        t[a] = f - i as f64;
    }
    let (mut s, mut ws) = ([0.0; 3], 0.0);
    for corner in 0..8 {
        let mut w = 1.0;
        let mut idx = [0usize; 3];
        for a in 0..3 {
            let hi = corner >> a & 1 == 1;
            idx[a] = (i0[a] + usize::from(hi)).min(d[a] - 1);
            w *= if hi { t[a] } else { 1.0 - t[a] };
        }
        let i = v.index(idx[0], idx[1], idx[2]);
        let wd = w * f64::from(v.data()[i]).max(dp);
        if wd > 0.0 {
            let r = g.radiance[i];
            for c in 0..3 {
                s[c] += wd * f64::from(r[c]);
            }
            ws += wd;
        }
    }
    if ws > 0.0 {
        s.map(|c| c / ws)
    } else {
        [0.0; 3]
    }
}

/// Transmittance below which the march stops (the rest cannot change a pixel by more
/// than this fraction of the remaining light).
pub const OPAQUE: f64 = 1e-4;

/// What the smoke adds along one pixel's ray, for compositing with other media: the
/// smoke's own radiance `L_s = Σ_i J̃(u_i)(1 − Δτ_i) Π_{j<i} Δτ_j` (no background), its
/// transmittance `T_s = Π Δτ_i`, and a representative depth `d` (distance from the eye).
///
/// `d` is the opacity-weighted mean of the slice positions,
/// `d = Σ_i t_i w_i / Σ_i w_i` with `w_i = (1 − Δτ_i) Π_{j<i} Δτ_j`: the discrete
/// `∫ t σt D(t) T_s(0, t) dt / (1 − T_s)`, the mean distance at which the smoke absorbs
/// or scatters the light coming along the ray (the density of that event is
/// `σt D(t) T_s(0, t)`, of total mass `1 − T_s`). When the smoke's source radiance `J̃` is
/// constant along the ray, the same weights are those of its emission, so `d` is also
/// where `L_s` comes from on average. Another medium that is split at `d` — its part in
/// front of `d` attenuating `L_s`, its part behind attenuated by `T_s` — is composited
/// exactly when the smoke is a thin sheet at `d`, and to first order in that medium's
/// optical depth across the smoke otherwise. A ray that meets no smoke has `L_s = 0`,
/// `T_s = 1` and `d = 0` (any split is then exact).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SmokeSample {
    /// `L_s`, linear RGB.
    pub radiance: [f32; 3],
    /// `T_s`.
    pub transmittance: f32,
    /// `d`, world length from the eye.
    pub depth: f32,
}

/// The view pass along one ray from `eye` along unit `d` (camera axis `axis`, slice
/// thickness `du`), stopping at `t_end` (an opaque surface; `∞` for none): the grids'
/// light carried to the eye through `σt(1 − Ωf)` ([`VolumeGrids::eye_peak`],
/// [`scattered_step`]), the transmittance it returns (the background's) through `σt`.
fn march(
    g: &VolumeGrids,
    medium: &Medium,
    eye: [f64; 3],
    d: [f64; 3],
    axis: [f64; 3],
    du: f64,
    t_end: f64,
) -> ([f64; 3], f64, f64) {
    let bbox = *g.density.bbox();
    let cos_g = (d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]).max(1e-6);
    let Some((t0, t1)) = field::ray_box(eye, d, &bbox) else {
        return ([0.0; 3], 1.0, 0.0);
    };
    let t1 = t1.min(t_end);
    let ds = du / cos_g;
    // Slice planes at axis distances k·du from the eye; the ray meets plane k at
    // t = k·du / cos γ.
    let k0 = (t0 * cos_g / du).floor() as i64;
    let k1 = (t1 * cos_g / du).ceil() as i64;
    let (mut tau, mut out) = (1.0f64, [0.0f64; 3]);
    let (mut depth, mut weight) = (0.0f64, 0.0f64);
    // The scattered light's transmittance, through σt(1 − Ωf) (`VolumeGrids::eye_peak`).
    let keep = 1.0 - g.eye_peak;
    let mut tau_j = 1.0f64;
    let sampler = field::Sampler::new(&g.density);
    for k in k0.max(0)..=k1 {
        let t = (k as f64 + 0.5) * ds;
        if t < t0 || t > t1 {
            continue;
        }
        let p = [eye[0] + t * d[0], eye[1] + t * d[1], eye[2] + t * d[2]];
        let dens = sampler.at(p);
        if dens <= 0.0 {
            continue;
        }
        let a = medium.sigma_t * dens * ds;
        let (share, dt_j) = scattered_step(a, keep);
        // Nothing given back: the background's transmittance is the scattered light's.
        let dt = if keep == 1.0 { dt_j } else { (-a).exp() };
        let j = sample_radiance(g, p, dens);
        let w = tau * (1.0 - dt);
        for c in 0..3 {
            out[c] += tau_j * share * j[c];
        }
        depth += w * t;
        weight += w;
        tau *= dt;
        tau_j *= dt_j;
        if tau_j < OPAQUE {
            tau = 0.0;
            break;
        }
    }
    let depth = if weight > 0.0 { depth / weight } else { 0.0 };
    (out, tau, depth)
}

/// One step of optical depth `a` for light emitted at `σt D J̃` and attenuated through
/// `keep·σt` (`keep = 1 − Ωf`, [`VolumeGrids::eye_peak`]): the share of `J̃` that leaves
/// the step, `(1 − e^{−keep·a})/keep` (→ `a` as `keep` → 0), and the step's
/// transmittance `e^{−keep·a}`. At `keep = 1` the view pass's own `1 − Δτ`, `Δτ`.
pub fn scattered_step(a: f64, keep: f64) -> (f64, f64) {
    let x = keep * a;
    let e = (-x).exp_m1();
    let share = if x > 1e-12 {
        -e / keep
    } else {
        // (1 − e^{−x})/keep = a(1 − x/2 + …), within x²/6 (relative).
        a * (1.0 - 0.5 * x)
    };
    (share, 1.0 + e)
}

/// View pass: the image of the volume-pass grids, slice thickness `du` (world units).
/// The background is the environment, or the `ground` where a ray meets it, with the
/// smoke's shadow marched through the grids' density ([`crate::ground`]).
pub fn view_pass(
    g: &VolumeGrids,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    du: f64,
    ground: Option<&GroundLight>,
) -> Vec<[f32; 3]> {
    let w = camera.width;
    let axis = camera.forward();
    (0..w * camera.height)
        .into_par_iter()
        .map(|i| {
            let d = camera.pixel_ray(i % w, i / w);
            let background = match ground.and_then(|gr| Some((gr, gr.hit(camera.eye, d)?))) {
                Some((gr, x)) => gr.radiance(x, |x, w, len| {
                    marched_transmittance(&g.density, medium.sigma_t, x, w, len)
                }),
                None => env.radiance(d),
            };
            let (out, tau, _) = march(g, medium, camera.eye, d, axis, du, f64::INFINITY);
            [0, 1, 2].map(|c| (out[c] + tau * background[c]) as f32)
        })
        .collect()
}

/// The view pass as a layer ([`SmokeSample`] per pixel, row 0 on top) for compositing
/// with another medium; `t_end(d)` is where the ray along unit `d` from the eye meets an
/// opaque surface (`f64::INFINITY` for none), beyond which the smoke is hidden.
pub fn view_layer(
    g: &VolumeGrids,
    medium: &Medium,
    camera: &Camera,
    du: f64,
    t_end: &(dyn Fn([f64; 3]) -> f64 + Sync),
) -> Vec<SmokeSample> {
    let w = camera.width;
    let axis = camera.forward();
    (0..w * camera.height)
        .into_par_iter()
        .map(|i| {
            let d = camera.pixel_ray(i % w, i / w);
            let (out, tau, depth) = march(g, medium, camera.eye, d, axis, du, t_end(d));
            SmokeSample {
                radiance: out.map(|c| c as f32),
                transmittance: tau as f32,
                depth: depth as f32,
            }
        })
        .collect()
}

/// Default slice thickness: half the smallest voxel side (paper A).
pub fn default_slice(dims: [usize; 3], bbox: &Bbox) -> f64 {
    let s = bbox.size();
    (0..3)
        .map(|a| s[a] / dims[a].max(1) as f64)
        .fold(f64::INFINITY, f64::min)
        * 0.5
}

#[cfg(test)]
mod tests {
    use super::scattered_step;

    /// The step's share against `∫₀^a e^{−keep·t} dt` by the midpoint rule (10⁵ nodes:
    /// relative error ≈ (keep·a/10⁵)²/24 ≤ 10⁻⁸), at `keep` 1, ½, 10⁻⁹ and 0 and optical
    /// depths from 0 to 50, and the transmittance against `e^{−keep·a}`.
    #[test]
    fn the_scattered_share_is_the_steps_integral() {
        for keep in [1.0, 0.5, 1e-9, 0.0] {
            for a in [0.0, 1e-14, 1e-6, 0.3, 2.0, 50.0] {
                let n = 100_000;
                let h = a / n as f64;
                let want: f64 = (0..n)
                    .map(|i| (-keep * (i as f64 + 0.5) * h).exp() * h)
                    .sum();
                let (share, dt) = scattered_step(a, keep);
                assert!(
                    (share - want).abs() <= 1e-7 * want + 1e-300,
                    "keep {keep}, a {a}: {share} vs {want}"
                );
                assert!(
                    (dt - (-keep * a).exp()).abs() <= 1e-15,
                    "keep {keep}, a {a}"
                );
                assert!(share.is_finite() && (0.0..=1.0).contains(&dt));
            }
        }
    }
}
