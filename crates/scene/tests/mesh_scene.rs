//! Mesh surfaces in scene files: glTF models read in all three containers (GLB, `.gltf`
//! with an external buffer, `.gltf` with an embedded data URI), node and scene-file
//! transforms applied, bad models refused in one line, and a tessellated sphere rendered
//! against the analytic sphere it approximates.

use haze_scene::mesh::model::{self, TriangleList};
use haze_scene::render::{Analytic, render};
use haze_scene::{Scene, Shape, file};
use std::path::Path;

/// A small list: a tetrahedron's four faces, without normals.
fn tetra() -> TriangleList {
    TriangleList {
        positions: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        normals: None,
        indices: vec![0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3],
        base_color: [0.2, 0.4, 0.6],
    }
}

/// Standard base64 (RFC 4648) with padding, for the data-URI case.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                out.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A scene around one mesh surface at `path` with the given extra keys.
fn scene_text(path: &str, extra: &str) -> String {
    format!(
        r#"{{"camera": {{"eye": [0, -6, 1], "target": [0, 0, 0.5], "width": 8, "height": 6}},
            "surfaces": [{{"type": "mesh", "path": "{path}"{extra}}}]}}"#
    )
}

fn load(dir: &Path, text: &str) -> Result<Scene, String> {
    let path = dir.join("scene.json");
    std::fs::write(&path, text).unwrap();
    file::load(&path).map_err(|e| e.to_string())
}

/// Every triangle corner of the scene's meshes, sorted.
fn corners(scene: &Scene) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for s in &scene.surfaces {
        let Shape::Mesh(m) = &s.shape else {
            panic!("not a mesh")
        };
        out.extend(m.triangles.iter().flat_map(|t| t.p));
    }
    out.sort_by(|a, b| a.partial_cmp(b).unwrap());
    out
}

#[test]
fn all_three_containers_read_the_same_triangles_placed_by_both_transforms() {
    let dir = tempfile::tempdir().unwrap();
    let list = tetra();
    std::fs::create_dir(dir.path().join("models")).unwrap();
    std::fs::write(dir.path().join("models/a.glb"), model::glb(&list)).unwrap();
    let (json, bin) = model::encode(&list, Some("a.bin"));
    std::fs::write(dir.path().join("models/a.gltf"), &json).unwrap();
    std::fs::write(dir.path().join("models/a.bin"), &bin).unwrap();
    let uri = format!("data:application/octet-stream;base64,{}", base64(&bin));
    let (json, _) = model::encode(&list, Some(&uri));
    std::fs::write(dir.path().join("models/b.gltf"), &json).unwrap();

    // Scene-file transform: scale 2, a quarter turn about z, then a shift.
    let extra = r#", "transform": {"translate": [1, 2, 3], "rotate": [0, 0, 1, 90], "scale": 2}"#;
    let placed = |p: [f32; 3]| {
        let (x, y, z) = (2.0 * p[0] as f64, 2.0 * p[1] as f64, 2.0 * p[2] as f64);
        [1.0 - y, 2.0 + x, 3.0 + z]
    };
    let mut want: Vec<[f64; 3]> = list
        .indices
        .iter()
        .map(|&i| placed(list.positions[i as usize]))
        .collect();
    want.sort_by(|a, b| a.partial_cmp(b).unwrap());
    for name in ["models/a.glb", "models/a.gltf", "models/b.gltf"] {
        let scene = load(dir.path(), &scene_text(name, extra)).unwrap();
        assert_eq!(scene.surfaces.len(), 1, "{name}");
        // No material in the scene file: the glTF's base colour.
        assert_eq!(
            scene.surfaces[0].material.diffuse,
            [0.2f32, 0.4, 0.6].map(f64::from)
        );
        let got = corners(&scene);
        assert_eq!(got.len(), 12, "{name}");
        for (g, w) in got.iter().zip(&want) {
            assert!(
                (0..3).all(|k| (g[k] - w[k]).abs() < 1e-12),
                "{name}: {g:?} vs {w:?}"
            );
        }
    }

    // A node hierarchy: the mesh under a parent translated by (1, 0, 0), itself scaled
    // by 3 about its own origin: x ↦ (1, 0, 0) + 3·x.
    let (json, bin) = model::encode(&list, Some("a.bin"));
    let json = json.replace(
        r#""scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}]"#,
        r#""scenes":[{"nodes":[0]}],"nodes":[{"children":[1],"translation":[1,0,0]},{"mesh":0,"scale":[3,3,3]}]"#,
    );
    std::fs::write(dir.path().join("models/c.gltf"), &json).unwrap();
    std::fs::write(dir.path().join("models/a.bin"), &bin).unwrap();
    let material = r#", "material": {"diffuse": [0.5, 0.5, 0.5]}"#;
    let scene = load(dir.path(), &scene_text("models/c.gltf", material)).unwrap();
    assert_eq!(scene.surfaces[0].material.diffuse, [0.5; 3]);
    let got = corners(&scene);
    let mut want: Vec<[f64; 3]> = list
        .indices
        .iter()
        .map(|&i| {
            let p = list.positions[i as usize].map(f64::from);
            [1.0 + 3.0 * p[0], 3.0 * p[1], 3.0 * p[2]]
        })
        .collect();
    want.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(got, want);
}

