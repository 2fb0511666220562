//! The edited medium in the scene file: [`save`] writes a scene file whose `which`-th
//! `"gaussians"` medium lists the edited Gaussians (its `asset`, `frame` and `offset` keys
//! dropped: the asset's Gaussians are in the list now; every other key of the file kept),
//! through a temporary file beside the destination renamed over it; [`load`] reads the
//! Gaussians of a scene file's `which`-th Gaussian medium.

use crate::media::gaussians::GaussianMediumOf;
use crate::scene::Scene;
use haze_gaussians::Gaussian;
use serde_json::{Value, json};
use std::io::Write;
use std::path::Path;

/// The `which`-th Gaussian medium of a loaded scene.
pub fn medium_of(scene: &Scene, which: usize) -> Option<&GaussianMediumOf> {
    scene.gaussian_media().nth(which)
}

/// Writes the scene file `source` to `dest` (the same path or another; relative paths in
/// the file stay as written) with the `which`-th Gaussian medium's list replaced by
/// `gaussians`. The error is one line naming the file.
pub fn save(
    source: &Path,
    dest: &Path,
    which: usize,
    gaussians: &[Gaussian],
) -> Result<(), String> {
    let name = |p: &Path| p.display().to_string();
    let text = std::fs::read_to_string(source).map_err(|e| format!("{}: {e}", name(source)))?;
    let mut v: Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", name(source)))?;
    let media = v
        .get_mut("media")
        .and_then(Value::as_array_mut)
        .ok_or_else(|| format!("{}: no \"media\" list", name(source)))?;
    let m = media
        .iter_mut()
        .filter(|m| m.get("type").and_then(Value::as_str) == Some("gaussians"))
        .nth(which)
        .and_then(Value::as_object_mut)
        .ok_or_else(|| format!("{}: no Gaussian medium number {which}", name(source)))?;
    for key in ["asset", "frame", "offset"] {
        m.remove(key);
    }
    let list: Vec<Value> = gaussians
        .iter()
        .map(|g| json!({"center": g.center, "radius": g.radius, "weight": g.weight}))
        .collect();
    m.insert("gaussians".into(), Value::Array(list));
    let out = serde_json::to_string_pretty(&v).map_err(|e| e.to_string())?;
    write_atomically(dest, out.as_bytes()).map_err(|e| format!("{}: {e}", name(dest)))
}

/// Writes `bytes` to a temporary file beside `dest`, synced, then renames it to `dest`.
fn write_atomically(dest: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = match dest.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let file_name = dest
        .file_name()
        .map_or("scene".into(), |n| n.to_string_lossy());
    let tmp = dir.join(format!(".{file_name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, dest)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The Gaussians of the `which`-th Gaussian medium of the scene file `path`.
pub fn load(path: &Path, which: usize) -> Result<Vec<Gaussian>, String> {
    let scene = crate::load(path).map_err(|e| e.to_string())?;
    medium_of(&scene, which)
        .map(|m| m.medium.gaussians().to_vec())
        .ok_or_else(|| format!("{}: no Gaussian medium number {which}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bundled scene, edited (a Gaussian dropped, one added with awkward digits),
    /// saved elsewhere and loaded: the same Gaussians bit for bit, every other key kept;
    /// bad requests fail on one line naming the file, leaving no file behind.
    #[test]
    fn save_then_load_gives_the_edited_gaussians_back() {
        let src = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../data/scenes/gaussians.json"
        ));
        let mut gs = load(src, 0).unwrap();
        gs.remove(3);
        gs.push(Gaussian {
            center: [0.1 + 0.2, -1.0 / 3.0, 2f64.sqrt()],
            radius: std::f64::consts::PI / 10.0,
            weight: 1e-7 / 3.0,
        });
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("edited.json");
        save(src, &dest, 0, &gs).unwrap();
        assert_eq!(load(&dest, 0).unwrap(), gs);
        let (a, b) = (crate::load(src).unwrap(), crate::load(&dest).unwrap());
        assert_eq!(
            (&a.lights, &a.surfaces, &a.camera),
            (&b.lights, &b.surfaces, &b.camera)
        );
        let (ma, mb) = (medium_of(&a, 0).unwrap(), medium_of(&b, 0).unwrap());
        assert_eq!(
            (
                ma.medium.sigma_t,
                ma.medium.albedo,
                ma.noise.as_ref().map(|n| n.gain)
            ),
            (
                mb.medium.sigma_t,
                mb.medium.albedo,
                mb.noise.as_ref().map(|n| n.gain)
            )
        );
        let e = save(src, &dest, 1, &gs).unwrap_err();
        assert!(
            e.contains("gaussians.json: no Gaussian medium number 1"),
            "{e}"
        );
        let e = save(src, &dir.path().join("no/such/dir.json"), 0, &gs).unwrap_err();
        assert!(e.contains("dir.json"), "{e}");
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(left.len(), 1, "only edited.json");
    }
}
