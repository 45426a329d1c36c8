//! Ward-Heckbert gradients against exact references: a point on a plane under a square emitter,
//! with zero, one and two square occluders. Prints errors and observed convergence rates.

#[path = "gather_support/mod.rs"]
mod support;

use glam::DVec3;
use support::*;

fn convergence(name: &str, scene: &Scene, ms: &[u32], seed: u64) -> (Vec<f64>, Vec<f64>) {
    let frame = plane_frame(0.05, -0.1);
    let x = frame.position;
    let e_ref = scene.irradiance(x, DVec3::Z);
    let g_ref = scene.irradiance_gradient(x, DVec3::Z);
    println!("{name}: E = {e_ref:.9}, grad E = {g_ref:.6}");
    let (mut ee, mut ge) = (Vec::new(), Vec::new());
    for &m in ms {
        let v = scene.gather(&polar(m, seed), &frame, true);
        let e_err = (v.irradiance[0] - e_ref).abs() / e_ref;
        let (t, f) = rel_err(v.gradient[0], g_ref);
        println!("  M={m:3} N={:3}: |dE|/E = {e_err:.2e}  grad tangent {t:.2e}  grad 3D {f:.2e}  ({:.5})", 2 * m, v.gradient[0]);
        ee.push(e_err);
        ge.push(f);
    }
    println!(
        "  rates: irradiance {:.2}, gradient {:.2}",
        rate(ms, &ee),
        rate(ms, &ge)
    );
    (ee, ge)
}

#[test]
fn emitter_only_converges() {
    let scene = Scene::new(vec![emitter()]);
    let (ee, ge) = convergence("emitter", &scene, &[8, 16, 32, 64], 0);
    assert!(ee[3] < 5e-3 && ge[3] < 2e-2, "{ee:?} {ge:?}");
    assert!(ge[3] < ge[0] / 3.0);
}

#[test]
fn one_occluder_converges() {
    let mut scene = Scene::new(vec![emitter(), occluder_a()]);
    scene.env = 0.05;
    let (ee, ge) = convergence("one occluder", &scene, &[8, 16, 32, 64], 0);
    assert!(ee[3] < 1e-2 && ge[3] < 2e-2, "{ee:?} {ge:?}");
    assert!(ge[3] < ge[0] / 3.0);
}

#[test]
fn two_occluders_converge() {
    let mut scene = Scene::new(vec![emitter(), occluder_a(), occluder_b()]);
    scene.env = 0.05;
    let (ee, ge) = convergence("two occluders", &scene, &[8, 16, 32, 64], 0);
    assert!(ee[3] < 1e-2 && ge[3] < 2e-2, "{ee:?} {ge:?}");
    assert!(ge[3] < ge[0] / 3.0);
}

/// Longer runs up to 256 x 512 (run with `--release -- --ignored --nocapture`).
#[test]
#[ignore]
fn extended_convergence() {
    let mut scene = Scene::new(vec![emitter(), occluder_a(), occluder_b()]);
    scene.env = 0.05;
    convergence("two occluders", &scene, &[8, 16, 32, 64, 128, 256], 0);
    let scene = Scene::new(vec![emitter()]);
    convergence("emitter", &scene, &[8, 16, 32, 64, 128, 256], 0);
    convergence("emitter jitter", &scene, &[8, 16, 32, 64, 128, 256], 99);
}

/// Rotational gradient: rotating the normal by a small ρ changes E by ρ·∇_r E (exact E by Lambert).
#[test]
fn rotation_gradient_matches_rotated_normal_differences() {
    let mut scene = Scene::new(vec![emitter(), occluder_a(), occluder_b()]);
    scene.env = 0.05;
    let frame = plane_frame(0.05, -0.1);
    let x = frame.position;
    let h = 1e-3;
    let mut want = DVec3::ZERO;
    for axis in 0..2 {
        let mut rho = DVec3::ZERO;
        rho[axis] = 1.0;
        let f = |s: f64| {
            let n = glam::DQuat::from_scaled_axis(rho * (s * h)) * DVec3::Z;
            scene.irradiance(x, n)
        };
        want[axis] = (f(-2.0) - 8.0 * f(-1.0) + 8.0 * f(1.0) - f(2.0)) / (12.0 * h);
    }
    println!("rotation gradient reference {want:.6}");
    let ms = [8, 16, 32, 64];
    let mut errs = Vec::new();
    for &m in &ms {
        let v = scene.gather(&polar(m, 0), &frame, true);
        let err = (v.rotation_gradient[0] - want).length() / want.length();
        println!(
            "  M={m:3}: rotation gradient {:.6}, rel. error {err:.2e}",
            v.rotation_gradient[0]
        );
        assert_eq!(v.rotation_gradient[0].z, 0.0);
        errs.push(err);
    }
    println!("  rate {:.2}", rate(&ms, &errs));
    assert!(errs[3] < 1e-2 && errs[3] < errs[0] / 3.0, "{errs:?}");
}

/// The reference values embedded in ffi-tests/gather.cpp (environment 0).
#[test]
fn reference_for_the_cpp_test() {
    let scene = Scene::new(vec![emitter(), occluder_a()]);
    let x = DVec3::new(0.05, -0.1, 0.0);
    let e = scene.irradiance(x, DVec3::Z);
    let g = scene.irradiance_gradient(x, DVec3::Z);
    println!(
        "cpp reference: E = {e:.10}, grad = {:.7} {:.7} {:.7}",
        g.x, g.y, g.z
    );
    assert!((e - 0.3040080277).abs() < 1e-9);
    assert!((g - DVec3::new(-0.6510830, -0.0671441, 0.2474822)).length() < 1e-6);
}

/// Jittered strata (seed != 0) converge like the stratum centres.
#[test]
fn jittered_layout_converges() {
    let mut scene = Scene::new(vec![emitter(), occluder_a(), occluder_b()]);
    scene.env = 0.05;
    let (ee, ge) = convergence("two occluders, jittered", &scene, &[8, 16, 32, 64], 7);
    assert!(ee[3] < 1e-2 && ge[3] < 3e-2, "{ee:?} {ge:?}");
    assert!(ge[3] < ge[0] / 3.0);
}
