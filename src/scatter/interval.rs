//! Per-triangle interval analysis along the eye segment (report sec. 3.2.2-3.2.3, Fig. 5).
//!
//! The solutions of f(x, α, β) = 0 form a curve; its part inside the triangle projects onto a few
//! intervals of x. The curve crosses the triangle's edges at the interval ends (edge solves), or the
//! interval reaches an end of the examined range with a solution inside the triangle there (interior
//! solves). Each edge crossing is a lower or an upper bound of x according to the direction the
//! curve enters the triangle, read off the tangent: ∂f/∂x = λ ∂f/∂α + μ ∂f/∂β (eq. 11) gives
//! δα = −λ δx, δβ = −μ δx (eq. 12), so
//! * on α = 0, the curve enters with δα > 0: x is a lower bound iff λ < 0;
//! * on β = 0, iff μ < 0;
//! * on α + β = 1 (entering means δα + δβ < 0), iff λ + μ > 0.
//!
//! Sweeping the sorted events with a counter (+1 at a lower bound, −1 at an upper bound, started at
//! the number of solutions at the range's start) gives the number of solutions on each piece. When
//! the counts do not close (the curve folds back in x inside the triangle: a caustic of the
//! refracted light crosses the eye segment there) the analysis falls back to the hull of the
//! events, sampled with several seeds.

use glam::DVec2;
use smallvec::SmallVec;

use super::constraint::Constraint;
use super::newton::{
    edge_crossings, foot_seed, inside_triangle, pinv_solve, polish, solve_interior,
    straight_line_seed, EdgeCrossing, NewtonCounters, NewtonSettings,
};

/// Seeds for interior solves without a better guess: the centroid, then the centroids of the corner
/// sub-triangles.
pub const SEEDS: [DVec2; 4] = [
    DVec2::new(1.0 / 3.0, 1.0 / 3.0),
    DVec2::new(2.0 / 3.0, 1.0 / 6.0),
    DVec2::new(1.0 / 6.0, 2.0 / 3.0),
    DVec2::new(1.0 / 6.0, 1.0 / 6.0),
];

/// The straight-line seed at `x` (see [`straight_line_seed`]), then V's foot on the plane when V is
/// within 10% of the triangle's size from it ([`foot_seed`]), then [`SEEDS`].
pub fn seeds_at(c: &Constraint, x: f64) -> SmallVec<[DVec2; 6]> {
    let mut s: SmallVec<[DVec2; 6]> = SmallVec::new();
    s.extend(straight_line_seed(c, x));
    let height = (c.eye.at(x) - c.tri.p0).dot(c.tri.geometric_normal).abs();
    if height < 0.1 * c.tri.e1.length().max(c.tri.e2.length()) {
        s.extend(foot_seed(c, x));
    }
    s.extend(SEEDS);
    s
}

/// The seeds of the range-end solves (made for every triangle that survives pruning, so kept
/// short): the straight-line guess, V's foot when V is close, and the centroid.
fn end_seeds(c: &Constraint, x: f64) -> SmallVec<[DVec2; 6]> {
    let mut s = seeds_at(c, x);
    s.truncate(s.len() - (SEEDS.len() - 1));
    s
}

/// A piece of the eye segment where the triangle holds `multiplicity` refraction points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupportInterval {
    /// Start (L).
    pub x0: f64,
    /// End (L).
    pub x1: f64,
    /// Number of solutions inside the triangle on this piece (2 also flags a fallback piece, where
    /// every sample is solved from several seeds).
    pub multiplicity: u32,
    /// Barycentric coordinates of the solution at x0 and x1 when known (seeds for the samples).
    pub ends: [Option<DVec2>; 2],
    /// Whether the piece ends at a fold of the solution curve (a caustic, where the contribution
    /// has an integrable 1/√ singularity) at x0 / x1: the quadrature then clusters its nodes there.
    pub folds: [bool; 2],
}

/// The result of a triangle's interval analysis.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Support {
    /// Pieces with at least one solution, sorted by x.
    pub intervals: SmallVec<[SupportInterval; 4]>,
    /// False when the fallback (hull of the events) was used.
    pub consistent: bool,
}

