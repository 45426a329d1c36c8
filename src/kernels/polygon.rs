//! Planar polygons seen from a point: validation, exact power-of-two rescaling, clipping by the
//! tangent plane, the far-field quadrature of the form factor, and Arvo's irradiance Jacobian.
//!
//! The public entry points for form factors are in [`form_factor`](super::form_factor); this module
//! holds the polygon machinery they share, plus [`vector_form_factor_jacobian`], an independent
//! implementation of Arvo's irradiance Jacobian (Schwarzhaupt thesis §5.1) used to cross-check the
//! form-factor gradient.

use std::sync::OnceLock;

use glam::{DMat3, DVec2, DVec3};
use smallvec::SmallVec;

use crate::error::{ensure_finite3, Error, Result};
use crate::{Deriv3, Order};

use super::numeric::dd;
use super::numeric::pow2::{exponent, pow2};

mod near_plane_polygon;
mod near_plane_triangle;
mod sliver;
mod sliver_fan;
use super::form_factor::{clip_edge_term, frame_term, outer_self, sym_outer, EdgeFrame, ExactEnds};
pub(crate) use near_plane_polygon::{
    clipped_polygon_value_and_loop as near_plane_clipped_polygon_value_and_loop,
    polygon_value as near_plane_polygon_value,
};
pub(crate) use near_plane_triangle::{
    clipped_triangle_value_and_loop as near_plane_clipped_triangle_value_and_loop,
    triangle_value as near_plane_triangle_value, RouteLoop,
};
pub(crate) use sliver_fan::very_thin_polygon_form_factor;

/// Relative tolerance on `‖n‖ − 1` before `n` is rejected (it is renormalized otherwise).
pub(crate) const NORMAL_TOLERANCE: f64 = 1e-6;
/// Largest distance of a vertex from the polygon's plane, relative to its extent.
const PLANARITY_TOLERANCE: f64 = 1e-8;
/// `2·area / extent²` at or below which a polygon counts as having zero area.
const AREA_TOLERANCE: f64 = 1e-13;
/// Distance (from the vertex centroid) over radius above which the form factor is integrated by
/// quadrature instead of the edge sum. Chosen by measurement (see `tests/kernels_b_accuracy.rs`): at
/// 16 the edge sum has lost ~16 ulps to cancellation and the 8x8 Gauss rule is at its rounding floor.
pub(crate) const FAR_FIELD_RATIO: f64 = 16.0;

/// The far-field rules: from this distance-over-radius ratio on, `n`x`n` Gauss-Legendre points per
/// fan triangle (largest ratio first). Above 16 the ratios come from the a-priori bound of
/// [`far_field_error_bound`]: at each listed ratio (and beyond) that bound on the relative error is
/// at most 1e-14 for the value and the gradient and 1e-12 for the Hessian (a factor 100 below the
/// generic accuracy contract; the bound itself ignores that Gauss rules converge faster than
/// polynomial exactness alone implies, and overestimates the measured errors by orders of
/// magnitude). Between 16 and 31 radii the 8x8 rule is kept on measurement: there its bound is above
/// 1e-14 (see the unit test) but its measured error is at the rounding floor.
pub(crate) const FAR_FIELD_RULES: [(f64, usize); 5] = [
    (3.6e4, 3),
    (1.5e3, 4),
    (280.0, 5),
    (100.0, 6),
    (FAR_FIELD_RATIO, 8),
];

const FRAC_1_PI: f64 = std::f64::consts::FRAC_1_PI;

type Points = SmallVec<[DVec3; 8]>;

/// Validates a receiver normal: finite, unit within [`NORMAL_TOLERANCE`]; returns it renormalized.
pub(crate) fn unit_normal(n: DVec3) -> Result<DVec3> {
    ensure_finite3(n, "n")?;
    let len = n.length();
    if (len - 1.0).abs() > NORMAL_TOLERANCE || len.is_nan() {
        return Err(Error::InvalidArgument(format!(
            "n must be a unit vector (|n| = {len}, tolerance {NORMAL_TOLERANCE:e})"
        )));
    }
    Ok(n / len)
}

/// Positions relative to the first vertex (`u`) and to `x` (`r`), rescaled by an exact power of two
/// so that the largest coordinate is in [1, 2): huge and tiny scenes neither overflow nor lose
/// precision, and derivatives are scaled back exactly.
pub(crate) struct Scaled {
    pub u: Points,
    pub r: Points,
    /// The rounding errors of `r`: `r + r_lo` is exactly `(v − x)` in scaled units, and `r` is
    /// that sum rounded (a double-double's parts, read with [`dd::Dd3::from_parts`]) unless the
    /// rescaling pushed a component of `r_lo` below the normal range (coordinates ~1e-292 of the
    /// largest), where the pair is exact but not renormalized.
    pub r_lo: Points,
    /// d(scaled coordinate)/d(world coordinate).
    inv_scale: f64,
}

impl Scaled {
    pub(crate) fn new(x: DVec3, vertices: &[DVec3]) -> Result<Self> {
        // Filled in place with pushes: collecting into fresh small vectors and moving them into
        // the result cost about as much as the rest of a near-plane evaluation's set-up.
        let mut out = Scaled {
            u: Points::new(),
            r: Points::new(),
            r_lo: Points::new(),
            inv_scale: 1.0,
        };
        let mut pre = 1.0;
        for attempt in 0..2 {
            if attempt == 1 {
                // Differences of coordinates near ±f64::MAX overflow: scale first (exactly).
                pre = pow2(-4);
                out.u.clear();
                out.r.clear();
                out.r_lo.clear();
            }
            let v0 = vertices[0] * pre;
            let xs = x * pre;
            let mut finite = true;
            for v in vertices {
                let vs = *v * pre;
                let (u, r) = (vs - v0, vs - xs);
                finite &= u.is_finite() && r.is_finite();
                // The rounding error of each difference (two-sum): cheap, and lets
                // near-singular configurations be evaluated from exact coordinate differences.
                let err = |a: f64, b: f64| dd::two_sum(a, -b).1;
                out.u.push(u);
                out.r.push(r);
                out.r_lo.push(DVec3::new(
                    err(vs.x, xs.x),
                    err(vs.y, xs.y),
                    err(vs.z, xs.z),
                ));
            }
            if finite {
                break;
            }
        }
        let max_abs = out
            .u
            .iter()
            .chain(out.r.iter())
            .map(|v| v.abs().max_element())
            .fold(0.0, f64::max);
        if max_abs == 0.0 {
            return Err(Error::Degenerate("x and all vertices coincide".into()));
        }
        let k = exponent(max_abs);
        let s = pow2(-k);
        for v in out
            .u
            .iter_mut()
            .chain(out.r.iter_mut())
            .chain(out.r_lo.iter_mut())
        {
            *v *= s;
        }
        out.inv_scale = pre * s;
        Ok(out)
    }

    /// The exact endpoints of the edge from vertex `i` to vertex `j`, relative to `x`.
    pub(crate) fn exact_ends(&self, i: usize, j: usize) -> ExactEnds {
        ExactEnds {
            a: [self.r[i], self.r_lo[i]],
            b: [self.r[j], self.r_lo[j]],
        }
    }

    /// Converts derivatives in scaled units back to world units; non-finite results are refused.
    pub(crate) fn finish(&self, mut d: Deriv3, order: Order) -> Result<Deriv3> {
        if order.gradient() {
            d.gradient *= self.inv_scale;
        }
        if order.hessian() {
            d.hessian *= self.inv_scale * self.inv_scale;
        }
        if d.is_finite() {
            Ok(d)
        } else {
            Err(Error::Degenerate(
                "form factor derivatives overflow f64 for this configuration".into(),
            ))
        }
    }
}

/// [`form_factor`] of a triangle without the exact power-of-two rescaling, when it is not needed:
/// every coordinate difference in (1e-30, 1e30) and `n` within the unit tolerance (`None`
/// otherwise; the caller falls back to [`form_factor`], which also reports invalid input).
/// Rescaling by a power of two changes no rounding away from overflow and underflow, which that
/// range keeps away, so the result has the bits of [`form_factor`]'s; the saving is its generic
/// set-up (validation, the rescaling pass over growable vectors), about a fifth of a clipped
/// triangle's evaluation.
pub(crate) fn triangle_form_factor_in_range(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    order: Order,
) -> Option<Result<Deriv3>> {
    in_range(x, n, v, order, false)
}

/// [`triangle_form_factor_in_range`] for a triangle [`is_very_thin_triangle`] accepts: the sliver
/// rule's direct entry first (the same bits; `sliver::direct_sliver`), then `evaluate`. Only
/// for such triangles, as the direct entry's plane costs the others ~100 instructions for nothing.
pub(crate) fn very_thin_triangle_form_factor_in_range(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    order: Order,
) -> Option<Result<Deriv3>> {
    in_range(x, n, v, order, true)
}

/// [`triangle_form_factor_in_range`] for a polygon of any vertex count: [`form_factor`] without
/// its validation of `x` and the vertices (finite, at least 3: `None` otherwise) and without the
/// rescaling pass, when every coordinate difference is in (1e-30, 1e30) and `n` within the unit
/// tolerance. The same bits as [`form_factor`], for the same reason.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn polygon_form_factor_in_range(
    x: DVec3,
    n: DVec3,
    v: &[DVec3],
    order: Order,
) -> Option<Result<Deriv3>> {
    if v.len() < 3 || !(x.is_finite() && v.iter().all(|vk| vk.is_finite())) {
        return None;
    }
    let mut scaled = Scaled {
        u: Points::new(),
        r: Points::new(),
        r_lo: Points::new(),
        inv_scale: 1.0,
    };
    let err = |a: f64, b: f64| dd::two_sum(a, -b).1;
    let mut largest = 0.0f64;
    for vk in v {
        let (u, r) = (*vk - v[0], *vk - x);
        largest = largest.max(u.abs().max_element().max(r.abs().max_element()));
        scaled.u.push(u);
        scaled.r.push(r);
        scaled
            .r_lo
            .push(DVec3::new(err(vk.x, x.x), err(vk.y, x.y), err(vk.z, x.z)));
    }
    if !(largest > 1e-30 && largest < 1e30) {
        return None;
    }
    let n = super::lambert::unit(n)?;
    Some(evaluate(&scaled, n, order).and_then(|d| scaled.finish(d, order)))
}

#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
#[inline(always)] // one copy per entry, without the other's branch
fn in_range(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    order: Order,
    very_thin: bool,
) -> Option<Result<Deriv3>> {
    // Non-finite input goes to `form_factor`, which refuses it (`f64::max` would skip a NaN).
    if !(x.is_finite() && v.iter().all(|vk| vk.is_finite())) {
        return None;
    }
    let r = v.map(|vk| vk - x);
    let u = [DVec3::ZERO, v[1] - v[0], v[2] - v[0]];
    let largest = r
        .iter()
        .chain(&u[1..])
        .fold(0.0f64, |m, d| m.max(d.abs().max_element()));
    if !(largest > 1e-30 && largest < 1e30) {
        return None;
    }
    let n = super::lambert::unit(n)?;
    let err = |a: f64, b: f64| dd::two_sum(a, -b).1;
    let r_lo = v.map(|vk| DVec3::new(err(vk.x, x.x), err(vk.y, x.y), err(vk.z, x.z)));
    // A sliver seen from afar: the sliver rule without `evaluate`'s set-up (the same bits).
    if very_thin {
        if let Some(d) = sliver::direct_sliver(&u, &r, &r_lo, n, order) {
            return Some(Ok(d));
        }
    }
    let scaled = Scaled {
        u: Points::from_slice(&u),
        r: Points::from_slice(&r),
        r_lo: Points::from_slice(&r_lo),
        inv_scale: 1.0,
    };
    Some(evaluate(&scaled, n, order).and_then(|d| scaled.finish(d, order)))
}

#[cfg(test)]
mod in_range_tests {
    use super::*;

    use crate::test_rng::lcg;

