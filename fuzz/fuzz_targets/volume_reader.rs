//! Any bytes read as a volume (OpenVDB, NumPy, or raw f32 with its sidecar: the first
//! byte picks the format, a raw volume's sidecar is the text before the first NUL)
//! yield a validated volume (finite, non-negative densities) or an error.
#![no_main]

use haze_volume::ImportOptions;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("haze-fuzz-volume-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let ext = ["vdb", "npy", "f32"][usize::from(pick % 3)];
    let path = dir.join(format!("v.{ext}"));
    let body = if ext == "f32" {
        let cut = rest.iter().position(|&b| b == 0).unwrap_or(rest.len());
        std::fs::write(dir.join("v.json"), &rest[..cut]).unwrap();
        &rest[(cut + 1).min(rest.len())..]
    } else {
        rest
    };
    std::fs::write(&path, body).unwrap();
    if let Ok(v) = haze_volume::import::import(&path, &ImportOptions::default()) {
        assert!(v.data().iter().all(|d| d.is_finite() && *d >= 0.0));
    }
});
