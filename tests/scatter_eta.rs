//! The η → 1 limit: single scattering through an index-matched interface converges to the
//! straight-line result (issue 19, item 5). Before the constraint was written with the tangential
//! part of η ω_V + ω_L, η = 1 + 1e-7 gave ~0.05x the limit and η = 1 + 1e-9 gave 0.

use glam::DVec3;
use raddiff::scatter::{
    scene, single_scatter, straight_line_single_scatter, Medium, RefractiveMesh, ScatterOptions,
};

mod scatter_common;

fn medium(eta: f64) -> Medium {
    Medium {
        eta,
        sigma_t: 0.6,
        sigma_s: 0.5,
        g: 0.3,
    }
}

/// xorshift in [0, 1).
fn rng(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A flat 20 x 20 two-triangle quad in z = 0 (outside is z > 0), large enough that every straight
/// line from the lights to the segments below crosses it.
fn flat_quad() -> RefractiveMesh {
    let p = [
        DVec3::new(-10.0, -10.0, 0.0),
        DVec3::new(10.0, -10.0, 0.0),
        DVec3::new(10.0, 10.0, 0.0),
        DVec3::new(-10.0, 10.0, 0.0),
    ];
    RefractiveMesh::new(&p, &[DVec3::Z; 4], &[[0, 1, 2], [0, 2, 3]]).unwrap()
}

/// The straight-line limit: its midpoint rule with Richardson extrapolation (the integrand is
/// smooth where every straight line crosses one convex interface; the error is O(h⁴)).
fn straight_line(mesh: &RefractiveMesh, entry: DVec3, exit: DVec3, light: DVec3) -> f64 {
    let m = medium(1.0 + 1e-12);
    let s = |n| straight_line_single_scatter(mesh, &m, entry, exit, light, 1.0, n).unwrap();
    let (a, b) = (s(4000), s(8000));
    b + (b - a) / 3.0
}

/// (entry, exit, light) triples on the flat quad: segments below it, lights above.
fn flat_cases(count: usize) -> Vec<(DVec3, DVec3, DVec3)> {
    let mut r = rng(0x2545f4914f6cdd1d);
    (0..count)
        .map(|_| {
            let mut p = |zlo: f64, zhi: f64| {
                DVec3::new(2.0 * r() - 1.0, 2.0 * r() - 1.0, zlo + (zhi - zlo) * r())
            };
            (p(-2.0, -0.05), p(-2.0, -0.05), p(0.2, 3.0))
        })
        .collect()
}

/// Chords of the smooth geodesic sphere (convex: every straight line from an outside light to an
/// inside point crosses it once) and lights 1.5-5 radii from the centre.
fn sphere_cases(mesh: &RefractiveMesh, count: usize) -> Vec<(DVec3, DVec3, DVec3)> {
    let mut r = rng(0x9e3779b97f4a7c15);
    let mut out = Vec::new();
    while out.len() < count {
        let mut unit = || {
            let z: f64 = 2.0 * r() - 1.0;
            let phi = std::f64::consts::TAU * r();
            let s = (1.0 - z * z).sqrt();
            DVec3::new(s * phi.cos(), s * phi.sin(), z)
        };
        let (o, d, l) = (3.0 * unit(), unit(), unit());
        let dist = 1.5 + 3.5 * r();
        if let Some((entry, exit)) = scatter_common::chord(mesh, o, -o + 0.6 * d) {
            out.push((entry, exit, dist * l));
        }
    }
    out
}

/// Worst relative deviation from the straight-line limit over the cases, at each η.
fn worst(mesh: &RefractiveMesh, cases: &[(DVec3, DVec3, DVec3)], eta: f64) -> f64 {
    let o = ScatterOptions::default();
    cases
        .iter()
        .map(|&(entry, exit, light)| {
            let reference = straight_line(mesh, entry, exit, light);
            assert!(reference > 0.0);
            let r = single_scatter(mesh, &medium(eta), entry, exit, light, 1.0, &o).unwrap();
            (r.radiance / reference - 1.0).abs()
        })
        .fold(0.0, f64::max)
}

/// η = 1 + δ differs from the limit by O(δ) (measured: 1.42 δ on the flat quad, 4.9 δ on the
/// sphere), plus the references' own error (~5e-8 on the sphere). Before the tangential constraint:
/// 0.05x the limit at δ = 1e-7 and 0 at δ = 1e-9.
#[test]
fn eta_close_to_one_converges_to_the_straight_line_limit() {
    let quad = flat_quad();
    let sphere = scene::bumpy_sphere(6, 0.0, 1.0).build().unwrap();
    let fc = flat_cases(12);
    let sc = sphere_cases(&sphere, 12);
    for d in [1e-6, 1e-7, 1e-9, 1e-12] {
        let bound = 1e-6 + 10.0 * d;
        let (wf, ws) = (worst(&quad, &fc, 1.0 + d), worst(&sphere, &sc, 1.0 + d));
        assert!(
            wf <= bound && ws <= bound,
            "eta = 1 + {d:e}: flat {wf:e}, sphere {ws:e}"
        );
    }
    // At 1e-9 the target of issue 19 (1e-6) holds with margin on both meshes.
    assert!(worst(&quad, &fc, 1.0 + 1e-9) <= 1e-8);
    assert!(worst(&sphere, &sc, 1.0 + 1e-9) <= 2e-7);
}

#[test]
fn eta_one_is_an_error_pointing_to_the_straight_line_function() {
    let quad = flat_quad();
    let (entry, exit, light) = flat_cases(1)[0];
    let r = single_scatter(
        &quad,
        &medium(1.0),
        entry,
        exit,
        light,
        1.0,
        &ScatterOptions::default(),
    );
    match r {
        Err(raddiff::Error::InvalidArgument(msg)) => {
            assert!(msg.contains("straight_line_single_scatter"), "{msg}")
        }
        other => panic!("expected an error, got {other:?}"),
    }
}