    /// Bit for bit the rescaled evaluation, in every regime `evaluate` distinguishes (clipped, near
    /// the plane, near an edge line, slivers, far field, cancelling sums) and at every order.
    #[test]
    fn unscaled_triangles_give_the_rescaled_bits() {
        let mut state = 11;
        let mut compared = 0;
        for k in 0..3000 {
            let scale = [1e-3, 1.0, 1e3, 3e-20, 7e25][k % 5];
            let offset = [0.0, 1.0, -1e3][k % 3] * scale;
            let mut p = || {
                let mut c = || lcg(&mut state);
                DVec3::new(c(), c(), c()) - 0.5
            };
            let t = p();
            let mut v = [p(), p(), p()];
            if k % 7 == 0 {
                v[2] = (v[0] + v[1]) * 0.5 + p() * 1e-6; // sliver
            }
            let plane_n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            let x = match k % 4 {
                0 => p() * 2.0,
                1 => v[0] + (v[1] - v[0]) * (t.x + 0.5) + plane_n * 1e-7 * t.y,
                2 => (v[0] + v[1] + v[2]) / 3.0 + plane_n * 10f64.powf(-18.0 * (t.z + 0.5)),
                _ => p() * 100.0,
            };
            let n = (p() + plane_n * 0.3).normalize();
            let v = v.map(|vk| vk * scale + DVec3::splat(offset));
            let x = x * scale + DVec3::splat(offset);
            for order in [Order::Value, Order::Gradient, Order::Hessian] {
                let entry = if is_very_thin_triangle(v) {
                    very_thin_triangle_form_factor_in_range
                } else {
                    triangle_form_factor_in_range
                };
                let Some(fast) = entry(x, n, v, order) else {
                    continue;
                };
                let robust = form_factor(x, n, &v, order);
                match (fast, robust) {
                    (Ok(a), Ok(b)) => {
                        assert_eq!(a.value.to_bits(), b.value.to_bits(), "{k}");
                        for i in 0..3 {
                            assert_eq!(a.gradient[i].to_bits(), b.gradient[i].to_bits(), "{k}");
                            for j in 0..3 {
                                let (ha, hb) = (a.hessian.col(i)[j], b.hessian.col(i)[j]);
                                assert_eq!(ha.to_bits(), hb.to_bits(), "{k}");
                            }
                        }
                    }
                    (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                    (a, b) => panic!("{k}: {a:?} vs {b:?}"),
                }
                compared += 1;
            }
        }
        assert!(compared > 8000, "{compared}");
    }

    /// The polygon entry gives the rescaled bits too: quads and pentagons (convex, non-convex,
    /// slivers) with x generic, near an edge line, near the plane over them and far away.
    #[test]
    fn unscaled_polygons_give_the_rescaled_bits() {
        let mut state = 17;
        let mut compared = 0;
        for k in 0..3000 {
            let scale = [1e-3, 1.0, 1e3, 3e-20, 7e25][k % 5];
            let offset = [0.0, 1.0, -1e3][k % 3] * scale;
            let mut c = || lcg(&mut state);
            let m = 4 + k % 2;
            let (t, jitter, tilt) = (DVec3::new(c(), c(), c()) - 0.5, c(), c());
            let width = if k % 7 == 0 { 1e-6 } else { 1.0 };
            // A star-shaped polygon around the origin in the plane z = 0.3 x - 0.2 y + 1,
            // non-convex when a radius is short.
            let v: Vec<DVec3> = (0..m)
                .map(|i| {
                    let phi = std::f64::consts::TAU * (i as f64 + 0.3 * jitter) / m as f64;
                    let rad = if k % 5 == 1 && i == 2 { 0.3 } else { 1.0 };
                    let (px, py) = (rad * phi.cos(), width * rad * phi.sin());
                    DVec3::new(px, py, 1.0 + 0.3 * px - 0.2 * py)
                })
                .collect();
            let plane_n = DVec3::new(-0.3, 0.2, 1.0).normalize();
            let x = match k % 4 {
                0 => t * 2.0,
                1 => v[0] + (v[1] - v[0]) * (t.x + 0.5) + plane_n * 1e-7 * t.y,
                2 => {
                    DVec3::new(0.1, 0.05 * width, 1.03) + plane_n * 10f64.powf(-18.0 * (t.z + 0.5))
                }
                _ => t * 100.0,
            };
            let n = (DVec3::new(t.y, tilt - 0.5, t.x) + plane_n * 0.3).normalize();
            let v: Vec<DVec3> = v
                .iter()
                .map(|vk| *vk * scale + DVec3::splat(offset))
                .collect();
            let x = x * scale + DVec3::splat(offset);
            for order in [Order::Value, Order::Gradient, Order::Hessian] {
                let Some(fast) = polygon_form_factor_in_range(x, n, &v, order) else {
                    continue;
                };
                match (fast, form_factor(x, n, &v, order)) {
                    (Ok(a), Ok(b)) => {
                        let bits = |d: Deriv3| {
                            let mut all = vec![d.value];
                            all.extend(d.gradient.to_array());
                            all.extend(d.hessian.to_cols_array());
                            all.iter().map(|e| e.to_bits()).collect::<Vec<_>>()
                        };
                        assert_eq!(bits(a), bits(b), "{k} {order:?}");
                    }
                    (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                    (a, b) => panic!("{k}: {a:?} vs {b:?}"),
                }
                compared += 1;
            }
        }
        assert!(compared > 8000, "{compared}");
    }

    /// Non-finite input is left to `form_factor`, which refuses it with `InvalidArgument`.
    #[test]
    fn non_finite_input_is_not_taken() {
        let v = [
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::X + DVec3::Z,
            DVec3::Y + DVec3::Z,
        ];
        let x = DVec3::new(0.2, 0.2, 0.0);
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let odd = DVec3::new(0.1, bad, 0.3);
            for order in [Order::Value, Order::Gradient, Order::Hessian] {
                assert!(triangle_form_factor_in_range(odd, DVec3::Z, v, order).is_none());
                assert!(
                    triangle_form_factor_in_range(x, DVec3::Z, [v[0], odd, v[2]], order).is_none()
                );
                assert!(triangle_form_factor_in_range(x, odd, v, order).is_none());
                for (x, n, v) in [
                    (odd, DVec3::Z, v),
                    (x, DVec3::Z, [v[0], v[1], odd]),
                    (x, odd, v),
                ] {
                    let got = crate::kernels::triangle_form_factor(x, n, v[0], v[1], v[2], order);
                    assert!(matches!(got, Err(Error::InvalidArgument(_))), "{got:?}");
                }
            }
        }
    }
}

/// The polygon's plane, checked for area, planarity and simplicity.
pub(crate) struct Plane {
    normal: DVec3,
    /// `‖Σ u_i × u_{i+1}‖` (twice the area).
    twice_area: f64,
    /// Largest distance from the first vertex.
    extent: f64,
}

impl Plane {
    pub(crate) fn new(u: &[DVec3]) -> Result<Self> {
        let count = u.len();
        // Newell's normal, relative to the first vertex (u[0] = 0).
        let mut nn = DVec3::ZERO;
        for i in 0..count {
            nn += u[i].cross(u[next(i, count)]);
        }
        let extent = u.iter().map(|v| v.length()).fold(0.0, f64::max);
        Self::validated(u, nn, extent, true)
    }

    /// [`Plane::new`] from the Newell sum `nn` and the `extent` the caller computed as `new` does
    /// (the same bits: the polygon sliver path has them already). `check_simplicity: false` skips
    /// the O(count²) simplicity test, for callers that have certified it otherwise (a fan from
    /// `u[0]` sorted by angle within a half-turn, `sliver_fan`). Inlined: as a call it cost
    /// `Plane::new` ~50 instructions.
    #[inline(always)]
    pub(crate) fn validated(
        u: &[DVec3],
        nn: DVec3,
        extent: f64,
        check_simplicity: bool,
    ) -> Result<Self> {
        let count = u.len();
        let twice_area = nn.length();
        if twice_area <= AREA_TOLERANCE * extent * extent || twice_area.is_nan() {
            return Err(Error::Degenerate(format!(
                "polygon has (numerically) zero area (2*area = {twice_area:e}, extent {extent:e})"
            )));
        }
        let normal = nn / twice_area;
        // A triangle is planar by construction: for a thin one the test would measure only the
        // rounding of its normal (~u extent²/area), and refuse valid slivers below ~1e-9.
        if count > 3 {
            let off_plane = u.iter().map(|v| normal.dot(*v).abs()).fold(0.0, f64::max);
            // The rounded normal itself is tilted: each rounded cross product is off by at most
            // `2√3 ε ‖u_i‖‖u_{i+1}‖ ≤ 4ε extent²`, the sum adds `count·ε` per term, so by up to
            // `(4 + count)·count·ε·extent² / twice_area` radians, which moves a vertex up to that
            // times `extent` off the plane (`extent²/area ~ 1/thinness`: a quad 1e-10 wide,
            // ~5e-5 of its extent); the dot product adds a few ε. Twice that is allowed on top of
            // the tolerance, so that thin but planar polygons are not refused for the normal's
            // rounding; a polygon bent by less than that cannot be told from a planar one by this
            // normal and is accepted (the sum it then gets is the one for the rounded plane).
            let rounding = ((4 + count) * count) as f64 * f64::EPSILON * extent * extent
                / twice_area
                + 4.0 * f64::EPSILON;
            if off_plane > (PLANARITY_TOLERANCE + 2.0 * rounding) * extent {
                return Err(Error::InvalidArgument(format!(
                    "polygon is not planar: a vertex is {off_plane:e} from its plane \
                     (tolerance {PLANARITY_TOLERANCE:e} x extent {extent:e})"
                )));
            }
            if check_simplicity {
                check_simple(u, normal)?;
            }
        }
        Ok(Plane {
            normal,
            twice_area,
            extent,
        })
    }
}

/// The plane of a triangle given relative to its first vertex (`u[0] = 0`), as [`Plane::new`]
/// computes it (a triangle is planar and simple); `None` for (numerically) zero area.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn triangle_plane(u: &[DVec3; 3]) -> Option<Plane> {
    // Newell's sum reduces to u_1 × u_2 (the other two terms are exactly zero).
    let nn = u[1].cross(u[2]);
    // sqrt is monotone and correctly rounded: the max of the roots is the root of the max.
    let extent = u[1].length_squared().max(u[2].length_squared()).sqrt();
    let twice_area = nn.length();
    if !(twice_area > AREA_TOLERANCE * extent * extent) {
        return None;
    }
    Some(Plane {
        normal: nn / twice_area,
        twice_area,
        extent,
    })
}

/// The decisions [`evaluate`] takes before its edge sum, for an unclipped polygon given relative to
/// `x`: `None` when `x` is in or near the polygon's plane (where it recomputes the height exactly),
/// otherwise the far-field rule if the quadrature applies and the signed height `h_P`.
pub(crate) fn fast_decisions(r: &[DVec3], plane: &Plane) -> Option<(Option<Rule>, f64)> {
    let h_p = plane_height(r, plane)?;
    Some((far_rule_of(r), h_p))
}

/// The first of [`fast_decisions`]: the signed height `h_P` of x over the plane as [`evaluate`]
/// takes it, `None` when x is in or near the plane. (A clipped sliver needs no more.)
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
#[inline]
pub(crate) fn plane_height(r: &[DVec3], plane: &Plane) -> Option<f64> {
    let nearest = r
        .iter()
        .min_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
        .copied()?;
    let h_p = plane.normal.dot(nearest);
    // One root each for r_max and the radius: the max of the roots is the root of the max, so the
    // decisions are those of `evaluate`.
    let r_max = r
        .iter()
        .map(|v| v.length_squared())
        .fold(0.0, f64::max)
        .sqrt();
    if !(h_p.abs() >= NEAR_PLANE_HEIGHT * r_max) {
        return None;
    }
    Some(h_p)
}

/// The second of [`fast_decisions`]: the far-field rule of the unclipped polygon, if any.
#[inline]
pub(crate) fn far_rule_of(r: &[DVec3]) -> Option<Rule> {
    let count = r.len() as f64;
    let centroid = r.iter().sum::<DVec3>() / count;
    let radius = r
        .iter()
        .map(|v| (*v - centroid).length_squared())
        .fold(0.0, f64::max)
        .sqrt();
    far_field_rule(centroid.length(), radius)
}

impl Plane {
    /// Whether [`evaluate`] takes the fan triangles' geometry from exact differences for this
    /// polygon even when x is not near its plane (a sliver: `2·area < 1e-2·extent²`).
    pub(crate) fn is_thin(&self) -> bool {
        self.twice_area < THIN_POLYGON * self.extent * self.extent
    }

    /// Whether the polygon is a sliver whose edge sum would cancel far beyond
    /// [`THIN_CANCELLATION_LIMIT`] (it cancels by about the inverse of `2·area / extent²`).
    fn is_very_thin(&self) -> bool {
        self.twice_area < VERY_THIN_POLYGON * self.extent * self.extent
    }
}

fn orient2(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b - a).perp_dot(c - a)
}

fn on_segment(a: DVec2, b: DVec2, p: DVec2) -> bool {
    p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
}

/// Whether closed segments `[a, b]` and `[c, d]` share a point.
fn segments_touch(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let d1 = orient2(c, d, a);
    let d2 = orient2(c, d, b);
    let d3 = orient2(a, b, c);
    let d4 = orient2(a, b, d);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && on_segment(c, d, a))
        || (d2 == 0.0 && on_segment(c, d, b))
        || (d3 == 0.0 && on_segment(a, b, c))
        || (d4 == 0.0 && on_segment(a, b, d))
}

/// Projection onto the coordinate plane most nearly parallel to a plane of normal `normal` (drops
/// the coordinate of its largest component, keeping a right-handed pair): orientation tests in 2D
/// then agree with those in the plane, up to the sign of that component.
fn dominant_projection(normal: DVec3) -> impl Fn(DVec3) -> DVec2 {
    let a = normal.abs();
    move |v: DVec3| {
        if a.x >= a.y && a.x >= a.z {
            DVec2::new(v.y, v.z)
        } else if a.y >= a.z {
            DVec2::new(v.z, v.x)
        } else {
            DVec2::new(v.x, v.y)
        }
    }
}

/// Rejects polygons where two non-adjacent edges touch (projected on the dominant plane).
fn check_simple(u: &[DVec3], normal: DVec3) -> Result<()> {
    let project = dominant_projection(normal);
    // Up to 8 vertices in a fixed array: collecting into the small vector cost more than the
    // tests for a quad (~200 instructions; the same points and tests either way).
    let mut fixed = [DVec2::ZERO; 8];
    let many: SmallVec<[DVec2; 8]>;
    let p: &[DVec2] = if u.len() <= fixed.len() {
        for (q, v) in fixed.iter_mut().zip(u) {
            *q = project(*v);
        }
        &fixed[..u.len()]
    } else {
        many = u.iter().map(|v| project(*v)).collect();
        &many
    };
    let count = p.len();
    for i in 0..count {
        for j in i + 2..count {
            if i == 0 && j == count - 1 {
                continue;
            }
            if segments_touch(p[i], p[(i + 1) % count], p[j], p[(j + 1) % count]) {
                return Err(Error::InvalidArgument(format!(
                    "polygon is not simple: edges {i} and {j} intersect"
                )));
            }
        }
    }
    Ok(())
}

/// A vertex of the clipped polygon.
#[derive(Clone, Copy)]
struct ClipVertex {
    /// Relative to the first input vertex (exact edge vectors).
    u: DVec3,
    /// Relative to x.
    r: DVec3,
    /// Rounding error of `r` (`r + r_lo` exact) for input vertices; zero for clip vertices.
    r_lo: DVec3,
    /// On the clip line (created by clipping, or an input vertex exactly on the tangent plane).
    on_line: bool,
}

/// The clipped loop: a triangle clips to at most 4 vertices, a polygon of `count` vertices to at
/// most `count` plus one per sign change of the heights.
type ClipLoop = SmallVec<[ClipVertex; 10]>;

/// Where [`clip`] puts the loop: a [`ClipLoop`], or a [`TriangleLoop`] for a triangle.
trait ClipOut {
    fn push(&mut self, v: ClipVertex);
}

impl ClipOut for ClipLoop {
    #[inline(always)]
    fn push(&mut self, v: ClipVertex) {
        SmallVec::push(self, v);
    }
}

/// A clipped triangle's loop (at most 4 vertices) in a plain array: the small vector's capacity
/// checks cost a clipped sliver's direct entry ~2% of its instructions.
struct TriangleLoop {
    verts: [ClipVertex; 4],
    len: usize,
}

impl TriangleLoop {
    fn new() -> Self {
        let zero = ClipVertex {
            u: DVec3::ZERO,
            r: DVec3::ZERO,
            r_lo: DVec3::ZERO,
            on_line: false,
        };
        TriangleLoop {
            verts: [zero; 4],
            len: 0,
        }
    }

    fn as_slice(&self) -> &[ClipVertex] {
        &self.verts[..self.len]
    }
}

impl ClipOut for TriangleLoop {
    /// Only for a triangle's clip (each vertex pushes itself and at most one clip point, and
    /// at most two of the three edges change sign).
    #[inline(always)]
    fn push(&mut self, v: ClipVertex) {
        self.verts[self.len] = v;
        self.len += 1;
    }
}

/// The index after `i` in a loop of `count` vertices (`(i + 1) % count` without the division).
#[inline]
fn next(i: usize, count: usize) -> usize {
    if i + 1 == count {
        0
    } else {
        i + 1
    }
}

/// Sutherland-Hodgman clip by the half-space `n·r ≥ 0`, onto `out` (empty; filled in place, as
/// returning the loop by value copies it). Returns whether any vertex was cut away. Inlined, so
/// that the clipped sliver's FMA build fuses its double-double products (`sliver::clipped`).
#[inline(always)]
fn clip<O: ClipOut>(u: &[DVec3], r: &[DVec3], r_lo: &[DVec3], n: DVec3, out: &mut O) -> bool {
    let count = u.len();
    let (u, r_lo) = (&u[..count], &r_lo[..count]);
    let r = &r[..count];
    let exact = |i: usize| dd::Dd3::from_parts_unpacked(r[i], r_lo[i]);
    // Heights over the tangent plane in double-double, so that the clip points (which land near
    // x whenever x is near the polygon's plane) are placed from exact data. A stack array for
    // the usual small polygons (a growable vector's pushes and indexing cost more than the
    // heights' arithmetic).
    const ZERO: dd::Dd = dd::Dd { hi: 0.0, lo: 0.0 };
    let mut inline = [ZERO; 8];
    let mut spilled = Vec::new();
    let d: &mut [dd::Dd] = if count <= inline.len() {
        &mut inline[..count]
    } else {
        spilled.resize(count, ZERO);
        &mut spilled
    };
    for (i, di) in d.iter_mut().enumerate() {
        *di = exact(i).dot_f64(n);
    }
    clip_by_heights(u, r, r_lo, exact, d, out)
}

