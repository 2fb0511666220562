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
    // The brightest light a picture's f32 carries, and no brighter.
    assert!(Sun::from_radiance([0.0, 0.0, 1.0], [MAX_LIGHT; 3], 0.0).is_ok());
    assert!(PointLight::new([0.0; 3], [MAX_LIGHT; 3]).is_ok());
    let e = Sun::from_radiance([0.0, 0.0, 1.0], [1.0, 1e45, 1.0], 0.53).unwrap_err();
    assert_eq!(
        e,
        "sun radiance 1e45 is above 1e30 (pictures are f32: brighter lights overflow them)"
    );
    assert!(PointLight::new([0.0; 3], [0.0, 0.0, MAX_LIGHT * 1.01]).is_err());
    assert!(PointLight::new([0.0; 3], [0.0, 0.0, f64::INFINITY]).is_err());
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

/// A shared table is the one [`DiskPhase::new`] builds, built once (asked for again at
/// once, the same table), and built again after `KEPT_TABLES` others pushed it out (tests
/// running beside this one only push it out sooner).
#[test]
fn shared_disk_phases_are_built_once_and_pushed_out_by_others() {
    use std::sync::Arc;
    let (g, angle) = (0.123_456_789, 4f64.to_radians());
    let a = DiskPhase::shared(g, angle);
    assert_eq!(*a, DiskPhase::new(g, angle));
    assert!(Arc::ptr_eq(&a, &DiskPhase::shared(g, angle)));
    for k in 1..=super::KEPT_TABLES {
        let _ = DiskPhase::shared(g, angle + k as f64 * 1e-3);
    }
    let again = DiskPhase::shared(g, angle);
    assert!(!Arc::ptr_eq(&a, &again));
    assert_eq!(*again, *a);
}
