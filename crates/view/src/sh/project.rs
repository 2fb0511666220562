//! Projection of spherical functions onto the SH basis, `f_i = ∫ f(ω)·Y_i(ω) dω`.

use std::f64::consts::PI;

use rayon::prelude::*;

use super::basis::{band_of, count, eval_into};
use super::quad::{SphereGrid, gauss_legendre};
use crate::distant::{Distant, LatLong, Sky, direction};
use crate::env::Environment;

/// Projection of `f` by `n_theta` Gauss–Legendre latitudes (in `cos θ`) × `n_phi`
/// uniform azimuths: exact for products `f·Y_i` that are polynomials of degree
/// `≤ min(2·n_theta − 1, n_phi − 1)` (see `quad`), accurate for smooth `f` otherwise.
pub fn project_fn(
    order: usize,
    f: impl Fn([f64; 3]) -> f64,
    n_theta: usize,
    n_phi: usize,
) -> Vec<f64> {
    project_on(&SphereGrid::new(n_theta, n_phi), order, |d| {
        [f(d), 0.0, 0.0]
    })[0]
        .clone()
}

fn project_on(grid: &SphereGrid, order: usize, f: impl Fn([f64; 3]) -> [f64; 3]) -> [Vec<f64>; 3] {
    let n = count(order);
    let mut out = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let mut y = vec![0.0; n];
    for (d, w) in grid.points() {
        eval_into(order, d, &mut y);
        let v = f(d);
        for (o, v) in out.iter_mut().zip(v) {
            for (o, y) in o.iter_mut().zip(&y) {
                *o += w * v * y;
            }
        }
    }
    out
}

/// RGB projection of an environment.
///
/// A [`LatLong`] map is projected as the piecewise-constant function of its texels,
/// exactly: `∫_texel Y_lm dω` separates into a polar integral (composite Gauss–Legendre
/// in θ, 8 nodes on panels of at most π/32 — the integrand is a trigonometric polynomial
/// of degree ≤ l + 1, so this is exact to rounding) and a closed-form azimuthal integral
/// of `cos(mφ)` / `sin(|m|φ)`. The texel solid angles `LatLong::texel_direction` reports
/// are the `l = 0` case. (The map's bilinear lookup differs from this within a texel.)
///
/// The [`Sky`] is projected with 48 Gauss–Legendre latitudes per hemisphere (split at
/// the horizon, where the sky jumps to the ground colour) × 128 azimuths: exact for
/// every band-limited part to degree 95, and the sun glow `max(0, ω·s)^k` is `C^{k−1}`.
pub fn project_env(env: &Environment, order: usize) -> [Vec<f64>; 3] {
    match &env.distant {
        Distant::Map(m) => project_latlong(m, order),
        Distant::Sky(s) => project_sky(s, order),
    }
}

fn project_sky(sky: &Sky, order: usize) -> [Vec<f64>; 3] {
    project_on(&SphereGrid::hemispheres(48, 128), order, |d| {
        sky.radiance(d)
    })
}

