//! Paper B on the GPU (`shaders/paper_b.wgsl` over `shaders/render.wgsl`, whose
//! helpers — intersections, shadow rays, paper C's airlight and tables, the BRDF, the
//! environment — it shares): the `f32` twin of [`crate::paper_b::Prepared::radiance`],
//! one invocation per pixel. The CPU prepares the frame as for its own render (the
//! Gaussians merged, each one's `e^{Eᵢ}` per light, `C_sv`) and uploads it, with
//! Abramowitz–Stegun's erf (`1.5·10⁻⁷`) for libm's.
//!
//! **Tiles** (§5's splatting, by screen tiles): a workgroup is an 8 × 8 tile of pixels.
//! Its 64 invocations test the Gaussians, 256 at a time, against a bound of the whole
//! tile and compact the survivors in index order into a workgroup list that every pixel
//! then loops over: for the view ray, the cull sphere `√(ln(cᵢ/ε))/aᵢ` against the
//! tile's cone of rays (its four side planes); for the optical depth `T(s,p)` to each
//! light, the `√40`-radii sphere beyond which the shader's line integral is zero
//! (`e⁻⁴⁰`) against the capsule from the sphere around the tile's surface points to the
//! light (a sun: the half-line towards it). A Gaussian left out fails the pixel's own test
//! for every pixel of the tile, so the lists change no sum (margins of `10⁻³` of the
//! radius cover `f32`'s rounding of the bounds). The environment's `T̄(p)` has no
//! cut-off: a Gaussian far from the sphere around the tile's surface points (every
//! point at `ρ ≥ 6`, where the shader takes Dawson's asymptotic series, and at least 16
//! times the sphere's radius away) enters through the second-order Taylor expansion of
//! that series about the sphere's centre, summed once per tile (remainder below `4ε³`
//! of its share, `ε ≤ 1/16`: `10⁻³`); the others are listed and summed exactly per pixel.
//! Frames of at most 32 Gaussians take the same shader without the lists (every sum
//! exact, no workgroup barriers: on lavapipe their mere presence costs ~30 %).
//!
//! Pairs integrated along the ray ([`haze_gaussians::integrated`], where the bound on the
//! factorization's error exceeds [`crate::paper_b::PaperBOptions::target`]): the CPU
//! uploads each pair's exponent without the light's exact list (its hosts, shadowers and
//! fog casters) and that list; the shader integrates as the CPU does (6-node
//! Gauss–Legendre in the angle from the light, the list's depths per node) and scales
//! the homogeneous term by the list's ratio.
//!
//! The environment ([`crate::paper_b::gaussian_env`]): the CPU uploads each Gaussian's
//! `αᵢ·Ēᵢ·e^{Eᵢ}` and `(Ē, β_bg·D)`; the shader adds `e^{−Tᵢ(v,bᵢʳ) − T̄ᵢ(bᵢʳ)}·Tᵢ(v,p)`
//! times it per Gaussian the ray gathers, and dims render.wgsl's SH lighting of surfaces
//! (paper C's, the same `EnvGlow`) by `e^{−T̄(p)}`, `T̄(p)` summed over the Gaussians
//! (above) with Dawson's integral by Rybicki's sum at `h = 0.4` (`~2·10⁻⁷`, Numerical
//! Recipes). Where the surfaces take the others' exact shadow on the sky
//! ([`crate::paper_b::sky_grid`]), the CPU builds the frame's table of ratios per pixel
//! and uploads it after the environment's records; the shader multiplies `e^{−T̄(p)}` by
//! the pixel's ratio where its ray ends on the table's surface (1 where `f32` found
//! another surface than the CPU, at a silhouette).
//!
//! Noise (§5.5): the shader's `perlin_value` is [`Perlin::value`] in `f32`, reading the
//! permutation the CPU drew from the medium's seed (uploaded once per distinct medium);
//! each noisy Gaussian carries its lookup origin `eye + offset`, the frequency and the
//! scale `gain·rᵢ/|v − bᵢ|` (in `f64` on the CPU), and the shader perturbs the direction
//! of `Tᵢ(v,p)` in the camera frame as [`haze_gaussians::noise::Noise::perturb`] does.

