//! The triangle form factor's gradient and Hessian in SIMD lanes where the single kernel integrates
//! by its far-field Gauss rule, and the single kernel as the fallback.
//!
//! Far from `x` (vertex centroid at least 16 radii away), `triangle_form_factor` takes its
//! derivatives from `form_factor::triangle_far_field_fast`: an `n`x`n` Gauss-Legendre rule on the
//! Duffy-mapped triangle (`triangle_rule`), `n` picked by distance over radius
//! (`far_field_rule`), with the value replaced by Lambert's where that is certified. Here
//! each element first replays, in scalar code and with the kernel's own functions, every decision
//! the single call takes before the rule (not a sliver, `maybe_far`, `fast_setup`, not thin, a rule
//! picked); the accepted elements are grouped by rule, and each group's quadrature sums run in lanes
//! (one element per lane, the rule's nodes in the same order). The lane code is the rule's loop body
//! with the same operations in the same order, with no FMA contraction (Rust never contracts, and
//! the code has plain products and sums) and correctly rounded division in every instruction set.
//! The node body is the rule's own (`tensor::node_terms`, called lane by lane), the sums are
//! assembled by the rule's own `RuleSums::assemble`, oriented and checked by the kernel's own
//! `oriented`, and given Lambert's value from the value lanes (`form_factor_lanes`) or its scalar
//! call. An accepted element is therefore the single call's result **bit for bit** (the tests
//! assert equality); a non-finite result, and every element the replay declines (near, clipped,
//! thin, near the plane, invalid), goes to the single kernel.
//!
//! Elements are classified in chunks of [`CHUNK`] and emitted in order, so sums add the per-element
//! results in the same order as a loop over single calls.

use glam::DVec3;

use super::form_factor_lanes;
use crate::error::Result;
use crate::kernels::form_factor::lambert::sum as lambert;
use crate::kernels::form_factor::orient::oriented;
use crate::kernels::form_factor::plane::{is_very_thin_triangle, triangle_plane};
use crate::kernels::form_factor::quadrature::rules::Rule;
use crate::kernels::form_factor::quadrature::tensor::{
    node_terms, rule_nodes, sums_formed, Node, RuleSums, RULE_SUMS,
};
use crate::kernels::form_factor::replay::{fast_setup, maybe_far};
use crate::kernels::numeric::lanes::V3;
use crate::simd::Isa;
use crate::{Deriv3, Order};

/// Lanes per evaluation (a multiple of the widest vector, 8 f64).
const BATCH: usize = 32;

/// Elements classified before their results are emitted in order: large enough that the partly
/// filled groups flushed at its end cost little.
const CHUNK: usize = 256;

/// The far-field rules by point count (`FAR_FIELD_RULES`: 3, 4, 5, 6 and 8).
const RULES: usize = 5;

/// The quadrature's running sums (`tensor::RULE_SUMS`).
const SUMS: usize = RULE_SUMS;

/// Structure-of-arrays batch: `triangle_rule`'s inputs `r_a`, `ab`, `bc`, `n` as `[axis][lane]`,
/// and the sums it accumulates, `[sum][lane]`.
struct Lanes {
    r_a: [[f64; BATCH]; 3],
    ab: [[f64; BATCH]; 3],
    bc: [[f64; BATCH]; 3],
    n: [[f64; BATCH]; 3],
    sums: [[f64; BATCH]; SUMS],
}

impl Lanes {
    fn new() -> Box<Lanes> {
        Box::new(Lanes {
            r_a: [[0.0; BATCH]; 3],
            ab: [[0.0; BATCH]; 3],
            bc: [[0.0; BATCH]; 3],
            n: [[0.0; BATCH]; 3],
            sums: [[0.0; BATCH]; SUMS],
        })
    }

    #[inline(always)]
    fn set(&mut self, i: usize, [r_a, ab, bc, n]: [DVec3; 4]) {
        for axis in 0..3 {
            self.r_a[axis][i] = r_a[axis];
            self.ab[axis][i] = ab[axis];
            self.bc[axis][i] = bc[axis];
            self.n[axis][i] = n[axis];
        }
    }
}