fn project_latlong(map: &LatLong, order: usize) -> [Vec<f64>; 3] {
    let n = count(order);
    let (w, h) = (map.width, map.height);
    // Azimuthal integrals per column: for band index i with m, ∫ cos(mφ) or sin(|m|φ).
    let dphi = 2.0 * PI / w as f64;
    let azimuth: Vec<Vec<f64>> = (0..w)
        .map(|x| {
            let (p0, p1) = (dphi * x as f64, dphi * (x as f64 + 1.0));
            (0..n)
                .map(|i| {
                    let l = band_of(i) as i64;
                    let m = i as i64 - l * (l + 1);
                    let mf = m.abs() as f64;
                    match m.signum() {
                        0 => p1 - p0,
                        1 => ((mf * p1).sin() - (mf * p0).sin()) / mf,
                        _ => ((mf * p0).cos() - (mf * p1).cos()) / mf,
                    }
                })
                .collect()
        })
        .collect();
    let rule = gauss_legendre(8);
    let panels = (32 / h).max(1);
    let rows: Vec<[Vec<f64>; 3]> = (0..h)
        .into_par_iter()
        .map(|row| {
            let (t0, t1) = (
                PI * row as f64 / h as f64,
                PI * (row as f64 + 1.0) / h as f64,
            );
            // Polar integrals ∫ P_l|m|(θ) sin θ dθ, where P_l|m|(θ) = Y_l|m|(θ, φ = 0).
            let mut at_phi0 = vec![0.0; n];
            let mut polar_pos = vec![0.0; n];
            let dt = (t1 - t0) / panels as f64;
            for p in 0..panels {
                let mid = t0 + (p as f64 + 0.5) * dt;
                for &(x, wt) in &rule {
                    let t = mid + 0.5 * dt * x;
                    eval_into(order, direction(t, 0.0), &mut at_phi0);
                    for (acc, y) in polar_pos.iter_mut().zip(&at_phi0) {
                        *acc += 0.5 * dt * wt * t.sin() * y;
                    }
                }
            }
            let polar: Vec<f64> = (0..n)
                .map(|i| {
                    let l = band_of(i);
                    let m = (i as i64 - (l * (l + 1)) as i64).unsigned_abs() as usize;
                    polar_pos[l * (l + 1) + m]
                })
                .collect();
            let mut acc = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
            for (x, az) in azimuth.iter().enumerate() {
                let t = map.texels[row * w + x];
                for (c, acc) in acc.iter_mut().enumerate() {
                    let v = f64::from(t[c]);
                    for i in 0..n {
                        acc[i] += v * polar[i] * az[i];
                    }
                }
            }
            acc
        })
        .collect();
    let mut out = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    for r in rows {
        for (o, r) in out.iter_mut().zip(r) {
            for (o, r) in o.iter_mut().zip(r) {
                *o += r;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::basis::reconstruct;

    #[test]
    fn constant_maps_project_to_band_0_only() {
        let c = [0.5, 1.0, 2.0];
        // Both the one-texel map of `Environment::constant` and a real-sized one.
        let big = LatLong::new(64, 32, vec![[0.5, 1.0, 2.0]; 64 * 32]).unwrap();
        for env in [Environment::constant(c), Environment::map(big)] {
            let p = project_env(&env, 6);
            for ch in 0..3 {
                // Exact texel integrals: only rounding of a few hundred sums remains.
                assert!(
                    (p[ch][0] - c[ch] * (4.0 * PI).sqrt()).abs() < 1e-12,
                    "{:?}",
                    p[ch]
                );
                assert!(p[ch][1..].iter().all(|v| v.abs() < 1e-12), "{:?}", p[ch]);
            }
        }
    }

    #[test]
    fn latlong_projection_matches_texel_solid_angles_and_fine_sampling() {
        // A smooth map: 2 + x + y·z at texel centers. Its band-0 coefficient must be
        // Σ L·Ω_texel / √(4π) with the solid angles of `texel_direction`, and its
        // reconstruction must follow the map (piecewise constant: error ~ a texel).
        let (w, h) = (128, 64);
        let f = |d: [f64; 3]| 2.0 + d[0] + d[1] * d[2];
        let mut texels = Vec::new();
        let mut band0 = 0.0;
        let probe = LatLong::new(w, h, vec![[0.0; 3]; w * h]).unwrap();
        for y in 0..h {
            for x in 0..w {
                let (d, solid) = probe.texel_direction(x, y);
                texels.push([f(d) as f32; 3]);
                band0 += f64::from(f(d) as f32) * solid / (4.0 * PI).sqrt();
            }
        }
        let p = project_env(&Environment::map(LatLong::new(w, h, texels).unwrap()), 3);
        assert!((p[0][0] - band0).abs() < 1e-9, "{} vs {band0}", p[0][0]);
        for d in [[0.3, 0.5, 0.81], [-1.0, 0.0, 0.0], [0.2, -0.7, -0.68]] {
            let n: f64 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let d = d.map(|v| v / n.sqrt());
            // Texels of π/64 rad: a first-order error in f of about 2e-2, and f is
            // exactly band-limited to order 3.
            assert!((reconstruct(&p[1], d) - f(d)).abs() < 2e-2, "{d:?}");
        }
    }

    #[test]
    fn default_sky_reconstructs_at_order_6_and_order_1_is_its_mean() {
        let sky = Sky::default();
        let env = Environment::sky(sky.clone());
        // Independent reference: midpoint rule in (θ, φ), 400 × 800 cells.
        let (nt, np) = (400, 800);
        let mut mean = [0.0; 3];
        let mut cells = Vec::new();
        for i in 0..nt {
            for j in 0..np {
                let t = PI * (i as f64 + 0.5) / nt as f64;
                let d = direction(t, 2.0 * PI * (j as f64 + 0.5) / np as f64);
                let solid = t.sin() * (PI / nt as f64) * (2.0 * PI / np as f64);
                let r = sky.radiance(d);
                for c in 0..3 {
                    mean[c] += r[c] * solid / (4.0 * PI);
                }
                cells.push((d, solid, r));
            }
        }
        let p1 = project_env(&env, 1);
        for c in 0..3 {
            let v = reconstruct(&p1[c], [0.0, 0.0, 1.0]);
            // Midpoint error of the reference ~ (π/400)² relative.
            assert!(
                (v - mean[c]).abs() < 1e-4 * mean[c],
                "{c}: {v} vs {}",
                mean[c]
            );
        }
        let p6 = project_env(&env, 6);
        for c in 0..3 {
            let (mut err, mut norm) = (0.0, 0.0);
            let mut far_max = 0.0f64;
            for (d, solid, r) in &cells {
                let e = reconstruct(&p6[c], *d) - r[c];
                err += e * e * solid;
                norm += r[c] * r[c] * solid;
                if d[2].abs() > 0.5 {
                    far_max = far_max.max(e.abs() / r[c]);
                }
            }
            let rel = (err / norm).sqrt();
            // The projection is the best L2 approximation, so its squared error is
            // ‖L‖² − Σc² (Parseval): a check of every coefficient at once, to the
            // reference's midpoint accuracy.
            let parseval = norm - p6[c].iter().map(|v| v * v).sum::<f64>();
            assert!(
                (err - parseval).abs() < 1e-4 * norm,
                "channel {c}: {err} vs {parseval}"
            );
            // The sky jumps by up to 0.55 at the horizon and the sun glow (4·cos⁸, about
            // 0.35 rad wide) is sharper than band 5: order 6 leaves a relative L2 error
            // of 12.8–13.6 % per channel (measured), and up to 59 % of the local radiance
            // pointwise away from the horizon (|z| > 0.5), next to the sun.
            assert!(rel < 0.15, "channel {c}: relative L2 error {rel}");
            assert!(far_max < 0.65, "channel {c}: {far_max}");
        }
    }

    #[test]
    fn project_fn_recovers_band_limited_functions() {
        let coeffs: Vec<f64> = (0..25).map(|i| ((i * 7 % 11) as f64 - 5.0) / 5.0).collect();
        // f·Y has degree ≤ 8: 5 latitudes × 9 azimuths are exact.
        let p = project_fn(5, |d| reconstruct(&coeffs, d), 5, 9);
        for (a, b) in p.iter().zip(&coeffs) {
            assert!((a - b).abs() < 1e-13, "{a} vs {b}");
        }
    }
}
