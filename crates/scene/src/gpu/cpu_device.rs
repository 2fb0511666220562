//! What the scene shaders can render on a CPU device (Mesa's lavapipe), whose driver ends
//! an invocation's loops silently after 65535 iterations in all (running eight pixels in
//! lock step, it counts the loops of untaken branches too): past that a picture comes out
//! dark with nothing said. A real GPU has no such limit, so these checks refuse only on a
//! CPU adapter, pointing to the CPU renderer, which takes any scene.
//!
//! The costs are models of the iterations an invocation takes, fitted on lavapipe
//! (llvmpipe, LLVM 15, 2-core AMD EPYC VM) to the first scenes whose `--gpu` pictures went
//! dark against the CPU renderer's (BENCHMARKS "Paper B and the march on a CPU adapter"),
//! each kept under [`LOOP_BUDGET`]. The march budgets its own steps per dispatch
//! ([`super::march::chunks`]).

use crate::scene::{Scene, Shape};
use haze_gpu::GpuError;

/// The loop iterations an invocation may be modelled to take on a CPU device: lavapipe's
/// 65535 less a margin for the model's error.
pub const LOOP_BUDGET: f64 = 60_000.0;

/// What a mesh costs a shadow ray against the cost of a sphere or a plane (its hierarchy's
/// nodes and triangles walked): fitted on the bundled torus, whose shading went dark with
/// 1000 lights over a plane but not with 256, nor 64 lights over eight tori.
pub const MESH_COST: f64 = 32.0;

/// The iterations a (light, surface) pair costs `render.wgsl`'s surface shading at a
/// pixel ([`shading_loops`]).
pub const SHADING_COST: f64 = 3.6;

/// The iterations a light costs the shading at a pixel beyond its shadow ray's surfaces
/// (its airlight and shading; [`shading_loops`]).
pub const LIGHT_COST: f64 = 30.0;

/// The iterations of `render.wgsl`'s shading at a pixel: `3.6·L·S + 30·L` for `L` lights and
/// `S` surfaces (a plane or a sphere 1, a mesh [`MESH_COST`]): every light's shadow ray
/// tests every surface. Measured with planes and spheres under point lights, 32 × 24: 128
/// lights × 129 surfaces and 250 × 55 equal the CPU's to `10⁻³`, 1000 × 1 to `10⁻⁶`; 300 × 55
/// 3.6 % off, 100 × 200 12 %, 8 × 4001 10 %, 170 × 170 24 %, 4000 × 9 41 %. Then, made after
/// the fit: 500 × 20 and 1500 × 1 right (`4·10⁻⁴`, `10⁻⁶`), 600 × 25 refused (1.8 % off).
pub fn shading_loops(scene: &Scene) -> f64 {
    let lights = scene.lights.len() as f64;
    lights * (SHADING_COST * surface_units(scene) + LIGHT_COST)
}

/// The scene's surfaces in units of a sphere's cost (a mesh [`MESH_COST`]).
fn surface_units(scene: &Scene) -> f64 {
    scene
        .surfaces
        .iter()
        .map(|s| match s.shape {
            Shape::Mesh(_) => MESH_COST,
            Shape::Plane { .. } | Shape::Sphere { .. } => 1.0,
        })
        .sum()
}

/// Refuses on a CPU device (`cpu`) a scene whose shading is over [`LOOP_BUDGET`]
/// ([`shading_loops`]).
pub fn check_shading(cpu: bool, scene: &Scene) -> Result<(), GpuError> {
    let loops = shading_loops(scene);
    if !cpu || loops <= LOOP_BUDGET {
        return Ok(());
    }
    let lights = scene.lights.len();
    let most = ((LOOP_BUDGET / lights as f64 - LIGHT_COST) / SHADING_COST)
        .floor()
        .max(0.0);
    let mesh_note = if scene
        .surfaces
        .iter()
        .any(|s| matches!(s.shape, Shape::Mesh(_)))
    {
        format!(", a mesh counting {MESH_COST}")
    } else {
        String::new()
    };
    Err(GpuError::Input(format!(
        "{lights} lights and {} surfaces are more than the shaders shade on a CPU adapter, whose loops stop after 65535 iterations (at most {most} surfaces with {lights} lights{mesh_note}); leave out --gpu: the CPU renderer takes any number",
        scene.surfaces.len(),
    )))
}

/// The iterations an invocation of paper B's shader takes at most for `gaussians`
/// Gaussians lit by `lights` lights and, if `environment`, an environment:
/// `N·(1 + 1.5·(L + E))` (`E` = 1 with an environment). Every pixel of a tile may meet
/// every Gaussian (its tile lists, its surface point's paths towards each light and the
/// sky), so the cost grows with both. The first counts whose pictures went dark (faint
/// Gaussians filling the view): 32 768 with one point light, 24 000 with four, 16 384 with
/// eight, 12 000 with four over a plane, 20 000 with one light or a sun under the built-in
/// sky over a plane; within the budget (24 000 / 8 500 / 4 600 Gaussians with 1 / 4 / 8
/// lamps over a plane; 12 000 / 6 000 with 1 / 4 lamps and the sky) the pictures equal the
/// CPU's to `10⁻⁵`.
pub fn gaussian_loops(gaussians: usize, lights: usize, environment: bool) -> f64 {
    let lit = lights as f64 + f64::from(u8::from(environment));
    gaussians as f64 * (1.0 + 1.5 * lit)
}