#[test]
fn bad_models_are_one_line_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("text.glb"), "hello, not a model").unwrap();
    let (json, bin) = model::encode(&tetra(), Some("p.bin"));
    // POINTS mode: no triangles at all.
    let points = json.replace(r#""material":0"#, r#""material":0,"mode":0"#);
    std::fs::write(d.join("points.gltf"), points).unwrap();
    std::fs::write(d.join("p.bin"), bin).unwrap();
    // An empty index accessor (glTF requires count ≥ 1).
    let empty = json.replace(
        r#""count":12,"type":"SCALAR""#,
        r#""count":0,"type":"SCALAR""#,
    );
    assert_ne!(empty, json);
    std::fs::write(d.join("empty.gltf"), empty).unwrap();
    let mut nan = tetra();
    nan.positions[2][1] = f32::NAN;
    std::fs::write(d.join("nan.glb"), model::glb(&nan)).unwrap();
    let (json, _) = model::encode(&tetra(), Some("gone.bin"));
    std::fs::write(d.join("nobuffer.gltf"), json).unwrap();
    let cases = [
        ("missing.glb", "", "missing.glb: no such model file"),
        ("text.glb", "", "text.glb: not a glTF 2.0 model"),
        ("points.gltf", "", "points.gltf: no triangles"),
        (
            "empty.gltf",
            "",
            "empty.gltf: mesh 0 primitive 0: accessor 1 is empty",
        ),
        (
            "nan.glb",
            "",
            "nan.glb: mesh 0 primitive 0: positions must be finite",
        ),
        (
            "nobuffer.gltf",
            "",
            "nobuffer.gltf: cannot read its buffers",
        ),
        (
            "nan.glb",
            r#", "transform": {"scale": [1, 0, 1]}"#,
            "transform.scale [1.0, 0.0, 1.0] must not be zero",
        ),
        (
            "nan.glb",
            r#", "transform": {"rotate": [0, 0, 0, 30]}"#,
            "the axis must not be zero",
        ),
        (
            "nan.glb",
            r#", "transform": {"shear": 1}"#,
            "unknown field `shear`",
        ),
    ];
    for (name, extra, needle) in cases {
        let e = load(d, &scene_text(name, extra)).unwrap_err();
        assert!(!e.contains('\n'), "not one line: {e}");
        assert!(e.contains("scene.json: surfaces[0]: "), "{e}");
        assert!(e.contains(needle), "{name}: {e}");
    }
}

/// The tessellated sphere against the analytic one, in fog under a point light and a
/// sun, on the CPU: the same image but for the silhouette and the shadow's edge.
///
/// **Tolerance.** The mesh (48 rings, unit radius) is inscribed: its points lie within
/// `δ ≈ π²/(4·48²) = 1.1·10⁻³` inside the sphere, its interpolated normals within
/// `≈ δ` rad of the sphere's. A diffuse point's radiance changes with its distance to the
/// lights and eye (relative `δ/d`, `d ≥ 1.5`) and with `cos θ` (relative `δ·tan θ`), so
/// away from the terminator (`θ < 84°`, `tan θ < 10`) pixels agree within `~10⁻²`. Pixels
/// whose ray or shadow ray takes a different branch (silhouette, shadow edge, terminator)
/// differ by whole terms: at most 2 % of them may (0.1 % did), and the image's relative
/// RMS difference must stay below 2 % (measured: 0.8 %).
#[test]
fn a_tessellated_sphere_renders_like_the_analytic_one() {
    let dir = tempfile::tempdir().unwrap();
    let rings = 48;
    let list = model::uv_sphere([0.0, 0.0, 1.0], 1.0, rings, [0.7, 0.5, 0.3]);
    std::fs::write(dir.path().join("ball.glb"), model::glb(&list)).unwrap();
    let base = |ball: &str| {
        format!(
            r#"{{"camera": {{"eye": [0.5, -4.5, 2.0], "target": [0, 0, 0.8], "fov": 45, "width": 64, "height": 48}},
            "environment": [0.05, 0.05, 0.06],
            "lights": [{{"type": "point", "position": [-2, -1.5, 3], "intensity": [8, 7, 6]}},
                       {{"type": "sun", "direction": [1, -0.5, 1], "radiance": [0.6, 0.6, 0.6], "angle": 0}}],
            "media": [{{"type": "homogeneous", "sigma_t": 0.1, "albedo": 0.8}}],
            "surfaces": [{{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": {{"diffuse": [0.5, 0.5, 0.5]}}}},
                         {ball}]}}"#
        )
    };
    let material = r#""material": {"diffuse": [0.7, 0.5, 0.3]}"#;
    let sphere = load(
        dir.path(),
        &base(&format!(
            r#"{{"type": "sphere", "center": [0, 0, 1], "radius": 1, {material}}}"#
        )),
    )
    .unwrap();
    let mesh = load(
        dir.path(),
        &base(&format!(
            r#"{{"type": "mesh", "path": "ball.glb", {material}}}"#
        )),
    )
    .unwrap();
    let Shape::Mesh(m) = &mesh.surfaces[1].shape else {
        panic!("not a mesh")
    };
    assert_eq!(m.triangles.len(), list.indices.len() / 3);
    let lim = Default::default();
    let a = render(&sphere, &Analytic::new(&sphere), &lim, &|_| {});
    let b = render(&mesh, &Analytic::new(&mesh), &lim, &|_| {});
    let (mut bad, mut worst) = (0, 0.0f64);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let e = (0..3)
            .map(|c| (p[c] - q[c]).abs() as f64 / (p[c] as f64).abs().max(1e-3))
            .fold(0.0, f64::max);
        if e > 1e-2 {
            bad += 1;
        } else {
            worst = worst.max(e);
        }
    }
    let share = bad as f64 / a.pixels.len() as f64;
    println!(
        "{} triangles: {:.2} % of pixels differ by > 1 %, the rest by at most {worst:.2e}; rel RMS {:.2e}",
        m.triangles.len(),
        100.0 * share,
        b.rel_rms(&a)
    );
    assert!(share <= 0.02, "{share}");
    assert!(b.rel_rms(&a) < 0.02);
}
