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

impl CameraArgs {
    /// Each flag with whether it differs from `defaults` ([`crate::unused_flags`]).
    pub fn given(&self, defaults: &CameraArgs) -> [(&'static str, bool); 4] {
        use crate::unused_flags::differs;
        [
            ("--eye", self.eye.is_some()),
            ("--target", self.target.is_some()),
            ("--up", differs(&self.up, &defaults.up)),
            ("--fov", differs(&self.fov, &defaults.fov)),
        ]
    }
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

impl MediumArgs {
    /// Each flag with whether it differs from `defaults` ([`crate::unused_flags`]).
    pub fn given(&self, defaults: &MediumArgs) -> [(&'static str, bool); 3] {
        use crate::unused_flags::differs;
        [
            ("--sigma-t", differs(&self.sigma_t, &defaults.sigma_t)),
            ("--albedo", differs(&self.albedo, &defaults.albedo)),
            ("--g", differs(&self.g, &defaults.g)),
        ]
    }
}
