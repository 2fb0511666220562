//! Lights lit exactly, beside the environment's SH: suns (distant disks) and point lights,
//! the disk-averaged phase function of a sun, and the decomposition of a lat-long map's
//! concentrated light into suns ([`decompose`]).
//!
//! A sun of radiance `L` and apparent (apex) angle `α` covers the solid angle
//! `Ω☉ = 2π(1 − cos(α/2))` and gives the irradiance `E = L·Ω☉` on a surface facing it. Its
//! single-scattering source at a point `x` seen along the viewing direction `d` is
//! `J(x, d) = (Ω/4π)∫_disk L·p(ω·d)·T(x, ω) dω ≈ Ω·E·T(x, s)·p̄(s·d)/4π`: the
//! transmittance taken toward the disk's center `s` (the shadow of a 0.5–8° disk is
//! sharp at voxel scale), the phase function averaged over the disk ([`DiskPhase`], which
//! matters for back light through forward-scattering smoke: HG with `g = 0.9` drops by a
//! third 3° off its peak). A zero-angle sun is a directional light of irradiance `E`.
//!
//! A point light of radiant intensity `I` at `P` gives `E = I/|P − x|²` at `x`; the fast
//! renderer uses `I/(|P − x|² + a²/3)`, `a` half the smallest voxel side, the mean of
//! `1/r²` over a ball of radius `a` about the light, so that a voxel holding the light
//! stays finite.

use crate::distant::Rgb;
use crate::medium::hg;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::sync::{Arc, Mutex};

pub mod decompose;

/// The largest radiance, irradiance or radiant intensity a light may have. Pictures are
/// f32 (largest `3.4·10³⁸`); `10³⁰` leaves eight orders of magnitude for the phase
/// function's peak, the sums over lights and orders, and the exposure, so a light the
/// parser accepts never turns a picture infinite (a sun of radiance `10⁴⁵` did, and was
/// refused only after rendering).
pub const MAX_LIGHT: f64 = 1e30;

/// `Err` naming `what` when a component of `v` is negative, not finite or above
/// [`MAX_LIGHT`].
pub fn check_light(what: &str, v: &Rgb) -> Result<(), String> {
    if let Some(c) = v.iter().find(|c| !(c.is_finite() && **c >= 0.0)) {
        return Err(format!(
            "{what} {} must be finite and non-negative",
            haze_core::number::shown(*c)
        ));
    }
    if let Some(c) = v.iter().find(|c| **c > MAX_LIGHT) {
        return Err(format!(
            "{what} {} is above {} (pictures are f32: brighter lights overflow them)",
            haze_core::number::shown(*c),
            haze_core::number::shown(MAX_LIGHT)
        ));
    }
    Ok(())
}

/// A distant light: a uniformly bright disk in the sky.
#[derive(Clone, Debug, PartialEq)]
pub struct Sun {
    /// Unit direction towards the disk's center.
    pub direction: [f64; 3],
    /// Irradiance on a surface facing the sun, RGB.
    pub irradiance: Rgb,
    /// Apparent (apex) angle of the disk, radians, in `[0, π]`.
    pub angle: f64,
}

/// Solid angle of a cone of apex angle `angle`: `2π(1 − cos(angle/2))`, without
/// cancellation for small angles (`4π sin²(angle/4)`).
pub fn cone_solid_angle(angle: f64) -> f64 {
    4.0 * PI * (angle / 4.0).sin().powi(2)
}

impl Sun {
    /// A sun towards `direction` (any length > 0) of disk radiance `radiance` and apparent
    /// angle `angle_degrees`; a zero angle makes a directional light whose irradiance is
    /// `radiance` itself. Refuses a zero or non-finite direction, negative or non-finite
    /// radiance or radiance above [`MAX_LIGHT`], and angles outside `[0°, 180°]`.
    pub fn from_radiance(
        direction: [f64; 3],
        radiance: Rgb,
        angle_degrees: f64,
    ) -> Result<Sun, String> {
        let dir = unit(direction).ok_or_else(|| {
            format!("sun direction {direction:?} must be a finite, non-zero vector")
        })?;
        check_light("sun radiance", &radiance)?;
        if !(0.0..=180.0).contains(&angle_degrees) {
            return Err(format!(
                "sun angle {}° must be between 0° and 180°",
                haze_core::number::shown(angle_degrees)
            ));
        }
        let angle = angle_degrees.to_radians();
        let omega = if angle > 0.0 {
            cone_solid_angle(angle)
        } else {
            1.0
        };
        Ok(Sun {
            direction: dir,
            irradiance: radiance.map(|c| c * omega),
            angle,
        })
    }

