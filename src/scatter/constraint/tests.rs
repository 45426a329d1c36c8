use super::*;

fn setup() -> (TriangleGeometry, EyeSegment, DVec3) {
    let tri = TriangleGeometry::new(
        [
            DVec3::new(-0.3, -0.2, 0.05),
            DVec3::new(0.4, -0.1, -0.02),
            DVec3::new(0.0, 0.5, 0.03),
        ],
        [
            DVec3::new(0.2, -0.1, 1.0),
            DVec3::new(-0.15, 0.05, 1.0),
            DVec3::new(0.05, 0.3, 1.0),
        ],
    )
    .unwrap();
    let eye = EyeSegment::new(DVec3::new(-0.5, 0.1, -0.3), DVec3::new(0.7, 0.2, -1.4)).unwrap();
    (tri, eye, DVec3::new(0.3, -0.4, 2.0))
}

#[test]
fn jacobian_matches_central_differences() {
    let (tri, eye, light) = setup();
    let c = Constraint {
        tri: &tri,
        eye: &eye,
        light,
        eta: 1.5,
    };
    for &(x, a, b) in &[(0.3, 0.2, 0.3), (1.1, 0.6, 0.1), (0.01, 0.05, 0.9)] {
        let j = c.eval(x, DVec2::new(a, b), true).unwrap().jacobian;
        let h = 1e-6;
        let fd = |dx: f64, da: f64, db: f64| {
            let fp = c.eval(x + dx, DVec2::new(a + da, b + db), false).unwrap().f;
            let fm = c.eval(x - dx, DVec2::new(a - da, b - db), false).unwrap().f;
            (fp - fm) / (2.0 * h)
        };
        let cols = [fd(h, 0.0, 0.0), fd(0.0, h, 0.0), fd(0.0, 0.0, h)];
        for (k, col) in cols.iter().enumerate() {
            let err = (j.col(k) - *col).length();
            assert!(err < 1e-8, "column {k}: analytic {} vs fd {col}", j.col(k));
        }
    }
}

#[test]
fn refraction_obeys_snell_and_zeroes_the_constraint() {
    let (tri, _, light) = setup();
    let ab = DVec2::new(0.3, 0.3);
    let p = tri.point(ab);
    let n = tri.raw_normal(ab).normalize();
    let t = refract_in(p, light, n, 1.5).unwrap();
    assert!((t.length() - 1.0).abs() < 1e-14);
    let wl = (light - p).normalize();
    let sin_i = wl.cross(n).length();
    let sin_t = t.cross(n).length();
    assert!((sin_i - 1.5 * sin_t).abs() < 1e-14);
    // Put V on the refracted ray: the constraint vanishes there.
    let v = p + 0.7 * t;
    let eye = EyeSegment::new(v, v + DVec3::X).unwrap();
    let c = Constraint {
        tri: &tri,
        eye: &eye,
        light,
        eta: 1.5,
    };
    assert!(c.eval(0.0, ab, false).unwrap().f.length() < 1e-14);
    assert!(refract_in(p, p - n, n, 1.5).is_none());
}
