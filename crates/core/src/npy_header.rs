//! A guard in front of the `.npy` reader (npyz): its header is a Python literal parsed by
//! a backtracking parser whose time grows exponentially with nested brackets, so a
//! 173-byte file of `[[[[…` kept it busy for minutes. A NumPy array's header is a flat
//! dict holding at most a tuple (the shape): brackets nest at most two deep (three with
//! a structured `descr`, which haze does not read either).

/// Checks the header of the `.npy` bytes `npy` (magic, version, length) nests brackets
/// at most two deep; the error is the problem in words. Bytes that are not a `.npy` file
/// pass, for the reader to name.
pub fn check(npy: &[u8]) -> Result<(), String> {
    const MAGIC: &[u8] = b"\x93NUMPY";
    if npy.len() < 10 || !npy.starts_with(MAGIC) {
        return Ok(());
    }
    let (len, start): (usize, usize) = match npy[6] {
        1 => (usize::from(u16::from_le_bytes([npy[8], npy[9]])), 10),
        _ if npy.len() >= 12 => (
            u32::from_le_bytes([npy[8], npy[9], npy[10], npy[11]]) as usize,
            12,
        ),
        _ => return Ok(()),
    };
    let header = &npy[start..npy.len().min(start.saturating_add(len))];
    let (mut depth, mut deepest) = (0usize, 0usize);
    for &b in header {
        match b {
            b'(' | b'[' | b'{' => {
                depth += 1;
                deepest = deepest.max(depth);
            }
            b')' | b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    if deepest > 2 {
        return Err(format!(
            "the header nests brackets {deepest} deep; a NumPy array's header is a dict with a shape tuple (2 deep)"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::check;

    fn npy(header: &str) -> Vec<u8> {
        let mut v = b"\x93NUMPY\x01\x00".to_vec();
        v.extend_from_slice(&(header.len() as u16).to_le_bytes());
        v.extend_from_slice(header.as_bytes());
        v
    }

    #[test]
    fn a_flat_header_passes_and_nested_brackets_are_refused_at_once() {
        assert!(
            check(&npy(
                "{'descr': '<f4', 'fortran_order': False, 'shape': (4, 4, 4), }\n"
            ))
            .is_ok()
        );
        assert!(
            check(&npy(
                "{'descr': '<f8', 'fortran_order': True, 'shape': (), }"
            ))
            .is_ok()
        );
        let deep = format!("{{'descr':{}", "[".repeat(60));
        let e = check(&npy(&deep)).unwrap_err();
        assert!(e.contains("61 deep"), "{e}");
        // Not a .npy file, or cut short: left to the reader.
        assert!(check(b"PNG").is_ok());
        assert!(check(b"\x93NUMPY\x02\x00\x05").is_ok());
        let mut cut = npy("{'shape': ((((");
        cut.truncate(14);
        assert!(check(&cut).is_ok());
    }
}
