//! Property tests of the form-factor kernels: Hessian symmetry, invariance under vertex order and
//! rigid motion, closed hemispheres summing to 1, gradients equal to finite differences, agreement
//! of the clipped kernel with the raw edge sum when nothing is clipped, and agreement of the
//! gradient with Arvo's irradiance Jacobian.

use glam::{DMat3, DQuat, DVec3};
use proptest::prelude::*;
use raddiff::{kernels, Deriv3, Order};

fn vec3(r: f64) -> impl Strategy<Value = DVec3> {
    (-r..r, -r..r, -r..r).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn unit() -> impl Strategy<Value = DVec3> {
    vec3(1.0)
        .prop_filter("not too short", |v| v.length() > 0.2)
        .prop_map(|v| v.normalize())
}

/// A triangle of reasonable shape and a point away from its plane (so derivatives exist).
fn configuration() -> impl Strategy<Value = (DVec3, DVec3, [DVec3; 3])> {
    (vec3(2.0), unit(), vec3(1.0), vec3(1.0), vec3(1.0)).prop_filter_map(
        "well-shaped",
        |(x, n, a, b, c)| {
            let normal = (b - a).cross(c - a);
            if normal.length() < 0.1 {
                return None;
            }
            if normal.normalize().dot(a - x).abs() < 0.05
                || (a - x).length().min((b - x).length()).min((c - x).length()) < 0.05
            {
                return None;
            }
            Some((x, n, [a, b, c]))
        },
    )
}

fn scale_of(d: &Deriv3) -> (f64, f64, f64) {
    (
        d.value.abs().max(1e-300),
        d.gradient.abs().max_element().max(1e-300),
        d.hessian
            .to_cols_array()
            .iter()
            .fold(1e-300f64, |m, v| m.max(v.abs())),
    )
}

fn close(a: &Deriv3, b: &Deriv3, tol: f64) -> bool {
    close_above(a, b, tol, (0.0, 0.0, 0.0))
}

/// A thousandth of the value and derivative scales of triangle `t` seen from `x` before any
/// clipping (its solid angle's, over π). Where the tangent plane leaves only a sliver of the triangle, the clipped
/// kernel's rounding errors are relative to these (the clip points carry them), not to the
/// sliver's own tiny values.
fn unclipped_scale(x: DVec3, t: &[DVec3; 3]) -> (f64, f64, f64) {
    let d = kernels::triangle_solid_angle(x, t[0], t[1], t[2], Order::Hessian).unwrap();
    let (v, g, h) = scale_of(&d);
    // the clip points' rounding (a few ulps of the triangle) reaches the sliver's values and
    // derivatives scaled down by far more than 1e-3
    let k = 1e-3 / std::f64::consts::PI;
    (v * k, g * k, h * k)
}

/// [`close`] with every scale at least `floor`'s.
fn close_above(a: &Deriv3, b: &Deriv3, tol: f64, floor: (f64, f64, f64)) -> bool {
    let (sv, sg, sh) = scale_of(b);
    let (sv, sg, sh) = (sv.max(floor.0), sg.max(floor.1), sh.max(floor.2));
    let dh = (a.hessian - b.hessian)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    (a.value - b.value).abs() <= tol * sv.max(1e-14)
        && (a.gradient - b.gradient).abs().max_element() <= tol * sg.max(1e-14)
        && dh <= tol * sh.max(1e-14)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn hessian_is_symmetric((x, n, t) in configuration()) {
        let d = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian).unwrap();
        prop_assert!(d.is_finite());
        prop_assert_eq!(d.hessian, d.hessian.transpose());
        prop_assert!((0.0..=1.0).contains(&d.value));
    }

    #[test]
    fn invariant_under_vertex_order((x, n, t) in configuration()) {
        let d = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian).unwrap();
        for p in [[1, 2, 0], [2, 0, 1], [0, 2, 1], [2, 1, 0], [1, 0, 2]] {
            let e = kernels::triangle_form_factor(x, n, t[p[0]], t[p[1]], t[p[2]], Order::Hessian).unwrap();
            // small clipped values are conditioned by the clip (see the accuracy tests): their
            // errors are relative to the unclipped triangle's scales
            prop_assert!(close_above(&e, &d, 1e-11, unclipped_scale(x, &t)), "{p:?}: {e:?} vs {d:?}");
        }
    }

    #[test]
    fn invariant_under_rigid_motion((x, n, t) in configuration(), axis in unit(), angle in -3.0..3.0f64, shift in vec3(100.0)) {
        let q = DQuat::from_axis_angle(axis, angle);
        let m = |v: DVec3| q * v + shift;
        let d = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian).unwrap();
        let e = kernels::triangle_form_factor(m(x), (q * n).normalize(), m(t[0]), m(t[1]), m(t[2]), Order::Hessian).unwrap();
        let r = DMat3::from_quat(q);
        let expect = Deriv3 { value: d.value, gradient: r * d.gradient, hessian: r * d.hessian * r.transpose() };
        // the translation by up to 100 costs ~100 ulps of the unit-size coordinates (relative to
        // the unclipped triangle's scales where the tangent plane leaves a sliver)
        prop_assert!(close_above(&e, &expect, 1e-10, unclipped_scale(x, &t)), "{e:?} vs {expect:?}");
    }

    #[test]
    fn gradient_and_hessian_match_finite_differences((x, n, t) in configuration()) {
        // The clipped kernel is not smooth where the tangent plane crosses a vertex: the steps
        // must stay well clear of that (their truncation error grows like (h / distance)²).
        prop_assume!(t.iter().all(|v| n.dot(*v - x).abs() > 1e-2));
        let d = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian).unwrap();
        let h = 1e-5;
        let (_, sg, sh) = scale_of(&d);
        for i in 0..3 {
            let mut e = DVec3::ZERO;
            e[i] = h;
            let fp = kernels::triangle_form_factor(x + e, n, t[0], t[1], t[2], Order::Gradient).unwrap();
            let fm = kernels::triangle_form_factor(x - e, n, t[0], t[1], t[2], Order::Gradient).unwrap();
            let g = (fp.value - fm.value) / (2.0 * h);
            prop_assert!((g - d.gradient[i]).abs() <= 1e-6 * sg.max(1e-3), "d/dx{i}: fd {g} vs {}", d.gradient[i]);
            let col = (fp.gradient - fm.gradient) / (2.0 * h);
            prop_assert!((col - d.hessian.col(i)).abs().max_element() <= 1e-5 * sh.max(1e-2), "H col {i}: fd {col:?} vs {:?}", d.hessian.col(i));
        }
    }

    /// Nothing below the tangent plane: the kernel equals |Σ edge terms| including derivatives.
    #[test]
    fn unclipped_equals_edge_sum((x, _n, t) in configuration(), tilt in vec3(0.3)) {
        let normal = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        // face the triangle so that all of it is above the tangent plane
        let towards = if normal.dot(t[0] - x) > 0.0 { normal } else { -normal };
        let n = (towards + tilt).normalize();
        prop_assume!(t.iter().all(|v| n.dot(*v - x) > 0.0));
        let d = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Hessian).unwrap();
        let mut sum = Deriv3::constant(0.0);
        let mut magnitudes = (0.0, 0.0, 0.0);
        for i in 0..3 {
            let e = kernels::edge_form_factor(x, n, t[i], t[(i + 1) % 3], Order::Hessian).unwrap();
            sum.value += e.value;
            sum.gradient += e.gradient;
            sum.hessian += e.hessian;
            let (v, g, h) = scale_of(&e);
            magnitudes = (magnitudes.0 + v, magnitudes.1 + g, magnitudes.2 + h);
        }
        if sum.value < 0.0 {
            sum.value = -sum.value;
            sum.gradient = -sum.gradient;
            sum.hessian = -sum.hessian;
        }
        // The reference is this plain sum, whose rounding errors are relative to its terms: where
        // they cancel (the triangle small or far, seen edge-on) it is the inaccurate side, so the
        // tolerance is relative to the terms' magnitudes (the kernel's own accuracy is asserted
        // against the 320-bit reference in `form_factor_accuracy`).
        prop_assert!(close_above(&d, &sum, 1e-11, magnitudes), "{d:?} vs {sum:?}");
    }

    /// Arvo's irradiance Jacobian (thesis §5.1): ∇F = ±Jᵀ n for an unclipped polygon.
    #[test]
    fn gradient_matches_arvo_jacobian((x, _n, t) in configuration(), tilt in vec3(0.3)) {
        let normal = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        let towards = if normal.dot(t[0] - x) > 0.0 { normal } else { -normal };
        let n = (towards + tilt).normalize();
        prop_assume!(t.iter().all(|v| n.dot(*v - x) > 0.0));
        let d = kernels::triangle_form_factor(x, n, t[0], t[1], t[2], Order::Gradient).unwrap();
        let jac = kernels::vector_form_factor_jacobian(x, &t).unwrap();
        // Φ·n is the signed form factor: + when the vertices run clockwise seen from x
        let sign = if normal.dot(t[0] - x) > 0.0 { 1.0 } else { -1.0 };
        let arvo = jac.transpose() * n * sign;
        // Arvo's edge sum cancels like the per-edge terms do (far away: terms ~1/d, sum ~1/d³),
        // so its rounding error scales with the terms, not with the sum.
        let terms: f64 = (0..3)
            .map(|k| {
                kernels::edge_form_factor(x, n, t[k], t[(k + 1) % 3], Order::Gradient)
                    .unwrap()
                    .gradient
                    .abs()
                    .max_element()
            })
            .sum();
        let scale = d.gradient.abs().max_element().max(terms).max(1e-12);
        prop_assert!((arvo - d.gradient).abs().max_element() <= 1e-11 * scale, "{arvo:?} vs {:?}", d.gradient);
    }

    /// The twelve triangles of a box around x (clipped by the tangent plane) sum to 1, and their
    /// gradients and Hessians sum to 0.
    #[test]
    fn closed_box_sums_to_one(x in vec3(0.45), n in unit(), half in (0.5..3.0f64, 0.5..3.0f64, 0.5..3.0f64)) {
        let (hx, hy, hz) = half;
        let c = |i: usize| DVec3::new(
            if i & 1 == 0 { -hx } else { hx },
            if i & 2 == 0 { -hy } else { hy },
            if i & 4 == 0 { -hz } else { hz },
        ) * 1.0 + DVec3::ZERO;
        let faces = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]];
        let mut total = Deriv3::constant(0.0);
        let mut quads = Deriv3::constant(0.0);
        for f in faces {
            for tri in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
                let d = kernels::triangle_form_factor(x, n, c(tri[0]), c(tri[1]), c(tri[2]), Order::Hessian).unwrap();
                total.value += d.value;
                total.gradient += d.gradient;
                total.hessian += d.hessian;
            }
            let q = kernels::polygon_form_factor(x, n, &[c(f[0]), c(f[1]), c(f[2]), c(f[3])], Order::Hessian).unwrap();
            quads.value += q.value;
            quads.gradient += q.gradient;
            quads.hessian += q.hessian;
        }
        for t in [total, quads] {
            prop_assert!((t.value - 1.0).abs() < 1e-13, "sum {}", t.value);
            prop_assert!(t.gradient.abs().max_element() < 1e-11, "gradient sum {:?}", t.gradient);
            prop_assert!(t.hessian.to_cols_array().iter().all(|v| v.abs() < 1e-9), "hessian sum {:?}", t.hessian);
        }
    }
}

