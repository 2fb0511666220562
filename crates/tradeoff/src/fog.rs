//! The fogmap sweep: a fogmap's wavelet fog (paper E) decomposed and rendered on the CPU
//! for every basis × levels × µ (`haze fog wavelet`'s code path); the space is small, so
//! every combination is measured.

use super::knobs::{Knob, KnobValue};
use crate::lab::{Lab, Sample};
use anyhow::{Context, Result, anyhow};
use haze_render::fog::FogModel;
use haze_wavelet::{Basis, Fog, Fogmap};
use serde_json::json;
use std::path::Path;
use std::time::Instant;

const LEVELS: [usize; 5] = [0, 1, 2, 3, 4];
const LEVELS_QUICK: [usize; 3] = [0, 1, 2];
const MU: [f64; 5] = [1.0, 0.8, 0.6, 0.4, 0.2];
const MU_QUICK: [f64; 2] = [1.0, 0.5];

/// The fog lab: the fogmap, the model's other settings and the picture size.
#[derive(Debug)]
pub struct FogLab {
    fogmap: Fogmap,
    label: String,
    model: FogModel,
    width: usize,
    height: usize,
    repeats: usize,
    knobs: Vec<Knob>,
}

impl FogLab {
    pub fn open(
        path: &Path,
        model: FogModel,
        width: usize,
        height: usize,
        quick: bool,
        repeats: usize,
    ) -> Result<FogLab> {
        let fogmap = Fogmap::load(path)?;
        let max = haze_wavelet::lod::max_levels(fogmap.width, fogmap.height);
        let levels: Vec<KnobValue> = if quick {
            &LEVELS_QUICK[..]
        } else {
            &LEVELS[..]
        }
        .iter()
        .filter(|&&l| l <= max)
        .map(|&l| KnobValue::Count(l as u64))
        .collect();
        let mu = KnobValue::numbers(if quick { &MU_QUICK[..] } else { &MU[..] });
        let knobs = vec![
            Knob::new(
                "basis",
                KnobValue::names(&["haar", "linear", "quadratic"]),
                1,
                1,
            ),
            Knob::new("levels", levels, 0, 0),
            Knob::new("mu", mu, 0, 0),
        ];
        Ok(FogLab {
            fogmap,
            label: path.display().to_string(),
            model,
            width,
            height,
            repeats: repeats.max(1),
            knobs,
        })
    }

    /// Keeps only the knobs named in `only` (the others stay at their defaults).
    pub fn restrict(&mut self, only: &[String]) {
        crate::lab::restrict(&mut self.knobs, only);
    }

    /// Every combination of the knobs' values, except µ < 1 at 0 levels (µ then changes
    /// nothing).
    pub fn factorial(&self) -> Vec<Vec<usize>> {
        let mut out = Vec::new();
        for b in 0..self.knobs[0].values.len() {
            for l in 0..self.knobs[1].values.len() {
                for m in 0..self.knobs[2].values.len() {
                    let at_zero = self.knobs[1].values[l] == KnobValue::Count(0);
                    if at_zero && m != self.knobs[2].default {
                        continue;
                    }
                    out.push(vec![b, l, m]);
                }
            }
        }
        out
    }
}

impl Lab for FogLab {
    fn kind(&self) -> &'static str {
        "fogmap"
    }

    fn knobs(&self) -> &[Knob] {
        &self.knobs
    }

    fn measure(&mut self, s: &[usize]) -> Result<Sample> {
        let v = |k: usize| self.knobs[k].values[s[k]];
        let basis = match v(0).name() {
            Some("haar") => Basis::Haar,
            Some("quadratic") => Basis::Quadratic,
            _ => Basis::Linear,
        };
        let levels = v(1).count().unwrap_or(0) as usize;
        let mu = v(2).number().unwrap_or(1.0);
        let placement = self.model.placement(self.fogmap.width, self.fogmap.height);
        let settings = haze_wavelet::Settings {
            mu,
            ..self.model.settings(false)
        };
        let t = Instant::now();
        let fog = Fog::new(&self.fogmap.grid(), basis, levels, placement, settings)
            .with_context(|| self.label.clone())?;
        let decompose_ms = t.elapsed().as_secs_f64() * 1e3;
        let framing = haze_wavelet::render::framing(&fog);
        let camera = framing
            .camera(self.width, self.height)
            .map_err(|e| anyhow!("camera: {e}"))?;
        let scene = self.model.scene();
        let mut best: Option<(f64, Vec<[f32; 3]>)> = None;
        for _ in 0..self.repeats {
            let t = Instant::now();
            let px = haze_wavelet::render::render(&fog, &camera, &scene, &|| {});
            let ms = t.elapsed().as_secs_f64() * 1e3;
            if best.as_ref().is_none_or(|(b, _)| ms < *b) {
                best = Some((ms, px));
            }
        }
        let (render_ms, pixels) = best.ok_or_else(|| anyhow!("no render"))?;
        Ok(Sample {
            image: haze_view::Image {
                width: self.width,
                height: self.height,
                pixels,
            },
            render_ms,
            ms: json!({"bake": decompose_ms, "decompose": decompose_ms, "render": render_ms}),
            detail: json!({}),
        })
    }

    fn reference(&mut self, _spp: u32) -> Result<haze_view::Image> {
        // The exact integral of the fogmap itself: 0 levels, µ = 1, no early exit.
        let placement = self.model.placement(self.fogmap.width, self.fogmap.height);
        let settings = haze_wavelet::Settings {
            mu: 1.0,
            min_transmittance: 0.0,
            ..self.model.settings(false)
        };
        let fog = Fog::new(&self.fogmap.grid(), Basis::Linear, 0, placement, settings)
            .with_context(|| self.label.clone())?;
        let camera = haze_wavelet::render::framing(&fog)
            .camera(self.width, self.height)
            .map_err(|e| anyhow!("camera: {e}"))?;
        Ok(haze_view::Image {
            width: self.width,
            height: self.height,
            pixels: haze_wavelet::render::render(&fog, &camera, &self.model.scene(), &|| {}),
        })
    }
}
