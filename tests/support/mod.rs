//! What the bad-input tests share: the binary, small inputs written on the fly, and the
//! promise every failing run keeps (exit 1 or 2, one line on stderr, no panic, inputs
//! untouched, nothing left behind).

#![allow(dead_code)]

use assert_cmd::Command;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(rel)
}

pub fn haze() -> Command {
    Command::cargo_bin("haze").unwrap()
}

/// The output of `haze ARGS`, after checking that it succeeded (its stderr shown if not).
pub fn succeeds<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> std::process::Output {
    let out = haze().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Every file under `dir` (recursively) with its bytes: compared before and after a run,
/// it shows that no input changed and nothing was left behind.
pub fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else {
                let bytes = std::fs::read(&p).unwrap_or_default();
                files.insert(p, bytes);
            }
        }
    }
    files
}

/// What a failed run printed, after checking the promise: exit status 1 or 2, exactly
/// one line on stderr starting `error:`, no panic, and `dir` exactly as it was.
pub fn refused(dir: &Path, args: &[&str]) -> String {
    let before = snapshot(dir);
    let out = haze().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        matches!(out.status.code(), Some(1 | 2)),
        "{args:?}: status {:?}: {err}",
        out.status.code()
    );
    assert_eq!(err.lines().count(), 1, "{args:?}: not one line: {err}");
    assert!(err.starts_with("error: "), "{args:?}: {err}");
    assert!(
        !err.contains("panicked") && !err.contains("internal error"),
        "{args:?}: {err}"
    );
    let after = snapshot(dir);
    let changed: Vec<_> = before
        .iter()
        .filter(|(p, b)| after.get(*p) != Some(*b))
        .map(|(p, _)| p)
        .collect();
    assert!(changed.is_empty(), "{args:?}: inputs touched: {changed:?}");
    let new: Vec<_> = after.keys().filter(|p| !before.contains_key(*p)).collect();
    assert!(new.is_empty(), "{args:?}: left behind: {new:?}");
    err
}

/// Writes a `.npy` of `f32` values shaped `(z, y, x)` = `dims` reversed.
pub fn write_npy(path: &Path, dims: [usize; 3], values: &[f32]) {
    let dict = format!(
        "{{'descr': '<f4', 'fortran_order': False, 'shape': ({}, {}, {}), }}",
        dims[2], dims[1], dims[0]
    );
    let mut header = dict.into_bytes();
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(b' ');
    }
    header.push(b'\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(&header);
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(path, bytes).unwrap();
}

/// A smooth blob on an `n³` grid, its peak 1 (a frame a few RBFs fit at once).
pub fn blob(n: usize) -> Vec<f32> {
    let c = (n as f32 - 1.0) / 2.0;
    let mut v = Vec::with_capacity(n * n * n);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let d2 = [x, y, z]
                    .iter()
                    .map(|&i| (i as f32 - c).powi(2))
                    .sum::<f32>();
                v.push((-d2 / (0.1 * (n * n) as f32)).exp());
            }
        }
    }
    v
}

/// Writes raw frame `STEM.f32` with its sidecar over the unit cube.
pub fn write_raw(stem: &Path, n: usize, values: &[f32]) {
    let bytes: Vec<u8> = values.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(stem.with_extension("f32"), bytes).unwrap();
    std::fs::write(
        stem.with_extension("json"),
        format!(
            r#"{{"dims": [{n}, {n}, {n}], "world_bbox_min": [0,0,0], "world_bbox_max": [1,1,1]}}"#
        ),
    )
    .unwrap();
}

/// A small analytic-fog scene (paper D) whose medium is `medium` (a JSON object).
pub fn fog_scene(medium: &str) -> String {
    format!(
        r#"{{
  "camera": {{"eye": [0, -6, 1.5], "target": [0, 0, 1], "width": 8, "height": 6}},
  "lights": [{{"type": "point", "position": [1, -1, 2], "intensity": [5, 5, 5]}}],
  "media": [{medium}],
  "surfaces": [{{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": {{"diffuse": [0.5, 0.5, 0.5]}}}}]
}}"#
    )
}

/// The analytic medium of [`fog_scene`] with `sigma_t` and a constant term of `weight`.
pub fn analytic(sigma_t: &str, weight: &str) -> String {
    format!(
        r#"{{"type": "analytic", "sigma_t": {sigma_t}, "terms": [{{"type": "constant", "weight": {weight}}}]}}"#
    )
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
