use super::*;
use crate::distant::direction;

/// A sky brighter towards the zenith and, `horizon > 0`, a glowing horizon band (`horizon`
/// times the base at the horizon, 8.6° wide), plus `lobes`: `(direction, peak, σ)` Gaussian
/// lobes `peak·exp(−θ²/2σ²)` (σ radians; 0 a disk of one texel's size is not needed) and
/// `disks`: `(direction, radiance, apex angle)` uniform disks. Each texel is the mean of
/// `sub × sub` subsamples weighted by `sin θ`, as a real map's texels average the sky.
/// Returns the map and, per lobe and disk in that order, its exact power `∫ excess dω`
/// (luminance) on this map's texels.
struct Synth {
    base: f64,
    horizon: f64,
    lobes: Vec<([f64; 3], f64, f64)>,
    disks: Vec<([f64; 3], f64, f64)>,
}

impl Synth {
    fn sky(base: f64) -> Synth {
        Synth {
            base,
            horizon: 0.0,
            lobes: Vec::new(),
            disks: Vec::new(),
        }
    }

    fn map(&self, w: usize, h: usize, sub: usize) -> (LatLong, Vec<f64>) {
        let n = self.lobes.len() + self.disks.len();
        let mut parts = vec![0.0; n];
        let mut texels = Vec::with_capacity(w * h);
        for y in 0..h {
            let (_, omega) = LatLong {
                width: w,
                height: h,
                texels: Vec::new(),
            }
            .texel_direction(0, y);
            for x in 0..w {
                let mut acc = vec![0.0; n];
                let mut norm = 0.0;
                for sy in 0..sub {
                    let theta = PI * (y as f64 + (sy as f64 + 0.5) / sub as f64) / h as f64;
                    for sx in 0..sub {
                        let phi = 2.0 * PI * (x as f64 + (sx as f64 + 0.5) / sub as f64) / w as f64;
                        let d = direction(theta, phi);
                        let wgt = theta.sin();
                        norm += wgt;
                        for (k, (dir, peak, sigma)) in self.lobes.iter().enumerate() {
                            let a = dot(d, *dir).clamp(-1.0, 1.0).acos();
                            acc[k] += wgt * peak * (-0.5 * (a / sigma).powi(2)).exp();
                        }
                        for (k, (dir, radiance, angle)) in self.disks.iter().enumerate() {
                            if dot(d, *dir) >= (0.5 * angle).cos() {
                                acc[self.lobes.len() + k] += wgt * radiance;
                            }
                        }
                    }
                }
                let theta = PI * (y as f64 + 0.5) / h as f64;
                let glow = self.horizon * (-((theta - 0.5 * PI) / 0.15).powi(2)).exp();
                let sky = self.base * (1.0 + 0.5 * theta.cos().max(0.0) + glow);
                let extra: f64 = acc.iter().map(|a| a / norm).sum();
                for (p, a) in parts.iter_mut().zip(&acc) {
                    *p += a / norm * omega;
                }
                let v = sky + extra;
                texels.push([v as f32, (0.9 * v) as f32, (0.8 * v) as f32]);
            }
        }
        // The map is grey-ish (1, 0.9, 0.8): its luminance is 0.9154 times the red.
        let y = 0.2126 + 0.7152 * 0.9 + 0.0722 * 0.8;
        (
            LatLong::new(w, h, texels).unwrap(),
            parts.iter().map(|p| p * y).collect(),
        )
    }
}

fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    dot(a, b).clamp(-1.0, 1.0).acos().to_degrees()
}

/// The suns' luminance-weighted mean direction and total luminance.
fn centroid(suns: &[Sun]) -> ([f64; 3], f64) {
    let mut s = [0.0; 3];
    let mut total = 0.0;
    for sun in suns {
        let y = luminance(sun.irradiance);
        total += y;
        for (v, d) in s.iter_mut().zip(sun.direction) {
            *v += y * d;
        }
    }
    (unit(s).unwrap_or([0.0, 0.0, 1.0]), total)
}

fn assert_power_kept(map: &LatLong, d: &Decomposition) {
    let (p0, p1) = (map_power(map), map_power(&d.rest));
    for c in 0..3 {
        let suns: f64 = d.suns.iter().map(|s| s.irradiance[c]).sum();
        // f32 texels: the rest is rounded to 2⁻²⁴ of each texel.
        assert!((p1[c] + suns - p0[c]).abs() < 1e-5 * p0[c], "channel {c}");
    }
}