/// Whether an edge crossing is a lower bound of x (the curve enters the triangle as x increases).
/// `None` when the tangent is undefined or runs along the edge.
pub fn crossing_is_lower_bound(c: &Constraint, cr: &EdgeCrossing) -> Option<bool> {
    let v = c.eval(cr.x, cr.ab, true)?;
    let j = v.jacobian;
    let lm = pinv_solve(j.y_axis, j.z_axis, j.x_axis)?;
    let (lambda, mu) = (lm.x, lm.y);
    let scale = lambda.abs() + mu.abs();
    let key = match cr.edge {
        0 => -mu,
        1 => lambda + mu,
        _ => -lambda,
    };
    (key.abs() > 1e-12 * scale).then_some(key > 0.0)
}

/// Two converged solutions closer than this in barycentric coordinates are one. Near a fold of the
/// solution curve (a caustic) J is nearly singular and a 1e-10 residual leaves ~1e-5 of slack in
/// (α, β); two genuine solutions that close are within ~1e-8 (relative) in x of the fold, where
/// dropping one changes the integral negligibly.
pub(crate) const DISTINCT: f64 = 1e-4;

/// Whether the path through (α, β) to V(x) is physical: the light on the outer side and V on the
/// inner side of both the geometric and the shading normal (Walter et al.'s sidedness agreement).
/// f = 0 also holds on mirrored configurations (light and V both inside), which must not count.
pub fn is_physical(c: &Constraint, x: f64, ab: DVec2) -> bool {
    let p = c.tri.point(ab);
    let Some(ns) = c.tri.raw_normal(ab).try_normalize() else {
        return false;
    };
    let ng = c.tri.geometric_normal;
    let (l, v) = (c.light - p, c.eye.at(x) - p);
    l.dot(ns) > 0.0 && l.dot(ng) > 0.0 && v.dot(ns) < 0.0 && v.dot(ng) < 0.0
}

pub use super::newton::BOUNDARY;

/// The edge opposite each vertex (the edge where its barycentric coordinate vanishes).
const OPPOSITE_EDGE: [usize; 3] = [1, 2, 0];

/// Which boundary features of a triangle (edges in the order of [`super::newton::EDGES`], vertices
/// P0, P1, P2) count the paths through them: each edge and vertex of a mesh is owned by exactly one
/// of the triangles sharing it (the one of lowest index), so a path through a shared edge or vertex
/// is counted once. Bits 0-2: edges, bits 3-5: vertices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ownership(pub u8);

impl Ownership {
    /// A lone triangle: it owns its whole boundary.
    pub const ALL: Ownership = Ownership(0b11_1111);

    /// Whether edge `e` ([`super::newton::EDGES`] order) is owned.
    #[inline]
    pub fn owns_edge(self, e: usize) -> bool {
        (self.0 >> e) & 1 == 1
    }

    /// Whether vertex `k` (P0, P1, P2) is owned.
    #[inline]
    pub fn owns_vertex(self, k: usize) -> bool {
        (self.0 >> (3 + k)) & 1 == 1
    }

    /// Whether the solution (α, β) counts for this triangle: inside the triangle widened by
    /// [`BOUNDARY`], and, within [`BOUNDARY`] of an edge or a vertex, only if that edge or vertex is
    /// owned. The widening makes a path exactly on a shared edge count even when rounding puts it
    /// just outside its owner.
    pub fn accepts(self, ab: DVec2) -> bool {
        let w = [1.0 - ab.x - ab.y, ab.x, ab.y];
        if w.iter().any(|&v| !(v >= -BOUNDARY)) {
            return false;
        }
        let near = w.map(|v| v <= BOUNDARY);
        match near.iter().filter(|&&b| b).count() {
            0 => true,
            1 => {
                let i = near.iter().position(|&b| b).unwrap_or(0);
                self.owns_edge(OPPOSITE_EDGE[i])
            }
            _ => {
                let k = near.iter().position(|&b| !b).unwrap_or(0);
                self.owns_vertex(k)
            }
        }
    }
}

