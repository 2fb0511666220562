//! The smoke renderer's WGSL (`crates/view/shaders/`): one entry file per pass, composed
//! with the modules they import (`haze_gpu::wgsl`).

use haze_gpu::GpuError;
use haze_gpu::wgsl::{Module, Variant};

/// The modules the passes import, besides [`haze_gpu::wgsl::SHARED`].
pub const MODULES: &[Module] = &[
    Module {
        name: "sh_basis",
        source: include_str!("../../shaders/sh_basis.wgsl"),
    },
    Module {
        name: "grid_march",
        source: include_str!("../../shaders/grid_march.wgsl"),
    },
    Module {
        name: "block_skip",
        source: include_str!("../../shaders/block_skip.wgsl"),
    },
    Module {
        name: "disk_phase",
        source: include_str!("../../shaders/disk_phase.wgsl"),
    },
    Module {
        name: "light_records",
        source: include_str!("../../shaders/light_records.wgsl"),
    },
    Module {
        name: "lit",
        source: include_str!("../../shaders/lit.wgsl"),
    },
    Module {
        name: "lat_long",
        source: include_str!("../../shaders/lat_long.wgsl"),
    },
    Module {
        name: "shadow_cutoff",
        source: include_str!("../../shaders/shadow_cutoff.wgsl"),
    },
    Module {
        name: "grid_shadow",
        source: include_str!("../../shaders/grid_shadow.wgsl"),
    },
    Module {
        name: "ln_radiance",
        source: include_str!("../../shaders/ln_radiance.wgsl"),
    },
];

/// Every module the passes may import: this crate's, then the shared ones.
const ALL: &[&[Module]] = &[MODULES, haze_gpu::wgsl::SHARED];

/// Every shader the smoke renderer compiles.
pub const VARIANTS: &[Variant] = &[
    super::single_scattering::SHADER,
    super::volume_pass::SHADER,
    super::env_pass::SHADER,
    super::env_pass::REMOVE_SHADER,
    super::occupancy::SHADER,
    super::lights_pass::SHADER,
    super::orders::SHADER,
    super::diffusion::SHADER,
    super::view_pass::SHADER,
    super::view_pass::GRID_SHADER,
    super::view_pass::SKY_SHADER,
    super::tone_pass::SHADER,
];

/// `variant`'s whole source.
pub fn source(variant: &Variant) -> Result<String, GpuError> {
    variant.source(ALL)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pass's shader composes and validates on the CPU (no device needed).
    #[test]
    fn every_variant_validates() {
        haze_gpu::wgsl::assert_variants_valid(VARIANTS, ALL);
    }
}
