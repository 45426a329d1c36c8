//! Integration across a fold of the solution curve (a caustic of the refracted light crossing the
//! eye segment) in the curve's own parameter.
//!
//! At a fold two branches of the solution curve meet: x(s) along the curve has an extremum there,
//! and the contribution, as a density in x, has a 1/√|x − x_fold| singularity. Integrating each
//! branch in x needs the fold's x to relative accuracy δ with an error ~√(δ / width): the 1e-9
//! bisection of the tracing gave 1e-3 of a fold piece, and even the last bit of x (1e-16) would
//! leave ~1e-7. The two branches together form one smooth arc of the curve, though, and in a
//! parameter s along that arc the integrand F(x(s)) |dx/ds| is smooth and finite through the
//! fold (F ~ 1/D, and D and dx/ds vanish linearly together there). So the two pieces that end at
//! one fold are integrated as one arc, from the regular end of one to the regular end of the other,
//! and where exactly the fold lies no longer matters.
//!
//! The arc is parametrized along the chord between its two regular ends in (α, β):
//! (α, β)(s, ν) = A + s (B − A) + ν n, with n the unit normal of the chord; at each s the solve is
//! for (x, ν) (Newton with the 3x2 pseudo-inverse, as on an edge), which stays well-conditioned at
//! the fold, where the fixed-x solve is singular. The chord parametrization requires the arc to be
//! a graph over its chord (a curve within one triangle is nearly straight); continuation checks it,
//! and the caller integrates the pieces separately when it fails.
//!
//! The same arc integration serves a fold whose other branch the edge scan missed (the arc is
//! followed through the fold until the other branch leaves the triangle or the range, the exit
//! located by bisection on s), and the fold-free pieces of a triangle whose analysis fell back to
//! tracing (near a fold, a fixed-x solve per node can land on the other branch).

use glam::DVec2;

use super::constraint::{Constraint, ConstraintValue};
use super::contribution::{path_contribution, Medium};
use super::interval::{is_physical, Ownership, SupportInterval};
use super::newton::{inside_triangle, pinv_solve, polish_steps, precision_floor, NewtonSettings};
use super::options::ScatterOptions;
use super::quadrature::{self, Adaptive};
use super::stats::ScatterStats;

/// Continuation steps that trace the arc before its quadrature (their solutions seed the nodes).
const TRACE_STEPS: usize = 32;

/// The chord parametrization of an arc between two known solutions.
#[derive(Debug, Clone, Copy)]
struct Chord {
    a: DVec2,
    d: DVec2,
    n: DVec2,
}

impl Chord {
    fn at(&self, s: f64, nu: f64) -> DVec2 {
        self.a + s * self.d + nu * self.n
    }
}

/// A point of the arc: x, the chord offset ν, the barycentric point and dx/ds.
#[derive(Debug, Clone, Copy)]
struct ArcPoint {
    x: f64,
    nu: f64,
    ab: DVec2,
    dx_ds: f64,
}

/// Solves f(x, chord(s, ν)) = 0 for (x, ν) from a guess.
fn solve_at(
    c: &Constraint,
    chord: &Chord,
    s: f64,
    (x0, nu0): (f64, f64),
    settings: &NewtonSettings,
    stats: &mut ScatterStats,
) -> Option<ArcPoint> {
    let k = &mut stats.interior;
    k.solves += 1;
    let (mut x, mut nu) = (x0, nu0);
    let mut v = c.eval(x, chord.at(s, nu), true)?;
    let mut r = v.f.length();
    for it in 0..=settings.max_iterations {
        let j = v.jacobian;
        let jn = j.y_axis * chord.n.x + j.z_axis * chord.n.y;
        let converged = r
            <= settings
                .tolerance
                .max(precision_floor(c, x, chord.at(s, nu)));
        if converged {
            let js = j.y_axis * chord.d.x + j.z_axis * chord.d.y;
            let dx_ds = pinv_solve(j.x_axis, jn, -js)?.x;
            return Some(ArcPoint {
                x,
                nu,
                ab: chord.at(s, nu),
                dx_ds,
            });
        }
        if it == settings.max_iterations {
            break;
        }
        k.iterations += 1;
        let step = pinv_solve(j.x_axis, jn, v.f)?;
        let mut scale = 1.0;
        let mut accepted = None;
        for _ in 0..9 {
            let (xc, nc) = (x - scale * step.x, nu - scale * step.y);
            if let Some(vc) = c.eval(xc, chord.at(s, nc), true) {
                let rc = vc.f.length();
                if rc < r {
                    accepted = Some((xc, nc, vc, rc));
                    break;
                }
            }
            scale *= 0.5;
        }
        let (xc, nc, vc, rc) = accepted?;
        // Further than a triangle from the chord: not this arc.
        if nc.abs() > 1.0 {
            return None;
        }
        (x, nu, v, r) = (xc, nc, vc, rc);
    }
    k.failures += 1;
    None
}