use super::GpuRenderer;
use super::shaders;
use crate::paper_b::sky_grid::sky_table;
use crate::paper_b::{PaperBOptions, Prepared};
use crate::paper_c::airlight::Limits;
use crate::render::Image;
use crate::scene::Environment;
use crate::vec3::{norm, sub};
use haze_gaussians::airlight::cull_radius;
use haze_gaussians::noise::{Noise, Perlin};
use haze_gpu::wgsl::Variant;
use haze_gpu::{GpuContext, GpuError, buffer_init, compute_pipeline_with};

/// Up to this many Gaussians every pixel loops over all of them, without the tile lists
/// (`paper_b.wgsl`'s `DIRECT_MAX`, set from here when the tiled pipeline is made).
const DIRECT_MAX: usize = 32;

/// The compiled paper B pipelines (tiled, and untiled for a few Gaussians); the tables
/// are the paper C renderer's.
#[derive(Debug)]
pub struct GpuPaperB {
    tiled: wgpu::ComputePipeline,
    untiled: wgpu::ComputePipeline,
}

impl GpuPaperB {
    /// Compiles [`shaders::PAPER_B_TILED`] and [`shaders::PAPER_B_UNTILED`] (the
    /// latter's `DIRECT_MAX` is every count: no tile lists, no workgroup barriers — on
    /// lavapipe a shader with barriers runs ~30 % slower even where it reaches none, which
    /// the lists repay only beyond a few dozen Gaussians).
    pub fn new(ctx: &GpuContext) -> Result<GpuPaperB, GpuError> {
        Ok(GpuPaperB {
            tiled: Self::compile(ctx, &shaders::PAPER_B_TILED, DIRECT_MAX as u32)?,
            untiled: Self::compile(ctx, &shaders::PAPER_B_UNTILED, u32::MAX)?,
        })
    }

    /// `variant`'s pipeline with its overridable constants: Perlin's vector offsets (the
    /// CPU's [`Perlin::VECTOR_OFFSETS`] in `f32`) and `DIRECT_MAX`.
    fn compile(
        ctx: &GpuContext,
        variant: &Variant,
        direct_max: u32,
    ) -> Result<wgpu::ComputePipeline, GpuError> {
        let off = Perlin::VECTOR_OFFSETS;
        let f = |v: f64| f64::from(v as f32);
        let constants = [
            ("NOISE_OFFSET_1_X", f(off[1][0])),
            ("NOISE_OFFSET_1_Y", f(off[1][1])),
            ("NOISE_OFFSET_1_Z", f(off[1][2])),
            ("NOISE_OFFSET_2_X", f(off[2][0])),
            ("NOISE_OFFSET_2_Y", f(off[2][1])),
            ("NOISE_OFFSET_2_Z", f(off[2][2])),
            ("DIRECT_MAX", f64::from(direct_max)),
        ];
        compute_pipeline_with(
            ctx,
            "paper B pipeline creation",
            &shaders::source(variant)?,
            "main",
            &constants,
        )
    }

