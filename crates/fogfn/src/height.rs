//! Height falloff (the common exponential fog; paper D cites it, refs 3 and 8):
//! `γ(x) = exp(−b (n·x − h₀))`, `n` the unit "up" of the layer, `b` its falloff (per world
//! unit), `h₀` its base.
//!
//! **Integral.** With `s₀ = n·o − h₀` and `x = b (n·w) L`:
//! `∫₀^L γ = L e^{−b s₀} E(x)`, `E(x) = (1 − e^{−x})/x` (`E(0) = 1`: a horizontal ray).
//! Evaluated as `L·exp(−b s₀ + ln E(x))`, `ln E` by `expm1` — `ln(−expm1(−x)) − ln x` for
//! `x > 0`, `−x + ln(−expm1(x)) − ln(−x)` for `x < 0` — so that neither a ray far above
//! the layer (`e^{−b s₀}` underflowing) nor a long ray down into it (`E` overflowing)
//! makes `0·∞`.

use crate::vec3::{Vec3, dot};

#[derive(Clone, Debug, PartialEq)]
pub struct Height {
    /// Unit normal of the layers.
    pub normal: Vec3,
    pub base: f64,
    pub falloff: f64,
}

/// `ln((1 − e^{−x})/x)`, 0 at 0.
pub fn ln_e(x: f64) -> f64 {
    if x > 0.0 {
        (-(-x).exp_m1()).ln() - x.ln()
    } else if x < 0.0 {
        -x + (-x.exp_m1()).ln() - (-x).ln()
    } else {
        0.0
    }
}

impl Height {
    pub fn value(&self, x: Vec3) -> f64 {
        (-self.falloff * (dot(self.normal, x) - self.base)).exp()
    }

    /// `∫₀^len γ(o + s w) ds` (module docs).
    pub fn integral(&self, o: Vec3, w: Vec3, len: f64) -> f64 {
        if len <= 0.0 {
            return 0.0;
        }
        let s0 = dot(self.normal, o) - self.base;
        let x = self.falloff * dot(self.normal, w) * len;
        len * (-self.falloff * s0 + ln_e(x)).exp()
    }
}
