//! Paper B's GPU renderer against its CPU twin (`paper_b::render`), pixel by pixel, on
//! small images: a cloud of 100 Gaussians with two point lights, the same with a sun, a
//! background and a homogeneous medium, dense Gaussians with a light beside one, an
//! empty Gaussian medium, the eye inside the cloud (the dense cloud's pairs and the wide
//! scene's light inside a Gaussian take the integrated path,
//! `haze_gaussians::integrated`, whose 6-node rule and hosts the shader repeats in `f32`), two noisy media (§5.5), the sky
//! through the average optical depth (§4.2; the others have a faint constant
//! environment) and dense Gaussians' exact shadow on the sky at the surfaces (the CPU's
//! table, `paper_b::sky_grid`), and for the shader's tile lists a wide sparse scene (most Gaussians
//! outside a tile's cone, most far from its surface points), a Gaussian covering the
//! view with a light inside it, and none at all.
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe) and fail with the
//! reason when there is none.
//!
//! **Tolerance.** Per pixel and channel `|L_gpu − L_cpu| ≤ REL·|L_cpu| + FLOOR·L̄`, `L̄`
//! the CPU image's mean. The GPU computes in `f32` what the CPU computes in `f64`, with
//! Abramowitz–Stegun's erf (absolute `1.5·10⁻⁷`, so a relative error of the line
//! integrals up to ~`10⁻⁴` where an erf difference is small, e.g. short or grazing
//! crossings) for libm's, and sums the `T(s,p)` of every Gaussian within `√40` radii of
//! a tile's shadow segments where the CPU drops those below `10⁻¹⁰`; paper C's part is
//! the same as `gpu_render.rs`'s (`5·10⁻⁴`). The tile lists drop only Gaussians the
//! pixels' own tests drop; the far Gaussians' `T̄(p)` by the tile's Taylor expansion is
//! within `10⁻³` of their share (in the wide scene a 1 % error of that share moves the
//! worst pixel by `7·10⁻⁵`, so the bound is far inside the tolerance; dropping every
//! Gaussian from the shadow lists fails it).
//! With noise the shader looks the Perlin field up at an `f32` point (relative rounding
//! ~`10⁻⁷`, the field's gradient bounded), which moves the perturbed direction by
//! ~`10⁻⁷·gain·rᵢ/|v − bᵢ|`, far below the rest. Measured on lavapipe: at most 1.5·10⁻⁵
//! (printed per case, the noise case included); `REL = 2·10⁻⁴` leaves a margin above ten, `FLOOR = 10⁻⁴` keeps values far below the image's from counting;
//! at most `OUTLIERS` of the pixels may take other discrete decisions (silhouettes,
//! shadow rays grazing an occluder; none did).

use haze_gaussians::cloud;
use haze_scene::gpu::GpuRenderer;
use haze_scene::gpu::paper_b::GpuPaperB;
use haze_scene::paper_b::{self, PaperBOptions, Prepared};
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::{Analytic, Image};
use haze_scene::{Scene, file};
use std::sync::OnceLock;

mod common;
use common::{Tolerance, assert_agree, context};

const REL: f64 = 2e-4;
const FLOOR: f64 = 1e-4;
const OUTLIERS: f64 = 0.01;

fn scene(lights: &str, media: &str, eye: &str) -> Scene {
    let text = format!(
        r#"{{
        "camera": {{"eye": {eye}, "target": [0, 0, 1.0], "fov": 50, "width": 24, "height": 18}},
        "environment": [0.05, 0.06, 0.08],
        "lights": [{lights}],
        "media": [{media}],
        "surfaces": [
            {{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": {{"diffuse": [0.6, 0.6, 0.6]}}}},
            {{"type": "sphere", "center": [0.9, 0.8, 0.5], "radius": 0.5,
             "material": {{"diffuse": [0.7, 0.3, 0.2], "specular": [0.3, 0.3, 0.3], "shininess": 20}}}}
        ]
    }}"#
    );
    file::parse(&text).unwrap()
}