/// `W` lanes from `base`, their sums in registers over every node (`tensor_rule`'s loop body with
/// the gradient on, the Hessian's sums when `HESSIAN`; glam's `dot` is `(x·x' + y·y') + z·z'`).
#[inline(always)]
fn block<const W: usize, const HESSIAN: bool>(l: &mut Lanes, base: usize, nodes: &[Node]) {
    let load = |v: &[[f64; BATCH]; 3]| -> [[f64; W]; 3] {
        std::array::from_fn(|axis| std::array::from_fn(|j| v[axis][base + j]))
    };
    let (r_a, ab, bc, n) = (load(&l.r_a), load(&l.ab), load(&l.bc), load(&l.n));
    let count = sums_formed(true, HESSIAN);
    let mut acc = [[0.0f64; W]; SUMS];
    for node in nodes {
        for j in 0..W {
            let at = |a: usize| r_a[a][j] + node.s * ab[a][j] + node.st * bc[a][j];
            let r = V3 {
                x: at(0),
                y: at(1),
                z: at(2),
            };
            let n = V3 {
                x: n[0][j],
                y: n[1][j],
                z: n[2][j],
            };
            let terms = node_terms::<f64, true, HESSIAN>(r, n, node.weight);
            for k in 0..count {
                acc[k][j] += terms[k];
            }
        }
    }
    for (sum, a) in l.sums.iter_mut().zip(&acc) {
        sum[base..base + W].copy_from_slice(a);
    }
}

