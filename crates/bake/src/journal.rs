//! The bake journal, `OUT.partial` beside the asset: every finished frame and hash volume
//! is appended to it (and synced) as soon as it exists, so an interrupted bake — killed,
//! out of time on a farm, a machine gone — loses nothing finished, and `--resume` goes on
//! from the last finished frame. The asset itself is written only at the end, to a
//! temporary file renamed into place, so it is never half-written; the journal is removed
//! once the asset is complete.
//!
//! Layout: the 8-byte magic `HAZEJNL1`, then records
//! `tag u32 | json_len u32 | bin_len u32 | crc32 u32 | json | bin` (little-endian; the
//! CRC covers tag, lengths, JSON and binary). A record cut short or failing its CRC ends
//! the journal: it is the one being written when the bake stopped, and is dropped.

use anyhow::{Context, Result, bail};
use serde_json::Value;
use std::fs::{File, OpenOptions};
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"HAZEJNL1";
const RECORD_HEAD: usize = 16;

/// What a record holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tag {
    /// The bake's settings and inputs (JSON); the first record.
    Start = 1,
    /// A finished frame: its report line and fitter state (JSON), its RBF block (binary).
    Frame = 2,
    /// A finished hash volume: its frames and their shares (JSON), its block (binary).
    Group = 3,
}

impl Tag {
    fn from_code(c: u32) -> Option<Tag> {
        match c {
            1 => Some(Tag::Start),
            2 => Some(Tag::Frame),
            3 => Some(Tag::Group),
            _ => None,
        }
    }
}

/// One record read back.
#[derive(Debug)]
pub struct Record {
    pub tag: Tag,
    pub json: Value,
    pub bin: Vec<u8>,
}

/// The journal of `out`: `out` with `.partial` appended.
pub fn path_for(out: &Path) -> PathBuf {
    let mut name = out.as_os_str().to_owned();
    name.push(".partial");
    PathBuf::from(name)
}

/// An open journal, appending.
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    file: File,
}

fn crc(tag: u32, json: &[u8], bin: &[u8]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(&tag.to_le_bytes());
    h.update(&(json.len() as u32).to_le_bytes());
    h.update(&(bin.len() as u32).to_le_bytes());
    h.update(json);
    h.update(bin);
    h.finalize()
}

/// Parses the records of a journal file's bytes; returns them and the length of the
/// intact prefix.
fn parse(path: &Path, bytes: &[u8]) -> Result<(Vec<Record>, usize)> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        bail!("{}: not a haze bake journal", path.display());
    }
    let mut records = Vec::new();
    let mut pos = MAGIC.len();
    let u32_at =
        |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    while bytes.len() - pos >= RECORD_HEAD {
        let (code, jl, bl, sum) = (
            u32_at(pos),
            u32_at(pos + 4) as usize,
            u32_at(pos + 8) as usize,
            u32_at(pos + 12),
        );
        let body = pos + RECORD_HEAD;
        let Some(end) = body.checked_add(jl).and_then(|e| e.checked_add(bl)) else {
            break;
        };
        if end > bytes.len() {
            break;
        }
        let (json, bin) = (&bytes[body..body + jl], &bytes[body + jl..end]);
        if crc(code, json, bin) != sum {
            break;
        }
        let Some(tag) = Tag::from_code(code) else {
            bail!("{}: unknown record type {code}", path.display());
        };
        let json = serde_json::from_slice(json)
            .with_context(|| format!("{}: unreadable record", path.display()))?;
        records.push(Record {
            tag,
            json,
            bin: bin.to_vec(),
        });
        pos = end;
    }
    Ok((records, pos))
}

impl Journal {
    /// Starts a new journal at `path` (replacing any), with its `Start` record.
    pub fn create(path: &Path, start: &Value) -> Result<Journal> {
        let ctx = || format!("{}: cannot write the bake journal", path.display());
        let mut file = File::create(path).with_context(ctx)?;
        file.write_all(MAGIC).with_context(ctx)?;
        let mut j = Journal {
            path: path.to_path_buf(),
            file,
        };
        j.append(Tag::Start, start, &[])?;
        Ok(j)
    }

