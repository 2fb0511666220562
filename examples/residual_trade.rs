//! The storage/accuracy trade of the quantized, hashed residual (paper A §5.2), printed as
//! the tables of BENCHMARKS.md.
//!
//! ```text
//! cargo run --release --example residual_trade -- INPUT [--frames A..B] [--upsample F]
//!     [--rbfs N,N,..] [--errors E,E,..] [--bricks B,B,..] [--bits B]
//! ```
//!
//! Fits the frames of INPUT (a sequence, up to 27 frames: one hash volume; optionally
//! resampled by F with trilinear interpolation) as `haze bake` does, then for every RBF
//! count, `--residual-error` E and brick side: the non-zero residual voxels and stored
//! bricks per frame, the share of bricks at each width, the reconstruction error of
//! `D̃ + R̂` against `D` (max and RMS over each frame's peak), the hash volume's bytes per
//! frame (the asset block) and per non-zero voxel, hashing time per frame (quantization +
//! build), random lookups per second (one thread), and what the same quantized residual
//! costs as a dense 8/16-bit array through zstd (level 3) and as a coordinate list (u32
//! index + 8/16-bit value).

use haze_fit::{SequenceFitter, SequenceOptions};
use haze_hash::pack::Width;
use haze_hash::tile::{GROUP, ResidualGroup, unpayload};
use haze_hash::{BuildOptions, QuantOptions, block, quantize};
use haze_volume::import::{FrameRange, Sequence};
use haze_volume::{ImportOptions, Rbf, Volume, rbf};
use std::time::Instant;

struct Args {
    input: String,
    range: FrameRange,
    upsample: f64,
    rbfs: Vec<usize>,
    errors: Vec<f64>,
    bricks: Vec<u32>,
    bits: u8,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        input: String::new(),
        range: FrameRange::default(),
        upsample: 1.0,
        rbfs: vec![300],
        errors: vec![haze_hash::DEFAULT_ERROR],
        bricks: vec![4],
        bits: 8,
    };
    let mut it = std::env::args().skip(1);
    while let Some(s) = it.next() {
        let mut val = || it.next().ok_or(format!("{s} needs a value"));
        match s.as_str() {
            "--frames" => a.range = val()?.parse()?,
            "--upsample" => a.upsample = val()?.parse().map_err(|e| format!("{e}"))?,
            "--rbfs" => a.rbfs = list(&val()?)?,
            "--errors" => a.errors = list(&val()?)?,
            "--bricks" => a.bricks = list(&val()?)?,
            "--bits" => a.bits = val()?.parse().map_err(|e| format!("--bits: {e}"))?,
            _ if a.input.is_empty() => a.input = s,
            _ => return Err(format!("unexpected argument {s}")),
        }
    }
    if a.input.is_empty() {
        return Err("usage: residual_trade INPUT [--frames A..B] [--upsample F] [--rbfs N,..] [--errors E,..] [--bricks B,..] [--bits B]".into());
    }
    Ok(a)
}

fn list<T: std::str::FromStr>(s: &str) -> Result<Vec<T>, String> {
    s.split(',')
        .map(|t| t.trim().parse().map_err(|_| format!("bad list item '{t}'")))
        .collect()
}

/// Trilinear resampling by `f` (voxel centers), same world box.
fn upsample(v: &Volume, f: f64) -> Volume {
    if f == 1.0 {
        return v.clone();
    }
    let d = v.dims();
    let n = d.map(|k| ((k as f64 * f).round() as usize).max(1));
    let mut out = Volume::zeros(n, *v.bbox()).expect("resampled dims");
    let src = |k: usize, a: usize| {
        let x = ((k as f64 + 0.5) * d[a] as f64 / n[a] as f64 - 0.5).clamp(0.0, (d[a] - 1) as f64);
        let i = (x.floor() as usize).min(d[a].saturating_sub(2));
        (i, x - i as f64)
    };
    for z in 0..n[2] {
        let (z0, tz) = src(z, 2);
        for y in 0..n[1] {
            let (y0, ty) = src(y, 1);
            for x in 0..n[0] {
                let (x0, tx) = src(x, 0);
                let mut s = 0.0;
                for (dz, wz) in [(0, 1.0 - tz), (1, tz)] {
                    for (dy, wy) in [(0, 1.0 - ty), (1, ty)] {
                        for (dx, wx) in [(0, 1.0 - tx), (1, tx)] {
                            let (xi, yi, zi) = (x0 + dx, y0 + dy, z0 + dz);
                            if xi < d[0] && yi < d[1] && zi < d[2] {
                                s += wz * wy * wx * f64::from(v.get(xi, yi, zi));
                            }
                        }
                    }
                }
                let i = out.index(x, y, z);
                out.data_mut()[i] = s as f32;
            }
        }
    }
    out
}

