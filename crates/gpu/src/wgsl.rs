//! WGSL shaders composed from modules: a line-based preprocessor, and a CPU-only
//! validation of its output with naga (the WGSL front end and validator wgpu itself runs),
//! so that a broken shader is found by a unit test, not when a device builds a pipeline.
//!
//! A shader is an **entry file** (a short WGSL source with the entry points) that imports
//! **modules** by name. Directives are whole lines (leading spaces allowed):
//!
//! - `#import NAME` — the module `NAME`'s text, composed the same way, in place of the
//!   line; each module enters a shader once (a second import of it is dropped), so
//!   modules may import what they use without care for who else does. WGSL declarations
//!   may come in any order, so where a module lands does not matter.
//! - `#ifdef NAME` / `#ifndef NAME` / `#else` / `#endif` — keep or drop the lines between
//!   by whether `NAME` is among the variant's defines. Blocks nest; an `#import` inside a
//!   dropped block is not followed.
//!
//! Nothing else is rewritten: no macros, no text substitution. Values that vary at run
//! time (sizes, counts, constants computed on the CPU) are WGSL `override` declarations
//! set when the pipeline is made ([`crate::compute_pipeline_with`]), not text.
//!
//! Each renderer crate lists its modules ([`Module`]) and its variants ([`Variant`]: an
//! entry file and its defines); its unit test composes every variant and calls
//! [`validate`]. The modules every renderer may import are [`SHARED`]
//! (`crates/gpu/shaders/`).

use crate::GpuError;
use std::collections::HashSet;
use std::fmt;

/// A WGSL module that entry files and other modules `#import` by `name`.
#[derive(Clone, Copy, Debug)]
pub struct Module {
    pub name: &'static str,
    pub source: &'static str,
}

/// The modules of `crates/gpu/shaders/`, for every renderer's module list:
///
/// - `optics`: `PI`, the Henyey–Greenstein lobe `hg_lobe(g, c)` and phase
///   `hg_phase(g, c)`;
/// - `finite`: `finite(v)` and `finite_or_zero(v)`, for values that overflowed or are NaN;
/// - `workgroup_sum`: a workgroup's sum of a `vec2<f32>` per invocation (the importer
///   defines `WG`, its workgroup size).
pub const SHARED: &[Module] = &[
    Module {
        name: "optics",
        source: include_str!("../shaders/optics.wgsl"),
    },
    Module {
        name: "finite",
        source: include_str!("../shaders/finite.wgsl"),
    },
    Module {
        name: "workgroup_sum",
        source: include_str!("../shaders/workgroup_sum.wgsl"),
    },
];

/// One shader a renderer compiles: an entry file composed with a set of defines.
#[derive(Clone, Copy, Debug)]
pub struct Variant {
    /// What it is, for messages (the pipeline's label).
    pub label: &'static str,
    /// The entry file's source.
    pub entry: &'static str,
    /// The names `#ifdef` sees defined.
    pub defines: &'static [&'static str],
}

impl Variant {
    /// The variant's whole WGSL source, its imports resolved among `modules`.
    pub fn compose(&self, modules: &[&[Module]]) -> Result<String, ComposeError> {
        compose(self.entry, modules, self.defines)
    }

    /// [`Variant::compose`] for a pipeline: a failure is a [`GpuError::Shader`].
    pub fn source(&self, modules: &[&[Module]]) -> Result<String, GpuError> {
        self.compose(modules).map_err(|e| GpuError::Shader {
            label: self.label,
            reason: e.to_string(),
        })
    }
}

/// Why a shader could not be composed (a mistake in a shader file or a module list,
/// found by each crate's validation test).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ComposeError {
    #[error("line {line}: `#import {name}`: no such module")]
    UnknownModule { line: usize, name: String },
    #[error("line {line}: `#import {name}` imports itself through {chain}")]
    Cycle {
        line: usize,
        name: String,
        chain: String,
    },
    #[error("line {line}: unknown directive `{text}`")]
    UnknownDirective { line: usize, text: String },
    #[error("line {line}: `{text}` without an open `#ifdef`")]
    Unbalanced { line: usize, text: String },
    #[error("an `#ifdef` opened on line {line} is never closed")]
    Unclosed { line: usize },
    #[error("line {line}: in module `{module}`: {inner}")]
    InModule {
        line: usize,
        module: &'static str,
        inner: Box<ComposeError>,
    },
}

