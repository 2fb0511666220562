//! The trade-off sweeper (`haze tradeoff`): the speed/accuracy curve of every knob on the
//! user's own data. Each setting is baked and rendered through the code paths of `haze
//! bake`/`haze render` (smoke) or `haze fog wavelet` (fogmaps) and timed; its error is the
//! rel RMS, `sqrt(Σ|a − b|² / Σ|b|²)` over the pixels' RGB, of its picture against the
//! most accurate setting's. Writes
//! `tradeoff.json` (every setting and the Pareto front of render time against error) and
//! plots; `haze render --budget-ms/--target-error` choose from it (`choice`,
//! `render_choice`).

pub mod choice;
pub mod extremes;
pub mod fog;
pub mod knobs;
pub mod lab;
pub mod pareto;
pub mod plot;
pub mod render_choice;
pub mod smoke;
pub mod sweep;

use anyhow::{Result, anyhow, bail};
use knobs::Knob;
use lab::Lab;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use sweep::{Plan, Sweep, describe_short, run_sweep};

/// The input kind: fogmaps are images (`.png`, `.exr`) or forced by `--fogmap`.
pub fn is_fogmap(input: &Path, forced: bool) -> bool {
    forced
        || input
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("png") || e.eq_ignore_ascii_case("exr"))
}

/// Everything `haze tradeoff` was asked.
#[derive(Debug)]
pub struct TradeoffArgs {
    pub input: PathBuf,
    pub frame: Option<i64>,
    pub out: PathBuf,
    pub reference: bool,
    pub spp: u32,
    /// Pixels of the best setting's check against the reference (0: none).
    pub check: usize,
    pub knobs: Option<Vec<String>>,
    pub quick: bool,
    pub fogmap: bool,
    pub extremes: bool,
    pub smoke: SmokeInput,
    pub fog_model: haze_render::fog::FogModel,
}

/// A smoke sweep's scene: the light, the medium, the camera and the import options.
#[derive(Debug, Clone)]
pub struct SmokeInput {
    pub lights: haze_render::lights::Lights,
    pub sigma_t: f64,
    pub albedo: f64,
    pub g: f64,
    pub view: smoke::View,
    pub import: haze_volume::ImportOptions,
    /// The renderer the sweep times.
    pub timing: smoke::Timing,
}

impl SmokeInput {
    /// The scene as `tradeoff.json` records it (`medium`): σt, albedo, g and the light
    /// in words.
    pub fn medium_json(&self) -> Value {
        json!({
            "sigma_t": self.sigma_t,
            "albedo": self.albedo,
            "g": self.g,
            "light": self.lights.describe(),
        })
    }
}

/// Every knob a sweep of `kind` knows, for `--knobs`' message.
fn check_knob_names(knobs: &[Knob], only: &[String]) -> Result<()> {
    for n in only {
        if !knobs.iter().any(|k| k.name == n) {
            let names: Vec<&str> = knobs.iter().map(|k| k.name).collect();
            bail!("--knobs: no knob '{n}' here (knobs: {})", names.join(", "));
        }
    }
    Ok(())
}

/// Opens the smoke lab of `input` (a volume, a sequence's frame or an asset's frame).
pub fn smoke_lab(
    input: &Path,
    frame: Option<i64>,
    s: &SmokeInput,
    quick: bool,
) -> Result<smoke::SmokeLab> {
    let medium = haze_view::Medium::new(s.sigma_t, s.albedo, s.g).map_err(|e| anyhow!("{e}"))?;
    let env = s.lights.environment()?;
    let density = haze_render::frame::load_density(input, frame, &s.import)?;
    let mut lab = smoke::SmokeLab::new(
        density,
        env,
        medium,
        s.view,
        quick,
        if quick { 1 } else { 2 },
    );
    lab.set_timing(s.timing)?;
    Ok(lab)
}

/// The renderer a sweep's times are of, in words.
pub fn timing_name(adapter: Option<String>) -> String {
    match adapter {
        Some(a) => format!("GPU: {a}"),
        None => "CPU".to_string(),
    }
}

/// A quick sweep of `input`'s smoke (`--quick`, with a progress bar) for a choice made
/// on the spot, as `tradeoff.json` would hold it; `only` restricts it to those knobs. An
/// asset is rendered with its own RBFs (the ones the render will use), not refitted.
pub fn quick_sweep(
    input: &Path,
    frame: Option<i64>,
    s: &SmokeInput,
    only: Option<&[&str]>,
) -> Result<Value> {
    let mut lab = smoke_lab(input, frame, s, true)?;
    if input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("haze"))
    {
        lab.use_rbfs(haze_render::frame::load_asset(input, frame)?.rbfs);
    }
    if let Some(only) = only {
        lab.restrict(&only.iter().map(|n| n.to_string()).collect::<Vec<_>>());
    }
    let bar = haze_render::progress::settings_bar();
    let sweep = run_sweep(&mut lab, smoke_plan(true), Vec::new(), None, &bar)?;
    let timing = timing_name(lab.adapter());
    Ok(sweep.to_json(input, frame, s.medium_json(), &timing))
}

