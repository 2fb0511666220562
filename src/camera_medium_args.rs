//! The camera and medium flags that `haze render`, `haze tradeoff` and `haze view` share.

use crate::import_args::parse_vec3;

/// Where the camera is and where it looks.
#[derive(Debug, clap::Args)]
pub struct CameraArgs {
    /// Camera position (world units), with --target.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<[f64; 3]>,
    /// Point the camera looks at, with --eye.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<[f64; 3]>,
    /// Camera up vector.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, default_value = "0,0,1", allow_hyphen_values = true)]
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 40.0)]
    pub fov: f64,
}

/// The smoke's optical properties.
#[derive(Debug, clap::Args)]
pub struct MediumArgs {
    /// Extinction cross-section: κt = σt · density.
    #[arg(long, default_value_t = 4.0)]
    pub sigma_t: f64,
    /// Single-scattering albedo, 0..1.
    #[arg(long, default_value_t = 0.8)]
    pub albedo: f64,
    /// Henyey–Greenstein asymmetry, −1..1.
    #[arg(long, default_value_t = 0.3, allow_hyphen_values = true)]
    pub g: f64,
}
