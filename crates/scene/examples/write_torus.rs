//! Writes the bundled low-poly model `data/scenes/torus.glb` (used by
//! `data/scenes/room_mesh.json`): a torus of major radius 0.5 and minor radius 0.18
//! around z, 16 × 8 quads (256 triangles) with vertex normals.
//!
//! ```text
//! cargo run -p haze-scene --example write_torus -- data/scenes/torus.glb
//! ```

use haze_scene::mesh::model::{TriangleList, glb};
use std::f32::consts::TAU;

fn main() {
    let Some(out) = std::env::args().nth(1) else {
        eprintln!("usage: write_torus OUT.glb");
        std::process::exit(2)
    };
    let (big, small, around, across) = (0.5f32, 0.18f32, 16u32, 8u32);
    let (mut positions, mut normals) = (Vec::new(), Vec::new());
    for i in 0..=around {
        let (s, c) = (TAU * i as f32 / around as f32).sin_cos();
        for j in 0..=across {
            let (sv, cv) = (TAU * j as f32 / across as f32).sin_cos();
            // The tube's unit normal, and the point `small` along it from the ring.
            let n = [cv * c, cv * s, sv];
            normals.push(n);
            positions.push([(big + small * cv) * c, (big + small * cv) * s, small * sv]);
        }
    }
    let at = |i: u32, j: u32| i * (across + 1) + j;
    let mut indices = Vec::new();
    for i in 0..around {
        for j in 0..across {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            indices.extend([a, b, c, a, c, d]);
        }
    }
    let list = TriangleList {
        positions,
        normals: Some(normals),
        indices,
        base_color: [0.85, 0.65, 0.2],
    };
    let bytes = glb(&list);
    // Temp file + rename: a reader never sees half a model.
    let tmp = format!("{out}.tmp");
    if let Err(e) = std::fs::write(&tmp, &bytes).and_then(|()| std::fs::rename(&tmp, &out)) {
        eprintln!("error: {out}: {e}");
        std::process::exit(1)
    }
    println!(
        "{out}: {} triangles, {} bytes",
        list.indices.len() / 3,
        bytes.len()
    );
}
