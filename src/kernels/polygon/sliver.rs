//! Thin triangles (slivers) by an anisotropic tensor rule.
//!
//! A sliver's edge sum cancels by about its inverse aspect ratio, and the isotropic subdivision
//! of [`subdivided_quadrature`](super::subdivided_quadrature) bisects it into hundreds of long
//! pieces. But a sliver is thin in one direction only: across its width `w` the integrand varies
//! over a distance ~`d` (the distance of x), so a few Gauss points suffice there, and only the
//! long direction needs many points, graded by the distance of x.
//!
//! The triangle is split at the foot `f` of its apex `c` on its longest edge `ab` (both angles
//! at `a` and `b` are acute, so `f` lies on the edge) into `(a, f, c)` and `(b, c, f)`, each
//! Duffy-mapped from its vertex on the long edge: `r = r_p + s·(q₁ − p) + s·t·(q₂ − q₁)`, with
//! `q₁q₂` the short edge `fc`. Their `(2·area·N̂, 2·area·N̂·r)` are the shares `t_f` and `1 − t_f`
//! (`f = a + t_f·ab`) of the whole triangle's, taken from the exact differences.
//!
//! Error bound (per direction; the tensor rule's error is at most their sum). The integrands
//! `(n·r)/‖r‖⁴ … (n·r) r rᵀ/‖r‖⁸` are analytic along any line except at the two complex zeros of
//! `‖r‖²`, where they have poles of order at most 4. An `m`-point Gauss rule on an interval whose
//! normalized pole `z` lies on the Bernstein ellipse of parameter `ρ` has error at most
//! `(64/15) M_σ σ^{-2m} / (σ² − 1)` for any `σ < ρ`, with `M_σ` the integrand's maximum on the
//! ellipse `E_σ`, at most `(1 − σ/ρ)^{-4}` times its real maximum (up to the scale of the
//! interval). With `σ = ρ·2m/(2m + 4)` (the minimizer of `σ^{-2m}(1 − σ/ρ)^{-4}`) the bound is
//! below ~1e-15 of the integrand's scale when `ρ ≥` 4.5 (16 points), 18 (8 points) along, and
//! 3.2e4 (2 points), 1.2e3 (3), 230 (4), 18 (8) across. Along the length, intervals of `s` are
//! bisected until one of the two rules applies; across, the pole of the line `t ↦ r(s, t)` is at
//! least `D` (the distance of x to the piece) from the segment of length `≤ w`.

use glam::DVec3;

use super::{
    accumulate, fan_geometry, gauss_legendre_16, gauss_legendre_2, gauss_legendre_3,
    gauss_legendre_4, gauss_legendre_8, tensor_rule, ClipVertex,
};
use crate::{Deriv3, Order};

/// Most intervals along one piece before the sliver rule gives up (x too close to the sliver
/// compared with its length; the isotropic subdivision takes over).
const MAX_INTERVALS: usize = 48;

/// `(ρ, points)`: the Gauss rules along the length and the smallest Bernstein parameter at which
/// each is used (module documentation).
const ALONG: [(f64, usize); 2] = [(18.0, 8), (4.5, 16)];
/// The same across the width.
const ACROSS: [(f64, usize); 4] = [(3.2e4, 2), (1.2e3, 3), (230.0, 4), (18.0, 8)];

fn rule(points: usize) -> &'static [(f64, f64)] {
    match points {
        2 => gauss_legendre_2(),
        3 => gauss_legendre_3(),
        4 => gauss_legendre_4(),
        8 => gauss_legendre_8(),
        _ => gauss_legendre_16(),
    }
}

/// The Bernstein-ellipse parameter of the point `z = re + i·im` for the interval [−1, 1]: the
/// sum of the semi-axes of the ellipse with foci ±1 through `z`.
fn bernstein(re: f64, im: f64) -> f64 {
    // Plain square roots: the arguments are ratios of lengths in scaled units (no overflow).
    let (im2, lo, hi) = (im * im, re - 1.0, re + 1.0);
    let a = 0.5 * ((lo * lo + im2).sqrt() + (hi * hi + im2).sqrt());
    a + (a * a - 1.0).max(0.0).sqrt()
}

