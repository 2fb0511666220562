//! `haze view --budget-ms T | --target-error E [--tradeoff FILE]`: the viewer's starting
//! knobs (SH order, slices per voxel, multiple scattering and its model, the residual and
//! the render size) chosen from a tradeoff sweep's front — the file's, its view-pass times rescaled
//! to the viewer's size, or a quick sweep of the asset measured here, at the viewer's
//! size with the viewer's renderer (every stage on the GPU, the asset's own RBFs), before
//! the window opens.

use super::ViewArgs;
use anyhow::{Result, anyhow, bail};
use haze_tradeoff::choice::{self, Choice};
use haze_tradeoff::pareto::Goal;
use haze_tradeoff::smoke::{Timing, View};
use haze_view::render::MsDiffusion;

/// The knobs the viewer can start with; a quick sweep turns these alone.
pub const VIEW_KNOBS: [&str; 6] = [
    "sh_order",
    "slices",
    "multiple",
    "residual",
    "size",
    "diffusion",
];

/// Chooses the starting knobs of `a` for `goal`, printing the choice, why, and what the
/// viewer starts with.
pub fn choose_knobs(a: &mut ViewArgs, goal: Goal) -> Result<()> {
    choice::check_goal(goal)?;
    let (doc, source) = match &a.tradeoff {
        Some(path) => {
            let mut doc = choice::read(path)?;
            if doc.get("kind").and_then(|k| k.as_str()) != Some("smoke") {
                bail!("{}: not a smoke sweep", path.display());
            }
            if let Some(warning) = choice::rescale(&mut doc, a.width, a.height)
                .map_err(|e| anyhow!("{}: {e}", path.display()))?
            {
                haze_render::say!("warning: {}: {warning}", path.display());
            }
            if let Some(warning) = choice::timing_mismatch(&doc, true) {
                haze_render::say!("warning: {}: {warning}", path.display());
            }
            (doc, path.display().to_string())
        }
        None => {
            let input = haze_tradeoff::SmokeInput {
                lights: a.env.clone(),
                sigma_t: a.knobs.sigma_t,
                albedo: a.knobs.albedo,
                g: a.knobs.g,
                view: View {
                    eye: None,
                    target: None,
                    up: [0.0, 0.0, 1.0],
                    fov: a.fov,
                    width: a.width,
                    height: a.height,
                },
                import: Default::default(),
                timing: Timing::Gpu(a.lighting),
            };
            haze_render::say!(
                "measuring a quick sweep of {} at {}×{} for the choice",
                a.input.display(),
                a.width,
                a.height
            );
            let doc = haze_tradeoff::quick_sweep(&a.input, None, &input, Some(&VIEW_KNOBS))?;
            (doc, format!("a quick sweep of {}", a.input.display()))
        }
    };
    let c = choice::choose(&doc, goal).map_err(|e| anyhow!("{source}: {e}"))?;
    apply(a, &c);
    haze_render::say!("choice from {source}: {}", c.reason);
    haze_render::say!(
        "starting with {}, {}×{}",
        a.knobs.describe(),
        a.width,
        a.height
    );
    Ok(())
}

