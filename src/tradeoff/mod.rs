//! `haze tradeoff`: the speed/accuracy curve of every knob on the user's own data. Each
//! setting is baked and rendered through the code paths of `haze bake`/`haze render`
//! (smoke) or `haze fog wavelet` (fogmaps) and timed; its error is the rel RMS
//! (docs/conventions.md "Errors") of its picture against the most accurate setting's. Writes
//! `tradeoff.json` (every setting and the Pareto front of render time against error) and
//! plots; `haze render --budget-ms/--target-error` choose from it (`choice`).

pub mod choice;
pub mod extremes;
pub mod fog;
pub mod knobs;
pub mod pareto;
pub mod plot;
pub mod smoke;

use anyhow::{Context, Result, anyhow, bail};
use haze_view::Image;
use knobs::{Effect, Knob, Setting};
use serde_json::{Map, Value, json};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What one setting measured.
#[derive(Debug)]
pub struct Sample {
    /// The picture (its size may be a fraction of the full one: the `size` knob).
    pub image: Image,
    /// Render milliseconds, the time the front is drawn over.
    pub render_ms: f64,
    /// Milliseconds of every stage measured (`bake`, `render` and their parts).
    pub ms: Value,
    /// What else the stages reported (fit error, CG iterations).
    pub detail: Value,
}

/// A sweepable model of the input: its knobs and how to measure a setting of them.
pub trait Lab {
    /// `smoke` or `fogmap`.
    fn kind(&self) -> &'static str;
    fn knobs(&self) -> &[Knob];
    /// Bakes and renders setting `s` (knob indices).
    fn measure(&mut self, s: &[usize]) -> Result<Sample>;
    /// The independent reference picture at the full size (`--reference`).
    fn reference(&mut self, spp: u32) -> Result<Image>;
    /// The setting that renders `s`: `s` itself, or the nearest one the renderer can run
    /// (two knob values that cannot go together are mapped as the command line maps
    /// them), or `Err` saying why `s` cannot run.
    fn runnable(&self, s: &[usize]) -> std::result::Result<Setting, String> {
        Ok(s.to_vec())
    }
}

/// Keeps only the knobs named in `only` (the others keep their default value alone).
pub fn restrict(knobs: &mut [Knob], only: &[String]) {
    for k in knobs.iter_mut() {
        if !only.iter().any(|n| n == k.name) {
            k.values = vec![k.values[k.default].clone()];
            k.default = 0;
            k.best = 0;
        }
    }
}

/// `img` resampled bilinearly to `w × h` (pixel centres mapped onto pixel centres), so
/// that a picture rendered smaller is compared with the full-size one as a user would
/// see it scaled up.
pub fn resample(img: &Image, w: usize, h: usize) -> Image {
    if (img.width, img.height) == (w, h) {
        return img.clone();
    }
    let mut out = Image::new(w, h);
    let coord = |i: usize, n_out: usize, n_in: usize| -> (usize, usize, f32) {
        let x = ((i as f64 + 0.5) * n_in as f64 / n_out as f64 - 0.5).clamp(0.0, (n_in - 1) as f64);
        let x0 = x.floor() as usize;
        let x1 = (x0 + 1).min(n_in - 1);
        (x0, x1, (x - x0 as f64) as f32)
    };
    for y in 0..h {
        let (y0, y1, fy) = coord(y, h, img.height);
        for x in 0..w {
            let (x0, x1, fx) = coord(x, w, img.width);
            let p = |xx: usize, yy: usize| img.pixels[yy * img.width + xx];
            let (a, b, c, d) = (p(x0, y0), p(x1, y0), p(x0, y1), p(x1, y1));
            let mut v = [0.0f32; 3];
            for ch in 0..3 {
                let top = a[ch] + fx * (b[ch] - a[ch]);
                let bot = c[ch] + fx * (d[ch] - c[ch]);
                v[ch] = top + fy * (bot - top);
            }
            out.pixels[y * w + x] = v;
        }
    }
    out
}

