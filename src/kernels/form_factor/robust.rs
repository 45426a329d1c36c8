//! The robust path: validation, exact power-of-two rescaling, exact clipping, then the edge sum,
//! the near-plane split, the sliver rule or quadrature, whichever the configuration needs.

use glam::DVec3;

use crate::error::{ensure_finite3, Error, Result};
use crate::kernels::form_factor::clip::{clip, edge_vector, next, ClipLoop, ClipVertex};
use crate::kernels::form_factor::clip_line::clip_line_hessian;
use crate::kernels::form_factor::edge::{clip_edge_term, frame_term, ExactEnds};
use crate::kernels::form_factor::near_plane::split::{
    edge_frames, foot_inside, near_plane_value, Frames, FACING_NT2, GRAZING_NT2,
    NEAR_PLANE_CANCELLATION, SPLIT_CANCELLATION_LIMIT, SPLIT_VALUE_LIMIT,
};
use crate::kernels::form_factor::plane::{exact_height, Plane, NEAR_PLANE_HEIGHT};
use crate::kernels::form_factor::quadrature::rules::far_field_rule;
use crate::kernels::form_factor::quadrature::subdivide::{
    subdivided_quadrature, MAX_PIECES, MAX_PIECES_NEAR_PLANE,
};
use crate::kernels::form_factor::quadrature::tensor::{accumulate, far_field};
use crate::kernels::form_factor::scaled::{Points, Scaled};
use crate::kernels::form_factor::sliver::clipped::clipped_sliver_quadrature;
use crate::kernels::form_factor::sliver::direct::direct_sliver;
use crate::kernels::form_factor::sliver::geometry::visible_plane;
use crate::kernels::form_factor::sliver::rule::sliver_quadrature;
use crate::kernels::form_factor::tolerance::cancellation_limit;
use crate::kernels::form_factor::validate::{unit, unit_normal};
use crate::kernels::numeric::dd;
use crate::{Deriv3, Order};

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
    without_rescaling(x, n, v, order, false)
}

/// [`triangle_form_factor_in_range`] for a triangle
/// [`is_very_thin_triangle`](crate::kernels::form_factor::plane::is_very_thin_triangle) accepts:
/// the sliver rule's direct entry first (the same bits; `sliver::direct_sliver`), then `evaluate`.
/// Only for such triangles: for the others the direct entry's plane would be work thrown away.
pub(crate) fn very_thin_triangle_form_factor_in_range(
    x: DVec3,
    n: DVec3,
    v: [DVec3; 3],
    order: Order,
) -> Option<Result<Deriv3>> {
    without_rescaling(x, n, v, order, true)
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
    let n = unit(n)?;
    Some(evaluate(&scaled, n, order).and_then(|d| scaled.finish(d, order)))
}

#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
#[inline(always)] // one copy per entry, without the other's branch
fn without_rescaling(
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
    let n = unit(n)?;
    let err = |a: f64, b: f64| dd::two_sum(a, -b).1;
    let r_lo = v.map(|vk| DVec3::new(err(vk.x, x.x), err(vk.y, x.y), err(vk.z, x.z)));
    // A sliver seen from afar: the sliver rule without `evaluate`'s set-up (the same bits).
    if very_thin {
        if let Some(d) = direct_sliver(&u, &r, &r_lo, n, order) {
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

/// The form factor in scaled units (see `polygon_form_factor`).
pub(crate) fn evaluate(s: &Scaled, n: DVec3, order: Order) -> Result<Deriv3> {
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
    // (`tests/form_factor_clipped_slivers.rs`).
    // The rule's fan geometry of a clipped sliver, for the clip line's Hessian term.
    let mut fan_geometry_sums = None;
    let sliver = if (far.is_none() || cut)
        && plane.is_very_thin()
        && !(near_plane && foot_inside(verts, plane.normal, h_p))
    {
        if cut {
            clipped_sliver_quadrature(verts, n, order).map(|(d, geometry)| {
                fan_geometry_sums = Some(geometry);
                d
            })
        } else {
            sliver_quadrature(verts, n, order)
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
        // `tests/form_factor_near_plane.rs` measures against the 320-bit reference.
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
                        quadrature = sliver_quadrature(verts, n, order);
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
            visible_plane(verts)
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

#[cfg(test)]
mod tests;
