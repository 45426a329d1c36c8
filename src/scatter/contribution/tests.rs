use super::super::constraint::refract_in;
use super::*;

#[test]
fn fresnel_limits() {
    let eta: f64 = 1.5;
    let t0 = 4.0 * eta / ((1.0 + eta) * (1.0 + eta));
    assert!((fresnel_transmittance(1.0, eta) - t0).abs() < 1e-15);
    assert!(fresnel_transmittance(0.0, eta) < 1e-12);
    // Brewster angle: p-polarized transmission is total, so T = 1 - Rs/2.
    let tb = eta.atan();
    let ci = tb.cos();
    let ct = (1.0 - (1.0 - ci * ci) / (eta * eta)).sqrt();
    let rs = (ci - eta * ct) / (ci + eta * ct);
    assert!((fresnel_transmittance(ci, eta) - (1.0 - 0.5 * rs * rs)).abs() < 1e-14);
}

#[test]
fn henyey_greenstein_is_normalized() {
    for &g in &[-0.7, 0.0, 0.3, 0.9] {
        let n = 200_000;
        let mut s = 0.0;
        for k in 0..n {
            let mu = -1.0 + (k as f64 + 0.5) * 2.0 / n as f64;
            s += henyey_greenstein(mu, g) * 2.0 / n as f64;
        }
        assert!(
            (2.0 * std::f64::consts::PI * s - 1.0).abs() < 1e-6,
            "g = {g}"
        );
    }
}

/// Forward D by finite differences: refract the neighbouring rays and measure the beam
/// cross-section at distance d_V, per solid angle at the light.
fn d_forward_fd(tri: &TriangleGeometry, ab: DVec2, light: DVec3, d_v: f64, eta: f64) -> f64 {
    let h = 1e-6;
    let ray = |q: DVec2| {
        let p = tri.point(q);
        let n = tri.raw_normal(q).normalize();
        (p, refract_in(p, light, n, eta).unwrap())
    };
    let (p0, t0) = ray(ab);
    let v0 = p0 + d_v * t0;
    // Point where the neighbouring ray crosses the plane through V perpendicular to t0.
    let hit = |q: DVec2| {
        let (p, t) = ray(q);
        let s = (v0 - p).dot(t0) / t.dot(t0);
        p + s * t
    };
    let da = (hit(ab + DVec2::new(h, 0.0)) - hit(ab - DVec2::new(h, 0.0))) / (2.0 * h);
    let db = (hit(ab + DVec2::new(0.0, h)) - hit(ab - DVec2::new(0.0, h))) / (2.0 * h);
    let area = da.cross(db).length();
    let dir = |q: DVec2| (tri.point(q) - light).normalize();
    let wa = (dir(ab + DVec2::new(h, 0.0)) - dir(ab - DVec2::new(h, 0.0))) / (2.0 * h);
    let wb = (dir(ab + DVec2::new(0.0, h)) - dir(ab - DVec2::new(0.0, h))) / (2.0 * h);
    area / wa.cross(wb).length()
}

