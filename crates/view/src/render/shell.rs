//! Which voxels the fast renderer lights: the smoke and its one-voxel shell. The CPU twin
//! of `shaders/lit.wgsl`.
//!
//! **Why.** The view pass reads the density trilinearly between voxel centers, so the
//! smoke reaches half a voxel and more beyond its last voxel with `D > 0`: a sample
//! there takes its radiance `J̃` from the corners of its cell, some of them empty. When
//! only voxels with `D > 0` were lit, that thin outer band borrowed the radiance of the
//! smoke's last voxel, lit at its center. Where light runs along the smoke's edge (a sun
//! behind or beside a plume) the center lies deep in that edge's shadow while the band,
//! where `D` falls to zero, is almost unshadowed: `τ` towards the light falls with `D`, so
//! the band's `T = e^{−τ}` climbs to 1. Silhouettes came out dark — on a held-out plume
//! back-lit by a soft sun, its last column of pixels at 60–75 % of the path tracer's and
//! single scattering 4.0 % off overall (lit on a grid twice as fine: 2.8 %).
//!
//! **The shell.** Every pass that gives voxels their `J̃` (the environment pass, the
//! lights pass, the multiple scattering's orders) also lights the empty voxels next to the
//! smoke: those with a voxel of `D > 0` among their 26 neighbours, each at its own
//! center, as if it held smoke. Every corner of a cell with `D > 0` somewhere in it is
//! then lit, so the view pass ([`super::crm::RadianceField`], which has the rule)
//! interpolates radiance that was computed where the band is. The shell is the smoke's
//! surface, one voxel thick: on a held-out 104 × 104 × 130 plume frame it made the
//! environment pass 19 % and the lights pass 30 % slower, the whole CPU frame 5 %; the
//! soft back-lit sun's single scattering went from 4.0 % to 2.2 % off the path tracer.

use haze_volume::Volume;

/// Per voxel (x fastest): true where `D > 0` at the voxel or at one of its 26 neighbours
/// (module docs). NaN and non-positive voxels are not density.
///
/// A 3 × 3 × 3 dilation, one axis at a time: along axis `a` (index stride `s`, `n`
/// voxels) the grid is a run of blocks of `s·n` entries in which entry `j` and `j ± s`
/// differ only by one step along `a`, so each pass ORs every entry with its two
/// neighbours' in the pass before, without an index's division.
pub fn lit_voxels(density: &Volume) -> Vec<bool> {
    let d = density.dims();
    let mut out: Vec<bool> = density.data().iter().map(|&v| v > 0.0).collect();
    if out.is_empty() {
        return out;
    }
    let mut before = vec![false; out.len()];
    let stride = [1, d[0], d[0] * d[1]];
    for a in 0..3 {
        if d[a] < 2 {
            continue;
        }
        let (s, block) = (stride[a], stride[a] * d[a]);
        before.copy_from_slice(&out);
        for (o, b) in out.chunks_mut(block).zip(before.chunks(block)) {
            for (o, &b) in o[s..].iter_mut().zip(&b[..block - s]) {
                *o |= b;
            }
            for (o, &b) in o[..block - s].iter_mut().zip(&b[s..]) {
                *o |= b;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_volume::Bbox;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    fn volume(dims: [usize; 3], smoke: &[[usize; 3]]) -> Volume {
        let mut data = vec![0.0f32; dims.iter().product()];
        for k in smoke {
            data[k[0] + dims[0] * (k[1] + dims[1] * k[2])] = 0.5;
        }
        let bbox = Bbox::new([0.0; 3], dims.map(|n| n as f64));
        Volume::new(dims, bbox, data).unwrap()
    }

    /// The lit voxels by their definition, neighbour by neighbour.
    fn brute(v: &Volume) -> Vec<bool> {
        let d = v.dims();
        let at = |x: i64, y: i64, z: i64| -> bool {
            let inside = x >= 0
                && y >= 0
                && z >= 0
                && (x as usize) < d[0]
                && (y as usize) < d[1]
                && (z as usize) < d[2];
            inside && v.data()[x as usize + d[0] * (y as usize + d[1] * z as usize)] > 0.0
        };
        let mut out = Vec::new();
        for z in 0..d[2] as i64 {
            for y in 0..d[1] as i64 {
                for x in 0..d[0] as i64 {
                    let mut any = false;
                    for (dx, dy, dz) in (-1..=1)
                        .flat_map(|a| (-1..=1).flat_map(move |b| (-1..=1).map(move |c| (a, b, c))))
                    {
                        any |= at(x + dx, y + dy, z + dz);
                    }
                    out.push(any);
                }
            }
        }
        out
    }

    #[test]
    fn one_voxel_lights_its_neighbourhood_clipped_to_the_grid() {
        let inner = volume([5, 5, 5], &[[2, 2, 2]]);
        assert_eq!(lit_voxels(&inner).iter().filter(|&&l| l).count(), 27);
        let corner = volume([5, 5, 5], &[[0, 0, 4]]);
        assert_eq!(lit_voxels(&corner).iter().filter(|&&l| l).count(), 8);
        assert_eq!(lit_voxels(&corner), brute(&corner));
    }

    #[test]
    fn the_dilation_equals_the_neighbour_test() {
        let v = volume(
            [7, 4, 6],
            &[[0, 0, 0], [3, 2, 1], [6, 3, 5], [4, 0, 3], [1, 3, 5]],
        );
        assert_eq!(lit_voxels(&v), brute(&v));
        // Axes one voxel thick.
        let flat = volume([6, 1, 3], &[[2, 0, 1]]);
        assert_eq!(lit_voxels(&flat), brute(&flat));
    }

    #[test]
    fn scattered_smoke_is_dilated_as_the_neighbour_test_says() {
        // Pseudo-random smoke (a seeded PCG) at about one voxel in
        // eight and one in sixty, on grids with every axis even, odd and one voxel thick.
        let mut rng = Pcg64::seed_from_u64(0x9e37_79b9_7f4a_7c15);
        for dims in [[9, 6, 7], [1, 8, 5], [10, 1, 4], [6, 5, 1], [2, 2, 2]] {
            for every in [8, 60] {
                let n: usize = dims.iter().product();
                let smoke: Vec<[usize; 3]> = (0..n)
                    .filter(|_| rng.random_range(0..every) == 0)
                    .map(|i| {
                        [
                            i % dims[0],
                            (i / dims[0]) % dims[1],
                            i / (dims[0] * dims[1]),
                        ]
                    })
                    .collect();
                let v = volume(dims, &smoke);
                assert_eq!(lit_voxels(&v), brute(&v), "{dims:?}, one in {every}");
            }
        }
    }

    #[test]
    fn nan_negative_and_empty_grids_light_nothing() {
        let dims = [3, 3, 3];
        let bbox = Bbox::new([0.0; 3], [3.0; 3]);
        let mut data = vec![0.0f32; 27];
        data[4] = f32::NAN;
        data[13] = -1.0;
        let v = Volume::new(dims, bbox, data).unwrap();
        assert!(lit_voxels(&v).iter().all(|&l| !l));
        let empty = Volume::new([0, 3, 3], bbox, Vec::new()).unwrap();
        assert!(lit_voxels(&empty).is_empty());
    }
}
