//! A fog read from JSON: the `"terms"` of an analytic medium and its `"wind"`
//! (docs/formats.md "Analytic fog"). Every term refuses keys it does not know and is validated —
//! finite numbers, non-zero directions, `c > 0`, `d ≥ 0`, `C > 0`, degrees `≤ 9` — and the
//! whole fog must be non-negative everywhere: the sum of the terms' lower bounds
//! ([`crate::Fog::lower_bound`]) must not be below 0 (paper D: "extinction function must
//! not be negative", `c₀ ≥ Σ|c_i|` for cosines). Clamping instead would break the closed
//! forms.

use crate::blob::{Blob, Shape};
use crate::cosine::{Cosine, Wave};
use crate::height::Height;
use crate::polynomial::{MAX_DEGREE, Polynomial};
use crate::vec3::{Vec3, normalize, scale};
use crate::{Family, Fog, Term};
use haze_core::number::shown;
use serde::Deserialize;
use serde::de::DeserializeOwned;
use serde_json::Value;

fn one() -> f64 {
    1.0
}
fn yes() -> bool {
    true
}
fn up() -> Vec3 {
    [0.0, 0.0, 1.0]
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ConstantSpec {
    #[allow(dead_code)]
    r#type: String,
    #[serde(default = "one")]
    weight: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CosineSpec {
    #[allow(dead_code)]
    r#type: String,
    #[serde(default = "one")]
    weight: f64,
    k: f64,
    direction: Vec3,
    #[serde(default)]
    phase: f64,
    #[serde(default)]
    omega: f64,
    #[serde(default = "yes")]
    wind: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CosineProductSpec {
    #[allow(dead_code)]
    r#type: String,
    #[serde(default = "one")]
    weight: f64,
    k: [f64; 2],
    directions: [Vec3; 2],
    #[serde(default)]
    phase: [f64; 2],
    #[serde(default)]
    omega: [f64; 2],
    #[serde(default = "yes")]
    wind: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PolynomialSpec {
    #[allow(dead_code)]
    r#type: String,
    #[serde(default = "one")]
    weight: f64,
    axes: Vec<Vec3>,
    #[serde(default)]
    center: Vec3,
    half_width: f64,
    #[serde(default)]
    outside: Outside,
    #[serde(default)]
    coefficients: Option<Vec<f64>>,
    #[serde(default)]
    monomials: Option<Vec<Vec<f64>>>,
    #[serde(default = "yes")]
    wind: bool,
}

#[derive(Deserialize, Default, PartialEq)]
#[serde(rename_all = "lowercase")]
enum Outside {
    #[default]
    Periodic,
    Zero,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BlobSpec {
    #[allow(dead_code)]
    r#type: String,
    #[serde(default = "one")]
    weight: f64,
    shape: String,
    center: Vec3,
    #[serde(default)]
    direction: Option<Vec3>,
    #[serde(default)]
    radius: Option<f64>,
    c: f64,
    d: f64,
    #[serde(default = "yes")]
    wind: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct HeightSpec {
    #[allow(dead_code)]
    r#type: String,
    #[serde(default = "one")]
    weight: f64,
    falloff: f64,
    #[serde(default = "up")]
    normal: Vec3,
    #[serde(default)]
    base: f64,
    #[serde(default = "yes")]
    wind: bool,
}

fn typed<T: DeserializeOwned>(v: &Value) -> Result<T, String> {
    T::deserialize(v).map_err(|e| e.to_string())
}

fn finite(what: &str, v: &[f64]) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what} must be finite"))
    }
}

fn unit(what: &str, v: Vec3) -> Result<Vec3, String> {
    finite(what, &v)?;
    normalize(v).ok_or_else(|| format!("{what} must not be zero"))
}

/// The fog of `terms` under the wind velocity `wind`; the error names the term
/// (`terms[2]: …`) and the problem.
pub fn fog(wind: Vec3, terms: &[Value]) -> Result<Fog, String> {
    finite("wind", &wind)?;
    let terms = terms
        .iter()
        .enumerate()
        .map(|(i, v)| term(v).map_err(|e| format!("terms[{i}]: {e}")))
        .collect::<Result<Vec<_>, _>>()?;
    let fog = Fog { terms, wind };
    let low = fog.lower_bound();
    if low < -1e-12 {
        return Err(format!(
            "the terms can sum to a negative extinction (their lower bounds add up to {}); raise the constant term or lower the amplitudes",
            haze_core::number::rounded(low, 6)
        ));
    }
    Ok(fog)
}

fn term(v: &Value) -> Result<Term, String> {
    let kind = match v.get("type") {
        Some(Value::String(s)) => s.as_str(),
        Some(other) => return Err(format!("\"type\" must be a string, not {other}")),
        None if v.is_object() => return Err("missing \"type\"".to_string()),
        None => return Err(format!("expected an object, found {v}")),
    };
    let (weight, windy, family) = match kind {
        "constant" => {
            let s: ConstantSpec = typed(v)?;
            (s.weight, false, Family::Constant)
        }
        "cosine" => {
            let s: CosineSpec = typed(v)?;
            finite("k, phase, omega", &[s.k, s.phase, s.omega])?;
            let d = unit("direction", s.direction)?;
            let wave = Wave {
                amp: 1.0,
                q: scale(d, s.k),
                phase: s.phase,
                omega: s.omega,
            };
            (
                s.weight,
                s.wind,
                Family::Cosine(Cosine { waves: vec![wave] }),
            )
        }
        "cosine_product" => {
            let s: CosineProductSpec = typed(v)?;
            finite("k, phase, omega", &[s.k, s.phase, s.omega].concat())?;
            let q1 = scale(unit("directions[0]", s.directions[0])?, s.k[0]);
            let q2 = scale(unit("directions[1]", s.directions[1])?, s.k[1]);
            // cos α cos β = ½cos(α + β) + ½cos(α − β).
            let waves = [1.0, -1.0]
                .map(|sg| Wave {
                    amp: 0.5,
                    q: [0, 1, 2].map(|k| q1[k] + sg * q2[k]),
                    phase: s.phase[0] + sg * s.phase[1],
                    omega: s.omega[0] + sg * s.omega[1],
                })
                .to_vec();
            (s.weight, s.wind, Family::Cosine(Cosine { waves }))
        }
        "polynomial" => {
            let s: PolynomialSpec = typed(v)?;
            (s.weight, s.wind, Family::Polynomial(polynomial(s)?))
        }
        "blob" => {
            let s: BlobSpec = typed(v)?;
            (s.weight, s.wind, Family::Blob(blob(&s)?))
        }
        "height" => {
            let s: HeightSpec = typed(v)?;
            finite("falloff, base", &[s.falloff, s.base])?;
            if s.weight < 0.0 {
                return Err(format!(
                    "weight {} of a height falloff must not be negative",
                    shown(s.weight)
                ));
            }
            let normal = unit("normal", s.normal)?;
            (
                s.weight,
                s.wind,
                Family::Height(Height {
                    normal,
                    base: s.base,
                    falloff: s.falloff,
                }),
            )
        }
        other => {
            return Err(format!(
                "unknown term type \"{other}\" (known: \"constant\", \"cosine\", \"cosine_product\", \"polynomial\", \"blob\", \"height\")"
            ));
        }
    };
    finite("weight", &[weight])?;
    Ok(Term {
        weight,
        windy,
        family,
    })
}

/// A blob term's shape and profile, or why the spec is not one: a center not finite,
/// `c` not positive, `d` negative, or a shape with the wrong parameters.
fn blob(s: &BlobSpec) -> Result<Blob, String> {
    finite("center", &s.center)?;
    if !(s.c > 0.0 && s.c.is_finite()) {
        return Err(format!("c = {} must be positive", shown(s.c)));
    }
    if !(s.d >= 0.0 && s.d.is_finite()) {
        return Err(format!("d = {} must not be negative", shown(s.d)));
    }
    let shape = match (s.shape.as_str(), s.direction, s.radius) {
        ("point", None, None) => Shape::Point { center: s.center },
        ("line", Some(d), None) => Shape::Line {
            point: s.center,
            direction: unit("direction", d)?,
        },
        ("sphere", None, Some(r)) if r > 0.0 && r.is_finite() => Shape::Sphere {
            center: s.center,
            radius: r,
        },
        ("sphere", None, Some(r)) => {
            return Err(format!("radius {} must be positive", shown(r)));
        }
        ("point", ..) => return Err("a point blob takes no direction or radius".into()),
        ("line", ..) => {
            return Err("a line blob takes a direction and no radius".into());
        }
        ("sphere", ..) => {
            return Err("a sphere blob takes a radius and no direction".into());
        }
        (other, ..) => {
            return Err(format!(
                "unknown blob shape \"{other}\" (known: \"point\", \"line\", \"sphere\")"
            ));
        }
    };
    Ok(Blob {
        shape,
        c: s.c,
        d: s.d,
    })
}

fn polynomial(s: PolynomialSpec) -> Result<Polynomial, String> {
    if s.axes.is_empty() || s.axes.len() > 3 {
        return Err(format!(
            "{} axes: a polynomial takes one to three",
            s.axes.len()
        ));
    }
    let axes = s
        .axes
        .iter()
        .enumerate()
        .map(|(i, a)| unit(&format!("axes[{i}]"), *a))
        .collect::<Result<Vec<_>, _>>()?;
    finite("center", &s.center)?;
    if !(s.half_width > 0.0 && s.half_width.is_finite()) {
        return Err(format!(
            "half_width {} must be positive",
            shown(s.half_width)
        ));
    }
    let n = axes.len();
    let monomials: Vec<(f64, [u32; 3])> = match (s.coefficients, s.monomials) {
        (Some(c), None) if n == 1 => c
            .iter()
            .enumerate()
            .map(|(i, &v)| (v, [i as u32, 0, 0]))
            .collect(),
        (Some(_), None) => {
            return Err("\"coefficients\" is for one axis; give \"monomials\" for more".into());
        }
        (None, Some(m)) => m
            .iter()
            .enumerate()
            .map(|(i, row)| {
                if row.len() != n + 1 {
                    return Err(format!(
                        "monomials[{i}] must be [coefficient, {n} powers], not {} numbers",
                        row.len()
                    ));
                }
                let mut p = [0u32; 3];
                for (j, &e) in row[1..].iter().enumerate() {
                    if !(e >= 0.0 && e.fract() == 0.0 && e <= f64::from(MAX_DEGREE)) {
                        return Err(format!(
                            "monomials[{i}]: power {e} must be a whole number in 0..={MAX_DEGREE}"
                        ));
                    }
                    p[j] = e as u32;
                }
                Ok((row[0], p))
            })
            .collect::<Result<_, _>>()?,
        _ => return Err("give exactly one of \"coefficients\" and \"monomials\"".into()),
    };
    for (i, (c, p)) in monomials.iter().enumerate() {
        finite(&format!("coefficient {i}"), &[*c])?;
        if p.iter().sum::<u32>() > MAX_DEGREE {
            return Err(format!(
                "degree {} is above {MAX_DEGREE}",
                p.iter().sum::<u32>()
            ));
        }
    }
    Ok(Polynomial {
        axes,
        center: s.center,
        half: s.half_width,
        periodic: s.outside == Outside::Periodic,
        monomials,
    })
}
