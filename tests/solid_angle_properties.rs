//! Property tests (proptest) of the triangle solid angle: the Hessian exactly symmetric,
//! invariance under vertex permutation and rigid motion, closed meshes subtending 4π inside and
//! nothing outside (signed), gradient and Hessian equal to finite differences of value and
//! gradient.

use glam::{DMat3, DQuat, DVec3};
use proptest::prelude::*;
use raddiff::{kernels, Deriv3, Order};
use std::f64::consts::PI;

fn vec3(range: f64) -> impl Strategy<Value = DVec3> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn unit_quat() -> impl Strategy<Value = DQuat> {
    (vec3(1.0), -1.0f64..1.0).prop_filter_map("degenerate axis", |(v, w)| {
        let q = DQuat::from_xyzw(v.x, v.y, v.z, w);
        (q.length() > 0.1).then(|| q.normalize())
    })
}

/// A well-shaped triangle scaled by 10^k, k ∈ [-3, 3], and an evaluation point at least 5% of its
/// size away from its plane and vertices.
fn configuration() -> impl Strategy<Value = (DVec3, [DVec3; 3])> {
    (vec3(1.0), vec3(1.0), vec3(1.0), vec3(3.0), -3.0f64..3.0).prop_filter_map(
        "ill-shaped or too close",
        |(a, b, c, x, k)| {
            let n = (b - a).cross(c - a);
            let l = (b - a).length().max((c - a).length()).max((c - b).length());
            if n.length() < 0.2 * l * l || l < 0.3 {
                return None;
            }
            let h = (x - a).dot(n.normalize()).abs();
            let near = [a, b, c]
                .iter()
                .map(|v| (*v - x).length())
                .fold(h, f64::min);
            if near < 0.05 * l {
                return None;
            }
            let s = 10f64.powf(k);
            Some((x * s, [a * s, b * s, c * s]))
        },
    )
}

fn scale_of(d: &Deriv3) -> (f64, f64) {
    let g = d.gradient.abs().max_element();
    let h = d
        .hessian
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    (g, h)
}

fn close3(a: &Deriv3, b: &Deriv3, tol: f64) -> bool {
    let (g, h) = scale_of(b);
    (a.value - b.value).abs() <= tol * b.value.abs().max(1e-300)
        && (a.gradient - b.gradient).abs().max_element() <= tol * g
        && (a.hessian - b.hessian)
            .to_cols_array()
            .iter()
            .all(|v| v.abs() <= tol * h)
}

fn tetrahedron() -> Vec<[DVec3; 3]> {
    // Regular tetrahedron (inradius 1/3 of the circumradius √3): outward-facing triangles.
    let v = [
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, -1.0),
        DVec3::new(-1.0, 1.0, -1.0),
        DVec3::new(-1.0, -1.0, 1.0),
    ];
    orient_outward(vec![
        [v[0], v[1], v[2]],
        [v[0], v[1], v[3]],
        [v[0], v[2], v[3]],
        [v[1], v[2], v[3]],
    ])
}

fn cube() -> Vec<[DVec3; 3]> {
    let mut tris = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let corner = |u: f64, v: f64| {
                let mut p = DVec3::ZERO;
                p[axis] = sign;
                p[(axis + 1) % 3] = u;
                p[(axis + 2) % 3] = v;
                p
            };
            let (a, b, c, d) = (
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, 1.0),
            );
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    orient_outward(tris)
}

fn icosahedron() -> Vec<[DVec3; 3]> {
    let p = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v = Vec::new();
    for (s1, s2) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        v.push(DVec3::new(0.0, s1, s2 * p));
        v.push(DVec3::new(s1, s2 * p, 0.0));
        v.push(DVec3::new(s2 * p, 0.0, s1));
    }
    // Faces: triples of mutually adjacent vertices (edge length 2).
    let mut tris = Vec::new();
    for i in 0..12 {
        for j in (i + 1)..12 {
            for k in (j + 1)..12 {
                let adj = |a: DVec3, b: DVec3| ((a - b).length() - 2.0).abs() < 1e-9;
                if adj(v[i], v[j]) && adj(v[j], v[k]) && adj(v[i], v[k]) {
                    tris.push([v[i], v[j], v[k]]);
                }
            }
        }
    }
    assert_eq!(tris.len(), 20);
    orient_outward(tris)
}

