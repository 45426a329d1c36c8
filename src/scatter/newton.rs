//! Newton iterations with the pseudo-inverse on the refraction constraint: the interior solve for
//! (α, β) at fixed x, and the edge solve for (x, t) on one triangle edge (report sec. 3.1.1, 3.2.2).
//!
//! Both solve an over-determined 3x2 system J δ = f with the pseudo-inverse (JᵀJ)⁻¹Jᵀ (the report's
//! eq. 3 drops the transpose on the right). Differences from the Mitsuba plugin, chosen by measurement
//! (see `tests/scatter_newton.rs` and the README):
//! * Convergence is |f| ≤ `tolerance` (default 1e-10, for both solves) instead of 1e-6 / 1e-3: the
//!   iteration converges quadratically, so the tighter tolerance costs about one iteration more, and
//!   the D factor (a derivative of the solution) needs the accuracy.
//! * Step control: an interior step is limited to half a triangle (a trust region: far from the
//!   solution f flattens out and a full Gauss-Newton step can leap anywhere), and a step that does
//!   not decrease |f| is halved (up to 8 times); an interior iterate
//!   that wanders more than one triangle away is abandoned. Edge solves are bracketed by a sign
//!   change of the coplanarity function g(t) (below) and fall back to bisection of that bracket
//!   whenever a Newton step leaves it or does not decrease |f|, so they cannot diverge.
//! * The residual floor of double precision grows as V approaches P (ω_V turns by ε|P|/|V − P| per
//!   rounding of P): the convergence test is |f| ≤ max(tolerance, [`precision_floor`]), which only
//!   matters within ~1e-5 (relative) of the surface, e.g. at the eye segment's ends.
//! * A singular normal matrix (det(JᵀJ) ≤ 1e-13 ‖J‖⁴), a non-finite value or an exhausted iteration
//!   budget (default 24) ends the solve as a failure: no NaN can escape.

use glam::{DVec2, DVec3};

use super::constraint::{refract_in, Constraint, ConstraintValue};

/// Iteration caps and tolerances of the Newton solves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    /// Maximum Newton iterations per interior solve.
    pub max_iterations: u32,
    /// Maximum iterations (Newton or bisection) per edge solve.
    pub max_edge_iterations: u32,
    /// Convergence threshold on |f| (dimensionless: f is the tangential part of η ω_V + ω_L).
    pub tolerance: f64,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        NewtonSettings {
            max_iterations: 24,
            max_edge_iterations: 64,
            tolerance: 1e-10,
        }
    }
}

/// Counters a solve adds to.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NewtonCounters {
    /// Solves started.
    pub solves: u64,
    /// Iterations (evaluations of f with its Jacobian).
    pub iterations: u64,
    /// Solves that ended without converging (no solution near the seed, or a singular system).
    pub failures: u64,
}

/// Solves the 3x2 least-squares system [a b] δ ≈ f through the normal equations. `None` if singular.
#[inline]
pub(crate) fn pinv_solve(a: DVec3, b: DVec3, f: DVec3) -> Option<DVec2> {
    let (g11, g12, g22) = (a.dot(a), a.dot(b), b.dot(b));
    let det = g11 * g22 - g12 * g12;
    if !(det > 1e-13 * g11 * g22) || !det.is_finite() {
        return None;
    }
    let (r1, r2) = (a.dot(f), b.dot(f));
    let d = DVec2::new(g22 * r1 - g12 * r2, g11 * r2 - g12 * r1) / det;
    d.is_finite().then_some(d)
}

/// A first guess for the interior solve at `x`: where the straight line from the light to V(x) meets
/// the triangle's plane (the refraction point lies near it, and between the feet of L and V), clamped
/// to one triangle around the triangle. `None` if the line is parallel to the plane.
pub fn straight_line_seed(c: &Constraint, x: f64) -> Option<DVec2> {
    let v = c.eye.at(x);
    let n = c.tri.geometric_normal;
    let d = v - c.light;
    let denom = d.dot(n);
    if denom == 0.0 {
        return None;
    }
    let s = (c.tri.p0 - c.light).dot(n) / denom;
    let p = c.light + s * d - c.tri.p0;
    let (e1, e2) = (c.tri.e1, c.tri.e2);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (r1, r2) = (p.dot(e1), p.dot(e2));
    let det = d11 * d22 - d12 * d12;
    let ab = DVec2::new(d22 * r1 - d12 * r2, d11 * r2 - d12 * r1) / det;
    ab.is_finite()
        .then(|| ab.clamp(DVec2::splat(-1.0), DVec2::splat(2.0)))
}

