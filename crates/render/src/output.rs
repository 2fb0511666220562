//! Files the commands write: checked before any work ([`Outputs`]), written to a
//! temporary file beside the destination and renamed into place when complete
//! ([`write_atomic`]), and removed again when the run that created them fails
//! ([`Created`]).
//!
//! The promise every command keeps: no input is ever overwritten, no output overwrites
//! another, and an output that cannot be written is refused before the work that would
//! have made it.

use anyhow::{Context, Result, bail};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The files a command reads and the files it will write, checked together by
/// [`Outputs::check`] before any work.
#[derive(Debug, Default)]
pub struct Outputs {
    inputs: Vec<PathBuf>,
    /// The flag that names each output, its path, and whether it is a `.haze` asset
    /// ([`Outputs::asset`]).
    outputs: Vec<(String, PathBuf, bool)>,
}

impl Outputs {
    pub fn new() -> Outputs {
        Outputs::default()
    }

    /// An input file; a raw `.f32`/`.raw` volume or fogmap and a `.npy` bring their `.json`
    /// sidecar (when there is one), a Blender cache's `.vdb` its configuration (when there
    /// is one). A directory or
    /// a glob of frames: every frame file in it (`haze_volume`'s discovery). Inputs that do
    /// not exist are left to the reader, which names them.
    pub fn input(mut self, path: &Path) -> Outputs {
        let files = match haze_volume::import::sequence::discover(path) {
            Ok(frames) if path.is_dir() || !path.exists() => {
                frames.into_iter().map(|f| f.path).collect()
            }
            _ => vec![path.to_path_buf()],
        };
        for f in files {
            let sidecar = f.extension().and_then(|e| e.to_str()).is_some_and(|e| {
                ["f32", "raw", "npy"]
                    .iter()
                    .any(|s| e.eq_ignore_ascii_case(s))
            });
            if sidecar {
                self.inputs.push(f.with_extension("json"));
            }
            // A frame of a Blender cache is placed by its configuration (an Adaptive
            // Domain's `config/config_NNNN.uni`), read as an input too.
            if f.extension().is_some_and(|e| e.eq_ignore_ascii_case("vdb")) {
                let config = haze_volume::import::adaptive_domain::config_path(&f);
                self.inputs.extend(config.filter(|c| c.is_file()));
            }
            self.inputs.push(f);
        }
        self
    }

    /// A file to be written, named by the flag that gives it (`--out`, `--report`).
    pub fn output(mut self, flag: &str, path: &Path) -> Outputs {
        self.outputs
            .push((flag.to_string(), path.to_path_buf(), false));
        self
    }

    /// An asset to be written: an output ([`Outputs::output`]) whose name must end in
    /// `.haze`, the extension `haze render`, `view`, `inspect` and `export` know an asset
    /// by (a bake written to `smoke.bin` would be refused by all of them).
    pub fn asset(mut self, flag: &str, path: &Path) -> Outputs {
        self.outputs
            .push((flag.to_string(), path.to_path_buf(), true));
        self
    }

    /// Refuses, in one line: an output that is one of the inputs (the same path once
    /// links are resolved, or the same file by device and inode: a hard link) or
    /// another output; an output that is a directory; an asset not named `.haze`; an output whose folder is missing
    /// or not writable (probed by creating and removing a temporary file in it).
    pub fn check(&self) -> Result<()> {
        let mut inputs = Seen::default();
        for p in &self.inputs {
            if let Some(id) = Identity::of(p) {
                inputs.insert(&id, ("the input", p.as_path()));
            }
        }
        let mut outputs = Seen::default();
        let mut probed = std::collections::HashSet::new();
        for (flag, out, asset) in &self.outputs {
            if out.is_dir() {
                bail!("{}: {flag} is a directory; give a file name", out.display());
            }
            let dir = folder(out);
            if !dir.is_dir() {
                bail!(
                    "{}: {flag}'s folder {} does not exist",
                    out.display(),
                    dir.display()
                );
            }
            let key = Identity::of(out).unwrap_or_else(|| Identity::unborn(&dir, out));
            if let Some((_, input)) = inputs.find(&key) {
                bail!(
                    "{}: {flag} is the input {}; inputs are never overwritten (choose another {flag})",
                    out.display(),
                    input.display()
                );
            }
            if let Some((other, path)) = outputs.find(&key) {
                bail!(
                    "{}: {flag} is the same file as {other} {}; give them different files",
                    out.display(),
                    path.display()
                );
            }
            let haze = out
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("haze"));
            if *asset && !haze {
                bail!(
                    "{}: {flag} must end in .haze (haze render, view, inspect and export know an asset by its extension)",
                    out.display()
                );
            }
            if probed.insert(dir.clone()) {
                tempfile::Builder::new()
                    .prefix(".haze-probe.")
                    .tempfile_in(&dir)
                    .map_err(|e| {
                        anyhow::anyhow!(
                            "{}: {flag} cannot be written in {} ({e})",
                            out.display(),
                            dir.display()
                        )
                    })?;
            }
            outputs.insert(&key, (flag.as_str(), out.as_path()));
        }
        Ok(())
    }
}