    /// Opens an existing journal: its intact records, and the journal positioned to append
    /// after them (a torn last record is cut off). `None` when there is no journal.
    pub fn open(path: &Path) -> Result<Option<(Journal, Vec<Record>)>> {
        let bytes = match std::fs::read(path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e).with_context(|| format!("{}: cannot read", path.display())),
        };
        let (records, good) = parse(path, &bytes)?;
        if records.first().is_none_or(|r| r.tag != Tag::Start) {
            bail!("{}: the bake journal has no start record", path.display());
        }
        let ctx = || format!("{}: cannot append to the bake journal", path.display());
        let mut file = OpenOptions::new()
            .write(true)
            .open(path)
            .with_context(ctx)?;
        file.set_len(good as u64).with_context(ctx)?;
        file.seek(SeekFrom::End(0)).with_context(ctx)?;
        Ok(Some((
            Journal {
                path: path.to_path_buf(),
                file,
            },
            records,
        )))
    }

    /// Appends a record and syncs it to disk.
    pub fn append(&mut self, tag: Tag, json: &Value, bin: &[u8]) -> Result<()> {
        let ctx = || format!("{}: cannot write the bake journal", self.path.display());
        let json = serde_json::to_vec(json)?;
        let (Ok(jl), Ok(bl)) = (u32::try_from(json.len()), u32::try_from(bin.len())) else {
            bail!("{}: record too large for the journal", self.path.display());
        };
        let code = tag as u32;
        let mut rec = Vec::with_capacity(RECORD_HEAD + json.len() + bin.len());
        for v in [code, jl, bl, crc(code, &json, bin)] {
            rec.extend_from_slice(&v.to_le_bytes());
        }
        rec.extend_from_slice(&json);
        rec.extend_from_slice(bin);
        self.file.write_all(&rec).with_context(ctx)?;
        self.file.sync_data().with_context(ctx)?;
        Ok(())
    }

    /// Removes the journal (the asset is complete).
    pub fn remove(self) -> Result<()> {
        drop(self.file);
        std::fs::remove_file(&self.path)
            .with_context(|| format!("{}: cannot remove the bake journal", self.path.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn records_round_trip_and_a_torn_tail_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.haze.partial");
        let mut j = Journal::create(&path, &json!({"k": 1})).unwrap();
        j.append(Tag::Frame, &json!({"frame": 3, "x": 0.1}), &[1, 2, 3])
            .unwrap();
        j.append(Tag::Group, &json!([1]), &[9; 100]).unwrap();
        drop(j);
        let full = std::fs::read(&path).unwrap();
        // Every cut inside the last record drops exactly that record.
        for cut in (full.len() - 116)..full.len() {
            std::fs::write(&path, &full[..cut]).unwrap();
            let (mut j, recs) = Journal::open(&path).unwrap().unwrap();
            assert_eq!(recs.len(), 2, "cut at {cut}");
            assert_eq!(recs[1].json, json!({"frame": 3, "x": 0.1}));
            assert_eq!(recs[1].bin, vec![1, 2, 3]);
            // Appending after a torn record gives a clean journal again.
            j.append(Tag::Group, &json!([2]), &[7]).unwrap();
            drop(j);
            let (_, recs) = Journal::open(&path).unwrap().unwrap();
            assert_eq!(recs.len(), 3);
            assert_eq!(recs[2].tag, Tag::Group);
            assert_eq!(recs[2].bin, vec![7]);
        }
        // A flipped byte in a record's body ends the journal there.
        let mut bad = full.clone();
        let n = bad.len();
        bad[n - 50] ^= 1;
        std::fs::write(&path, &bad).unwrap();
        let (_, recs) = Journal::open(&path).unwrap().unwrap();
        assert_eq!(recs.len(), 2);
        // Not a journal at all.
        std::fs::write(&path, b"something else").unwrap();
        let e = Journal::open(&path).unwrap_err().to_string();
        assert!(e.contains("not a haze bake journal"), "{e}");
        assert!(Journal::open(&dir.path().join("none")).unwrap().is_none());
    }
}