#[test]
fn gaussian_suns_of_every_width_are_found_at_every_map_size() {
    // Sharp to soft suns, 450–840× the sky as in downloaded HDRIs, at the sizes of a
    // preview map up to a typical HDRI.
    let dir = direction(0.9, 2.2);
    for (sigma_deg, peak, sizes) in [
        (
            0.3f64,
            40_000.0,
            &[(512, 256), (1024, 512), (4096, 2048)][..],
        ),
        (0.75, 5_000.0, &[(512, 256), (2048, 1024)][..]),
        (2.0, 2_000.0, &[(512, 256), (1024, 512)][..]),
        (6.0, 840.0, &[(256, 128), (1024, 512)][..]),
        (8.0, 450.0, &[(256, 128), (512, 256)][..]),
    ] {
        for &(w, h) in sizes {
            let mut s = Synth::sky(1.0);
            s.lobes.push((dir, peak, sigma_deg.to_radians()));
            // Subsamples: enough to resolve the lobe inside a texel.
            let sub = (4.0 * (180.0 / h as f64) / sigma_deg)
                .ceil()
                .clamp(1.0, 16.0) as usize;
            let (map, parts) = s.map(w, h, sub);
            let d = decompose(&map, &DecomposeOptions::default());
            let (c, total) = centroid(&d.suns);
            let what = format!("σ {sigma_deg}° at {w}×{h}");
            assert!(!d.suns.is_empty(), "{what}: no sun");
            // 99 % of a lobe lies inside 3σ; the background's bilinear interpolation
            // between 2.8° texels takes a little of a broad lobe's tail: 4 %.
            assert!(
                (total / parts[0] - 1.0).abs() < 0.04,
                "{what}: {total} of {}",
                parts[0]
            );
            // The direction within a fifth of a coarse texel (2.8°) or of a fine one.
            let off = angle_deg(c, dir);
            assert!(off < 0.5, "{what}: off by {off}°");
            assert_power_kept(&map, &d);
            // The soft suns are split into a cluster whose spread is the lobe's:
            // ⟨θ²⟩ = 2σ² for a 2-D Gaussian.
            if sigma_deg >= 6.0 {
                assert!(d.suns.len() >= 4, "{what}: {} suns", d.suns.len());
            }
        }
    }
}

#[test]
fn two_suns_a_key_and_a_fill_are_two_clusters() {
    let (key, fill) = (direction(0.8, 0.5), direction(1.2, 3.5));
    let mut s = Synth::sky(0.5);
    s.lobes.push((key, 3000.0, 1.0f64.to_radians()));
    s.lobes.push((fill, 300.0, 3.0f64.to_radians()));
    let (map, parts) = s.map(512, 256, 4);
    let d = decompose(&map, &DecomposeOptions::default());
    assert_power_kept(&map, &d);
    // Each sun belongs to the nearer light; each cluster carries its light's power.
    let (mut near_key, mut near_fill) = (Vec::new(), Vec::new());
    for sun in &d.suns {
        if angle_deg(sun.direction, key) < angle_deg(sun.direction, fill) {
            near_key.push(sun.clone());
        } else {
            near_fill.push(sun.clone());
        }
    }
    for (cluster, dir, part, name) in [
        (&near_key, key, parts[0], "key"),
        (&near_fill, fill, parts[1], "fill"),
    ] {
        let (c, total) = centroid(cluster);
        assert!(
            (total / part - 1.0).abs() < 0.04,
            "{name}: {total} of {part}"
        );
        assert!(angle_deg(c, dir) < 0.5, "{name}");
    }
}

#[test]
fn a_disk_sun_is_found_and_a_low_sun_beside_a_bright_horizon_is_the_disk_alone() {
    for (dir, deg, horizon) in [
        (direction(1.0, 0.7), 6.0, 0.0),
        (direction(0.3, 3.0), 0.53, 0.0),
        // The horizon 6× the zenith's sky, the sun 20× and 4.6° above it.
        (direction(0.5 * PI - 0.08, 2.0), 5.0, 5.0),
    ] {
        let mut s = Synth::sky(1.0);
        s.horizon = horizon;
        let radiance = if deg < 1.0 { 20_000.0 } else { 20.0 };
        s.disks.push((dir, radiance, f64::to_radians(deg)));
        let (map, parts) = s.map(512, 256, 8);
        let d = decompose(&map, &DecomposeOptions::default());
        let (c, total) = centroid(&d.suns);
        // Beside the horizon the sun takes the glow behind it too (4.6° up, the glow is
        // 3.8× the base sky, a fifth of the disk's 20×): the map keeps that power, the
        // sun carries it in the disk's direction.
        let over = if horizon > 0.0 { 0.25 } else { 0.05 };
        assert!(
            total / parts[0] - 1.0 < over && total / parts[0] - 1.0 > -0.05,
            "{deg}°: {total} of {}",
            parts[0]
        );
        assert!(angle_deg(c, dir) < 0.5, "{deg}°");
        assert_power_kept(&map, &d);
        // The horizon band is no light: every sun is near the disk.
        for sun in &d.suns {
            assert!(
                angle_deg(sun.direction, dir) < deg + 3.0,
                "{deg}°: a sun elsewhere"
            );
        }
    }
}