const POINTS: &str = r#"{"type": "point", "position": [-1.6, -0.8, 2.6], "intensity": [8, 7, 6]},
    {"type": "point", "position": [1.8, 1.0, 0.9], "intensity": [2, 3, 6]}"#;

fn gaussians(n: usize, tau: f64, extra: &str) -> String {
    let gs = cloud::ball(n, 42, [0.0, 0.0, 1.0], 1.2, (0.2, 0.35), tau, 2.0);
    let list: Vec<String> = gs
        .iter()
        .map(|g| {
            format!(
                r#"{{"center": [{}, {}, {}], "radius": {}, "weight": {}}}"#,
                g.center[0], g.center[1], g.center[2], g.radius, g.weight
            )
        })
        .collect();
    format!(
        r#"{{"type": "gaussians", "sigma_t": 2, "albedo": 0.9{extra}, "gaussians": [{}]}}"#,
        list.join(", ")
    )
}

/// Paper C's tables for every scene here (one Phong exponent, 20), built once, and their
/// GPU upload.
fn tables() -> &'static (Analytic, GpuRenderer) {
    static T: OnceLock<(Analytic, GpuRenderer)> = OnceLock::new();
    T.get_or_init(|| {
        let a = Analytic::new(&scene(POINTS, "", "[0, -6, 1.6]"));
        let g = GpuRenderer::new(context(), &a).unwrap();
        (a, g)
    })
}

/// Compares the two renders of `s`; the CPU's image.
fn compare(name: &str, s: &Scene) -> Image {
    compare_with(name, s, OUTLIERS)
}

/// [`compare`] with at most `outliers` of the pixels allowed to differ.
fn compare_with(name: &str, s: &Scene, outliers_allowed: f64) -> Image {
    let (analytic, tables) = tables();
    // The device's options (fewer Gaussians exact per pair on lavapipe), the CPU twin
    // prepared with the same.
    let prep = Prepared::new(s, analytic, haze_scene::gpu::paper_b::options(context())).unwrap();
    let (k, n) = prep.integrated_pairs();
    println!("{name}: {k} of {n} light–gaussian pairs integrated along the ray");
    let lim = Limits::default();
    let cpu = paper_b::render(&prep, &lim, &|_| {});
    let gpu = GpuPaperB::new(context())
        .unwrap()
        .render(context(), tables, &prep, &lim)
        .unwrap();
    assert_agree(
        name,
        &gpu,
        &cpu,
        Tolerance::new(REL, FLOOR, outliers_allowed),
    );
    cpu
}

#[test]
fn cloud_with_point_lights() {
    compare(
        "cloud",
        &scene(POINTS, &gaussians(100, 0.1, ""), "[0, -6, 1.6]"),
    );
}