/// Refuses on a CPU device (`cpu`) a paper B scene over [`LOOP_BUDGET`]
/// ([`gaussian_loops`]).
pub fn check_gaussians(
    cpu: bool,
    gaussians: usize,
    lights: usize,
    environment: bool,
) -> Result<(), GpuError> {
    let loops = gaussian_loops(gaussians, lights, environment);
    if !cpu || loops <= LOOP_BUDGET {
        return Ok(());
    }
    let most = (LOOP_BUDGET * gaussians as f64 / loops).floor();
    let mut lit = match lights {
        1 => "1 light".to_string(),
        n => format!("{n} lights"),
    };
    if environment {
        lit += " and an environment";
    }
    Err(GpuError::Input(format!(
        "{gaussians} Gaussians with {lit} are more than paper B's shader renders on a CPU adapter, whose loops stop after 65535 iterations (at most {most} Gaussians with {lit}); leave out --gpu: the CPU renderer takes any number"
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Light, Material, Surface};

    /// A scene of `lights` point lights over a plane and `spheres` spheres.
    fn scene(lights: usize, spheres: usize) -> Scene {
        let mut s = crate::file::parse(
            r#"{"camera": {"eye": [0, -5, 1], "target": [0, 0, 1], "width": 4, "height": 3}}"#,
        )
        .unwrap();
        s.lights = (0..lights)
            .map(|k| Light::Point {
                position: [k as f64 * 0.01, 0.0, 3.0],
                intensity: [1.0; 3],
            })
            .collect();
        let material = Material {
            diffuse: [0.5; 3],
            specular: [0.0; 3],
            shininess: 1.0,
        };
        s.surfaces.push(Surface {
            shape: Shape::Plane {
                point: [0.0; 3],
                normal: [0.0, 0.0, 1.0],
            },
            material: material.clone(),
        });
        for k in 0..spheres {
            s.surfaces.push(Surface {
                shape: Shape::Sphere {
                    center: [k as f64 * 0.3, 1.0, 1.0],
                    radius: 0.1,
                },
                material: material.clone(),
            });
        }
        s
    }

    /// The shading budget's ends as measured (`shading_loops`' docs): what rendered right
    /// passes, the first scenes that went dark are refused; a real GPU takes any.
    #[test]
    fn the_shading_budget_takes_what_rendered_right() {
        for (l, s) in [(250, 54), (1000, 0), (2, 2000), (500, 19), (1500, 0)] {
            assert!(check_shading(true, &scene(l, s)).is_ok(), "{l} × {s}");
        }
        for (l, s) in [
            (300, 54),
            (100, 199),
            (8, 4000),
            (170, 169),
            (4000, 8),
            (600, 24),
        ] {
            let sc = scene(l, s);
            let e = check_shading(true, &sc).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("{l} lights and {} surfaces are more", s + 1)),
                "{e}"
            );
            assert!(check_shading(false, &sc).is_ok());
        }
        // 100 lights: (60 000 / 100 − 30) / 3.6 = 158.3 surfaces.
        let e = check_shading(true, &scene(100, 199))
            .unwrap_err()
            .to_string();
        assert!(e.contains("(at most 158 surfaces with 100 lights)"), "{e}");
    }

    /// Paper B's budget's ends as measured on lavapipe (`gaussian_loops`' docs).
    #[test]
    fn the_gaussian_budget_takes_what_rendered_right() {
        let right = [
            (24_000, 1, false),
            (8_500, 4, false),
            (4_600, 8, false),
            (12_000, 1, true),
            (6_000, 4, true),
        ];
        for (n, lights, env) in right {
            assert!(
                check_gaussians(true, n, lights, env).is_ok(),
                "{n}, {lights}"
            );
        }
        let dark = [
            (32_768, 1, false),
            (24_000, 4, false),
            (16_384, 8, false),
            (12_000, 4, false),
            (20_000, 1, true),
        ];
        for (n, lights, env) in dark {
            let e = check_gaussians(true, n, lights, env)
                .unwrap_err()
                .to_string();
            assert!(e.contains(&format!("{n} Gaussians")), "{e}");
            assert!(check_gaussians(false, n, lights, env).is_ok());
        }
        let e = check_gaussians(true, 30_000, 1, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("30000 Gaussians with 1 light are more"), "{e}");
        assert!(e.contains("at most 24000 Gaussians with 1 light)"), "{e}");
        let e = check_gaussians(true, 20_000, 1, true)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("at most 15000 Gaussians with 1 light and an environment)"),
            "{e}"
        );
    }
}
