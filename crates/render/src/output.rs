//! Files the CLI writes besides assets (reports, exported volumes): always to a temporary
//! file beside the destination, renamed into place when complete.

use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let ctx = || format!("{}: cannot write", path.display());
    let mut tmp = tempfile::Builder::new()
        .prefix(".haze-out.")
        .suffix(".tmp")
        .tempfile_in(dir)
        .with_context(ctx)?;
    tmp.write_all(bytes).with_context(ctx)?;
    // Temporary files are created private (0600); outputs are normal files.
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

/// Writes pretty JSON (and a final newline) atomically.
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let mut text = serde_json::to_vec_pretty(value)?;
    text.push(b'\n');
    write_atomic(path, &text)
}
