//! The sliver rule's sums, four nodes at a time.
//!
//! Why: the sliver rule evaluates its integrand at 50-60 nodes (13 or 14 along each piece of a
//! sliver seen from about its length, 2 across), and the scalar loop body updates one `r` and
//! its fifteen running sums per node. Four nodes with the same `t` and consecutive
//! `s` (a group) in the four lanes of an AVX register ([`Wide`]) take one packed instruction per
//! operation in the AVX2 build ([`AvxSums`]). The portable build ([`PortableSums`]) takes each
//! group's halves in two SSE2 [`Pair`]s with their own running sums, one half after the other
//! (fifteen sums live at a time, as many as two lanes had, where four lanes side by side spilled
//! twice as many), and skips a last half that is all padding. Each lane rounds as the scalar `f64`
//! code would (no fused multiply-add), lane `l` sums the nodes `4k + l` of the rule along in the
//! same order in both builds (a skipped padding node would have added an exact zero, which
//! changes no sum: the sums start at +0, and a sum rounded to nearest is −0 only when both of
//! its terms are), and the lanes are
//! added in one tree, `(l0 + l1) + (l2 + l3)`: the builds give the same bits. The order of the
//! operations does not depend on `GRADIENT` or `HESSIAN`, so the value is the same for every
//! order, bit for bit, on every target.

use std::sync::OnceLock;

use glam::DVec3;

use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::form_factor::quadrature::rules::{
    gauss_legendre_3, gauss_legendre_4, gauss_legendre_5, gauss_legendre_6, gauss_legendre_8, Rule,
};
use crate::kernels::form_factor::quadrature::tensor::RuleSums;
#[cfg(target_arch = "x86_64")]
use crate::kernels::numeric::lanes::Wide;
use crate::kernels::numeric::lanes::{Lanes, Pair, V3};

/// The sums of a rule over groups of four nodes, as one build takes them.
pub(crate) trait GroupSums {
    /// One register's lanes.
    type Lane: Lanes;
    fn new() -> Self;
    /// As [`LaneSums::add_lanes`], for all four lanes of every group.
    fn add<const GRADIENT: bool, const HESSIAN: bool>(
        &mut self,
        piece: &PieceFrame,
        n: &V3<Self::Lane>,
        along: (f64, f64, &[[[f64; 4]; 2]]),
        t_rule: &[(f64, f64)],
    );
    /// The sums over the lanes, `(l0 + l1) + (l2 + l3)`.
    fn total(&self) -> RuleSums;
}

/// The AVX2 build's sums: four lanes per register.
#[cfg(target_arch = "x86_64")]
pub(crate) type AvxSums = LaneSums<Wide>;

#[cfg(target_arch = "x86_64")]
impl GroupSums for LaneSums<Wide> {
    type Lane = Wide;
    #[inline(always)]
    fn new() -> Self {
        LaneSums::zero()
    }
    #[inline(always)]
    fn add<const GRADIENT: bool, const HESSIAN: bool>(
        &mut self,
        piece: &PieceFrame,
        n: &V3<Wide>,
        along: (f64, f64, &[[[f64; 4]; 2]]),
        t_rule: &[(f64, f64)],
    ) {
        self.add_lanes::<GRADIENT, HESSIAN>(piece, n, along, t_rule, 0);
    }
    #[inline(always)]
    fn total(&self) -> RuleSums {
        self.lane_totals()
    }
}

/// The portable build's sums: lanes 0 and 1 of each group in `lo`, 2 and 3 in `hi`.
#[derive(Clone, Copy)]
pub(crate) struct PortableSums {
    lo: LaneSums<Pair>,
    hi: LaneSums<Pair>,
}

impl GroupSums for PortableSums {
    type Lane = Pair;
    #[inline(always)]
    fn new() -> Self {
        PortableSums {
            lo: LaneSums::zero(),
            hi: LaneSums::zero(),
        }
    }
    #[inline(always)]
    fn add<const GRADIENT: bool, const HESSIAN: bool>(
        &mut self,
        piece: &PieceFrame,
        n: &V3<Pair>,
        along: (f64, f64, &[[[f64; 4]; 2]]),
        t_rule: &[(f64, f64)],
    ) {
        self.lo
            .add_lanes::<GRADIENT, HESSIAN>(piece, n, along, t_rule, 0);
        self.hi
            .add_lanes::<GRADIENT, HESSIAN>(piece, n, along, t_rule, 2);
    }
    #[inline(always)]
    fn total(&self) -> RuleSums {
        let (lo, hi) = (self.lo.lane_totals(), self.hi.lane_totals());
        let second = |k: usize| lo.second[k] + hi.second[k];
        RuleSums {
            q0: lo.q0 + hi.q0,
            s4: lo.s4 + hi.s4,
            u6: lo.u6 + hi.u6,
            v6: lo.v6 + hi.v6,
            s6: lo.s6 + hi.s6,
            second: [
                second(0),
                second(1),
                second(2),
                second(3),
                second(4),
                second(5),
            ],
        }
    }
}

