//! Perfect spatial hashing (Lefebvre & Hoppe 2006, "Perfect Spatial Hashing").
//!
//! `K` cells `p` of a 3-D integer domain, each with a value, go into a hash table `H` of
//! side `m̄` (`m̄³ ≥ K`) through an offset table `Φ` of side `r̄`:
//!
//! ```text
//! h(p) = (h₀(p) + Φ[h₁(p)]) mod m̄,   h₀(p) = p mod m̄,   h₁(p) = p mod r̄   (per axis)
//! ```
//!
//! Construction: cells are grouped by `h₁` into buckets; buckets are placed largest first,
//! each by searching an offset `Φ` that sends all of its cells to free slots; one-cell
//! buckets, which come last, take any free slot directly. `r̄` starts at `⌈∛(K/5)⌉`
//! (Lefebvre & Hoppe's `r̄³ ≈ σK` with σ ≈ 0.2; paper A's `⌈∛(K/3)⌉ + 9` is 2–6× larger for
//! the few thousand bricks of a frame, and `Φ` is then a large part of the bytes), is kept
//! coprime with `m̄` (so `h₀` and `h₁` are independent), and grows by an eighth when a
//! bucket cannot be placed, a bounded number of times.
//!
//! Lookups are exact: every slot stores its cell's key (linear index in the domain, plus
//! one; 0 is an empty slot), so a cell without data reads `None`, never another cell's
//! payload.
//!
//! The layout is flat arrays for GPU upload: `Φ` as one `u32` per entry (three 10-bit
//! components), keys and payloads as `u32`. [`PerfectHash::get`] is the lookup the shader
//! mirrors. The residual hashes bricks of voxels, not voxels (see [`crate::tile`]): the
//! payload of a brick says where its packed values start and how wide they are.

use serde::Serialize;

/// Largest hash table side (offset components are 10 bits).
pub const MAX_SIDE: u32 = 1024;

/// Limits of the construction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct BuildOptions {
    /// How many offset tables (growing each time) to try before giving up.
    pub max_attempts: u32,
    /// Offsets tried per multi-cell bucket before the attempt fails.
    pub tries_per_bucket: u32,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            max_attempts: 24,
            tries_per_bucket: 1 << 16,
        }
    }
}

/// Why a hash could not be built.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum HashError {
    #[error(
        "the residual is too dense to hash: {cells} bricks did not fit a {m}³ table with offset tables up to {r}³ in {attempts} attempts (accept a larger --residual-error or use more RBFs)"
    )]
    TooDense {
        cells: usize,
        m: u32,
        r: u32,
        attempts: u32,
    },
    #[error("{0}")]
    Invalid(String),
}

/// A perfect spatial hash of `u32` payloads over a 3-D domain.
#[derive(Clone, Debug, PartialEq)]
pub struct PerfectHash {
    pub domain: [u32; 3],
    /// Hash table side `m̄`.
    pub m: u32,
    /// Offset table side `r̄`.
    pub r: u32,
    /// `Φ`: `r̄³` packed offsets `x | y << 10 | z << 20`.
    pub offsets: Vec<u32>,
    /// `m̄³` keys: linear cell index + 1, or 0 for an empty slot.
    pub keys: Vec<u32>,
    /// `m̄³` payloads (0 in empty slots).
    pub payloads: Vec<u32>,
}

fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 { a } else { gcd(b, a % b) }
}

fn coprime_at_least(r: u32, m: u32) -> u32 {
    (r.max(1)..).find(|&v| gcd(v, m) == 1).unwrap_or(r)
}

#[inline]
fn unpack(o: u32) -> [u32; 3] {
    [o & 1023, (o >> 10) & 1023, (o >> 20) & 1023]
}

