//! Smoke composited with the fog by depth (`render::shade_over`) against a brute-force
//! integration of both media together along the same rays.
//!
//! The smoke is a Gaussian blob of density on a voxel grid with a constant source
//! radiance `J` (`haze_view`'s volume-pass grids), its layer computed by
//! `crm::view_layer`. The oracle marches each ray in steps of a twentieth of a voxel:
//! per step the fog's optical depth is exact (`Fog::optical_depth_span`), the smoke's is
//! `σt·D(midpoint)·Δt` with `D` from `haze_view::field::sample`, and the step emits
//! `(1 − e^{−τ})·(τ_f L_fog + τ_s J)/τ` attenuated by everything in front of it.
//!
//! Error budget of the composite, per ray (module docs of `render::shade_over`): the
//! smoke's own slice march (half-voxel slices) against the fine march, `e_s`, measured
//! per ray on the smoke alone; and the thin-sheet approximation. The depth `d` is the
//! opacity-weighted mean, which makes the approximation exact to first order in the fog's
//! optical depth `τ_ab` across the smoke's span `[a, b]` of the ray when the fog's
//! extinction is constant there (both error integrals, `∫(T_f(0,t) − T_f(0,d))w(t)dt`
//! for the smoke's light and `∫σ_f(T_s(0,t) − H_d(t))dt` for the fog's, have first
//! moments that vanish exactly at that `d`); what remains is of order `τ_ab²` times the
//! radiances (≤ 1 here) plus the fog's extinction varying across the span. The test
//! allows `e_s + τ_ab² + 1e-4` and checks the depth matters: compositing the smoke in
//! front of all the fog, or behind all of it, errs by more.

use haze_camera::LookAt;
use haze_view::Medium;
use haze_view::field;
use haze_view::render::crm::{self, RadianceField, SmokeSample, VolumeGrids};
use haze_volume::{Bbox, Volume};
use haze_wavelet::lod::{Fog, Mode, Settings};
use haze_wavelet::render::{self, Scene};
use haze_wavelet::{Basis, Grid, Placement};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

const J: [f32; 3] = [0.95, 0.55, 0.25];

/// A 16³ Gaussian blob over `[cx ± 1.5] × [cy ± 1.5] × [0.3, 3.3]`, radiance `J`.
fn blob() -> VolumeGrids {
    let n = 16;
    let bbox = Bbox::new([-1.5, 1.5, 0.3], [1.5, 4.5, 3.3]);
    let mut data = Vec::with_capacity(n * n * n);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let c = |i: usize| (i as f64 + 0.5) / n as f64 * 2.0 - 1.0;
                let r2 = c(x).powi(2) + c(y).powi(2) + (c(z) * 1.2).powi(2);
                data.push((1.2 * (-3.0 * r2).exp()) as f32);
            }
        }
    }
    let density = Volume::new([n; 3], bbox, data).unwrap();
    let radiance = vec![J; n * n * n];
    VolumeGrids {
        density,
        radiance,
        eye_peak: 0.0,
    }
}

fn fog() -> Fog {
    let mut rng = Pcg64::seed_from_u64(5);
    let (nx, ny) = (12, 10);
    let mut g = Grid::zeros(0, 0, nx, ny);
    for v in g.data.iter_mut() {
        *v = rng.random_range(0.2..0.8);
    }
    let placement = Placement {
        origin: [-9.0, -4.0],
        cell: 1.5,
        density: 0.12,
        bottom: 0.0,
        top: 5.0,
        falloff: 0.2,
    };
    let settings = Settings {
        mu: 1.0,
        mode: Mode::Deconstructed,
        min_transmittance: 0.0,
    };
    Fog::new(&g, Basis::Linear, 2, placement, settings).unwrap()
}

/// The oracle: both media marched together in fine steps; also the smoke alone.
fn brute_force(
    fog: &Fog,
    scene: &Scene,
    smoke: &RadianceField<'_>,
    medium: &Medium,
    eye: [f64; 3],
    d: [f64; 3],
) -> ([f64; 3], ([f64; 3], f64)) {
    let (surface, len) = match render::ground_distance(eye, d) {
        Some(t) => {
            // The ground's colour from the renderer itself: a fogless pixel.
            (render::shade(&clear(fog), scene, eye, d), t)
        }
        None => (
            render::shade(&clear(fog), scene, eye, d),
            fog.exit_distance(eye, d).max(30.0),
        ),
    };
    let step = 3.0 / 16.0 / 20.0;
    let steps = (len / step).ceil() as usize;
    let dt = len / steps as f64;
    let (mut tr, mut out) = (1.0f64, [0.0f64; 3]);
    let (mut ts, mut ls) = (1.0f64, [0.0f64; 3]);
    for i in 0..steps {
        let (t0, t1) = (i as f64 * dt, (i + 1) as f64 * dt);
        let tm = 0.5 * (t0 + t1);
        let p = [eye[0] + tm * d[0], eye[1] + tm * d[1], eye[2] + tm * d[2]];
        let tau_f = fog.optical_depth_span(eye, d, len, t0, t1);
        let dens = field::sample(&smoke.grids().density, p);
        let tau_s = medium.sigma_t * dens * dt;
        let j = smoke.sample(p, dens);
        let tau = tau_f + tau_s;
        if tau > 0.0 {
            let a = -(-tau).exp_m1();
            for c in 0..3 {
                out[c] += tr * a * (tau_f * scene.fog[c] + tau_s * j[c]) / tau;
            }
            tr *= (-tau).exp();
        }
        if tau_s > 0.0 {
            let a = -(-tau_s).exp_m1();
            for c in 0..3 {
                ls[c] += ts * a * j[c];
            }
            ts *= (-tau_s).exp();
        }
    }
    ([0, 1, 2].map(|c| out[c] + tr * surface[c]), (ls, ts))
}