/// [`clip`]'s loop from the heights `d_k = n·R_k` (double-double) and the exact differences
/// `exact(k) = R_k`: kept vertices and clip points pushed onto `out` in loop order; whether any
/// vertex was cut away. Shared with the near-plane routes (`near_plane_triangle`,
/// `near_plane_polygon`), which compute the heights on fixed arrays and must place the same
/// points.
#[inline(always)]
fn clip_by_heights<O: ClipOut>(
    u: &[DVec3],
    r: &[DVec3],
    r_lo: &[DVec3],
    exact: impl Fn(usize) -> dd::Dd3,
    d: &[dd::Dd],
    out: &mut O,
) -> bool {
    let count = d.len();
    let mut cut = false;
    for i in 0..count {
        let j = next(i, count);
        let (di, dj) = (d[i].hi, d[j].hi);
        if di >= 0.0 {
            out.push(ClipVertex {
                u: u[i],
                r: r[i],
                r_lo: r_lo[i],
                on_line: di == 0.0,
            });
        } else {
            cut = true;
        }
        if (di > 0.0 && dj < 0.0) || (di < 0.0 && dj > 0.0) {
            let t = d[i].div(d[i].add(d[j].neg()));
            let (ri, rj) = (exact(i), exact(j));
            let (rc, rc_lo) = ri.add(&rj.sub(&ri).scale(t)).split();
            out.push(ClipVertex {
                u: u[i] + t.hi * (u[j] - u[i]),
                r: rc,
                r_lo: rc_lo,
                on_line: true,
            });
        }
    }
    cut
}

/// A near-plane route's fixed array as a [`ClipOut`]; `len` counts the pushed vertices.
struct ArrayOut<'a> {
    verts: &'a mut [ClipVertex],
    len: usize,
}

impl ClipOut for ArrayOut<'_> {
    #[inline(always)]
    fn push(&mut self, v: ClipVertex) {
        self.verts[self.len] = v;
        self.len += 1;
    }
}

/// Gauss-Legendre nodes and weights on [0, 1] (Newton on the Legendre polynomial).
fn legendre_rule<const N: usize>() -> [(f64, f64); N] {
    let mut rule = [(0.0, 0.0); N];
    for (i, slot) in rule.iter_mut().enumerate() {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (N as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=N {
                let kf = k as f64;
                let p2 = ((2.0 * kf - 1.0) * z * p1 - (kf - 1.0) * p0) / kf;
                p0 = p1;
                p1 = p2;
            }
            dp = N as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-17 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - z * z) * dp * dp);
        *slot = (0.5 * (1.0 - z), 0.5 * w);
    }
    rule
}

/// The `N`-point Gauss-Legendre rule on [0, 1], computed once.
macro_rules! cached_rule {
    ($name:ident, $n:literal) => {
        fn $name() -> &'static [(f64, f64)] {
            static RULE: OnceLock<[(f64, f64); $n]> = OnceLock::new();
            RULE.get_or_init(legendre_rule::<$n>)
        }
    };
}
cached_rule!(gauss_legendre_2, 2);
cached_rule!(gauss_legendre_3, 3);
cached_rule!(gauss_legendre_4, 4);
cached_rule!(gauss_legendre_5, 5);
cached_rule!(gauss_legendre_6, 6);
cached_rule!(gauss_legendre_8, 8);

/// A far-field quadrature rule: Gauss-Legendre nodes and weights on [0, 1], used in both directions
/// of the Duffy-mapped fan triangle.
#[derive(Clone, Copy)]
pub(crate) struct Rule(pub(crate) &'static [(f64, f64)]);

impl Rule {
    /// The smallest distance-over-radius ratio at which [`far_field_rule`] returns this rule.
    pub(crate) fn min_ratio(self) -> f64 {
        FAR_FIELD_RULES
            .iter()
            .find(|(_, points)| *points == self.0.len())
            .map_or(FAR_FIELD_RATIO, |r| r.0)
    }
}

/// The rule for a (visible) polygon whose vertex centroid is `distance` from x and whose vertices
/// are within `radius` of that centroid: the cheapest of [`FAR_FIELD_RULES`] whose ratio
/// `distance / radius` reaches; `None` below [`FAR_FIELD_RATIO`] (the edge sum applies).
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn far_field_rule(distance: f64, radius: f64) -> Option<Rule> {
    if !(distance >= FAR_FIELD_RATIO * radius) {
        return None;
    }
    let points = FAR_FIELD_RULES
        .iter()
        .find(|(ratio, _)| distance >= ratio * radius)
        .map_or(8, |r| r.1);
    Some(Rule(match points {
        3 => gauss_legendre_3(),
        4 => gauss_legendre_4(),
        5 => gauss_legendre_5(),
        6 => gauss_legendre_6(),
        _ => gauss_legendre_8(),
    }))
}

/// A-priori bound on the relative quadrature error of [`triangle_rule`] with `points`x`points`
/// Gauss-Legendre points, for a triangle within `rho` (radius over distance, `ρ < 1`) of x, as
/// `[value, gradient, Hessian]` (the value relative to itself, the derivatives relative to their
/// natural scale, which their largest entry reaches within a factor ~2).
///
/// Derivation. The Duffy-mapped tensor rule integrates polynomials of total degree
/// `D = 2·points − 2` over the triangle exactly (a degree-`k` polynomial maps to degree `k + 1` in
/// `s`, `k` in `t`). The integrands are `L·g` and `g'`, with `L = n·r ≥ 0` on the visible part
/// (linear) and `g`, `g'` of the form `P_p(r)/(r·r)^j` (`p ≤ 2`). Along any real line
/// `c + τ û` through the centroid `c`, `r·r = (τ − τ₁)(τ − τ₂)` with `|τ₁| = |τ₂| = d`, so `g` is
/// analytic for `|τ| < d` and, on the circle `|τ| = σd`, `|g| ≤ (1 + σ)^p d^p / ((1 − σ) d)^{2j}`.
/// Cauchy's estimate bounds the Taylor remainder beyond degree `m` for `|τ| ≤ R` by that maximum
/// times `(ρ/σ)^{m+1} / (1 − ρ/σ)`. The rule is exact on `L·P_{D−1}g` (positive weights, summing to
/// the area, and `Q(L) = ∫L`), so `|Q(Lg) − ∫Lg| ≤ 2 ∫L · max|g − P_{D−1}g|`; likewise
/// `|Q(g') − ∫g'| ≤ 2·area·max|g' − P_D g'|`. With `∫L ≤ area·d(1 + ρ)` and the integrands at least
/// their values at distance `d(1 + ρ)`:
///
/// ```text
/// value:    2 (1+ρ)⁴ (1−σ)⁻⁴ (ρ/σ)^D / (1 − ρ/σ)
/// gradient: √3 (1+ρ)⁴ [8 (1+ρ)(1+σ)(1−σ)⁻⁶ (ρ/σ)^D + 2 (1−σ)⁻⁴ (ρ/σ)^{D+1}] / (1 − ρ/σ)
/// Hessian:  (1+ρ)⁵ [48 (1+ρ)(1+σ)²(1−σ)⁻⁸ (ρ/σ)^D + 16 (1+σ)(1−σ)⁻⁶ (ρ/σ)^{D+1}
///                   + 8 (1+ρ)(1−σ)⁻⁶ (ρ/σ)^D] / (1 − ρ/σ)
/// ```
///
/// minimized over `σ ∈ (ρ, 1)` (the gradient's scale is `|4(n·r̂) r̂ − n| ≥ 1`, its largest entry
/// `≥ 1/√3` of it; the Hessian's `24 (n·r̂) r̂r̂ᵀ − 4(n r̂ᵀ + r̂ nᵀ) − 4 (n·r̂) 𝟙` has an entry of at
/// least 1). Fan triangles of a non-convex polygon can overlap with opposite signs, which
/// multiplies the bound by `Σ|area_k| / area`.
/// Only the unit tests evaluate it (to check [`FAR_FIELD_RULES`]); the kernel uses the ratios.
#[cfg(test)]
pub(crate) fn far_field_error_bound(points: usize, rho: f64) -> [f64; 3] {
    let d = (2 * points - 2) as i32;
    let mut best = [f64::INFINITY; 3];
    for k in 1..1000 {
        let s = k as f64 / 1000.0;
        if s <= rho {
            continue;
        }
        let q = rho / s;
        let (qd, qd1, tail) = (q.powi(d), q.powi(d + 1), 1.0 / (1.0 - q));
        let (p, m) = (1.0 + rho, 1.0 - s);
        let value = 2.0 * p.powi(4) * m.powi(-4) * qd * tail;
        let gradient = 3f64.sqrt()
            * p.powi(4)
            * (8.0 * p * (1.0 + s) * m.powi(-6) * qd + 2.0 * m.powi(-4) * qd1)
            * tail;
        let hessian = p.powi(5)
            * (48.0 * p * (1.0 + s).powi(2) * m.powi(-8) * qd
                + 16.0 * (1.0 + s) * m.powi(-6) * qd1
                + 8.0 * p * m.powi(-6) * qd)
            * tail;
        for (b, e) in best.iter_mut().zip([value, gradient, hessian]) {
            *b = b.min(e);
        }
    }
    best
}

fn gauss_legendre_16() -> &'static [(f64, f64); 16] {
    static RULE: OnceLock<[(f64, f64); 16]> = OnceLock::new();
    RULE.get_or_init(legendre_rule::<16>)
}

/// Above this ratio of `Σ|edge term|` to `|Σ edge term|` (the sum has lost a bit or more), the
/// value near the plane is recomputed by [`near_plane_value`]; below, the plain sum has lost less
/// than one bit to cancellation.
const NEAR_PLANE_CANCELLATION: f64 = 2.0;

/// Below this `|h_P| / d_e` for every edge not in the tangent plane (x close to the polygon's
/// plane compared with its distance to every such edge line, in the plane), the value is
/// recomputed by [`near_plane_value`]; at or above it for some edge, that function declines.
const NEAR_PLANE_RATIO: f64 = 0.1;

/// Above this ratio of the near-plane split's parts (in magnitude) to its sum, [`evaluate`] does not
/// take the split up front for a clipped polygon (the value would keep ~`u` times this ratio): the
/// O(h_P) parts then cancel too, which happens when the visible part is small against its distance
/// from x (the clip line cuts a small corner off the polygon), where the edge sum's derivatives
/// cancel as well and the quadrature takes over. Measured: the walks of
/// `tests/kernels_b_near_plane.rs` cancel by 25 to ~150; the accuracy test's worst case (a corner
/// of 1e-12 relative value) by far more.
const SPLIT_CANCELLATION_LIMIT: f64 = 1e3;

/// Up to this ratio of the split's parts to its sum the value is still the split's, while above
/// [`SPLIT_CANCELLATION_LIMIT`] the derivatives come from the quadrature (which then also
/// integrates a value, discarded). The split's parts are accurate to a few ulps each (the grazing
/// receiver's `n_t` included, see [`grazing_tangent`]), so its value keeps ~`u` times this ratio,
/// ~1e-11; the quadrature's value near the plane is worse there (5.5e-10 on issue 18's grazing
/// example, whose split cancels by 1000.0000016).
const SPLIT_VALUE_LIMIT: f64 = 1e5;

/// What [`near_plane_value`] reads of an edge's frame ([`EdgeFrame`]'s fields of the same names):
/// the value-only route builds just these.
#[derive(Clone, Copy)]
pub(crate) struct InPlaneEdge {
    pub e_hat: DVec3,
    pub len: f64,
    /// `r_a × e`.
    pub w: DVec3,
    pub sa: f64,
    pub sb: f64,
}

impl From<EdgeFrame> for InPlaneEdge {
    #[inline]
    fn from(f: EdgeFrame) -> Self {
        InPlaneEdge {
            e_hat: f.e_hat,
            len: f.len,
            w: f.w,
            sa: f.sa,
            sb: f.sb,
        }
    }
}

