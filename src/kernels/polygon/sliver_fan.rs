//! Very thin polygons (slivers of 4 to 8 vertices) by the triangles' sliver rule, one fan triangle
//! at a time.
//!
//! The sliver rule ([`sliver`](super::sliver)) takes triangles only. A polygon thinner than
//! `2·area < 1e-5·extent²` has an edge sum that cancels beyond
//! [`THIN_CANCELLATION_LIMIT`](super::THIN_CANCELLATION_LIMIT), and `evaluate` then bisects it
//! isotropically into up to 256 pieces: ~230 000 instructions for a quad 1e-6 wide seen from a
//! length away, against ~1 700 for a generic quad.
//!
//! The clipped form factor is the integral over the polygon of a pointwise integrand (the clip
//! is a pointwise factor), so it is additive over a partition. When every fan triangle
//! `(v_0, v_k, v_{k+1})` has the polygon's orientation, the fan partitions the polygon and its
//! form factor is the sum of the triangles' (each a non-negative number: no cancellation in the
//! value). The decisions of the sliver rule's direct entry
//! ([`direct_sliver`](super::sliver::direct_sliver)) are taken once for the polygon (not
//! near the plane, nothing clipped, no far-field rule), then each triangle is integrated by the
//! rule ([`sliver_quadrature`], which declines when `x` is not far from the triangle compared
//! with its width); as soon as one triangle is declined, so is the polygon (with `x` near its
//! plane [`fan_of_triangles`] then sums the fan triangles through the triangle
//! kernel, elsewhere the robust path runs). Where the robust path on a fan triangle takes the rule too, the sum has its bits up to
//! the order of the additions. The derivatives are sums too: a triangle's gradient and Hessian are
//! within its own accuracy relative to its largest entry, and the pieces' derivatives can only
//! partly cancel (all pieces are seen under the same small width, from the same side), which
//! `tests/kernels_b_polygon_slivers.rs` measures against 320-bit references.

use glam::DVec3;

use super::sliver::sliver_quadrature;
use super::{dd, fast_decisions, ClipVertex, Plane};
use crate::kernels::form_factor::oriented;
use crate::kernels::lambert;
use crate::kernels::lambert_polygon::SLIVER_AREA2;
use crate::{Deriv3, Order};

/// Smallest `(u_k × u_{k+1})·N / (‖u_k‖‖u_{k+1}‖‖N‖)` of a fan triangle: its orientation is then
/// certainly the polygon's (the rounded cross product errs by a few ulps of
/// `‖u_k‖‖u_{k+1}‖`), and its area is above the triangles' zero-area limit (1e-13).
const FAN_SINE: f64 = 1e-12;

/// Most vertices taken (the fan's arrays live on the stack).
const MAX_VERTICES: usize = 8;

/// [`polygon_form_factor`](crate::kernels::polygon_form_factor) of a very thin polygon:
/// [`fan_rule`], else [`fan_of_triangles`]; `None` when neither takes it.
/// Polygons that are not thin at all pay one Newell normal here and nothing else (the routes
/// validate the polygon: ~700 instructions on every polygon reaching the robust path).
pub(crate) fn very_thin_polygon_form_factor(
    x: DVec3,
    n: DVec3,
    v: &[DVec3],
    order: Order,
) -> Option<Deriv3> {
    let u = thin_differences(x, v)?;
    fan_rule(x, n, v, &u, order).or_else(|| fan_of_triangles(x, n, v, &u, order))
}

/// Whether every fan triangle `(v_0, v_k, v_{k+1})` (from the differences `u_k = v_k − v_0`)
/// certainly has the orientation of the polygon's unit `normal` ([`FAN_SINE`]): the fan then
/// partitions the polygon.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails
fn fan_keeps_orientation(u: &[DVec3], normal: DVec3) -> bool {
    u[1..].windows(2).all(|w| {
        let scale = w[0].length() * w[1].length();
        w[0].cross(w[1]).dot(normal) > FAN_SINE * scale
    })
}

