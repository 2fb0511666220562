//! `haze tradeoff --extremes`: bakes and renders at the edges of every knob and of the
//! medium on tiny grids and pictures, and reports per case the non-finite pixels of both
//! renderers, the energy (mean radiance of the fast renderer over the reference's) and
//! how the diffusion solve ended. Every case is also a test (`tests/extremes.rs`).

use anyhow::{Result, anyhow};
use haze_bake::residual::as_stored;
use haze_fit::{FitOptions, SequenceFitter, SequenceOptions};
use haze_view::lighting::single::SourcePoints;
use haze_view::reference::{self, RefOptions};
use haze_view::render::{CrmOptions, crm_render};
use haze_view::{Camera, Environment, Image, Medium, Sky, Sun};
use haze_volume::{Bbox, Volume};
use serde_json::{Value, json};
use std::path::Path;

/// The density of a case, on an `n³` grid over `[-1, 1]³`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// A Gaussian puff, `exp(−|x|²/(2·0.35²))`, peak 1.
    Puff,
    /// All zero.
    Empty,
    /// One voxel of density 1 at the centre.
    SingleVoxel,
}

/// The light of a case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// The built-in sky.
    Sky,
    /// The sky plus a directional sun 1° above the horizon, from the side.
    Grazing,
    /// The sky plus a directional sun behind the smoke as the camera sees it.
    BackLit,
}

/// One extreme case.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    pub name: &'static str,
    pub shape: Shape,
    pub n: usize,
    pub sigma_t: f64,
    pub albedo: f64,
    pub g: f64,
    pub light: Light,
    pub rbfs: usize,
    pub sh_order: usize,
    /// Iteration budget of the fit (kept small where the RBFs are many).
    pub fit_iterations: u64,
    /// Where each RBF's transmittance is taken (the centre alone keeps 5000 RBFs' n²
    /// single scattering cheap).
    pub source: SourcePoints,
}

const BASE: Case = Case {
    name: "baseline",
    shape: Shape::Puff,
    n: 12,
    sigma_t: 4.0,
    albedo: 0.8,
    g: 0.3,
    light: Light::Sky,
    rbfs: 20,
    sh_order: 4,
    fit_iterations: 200,
    source: SourcePoints::Footprint,
};

/// Every case: the baseline and one edge of one knob or medium parameter each.
pub fn cases() -> Vec<Case> {
    vec![
        BASE,
        Case {
            name: "sigma_t 1e-6",
            sigma_t: 1e-6,
            ..BASE
        },
        Case {
            name: "sigma_t 1e3",
            sigma_t: 1e3,
            ..BASE
        },
        Case {
            name: "albedo 0",
            albedo: 0.0,
            ..BASE
        },
        Case {
            name: "albedo 1",
            albedo: 1.0,
            ..BASE
        },
        Case {
            name: "g 0.95",
            g: 0.95,
            ..BASE
        },
        Case {
            name: "g -0.95",
            g: -0.95,
            ..BASE
        },
        Case {
            name: "grazing light",
            light: Light::Grazing,
            ..BASE
        },
        Case {
            name: "back-lit",
            light: Light::BackLit,
            ..BASE
        },
        Case {
            name: "empty frame",
            shape: Shape::Empty,
            ..BASE
        },
        Case {
            name: "single voxel",
            shape: Shape::SingleVoxel,
            ..BASE
        },
        Case {
            name: "1 RBF",
            rbfs: 1,
            ..BASE
        },
        Case {
            name: "5000 RBFs",
            rbfs: 5000,
            n: 18,
            fit_iterations: 3,
            sh_order: 2,
            source: SourcePoints::Center,
            ..BASE
        },
        Case {
            name: "SH order 1",
            sh_order: 1,
            ..BASE
        },
        Case {
            name: "SH order max",
            sh_order: haze_view::sh::MAX_ORDER,
            ..BASE
        },
    ]
}

/// What a case measured.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub rbfs: usize,
    pub fit_rel_l2: f64,
    /// Non-finite RBF parameters after the fit.
    pub bad_rbfs: usize,
    /// Non-finite pixel channels of the fast renderer and of the reference.
    pub nan: usize,
    pub inf: usize,
    pub reference_nan: usize,
    pub reference_inf: usize,
    /// Mean radiance of the fast renderer over the reference's.
    pub energy: f64,
    pub cg_iterations: u32,
    pub cg_residual: f64,
    pub converged: bool,
}

impl Outcome {
    pub fn to_json(&self, case: &Case) -> Value {
        json!({
            "case": case.name, "grid": case.n, "sigma_t": case.sigma_t, "albedo": case.albedo,
            "g": case.g, "light": format!("{:?}", case.light), "sh_order": case.sh_order,
            "rbfs_asked": case.rbfs, "rbfs": self.rbfs, "fit_rel_l2": self.fit_rel_l2,
            "bad_rbfs": self.bad_rbfs, "nan": self.nan, "inf": self.inf,
            "reference_nan": self.reference_nan, "reference_inf": self.reference_inf,
            "energy": self.energy, "cg_iterations": self.cg_iterations,
            "cg_residual": self.cg_residual, "converged": self.converged,
        })
    }
}

fn density(case: &Case) -> Result<Volume> {
    let n = case.n;
    let bbox = Bbox::new([-1.0; 3], [1.0; 3]);
    let mut data = vec![0.0f32; n * n * n];
    match case.shape {
        Shape::Empty => {}
        Shape::SingleVoxel => data[(n / 2) * n * n + (n / 2) * n + n / 2] = 1.0,
        Shape::Puff => {
            let c = |i: usize| -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
            for z in 0..n {
                for y in 0..n {
                    for x in 0..n {
                        let r2 = c(x) * c(x) + c(y) * c(y) + c(z) * c(z);
                        data[z * n * n + y * n + x] = (-r2 / (2.0 * 0.35 * 0.35)).exp() as f32;
                    }
                }
            }
        }
    }
    Volume::new([n; 3], bbox, data).map_err(|e| anyhow!("{e}"))
}