/// The signed edge-sum value for x near the polygon's plane, without the cancellation of the plain
/// sum (the convention of the edge terms, [`frame_term`]: positive when the loop's right-hand normal `N̂`
/// points away from x, i.e. for `h_P = N̂·(v − x) > 0`; both signs of `h_P` are handled alike).
///
/// Edges not in the tangent plane. Split `n = n_N N̂ + n_t`. With `r_a = q_a + h_P N̂` (`q_a` in the
/// plane) the lever arm is `r_a × e = q_a × e + h_P N̂ × e`, where `q_a × e` is along `N̂`. So the
/// `n_t` part of the term is `h_P n_t·(N̂ × ê) A_1/2π` (`A_1 = ∫ ds/‖r‖²`): O(h_P), no cancellation.
/// The `N̂` part is the parallel-receiver term `d_e A_1/2π` (`d_e = N̂·(r_a × ê)`, the signed
/// in-plane distance from the foot point `x_P` of x to the edge line); with `s = |d_e| tan ψ` it is
/// `(Δψ_e − G_e)/2π`, `Δψ_e` the signed angle the edge subtends at `x_P`, and
/// `G_e = ∫ ε cos²ψ/(1 + ε cos²ψ) dψ` over the edge's angular range (`ε = h_P²/d_e²`), in closed
/// form by [`near_plane_deficit`].
///
/// Edges in the tangent plane (the clip edges, and input edges whose ends lie exactly on it). Their
/// line ℓ is where the tangent plane meets the polygon's plane, so it passes within
/// `D = |h_P|/‖n_t‖` of x and `D_P = |n_N| D` of `x_P`: `ε` is not small and the split above
/// fails. But `r_a` and `e` both lie in the tangent plane, so `w = r_a × e = ±‖w‖ n`, and the whole
/// term is `sign(n·w) β_c/2π` with `β_c = atan2(D L, D² + s_a s_b)` (`s_a, s_b` the abscissae of the
/// ends along ℓ from the foot of x, `L = s_b − s_a`): the edge's own closed form. `D` and the sign
/// come from the exact height rather than from the edge's near-degenerate cross product: ℓ's
/// point nearest x is `p = (h_P/‖n_t‖²)(N̂ − n_N n)` (`n·p = 0`, `N̂·p = h_P`), so `D = |h_P|/‖n_t‖`
/// and `w = p × e`, `sign(n·w) = sign(h_P e·(n × N̂))`. Its in-plane angle at `x_P` is
/// `Δψ_c = atan2(d_c L, s_a s_b + d_c²)` with `d_c = N̂·w/L = sign(n·w) n_N D` (x and `x_P` have the
/// same abscissae: ℓ ⊥ N̂). Where the clip segment lies on one side of the foot (`s_a s_b > 0`)
/// both angles are O(h_P); otherwise (the foot beyond ℓ, outside the polygon too) they are O(1)
/// but [`tangent_excess`] still forms their combination without cancellation.
///
/// The sum. `Σ_all Δψ = 2π W` exactly (`W` the winding number of the clipped loop about `x_P`,
/// rounded from the f64 sum), so
///
/// ```text
/// 2π F = n_N (2π W − Σ_clip Δψ_c − Σ_other G_e) + Σ_other h_P n_t·(N̂ × ê) A_1 + Σ_clip sign(n·w) β_c,
/// ```
///
/// a sum of O(h_P) terms (the O(h_P²) `G_e` aside) when x is outside (`W = 0`). Per clip edge the
/// two O(h_P) parts combine into `sign(n·w) (β(D) − |n_N| β(|n_N| D))`, which [`tangent_excess`]
/// evaluates with its factor `1 − |n_N|` explicit (a receiver facing the plane head-on would
/// otherwise lose `1/‖n_t‖²`). The O(h_P) parts of different edges still cancel by a geometric
/// factor (25-150 in `tests/kernels_b_near_plane.rs`; far more when the clip line cuts a small
/// corner off, which `max_cancellation` refuses). Non-convex polygons can be clipped into
/// several clip edges, including bridges that run along ℓ in both directions; each is its own
/// closed form and the bridges' terms cancel between themselves, O(h_P) each.
///
/// Returned with the parts' cancellation (their magnitudes' sum over the sum's magnitude). `None`
/// when not applicable: an edge not in the tangent plane has `|h_P| ≥ 0.1 |d_e|` (x near its line
/// in the plane, which includes x near a clip vertex), a term is undefined, or the parts sum to
/// less than `1/max_cancellation` of their magnitudes.
///
/// `angles[i]`, where `angles` has an entry `i`, receives the angle edge `i` subtends at x
/// (`atan(s_b/H) − atan(s_a/H)`, Lambert's `β`, in `[0, π]`) for the edges off the tangent
/// plane that reach the sum, where it is well conditioned (entries of other edges are left
/// alone): the clipped loop's derivatives (`lambert_clipped_derivs`) reuse them instead of an
/// `atan2` each. Well conditioned: both ends at least `L/4` from x and `sin β ≥ 1/4`. The far
/// abscissa `s_b = s_a + L` errs by `~u(‖r_a‖ + L)`, which moves the angle by up to
/// `u(‖r_a‖ + L)/‖r_b‖` (133 ulps measured with an end at `L/73`): at most ~9u here. And the
/// derivatives' bracket `c/P − β/s` amplifies a difference between this `β` and `atan2(s, c)`
/// of their rounded inputs by ~`1.5/tan²β`: at most 24 at `sin β = 1/4`.
///
/// `edges[i]`, where `edges` has an entry `i`, receives the vector of edge `i` when it lies in
/// the tangent plane ([`edge_vector`]'s: the ends' double-double difference rounded once), for
/// the same loop's derivatives.
#[inline]
#[allow(clippy::too_many_arguments)]
fn near_plane_value<E: Copy + Into<InPlaneEdge>>(
    verts: &[ClipVertex],
    frames: &[Option<E>],
    n: DVec3,
    plane_n: DVec3,
    h_p: f64,
    max_cancellation: f64,
    angles: &mut [f64],
    edges: &mut [DVec3],
) -> Option<(f64, f64)> {
    let count = verts.len();
    let h2 = h_p * h_p;
    let n_par = n.dot(plane_n);
    let n_t = n - n_par * plane_n;
    let nt2 = n_t.length_squared();
    if nt2 == 0.0 {
        // n along N̂: nothing is clipped and no edge lies in the tangent plane.
        return None;
    }
    let mut transverse = 0.0;
    let mut turning = 0.0;
    let mut small = 0.0;
    // Σ sign(n·w) (β_c − n_N sign(n·w) Δψ_c) over the edges in the tangent plane.
    let mut tangent = 0.0;
    // Σ of the parts' magnitudes, to measure the split's own cancellation.
    let mut magnitude = 0.0;
    // The cheap test first: every edge off the tangent plane far enough from x_P (in units of
    // h_P), before any angle is computed.
    for (i, frame) in frames.iter().enumerate() {
        if let Some(f) = frame {
            let f: InPlaneEdge = (*f).into();
            let on_line = verts[i].on_line && verts[next(i, count)].on_line;
            #[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN declines
            if !on_line && !(h_p.abs() * f.len < NEAR_PLANE_RATIO * plane_n.dot(f.w).abs()) {
                return None;
            }
        }
    }
    // The clip line ℓ (where the tangent plane meets the polygon's plane) runs along n × N̂; its
    // point nearest x is p = (h_P/‖n_t‖²)(N̂ − n_N n) (n·p = 0, N̂·p = h_P), at D = |h_P|/‖n_t‖.
    // An edge on ℓ has r_a × e = p × e, so sign(n·w) = sign(e·(n × p)) = sign(h_P e·(n × N̂)) and
    // N̂·w/L = sign(n·w) n_N D: its geometry comes from the exact height without a double-double
    // cross product.
    let n_x_plane = n.cross(plane_n);
    let (n_t, nt2, big_d) = grazing_tangent(verts, n, plane_n, h_p, n_t, nt2);
    for (i, frame) in frames.iter().enumerate() {
        let (a, b) = (&verts[i], &verts[next(i, count)]);
        if a.on_line && b.on_line {
            // The clip edge's whole term minus its share n_N Δψ_c of the parallel part.
            let e = edge_vector(a, b);
            if let Some(edge) = edges.get_mut(i) {
                *edge = e;
            }
            let len = e.length();
            if len == 0.0 {
                continue;
            }
            let e_hat = e / len;
            let sa = a.r.dot(e_hat) + a.r_lo.dot(e_hat);
            let sb = b.r.dot(e_hat) + b.r_lo.dot(e_hat);
            let sigma = (h_p * e.dot(n_x_plane)).signum();
            // Its in-plane angle Δψ_c = atan2(d_c L, s_a s_b + d_c²), d_c = σ n_N D, is
            // σ sign(n_N) β(|n_N| D), which `tangent_excess` forms anyway (to rounding, which
            // the winding number's rounding to an integer absorbs).
            let (t, beta_c) = tangent_excess(big_d, len, sa * sb, n_par.abs(), nt2);
            turning += (sigma * n_par.signum()) * beta_c;
            tangent += sigma * t;
            magnitude += t.abs();
            continue;
        }
        let Some(frame) = frame else {
            continue;
        };
        let frame: InPlaneEdge = (*frame).into();
        let len = frame.len;
        // Signed in-plane distance of x_P from the edge line: N̂·(r_a × ê), from the (exact when x
        // is near the line) lever arm.
        let d = plane_n.dot(frame.w) / len;
        let (sa, sb) = (frame.sa, frame.sb);
        let dpsi = (d * len).atan2(sa * sb + d * d);
        turning += dpsi;
        let deficit = near_plane_deficit(d.abs(), h2, sa, sb, dpsi.abs());
        small += deficit.g.copysign(d);
        magnitude += (n_par * deficit.g).abs();
        // n_t·(r_a × e) = h_P n_t·(N̂ × e): the in-plane part of r_a × e is exactly h_P N̂ × e, and
        // taking it from the plane avoids the cancellation against the large N̂ part. The edge's
        // A_1 = atan2(H L, H² + s_a s_b)/H (H = √(d² + h_P²), its distance from x) comes with the
        // deficit.
        let nu_t = h_p * n_t.dot(plane_n.cross(frame.e_hat));
        let t = nu_t * deficit.spread / deficit.big_h;
        if let Some(angle) = angles.get_mut(i) {
            let big_h2 = deficit.big_h * deficit.big_h;
            let (ra2, rb2, len2) = (big_h2 + sa * sa, big_h2 + sb * sb, len * len);
            // sin²β = H²L²/(‖r_a‖²‖r_b‖²).
            if 16.0 * ra2.min(rb2) >= len2 && 16.0 * big_h2 * len2 >= ra2 * rb2 {
                *angle = deficit.spread;
            }
        }
        transverse += t;
        magnitude += t.abs();
    }
    let winding = (turning / std::f64::consts::TAU).round();
    let parallel = std::f64::consts::TAU * winding - small;
    let total = n_par * parallel + transverse + tangent;
    magnitude += (n_par * std::f64::consts::TAU * winding).abs();
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN declines
    if !(magnitude <= max_cancellation * total.abs()) {
        return None;
    }
    Some((0.5 * FRAC_1_PI * total, magnitude / total.abs()))
}

/// Below this `‖n_t‖²` (a receiver within ~0.1 rad of facing the polygon's plane head-on)
/// [`near_plane_value`] takes `n_t` from the clip line ([`grazing_tangent`]) rather than from
/// `n − n_N N̂` in f64: the latter's relative error, ~`u/‖n_t‖`, is multiplied by the split's
/// cancellation (up to [`SPLIT_CANCELLATION_LIMIT`]), which at this threshold keeps it below
/// ~1e-12 and at 2.5e-6 rad would reach 1e-9.
const GRAZING_NT2: f64 = 1e-2;

/// Below this `‖n_t‖²` (a receiver within 1e-4 rad of facing the polygon's plane head-on, near
/// the plane and clipping it) [`evaluate`] takes the derivatives from the quadrature even where the
/// split does not cancel beyond [`SPLIT_CANCELLATION_LIMIT`]: the edge sum's terms are O(1/size)
/// while the derivatives are O(F/h_P), which vanish with `h_P` for a head-on receiver
/// (`tests/kernels_b_grazing.rs`: gradient errors up to 6.3e-6 from the edge sum, 3.9e-7 from the
/// quadrature; above 1e-4 rad the edge sum's were within 5e-11).
const FACING_NT2: f64 = 1e-8;

/// The in-plane part `n_t` of the receiver normal, `‖n_t‖²` and the distance `D = |h_P|/‖n_t‖`
/// from x to the clip line ℓ, for [`near_plane_value`] (`n_t`, `nt2` its f64 estimates).
///
/// Why: `n_t = n − n_N N̂` is a difference of nearly equal vectors when the receiver faces the
/// plane nearly head-on, and the rounded `N̂` (an ulp, ~1e-16) tilts it by ~1e-16/‖n_t‖ rad. The
/// value is that sensitive to it: per ulp of `n` it moves by ~4e-10 relative at `‖n_t‖` = 2.3e-6
/// (the example of issue 18's grazing gap), which the f64 route turned into errors of 1.7e-9.
/// The clip points carry the same information exactly: they are the polygon's edges (exact, in the
/// plane) cut by the tangent plane in double-double, so ℓ's direction `ê` and x's distance from
/// it, `D = ‖r_a × r_b‖/L` (double-double cross product: `D ≪ ‖r_a‖` where the receiver is tilted
/// more), are accurate to a few ulps whatever `‖n_t‖`. Then `‖n_t‖ = |h_P|/D` (the exact height),
/// and `n_t` is along `N̂ × ê` (in the plane, perpendicular to ℓ = the direction of `n × N̂`; the
/// rounding of `N̂` now moves it by an ulp of its own size), oriented as the f64 estimate.
///
/// Above [`GRAZING_NT2`], or without a clip edge of nonzero length, the f64 estimates as they are
/// (and `D = |h_P|/‖n_t‖`).
#[inline]
fn grazing_tangent(
    verts: &[ClipVertex],
    n: DVec3,
    plane_n: DVec3,
    h_p: f64,
    n_t: DVec3,
    nt2: f64,
) -> (DVec3, f64, f64) {
    if nt2 < GRAZING_NT2 {
        let count = verts.len();
        for i in 0..count {
            let (a, b) = (&verts[i], &verts[next(i, count)]);
            if !(a.on_line && b.on_line) {
                continue;
            }
            let (ra, rb) = (
                dd::Dd3::from_parts(a.r, a.r_lo),
                dd::Dd3::from_parts(b.r, b.r_lo),
            );
            let e = rb.sub(&ra).to_dvec3();
            let len = e.length();
            if len == 0.0 {
                continue;
            }
            let big_d = ra.cross(&rb).to_dvec3().length() / len;
            let norm = h_p.abs() / big_d;
            let m = plane_n.cross(e) / len;
            let m = if m.dot(n_t) < 0.0 { -m } else { m };
            return (m * norm, norm * norm, big_d);
        }
        // Nothing clipped (the clip line passes beside the polygon): `n_t` from the polygon's own
        // normal in double-double, `N' = Σ r_i × r_{i+1}` (the vertices are exact pairs), as
        // `N' × (n × N') / ‖N'‖²` (`n` is exact): its relative error is then ~u whatever `‖n_t‖`.
        let exact = |v: &ClipVertex| dd::Dd3::from_parts(v.r, v.r_lo);
        let mut newell = dd::Dd3::new(DVec3::ZERO, DVec3::ZERO);
        for i in 0..count {
            newell = newell.add(&exact(&verts[i]).cross(&exact(&verts[next(i, count)])));
        }
        let tangent = newell.cross(&dd::Dd3::new(n, DVec3::ZERO).cross(&newell));
        let norm2 = newell.dot(&newell);
        let n_t = DVec3::new(
            tangent.x.div(norm2).to_f64(),
            tangent.y.div(norm2).to_f64(),
            tangent.z.div(norm2).to_f64(),
        );
        let nt2 = n_t.length_squared();
        return (n_t, nt2, h_p.abs() / nt2.sqrt());
    }
    (n_t, nt2, h_p.abs() / nt2.sqrt())
}

/// The frames of the loop's edges as the edge sum builds them ([`frame_of`]), pushed onto `out`
/// (filled in place: returning the small vector would copy it); `None` for the clip edges (when
/// `cut`), whose terms [`clip_edge_term`] forms from its own frame.
fn edge_frames(verts: &[ClipVertex], cut: bool, out: &mut Frames) {
    let count = verts.len();
    for i in 0..count {
        let clip_edge = cut && verts[i].on_line && verts[next(i, count)].on_line;
        out.push(if clip_edge { None } else { frame_of(verts, i) });
    }
}

/// The frame of the edge from vertex `i` of the loop to the next: a clip point's `u` is rounded
/// independently of its exact `r`, so the edge vector of an edge with a clip point is taken from
/// the exact ends, and the frame's cross product is recomputed in double-double when x is near the
/// edge's line. `None` for a zero-length edge.
fn frame_of(verts: &[ClipVertex], i: usize) -> Option<EdgeFrame> {
    let (a, b) = (&verts[i], &verts[next(i, verts.len())]);
    let ends = ExactEnds {
        a: [a.r, a.r_lo],
        b: [b.r, b.r_lo],
    };
    EdgeFrame::with_exact_ends(a.r, edge_vector(a, b), Some(&ends))
}

type Frames = SmallVec<[Option<EdgeFrame>; 10]>;