/// Like [`solutions_at`], with the solutions that [`Ownership::accepts`] (polished first when near
/// the boundary, so that the ownership decision is not left to Newton's slack).
pub fn owned_solutions_at(
    c: &Constraint,
    x: f64,
    seeds: &[DVec2],
    all: bool,
    own: Ownership,
    settings: &NewtonSettings,
    counters: &mut NewtonCounters,
) -> SmallVec<[DVec2; 2]> {
    let mut out: SmallVec<[DVec2; 2]> = SmallVec::new();
    for &seed in seeds {
        if let Some(ab) = solve_interior(c, x, seed, settings, counters) {
            let ab = if ab.x.min(ab.y).min(1.0 - ab.x - ab.y) < 1e-6 {
                polish(c, x, ab)
            } else {
                ab
            };
            if own.accepts(ab)
                && is_physical(c, x, ab)
                && out.iter().all(|q| (*q - ab).length() > DISTINCT)
            {
                out.push(ab);
            }
            if !all {
                break;
            }
        }
    }
    out
}

/// Physical interior solutions inside the triangle at `x`: the first seed that converges inside decides (a small
/// triangle holds at most one solution away from caustics; a seed converging to the curve outside
/// the triangle does not stop the search, or a tiny range crossed by a branch without edge events
/// would lose it); with `all`, every seed is tried and distinct solutions are collected.
pub fn solutions_at(
    c: &Constraint,
    x: f64,
    seeds: &[DVec2],
    all: bool,
    settings: &NewtonSettings,
    counters: &mut NewtonCounters,
) -> SmallVec<[DVec2; 2]> {
    let mut out: SmallVec<[DVec2; 2]> = SmallVec::new();
    for &seed in seeds {
        if let Some(ab) = solve_interior(c, x, seed, settings, counters) {
            if inside_triangle(ab)
                && is_physical(c, x, ab)
                && out.iter().all(|q| (*q - ab).length() > DISTINCT)
            {
                out.push(ab);
                if !all {
                    break;
                }
            }
        }
    }
    out
}

/// Follows the solution curve from (x_from, ab_from) to x_to in up to 16 continuation steps, each
/// solve seeded by the previous solution; the solution at x_to if it stays inside the triangle.
pub fn follow_curve(
    c: &Constraint,
    x_from: f64,
    ab_from: DVec2,
    x_to: f64,
    settings: &NewtonSettings,
    counters: &mut NewtonCounters,
) -> Option<DVec2> {
    const STEPS: usize = 16;
    let mut ab = ab_from;
    for k in 1..=STEPS {
        let x = x_from + (x_to - x_from) * k as f64 / STEPS as f64;
        ab = solve_interior(c, x, ab, settings, counters)?;
    }
    inside_triangle(ab).then_some(ab)
}

