//! The far-field rule on a triangle: an `n`x`n` Gauss-Legendre tensor rule on the Duffy-mapped
//! triangle, summed into value, gradient and Hessian moments.

use std::f64::consts::FRAC_1_PI;
use std::sync::OnceLock;

use glam::{DMat3, DVec3};

use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::edge::sym_outer;
use crate::kernels::form_factor::quadrature::rules::Rule;
use crate::kernels::numeric::dd;
use crate::kernels::numeric::lanes::{Lane, Pair, V3};
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
    tensor_rule(r_a, ab, bc, n, order, geometry, rule_nodes(rule))
}

/// [`triangle_rule`] with the nodes of any tensor rule ([`tensor_nodes`]), summed in their order.
/// (The sliver rule and the subdivided quadrature's pieces sum the same integrand four nodes at a
/// time, in `quadrature::lanes`, rounded in another order.)
#[inline]
pub(crate) fn tensor_rule(
    r_a: DVec3,
    ab: DVec3,
    bc: DVec3,
    n: DVec3,
    order: Order,
    geometry: (DVec3, f64),
    nodes: &[Node],
) -> Deriv3 {
    let sums = match (order.gradient(), order.hessian()) {
        (false, _) => rule_sums::<false, false>(r_a, ab, bc, n, nodes),
        (true, false) => rule_sums::<true, false>(r_a, ab, bc, n, nodes),
        (true, true) => rule_sums::<true, true>(r_a, ab, bc, n, nodes),
    };
    RuleSums::from_array(&sums).assemble(n, geometry, order)
}

/// A node of the tensor rule on the Duffy-mapped triangle: `s`, `s·t` and the weight `ws·wt·s`.
#[derive(Clone, Copy)]
pub(crate) struct Node {
    pub(crate) s: f64,
    pub(crate) st: f64,
    pub(crate) weight: f64,
}

/// The nodes of the tensor rule with `s_rule` on `s ∈ [s0, s1]` (the part of the triangle between
/// two lines parallel to `bc`) and `t_rule` along `t`, in the order they are summed (`s` outer).
/// With `[0, 1]` the nodes and weights along `s` are exactly those of `s_rule`.
pub(crate) fn tensor_nodes(
    (s0, s1, s_rule): (f64, f64, &[(f64, f64)]),
    t_rule: &[(f64, f64)],
) -> Vec<Node> {
    let span = s1 - s0;
    let mut nodes = Vec::with_capacity(s_rule.len() * t_rule.len());
    for &(s, ws) in s_rule {
        let (s, ws) = (s0 + span * s, ws * span);
        for &(t, wt) in t_rule {
            nodes.push(Node {
                s,
                st: s * t,
                weight: ws * wt * s,
            });
        }
    }
    nodes
}

/// [`tensor_nodes`] of a far-field `rule` in both directions on `[0, 1]`
/// ([`FAR_FIELD_RULES`](crate::kernels::form_factor::quadrature::rules::FAR_FIELD_RULES): at most
/// 8 points; a rule is the Gauss-Legendre rule of its number of points), built once per rule.
pub(crate) fn rule_nodes(rule: Rule) -> &'static [Node] {
    static NODES: [OnceLock<Vec<Node>>; 9] = [const { OnceLock::new() }; 9];
    NODES[rule.0.len()].get_or_init(|| tensor_nodes((0.0, 1.0, rule.0), rule.0))
}

/// [`tensor_rule`]'s running sums, the first [`sums_formed`] of them, over `nodes` in their order.
///
/// Two consecutive nodes side by side in the lanes of a [`Pair`], each lane then added to the
/// sums, first lane first, and an odd last node alone: the sums of one node at a time, bit for bit
/// (those of the batch lanes, which take one node per lane). Why: written for one node, the
/// body's 3-vectors fill one and a half SSE2 registers, and how LLVM paired their components
/// depended on the code around the body (sharing [`node_terms`] with the batch lanes made this
/// loop slower that way, with the same operations); two nodes in two lanes need no shuffles until
/// the sums.
#[inline(always)]
fn rule_sums<const GRADIENT: bool, const HESSIAN: bool>(
    r_a: DVec3,
    ab: DVec3,
    bc: DVec3,
    n: DVec3,
    nodes: &[Node],
) -> [f64; RULE_SUMS] {
    let count = sums_formed(GRADIENT, HESSIAN);
    let mut sums = [0.0; RULE_SUMS];
    let [r_a2, ab2, bc2, n2] = [r_a, ab, bc, n].map(V3::<Pair>::splat);
    let mut pairs = nodes.chunks_exact(2);
    for pair in &mut pairs {
        let (a, b) = (pair[0], pair[1]);
        let r = r_a2 + ab2.scale(Pair::new(a.s, b.s)) + bc2.scale(Pair::new(a.st, b.st));
        let terms = node_terms::<Pair, GRADIENT, HESSIAN>(r, n2, Pair::new(a.weight, b.weight));
        for lane in 0..2 {
            for k in 0..count {
                sums[k] += terms[k].get(lane);
            }
        }
    }
    if let [last] = pairs.remainder() {
        let r = r_a + last.s * ab + last.st * bc;
        let (r, n) = (V3::from_dvec(r), V3::from_dvec(n));
        let terms = node_terms::<f64, GRADIENT, HESSIAN>(r, n, last.weight);
        for k in 0..count {
            sums[k] += terms[k];
        }
    }
    sums
}

