//! The types every haze crate shares: points and directions as `[f64; 3]` with their
//! few operations ([`vec3`]), linear RGB ([`Rgb`]), and rendered images ([`Image`]) with
//! their OpenEXR and PNG writers, which refuse a picture holding NaN or infinity; and
//! the JSON reader's guard against repeated keys ([`json`]) and the `.npy` reader's
//! against headers that would keep it busy ([`npy_header`]); and the coded blocks'
//! zstd frames with their guard against implausible sizes ([`coded`]) and the range
//! coder of their binary adaptive models ([`adaptive`]) and the logistic mixing of
//! several such predictions ([`mixing`]); and the tone
//! curves of displayed pictures ([`tone`]).

pub mod adaptive;
pub mod coded;
mod image;
pub mod json;
pub mod mixing;
pub mod npy_header;
pub mod number;
pub mod temp_output;
pub mod tone;
pub mod vec3;

pub use image::{Image, ImageError, NonFinite, srgb8_code, srgb8_thresholds};
pub use tone::ToneMap;

/// Linear RGB, per channel.
pub type Rgb = [f64; 3];