/// `entry` with every `#import` replaced by its module's composed text (each module
/// once) and every `#ifdef` block resolved against `defines`. `modules` is searched in
/// order: a renderer's own modules, then those of the crates it builds on.
pub fn compose(
    entry: &str,
    modules: &[&[Module]],
    defines: &[&str],
) -> Result<String, ComposeError> {
    let mut out = String::with_capacity(entry.len());
    let mut state = Composer {
        modules,
        defines,
        imported: HashSet::new(),
        stack: Vec::new(),
    };
    state.expand(entry, &mut out)?;
    Ok(out)
}

struct Composer<'a> {
    modules: &'a [&'a [Module]],
    defines: &'a [&'a str],
    /// Modules already in the output.
    imported: HashSet<&'static str>,
    /// The imports being expanded, outermost first (for cycles).
    stack: Vec<&'static str>,
}

/// One open `#ifdef`: whether its current branch is kept, whether the block is inside a
/// dropped one, whether `#else` was seen, and its line.
struct Open {
    keep: bool,
    outer: bool,
    seen_else: bool,
    line: usize,
}

impl Composer<'_> {
    fn find(&self, name: &str) -> Option<Module> {
        self.modules
            .iter()
            .flat_map(|m| m.iter())
            .find(|m| m.name == name)
            .copied()
    }

    fn expand(&mut self, source: &str, out: &mut String) -> Result<(), ComposeError> {
        let mut open: Vec<Open> = Vec::new();
        for (i, text) in source.lines().enumerate() {
            let line = i + 1;
            let active = open.last().is_none_or(|o| o.keep);
            let directive = text.trim_start();
            if !directive.starts_with('#') {
                if active {
                    out.push_str(text);
                    out.push('\n');
                }
                continue;
            }
            let mut words = directive.split_whitespace();
            let (word, arg) = (words.next().unwrap_or(""), words.next());
            match (word, arg) {
                ("#ifdef" | "#ifndef", Some(name)) => {
                    let defined = self.defines.contains(&name);
                    open.push(Open {
                        keep: active && (defined == (word == "#ifdef")),
                        outer: active,
                        seen_else: false,
                        line,
                    });
                }
                ("#else", None) => match open.last_mut() {
                    Some(o) if !o.seen_else => {
                        o.keep = o.outer && !o.keep;
                        o.seen_else = true;
                    }
                    _ => {
                        return Err(ComposeError::Unbalanced {
                            line,
                            text: text.trim().to_string(),
                        });
                    }
                },
                ("#endif", None) => {
                    if open.pop().is_none() {
                        return Err(ComposeError::Unbalanced {
                            line,
                            text: text.trim().to_string(),
                        });
                    }
                }
                ("#import", Some(name)) if words.next().is_none() => {
                    if active {
                        self.import(name, line, out)?;
                    }
                }
                _ => {
                    return Err(ComposeError::UnknownDirective {
                        line,
                        text: text.trim().to_string(),
                    });
                }
            }
        }
        match open.last() {
            Some(o) => Err(ComposeError::Unclosed { line: o.line }),
            None => Ok(()),
        }
    }

    fn import(&mut self, name: &str, line: usize, out: &mut String) -> Result<(), ComposeError> {
        let module = self.find(name).ok_or_else(|| ComposeError::UnknownModule {
            line,
            name: name.to_string(),
        })?;
        if self.stack.contains(&module.name) {
            return Err(ComposeError::Cycle {
                line,
                name: name.to_string(),
                chain: self.stack.join(" → "),
            });
        }
        if !self.imported.insert(module.name) {
            return Ok(());
        }
        self.stack.push(module.name);
        // Errors inside a module name it: its lines are counted from its own start.
        self.expand(module.source, out).map_err(|e| match e {
            ComposeError::Cycle { .. } => e,
            inner => ComposeError::InModule {
                line,
                module: module.name,
                inner: Box::new(inner),
            },
        })?;
        self.stack.pop();
        Ok(())
    }
}

/// A shader naga refused, with naga's own (multi-line) report.
#[derive(Clone, Debug)]
pub struct ShaderError {
    pub report: String,
}

impl fmt::Display for ShaderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.report)
    }
}

impl std::error::Error for ShaderError {}

/// Parses `source` as WGSL and validates it as wgpu would before building a pipeline
/// (types, uniformity, bindings), on the CPU; `label` names the shader in the report.
/// `override` declarations are validated as declared (their values are only known to a
/// pipeline).
pub fn validate(label: &str, source: &str) -> Result<(), ShaderError> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| ShaderError {
        report: format!("{label}: {}", e.emit_to_string_with_path(source, label)),
    })?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| ShaderError {
        report: format!("{label}: {}", e.emit_to_string_with_path(source, label)),
    })?;
    Ok(())
}