    /// Solid angle of the disk (0 for a directional light).
    pub fn solid_angle(&self) -> f64 {
        cone_solid_angle(self.angle)
    }

    /// Radiance of the disk, `E/Ω☉` (0 for a zero-angle sun: it has no visible disk).
    pub fn radiance(&self) -> Rgb {
        let omega = self.solid_angle();
        if omega > 0.0 {
            self.irradiance.map(|c| c / omega)
        } else {
            [0.0; 3]
        }
    }

    /// True when direction `d` (any length) points into the disk.
    pub fn covers(&self, d: [f64; 3]) -> bool {
        if self.angle <= 0.0 {
            return false;
        }
        let Some(u) = unit(d) else {
            return false;
        };
        dot(u, self.direction) >= (0.5 * self.angle).cos()
    }

    /// A direction drawn uniformly (per solid angle) in the disk from `u1, u2 ∈ [0, 1)`;
    /// the center for a zero-angle sun.
    pub fn sample_direction(&self, u1: f64, u2: f64) -> [f64; 3] {
        if self.angle <= 0.0 {
            return self.direction;
        }
        // cos θ uniform on [cos(α/2), 1]: 1 − cos θ = u1·(1 − cos(α/2)), without
        // cancellation.
        let one_minus = u1 * 2.0 * (0.25 * self.angle).sin().powi(2);
        let cos_t = 1.0 - one_minus;
        let sin_t = (one_minus * (2.0 - one_minus)).max(0.0).sqrt();
        let (t1, t2) = basis(self.direction);
        let phi = 2.0 * PI * u2;
        let (c, s) = (phi.cos(), phi.sin());
        [0, 1, 2].map(|k| cos_t * self.direction[k] + sin_t * (c * t1[k] + s * t2[k]))
    }
}

/// A point light.
#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    pub position: [f64; 3],
    /// Radiant intensity, RGB: irradiance `I/d²` at distance `d`, unoccluded.
    pub intensity: Rgb,
}

impl PointLight {
    /// Refuses non-finite positions and negative, non-finite or above-[`MAX_LIGHT`]
    /// intensity.
    pub fn new(position: [f64; 3], intensity: Rgb) -> Result<PointLight, String> {
        if position.iter().any(|c| !c.is_finite()) {
            return Err(format!("light position {position:?} must be finite"));
        }
        check_light("light intensity", &intensity)?;
        Ok(PointLight {
            position,
            intensity,
        })
    }
}

/// The HG phase function averaged over a sun's disk, `p̄(cos θc)`, `θc` the angle between
/// the disk's center and the viewing direction: a table over `θc ∈ [0, π]`, linear
/// between entries. Exact HG for a zero-angle sun.
#[derive(Clone, Debug, PartialEq)]
pub struct DiskPhase {
    g: f64,
    /// `p̄` at `θc = k·π/(n − 1)`; empty for a zero-angle sun.
    table: Vec<f64>,
}

/// Entries of a [`DiskPhase`] table: the step `π/511` is 0.35°, a tenth of the width of
/// HG's forward peak at `g = 0.95` (`≈ (1 − g)` rad).
pub const DISK_PHASE_ENTRIES: usize = 512;

/// Tables [`DiskPhase::shared`] keeps, the most recently asked for last.
const KEPT_TABLES: usize = 16;

/// The tables built so far by [`DiskPhase::shared`], keyed by `(g, angle)`'s bits.
static TABLES: Mutex<Vec<(u64, u64, Arc<DiskPhase>)>> = Mutex::new(Vec::new());

