//! A renderable wavelet fog: levels of detail with µ, deconstruction, early termination
//! (paper E §4.3–4.4).
//!
//! # Levels and µ
//!
//! With `L` decomposition steps, level 0 is the coarse approximation `α` and level
//! `l = 1 … L` is the layer of details that refines level `l − 1` into level `l` (the
//! details stored on the grid of level `l − 1`). Integrating from the eye `O` towards the
//! point `P` (the surface hit, or where a sky ray leaves the fog), level `l` is integrated
//! only up to `d_max,l = |OP|·µ^l` (eq. 12, with `µ^0 = 1`): `µ = 1` integrates every level
//! over the whole ray (the full fog), `µ = 0` only the coarse approximation.
//!
//! # Two ways to integrate
//!
//! * [`Mode::Direct`] is the paper's Algorithm 1: level 0 integrates `α φφ`, and each
//!   level `l ≥ 1` its three detail bases `φψ, ψφ, ψψ` directly, up to `d_max,l`. A
//!   wavelet is a spline on the *finer* grid (its knots fall at half cells of its own
//!   level), so detail bases are traversed on the grid of level `l`, where each is a
//!   polynomial per cell.
//! * [`Mode::Deconstructed`] first re-synthesizes each level's three detail bases into
//!   scaling functions of the finer level with the two-scale relations (eq. 6 and 8) and
//!   merges them with the approximation, so level `l` becomes the single scaling basis
//!   `A_l = A_{l−1} + details` (the approximation at level `l`; `A_L` is the fogmap). On
//!   the part of the ray `d_max,l+1 < t ≤ d_max,l` exactly the levels `0 … l` are active,
//!   and their sum there is `A_l`; so the ray is cut into bands, band `l` integrates only
//!   `A_l`, bands run from the eye outwards (finest first), and the result equals the
//!   direct integral for every µ. Scaling functions are non-negative, so a band of
//!   non-negative coefficients only adds opacity and the march stops once the
//!   transmittance falls below a threshold ([`Settings::min_transmittance`]).
//!
//! A fogmap is non-negative, and so are Haar approximations (averages). Linear and
//! quadratic approximations can dip below zero near sharp edges (no lossless transform
//! with these synthesis filters has a non-negative analysis, see [`crate::basis`]); since
//! B-splines are non-negative and sum to at most one, `A_l ≥ min(0, min_k A_l[k])`
//! everywhere, and the early exit subtracts that floor times the length still to come,
//! so it never stops before the exact transmittance is below the threshold.

use crate::basis::Basis;
use crate::integrate::{self, Layer, LayerRay, Stop, Term, Vertical};
use crate::mallat::{Decomposition, Grid};
use crate::placement::Placement;
use haze_core::number::shown;
use thiserror::Error;

/// How levels are integrated (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Detail bases integrated as wavelets (paper E Algorithm 1).
    Direct,
    /// Details re-synthesized into one scaling basis per level (paper E §4.4).
    Deconstructed,
}

/// Rendering settings of a fog.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// µ ∈ [0, 1] of eq. 12.
    pub mu: f64,
    /// How levels are integrated.
    pub mode: Mode,
    /// Deconstructed mode stops a ray once its transmittance is certainly below this
    /// (0: never stop early).
    pub min_transmittance: f64,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            mu: 1.0,
            mode: Mode::Deconstructed,
            min_transmittance: 1.0 / 1024.0,
        }
    }
}

/// A fog that cannot be built.
#[derive(Debug, Error, PartialEq)]
pub enum FogError {
    /// The fogmap has no pixels.
    #[error("the fogmap is empty")]
    Empty,
    /// More decomposition steps than the size allows.
    #[error("{levels} levels is more than a {nx} × {ny} fogmap allows (at most {max})")]
    TooManyLevels {
        /// Requested.
        levels: usize,
        /// Fogmap width.
        nx: usize,
        /// Fogmap height.
        ny: usize,
        /// Allowed.
        max: usize,
    },
    /// A placement value is out of range.
    #[error(transparent)]
    Placement(#[from] crate::placement::PlacementError),
    /// A coefficient is NaN or infinite.
    #[error("coefficient ({x}, {y}) is {value}")]
    NotFinite {
        /// Column.
        x: i64,
        /// Row.
        y: i64,
        /// The value.
        value: f64,
    },
    /// µ or the threshold is out of range.
    #[error("{0}")]
    Settings(String),
    /// The optical depth through the fog could overflow.
    #[error(
        "density {} is too large: the optical depth through the fog would overflow (at most {max:e})",
        shown(*density)
    )]
    Overflow {
        /// The density asked for.
        density: f64,
        /// Largest usable density.
        max: f64,
    },
}