/// How a setting came to be measured.
#[derive(Clone, Debug, PartialEq)]
pub enum Why {
    Best,
    Default,
    /// One knob changed from the defaults (its index).
    OneKnob(usize),
    /// A greedy chain towards cheaper or more accurate settings.
    Chain {
        cheaper: bool,
    },
    /// One combination of a full factorial sweep.
    Factorial,
}

/// A measured setting.
#[derive(Debug)]
pub struct Measured {
    pub setting: Setting,
    pub why: Why,
    pub sample: Sample,
    pub error: f64,
    pub error_reference: Option<f64>,
}

/// The whole sweep: every setting measured, errors against the best.
#[derive(Debug)]
pub struct Sweep {
    pub kind: &'static str,
    pub knobs: Vec<Knob>,
    pub measured: Vec<Measured>,
    pub front: Vec<usize>,
    pub size: [usize; 2],
    pub reference_spp: Option<u32>,
    /// Settings the renderer cannot run, with why.
    pub skipped: Vec<(Setting, String)>,
}

/// How long a sweep may search for combinations.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    /// Greedy steps towards cheaper settings.
    pub cheaper_steps: usize,
    /// Greedy steps towards more accurate settings.
    pub accurate_steps: usize,
    /// Every combination instead of one at a time and chains.
    pub factorial: Option<usize>,
}

/// Measures `lab` over its knobs: the best setting, the defaults, every knob one at a
/// time (or the `factorial` list), then the greedy chains; `bar` counts the settings.
pub fn run_sweep(
    lab: &mut dyn Lab,
    plan: Plan,
    factorial: Vec<Setting>,
    reference: Option<u32>,
    bar: &indicatif::ProgressBar,
) -> Result<Sweep> {
    let knobs = lab.knobs().to_vec();
    let best = knobs::best(&knobs);
    let default = knobs::defaults(&knobs);
    let mut queue: Vec<(Setting, Why)> =
        vec![(best.clone(), Why::Best), (default.clone(), Why::Default)];
    if plan.factorial.is_some() {
        queue.extend(factorial.into_iter().map(|s| (s, Why::Factorial)));
    } else {
        queue.extend(
            knobs::one_at_a_time(&knobs)
                .into_iter()
                .map(|(k, s)| (s, Why::OneKnob(k))),
        );
    }
    bar.set_length((queue.len() + plan.cheaper_steps + plan.accurate_steps) as u64);
    // A first render warms the caches and the thread pool; its timing is not kept.
    bar.set_message("warm-up");
    lab.measure(&default)?;
    let mut seen: HashMap<Setting, usize> = HashMap::new();
    let mut measured: Vec<Measured> = Vec::new();
    let reference_img = match reference {
        Some(spp) => {
            bar.set_message("reference");
            Some(lab.reference(spp)?)
        }
        None => None,
    };
    let mut skipped: Vec<(Setting, String)> = Vec::new();
    // Measures `s` (as the renderer runs it, `Lab::runnable`) unless already measured;
    // the setting measured, or `None` when `s` cannot run.
    let mut measure = |lab: &mut dyn Lab,
                       s: Setting,
                       why: Why,
                       measured: &mut Vec<Measured>|
     -> Result<Option<Setting>> {
        let s = match lab.runnable(&s) {
            Ok(r) => r,
            Err(reason) => {
                if !skipped.iter().any(|(k, _)| *k == s) {
                    skipped.push((s, reason));
                }
                bar.inc(1);
                return Ok(None);
            }
        };
        if seen.contains_key(&s) {
            bar.inc(1);
            return Ok(Some(s));
        }
        bar.set_message(describe_short(&knobs, &s, &default));
        let sample = lab.measure(&s)?;
        let (error, error_reference) = match measured.first() {
            Some(b) => {
                let full = &b.sample.image;
                let img = resample(&sample.image, full.width, full.height);
                let r = reference_img
                    .as_ref()
                    .map(|r| resample(&sample.image, r.width, r.height).rel_rms(r));
                (img.rel_rms(full), r)
            }
            None => (
                0.0,
                reference_img
                    .as_ref()
                    .map(|r| resample(&sample.image, r.width, r.height).rel_rms(r)),
            ),
        };
        seen.insert(s.clone(), measured.len());
        measured.push(Measured {
            setting: s.clone(),
            why,
            sample,
            error,
            error_reference,
        });
        bar.inc(1);
        Ok(Some(s))
    };
    for (s, why) in queue {
        measure(lab, s, why, &mut measured)?;
    }
    if plan.factorial.is_none() {
        // The one-knob effects, relative to the defaults (the best setting itself when
        // every knob's default is its best).
        let d = measured
            .iter()
            .find(|m| m.setting == default)
            .ok_or_else(|| anyhow!("the defaults were not measured"))?;
        let effects: Vec<Effect> = measured
            .iter()
            .filter_map(|m| match m.why {
                Why::OneKnob(k) => Some(Effect {
                    knob: k,
                    value: m.setting[k],
                    d_ms: if knobs[k].render_neutral {
                        0.0
                    } else {
                        m.sample.render_ms - d.sample.render_ms
                    },
                    d_error: m.error - d.error,
                }),
                _ => None,
            })
            .collect();
        // Timing noise: 5 % of the default's render time; error changes below 0.01 %
        // are not worth a step.
        let noise = knobs::Noise {
            ms: 0.05 * d.sample.render_ms,
            error: 1e-4,
        };
        for (cheaper, steps) in [(true, plan.cheaper_steps), (false, plan.accurate_steps)] {
            let mut current = default.clone();
            for _ in 0..steps {
                let Some(s) = knobs::next_step(&current, &effects, cheaper, noise) else {
                    break;
                };
                match measure(lab, s, Why::Chain { cheaper }, &mut measured)? {
                    Some(s) if s != current => current = s,
                    _ => break,
                }
            }
        }
    }
    bar.finish_and_clear();
    share_render_times(&knobs, &mut measured);
    let points: Vec<pareto::Point> = measured
        .iter()
        .map(|m| pareto::Point {
            ms: m.sample.render_ms,
            error: m.error,
        })
        .collect();
    let front = pareto::front(&points);
    let full = &measured[0].sample.image;
    Ok(Sweep {
        kind: lab.kind(),
        knobs,
        front,
        size: [full.width, full.height],
        measured,
        reference_spp: reference,
        skipped,
    })
}

