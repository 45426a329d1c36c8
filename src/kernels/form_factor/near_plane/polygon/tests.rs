use super::*;
use crate::kernels::form_factor::near_plane::route_loop::CLIP_VERTEX_ZERO;
use crate::kernels::form_factor::near_plane::triangle::tests::robust_takes_the_split;
use crate::kernels::form_factor::robust::form_factor;
use crate::test_rng::lcg;
use crate::Order;

/// [`polygon_value`] for 4 to 8 vertices from a slice (`None` for other counts): the tests' entry.
fn polygon_value_of(x: DVec3, n: DVec3, v: &[DVec3]) -> Option<f64> {
    match v.len() {
        4 => polygon_value::<4, 8>(x, n, v.try_into().ok()?),
        5 => polygon_value::<5, 10>(x, n, v.try_into().ok()?),
        6 => polygon_value::<6, 12>(x, n, v.try_into().ok()?),
        7 => polygon_value::<7, 14>(x, n, v.try_into().ok()?),
        8 => polygon_value::<8, 16>(x, n, v.try_into().ok()?),
        _ => None,
    }
}

/// A random strictly convex polygon of `m` vertices and size `scale` (jittered angles on an
/// ellipse with axes 0.5-1, in a random plane, offset from the origin), `x` 1e-9..1e-3 sizes
/// from its plane (either side) over a random in-plane point, mostly outside the polygon (up
/// to 2.5 sizes from its centre), and a receiver normal tilted 2-88 degrees from the plane's,
/// either way, so that the tangent plane usually cuts the polygon.
fn configuration(state: &mut u64, m: usize, scale: f64) -> (DVec3, DVec3, Vec<DVec3>) {
    let mut c = || lcg(state);
    let plane_n = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
    let (a1, a2) = (plane_n.any_orthonormal_vector(), 0.5 + 0.5 * c());
    let a1 = a1 * (0.5 + 0.5 * c());
    let b1 = plane_n.cross(a1).normalize() * a2;
    let centre = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * 10.0 * scale;
    let v: Vec<DVec3> = (0..m)
        .map(|k| {
            let phi = std::f64::consts::TAU * (k as f64 + 0.6 * (c() - 0.5)) / m as f64;
            centre + (a1 * phi.cos() + b1 * phi.sin()) * scale
        })
        .collect();
    let mut c = || lcg(state);
    let phi = std::f64::consts::TAU * c();
    let foot =
        centre + (a1.normalize() * phi.cos() + b1.normalize() * phi.sin()) * (2.5 * c()) * scale;
    let side = if c() < 0.5 { -1.0 } else { 1.0 };
    let x = foot + plane_n * side * scale * 10f64.powf(-3.0 - 6.0 * c());
    let tilt = (2.0 + 86.0 * c()).to_radians();
    let t = plane_n.any_orthonormal_vector();
    let psi = 6.3 * c();
    let t = t * psi.cos() + plane_n.cross(t) * psi.sin();
    let n = (plane_n * tilt.cos() + t * tilt.sin()).normalize();
    let n = if c() < 0.5 { n } else { -n };
    (x, n, v)
}