#[test]
fn overcast_broad_and_black_maps_have_no_suns() {
    // A smooth sky with a glowing horizon: no concentrated light.
    let mut s = Synth::sky(1.0);
    s.horizon = 2.0;
    let (map, _) = s.map(256, 128, 2);
    let d = decompose(&map, &DecomposeOptions::default());
    assert!(d.suns.is_empty(), "{:?}", d.suns);
    assert_eq!(d.rest, map);
    // A bright region of 60°, 50× the sky: broad light, it stays in the map.
    let mut s = Synth::sky(1.0);
    s.disks.push(([1.0, 0.0, 0.0], 50.0, 60f64.to_radians()));
    let (map, _) = s.map(128, 64, 4);
    assert!(
        decompose(&map, &DecomposeOptions::default())
            .suns
            .is_empty()
    );
    // Black, and one texel.
    let black = LatLong::new(4, 2, vec![[0.0; 3]; 8]).unwrap();
    assert!(
        decompose(&black, &DecomposeOptions::default())
            .suns
            .is_empty()
    );
    let one = LatLong::new(1, 1, vec![[3.0; 3]]).unwrap();
    let d = decompose(&one, &DecomposeOptions::default());
    assert!(d.suns.is_empty() && d.rest == one);
    // No budget: the map stays whole.
    let mut s = Synth::sky(1.0);
    s.lobes.push(([0.0, 0.0, 1.0], 1000.0, 0.05));
    let (map, _) = s.map(64, 32, 2);
    let none = DecomposeOptions {
        max_lights: 0,
        ..DecomposeOptions::default()
    };
    assert!(decompose(&map, &none).suns.is_empty());
}

#[test]
fn one_bright_texel_in_a_black_map_is_a_sun_of_its_power() {
    let mut t = vec![[0.0f32; 3]; 64 * 32];
    t[10 * 64 + 5] = [100.0, 100.0, 100.0];
    let m = LatLong::new(64, 32, t).unwrap();
    let d = decompose(&m, &DecomposeOptions::default());
    assert_eq!(d.suns.len(), 1);
    let (dir, omega) = m.texel_direction(5, 10);
    assert!((d.suns[0].irradiance[0] - 100.0 * omega).abs() < 1e-9 * 100.0);
    assert!(dot(d.suns[0].direction, dir) > 1.0 - 1e-12);
    assert!(d.rest.texels.iter().all(|t| t[0] == 0.0));
    assert!((d.share(0) - 1.0).abs() < 1e-12);
}

#[test]
fn opening_keeps_smooth_skies_and_removes_narrow_peaks() {
    // A sky linear in cos θ: every cap's minimum and the maximum of those give it back
    // (an opening keeps monotone ramps) up to the coarse texels' discretization.
    let (w, h) = (128, 64);
    let texels: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let theta = PI * ((i / w) as f64 + 0.5) / h as f64;
            let v = (2.0 + theta.cos()) as f32;
            [v, v, v]
        })
        .collect();
    let map = LatLong::new(w, h, texels).unwrap();
    let coarse = Coarse::of(&map);
    let radius = DecomposeOptions::default().scale_degrees.to_radians();
    let open = coarse.opening(radius);
    for (o, t) in open.iter().zip(&coarse.texels) {
        // The ramp's maximum at the zenith loses at most the change of cos θ over the
        // cap's diameter from the pole, 1 − cos 2R; elsewhere it is kept.
        assert!(o[0] <= t[0] + 1e-12, "{o:?} {t:?}");
        assert!(
            t[0] - o[0] <= 1.0 - (2.0 * radius).cos() + 1e-9,
            "{o:?} {t:?}"
        );
    }
    // A one-texel peak is removed entirely.
    let mut tex = map.texels.clone();
    tex[20 * w + 40] = [1e4; 3];
    let peaked = Coarse::of(&LatLong::new(w, h, tex).unwrap());
    let open2 = peaked.opening(radius);
    assert!(open2[20 * w + 40][0] < 3.0 + 1e-9);
}

