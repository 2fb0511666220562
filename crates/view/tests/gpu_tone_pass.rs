//! The GPU's 8-bit encoding (`gpu::tone_pass`) against its host twin
//! (`haze_core::Image::to_srgb8`): the same codes, byte for byte, on a wide spread of
//! linear values and the extremes (zero, negative, NaN, +∞, the largest `f32`), at several
//! exposures and both tone curves. Needs a GPU adapter
//! (lavapipe will do); fails without one.

use haze_core::{Image, ToneMap};
use haze_gpu::GpuContext;
use haze_view::gpu::tone_pass::TonePass;
use haze_view::gpu::view_pass::ImageBuffer;

#[test]
fn the_gpu_encodes_as_the_host() {
    let ctx = GpuContext::new().unwrap_or_else(|e| panic!("{e}"));
    let pass = TonePass::new(&ctx).unwrap();
    // 517 × 3 pixels (not a whole number of workgroups): values spread over 24 decades,
    // channels apart, then the extremes.
    let (w, h) = (517, 3);
    let mut pixels: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let x = 1e-12f64 * 1.1f64.powi(i as i32 % 580);
            [x as f32, (x * 0.37) as f32, (x * 2.9) as f32]
        })
        .collect();
    let extremes = [
        [0.0, -0.0, -1.0],
        [f32::NAN, f32::INFINITY, f32::MAX],
        [f32::MIN_POSITIVE, f32::NEG_INFINITY, 1.0],
    ];
    pixels[..3].copy_from_slice(&extremes);
    let host = Image {
        width: w,
        height: h,
        pixels: pixels.clone(),
    };
    let image = ImageBuffer::upload(&ctx, w, h, &pixels).unwrap();
    for tone in [ToneMap::Filmic, ToneMap::Clip] {
        for exposure in [1.0, 0.25, 3.7, 1e-5, 2e6] {
            let gpu = pass.encode(&ctx, &image, exposure, tone).unwrap();
            let cpu = host.to_srgb8(exposure, tone);
            assert_eq!(gpu.len(), cpu.len());
            let differ = gpu.iter().zip(&cpu).filter(|(a, b)| a != b).count();
            assert_eq!(differ, 0, "{tone:?} at {exposure}: {differ} bytes differ");
        }
    }
    // A bad exposure is refused; a picture of no pixels encodes to nothing.
    assert!(pass.encode(&ctx, &image, 0.0, ToneMap::Filmic).is_err());
    assert!(
        pass.encode(&ctx, &image, f64::NAN, ToneMap::Filmic)
            .is_err()
    );
    let empty = ImageBuffer::upload(&ctx, 0, 4, &[]).unwrap();
    assert!(
        pass.encode(&ctx, &empty, 1.0, ToneMap::Filmic)
            .unwrap()
            .is_empty()
    );
    assert!(ImageBuffer::upload(&ctx, 2, 2, &pixels[..3]).is_err());
}