/// Files met so far, by canonical path and by device and inode, with the flag that
/// named each.
#[derive(Default)]
struct Seen<'a> {
    by_path: std::collections::HashMap<PathBuf, (&'a str, &'a Path)>,
    by_inode: std::collections::HashMap<(u64, u64), (&'a str, &'a Path)>,
}

impl<'a> Seen<'a> {
    fn insert(&mut self, id: &Identity, what: (&'a str, &'a Path)) {
        self.by_path.insert(id.path.clone(), what);
        if let Some(inode) = id.inode {
            self.by_inode.insert(inode, what);
        }
    }

    fn find(&self, id: &Identity) -> Option<(&'a str, &'a Path)> {
        self.by_path
            .get(&id.path)
            .or_else(|| id.inode.and_then(|i| self.by_inode.get(&i)))
            .copied()
    }
}

/// The folder `path` is written in (`.` for a bare file name).
fn folder(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Whether two existing files or directories are one, once links are resolved (the same
/// canonical path, or on Unix the same device and inode); false where either is missing.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (Identity::of(a), Identity::of(b)) {
        (Some(a), Some(b)) => a.path == b.path || (a.inode.is_some() && a.inode == b.inode),
        _ => false,
    }
}

/// What makes two paths one file: the canonical path, and on Unix the device and inode.
#[derive(Debug, Clone)]
struct Identity {
    path: PathBuf,
    inode: Option<(u64, u64)>,
}

impl Identity {
    /// The identity of an existing file (`None` if it does not exist).
    fn of(path: &Path) -> Option<Identity> {
        let meta = std::fs::metadata(path).ok()?;
        let path = std::fs::canonicalize(path).ok()?;
        #[cfg(unix)]
        let inode = {
            use std::os::unix::fs::MetadataExt;
            Some((meta.dev(), meta.ino()))
        };
        #[cfg(not(unix))]
        let inode = {
            let _ = meta;
            None
        };
        Some(Identity { path, inode })
    }

    /// The identity a file not yet written will have: its folder's canonical path and
    /// its name.
    fn unborn(dir: &Path, path: &Path) -> Identity {
        let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
        Identity {
            path: dir.join(path.file_name().unwrap_or_default()),
            inode: None,
        }
    }
}

/// Files a run has written so far, and directories it made, removed again unless the run
/// ends with [`Created::keep`] (the first frames of a sequence whose later frame failed,
/// a sweep whose input could not be read).
#[derive(Debug, Default)]
pub struct Created {
    files: Vec<PathBuf>,
    /// The outermost directory each [`Created::dir`] made; everything in it is this run's.
    dirs: Vec<PathBuf>,
}

impl Created {
    pub fn new() -> Created {
        Created::default()
    }

    /// `path` was written by this run.
    pub fn push(&mut self, path: PathBuf) {
        self.files.push(path);
    }

