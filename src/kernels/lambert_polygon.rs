//! Certified value fast path of [`polygon_form_factor`](super::polygon_form_factor) for 4 to 8
//! vertices: Lambert's sum (or its far-field form) with the running bound of
//! [`lambert`](super::lambert), for convex polygons that the robust path certainly accepts.
//!
//! The robust path validates area, planarity (1e-8 of the extent) and simplicity (an O(m²)
//! segment test) before it evaluates; Lambert's sum needs none of it, but the fast path must keep
//! that contract, so it accepts only polygons the robust checks pass by a wide margin, with a few
//! products per vertex (`d_k = v_k − v_0`, `e_i = v_{i+1} − v_i`, `N` Newell's normal
//! `Σ d_k × d_{k+1}`, `X = max ‖d_k‖` the robust path's extent):
//!
//! * area: `‖N‖ > 4·1e-13·X²` (the robust limit is 1e-13);
//! * planarity: `|d_k·N| ≤ 0.25·1e-8·X‖N‖` (a quarter of the robust tolerance);
//! * strictly convex, winding once: every edge `‖e_i‖ ≥ 1e-3 X`, every turn
//!   `(e_{i−1} × e_i)·N ≥ 1e-3 ‖e_{i−1}‖‖e_i‖‖N‖` (a sine of 1e-3), the fan from `v_0` monotone
//!   (`(d_k × d_{k+1})·N > 0`) and inside the half-plane left of `d_1` (`(d_1 × d_k)·N > 0`): the
//!   vertices are sorted by angle around `v_0` within less than π, so the polygon is simple (star-
//!   shaped from `v_0`), and the margins keep every vertex at least ~1e-6 X from the line of any
//!   edge it is not on, far beyond the rounding of the robust path's orientation tests.
//!
//! Anything else (non-convex, nearly degenerate, non-planar or self-intersecting polygons, more
//! than 8 vertices) goes to the robust path, which gives the errors.

use glam::DVec3;

use super::lambert::{certified_sum, unclipped, INV_2PI};

/// A quarter of the robust path's planarity tolerance (1e-8 of the extent).
const PLANARITY: f64 = 0.25e-8;
/// Four times the robust path's zero-area limit (`2·area ≤ 1e-13 extent²`).
const AREA: f64 = 4e-13;
/// Smallest edge length and turn sine, relative (see the module documentation).
const MARGIN: f64 = 1e-3;

/// Whether the polygon is certainly accepted by the robust path's validation and strictly convex
/// (see the module documentation).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
fn convex_and_valid<const M: usize>(v: &[DVec3; M]) -> bool {
    let d: [DVec3; M] = std::array::from_fn(|k| v[k] - v[0]);
    let e: [DVec3; M] = std::array::from_fn(|i| v[(i + 1) % M] - v[i]);
    let mut normal = DVec3::ZERO;
    for k in 1..M - 1 {
        normal += d[k].cross(d[k + 1]);
    }
    let nn = normal.length_squared();
    let extent2 = d.iter().map(|dk| dk.length_squared()).fold(0.0, f64::max);
    if !(nn > AREA * AREA * extent2 * extent2) {
        return false;
    }
    let e2 = e.map(|ei| ei.length_squared());
    let m2 = MARGIN * MARGIN;
    for k in 1..M {
        let h = d[k].dot(normal);
        if !(h * h <= PLANARITY * PLANARITY * extent2 * nn) {
            return false;
        }
        if k + 1 < M && !(d[k].cross(d[k + 1]).dot(normal) > 0.0) {
            return false;
        }
        if k > 1 && !(d[1].cross(d[k]).dot(normal) > 0.0) {
            return false;
        }
    }
    for i in 0..M {
        let p = (i + M - 1) % M;
        let t = e[p].cross(e[i]).dot(normal);
        if !(e2[i] >= m2 * extent2 && t > 0.0 && t * t >= m2 * e2[p] * e2[i] * nn) {
            return false;
        }
    }
    true
}

#[inline(always)]
fn value<const M: usize>(x: DVec3, n: DVec3, v: &[DVec3; M]) -> Option<f64> {
    let (n, r, r2) = unclipped(x, n, v)?;
    if !convex_and_valid(v) {
        return None;
    }
    let sum = certified_sum(n, v, &r, &r2)?;
    Some((sum.abs() * INV_2PI).min(1.0))
}