/// Every lane's sums, `W` lanes at a time (the vector width: the sums stay in registers).
#[inline(always)]
fn evaluate<const W: usize>(l: &mut Lanes, nodes: &[Node], hessian: bool) {
    for base in (0..BATCH).step_by(W) {
        if hessian {
            block::<W, true>(l, base, nodes);
        } else {
            block::<W, false>(l, base, nodes);
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn evaluate_avx2(l: &mut Lanes, nodes: &[Node], hessian: bool) {
    evaluate::<4>(l, nodes, hessian)
}

#[cfg(all(target_arch = "x86_64", raddiff_avx512))]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,fma")]
unsafe fn evaluate_avx512(l: &mut Lanes, nodes: &[Node], hessian: bool) {
    evaluate::<8>(l, nodes, hessian)
}

fn evaluate_on(isa: Isa, l: &mut Lanes, nodes: &[Node], hessian: bool) {
    match isa {
        Isa::Portable => evaluate::<2>(l, nodes, hessian),
        // SAFETY: `best_isa` (or the test choosing it) checked that the CPU has these features.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { evaluate_avx2(l, nodes, hessian) },
        // SAFETY: as above.
        #[cfg(all(target_arch = "x86_64", raddiff_avx512))]
        Isa::Avx512 => unsafe { evaluate_avx512(l, nodes, hessian) },
    }
}

/// `tensor_rule`'s result from lane `i`'s sums, by its own assembly.
fn assemble(l: &Lanes, i: usize, n: DVec3, geometry: (DVec3, f64), order: Order) -> Deriv3 {
    let s: [f64; SUMS] = std::array::from_fn(|k| l.sums[k][i]);
    RuleSums::from_array(&s).assemble(n, geometry, order)
}

/// What the assembly needs of an element the replay accepted: the unit normal, the fan geometry
/// `(2·area·N̂, 2·area·N̂·r_a)` and the height over the plane (the orientation).
#[derive(Clone, Copy)]
struct Accepted {
    n: DVec3,
    geometry: (DVec3, f64),
    h_p: f64,
}

/// The single call's decisions before its far-field rule (`triangle_form_factor` for gradient and
/// Hessian orders, then `triangle_far_field_fast`), replayed with its own functions: the rule and
/// `triangle_rule`'s inputs where it would integrate by that rule, `None` where it would not.
#[inline]
fn classify(x: DVec3, n: DVec3, v: [DVec3; 3]) -> Option<(Rule, [DVec3; 4], Accepted)> {
    if is_very_thin_triangle(v) || !maybe_far(&v, x) {
        return None;
    }
    let setup = fast_setup(x, n, v, triangle_plane)?;
    if setup.plane.is_thin() {
        return None;
    }
    let rule = setup.far?;
    let (r, u) = (setup.r, setup.u);
    let normal = u[1].cross(u[2]);
    let accepted = Accepted {
        n: setup.n,
        geometry: (normal, normal.dot(r[0])),
        h_p: setup.h_p,
    };
    Some((rule, [r[0], u[1], u[2] - u[1], setup.n], accepted))
}

/// The elements of one rule awaiting evaluation: lane `k` is chunk slot `slots[k]`.
struct Group {
    nodes: &'static [Node],
    lanes: Box<Lanes>,
    slots: [usize; BATCH],
    len: usize,
}

/// An element: receiver, normal, the normal as the value lanes take it, triangle.
type Element = (DVec3, DVec3, DVec3, [DVec3; 3]);

/// Per-chunk state, by slot (sized for the chunk, not [`CHUNK`], so that small batches stay cheap).
struct Chunk {
    elements: Vec<Element>,
    /// The replay's outcome.
    accepted: Vec<Option<Accepted>>,
    /// The lane result (oriented, `None` if not finite).
    result: Vec<Option<Deriv3>>,
    /// Slots with a lane result, and Lambert's value for each.
    taken: Vec<usize>,
    values: Vec<Option<f64>>,
}

impl Group {
    fn new(rule: Rule) -> Group {
        Group {
            nodes: rule_nodes(rule),
            lanes: Lanes::new(),
            slots: [0; BATCH],
            len: 0,
        }
    }

    /// Evaluates the pending lanes and stores their results in `chunk`.
    fn flush(&mut self, isa: Isa, order: Order, chunk: &mut Chunk) {
        if self.len == 0 {
            return;
        }
        // Unused lanes get a harmless far triangle (their outputs are ignored).
        for i in self.len..BATCH {
            let far = [DVec3::Z * 10.0, DVec3::X * 0.1, DVec3::Y * 0.1, DVec3::Z];
            self.lanes.set(i, far);
        }
        evaluate_on(isa, &mut self.lanes, self.nodes, order.hessian());
        for (k, &slot) in self.slots[..self.len].iter().enumerate() {
            let a = chunk.accepted[slot].expect("grouped slots were accepted");
            let d = assemble(&self.lanes, k, a.n, a.geometry, order);
            chunk.result[slot] = oriented(d, a.h_p);
        }
        self.len = 0;
    }
}

/// Index of a rule among [`RULES`] (by its point count).
fn rule_index(rule: Rule) -> usize {
    match rule.0.len() {
        3 => 0,
        4 => 1,
        5 => 2,
        6 => 3,
        _ => 4,
    }
}

/// The form factor of `count` elements at `order` (gradient or Hessian), element `i` being
/// receiver `x`, normal `n`, the normal as the value lanes take it (`form_factor_lanes::lane_normal`)
/// and triangle `get(i)`, handed to `sink(i, result)` in increasing `i`. Elements the lanes do not
/// take get `fallback(i)` (the single call), whose error stops the run.
pub(super) fn run_on(
    isa: Isa,
    count: usize,
    get: impl Fn(usize) -> (DVec3, DVec3, DVec3, [DVec3; 3]),
    order: Order,
    fallback: impl Fn(usize) -> Result<Deriv3>,
    mut sink: impl FnMut(usize, Deriv3),
) -> Result<()> {
    debug_assert!(order.gradient());
    if count == 0 {
        return Ok(());
    }
    let mut groups: [Option<Group>; RULES] = Default::default();
    let size = CHUNK.min(count);
    let mut chunk = Chunk {
        elements: Vec::with_capacity(size),
        accepted: Vec::with_capacity(size),
        result: Vec::with_capacity(size),
        taken: Vec::with_capacity(size),
        values: vec![None; size],
    };
    let mut start = 0;
    while start < count {
        let m = CHUNK.min(count - start);
        chunk.elements.clear();
        chunk.elements.extend((start..start + m).map(&get));
        chunk.accepted.clear();
        chunk.result.clear();
        chunk.result.resize(m, None);
        for slot in 0..m {
            let (x, n, _, v) = chunk.elements[slot];
            let accepted = classify(x, n, v).map(|(rule, inputs, accepted)| {
                let g = groups[rule_index(rule)].get_or_insert_with(|| Group::new(rule));
                g.lanes.set(g.len, inputs);
                g.slots[g.len] = slot;
                g.len += 1;
                accepted
            });
            chunk.accepted.push(accepted);
            if let Some(g) = groups.iter_mut().flatten().find(|g| g.len == BATCH) {
                g.flush(isa, order, &mut chunk);
            }
        }
        for g in groups.iter_mut().flatten() {
            g.flush(isa, order, &mut chunk);
        }
        // Lambert's value where certified, as the single call puts it in.
        let Chunk {
            elements,
            result,
            taken,
            values,
            ..
        } = &mut chunk;
        taken.clear();
        taken.extend((0..m).filter(|&s| result[s].is_some()));
        form_factor_lanes::lambert_values(
            isa,
            taken.len(),
            |k| {
                let (x, _, ln, v) = elements[taken[k]];
                (x, ln, v)
            },
            |k| {
                let (x, n, _, v) = elements[taken[k]];
                lambert::triangle_value(x, n, v)
            },
            values,
        );
        let mut k = 0;
        for (slot, r) in result.iter().enumerate() {
            let d = match *r {
                Some(mut d) => {
                    if let Some(f) = values[k] {
                        d.value = f;
                    }
                    k += 1;
                    d
                }
                None => fallback(start + slot)?,
            };
            sink(start + slot, d);
        }
        start += m;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
