//! The knobs a sweep turns and the settings it measures: every knob one at a time around
//! the defaults, then the combinations a Pareto front needs (greedy chains from the
//! default towards cheaper and towards more accurate settings).

use serde::Serialize;
use serde_json::{Map, Value};
use std::fmt;

/// One value of a knob, written to `tradeoff.json` as the JSON number, boolean or string
/// it holds (a count as an integer, a number as a float).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum KnobValue {
    /// A count: RBFs, bits, an SH order, iterations, levels.
    Count(u64),
    /// A real number: an error, slices per voxel, a size fraction, µ.
    Number(f64),
    /// On or off.
    Flag(bool),
    /// A named choice, spelled as on the command line.
    Name(&'static str),
}

impl KnobValue {
    /// A count, or a number's value (as `f64`); `None` for a flag or a name.
    pub fn number(self) -> Option<f64> {
        match self {
            KnobValue::Count(n) => Some(n as f64),
            KnobValue::Number(x) => Some(x),
            KnobValue::Flag(_) | KnobValue::Name(_) => None,
        }
    }

    /// A count; `None` for anything else.
    pub fn count(self) -> Option<u64> {
        match self {
            KnobValue::Count(n) => Some(n),
            _ => None,
        }
    }

    /// A flag; `None` for anything else.
    pub fn flag(self) -> Option<bool> {
        match self {
            KnobValue::Flag(b) => Some(b),
            _ => None,
        }
    }

    /// A name; `None` for anything else.
    pub fn name(self) -> Option<&'static str> {
        match self {
            KnobValue::Name(n) => Some(n),
            _ => None,
        }
    }

    /// Counts.
    pub fn counts<T: Copy + Into<u64>>(values: &[T]) -> Vec<KnobValue> {
        values.iter().map(|&v| KnobValue::Count(v.into())).collect()
    }

    /// Numbers.
    pub fn numbers(values: &[f64]) -> Vec<KnobValue> {
        values.iter().map(|&v| KnobValue::Number(v)).collect()
    }

    /// Names.
    pub fn names(values: &[&'static str]) -> Vec<KnobValue> {
        values.iter().map(|&v| KnobValue::Name(v)).collect()
    }

    /// Off, then on.
    pub fn flags() -> Vec<KnobValue> {
        vec![KnobValue::Flag(false), KnobValue::Flag(true)]
    }
}

/// As in a setting's short description: a name bare, a number with at most four
/// decimals and no trailing zeros.
impl fmt::Display for KnobValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KnobValue::Count(n) => write!(f, "{n}"),
            KnobValue::Number(x) => {
                let s = format!("{x:.4}");
                f.write_str(s.trim_end_matches('0').trim_end_matches('.'))
            }
            KnobValue::Flag(b) => write!(f, "{b}"),
            KnobValue::Name(n) => f.write_str(n),
        }
    }
}

/// One knob: its candidate values (as written in `tradeoff.json`), the default and the
/// most accurate of them.
#[derive(Clone, Debug)]
pub struct Knob {
    pub name: &'static str,
    pub values: Vec<KnobValue>,
    pub default: usize,
    pub best: usize,
    /// The knob acts on the bake alone and cannot change the render time (the residual's
    /// error and bits, teleportation): its measured render-time differences are noise.
    pub render_neutral: bool,
}

impl Knob {
    pub fn new(name: &'static str, values: Vec<KnobValue>, default: usize, best: usize) -> Knob {
        debug_assert!(default < values.len() && best < values.len());
        Knob {
            name,
            values,
            default,
            best,
            render_neutral: false,
        }
    }

    /// The same knob, marked as acting on the bake alone.
    pub fn render_neutral(self) -> Knob {
        Knob {
            render_neutral: true,
            ..self
        }
    }
}

/// A setting: the index of every knob's value, in the order of the knob list.
pub type Setting = Vec<usize>;

pub fn defaults(knobs: &[Knob]) -> Setting {
    knobs.iter().map(|k| k.default).collect()
}

pub fn best(knobs: &[Knob]) -> Setting {
    knobs.iter().map(|k| k.best).collect()
}

/// The knob values of `s` by name, as `tradeoff.json` writes them.
pub fn describe(knobs: &[Knob], s: &[usize]) -> Map<String, Value> {
    knobs
        .iter()
        .zip(s)
        .map(|(k, &i)| (k.name.to_string(), serde_json::json!(k.values[i])))
        .collect()
}

/// The settings that change one knob of the defaults, each tagged with that knob's index.
pub fn one_at_a_time(knobs: &[Knob]) -> Vec<(usize, Setting)> {
    let d = defaults(knobs);
    let mut out = Vec::new();
    for (k, knob) in knobs.iter().enumerate() {
        for v in 0..knob.values.len() {
            if v != knob.default {
                let mut s = d.clone();
                s[k] = v;
                out.push((k, s));
            }
        }
    }
    out
}

