//! Where paper B's one-point factorization ([`crate::airlight::factored`]) is not good
//! enough, Gaussian `i`'s airlight integrated along the ray.
//!
//! **The bound.** For a (light, Gaussian) pair the factorization samples `f(x) =
//! I/(4π|x − s|²)·e^{−Tᵢ(s,x) − Tᵢ(v,x)}` at one point. Its relative error has two
//! causes, each bounded from the pair's geometry alone (independent of the ray, so it
//! is decided once per frame):
//!
//! * **self-shadowing**: the centre is the Gaussian's most shadowed point; the error
//!   grows with the peak optical depth `τᵢ = cᵢ√π/aᵢ` — measured `−2…+3 %` at `τ = 0.18`,
//!   `−25…−34 %` at `τ = 1.8` ([`crate::airlight`]'s tests): `e_τ = 0.2·τᵢ`;
//! * **the light's `1/d²`** over the Gaussian's width: `+1/(2a²h²)` for a light at
//!   distance `h` from the ray (the notes' thin-Gaussian law). A ray that meets most of
//!   the Gaussian passes within `1.5` radii of its centre, so with the light `ρ = aᵢ|s −
//!   bᵢ|` radii from the centre `h ≥ (ρ − 1.5)/aᵢ`: `e_d = 1/(2(ρ − 1.5)²)`, infinite for
//!   `ρ ≤ 1.5` (a light inside the Gaussian); 0 for a sun.
//!
//! [`bound`]` = e_τ + e_d`; the renderer integrates the pairs whose bound exceeds its
//! target and keeps the closed form elsewhere.
//!
//! **The integral.** `Lᵢ = αᵢ∫ cᵢe^{−aᵢ²|x(t) − bᵢ|²}·I/(4π d(t)²)·e^{−Tᵢ(v,x) − Tᵢ(x,s) −
//! β0(t + |s − x|) + Eᵢ} dt` over the ray's chord through the sphere of [`SUPPORT`]
//! radii (density `e^{−9}` of the peak beyond, the paper's `3r`), Gaussian `i`'s own
//! attenuation and the homogeneous part along the true path `s → x → v` (exact erf line
//! integrals, [`crate::line`]), the other Gaussians' through `bᵢ` as in the paper
//! (`Eᵢ`, the caller's). The chord is cut where the light is closest to the ray (`t_s`)
//! and at the Gaussian's peak along it (`m`); each piece is integrated by 6-node
//! Gauss–Legendre in the angle `θ = atan((t − t_s)/h_s)` seen from the light, `h_s` its
//! distance from the ray: `dt/d² = dθ/h_s`, so the `1/d²` peak of a light beside or on the
//! ray (`h_s` floored at `r_min`) costs no nodes. For a sun, in `t` itself. Measured
//! against Simpson's rule: `≤ 3·10⁻³` relative on lights inside, at the edge of and
//! outside dense Gaussians (tests below; `4·10⁻⁴` but for a light a tenth of a radius
//! from the centre); 4 nodes a piece: `2 %`.
//!
//! **Hosts.** A light within [`SUPPORT`] radii of a Gaussian's centre sits inside it: the
//! Gaussian's attenuation of the light varies across every other Gaussian and along every
//! ray, which the paper's `Eᵢ` (taken through `bᵢ`) and `C_sv = e^{−Σ Tⱼ(s,v)}` miss. For
//! those hosts (at most [`MAX_HOSTS`] per light, the nearest in radii) the renderer moves
//! `Tₖ(s, ·)` and `Tₖ(·, v)` out of `Eᵢ` and evaluates them at every node ([`integrated`]'s
//! `others`), and
//! scales the homogeneous term by [`host_ratio`].
//!
//! **Shadowers.** The same holds for any other dense Gaussian whose support meets the
//! paths of an integrated pair: the cone from the light to the integrated Gaussian's
//! support (its shadow falls across part of the Gaussian) or the cone from the eye to it
//! (it hides part of the Gaussian). Taken through `bᵢ` its attenuation is all or nothing
//! where it is partial: a lamp inside one dense Gaussian lighting its neighbours through
//! a third was 24 % off (`data/scenes/lamps/held_out.json`'s first light). [`shadowers`]
//! picks them per pair, those whose attenuation taken at the centre errs most
//! ([`shadow_error`], at least [`MIN_SHADOW_ERROR`]); with the hosts they make the pair's
//! *exact* list of at most [`MAX_EXACT`] Gaussians, whose depths the pair takes per node.
//! The homogeneous term's own list is the hosts and [`fog_casters`].

use crate::airlight::{Blob, Source, own_depth_between};
use crate::line;
use errorfunctions::ComplexErrorFunctions;
use haze_core::vec3::{Vec3, axpy, dot, norm, sub};
use num_complex::Complex64;
use std::f64::consts::PI;

/// The chord integrated, in radii from the centre; a light nearer a centre has it as a host.
pub const SUPPORT: f64 = 3.0;

/// Most hosts of a light.
pub const MAX_HOSTS: usize = 3;

/// Most Gaussians of a light taken exactly per node (hosts first, then [`shadowers`]).
pub const MAX_EXACT: usize = 16;

/// The error of a Gaussian's attenuation taken at an integrated Gaussian's centre
/// ([`shadow_error`]) below which it is not a shadower. Measured on the lamp scenes
/// (BENCHMARKS): 10⁻³ and 3·10⁻³ give 0.7–1.6 % and 1.1–1.6 %; ranking by the depth's
/// spread instead (max − min) and keeping from 0.1 gave up to 3.9 %.
pub const MIN_SHADOW_ERROR: f64 = 1e-3;

/// Gauss–Legendre nodes a side of [`host_ratio`]'s light.
const HOST_NODES: usize = 2;

