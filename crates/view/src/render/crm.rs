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
//! `D` between voxel centers is trilinear. `J̃` between them is interpolated
//! geometrically, `J̃ = Π_k J̃_k^{w_k}` with the trilinear weights `w_k` (decision 0049,
//! [`RadianceField`]), where paper A's eq. 15 takes `J̃_D = D·J̃` trilinear: the light
//! a voxel receives falls as `e^{−τ}` with the optical depth `τ` towards its source,
//! and `τ`, an integral of the trilinear density, is what varies smoothly across a cell.

use super::ground_shadow::ShadowMarch;
use super::near_light::NearLights;
use super::occupancy::Occupancy;
use super::pixel_reuse::{self, ReuseCount};
use crate::Camera;
use crate::distant::Rgb;
use crate::env::Environment;
use crate::field;
use crate::ground::GroundLight;
use crate::lighting::single::RgbSh;
use crate::lights::PointLight;
use crate::medium::Medium;
use crate::sh;
use haze_volume::rbf::SliceSplats;
use haze_volume::{Bbox, Rbf, Volume};
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

/// Rows of a slice whose sums [`volume_pass`] holds at once: `ROWS × dims[0]` voxels'
/// `3·order²` sums (96 voxels a row at order 4: 295 KB, within a core's L2 cache).
const ROWS: usize = 8;

/// Volume pass: `D` and `J̃` at every voxel center of a `dims` grid over `bbox`, for
/// per-center source radiance `source[ℓ]` (RGB SH of `order`) and the camera at `eye`.
/// `residual`, when given, holds `R` at every voxel (x fastest).
///
/// Per slice, [`ROWS`] rows at a time; each RBF's `B_ℓ = w_ℓ e^{−|u − c_ℓ|²/r²}` is
/// separable, so a slice takes its factors per axis (`e^{−Δx²/r²}` per column and row of
/// its span, `e^{−Δz²/r²}` once) and a voxel their product: no `exp` per voxel. The
/// support is the sphere of [`Rbf::support_radius`], as [`Rbf::eval`]'s.
pub fn volume_pass(
    rbfs: &[Rbf],
    source: &[RgbSh],
    order: usize,
    dims: [usize; 3],
    bbox: &Bbox,
    residual: Option<&[f32]>,
    eye: [f64; 3],
) -> VolumeGrids {
    let plane = dims[0] * dims[1];
    let size = bbox.size();
    let vs = [0, 1, 2].map(|a| size[a] / dims[a].max(1) as f64);
    let mut density = vec![0.0f32; plane * dims[2]];
    let mut radiance = vec![[0.0f32; 3]; plane * dims[2]];
    density
        .par_chunks_mut(plane.max(1))
        .zip(radiance.par_chunks_mut(plane.max(1)))
        .enumerate()
        .for_each_init(
            || Band::new(dims[0], order),
            |band, (z, (dens, rad))| {
                let slice = SliceSplats::new(rbfs, z, dims, bbox);
                for y0 in (0..dims[1]).step_by(ROWS) {
                    let y1 = (y0 + ROWS).min(dims[1]);
                    band.clear();
                    band.splat(&slice, source, y0, y1);
                    let at = y0 * dims[0]..y1 * dims[0];
                    let r = residual.map(|r| &r[z * plane + at.start..z * plane + at.end]);
                    let eye_u = |i: usize| {
                        let (x, y) = (i % dims[0], y0 + i / dims[0]);
                        [0, 1, 2].map(|a| {
                            let c = [x as f64, y as f64, z as f64][a];
                            bbox.min[a] + (c + 0.5) * vs[a] - eye[a]
                        })
                    };
                    band.finish(r, eye_u, &mut dens[at.clone()], &mut rad[at]);
                }
            },
        );
    VolumeGrids {
        density: Volume::new(dims, *bbox, density).expect("dims match the data"),
        radiance,
        eye_peak: 0.0,
    }
}

/// [`volume_pass`]'s sums over a band of rows: `D̃` and `Σ B_ℓ J̃(c_ℓ)` per voxel. A
/// voxel's sums are zeroed when the first RBF reaches it ([`Band::splat`]), so a band
/// whose RBFs cover a few voxels clears only those; a voxel no RBF reaches reads as
/// `D̃ = 0`.
struct Band {
    nx: usize,
    n2: usize,
    order: usize,
    /// Whether an RBF reached the voxel since [`Band::clear`] (its sums hold values).
    touched: Vec<bool>,
    dt: Vec<f64>,
    acc: Vec<f64>,
    y: Vec<f64>,
}