/// The barycentric coordinates of the orthogonal projection of V(x) on the triangle's plane: the
/// refraction point tends to it as V approaches the surface (where the straight-line seed is poor
/// and the Newton basin small). Clamped like [`straight_line_seed`].
pub fn foot_seed(c: &Constraint, x: f64) -> Option<DVec2> {
    let p = c.eye.at(x) - c.tri.p0;
    let (e1, e2) = (c.tri.e1, c.tri.e2);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (r1, r2) = (p.dot(e1), p.dot(e2));
    let det = d11 * d22 - d12 * d12;
    let ab = DVec2::new(d22 * r1 - d12 * r2, d11 * r2 - d12 * r1) / det;
    ab.is_finite()
        .then(|| ab.clamp(DVec2::splat(-1.0), DVec2::splat(2.0)))
}

/// Solutions this close to a boundary feature (in barycentric coordinates, i.e. relative to the
/// triangle's size) lie on it: an edge or a vertex shared by several triangles, whose paths only its
/// owner counts ([`Ownership`](super::interval::Ownership)). A polished solution ([`polish`]) is within ~1e-14
/// of its true coordinates, and a generic solution falls within the band only on a set of x of
/// relative measure ~1e-12.
pub const BOUNDARY: f64 = 1e-12;

/// Whether (α, β) lies in the closed triangle widened by [`BOUNDARY`] (so that a
/// solution on a shared edge or vertex, which rounding may put just outside either triangle, is
/// found by every triangle sharing it; [`super::interval::Ownership`] then counts it once).
#[inline]
pub fn inside_triangle(ab: DVec2) -> bool {
    let d = BOUNDARY;
    ab.x >= -d && ab.y >= -d && ab.x + ab.y <= 1.0 + d
}

/// Interior solve: (α, β) with f(x, α, β) = 0, starting from `seed`. Returns the converged
/// coordinates (possibly outside the triangle: the caller decides) or `None`.
pub fn solve_interior(
    c: &Constraint,
    x: f64,
    seed: DVec2,
    settings: &NewtonSettings,
    counters: &mut NewtonCounters,
) -> Option<DVec2> {
    counters.solves += 1;
    let mut ab = seed;
    let mut value = match c.eval(x, ab, true) {
        Some(v) => v,
        None => {
            counters.failures += 1;
            return None;
        }
    };
    let mut r = value.f.length();
    for _ in 0..settings.max_iterations {
        if r <= settings.tolerance.max(precision_floor(c, x, ab)) {
            // One more full step, kept if it lowers |f|: the quadratic convergence takes the
            // residual to the rounding floor for one evaluation (the tangential constraint's
            // iterates do not land as deep below the tolerance as the report's ĥ + n_s did).
            let step = pinv_solve(value.jacobian.y_axis, value.jacobian.z_axis, value.f);
            if let Some(cand) = step.map(|s| ab - s) {
                if c.eval(x, cand, false).is_some_and(|v| v.f.length() < r) {
                    return Some(cand);
                }
            }
            return Some(ab);
        }
        counters.iterations += 1;
        let j = value.jacobian;
        let Some(step) = pinv_solve(j.y_axis, j.z_axis, value.f) else {
            break;
        };
        // Trust region: at most half a triangle per step. Far from the solution f flattens out
        // (|f| → √2 as P → ∞) and a full Gauss-Newton step can leap arbitrarily far.
        let mut scale = (0.5 / step.length()).min(1.0);
        let mut accepted = None;
        for _ in 0..9 {
            let cand = ab - scale * step;
            if let Some(v) = c.eval(x, cand, true) {
                let rc = v.f.length();
                if rc < r {
                    accepted = Some((cand, v, rc));
                    break;
                }
            }
            scale *= 0.5;
        }
        let Some((cand, v, rc)) = accepted else {
            break;
        };
        // More than a triangle away from the triangle: the solution (if any) belongs elsewhere.
        if cand.x < -1.0 || cand.y < -1.0 || cand.x + cand.y > 2.0 {
            break;
        }
        ab = cand;
        value = v;
        r = rc;
    }
    if r <= settings.tolerance.max(precision_floor(c, x, ab)) {
        return Some(ab);
    }
    counters.failures += 1;
    None
}

