//! Any text given to the scene-file parser yields a scene or a one-line error.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Err(e) = haze_scene::file::parse(text) {
            assert!(!e.contains('\n'), "a two-line error: {e}");
        }
    }
});