/// A setting that differs from another measured one in bake-only knobs alone (residual
/// error and bits, teleportation) renders the same work: its render time is taken from
/// that twin (the one with those knobs at their defaults), so that timing noise cannot put
/// a bake-only change on the render front. Its own measured time stays in `ms` as
/// `render_measured`.
fn share_render_times(knobs: &[Knob], measured: &mut [Measured]) {
    let twin_of = |s: &Setting| -> Setting {
        s.iter()
            .zip(knobs)
            .map(|(&v, k)| if k.render_neutral { k.default } else { v })
            .collect()
    };
    let index: HashMap<Setting, usize> = measured
        .iter()
        .enumerate()
        .map(|(i, m)| (m.setting.clone(), i))
        .collect();
    for i in 0..measured.len() {
        let twin = twin_of(&measured[i].setting);
        let Some(&j) = index.get(&twin) else { continue };
        if j == i {
            continue;
        }
        let (ms, view) = (
            measured[j].sample.render_ms,
            measured[j].sample.ms.get("view").cloned(),
        );
        let m = &mut measured[i];
        m.sample.ms["render_measured"] = json!(m.sample.render_ms);
        m.sample.ms["render"] = json!(ms);
        if let Some(v) = view {
            m.sample.ms["view"] = v;
        }
        m.sample.render_ms = ms;
    }
}

/// A knob value for people: names unquoted, fractions to 4 significant digits.
fn short(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Number(n) if n.is_f64() => {
            let x = n.as_f64().unwrap_or(0.0);
            let s = format!("{x:.4}");
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        }
        other => other.to_string(),
    }
}

/// "sh_order=2" for the knobs of `s` that differ from `default` ("defaults" if none).
pub fn describe_short(knobs: &[Knob], s: &[usize], default: &[usize]) -> String {
    let parts: Vec<String> = knobs
        .iter()
        .enumerate()
        .filter(|&(k, _)| s[k] != default[k])
        .map(|(k, knob)| format!("{}={}", knob.name, short(&knob.values[s[k]])))
        .collect();
    if parts.is_empty() {
        "defaults".to_string()
    } else {
        parts.join(" ")
    }
}