/// Up to three more Newton steps in (x, ν) from a converged arc point, each kept only if it lowers
/// |f|; quadratic convergence takes the 1e-10 residual of a converged solve to the rounding floor.
/// That residual leaves x off by ~1e-10 (absolute): where the point locates an arc's exit from the
/// x range it moved the end of the quadrature by up to 1e-8 of a short piece, and at the quadrature
/// nodes it biased a whole fold arc by 3e-9 (same-signed errors, not noise), so that the same
/// support integrated as one arc or as an arc plus x pieces disagreed (issue 19).
fn polish_at(c: &Constraint, chord: &Chord, s: f64, pt: ArcPoint) -> ArcPoint {
    let Some(v) = c.eval(pt.x, pt.ab, true) else {
        return pt;
    };
    let across =
        |v: &ConstraintValue, dir: DVec2| v.jacobian.y_axis * dir.x + v.jacobian.z_axis * dir.y;
    polish_steps(
        pt,
        v,
        |pt, v| {
            let step = pinv_solve(v.jacobian.x_axis, across(v, chord.n), v.f)?;
            let (x, nu) = (pt.x - step.x, pt.nu - step.y);
            Some(ArcPoint {
                x,
                nu,
                ab: chord.at(s, nu),
                dx_ds: pt.dx_ds,
            })
        },
        |pt| {
            let v = c.eval(pt.x, pt.ab, true)?;
            let dx = pinv_solve(v.jacobian.x_axis, across(&v, chord.n), -across(&v, chord.d))?;
            pt.dx_ds = dx.x;
            Some(v)
        },
    )
}

/// The solution at the fold-free end of a piece that ends at a fold on one side.
fn regular_end(p: &SupportInterval) -> Option<(f64, DVec2)> {
    match p.folds {
        [true, false] => Some((p.x1, p.ends[1]?)),
        [false, true] => Some((p.x0, p.ends[0]?)),
        _ => None,
    }
}

/// The fold end (x, (α, β)) of a piece, and whether it is its start.
fn fold_end(p: &SupportInterval) -> Option<(f64, DVec2, bool)> {
    match p.folds {
        [true, false] => Some((p.x0, p.ends[0]?, true)),
        [false, true] => Some((p.x1, p.ends[1]?, false)),
        _ => None,
    }
}

/// Pairs of pieces (indices into `pieces`) that end at the same fold: the two branches meeting
/// there. A fold located from both branches agrees to the tracing's bisection (1e-9 of the range in
/// x, ~3e-5 in (α, β) at the square-root fold).
pub(crate) fn fold_pairs(pieces: &[SupportInterval], range: (f64, f64)) -> Vec<(usize, usize)> {
    let tol_x = 1e-6 * (range.1 - range.0);
    let mut used = vec![false; pieces.len()];
    let mut out = Vec::new();
    for i in 0..pieces.len() {
        let Some((xi, abi, si)) = fold_end(&pieces[i]) else {
            continue;
        };
        if used[i] || regular_end(&pieces[i]).is_none() {
            continue;
        }
        let partner = (i + 1..pieces.len()).find(|&j| {
            !used[j]
                && regular_end(&pieces[j]).is_some()
                && fold_end(&pieces[j]).is_some_and(|(xj, abj, sj)| {
                    sj == si && (xj - xi).abs() <= tol_x && (abj - abi).length() < 1e-3
                })
        });
        if let Some(j) = partner {
            used[i] = true;
            used[j] = true;
            out.push((i, j));
        }
    }
    out
}

/// ∫ over the arc through the fold shared by `p` and `q` of the contribution, in the arc parameter;
/// `None` when the arc cannot be followed along its chord (the caller then integrates the pieces
/// separately).
#[allow(clippy::too_many_arguments)]
pub(crate) fn integrate_fold_pair(
    c: &Constraint,
    p: &SupportInterval,
    q: &SupportInterval,
    range: (f64, f64),
    own: Ownership,
    intensity: f64,
    medium: &Medium,
    options: &ScatterOptions,
    stats: &mut ScatterStats,
    paths: &mut u64,
) -> Option<f64> {
    let (xa, a) = regular_end(p)?;
    let (xb, b) = regular_end(q)?;
    integrate_between(
        c,
        (xa, a),
        (xb, b),
        range,
        own,
        intensity,
        medium,
        options,
        stats,
        paths,
    )
}

