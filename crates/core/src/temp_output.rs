//! The temporary file an output is written to before it is renamed over its path (so no
//! output is ever half-written).

use std::path::Path;

/// A temporary file in `dir` for an output, created 0644 less the umask like every other
/// output (a plain temporary file is 0600), named `.haze-out.*.tmp`.
pub fn temp_output(dir: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let mut builder = tempfile::Builder::new();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    builder.prefix(".haze-out.").suffix(".tmp").tempfile_in(dir)
}