    /// Renders `prep`'s scene (as [`crate::paper_b::render`] with `lim`) with the tables
    /// of `tables` (built from the same scene's [`crate::render::Analytic`]).
    pub fn render(
        &self,
        ctx: &GpuContext,
        tables: &GpuRenderer,
        prep: &Prepared<'_>,
        lim: &Limits,
    ) -> Result<Image, GpuError> {
        let eye = prep.scene.camera.eye;
        let blobs_in = prep.set.blobs();
        super::cpu_device::check_gaussians(
            ctx.is_cpu_adapter(),
            blobs_in.len(),
            prep.lights.len(),
            !matches!(prep.scene.environment, Environment::Black),
        )?;
        if blobs_in.len() >= 1 << 24 {
            return Err(GpuError::Input(format!(
                "{} Gaussians are too many for the GPU renderer",
                blobs_in.len()
            )));
        }
        let mut blobs: Vec<[f32; 4]> = Vec::with_capacity(2 * blobs_in.len().max(1));
        for b in blobs_in {
            let r = cull_radius(b);
            blobs.push([
                (b.center[0] - eye[0]) as f32,
                (b.center[1] - eye[1]) as f32,
                (b.center[2] - eye[2]) as f32,
                b.a as f32,
            ]);
            blobs.push([b.c as f32, b.albedo as f32, (r * r) as f32, 0.0]);
        }
        let noisy = prep.noise.iter().any(|n| n.is_some_and(|n| n.gain > 0.0));
        if noisy {
            noise_records(prep, &mut blobs)?;
        }
        if blobs.is_empty() {
            blobs.push([0.0; 4]);
        }
        let mut bexp = light_records(prep);
        // The environment (crate::paper_b::gaussian_env): αᵢ·Ēᵢ·e^{Eᵢ} per Gaussian, then (Ē, β_bg·D).
        let env_flag = match &prep.env {
            Some(env) => {
                for e in &env.center {
                    bexp.push([e[0] as f32, e[1] as f32, e[2] as f32, 0.0]);
                }
                let m = env.mean;
                bexp.push([
                    m[0] as f32,
                    m[1] as f32,
                    m[2] as f32,
                    env.background_depth as f32,
                ]);
                if prep.options.surface_scattering {
                    2.0
                } else {
                    1.0
                }
            }
            None => 0.0,
        };
        let sky_at = sky_records(prep, lim, &mut bexp)?;
        bexp.push([
            blobs_in.len() as f32,
            if prep.background { 1.0 } else { 0.0 },
            if noisy { 1.0 } else { 0.0 },
            env_flag,
        ]);
        let ss = prep.scene.medium.sigma_s();
        bexp.push([ss[0] as f32, ss[1] as f32, ss[2] as f32, sky_at]);
        let exponents = if sky_at < 0.0 {
            "their exponents"
        } else {
            "their exponents and the surfaces' shadow on the sky per pixel"
        };
        for (what, n) in [("the Gaussians", blobs.len()), (exponents, bexp.len())] {
            ctx.check_storage_size(what, 16 * n as u64)?;
        }
        let (blobs, bexp) = ctx.scoped("paper B upload", || {
            (
                buffer_init(
                    ctx,
                    "paper B gaussians",
                    bytemuck::cast_slice(&blobs),
                    wgpu::BufferUsages::STORAGE,
                ),
                buffer_init(
                    ctx,
                    "paper B exponents",
                    bytemuck::cast_slice(&bexp),
                    wgpu::BufferUsages::STORAGE,
                ),
            )
        })?;
        let pipeline = if blobs_in.len() <= DIRECT_MAX {
            &self.untiled
        } else {
            &self.tiled
        };
        tables.render_pass(
            ctx,
            prep.scene,
            lim,
            pipeline,
            Some((prep.beta0, prep.sigma_s0)),
            &[&blobs, &bexp],
        )
    }
}

/// The lights' records of the exponents buffer (paper_b.wgsl's `bexp`, up to the
/// environment's): per light and Gaussian `e^{Eᵢ}` and the pair's exponent (−1: the closed
/// form), per light `(C_sv, C_sv without its list, the list's length, -)`, then the
/// homogeneous term's lists and the pairs' lists.
fn light_records(prep: &Prepared<'_>) -> Vec<[f32; 4]> {
    let mut bexp: Vec<[f32; 4]> = Vec::new();
    for l in &prep.lights {
        for (e, pair) in l.center.iter().zip(&l.pairs.integrated) {
            let pair = pair.map_or(-1.0, |p| p as f32);
            bexp.push([e[0] as f32, e[1] as f32, e[2] as f32, pair]);
        }
    }
    for l in &prep.lights {
        bexp.push([
            l.pairs.c_sv as f32,
            l.pairs.c_sv_rest as f32,
            l.pairs.exact.len() as f32,
            0.0,
        ]);
    }
    // Each light's list for the homogeneous term, then each pair's list, in
    // MAX_EXACT / 4 records (paper_b.wgsl's EXACT_RECORDS; −1 past a pair's end).
    for l in &prep.lights {
        push_ids(&mut bexp, &l.pairs.exact, 0.0);
    }
    for l in &prep.lights {
        for list in &l.pairs.pair_exact {
            push_ids(&mut bexp, list, -1.0);
        }
    }
    bexp
}

/// The most Gaussians an integrated pair takes exactly per node on a CPU device
/// (lavapipe): Mesa's CPU driver ends an invocation's loops after 65535 iterations in
/// all (`crate::gpu::march`'s module docs), and each entry costs every node of every
/// integrated pair a ray crosses an iteration — with 16 the 150 dense Gaussians around a
/// lamp of `tests/gpu_paper_b.rs`'s wide scene left two tiles black, with 8 one, with 4
/// none.
pub const CPU_DEVICE_EXACT: usize = 4;

