//! Non-finite input to every closed-form kernel, one coordinate at a time, in the configurations
//! that select each evaluation path (generic, far away, near the plane with clipping, a sliver,
//! the triangle below the tangent plane): `Error::InvalidArgument` at every order, never a value.
//!
//! The fast paths test their ranges with `f64::max`, which drops a NaN operand, so a single NaN
//! coordinate can pass a range check that an all-NaN vector fails: this walks every coordinate
//! separately.

use glam::{DVec2, DVec3};
use raddiff::{kernels, Error, Order};

const ORDERS: [Order; 3] = [Order::Value, Order::Gradient, Order::Hessian];
const BAD: [f64; 3] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];

/// `(name, x, n, vertices)`: each selects a different path of the form-factor kernels.
fn configurations() -> Vec<(&'static str, DVec3, DVec3, Vec<DVec3>)> {
    let tri = vec![
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(1.0, 0.0, 1.2),
        DVec3::new(0.2, 1.0, 0.9),
    ];
    let tilted = DVec3::new(0.3, 0.1, 1.0).normalize();
    let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
    let plane_n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
    vec![
        ("generic", DVec3::ZERO, DVec3::Z, tri.clone()),
        ("far", DVec3::new(0.0, 0.0, -1e3), DVec3::Z, tri.clone()),
        (
            "near the plane, clipped",
            centroid - 1e-6 * plane_n,
            tilted.cross(plane_n).normalize(),
            tri.clone(),
        ),
        (
            "sliver",
            DVec3::new(0.4, 0.1, 0.3),
            DVec3::Z,
            vec![
                DVec3::new(0.0, 0.0, 1.0),
                DVec3::new(1.0, 0.0, 1.0),
                DVec3::new(0.5, 1e-6, 1.0),
            ],
        ),
        ("below the tangent plane", DVec3::ZERO, -DVec3::Z, tri),
    ]
}

/// Every way to make one coordinate of `points` non-finite.
fn spoiled(points: &[DVec3]) -> impl Iterator<Item = (usize, Vec<DVec3>)> + '_ {
    (0..points.len()).flat_map(move |k| {
        (0..3).flat_map(move |axis| {
            BAD.into_iter().map(move |bad| {
                let mut p = points.to_vec();
                p[k][axis] = bad;
                (k, p)
            })
        })
    })
}

fn assert_invalid<T: std::fmt::Debug>(r: raddiff::Result<T>, what: &str) {
    assert!(
        matches!(r, Err(Error::InvalidArgument(_))),
        "{what}: expected InvalidArgument, got {r:?}"
    );
}

#[test]
fn form_factors_refuse_every_non_finite_coordinate() {
    let quad_extra = DVec3::new(0.9, 1.1, 1.1);
    for (name, x, n, tri) in configurations() {
        // x, n, then the vertices: one list, spoiled one coordinate at a time.
        let mut args = vec![x, n];
        args.extend(&tri);
        for order in ORDERS {
            for (k, a) in spoiled(&args) {
                let what = format!("{name}, argument {k}, {a:?}, {order:?}");
                let (x, n, v) = (a[0], a[1], &a[2..]);
                assert_invalid(
                    kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order),
                    &format!("triangle_form_factor: {what}"),
                );
                assert_invalid(
                    kernels::polygon_form_factor(x, n, v, order),
                    &format!("polygon_form_factor (3): {what}"),
                );
                // A convex quad through the same corners: the polygon fast paths.
                let quad = [v[0], v[1], quad_extra, v[2]];
                assert_invalid(
                    kernels::polygon_form_factor(x, n, &quad, order),
                    &format!("polygon_form_factor (4): {what}"),
                );
                // The edge runs from the first vertex to the second.
                if k < 4 {
                    assert_invalid(
                        kernels::edge_form_factor(x, n, v[0], v[1], order),
                        &format!("edge_form_factor: {what}"),
                    );
                }
            }
        }
    }
}

#[test]
fn solid_angles_and_jacobian_refuse_every_non_finite_coordinate() {
    for (name, x, _, tri) in configurations() {
        let mut args = vec![x];
        args.extend(&tri);
        for (k, a) in spoiled(&args) {
            let what = format!("{name}, argument {k}, {a:?}");
            for order in ORDERS {
                assert_invalid(
                    kernels::triangle_solid_angle(a[0], a[1], a[2], a[3], order),
                    &format!("triangle_solid_angle: {what}, {order:?}"),
                );
                assert_invalid(
                    kernels::triangle_solid_angle_signed(a[0], a[1], a[2], a[3], order),
                    &format!("triangle_solid_angle_signed: {what}, {order:?}"),
                );
            }
            assert_invalid(
                kernels::vector_form_factor_jacobian(a[0], &a[1..]),
                &format!("vector_form_factor_jacobian: {what}"),
            );
        }
    }
}

#[test]
fn flatland_and_transmittance_refuse_every_non_finite_coordinate() {
    let (x, a, b) = (
        DVec2::new(0.2, -1.0),
        DVec2::new(-1.0, 0.0),
        DVec2::new(1.0, 0.3),
    );
    for order in ORDERS {
        for k in 0..3 {
            for axis in 0..2 {
                for bad in BAD {
                    let mut p = [x, a, b];
                    p[k][axis] = bad;
                    assert_invalid(
                        kernels::segment_form_factor_2d(p[0], p[1], p[2], order),
                        &format!("segment_form_factor_2d: {p:?}, {order:?}"),
                    );
                }
            }
        }
        for (_, p) in spoiled(&[DVec3::ZERO, DVec3::new(0.5, 1.0, 2.0)]) {
            assert_invalid(
                kernels::transmittance(p[0], p[1], 0.7, order),
                &format!("transmittance: {p:?}, {order:?}"),
            );
        }
        for bad in BAD {
            assert_invalid(
                kernels::transmittance(DVec3::ZERO, DVec3::X, bad, order),
                &format!("transmittance: sigma_t {bad}, {order:?}"),
            );
        }
    }
}