/// Gauss–Legendre nodes and weights on `[−1, 1]`, 6 points.
pub const GAUSS_LEGENDRE_6: [(f64, f64); 6] = [
    (-0.932_469_514_203_152, 0.171_324_492_379_170),
    (-0.661_209_386_466_264_5, 0.360_761_573_048_138_6),
    (-0.238_619_186_083_196_9, 0.467_913_934_572_691),
    (0.238_619_186_083_196_9, 0.467_913_934_572_691),
    (0.661_209_386_466_264_5, 0.360_761_573_048_138_6),
    (0.932_469_514_203_152, 0.171_324_492_379_170),
];

/// The bound on the factorization's relative error for Gaussian `b` and `light` (module
/// docs); `∞` for a point light within 1.5 radii of the centre.
pub fn bound(b: &Blob, light: Source) -> f64 {
    let e_tau = 0.2 * b.c * PI.sqrt() / b.a;
    match light {
        Source::Point(s) => {
            let rho = b.a * norm(sub(s, b.center)) - 1.5;
            if rho > 0.0 {
                e_tau + 0.5 / (rho * rho)
            } else {
                f64::INFINITY
            }
        }
        Source::Sun(_) => e_tau,
    }
}

/// `αᵢ∫ βᵢ(x)·e^{−Tᵢ(v,x) − Tᵢ(x,s) − β0_c·path_c(x)}/(4π d²) dt` per channel over the
/// segment `v + t·dir`, `t ∈ [0, dr]`, for unit intensity (module docs): multiply by the
/// light's power and `e^{Eᵢ}` (the other Gaussians only). `beta0` is the homogeneous
/// extinction per channel; its path is `t + |s − x|` for a point light and `t` for a sun
/// (whose attenuation by a background the caller handles, as for the closed form);
/// `d` is floored at `r_min`. `others(t)` is added to the exponent at `v + t·dir` (the
/// renderer's hosts; 0 for none).
#[allow(clippy::too_many_arguments)]
pub fn integrated(
    b: &Blob,
    v: Vec3,
    dir: Vec3,
    dr: f64,
    light: Source,
    r_min: f64,
    beta0: [f64; 3],
    others: &dyn Fn(f64) -> f64,
) -> [f64; 3] {
    let mut out = [0.0; 3];
    if b.albedo <= 0.0 {
        return out;
    }
    let own = line::AlongRay::new(b.c, b.a, b.center, v, dir);
    chord_nodes(b, v, dir, dr, light, r_min, |t, weight| {
        // The node's integrand is `prefactor·e^{exponent − β0_c·path}` (one exp a node
        // for a grey β0).
        let x = axpy(v, t, dir);
        let dx = sub(x, b.center);
        let own_v = own.to(t);
        let (inv_d2, own_s, path) = match light {
            Source::Point(s) => {
                let (d, own) = own_depth_between(b, x, s);
                let dd = d.max(r_min);
                (1.0 / (dd * dd), own, t + d)
            }
            Source::Sun(l) => (
                1.0,
                line::gaussian(b.c, b.a, b.center, x, l, f64::INFINITY),
                t,
            ),
        };
        let pre = weight * b.albedo * b.c * inv_d2 / (4.0 * PI);
        let exponent = others(t) - own_v - own_s - b.a * b.a * dot(dx, dx);
        let mut last = (f64::NAN, 0.0);
        for (c, o) in out.iter_mut().enumerate() {
            // One exp per distinct β0 (a grey background: one for the three).
            if beta0[c] != last.0 {
                let e = if beta0[c] > 0.0 { beta0[c] * path } else { 0.0 };
                last = (beta0[c], pre * (exponent - e).exp());
            }
            *o += last.1;
        }
    });
    out
}

/// [`integrated`] without any attenuation: `αᵢ∫ βᵢ(x)/(4π d²) dt` along the ray. What the
/// renderer's screen-space reuse divides the integrated airlight by (`haze_scene`'s
/// `paper_b::reuse`): the ratio is the airlight's attenuation averaged along the ray,
/// which varies on the scale of the Gaussians, while this carries the light's `1/d²` and
/// the Gaussian's footprint. Asked at every pixel a pair's Gaussian covers, so in closed
/// form where the ray holds the whole [`SUPPORT`] chord ([`unattenuated_whole`]); over
/// [`integrated`]'s chord and nodes (one `exp` a node) where the eye or the ray's end lies
/// within it.
pub fn unattenuated(b: &Blob, v: Vec3, dir: Vec3, dr: f64, light: Source, r_min: f64) -> f64 {
    if let Some(u) = unattenuated_whole(b, v, dir, dr, light, r_min) {
        return u;
    }
    let mut out = 0.0;
    chord_nodes(b, v, dir, dr, light, r_min, |t, weight| {
        let x = axpy(v, t, dir);
        let dx = sub(x, b.center);
        let inv_d2 = match light {
            Source::Point(s) => {
                let d = norm(sub(s, x)).max(r_min);
                1.0 / (d * d)
            }
            Source::Sun(_) => 1.0,
        };
        out += weight * inv_d2 * (-b.a * b.a * dot(dx, dx)).exp();
    });
    b.albedo * b.c * out / (4.0 * PI)
}