/// Wherever the route answers it returns the robust evaluation's bits, with and without FMA,
/// only where that evaluation takes its near-plane split for the value, and for every such
/// configuration (quads, pentagons, hexagons, octagons at scales 1e-3..1e3); the entry
/// point's value is the same at every order.
#[test]
fn the_route_returns_the_robust_bits() {
    let mut state = 7;
    let (mut taken, mut robust_split) = (0, 0);
    let total = 12000;
    for k in 0..total {
        let scale = [1e-3, 1.0, 1e3][k % 3];
        let m = [4, 5, 6, 8][(k / 3) % 4];
        let (x, n, v) = configuration(&mut state, m, scale);
        let got = polygon_value_of(x, n, &v);
        let portable = match m {
            4 => screen::<4>(x, n, v[..].try_into().unwrap())
                .and_then(|s| {
                    let mut points = [CLIP_VERTEX_ZERO; 8];
                    split::<4, 8>(
                        x,
                        v[..].try_into().unwrap(),
                        &s,
                        &mut points,
                        &mut [],
                        &mut [],
                        &mut None,
                        false,
                    )
                })
                .map(|(f, _, _)| f),
            5 => screen::<5>(x, n, v[..].try_into().unwrap())
                .and_then(|s| {
                    let mut points = [CLIP_VERTEX_ZERO; 10];
                    split::<5, 10>(
                        x,
                        v[..].try_into().unwrap(),
                        &s,
                        &mut points,
                        &mut [],
                        &mut [],
                        &mut None,
                        false,
                    )
                })
                .map(|(f, _, _)| f),
            6 => screen::<6>(x, n, v[..].try_into().unwrap())
                .and_then(|s| {
                    let mut points = [CLIP_VERTEX_ZERO; 12];
                    split::<6, 12>(
                        x,
                        v[..].try_into().unwrap(),
                        &s,
                        &mut points,
                        &mut [],
                        &mut [],
                        &mut None,
                        false,
                    )
                })
                .map(|(f, _, _)| f),
            _ => screen::<8>(x, n, v[..].try_into().unwrap())
                .and_then(|s| {
                    let mut points = [CLIP_VERTEX_ZERO; 16];
                    split::<8, 16>(
                        x,
                        v[..].try_into().unwrap(),
                        &s,
                        &mut points,
                        &mut [],
                        &mut [],
                        &mut None,
                        false,
                    )
                })
                .map(|(f, _, _)| f),
        };
        assert_eq!(
            got.map(f64::to_bits),
            portable.map(f64::to_bits),
            "{k}: dispatch vs portable"
        );
        let robust_takes = robust_takes_the_split(x, n, &v, true);
        robust_split += usize::from(robust_takes);
        if let Some(f) = got {
            taken += 1;
            assert!(
                robust_takes,
                "{k}: the route answers where the robust path does not"
            );
            let want = form_factor(x, n, &v, Order::Value).unwrap();
            assert_eq!(f.to_bits(), want.value.to_bits(), "{k}: {x:?} {n:?} {v:?}");
        }
        let entry = |order| crate::kernels::polygon_form_factor(x, n, &v, order);
        if let (Ok(value), Ok(hessian)) = (entry(Order::Value), entry(Order::Hessian)) {
            assert_eq!(value.value.to_bits(), hessian.value.to_bits(), "{k}: order");
        }
    }
    println!("route taken in {taken} of {total} configurations, robust split {robust_split}");
    assert_eq!(taken, robust_split);
    assert!(taken > total / 10, "{taken}");
}

/// The benchmarked quad and pentagon 1e-6 from the plane outside (`benches/kernels_regimes.rs`,
/// the same construction) are taken, with the robust bits.
#[test]
fn the_benchmarked_cases_are_taken() {
    let quad: Vec<DVec3> = [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
        .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
        .to_vec();
    let pentagon: Vec<DVec3> = (0..5)
        .map(|i| {
            let phi = std::f64::consts::TAU * i as f64 / 5.0;
            DVec3::new(phi.cos(), phi.sin(), 1.2 + 0.3 * phi.sin())
        })
        .collect();
    for (v, edge) in [(quad, 0), (pentagon, 1)] {
        let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let centroid = v.iter().sum::<DVec3>() / v.len() as f64;
        let mid = (v[edge] + v[(edge + 1) % v.len()]) * 0.5;
        let x = mid + (mid - centroid) * 0.2 - plane_n * 1e-6;
        let normal = DVec3::new(0.1, -0.2, 1.0).normalize();
        let n = if (v[0] - x).dot(normal) > 0.0 {
            normal
        } else {
            -normal
        };
        let got = polygon_value_of(x, n, &v).expect("taken");
        let want = form_factor(x, n, &v, Order::Value).unwrap().value;
        assert_eq!(got.to_bits(), want.to_bits());
    }
}