/// The value of [`polygon_form_factor`](super::polygon_form_factor) for a strictly convex polygon
/// of 4 to 8 vertices, every vertex certainly above the tangent plane, when the certified sum is
/// within the fast-path tolerance; `None` otherwise (including invalid input, which the robust
/// path reports).
pub(crate) fn polygon_value(x: DVec3, n: DVec3, v: &[DVec3]) -> Option<f64> {
    match v.len() {
        4 => value::<4>(x, n, v.try_into().ok()?),
        5 => value::<5>(x, n, v.try_into().ok()?),
        6 => value::<6>(x, n, v.try_into().ok()?),
        7 => value::<7>(x, n, v.try_into().ok()?),
        8 => value::<8>(x, n, v.try_into().ok()?),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::{polygon, polygon_form_factor};
    use crate::{Error, Order};

    fn pentagon(z: f64) -> Vec<DVec3> {
        (0..5)
            .map(|i| {
                let phi = std::f64::consts::TAU * i as f64 / 5.0;
                DVec3::new(phi.cos(), phi.sin(), z + 0.3 * phi.sin())
            })
            .collect()
    }

    /// A convex quad in the plane z = 1 + 0.1 x + 0.1 y.
    fn quad() -> Vec<DVec3> {
        [(-0.5, -0.4), (0.6, -0.5), (0.7, 0.6), (-0.4, 0.5)]
            .map(|(x, y)| DVec3::new(x, y, 1.0 + 0.1 * x + 0.1 * y))
            .to_vec()
    }

    fn robust(x: DVec3, n: DVec3, v: &[DVec3]) -> f64 {
        polygon::form_factor(x, n, v, Order::Value).unwrap().value
    }

    #[test]
    fn convex_polygons_agree_with_the_robust_path_near_and_far() {
        let n = DVec3::new(0.1, -0.2, 1.0).normalize();
        for v in [quad(), pentagon(1.0)] {
            let c = v.iter().sum::<DVec3>() / v.len() as f64;
            // From 0.3 to 1e4 sizes below the centroid: Lambert's sum near, the far form beyond.
            for k in 0..=40 {
                let t = 0.3 * 10f64.powf(k as f64 / 8.0);
                let x = c - DVec3::new(0.1, 0.05, 1.0) * t;
                let f = polygon_value(x, n, &v).unwrap_or_else(|| panic!("declined at {t:e}"));
                let r = robust(x, n, &v);
                assert!((f - r).abs() < 1e-12 * r, "t = {t:e}: {f} vs {r}");
                // The public entry returns the certified value at every order.
                assert_eq!(
                    polygon_form_factor(x, n, &v, Order::Value).unwrap().value,
                    f
                );
                assert_eq!(
                    polygon_form_factor(x, n, &v, Order::Hessian).unwrap().value,
                    f
                );
            }
        }
    }

    #[test]
    fn declines_what_the_robust_path_must_judge() {
        let n = DVec3::Z;
        let x = DVec3::new(0.1, 0.0, 0.0);
        // Control: the quad is taken.
        assert!(polygon_value(x, n, &quad()).is_some());
        // Self-intersecting (bow-tie): declined, and the robust path reports it.
        let mut bow = quad();
        bow.swap(1, 2);
        assert!(polygon_value(x, n, &bow).is_none());
        assert!(matches!(
            polygon_form_factor(x, n, &bow, Order::Value),
            Err(Error::InvalidArgument(_))
        ));
        // A pentagram (all turns the same way, winding twice).
        let p = pentagon(1.0);
        let star: Vec<DVec3> = [0, 2, 4, 1, 3].iter().map(|&i| p[i]).collect();
        assert!(polygon_value(x, n, &star).is_none());
        // Non-planar beyond the tolerance: declined, InvalidArgument.
        let mut bent = quad();
        bent[2].z += 1e-3;
        assert!(polygon_value(x, n, &bent).is_none());
        assert!(matches!(
            polygon_form_factor(x, n, &bent, Order::Value),
            Err(Error::InvalidArgument(_))
        ));
        // Non-planar within the robust tolerance but beyond a quarter of it: declined, and the
        // robust path evaluates it.
        let mut slight = quad();
        slight[2].z += 3e-8;
        assert!(polygon_value(x, n, &slight).is_none());
        assert!(polygon_form_factor(x, n, &slight, Order::Value).is_ok());
        // Non-convex (an arrowhead), a repeated vertex, a collinear vertex: declined.
        let arrow = vec![
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.5, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
            DVec3::new(0.3, 0.5, 1.0),
        ];
        assert!(polygon_value(x, n, &arrow).is_none());
        assert!(polygon_form_factor(x, n, &arrow, Order::Value).is_ok());
        let mut rep = quad();
        rep.insert(2, rep[2]);
        assert!(polygon_value(x, n, &rep).is_none());
        let mut col = quad();
        col.insert(1, (col[0] + col[1]) * 0.5);
        assert!(polygon_value(x, n, &col).is_none());
        // Clipped, non-finite, too many vertices.
        assert!(polygon_value(DVec3::new(0.0, 0.0, 1.05), n, &quad()).is_none());
        assert!(polygon_value(DVec3::NAN, n, &quad()).is_none());
        let ring: Vec<DVec3> = (0..9)
            .map(|i| {
                let phi = std::f64::consts::TAU * i as f64 / 9.0;
                DVec3::new(phi.cos(), phi.sin(), 1.0)
            })
            .collect();
        assert!(polygon_value(x, n, &ring).is_none());
        assert!(polygon_value(x, n, &ring[..8]).is_some());
    }
}
