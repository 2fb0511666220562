//! JSON reports, written atomically (temporary file beside the destination, then rename).

use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;

pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let ctx = || format!("{}: cannot write the report", path.display());
    let mut tmp = tempfile::Builder::new()
        .prefix(".report.")
        .suffix(".tmp")
        .tempfile_in(dir)
        .with_context(ctx)?;
    serde_json::to_writer_pretty(&mut tmp, value).with_context(ctx)?;
    tmp.write_all(b"\n").with_context(ctx)?;
    // Temporary files are created private (0600); a report is a normal file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))
            .with_context(ctx)?;
    }
    tmp.persist(path).map_err(|e| e.error).with_context(ctx)?;
    Ok(())
}
