//! The rasterized scene renderer (`haze_scene::gpu::raster`) against the ray-traced one on the
//! GPU and the CPU's visibility, on small scenes holding a plane, spheres and glTF meshes
//! (smooth and faceted), lit by point lights and a sun whose shadow rays cross them.
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.
//!
//! **Which pixels.** The rasterizer decides that a pixel's ray meets a primitive by its
//! coverage rule (the pixel center inside the projected triangle, ties by the top-left
//! rule), the ray tracer by its edge tests: the same test, rounded differently, so a pixel
//! whose center lies within rounding of a silhouette or of a faceted mesh's edge may see
//! the neighbouring primitive and differ by whole terms. The comparison takes the
//! *interior* pixels: those whose 3 × 3 neighbourhood sees one surface (or none) on the
//! CPU (`Scene::intersect` in `f64`, independent of both GPU paths). On them the raster
//! pass's surface must be the CPU's, exactly; the others are counted and printed (none
//! differed on lavapipe), and must be at most a quarter of the image, so the check covers
//! most of it.
//!
//! **Tolerance.** On interior pixels both GPU paths run the same `f32` operations on the
//! same primitive — the raster pass's fragment intersects the pixel's ray as the ray
//! tracer does, the shading pass is `render.wgsl`'s — in another stage, where the
//! compiler may contract them differently (fused multiply–adds): a few ulp in the hit's
//! distance, ~10⁻⁶ relative in the picture. Per pixel and channel `|L_raster − L_traced| ≤
//! REL·|L_traced| + FLOOR·L̄`, `L̄` the traced image's mean; `REL = 10⁻⁴` (measured on
//! lavapipe: 0, the pictures bit-identical, printed per case), `FLOOR = 10⁻⁶`.

use haze_gpu::GpuContext;
use haze_scene::gpu::GpuRenderer;
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::Analytic;
use haze_scene::{Scene, mesh::model};

mod common;
use common::context;

const REL: f64 = 1e-4;
const FLOOR: f64 = 1e-6;

const SCENE: &str = r#"{
    "camera": {"eye": [0, -6, 1.6], "target": [0, 0, 0.8], "fov": 55, "width": 64, "height": 48},
    "environment": [0.1, 0.12, 0.15],
    "lights": [
        {"type": "sun", "direction": [0.4, -0.3, 0.8], "radiance": [0.8, 0.8, 0.7], "angle": 0},
        {"type": "point", "position": [-1.2, -0.5, 1.8], "intensity": [6, 5, 4]},
        {"type": "point", "position": [1.5, 1.0, 0.6], "intensity": [1, 2, 4]}
    ],
    "media": [{"type": "homogeneous", "sigma_t": 0.25, "albedo": 0.9}],
    "surfaces": [
        {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": {"diffuse": [0.6, 0.6, 0.6]}},
        {"type": "sphere", "center": [0.2, 0.8, 0.7], "radius": 0.7,
         "material": {"diffuse": [0.7, 0.3, 0.2], "specular": [0.3, 0.3, 0.3], "shininess": 12}},
        {"type": "mesh", "path": "smooth.glb", "transform": {"translate": [-0.9, 0.1, 0.6]},
         "material": {"diffuse": [0.3, 0.6, 0.2], "specular": [0.3, 0.3, 0.3], "shininess": 12}},
        {"type": "mesh", "path": "faceted.glb",
         "transform": {"translate": [1.1, -0.6, 0.5], "rotate": [1, 1, 0, 35], "scale": [1, 1, 1.4]}}
    ]
}"#;

/// The scene with `edits` (text replacements), its meshes written next to it.
fn load(dir: &std::path::Path, edits: &[(&str, &str)]) -> Scene {
    let smooth = model::uv_sphere([0.0, 0.0, 0.0], 0.6, 8, [0.7, 0.3, 0.2]);
    let mut faceted = model::uv_sphere([0.0, 0.0, 0.0], 0.5, 5, [0.2, 0.5, 0.7]);
    faceted.normals = None;
    std::fs::write(dir.join("smooth.glb"), model::glb(&smooth)).unwrap();
    std::fs::write(dir.join("faceted.glb"), model::glb(&faceted)).unwrap();
    let mut text = SCENE.to_string();
    for (from, to) in edits {
        assert!(text.contains(from), "{from}");
        text = text.replacen(from, to, 1);
    }
    let path = dir.join("scene.json");
    std::fs::write(&path, text).unwrap();
    haze_scene::load(&path).unwrap()
}

/// The surface the CPU sees at each pixel (`f64`), row by row.
fn cpu_surfaces(scene: &Scene) -> Vec<Option<usize>> {
    let cam = &scene.camera;
    let far = scene.environment_distance;
    let t_max = if far.is_finite() { far } else { f64::INFINITY };
    (0..cam.height)
        .flat_map(|y| (0..cam.width).map(move |x| (x, y)))
        .map(|(x, y)| {
            scene
                .intersect(cam.eye, cam.pixel_ray(x, y), 0.0, t_max)
                .map(|h| h.surface)
        })
        .collect()
}