fn main() {
    let a = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let seq = Sequence::open(a.input.as_ref(), &ImportOptions::default(), a.range)
        .unwrap_or_else(|e| fail(&e.to_string()));
    let frames: Vec<Volume> = (0..seq.len().min(GROUP))
        .map(|i| {
            upsample(
                &seq.load(i).unwrap_or_else(|e| fail(&e.to_string())),
                a.upsample,
            )
        })
        .collect();
    let dims = frames[0].dims();
    let voxels = dims.iter().product::<usize>();
    println!(
        "{} frames of {}×{}×{} ({} voxels), {} cores",
        frames.len(),
        dims[0],
        dims[1],
        dims[2],
        voxels,
        rayon::current_num_threads()
    );
    println!();
    println!(
        "| RBFs | rel_l2 D̃ | E | brick | non-zero/frame | bricks/frame | 2/4/8/16-bit bricks | max err / peak | rms err / peak | hash B/frame | B/non-zero | hash ms/frame | lookups/s | dense+zstd | coord list |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for &n in &a.rbfs {
        let mut fitter = SequenceFitter::new(SequenceOptions {
            rbfs: n,
            ..SequenceOptions::default()
        });
        let t = Instant::now();
        let mut approx = Vec::new();
        let mut rel = 0.0;
        for v in &frames {
            let f = fitter.fit(v).unwrap_or_else(|e| fail(&e));
            rel += f.rel_l2 / frames.len() as f64;
            let stored: Vec<Rbf> = f
                .rbfs
                .iter()
                .map(|r| Rbf {
                    center: r.center.map(|c| f64::from(c as f32)),
                    radius: f64::from(r.radius as f32),
                    weight: f64::from(r.weight as f32),
                })
                .collect();
            approx.push(rbf::evaluate_on_grid(dims, v.bbox(), &stored));
        }
        eprintln!("{n} RBFs fitted in {:.1} s", t.elapsed().as_secs_f64());
        for &e in &a.errors {
            for &brick in &a.bricks {
                row(&frames, &approx, n, rel, (e, brick, a.bits), voxels);
            }
        }
    }
}

fn row(
    frames: &[Volume],
    approx: &[Vec<f64>],
    n: usize,
    rel: f64,
    (error, brick, bits): (f64, u32, u8),
    voxels: usize,
) {
    let dims = frames[0].dims();
    let t = Instant::now();
    let mut qs = Vec::new();
    let (mut max_err, mut sq) = (0.0f64, 0.0f64);
    for (v, ap) in frames.iter().zip(approx) {
        let r: Vec<f32> = v
            .data()
            .iter()
            .zip(ap)
            .map(|(d, a)| (f64::from(*d) - a) as f32)
            .collect();
        let peak = v.data().iter().fold(0.0f32, |m, d| m.max(*d));
        let q = quantize(&r, peak, QuantOptions { error, bits }).unwrap_or_else(|e| fail(&e));
        let p = f64::from(peak).max(f64::MIN_POSITIVE);
        max_err = max_err.max(q.max_error / p);
        sq += (q.rms_error / p).powi(2);
        qs.push(q);
    }
    let quant_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let g = ResidualGroup::build(dims.map(|d| d as u32), brick, &qs, BuildOptions::default())
        .unwrap_or_else(|e| fail(&e.to_string()));
    let bytes = block::encode(&g).unwrap_or_else(|e| fail(&e)).len();
    let hash_s = t.elapsed().as_secs_f64() + quant_s;

    // Random lookups over the frames (hits and misses alike).
    let lookups = 4_000_000u64;
    let t = Instant::now();
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut acc = 0.0f32;
    let dom = dims.map(|d| d as u64);
    for i in 0..lookups {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let p = [0, 1, 2].map(|k| ((state >> (20 * k)) % dom[k]) as u32);
        acc += g.lookup((i % frames.len() as u64) as usize, p);
    }
    let per_s = lookups as f64 / t.elapsed().as_secs_f64();
    std::hint::black_box(acc);

    let nf = frames.len() as f64;
    let cells: usize = qs.iter().map(|q| q.cells.len()).sum();
    let stored = g.hash.keys.iter().filter(|&&k| k != 0).count();
    let mut per_width = [0usize; 5];
    for (&k, &p) in g.hash.keys.iter().zip(&g.hash.payloads) {
        if let (true, Some((_, w))) = (k != 0, unpayload(p)) {
            per_width[w.code() as usize] += 1;
        }
    }
    let share = |w: Width| 100.0 * per_width[w.code() as usize] as f64 / stored.max(1) as f64;
    let vbytes = if qs.iter().any(|q| q.lossless) {
        4
    } else if qs
        .iter()
        .all(|q| q.cells.iter().all(|&(_, v)| (-128..128).contains(&v)))
    {
        1
    } else {
        2
    };
    let mut zstd_bytes = 0usize;
    for q in &qs {
        let mut dense = vec![0u8; voxels * vbytes];
        for &(i, v) in &q.cells {
            let i = i as usize * vbytes;
            dense[i..i + vbytes].copy_from_slice(&v.to_le_bytes()[..vbytes]);
        }
        zstd_bytes += zstd::bulk::compress(&dense, 3).expect("zstd").len();
    }
    let kb = |b: f64| format!("{:.1} kB", b / 1000.0);
    println!(
        "| {n} | {rel:.4} | {error:.4} | {brick} | {:.0} ({:.2} %) | {:.0} | {:.0}/{:.0}/{:.0}/{:.0} % | {:.2e} | {:.3} % | {} | {:.2} | {:.1} | {:.0} M | {} | {} |",
        cells as f64 / nf,
        100.0 * cells as f64 / nf / voxels as f64,
        stored as f64 / nf,
        share(Width::W2),
        share(Width::W4),
        share(Width::W8),
        share(Width::W16),
        max_err,
        100.0 * (sq / nf).sqrt(),
        kb(bytes as f64 / nf),
        bytes as f64 / cells.max(1) as f64,
        1000.0 * hash_s / nf,
        per_s / 1e6,
        kb(zstd_bytes as f64 / nf),
        kb(cells as f64 * (4 + vbytes) as f64 / nf),
    );
}

fn fail(e: &str) -> ! {
    eprintln!("error: {e}");
    std::process::exit(1)
}