/// The running sums of [`RuleSums`] per lane (each lane holds different nodes' terms).
#[derive(Clone, Copy)]
pub(crate) struct LaneSums<L> {
    q0: L,
    s4: L,
    u6: V3<L>,
    v6: V3<L>,
    s6: L,
    second: [L; 6],
}

/// A Gauss rule `(s, w)` on [0, 1] as [`LaneSums::add`] takes it: its nodes four at a time,
/// `[[s_a, s_b, s_c, s_d], [w_a, w_b, w_c, w_d]]`, the last group padded with copies of its first
/// node at weight zero (they add zeros). Built once per rule.
pub(crate) fn quads(rule: &[(f64, f64)]) -> Vec<[[f64; 4]; 2]> {
    rule.chunks(4)
        .map(|nodes| {
            let mut group = [[nodes[0].0; 4], [0.0; 4]];
            for (l, &(s, w)) in nodes.iter().enumerate() {
                group[0][l] = s;
                group[1][l] = w;
            }
            group
        })
        .collect()
}

/// A piece `r_p + s·ab + s·t·bc` relative to x, with the share `part` of the whole triangle's
/// geometry that it takes (folded into the weights, so that both pieces add to the same sums).
#[derive(Clone, Copy)]
pub(crate) struct PieceFrame {
    pub(crate) r_p: DVec3,
    pub(crate) ab: DVec3,
    pub(crate) bc: DVec3,
    pub(crate) part: f64,
}

impl<L: Lanes> LaneSums<L> {
    #[inline(always)]
    fn zero() -> Self {
        let zero = L::splat(0.0);
        let zero3 = V3::splat(DVec3::ZERO);
        LaneSums {
            q0: zero,
            s4: zero,
            u6: zero3,
            v6: zero3,
            s6: zero,
            second: [zero; 6],
        }
    }

    /// Adds the tensor rule with `s_rule` along `s ∈ [s0, s1]` (as [`quads`] gives it) and
    /// `t_rule` across (both on [0, 1]) on `piece`, for the receiver normal `n`: the sums
    /// `Σ w (n·r)/‖r‖⁴` and, with `GRADIENT`, `HESSIAN`, those of the derivatives (see
    /// [`RuleSums`]), each weight `w` being the node's `w_s·w_t·span·s·part` (`s` is the Duffy
    /// map's Jacobian). The lanes `first..first + L::WIDTH` of each group of four `s` nodes share
    /// a register; a half (`first` = 2) whose first node is padding is skipped (module
    /// documentation).
    #[inline(always)]
    fn add_lanes<const GRADIENT: bool, const HESSIAN: bool>(
        &mut self,
        piece: &PieceFrame,
        n: &V3<L>,
        (s0, s1, s_rule): (f64, f64, &[[[f64; 4]; 2]]),
        t_rule: &[(f64, f64)],
        first: usize,
    ) {
        let span = s1 - s0;
        let scale = span * piece.part;
        let (r_p, ab, bc) = (
            V3::splat(piece.r_p),
            V3::splat(piece.ab),
            V3::splat(piece.bc),
        );
        let (s0, span, scale) = (L::splat(s0), L::splat(span), L::splat(scale));
        for [s_nodes, w_nodes] in s_rule {
            // Padding comes last in a group, and only in the last group.
            if first > 0 && w_nodes[first] == 0.0 {
                break;
            }
            // Lane by lane the scalar `s0 + span·s_a` and `(w_a·scale)·s`.
            let s = s0 + span * L::load(s_nodes, first);
            let ws = L::load(w_nodes, first) * scale * s;
            let base = r_p + ab.scale(s);
            for &(t, wt) in t_rule {
                let r = base + bc.scale(s * L::splat(t));
                self.node::<GRADIENT, HESSIAN>(r, n, ws * L::splat(wt));
            }
        }
    }