/// Most decomposition steps of any fog.
pub const MAX_LEVELS: usize = 16;

/// Most decomposition steps for a `nx × ny` fogmap: until one coarse cell covers it,
/// `⌈log2 max(nx, ny)⌉`, and at most [`MAX_LEVELS`].
pub fn max_levels(nx: usize, ny: usize) -> usize {
    let n = nx.max(ny).max(1);
    ((usize::BITS - (n - 1).leading_zeros()) as usize).min(MAX_LEVELS)
}

/// A fog ready to integrate: placement, levels as traversable layers, settings.
#[derive(Clone, Debug)]
pub struct Fog {
    placement: Placement,
    basis: Basis,
    levels: usize,
    settings: Settings,
    /// One layer per level `0 … L` (module docs).
    layers: Vec<Layer>,
    /// World box of every layer's footprint: x min, x max, y min, y max.
    bounds: [f64; 4],
    /// Fogmap size in pixels.
    size: [usize; 2],
}

impl Fog {
    /// Decomposes `fogmap` (`L = levels` steps) and prepares its layers.
    pub fn new(
        fogmap: &Grid,
        basis: Basis,
        levels: usize,
        placement: Placement,
        settings: Settings,
    ) -> Result<Fog, FogError> {
        if fogmap.nx == 0 || fogmap.ny == 0 {
            return Err(FogError::Empty);
        }
        let max = max_levels(fogmap.nx, fogmap.ny);
        if levels > max {
            return Err(FogError::TooManyLevels {
                levels,
                nx: fogmap.nx,
                ny: fogmap.ny,
                max,
            });
        }
        placement.validate()?;
        if !(0.0..=1.0).contains(&settings.mu) {
            return Err(FogError::Settings(format!(
                "µ = {} must be in [0, 1]",
                shown(settings.mu)
            )));
        }
        if !(0.0..1.0).contains(&settings.min_transmittance) {
            return Err(FogError::Settings(format!(
                "minimum transmittance {} must be in [0, 1)",
                settings.min_transmittance
            )));
        }
        if let Some(i) = fogmap.data.iter().position(|v| !v.is_finite()) {
            return Err(FogError::NotFinite {
                x: fogmap.x0 + (i % fogmap.nx) as i64,
                y: fogmap.y0 + (i / fogmap.nx) as i64,
                value: fogmap.data[i],
            });
        }
        let dec = Decomposition::new(basis, fogmap, levels);
        let approx = dec.deconstruct();
        let scale = |l: usize| f64::from(1u32 << (levels - l));
        let d = basis.degree();
        let layers: Vec<Layer> = match settings.mode {
            Mode::Deconstructed => {
                let phi = basis.scaling();
                approx
                    .iter()
                    .enumerate()
                    .map(|(l, a)| Layer::new(scale(l), d, vec![Term::new(a, &phi, &phi)], a.min()))
                    .collect()
            }
            Mode::Direct => {
                let f = basis.filters();
                let (phi, phi2, psi2) = (basis.scaling(), basis.refined(&f.p), basis.refined(&f.q));
                let mut layers = vec![Layer::new(
                    scale(0),
                    d,
                    vec![Term::new(&dec.approx, &phi, &phi)],
                    dec.approx.min(),
                )];
                for (n, det) in dec.details.iter().enumerate() {
                    let terms = vec![
                        Term::new(&det.phi_psi, &phi2, &psi2),
                        Term::new(&det.psi_phi, &psi2, &phi2),
                        Term::new(&det.psi_psi, &psi2, &psi2),
                    ];
                    // Details are signed: no early exit in this mode, the floor is unused.
                    layers.push(Layer::new(scale(n + 1), d, terms, 0.0));
                }
                layers
            }
        };
        let bounds = world_bounds(&layers, d, &placement);
        // Guard: on the part of a ray where levels 0 … l are active the integrand is A_l
        // (module docs), bounded by max|A_l| (B-splines sum to at most one); each of the
        // L + 1 levels adds at most twice that along a path no longer than the fog box's
        // diagonal. That bound times the density must stay far from overflow.
        let coef_max = approx.iter().map(Grid::max_abs).fold(0.0, f64::max);
        let diagonal = ((bounds[1] - bounds[0]).powi(2)
            + (bounds[3] - bounds[2]).powi(2)
            + (placement.top - placement.bottom).powi(2))
        .sqrt();
        if !diagonal.is_finite() {
            return Err(FogError::Settings(format!(
                "cell size {} makes the fog's box ({} × {} cells) larger than numbers reach",
                shown(placement.cell),
                fogmap.nx,
                fogmap.ny
            )));
        }
        let bound = 2.0 * (levels + 1) as f64 * coef_max * diagonal;
        if bound > 0.0 && placement.density > 1e300 / bound {
            return Err(FogError::Overflow {
                density: placement.density,
                max: 1e300 / bound,
            });
        }
        Ok(Fog {
            placement,
            basis,
            levels,
            settings,
            layers,
            bounds,
            size: [fogmap.nx, fogmap.ny],
        })
    }

