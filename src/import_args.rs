//! Options shared by every command that imports volumes.

use clap::Args;
use haze_volume::ImportOptions;
use haze_volume::import::IndexAt;

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
    /// Where an OpenVDB grid's transform puts a voxel's index: `centre` (OpenVDB's own
    /// convention: Houdini, EmberGen, haze's exports) or `corner` (the voxel's min corner:
    /// Blender's fluid caches). Default: the file's own word (haze's exports say it), else
    /// `corner` for a grid that records its Blender domain (`file_base_resolution`), else
    /// `centre`. The two place the smoke half a voxel apart.
    #[arg(long, value_name = "centre|corner")]
    pub vdb_index: Option<IndexAt>,
}

impl ImportArgs {
    /// Each flag with whether it differs from `defaults` ([`crate::unused_flags`]).
    pub fn given(&self, defaults: &ImportArgs) -> [(&'static str, bool); 4] {
        [
            (
                "--grid",
                crate::unused_flags::differs(&self.grid, &defaults.grid),
            ),
            ("--clamp-negative", self.clamp_negative),
            ("--domain-offset", self.domain_offset.is_some()),
            ("--vdb-index", self.vdb_index.is_some()),
        ]
    }

    pub fn options(&self) -> ImportOptions {
        ImportOptions {
            grid: self.grid.clone(),
            clamp_negative: self.clamp_negative,
            domain_offset: self.domain_offset.unwrap_or([0.0; 3]),
            vdb_index: self.vdb_index,
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