/// Composes every variant of a renderer and validates each with naga: the body of each
/// renderer crate's shader test. Panics with every failure's report.
pub fn assert_variants_valid(variants: &[Variant], modules: &[&[Module]]) {
    let mut failures = Vec::new();
    for v in variants {
        match v.compose(modules) {
            Ok(source) => {
                if let Err(e) = validate(v.label, &source) {
                    failures.push(e.report);
                }
            }
            Err(e) => failures.push(format!("{}: {e}", v.label)),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: Module = Module {
        name: "a",
        source: "#import b\nfn a() -> f32 { return b(); }",
    };
    const B: Module = Module {
        name: "b",
        source: "#ifdef BIG\nfn b() -> f32 { return 2.0; }\n#else\nfn b() -> f32 { return 1.0; }\n#endif",
    };

    #[test]
    fn imports_once_and_resolves_defines() {
        let entry = "#import a\n#import b\n@compute @workgroup_size(1) fn main() { let x = a(); }";
        let small = compose(entry, &[&[A, B]], &[]).unwrap();
        assert_eq!(
            small,
            "fn b() -> f32 { return 1.0; }\nfn a() -> f32 { return b(); }\n\
             @compute @workgroup_size(1) fn main() { let x = a(); }\n"
        );
        let big = compose(entry, &[&[A], &[B]], &["BIG"]).unwrap();
        assert!(
            big.contains("return 2.0") && !big.contains("return 1.0"),
            "{big}"
        );
        validate("small", &small).unwrap();
        validate("big", &big).unwrap();
    }

    #[test]
    fn nested_blocks_inside_a_dropped_block_stay_dropped() {
        let src = "#ifdef X\n#ifndef Y\nx\n#else\ny\n#endif\n#else\nz\n#endif";
        assert_eq!(compose(src, &[], &[]).unwrap(), "z\n");
        assert_eq!(compose(src, &[], &["X"]).unwrap(), "x\n");
        assert_eq!(compose(src, &[], &["X", "Y"]).unwrap(), "y\n");
        // An import in a dropped block is not followed, even when it does not exist.
        assert_eq!(
            compose("#ifdef X\n#import nowhere\n#endif\nw", &[], &[]).unwrap(),
            "w\n"
        );
    }

    #[test]
    fn mistakes_are_named() {
        let err = |src: &str, m: &[Module]| compose(src, &[m], &[]).unwrap_err().to_string();
        assert_eq!(
            err("x\n#import c", &[]),
            "line 2: `#import c`: no such module"
        );
        assert_eq!(
            err("#endif", &[]),
            "line 1: `#endif` without an open `#ifdef`"
        );
        assert_eq!(
            err("#ifdef X\n#else\n#else", &[]),
            "line 3: `#else` without an open `#ifdef`"
        );
        assert_eq!(
            err("\n#ifdef X\n", &[]),
            "an `#ifdef` opened on line 2 is never closed"
        );
        assert_eq!(
            err("#define X", &[]),
            "line 1: unknown directive `#define X`"
        );
        let c = Module {
            name: "c",
            source: "#import d",
        };
        let d = Module {
            name: "d",
            source: "#import c",
        };
        assert_eq!(
            err("#import c", &[c, d]),
            "line 1: `#import c` imports itself through c → d"
        );
        let broken = Module {
            name: "broken",
            source: "#endif",
        };
        assert_eq!(
            err("#import broken", &[broken]),
            "line 1: in module `broken`: line 1: `#endif` without an open `#ifdef`"
        );
    }

    #[test]
    fn naga_refuses_invalid_wgsl_with_the_label() {
        let e = validate("bad.wgsl", "fn f() -> f32 { return 1u; }").unwrap_err();
        assert!(e.report.starts_with("bad.wgsl: "), "{}", e.report);
        let e = validate("syntax.wgsl", "fn f( {").unwrap_err();
        assert!(e.report.starts_with("syntax.wgsl: "), "{}", e.report);
    }

    #[test]
    fn overrides_validate_unset() {
        validate(
            "override.wgsl",
            "override N: u32 = 32u;\noverride S: f32;\n\
             @compute @workgroup_size(1) fn main() { var x = 0u; if (x < N) { x = u32(S); } }",
        )
        .unwrap();
    }
}