/// Up to three more full Newton steps from a converged solution, each kept only if it lowers |f|:
/// quadratic convergence takes a 1e-10 residual to the rounding floor, so that the solution's
/// distance to an edge is known to ~1e-13 of the triangle's size (ownership of shared edges).
pub fn polish(c: &Constraint, x: f64, ab: DVec2) -> DVec2 {
    let Some(v) = c.eval(x, ab, true) else {
        return ab;
    };
    polish_steps(
        ab,
        v,
        |ab, v| pinv_solve(v.jacobian.y_axis, v.jacobian.z_axis, v.f).map(|step| *ab - step),
        |ab| c.eval(x, *ab, true),
    )
}

/// The polishing loop shared by every solve: up to three Newton steps from a converged `point`
/// with constraint value `value`, each kept only if it lowers |f|. `step` proposes the Newton
/// candidate (`None` stops); `eval` evaluates a candidate, completing any fields derived from its
/// value (`None` stops).
pub(crate) fn polish_steps<P>(
    mut point: P,
    mut value: ConstraintValue,
    mut step: impl FnMut(&P, &ConstraintValue) -> Option<P>,
    mut eval: impl FnMut(&mut P) -> Option<ConstraintValue>,
) -> P {
    for _ in 0..3 {
        let r = value.f.length();
        let Some(mut candidate) = step(&point, &value) else {
            break;
        };
        match eval(&mut candidate) {
            Some(v) if v.f.length() < r => {
                point = candidate;
                value = v;
            }
            _ => break,
        }
    }
    point
}

/// The smallest |f| double precision can resolve at (x, α, β): rounding P and V (or L) by ε times
/// the magnitudes they are computed from turns ω_V by that over |V − P|, and the residual floor is a
/// small multiple of it.
/// It exceeds the tolerance only when V (or L) is within ~1e-5 of the triangle's size of P, as at
/// an eye segment's end on the mesh.
pub fn precision_floor(c: &Constraint, x: f64, ab: DVec2) -> f64 {
    let p = c.tri.point(ab);
    let v = c.eye.at(x);
    let near = (v - p).length().min((c.light - p).length());
    // P = P0 + α e1 + β e2 and V = origin + x u are rounded at the magnitudes of their terms (a
    // large triangle's vertices and edges, not the small P they may add up to).
    let t = c.tri;
    let magnitude = t.p0.abs().max_element()
        + ab.x.abs() * t.e1.abs().max_element()
        + ab.y.abs() * t.e2.abs().max_element()
        + c.eye.origin.abs().max_element()
        + x.abs()
        + c.light.abs().max_element();
    64.0 * f64::EPSILON * magnitude / near
}

/// A triangle edge as a segment of the (α, β) plane: (α, β)(t) = start + t dir, t in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// (α, β) at t = 0.
    pub start: DVec2,
    /// d(α, β)/dt.
    pub dir: DVec2,
}

/// The three edges: 0 is P0→P1 (β = 0), 1 is P1→P2 (α + β = 1), 2 is P2→P0 (α = 0).
pub const EDGES: [Edge; 3] = [
    Edge {
        start: DVec2::new(0.0, 0.0),
        dir: DVec2::new(1.0, 0.0),
    },
    Edge {
        start: DVec2::new(1.0, 0.0),
        dir: DVec2::new(-1.0, 1.0),
    },
    Edge {
        start: DVec2::new(0.0, 1.0),
        dir: DVec2::new(0.0, -1.0),
    },
];

impl Edge {
    /// (α, β) at parameter t.
    #[inline]
    pub fn at(&self, t: f64) -> DVec2 {
        self.start + t * self.dir
    }
}

/// Where the refracted ray through the edge point at `t` meets the eye line.
#[derive(Debug, Clone, Copy)]
struct RefractedRay {
    /// Signed coplanarity of the refracted ray and the eye line: det[t̂, u, P − E] (L).
    g: f64,
    /// Eye-line parameter of the closest approach.
    x: f64,
}

fn refracted_ray(c: &Constraint, edge: &Edge, t: f64) -> Option<RefractedRay> {
    let ab = edge.at(t);
    let p = c.tri.point(ab);
    let n = c.tri.raw_normal(ab).try_normalize()?;
    if (c.light - p).dot(c.tri.geometric_normal) <= 0.0 {
        return None;
    }
    let dir = refract_in(p, c.light, n, c.eta)?;
    let u = c.eye.dir;
    let w0 = p - c.eye.origin;
    let g = dir.cross(u).dot(w0);
    let b = dir.dot(u);
    let denom = 1.0 - b * b;
    if !(denom > 1e-14) {
        return None;
    }
    let (d, e) = (dir.dot(w0), u.dot(w0));
    let s = (b * e - d) / denom;
    let x = e + b * s;
    (g.is_finite() && x.is_finite()).then_some(RefractedRay { g, x })
}

