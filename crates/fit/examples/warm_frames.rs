//! Per-frame cost of warm-started fitting on a volume that drifts one voxel along +x per
//! frame (a stand-in for a sequence at any resolution): prints each frame's RBF count,
//! errors, iterations and seconds.
//!
//! cargo run --release -p haze-fit --example warm_frames -- VOLUME [RBFS] [FRAMES] [TOLERANCE]

use haze_fit::{SequenceFitter, SequenceOptions};
use haze_volume::{ImportOptions, Volume, import};

fn shifted(v: &Volume, s: usize) -> Volume {
    let [nx, ny, nz] = v.dims();
    let mut out = Volume::zeros(v.dims(), *v.bbox()).unwrap_or_else(|e| panic!("{e}"));
    for z in 0..nz {
        for y in 0..ny {
            for x in s..nx {
                let i = out.index(x, y, z);
                out.data_mut()[i] = v.get(x - s, y, z);
            }
        }
    }
    out
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: warm_frames VOLUME [RBFS] [FRAMES] [TOLERANCE]");
        std::process::exit(2);
    };
    let rbfs = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(600);
    let frames = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(6);
    let mut opts = SequenceOptions {
        rbfs,
        ..SequenceOptions::default()
    };
    if let Some(t) = args.get(3).and_then(|a| a.parse().ok()) {
        opts.fit.stop.relative_reduction = t;
    }
    let v = match import::import(std::path::Path::new(path), &ImportOptions::default()) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let mut fitter = SequenceFitter::new(opts);
    println!("| frame | RBFs | rel_l2 | rms_over_max | iterations | inserted | seconds |");
    println!("|---|---|---|---|---|---|---|");
    for k in 0..frames {
        let f = match fitter.fit(&shifted(&v, k)) {
            Ok(f) => f,
            Err(e) => {
                eprintln!("error: {path}: {e}");
                std::process::exit(1);
            }
        };
        println!(
            "| {k} | {} | {:.4} | {:.2} % | {} | {} | {:.2} |",
            f.rbfs.len(),
            f.rel_l2,
            f.rms_over_max * 100.0,
            f.iterations,
            f.inserted,
            f.fit_seconds
        );
    }
}