/// Orders each triangle of a convex mesh around the origin so that its normal faces outwards.
fn orient_outward(tris: Vec<[DVec3; 3]>) -> Vec<[DVec3; 3]> {
    tris.into_iter()
        .map(|[a, b, c]| {
            if (b - a).cross(c - a).dot(a) > 0.0 {
                [a, b, c]
            } else {
                [a, c, b]
            }
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn solid_angle_hessian_is_exactly_symmetric((x, [a, b, c]) in configuration()) {
        for d in [
            kernels::triangle_solid_angle(x, a, b, c, Order::Hessian).unwrap(),
            kernels::triangle_solid_angle_signed(x, a, b, c, Order::Hessian).unwrap(),
        ] {
            prop_assert_eq!(d.hessian, d.hessian.transpose());
        }
    }

    #[test]
    fn solid_angle_is_invariant_under_vertex_permutation((x, [a, b, c]) in configuration()) {
        let d = kernels::triangle_solid_angle(x, a, b, c, Order::Hessian).unwrap();
        let s = kernels::triangle_solid_angle_signed(x, a, b, c, Order::Hessian).unwrap();
        prop_assert!((d.value - s.value.abs()).abs() <= 1e-15 * d.value);
        for (p, odd) in [([a, b, c], false), ([b, c, a], false), ([c, a, b], false),
                         ([b, a, c], true), ([a, c, b], true), ([c, b, a], true)] {
            let e = kernels::triangle_solid_angle(x, p[0], p[1], p[2], Order::Hessian).unwrap();
            prop_assert!(close3(&e, &d, 1e-13), "{:?} vs {:?}", e, d);
            let t = kernels::triangle_solid_angle_signed(x, p[0], p[1], p[2], Order::Hessian)
                .unwrap();
            let expect = if odd {
                Deriv3 { value: -s.value, gradient: -s.gradient, hessian: s.hessian * -1.0 }
            } else {
                s
            };
            prop_assert!(close3(&t, &expect, 1e-13), "{:?} vs {:?}", t, expect);
        }
    }

    #[test]
    fn solid_angle_is_invariant_under_rigid_motion(
        (x, [a, b, c]) in configuration(), q in unit_quat(), t in vec3(5.0)
    ) {
        let scale = (b - a).length();
        let m = |p: DVec3| q * p + t * scale;
        let d = kernels::triangle_solid_angle(x, a, b, c, Order::Hessian).unwrap();
        let e = kernels::triangle_solid_angle(m(x), m(a), m(b), m(c), Order::Hessian).unwrap();
        let r = DMat3::from_quat(q);
        let expect = Deriv3 {
            value: d.value,
            gradient: r * d.gradient,
            hessian: r * d.hessian * r.transpose(),
        };
        prop_assert!(close3(&e, &expect, 1e-12), "{:?} vs {:?}", e, expect);
    }

    #[test]
    fn solid_angle_derivatives_match_finite_differences((x, [a, b, c]) in configuration()) {
        let l = (b - a).length();
        let h = 1e-4 * l;
        let f = |p: DVec3| kernels::triangle_solid_angle(p, a, b, c, Order::Gradient).unwrap();
        let d = kernels::triangle_solid_angle(x, a, b, c, Order::Hessian).unwrap();
        let (gs, hs) = scale_of(&d);
        for i in 0..3 {
            // Richardson-extrapolated central differences (steps h and h/2): the O(h²) error of
            // one central difference reaches 1e-6 relative where x is only ~0.07 sizes from an
            // edge's line (the configurations keep x away from the plane and the vertices only)
            let central = |h: f64| {
                let mut e = DVec3::ZERO;
                e[i] = h;
                let (p, m) = (f(x + e), f(x - e));
                ((p.value - m.value) / (2.0 * h), (p.gradient - m.gradient) / (2.0 * h))
            };
            let ((g1, c1), (g2, c2)) = (central(h), central(0.5 * h));
            let g = (4.0 * g2 - g1) / 3.0;
            let col = (c2 * 4.0 - c1) / 3.0;
            prop_assert!((g - d.gradient[i]).abs() <= 1e-6 * gs, "grad {i}: {g} vs {}", d.gradient[i]);
            prop_assert!((col - d.hessian.col(i)).abs().max_element() <= 1e-6 * hs,
                "hessian col {i}: {col:?} vs {:?}", d.hessian.col(i));
        }
    }

    #[test]
    fn closed_meshes_subtend_four_pi_inside_and_nothing_outside(
        q in unit_quat(), t in vec3(10.0), k in -3.0f64..3.0, inside in vec3(0.3),
        out_dir in vec3(1.0), out_dist in 1.5f64..100.0, mesh in 0usize..3
    ) {
        prop_assume!(out_dir.length() > 0.1);
        let s = 10f64.powf(k);
        let tris = match mesh { 0 => tetrahedron(), 1 => cube(), _ => icosahedron() };
        let place = |p: DVec3| (q * p + t) * s;
        // The three meshes contain the ball of radius 0.3 / sqrt(3) around the origin.
        let inner = place(inside / 3f64.sqrt());
        let outer = place(out_dir.normalize() * 2.0 * out_dist);
        for (x, total) in [(inner, 4.0 * PI), (outer, 0.0)] {
            // Not Deriv3::default(): glam's default matrix is the identity.
            let mut sum = Deriv3::constant(0.0);
            let mut gscale = 0.0f64;
            let mut hscale = 0.0f64;
            for [a, b, c] in &tris {
                let d = kernels::triangle_solid_angle_signed(
                    x, place(*a), place(*b), place(*c), Order::Hessian).unwrap();
                let (g, h) = scale_of(&d);
                gscale = gscale.max(g);
                hscale = hscale.max(h);
                sum.value += d.value;
                sum.gradient += d.gradient;
                sum.hessian += d.hessian;
            }
            prop_assert!((sum.value - total).abs() <= 1e-12 * 4.0 * PI, "{} vs {}", sum.value, total);
            prop_assert!(sum.gradient.abs().max_element() <= 1e-12 * gscale, "{:?}", sum.gradient);
            prop_assert!(sum.hessian.to_cols_array().iter().all(|v| v.abs() <= 1e-12 * hscale),
                "{:?}", sum.hessian);
            if total > 0.0 {
                // Inside a convex mesh every face is seen from its back: unsigned = signed.
                let unsigned: f64 = tris.iter().map(|[a, b, c]| kernels::triangle_solid_angle(
                    x, place(*a), place(*b), place(*c), Order::Value).unwrap().value).sum();
                prop_assert!((unsigned - total).abs() <= 1e-12 * total);
            }
        }
    }
}