impl Band {
    fn new(nx: usize, order: usize) -> Self {
        let n2 = order * order;
        Band {
            nx,
            n2,
            order,
            touched: vec![false; ROWS * nx],
            dt: vec![0.0; ROWS * nx],
            acc: vec![0.0; ROWS * nx * 3 * n2],
            y: vec![0.0; n2],
        }
    }

    /// Adds every RBF's `B_ℓ` and `B_ℓ J̃(c_ℓ)` at the rows `y0..y1` of `slice`.
    fn splat(&mut self, slice: &SliceSplats, source: &[RgbSh], y0: usize, y1: usize) {
        let (nx, n2) = (self.nx, self.n2);
        slice.splat(y0, y1, |l, x, y, b| {
            let i = x + nx * (y - y0);
            let a = &mut self.acc[i * 3 * n2..(i + 1) * 3 * n2];
            if !self.touched[i] {
                self.touched[i] = true;
                self.dt[i] = 0.0;
                a.fill(0.0);
            }
            self.dt[i] += b;
            for (ch, j) in source[l].iter().enumerate() {
                for (s, v) in a[ch * n2..(ch + 1) * n2].iter_mut().zip(j) {
                    *s += b * v;
                }
            }
        });
    }

    /// Marks every voxel of the band as reached by no RBF.
    fn clear(&mut self) {
        self.touched.fill(false);
    }

    /// `D` and `J̃` towards the eye of the band's voxels (module docs): `residual` their
    /// `R`, `eye_u(i)` voxel `i`'s offset from the eye.
    fn finish(
        &mut self,
        residual: Option<&[f32]>,
        eye_u: impl Fn(usize) -> [f64; 3],
        dens: &mut [f32],
        rad: &mut [[f32; 3]],
    ) {
        let n2 = self.n2;
        for i in 0..dens.len() {
            let d_tilde = if self.touched[i] { self.dt[i] } else { 0.0 };
            if d_tilde < MIN_DENSITY {
                dens[i] = d_tilde.max(0.0) as f32;
                continue;
            }
            let r = residual.map_or(0.0, |r| f64::from(r[i]));
            dens[i] = (d_tilde + r).max(0.0) as f32;
            sh::eval_into(self.order, eye_u(i), &mut self.y);
            let a = &self.acc[i * 3 * n2..(i + 1) * 3 * n2];
            for ch in 0..3 {
                let dot: f64 = a[ch * n2..(ch + 1) * n2]
                    .iter()
                    .zip(&self.y)
                    .map(|(s, b)| s * b)
                    .sum();
                rad[i][ch] = (dot / d_tilde).max(0.0) as f32;
            }
        }
    }
}

/// The ratio across a cell that [`RadianceField::sample`]'s geometric mean spans at most: a
/// corner below `1/MAX_SPAN` of the cell's brightest (per channel) counts as that.
pub const MAX_SPAN: f64 = 1e3;

/// `J̃` between voxel centers, as the view pass reads it: the grids with the logarithm
/// of every voxel's `J̃` taken once ([`RadianceField::sample`] has the rule).
#[derive(Debug)]
pub struct RadianceField<'a> {
    grids: &'a VolumeGrids,
    /// `ln J̃` per voxel and channel (`−∞` where `J̃ = 0`).
    ln: Vec<[f64; 3]>,
    /// The density's blocks that may hold density (`None`: no voxel does), so that the
    /// view rays pass over the steps whose trilinear density is exactly zero.
    occupied: Option<Occupancy>,
    /// The density's sampler, whose stencils the radiance shares.
    sampler: field::Sampler<'a>,
}

impl<'a> RadianceField<'a> {
    /// The field of `grids`' radiance.
    pub fn new(grids: &'a VolumeGrids) -> Self {
        let ln = grids
            .radiance
            .par_iter()
            .map(|r| r.map(|c| f64::from(c).ln()))
            .collect();
        let occupied = Occupancy::new(&grids.density);
        RadianceField {
            grids,
            ln,
            occupied,
            sampler: field::Sampler::new(&grids.density),
        }
    }

