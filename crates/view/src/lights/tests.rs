use super::*;
use crate::distant::direction;

#[test]
fn cone_solid_angle_matches_the_textbook_form_and_limits() {
    for a in [0.01, 0.1, 1.0, 3.0, PI] {
        let textbook = 2.0 * PI * (1.0 - (0.5 * a).cos());
        assert!(
            (cone_solid_angle(a) - textbook).abs() <= 1e-12 * textbook.max(1e-9),
            "{a}"
        );
    }
    assert_eq!(cone_solid_angle(0.0), 0.0);
    assert!((cone_solid_angle(2.0 * PI) - 4.0 * PI).abs() < 1e-12);
    // Small angles: πα²/4 without cancellation.
    let a = 1e-9;
    assert!((cone_solid_angle(a) / (PI * a * a / 4.0) - 1.0).abs() < 1e-9);
}

#[test]
fn sun_radiance_and_irradiance_agree_and_bad_suns_are_refused() {
    let s = Sun::from_radiance([0.0, 0.0, 2.0], [10.0, 20.0, 30.0], 6.0).unwrap();
    let omega = cone_solid_angle(6f64.to_radians());
    assert!((s.irradiance[1] - 20.0 * omega).abs() < 1e-12);
    assert!((s.radiance()[2] - 30.0).abs() < 1e-9);
    assert_eq!(s.direction, [0.0, 0.0, 1.0]);
    assert!(s.covers([0.02, 0.0, 1.0]) && !s.covers([0.06, 0.0, 1.0]));
    // A zero-angle sun is a directional light of irradiance RGB, with no visible disk.
    let d = Sun::from_radiance([1.0, 0.0, 0.0], [2.0, 2.0, 2.0], 0.0).unwrap();
    assert_eq!(d.irradiance, [2.0; 3]);
    assert_eq!(d.radiance(), [0.0; 3]);
    assert!(!d.covers([1.0, 0.0, 0.0]));
    assert_eq!(d.sample_direction(0.3, 0.7), [1.0, 0.0, 0.0]);
    assert!(Sun::from_radiance([0.0; 3], [1.0; 3], 1.0).is_err());
    assert!(Sun::from_radiance([0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], 1.0).is_err());
    assert!(Sun::from_radiance([0.0, 0.0, 1.0], [1.0; 3], 181.0).is_err());
    assert!(Sun::from_radiance([f64::NAN, 0.0, 1.0], [1.0; 3], 1.0).is_err());
    assert!(PointLight::new([0.0, f64::INFINITY, 0.0], [1.0; 3]).is_err());
    assert!(PointLight::new([0.0; 3], [1.0, f64::NAN, 0.0]).is_err());
}

