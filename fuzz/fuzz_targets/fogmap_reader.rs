//! Any bytes read as a fogmap (PNG, OpenEXR, NumPy, or raw f32 with its sidecar: the
//! first byte picks the format, a raw map's sidecar is the text before the first NUL)
//! yield a fogmap of finite, non-negative values or an error.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("haze-fuzz-fogmap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let ext = ["png", "exr", "npy", "f32"][usize::from(pick % 4)];
    let path = dir.join(format!("m.{ext}"));
    let body = if ext == "f32" {
        let cut = rest.iter().position(|&b| b == 0).unwrap_or(rest.len());
        std::fs::write(dir.join("m.json"), &rest[..cut]).unwrap();
        &rest[(cut + 1).min(rest.len())..]
    } else {
        rest
    };
    std::fs::write(&path, body).unwrap();
    if let Ok(map) = haze_wavelet::Fogmap::load(&path) {
        assert_eq!(map.values.len(), map.width * map.height);
        assert!(map.values.iter().all(|v| v.is_finite() && *v >= 0.0));
    }
});