/// Paper B's default options for rendering on `ctx`'s device: [`CPU_DEVICE_EXACT`] Gaussians
/// exact per integrated pair on a CPU device, `MAX_EXACT` elsewhere, and every pixel
/// integrating its pairs (the GPU does not reuse them across the screen; the surfaces'
/// shadow on the sky comes from the CPU's table, `crate::paper_b::sky_grid`). Prepare the
/// scene with these (and the CPU twin with the same, to compare).
pub fn options(ctx: &GpuContext) -> PaperBOptions {
    let max_exact = if ctx.adapter_info().device_type == wgpu::DeviceType::Cpu {
        CPU_DEVICE_EXACT
    } else {
        crate::paper_b::MAX_EXACT
    };
    PaperBOptions {
        max_exact,
        reuse: 1,
        ..PaperBOptions::default()
    }
}

/// Appends the surfaces' shadow on the sky per pixel ([`sky_table`] at
/// [`PaperBOptions::sky_stride`]): `(ratio, surface)`, the surface −1 where the pixel's
/// ray ends on none. Returns where the records start, −1 without a table (paper_b.wgsl's
/// `sky_ratio`); an error when that index would not be exact in `f32` (`2²⁴`).
fn sky_records(
    prep: &Prepared<'_>,
    lim: &Limits,
    bexp: &mut Vec<[f32; 4]>,
) -> Result<f32, GpuError> {
    let Some(table) = sky_table(prep, lim, prep.options.sky_stride) else {
        return Ok(-1.0);
    };
    let start = bexp.len();
    if start + table.pixels.len() >= 1 << 24 {
        return Err(GpuError::Input(format!(
            "a picture of {} pixels is too large for the GPU's shadow on the sky \
             (--sky-shadow mean renders without it)",
            table.pixels.len()
        )));
    }
    bexp.extend(table.pixels.iter().map(|p| match *p {
        Some((s, r)) => [r[0] as f32, r[1] as f32, r[2] as f32, s as f32],
        None => [1.0, 1.0, 1.0, -1.0],
    }));
    Ok(start as f32)
}

/// Appends a list of Gaussian indices (at most `MAX_EXACT`) as `MAX_EXACT / 4` records,
/// `fill` past its end.
fn push_ids(bexp: &mut Vec<[f32; 4]>, list: &[usize], fill: f32) {
    let mut ids = [fill; crate::paper_b::MAX_EXACT];
    for (slot, &h) in ids.iter_mut().zip(list) {
        *slot = h as f32;
    }
    for rec in ids.chunks(4) {
        bexp.push([rec[0], rec[1], rec[2], rec[3]]);
    }
}

/// Appends to `blobs` (the `2n` records of the `n` Gaussians) two noise records per
/// Gaussian — `(eye + offset, frequency)` and `(gain·rᵢ/|v − bᵢ|, index of its
/// permutation, -, -)`, a scale of 0 where [`Noise::perturb`] leaves the direction alone —
/// then each distinct medium's permutation, four entries per record. An error when a
/// record's index would not be exact in `f32` (`2²⁴`).
fn noise_records(prep: &Prepared<'_>, blobs: &mut Vec<[f32; 4]>) -> Result<(), GpuError> {
    let eye = prep.scene.camera.eye;
    let n = prep.set.blobs().len();
    let mut tables: Vec<&Noise> = Vec::new();
    let table_start = 4 * n;
    for (i, b) in prep.set.blobs().iter().enumerate() {
        let (origin, scale, table) = match prep.noise[i] {
            Some(noise) => {
                let dist = norm(sub(b.center, eye));
                let scale = if noise.gain == 0.0 || dist <= 0.0 {
                    0.0
                } else {
                    noise.gain * prep.radius[i] / dist
                };
                let k = match tables.iter().position(|t| std::ptr::eq(*t, noise)) {
                    Some(k) => k,
                    None => {
                        tables.push(noise);
                        tables.len() - 1
                    }
                };
                let origin = [0, 1, 2].map(|a| (eye[a] + noise.offset[a]) as f32);
                ((origin, noise.frequency as f32), scale, k)
            }
            None => (([0.0; 3], 0.0), 0.0, 0),
        };
        blobs.push([origin.0[0], origin.0[1], origin.0[2], origin.1]);
        blobs.push([scale as f32, (table_start + 128 * table) as f32, 0.0, 0.0]);
    }
    for t in tables {
        for q in t.perlin.permutation().chunks_exact(4) {
            blobs.push([q[0], q[1], q[2], q[3]].map(f32::from));
        }
    }
    if blobs.len() > 1 << 24 {
        return Err(GpuError::Input(format!(
            "{n} Gaussians with noise are too many for the GPU renderer"
        )));
    }
    Ok(())
}