    /// The placement.
    pub fn placement(&self) -> &Placement {
        &self.placement
    }

    /// The basis.
    pub fn basis(&self) -> Basis {
        self.basis
    }

    /// Decomposition steps `L`.
    pub fn levels(&self) -> usize {
        self.levels
    }

    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// One layer per level `0 … L`: in [`Mode::Deconstructed`] the scaling basis `A_l`.
    pub fn layers(&self) -> &[Layer] {
        &self.layers
    }

    /// World box `[x min, x max, y min, y max]` of every layer's footprint: where the fog
    /// can be non-zero.
    pub fn bounds(&self) -> [f64; 4] {
        self.bounds
    }

    /// Moves the fog by `by` in world `(x, y)` — wind carrying it along (the fog at time
    /// `t` under a wind `w` is the fog moved by `w·t`) — without recomputing its
    /// transform: the placement's origin and the footprint shift, the levels stay.
    pub fn translate(&mut self, by: [f64; 2]) {
        for (axis, d) in by.into_iter().enumerate() {
            self.placement.origin[axis] += d;
            self.bounds[2 * axis] += d;
            self.bounds[2 * axis + 1] += d;
        }
    }

    /// World box `[x min, x max, y min, y max]` of the fogmap's pixels (whatever the basis
    /// and levels; splines reach up to `d/2` cells beyond it).
    pub fn map_box(&self) -> [f64; 4] {
        let [ox, oy] = self.placement.origin;
        let c = self.placement.cell;
        [
            ox,
            ox + self.size[0] as f64 * c,
            oy,
            oy + self.size[1] as f64 * c,
        ]
    }

    /// Optical depth `∫_O^P K_t` of the segment from `o` to `p` (paper E eq. 2, 11).
    pub fn optical_depth(&self, o: [f64; 3], p: [f64; 3]) -> f64 {
        let v = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if !(len.is_finite() && len > 0.0) {
            return 0.0;
        }
        self.depth(o, v.map(|c| c / len), len)
    }

    /// Optical depth of the ray from `o` along `dir` up to where it leaves the fog (a sky
    /// ray: `P` is that exit point). `dir` need not be normalized; zero gives 0.
    pub fn optical_depth_ray(&self, o: [f64; 3], dir: [f64; 3]) -> f64 {
        let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
        if !(n.is_finite() && n > 0.0) {
            return 0.0;
        }
        let d = dir.map(|c| c / n);
        match self.fog_interval(o, d, f64::INFINITY) {
            Some((_, tb)) => self.depth(o, d, tb),
            None => 0.0,
        }
    }

    /// Where a ray from `o` along unit `d` leaves the fog (0 if it never enters it): the
    /// length `|OP|` of a sky ray ([`Fog::optical_depth_ray`]).
    pub fn exit_distance(&self, o: [f64; 3], d: [f64; 3]) -> f64 {
        self.fog_interval(o, d, f64::INFINITY)
            .map_or(0.0, |(_, tb)| tb)
    }

    /// Optical depth of the part `t ∈ [t0, t1]` of the ray `o + t·d` (`d` unit) whose end
    /// `P` is at `t = len`: the levels' µ bands are those of the whole ray (`|OP|·µ^l`,
    /// eq. 12), so for `0 ≤ s ≤ len` the spans `[0, s]` and `[s, len]` add up to
    /// [`Fog::optical_depth`] of `O, P` (exactly, up to rounding, when no early exit
    /// happens: every level is integrated cell by cell and a cell cut at `s` is two exact
    /// integrals). The early exit applies to the span on its own.
    pub fn optical_depth_span(&self, o: [f64; 3], d: [f64; 3], len: f64, t0: f64, t1: f64) -> f64 {
        if !(len.is_finite() && len > 0.0 && t1 > t0) {
            return 0.0;
        }
        self.depth_span(o, d, len, t0.max(0.0), t1.min(len))
    }

    /// Transmittance `τ = e^{−depth}` of a segment.
    pub fn transmittance(&self, o: [f64; 3], p: [f64; 3]) -> f64 {
        (-self.optical_depth(o, p)).exp()
    }