#[test]
fn unit_normal_is_checked_and_renormalized() {
    let t = [
        DVec3::new(0., 0., 1.),
        DVec3::new(1., 0., 1.),
        DVec3::new(0., 1., 1.),
    ];
    let a = kernels::triangle_form_factor(DVec3::ZERO, DVec3::Z, t[0], t[1], t[2], Order::Hessian)
        .unwrap();
    let b = kernels::triangle_form_factor(
        DVec3::ZERO,
        DVec3::Z * (1.0 + 5e-7),
        t[0],
        t[1],
        t[2],
        Order::Hessian,
    )
    .unwrap();
    assert_eq!(a, b);
    for bad in [DVec3::ZERO, DVec3::Z * 1.01, DVec3::new(f64::NAN, 0., 1.)] {
        assert!(matches!(
            kernels::triangle_form_factor(DVec3::ZERO, bad, t[0], t[1], t[2], Order::Value),
            Err(raddiff::Error::InvalidArgument(_))
        ));
    }
}

#[test]
fn edge_term_limits() {
    let (a, b) = (DVec3::new(0., 0., 1.), DVec3::new(1., 0., 1.));
    // on the segment: undefined
    assert!(matches!(
        kernels::edge_form_factor((a + b) / 2.0, DVec3::Z, a, b, Order::Value),
        Err(raddiff::Error::Degenerate(_))
    ));
    assert!(matches!(
        kernels::edge_form_factor(a, DVec3::Z, a, b, Order::Value),
        Err(raddiff::Error::Degenerate(_))
    ));
    // on the line outside the segment: the finite limit, continuous with nearby points
    let x = DVec3::new(-1., 0., 1.);
    let on = kernels::edge_form_factor(x, DVec3::Y, a, b, Order::Hessian).unwrap();
    let near =
        kernels::edge_form_factor(x + DVec3::new(0., 0., 1e-9), DVec3::Y, a, b, Order::Hessian)
            .unwrap();
    assert!(on.is_finite());
    assert!((on.value - near.value).abs() < 1e-8);
    assert!((on.gradient - near.gradient).abs().max_element() < 1e-7);
    // a zero-length edge contributes nothing; reversing the edge flips the sign
    assert_eq!(
        kernels::edge_form_factor(x, DVec3::Y, a, a, Order::Hessian).unwrap(),
        Deriv3::constant(0.0)
    );
    let y = DVec3::new(0.3, -0.4, 0.2);
    let ab = kernels::edge_form_factor(y, DVec3::Z, a, b, Order::Hessian).unwrap();
    let ba = kernels::edge_form_factor(y, DVec3::Z, b, a, Order::Hessian).unwrap();
    assert!((ab.value + ba.value).abs() < 1e-16);
    assert!((ab.gradient + ba.gradient).abs().max_element() < 1e-15);
}