    /// The grids the field reads.
    pub fn grids(&self) -> &'a VolumeGrids {
        self.grids
    }

    /// `J̃` at world point `p` (0 outside the box), `dp` the density there
    /// ([`field::sample`]): per channel, the geometric mean of the 8 corners' `J̃` of
    /// [`field::sample`]'s stencil weighed by their trilinear weights `w_k`,
    /// `exp(Σ w_k ln max(J̃_k, J̃_max/MAX_SPAN))`, `J̃_max` the cell's brightest corner.
    ///
    /// **Why geometric** (decision 0049). A voxel's light from a sun or the sky is
    /// `J̃ ∝ e^{−τ}`, `τ` the optical depth towards the light, and `τ` — an integral of
    /// the trilinear density — is what is smooth across a cell. Where `τ` changes by about
    /// one or more between voxel centers (smoke a few optical depths a voxel thick along
    /// the light: the lit face of dense smoke, a back-lit silhouette) a linear mean of
    /// `J̃` is too bright inside the cell, and paper A's eq. 15 (`D·J̃` trilinear) also
    /// pulls the thin outer band towards its denser, more shadowed neighbour. The
    /// geometric mean is exact where `ln J̃` is linear. The floor at `J̃_max/MAX_SPAN`
    /// bounds what an unlit corner (`J̃ = 0`: a shadow past the march's cut-off, or no
    /// light at all) takes from a lit cell: at most a factor `MAX_SPAN^{w_k}`.
    ///
    /// Every corner of a cell with smoke is lit: the empty ones are the smoke's shell, lit
    /// at their own centers ([`super::shell`]), so the band beyond the last smoke voxel
    /// takes the light that reaches it. With `dp ≤ 0` (no smoke at `p`) the result is 0.
    /// The GPU twin is `sample_grid` in `shaders/view_pass.wgsl`.
    pub fn sample(&self, p: [f64; 3], dp: f64) -> Rgb {
        match self.sampler.coords(p) {
            Some(q) => self.sample_stencil(&self.sampler.stencil(q), dp),
            None => [0.0; 3],
        }
    }

    /// [`RadianceField::sample`] at the point whose trilinear stencil in the density grid
    /// is `s` (the view pass takes the density and the radiance from one stencil).
    #[inline]
    fn sample_stencil(&self, s: &field::Stencil, dp: f64) -> Rgb {
        if dp.is_nan() || dp <= 0.0 {
            return [0.0; 3];
        }
        let mut corners = [([0.0f64; 3], 0.0f64); 8];
        let mut top = [f64::NEG_INFINITY; 3];
        for (slot, (offset, w)) in corners.iter_mut().zip(s.corners()) {
            let ln = self.ln[offset];
            for c in 0..3 {
                top[c] = top[c].max(ln[c]);
            }
            *slot = (ln, w);
        }
        std::array::from_fn(|c| {
            if top[c] == f64::NEG_INFINITY || top[c].is_nan() {
                return 0.0;
            }
            let floor = top[c] - MAX_SPAN.ln();
            let ln: f64 = corners.iter().map(|(r, w)| w * r[c].max(floor)).sum();
            ln.exp()
        })
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
/// [`scattered_step`]), the transmittance it returns (the background's) through `σt`;
/// the point lights' light near them added at each step ([`NearLights`]). Without
/// `want_depth` the depth is 0 and the background's transmittance, where the eye's peak
/// makes it differ from the scattered light's, is `e^{−Σ a}` taken once after the march
/// (the steps' product to rounding).
#[allow(clippy::too_many_arguments)]
fn march(
    field: &RadianceField<'_>,
    medium: &Medium,
    near: &NearLights<'_>,
    eye: [f64; 3],
    d: [f64; 3],
    axis: [f64; 3],
    du: f64,
    t_end: f64,
    want_depth: bool,
) -> ([f64; 3], f64, f64) {
    let g = field.grids;
    let bbox = *g.density.bbox();
    let cos_g = (d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]).max(1e-6);
    let Some((t0, t1)) = field::ray_box(eye, d, &bbox) else {
        return ([0.0; 3], 1.0, 0.0);
    };
    // No density anywhere, or none on this ray: every sample would be zero.
    let Some(occupied) = &field.occupied else {
        return ([0.0; 3], 1.0, 0.0);
    };
    let Some((ta, tb)) = field::ray_box(eye, d, occupied.bbox()) else {
        return ([0.0; 3], 1.0, 0.0);
    };
    let t1 = t1.min(t_end);
    let ds = du / cos_g;
    // Slice planes at axis distances k·du from the eye; the ray meets plane k at
    // t = k·du / cos γ. Only the slices within a step of the occupied box may see
    // density (outside it the trilinear density is zero); the others are not visited.
    let k0 = (t0.max(ta - ds) * cos_g / du).floor() as i64;
    let k1 = (t1.min(tb + ds) * cos_g / du).ceil() as i64;
    let (mut tau, mut out) = (1.0f64, [0.0f64; 3]);
    let (mut depth, mut weight) = (0.0f64, 0.0f64);
    // The scattered light's transmittance, through σt(1 − Ωf) (`VolumeGrids::eye_peak`).
    let keep = 1.0 - g.eye_peak;
    let mut tau_j = 1.0f64;
    // Without a depth to weigh, the background's transmittance through σt where it differs
    // from the scattered light's is taken once at the end, `e^{−Σ a}`, not a step at a time.
    let tau_at_end = !want_depth && keep != 1.0;
    let mut optical_depth = 0.0f64;
    let (sampler, data) = (&field.sampler, g.density.data());
    let crossings = near.crossings(eye, d);
    for k in k0.max(0)..=k1 {
        let t = (k as f64 + 0.5) * ds;
        if t < t0 || t > t1 {
            continue;
        }
        let p = [eye[0] + t * d[0], eye[1] + t * d[1], eye[2] + t * d[2]];
        // An empty block's samples are exactly zero: passed over as a zero would be.
        let Some(q) = sampler.coords(p) else { continue };
        if !occupied.may_hold_coords(q) {
            continue;
        }
        let stencil = sampler.stencil(q);
        let dens = stencil.sum(data);
        if dens <= 0.0 {
            continue;
        }
        let a = medium.sigma_t * dens * ds;
        let (share, dt_j) = scattered_step(a, keep);
        // Nothing given back: the background's transmittance is the scattered light's.
        let dt = if keep == 1.0 {
            dt_j
        } else if tau_at_end {
            optical_depth += a;
            1.0
        } else {
            (-a).exp()
        };
        let mut j = field.sample_stencil(&stencil, dens);
        if !crossings.is_empty() {
            let n = near.at_step(&crossings, eye, d, t, ds);
            for c in 0..3 {
                j[c] += n[c];
            }
        }
        let w = tau * (1.0 - dt);
        for c in 0..3 {
            out[c] += tau_j * share * j[c];
        }
        depth += w * t;
        weight += w;
        tau *= dt;
        tau_j *= dt_j;
        if tau_j < OPAQUE {
            return (out, 0.0, if weight > 0.0 { depth / weight } else { 0.0 });
        }
    }
    if tau_at_end {
        tau = (-optical_depth).exp();
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
    let lost = one_minus_exp(x);
    let share = if x > 1e-12 {
        lost / keep
    } else {
        // (1 − e^{−x})/keep = a(1 − x/2 + …), within x²/6 (relative).
        a * (1.0 - 0.5 * x)
    };
    (share, 1.0 - lost)
}

/// `1 − e^{−x}`: for `|x| < 1/32` its series `x(1 − x/2(1 − x/3(1 − … (1 − x/8))))`,
/// whose first term left out is `x⁹/9!` (within `3·10⁻¹⁸` relative there); beyond,
/// `1 − e^{−x}`, whose rounding of `e^{−x}` (half an ulp of 1 where `x > 0`) is at most
/// `4·10⁻¹⁵` relative of `|1 − e^{−x}| ≥ 0.03`. One `exp` at most (glibc's `expm1` costs
/// more), none where the steps are thin. `∞` gives 1, NaN NaN.
#[inline]
pub fn one_minus_exp(x: f64) -> f64 {
    if x.abs() < 1.0 / 32.0 {
        const R: [f64; 7] = [
            1.0 / 2.0,
            1.0 / 3.0,
            1.0 / 4.0,
            1.0 / 5.0,
            1.0 / 6.0,
            1.0 / 7.0,
            1.0 / 8.0,
        ];
        let mut s = 1.0;
        for r in R.iter().rev() {
            s = 1.0 - x * r * s;
        }
        x * s
    } else {
        1.0 - (-x).exp()
    }
}

/// View pass: the image of the volume-pass grids, slice thickness `du` (world units).
/// The background is the environment, or the `ground` where a ray meets it, with the
/// smoke's shadow marched through the grids' density, the sky's share that reaches it
/// taken on its grid ([`crate::ground`]).
pub fn view_pass(
    g: &VolumeGrids,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    du: f64,
    ground: Option<&GroundLight>,
) -> Vec<[f32; 3]> {
    view_pass_reused(g, medium, env, camera, du, ground, 0.0).0
}

/// [`view_pass`] with its smooth parts' pixels between the even rows and columns taken
/// from their neighbours where the picture's second differences bound that within `tol`
/// ([`pixel_reuse`]; `tol` 0 marches every pixel, as [`view_pass`]); how many were
/// computed and reused.
pub fn view_pass_reused(
    g: &VolumeGrids,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    du: f64,
    ground: Option<&GroundLight>,
    tol: f64,
) -> (Vec<[f32; 3]>, ReuseCount) {
    let w = camera.width;
    let axis = camera.forward();
    let field = RadianceField::new(g);
    let near = NearLights::new(&env.points, &g.density, medium, camera);
    // The ground's shadow rays step as the eye's do: a slice (`ground_shadow`).
    let shadows = ground.map(|_| ShadowMarch::new(&g.density, medium.sigma_t, du));
    // The sky's share that reaches the ground, on its grid (`ground::sky_seen`).
    let ground = ground.zip(shadows.as_ref()).map(|(gr, sh)| {
        gr.clone()
            .seeing_sky_through(g.density.bbox(), |x, w, len| sh.transmittance(x, w, len))
    });
    let ground = ground.as_ref();
    let pixel = |i: usize| {
        let d = camera.pixel_ray(i % w, i / w);
        let hit = ground.zip(shadows.as_ref()).and_then(|(gr, sh)| {
            let x = gr.hit(camera.eye, d)?;
            Some((gr, sh, x))
        });
        let background = match hit {
            Some((gr, sh, x)) => gr.radiance(x, |x, w, len| sh.transmittance(x, w, len)),
            None => env.radiance(d),
        };
        let (out, tau, _) = march(
            &field,
            medium,
            &near,
            camera.eye,
            d,
            axis,
            du,
            f64::INFINITY,
            false,
        );
        [0, 1, 2].map(|c| out[c] + tau * background[c])
    };
    let n = w * camera.height;
    if tol > 0.0 {
        return pixel_reuse::reused(w, camera.height, tol, pixel);
    }
    let pixels = (0..n)
        .into_par_iter()
        .map(|i| pixel(i).map(|v| v as f32))
        .collect();
    (
        pixels,
        ReuseCount {
            computed: n,
            reused: 0,
        },
    )
}

/// The view pass as a layer ([`SmokeSample`] per pixel, row 0 on top) for compositing
/// with another medium; `t_end(d)` is where the ray along unit `d` from the eye meets an
/// opaque surface (`f64::INFINITY` for none), beyond which the smoke is hidden. `points`
/// are the point lights the lights pass lit the grids with.
pub fn view_layer(
    g: &VolumeGrids,
    medium: &Medium,
    points: &[PointLight],
    camera: &Camera,
    du: f64,
    t_end: &(dyn Fn([f64; 3]) -> f64 + Sync),
) -> Vec<SmokeSample> {
    let w = camera.width;
    let axis = camera.forward();
    let field = RadianceField::new(g);
    let near = NearLights::new(points, &g.density, medium, camera);
    (0..w * camera.height)
        .into_par_iter()
        .map(|i| {
            let d = camera.pixel_ray(i % w, i / w);
            let (out, tau, depth) = march(
                &field,
                medium,
                &near,
                camera.eye,
                d,
                axis,
                du,
                t_end(d),
                true,
            );
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
    use super::{
        MAX_SPAN, MIN_DENSITY, RadianceField, VolumeGrids, march, scattered_step, volume_pass,
    };
    use crate::render::occupancy::Occupancy;
    use crate::sh;
    use haze_volume::{Bbox, Rbf, Volume};

    /// The volume pass against its definition evaluated voxel by voxel: `D̃ = Σ B_ℓ` with
    /// [`Rbf::eval`] (one `exp` of the summed square distance), `J̃ = y·Σ B_ℓ J̃(c_ℓ)/D̃`,
    /// `D = D̃ + R`. RBFs across the row bands' edges and the box's faces, one of zero
    /// radius, one of no weight, one reaching no voxel. The pass takes `B_ℓ` as a product
    /// of per-axis factors, which differs from one `exp` by a few ulps: `10⁻⁵` relative
    /// of the f32 outputs is that plus rounding.
    #[test]
    fn volume_pass_matches_the_sum_per_voxel() {
        let dims = [13, 21, 6];
        let bbox = Bbox::new([-1.0, 0.0, 0.5], [1.6, 4.2, 1.7]);
        let order = 3;
        let n2 = order * order;
        let mut rbfs = Vec::new();
        let mut source = Vec::new();
        for k in 0..14 {
            let f = k as f64;
            // Off the voxels' lattice, so that no voxel sits on a support's sphere.
            let c = [-1.087 + 0.2 * f, 0.0131 + 0.3 * f, 0.4113 + 0.1 * f];
            rbfs.push(Rbf::new(c, 0.1511 + 0.05 * (f % 4.0), 0.5 + 0.1 * f));
            source.push([0, 1, 2].map(|ch| {
                (0..n2)
                    .map(|i| 1.0 / (1.0 + i as f64) + 0.1 * ch as f64 - 0.05 * f)
                    .collect::<Vec<f64>>()
            }));
        }
        rbfs.push(Rbf::new([0.0, 1.0, 1.0], 0.0, 1.0));
        rbfs.push(Rbf::new([0.2, 2.0, 1.0], 0.4, 0.0));
        rbfs.push(Rbf::new([9.0, 9.0, 9.0], 0.3, 1.0));
        source.extend((0..3).map(|_| [0, 1, 2].map(|_| vec![1.0; n2])));
        let n: usize = dims.iter().product();
        let residual: Vec<f32> = (0..n).map(|i| 0.01 * ((i % 7) as f32 - 3.0)).collect();
        let eye = [0.3, -5.0, 1.1];
        let got = volume_pass(&rbfs, &source, order, dims, &bbox, Some(&residual), eye);
        let size = bbox.size();
        let mut y = vec![0.0; n2];
        for (i, &res) in residual.iter().enumerate() {
            let v = [
                i % dims[0],
                (i / dims[0]) % dims[1],
                i / (dims[0] * dims[1]),
            ];
            let p = [0, 1, 2].map(|a| bbox.min[a] + (v[a] as f64 + 0.5) * size[a] / dims[a] as f64);
            let mut dt = 0.0;
            let mut acc = vec![[0.0; 3]; n2];
            for (rbf, j) in rbfs.iter().zip(&source) {
                let b = rbf.eval(p);
                dt += b;
                for (k, a) in acc.iter_mut().enumerate() {
                    for ch in 0..3 {
                        a[ch] += b * j[ch][k];
                    }
                }
            }
            let close = |a: f32, b: f64| (f64::from(a) - b).abs() <= 1e-5 * b.abs().max(1e-3);
            if dt < MIN_DENSITY {
                assert_eq!(got.density.data()[i], dt.max(0.0) as f32, "voxel {v:?}");
                assert_eq!(got.radiance[i], [0.0; 3]);
                continue;
            }
            let want_d = (dt + f64::from(res)).max(0.0);
            assert!(close(got.density.data()[i], want_d), "voxel {v:?}: D");
            sh::eval_into(order, [0, 1, 2].map(|a| p[a] - eye[a]), &mut y);
            for ch in 0..3 {
                let dot: f64 = acc.iter().zip(&y).map(|(a, b)| a[ch] * b).sum();
                let want = (dot / dt).max(0.0);
                assert!(
                    close(got.radiance[i][ch], want),
                    "voxel {v:?} ch {ch}: {} vs {want}",
                    got.radiance[i][ch]
                );
            }
        }
    }

    /// A 4 × 3 × 5 grid of unit density over `[0, 4] × [0, 3] × [0, 5]` with radiance
    /// `f(center)` per voxel.
    fn grids(f: impl Fn([f64; 3]) -> [f32; 3]) -> VolumeGrids {
        let dims = [4, 3, 5];
        let bbox = Bbox {
            min: [0.0; 3],
            max: [4.0, 3.0, 5.0],
        };
        let n = dims.iter().product();
        let radiance = (0..n)
            .map(|i| {
                let c = [i % 4, i / 4 % 3, i / 12].map(|a| a as f64 + 0.5);
                f(c)
            })
            .collect();
        VolumeGrids {
            density: Volume::new(dims, bbox, vec![1.0; n]).unwrap(),
            radiance,
            eye_peak: 0.0,
        }
    }

    /// Light falling as `e^{−τ}` with `τ` linear in the position (a sun's beam into
    /// uniform smoke, up to 3 optical depths a voxel) is interpolated exactly between the
    /// voxel centers, against the closed form at points across the cells; a constant is
    /// kept to the last bits.
    #[test]
    fn the_radiance_between_centers_is_exact_for_exponential_light() {
        let k = [0.7, -1.3, 3.0];
        let at = |c: [f64; 3]| (-(k[0] * c[0] + k[1] * c[1] + k[2] * c[2]) * 0.5).exp();
        let g = grids(|c| [at(c), 2.0 * at(c), 0.25].map(|v| v as f32));
        let field = RadianceField::new(&g);
        for p in [
            [0.5, 0.5, 0.5],
            [1.2, 1.7, 2.9],
            [3.49, 0.51, 4.4],
            [2.0, 2.5, 1.0],
        ] {
            let j = field.sample(p, 1.0);
            // The voxels hold f32: their logarithms are exact to ~6e-8 each.
            let want = at(p);
            assert!(
                (j[0] / want - 1.0).abs() < 1e-6,
                "{p:?}: {} vs {want}",
                j[0]
            );
            assert!((j[1] / (2.0 * want) - 1.0).abs() < 1e-6, "{p:?}");
            assert!((j[2] - 0.25).abs() < 1e-15, "{p:?}: {}", j[2]);
        }
    }

    /// An unlit corner (`J̃ = 0`) counts as the cell's brightest over `MAX_SPAN`: at a
    /// cell's middle, where every corner weighs ⅛, one dark corner among seven of 1 gives
    /// `MAX_SPAN^{−1/8}`. A cell with every corner dark, a sample without smoke and one
    /// outside the box give 0.
    #[test]
    fn unlit_corners_take_a_bounded_share() {
        let g = grids(|c| {
            if c == [1.5, 1.5, 1.5] {
                [0.0; 3]
            } else {
                [1.0, 0.0, 3.0]
            }
        });
        let field = RadianceField::new(&g);
        let j = field.sample([2.0, 2.0, 2.0], 1.0);
        let want = MAX_SPAN.powf(-0.125);
        assert!((j[0] - want).abs() < 1e-12, "{} vs {want}", j[0]);
        assert_eq!(j[1], 0.0);
        assert!((j[2] - 3.0 * want).abs() < 1e-12);
        assert_eq!(field.sample([2.0, 2.0, 2.0], 0.0), [0.0; 3]);
        assert_eq!(field.sample([2.0, 2.0, 2.0], f64::NAN), [0.0; 3]);
        assert_eq!(field.sample([5.0, 2.0, 2.0], 1.0), [0.0; 3]);
        // Extremes of the stored range stay finite.
        let g = grids(|c| {
            if c[0] < 2.0 {
                [f32::MAX; 3]
            } else {
                [f32::MIN_POSITIVE; 3]
            }
        });
        let j = RadianceField::new(&g).sample([2.0, 1.5, 2.5], 1.0);
        assert!(j.iter().all(|v| v.is_finite() && *v > 0.0), "{j:?}");
    }

    /// The view rays pass over the slices outside the occupied box and in empty blocks;
    /// on a sparse grid (two lumps in a box of air) they sum the same samples as a march
    /// that visits every slice (the field's occupancy taken from a grid with density
    /// everywhere): the same radiance, transmittance and depth to the bit, for rays from
    /// eyes outside and inside the box, ending behind the smoke or at a surface inside
    /// it, with and without the eye's peak. An all-air grid lets every ray through.
    #[test]
    fn view_rays_skipping_empty_blocks_sum_the_same() {
        let dims = [30, 26, 34];
        let bbox = Bbox::new([-2.0, 1.0, 0.5], [1.0, 3.6, 4.0]);
        let n: usize = dims.iter().product();
        let mut density = vec![0.0f32; n];
        let mut radiance = vec![[0.0f32; 3]; n];
        for (c, r) in [([7.0, 8.0, 9.0], 3.5), ([21.0, 17.0, 25.0], 4.0)] {
            for (i, d) in density.iter_mut().enumerate() {
                let k = [i % dims[0], i / dims[0] % dims[1], i / (dims[0] * dims[1])];
                let d2: f64 = (0..3).map(|a| (k[a] as f64 - c[a]).powi(2)).sum();
                if d2 < r * r {
                    *d = (1.0 - d2 / (r * r) + 0.01 * k[0] as f64) as f32;
                    radiance[i] = [0.5 + 0.01 * k[2] as f32, 0.3, 0.1 * k[1] as f32 + 0.05];
                }
            }
        }
        let air = VolumeGrids {
            density: Volume::new(dims, bbox, vec![0.0; n]).unwrap(),
            radiance: radiance.clone(),
            eye_peak: 0.0,
        };
        let mut g = VolumeGrids {
            density: Volume::new(dims, bbox, density).unwrap(),
            radiance,
            eye_peak: 0.0,
        };
        let everywhere = Volume::new(dims, bbox, vec![1.0; n]).unwrap();
        let mut marched = 0;
        for peak in [0.0, 0.4] {
            g.eye_peak = peak;
            let medium = crate::Medium::new(3.0, 0.8, 0.3).unwrap();
            let camera =
                super::Camera::new([0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 40.0, 8, 6).unwrap();
            let none = super::NearLights::new(&[], &g.density, &medium, &camera);
            let fast = RadianceField::new(&g);
            let mut every = RadianceField::new(&g);
            every.occupied = Occupancy::new(&everywhere);
            for k in 0..300u32 {
                let u = |s: u32| f64::from((k * s + 11) % 101) / 101.0;
                let eye = if k % 3 == 0 {
                    [-1.5 + 2.0 * u(7), 1.5 + 1.5 * u(17), 1.0 + 2.5 * u(23)]
                } else {
                    [-6.0 + 2.0 * u(7), -3.0 + 2.0 * u(17), 4.0 + 3.0 * u(23)]
                };
                // Every other ray aimed near a lump's centre, the rest anywhere in the box.
                let target = match k % 4 {
                    0 => [-1.25 + 0.2 * u(31), 1.85, 1.45],
                    2 => [0.15, 2.75 + 0.2 * u(37), 3.1],
                    _ => [-1.3 + 2.0 * u(31), 1.6 + 1.5 * u(37), 1.0 + 2.5 * u(43)],
                };
                let v = [0, 1, 2].map(|a| target[a] - eye[a]);
                let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                let d = v.map(|c| c / len);
                let axis = [0.6f64, 0.64, -0.48];
                let t_end = if k % 3 == 1 { len } else { f64::INFINITY };
                let got = march(&fast, &medium, &none, eye, d, axis, 0.045, t_end, true);
                let want = march(&every, &medium, &none, eye, d, axis, 0.045, t_end, true);
                for c in 0..3 {
                    assert_eq!(got.0[c].to_bits(), want.0[c].to_bits(), "ray {k} ch {c}");
                }
                assert_eq!(got.1.to_bits(), want.1.to_bits(), "ray {k}");
                assert_eq!(got.2.to_bits(), want.2.to_bits(), "ray {k}");
                // Without the depth the background's transmittance is `e^{−Σ a}` taken
                // once: the product of the steps' `e^{−a}` to rounding (a few hundred
                // steps, an ulp each); the scattered light is the same to the bit.
                let at_end = march(&fast, &medium, &none, eye, d, axis, 0.045, t_end, false);
                assert_eq!(
                    at_end.0.map(f64::to_bits),
                    got.0.map(f64::to_bits),
                    "ray {k}"
                );
                assert!(
                    (at_end.1 - got.1).abs() <= 1e-13 * got.1,
                    "ray {k}: {} vs {}",
                    at_end.1,
                    got.1
                );
                marched += usize::from(want.1 < 0.99);
            }
            let through = march(
                &RadianceField::new(&air),
                &medium,
                &none,
                [-5.0, 2.0, 2.0],
                [1.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                0.045,
                f64::INFINITY,
                true,
            );
            assert_eq!(through, ([0.0; 3], 1.0, 0.0));
        }
        assert!(marched > 250, "{marched} of 600 rays met the smoke");
    }

    /// `one_minus_exp` against glibc's `−expm1(−x)` on both sides of the series' edge at
    /// 1/32, at its ends and beyond: within `5·10⁻¹⁵` relative (the docs' bound, with the
    /// last multiplications' rounding), `∞` → 1, NaN → NaN, 0 → 0 exactly.
    #[test]
    fn one_minus_exp_is_expm1_to_rounding() {
        let edge = 1.0f64 / 32.0;
        let mut xs = vec![
            1e-300,
            1e-12,
            1e-6,
            1e-3,
            0.01,
            edge * (1.0 - 1e-15),
            edge,
            edge * (1.0 + 1e-15),
            0.1,
            0.5,
            1.0,
            7.0,
            40.0,
            800.0,
        ];
        xs.extend(xs.clone().iter().filter(|x| **x < 10.0).map(|x| -x));
        for x in xs {
            let want = -(-x).exp_m1();
            let got = super::one_minus_exp(x);
            assert!(
                (got - want).abs() <= 5e-15 * want.abs(),
                "{x}: {got} vs {want}"
            );
        }
        assert_eq!(super::one_minus_exp(0.0), 0.0);
        assert_eq!(super::one_minus_exp(f64::INFINITY), 1.0);
        assert!(super::one_minus_exp(f64::NAN).is_nan());
    }

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