/// The number of running sums of the far-field rule ([`RuleSums::from_array`]'s order: `q0`,
/// `s4`, `u6`, `v6`, `s6`, then the six entries of the second moment).
pub(crate) const RULE_SUMS: usize = 15;

/// How many of the [`RULE_SUMS`] sums an order forms: the value's one, the gradient's five, all.
#[inline(always)]
pub(crate) const fn sums_formed(gradient: bool, hessian: bool) -> usize {
    match (gradient, hessian) {
        (false, _) => 1,
        (true, false) => 5,
        (true, true) => RULE_SUMS,
    }
}

/// What the node at `r` (relative to x) with weight `weight` adds to each running sum of the
/// far-field rule, for the receiver normal `n`, in each lane: the one node body of
/// [`tensor_rule`] (two nodes in a [`Pair`], an odd last one in `f64`) and of the batch lanes
/// (`batch::far_field_lanes`, one `f64` lane at a time), so that both round alike. Only the first
/// [`sums_formed`] terms are formed; the moments of the integrand's derivatives are assembled once
/// after the loop ([`RuleSums::assemble`]):
///
/// ```text
/// ∇q = 4 (n·r) r/‖r‖⁶ − n/‖r‖⁴,
/// Hq = 24 (n·r) r rᵀ/‖r‖⁸ − 4 (n rᵀ + r nᵀ)/‖r‖⁶ − 4 (n·r) 𝟙/‖r‖⁶.
/// ```
///
/// `r·r` and `n·r` are [`V3::dot`], glam's `(x·x' + y·y') + z·z'`.
#[inline(always)]
pub(crate) fn node_terms<L: Lane, const GRADIENT: bool, const HESSIAN: bool>(
    r: V3<L>,
    n: V3<L>,
    weight: L,
) -> [L; RULE_SUMS] {
    let mut t = [L::splat(0.0); RULE_SUMS];
    let inv2 = r.dot(r).recip();
    let inv4 = inv2 * inv2;
    let nr = n.dot(r);
    t[0] = weight * nr * inv4;
    if GRADIENT {
        let w6 = weight * inv4 * inv2;
        t[1] = weight * inv4;
        let w6nr = w6 * nr;
        let r = [r.x, r.y, r.z];
        for a in 0..3 {
            t[2 + a] = w6nr * r[a];
        }
        if HESSIAN {
            for a in 0..3 {
                t[5 + a] = w6 * r[a];
            }
            t[8] = w6 * nr;
            let w8 = w6 * nr * inv2;
            t[9] = w8 * r[0] * r[0];
            t[10] = w8 * r[1] * r[1];
            t[11] = w8 * r[2] * r[2];
            t[12] = w8 * r[0] * r[1];
            t[13] = w8 * r[0] * r[2];
            t[14] = w8 * r[1] * r[2];
        }
    }
    t
}

/// The sums a fan triangle's Gauss rule accumulates (see [`tensor_rule`]): `q0 = Σ w (n·r)/‖r‖⁴`,
/// `s4 = Σ w/‖r‖⁴`, `u6 = Σ w (n·r) r/‖r‖⁶`, `v6 = Σ w r/‖r‖⁶`, `s6 = Σ w (n·r)/‖r‖⁶` and the
/// entries `xx, yy, zz, xy, xz, yz` of `Σ w (n·r) r rᵀ/‖r‖⁸`. The batch lanes accumulate the same
/// sums ([`node_terms`]) and assemble them here, so that both give the same bits.
pub(crate) struct RuleSums {
    pub(crate) q0: f64,
    pub(crate) s4: f64,
    pub(crate) u6: DVec3,
    pub(crate) v6: DVec3,
    pub(crate) s6: f64,
    pub(crate) second: [f64; 6],
}

impl RuleSums {
    /// The sums from an array in [`node_terms`]' order.
    #[inline(always)]
    pub(crate) fn from_array(s: &[f64; RULE_SUMS]) -> RuleSums {
        RuleSums {
            q0: s[0],
            s4: s[1],
            u6: DVec3::new(s[2], s[3], s[4]),
            v6: DVec3::new(s[5], s[6], s[7]),
            s6: s[8],
            second: [s[9], s[10], s[11], s[12], s[13], s[14]],
        }
    }

    /// The signed form factor and its derivatives from the sums, for the fan geometry
    /// `(2·area·N̂, 2·area·N̂·r_a)` and the receiver normal `n` (`Order` decides what is formed).
    #[inline(always)]
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