#[test]
fn far_field_switch_is_continuous() {
    // Walk x outwards through the switch: the kernel changes formulation but not value.
    let t = [
        DVec3::new(-0.5, -0.3, 0.0),
        DVec3::new(0.6, -0.2, 0.1),
        DVec3::new(0.1, 0.7, -0.1),
    ];
    let c = (t[0] + t[1] + t[2]) / 3.0;
    let radius = t.iter().map(|v| (*v - c).length()).fold(0.0, f64::max);
    let dir = DVec3::new(0.3, 0.2, 0.9).normalize();
    let n = -DVec3::new(0.1, 0.3, 0.9).normalize();
    let at = |k: f64| {
        kernels::triangle_form_factor(c + dir * k * radius, n, t[0], t[1], t[2], Order::Hessian)
            .unwrap()
    };
    let (below, above) = (at(16.0 * (1.0 - 1e-14)), at(16.0 * (1.0 + 1e-14)));
    assert!(close(&below, &above, 1e-12), "{below:?} vs {above:?}");
}

#[test]
fn polygon_validation() {
    use raddiff::Error;
    let x = DVec3::new(0.1, 0.2, -1.0);
    let sq = [
        DVec3::new(0., 0., 0.),
        DVec3::new(1., 0., 0.),
        DVec3::new(1., 1., 0.),
        DVec3::new(0., 1., 0.),
    ];
    assert!(kernels::polygon_form_factor(x, DVec3::Z, &sq, Order::Hessian).is_ok());
    // fewer than 3 vertices
    assert!(matches!(
        kernels::polygon_form_factor(x, DVec3::Z, &sq[..2], Order::Value),
        Err(Error::InvalidArgument(_))
    ));
    // not planar beyond 1e-8 of the extent; within it is accepted
    let mut bent = sq;
    bent[2].z = 1e-6;
    assert!(
        matches!(kernels::polygon_form_factor(x, DVec3::Z, &bent, Order::Value), Err(Error::InvalidArgument(m)) if m.contains("planar"))
    );
    bent[2].z = 1e-9;
    assert!(kernels::polygon_form_factor(x, DVec3::Z, &bent, Order::Value).is_ok());
    // self-intersecting
    let bow = [sq[0], DVec3::new(1.3, 1.1, 0.0), sq[1], sq[3]];
    assert!(
        matches!(kernels::polygon_form_factor(x, DVec3::Z, &bow, Order::Value), Err(Error::InvalidArgument(m)) if m.contains("simple"))
    );
    // non-finite vertex
    let mut nan = sq;
    nan[1].y = f64::INFINITY;
    assert!(matches!(
        kernels::polygon_form_factor(x, DVec3::Z, &nan, Order::Value),
        Err(Error::InvalidArgument(_))
    ));
    // zero area (collinear) is degenerate
    let line = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
    assert!(matches!(
        kernels::polygon_form_factor(x, DVec3::Z, &line, Order::Value),
        Err(Error::Degenerate(_))
    ));
    // a non-convex (L-shaped) polygon equals the sum of its two rectangles, clipped or not
    let l_shape = [
        DVec3::new(0., 0., 0.),
        DVec3::new(2., 0., 0.),
        DVec3::new(2., 1., 0.),
        DVec3::new(1., 1., 0.),
        DVec3::new(1., 2., 0.),
        DVec3::new(0., 2., 0.),
    ];
    let a = [
        DVec3::new(0., 0., 0.),
        DVec3::new(2., 0., 0.),
        DVec3::new(2., 1., 0.),
        DVec3::new(0., 1., 0.),
    ];
    let b = [
        DVec3::new(0., 1., 0.),
        DVec3::new(1., 1., 0.),
        DVec3::new(1., 2., 0.),
        DVec3::new(0., 2., 0.),
    ];
    for n in [
        DVec3::Z,
        DVec3::new(0.6, 0.0, 0.8),
        DVec3::new(-0.3, 0.9, 0.3).normalize(),
    ] {
        let x = DVec3::new(0.7, 0.9, -0.4);
        let l = kernels::polygon_form_factor(x, n, &l_shape, Order::Hessian).unwrap();
        let pa = kernels::polygon_form_factor(x, n, &a, Order::Hessian).unwrap();
        let pb = kernels::polygon_form_factor(x, n, &b, Order::Hessian).unwrap();
        let sum = Deriv3 {
            value: pa.value + pb.value,
            gradient: pa.gradient + pb.gradient,
            hessian: pa.hessian + pb.hessian,
        };
        assert!(close(&l, &sum, 1e-12), "{n:?}: {l:?} vs {sum:?}");
    }
}