/// Whether the foot point of x (`h_p N̂` from x) lies inside the clipped loop, by the crossing
/// number of the loop projected along the dominant axis of `N̂` (bridges along the clip line cross
/// in pairs and leave the parity alone). Only used to choose between two accurate evaluations
/// (see [`evaluate`]), so a foot on or next to the boundary may go either way.
#[inline]
fn foot_inside(verts: &[ClipVertex], plane_n: DVec3, h_p: f64) -> bool {
    // `dominant_projection`'s choice made once, each case with its own loop (the choice per
    // point cost ~10 instructions per edge).
    let a = plane_n.abs();
    let foot = plane_n * h_p;
    if a.x >= a.y && a.x >= a.z {
        crossing_parity(verts, foot, |v| DVec2::new(v.y, v.z))
    } else if a.y >= a.z {
        crossing_parity(verts, foot, |v| DVec2::new(v.z, v.x))
    } else {
        crossing_parity(verts, foot, |v| DVec2::new(v.x, v.y))
    }
}

/// [`foot_inside`] for the projection `project`.
#[inline(always)]
fn crossing_parity(verts: &[ClipVertex], foot: DVec3, project: impl Fn(DVec3) -> DVec2) -> bool {
    let foot = project(foot);
    let count = verts.len();
    if count == 0 {
        return false;
    }
    // Each vertex projected once, carried to the next edge.
    let first = project(verts[0].r) - foot;
    let mut p = first;
    let mut inside = false;
    for i in 0..count {
        let q = if i + 1 == count {
            first
        } else {
            project(verts[i + 1].r) - foot
        };
        // The edge crosses the ray from the foot along +x: it straddles y = 0 at a positive x.
        let dy = q.y - p.y;
        if (p.y > 0.0) != (q.y > 0.0) && ((p.x * dy - p.y * (q.x - p.x)) > 0.0) == (dy > 0.0) {
            inside = !inside;
        }
        p = q;
    }
    inside
}

/// The edge vector from `a` to `b` (see [`edge_frames`]). Inlined: as a call it cost the
/// near-plane routes ~15 instructions per edge (callgrind).
#[inline(always)]
fn edge_vector(a: &ClipVertex, b: &ClipVertex) -> DVec3 {
    if a.on_line || b.on_line {
        let (ra, rb) = (
            dd::Dd3::from_parts(a.r, a.r_lo),
            dd::Dd3::from_parts(b.r, b.r_lo),
        );
        rb.sub(&ra).to_dvec3()
    } else {
        b.u - a.u
    }
}

/// `atan(z)`, by its series where `|z|` is small (the arguments of the near-plane corrections are
/// O(h_P) or O(ε)): below 1e-4 three terms are exact to 1e-28 relative.
fn atan_small(z: f64) -> f64 {
    if z.abs() < 1e-4 {
        let z2 = z * z;
        z * (1.0 - z2 * (1.0 / 3.0 - 0.2 * z2))
    } else {
        z.atan()
    }
}

/// `β(D) − c β(cD)` with `β(t) = atan2(t L, t² + P)`: for an edge in the tangent plane at distance
/// `d = D` from x (`L` its length, `P = s_a s_b` the product of its ends' abscissae from the foot of
/// x, `c = |n_N|`, `nt2 = ‖n_t‖² = 1 − c²`), its term `β_c` less its share `c β(cD) = sign(n·w) n_N Δψ_c`
/// of the parallel part (see [`near_plane_value`]).
///
/// Outside the polygon (`P > 0`) both angles are O(D) and agree to `1 − c`, which is small when the
/// receiver faces the plane nearly head-on. With `u = DL/(D² + P)` and `v = cDL/(c²D² + P)` (the
/// tangents of the two angles), `β(D) − cβ(cD) = atan((u − v)/(1 + uv)) + (1 − c) atan(v)`, and
/// `u − v = DL (1 − c)(P − cD²)/((D² + P)(c²D² + P))`, with `1 − c = ‖n_t‖²/(1 + c)`: every part
/// carries its factor `1 − c` explicitly, so nothing cancels. Otherwise (`P ≤ 0`, the foot's
/// projection on ℓ inside the segment, which happens outside the polygon too: the foot beyond the
/// clip line) the angles are O(1) but still agree to `1 − c`; their difference is the angle between
/// the vectors `(D² + P, DL)` and `(c²D² + P, cDL)`, an `atan2` of their cross product (the same
/// numerator, factor `1 − c` explicit) and their dot product (positive, no cancellation).
/// Subtracting the angles as they are lost `~u β/(1 − c)` relative: 8.7e-6 of the value for a
/// receiver 1.9e-6 rad from head-on (`tests/kernels_b_grazing.rs`). Returned with `β(cD)` itself,
/// which gives the edge's in-plane angle for the winding number.
fn tangent_excess(d: f64, len: f64, p: f64, c: f64, nt2: f64) -> (f64, f64) {
    let one_minus_c = nt2 / (1.0 + c);
    let (d2, cd2) = (d * d, c * c * d * d);
    if p <= 0.0 {
        // The angles are not small, but they still agree to `1 − c`: their difference is the
        // angle between (D² + P, DL) and (c²D² + P, cDL), whose cross product is `u − v`'s
        // numerator and whose dot product is positive (the two directions nearly agree).
        let beta_c = (c * d * len).atan2(cd2 + p);
        let cross = d * len * one_minus_c * (p - c * d2);
        let dot = (d2 + p) * (cd2 + p) + c * d2 * len * len;
        return (cross.atan2(dot) + one_minus_c * beta_c, beta_c);
    }
    let u = d * len / (d2 + p);
    let v = c * d * len / (cd2 + p);
    let u_minus_v = d * len * one_minus_c * (p - c * d2) / ((d2 + p) * (cd2 + p));
    // β(cD) = atan(v): its second argument c²D² + P is positive.
    let beta_c = atan_small(v);
    (
        atan_small(u_minus_v / (1.0 + u * v)) + one_minus_c * beta_c,
        beta_c,
    )
}

/// What [`near_plane_deficit`] returns for one edge.
struct Deficit {
    /// `G_e`.
    g: f64,
    /// `atan(s_b/H) − atan(s_a/H)`, the angle the edge subtends at x (`H A_1`).
    spread: f64,
    /// `H = √(d² + h_P²)`, the distance from x to the edge's line.
    big_h: f64,
}

/// `G_e = ∫ ε cos²ψ/(1 + ε cos²ψ) dψ` for an edge at in-plane distance `d > 0` from the foot point
/// of x, `h2 = h_P²`, abscissae `s_a < s_b` along its line (`ψ = atan(s/d)`, `ε = h_P²/d²`), given
/// `abs_dpsi = atan(s_b/d) − atan(s_a/d)` (the unsigned angle at the foot, which the caller has).
///
/// With `s = d tan ψ` the integrand is `d h²/((d² + s²)(H² + s²)) ds`, `H² = d² + h_P²`, which splits
/// into `d/(d² + s²) − d/(H² + s²)`: `G_e = [atan(s/d) − atan(s/H)] + (1 − d/H) [atan(s/H)]`, both
/// brackets taken between `s_a` and `s_b`. Written that way each part is a difference of angles
/// that agree to O(ε) and would lose everything to rounding; instead
/// `δ(s) = atan(s/d) − atan(s/H) = atan(s k/(d H + s²))` and `1 − d/H = k/H` with
/// `k = H − d = h²/(H + d)`, all without cancellation, and the second bracket is
/// `abs_dpsi − [δ]`. What remains is a difference of two O(ε) angles (at `s_b` and `s_a`), whose
/// rounding error is O(ε·u), far below the O(h_P) value it corrects.
fn near_plane_deficit(d: f64, h2: f64, sa: f64, sb: f64, abs_dpsi: f64) -> Deficit {
    let big_h = (d * d + h2).sqrt();
    let k = h2 / (big_h + d);
    let delta = |s: f64| atan_small(s * k / (d * big_h + s * s));
    let dd = delta(sb) - delta(sa);
    let spread = abs_dpsi - dd;
    Deficit {
        g: dd + k / big_h * spread,
        spread,
        big_h,
    }
}

/// Signed form factor of one triangle by quadrature of `(n·r)(N·r)/(π‖r‖⁴)` (Duffy map, `rule` in
/// both directions), with analytic derivatives of the integrand. Accurate when x is far from the
/// triangle compared with its size (see [`far_field_rule`]). Signed by the triangle's orientation
/// (`N` right-handed). The triangle is `r_a + s·ab + s·t·bc` (`s, t ∈ [0, 1]`) relative to x;
/// `geometry` is its `(2·area·N̂, 2·area·N̂·r_a)` from [`fan_geometry`].
pub(crate) fn triangle_rule(
    r_a: DVec3,
    ab: DVec3,
    bc: DVec3,
    n: DVec3,
    order: Order,
    geometry: (DVec3, f64),
    rule: Rule,
) -> Deriv3 {
    tensor_rule(r_a, ab, bc, n, order, geometry, (0.0, 1.0, rule.0), rule.0)
}

/// [`triangle_rule`] restricted to `s ∈ [s0, s1]` (the part of the triangle between two lines
/// parallel to `bc`), with Gauss rules `s_rule` along `s` and `t_rule` along `t`. With `[0, 1]`
/// the nodes and weights are exactly those of `s_rule`, so [`triangle_rule`] is unchanged bit for
/// bit. (The sliver rule and the subdivided quadrature's pieces sum the same integrand four
/// nodes at a time, in `sliver::sums`.)
#[allow(clippy::too_many_arguments)]
#[inline]
fn tensor_rule(
    r_a: DVec3,
    ab: DVec3,
    bc: DVec3,
    n: DVec3,
    order: Order,
    geometry: (DVec3, f64),
    (s0, s1, s_rule): (f64, f64, &[(f64, f64)]),
    t_rule: &[(f64, f64)],
) -> Deriv3 {
    let (normal, c_t) = geometry;
    // Moments of the integrand's derivatives, assembled once after the loop:
    // ∇q = 4 (n·r) r/‖r‖⁶ − n/‖r‖⁴,
    // Hq = 24 (n·r) r rᵀ/‖r‖⁸ − 4 (n rᵀ + r nᵀ)/‖r‖⁶ − 4 (n·r) 𝟙/‖r‖⁶.
    let mut q0 = 0.0;
    let mut s4 = 0.0; // Σ w/‖r‖⁴
    let mut u6 = DVec3::ZERO; // Σ w (n·r) r/‖r‖⁶
    let mut v6 = DVec3::ZERO; // Σ w r/‖r‖⁶
    let mut s6 = 0.0; // Σ w (n·r)/‖r‖⁶
    let (mut xx, mut yy, mut zz, mut xy, mut xz, mut yz) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let span = s1 - s0;
    for &(s, ws) in s_rule {
        let (s, ws) = (s0 + span * s, ws * span);
        for &(t, wt) in t_rule {
            let weight = ws * wt * s;
            let r = r_a + s * ab + (s * t) * bc;
            let inv2 = 1.0 / r.length_squared();
            let inv4 = inv2 * inv2;
            let nr = n.dot(r);
            q0 += weight * nr * inv4;
            if order.gradient() {
                let w6 = weight * inv4 * inv2;
                s4 += weight * inv4;
                u6 += (w6 * nr) * r;
                if order.hessian() {
                    v6 += w6 * r;
                    s6 += w6 * nr;
                    let w8 = w6 * nr * inv2;
                    xx += w8 * r.x * r.x;
                    yy += w8 * r.y * r.y;
                    zz += w8 * r.z * r.z;
                    xy += w8 * r.x * r.y;
                    xz += w8 * r.x * r.z;
                    yz += w8 * r.y * r.z;
                }
            }
        }
    }
    let sums = RuleSums {
        q0,
        s4,
        u6,
        v6,
        s6,
        second: [xx, yy, zz, xy, xz, yz],
    };
    sums.assemble(n, (normal, c_t), order)
}

/// The sums a fan triangle's Gauss rule accumulates (see [`tensor_rule`]): `q0 = Σ w (n·r)/‖r‖⁴`,
/// `s4 = Σ w/‖r‖⁴`, `u6 = Σ w (n·r) r/‖r‖⁶`, `v6 = Σ w r/‖r‖⁶`, `s6 = Σ w (n·r)/‖r‖⁶` and the
/// entries `xx, yy, zz, xy, xz, yz` of `Σ w (n·r) r rᵀ/‖r‖⁸`. The batch lanes accumulate the same
/// sums and assemble them here, so that both give the same bits.
pub(crate) struct RuleSums {
    pub(crate) q0: f64,
    pub(crate) s4: f64,
    pub(crate) u6: DVec3,
    pub(crate) v6: DVec3,
    pub(crate) s6: f64,
    pub(crate) second: [f64; 6],
}

impl RuleSums {
    /// The signed form factor and its derivatives from the sums, for the fan geometry
    /// `(2·area·N̂, 2·area·N̂·r_a)` and the receiver normal `n` (`Order` decides what is formed).
    #[inline]
    pub(crate) fn assemble(&self, n: DVec3, (normal, c_t): (DVec3, f64), order: Order) -> Deriv3 {
        let mut out = Deriv3::constant(0.0);
        let q1 = 4.0 * self.u6 - self.s4 * n;
        out.value = FRAC_1_PI * c_t * self.q0;
        if order.gradient() {
            out.gradient = FRAC_1_PI * (c_t * q1 - self.q0 * normal);
            if order.hessian() {
                let [xx, yy, zz, xy, xz, yz] = self.second;
                let q2 = DMat3::from_cols(
                    DVec3::new(xx, xy, xz),
                    DVec3::new(xy, yy, yz),
                    DVec3::new(xz, yz, zz),
                ) * 24.0
                    - sym_outer(n, self.v6) * 4.0
                    - DMat3::IDENTITY * (4.0 * self.s6);
                out.hessian = (q2 * c_t - sym_outer(normal, q1)) * FRAC_1_PI;
            }
        }
        out
    }
}

fn accumulate(sum: &mut Deriv3, d: Deriv3) {
    sum.value += d.value;
    sum.gradient += d.gradient;
    sum.hessian += d.hessian;
}

/// [`triangle_rule`] on the triangle `(a, b, c)`.
fn rule_on(
    a: &ClipVertex,
    b: &ClipVertex,
    c: &ClipVertex,
    n: DVec3,
    order: Order,
    geometry: (DVec3, f64),
    rule: Rule,
) -> Deriv3 {
    triangle_rule(a.r, b.u - a.u, c.u - b.u, n, order, geometry, rule)
}

/// Signed form factor of the clipped loop by [`triangle_rule`] on its fan triangles.
fn far_field(verts: &[ClipVertex], n: DVec3, order: Order, exact: bool, rule: Rule) -> Deriv3 {
    let mut out = Deriv3::constant(0.0);
    for k in 1..verts.len() - 1 {
        let (a, b, c) = (&verts[0], &verts[k], &verts[k + 1]);
        let geometry = fan_geometry(a, b, c, exact);
        accumulate(&mut out, rule_on(a, b, c, n, order, geometry, rule));
    }
    out
}

/// The near-plane routes' branch where the visible part `verts` (their clipped loop) is
/// far-field against its size: `evaluate`'s far-field branch (its `exact` set near the plane),
/// which it takes before the split. Records the rule in `far`; returns its value as
/// [`visible_value`] makes it from the exact height `h_p`, or with `defer` NaN, the value being
/// left to [`deferred_far_piece`] (which sums the rule once for the value and the derivatives).
/// `None` for a non-finite value.
fn far_piece_value(
    verts: &[ClipVertex],
    n: DVec3,
    plane_normal: DVec3,
    h_p: f64,
    rule: Rule,
    far: &mut Option<near_plane_triangle::FarPiece>,
    defer: bool,
) -> Option<f64> {
    *far = Some(near_plane_triangle::FarPiece {
        rule,
        n,
        plane_normal,
        h_p,
    });
    if defer {
        return Some(f64::NAN);
    }
    visible_value(far_field(verts, n, Order::Value, true, rule).value, h_p)
}