/// A point where the solution curve f = 0 crosses a triangle edge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeCrossing {
    /// Eye-segment parameter (L).
    pub x: f64,
    /// Barycentric coordinates of the crossing (on the edge).
    pub ab: DVec2,
    /// Which edge (index into [`EDGES`]).
    pub edge: usize,
}

/// Number of sub-intervals of an edge scanned for sign changes of g before the bracketed solves.
/// Two roots of g within one sub-interval (a crossing and a rejected coplanarity, or the curve
/// entering and leaving through the edge) show no sign change and are both lost: with 6 a branch
/// of 1e-2 of a chord went missing on the bumpy sphere (`tests/scatter_split.rs`); 24 costs no
/// measurable time (g is cheap next to the Newton solves).
pub(crate) const EDGE_SCAN_INTERVALS: usize = 24;

/// All crossings of the solution curve with edge `edge_index` whose x lies in `[x_lo, x_hi]`.
///
/// The edge is scanned at `EDGE_SCAN_INTERVALS` + 1 points for sign changes of the coplanarity of
/// the refracted ray with the eye line; each bracket is solved by safeguarded Newton on (x, t) with
/// the pseudo-inverse of the 3x2 Jacobian [∂f/∂x, ∂f/∂t]. A crossing is kept only if f vanishes
/// (coplanar but parallel or non-intersecting lines are rejected) with V in front of P.
pub fn edge_crossings(
    c: &Constraint,
    edge_index: usize,
    x_lo: f64,
    x_hi: f64,
    settings: &NewtonSettings,
    counters: &mut NewtonCounters,
    out: &mut smallvec::SmallVec<[EdgeCrossing; 6]>,
) {
    let edge = &EDGES[edge_index];
    let n = EDGE_SCAN_INTERVALS;
    let mut prev: Option<(f64, RefractedRay)> = None;
    for k in 0..=n {
        let t = k as f64 / n as f64;
        let cur = refracted_ray(c, edge, t);
        if let (Some((t0, r0)), Some(r1)) = (prev, cur) {
            let straddles = (r0.g <= 0.0) != (r1.g <= 0.0) || r1.g == 0.0;
            if straddles {
                if let Some(cr) = solve_edge(c, edge, (t0, r0), (t, r1), settings, counters) {
                    if cr.x >= x_lo && cr.x <= x_hi {
                        out.push(EdgeCrossing {
                            x: cr.x,
                            ab: edge.at(cr.t),
                            edge: edge_index,
                        });
                    }
                }
            }
        }
        prev = cur.map(|r| (t, r));
    }
}

struct EdgeRoot {
    x: f64,
    t: f64,
}

/// Up to three more Newton steps in (x, t) from a converged edge solve, each kept only if it
/// lowers |f|. A 1e-10 residual leaves the crossing's x off by ~1e-10 (absolute; 1.6e-10 on a
/// 1.7-long segment, issue 19): a piece integrated in x up to that crossing then misses (or adds)
/// F·δx, ~1e-8 of a triangle, while an arc through the same end (`fold.rs`) does not, so the same
/// support split differently disagreed by that much. Quadratic convergence takes it to the floor.
fn polish_edge(c: &Constraint, edge: &Edge, xt: (f64, f64), v: ConstraintValue) -> (f64, f64) {
    polish_steps(
        xt,
        v,
        |&(x, t), v| {
            let j = v.jacobian;
            let jt = j.y_axis * edge.dir.x + j.z_axis * edge.dir.y;
            pinv_solve(j.x_axis, jt, v.f).map(|step| (x - step.x, t - step.y))
        },
        |&mut (x, t)| c.eval(x, edge.at(t), true),
    )
}