/// ∫ over a fold-free piece of a triangle whose analysis fell back to tracing, along the arc
/// between its two end solutions: near a fold the two branches are close and a fixed-x solve per
/// node can land on the other one (one branch counted twice, one missed: 5e-8 of a triangle),
/// while the chord parameter pins the place along this branch. `None` when the arc cannot be
/// followed (the caller integrates in x).
#[allow(clippy::too_many_arguments)]
pub(crate) fn integrate_piece_along_arc(
    c: &Constraint,
    p: &SupportInterval,
    range: (f64, f64),
    own: Ownership,
    intensity: f64,
    medium: &Medium,
    options: &ScatterOptions,
    stats: &mut ScatterStats,
    paths: &mut u64,
) -> Option<f64> {
    if p.folds != [false, false] || p.multiplicity != 1 {
        return None;
    }
    let (a, b) = (p.ends[0]?, p.ends[1]?);
    integrate_between(
        c,
        (p.x0, a),
        (p.x1, b),
        range,
        own,
        intensity,
        medium,
        options,
        stats,
        paths,
    )
}

/// The arc from the solution (x_a, a) to the solution (x_b, b), traced along their chord and
/// integrated in the chord parameter; `None` if the trace does not arrive at B.
#[allow(clippy::too_many_arguments)]
fn integrate_between(
    c: &Constraint,
    (xa, a): (f64, DVec2),
    (xb, b): (f64, DVec2),
    range: (f64, f64),
    own: Ownership,
    intensity: f64,
    medium: &Medium,
    options: &ScatterOptions,
    stats: &mut ScatterStats,
    paths: &mut u64,
) -> Option<f64> {
    let arc = trace_arc(c, (xa, a), b - a, 1.0, range, options, stats)?;
    let &(s_end, x_end, nu_end) = arc.last()?;
    if s_end != 1.0 || (x_end - xb).abs() > 1e-6 * (range.1 - range.0) || nu_end.abs() > 1e-6 {
        return None;
    }
    integrate_arc(
        c,
        a,
        b - a,
        &arc,
        range,
        own,
        intensity,
        medium,
        options,
        stats,
        paths,
    )
}

/// ∫ over the arc from the regular end of `p` through its fold and along the other branch until
/// that leaves the triangle or the range: for a fold whose other branch the edge scan missed (both
/// its crossings of one edge fell between two scan points). The chord runs to the mirror image of
/// the regular end through the fold (where a parabolic fold puts the other branch at the same x)
/// and beyond. `None` when the arc does not leave within three chord lengths or cannot be followed.
#[allow(clippy::too_many_arguments)]
pub(crate) fn integrate_lone_fold(
    c: &Constraint,
    p: &SupportInterval,
    range: (f64, f64),
    own: Ownership,
    intensity: f64,
    medium: &Medium,
    options: &ScatterOptions,
    stats: &mut ScatterStats,
    paths: &mut u64,
) -> Option<f64> {
    let (xa, a) = regular_end(p)?;
    let (_, f, _) = fold_end(p)?;
    let d = 2.0 * (f - a);
    let arc = trace_arc(c, (xa, a), d, 3.0, range, options, stats)?;
    let &(s_end, _, _) = arc.last()?;
    if !(s_end > 0.5 && s_end < 3.0) {
        return None;
    }
    integrate_arc(
        c, a, d, &arc, range, own, intensity, medium, options, stats, paths,
    )
}

