//! Options shared by every command that imports volumes.

use clap::Args;
use haze_volume::ImportOptions;

#[derive(Debug, Args)]
pub struct ImportArgs {
    /// Grid to read from OpenVDB files.
    #[arg(long, default_value = "density")]
    pub grid: String,
    /// Clamp negative densities to 0 instead of refusing the input.
    #[arg(long)]
    pub clamp_negative: bool,
    /// World offset added to OpenVDB grids, whose transforms are often local to the
    /// simulation domain (Blender: the domain object's min corner), as X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub domain_offset: Option<[f64; 3]>,
}

impl ImportArgs {
    /// Each flag with whether it differs from `defaults` ([`crate::unused_flags`]).
    pub fn given(&self, defaults: &ImportArgs) -> [(&'static str, bool); 3] {
        [
            (
                "--grid",
                crate::unused_flags::differs(&self.grid, &defaults.grid),
            ),
            ("--clamp-negative", self.clamp_negative),
            ("--domain-offset", self.domain_offset.is_some()),
        ]
    }

    pub fn options(&self) -> ImportOptions {
        ImportOptions {
            grid: self.grid.clone(),
            clamp_negative: self.clamp_negative,
            domain_offset: self.domain_offset.unwrap_or([0.0; 3]),
        }
    }
}

/// Parses "x,y,z" into three finite numbers.
pub fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(format!("expected X,Y,Z, got '{s}'"));
    }
    let mut v = [0.0; 3];
    for (o, p) in v.iter_mut().zip(&parts) {
        *o = p
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("'{p}' is not a finite number"))?;
        let max = haze_volume::import::raw::MAX_COORDINATE;
        if o.abs() > max {
            return Err(format!(
                "'{}' is out of range: coordinates lie within ±{max:e}",
                p.trim()
            ));
        }
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::parse_vec3;

    #[test]
    fn vec3_parsing() {
        assert_eq!(parse_vec3("-1.5, -1.5,0").unwrap(), [-1.5, -1.5, 0.0]);
        assert!(parse_vec3("1,2").is_err());
        assert!(parse_vec3("1,x,2").is_err());
        assert!(parse_vec3("1,inf,2").is_err());
    }
}
