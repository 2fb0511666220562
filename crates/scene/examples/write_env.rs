//! Writes the bundled environment map `data/scenes/glow_env.exr`: a 128×64 lat-long
//! HDR sky (crates/view's convention) — a zenith-to-horizon gradient, a dim ground, a
//! bright sun and two coloured lamps near the horizon, Gaussian spots of 0.12–0.2 rad —
//! for the environment-glow scene `data/scenes/glow.json`. (A sharp sun belongs in the
//! scene's lights, which are exact; the environment's glow is in SH.)
//!
//! `cargo run -p haze-scene --example write_env -- data/scenes/glow_env.exr`

use haze_view::distant::{LatLong, direction};

fn main() {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "data/scenes/glow_env.exr".to_string());
    let (w, h) = (128, 64);
    // (direction, angular width w, peak radiance) of the spots `peak·e^{−(γ/w)²}`.
    let spots: [([f64; 3], f64, [f64; 3]); 3] = [
        (direction(0.9, 1.2), 0.12, [20.0, 18.0, 15.0]),
        (direction(1.45, 3.6), 0.2, [6.0, 2.5, 1.0]),
        (direction(1.4, 5.2), 0.2, [1.0, 2.5, 7.0]),
    ];
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let theta = std::f64::consts::PI * (y as f64 + 0.5) / h as f64;
            let phi = 2.0 * std::f64::consts::PI * (x as f64 + 0.5) / w as f64;
            let d = direction(theta, phi);
            let mut l = if d[2] >= 0.0 {
                [0, 1, 2].map(|c| [0.7, 0.75, 0.8][c] * (1.0 - d[2]) + [0.2, 0.35, 0.7][c] * d[2])
            } else {
                [0.15, 0.13, 0.12]
            };
            for (s, width, peak) in &spots {
                let cos = d[0] * s[0] + d[1] * s[1] + d[2] * s[2];
                let gamma = cos.clamp(-1.0, 1.0).acos();
                let f = (-(gamma / width) * (gamma / width)).exp();
                for c in 0..3 {
                    l[c] += peak[c] * f;
                }
            }
            texels.push(l.map(|v| v as f32));
        }
    }
    let map = LatLong::new(w, h, texels).expect("valid map");
    let image = haze_view::Image {
        width: map.width,
        height: map.height,
        pixels: map.texels,
    };
    image
        .write_exr(std::path::Path::new(&path))
        .unwrap_or_else(|e| panic!("{path}: {e}"));
    println!("wrote {path}: {w}×{h}");
}