impl DiskPhase {
    /// The table of HG(`g`) averaged over a disk of apex angle `angle` (radians), by a
    /// product rule over the disk: Gauss–Legendre in `1 − cos θ` (uniform per solid
    /// angle) × the trapezoid rule in azimuth (periodic, so spectrally accurate).
    pub fn new(g: f64, angle: f64) -> DiskPhase {
        if angle <= 0.0 {
            return DiskPhase {
                g,
                table: Vec::new(),
            };
        }
        let (nodes, weights) = gauss_legendre_01(24);
        let azimuths = 96;
        let h = 2.0 * (0.25 * angle).sin().powi(2); // 1 − cos(α/2)
        let n = DISK_PHASE_ENTRIES;
        let table = (0..n)
            .into_par_iter()
            .map(|k| {
                let tc = PI * k as f64 / (n - 1) as f64;
                // Disk about +Z; viewing direction at polar angle tc in the XZ plane.
                let (st, ct) = tc.sin_cos();
                let mut sum = 0.0;
                for (x, w) in nodes.iter().zip(&weights) {
                    let one_minus = x * h;
                    let cz = 1.0 - one_minus;
                    let sz = (one_minus * (2.0 - one_minus)).max(0.0).sqrt();
                    let mut ring = 0.0;
                    for j in 0..azimuths {
                        let phi = 2.0 * PI * (j as f64 + 0.5) / azimuths as f64;
                        ring += hg(g, sz * phi.cos() * st + cz * ct);
                    }
                    sum += w * ring / azimuths as f64;
                }
                sum
            })
            .collect();
        DiskPhase { g, table }
    }

    /// [`DiskPhase::new`], built once per `(g, angle)` while it is among the last
    /// [`KEPT_TABLES`] asked for: a table is ~1.2 million phase evaluations, and a frame
    /// asks for each sun's several times (the lights pass, the orders' first source, the
    /// GPU's shadow volume at `g = 0` beside its lights pass), so playback and camera
    /// moves would otherwise build them again every picture.
    pub fn shared(g: f64, angle: f64) -> Arc<DiskPhase> {
        let key = (g.to_bits(), angle.to_bits());
        let mut kept = TABLES
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some(i) = kept.iter().position(|(a, b, _)| (*a, *b) == key) {
            let entry = kept.remove(i);
            let table = Arc::clone(&entry.2);
            kept.push(entry);
            return table;
        }
        // Built under the lock: two threads asking for the same table build it once.
        let table = Arc::new(DiskPhase::new(g, angle));
        if kept.len() >= KEPT_TABLES {
            kept.remove(0);
        }
        kept.push((key.0, key.1, Arc::clone(&table)));
        table
    }

    /// `p̄` for `cos θc` (clamped to [−1, 1]).
    pub fn eval(&self, cos_c: f64) -> f64 {
        if self.table.is_empty() {
            return hg(self.g, cos_c);
        }
        let n = self.table.len();
        let f = cos_c.clamp(-1.0, 1.0).acos() / PI * (n - 1) as f64;
        let i = (f.floor() as usize).min(n - 2);
        let t = f - i as f64;
        self.table[i] * (1.0 - t) + self.table[i + 1] * t
    }

    /// The table (empty for a zero-angle sun), for GPU upload.
    pub fn table(&self) -> &[f64] {
        &self.table
    }
}

/// Gauss–Legendre nodes and weights on `[0, 1]` (Newton on the Legendre recurrence).
fn gauss_legendre_01(n: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut w) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-15 {
                break;
            }
        }
        x.push(0.5 * (1.0 - z));
        w.push(1.0 / ((1.0 - z * z) * dp * dp));
    }
    (x, w)
}

/// `a·b`.
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `v/|v|`, or `None` for a zero or non-finite vector.
pub(crate) fn unit(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(v, v).sqrt();
    (n > 0.0 && n.is_finite()).then(|| v.map(|c| c / n))
}

/// Two unit vectors completing the unit `d` to an orthonormal basis (Duff et al. 2017).
pub(crate) fn basis(d: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let sign = 1.0f64.copysign(d[2]);
    let a = -1.0 / (sign + d[2]);
    let b = d[0] * d[1] * a;
    (
        [1.0 + sign * d[0] * d[0] * a, sign * b, -sign * d[0]],
        [b, sign + d[1] * d[1] * a, -d[1]],
    )
}

#[cfg(test)]
mod tests;