#[test]
fn sun_background_and_homogeneous_medium() {
    let lights = format!(
        r#"{POINTS}, {{"type": "sun", "direction": [0.3, -0.2, 1], "radiance": [2, 2, 2], "angle": 0}}"#
    );
    // A sun through the Gaussians alone, then with a background (which hides it) and a
    // homogeneous medium of another colour.
    compare(
        "sun",
        &scene(&lights, &gaussians(60, 0.1, ""), "[0, -6, 1.6]"),
    );
    let media = format!(
        r#"{{"type": "homogeneous", "sigma_t": [0.05, 0.1, 0.15], "albedo": 0.8}}, {}"#,
        gaussians(60, 0.1, r#", "background": 0.03"#)
    );
    compare("background", &scene(&lights, &media, "[0, -6, 1.6]"));
}

#[test]
fn sky_through_the_average_optical_depth() {
    // §4.2 on the GPU: the built-in sky lights the Gaussians and the (glossy) surfaces
    // through T̄, with and without the light scattered onto them; a sun beside it.
    let sun = r#"{"type": "sun", "direction": [0.48, 0.36, 0.8], "radiance": [20, 19, 17], "angle": 0.01}"#;
    let mut s = scene(sun, &gaussians(100, 0.1, ""), "[0, -6, 1.6]");
    s.environment = haze_scene::Environment::Sky;
    compare("sky", &s);
    let (analytic, tables) = tables();
    let prep = Prepared::new(
        &s,
        analytic,
        PaperBOptions {
            surface_scattering: false,
            ..haze_scene::gpu::paper_b::options(context())
        },
    )
    .unwrap();
    let lim = Limits::default();
    let cpu = paper_b::render(&prep, &lim, &|_| {});
    let gpu = GpuPaperB::new(context())
        .unwrap()
        .render(context(), tables, &prep, &lim)
        .unwrap();
    let e = gpu.rel_rms(&cpu);
    println!("sky without surface scattering: rel RMS {e:.2e}");
    assert!(e < REL, "{e}");
}

#[test]
fn dense_cloud_shadows_the_sky_on_the_surfaces() {
    // Dense Gaussians under the built-in sky: where e^{−T̄(p)}'s bound exceeds the target,
    // the floor and the sphere take the others' exact shadow on the sky from the CPU's
    // table (paper_b::sky_grid, 4-pixel grid), which the shader reads per pixel. The
    // table must move the picture (else this would not see a shader that ignores it).
    let mut s = scene("", &gaussians(40, 1.5, ""), "[0, -6, 1.6]");
    s.environment = haze_scene::Environment::Sky;
    let exact = compare("dense under the sky", &s);
    let (analytic, _) = tables();
    let mean = Prepared::new(
        &s,
        analytic,
        PaperBOptions {
            surface_sky: false,
            ..haze_scene::gpu::paper_b::options(context())
        },
    )
    .unwrap();
    let mean = paper_b::render(&mean, &Limits::default(), &|_| {});
    let moved = exact.rel_rms(&mean);
    println!("the exact shadow on the sky against e^(-T̄): rel RMS {moved:.4}");
    assert!(moved > 0.01, "{moved}");
}

#[test]
fn dense_cloud_inside_and_empty() {
    compare(
        "dense",
        &scene(POINTS, &gaussians(40, 1.5, ""), "[0, -6, 1.6]"),
    );
    compare(
        "eye inside",
        &scene(POINTS, &gaussians(100, 0.1, ""), "[0.1, -0.3, 1.1]"),
    );
    compare(
        "empty",
        &scene(
            POINTS,
            r#"{"type": "homogeneous", "sigma_t": 0.2, "albedo": 0.9}, {"type": "gaussians", "sigma_t": 1}"#,
            "[0, -6, 1.6]",
        ),
    );
}

#[test]
fn noise_of_two_media() {
    // Two media with their own seeds (two permutations on the GPU), an offset and a
    // frequency off the lattice; gain 0 for the same clouds without noise.
    let media = |gain: f64| {
        let noise = |seed: u32| {
            format!(
                r#", "noise": {{"seed": {seed}, "gain": {gain}, "frequency": 1.7, "offset": [0.3, -0.2, 0.5]}}"#
            )
        };
        format!(
            "{}, {}",
            gaussians(60, 0.4, &noise(7)),
            gaussians(30, 0.4, &noise(11))
        )
    };
    let noisy = compare("noise", &scene(POINTS, &media(3.0), "[0, -6, 1.6]"));
    let (analytic, _) = tables();
    let flat = scene(POINTS, &media(0.0), "[0, -6, 1.6]");
    let prep = Prepared::new(&flat, analytic, PaperBOptions::default()).unwrap();
    let plain = paper_b::render(&prep, &Limits::default(), &|_| {});
    // The noise moves far more than the tolerance: the comparison above sees it.
    let moved = noisy
        .pixels
        .iter()
        .zip(&plain.pixels)
        .filter(|(a, b)| (0..3).any(|k| (a[k] - b[k]).abs() > 10.0 * REL as f32 * b[k].abs()))
        .count();
    let share = moved as f64 / plain.pixels.len() as f64;
    println!("noise changes {share:.3} of the pixels by more than 10·REL");
    assert!(share > 0.2, "{share}");
}

/// A wide, sparse scene for the tile lists: `n` small Gaussians (radii 0.08–0.2, peak
/// depth 0.3) scattered over 16 × 16 × 1.6 above a floor seen from low down, with (when
/// `n > 0`) a tight ball of 150 more under the first light that shadows the floor; two
/// point lights (the first at the centre of `extra`'s Gaussian in the first case) and a
/// sun; `extra` Gaussians appended as JSON.
fn wide(n: usize, extra: &str) -> Scene {
    let mut u = cloud::Uniform::new(17);
    let mut list: Vec<String> = (0..n)
        .map(|_| {
            let c = [
                16.0 * u.sample() - 8.0,
                16.0 * u.sample() + 0.5,
                0.3 + 1.6 * u.sample(),
            ];
            let r = 0.08 + 0.12 * u.sample();
            // σt = 2: peak depth 2·w·√π·r = 0.3.
            let w = 0.3 / (2.0 * std::f64::consts::PI.sqrt() * r);
            format!(
                r#"{{"center": [{}, {}, {}], "radius": {r}, "weight": {w}}}"#,
                c[0], c[1], c[2]
            )
        })
        .collect();
    if n > 0 {
        for g in cloud::ball(150, 5, [-0.8, 2.2, 0.8], 0.5, (0.06, 0.12), 0.3, 2.0) {
            list.push(format!(
                r#"{{"center": [{}, {}, {}], "radius": {}, "weight": {}}}"#,
                g.center[0], g.center[1], g.center[2], g.radius, g.weight
            ));
        }
    }
    if !extra.is_empty() {
        list.push(extra.to_string());
    }
    let text = format!(
        r#"{{
        "camera": {{"eye": [0.3, -1.5, 0.9], "target": [0, 8, 0.6], "fov": 60, "width": 64, "height": 40}},
        "environment": "sky",
        "lights": [
            {{"type": "point", "position": [-1.0, 2.0, 1.4], "intensity": [3, 3, 2]}},
            {{"type": "point", "position": [1.2, 4.0, 0.8], "intensity": [1, 2, 3]}},
            {{"type": "sun", "direction": [0.3, 0.4, 0.866], "radiance": [10, 9, 8], "angle": 0.01}}
        ],
        "media": [{{"type": "gaussians", "sigma_t": 2, "albedo": 0.9, "gaussians": [{}]}}],
        "surfaces": [
            {{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": {{"diffuse": [0.6, 0.6, 0.6]}}}},
            {{"type": "sphere", "center": [0.9, 3.0, 0.5], "radius": 0.5,
             "material": {{"diffuse": [0.7, 0.3, 0.2], "specular": [0.3, 0.3, 0.3], "shininess": 20}}}}
        ]
    }}"#,
        list.join(", ")
    );
    file::parse(&text).unwrap()
}

#[test]
fn tiles_drop_most_gaussians_and_the_extremes() {
    // 1500 Gaussians of which a tile's cone meets a few dozen, the floor's tiles far from
    // most of them (T̄ through the tile's expansion); the first light sits at the centre
    // of one more Gaussian.
    let inside = r#"{"center": [-1.0, 2.0, 1.4], "radius": 0.3, "weight": 0.1}"#;
    // Every pixel within the tolerance but a few (2 of 2560) for silhouettes: a wrong cull
    // shows as a scatter of outliers, not as a worst case.
    compare_with("wide", &wide(1500, inside), 1e-3);
    // A Gaussian larger than the view, centred on the camera's target, the lights inside
    // it: with the tiles (191 Gaussians) and alone (the untiled pipeline, ≤ 32).
    let covering = r#"{"center": [0, 8, 0.6], "radius": 6, "weight": 0.02}"#;
    compare("covering, tiled", &wide(40, covering));
    compare("covering alone", &wide(0, covering));
    // No Gaussians: paper C's part alone.
    compare("none", &wide(0, ""));
}