/// What one change of one knob did, measured from the defaults: `(knob, value, Δms,
/// Δerror)` (render milliseconds and error of the changed setting minus the default's).
#[derive(Clone, Copy, Debug)]
pub struct Effect {
    pub knob: usize,
    pub value: usize,
    pub d_ms: f64,
    pub d_error: f64,
}

/// The smallest changes a chain step counts.
#[derive(Clone, Copy, Debug, Default)]
pub struct Noise {
    pub ms: f64,
    pub error: f64,
}

/// The next step of a greedy chain from `current`: the knob change that buys the most
/// time per unit of error (`towards_cheaper`: least `Δerror / −Δms` among the values
/// faster than the knob's current one) or the most accuracy per millisecond (least `Δms /
/// −Δerror` among the values more accurate than the current one), judged by the
/// one-at-a-time effects. Each step moves one knob strictly further in its direction, so
/// a chain ends. Changes smaller than `noise` (milliseconds saved, or error removed) do
/// not count: timings on a busy machine vary by several percent. `None` when no change
/// qualifies.
pub fn next_step(
    current: &[usize],
    effects: &[Effect],
    towards_cheaper: bool,
    noise: Noise,
) -> Option<Setting> {
    // The current value's own effect (zero at the default).
    let now = |knob: usize| -> (f64, f64) {
        effects
            .iter()
            .find(|e| e.knob == knob && e.value == current[knob])
            .map_or((0.0, 0.0), |e| (e.d_ms, e.d_error))
    };
    let score = |e: &Effect| -> Option<f64> {
        let (ms, err) = now(e.knob);
        let (d_ms, d_error) = (e.d_ms - ms, e.d_error - err);
        if towards_cheaper {
            (d_ms < -noise.ms).then(|| d_error.max(0.0) / -d_ms)
        } else {
            (d_error < -noise.error).then(|| d_ms.max(0.0) / -d_error)
        }
    };
    let mut best: Option<(f64, &Effect)> = None;
    for e in effects {
        if let Some(s) = score(e)
            && best.is_none_or(|(b, _)| s < b)
        {
            best = Some((s, e));
        }
    }
    best.map(|(_, e)| {
        let mut s = current.to_vec();
        s[e.knob] = e.value;
        s
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn two() -> Vec<Knob> {
        vec![
            Knob::new("a", KnobValue::counts(&[1u32, 2, 3]), 1, 2),
            Knob::new("b", KnobValue::flags(), 1, 1),
        ]
    }

    #[test]
    fn one_at_a_time_changes_exactly_one_knob() {
        let k = two();
        let s = one_at_a_time(&k);
        // 2 other values of a, 1 of b.
        assert_eq!(s.len(), 3);
        for (knob, setting) in &s {
            let changed: Vec<usize> = (0..2).filter(|&i| setting[i] != k[i].default).collect();
            assert_eq!(changed, vec![*knob]);
        }
        assert_eq!(describe(&k, &best(&k))["a"], json!(3));
    }

    #[test]
    fn greedy_steps_take_the_best_ratio_and_stop() {
        let effects = [
            // Saves 10 ms for 1 % error.
            Effect {
                knob: 0,
                value: 0,
                d_ms: -10.0,
                d_error: 0.01,
            },
            // Saves 2 ms for nothing: the best ratio.
            Effect {
                knob: 1,
                value: 0,
                d_ms: -2.0,
                d_error: 0.0,
            },
            // Costs 5 ms, gains 2 %.
            Effect {
                knob: 0,
                value: 2,
                d_ms: 5.0,
                d_error: -0.02,
            },
        ];
        let quiet = Noise::default();
        let s1 = next_step(&[1, 1], &effects, true, quiet).unwrap();
        assert_eq!(s1, vec![1, 0]);
        let s2 = next_step(&s1, &effects, true, quiet).unwrap();
        assert_eq!(s2, vec![0, 0]);
        assert!(next_step(&s2, &effects, true, quiet).is_none());
        assert_eq!(
            next_step(&[1, 1], &effects, false, quiet).unwrap(),
            vec![2, 1]
        );
        // Saving 2 ms is noise when timings vary by 3 ms: the 10 ms change comes first.
        let noisy = Noise {
            ms: 3.0,
            error: 0.0,
        };
        assert_eq!(
            next_step(&[1, 1], &effects, true, noisy).unwrap(),
            vec![0, 1]
        );
        assert!(next_step(&[0, 1], &effects, true, noisy).is_none());
    }
}