impl Sweep {
    fn entry(&self, i: usize) -> Value {
        let m = &self.measured[i];
        let default = knobs::defaults(&self.knobs);
        let why = match &m.why {
            Why::Best => "best".to_string(),
            Why::Default => "default".to_string(),
            Why::OneKnob(k) => format!("knob {}", self.knobs[*k].name),
            Why::Chain { cheaper: true } => "chain towards speed".to_string(),
            Why::Chain { cheaper: false } => "chain towards accuracy".to_string(),
            Why::Factorial => "combination".to_string(),
        };
        let mut e = Map::new();
        e.insert("index".into(), json!(i));
        e.insert(
            "knobs".into(),
            Value::Object(knobs::describe(&self.knobs, &m.setting)),
        );
        e.insert(
            "changed".into(),
            json!(describe_short(&self.knobs, &m.setting, &default)),
        );
        e.insert("why".into(), json!(why));
        e.insert("ms".into(), m.sample.ms.clone());
        e.insert("error".into(), json!(m.error));
        if let Some(r) = m.error_reference {
            e.insert("error_reference".into(), json!(r));
        }
        e.insert(
            "size".into(),
            json!([m.sample.image.width, m.sample.image.height]),
        );
        e.insert("detail".into(), m.sample.detail.clone());
        Value::Object(e)
    }

    /// What each knob does alone on this scene: for every value, the setting with that
    /// value and every other knob at its default — its render ms, `change` (rel RMS of its
    /// picture against the defaults' picture) and `vs_best` (against the picture with this
    /// knob at its most accurate value, the others at their defaults). The choice's
    /// reasons are read from it (`choice`). Values whose setting was not measured are left
    /// out.
    pub fn effects(&self) -> Value {
        let index: HashMap<&[usize], usize> = self
            .measured
            .iter()
            .enumerate()
            .map(|(i, m)| (m.setting.as_slice(), i))
            .collect();
        let default = knobs::defaults(&self.knobs);
        let Some(&d) = index.get(default.as_slice()) else {
            return json!({});
        };
        let picture = |i: usize, like: usize| {
            let to = &self.measured[like].sample.image;
            resample(&self.measured[i].sample.image, to.width, to.height)
        };
        let mut out = Map::new();
        for (k, knob) in self.knobs.iter().enumerate() {
            if knob.values.len() < 2 {
                continue;
            }
            let with = |v: usize| {
                let mut s = default.clone();
                s[k] = v;
                index.get(s.as_slice()).copied()
            };
            let best = with(knob.best);
            let rows: Vec<Value> = (0..knob.values.len())
                .filter_map(|v| {
                    let i = with(v)?;
                    let m = &self.measured[i];
                    Some(json!({
                        "value": knob.values[v],
                        "ms": m.sample.render_ms,
                        "view": m.sample.ms.get("view"),
                        "change": picture(i, d).rel_rms(&self.measured[d].sample.image),
                        "vs_best": best.map(|b| picture(i, b).rel_rms(&self.measured[b].sample.image)),
                    }))
                })
                .collect();
            out.insert(knob.name.to_string(), Value::Array(rows));
        }
        Value::Object(out)
    }

