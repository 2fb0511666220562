//! The scene renderers' WGSL (`crates/scene/shaders/`), composed from modules
//! (`haze_gpu::wgsl`): `render.wgsl`, paper C's renderer, is the module every variant
//! imports (bindings, intersections, shadow rays, airlight tables, BRDF, environment,
//! and the pixel `paper_c_main`); each variant is a short entry file over it.
//!
//! | variant | entry | defines | renderer |
//! |---|---|---|---|
//! | [`PAPER_C`] | `paper_c.wgsl` | | [`super::GpuRenderer`] |
//! | [`ANALYTIC`] | `analytic.wgsl` (+ `fogfn`) | | [`super::analytic`] |
//! | [`MARCH`] | `march.wgsl` (+ `env_smoke`, `fogfn`) | | [`super::march`] |
//! | [`RASTER`] | `raster.wgsl` | `GBUFFER`, `PARAMS_IN_STORAGE` | [`super::raster`] |
//! | [`PAPER_B_TILED`], [`PAPER_B_UNTILED`] | `paper_b.wgsl` | —, `UNTILED` | [`super::paper_b`] |

use haze_gpu::GpuError;
use haze_gpu::wgsl::{Module, Variant};

/// This crate's modules (with `haze_fogfn`'s `fogfn` and [`haze_gpu::wgsl::SHARED`], the
/// modules the entry files import).
const OWN: &[Module] = &[
    Module {
        name: "render",
        source: include_str!("../../shaders/render.wgsl"),
    },
    Module {
        name: "env_smoke",
        source: include_str!("../../shaders/env_smoke.wgsl"),
    },
];

/// Paper C alone: one invocation of `paper_c_main` per pixel.
pub const PAPER_C: Variant = Variant {
    label: "scene render",
    entry: include_str!("../../shaders/paper_c.wgsl"),
    defines: &[],
};

/// Paper D's composite: paper C's pixel, then the analytic fogs' optical depth to its hit.
pub const ANALYTIC: Variant = Variant {
    label: "analytic fog",
    entry: include_str!("../../shaders/analytic.wgsl"),
    defines: &[],
};

/// The single-scattering march through voxel media and analytic fogs.
pub const MARCH: Variant = Variant {
    label: "scene march",
    entry: include_str!("../../shaders/march.wgsl"),
    defines: &[],
};

/// Paper C with primary hits from the rasterizer's G-buffer, its parameters in a storage
/// buffer (lavapipe inlines uniforms that steer branches: a recompile per camera).
pub const RASTER: Variant = Variant {
    label: "rasterized scene",
    entry: include_str!("../../shaders/raster.wgsl"),
    defines: &["GBUFFER", "PARAMS_IN_STORAGE"],
};

/// Paper B with the per-tile lists of Gaussians.
pub const PAPER_B_TILED: Variant = Variant {
    label: "paper B (tiled)",
    entry: include_str!("../../shaders/paper_b.wgsl"),
    defines: &[],
};

/// Paper B without the lists nor their workgroup barriers (a few Gaussians).
pub const PAPER_B_UNTILED: Variant = Variant {
    label: "paper B (untiled)",
    entry: include_str!("../../shaders/paper_b.wgsl"),
    defines: &["UNTILED"],
};

/// Every shader the scene renderers compile.
pub const VARIANTS: &[Variant] = &[
    PAPER_C,
    ANALYTIC,
    MARCH,
    RASTER,
    PAPER_B_TILED,
    PAPER_B_UNTILED,
];

/// Every module the variants may import: this crate's, `haze_fogfn`'s, then the shared
/// ones.
pub const MODULES: &[&[Module]] = &[OWN, haze_fogfn::gpu::MODULES, haze_gpu::wgsl::SHARED];

/// `variant`'s whole source.
pub fn source(variant: &Variant) -> Result<String, GpuError> {
    variant.source(MODULES)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every variant composes and validates on the CPU (no device needed).
    #[test]
    fn every_variant_validates() {
        haze_gpu::wgsl::assert_variants_valid(VARIANTS, MODULES);
    }

    /// The variants differ where they should and nowhere else: the G-buffer's hit and the
    /// storage parameters in the raster variant only; barriers in the tiled paper B only.
    #[test]
    fn variants_differ_where_they_should() {
        let c = source(&PAPER_C).unwrap();
        let r = source(&RASTER).unwrap();
        assert!(c.contains("let hit = intersect(vec3<f32>(0.0), dir, 0.0, t_max);"));
        assert!(!c.contains("gbuffer_hit(id"));
        assert!(r.contains("let hit = gbuffer_hit(id, dir, t_max);"));
        assert!(r.contains("var<storage, read> P: Params;"));
        assert!(!r.contains("var<uniform> P: Params;"));
        let tiled = source(&PAPER_B_TILED).unwrap();
        let untiled = source(&PAPER_B_UNTILED).unwrap();
        assert!(tiled.contains("workgroupBarrier();"));
        assert!(!untiled.contains("workgroupBarrier"));
        assert_eq!(
            tiled.matches("tile_barrier();").count(),
            untiled.matches("tile_barrier();").count()
        );
        // Each module enters once, however many entry files and modules import it.
        for v in VARIANTS {
            let s = source(v).unwrap();
            assert_eq!(s.matches("fn paper_c_main(").count(), 1, "{}", v.label);
        }
    }
}