#[test]
fn disk_samples_are_uniform_in_the_cone() {
    // Uniform per solid angle: the mean cosine to the axis is (1 + cos(α/2))/2 and every
    // sample lies in the disk.
    let s = Sun::from_radiance([0.3, -0.4, 0.8], [1.0; 3], 20.0).unwrap();
    let n = 200;
    let mut mean = 0.0;
    for i in 0..n {
        for j in 0..n {
            let w = s.sample_direction((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let len = dot(w, w).sqrt();
            assert!((len - 1.0).abs() < 1e-12);
            assert!(s.covers(w) || dot(w, s.direction) > (0.5 * s.angle).cos() - 1e-12);
            mean += dot(w, s.direction);
        }
    }
    mean /= (n * n) as f64;
    let expect = 0.5 * (1.0 + (0.5 * s.angle).cos());
    assert!((mean - expect).abs() < 1e-9, "{mean} {expect}");
}

/// `p̄` by brute force: the midpoint rule over the disk's uniform parameterization,
/// through `Sun::sample_direction` (another quadrature than the table's).
fn brute_disk_phase(g: f64, angle: f64, view: [f64; 3]) -> f64 {
    let s = Sun {
        direction: [0.0, 0.0, 1.0],
        irradiance: [1.0; 3],
        angle,
    };
    let n = 400;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let w = s.sample_direction((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            sum += hg(g, dot(w, view));
        }
    }
    sum / (n * n) as f64
}

#[test]
fn disk_phase_matches_brute_force_and_stays_normalized() {
    for (g, deg) in [(0.9, 6.0), (0.95, 8.0), (-0.5, 6.0), (0.2, 0.53)] {
        let angle = f64::to_radians(deg);
        let p = DiskPhase::new(g, angle);
        // On and between table entries, forward peak, side and back.
        for tc in [0.0, 0.01, 0.05, 0.1, 0.3, 1.0, 2.0, PI] {
            let view = direction(tc, 0.0);
            let brute = brute_disk_phase(g, angle, view);
            let table = p.eval(tc.cos());
            // Linear interpolation of a smooth function between entries π/511 apart,
            // and the brute force's own midpoint error: 0.3 %.
            assert!(
                (table / brute - 1.0).abs() < 3e-3,
                "g {g}, {deg}°, θc {tc}: table {table}, brute force {brute}"
            );
        }
        // (1/4π)∫p̄ dω = 1: averaging over the disk keeps HG normalized.
        let m = 20000;
        let mut integral = 0.0;
        for k in 0..m {
            let mu = -1.0 + 2.0 * (k as f64 + 0.5) / m as f64;
            integral += p.eval(mu) / m as f64;
        }
        assert!((integral - 1.0).abs() < 2e-3, "g {g}: {integral}");
    }
    // A zero-angle sun: HG exactly; the 6° disk lowers HG(0.9)'s forward peak by a lot.
    let z = DiskPhase::new(0.9, 0.0);
    assert_eq!(z.eval(0.7), hg(0.9, 0.7));
    assert!(DiskPhase::new(0.9, 6f64.to_radians()).eval(1.0) < 0.9 * hg(0.9, 1.0));
}

/// A sky of `base` radiance (brighter towards the zenith) with a disk of radiance
/// `sun` and apex angle `angle` about `dir`, each texel the mean of 8×8 subsamples (so
/// the disk's edge texels are partly covered, as in a real map).
fn sky_with_sun(w: usize, h: usize, base: f64, sun: f64, dir: [f64; 3], angle: f64) -> LatLong {
    sky_with_sun_and_horizon(w, h, base, 0.0, sun, dir, angle)
}

/// [`sky_with_sun`] with a glowing horizon band: `horizon × base` more at the horizon.
fn sky_with_sun_and_horizon(
    w: usize,
    h: usize,
    base: f64,
    horizon: f64,
    sun: f64,
    dir: [f64; 3],
    angle: f64,
) -> LatLong {
    let cos_edge = (0.5 * angle).cos();
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            let mut sky = 0.0;
            for sy in 0..8 {
                for sx in 0..8 {
                    let theta = PI * (y as f64 + (sy as f64 + 0.5) / 8.0) / h as f64;
                    let phi = 2.0 * PI * (x as f64 + (sx as f64 + 0.5) / 8.0) / w as f64;
                    let d = direction(theta, phi);
                    // Solid-angle weights within the texel: sin θ.
                    let wgt = theta.sin();
                    acc += wgt * if dot(d, dir) >= cos_edge { sun } else { 0.0 };
                    sky += wgt;
                }
            }
            let theta = PI * (y as f64 + 0.5) / h as f64;
            let glow = horizon * (-((theta - 0.5 * PI) / 0.15).powi(2)).exp();
            let v = base * (1.0 + 0.5 * theta.cos() + glow) + acc / sky;
            texels.push([v as f32, (0.9 * v) as f32, (0.8 * v) as f32]);
        }
    }
    LatLong::new(w, h, texels).unwrap()
}

fn power(map: &LatLong) -> [f64; 3] {
    let mut p = [0.0; 3];
    for y in 0..map.height {
        for x in 0..map.width {
            let (_, omega) = map.texel_direction(x, y);
            for (p, t) in p.iter_mut().zip(map.texels[y * map.width + x]) {
                *p += f64::from(t) * omega;
            }
        }
    }
    p
}