    /// `[ta, tb] ⊂ [0, len]` where the ray is inside the slab and the fog's box.
    fn fog_interval(&self, o: [f64; 3], d: [f64; 3], len: f64) -> Option<(f64, f64)> {
        let (mut ta, mut tb) = self.placement.clip_slab(o, d, 0.0, len)?;
        for axis in 0..2 {
            let (lo, hi) = (self.bounds[2 * axis], self.bounds[2 * axis + 1]);
            if d[axis] == 0.0 {
                if !(lo..=hi).contains(&o[axis]) {
                    return None;
                }
            } else {
                let (t0, t1) = ((lo - o[axis]) / d[axis], (hi - o[axis]) / d[axis]);
                ta = ta.max(t0.min(t1));
                tb = tb.min(t0.max(t1));
            }
        }
        (tb > ta).then_some((ta, tb))
    }

    /// The ray in the units of level `l`.
    fn layer_ray(&self, l: usize, o: [f64; 3], d: [f64; 3]) -> LayerRay {
        let scale = self.layers[l].scale;
        let [u, v] = self.placement.to_grid(self.basis.degree(), o[0], o[1]);
        let k = 1.0 / (self.placement.cell * scale);
        LayerRay {
            uv0: [u / scale, v / scale],
            duv: [d[0] * k, d[1] * k],
            z0: o[2],
            dz: d[2],
        }
    }

    /// `density · ∫ f h` along `o + t·d`, `t ∈ [0, len]`, `d` unit, `len = |OP|`.
    fn depth(&self, o: [f64; 3], d: [f64; 3], len: f64) -> f64 {
        self.depth_span(o, d, len, 0.0, len)
    }

    /// `density · ∫ f h` along `o + t·d` over `t ∈ [t0, t1] ⊂ [0, len]`, `d` unit, with the
    /// µ bands of `len = |OP|`.
    fn depth_span(&self, o: [f64; 3], d: [f64; 3], len: f64, t0: f64, t1: f64) -> f64 {
        let Some((ta, tb)) = self.fog_interval(o, d, len) else {
            return 0.0;
        };
        let (ta, tb) = (ta.max(t0), tb.min(t1));
        if tb <= ta {
            return 0.0;
        }
        if self.placement.density == 0.0 {
            return 0.0;
        }
        let vert = Vertical {
            falloff: self.placement.falloff,
            bottom: self.placement.bottom,
        };
        let big_l = self.levels;
        // d_max,l = |OP|·µ^l; d_max,0 = |OP|.
        let dmax = |l: usize| {
            if l == 0 {
                len
            } else {
                len * self.settings.mu.powi(l as i32)
            }
        };
        let mut acc = 0.0;
        match self.settings.mode {
            Mode::Direct => {
                for l in 0..=big_l {
                    let b = tb.min(dmax(l));
                    let ray = self.layer_ray(l, o, d);
                    integrate::integrate(&self.layers[l], &ray, vert, ta, b, Stop::NEVER, &mut acc);
                }
            }
            Mode::Deconstructed => {
                let band = |l: usize| -> (f64, f64) {
                    let lo = if l == big_l { 0.0 } else { dmax(l + 1) };
                    (lo.max(ta), dmax(l).min(tb))
                };
                let stop_depth = if self.settings.min_transmittance > 0.0 {
                    -self.settings.min_transmittance.ln() / self.placement.density
                } else {
                    f64::INFINITY
                };
                // Lowest total the bands farther than band l can add: Σ floor × length.
                let mut later = 0.0;
                let mut floors = [0.0; MAX_LEVELS + 1];
                for (l, floor) in floors.iter_mut().enumerate().take(big_l + 1) {
                    *floor = later;
                    let (a, b) = band(l);
                    later += self.layers[l].floor * (b - a).max(0.0);
                }
                for l in (0..=big_l).rev() {
                    let (a, b) = band(l);
                    if b <= a {
                        continue;
                    }
                    let ray = self.layer_ray(l, o, d);
                    let stop = Stop {
                        target: stop_depth - floors[l],
                    };
                    if integrate::integrate(&self.layers[l], &ray, vert, a, b, stop, &mut acc) {
                        break;
                    }
                }
            }
        }
        self.placement.density * acc
    }
}

/// The world box `[x0, x1, y0, y1]` the levels' cells cover (a basis of `degree` centred
/// by half its degree), empty (`+∞, −∞`) when no level has a cell.
fn world_bounds(layers: &[Layer], degree: usize, placement: &Placement) -> [f64; 4] {
    let shift = degree as f64 / 2.0;
    let mut bounds = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for layer in layers {
        let [x0, x1, y0, y1] = layer.cells;
        if x0 >= x1 {
            continue;
        }
        let world = |c: i64, axis: usize| {
            (c as f64 * layer.scale - shift) * placement.cell + placement.origin[axis]
        };
        bounds = [
            bounds[0].min(world(x0, 0)),
            bounds[1].max(world(x1, 0)),
            bounds[2].min(world(y0, 1)),
            bounds[3].max(world(y1, 1)),
        ];
    }
    bounds
}