    /// `tradeoff.json` (docs/formats.md "Trade-off sweep"). `medium` describes the scene (σt,
    /// albedo, g and the light for smoke) and `timing` the renderer the times are of.
    pub fn to_json(&self, input: &Path, frame: Option<i64>, medium: Value, timing: &str) -> Value {
        json!({
            "input": input.display().to_string(),
            "frame": frame,
            "kind": self.kind,
            "size": self.size,
            "threads": rayon::current_num_threads(),
            "timing": timing,
            "medium": medium,
            "effects": self.effects(),
            "front_over": "render",
            "error_against": "best",
            "reference_spp": self.reference_spp,
            "knobs": self.knobs.iter().map(|k| json!({
                "name": k.name, "values": k.values, "default": k.values[k.default], "best": k.values[k.best],
            })).collect::<Vec<_>>(),
            "settings": (0..self.measured.len()).map(|i| self.entry(i)).collect::<Vec<_>>(),
            "pareto": self.front.iter().map(|&i| self.entry(i)).collect::<Vec<_>>(),
            "skipped": self.skipped.iter().map(|(s, why)| json!({
                "knobs": knobs::describe(&self.knobs, s), "why": why,
            })).collect::<Vec<_>>(),
        })
    }
}

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
    pub knobs: Option<Vec<String>>,
    pub quick: bool,
    pub fogmap: bool,
    pub extremes: bool,
    pub smoke: SmokeInput,
    pub fog_model: crate::fog::FogModelArgs,
}

/// A smoke sweep's scene: the light, the medium, the camera and the import options.
#[derive(Debug, Clone)]
pub struct SmokeInput {
    pub lights: crate::light_args::LightArgs,
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
    let density = crate::render::load_density(input, frame, &s.import)?;
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
        lab.use_rbfs(crate::render::load_asset(input, frame)?.rbfs);
    }
    if let Some(only) = only {
        lab.restrict(&only.iter().map(|n| n.to_string()).collect::<Vec<_>>());
    }
    let bar = crate::progress::settings_bar();
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