/// Reverse D (report eq. 7): perturb the direction at V, trace back through the interface,
/// measure the spread at the light's distance; forward D is this over η².
fn d_reverse_fd(tri: &TriangleGeometry, ab: DVec2, light: DVec3, d_v: f64, eta: f64) -> f64 {
    let p0 = tri.point(ab);
    let n0 = tri.raw_normal(ab).normalize();
    let t0 = refract_in(p0, light, n0, eta).unwrap();
    let v = p0 + d_v * t0;
    let back = -t0;
    let (u1, u2) = back.any_orthonormal_pair();
    let ng = tri.geometric_normal;
    let wl0 = (light - p0).normalize();
    let d_l = (light - p0).length();
    let trace = |dir: DVec3| {
        // Hit the triangle plane, refract out (eta -> 1) with the interpolated normal there.
        let s = (tri.p0 - v).dot(ng) / dir.dot(ng);
        let p = v + s * dir;
        // Barycentrics of p.
        let r = p - tri.p0;
        let (e1, e2) = (tri.e1, tri.e2);
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (r1, r2) = (r.dot(e1), r.dot(e2));
        let det = d11 * d22 - d12 * d12;
        let q = DVec2::new((d22 * r1 - d12 * r2) / det, (d11 * r2 - d12 * r1) / det);
        let n = tri.raw_normal(q).normalize();
        // Refract the propagation direction `dir` (inside, going out) into index 1.
        let ci = dir.dot(n);
        let st2 = eta * eta * (1.0 - ci * ci);
        let ct = (1.0 - st2).sqrt();
        let out = eta * dir + (ct - eta * ci) * n;
        (p, out)
    };
    let (p_c, o_c) = trace(back);
    let plane_hit = |dir: DVec3| {
        let (p, o) = trace(dir);
        let _ = p_c;
        let target = p_c + d_l * o_c;
        let s = (target - p).dot(o_c) / o.dot(o_c);
        p + s * o
    };
    let h = 1e-6;
    let perturb = |k: DVec3, s: f64| (back + s * k).normalize();
    let d1 = (plane_hit(perturb(u1, h)) - plane_hit(perturb(u1, -h))) / (2.0 * h);
    let d2 = (plane_hit(perturb(u2, h)) - plane_hit(perturb(u2, -h))) / (2.0 * h);
    assert!(
        (o_c - wl0).length() < 1e-9,
        "trace back reaches the light direction"
    );
    d1.cross(d2).length() / (eta * eta)
}

fn flat_and_curved() -> [TriangleGeometry; 2] {
    let p = [
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::new(1.0, -0.8, 0.1),
        DVec3::new(0.1, 1.0, -0.05),
    ];
    let ng = (p[1] - p[0]).cross(p[2] - p[0]);
    [
        TriangleGeometry::new(p, [ng; 3]).unwrap(),
        TriangleGeometry::new(
            p,
            [
                ng.normalize() + DVec3::new(0.3, 0.1, 0.0),
                ng.normalize() + DVec3::new(-0.2, 0.2, 0.0),
                ng.normalize() + DVec3::new(0.0, -0.3, 0.1),
            ],
        )
        .unwrap(),
    ]
}

#[test]
fn interpolated_d_matches_forward_and_reverse_ray_tracing() {
    let light = DVec3::new(0.7, -0.4, 2.5);
    for tri in flat_and_curved() {
        for &(a, b, d_v) in &[(0.3, 0.3, 0.8), (0.1, 0.7, 2.0), (0.6, 0.2, 0.05)] {
            let ab = DVec2::new(a, b);
            let d = distance_factor_interpolated(&tri, ab, light, d_v, 1.5).unwrap();
            let fwd = d_forward_fd(&tri, ab, light, d_v, 1.5);
            let rev = d_reverse_fd(&tri, ab, light, d_v, 1.5);
            assert!(
                (d - fwd).abs() < 1e-6 * d,
                "analytic {d} vs forward fd {fwd}"
            );
            if tri.is_flat() {
                // Étendue conservation: the reverse trace of eq. 7 over η² is the forward D.
                // (Interpolated normals are not the normals of a surface, so the refraction map
                // is not reciprocal and the two differ by up to a few % on curved facets.)
                assert!(
                    (d - rev).abs() < 1e-6 * d,
                    "analytic {d} vs reverse fd {rev}"
                );
                let p = tri.point(ab);
                let n = tri.geometric_normal;
                let t = refract_in(p, light, n, 1.5).unwrap();
                let wl = (light - p).normalize();
                let flat = distance_factor_flat(n, wl, t, (light - p).length(), d_v, 1.5);
                assert!(
                    (d - flat).abs() < 1e-12 * d,
                    "ray differentials {d} vs closed form {flat}"
                );
            }
        }
    }
}

#[test]
fn without_refraction_d_is_the_squared_distance() {
    // eta -> 1: D -> (d_L + d_V)^2 (checked at eta = 1 + 1e-12 with the closed form).
    let n = DVec3::Z;
    let wl = DVec3::new(0.3, 0.0, 1.0).normalize();
    let d = distance_factor_flat(n, wl, -wl, 2.0, 0.5, 1.0 + 1e-12);
    assert!((d - 6.25).abs() < 1e-10);
}
