use super::super::constraint::{EyeSegment, TriangleGeometry};
use super::super::newton::{solve_interior, NewtonCounters};
use super::*;
use glam::DVec3;

/// dx/ds from the implicit system (the arc integrand's measure) against central differences of
/// the solved x(s), on an arc of a curved triangle.
#[test]
fn arc_measure_matches_finite_differences() {
    let tri = TriangleGeometry::new(
        [
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(1.0, -1.0, 0.02),
            DVec3::new(0.0, 1.0, -0.03),
        ],
        [
            DVec3::new(0.3, 0.0, 1.0),
            DVec3::new(-0.3, 0.15, 1.0),
            DVec3::new(0.0, -0.3, 1.0),
        ],
    )
    .unwrap();
    let eye = EyeSegment::new(DVec3::new(-2.0, 0.1, -0.5), DVec3::new(2.0, -0.2, -0.7)).unwrap();
    let c = Constraint {
        tri: &tri,
        eye: &eye,
        light: DVec3::new(0.2, 0.1, 3.0),
        eta: 1.5,
    };
    let settings = NewtonSettings::default();
    let mut k = NewtonCounters::default();
    let (xa, xb) = (1.9, 2.1);
    let a = solve_interior(&c, xa, DVec2::splat(1.0 / 3.0), &settings, &mut k).unwrap();
    let b = solve_interior(&c, xb, a, &settings, &mut k).unwrap();
    let d = b - a;
    let chord = Chord {
        a,
        d,
        n: DVec2::new(-d.y, d.x) / d.length(),
    };
    let mut stats = ScatterStats::default();
    let mut solve =
        |s: f64, guess: (f64, f64)| solve_at(&c, &chord, s, guess, &settings, &mut stats).unwrap();
    for s in [0.2, 0.5, 0.8] {
        let guess = (xa + s * (xb - xa), 0.0);
        let p = solve(s, guess);
        let h = 1e-5;
        let fd = (solve(s + h, (p.x, p.nu)).x - solve(s - h, (p.x, p.nu)).x) / (2.0 * h);
        assert!(
            (p.dx_ds - fd).abs() <= 1e-6 * fd.abs(),
            "s = {s}: implicit {} vs central difference {fd}",
            p.dx_ds
        );
        assert!(c.eval(p.x, p.ab, false).unwrap().f.length() <= 1e-10);
    }
    // The chord's far end is the solution it was built from.
    assert!((solve(1.0, (xb, 0.0)).x - xb).abs() < 1e-9);
}