/// The same fog with no density: what the renderer shows of the ground and sky.
fn clear(fog: &Fog) -> Fog {
    let mut p = *fog.placement();
    p.density = 0.0;
    let g = Grid::zeros(0, 0, 1, 1);
    Fog::new(&g, Basis::Haar, 0, p, *fog.settings()).unwrap()
}

#[test]
fn smoke_composited_by_depth_matches_both_media_marched_together() {
    let fog = fog();
    let scene = Scene::default();
    let smoke = blob();
    let medium = Medium::new(1.6, 0.9, 0.0).unwrap();
    let (w, h) = (28, 20);
    let look = LookAt {
        eye: [1.0, -9.0, 4.5],
        target: [0.0, 3.0, 1.8],
        up: [0.0, 0.0, 1.0],
        fov_deg: 22.0,
    };
    let camera = look.camera(w, h).unwrap();
    let du = crm::default_slice([16; 3], smoke.density.bbox());
    let eye = camera.eye;
    let end = |d: [f64; 3]| render::ground_distance(eye, d).unwrap_or(f64::INFINITY);
    let layer = crm::view_layer(&smoke, &medium, &[], &camera, du, &end);
    let image = render::render_over(&fog, &camera, &scene, &layer, &|| {});
    let radiance = RadianceField::new(&smoke);
    let (mut through, mut worse_front, mut worse_back) = (0, 0, 0);
    let (mut err_sum, mut front_sum, mut back_sum) = (0.0, 0.0, 0.0);
    let mut worst_ratio = 0.0f64;
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let d = camera.pixel_ray(x, y);
            let (want, (ls, ts)) = brute_force(&fog, &scene, &radiance, &medium, eye, d);
            let s = layer[i];
            // The smoke's own march against the fine one.
            let e_s = (0..3)
                .map(|c| (f64::from(s.radiance[c]) - ls[c]).abs())
                .fold((f64::from(s.transmittance) - ts).abs(), f64::max);
            let len = render::ground_distance(eye, d).unwrap_or(fog.exit_distance(eye, d));
            let tau_ab = match field::ray_box(eye, d, smoke.density.bbox()) {
                Some((a, b)) => fog.optical_depth_span(eye, d, len, a, b.min(len)),
                None => 0.0,
            };
            let tol = e_s + tau_ab * tau_ab + 1e-4;
            let got = image[i];
            let err = (0..3)
                .map(|c| (f64::from(got[c]) - want[c]).abs())
                .fold(0.0, f64::max);
            assert!(
                err <= tol,
                "pixel ({x}, {y}): {got:?} vs {want:?}, error {err} > {tol} (e_s {e_s}, τ_ab {tau_ab})"
            );
            if s.transmittance < 0.8 {
                through += 1;
                worst_ratio = worst_ratio.max((err - e_s).max(0.0) / (tau_ab * tau_ab).max(1e-12));
                // The same smoke put in front of all the fog, or behind all of it.
                let at = |depth: f64| {
                    let moved = SmokeSample {
                        depth: depth as f32,
                        ..s
                    };
                    let px = render::shade_over(&fog, &scene, eye, d, &moved);
                    (0..3).map(|c| (px[c] - want[c]).abs()).fold(0.0, f64::max)
                };
                let (e_front, e_back) = (at(0.0), at(len));
                worse_front += usize::from(e_front > 3.0 * err);
                worse_back += usize::from(e_back > 3.0 * err);
                err_sum += err;
                front_sum += e_front;
                back_sum += e_back;
            }
        }
    }
    println!(
        "{through} rays through the smoke: mean error {:.2e} (in front of the fog {:.2e}, behind it {:.2e}); worst (error − e_s)/τ_ab² {worst_ratio:.3}",
        err_sum / through as f64,
        front_sum / through as f64,
        back_sum / through as f64
    );
    assert!(through > w * h / 10, "{through} rays through the smoke");
    assert!(worse_front * 10 > through * 9, "{worse_front} of {through}");
    assert!(worse_back * 10 > through * 9, "{worse_back} of {through}");
}

/// Without smoke the composite is the fog alone, whatever the depth: splitting the fog's
/// integral is exact.
#[test]
fn no_smoke_at_any_depth_is_the_fog_alone() {
    let fog = fog();
    let scene = Scene::default();
    let look = render::framing(&fog);
    let camera = look.camera(20, 15).unwrap();
    for (i, depth) in [0.0, 3.7, 11.0, 1e9].into_iter().enumerate() {
        for y in 0..15 {
            for x in 0..20 {
                let d = camera.pixel_ray(x, y);
                let none = SmokeSample {
                    radiance: [0.0; 3],
                    transmittance: 1.0,
                    depth: depth as f32 + (x + y + i) as f32 * 0.37,
                };
                let got = render::shade_over(&fog, &scene, camera.eye, d, &none);
                let want = render::shade(&fog, &scene, camera.eye, d);
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() < 1e-12,
                        "({x}, {y}): {got:?} vs {want:?}"
                    );
                }
            }
        }
    }
}