impl PerfectHash {
    /// Builds the hash of `cells` (distinct coordinates inside `domain`, with payloads).
    pub fn build(
        domain: [u32; 3],
        cells: &[([u32; 3], u32)],
        opts: BuildOptions,
    ) -> Result<PerfectHash, HashError> {
        let volume = u64::from(domain[0]) * u64::from(domain[1]) * u64::from(domain[2]);
        if volume >= u64::from(u32::MAX) {
            return Err(HashError::Invalid(format!(
                "domain {domain:?} has {volume} cells; keys hold at most 2³²−1"
            )));
        }
        if let Some((p, _)) = cells
            .iter()
            .find(|(p, _)| (0..3).any(|a| p[a] >= domain[a]))
        {
            return Err(HashError::Invalid(format!(
                "cell {p:?} lies outside {domain:?}"
            )));
        }
        let k = cells.len();
        let m = Self::side_for(k);
        if m > MAX_SIDE {
            return Err(HashError::Invalid(format!(
                "{k} cells need a table side over {MAX_SIDE}"
            )));
        }
        let mut r = coprime_at_least(((k as f64) / 5.0).cbrt().ceil() as u32, m);
        for _ in 0..opts.max_attempts {
            if let Some(h) = Self::try_build(domain, cells, m, r, opts.tries_per_bucket) {
                return Ok(h);
            }
            r = coprime_at_least(r + r.div_ceil(8), m);
        }
        Err(HashError::TooDense {
            cells: k,
            m,
            r,
            attempts: opts.max_attempts,
        })
    }

    /// The hash table side for `k` cells: the least `m̄ ≥ 1` with `m̄³ ≥ k`.
    pub fn side_for(k: usize) -> u32 {
        let mut m = (k as f64).cbrt().ceil().max(1.0) as u32;
        while u64::from(m).pow(3) < k as u64 {
            m += 1;
        }
        while m > 1 && u64::from(m - 1).pow(3) >= k as u64 {
            m -= 1;
        }
        m
    }

    fn try_build(
        domain: [u32; 3],
        cells: &[([u32; 3], u32)],
        m: u32,
        r: u32,
        tries: u32,
    ) -> Option<PerfectHash> {
        let (mu, ru) = (m as usize, r as usize);
        let slot = |h: [u32; 3]| h[0] as usize + mu * (h[1] as usize + mu * h[2] as usize);
        let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); ru * ru * ru];
        for (i, (p, _)) in cells.iter().enumerate() {
            let b = (p[0] % r) as usize + ru * ((p[1] % r) as usize + ru * (p[2] % r) as usize);
            buckets[b].push(i as u32);
        }
        let mut order: Vec<usize> = (0..buckets.len())
            .filter(|&b| !buckets[b].is_empty())
            .collect();
        order.sort_by(|&a, &b| buckets[b].len().cmp(&buckets[a].len()).then(a.cmp(&b)));
        let mut h = PerfectHash {
            domain,
            m,
            r,
            offsets: vec![0; ru * ru * ru],
            keys: vec![0; mu * mu * mu],
            payloads: vec![0; mu * mu * mu],
        };
        let key = |p: [u32; 3]| p[0] + domain[0] * (p[1] + domain[1] * p[2]) + 1;
        let table = (mu * mu * mu) as u64;
        // Which slots are taken, a bit each: the trials below test slots at random, and
        // this fits in a core's cache where the keys (32 bits a slot) do not.
        let mut taken = vec![0u64; (mu * mu * mu).div_ceil(64)];
        let is_taken = |taken: &[u64], s: usize| taken[s / 64] >> (s % 64) & 1 == 1;
        let mut free_cursor = 0usize;
        let mut slots = Vec::new();
        for &b in &order {
            let members = &buckets[b];
            let phi = if members.len() == 1 {
                // Any free slot will do: point the offset at it.
                while is_taken(&taken, free_cursor) {
                    free_cursor += 1;
                }
                let p = cells[members[0] as usize].0;
                let s = free_cursor;
                let target = [s % mu, (s / mu) % mu, s / (mu * mu)].map(|v| v as u32);
                [0, 1, 2].map(|a| (target[a] + m - p[a] % m) % m)
            } else {
                // Offsets in a fixed pseudo-random order (an LCG over the table), seeded by
                // the bucket so that neighbouring buckets do not probe alike.
                let mut state = (b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
                // The members' coordinates mod m̄, once (a table side is at most 1024, so
                // the table's size and every sum below fit 32 bits).
                let at: Vec<[u32; 3]> = members
                    .iter()
                    .map(|&i| cells[i as usize].0.map(|c| c % m))
                    .collect();
                let wrap = |v: u32| if v >= m { v - m } else { v };
                let mut found = None;
                for _ in 0..tries.min(u32::try_from(table).unwrap_or(u32::MAX)) {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let o = ((state >> 33) % table) as u32;
                    let phi = [o % m, (o / m) % m, o / (m * m)];
                    slots.clear();
                    let fits = at.iter().all(|q| {
                        let s = slot([0, 1, 2].map(|a| wrap(q[a] + phi[a])));
                        let ok = !is_taken(&taken, s) && !slots.contains(&s);
                        slots.push(s);
                        ok
                    });
                    if fits {
                        found = Some(phi);
                        break;
                    }
                }
                found?
            };
            h.offsets[b] = phi[0] | phi[1] << 10 | phi[2] << 20;
            for &i in members {
                let (p, v) = cells[i as usize];
                let s = slot([0, 1, 2].map(|a| (p[a] % m + phi[a]) % m));
                h.keys[s] = key(p);
                h.payloads[s] = v;
                taken[s / 64] |= 1 << (s % 64);
            }
        }
        Some(h)
    }

    /// The payload stored for cell `p`, or `None` when `p` has none (or lies outside the
    /// domain).
    #[inline]
    pub fn get(&self, p: [u32; 3]) -> Option<u32> {
        let d = self.domain;
        if p[0] >= d[0] || p[1] >= d[1] || p[2] >= d[2] {
            return None;
        }
        let s = self.slot(p);
        (self.keys[s] == p[0] + d[0] * (p[1] + d[1] * p[2]) + 1).then(|| self.payloads[s])
    }

    /// The table slot of cell `p`, `h(p) = (p mod m̄ + Φ[p mod r̄]) mod m̄` as a linear
    /// index (x fastest); `p` inside the domain, `Φ` of `r̄³` entries.
    #[inline]
    pub fn slot(&self, p: [u32; 3]) -> usize {
        let (m, r) = (self.m, self.r);
        let b = p[0] % r + r * (p[1] % r + r * (p[2] % r));
        let phi = unpack(self.offsets[b as usize]);
        let h = [0, 1, 2].map(|a| (p[a] % m + phi[a]) % m);
        (h[0] + m * (h[1] + m * h[2])) as usize
    }

    /// The coordinates of the cell whose key is `key` (its linear index plus one).
    #[inline]
    pub fn cell_of_key(&self, key: u32) -> [u32; 3] {
        let (d, i) = (self.domain, key - 1);
        [i % d[0], (i / d[0]) % d[1], i / (d[0] * d[1])]
    }

    /// Stored cells.
    pub fn len(&self) -> usize {
        self.keys.iter().filter(|&&k| k != 0).count()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bytes of the three arrays (what a GPU upload costs).
    pub fn bytes(&self) -> usize {
        4 * (self.offsets.len() + self.keys.len() + self.payloads.len())
    }
}

