//! The sweep: every knob one at a time around the defaults, then greedy chains from the
//! defaults towards cheaper and towards more accurate settings; each setting measured,
//! its error taken against the most accurate setting's picture, and the Pareto front.

use crate::knobs::{self, Effect, Knob, Setting};
use crate::lab::{Lab, Sample};
use crate::pareto;
use anyhow::{Result, anyhow};
use haze_render::check::ErrorEstimate;
use haze_view::Image;
use serde_json::{Map, Value, json};
use std::collections::HashMap;
use std::path::Path;

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
    /// The best setting's own error against the reference, estimated on a few of its
    /// pixels ([`Sweep::check_best`]): every error of the sweep is against the best.
    pub best_check: Option<ErrorEstimate>,
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
        best_check: None,
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

/// "sh_order=2" for the knobs of `s` that differ from `default` ("defaults" if none).
pub fn describe_short(knobs: &[Knob], s: &[usize], default: &[usize]) -> String {
    let parts: Vec<String> = knobs
        .iter()
        .enumerate()
        .filter(|&(k, _)| s[k] != default[k])
        .map(|(k, knob)| format!("{}={}", knob.name, knob.values[s[k]]))
        .collect();
    if parts.is_empty() {
        "defaults".to_string()
    } else {
        parts.join(" ")
    }
}

impl Sweep {
    /// Estimates the best setting's error against `lab`'s reference on `n` of its pixels
    /// (none for `n = 0` or a lab without a reference).
    pub fn check_best(&mut self, lab: &mut dyn Lab, n: usize) {
        if n == 0 {
            return;
        }
        let best = self.measured.iter().find(|m| matches!(m.why, Why::Best));
        self.best_check = best.and_then(|m| lab.check(&m.sample.image, n));
    }

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

    /// `tradeoff.json` (docs/formats.md "Trade-off sweep"), the file `haze render
    /// --budget-ms` and `haze view` read back. `medium` describes the scene (σt,
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
            "best_estimated_error": self.best_check.map(|e| json!({
                "error": e.error, "noise": e.noise, "pixels": e.pixels, "samples": e.samples,
            })),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::knobs::KnobValue;

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
                Knob::new("model", KnobValue::counts(&[0u32, 1, 2]), 1, 2),
                Knob::new("stored", KnobValue::counts(&[0u32, 1]), 0, 1).render_neutral(),
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