/// [`unattenuated`] along the whole line, in closed form, when the segment `[0, dr]` holds
/// the Gaussian's whole [`SUPPORT`] chord (`None` otherwise; `Some(0)` for a ray that
/// misses the support or a Gaussian of no density). With `m` the centre's foot on the
/// ray, `h` its distance from it, the light's foot `t_s` and distance `h_s` (floored at
/// `r_min`, as the nodes' `d` is):
///
/// `∫ e^{−a²(t − m)²}/(h_s² + (t − t_s)²) dt = (π/h_s)·Re w(a(t_s − m) + i·a·h_s)`
///
/// over the whole line (the Voigt profile; `w` the Faddeeva function, `u = a(t − m)`
/// turns it into `Re w(x + iy) = (y/π)∫ e^{−u²}/((x − u)² + y²) du`), so
/// `U = αc·e^{−a²h²}·Re w(…)/(4h_s)`; for a sun `αc·e^{−a²h²}·√π/(4πa)`. The line beyond
/// the chord holds at most `erfc(3) ≈ 2·10⁻⁵` of the density along it (relative to the
/// ray's own, whatever `h`, up to `e^{−9}` of the peak at the support's rim).
pub fn unattenuated_whole(
    b: &Blob,
    v: Vec3,
    dir: Vec3,
    dr: f64,
    light: Source,
    r_min: f64,
) -> Option<f64> {
    if b.c <= 0.0 || b.albedo <= 0.0 {
        return Some(0.0);
    }
    let Some((m, h2, half)) = support_chord(b, v, dir) else {
        return Some(0.0);
    };
    if m - half < 0.0 || m + half > dr {
        return None;
    }
    let scale = b.albedo * b.c * (-b.a * b.a * h2).exp();
    Some(match light_foot(v, dir, light, r_min) {
        Some((ts, hs)) => {
            let z = Complex64::new(b.a * (ts - m), b.a * hs);
            scale * z.w().re / (4.0 * hs)
        }
        None => scale * PI.sqrt() / (4.0 * PI * b.a),
    })
}

/// The line `v + t·dir` through `b`'s [`SUPPORT`] sphere: the centre's foot `m` on it,
/// the centre's squared distance `h²` from it and the chord's half-length (the chord is
/// `m ± half`); `None` where the line misses the sphere.
fn support_chord(b: &Blob, v: Vec3, dir: Vec3) -> Option<(f64, f64, f64)> {
    let bv = sub(b.center, v);
    let m = dot(bv, dir);
    let h2 = (dot(bv, bv) - m * m).max(0.0);
    let reach = SUPPORT / b.a;
    (h2 < reach * reach).then(|| (m, h2, (reach * reach - h2).sqrt()))
}

/// A point light's foot `t_s` on the line `v + t·dir` and its distance `h_s` from it,
/// floored at `r_min`; `None` for a sun.
fn light_foot(v: Vec3, dir: Vec3, light: Source, r_min: f64) -> Option<(f64, f64)> {
    match light {
        Source::Point(s) => {
            let sv = sub(s, v);
            let ts = dot(sv, dir);
            Some((ts, (dot(sv, sv) - ts * ts).max(0.0).sqrt().max(r_min)))
        }
        Source::Sun(_) => None,
    }
}

/// The quadrature of [`integrated`] (module docs): calls `visit(t, w)` for each node `t`
/// of the chord of `v + t·dir`, `t ∈ [0, dr]`, through `b`'s [`SUPPORT`] sphere, with
/// `w` its weight in `t` (the `1/d²`-flattening substitution's `d²/h_s` included); none
/// for an empty chord or a Gaussian of no density.
fn chord_nodes(
    b: &Blob,
    v: Vec3,
    dir: Vec3,
    dr: f64,
    light: Source,
    r_min: f64,
    mut visit: impl FnMut(f64, f64),
) {
    if b.c <= 0.0 || dr <= 0.0 {
        return;
    }
    let Some((m, _, half)) = support_chord(b, v, dir) else {
        return;
    };
    let (lo, hi) = ((m - half).max(0.0), (m + half).min(dr));
    if hi <= lo {
        return;
    }
    let foot = light_foot(v, dir, light, r_min);
    let mut cuts = [lo, hi, hi, hi];
    let mut n = 1;
    for q in [foot.map(|f| f.0), Some(m)].into_iter().flatten() {
        if q > lo && q < hi {
            cuts[n] = q;
            n += 1;
        }
    }
    cuts[n] = hi;
    cuts[..=n].sort_by(f64::total_cmp);
    for w in cuts[..=n].windows(2) {
        let (p0, p1) = (w[0], w[1]);
        if p1 <= p0 {
            continue;
        }
        for &(x, wq) in &GAUSS_LEGENDRE_6 {
            match foot {
                // t = t_s + h_s·tan θ: dt = d²/h_s dθ with d² = h_s²/cos²θ.
                Some((ts, hs)) => {
                    let (th0, th1) = (((p0 - ts) / hs).atan(), ((p1 - ts) / hs).atan());
                    let th = 0.5 * (th0 + th1) + 0.5 * (th1 - th0) * x;
                    let (sin, c) = th.sin_cos();
                    let t = ts + hs * sin / c;
                    let d2 = (hs * hs / (c * c)).max(r_min * r_min);
                    visit(t, 0.5 * (th1 - th0) * wq * d2 / hs);
                }
                None => visit(0.5 * (p0 + p1) + 0.5 * (p1 - p0) * x, 0.5 * (p1 - p0) * wq),
            }
        }
    }
}

/// Whether a point light at `s` sits inside `b` (within [`SUPPORT`] radii), and how deep
/// (in radii).
pub fn host_depth(b: &Blob, s: Vec3) -> Option<f64> {
    let rho = b.a * norm(sub(s, b.center));
    (rho <= SUPPORT && b.c > 0.0).then_some(rho)
}