/// The form factor of the visible part from the signed sum `value` over its loop: the edge sum's
/// sign convention (positive when the polygon's right-hand normal points away from x, whose exact
/// height over the plane is `h_p`), then the clamp to `[0, 1]` that rounding may step outside;
/// `None` when not finite. Shared by the near-plane routes' split and far-field branch, whose
/// values at the value and derivative orders must have the same bits.
fn visible_value(value: f64, h_p: f64) -> Option<f64> {
    let value = if h_p < 0.0 { -value } else { value };
    let value = value.clamp(0.0, 1.0);
    value.is_finite().then_some(value)
}

/// Value, gradient and (at [`Order::Hessian`]) Hessian of the far-field rule on a near-plane
/// route's loop where the route took it and left its value to the derivative order
/// ([`RouteLoop::defer_far`](near_plane_triangle::RouteLoop)): the rule summed once, for the value
/// and the derivatives, the derivatives as `evaluate` has them (the clip line's Hessian term
/// included). The value is [`far_piece_value`]'s bits: `triangle_rule` sums the value's `q0` and
/// `RuleSums::assemble` forms it by the same operations at every order, and it is signed and
/// clamped here as there ([`visible_value`]). `None` where that value is not finite (where
/// [`far_piece_value`] declines, and the route with it) or `route.far` is not set; `Err(value)`
/// where the derivatives overflow. Per unit length (per squared length), in the units of the vertices.
pub(crate) fn deferred_far_piece<const N: usize>(
    route: &RouteLoop<N>,
    order: Order,
) -> Option<std::result::Result<Deriv3, f64>> {
    let far = route.far?;
    let verts = &route.points[..route.count];
    let mut d = far_field(verts, far.n, order, true, far.rule);
    let value = visible_value(d.value, far.h_p)?;
    if far.h_p < 0.0 {
        d.gradient = -d.gradient;
        d.hessian = -d.hessian;
    }
    if order.hessian() {
        match clip_line_hessian(verts, far.n, far.plane_normal, far.h_p, false, false) {
            Ok(h) => d.hessian += h,
            Err(_) => return Some(Err(value)),
        }
    }
    d.value = value;
    Some(d.is_finite().then_some(d).ok_or(value))
}

/// A triangle awaiting quadrature, with its [`fan_geometry`].
type Piece = ([ClipVertex; 3], (DVec3, f64));

/// `(2·area·N̂, 2·area·N̂·r_a)` of the triangle `(a, b, c)` (`N̂` right-handed). With `exact`,
/// from the exact differences in double-double: for slivers and for x near the plane these two
/// lose digits in f64 (the normal of a sliver, the height of a point near its plane), and they
/// multiply the whole integral.
fn fan_geometry(a: &ClipVertex, b: &ClipVertex, c: &ClipVertex, exact: bool) -> (DVec3, f64) {
    if !exact {
        let normal = (b.u - a.u).cross(c.u - a.u);
        return (normal, normal.dot(a.r));
    }
    let (ra, rb, rc) = (
        dd::Dd3::from_parts(a.r, a.r_lo),
        dd::Dd3::from_parts(b.r, b.r_lo),
        dd::Dd3::from_parts(c.r, c.r_lo),
    );
    let bc = rb.cross(&rc);
    let normal = ra.cross(&rb).add(&bc).add(&rc.cross(&ra));
    (normal.to_dvec3(), ra.dot(&bc).to_f64())
}

/// Most triangles [`subdivided_quadrature`] may use before giving up.
const MAX_PIECES: usize = 256;
/// The same for x near the polygon's plane with part of the polygon clipped away and the foot of x
/// outside the visible part, when [`near_plane_value`] declines: x also within `10 h_P` of an edge
/// line, or the split's own parts cancelling (a small corner cut off). There the edge sum's O(1)
/// terms sum to the O(h_P) value, and graded refinement towards x takes up to ~1500 pieces at
/// h_P = 1e-6. Elsewhere in this configuration the split takes the value in closed form (the
/// cancellation is not intrinsic: see [`near_plane_value`]).
const MAX_PIECES_NEAR_PLANE: usize = 4096;

/// The fan triangles of the loop, bisected along their longest edge until each is far from x
/// (centroid distance ≥ [`FAR_FIELD_RATIO`] × radius), then integrated by [`triangle_rule`]'s
/// rule, four nodes at a time ([`sliver::rule_piece_sums`]: the node loop is most of the
/// quadrature's cost, and in the AVX2 build takes ~2.6x fewer instructions so than one node at a
/// time; the portable build gives the same bits). For polygons whose edge sum cancels (slivers, x near the plane) while x
/// is not close to them. `None` if that would take more than `max_pieces` triangles.
fn subdivided_quadrature(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
    exact: bool,
    max_pieces: usize,
) -> Option<Deriv3> {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2_fma() {
        // SAFETY: `simd::avx2_fma` checked that the CPU has AVX2 and FMA.
        return unsafe { subdivided_quadrature_fma(verts, n, order, exact, max_pieces) };
    }
    subdivided_quadrature_with::<sliver::PortableSums>(verts, n, order, exact, max_pieces)
}

/// [`subdivided_quadrature`] compiled with AVX2 and FMA: four nodes per register in the pieces'
/// sums, and fused double-double products in their exact fan geometry, with the portable build's
/// bits (the lanes round and are added as there; the fused product is correctly rounded either
/// way and Rust fuses nothing else).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn subdivided_quadrature_fma(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
    exact: bool,
    max_pieces: usize,
) -> Option<Deriv3> {
    subdivided_quadrature_with::<sliver::AvxSums>(verts, n, order, exact, max_pieces)
}

#[inline(always)]
fn subdivided_quadrature_with<S: sliver::GroupSums>(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
    exact: bool,
    max_pieces: usize,
) -> Option<Deriv3> {
    match order {
        Order::Value => subdivide::<S, false, false>(verts, n, exact, max_pieces),
        Order::Gradient => subdivide::<S, true, false>(verts, n, exact, max_pieces),
        Order::Hessian => subdivide::<S, true, true>(verts, n, exact, max_pieces),
    }
}

/// [`subdivided_quadrature`]'s bisection, with the pieces' sums as asked.
#[inline(always)]
fn subdivide<S: sliver::GroupSums, const GRADIENT: bool, const HESSIAN: bool>(
    verts: &[ClipVertex],
    n: DVec3,
    exact: bool,
    max_pieces: usize,
) -> Option<Deriv3> {
    let order = match (GRADIENT, HESSIAN) {
        (false, _) => Order::Value,
        (true, false) => Order::Gradient,
        (true, true) => Order::Hessian,
    };
    let n_lanes = crate::kernels::numeric::lanes::V3::<S::Lane>::splat(n);
    // Each piece carries its (2·area·N̂, 2·area·N̂·r_a): bisection halves both exactly, so the
    // pieces inherit the accuracy of the fan triangles' geometry.
    let mut stack: SmallVec<[Piece; 16]> = SmallVec::new();
    for k in 1..verts.len() - 1 {
        let (a, b, c) = (verts[0], verts[k], verts[k + 1]);
        stack.push(([a, b, c], fan_geometry(&a, &b, &c, exact)));
    }
    let mut out = Deriv3::constant(0.0);
    let mut pieces = 0;
    while let Some((t, geometry)) = stack.pop() {
        let centroid = (t[0].r + t[1].r + t[2].r) / 3.0;
        let radius = t
            .iter()
            .map(|v| (v.r - centroid).length())
            .fold(0.0, f64::max);
        if let Some(rule) = far_field_rule(centroid.length(), radius) {
            pieces += 1;
            if pieces > max_pieces {
                return None;
            }
            let sums = sliver::rule_piece_sums::<S, GRADIENT, HESSIAN>(
                &t[0], &t[1], &t[2], &n_lanes, rule,
            );
            accumulate(&mut out, sums.assemble(n, geometry, order));
            continue;
        }
        if stack.len() + pieces >= max_pieces {
            return None;
        }
        // bisect the longest edge (keeps the orientation of both halves)
        let len = |i: usize| (t[(i + 1) % 3].u - t[i].u).length_squared();
        let i = (0..3)
            .max_by(|&p, &q| len(p).total_cmp(&len(q)))
            .unwrap_or(0);
        let (p, q, o) = (t[i], t[(i + 1) % 3], t[(i + 2) % 3]);
        let m = ClipVertex {
            u: (p.u + q.u) * 0.5,
            r: (p.r + q.r) * 0.5,
            r_lo: DVec3::ZERO,
            on_line: false,
        };
        let half = (geometry.0 * 0.5, geometry.1 * 0.5);
        stack.push(([p, m, o], half));
        stack.push(([m, q, o], half));
    }
    Some(out)
}

/// Above this ratio of `Σ|edge term|` to `|Σ edge term|` (the edge sum has lost more than ~1e4 ulps
/// to cancellation), [`subdivided_quadrature`] is tried instead.
pub(crate) const CANCELLATION_LIMIT: f64 = 1e2;

/// [`CANCELLATION_LIMIT`] for slivers (`2·area < 1e-2·extent²`) with x neither near their plane
/// nor clipping them, whose edge sum cancels by about the inverse aspect ratio: each edge term is
/// accurate to a few ulps, so the sum's relative error is a few ulps times the cancellation ratio
/// (measured on the slivers of `tests/kernels_b_accuracy.rs` with the limit lifted: value errors
/// 0.1-5.1 ε·ratio, gradient and Hessian (relative to their largest entry) within 10 ε·ratio over
/// ratios 1e3-4e7). Slivers are a hard regime (contract 1e-10 / 1e-9 / 1e-8): at 1e4 the edge sum
/// is within ~6e-12, and [`subdivided_quadrature`], 100x slower, is only needed beyond (aspect
/// below ~1e-4).
pub(crate) const THIN_CANCELLATION_LIMIT: f64 = 1e4;

/// The cancellation the edge sum may have before the quadrature is tried instead.
pub(crate) fn cancellation_limit(plane: &Plane, near_plane_or_cut: bool) -> f64 {
    if plane.is_thin() && !near_plane_or_cut {
        THIN_CANCELLATION_LIMIT
    } else {
        CANCELLATION_LIMIT
    }
}

/// The Hessian term from the motion of the clip line ℓ:
/// `n nᵀ (|h_P| / (π ‖n_t‖)) ∫_{P∩ℓ} ds/‖r‖⁴`, with `P∩ℓ` the oriented clip edges (bridges of
/// non-convex polygons traverse ℓ twice in opposite directions and cancel).
///
/// With `exact_edges` the clip edges come from the clip points' exact differences
/// ([`edge_vector`]) instead of their rounded `u`, whose difference errs by ~ε·extent: a sliver's
/// clip edge spans its width, so that error is ~ε/aspect of its length (2.5e-6 of the Hessian for
/// apex 1e-9 of the length, `tests/kernels_b_clipped_slivers.rs`), and `∫ ds/‖r‖⁴` is the
/// closed form's `A_2` ([`EdgeFrame::moments`], a few ulps also on such short edges seen from
/// near their line's extension, where its series once cancelled to 3.8e-8). With `local_planes`
/// each clip edge takes `|h_P| / ‖n_t‖` from the plane of the triangle it forms with the loop's
/// next vertex (`plane_n`, `h_p` only where that triangle is degenerate): a thin polygon's rounded
/// vertices twist its plane by ~ε/aspect, which cost 5.3e-9 of the Hessian with the plane of the
/// whole loop (a 6-vertex visible loop 1e-7 wide, `tests/kernels_b_polygon_slivers.rs`; 5.9e-15
/// with the edge's own plane). A clipped triangle's loop is planar (its clip points lie on its
/// edges to double-double): `plane_n`, `h_p` from its exact fan geometry serve every clip edge.
/// Inlined, as [`clip`].
#[inline(always)]
fn clip_line_hessian(
    verts: &[ClipVertex],
    n: DVec3,
    plane_n: DVec3,
    h_p: f64,
    exact_edges: bool,
    local_planes: bool,
) -> Result<DMat3> {
    let n_t = n - n.dot(plane_n) * plane_n;
    let nt_len = n_t.length();
    let along = (n_t / nt_len).cross(plane_n);
    let count = verts.len();
    let mut integral = 0.0;
    for i in 0..count {
        let (a, b) = (verts[i], verts[next(i, count)]);
        if !(a.on_line && b.on_line) {
            continue;
        }
        let e = if exact_edges {
            edge_vector(&a, &b)
        } else {
            b.u - a.u
        };
        let Some(frame) = EdgeFrame::new(a.r, e) else {
            continue;
        };
        let a2 = frame.moments(Order::Gradient)?.a2;
        if !exact_edges {
            integral += a2.copysign(e.dot(along));
            continue;
        }
        if !local_planes {
            integral += a2.copysign(e.dot(along)) * (h_p.abs() / nt_len);
            continue;
        }
        // The plane at the clip edge: the triangle of the edge and the loop's next vertex. A thin
        // polygon's rounded vertices twist its plane by ~ε/aspect radians (1e-9 for a width of
        // 1e-7 of the length), and `|h_P| / ‖n_t‖` follows the plane where the line moves.
        let c = verts[next(next(i, count), count)];
        let (local_n, local_h) = sliver::visible_plane(&[a, b, c]).unwrap_or((plane_n, h_p));
        let local_t = n - n.dot(local_n) * local_n;
        let local_len = local_t.length();
        let local_along = (local_t / local_len).cross(local_n);
        integral += a2.copysign(e.dot(local_along)) * (local_h.abs() / local_len);
    }
    if integral == 0.0 {
        return Ok(DMat3::ZERO);
    }
    if exact_edges {
        return Ok(outer_self(n) * (FRAC_1_PI * integral));
    }
    Ok(outer_self(n) * (h_p.abs() * FRAC_1_PI / nt_len * integral))
}

/// Below this `2·area / extent²` a polygon counts as thin (a sliver): its normal, computed from
/// rounded edge vectors, has lost more than ~2 digits.
const THIN_POLYGON: f64 = 1e-2;

/// Below this `2·area / extent²` a sliver's edge sum cancels by ~1e5, beyond
/// [`THIN_CANCELLATION_LIMIT`]: [`evaluate`] tries the sliver rule without computing the edge sum.
const VERY_THIN_POLYGON: f64 = 1e-5;

/// Whether the triangle is a sliver by [`VERY_THIN_POLYGON`] (from its rounded edge vectors,
/// accurate to ~1e-11 relative at that threshold; non-finite input gives `false`): its form factor
/// goes to [`evaluate`] directly, where the sliver rule applies unless x is near it.
#[inline]
pub(crate) fn is_very_thin_triangle([a, b, c]: [DVec3; 3]) -> bool {
    let (ab, ac) = (b - a, c - a);
    let extent2 = ab.length_squared().max(ac.length_squared());
    ab.cross(ac).length() < VERY_THIN_POLYGON * extent2
}

