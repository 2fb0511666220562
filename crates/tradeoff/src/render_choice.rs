//! `--budget-ms`/`--target-error` of a smoke render: the knobs of a render chosen from a
//! sweep's front.

use super::choice;
use super::pareto::Goal;
use anyhow::{Result, anyhow, bail};
use haze_render::check::ErrorEstimate;
use haze_render::frame::is_asset;
use haze_render::smoke::RenderOptions;
use haze_view::lighting::single::SourcePoints;
use haze_view::render::MsDiffusion;
use haze_view::render::env_pass::{EnvGridOptions, EnvSource};
use haze_view::sh::ExpMethod;
use std::path::Path;

/// Renders `a` with its knobs chosen for `goal` from the sweep (read, or a quick one run
/// here), printing the choice and why. For a target error, the render checks itself
/// against the reference ([`RenderOptions::check`]); where the check finds the target
/// missed beyond its spread, the choice is made again for half the error the setting had
/// against the sweep's best, up to [`RECHOICES`] times: the sweep's errors are against its
/// best setting, and the check is what knows the truth.
pub fn render_for_goal(a: RenderOptions, goal: Goal, tradeoff: Option<&Path>) -> Result<()> {
    choice::check_goal(goal)?;
    let (doc, source) = sweep(&a, tradeoff)?;
    if let Some(warning) = best_above_target(&doc, goal) {
        haze_render::say!("warning: {source}: {warning}");
    }
    let mut want = goal;
    for round in 0..=RECHOICES {
        let mut chosen = a.clone();
        let against_best = apply_goal(&mut chosen, &doc, &source, want)?;
        let estimate = haze_render::smoke::render(chosen)?;
        let (Goal::TargetError(target), Some(e)) = (goal, estimate) else {
            return Ok(());
        };
        let Some(next) = choose_again(target, &e, against_best, round) else {
            return Ok(());
        };
        haze_render::say!(
            "the check found {:.1} % ± {:.1} % against the target {:.1} %: choosing again, within {:.2} % of the best setting",
            100.0 * e.error,
            100.0 * e.spread,
            100.0 * target,
            100.0 * next
        );
        want = Goal::TargetError(next);
    }
    Ok(())
}

/// The error against the sweep's best to choose for next, after round `round` rendered a
/// setting `against_best` from the best and its check estimated `e` for a `target`: half
/// of `against_best` where the target is missed beyond the check's spread, rounds remain
/// and a more accurate setting exists; `None` otherwise.
fn choose_again(target: f64, e: &ErrorEstimate, against_best: f64, round: usize) -> Option<f64> {
    (e.above(target) == Some(true) && round < RECHOICES && against_best > 0.0)
        .then_some(0.5 * against_best)
}

/// How many times [`render_for_goal`] chooses again after a failed check.
pub const RECHOICES: usize = 2;

/// The sweep a choice is made from — `tradeoff`'s file (its view-pass times rescaled to
/// `a`'s picture size, with a warning, where it was measured at another) or a quick sweep
/// of `a`'s input — and its name for messages.
fn sweep(a: &RenderOptions, tradeoff: Option<&Path>) -> Result<(serde_json::Value, String)> {
    match tradeoff {
        Some(path) => {
            let mut doc = choice::read(path)?;
            if doc.get("kind").and_then(|k| k.as_str()) == Some("fogmap") {
                bail!(
                    "{}: a fogmap's sweep cannot choose a smoke render's knobs",
                    path.display()
                );
            }
            if let Some(warning) = choice::rescale(&mut doc, a.width, a.height)
                .map_err(|e| anyhow!("{}: {e}", path.display()))?
            {
                haze_render::say!("warning: {}: {warning}", path.display());
            }
            if let Some(warning) = choice::timing_mismatch(&doc, false) {
                haze_render::say!("warning: {}: {warning}", path.display());
            }
            Ok((doc, path.display().to_string()))
        }
        None => {
            let input = super::SmokeInput {
                lights: a.env.clone(),
                sigma_t: a.sigma_t,
                albedo: a.albedo,
                g: a.g,
                view: super::smoke::View {
                    eye: a.eye,
                    target: a.target,
                    up: a.up,
                    fov: a.fov,
                    width: a.width,
                    height: a.height,
                },
                import: a.import.clone(),
                timing: super::smoke::Timing::Cpu,
            };
            // An asset's bake knobs are its own: only the render's are swept.
            let doc = super::quick_sweep(
                &a.input,
                a.frame,
                &input,
                is_asset(&a.input).then_some(&RENDER_KNOBS[..]),
            )?;
            Ok((doc, format!("a quick sweep of {}", a.input.display())))
        }
    }
}

/// Sets the knobs of `a` to the sweep's setting for `goal`, printing the choice and why;
/// returns that setting's error against the sweep's best.
fn apply_goal(
    a: &mut RenderOptions,
    doc: &serde_json::Value,
    source: &str,
    goal: Goal,
) -> Result<f64> {
    let c = choice::choose(doc, goal).map_err(|e| anyhow!("{source}: {e}"))?;
    let asset = is_asset(&a.input);
    apply_choice(a, &c, !asset);
    let note = if asset {
        " (RBF count, teleportation and residual error are the asset's own: bake with them to get the measured error)"
    } else {
        ""
    };
    haze_render::say!("choice from {source}: {}{note}", c.reason);
    Ok(c.error)
}