/// Whether the sphere `(c, r)` meets the cone of segments from `apex` to the sphere
/// `(target, reach)` (every point of which lies within `|target − apex| + reach` of the
/// apex, at an angle of at most `asin(reach/|target − apex|)` from its axis). Conservative:
/// true whenever the apex lies inside either sphere.
fn meets_cone(apex: Vec3, target: Vec3, reach: f64, c: Vec3, r: f64) -> bool {
    let (u, w) = (sub(target, apex), sub(c, apex));
    let (du, dw) = (norm(u), norm(w));
    if dw <= r {
        return true;
    }
    if dw - r > du + reach {
        return false;
    }
    if du <= reach {
        return true;
    }
    let cos = (dot(u, w) / (du * dw)).clamp(-1.0, 1.0);
    cos.acos() <= (reach / du).asin() + (r / dw).min(1.0).asin()
}

/// The shadowers of the integrated pair of Gaussian `i` and the point light `s` seen from
/// `eye`: of `candidates` (indices into `blobs`; a superset, e.g. the Gaussians near the
/// segments from the light and the eye to `bᵢ`), those whose support ([`SUPPORT`] radii)
/// meets the cone from the light to the pair's support or the cone from the eye to it
/// (module docs), leaving out `i` and `exclude` (the hosts); only those whose
/// [`shadow_error`] reaches [`MIN_SHADOW_ERROR`] (a shadow that covers the whole Gaussian
/// evenly is right at the centre), as `(error, index)`, the largest error first: the
/// caller keeps as many as it can afford.
pub fn shadowers(
    blobs: &[Blob],
    candidates: &[usize],
    s: Vec3,
    eye: Vec3,
    i: usize,
    exclude: &[usize],
) -> Vec<(f64, usize)> {
    let p = &blobs[i];
    let reach = SUPPORT / p.a;
    let mut found: Vec<(f64, usize)> = candidates
        .iter()
        .map(|&j| (j, &blobs[j]))
        .filter(|&(j, b)| {
            j != i
                && b.c > 0.0
                && b.a > 0.0
                && !exclude.contains(&j)
                && (meets_cone(s, p.center, reach, b.center, SUPPORT / b.a)
                    || meets_cone(eye, p.center, reach, b.center, SUPPORT / b.a))
        })
        .map(|(j, b)| (shadow_error(b, p, s, eye), j))
        .filter(|&(e, _)| e >= MIN_SHADOW_ERROR)
        .collect();
    found.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    found.dedup_by_key(|x| x.1);
    found
}

/// The relative error of taking Gaussian `b`'s attenuation of Gaussian `p` (lit by the
/// point light `s`, seen from `eye`) at `p`'s centre, as paper B does: with
/// `T(x) = T_b(s, x) + T_b(x, eye)` at `p`'s centre `x₀` and one radius (`1/aₚ`) from it
/// along each axis (`x₁…x₆`, the body's spread), `|⅐Σₖ e^{−(T(xₖ) − T(x₀))} − 1|` — the
/// mean attenuation over the body against the centre's. A shadow that varies evenly
/// across the body cancels to second order (`≈ Var T/2`); an edge across it does not.
pub fn shadow_error(b: &Blob, p: &Blob, s: Vec3, eye: Vec3) -> f64 {
    let r = 1.0 / p.a;
    let mut points = [p.center; 7];
    for k in 0..3 {
        points[2 * k + 1][k] += r;
        points[2 * k + 2][k] -= r;
    }
    let depth = |x: Vec3| -> f64 {
        [s, eye]
            .iter()
            .map(|&o| {
                let u = sub(o, x);
                let len = norm(u);
                if len > 0.0 {
                    line::gaussian(b.c, b.a, b.center, x, u.map(|c| c / len), len)
                } else {
                    0.0
                }
            })
            .sum()
    };
    let t0 = depth(points[0]);
    let mean = points.iter().map(|&x| (t0 - depth(x)).exp()).sum::<f64>() / 7.0;
    (mean - 1.0).abs()
}

/// The Gaussians (indices into `blobs`) that shade the homogeneous medium around the
/// point light `s`: peak depth `τⱼ` above `min_depth`, ranked by `τⱼ/max(1, (aⱼDⱼ)²)`
/// (the depth times the solid angle, in units of its radius, it blocks at distance `Dⱼ`
/// from the light: the share of the lit fog it darkens), leaving out `exclude`; at most
/// `max`. Paper B's homogeneous term dims all of it by one `C_sv = e^{−Σ Tⱼ(s,v)}`, which
/// misses these shadows (its light shafts): `data/scenes/lamps/outside.json` was 5.2 %
/// off with every pair integrated, 0.05 % with the background taken away.
pub fn fog_casters(
    blobs: &[Blob],
    s: Vec3,
    exclude: &[usize],
    min_depth: f64,
    max: usize,
) -> Vec<usize> {
    let mut found: Vec<(f64, usize)> = blobs
        .iter()
        .enumerate()
        .filter(|&(j, b)| b.c > 0.0 && b.a > 0.0 && !exclude.contains(&j))
        .filter_map(|(j, b)| {
            let tau = b.c * PI.sqrt() / b.a;
            let rho = b.a * norm(sub(b.center, s));
            (tau > min_depth).then(|| (tau / (rho * rho).max(1.0), j))
        })
        .collect();
    found.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    found.truncate(max);
    found.into_iter().map(|(_, j)| j).collect()
}