/// Below this `|h_P| / max ‖r‖`, the height of x over the polygon's plane is recomputed by
/// [`exact_height`] (the rounded one has lost more than ~3 digits).
const NEAR_PLANE_HEIGHT: f64 = 1e-3;

/// The signed height of x over the polygon's plane (along the Newell normal), from the exact
/// differences `r_i = v_i − x`: `r_0 · Σ_i r_i × r_{i+1} / (2·area)` with the triple products
/// `det(r_0, r_i, r_{i+1})` summed in double-double.
fn exact_height(s: &Scaled, twice_area: f64) -> f64 {
    exact_height_of(&s.r, &s.r_lo, twice_area)
}

/// [`exact_height`] from the parts `hi + lo` of the differences `v_i − x` (inlined into the callers,
/// which may be compiled with FMA: see `near_plane_triangle`).
#[inline(always)]
fn exact_height_of(hi: &[DVec3], lo: &[DVec3], twice_area: f64) -> f64 {
    let lo = &lo[..hi.len()];
    let r = |i: usize| dd::Dd3::from_parts(hi[i], lo[i]);
    let r0 = r(0);
    let mut volume = dd::Dd::new(0.0, 0.0);
    let mut prev = r(1);
    for i in 2..hi.len() {
        let next = r(i);
        volume = volume.add(r0.dot(&prev.cross(&next)));
        prev = next;
    }
    volume.to_f64() / twice_area
}

/// The form factor in scaled units (see `polygon_form_factor`).
fn evaluate(s: &Scaled, n: DVec3, order: Order) -> Result<Deriv3> {
    let plane = Plane::new(&s.u)?;
    let nearest =
        s.r.iter()
            .min_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
            .copied()
            .unwrap_or_default();
    let mut h_p = plane.normal.dot(nearest);
    let r_max = s.r.iter().map(|r| r.length()).fold(0.0, f64::max);
    if h_p.abs() <= 4.0 * f64::EPSILON * r_max {
        if order.gradient() {
            return Err(Error::Degenerate(
                "x lies in the polygon's plane: the form factor has a crease there".into(),
            ));
        }
        return Ok(Deriv3::constant(0.0));
    }
    // Near the plane the rounded N·r has lost digits to cancellation (relative error ~ε r/h_P), and
    // the height multiplies the whole value: recompute it from the exact differences.
    let near_plane = h_p.abs() < NEAR_PLANE_HEIGHT * r_max;
    if near_plane {
        h_p = exact_height(s, plane.twice_area);
    }
    // Quadrature geometry from exact differences near the plane and for slivers.
    let exact = near_plane || plane.is_thin();
    let mut clipped = ClipLoop::new();
    let cut = clip(&s.u, &s.r, &s.r_lo, n, &mut clipped);
    // One slice for the whole evaluation: indexing the small vector checks where its data lives
    // at every access.
    let verts: &[ClipVertex] = &clipped;
    if verts.len() < 3 {
        return Ok(Deriv3::constant(0.0));
    }
    // The switch looks at the visible (clipped) part: a thin sliver above the horizon is "far" from x
    // relative to its own size even when the whole polygon is not.
    let count = verts.len() as f64;
    let centroid = verts.iter().map(|v| v.r).sum::<DVec3>() / count;
    let radius = verts
        .iter()
        .map(|v| (v.r - centroid).length())
        .fold(0.0, f64::max);
    let far = far_field_rule(centroid.length(), radius);
    let mut used_quadrature = far.is_some();
    // Far thinner than the edge sum's limit, a sliver goes to its rule without the edge sum, near
    // its plane too (the rule needs x far from the sliver compared with its width only, and its
    // height comes from the exact triple product, `sliver_geometry`, not from h_P) unless x is
    // over the sliver: there the edge sum's terms share a sign, and the rule would bisect
    // towards x.
    // Clipped, the visible part's fan triangles take the rule (`clipped_sliver_quadrature`), also
    // where the visible part is far-field: the far-field rule and the robust path's edge sum,
    // subdivision and near-plane split erred by up to 1.2e-4 there, the rule by ~3e-13
    // (`tests/kernels_b_clipped_slivers.rs`).
    // The rule's fan geometry of a clipped sliver, for the clip line's Hessian term.
    let mut fan_geometry_sums = None;
    let sliver = if (far.is_none() || cut)
        && plane.is_very_thin()
        && !(near_plane && foot_inside(verts, plane.normal, h_p))
    {
        if cut {
            sliver::clipped_sliver_quadrature(verts, n, order).map(|(d, geometry)| {
                fan_geometry_sums = Some(geometry);
                d
            })
        } else {
            sliver::sliver_quadrature(verts, n, order)
        }
    } else {
        None
    };
    let mut d = if let Some(q) = sliver {
        used_quadrature = true;
        q
    } else if let Some(rule) = far {
        far_field(verts, n, order, exact, rule)
    } else {
        let mut frames = Frames::new();
        edge_frames(verts, cut, &mut frames);
        // x near the plane with the polygon clipped: the clip line passes within ~h_P of x and the
        // edge terms, O(1), cancel down to the O(h_P) value. The near-plane split, with the clip
        // edges in closed form, is a sum of O(h_P) terms instead (see `near_plane_value`). It is
        // taken for the value whenever it applies and the foot of x is outside the clipped loop
        // (above the interior the terms share a sign and the plain sum is accurate, and cheaper
        // for the derivatives), without looking at the sum, so that `Order::Value` skips the
        // edge sum and the value does not depend on the order. The derivatives come from the
        // edge sum: its terms are not large against
        // the derivatives (∂F/∂h_P is O(1) while F is O(h_P); `clip_edge_term` removes the clip
        // line's 1/h_P and 1/h_P² parts analytically, clip-line motion included), which
        // `tests/kernels_b_near_plane.rs` measures against the 320-bit reference.
        // A grazing receiver (`‖n_t‖² < GRAZING_NT2`) whose tangent plane passes beside the
        // polygon: the split too, for the value only. The quadrature's `n·r` loses
        // `u‖r‖/|n·r|` there (1.1e-10 of the value at 2.5e-7 rad, 2.6e-11 sizes from the plane),
        // the split's parts do not.
        let nt2 = if near_plane {
            (n - n.dot(plane.normal) * plane.normal).length_squared()
        } else {
            1.0
        };
        let grazing = !cut && nt2 < GRAZING_NT2;
        let mut split = if near_plane && (cut || grazing) && !foot_inside(verts, plane.normal, h_p)
        {
            near_plane_value(
                verts,
                &frames,
                n,
                plane.normal,
                h_p,
                SPLIT_VALUE_LIMIT,
                &mut [],
                &mut [],
            )
        } else {
            None
        };
        match (split, order) {
            (Some((v, _)), Order::Value) => Deriv3::constant(v),
            _ => {
                let mut sum = Deriv3::constant(0.0);
                let mut magnitude = 0.0;
                for (i, frame) in frames.iter().enumerate() {
                    let (a, b) = (verts[i], verts[next(i, verts.len())]);
                    let t = if cut && a.on_line && b.on_line {
                        let ends = ExactEnds {
                            a: [a.r, a.r_lo],
                            b: [b.r, b.r_lo],
                        };
                        clip_edge_term(a.r, edge_vector(&a, &b), n, order, Some(&ends))?
                    } else if let Some(f) = frame {
                        frame_term(f, n, order)?
                    } else {
                        continue;
                    };
                    magnitude += t.value.abs();
                    accumulate(&mut sum, t);
                }
                let cancels =
                    magnitude > cancellation_limit(&plane, near_plane || cut) * sum.value.abs();
                let mut quadrature = None;
                // The derivatives from the edge sum only where the split does not cancel beyond
                // its limit for them (its value is taken up to `SPLIT_VALUE_LIMIT`).
                // Never with nothing clipped (the edge sum's derivatives keep their 1/h_P parts),
                // nor for a receiver within 1e-4 rad of head-on (`FACING_NT2`).
                let split_for_derivatives = cut
                    && nt2 >= FACING_NT2
                    && split.is_some_and(|(_, c)| c <= SPLIT_CANCELLATION_LIMIT);
                if cancels && !split_for_derivatives {
                    let max_pieces = if near_plane && cut {
                        MAX_PIECES_NEAR_PLANE
                    } else {
                        MAX_PIECES
                    };
                    // A sliver seen from afar (or from near its plane, but far compared with its
                    // width) is thin in one direction only: the anisotropic rule first. Near the
                    // plane it needs x far from the sliver compared with its width only, and its
                    // height comes from the exact triple product (`sliver_geometry`), not h_P.
                    if plane.is_thin() && !cut {
                        quadrature = sliver::sliver_quadrature(verts, n, order);
                    }
                    if quadrature.is_none() {
                        quadrature = subdivided_quadrature(verts, n, order, exact, max_pieces);
                    }
                }
                match quadrature {
                    Some(mut q) => {
                        used_quadrature = true;
                        if let Some((v, _)) = split {
                            q.value = v;
                        }
                        q
                    }
                    None => {
                        // Without cancellation the plain sum is accurate (every term to a few ulps
                        // of its own size), also near the plane: x above the polygon's interior,
                        // where the terms share a sign. Only a cancelling sum needs the near-plane
                        // split.
                        if split.is_none() && magnitude > NEAR_PLANE_CANCELLATION * sum.value.abs()
                        {
                            split = near_plane_value(
                                verts,
                                &frames,
                                n,
                                plane.normal,
                                h_p,
                                f64::INFINITY,
                                &mut [],
                                &mut [],
                            );
                        }
                        if let Some((v, _)) = split {
                            sum.value = v;
                        }
                        sum
                    }
                }
            }
        }
    };
    // The edge sum is positive when the polygon's right-hand normal points away from x.
    if h_p < 0.0 {
        d.value = -d.value;
        d.gradient = -d.gradient;
        d.hessian = -d.hessian;
    }
    if used_quadrature && cut && order.hessian() {
        // A sliver's clip edge spans its width and its Newell normal errs by ~ε/aspect: the
        // clip line's term from the exact geometry (see `clip_line_hessian`): the rule's own fan
        // geometry where it answered, except near the plane where the robust path answered (its
        // bits unchanged there).
        let sliver_plane = if let Some(geometry) = fan_geometry_sums {
            geometry.plane()
        } else if plane.is_very_thin() && !near_plane {
            sliver::visible_plane(verts)
        } else {
            None
        };
        let (plane_n, height) = sliver_plane.unwrap_or((plane.normal, h_p));
        let exact = sliver_plane.is_some();
        d.hessian += clip_line_hessian(verts, n, plane_n, height, exact, exact && s.u.len() > 3)?;
    }
    // The clipped, visible part satisfies 0 ≤ F ≤ 1; rounding may step outside by an ulp.
    d.value = d.value.clamp(0.0, 1.0);
    Ok(d)
}

/// Shared implementation of `polygon_form_factor` / `triangle_form_factor`.
pub(crate) fn form_factor(x: DVec3, n: DVec3, vertices: &[DVec3], order: Order) -> Result<Deriv3> {
    ensure_finite3(x, "x")?;
    if vertices.len() < 3 {
        return Err(Error::InvalidArgument(format!(
            "a polygon needs at least 3 vertices (got {})",
            vertices.len()
        )));
    }
    for v in vertices {
        ensure_finite3(*v, "vertex")?;
    }
    let n = unit_normal(n)?;
    let scaled = Scaled::new(x, vertices)?;
    let d = evaluate(&scaled, n, order)?;
    scaled.finish(d, order)
}