/// The differences `v_k − v_0` of a polygon of 4 to 8 finite vertices seen from a finite `x`
/// when it is thin at all: exactly the complement of the Lambert fast paths' test (the same
/// rounded Newell normal and extent), so that they never took it; `None` otherwise. `Plane::new`
/// then decides with the robust path's threshold: the other polygons that reach the robust path
/// pay only this test here.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn thin_differences(x: DVec3, v: &[DVec3]) -> Option<[DVec3; MAX_VERTICES]> {
    let m = v.len();
    if !(4..=MAX_VERTICES).contains(&m) || !x.is_finite() || !v.iter().all(|p| p.is_finite()) {
        return None;
    }
    let mut u = [DVec3::ZERO; MAX_VERTICES];
    for k in 1..m {
        u[k] = v[k] - v[0];
    }
    let mut newell = DVec3::ZERO;
    let mut extent2 = 0.0f64;
    for k in 1..m {
        newell += u[k].cross(u[(k + 1) % m]);
        extent2 = extent2.max(u[k].length_squared());
    }
    (newell.length_squared() < SLIVER_AREA2 * extent2 * extent2).then_some(u)
}

/// [`fan_rule`] from the vertices alone (the unit tests' entry).
#[cfg(test)]
pub(crate) fn very_thin_polygon(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Option<Deriv3> {
    fan_rule(x, n, v, &thin_differences(x, v)?, order)
}

/// [`polygon_form_factor`](crate::kernels::polygon_form_factor) of a valid polygon of 4 to 8
/// vertices that is very thin (`2·area < 1e-5·extent²`) with a consistently oriented fan from
/// `v_0`, as the sum of the fan triangles' sliver rules; `None` when any condition fails or a
/// triangle is declined (module documentation), including for invalid input, which the robust
/// path reports. Coordinates differences must be within (1e-30, 1e30), where no rescaling is
/// needed.
/// `u`: the differences of [`thin_differences`].
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn fan_rule(
    x: DVec3,
    n: DVec3,
    v: &[DVec3],
    u: &[DVec3; MAX_VERTICES],
    order: Order,
) -> Option<Deriv3> {
    let m = v.len();
    let mut r = [DVec3::ZERO; MAX_VERTICES];
    let mut r_lo = [DVec3::ZERO; MAX_VERTICES];
    let mut largest = 0.0f64;
    let err = |a: f64, b: f64| dd::two_sum(a, -b).1;
    for k in 0..m {
        r[k] = v[k] - x;
        r_lo[k] = DVec3::new(err(v[k].x, x.x), err(v[k].y, x.y), err(v[k].z, x.z));
        largest = largest.max(u[k].abs().max_element().max(r[k].abs().max_element()));
    }
    if !(largest > 1e-30 && largest < 1e30) {
        return None;
    }
    let n = lambert::unit(n)?;
    // The robust path's validation (area, planarity, simplicity) on the same differences.
    let plane = Plane::new(&u[..m]).ok()?;
    if !plane.is_very_thin() {
        return None;
    }
    // The decisions the sliver rule's direct entry takes per triangle, once for the polygon:
    // x not near the plane (so the side it is on is certain, the same for every fan triangle),
    // no far-field rule (the robust path's far field takes the polygon), and every vertex above
    // the tangent plane by more than the rounding of `n·r` (nothing clipped).
    let (far, h_p) = fast_decisions(&r[..m], &plane)?;
    if far.is_some() {
        return None;
    }
    let above = |v: &DVec3| {
        let h = n.dot(*v);
        h > 0.0 && h * h > 1e-26 * v.length_squared()
    };
    if !r[..m].iter().all(above) {
        return None;
    }
    let vertex = |k: usize| ClipVertex {
        u: u[k],
        r: r[k],
        r_lo: r_lo[k],
        on_line: false,
    };
    if !fan_keeps_orientation(&u[..m], plane.normal) {
        return None;
    }
    let mut sum = Deriv3::constant(0.0);
    for k in 1..m - 1 {
        let d = sliver_quadrature(&[vertex(0), vertex(k), vertex(k + 1)], n, order)?;
        sum.value += d.value;
        sum.gradient += d.gradient;
        sum.hessian += d.hessian;
    }
    oriented(sum, h_p)
}

/// [`fan_of_triangles`] from the vertices alone (the unit tests' entry).
#[cfg(test)]
pub(crate) fn very_thin_polygon_by_triangles(
    x: DVec3,
    n: DVec3,
    v: &[DVec3],
    order: Order,
) -> Option<Deriv3> {
    fan_of_triangles(x, n, v, &thin_differences(x, v)?, order)
}

/// [`polygon_form_factor`](crate::kernels::polygon_form_factor) of the polygons
/// [`fan_rule`] takes up to its per-triangle decisions (valid, 4 to 8 vertices, very
/// thin, a fan from `v_0` with the polygon's orientation) with `x` within 1e-3 of its largest
/// distance to a vertex from the plane: the sum
/// of the fan triangles' [`triangle_form_factor`](crate::kernels::triangle_form_factor), whose
/// very-thin branch handles `x` near the sliver, near its plane and clipping (the clipped
/// integrand is pointwise, so additive over the fan). `None` when any condition fails or a
/// triangle reports an error (the robust path then runs, and reports).
///
/// The value is a sum of non-negative pieces, each within the triangles' sliver accuracy of its
/// own value: the sum is within that accuracy of its value. The derivatives' pieces can partly
/// cancel: each is within its accuracy of its own largest entry, so the sum's error relative to
/// its largest entry is bounded by that accuracy times `Σ|piece| / |sum|` (per entry);
/// `tests/kernels_b_polygon_slivers.rs` measures that ratio.
/// `u`: the differences of [`thin_differences`].
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn fan_of_triangles(
    x: DVec3,
    n: DVec3,
    v: &[DVec3],
    u: &[DVec3; MAX_VERTICES],
    order: Order,
) -> Option<Deriv3> {
    let m = v.len();
    let plane = Plane::new(&u[..m]).ok()?;
    if !plane.is_very_thin() {
        return None;
    }
    // Only near the plane (the robust path's own `NEAR_PLANE_HEIGHT` switch, on rounded
    // heights: a decision, not a value); farther, the robust path (which takes clipped slivers to
    // the clipped sliver rule) is kept.
    let (mut h_min, mut r_max) = (f64::INFINITY, 0.0f64);
    for p in v {
        let r = *p - x;
        h_min = h_min.min(plane.normal.dot(r).abs());
        r_max = r_max.max(r.length());
    }
    if !(h_min < 1e-3 * r_max) {
        return None;
    }
    if !fan_keeps_orientation(&u[..m], plane.normal) {
        return None;
    }
    let mut sum = Deriv3::constant(0.0);
    for k in 1..m - 1 {
        let d = crate::kernels::triangle_form_factor(x, n, v[0], v[k], v[k + 1], order).ok()?;
        sum.value += d.value;
        sum.gradient += d.gradient;
        sum.hessian += d.hessian;
    }
    Some(sum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::polygon::form_factor;
    use crate::kernels::test_rng::lcg;

    /// A convex sliver in a random plane: `m` points along a flat arc of length `len` and height
    /// `width` (the first two at the ends of the long side), shifted by `origin`.
    fn sliver(seed: &mut u64, m: usize, len: f64, width: f64, origin: DVec3) -> Vec<DVec3> {
        let along = DVec3::new(lcg(seed) - 0.5, lcg(seed) - 0.5, lcg(seed) - 0.5).normalize();
        let across = along.any_orthonormal_vector();
        let mut v = vec![origin, origin + along * len];
        // The arc's points from the far end back, strictly convex (heights of a parabola).
        for k in (1..m - 1).rev() {
            let t = k as f64 / (m - 1) as f64 + 0.1 * (lcg(seed) - 0.5) / m as f64;
            v.push(origin + along * (t * len) + across * (width * 4.0 * t * (1.0 - t)));
        }
        v
    }

    /// Agreement with [`fan_reference`]: the same triangles' sums up to the order of the additions.
    /// (Not with the robust path on the whole polygon: its subdivided quadrature and edge sum are
    /// the inaccurate side here, off by up to 4e-8 where `tests/kernels_b_polygon_slivers.rs`
    /// measures the fan path within 1e-15 of 320-bit references.)
    const TOL: [f64; 3] = [1e-14, 1e-14, 1e-14];

    /// The robust path on each fan triangle (its own set-up, rescaling and clipping), summed.
    fn fan_reference(x: DVec3, n: DVec3, v: &[DVec3], order: Order) -> Deriv3 {
        let mut sum = Deriv3::constant(0.0);
        for k in 1..v.len() - 1 {
            let d = form_factor(x, n, &[v[0], v[k], v[k + 1]], order).unwrap();
            sum.value += d.value;
            sum.gradient += d.gradient;
            sum.hessian += d.hessian;
        }
        sum
    }

    /// Value relative error; gradient and Hessian relative to their largest reference entry.
    fn errors(a: &Deriv3, b: &Deriv3) -> [f64; 3] {
        let big = |m: glam::DMat3| m.to_cols_array().iter().fold(0.0f64, |s, e| s.max(e.abs()));
        [
            (a.value - b.value).abs() / b.value.abs(),
            (a.gradient - b.gradient).abs().max_element() / b.gradient.abs().max_element(),
            big(a.hessian - b.hessian) / big(b.hessian),
        ]
    }

    /// On random convex slivers (4 to 8 vertices, widths 1e-5.2..1e-10 of the length, x from 0.2
    /// to 30 lengths away, some near the plane): wherever the fan path accepts it agrees with the
    /// robust path on its fan triangles, at every order, the value the same at every order;
    /// it accepts over a third of them and declines the rest (x over the sliver near its plane, far
    /// field, clipped).
    #[test]
    fn fan_of_slivers_agrees_with_the_robust_path() {
        let mut seed = 7u64;
        let (mut accepted, mut total, mut worst) = (0, 0, [0.0f64; 3]);
        for case in 0..400 {
            let m = 4 + case % 5;
            let len = 10f64.powf(4.0 * lcg(&mut seed) - 2.0);
            let width = len * 10f64.powf(-5.2 - 4.8 * lcg(&mut seed));
            let origin = DVec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed)) * 3.0 * len;
            let v = sliver(&mut seed, m, len, width, origin);
            let c = v.iter().sum::<DVec3>() / m as f64;
            let dir = DVec3::new(
                lcg(&mut seed) - 0.5,
                lcg(&mut seed) - 0.5,
                lcg(&mut seed) - 0.5,
            )
            .normalize();
            let x = c + dir * (len * 10f64.powf(2.2 * lcg(&mut seed) - 0.7));
            let tilt = DVec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed)) - 0.5;
            let n0 = ((c - x).normalize() + tilt).normalize();
            total += 1;
            let values: Vec<Option<Deriv3>> = [Order::Value, Order::Gradient, Order::Hessian]
                .iter()
                .map(|&order| {
                    let got = very_thin_polygon(x, n0, &v, order)?;
                    let want = fan_reference(x, n0, &v, order);
                    let e = errors(&got, &want);
                    let at = format!("case {case} {order:?}: {e:?} x={x:?} n={n0:?} v={v:?} got={got:?} want={want:?}");
                    assert!(e[0] < TOL[0], "{at}");
                    if order.gradient() {
                        assert!(e[1] < TOL[1], "{at}");
                    }
                    if order.hessian() {
                        assert!(e[2] < TOL[2], "{at}");
                    }
                    for k in 0..3 {
                        worst[k] = worst[k].max(if k <= order as usize { e[k] } else { 0.0 });
                    }
                    Some(got)
                })
                .collect();
            // All orders accept or decline together, with one value.
            assert!(values.iter().all(Option::is_some) || values.iter().all(Option::is_none));
            if let [Some(a), Some(b), Some(c)] = &values[..] {
                assert!(a.value == b.value && b.value == c.value, "case {case}");
                accepted += 1;
            }
        }
        println!("accepted {accepted} of {total}, worst {worst:?}");
        assert!(accepted > total / 3, "accepted {accepted} of {total}");
    }

    /// Across the switches: the thinness threshold (widths around 1e-5 of the length: on the
    /// thin side the fan path, the public entry's result, on the other the robust path) and x
    /// walking in towards the sliver until the rule declines, once.
    #[test]
    fn continuous_across_the_switches() {
        let base = |w: f64| {
            vec![
                DVec3::new(0.0, 0.0, 1.0),
                DVec3::new(1.0, 0.0, 1.0),
                DVec3::new(0.7, w, 1.0),
                DVec3::new(0.2, w, 1.0),
            ]
        };
        let n = DVec3::new(0.1, -0.2, 1.0).normalize();
        let x = DVec3::new(0.4, 0.1, 0.3);
        // Twice the area of the trapezoid is 1.5 w: very thin below w = 1e-5 / 1.5.
        let (mut thin, mut thick) = (0, 0);
        for k in -20..=20 {
            let w = 1e-5 / 1.5 * (1.0 + k as f64 * 1e-3);
            let v = base(w);
            let robust = fan_reference(x, n, &v, Order::Hessian);
            let public = crate::kernels::polygon_form_factor(x, n, &v, Order::Hessian).unwrap();
            match very_thin_polygon(x, n, &v, Order::Hessian) {
                Some(d) => {
                    thin += 1;
                    assert_eq!(d, public);
                    let e = errors(&d, &robust);
                    assert!(
                        e[0] < TOL[0] && e[1] < TOL[1] && e[2] < TOL[2],
                        "w {w:e}: {e:?}"
                    );
                }
                None => thick += 1,
            }
        }
        assert!(thin > 10 && thick > 10, "{thin} thin, {thick} thick");
        // x down the normal onto the sliver's middle: accepted far out, declined once x is
        // close (the rule's width condition, then near the plane).
        let v = base(1e-7);
        let (mut last, mut declined) = (None::<Deriv3>, false);
        for k in 0..=120 {
            let h = 10f64.powf(0.3 - k as f64 * 0.1);
            let x = DVec3::new(0.45, 0.5e-7, 1.0 - h);
            let got = very_thin_polygon(x, DVec3::Z, &v, Order::Hessian);
            let robust = fan_reference(x, DVec3::Z, &v, Order::Hessian);
            match got {
                Some(d) => {
                    assert!(!declined, "accepted again at h = {h:e}");
                    let e = errors(&d, &robust);
                    assert!(
                        e[0] < TOL[0] && e[1] < TOL[1] && e[2] < TOL[2],
                        "h {h:e}: {e:?}"
                    );
                    last = Some(d);
                }
                None => declined = true,
            }
        }
        assert!(declined && last.is_some());
    }

    /// The near-plane fallback: taken with x within 1e-3 of the largest vertex distance from the
    /// plane (the sum of the public triangle kernel on the fan, the public entry's result),
    /// declined farther, for polygons that are not very thin or whose fan turns over, and for
    /// x in the plane with derivatives (the robust path reports the crease).
    #[test]
    fn fan_of_triangles_near_the_plane() {
        let v = vec![
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.7, 1e-7, 1.0),
            DVec3::new(0.2, 1e-7, 1.0),
        ];
        // Beside the sliver, 1e-5 above its plane, the tangent plane cutting it across.
        let x = DVec3::new(0.5, 0.1, 1.0 - 1e-5);
        let n = DVec3::new(1.0, 0.0, 0.3).normalize();
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            assert!(very_thin_polygon(x, n, &v, order).is_none());
            let got = very_thin_polygon_by_triangles(x, n, &v, order).unwrap();
            let mut want = Deriv3::constant(0.0);
            for k in 1..3 {
                let d = crate::kernels::triangle_form_factor(x, n, v[0], v[k], v[k + 1], order)
                    .unwrap();
                want.value += d.value;
                want.gradient += d.gradient;
                want.hessian += d.hessian;
            }
            assert_eq!(got, want);
            assert!(got.value > 0.0);
            assert_eq!(
                crate::kernels::polygon_form_factor(x, n, &v, order).unwrap(),
                got
            );
        }
        // Farther from the plane than 1e-3 of the distance: the robust path's.
        let far = DVec3::new(0.5, 0.1, 1.0 - 1e-2);
        assert!(very_thin_polygon_by_triangles(far, n, &v, Order::Hessian).is_none());
        let fat = vec![
            v[0],
            v[1],
            DVec3::new(0.7, 0.1, 1.0),
            DVec3::new(0.2, 0.1, 1.0),
        ];
        assert!(very_thin_polygon_by_triangles(x, n, &fat, Order::Hessian).is_none());
        let arrow = vec![
            v[0],
            v[1],
            DVec3::new(0.5, 1e-7, 1.0),
            DVec3::new(0.5, 0.5e-7, 1.0),
        ];
        assert!(very_thin_polygon_by_triangles(x, n, &arrow, Order::Hessian).is_none());
        let in_plane = DVec3::new(0.5, 0.1, 1.0);
        assert!(very_thin_polygon_by_triangles(in_plane, n, &v, Order::Gradient).is_none());
        assert!(matches!(
            crate::kernels::polygon_form_factor(in_plane, n, &v, Order::Gradient),
            Err(crate::Error::Degenerate(_))
        ));
    }

    #[test]
    fn declines_what_it_must() {
        let n = DVec3::Z;
        let x = DVec3::new(0.4, 0.1, 0.3);
        let v = vec![
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.7, 1e-7, 1.0),
            DVec3::new(0.2, 1e-7, 1.0),
        ];
        assert!(very_thin_polygon(x, n, &v, Order::Value).is_some());
        // A bow-tie (self-intersecting): declined, and the robust path refuses it.
        let bow = vec![v[0], v[1], v[3], v[2]];
        assert!(very_thin_polygon(x, n, &bow, Order::Value).is_none());
        assert!(matches!(
            crate::kernels::polygon_form_factor(x, n, &bow, Order::Value),
            Err(crate::Error::InvalidArgument(_))
        ));
        // Non-planar beyond the tolerance.
        let mut bent = v.clone();
        bent[2].z += 1e-6;
        assert!(very_thin_polygon(x, n, &bent, Order::Value).is_none());
        // Non-convex (a fan triangle turned over), clipped, a bad normal, non-finite, triangles
        // and more than 8 vertices.
        let arrow = vec![
            v[0],
            v[1],
            DVec3::new(0.5, 1e-7, 1.0),
            DVec3::new(0.5, 0.5e-7, 1.0),
        ];
        assert!(very_thin_polygon(x, n, &arrow, Order::Value).is_none());
        let tilted = DVec3::new(0.9, 0.0, 0.1).normalize();
        assert!(very_thin_polygon(DVec3::new(0.5, 0.0, 0.5), tilted, &v, Order::Value).is_none());
        assert!(very_thin_polygon(x, n * 1.1, &v, Order::Value).is_none());
        assert!(very_thin_polygon(DVec3::NAN, n, &v, Order::Value).is_none());
        assert!(very_thin_polygon(x, n, &v[..3], Order::Value).is_none());
        let many: Vec<DVec3> = (0..9)
            .map(|k| {
                let t = k as f64 / 8.0;
                DVec3::new(t, 1e-7 * t * (1.0 - t), 1.0)
            })
            .collect();
        assert!(very_thin_polygon(x, n, &many, Order::Value).is_none());
        assert!(very_thin_polygon(x, n, &many[..8], Order::Value).is_some());
        // Not thin.
        let fat = vec![
            v[0],
            v[1],
            DVec3::new(0.7, 0.1, 1.0),
            DVec3::new(0.2, 0.1, 1.0),
        ];
        assert!(very_thin_polygon(x, n, &fat, Order::Value).is_none());
    }
}