/// Sets the viewer's knobs that choice `c` names (the others are the sweep's bake).
fn apply(a: &mut ViewArgs, c: &Choice) {
    if let Some(v) = choice::f64_knob(c, "sh_order") {
        a.knobs.sh_order = v as usize;
    }
    if let Some(v) = choice::f64_knob(c, "slices") {
        a.knobs.slices = v;
    }
    if let Some(v) = choice::bool_knob(c, "multiple") {
        a.knobs.multiple = v;
    }
    if let Some(v) = choice::bool_knob(c, "residual") {
        a.knobs.residual = v;
    }
    if let Some(v) = choice::f64_knob(c, "size") {
        a.width = ((a.width as f64 * v).round() as usize).max(8);
        a.height = ((a.height as f64 * v).round() as usize).max(8);
    }
    // The multiple-scattering model; a sweep without the knob (written before it) timed
    // the centers' diffusion.
    match choice::str_knob(c, "diffusion").map(str::parse::<MsDiffusion>) {
        Some(Ok(m @ MsDiffusion::Orders { .. })) => {
            a.knobs.orders = true;
            a.knobs.orders_model = m;
        }
        Some(Ok(_)) | None => a.knobs.orders = false,
        // A model the viewer does not name keeps the command line's.
        Some(Err(_)) => {}
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::write_asset;
    use super::super::{Knobs, run};
    use super::*;
    use serde_json::json;

    /// A sweep of the viewer's knobs measured at 80 × 60 whose front, within 60 ms,
    /// holds SH order 2, one slice per voxel, no multiple scattering, half the size and
    /// the cheaper explicit orders.
    fn sweep() -> serde_json::Value {
        let setting = |sh: u64, slices: f64, m: bool, size: f64, ms: f64, error: f64| {
            let diffusion = if ms < 100.0 {
                "orders:3:3"
            } else {
                "orders:auto:6"
            };
            json!({"knobs": {"sh_order": sh, "slices": slices, "multiple": m, "residual": true,
                             "size": size, "diffusion": diffusion},
                   "ms": {"render": ms, "view": 0.5 * ms}, "error": error})
        };
        json!({
            "kind": "smoke",
            "size": [80, 60],
            "knobs": [
                {"name": "sh_order", "values": [2, 4, 6], "default": 4, "best": 6},
                {"name": "slices", "values": [1.0, 2.0], "default": 2.0, "best": 2.0},
                {"name": "multiple", "values": [false, true], "default": true, "best": true},
                {"name": "residual", "values": [false, true], "default": true, "best": true},
                {"name": "size", "values": [0.5, 1.0], "default": 1.0, "best": 1.0},
                {"name": "diffusion", "values": ["orders:3:3", "orders:auto:6"],
                 "default": "orders:auto:6", "best": "orders:auto:6"},
            ],
            "settings": [
                setting(6, 2.0, true, 1.0, 400.0, 0.0),
                setting(4, 2.0, true, 1.0, 200.0, 0.01),
                setting(2, 1.0, false, 0.5, 50.0, 0.08),
            ],
        })
    }

    /// `--budget-ms 60 --tradeoff FILE`: the viewer starts with the front's knobs — they
    /// are what its first view renders with — and plays them without a window.
    #[test]
    fn the_viewer_starts_with_the_knobs_the_budget_chooses() {
        let dir = tempfile::tempdir().unwrap();
        let asset = write_asset(dir.path(), "a.haze", 2);
        let file = dir.path().join("tradeoff.json");
        std::fs::write(&file, sweep().to_string()).unwrap();
        let defaults = super::super::testing::default_knobs();
        let args = |tradeoff: &std::path::Path| ViewArgs {
            input: asset.clone(),
            fps: 0.0,
            width: 80,
            height: 60,
            fov: 40.0,
            env: haze_render::lights::Lights::default(),
            knobs: defaults.clone(),
            play_for: Some(0.3),
            window: false,
            orbit: false,
            lighting: haze_view::gpu::renderer::LightingOn::Cpu,
            supersample: haze_render::smoke::Supersample::Auto,
            ground: haze_render::lights::GroundChoice::Auto,
            goal: Some(Goal::BudgetMs(60.0)),
            tradeoff: Some(tradeoff.to_path_buf()),
        };
        let mut a = args(&file);
        choose_knobs(&mut a, Goal::BudgetMs(60.0)).unwrap();
        let cheaper = MsDiffusion::Orders {
            factor: 3,
            orders: 3,
        };
        assert_eq!(
            a.knobs,
            Knobs {
                sh_order: 2,
                slices: 1.0,
                multiple: false,
                orders_model: cheaper,
                ..defaults.clone()
            }
        );
        assert_eq!((a.width, a.height), (40, 30));
        let scene = a
            .knobs
            .scene(std::sync::Arc::new(a.env.environment().unwrap()))
            .unwrap();
        assert_eq!(
            (
                scene.opts.order,
                scene.opts.slices_per_voxel,
                scene.opts.multiple,
                scene.opts.residual,
                scene.opts.diffusion
            ),
            (2, 1.0, false, true, cheaper)
        );
        // A sweep written before the `diffusion` knob timed the centers' diffusion.
        let mut old = sweep();
        for s in old["settings"].as_array_mut().unwrap() {
            s["knobs"].as_object_mut().unwrap().remove("diffusion");
        }
        let old_file = dir.path().join("old.json");
        std::fs::write(&old_file, old.to_string()).unwrap();
        let mut b = args(&old_file);
        choose_knobs(&mut b, Goal::BudgetMs(60.0)).unwrap();
        assert!(!b.knobs.orders);
        // The whole viewer without a window, choosing again inside `run`.
        a.knobs = defaults;
        a.width = 80;
        a.height = 60;
        run(a).unwrap();
    }
}