#[test]
fn running_windows_match_brute_force() {
    let row: Vec<Rgb> = (0..23)
        .map(|i| [((i * 7) % 11) as f64, (i % 5) as f64, -(i as f64)])
        .collect();
    for k in [0, 1, 2, 5, 10, 11, 30] {
        for (op, init) in [
            (f64::min as fn(f64, f64) -> f64, f64::INFINITY),
            (f64::max, f64::NEG_INFINITY),
        ] {
            let fast = running(&row, k, op, init);
            for x in 0..row.len() {
                let mut want = [init; 3];
                for dx in -(k as i64)..=k as i64 {
                    let v = row[(x as i64 + dx).rem_euclid(row.len() as i64) as usize];
                    for c in 0..3 {
                        want[c] = op(want[c], v[c]);
                    }
                }
                assert_eq!(fast[x], want, "k {k}, x {x}");
            }
        }
    }
}

/// A camera ray sees a map split into suns as the map itself (`Environment::backdrop`),
/// texel for texel, while the suns light the smoke; a sun added after the split (`--sun`)
/// keeps its disk. The suns' disks over the rest of the map, which the background showed
/// before, are a different picture of a soft sun: more than 10 % off it somewhere in the
/// lobe.
#[test]
fn a_map_split_into_suns_is_seen_as_given() {
    let dir = direction(0.9, 2.2);
    let mut s = Synth::sky(1.0);
    s.lobes.push((dir, 840.0, 6f64.to_radians()));
    let (map, _) = s.map(256, 128, 4);
    let (mut env, found) = crate::Environment::map_decomposed(&map, &DecomposeOptions::default());
    assert!(found.suns.len() > 1, "{} suns", found.suns.len());
    let extra = Sun::from_radiance(direction(2.0, 0.5), [5.0, 4.0, 3.0], 4.0).unwrap();
    env.suns.push(extra.clone());
    let disks = |d: [f64; 3]| {
        let mut out = env.distant.radiance(d);
        for sun in env.suns.iter().filter(|s| s.covers(d)) {
            (0..3).for_each(|c| out[c] += sun.radiance()[c]);
        }
        out
    };
    let mut worst = 0.0f64;
    for i in 0..400 {
        let z = 1.0 - (i as f64 + 0.5) / 200.0;
        let phi = i as f64 * 2.399_963;
        let r = (1.0 - z * z).sqrt();
        let d = [r * phi.cos(), r * phi.sin(), z];
        let want = map.radiance(d);
        let extra_disk = if extra.covers(d) {
            extra.radiance()
        } else {
            [0.0; 3]
        };
        let got = env.radiance(d);
        for c in 0..3 {
            assert_eq!(got[c], want[c] + extra_disk[c], "{d:?}");
        }
    }
    // Around the lobe: the old picture against the map.
    for k in 0..200 {
        let (th, ph) = (
            0.9 + 0.15 * ((k % 20) as f64 / 10.0 - 1.0),
            2.2 + 0.15 * ((k / 20) as f64 / 5.0 - 1.0),
        );
        let d = direction(th, ph);
        let (a, b) = (disks(d)[1], map.radiance(d)[1]);
        worst = worst.max((a - b).abs() / b);
    }
    assert!(worst > 0.1, "the disks are within {worst} of the lobe");
}

#[test]
fn a_soft_suns_faint_fringe_stays_in_the_map() {
    // A 3° lobe 900× a sky that varies with elevation, on a map the size of a downloaded
    // HDRI: coarse texels beyond the core's 1 % contour pass `min_share` on the coarse
    // map, but their excess over the full-resolution background does not. Every sun
    // carries at least `min_share` (a piece's halves too), and the suns with the rest keep
    // the map's power.
    let dir = direction(1.05, 1.05);
    let mut s = Synth::sky(0.4);
    s.lobes.push((dir, 900.0, 3f64.to_radians()));
    let (map, parts) = s.map(2048, 1024, 1);
    let opts = DecomposeOptions::default();
    let d = decompose(&map, &opts);
    assert_power_kept(&map, &d);
    for k in 0..d.suns.len() {
        assert!(
            d.share(k) >= opts.min_share,
            "sun {k}: share {}",
            d.share(k)
        );
    }
    // The core: two suns of about half the lobe each (a median cut); what else passes is
    // the tail's ring between 3σ and where it meets twice the sky, about 1 % of the lobe.
    assert!(d.suns.len() >= 2, "{} suns", d.suns.len());
    let core = (d.share(0) + d.share(1)) * d.power / parts[0];
    assert!(core > 0.95, "the core carries {core} of the lobe");
    let (c, total) = centroid(&d.suns);
    assert!(angle_deg(c, dir) < 0.5);
    assert!(
        (total / parts[0] - 1.0).abs() < 0.04,
        "{total} of {}",
        parts[0]
    );
}
