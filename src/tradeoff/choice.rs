//! Automatic choice ("model only what the scene requires"): the setting on a sweep's
//! Pareto front that meets a render-time budget or an error target, and why.

use super::pareto::{self, Goal, Point};
use anyhow::{Context, Result, anyhow};
use serde_json::{Map, Value};
use std::path::Path;

/// A chosen setting: its knob values and the reason in words (with its measured time
/// and error).
#[derive(Clone, Debug)]
pub struct Choice {
    pub knobs: Map<String, Value>,
    pub reason: String,
}

/// Reads a `tradeoff.json`.
pub fn read(path: &Path) -> Result<Value> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_str(&text)
        .with_context(|| format!("{}: not a tradeoff.json (invalid JSON)", path.display()))
}

fn num(v: &Value, at: &str) -> Result<f64> {
    v.pointer(at)
        .and_then(Value::as_f64)
        .ok_or_else(|| anyhow!("no number at {at}"))
}

/// The front entry of sweep `doc` meeting `goal`.
pub fn choose(doc: &Value, goal: Goal) -> Result<Choice> {
    let front = doc
        .get("pareto")
        .and_then(Value::as_array)
        .ok_or_else(|| anyhow!("no \"pareto\" list"))?;
    let points = front
        .iter()
        .map(|e| {
            Ok(Point {
                ms: num(e, "/ms/render")?,
                error: num(e, "/error")?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let order: Vec<usize> = (0..points.len()).collect();
    let i = pareto::choose(&points, &order, goal).map_err(anyhow::Error::msg)?;
    let e = &front[i];
    let knobs = e
        .get("knobs")
        .and_then(Value::as_object)
        .cloned()
        .ok_or_else(|| anyhow!("a front entry has no \"knobs\""))?;
    let goal_text = match goal {
        Goal::BudgetMs(t) => format!(
            "budget {t:.1} ms: the most accurate of the {} front settings within it",
            points.len()
        ),
        Goal::TargetError(x) => format!(
            "target error {x}: the fastest of the {} front settings reaching it",
            points.len()
        ),
    };
    let mut reason = format!(
        "{goal_text}, {:.1} ms at {:.2} % against the best setting",
        points[i].ms,
        100.0 * points[i].error
    );
    for why in knob_reasons(doc, &knobs) {
        reason += "; ";
        reason += &why;
    }
    Ok(Choice { knobs, reason })
}

/// For every knob the choice moves off its default: what that change alone measured
/// ("multiple = false alone: error +0.31 %, −12.0 ms").
fn knob_reasons(doc: &Value, chosen: &Map<String, Value>) -> Vec<String> {
    let empty = Vec::new();
    let knobs = doc.get("knobs").and_then(Value::as_array).unwrap_or(&empty);
    let settings = doc
        .get("settings")
        .and_then(Value::as_array)
        .unwrap_or(&empty);
    let default = settings
        .iter()
        .find(|s| s.get("why").and_then(Value::as_str) == Some("default"));
    let mut out = Vec::new();
    for k in knobs {
        let (Some(name), Some(d)) = (k.get("name").and_then(Value::as_str), k.get("default"))
        else {
            continue;
        };
        let Some(v) = chosen.get(name) else { continue };
        if v == d {
            continue;
        }
        let alone = settings.iter().find(|s| {
            s.get("why").and_then(Value::as_str) == Some(&format!("knob {name}"))
                && s.pointer(&format!("/knobs/{name}")) == Some(v)
        });
        match (alone, default) {
            (Some(a), Some(d)) => {
                let (Ok(ea), Ok(ed), Ok(ta), Ok(td)) = (
                    num(a, "/error"),
                    num(d, "/error"),
                    num(a, "/ms/render"),
                    num(d, "/ms/render"),
                ) else {
                    continue;
                };
                out.push(format!(
                    "{name} = {v} alone: error {:+.2} %, {:+.1} ms",
                    100.0 * (ea - ed),
                    ta - td
                ));
            }
            _ => out.push(format!("{name} = {v}")),
        }
    }
    out
}

/// A knob value of a choice as a number.
pub fn f64_knob(c: &Choice, name: &str) -> Option<f64> {
    c.knobs.get(name).and_then(Value::as_f64)
}

/// A knob value of a choice as a flag.
pub fn bool_knob(c: &Choice, name: &str) -> Option<bool> {
    c.knobs.get(name).and_then(Value::as_bool)
}

/// A knob value of a choice as a name.
pub fn str_knob<'a>(c: &'a Choice, name: &str) -> Option<&'a str> {
    c.knobs.get(name).and_then(Value::as_str)
}

/// The setting of the sweep in `file` for a viewer with `budget_ms` per picture.
pub fn for_view(file: &Path, budget_ms: f64) -> Result<Choice> {
    if !(budget_ms > 0.0 && budget_ms.is_finite()) {
        anyhow::bail!("--view-budget-ms {budget_ms} must be a positive number of milliseconds");
    }
    let doc = read(file)?;
    if doc.get("kind").and_then(Value::as_str) != Some("smoke") {
        anyhow::bail!("{}: not a smoke sweep", file.display());
    }
    choose(&doc, Goal::BudgetMs(budget_ms)).map_err(|e| anyhow!("{}: {e}", file.display()))
}

/// The viewer knobs and why stored in an asset's header (`extra.choices.view`), if any.
pub fn stored_view_knobs(asset: &Path) -> Option<(Map<String, Value>, String)> {
    let a = haze_asset::Asset::open(asset).ok()?;
    let view = a.header().extra.get("choices")?.get("view")?;
    let knobs = view.get("knobs")?.as_object()?.clone();
    let why = view.get("why")?.as_str()?.to_string();
    Some((knobs, why))
}