/// The support of the triangle's contribution within `[x_lo, x_hi]`.
pub fn triangle_support(
    c: &Constraint,
    (x_lo, x_hi): (f64, f64),
    settings: &NewtonSettings,
    interior: &mut NewtonCounters,
    edge: &mut NewtonCounters,
) -> Support {
    let mut crossings: SmallVec<[EdgeCrossing; 6]> = SmallVec::new();
    for e in 0..3 {
        edge_crossings(c, e, x_lo, x_hi, settings, edge, &mut crossings);
    }
    // The segment's ends usually lie on the mesh: on a triangle holding one, V(x) → P and the Newton
    // basin shrinks to nothing. The end solves are therefore made a relative 1e-7 inside the range
    // (the contribution is bounded there, so the inset changes the integral by ~1e-7 of a piece).
    let inset = 1e-7 * (x_hi - x_lo);
    let (xs, xe) = (x_lo + inset, x_hi - inset);
    let start = solutions_at(c, xs, &end_seeds(c, xs), false, settings, interior);
    let end = solutions_at(c, xe, &end_seeds(c, xe), false, settings, interior);
    let mut events: SmallVec<[(f64, i32, DVec2); 6]> = SmallVec::new();
    let mut consistent = true;
    for cr in &crossings {
        match crossing_is_lower_bound(c, cr) {
            Some(true) => events.push((cr.x, 1, cr.ab)),
            Some(false) => events.push((cr.x, -1, cr.ab)),
            None => {
                consistent = false;
                events.push((cr.x, 0, cr.ab));
            }
        }
    }
    events.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut intervals: SmallVec<[SupportInterval; 4]> = SmallVec::new();
    let mut count = start.len() as i32;
    let mut prev_x = x_lo;
    let mut prev_ab = start.first().copied();
    for &(x, delta, ab) in &events {
        if count > 0 && x > prev_x {
            intervals.push(SupportInterval {
                x0: prev_x,
                x1: x,
                multiplicity: count as u32,
                ends: [prev_ab, Some(ab)],
                folds: [false; 2],
            });
        }
        count += delta;
        if count < 0 {
            consistent = false;
        }
        prev_x = x;
        prev_ab = Some(ab);
    }
    if count > 0 && x_hi > prev_x {
        intervals.push(SupportInterval {
            x0: prev_x,
            x1: x_hi,
            multiplicity: count as u32,
            ends: [prev_ab, end.first().copied()],
            folds: [false; 2],
        });
    }
    if count != end.len() as i32 {
        // The end solve may have missed a solution whose Newton basin is small (V close to the
        // triangle's plane): follow the curve from the last event to the end before giving up.
        let followed = events
            .last()
            .and_then(|&(x, _, ab)| follow_curve(c, x, ab, x_hi, settings, interior));
        match followed {
            Some(ab) if count == end.len() as i32 + 1 => {
                if let Some(last) = intervals.last_mut() {
                    last.ends[1] = Some(ab);
                }
            }
            _ => consistent = false,
        }
    }
    if consistent {
        return Support {
            intervals,
            consistent,
        };
    }
    // Fallback: the curve folds back in x inside the triangle. Trace every branch from its event
    // (or from a solution at a range end) into the triangle by continuation, up to the next event
    // or to the fold, located by bisection.
    let mut anchors: SmallVec<[(f64, f64, DVec2); 8]> = SmallVec::new();
    for &(x, delta, ab) in &events {
        match delta {
            1 => anchors.push((x, 1.0, ab)),
            -1 => anchors.push((x, -1.0, ab)),
            _ => {
                anchors.push((x, 1.0, ab));
                anchors.push((x, -1.0, ab));
            }
        }
    }
    // A branch through a range end starts exactly there when the solve at the end converges
    // (else at the inset, 1e-7 of the range short): the pieces of a split then tile the segment.
    let at_end = |x_end: f64, x_in: f64, ab: DVec2, counters: &mut NewtonCounters| {
        solve_interior(c, x_end, ab, settings, counters)
            .filter(|&e| inside_triangle(e) && is_physical(c, x_end, e))
            .map_or((x_in, ab), |e| (x_end, e))
    };
    for &ab in &start {
        let (x, ab) = at_end(x_lo, xs, ab, interior);
        anchors.push((x, 1.0, ab));
    }
    for &ab in &end {
        let (x, ab) = at_end(x_hi, xe, ab, interior);
        anchors.push((x, -1.0, ab));
    }
    let mut intervals: SmallVec<[SupportInterval; 4]> = SmallVec::new();
    let mut consumed: SmallVec<[bool; 8]> = smallvec::smallvec![false; anchors.len()];
    for i in 0..anchors.len() {
        if consumed[i] {
            continue;
        }
        let (x0, dir, ab0) = anchors[i];
        let limit = if dir > 0.0 { x_hi } else { x_lo };
        let Some(b) = trace_branch(c, x0, ab0, limit, settings, interior) else {
            continue;
        };
        // A branch that reaches another anchor from the opposite side is the same branch.
        let mut end_x = b.x;
        let mut end_ab = b.ab;
        let mut fold = b.fold;
        if let Some(j) = (0..anchors.len()).find(|&j| {
            j != i
                && !consumed[j]
                && anchors[j].1 == -dir
                && (anchors[j].0 - b.x).abs() <= 1e-6 * (x_hi - x_lo)
                && (anchors[j].2 - b.ab).length() < 1e-3
        }) {
            consumed[j] = true;
            end_x = anchors[j].0;
            end_ab = anchors[j].2;
            fold = false;
        }
        if (end_x - x0).abs() == 0.0 {
            continue;
        }
        let (lo, hi, ends, folds) = if dir > 0.0 {
            (x0, end_x, [Some(ab0), Some(end_ab)], [false, fold])
        } else {
            (end_x, x0, [Some(end_ab), Some(ab0)], [fold, false])
        };
        intervals.push(SupportInterval {
            x0: lo,
            x1: hi,
            multiplicity: 1,
            ends,
            folds,
        });
    }
    Support {
        intervals: merge_branches(c, intervals, settings, interior),
        consistent: false,
    }
}