fn environment(light: Light) -> Result<Environment> {
    let mut env = Environment::sky(Sky::default());
    let dir = match light {
        Light::Sky => return Ok(env),
        // 1° above the horizon, from +x (the camera looks along +y).
        Light::Grazing => [1.0, 0.0, 1f64.to_radians().tan()],
        // Behind the smoke, slightly above: towards +y.
        Light::BackLit => [0.0, 1.0, 0.1],
    };
    env.suns
        .push(Sun::from_radiance(dir, [3.0, 3.0, 3.0], 0.0).map_err(anyhow::Error::msg)?);
    Ok(env)
}

/// Non-finite channels: (NaN, ±∞).
fn non_finite(img: &Image) -> (usize, usize) {
    let mut out = (0, 0);
    for p in &img.pixels {
        for c in p {
            if c.is_nan() {
                out.0 += 1;
            } else if c.is_infinite() {
                out.1 += 1;
            }
        }
    }
    out
}

fn mean(img: &Image) -> f64 {
    let s: f64 = img
        .pixels
        .iter()
        .flat_map(|p| p.iter())
        .filter(|c| c.is_finite())
        .map(|&c| f64::from(c))
        .sum();
    s / (3 * img.pixels.len()).max(1) as f64
}

/// Bakes (fit + exact residual) and renders `case` with both renderers at 24 × 18.
pub fn run_case(case: &Case) -> Result<Outcome> {
    let d = density(case)?;
    let medium = Medium::new(case.sigma_t, case.albedo, case.g).map_err(anyhow::Error::msg)?;
    let env = environment(case.light)?;
    let opts = SequenceOptions {
        rbfs: case.rbfs,
        fit: FitOptions {
            max_iterations: case.fit_iterations,
            teleport: false,
            ..FitOptions::default()
        },
        ..SequenceOptions::default()
    };
    let fit = SequenceFitter::new(opts)
        .fit(&d)
        .map_err(|e| anyhow!("{}: fit: {e}", case.name))?;
    let bad_rbfs = fit
        .rbfs
        .iter()
        .filter(|r| {
            !(r.center.iter().all(|c| c.is_finite())
                && r.radius.is_finite()
                && r.weight.is_finite())
        })
        .count();
    let rbfs = as_stored(&fit.rbfs)?;
    let (residual, _) = super::smoke::stored_residual(
        &d,
        &rbfs,
        haze_hash::QuantOptions {
            error: 0.0,
            bits: 16,
        },
    )?;
    let camera = Camera::new([0.0, -3.2, 0.4], [0.0; 3], [0.0, 0.0, 1.0], 40.0, 24, 18)
        .map_err(anyhow::Error::msg)?;
    let crm = CrmOptions {
        order: case.sh_order,
        source_points: case.source,
        ..CrmOptions::default()
    };
    let (img, stats) = crm_render(
        &rbfs,
        Some(&residual),
        d.dims(),
        d.bbox(),
        &medium,
        &env,
        &camera,
        &crm,
    );
    let reference = reference::render(
        &d,
        &medium,
        &env,
        &camera,
        &RefOptions {
            spp: 32,
            ..RefOptions::default()
        },
    );
    tracing::info!("{}: fit {:.3} s; {stats}", case.name, fit.fit_seconds);
    let (nan, inf) = non_finite(&img);
    let (reference_nan, reference_inf) = non_finite(&reference);
    let r = mean(&reference);
    Ok(Outcome {
        rbfs: rbfs.len(),
        fit_rel_l2: fit.rel_l2,
        bad_rbfs,
        nan,
        inf,
        reference_nan,
        reference_inf,
        energy: if r > 0.0 { mean(&img) / r } else { f64::NAN },
        cg_iterations: stats.cg_iterations,
        cg_residual: stats.cg_residual,
        converged: stats.cg_residual <= crm.solve.tolerance,
    })
}

/// Runs every case, prints a table and writes `DIR/extremes.json` (`out` exists).
pub fn run(out: &Path) -> Result<()> {
    let all = cases();
    let bar = haze_render::progress::settings_bar();
    bar.set_length(all.len() as u64);
    let mut rows = Vec::new();
    let mut lines = Vec::new();
    for c in &all {
        bar.set_message(c.name);
        let o = run_case(c)?;
        lines.push(format!(
            "{:<14} {:>5} {:>9.4} {:>4} {:>4} {:>4} {:>4} {:>4} {:>8.4} {:>5} {:>9.2e} {}",
            c.name,
            o.rbfs,
            o.fit_rel_l2,
            o.bad_rbfs,
            o.nan,
            o.inf,
            o.reference_nan,
            o.reference_inf,
            o.energy,
            o.cg_iterations,
            o.cg_residual,
            if o.converged { "yes" } else { "no" }
        ));
        rows.push(o.to_json(c));
        bar.inc(1);
    }
    bar.finish_and_clear();
    let path = out.join("extremes.json");
    haze_render::output::write_json(&path, &json!({"cases": rows}))?;
    println!(
        "{:<14} {:>5} {:>9} {:>4} {:>4} {:>4} {:>4} {:>4} {:>8} {:>5} {:>9} converged",
        "case",
        "rbfs",
        "fit rel_l2",
        "bad",
        "nan",
        "inf",
        "rnan",
        "rinf",
        "energy",
        "cg",
        "cg resid"
    );
    for l in lines {
        println!("{l}");
    }
    println!("{}", path.display());
    Ok(())
}