#[test]
fn a_maps_sun_is_found_and_the_power_is_kept() {
    for (dir, deg) in [
        (direction(1.0, 0.7), 6.0),
        (direction(1.45, 5.9), 3.0),
        (direction(0.3, 3.0), 8.0),
    ] {
        let angle = f64::to_radians(deg);
        let map = sky_with_sun(512, 256, 1.0, 20.0, dir, angle);
        let (sun, rest) = extract_sun(&map).expect("a sun");
        // Direction within a texel (0.7°).
        let off = dot(sun.direction, dir).clamp(-1.0, 1.0).acos().to_degrees();
        assert!(off < 0.7, "{deg}°: direction off by {off}°");
        // Irradiance: the disk's excess over the sky, 20·Ω☉ (red), within the texels
        // partly covered below the threshold (a few %).
        let expect = 20.0 * cone_solid_angle(angle);
        assert!(
            (sun.irradiance[0] / expect - 1.0).abs() < 0.05,
            "{deg}°: irradiance {} vs {expect}",
            sun.irradiance[0]
        );
        assert!(
            (sun.angle.to_degrees() / deg - 1.0).abs() < 0.2,
            "{}",
            sun.angle.to_degrees()
        );
        // Map + sun carry the map's power (the excess moved, nothing lost).
        let (p0, p1) = (power(&map), power(&rest));
        for c in 0..3 {
            assert!(
                (p1[c] + sun.irradiance[c] - p0[c]).abs() < 1e-5 * p0[c],
                "{c}"
            );
        }
        // What is left near the sun is sky.
        let near = rest.radiance(dir);
        assert!(near[0] < 2.0, "{near:?}");
    }
}

#[test]
fn a_low_sun_beside_a_bright_horizon_is_the_disk_alone() {
    // The horizon is 6× the zenith's sky and the sun 20× the zenith: a threshold from the
    // map's median would take the whole horizon band for the sun.
    let dir = direction(0.5 * PI - 0.08, 2.0);
    let angle = 5f64.to_radians();
    let map = sky_with_sun_and_horizon(512, 256, 1.0, 5.0, 20.0, dir, angle);
    let (sun, _) = extract_sun(&map).expect("a sun");
    let off = dot(sun.direction, dir).clamp(-1.0, 1.0).acos().to_degrees();
    assert!(off < 0.7, "{off}°");
    let expect = 20.0 * cone_solid_angle(angle);
    assert!(
        (sun.irradiance[0] / expect - 1.0).abs() < 0.05,
        "{}",
        sun.irradiance[0]
    );
}

#[test]
fn overcast_and_broad_lights_are_not_suns() {
    // No contrast.
    let flat = sky_with_sun(128, 64, 1.0, 0.0, [0.0, 0.0, 1.0], 0.1);
    assert!(extract_sun(&flat).is_none());
    // A bright region of 60°: not compact.
    let broad = sky_with_sun(128, 64, 1.0, 50.0, [1.0, 0.0, 0.0], 60f64.to_radians());
    assert!(extract_sun(&broad).is_none());
    // Black map.
    let black = LatLong::new(4, 2, vec![[0.0; 3]; 8]).unwrap();
    assert!(extract_sun(&black).is_none());
    // One bright texel in a black map: a sun of that texel's power.
    let mut t = vec![[0.0f32; 3]; 64 * 32];
    t[10 * 64 + 5] = [100.0, 100.0, 100.0];
    let m = LatLong::new(64, 32, t).unwrap();
    let (sun, rest) = extract_sun(&m).expect("a sun");
    let (d, omega) = m.texel_direction(5, 10);
    assert!((sun.irradiance[0] - 100.0 * omega).abs() < 1e-9 * 100.0);
    assert!(dot(sun.direction, d) > 1.0 - 1e-12);
    assert!(rest.texels.iter().all(|t| t[0] == 0.0));
}