/// The plan of a smoke sweep.
pub fn smoke_plan(quick: bool) -> Plan {
    Plan {
        cheaper_steps: if quick { 3 } else { 10 },
        accurate_steps: if quick { 1 } else { 4 },
        factorial: None,
    }
}

/// Before any work: `--out` is a directory (or will be made one), and none of the files
/// the sweep writes there is its input.
fn check_out_dir(a: &TradeoffArgs) -> Result<()> {
    if a.out.exists() && !a.out.is_dir() {
        bail!(
            "{}: --out is a file; the sweep writes a directory of files",
            a.out.display()
        );
    }
    if !a.out.is_dir() {
        // A directory still to be made holds no input.
        return Ok(());
    }
    if !a.extremes && a.input.is_dir() && haze_render::output::same_file(&a.input, &a.out) {
        bail!(
            "{}: --out is the input's directory of frames; the sweep's files would mix with them (choose another --out)",
            a.out.display()
        );
    }
    let names = ["tradeoff.json", "pareto.svg", "pareto.png", "extremes.json"];
    let mut files = haze_render::output::Outputs::new();
    if !a.extremes {
        files = files.input(&a.input);
    }
    names
        .iter()
        .fold(files, |f, n| f.output("--out", &a.out.join(n)))
        .check()
}

/// Runs the sweep; `--out` is made if missing, and removed again if the run fails.
pub fn run(a: TradeoffArgs) -> Result<()> {
    check_out_dir(&a)?;
    if !a.extremes && a.frame.is_some() && is_fogmap(&a.input, a.fogmap) {
        bail!(
            "{}: --frame picks a frame of smoke; a fogmap is one picture (leave --frame out)",
            a.input.display()
        );
    }
    let mut created = haze_render::output::Created::new();
    created.dir("--out", &a.out)?;
    if a.extremes {
        extremes::run(&a.out)?;
    } else {
        sweep_and_write(&a)?;
    }
    created.keep();
    Ok(())
}

fn sweep_and_write(a: &TradeoffArgs) -> Result<()> {
    let fog = is_fogmap(&a.input, a.fogmap);
    let bar = haze_render::progress::settings_bar();
    let (sweep, medium, timing) = if fog {
        let mut lab = fog::FogLab::open(
            &a.input,
            a.fog_model.clone(),
            a.smoke.view.width,
            a.smoke.view.height,
            a.quick,
            if a.quick { 1 } else { 2 },
        )?;
        if let Some(only) = &a.knobs {
            check_knob_names(lab.knobs(), only)?;
            lab.restrict(only);
        }
        let list = lab.factorial();
        let plan = Plan {
            cheaper_steps: 0,
            accurate_steps: 0,
            factorial: Some(list.len()),
        };
        let sweep = run_sweep(&mut lab, plan, list, a.reference.then_some(0), &bar)?;
        (
            sweep,
            json!({"density": a.fog_model.density, "falloff": a.fog_model.falloff}),
            "CPU".to_string(),
        )
    } else {
        let mut lab = smoke_lab(&a.input, a.frame, &a.smoke, a.quick)?;
        if let Some(only) = &a.knobs {
            check_knob_names(lab.knobs(), only)?;
            lab.restrict(only);
        }
        let mut sweep = run_sweep(
            &mut lab,
            smoke_plan(a.quick),
            Vec::new(),
            a.reference.then_some(a.spp),
            &bar,
        )?;
        if !a.reference && a.check > 0 {
            let spinner = haze_render::progress::spinner(&format!(
                "checking the best setting's {} pixels against the reference",
                a.check
            ));
            sweep.check_best(&mut lab, a.check);
            spinner.finish_and_clear();
        }
        let timing = timing_name(lab.adapter());
        (sweep, a.smoke.medium_json(), timing)
    };
    let doc = sweep.to_json(&a.input, a.frame, medium, &timing);
    let path = a.out.join("tradeoff.json");
    haze_render::output::write_json(&path, &doc)?;
    let plots = plot::write_all(&a.out, &sweep)?;
    print_summary(&sweep, &path, plots, &timing);
    Ok(())
}

fn print_summary(sweep: &Sweep, path: &Path, plots: usize, timing: &str) {
    let default = knobs::defaults(&sweep.knobs);
    println!(
        "{}: {} settings measured at {} × {} ({timing}), {} on the front (render ms, error against the best setting):",
        path.display(),
        sweep.measured.len(),
        sweep.size[0],
        sweep.size[1],
        sweep.front.len()
    );
    if let Some(e) = &sweep.best_check {
        println!("  the best setting against the reference: {e}");
    }
    for &i in &sweep.front {
        let m = &sweep.measured[i];
        println!(
            "  {:>9.1} ms  {:>7.3} %  {}",
            m.sample.render_ms,
            100.0 * m.error,
            describe_short(&sweep.knobs, &m.setting, &default)
        );
    }
    for (s, why) in &sweep.skipped {
        println!(
            "  not measured: {} ({why})",
            describe_short(&sweep.knobs, s, &default)
        );
    }
    println!(
        "{plots} plots (SVG and PNG) in {}",
        path.parent()
            .map_or_else(String::new, |p| p.display().to_string())
    );
}
