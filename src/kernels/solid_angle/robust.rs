//! The solid angle's robust rung: any finite input at any scale, and the singular limits.
//!
//! The vertices are rescaled by an exact power of two so that the farthest is at distance ~1
//! (`A` and `D` are cubic in lengths and `g = A² + D²` of degree six: without rescaling, inputs
//! of 1e-60 or 1e60 would underflow or overflow). `A` and the normal come from the vertex nearest
//! `x` and the two shortest edges; where `|A|` is below its rounding bound (x nearly in the plane,
//! seen from the triangle) both are recomputed in double-double from the exact coordinate
//! differences, and near an edge (`A² + D² < 1e-6 (s_0 s_1 s_2)²`) so are `D` and `∇D`, whose
//! terms cancel to O(distance) there. On the plane the value is 2π inside and 0 outside with zero
//! derivatives (the averages of the one-sided limits); on an edge or at a vertex, where the limit
//! depends on the direction of approach, [`Error::Degenerate`].
//!
//! Error: within the hard-regime contract everywhere it answers (measured worst 5e-14 in
//! `tests/solid_angle_accuracy.rs`); it is the reference the certified rung is tested against at
//! their switch.

use glam::DVec3;

use super::hessian::{hessian_of_parts, Parts, Quotient};
use crate::error::{ensure_finite3, Error, Result};
use crate::kernels::numeric::dd::{Dd, Dd3};
use crate::kernels::numeric::pow2::pow2_scale;
use crate::{Deriv3, Order};

pub(super) fn solid_angle_unchecked(
    x: DVec3,
    y: [DVec3; 3],
    order: Order,
    signed: bool,
) -> Result<Deriv3> {
    ensure_finite3(x, "x")?;
    ensure_finite3(y[0], "a")?;
    ensure_finite3(y[1], "b")?;
    ensure_finite3(y[2], "c")?;

    // Work in units where the farthest vertex is at distance ~1: the formulas are homogeneous
    // (A, D ~ L³, g ~ L⁶), so this keeps every intermediate product in range.
    let raw = [y[0] - x, y[1] - x, y[2] - x];
    let raw_edges = [y[2] - y[1], y[0] - y[2], y[1] - y[0]];
    let extent = raw.iter().fold(0.0f64, |m, r| m.max(r.abs().max_element()));
    if !extent.is_finite() || !raw_edges.iter().all(|e| e.is_finite()) {
        // Finite points more than f64::MAX apart: halve everything (exact) and retry.
        return solid_angle_unchecked(x * 0.5, y.map(|v| v * 0.5), order, signed)
            .map(|d| rescale(d, 0.5, 1.0));
    }
    if extent == 0.0 {
        return Err(Error::Degenerate(
            "solid angle: x coincides with every vertex".into(),
        ));
    }
    let (sc1, sc2) = pow2_scale(extent);
    let r = raw.map(|v| v * sc1 * sc2);
    let s = r.map(|v| v.length());
    if s.contains(&0.0) {
        return Err(Error::Degenerate(
            "solid angle: x lies at a vertex of the triangle".into(),
        ));
    }

    // Edges from the coordinates themselves (differences of the r_k would lose distance/size).
    let edges = raw_edges.map(|v| v * sc1 * sc2);
    let (mut a_num, mut normal) = robust_a(x, y, &r, &edges, &s, sc1, sc2);
    if normal == DVec3::ZERO {
        // Exactly collinear vertices: no area, no solid angle, anywhere.
        return Ok(Deriv3::constant(0.0));
    }

    let d01 = r[0].dot(r[1]);
    let d12 = r[1].dot(r[2]);
    let d20 = r[2].dot(r[0]);
    let s012 = s[0] * s[1] * s[2];
    let mut d_den = s012 + d01 * s[2] + d12 * s[0] + d20 * s[1];

    // Near an edge (|A|, |D| ≪ s_0 s_1 s_2) D and its gradient cancel to O(distance), and the
    // rounding of r_k = y_k − x would cost size/distance digits: redo them in double-double from
    // the exact coordinate differences (rare path).
    let refined = if a_num * a_num + d_den * d_den < 1e-6 * s012 * s012 {
        let rf = refine_near_edge(x, y, sc1, sc2, order.gradient());
        d_den = rf.d;
        Some(rf)
    } else {
        None
    };

    if a_num == 0.0 {
        // On the plane. D vanishes on the edges (where the limit depends on the direction).
        if d_den.abs() <= 1e-28 * s012 {
            return Err(Error::Degenerate(
                "solid angle: x lies on an edge of the triangle".into(),
            ));
        }
        if d_den < 0.0 {
            if signed {
                return Err(Error::Degenerate(
                    "signed solid angle: x lies inside the triangle on its plane, where the \
                     value jumps between -2π and 2π"
                        .into(),
                ));
            }
            return Ok(Deriv3::constant(2.0 * std::f64::consts::PI));
        }
        if !signed {
            return Ok(Deriv3::constant(0.0));
        }
        // Signed, outside on the plane: smooth, fall through with A = +0.
    }
    if !signed && a_num < 0.0 {
        a_num = -a_num;
        normal = -normal;
    }

    let mut out = Deriv3::constant(2.0 * a_num.atan2(d_den));
    if !order.gradient() {
        return Ok(out);
    }

    let inv_s = s.map(|v| 1.0 / v);
    let (p, c, grad_d) = match refined {
        Some(rf) => (rf.p, rf.c, rf.grad_d),
        None => {
            let p = [
                s[1] * s[2] + d12, // p_0 = s_1 s_2 + r_1·r_2
                s[2] * s[0] + d20,
                s[0] * s[1] + d01,
            ];
            let c = [
                p[0] * inv_s[0] + s[1] + s[2],
                p[1] * inv_s[1] + s[2] + s[0],
                p[2] * inv_s[2] + s[0] + s[1],
            ];
            (p, c, -(r[0] * c[0] + r[1] * c[1] + r[2] * c[2]))
        }
    };
    let g = a_num * a_num + d_den * d_den;
    let quotient = Quotient::new(a_num, d_den, g, -normal, grad_d);
    out.gradient = quotient.gradient;

    if order.hessian() {
        out.hessian = hessian_of_parts(&Parts { r, s, inv_s, p, c }, &quotient);
    }

    Ok(rescale(out, sc1, sc2))
}