    /// Makes the directory `dir` and its missing parents (`flag` names it in the error).
    /// The outermost one that did not exist is this run's: removed with its contents if
    /// the run fails. A directory that already existed is left as it was.
    pub fn dir(&mut self, flag: &str, dir: &Path) -> Result<()> {
        let outermost = dir
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
            .last()
            .map(Path::to_path_buf);
        std::fs::create_dir_all(dir).map_err(|e| {
            anyhow::anyhow!("{}: cannot create {flag}'s directory ({e})", dir.display())
        })?;
        self.dirs.extend(outermost);
        Ok(())
    }

    /// The run succeeded: its files and directories stay.
    pub fn keep(mut self) {
        self.files.clear();
        self.dirs.clear();
    }
}

impl Drop for Created {
    fn drop(&mut self) {
        for f in &self.files {
            if let Err(e) = std::fs::remove_file(f) {
                tracing::warn!("{}: cannot remove ({e})", f.display());
            }
        }
        for d in &self.dirs {
            if let Err(e) = std::fs::remove_dir_all(d) {
                tracing::warn!("{}: cannot remove ({e})", d.display());
            }
        }
    }
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = folder(path);
    let ctx = || format!("{}: cannot write", path.display());
    let mut tmp = haze_core::temp_output::temp_output(&dir).with_context(ctx)?;
    tmp.write_all(bytes).with_context(ctx)?;
    tmp.persist(path).map_err(|e| e.error).with_context(ctx)?;
    Ok(())
}