/// Where a target error is below the sweep's best setting's own estimated error against
/// the reference (`haze tradeoff --check`): the sweep's errors are against that setting,
/// so no choice from it can promise the target against the truth.
fn best_above_target(doc: &serde_json::Value, goal: Goal) -> Option<String> {
    let Goal::TargetError(target) = goal else {
        return None;
    };
    let best = doc["best_estimated_error"]["error"].as_f64()?;
    (best > target).then(|| {
        format!(
            "the best setting itself is estimated {:.1} % off the reference, above the target {:.1} %: the choice is within the target of the best setting, not of the truth",
            100.0 * best,
            100.0 * target
        )
    })
}

/// The knobs of a render (the others are the bake's).
const RENDER_KNOBS: [&str; 9] = [
    "sh_order",
    "exp",
    "source",
    "cg_iterations",
    "slices",
    "size",
    "multiple",
    "residual",
    "diffusion",
];

/// Sets the knobs of `a` that choice `c` names; the fit's (RBF count, teleportation)
/// only when `fit` (a volume input, fitted here).
fn apply_choice(a: &mut RenderOptions, c: &choice::Choice, fit: bool) {
    if let Some(v) = choice::f64_knob(c, "sh_order") {
        a.sh_order = v as usize;
    }
    if let Some(v) = choice::str_knob(c, "exp") {
        a.exp = if v == "linear" {
            ExpMethod::OptimalLinear
        } else {
            ExpMethod::ScaleSquareAuto
        };
    }
    if let Some(v) = choice::str_knob(c, "source") {
        // "grid": the environment pass (at the spacing asked for, else the default);
        // "footprint" and "center": paper A's sources at the centers.
        a.source_points = if v == "center" {
            SourcePoints::Center
        } else {
            SourcePoints::Footprint
        };
        if v != "grid" {
            a.env_source = EnvSource::Centers;
        } else if a.env_source == EnvSource::Centers {
            a.env_source = EnvSource::Grid(EnvGridOptions::default());
        }
    }
    if let Some(v) = choice::f64_knob(c, "cg_iterations") {
        a.solve.max_iterations = v as u32;
    }
    if let Some(v) = choice::f64_knob(c, "slices") {
        a.slices = v;
    }
    if let Some(v) = choice::bool_knob(c, "multiple") {
        a.multiple = v;
    }
    if let Some(v) = choice::bool_knob(c, "residual") {
        a.residual = v;
    }
    // The multiple-scattering model the chosen setting was measured with; a sweep
    // without the knob (written before it) timed the centers' diffusion.
    a.diffusion = match choice::str_knob(c, "diffusion") {
        Some(v) => v.parse().unwrap_or(a.diffusion),
        None => MsDiffusion::Centers,
    };
    if let Some(v) = choice::f64_knob(c, "size") {
        a.width = ((a.width as f64 * v).round() as usize).max(8);
        a.height = ((a.height as f64 * v).round() as usize).max(8);
    }
    if fit {
        if let Some(v) = choice::f64_knob(c, "rbfs") {
            a.rbfs = v as usize;
        }
        if let Some(v) = choice::bool_knob(c, "teleport") {
            a.teleport = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{Value, json};

    #[test]
    fn a_missed_target_chooses_again_for_less() {
        let est = |error, spread| ErrorEstimate {
            error,
            noise: 0.036,
            pixels: 220,
            samples: 128,
            seconds: 1.0,
            spread,
        };
        // Missed beyond the spread: half the chosen setting's error against the best.
        assert_eq!(
            choose_again(0.019, &est(0.05, 0.002), 0.0132, 0),
            Some(0.0066)
        );
        assert_eq!(
            choose_again(0.019, &est(0.05, 0.002), 0.0066, 1),
            Some(0.0033)
        );
        // No more rounds, or the best setting itself: keep what was rendered.
        assert_eq!(
            choose_again(0.019, &est(0.05, 0.002), 0.0033, RECHOICES),
            None
        );
        assert_eq!(choose_again(0.019, &est(0.05, 0.002), 0.0, 0), None);
        // Within the spread of the target, or met: no new choice.
        assert_eq!(choose_again(0.019, &est(0.021, 0.002), 0.0132, 0), None);
        assert_eq!(choose_again(0.019, &est(0.012, 0.002), 0.0132, 0), None);
    }

    #[test]
    fn a_target_below_the_best_settings_own_error_is_warned_about() {
        let doc = json!({"best_estimated_error": {"error": 0.04, "noise": 0.03}});
        let w = best_above_target(&doc, Goal::TargetError(0.02)).unwrap();
        assert!(w.contains("4.0 %") && w.contains("2.0 %"), "{w}");
        assert!(best_above_target(&doc, Goal::TargetError(0.05)).is_none());
        assert!(best_above_target(&doc, Goal::BudgetMs(10.0)).is_none());
        // A sweep without the check (or written before it) says nothing.
        assert!(best_above_target(&json!({}), Goal::TargetError(0.001)).is_none());
        let unchecked = json!({"best_estimated_error": null});
        assert!(best_above_target(&unchecked, Goal::TargetError(0.001)).is_none());
    }

    /// `haze render smoke.vdb --out out.png`'s options.
    fn args() -> RenderOptions {
        RenderOptions::new("smoke.vdb", "out.png")
    }

    /// A sweep of the `exp`, `source` and `cg_iterations` knobs where changing `knob` to
    /// `value` alone is the fastest setting: the best (slow, exact), the defaults, and
    /// that change.
    fn front_decided_by(knob: &str, value: Value) -> Value {
        let defaults = json!({"exp": "square", "source": "footprint", "cg_iterations": 20,
                              "diffusion": "orders:auto:6"});
        let best = json!({"exp": "square", "source": "footprint", "cg_iterations": 500,
                          "diffusion": "orders:auto:6"});
        let mut changed = defaults.clone();
        changed[knob] = value;
        json!({
            "kind": "smoke",
            "size": [400, 300],
            "knobs": [
                {"name": "exp", "values": ["square", "linear"], "default": "square", "best": "square"},
                {"name": "source", "values": ["footprint", "center"], "default": "footprint", "best": "footprint"},
                {"name": "cg_iterations", "values": [5, 20, 500], "default": 20, "best": 500},
                {"name": "diffusion", "values": ["centers", "orders:3:3", "orders:auto:6"],
                 "default": "orders:auto:6", "best": "orders:auto:6"},
            ],
            "settings": [
                {"knobs": best, "ms": {"render": 300.0, "view": 100.0}, "error": 0.0},
                {"knobs": defaults, "ms": {"render": 100.0, "view": 100.0}, "error": 0.01},
                {"knobs": changed, "ms": {"render": 50.0, "view": 50.0}, "error": 0.02},
            ],
        })
    }

    /// Each of the exp variant, the source placement, the CG iterations and the
    /// multiple-scattering model, when it is the knob that meets the budget, is chosen and
    /// reaches the render's options; a sweep without the `diffusion` knob (which timed
    /// the centers' diffusion) renders with the centers.
    #[test]
    fn exp_source_cg_and_diffusion_choices_reach_the_render() {
        type Applied = fn(&RenderOptions) -> bool;
        let cases: [(&str, Value, Applied); 5] = [
            ("exp", json!("linear"), |a| {
                a.exp == ExpMethod::OptimalLinear
            }),
            ("source", json!("center"), |a| {
                a.source_points == SourcePoints::Center
            }),
            ("cg_iterations", json!(5), |a| a.solve.max_iterations == 5),
            ("diffusion", json!("centers"), |a| {
                a.diffusion == MsDiffusion::Centers
            }),
            ("diffusion", json!("orders:3:3"), |a| {
                a.diffusion
                    == MsDiffusion::Orders {
                        factor: 3,
                        orders: 3,
                    }
            }),
        ];
        for (knob, value, applied) in cases {
            let doc = front_decided_by(knob, value.clone());
            let mut a = args();
            assert!(!applied(&a), "{knob}: already at the choice");
            // Within 60 ms only the change is; within 150 ms the defaults are better.
            let c = choice::choose(&doc, Goal::BudgetMs(60.0)).unwrap();
            assert_eq!(c.knobs[knob], value);
            apply_choice(&mut a, &c, true);
            assert!(applied(&a), "{knob}: {a:?}");
            assert!(c.reason.contains("50.0 ms at 2.00 %"), "{}", c.reason);
            let mut a = args();
            let c = choice::choose(&doc, Goal::BudgetMs(150.0)).unwrap();
            apply_choice(&mut a, &c, true);
            assert!(!applied(&a), "{knob}: {a:?}");
            // A target of 1.5 % is met by the defaults alone.
            let c = choice::choose(&doc, Goal::TargetError(0.015)).unwrap();
            assert_ne!(c.knobs[knob], value);
        }
        let mut old = front_decided_by("exp", json!("linear"));
        for s in old["settings"].as_array_mut().unwrap() {
            s["knobs"].as_object_mut().unwrap().remove("diffusion");
        }
        let mut a = args();
        apply_choice(
            &mut a,
            &choice::choose(&old, Goal::BudgetMs(150.0)).unwrap(),
            true,
        );
        assert_eq!(a.diffusion, MsDiffusion::Centers);
        // The reason names the model in words.
        let c = choice::choose(
            &front_decided_by("diffusion", json!("orders:3:3")),
            Goal::BudgetMs(60.0),
        )
        .unwrap();
        assert!(
            c.reason.contains(
                "multiple scattering by explicit orders (3 orders on cells of 3³ voxels)"
            ),
            "{}",
            c.reason
        );
    }
}