/// Follows the arc from (x_a, a) along the chord direction `d` for s in [0, s_max] by
/// continuation; where it leaves the triangle or the x range (or stops being solvable), the exit
/// is located by bisection on s and ends the arc. Returns the (s, x, ν) of the continuation steps.
fn trace_arc(
    c: &Constraint,
    (xa, a): (f64, DVec2),
    d: DVec2,
    s_max: f64,
    range: (f64, f64),
    options: &ScatterOptions,
    stats: &mut ScatterStats,
) -> Option<Vec<(f64, f64, f64)>> {
    let len = d.length();
    if !(len > 1e-9) {
        return None;
    }
    let chord = Chord {
        a,
        d,
        n: DVec2::new(-d.y, d.x) / len,
    };
    let settings = &options.newton;
    let span = range.1 - range.0;
    let valid = |pt: &ArcPoint, slack: f64| {
        inside_triangle_loose(pt.ab) && pt.x >= range.0 - slack && pt.x <= range.1 + slack
    };
    // The last step may overshoot a range end by the solves' error in x (a 1e-10 residual moves x
    // by up to ~1e-9 of the distances involved, more than a rounding of a short range): an arc
    // that ends exactly at a range end must arrive. Exits inside are located exactly (nodes beyond
    // the range contribute nothing).
    let end_slack = 1e-6 * span;
    let steps = (TRACE_STEPS as f64 * s_max).ceil() as usize;
    let mut trace: Vec<(f64, f64, f64)> = Vec::with_capacity(steps + 1);
    trace.push((0.0, xa, 0.0));
    for k in 1..=steps {
        let s = s_max * k as f64 / steps as f64;
        let &(s0, x, nu) = trace.last()?;
        let slack = if k == steps { end_slack } else { 0.0 };
        match solve_at(c, &chord, s, (x, nu), settings, stats) {
            Some(pt) if valid(&pt, slack) => trace.push((s, pt.x, pt.nu)),
            _ => {
                // Bisect for the exit between the last valid step and this one.
                let (mut lo, mut hi) = (s0, s);
                let mut last = (s0, x, nu);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if !(mid > lo && mid < hi) {
                        break;
                    }
                    let pt = solve_at(c, &chord, mid, (last.1, last.2), settings, stats)
                        .map(|pt| polish_at(c, &chord, mid, pt));
                    match pt {
                        Some(pt) if valid(&pt, 0.0) && inside_triangle(pt.ab) => {
                            lo = mid;
                            last = (mid, pt.x, pt.nu);
                        }
                        _ => hi = mid,
                    }
                }
                if last.0 > s0 {
                    trace.push(last);
                }
                return Some(trace);
            }
        }
    }
    Some(trace)
}

/// The adaptive quadrature of F(x(s)) |dx/ds| over the traced arc's s range.
#[allow(clippy::too_many_arguments)]
fn integrate_arc(
    c: &Constraint,
    a: DVec2,
    d: DVec2,
    trace: &[(f64, f64, f64)],
    range: (f64, f64),
    own: Ownership,
    intensity: f64,
    medium: &Medium,
    options: &ScatterOptions,
    stats: &mut ScatterStats,
    paths: &mut u64,
) -> Option<f64> {
    let len = d.length();
    let chord = Chord {
        a,
        d,
        n: DVec2::new(-d.y, d.x) / len,
    };
    let settings = &options.newton;
    let s_end = trace.last()?.0;
    if trace.len() < 2 || !(s_end > 0.0) {
        return None;
    }
    let guess = |s: f64| -> (f64, f64) {
        let k = trace
            .partition_point(|t| t.0 <= s)
            .clamp(1, trace.len() - 1);
        let (s0, x0, n0) = trace[k - 1];
        let (s1, x1, n1) = trace[k];
        let t = (s - s0) / (s1 - s0);
        (x0 + t * (x1 - x0), n0 + t * (n1 - n0))
    };
    let adaptive = Adaptive {
        relative: options.tolerance,
        absolute: 0.0,
        max_intervals: options.max_subintervals,
    };
    let mut failed = false;
    let (sum, _, intervals) = quadrature::integrate(0.0, s_end, &adaptive, |ss, values| {
        for (k, &s) in ss.iter().enumerate() {
            stats.samples += 1;
            values[k] = 0.0;
            let Some(pt) = solve_at(c, &chord, s, guess(s), settings, stats)
                .map(|pt| polish_at(c, &chord, s, pt))
            else {
                failed = true;
                continue;
            };
            let counts = pt.x >= range.0
                && pt.x <= range.1
                && own.accepts(pt.ab)
                && is_physical(c, pt.x, pt.ab);
            if !counts {
                continue;
            }
            if let Some(path) = path_contribution(
                c.tri,
                pt.ab,
                c.eye,
                pt.x,
                c.light,
                intensity,
                medium,
                options.distance_factor,
            ) {
                values[k] = path.value * pt.dx_ds.abs();
                stats.paths += 1;
                *paths += 1;
            }
        }
    });
    stats.subintervals += intervals as u64;
    (!failed).then_some(sum)
}

/// The triangle widened by 1e-9: the arc's ends lie on its edges up to the edge solve's accuracy.
fn inside_triangle_loose(ab: DVec2) -> bool {
    inside_triangle(ab) || (ab.x >= -1e-9 && ab.y >= -1e-9 && ab.x + ab.y <= 1.0 + 1e-9)
}

#[cfg(test)]
mod tests;
