//! A sweepable model of the input: its knobs and how to measure a setting of them.

use crate::knobs::{Knob, Setting};
use anyhow::Result;
use haze_render::check::ErrorEstimate;
use haze_view::Image;
use serde_json::Value;

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
    /// The error of `image` (a setting's picture) against the reference, estimated on `n`
    /// of its smoke pixels as `haze render --check` does; `None` where the lab has no
    /// reference renderer or no pixel shows smoke.
    fn check(&mut self, _image: &Image, _n: usize) -> Option<ErrorEstimate> {
        None
    }
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
            k.values = vec![k.values[k.default]];
            k.default = 0;
            k.best = 0;
        }
    }
}