    /// A register's nodes at `r` (relative to x) with weights `weight`.
    #[inline(always)]
    fn node<const GRADIENT: bool, const HESSIAN: bool>(&mut self, r: V3<L>, n: &V3<L>, weight: L) {
        let inv2 = L::splat(1.0).div(r.dot(r));
        let nr = n.dot(r);
        let w4 = weight * (inv2 * inv2);
        self.q0 = self.q0 + w4 * nr;
        if GRADIENT {
            self.s4 = self.s4 + w4;
            let w6 = w4 * inv2;
            let w6nr = w6 * nr;
            self.u6 = self.u6 + r.scale(w6nr);
            if HESSIAN {
                self.v6 = self.v6 + r.scale(w6);
                self.s6 = self.s6 + w6nr;
                let w8 = w6nr * inv2;
                let (wx, wy, wz) = (w8 * r.x, w8 * r.y, w8 * r.z);
                let s = &mut self.second;
                s[0] = s[0] + wx * r.x;
                s[1] = s[1] + wy * r.y;
                s[2] = s[2] + wz * r.z;
                s[3] = s[3] + wx * r.y;
                s[4] = s[4] + wx * r.z;
                s[5] = s[5] + wy * r.z;
            }
        }
    }

    /// The sums over the lanes ([`Lanes::total`]).
    #[inline(always)]
    fn lane_totals(&self) -> RuleSums {
        let sum = |p: L| p.total();
        let sum3 = |v: V3<L>| DVec3::new(sum(v.x), sum(v.y), sum(v.z));
        RuleSums {
            q0: sum(self.q0),
            s4: sum(self.s4),
            u6: sum3(self.u6),
            v6: sum3(self.v6),
            s6: sum(self.s6),
            // Written out: `array::map` is not always inlined, and outside the AVX2 twins its
            // closure called the AVX intrinsics as functions.
            second: {
                let q = &self.second;
                [
                    sum(q[0]),
                    sum(q[1]),
                    sum(q[2]),
                    sum(q[3]),
                    sum(q[4]),
                    sum(q[5]),
                ]
            },
        }
    }
}

/// The far-field rules
/// ([`FAR_FIELD_RULES`](crate::kernels::form_factor::quadrature::rules::FAR_FIELD_RULES): 3, 4, 5,
/// 6 and 8 points) as the sums take them
/// ([`quadrature::lanes::quads`](crate::kernels::form_factor::quadrature::lanes::quads)), by their
/// number of points, built once.
fn far_quads(points: usize) -> &'static [[[f64; 4]; 2]] {
    static QUADS: OnceLock<[&'static [[[f64; 4]; 2]]; 9]> = OnceLock::new();
    QUADS.get_or_init(|| {
        let mut quads: [&'static [[[f64; 4]; 2]]; 9] = [&[]; 9];
        for rule in [
            gauss_legendre_3(),
            gauss_legendre_4(),
            gauss_legendre_5(),
            gauss_legendre_6(),
            gauss_legendre_8(),
        ] {
            // Built once per process and kept for it.
            quads[rule.len()] = Box::leak(self::quads(rule).into_boxed_slice());
        }
        quads
    })[points]
}

/// The sums of the far-field `rule` (`n`x`n` Gauss-Legendre points, Duffy-mapped) over the triangle
/// `(a, b, c)` (relative to x, as
/// [`triangle_rule`](crate::kernels::form_factor::quadrature::tensor::triangle_rule) parametrizes
/// it: `r_a + s·(u_b − u_a) + s·t·(u_c − u_b)`), four nodes at a time: the subdivided quadrature's
/// pieces, whose node loop is most of the robust path's cost where it integrates (x near a
/// polygon's plane with a small or thin visible part). The same rule and integrand as
/// `triangle_rule`, summed lane by lane (so rounded in another order); the order of the operations
/// does not depend on `GRADIENT` or `HESSIAN`, nor on the build (module documentation of
/// [`quadrature::lanes`](crate::kernels::form_factor::quadrature::lanes)).
#[inline(always)]
pub(crate) fn rule_piece_sums<S: GroupSums, const GRADIENT: bool, const HESSIAN: bool>(
    a: &ClipVertex,
    b: &ClipVertex,
    c: &ClipVertex,
    n: &V3<S::Lane>,
    rule: Rule,
) -> RuleSums {
    let frame = PieceFrame {
        r_p: a.r,
        ab: b.u - a.u,
        bc: c.u - b.u,
        part: 1.0,
    };
    let mut sums = S::new();
    sums.add::<GRADIENT, HESSIAN>(&frame, n, (0.0, 1.0, far_quads(rule.0.len())), rule.0);
    sums.total()
}

#[cfg(test)]
mod tests;
