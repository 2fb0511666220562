//! Like `asset_reader`, but first rewrites every checksum the input's own preamble and
//! index point at, so mutations reach the header, index and block decoding instead of
//! stopping at the first CRC.
#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;

fn u64_at(b: &[u8], i: usize) -> u64 {
    u64::from_le_bytes(b[i..i + 8].try_into().unwrap())
}

fn range(b: &[u8], off: u64, len: u64) -> Option<std::ops::Range<usize>> {
    let end = off.checked_add(len)?;
    (end <= b.len() as u64).then(|| off as usize..end as usize)
}

fn fix_checksums(b: &mut [u8]) {
    if b.len() < 64 {
        return;
    }
    let (ho, hl, io, n) = (u64_at(b, 16), u64_at(b, 24), u64_at(b, 32), u64_at(b, 40));
    if let Some(r) = range(b, io, n.saturating_mul(40)) {
        for e in r.clone().step_by(40) {
            if let Some(br) = range(b, u64_at(b, e + 16), u64_at(b, e + 24)) {
                let crc = crc32fast::hash(&b[br]);
                b[e + 12..e + 16].copy_from_slice(&crc.to_le_bytes());
            }
        }
        let crc = crc32fast::hash(&b[r]);
        b[52..56].copy_from_slice(&crc.to_le_bytes());
    }
    if let Some(r) = range(b, ho, hl) {
        let crc = crc32fast::hash(&b[r]);
        b[48..52].copy_from_slice(&crc.to_le_bytes());
    }
    let crc = crc32fast::hash(&b[0..56]);
    b[56..60].copy_from_slice(&crc.to_le_bytes());
}

fuzz_target!(|data: &[u8]| {
    let mut b = data.to_vec();
    fix_checksums(&mut b);
    common::exercise(&b);
});