fn solve_edge(
    c: &Constraint,
    edge: &Edge,
    (mut lo, r_lo): (f64, RefractedRay),
    (mut hi, r_hi): (f64, RefractedRay),
    settings: &NewtonSettings,
    counters: &mut NewtonCounters,
) -> Option<EdgeRoot> {
    counters.solves += 1;
    let lo_negative = r_lo.g <= 0.0;
    let (mut t, mut x) = if r_hi.g == r_lo.g {
        (0.5 * (lo + hi), 0.5 * (r_lo.x + r_hi.x))
    } else {
        let t = lo + (hi - lo) * r_lo.g / (r_lo.g - r_hi.g);
        (t, r_lo.x + (r_hi.x - r_lo.x) * (t - lo) / (hi - lo))
    };
    for _ in 0..settings.max_edge_iterations {
        counters.iterations += 1;
        let Some(v) = c.eval(x, edge.at(t), true) else {
            break;
        };
        let r = v.f.length();
        let in_range = (-1e-12..=1.0 + 1e-12).contains(&t);
        if r <= settings.tolerance && in_range {
            let (x, t) = polish_edge(c, edge, (x, t), v);
            return accept(c, edge, x, t);
        }
        let j = v.jacobian;
        let jt = j.y_axis * edge.dir.x + j.z_axis * edge.dir.y;
        let mut next = None;
        if let Some(step) = pinv_solve(j.x_axis, jt, v.f) {
            let (xn, tn) = (x - step.x, t - step.y);
            if tn > lo && tn < hi {
                if let Some(vn) = c.eval(xn, edge.at(tn), false) {
                    if vn.f.length() < r {
                        next = Some((xn, tn));
                    }
                }
            }
        }
        let (xn, tn) = match next {
            Some(p) => p,
            None => {
                let tm = 0.5 * (lo + hi);
                let ray = refracted_ray(c, edge, tm)?;
                (ray.x, tm)
            }
        };
        // Keep the bracket around the sign change of g.
        let ray = refracted_ray(c, edge, tn)?;
        if (ray.g <= 0.0) == lo_negative {
            lo = tn;
        } else {
            hi = tn;
        }
        x = xn;
        t = tn;
        if hi - lo <= 4.0 * f64::EPSILON {
            // The bracket collapsed onto a root of g: a true crossing has f ≈ 0 there.
            let v = c.eval(x, edge.at(t), false)?;
            if v.f.length() <= 1e-7 {
                return accept(c, edge, x, t);
            }
            break;
        }
    }
    counters.failures += 1;
    None
}

fn accept(c: &Constraint, edge: &Edge, x: f64, t: f64) -> Option<EdgeRoot> {
    let t = t.clamp(0.0, 1.0);
    let p = c.tri.point(edge.at(t));
    let n = c.tri.raw_normal(edge.at(t)).try_normalize()?;
    let dir = refract_in(p, c.light, n, c.eta)?;
    // V must lie in front of P along the refracted ray, and inside the shading normal: the
    // tangential constraint also vanishes where V sits at the mirror image across the tangent plane.
    let v = c.eye.at(x) - p;
    (dir.dot(v) > 0.0 && v.dot(n) < 0.0).then_some(EdgeRoot { x, t })
}

#[cfg(test)]
mod tests {
    use super::super::constraint::{EyeSegment, TriangleGeometry};
    use super::*;

    #[test]
    fn interior_and_edge_solves_find_the_refraction_point() {
        let tri = TriangleGeometry::new(
            [
                DVec3::new(-1.0, -1.0, 0.0),
                DVec3::new(1.0, -1.0, 0.02),
                DVec3::new(0.0, 1.0, -0.03),
            ],
            [
                DVec3::new(0.1, 0.0, 1.0),
                DVec3::new(-0.1, 0.05, 1.0),
                DVec3::new(0.0, -0.1, 1.0),
            ],
        )
        .unwrap();
        let eye =
            EyeSegment::new(DVec3::new(-2.0, 0.1, -0.5), DVec3::new(2.0, -0.2, -0.7)).unwrap();
        let light = DVec3::new(0.2, 0.1, 3.0);
        let c = Constraint {
            tri: &tri,
            eye: &eye,
            light,
            eta: 1.5,
        };
        let s = NewtonSettings::default();
        let mut k = NewtonCounters::default();
        let ab = solve_interior(&c, 2.0, DVec2::splat(1.0 / 3.0), &s, &mut k).unwrap();
        assert!(c.eval(2.0, ab, false).unwrap().f.length() <= s.tolerance);
        assert!(inside_triangle(ab));
        assert!(k.iterations < 10, "{k:?}");
        let mut out = smallvec::SmallVec::new();
        for e in 0..3 {
            edge_crossings(&c, e, 0.0, eye.length, &s, &mut k, &mut out);
        }
        // The line crosses the triangle's refraction footprint: it enters and leaves once each.
        assert_eq!(out.len(), 2, "{out:?}");
        for cr in &out {
            assert!(c.eval(cr.x, cr.ab, false).unwrap().f.length() < 1e-9);
        }
    }
}