/// Arvo's irradiance Jacobian (Arvo 1994; Schwarzhaupt thesis §5.1, eq. 5.19) of the *vector form
/// factor* of an unoccluded, unclipped polygon:
///
/// ```text
/// Φ(x) = (1/2π) Σ_k Θ_k Γ_k,   Θ_k = angle(v_k − x, v_{k+1} − x),
/// Γ_k = unit((v_k − x) × (v_{k+1} − x)),    J = ∂Φ/∂x  (J_ij = ∂Φ_i/∂x_j).
/// ```
///
/// `n·Φ` is the signed, unclipped form factor of [`edge_form_factor`](super::edge_form_factor)'s
/// convention (positive when the vertices run clockwise as seen from `x`), so its gradient is
/// `Jᵀ n`. This is an independent formulation (unit vertex vectors, edge matrices
/// `E(a, b) = w wᵀ/(‖w‖² a·b) + (acos(a·b)/‖w‖)(𝟙 − w wᵀ/‖w‖²)` and skew matrices), kept to
/// cross-check the form-factor gradient.
///
/// Limits: Arvo's edge matrix divides by `a·b`, so an edge seen under exactly a right angle, `x` on
/// an edge's line, or `x` at a vertex gives [`Error::Degenerate`]. Units: per L.
pub fn vector_form_factor_jacobian(x: DVec3, vertices: &[DVec3]) -> Result<DMat3> {
    ensure_finite3(x, "x")?;
    if vertices.len() < 3 {
        return Err(Error::InvalidArgument(format!(
            "a polygon needs at least 3 vertices (got {})",
            vertices.len()
        )));
    }
    let skew = |p: DVec3| {
        DMat3::from_cols(
            DVec3::new(0.0, p.z, -p.y),
            DVec3::new(-p.z, 0.0, p.x),
            DVec3::new(p.y, -p.x, 0.0),
        )
    };
    let mut unit = SmallVec::<[(DVec3, DMat3); 8]>::new();
    for v in vertices {
        ensure_finite3(*v, "vertex")?;
        let d = *v - x;
        let len = d.length();
        if len == 0.0 {
            return Err(Error::Degenerate("x coincides with a vertex".into()));
        }
        let u = d / len;
        // ∂u/∂x = −(𝟙 − u uᵀ)/‖v − x‖
        unit.push((u, (outer_self(u) - DMat3::IDENTITY) * (1.0 / len)));
    }
    let count = unit.len();
    let mut jac = DMat3::ZERO;
    for k in 0..count {
        let (a, ja) = unit[k];
        let (b, jb) = unit[(k + 1) % count];
        let w = a.cross(b);
        let w2 = w.length_squared();
        let ab = a.dot(b);
        if w2 == 0.0 || ab == 0.0 {
            return Err(Error::Degenerate(
                "Arvo's edge matrix is singular (x on an edge's line, or a right angle)".into(),
            ));
        }
        let ww = outer_self(w) * (1.0 / w2);
        let edge =
            ww * (1.0 / ab) + (DMat3::IDENTITY - ww) * (ab.clamp(-1.0, 1.0).acos() / w2.sqrt());
        jac += edge * (skew(a) * jb - skew(b) * ja);
    }
    let jac = jac * (0.5 * FRAC_1_PI);
    if jac.is_finite() {
        Ok(jac)
    } else {
        Err(Error::Degenerate("Arvo Jacobian overflows".into()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::lcg;

    /// The switch ratios of [`FAR_FIELD_RULES`] above 16 satisfy the documented tolerances of
    /// [`far_field_error_bound`] (1e-14 value and gradient, 1e-12 Hessian) at the switch, and so
    /// beyond it (the bound grows with ρ); the next cheaper rule would not (each ratio is within
    /// 10 % of the smallest the bound allows).
    #[test]
    fn far_field_switches_satisfy_the_a_priori_bound() {
        let tolerance = [1e-14, 1e-14, 1e-12];
        let fits = |points: usize, ratio: f64| {
            far_field_error_bound(points, 1.0 / ratio)
                .iter()
                .zip(tolerance)
                .all(|(e, t)| *e <= t)
        };
        for (ratio, points) in FAR_FIELD_RULES {
            if ratio > FAR_FIELD_RATIO {
                assert!(fits(points, ratio), "{points} points at {ratio}");
                assert!(!fits(points, ratio / 1.1), "{points} points at {ratio}/1.1");
            }
            // The rule returned at and just below each switch.
            let rule = far_field_rule(ratio, 1.0).unwrap();
            assert_eq!(rule.0.len(), points);
        }
        for w in FAR_FIELD_RULES.windows(2) {
            let below = far_field_rule(w[0].0 * (1.0 - 1e-15), 1.0).unwrap();
            assert_eq!(below.0.len(), w[1].1);
        }
        assert!(far_field_rule(FAR_FIELD_RATIO * (1.0 - 1e-15), 1.0).is_none());
        assert!(far_field_rule(f64::NAN, 1.0).is_none());
        // The 8x8 rule between 16 and 31 radii is kept on measurement, not on this bound.
        let at_16 = far_field_error_bound(8, 1.0 / 16.0);
        assert!(at_16[0] > 1e-14 && at_16[0] < 1e-12, "{at_16:?}");
        assert!(at_16[2] > 1e-12 && at_16[2] < 1e-8, "{at_16:?}");
        assert!(fits(8, 31.0));
    }

    /// A random visible loop for the subdivided quadrature: a triangle or a convex quad of size
    /// 1e-2..1e2 (some of them slivers), `x` 1.05-3 sizes from its centre and 1e-8..1 sizes
    /// from its plane, so that the bisection takes from one piece to hundreds.
    fn quadrature_loop(state: &mut u64) -> (Vec<ClipVertex>, DVec3) {
        let mut c = || lcg(state);
        let scale = 10f64.powf(4.0 * c() - 2.0);
        let m = 3 + usize::from(c() < 0.5);
        let thin = if c() < 0.2 { 1e-3 } else { 1.0 };
        let offset = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5) * 10.0 * scale;
        let verts: Vec<DVec3> = (0..m)
            .map(|k| {
                let a = (k as f64 + 0.3 * c()) / m as f64 * std::f64::consts::TAU;
                DVec3::new(a.cos(), thin * a.sin(), 0.0) * scale + offset
            })
            .collect();
        let a = c() * std::f64::consts::TAU;
        let d = 1.05 + 2.0 * c();
        let h = 10f64.powf(-8.0 * c()) * if c() < 0.5 { 1.0 } else { -1.0 };
        let x = offset + DVec3::new(d * a.cos(), d * a.sin(), h) * scale;
        let n = DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5).normalize();
        let loop_ = verts
            .iter()
            .map(|&u| ClipVertex {
                u,
                r: u - x,
                r_lo: DVec3::ZERO,
                on_line: false,
            })
            .collect();
        (loop_, n)
    }

    fn deriv_bits(d: &Deriv3) -> Vec<u64> {
        let mut b = vec![d.value.to_bits()];
        b.extend(d.gradient.to_array().map(f64::to_bits));
        b.extend(d.hessian.to_cols_array().map(f64::to_bits));
        b
    }

    /// The subdivided quadrature's AVX2+FMA build gives the portable build's bits at every
    /// order, and the gradient's bits do not depend on the order (nor the value's).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn subdivided_quadrature_fma_twin_keeps_the_bits() {
        if !crate::simd::avx2_fma() {
            return;
        }
        let mut state = 1866;
        let mut answered = 0;
        for k in 0..400 {
            let (verts, n) = quadrature_loop(&mut state);
            let exact = k % 2 == 0;
            let mut by_order = Vec::new();
            for order in [Order::Value, Order::Gradient, Order::Hessian] {
                let portable = subdivided_quadrature_with::<sliver::PortableSums>(
                    &verts, n, order, exact, MAX_PIECES,
                );
                // SAFETY: checked above that the CPU has AVX2 and FMA.
                let fused =
                    unsafe { subdivided_quadrature_fma(&verts, n, order, exact, MAX_PIECES) };
                assert_eq!(
                    portable.as_ref().map(deriv_bits),
                    fused.as_ref().map(deriv_bits),
                    "{k} {order:?}"
                );
                answered += usize::from(portable.is_some());
                by_order.push(portable);
            }
            if let [Some(v), Some(g), Some(h)] = &by_order[..] {
                assert_eq!(v.value.to_bits(), h.value.to_bits(), "{k}");
                assert_eq!(g.value.to_bits(), h.value.to_bits(), "{k}");
                assert_eq!(g.gradient, h.gradient, "{k}");
            }
        }
        // 819 of 1200 when written: the closest loops take more than `MAX_PIECES`.
        assert!(answered > 700, "{answered}");
    }

    /// The pieces' sums four nodes at a time agree with the scalar rule (`triangle_rule`, one
    /// node at a time) to rounding, for every far-field rule and order, on pieces 16 to 1e4
    /// radii away.
    #[test]
    fn lane_piece_sums_agree_with_the_scalar_rule() {
        let mut state = 1867;
        let mut worst = 0.0f64;
        for k in 0..600 {
            let mut c = || lcg(&mut state);
            let p = |c: &mut dyn FnMut() -> f64| DVec3::new(c() - 0.5, c() - 0.5, c() - 0.5);
            let centre = p(&mut c).normalize() * 10f64.powf(1.2 + 3.0 * c());
            let t: Vec<ClipVertex> = (0..3)
                .map(|_| {
                    let u = centre + p(&mut c);
                    ClipVertex {
                        u,
                        r: u,
                        r_lo: DVec3::ZERO,
                        on_line: false,
                    }
                })
                .collect();
            let n = p(&mut c).normalize();
            let geometry = fan_geometry(&t[0], &t[1], &t[2], false);
            let (_, points) = FAR_FIELD_RULES[k % FAR_FIELD_RULES.len()];
            let rule = Rule(match points {
                3 => gauss_legendre_3(),
                4 => gauss_legendre_4(),
                5 => gauss_legendre_5(),
                6 => gauss_legendre_6(),
                _ => gauss_legendre_8(),
            });
            let n_lanes = crate::kernels::numeric::lanes::V3::splat(n);
            for order in [Order::Value, Order::Gradient, Order::Hessian] {
                let want = rule_on(&t[0], &t[1], &t[2], n, order, geometry, rule);
                let sums = match order {
                    Order::Value => sliver::rule_piece_sums::<sliver::PortableSums, false, false>(
                        &t[0], &t[1], &t[2], &n_lanes, rule,
                    ),
                    Order::Gradient => {
                        sliver::rule_piece_sums::<sliver::PortableSums, true, false>(
                            &t[0], &t[1], &t[2], &n_lanes, rule,
                        )
                    }
                    Order::Hessian => sliver::rule_piece_sums::<sliver::PortableSums, true, true>(
                        &t[0], &t[1], &t[2], &n_lanes, rule,
                    ),
                };
                let got = sums.assemble(n, geometry, order);
                let rel = |a: f64, b: f64, scale: f64| (a - b).abs() / scale;
                worst = worst.max(rel(got.value, want.value, want.value.abs()));
                if order.gradient() {
                    let g = want.gradient.abs().max_element();
                    worst = worst.max(rel(got.gradient.x, want.gradient.x, g));
                    worst = worst.max(rel(got.gradient.y, want.gradient.y, g));
                    worst = worst.max(rel(got.gradient.z, want.gradient.z, g));
                }
                if order.hessian() {
                    let (a, b) = (got.hessian.to_cols_array(), want.hessian.to_cols_array());
                    let h = b.iter().fold(0.0f64, |m, e| m.max(e.abs()));
                    for (x, y) in a.iter().zip(&b) {
                        worst = worst.max(rel(*x, *y, h));
                    }
                }
            }
        }
        assert!(worst < 1e-13, "{worst:e}");
    }

    /// The closed form of [`near_plane_deficit`] against a composite 16-point Gauss rule (64
    /// panels in ψ) of its defining integral `∫ ε cos²ψ/(1 + ε cos²ψ) dψ`, whose terms are positive
    /// (no cancellation): for `ε` from 1e-2 down to 1e-24 and edges on one side of the foot, across
    /// it and far along their line, the difference is within a few ulps of `ε` (the scale of the
    /// two angle differences it subtracts), far below the O(h_P) value it enters.
    #[test]
    fn near_plane_deficit_matches_its_integral() {
        for (d, sa, sb) in [
            (1.0, -0.7, 2.3),
            (0.3, 0.1, 0.4),
            (0.05, 1.0, 3.0),
            (2.0, -5.0, -1.5),
            (1e-3, -1.0, 1e-2),
        ] {
            for k in 1..=12 {
                let h = d * 10f64.powi(-k) * 0.9;
                let eps = (h / d) * (h / d);
                let (pa, pb) = ((sa / d).atan(), (sb / d).atan());
                let panels = 64;
                let mut reference = 0.0;
                for p in 0..panels {
                    let (lo, hi) = (
                        pa + (pb - pa) * p as f64 / panels as f64,
                        pa + (pb - pa) * (p + 1) as f64 / panels as f64,
                    );
                    for &(t, w) in gauss_legendre_16() {
                        let c = (lo + t * (hi - lo)).cos();
                        let c2e = eps * c * c;
                        reference += w * (hi - lo) * c2e / (1.0 + c2e);
                    }
                }
                let got = near_plane_deficit(d, h * h, sa, sb, pb - pa);
                let want_spread =
                    (sb / (d * d + h * h).sqrt()).atan() - (sa / (d * d + h * h).sqrt()).atan();
                assert!(
                    (got.spread - want_spread).abs() <= 8.0 * f64::EPSILON * (pa.abs() + pb.abs())
                );
                let got = got.g;
                let bound = 8.0 * f64::EPSILON * eps * (pa.abs() + pb.abs() + 1.0);
                assert!(
                    (got - reference).abs() <= bound,
                    "d={d} h={h:e} s=[{sa}, {sb}]: {got:e} vs {reference:e}"
                );
                assert!(got > 0.0);
            }
        }
    }

    /// [`tangent_excess`] against the plain difference `β(D) − cβ(cD)` where that has nothing to
    /// cancel (`c` up to 0.7, and `P ≤ 0`), and against the first terms of its expansion in `D`,
    /// `(1 − c²) D L/P`, as the receiver turns head-on (`1 − c` down to 1e-12) for `D` small.
    #[test]
    fn tangent_excess_against_direct_and_series() {
        let beta = |t: f64, len: f64, p: f64| (t * len).atan2(t * t + p);
        for (d, len, p) in [
            (1e-3, 0.8, 0.3),
            (1e-6, 2.0, 1.5),
            (0.2, 1.0, 0.05),
            (1e-3, 1.0, -0.2),
        ] {
            for c in [0.0, 0.3, 0.7] {
                let direct = beta(d, len, p) - c * beta(c * d, len, p);
                let got = tangent_excess(d, len, p, c, 1.0 - c * c).0;
                assert!(
                    (got - direct).abs() <= 1e-14 * direct.abs(),
                    "d={d} L={len} P={p} c={c}: {got:e} vs {direct:e}"
                );
            }
        }
        let (d, len, p) = (1e-9, 0.8, 0.3);
        for k in 2..=12 {
            let nt2 = 10f64.powi(-k);
            let c = (1.0 - nt2).sqrt();
            // β(t) = tL/P − O(t³): the O(D³) remainder is ~1e-18 relative here.
            let series = nt2 * d * len / p;
            let got = tangent_excess(d, len, p, c, nt2).0;
            assert!(
                (got - series).abs() <= 1e-14 * series,
                "1 − c² = {nt2:e}: {got:e} vs {series:e}"
            );
        }
    }

    /// Coordinates whose differences overflow take `Scaled::new`'s second attempt (pre-scaled by
    /// 2⁻⁴): the value is bit for bit that of the same configuration scaled down exactly by
    /// 2⁻¹⁰⁰⁰, and so is the gradient scaled back (it is ~1e-309, subnormal, at this scale; the
    /// Hessian underflows to zero).
    #[test]
    fn overflowing_differences_are_rescaled_exactly() {
        let big = 1.5e308;
        let tri = [
            DVec3::new(big, 0.2 * big, 0.9 * big),
            DVec3::new(0.7 * big, -0.1 * big, big),
            DVec3::new(0.9 * big, 0.8 * big, 0.6 * big),
        ];
        let x = DVec3::new(-big, -0.3 * big, -0.2 * big);
        assert!(!(tri[0] - x).is_finite());
        let n = DVec3::new(0.8, 0.3, 0.5).normalize();
        let down = pow2(-1000);
        let small: Vec<DVec3> = tri.iter().map(|v| *v * down).collect();
        let got = form_factor(x, n, &tri, Order::Hessian).unwrap();
        let want = form_factor(x * down, n, &small, Order::Hessian).unwrap();
        assert!(got.value > 0.0);
        assert_eq!(got.value, want.value);
        assert_eq!(got.gradient, want.gradient * down);
        assert!(got.gradient.abs().max_element() > 0.0);
    }

    /// The bound against the measured quadrature error of the value of a flat-on triangle (the
    /// exact form factor of a parallel receiver from the edge sum at a moderate distance where it
    /// does not cancel): the bound holds, and overestimates.
    #[test]
    fn far_field_bound_holds_for_each_rule() {
        let tri = [
            DVec3::new(-0.4, -0.3, 0.0),
            DVec3::new(0.7, -0.1, 0.0),
            DVec3::new(0.0, 0.8, 0.0),
        ];
        let c = (tri[0] + tri[1] + tri[2]) / 3.0;
        let radius = tri.iter().map(|v| (*v - c).length()).fold(0.0, f64::max);
        let n = DVec3::new(0.3, 0.1, 1.0).normalize();
        for (points, rule) in [
            (3, gauss_legendre_3()),
            (4, gauss_legendre_4()),
            (5, gauss_legendre_5()),
            (6, gauss_legendre_6()),
        ] {
            // Close enough that the error is well above rounding: 2-4 radii.
            for ratio in [2.0, 3.0, 4.0] {
                let x = c - DVec3::new(0.2, -0.1, 1.0).normalize() * (ratio * radius);
                let verts: Vec<ClipVertex> = tri
                    .iter()
                    .map(|v| ClipVertex {
                        u: *v - tri[0],
                        r: *v - x,
                        r_lo: DVec3::ZERO,
                        on_line: false,
                    })
                    .collect();
                let got = far_field(&verts, n, Order::Value, false, Rule(rule)).value;
                let reference = form_factor(x, n, &tri, Order::Value).unwrap().value;
                let err = (got.abs() - reference).abs() / reference;
                let bound = far_field_error_bound(points, 1.0 / ratio)[0];
                assert!(
                    err <= bound,
                    "{points} points, ratio {ratio}: {err:e} > {bound:e}"
                );
                assert!(
                    err > 1e-15,
                    "{points} points, ratio {ratio}: error {err:e} at rounding"
                );
            }
        }
    }
}