#[cfg(test)]
mod tests {
    use super::{BuildOptions, PerfectHash};

    /// A hash built without payloads, then given them at their cells' slots, is the hash
    /// built with them: placement depends on the cells alone (the residual's decoding
    /// builds the hash before the payloads are known).
    #[test]
    fn payloads_set_after_the_build_are_the_payloads_built_with() {
        let domain = [40, 30, 20];
        // Dense enough that buckets need several trials: every third cell of the domain.
        let cells: Vec<([u32; 3], u32)> = (0..40 * 30 * 20u32)
            .filter(|i| i % 3 == 0)
            .map(|i| {
                (
                    [i % 40, (i / 40) % 30, i / 1200],
                    i.wrapping_mul(2_654_435_761),
                )
            })
            .collect();
        let with = PerfectHash::build(domain, &cells, BuildOptions::default()).unwrap();
        let places: Vec<([u32; 3], u32)> = cells.iter().map(|&(p, _)| (p, 0)).collect();
        let mut later = PerfectHash::build(domain, &places, BuildOptions::default()).unwrap();
        for &(p, v) in &cells {
            let s = later.slot(p);
            later.payloads[s] = v;
        }
        assert_eq!(later, with);
    }

    /// `side_for` is the least side whose cube holds k (brute force, float cube roots
    /// near perfect cubes included), and 1 for no cells.
    #[test]
    fn side_for_is_the_least_cube_side() {
        for k in (0..20_000usize).chain([999_999, 1_000_000, 1_000_001, 1 << 30]) {
            let m = u64::from(PerfectHash::side_for(k));
            let least = (1u64..).find(|&s| s * s * s >= k.max(1) as u64).unwrap();
            assert_eq!(m, least, "k = {k}");
        }
    }
}