/// The signed form factor of a sliver triangle (x origin of the `r`; nothing clipped) by the
/// anisotropic rule, or `None` when x is too close to it for the rule (the width is not small
/// against the distance, or the length needs more than [`MAX_INTERVALS`] intervals).
pub(super) fn sliver_quadrature(verts: &[ClipVertex], n: DVec3, order: Order) -> Option<Deriv3> {
    if verts.len() != 3 {
        return None;
    }
    let len = |i: usize| (verts[(i + 1) % 3].u - verts[i].u).length_squared();
    let i = (0..3).max_by(|&p, &q| len(p).total_cmp(&len(q)))?;
    let (a, b, c) = (verts[i], verts[(i + 1) % 3], verts[(i + 2) % 3]);
    let ab = b.u - a.u;
    let share = ((c.u - a.u).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    // The foot's rounding moves it by ~ε·length, which changes the integrand by ~ε·length/d;
    // the pieces' areas are the exact shares of the exact geometry.
    let f = ClipVertex {
        u: a.u + share * ab,
        r: a.r + share * (b.r - a.r),
        r_lo: DVec3::ZERO,
        on_line: false,
    };
    let (normal, c_t) = fan_geometry(&a, &b, &c, true);
    let mut out = Deriv3::constant(0.0);
    for (p, q1, q2, part) in [(a, f, c, share), (b, c, f, 1.0 - share)] {
        if part > 0.0 {
            let geometry = (normal * part, c_t * part);
            accumulate(&mut out, thin_piece(&p, &q1, &q2, n, order, geometry)?);
        }
    }
    Some(out)
}

/// One piece `(p, q₁, q₂)` with `q₁q₂` short, Duffy-mapped from `p`.
fn thin_piece(
    p: &ClipVertex,
    q1: &ClipVertex,
    q2: &ClipVertex,
    n: DVec3,
    order: Order,
    geometry: (DVec3, f64),
) -> Option<Deriv3> {
    let (pq1, q1q2) = (q1.u - p.u, q2.u - q1.u);
    let spine = pq1 + 0.5 * q1q2;
    let length = spine.length();
    let width = q1q2.length();
    // x relative to the spine p + s·spine: foot parameter and distance from the line.
    let s_foot = -p.r.dot(spine) / (length * length);
    let line_distance = p.r.cross(spine).length() / length;
    let segment_distance = (p.r + s_foot.clamp(0.0, 1.0) * spine).length();
    // Across: every t-line has length ≤ width and lies ≥ segment_distance − width from x.
    let across_distance = segment_distance - width;
    if across_distance.is_nan() || across_distance <= 0.0 {
        return None;
    }
    let rho_t = bernstein(0.0, 2.0 * across_distance / width);
    let t_points = ACROSS.iter().find(|(r, _)| rho_t >= *r)?.1;
    let t_rule = rule(t_points);
    // Along: the poles of the t-lines are within `width` of the spine's.
    let pole_distance = line_distance - width;
    if pole_distance.is_nan() || pole_distance <= 0.0 {
        return None;
    }
    let ab = pq1;
    let mut out = Deriv3::constant(0.0);
    let mut stack: [(f64, f64); MAX_INTERVALS] = [(0.0, 0.0); MAX_INTERVALS];
    stack[0] = (0.0, 1.0);
    let (mut top, mut used) = (1, 0);
    while top > 0 {
        top -= 1;
        let (s0, s1) = stack[top];
        let (mid, half) = (0.5 * (s0 + s1), 0.5 * (s1 - s0));
        let rho = bernstein((s_foot - mid) / half, pole_distance / (length * half));
        if let Some(&(_, points)) = ALONG.iter().find(|(r, _)| rho >= *r) {
            let d = tensor_rule(
                p.r,
                ab,
                q1q2,
                n,
                order,
                geometry,
                (s0, s1, rule(points)),
                t_rule,
            );
            accumulate(&mut out, d);
            used += 1;
            continue;
        }
        if top + used + 2 > MAX_INTERVALS {
            return None;
        }
        stack[top] = (s0, mid);
        stack[top + 1] = (mid, s1);
        top += 2;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::super::subdivided_quadrature;
    use super::*;

    fn vertex(v: DVec3, x: DVec3) -> ClipVertex {
        ClipVertex {
            u: v,
            r: v - x,
            r_lo: DVec3::ZERO,
            on_line: false,
        }
    }

    /// The sliver rule is taken for a cap and a needle seen from afar, agrees with the isotropic
    /// subdivision (an independent rule) to 1e-12, and declines when x is within a width of it.
    #[test]
    fn sliver_rule_agrees_with_the_subdivision_and_declines_near_x() {
        let n = DVec3::new(0.1, -0.2, 1.0).normalize();
        let x = DVec3::new(0.4, 0.1, -0.7);
        for apex in [DVec3::new(0.5, 1e-6, 0.0), DVec3::new(1.0, 1e-6, 0.0)] {
            let t = [DVec3::ZERO, DVec3::X, apex].map(|v| vertex(v, x));
            let d = sliver_quadrature(&t, n, Order::Hessian).expect("sliver rule declined");
            let r = subdivided_quadrature(&t, n, Order::Hessian, true, 100_000).unwrap();
            assert!(
                (d.value - r.value).abs() <= 1e-12 * r.value.abs(),
                "{d:?} {r:?}"
            );
            let g = r.gradient.abs().max_element();
            assert!((d.gradient - r.gradient).abs().max_element() <= 1e-12 * g);
            let max = |m: glam::DMat3| {
                m.to_cols_array()
                    .iter()
                    .fold(0.0, |a: f64, v| a.max(v.abs()))
            };
            assert!(max(d.hessian - r.hessian) <= 1e-11 * max(r.hessian));
        }
        // x 1e-7 above the cap's middle: the width is not small against the distance
        let near = DVec3::new(0.5, 5e-7, -1e-7);
        let t = [DVec3::ZERO, DVec3::X, DVec3::new(0.5, 1e-6, 0.0)].map(|v| vertex(v, near));
        assert!(sliver_quadrature(&t, n, Order::Value).is_none());
    }
}