pub fn run(a: TradeoffArgs) -> Result<()> {
    if a.extremes {
        return extremes::run(&a.out);
    }
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("{}: cannot create the output directory", a.out.display()))?;
    let fog = is_fogmap(&a.input, a.fogmap);
    let bar = crate::progress::settings_bar();
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
        let sweep = run_sweep(
            &mut lab,
            smoke_plan(a.quick),
            Vec::new(),
            a.reference.then_some(a.spp),
            &bar,
        )?;
        let timing = timing_name(lab.adapter());
        (sweep, a.smoke.medium_json(), timing)
    };
    let doc = sweep.to_json(&a.input, a.frame, medium, &timing);
    let path = a.out.join("tradeoff.json");
    crate::output::write_json(&path, &doc)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A lab of two knobs, `model` (changes the render's work and its picture) and
    /// `stored` (bake-only: changes the picture, not the work), whose pictures are flat at
    /// `1 + 0.1·model + 0.01·stored` and whose clock runs down with every call: timing
    /// noise that would make each later setting look faster.
    struct Flat {
        knobs: Vec<Knob>,
        calls: f64,
        /// A `model` value the renderer cannot run.
        cannot: Option<usize>,
    }

    impl Lab for Flat {
        fn kind(&self) -> &'static str {
            "smoke"
        }
        fn knobs(&self) -> &[Knob] {
            &self.knobs
        }
        fn measure(&mut self, s: &[usize]) -> Result<Sample> {
            self.calls += 1.0;
            let v = 1.0 + 0.1 * s[0] as f32 + 0.01 * s[1] as f32;
            let mut image = Image::new(4, 3);
            image.pixels.iter_mut().for_each(|p| *p = [v; 3]);
            // Work: 100 ms per step of `model` down from 2, less the noise.
            let render_ms = 100.0 * (3.0 - s[0] as f64) - self.calls;
            Ok(Sample {
                image,
                render_ms,
                ms: json!({"render": render_ms, "view": render_ms / 2.0}),
                detail: json!({}),
            })
        }
        fn reference(&mut self, _spp: u32) -> Result<Image> {
            unreachable!("not asked for")
        }
        fn runnable(&self, s: &[usize]) -> std::result::Result<Setting, String> {
            match self.cannot {
                Some(v) if s[0] == v => Err(format!("model {v} cannot run")),
                _ => Ok(s.to_vec()),
            }
        }
    }

    fn flat() -> Flat {
        Flat {
            knobs: vec![
                Knob::new("model", vec![json!(0), json!(1), json!(2)], 1, 2),
                Knob::new("stored", vec![json!(0), json!(1)], 0, 1).render_neutral(),
            ],
            calls: 0.0,
            cannot: None,
        }
    }

    /// A bake-only change takes the render time of its twin (the same render knobs):
    /// the noise that made it look faster is gone and it cannot undercut its twin on the
    /// front. Its own measured time is kept beside.
    #[test]
    fn bake_only_changes_render_in_their_twins_time() {
        let plan = Plan {
            cheaper_steps: 3,
            accurate_steps: 3,
            factorial: None,
        };
        let bar = indicatif::ProgressBar::hidden();
        let sweep = run_sweep(&mut flat(), plan, Vec::new(), None, &bar).unwrap();
        let at = |s: &[usize]| sweep.measured.iter().find(|m| m.setting == s).unwrap();
        let (default, stored) = (at(&[1, 0]), at(&[1, 1]));
        assert_eq!(stored.sample.render_ms, default.sample.render_ms);
        assert_eq!(stored.sample.ms["render"], json!(default.sample.render_ms));
        assert!(stored.sample.ms["render_measured"].as_f64().unwrap() < default.sample.render_ms);
        // The best setting (model 2, stored 1) shares the time of (2, 0) when measured.
        if let Some(twin) = sweep.measured.iter().find(|m| m.setting == [2, 0]) {
            assert_eq!(at(&[2, 1]).sample.render_ms, twin.sample.render_ms);
        }
        // On the front, of two settings with the same render knobs only the more accurate
        // one remains.
        for &i in &sweep.front {
            for &j in &sweep.front {
                if i != j {
                    assert_ne!(sweep.measured[i].setting[0], sweep.measured[j].setting[0]);
                }
            }
        }
    }

    /// The knob effects against flat pictures: the rel RMS of `a` against `b` is
    /// `|a − b| / b`.
    #[test]
    fn knob_effects_are_the_picture_changes_measured() {
        let plan = Plan {
            cheaper_steps: 0,
            accurate_steps: 0,
            factorial: None,
        };
        let bar = indicatif::ProgressBar::hidden();
        let sweep = run_sweep(&mut flat(), plan, Vec::new(), None, &bar).unwrap();
        let e = sweep.effects();
        let rows = e["model"].as_array().unwrap();
        assert_eq!(rows.len(), 3);
        let close = |x: &Value, y: f64| (x.as_f64().unwrap() - y).abs() < 1e-6;
        // model 0: 1.0 against the defaults' 1.1 and the best's 1.2.
        assert_eq!(rows[0]["value"], json!(0));
        assert!(close(&rows[0]["change"], 0.1 / 1.1), "{}", rows[0]);
        assert!(close(&rows[0]["vs_best"], 0.2 / 1.2), "{}", rows[0]);
        assert!(close(&rows[1]["change"], 0.0));
        let stored = e["stored"].as_array().unwrap();
        assert!(close(&stored[1]["change"], 0.01 / 1.1), "{}", stored[1]);
        assert!(close(&stored[0]["vs_best"], 0.01 / 1.11), "{}", stored[0]);
        // Its render time is its twin's (the defaults').
        assert_eq!(stored[1]["ms"], stored[0]["ms"]);
    }

    /// A setting the renderer cannot run is not measured: the sweep lists it with why,
    /// and the rest of the sweep goes on.
    #[test]
    fn settings_that_cannot_run_are_listed_not_measured() {
        let plan = Plan {
            cheaper_steps: 3,
            accurate_steps: 0,
            factorial: None,
        };
        let bar = indicatif::ProgressBar::hidden();
        let mut lab = Flat {
            cannot: Some(0),
            ..flat()
        };
        let sweep = run_sweep(&mut lab, plan, Vec::new(), None, &bar).unwrap();
        assert!(sweep.measured.iter().all(|m| m.setting[0] != 0));
        assert!(sweep.measured.iter().any(|m| m.setting == [1, 1]));
        assert_eq!(
            sweep.skipped,
            vec![(vec![0, 0], "model 0 cannot run".to_string())]
        );
        let doc = sweep.to_json(Path::new("x"), None, json!({}), "CPU");
        assert_eq!(doc["skipped"][0]["knobs"], json!({"model": 0, "stored": 0}));
        assert_eq!(doc["skipped"][0]["why"], "model 0 cannot run");
    }
}
