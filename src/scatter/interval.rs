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
    edge_crossings, inside_triangle, pinv_solve, solve_interior, straight_line_seed, EdgeCrossing,
    NewtonCounters, NewtonSettings,
};

/// Seeds for interior solves without a better guess: the centroid, then the centroids of the corner
/// sub-triangles.
pub const SEEDS: [DVec2; 4] = [
    DVec2::new(1.0 / 3.0, 1.0 / 3.0),
    DVec2::new(2.0 / 3.0, 1.0 / 6.0),
    DVec2::new(1.0 / 6.0, 2.0 / 3.0),
    DVec2::new(1.0 / 6.0, 1.0 / 6.0),
];

/// The straight-line seed at `x` (see [`straight_line_seed`]) followed by [`SEEDS`].
pub fn seeds_at(c: &Constraint, x: f64) -> SmallVec<[DVec2; 6]> {
    let mut s: SmallVec<[DVec2; 6]> = SmallVec::new();
    s.extend(straight_line_seed(c, x));
    s.extend(SEEDS);
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

/// Interior solutions inside the triangle at `x`: the first seed that converges decides (a small
/// triangle holds at most one solution away from caustics); with `all`, every seed is tried and
/// distinct solutions are collected.
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
            if inside_triangle(ab) && out.iter().all(|q| (*q - ab).length() > 1e-7) {
                out.push(ab);
            }
            if !all {
                break;
            }
        }
    }
    out
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
    let start = solutions_at(c, x_lo, &seeds_at(c, x_lo), false, settings, interior);
    let end = solutions_at(c, x_hi, &seeds_at(c, x_hi), false, settings, interior);
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
        });
    }
    if count != end.len() as i32 {
        consistent = false;
    }
    if consistent {
        return Support {
            intervals,
            consistent,
        };
    }
    // Fallback: the hull of everything found, open towards an end where the counts say a branch
    // may continue.
    let first_is_upper = events.first().is_some_and(|e| e.1 <= 0);
    let last_is_lower = events.last().is_some_and(|e| e.1 >= 0);
    let lo = if !start.is_empty() || first_is_upper {
        x_lo
    } else {
        events.first().map_or(x_lo, |e| e.0)
    };
    let hi = if !end.is_empty() || last_is_lower {
        x_hi
    } else {
        events.last().map_or(x_hi, |e| e.0)
    };
    let mut intervals = SmallVec::new();
    if hi > lo {
        intervals.push(SupportInterval {
            x0: lo,
            x1: hi,
            multiplicity: 2,
            ends: [None, None],
        });
    }
    Support {
        intervals,
        consistent: false,
    }
}