/// Over a closed mesh every edge appears twice with opposite directions, so the signed edge terms
/// cancel exactly (value and derivatives): the property the occlusion-aware Hessian relies on when it
/// keeps one term per shared edge weighted by the radiance difference of the adjacent triangles.
#[test]
fn edge_terms_of_a_closed_mesh_cancel() {
    let c = |i: usize| {
        DVec3::new(
            if i & 1 == 0 { -1.0 } else { 1.3 },
            if i & 2 == 0 { -0.8 } else { 1.1 },
            if i & 4 == 0 { -0.7 } else { 0.9 },
        )
    };
    let faces = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let x = DVec3::new(0.1, -0.05, 0.2);
    let n = DVec3::new(0.3, -0.2, 0.9).normalize();
    let mut total = Deriv3::constant(0.0);
    for f in faces {
        for k in 0..4 {
            let e = kernels::edge_form_factor(x, n, c(f[k]), c(f[(k + 1) % 4]), Order::Hessian)
                .unwrap();
            total.value += e.value;
            total.gradient += e.gradient;
            total.hessian += e.hessian;
        }
    }
    assert!(total.value.abs() < 1e-15 && total.gradient.abs().max_element() < 1e-14);
    assert!(total
        .hessian
        .to_cols_array()
        .iter()
        .all(|v| v.abs() < 1e-13));
}

#[test]
fn arvo_jacobian_limits() {
    let t = [
        DVec3::new(0., 0., 1.),
        DVec3::new(1., 0., 1.),
        DVec3::new(0., 1., 1.),
    ];
    assert!(matches!(
        kernels::vector_form_factor_jacobian(t[0], &t),
        Err(raddiff::Error::Degenerate(_))
    ));
    assert!(matches!(
        kernels::vector_form_factor_jacobian(DVec3::ZERO, &t[..2]),
        Err(raddiff::Error::InvalidArgument(_))
    ));
    let j = kernels::vector_form_factor_jacobian(DVec3::new(0.2, 0.1, 0.0), &t).unwrap();
    assert!(j.is_finite());
}