/// `A = (y_v − x)·N` and the normal `N = (b − a)×(c − a)` in the scaled units.
///
/// The fast path uses the vertex nearest to `x` and the two shortest edges (smallest rounding
/// errors); when `|A|` is small against its rounding bound (x nearly in the plane as seen from the
/// triangle), both are recomputed in double-double from the exact coordinate differences.
fn robust_a(
    x: DVec3,
    y: [DVec3; 3],
    r: &[DVec3; 3],
    e: &[DVec3; 3],
    s: &[f64; 3],
    sc1: f64,
    sc2: f64,
) -> (f64, DVec3) {
    // e_k is the edge opposite vertex k, oriented along the cycle (a, b, c).
    let l2 = e.map(|v| v.length_squared());
    // Base the cross product at the vertex opposite the longest edge (its two edges are shortest).
    let k = if l2[0] >= l2[1] && l2[0] >= l2[2] {
        0
    } else if l2[1] >= l2[2] {
        1
    } else {
        2
    };
    // N = (y_{k+1} − y_k) × (y_{k+2} − y_k) for any rotation k of (a, b, c).
    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
    // y_i − y_k = e_j and y_j − y_k = −e_i.
    let normal = e[i].cross(e[j]);
    let v = if s[0] <= s[1] && s[0] <= s[2] {
        0
    } else if s[1] <= s[2] {
        1
    } else {
        2
    };
    let a_num = r[v].dot(normal);
    // Relative rounding error of the fast path is below ~4 eps · s_v ‖e_i‖ ‖e_j‖ / |A|: accept it
    // when that is below ~1.5e-14, i.e. |A| ≥ s_v ‖e_i‖ ‖e_j‖ / 32 (compared squared: no sqrt).
    let bound2 = s[v] * s[v] * l2[i] * l2[j];
    if a_num != 0.0 && a_num * a_num * 1024.0 >= bound2 && normal != DVec3::ZERO {
        return (a_num, normal);
    }
    let scale = |v: Dd3| v.scale_pow2(sc1).scale_pow2(sc2);
    let ra = scale(Dd3::diff(y[0], x));
    let eb = scale(Dd3::diff(y[1], y[0]));
    let ec = scale(Dd3::diff(y[2], y[0]));
    let n = eb.cross(&ec);
    (ra.dot(&n).to_f64(), n.to_dvec3())
}

/// D and, if `derivs`, `p_k`, `c_k` and `∇D` (see the module documentation), evaluated in
/// double-double from the exact differences `y_k − x`, in the scaled units.
struct Refined {
    d: f64,
    p: [f64; 3],
    c: [f64; 3],
    grad_d: DVec3,
}

fn refine_near_edge(x: DVec3, y: [DVec3; 3], sc1: f64, sc2: f64, derivs: bool) -> Refined {
    let r = y.map(|v| Dd3::diff(v, x).scale_pow2(sc1).scale_pow2(sc2));
    let s = r.map(|v| v.dot(&v).sqrt());
    let d01 = r[0].dot(&r[1]);
    let d12 = r[1].dot(&r[2]);
    let d20 = r[2].dot(&r[0]);
    let d = s[0]
        .mul(s[1])
        .mul(s[2])
        .add(d01.mul(s[2]))
        .add(d12.mul(s[0]))
        .add(d20.mul(s[1]));
    let mut out = Refined {
        d: d.to_f64(),
        p: [0.0; 3],
        c: [0.0; 3],
        grad_d: DVec3::ZERO,
    };
    if derivs {
        let p = [
            s[1].mul(s[2]).add(d12),
            s[2].mul(s[0]).add(d20),
            s[0].mul(s[1]).add(d01),
        ];
        let c = [
            p[0].div(s[0]).add(s[1]).add(s[2]),
            p[1].div(s[1]).add(s[2]).add(s[0]),
            p[2].div(s[2]).add(s[0]).add(s[1]),
        ];
        let g = r[0]
            .scale(c[0])
            .add(&r[1].scale(c[1]))
            .add(&r[2].scale(c[2]));
        out.p = p.map(Dd::to_f64);
        out.c = c.map(Dd::to_f64);
        out.grad_d = -g.to_dvec3();
    }
    out
}

/// Converts derivatives computed in units scaled by `f1·f2` back to the caller's units.
pub(crate) fn rescale(mut d: Deriv3, f1: f64, f2: f64) -> Deriv3 {
    d.gradient = d.gradient * f1 * f2;
    d.hessian = d.hessian * f1 * f1 * f2 * f2;
    d
}
