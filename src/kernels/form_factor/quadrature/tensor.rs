//! The far-field rule on a triangle: an `n`x`n` Gauss-Legendre tensor rule on the Duffy-mapped
//! triangle, summed into value, gradient and Hessian moments.

use std::f64::consts::FRAC_1_PI;

use glam::{DMat3, DVec3};

use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::edge::sym_outer;
use crate::kernels::form_factor::quadrature::rules::Rule;
use crate::kernels::numeric::dd;
use crate::{Deriv3, Order};

/// Signed form factor of one triangle by quadrature of `(n·r)(N·r)/(π‖r‖⁴)` (Duffy map, `rule` in
/// both directions), with analytic derivatives of the integrand. Accurate when x is far from the
/// triangle compared with its size (see
/// [`far_field_rule`](crate::kernels::form_factor::quadrature::rules::far_field_rule)). Signed by
/// the triangle's orientation (`N` right-handed). The triangle is `r_a + s·ab + s·t·bc` (`s, t ∈
/// [0, 1]`) relative to x; `geometry` is its `(2·area·N̂, 2·area·N̂·r_a)` from [`fan_geometry`].
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
pub(crate) fn tensor_rule(
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

pub(crate) fn accumulate(sum: &mut Deriv3, d: Deriv3) {
    sum.value += d.value;
    sum.gradient += d.gradient;
    sum.hessian += d.hessian;
}

/// [`triangle_rule`] on the triangle `(a, b, c)`.
pub(crate) fn rule_on(
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
pub(crate) fn far_field(
    verts: &[ClipVertex],
    n: DVec3,
    order: Order,
    exact: bool,
    rule: Rule,
) -> Deriv3 {
    let mut out = Deriv3::constant(0.0);
    for k in 1..verts.len() - 1 {
        let (a, b, c) = (&verts[0], &verts[k], &verts[k + 1]);
        let geometry = fan_geometry(a, b, c, exact);
        accumulate(&mut out, rule_on(a, b, c, n, order, geometry, rule));
    }
    out
}

/// `(2·area·N̂, 2·area·N̂·r_a)` of the triangle `(a, b, c)` (`N̂` right-handed). With `exact`,
/// from the exact differences in double-double: for slivers and for x near the plane these two
/// lose digits in f64 (the normal of a sliver, the height of a point near its plane), and they
/// multiply the whole integral.
pub(crate) fn fan_geometry(
    a: &ClipVertex,
    b: &ClipVertex,
    c: &ClipVertex,
    exact: bool,
) -> (DVec3, f64) {
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