/// The hosts' share of the homogeneous term's attenuation along the ray `v + t·dir`,
/// `t ∈ [0, dr]`, lit by the point light `s` (the renderer passes the light's exact list:
/// hosts, shadowers and [`fog_casters`]):
///
/// `R = ∫ β0e^{−β0(t + d)}/d²·e^{−Σₖ[Tₖ(v,x) + Tₖ(x,s)]} dt / ∫ β0e^{−β0(t + d)}/d² dt`,
///
/// which replaces the hosts' `e^{−Σₖ Tₖ(s,v)}` in `C_sv` (paper C's closed form keeps the
/// unattenuated integral). Both integrals take the same nodes — Gauss–Legendre in the
/// angle from the light ([`integrated`]), [`HOST_NODES`] × 6 a side of its foot — so their
/// common quadrature error cancels in the ratio. 1 without hosts.
///
/// Each listed Gaussian may drop `delta` of depth on each of a node's two lines (towards
/// the eye and towards the light; [`line::AlongRay::within`], [`line::gaussian_within`]:
/// no error function where a line's ends lie far past its tails), so a node's exponent is
/// off by at most `2·n·delta` for `n` listed Gaussians and the ratio by that, relative;
/// 0 takes every line exactly.
#[allow(clippy::too_many_arguments)]
pub fn host_ratio(
    hosts: &[Blob],
    v: Vec3,
    dir: Vec3,
    dr: f64,
    s: Vec3,
    r_min: f64,
    beta0: f64,
    delta: f64,
) -> f64 {
    if hosts.is_empty() || dr <= 0.0 {
        return 1.0;
    }
    let sv = sub(s, v);
    let ts = dot(sv, dir);
    let hs = (dot(sv, sv) - ts * ts).max(0.0).sqrt().max(r_min);
    let (lo, hi) = ((-ts / hs).atan(), ((dr - ts) / hs).atan());
    let (mut num, mut den) = (0.0, 0.0);
    let along: Vec<(line::AlongRay, f64)> = hosts
        .iter()
        .map(|b| {
            if delta > 0.0 {
                let far = line::far_for(b.c, b.a, delta);
                (line::AlongRay::within(b.c, b.a, b.center, v, dir, far), far)
            } else {
                (line::AlongRay::new(b.c, b.a, b.center, v, dir), line::FAR)
            }
        })
        .collect();
    let pieces = [lo, 0.0f64.clamp(lo, hi), hi];
    for w in pieces.windows(2) {
        for k in 0..HOST_NODES {
            let (a0, a1) = (
                w[0] + (w[1] - w[0]) * k as f64 / HOST_NODES as f64,
                w[0] + (w[1] - w[0]) * (k + 1) as f64 / HOST_NODES as f64,
            );
            if a1 <= a0 {
                continue;
            }
            for &(x, wq) in &GAUSS_LEGENDRE_6 {
                let th = 0.5 * (a0 + a1) + 0.5 * (a1 - a0) * x;
                let t = ts + hs * th.tan();
                let p = axpy(v, t, dir);
                let ls = sub(s, p);
                let d = norm(ls);
                let g = wq
                    * (a1 - a0)
                    * if beta0 > 0.0 {
                        (-beta0 * (t + d)).exp()
                    } else {
                        1.0
                    };
                if g <= 0.0 {
                    continue;
                }
                let mut depth = 0.0;
                for (b, (along, far)) in hosts.iter().zip(&along) {
                    depth += along.to(t);
                    if d > 0.0 {
                        let u = ls.map(|c| c / d);
                        depth += line::gaussian_within(b.c, b.a, b.center, p, u, d, *far);
                    }
                }
                num += g * (-depth).exp();
                den += g;
            }
        }
    }
    if den > 0.0 { num / den } else { 1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_core::vec3::normalize;

    #[test]
    fn host_ratio_matches_quadrature_and_drops_at_most_its_delta() {
        // Three dense Gaussians, the light inside the first, a grey background: the ratio
        // against Simpson's rule of its definition (exact line depths, 200 000 intervals in
        // `t`; the 24-node rule in the light's angle measured within 3·10⁻⁵ here, held to
        // 3·10⁻⁴), and with `δ = 10⁻⁷` against `δ = 0` within the bound `2·n·δ`.
        let blob = |center: Vec3, r: f64, c: f64| Blob {
            center,
            a: 1.0 / r,
            c,
            albedo: 0.9,
        };
        let hosts = [
            blob([0.0, 0.0, 0.0], 0.6, 3.0),
            blob([0.9, 0.3, 0.4], 0.4, 5.0),
            blob([-0.5, 1.2, 0.8], 0.9, 1.5),
        ];
        let s = [0.1, -0.2, 0.15];
        let v = [-3.0, -4.0, 1.0];
        let beta0 = 0.15;
        let dr = 12.0;
        let mut worst: f64 = 0.0;
        for target in [
            [0.0, 0.0, 0.0],
            [0.8, 0.4, 0.3],
            [-0.6, 1.5, 1.0],
            [2.0, 2.0, 0.0],
        ] {
            let dir = normalize(sub(target, v)).unwrap();
            let depth = |x: Vec3| -> f64 {
                let ls = sub(s, x);
                let d = norm(ls);
                let u = ls.map(|c| c / d);
                hosts
                    .iter()
                    .map(|b| {
                        line::gaussian(b.c, b.a, b.center, v, dir, dot(sub(x, v), dir))
                            + line::gaussian(b.c, b.a, b.center, x, u, d)
                    })
                    .sum()
            };
            let weight = |t: f64| {
                let x = axpy(v, t, dir);
                let d = norm(sub(s, x));
                (-beta0 * (t + d)).exp() / (d * d)
            };
            let num = crate::simpson(
                |t| weight(t) * (-depth(axpy(v, t, dir))).exp(),
                0.0,
                dr,
                200_000,
            );
            let den = crate::simpson(weight, 0.0, dr, 200_000);
            let want = num / den;
            let exact = host_ratio(&hosts, v, dir, dr, s, 1e-9, beta0, 0.0);
            let cut = host_ratio(&hosts, v, dir, dr, s, 1e-9, beta0, 1e-7);
            assert!(want > 0.0 && want < 1.0, "{want}");
            worst = worst.max((exact / want - 1.0).abs());
            assert!((exact / want - 1.0).abs() < 3e-4, "{exact} against {want}");
            assert!(
                (cut / exact - 1.0).abs() <= 2.0 * 3.0 * 1e-7,
                "{cut} against {exact}"
            );
        }
        println!("host ratio against Simpson: worst {worst:.2e}");
        // No hosts, or an empty ray: 1.
        assert_eq!(
            host_ratio(&[], v, [1.0, 0.0, 0.0], dr, s, 1e-9, beta0, 1e-7),
            1.0
        );
        assert_eq!(
            host_ratio(&hosts, v, [1.0, 0.0, 0.0], 0.0, s, 1e-9, beta0, 1e-7),
            1.0
        );
    }

    /// The same integral by composite Simpson over `[0, dr]`, 200 000 panels, with the
    /// Gaussian's attenuation from its own line integrals — independent of the chord, the
    /// cuts and the angle substitution (on these segments of length ≤ 12 and radii
    /// ≥ 0.3 its error is below `10⁻⁸` relative; the light never lies on the ray).
    fn simpson(b: &Blob, v: Vec3, dir: Vec3, dr: f64, s: Vec3, beta0: f64) -> f64 {
        let f = |t: f64| {
            let x = axpy(v, t, dir);
            let ls = sub(s, x);
            let d = norm(ls);
            let dx = sub(x, b.center);
            let tv = line::gaussian(b.c, b.a, b.center, v, dir, t);
            let ts = line::gaussian(b.c, b.a, b.center, x, ls.map(|c| c / d), d);
            b.albedo * b.c * (-b.a * b.a * dot(dx, dx)).exp() / (4.0 * PI * d * d)
                * (-tv - ts - beta0 * (t + d)).exp()
        };
        crate::simpson(f, 0.0, dr, 200_000)
    }

    #[test]
    fn matches_quadrature_inside_at_the_edge_and_outside() {
        // Dense Gaussians (peak optical depth 1.9–3.2), the light at 0.1–4 radii from the
        // centre, rays through the centre and past it. The rule errs most where the light
        // is a tenth of a radius from the centre, 0.03 radii from the ray: there the
        // Gaussian's own shadow Tᵢ(x,s) turns within the 1/d² peak the angle absorbs
        // (measured 2.8·10⁻³; 4·10⁻⁴ at ρ ≥ 0.5). 5·10⁻³ keeps that margin; the
        // factorization is 20–70 % off on the same rays.
        let mut worst: f64 = 0.0;
        for (c, r) in [(3.6, 0.5), (1.2, 0.9)] {
            let b = Blob {
                center: [0.2, 0.1, 1.0],
                a: 1.0 / r,
                c,
                albedo: 0.9,
            };
            for rho in [0.1, 0.5, 1.0, 2.0, 4.0] {
                let s = axpy(b.center, rho * r, normalize([0.3, -0.5, 0.8]).unwrap());
                for off in [0.0, 0.4, 1.2] {
                    let v = [-4.0, -3.0, 0.5];
                    let target = axpy(b.center, off * r, [0.0, 0.0, 1.0]);
                    let dir = normalize(sub(target, v)).unwrap();
                    let got =
                        integrated(&b, v, dir, 12.0, Source::Point(s), 1e-9, [0.09; 3], &|_| {
                            0.0
                        });
                    let want = simpson(&b, v, dir, 12.0, s, 0.09);
                    let err = (got[0] / want - 1.0).abs();
                    worst = worst.max(err);
                    assert!(err < 5e-3, "c {c} r {r} ρ {rho} off {off}: {err}");
                    assert!(got.iter().all(|&x| x == got[0]));
                }
            }
        }
        println!("worst relative error {worst:.2e}");
    }

    #[test]
    fn unattenuated_matches_quadrature_and_a_sun_its_closed_form() {
        // Against Simpson's rule of `αc·e^{−a²|x−b|²}/(4πd²)` along the segment, for lights
        // 0.1–4 radii from the centre (0.03–2.8 radii from the ray). A segment holding the
        // whole support takes the Voigt closed form: the line beyond it holds `< e^{−49}`
        // of the density here and Simpson's error is below 10⁻⁸, so 10⁻⁷ is what `w`'s
        // rounding leaves room for. A segment that starts or ends within the support (the
        // eye inside the Gaussian, a surface through it) takes the chord's nodes, within
        // the integrated rule's 5·10⁻³. For a sun, against `αc√π e^{−a²h²}/(4πa)`.
        let b = Blob {
            center: [0.2, 0.1, 1.0],
            a: 1.0 / 0.7,
            c: 2.0,
            albedo: 0.9,
        };
        let want = |v: Vec3, dir: Vec3, s: Vec3, dr: f64| {
            let f = |t: f64| {
                let x = axpy(v, t, dir);
                let (d, dx) = (norm(sub(s, x)), sub(x, b.center));
                b.albedo * b.c * (-b.a * b.a * dot(dx, dx)).exp() / (4.0 * PI * d * d)
            };
            crate::simpson(f, 0.0, dr, 200_000)
        };
        let v = [-4.0, -3.0, 0.5];
        let (mut closed, mut nodes): (f64, f64) = (0.0, 0.0);
        for rho in [0.1, 0.5, 1.0, 2.0, 4.0] {
            let s = axpy(b.center, rho * 0.7, normalize([0.3, -0.5, 0.8]).unwrap());
            for off in [0.0, 0.4, 1.2] {
                let target = axpy(b.center, off * 0.7, [0.0, 0.0, 1.0]);
                let dir = normalize(sub(target, v)).unwrap();
                let light = Source::Point(s);
                assert!(unattenuated_whole(&b, v, dir, 12.0, light, 1e-9).is_some());
                let got = unattenuated(&b, v, dir, 12.0, light, 1e-9);
                let err = (got / want(v, dir, s, 12.0) - 1.0).abs();
                closed = closed.max(err);
                assert!(err < 1e-7, "ρ {rho} off {off}: {err:e}");
                // The eye half a radius from the centre; a ray ending at the centre's foot.
                let inside = axpy(b.center, -0.35, dir);
                let foot = dot(sub(b.center, v), dir);
                for (v, dr) in [(inside, 12.0), (v, foot)] {
                    assert!(unattenuated_whole(&b, v, dir, dr, light, 1e-9).is_none());
                    let got = unattenuated(&b, v, dir, dr, light, 1e-9);
                    let err = (got / want(v, dir, s, dr) - 1.0).abs();
                    nodes = nodes.max(err);
                    assert!(err < 5e-3, "ρ {rho} off {off} from {v:?} to {dr}: {err:e}");
                }
            }
            let dir = normalize(sub(axpy(b.center, 0.5, [0.0, 0.0, 1.0]), v)).unwrap();
            let bv = sub(b.center, v);
            let h2 = dot(bv, bv) - dot(bv, dir).powi(2);
            let sun = unattenuated(&b, v, dir, 12.0, Source::Sun([0.0, 0.0, 1.0]), 1e-9);
            let want = b.albedo * b.c * PI.sqrt() * (-b.a * b.a * h2).exp() / (4.0 * PI * b.a);
            assert!(
                (sun / want - 1.0).abs() < 1e-12,
                "sun: {sun} against {want}"
            );
        }
        println!("worst relative error: closed form {closed:.2e}, nodes {nodes:.2e}");
        // No chord, no density: 0. A light on the ray at the centre: its distance from the
        // ray floored at `r_min`, the whole line gives `αc/(4π)·(π/r_min)·erfcx(a·r_min)`
        // (`w(iy) = erfcx(y)`, within `2a·r_min/√π` of 1 for a small `r_min`); the nodes
        // (a segment ending within the support) floor each node's distance instead, a
        // regularization of the same divergent integral: finite and of the same order.
        let up = [0.0, 0.0, 1.0];
        assert_eq!(
            unattenuated(&b, [9.0, 9.0, 9.0], up, 5.0, Source::Sun(up), 1e-9),
            0.0
        );
        let none = Blob { c: 0.0, ..b };
        assert_eq!(unattenuated(&none, v, up, 12.0, Source::Sun(up), 1e-9), 0.0);
        let dir = normalize(sub(b.center, v)).unwrap();
        let on_ray = Source::Point(b.center);
        let r_min = 1e-6;
        let whole = unattenuated(&b, v, dir, 12.0, on_ray, r_min);
        let limit = b.albedo * b.c / (4.0 * r_min);
        assert!(
            (whole / limit - 1.0).abs() < 2.0 * b.a * r_min,
            "{whole:e} against {limit:e}"
        );
        let foot = dot(sub(b.center, v), dir);
        let near = unattenuated(&b, v, dir, foot + 2.0, on_ray, r_min);
        assert!(near.is_finite() && near > 0.5 * whole && near < 2.0 * whole);
    }

    /// `meets_cone` against brute force: points spread through the target sphere, each
    /// segment to the apex walked in 400 steps, a hit wherever one comes within `r` of
    /// `c` (less a step's length, the walk's resolution). The cone test may only err on
    /// the side of a hit; over these random configurations it also rejects some.
    #[test]
    fn cone_test_never_misses_a_sphere_on_the_paths() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rand = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut hits, mut rejected) = (0, 0);
        for _ in 0..300 {
            let mut pt = |k: f64| [0, 1, 2].map(|_| k * (2.0 * rand() - 1.0));
            let (apex, target, off, far) = (pt(3.0), pt(3.0), pt(1.2), pt(3.0));
            // Near the cone half of the time, anywhere else the rest.
            let c = if rand() < 0.5 {
                let base = [0, 1, 2].map(|k| apex[k] + off[k]);
                axpy(base, rand(), sub(target, apex))
            } else {
                far
            };
            let (reach, r) = (0.2 + 0.8 * rand(), 0.1 + 0.6 * rand());
            let mut brute = false;
            'points: for _ in 0..400 {
                let q = loop {
                    let q = [0, 1, 2].map(|_| 2.0 * rand() - 1.0);
                    if dot(q, q) <= 1.0 {
                        break axpy(target, reach, q);
                    }
                };
                let len = norm(sub(q, apex));
                for k in 0..=400 {
                    let x = axpy(apex, k as f64 / 400.0, sub(q, apex));
                    if norm(sub(x, c)) < r - len / 400.0 {
                        brute = true;
                        break 'points;
                    }
                }
            }
            let cone = meets_cone(apex, target, reach, c, r);
            assert!(cone || !brute, "{apex:?} {target:?} {reach} {c:?} {r}");
            hits += usize::from(brute);
            rejected += usize::from(!cone);
        }
        assert!(
            hits > 20 && rejected > 20,
            "{hits} hits, {rejected} rejected"
        );
    }

    #[test]
    fn shadowers_are_the_dense_gaussians_across_the_paths() {
        let b = |x: f64, y: f64, c: f64| Blob {
            center: [x, y, 0.0],
            a: 2.0,
            c,
            albedo: 1.0,
        };
        // The light at the origin inside 0; 1 integrated at x = 4; 2 across the light's
        // path to it, 3 across the eye's (the eye at (4, −6)), 4 off both, 5 across but
        // too thin to vary by 0.01, 6 across and less dense than 2.
        let blobs = [
            b(0.0, 0.0, 5.0),
            b(4.0, 0.0, 5.0),
            b(2.0, 0.3, 3.0),
            b(4.2, -3.0, 4.0),
            b(-3.0, 4.0, 9.0),
            b(2.5, -0.2, 1e-3),
            b(1.2, 0.1, 1.0),
        ];
        let all: Vec<usize> = (0..blobs.len()).collect();
        let eye = [4.0, -6.0, 0.0];
        let ids = |c: &[usize]| -> Vec<usize> {
            shadowers(&blobs, c, [0.0; 3], eye, 1, &[0])
                .into_iter()
                .map(|(_, j)| j)
                .collect()
        };
        let mut found = ids(&all);
        let ranked = shadowers(&blobs, &all, [0.0; 3], eye, 1, &[0]);
        assert!(ranked.windows(2).all(|w| w[0].0 >= w[1].0), "{ranked:?}");
        found.sort_unstable();
        assert_eq!(found, vec![2, 3, 6]);
        // Only among the candidates given.
        assert_eq!(ids(&[4, 6]), vec![6]);
    }

    /// A wide Gaussian that covers the lit one evenly is right at the centre; a dense one
    /// whose edge crosses it is not. Checked against the depths at the seven points
    /// computed here from the density by Simpson's rule.
    #[test]
    fn shadow_error_sees_edges_not_even_cover() {
        let p = Blob {
            center: [4.0, 0.0, 0.0],
            a: 4.0,
            c: 1.0,
            albedo: 1.0,
        };
        let (s, eye) = ([0.0; 3], [4.0, -6.0, 0.0]);
        let even = Blob {
            center: [2.0, 0.0, 0.0],
            a: 0.3,
            c: 0.3,
            albedo: 1.0,
        };
        let edge = Blob {
            center: [2.0, 0.12, 0.0],
            a: 8.0,
            c: 2.0,
            albedo: 1.0,
        };
        let v_even = shadow_error(&even, &p, s, eye);
        let v_edge = shadow_error(&edge, &p, s, eye);
        assert!(v_even < 3e-3, "{v_even}");
        assert!(v_edge > 0.02 && v_edge > 10.0 * v_even, "{v_edge}");
        // The edge's error by quadrature of its density along the 14 segments.
        let simpson = |b: &Blob, o: Vec3, x: Vec3| -> f64 {
            let u = sub(x, o);
            let f = |t: f64| {
                let dq = sub(axpy(o, t, u), b.center);
                b.c * (-b.a * b.a * dot(dq, dq)).exp()
            };
            crate::simpson(f, 0.0, 1.0, 20_000) * norm(u)
        };
        let r = 1.0 / p.a;
        let mut depths = Vec::new();
        for k in 0..7 {
            let mut x = p.center;
            if k > 0 {
                x[(k - 1) / 2] += if k % 2 == 1 { r } else { -r };
            }
            depths.push(simpson(&edge, s, x) + simpson(&edge, eye, x));
        }
        let want = (depths.iter().map(|d| (depths[0] - d).exp()).sum::<f64>() / 7.0 - 1.0).abs();
        assert!(
            (v_edge - want).abs() < 1e-6 * want.max(1.0),
            "{v_edge} {want}"
        );
    }

    #[test]
    fn bound_flags_inside_and_dense_pairs() {
        let b = |c: f64, a: f64| Blob {
            center: [0.0; 3],
            a,
            c,
            albedo: 1.0,
        };
        // A light inside: unbounded; a faint Gaussian far from the light: the thin law.
        assert!(bound(&b(0.01, 1.0), Source::Point([1.0, 0.0, 0.0])).is_infinite());
        let far = bound(&b(1e-6, 1.0), Source::Point([11.5, 0.0, 0.0]));
        assert!((far - 0.005).abs() < 1e-5, "{far}");
        // Dense: the optical depth alone exceeds a few per cent, for a sun too.
        assert!(bound(&b(1.0, 1.0), Source::Sun([0.0, 0.0, 1.0])) > 0.3);
    }

    #[test]
    fn extremes_stay_finite() {
        let b = Blob {
            center: [0.0; 3],
            a: 2.0,
            c: 50.0,
            albedo: 1.0,
        };
        let v = [-3.0, 0.0, 0.0];
        let dir = [1.0, 0.0, 0.0];
        // The light at the centre, on the ray: d floored at r_min.
        let l = integrated(
            &b,
            v,
            dir,
            6.0,
            Source::Point([0.0; 3]),
            1e-3,
            [0.0; 3],
            &|_| 0.0,
        );
        assert!(l[0].is_finite() && l[0] > 0.0, "{l:?}");
        // The ray misses the support, an empty segment, a segment ending before it.
        let miss = integrated(
            &b,
            [-3.0, 2.0, 0.0],
            dir,
            6.0,
            Source::Sun(dir),
            1e-3,
            [0.0; 3],
            &|_| 0.0,
        );
        assert_eq!(miss, [0.0; 3]);
        assert_eq!(
            integrated(
                &b,
                v,
                dir,
                0.0,
                Source::Point([1.0; 3]),
                1e-3,
                [0.0; 3],
                &|_| 0.0
            ),
            [0.0; 3]
        );
        assert_eq!(
            integrated(
                &b,
                v,
                dir,
                1.0,
                Source::Point([1.0; 3]),
                1e-3,
                [0.0; 3],
                &|_| 0.0
            ),
            [0.0; 3]
        );
        // Infinite segment and a sun: finite.
        let sun = integrated(
            &b,
            v,
            dir,
            f64::INFINITY,
            Source::Sun([0.0, 0.0, 1.0]),
            1e-3,
            [0.1; 3],
            &|_| 0.0,
        );
        assert!(sun[0].is_finite() && sun[0] > 0.0);
    }
}