/// Writes pretty JSON (and a final newline) atomically.
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let mut text = serde_json::to_vec_pretty(value)?;
    text.push(b'\n');
    write_atomic(path, &text)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(o: Outputs) -> String {
        o.check().unwrap_err().to_string()
    }

    /// One folder or file by another spelling or through a link is the same; two
    /// different ones, or one missing, are not.
    #[test]
    fn same_file_sees_through_spellings_and_links() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let (a, b) = (d.join("a"), d.join("b"));
        std::fs::create_dir(&a).unwrap();
        std::fs::create_dir(&b).unwrap();
        assert!(same_file(&a, &d.join("b/../a/.")));
        assert!(!same_file(&a, &b));
        assert!(!same_file(&a, &d.join("missing")));
        std::fs::write(d.join("f"), [0u8]).unwrap();
        std::fs::hard_link(d.join("f"), d.join("g")).unwrap();
        assert!(same_file(&d.join("f"), &d.join("g")));
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(&a, d.join("link")).unwrap();
            assert!(same_file(&a, &d.join("link")));
        }
    }

    #[test]
    fn an_output_that_is_an_input_or_another_output_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let input = d.join("v.f32");
        std::fs::write(&input, [0u8; 4]).unwrap();
        std::fs::write(d.join("v.json"), "{}").unwrap();
        // The same file by another spelling, its sidecar, a hard link, a symlink.
        let dotted = d.join(".").join("v.f32");
        let e = err(Outputs::new().input(&input).output("--out", &dotted));
        assert!(e.contains("--out is the input"), "{e}");
        let e = err(Outputs::new()
            .input(&input)
            .output("--out", &d.join("v.json")));
        assert!(e.contains("v.json: --out is the input"), "{e}");
        std::fs::hard_link(&input, d.join("hard.f32")).unwrap();
        let e = err(Outputs::new()
            .input(&input)
            .output("--out", &d.join("hard.f32")));
        assert!(e.contains("is the input"), "{e}");
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(&input, d.join("soft.npy")).unwrap();
            let e = err(Outputs::new()
                .input(&input)
                .output("--out", &d.join("soft.npy")));
            assert!(e.contains("is the input"), "{e}");
        }
        // Two outputs on one file not yet written.
        let e = err(Outputs::new()
            .input(&input)
            .output("--out", &d.join("o.haze"))
            .output("--report", &d.join("sub/../o.haze")));
        assert!(
            e.contains("does not exist") || e.contains("same file"),
            "{e}"
        );
        let e = err(Outputs::new()
            .input(&input)
            .output("--out", &d.join("o.haze"))
            .output("--report", &d.join("./o.haze")));
        assert!(e.contains("--report is the same file as --out"), "{e}");
        // A frame of a directory input.
        let frames = d.join("frames");
        std::fs::create_dir(&frames).unwrap();
        std::fs::write(frames.join("f_0001.npy"), b"x").unwrap();
        let e = err(Outputs::new()
            .input(&frames)
            .output("--out", &frames.join("f_0001.npy")));
        assert!(e.contains("is the input"), "{e}");
        // A Blender cache's frame brings its configuration.
        let cache = d.join("cache");
        std::fs::create_dir_all(cache.join("data")).unwrap();
        std::fs::create_dir_all(cache.join("config")).unwrap();
        std::fs::write(cache.join("data/fluid_data_0007.vdb"), b"x").unwrap();
        std::fs::write(cache.join("config/config_0007.uni"), b"x").unwrap();
        let e = err(Outputs::new()
            .input(&cache.join("data"))
            .output("--report", &cache.join("config/config_0007.uni")));
        assert!(
            e.contains("config_0007.uni") && e.contains("is the input"),
            "{e}"
        );
        std::fs::remove_dir_all(&cache).unwrap();
        // Different files pass, and the probe leaves nothing behind.
        Outputs::new()
            .input(&input)
            .output("--out", &d.join("o.haze"))
            .output("--report", &d.join("r.json"))
            .check()
            .unwrap();
        let names: Vec<_> = std::fs::read_dir(d).unwrap().collect();
        assert_eq!(names.len(), 5, "{names:?}");
    }

    /// An asset must be named `.haze` (in any case), else nothing would read it back.
    #[test]
    fn an_asset_not_named_haze_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let e = err(Outputs::new().asset("--out", &d.join("smoke.bin")));
        assert!(e.contains("smoke.bin: --out must end in .haze"), "{e}");
        let e = err(Outputs::new().asset("--out", &d.join("smoke")));
        assert!(e.contains("must end in .haze"), "{e}");
        // A directory keeps its own message.
        let e = err(Outputs::new().asset("--out", d));
        assert!(e.contains("is a directory"), "{e}");
        for name in ["smoke.haze", "SMOKE.HAZE"] {
            Outputs::new()
                .asset("--out", &d.join(name))
                .check()
                .unwrap();
        }
    }

    #[test]
    fn an_output_that_cannot_be_written_is_refused_before_the_work() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let e = err(Outputs::new().output("--report", &d.join("missing/r.json")));
        assert!(
            e.contains("--report's folder") && e.contains("does not exist"),
            "{e}"
        );
        let e = err(Outputs::new().output("--out", d));
        assert!(e.contains("is a directory"), "{e}");
        // /proc takes no new files, whoever runs the test.
        if Path::new("/proc/self").exists() {
            let e = err(Outputs::new().output("--report", Path::new("/proc/r.json")));
            assert!(e.contains("cannot be written in /proc"), "{e}");
        }
    }

    #[test]
    fn created_files_are_removed_unless_kept() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        std::fs::write(&a, b"1").unwrap();
        std::fs::write(&b, b"2").unwrap();
        let mut failed = Created::new();
        failed.push(a.clone());
        drop(failed);
        assert!(!a.exists());
        let mut done = Created::new();
        done.push(b.clone());
        done.keep();
        assert!(b.exists());
    }

    #[test]
    fn a_directory_made_by_a_failed_run_is_removed_and_one_that_existed_stays() {
        let root = tempfile::tempdir().unwrap();
        let made = root.path().join("new/inner");
        let mut failed = Created::new();
        failed.dir("--out", &made).unwrap();
        std::fs::write(made.join("tradeoff.json"), b"{}").unwrap();
        drop(failed);
        assert!(!root.path().join("new").exists());

        let mut again = Created::new();
        again.dir("--out", root.path()).unwrap();
        drop(again);
        assert!(root.path().is_dir());

        let mut done = Created::new();
        done.dir("--out", &made).unwrap();
        done.keep();
        assert!(made.is_dir());

        let file = root.path().join("f");
        std::fs::write(&file, b"1").unwrap();
        let e = Created::new().dir("--out", &file.join("d")).unwrap_err();
        assert!(
            e.to_string().contains("cannot create --out's directory"),
            "{e}"
        );
    }
}