/// Whether every pixel of the 3 × 3 neighbourhood of `(x, y)` (inside the image) sees the
/// surface `(x, y)` sees.
fn interior(ids: &[Option<usize>], w: usize, h: usize, x: usize, y: usize) -> bool {
    let c = ids[y * w + x];
    (y.saturating_sub(1)..(y + 2).min(h))
        .all(|j| (x.saturating_sub(1)..(x + 2).min(w)).all(|i| ids[j * w + i] == c))
}

/// Compares the rasterized picture with the ray-traced one (module docs).
fn compare(ctx: &GpuContext, gpu: &GpuRenderer, name: &str, scene: &Scene) {
    let lim = Limits::default();
    let traced = gpu.render(ctx, scene, &lim).unwrap();
    let (raster, seen) = gpu
        .render_rasterized_with_surfaces(ctx, scene, &lim)
        .unwrap();
    let (w, h) = (scene.camera.width, scene.camera.height);
    assert_eq!((raster.width, raster.height), (w, h));
    let cpu = cpu_surfaces(scene);
    let mean = traced
        .pixels
        .iter()
        .flat_map(|p| p.iter().map(|&v| f64::from(v)))
        .sum::<f64>()
        / (3 * w * h) as f64;
    assert!(mean > 0.0, "{name}: a black image tests nothing");
    let (mut edge, mut edge_differ, mut worst) = (0, 0, 0.0f64);
    let mut kinds = std::collections::BTreeSet::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let (r, t) = (raster.pixels[i], traced.pixels[i]);
            assert!(
                r.iter().all(|v| v.is_finite() && *v >= 0.0),
                "{name}: pixel {i} is {r:?}"
            );
            if !interior(&cpu, w, h, x, y) {
                edge += 1;
                edge_differ += usize::from(r != t);
                continue;
            }
            assert_eq!(seen[i], cpu[i], "{name}: surface at pixel ({x}, {y})");
            kinds.insert(cpu[i]);
            for k in 0..3 {
                let (a, b) = (f64::from(r[k]), f64::from(t[k]));
                let d = (a - b).abs();
                worst = worst.max(d / (b.abs() + FLOOR * mean));
                assert!(
                    d <= REL * b.abs() + FLOOR * mean,
                    "{name}: pixel ({x}, {y}) channel {k}: rasterized {a}, ray-traced {b}"
                );
            }
        }
    }
    println!(
        "{name}: worst relative difference {worst:.2e} on {} interior pixels; {edge} pixels at edges, {edge_differ} of them differ",
        w * h - edge
    );
    assert!(
        4 * edge <= w * h,
        "{name}: {edge} of {} pixels at edges",
        w * h
    );
    // The plane, the sphere, both meshes and the background all checked.
    assert_eq!(kinds.len(), 5, "{name}: surfaces seen {kinds:?}");
}

/// Plane, sphere and meshes in fog, from afar and with the eye close to the smooth mesh
/// (its triangles near the view's edge, some crossing the eye's plane), and with the
/// environment 7 units away, cutting the plane off in the distance.
#[test]
fn rasterized_surfaces_match_the_ray_tracer() {
    let ctx = context();
    let dir = tempfile::tempdir().unwrap();
    let base = load(dir.path(), &[]);
    let gpu = GpuRenderer::new(ctx, &Analytic::new(&base)).unwrap();
    compare(ctx, &gpu, "plane, sphere, meshes", &base);
    let near = load(
        dir.path(),
        &[
            ("\"eye\": [0, -6, 1.6]", "\"eye\": [-0.4, -1.2, 1.0]"),
            ("\"target\": [0, 0, 0.8]", "\"target\": [0, 0.5, 0.6]"),
        ],
    );
    compare(ctx, &gpu, "eye close to a mesh", &near);
    let far = load(
        dir.path(),
        &[(
            "\"environment\": [0.1, 0.12, 0.15]",
            "\"environment\": \"sky\", \"environment_distance\": 7",
        )],
    );
    compare(ctx, &gpu, "environment at 7", &far);
}

/// A scene without surfaces draws nothing and shades the background as the ray tracer.
#[test]
fn rasterized_without_surfaces_is_the_fog_alone() {
    let ctx = context();
    let dir = tempfile::tempdir().unwrap();
    let mut s = load(dir.path(), &[]);
    s.surfaces.clear();
    let gpu = GpuRenderer::new(ctx, &Analytic::new(&s)).unwrap();
    let lim = Limits::default();
    let traced = gpu.render(ctx, &s, &lim).unwrap();
    let (raster, seen) = gpu.render_rasterized_with_surfaces(ctx, &s, &lim).unwrap();
    assert!(seen.iter().all(Option::is_none));
    assert_eq!(raster.pixels, traced.pixels);
}