/// Merges traced pieces that follow the same branch of the solution curve. Tracing starts from every
/// anchor, and anchors that lie on one branch (several events along a branch that runs on an edge,
/// or a range-end solution and an event) give overlapping pieces of it: a piece that starts inside
/// another is the same branch when continuation along the other reaches its start solution.
fn merge_branches(
    c: &Constraint,
    mut pieces: SmallVec<[SupportInterval; 4]>,
    settings: &NewtonSettings,
    counters: &mut NewtonCounters,
) -> SmallVec<[SupportInterval; 4]> {
    pieces.sort_by(|a, b| a.x0.total_cmp(&b.x0));
    let mut out: SmallVec<[SupportInterval; 4]> = SmallVec::new();
    'next: for p in pieces {
        for q in out.iter_mut() {
            if !(p.x0 >= q.x0 && p.x0 <= q.x1) {
                continue;
            }
            let (Some(q_start), Some(p_start)) = (q.ends[0], p.ends[0]) else {
                continue;
            };
            let same = if p.x0 == q.x0 {
                (q_start - p_start).length() < 1e-6
            } else {
                trace_branch(c, q.x0, q_start, p.x0, settings, counters)
                    .is_some_and(|b| b.x == p.x0 && (b.ab - p_start).length() < 1e-6)
            };
            if same {
                if p.x1 > q.x1 {
                    q.x1 = p.x1;
                    q.ends[1] = p.ends[1];
                    q.folds[1] = p.folds[1];
                }
                continue 'next;
            }
        }
        out.push(p);
    }
    out
}

/// Where a traced branch ends.
#[derive(Debug, Clone, Copy)]
struct BranchEnd {
    x: f64,
    ab: DVec2,
    fold: bool,
}

/// Follows the solution curve from (x0, ab0) towards `limit` by continuation until it leaves the
/// triangle (end: the last point inside, refined by bisection), reaches `limit`, or stops existing
/// (a fold, located by bisection to 1e-9 of the range).
fn trace_branch(
    c: &Constraint,
    x0: f64,
    ab0: DVec2,
    limit: f64,
    settings: &NewtonSettings,
    counters: &mut NewtonCounters,
) -> Option<BranchEnd> {
    let span = limit - x0;
    if span == 0.0 {
        return None;
    }
    let min_step = 1e-9 * span.abs();
    let mut h = span / 16.0;
    let (mut x, mut ab) = (x0, ab0);
    let mut steps = 0;
    loop {
        steps += 1;
        if steps > 400 {
            return Some(BranchEnd { x, ab, fold: false });
        }
        let xn = if (x + h - x0).abs() >= span.abs() {
            limit
        } else {
            x + h
        };
        match solve_interior(c, xn, ab, settings, counters) {
            Some(abn) if inside_triangle(abn) && is_physical(c, xn, abn) => {
                x = xn;
                ab = abn;
                if x == limit {
                    return Some(BranchEnd { x, ab, fold: false });
                }
            }
            outcome => {
                if h.abs() <= min_step {
                    // Still inside and no solution ahead: a fold; a solution outside: an edge.
                    return Some(BranchEnd {
                        x,
                        ab,
                        fold: outcome.is_none(),
                    });
                }
                h *= 0.5;
            }
        }
    }
}
