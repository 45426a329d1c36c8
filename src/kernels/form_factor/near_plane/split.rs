//! The near-plane split: the value of a clipped polygon with `x` near its plane as a sum of
//! small, non-cancelling parts (exact winding number, per-edge deficits, the clip edges in closed
//! form).

use glam::{DVec2, DVec3};
use smallvec::SmallVec;

use crate::kernels::form_factor::clip::{edge_vector, next, ClipVertex};
use crate::kernels::form_factor::edge::{EdgeFrame, ExactEnds, INV_2PI};
use crate::kernels::numeric::dd;

/// Above this ratio of `Σ|edge term|` to `|Σ edge term|` (the sum has lost a bit or more), the
/// value near the plane is recomputed by [`near_plane_value`]; below, the plain sum has lost less
/// than one bit to cancellation.
pub(crate) const NEAR_PLANE_CANCELLATION: f64 = 2.0;

/// Below this `|h_P| / d_e` for every edge not in the tangent plane (x close to the polygon's
/// plane compared with its distance to every such edge line, in the plane), the value is
/// recomputed by [`near_plane_value`]; at or above it for some edge, that function declines.
pub(crate) const NEAR_PLANE_RATIO: f64 = 0.1;

/// Above this ratio of the near-plane split's parts (in magnitude) to its sum,
/// [`evaluate`](crate::kernels::form_factor::robust::evaluate) does not take the split up front for
/// a clipped polygon (the value would keep ~`u` times this ratio): the O(h_P) parts then cancel
/// too, which happens when the visible part is small against its distance from x (the clip line
/// cuts a small corner off the polygon), where the edge sum's derivatives cancel as well and the
/// quadrature takes over. Measured: the walks of `tests/form_factor_near_plane.rs` cancel by 25 to
/// ~150; the accuracy test's worst case (a corner of 1e-12 relative value) by far more.
pub(crate) const SPLIT_CANCELLATION_LIMIT: f64 = 1e3;

/// Up to this ratio of the split's parts to its sum the value is still the split's, while above
/// [`SPLIT_CANCELLATION_LIMIT`] the derivatives come from the quadrature (which then also
/// integrates a value, discarded). The split's parts are accurate to a few ulps each (the grazing
/// receiver's `n_t` included, see [`grazing_tangent`]), so its value keeps ~`u` times this ratio,
/// ~1e-11; the quadrature's value near the plane is worse there (5.5e-10 on issue 18's grazing
/// example, whose split cancels by 1000.0000016).
pub(crate) const SPLIT_VALUE_LIMIT: f64 = 1e5;

/// What [`near_plane_value`] reads of an edge's frame ([`EdgeFrame`]'s fields of the same names):
/// the value-only route builds just these.
#[derive(Clone, Copy)]
pub(crate) struct InPlaneEdge {
    pub e_hat: DVec3,
    pub len: f64,
    /// `r_a × e`.
    pub w: DVec3,
    pub sa: f64,
    pub sb: f64,
}

impl From<EdgeFrame> for InPlaneEdge {
    #[inline]
    fn from(f: EdgeFrame) -> Self {
        InPlaneEdge {
            e_hat: f.e_hat,
            len: f.len,
            w: f.w,
            sa: f.sa,
            sb: f.sb,
        }
    }
}

/// The signed edge-sum value for x near the polygon's plane, without the cancellation of the plain
/// sum (the convention of the edge terms,
/// [`frame_term`](crate::kernels::form_factor::edge::frame_term): positive when the loop's
/// right-hand normal `N̂` points away from x, i.e. for `h_P = N̂·(v − x) > 0`; both signs of `h_P`
/// are handled alike).
///
/// Edges not in the tangent plane. Split `n = n_N N̂ + n_t`. With `r_a = q_a + h_P N̂` (`q_a` in the
/// plane) the lever arm is `r_a × e = q_a × e + h_P N̂ × e`, where `q_a × e` is along `N̂`. So the
/// `n_t` part of the term is `h_P n_t·(N̂ × ê) A_1/2π` (`A_1 = ∫ ds/‖r‖²`): O(h_P), no cancellation.
/// The `N̂` part is the parallel-receiver term `d_e A_1/2π` (`d_e = N̂·(r_a × ê)`, the signed
/// in-plane distance from the foot point `x_P` of x to the edge line); with `s = |d_e| tan ψ` it is
/// `(Δψ_e − G_e)/2π`, `Δψ_e` the signed angle the edge subtends at `x_P`, and
/// `G_e = ∫ ε cos²ψ/(1 + ε cos²ψ) dψ` over the edge's angular range (`ε = h_P²/d_e²`), in closed
/// form by [`near_plane_deficit`].
///
/// Edges in the tangent plane (the clip edges, and input edges whose ends lie exactly on it). Their
/// line ℓ is where the tangent plane meets the polygon's plane, so it passes within
/// `D = |h_P|/‖n_t‖` of x and `D_P = |n_N| D` of `x_P`: `ε` is not small and the split above
/// fails. But `r_a` and `e` both lie in the tangent plane, so `w = r_a × e = ±‖w‖ n`, and the whole
/// term is `sign(n·w) β_c/2π` with `β_c = atan2(D L, D² + s_a s_b)` (`s_a, s_b` the abscissae of the
/// ends along ℓ from the foot of x, `L = s_b − s_a`): the edge's own closed form. `D` and the sign
/// come from the exact height rather than from the edge's near-degenerate cross product: ℓ's
/// point nearest x is `p = (h_P/‖n_t‖²)(N̂ − n_N n)` (`n·p = 0`, `N̂·p = h_P`), so `D = |h_P|/‖n_t‖`
/// and `w = p × e`, `sign(n·w) = sign(h_P e·(n × N̂))`. Its in-plane angle at `x_P` is
/// `Δψ_c = atan2(d_c L, s_a s_b + d_c²)` with `d_c = N̂·w/L = sign(n·w) n_N D` (x and `x_P` have the
/// same abscissae: ℓ ⊥ N̂). Where the clip segment lies on one side of the foot (`s_a s_b > 0`)
/// both angles are O(h_P); otherwise (the foot beyond ℓ, outside the polygon too) they are O(1)
/// but [`tangent_excess`] still forms their combination without cancellation.
///
/// The sum. `Σ_all Δψ = 2π W` exactly (`W` the winding number of the clipped loop about `x_P`,
/// rounded from the f64 sum), so
///
/// ```text
/// 2π F = n_N (2π W − Σ_clip Δψ_c − Σ_other G_e) + Σ_other h_P n_t·(N̂ × ê) A_1 + Σ_clip sign(n·w) β_c,
/// ```
///
/// a sum of O(h_P) terms (the O(h_P²) `G_e` aside) when x is outside (`W = 0`). Per clip edge the
/// two O(h_P) parts combine into `sign(n·w) (β(D) − |n_N| β(|n_N| D))`, which [`tangent_excess`]
/// evaluates with its factor `1 − |n_N|` explicit (a receiver facing the plane head-on would
/// otherwise lose `1/‖n_t‖²`). The O(h_P) parts of different edges still cancel by a geometric
/// factor (25-150 in `tests/form_factor_near_plane.rs`; far more when the clip line cuts a small
/// corner off, which `max_cancellation` refuses). Non-convex polygons can be clipped into
/// several clip edges, including bridges that run along ℓ in both directions; each is its own
/// closed form and the bridges' terms cancel between themselves, O(h_P) each.
///
/// Returned with the parts' cancellation (their magnitudes' sum over the sum's magnitude). `None`
/// when not applicable: an edge not in the tangent plane has `|h_P| ≥ 0.1 |d_e|` (x near its line
/// in the plane, which includes x near a clip vertex), a term is undefined, or the parts sum to
/// less than `1/max_cancellation` of their magnitudes.
///
/// `angles[i]`, where `angles` has an entry `i`, receives the angle edge `i` subtends at x
/// (`atan(s_b/H) − atan(s_a/H)`, Lambert's `β`, in `[0, π]`) for the edges off the tangent
/// plane that reach the sum, where it is well conditioned (entries of other edges are left
/// alone): the clipped loop's derivatives (`lambert::clipped_derivs`) reuse them instead of an
/// `atan2` each. Well conditioned: both ends at least `L/4` from x and `sin β ≥ 1/4`. The far
/// abscissa `s_b = s_a + L` errs by `~u(‖r_a‖ + L)`, which moves the angle by up to
/// `u(‖r_a‖ + L)/‖r_b‖` (133 ulps measured with an end at `L/73`): at most ~9u here. And the
/// derivatives' bracket `c/P − β/s` amplifies a difference between this `β` and `atan2(s, c)`
/// of their rounded inputs by ~`1.5/tan²β`: at most 24 at `sin β = 1/4`.
///
/// `edges[i]`, where `edges` has an entry `i`, receives the vector of edge `i` when it lies in
/// the tangent plane ([`edge_vector`]'s: the ends' double-double difference rounded once), for
/// the same loop's derivatives.
#[inline]
#[allow(clippy::too_many_arguments)]
pub(crate) fn near_plane_value<E: Copy + Into<InPlaneEdge>>(
    verts: &[ClipVertex],
    frames: &[Option<E>],
    n: DVec3,
    plane_n: DVec3,
    h_p: f64,
    max_cancellation: f64,
    angles: &mut [f64],
    edges: &mut [DVec3],
) -> Option<(f64, f64)> {
    let count = verts.len();
    let h2 = h_p * h_p;
    let n_par = n.dot(plane_n);
    let n_t = n - n_par * plane_n;
    let nt2 = n_t.length_squared();
    if nt2 == 0.0 {
        // n along N̂: nothing is clipped and no edge lies in the tangent plane.
        return None;
    }
    let mut transverse = 0.0;
    let mut turning = 0.0;
    let mut small = 0.0;
    // Σ sign(n·w) (β_c − n_N sign(n·w) Δψ_c) over the edges in the tangent plane.
    let mut tangent = 0.0;
    // Σ of the parts' magnitudes, to measure the split's own cancellation.
    let mut magnitude = 0.0;
    // The cheap test first: every edge off the tangent plane far enough from x_P (in units of
    // h_P), before any angle is computed.
    for (i, frame) in frames.iter().enumerate() {
        if let Some(f) = frame {
            let f: InPlaneEdge = (*f).into();
            let on_line = verts[i].on_line && verts[next(i, count)].on_line;
            #[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN declines
            if !on_line && !(h_p.abs() * f.len < NEAR_PLANE_RATIO * plane_n.dot(f.w).abs()) {
                return None;
            }
        }
    }
    // The clip line ℓ (where the tangent plane meets the polygon's plane) runs along n × N̂; its
    // point nearest x is p = (h_P/‖n_t‖²)(N̂ − n_N n) (n·p = 0, N̂·p = h_P), at D = |h_P|/‖n_t‖.
    // An edge on ℓ has r_a × e = p × e, so sign(n·w) = sign(e·(n × p)) = sign(h_P e·(n × N̂)) and
    // N̂·w/L = sign(n·w) n_N D: its geometry comes from the exact height without a double-double
    // cross product.
    let n_x_plane = n.cross(plane_n);
    let (n_t, nt2, big_d) = grazing_tangent(verts, n, plane_n, h_p, n_t, nt2);
    for (i, frame) in frames.iter().enumerate() {
        let (a, b) = (&verts[i], &verts[next(i, count)]);
        if a.on_line && b.on_line {
            // The clip edge's whole term minus its share n_N Δψ_c of the parallel part.
            let e = edge_vector(a, b);
            if let Some(edge) = edges.get_mut(i) {
                *edge = e;
            }
            let len = e.length();
            if len == 0.0 {
                continue;
            }
            let e_hat = e / len;
            let sa = a.r.dot(e_hat) + a.r_lo.dot(e_hat);
            let sb = b.r.dot(e_hat) + b.r_lo.dot(e_hat);
            let sigma = (h_p * e.dot(n_x_plane)).signum();
            // Its in-plane angle Δψ_c = atan2(d_c L, s_a s_b + d_c²), d_c = σ n_N D, is
            // σ sign(n_N) β(|n_N| D), which `tangent_excess` forms anyway (to rounding, which
            // the winding number's rounding to an integer absorbs).
            let (t, beta_c) = tangent_excess(big_d, len, sa * sb, n_par.abs(), nt2);
            turning += (sigma * n_par.signum()) * beta_c;
            tangent += sigma * t;
            magnitude += t.abs();
            continue;
        }
        let Some(frame) = frame else {
            continue;
        };
        let frame: InPlaneEdge = (*frame).into();
        let len = frame.len;
        // Signed in-plane distance of x_P from the edge line: N̂·(r_a × ê), from the (exact when x
        // is near the line) lever arm.
        let d = plane_n.dot(frame.w) / len;
        let (sa, sb) = (frame.sa, frame.sb);
        let dpsi = (d * len).atan2(sa * sb + d * d);
        turning += dpsi;
        let deficit = near_plane_deficit(d.abs(), h2, sa, sb, dpsi.abs());
        small += deficit.g.copysign(d);
        magnitude += (n_par * deficit.g).abs();
        // n_t·(r_a × e) = h_P n_t·(N̂ × e): the in-plane part of r_a × e is exactly h_P N̂ × e, and
        // taking it from the plane avoids the cancellation against the large N̂ part. The edge's
        // A_1 = atan2(H L, H² + s_a s_b)/H (H = √(d² + h_P²), its distance from x) comes with the
        // deficit.
        let nu_t = h_p * n_t.dot(plane_n.cross(frame.e_hat));
        let t = nu_t * deficit.spread / deficit.big_h;
        if let Some(angle) = angles.get_mut(i) {
            let big_h2 = deficit.big_h * deficit.big_h;
            let (ra2, rb2, len2) = (big_h2 + sa * sa, big_h2 + sb * sb, len * len);
            // sin²β = H²L²/(‖r_a‖²‖r_b‖²).
            if 16.0 * ra2.min(rb2) >= len2 && 16.0 * big_h2 * len2 >= ra2 * rb2 {
                *angle = deficit.spread;
            }
        }
        transverse += t;
        magnitude += t.abs();
    }
    let winding = (turning / std::f64::consts::TAU).round();
    let parallel = std::f64::consts::TAU * winding - small;
    let total = n_par * parallel + transverse + tangent;
    magnitude += (n_par * std::f64::consts::TAU * winding).abs();
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN declines
    if !(magnitude <= max_cancellation * total.abs()) {
        return None;
    }
    Some((INV_2PI * total, magnitude / total.abs()))
}

/// Below this `‖n_t‖²` (a receiver within ~0.1 rad of facing the polygon's plane head-on)
/// [`near_plane_value`] takes `n_t` from the clip line ([`grazing_tangent`]) rather than from
/// `n − n_N N̂` in f64: the latter's relative error, ~`u/‖n_t‖`, is multiplied by the split's
/// cancellation (up to [`SPLIT_CANCELLATION_LIMIT`]), which at this threshold keeps it below
/// ~1e-12 and at 2.5e-6 rad would reach 1e-9.
pub(crate) const GRAZING_NT2: f64 = 1e-2;

/// Below this `‖n_t‖²` (a receiver within 1e-4 rad of facing the polygon's plane head-on, near the
/// plane and clipping it) [`evaluate`](crate::kernels::form_factor::robust::evaluate) takes the
/// derivatives from the quadrature even where the split does not cancel beyond
/// [`SPLIT_CANCELLATION_LIMIT`]: the edge sum's terms are O(1/size) while the derivatives are
/// O(F/h_P), which vanish with `h_P` for a head-on receiver (`tests/form_factor_grazing.rs`:
/// gradient errors up to 6.3e-6 from the edge sum, 3.9e-7 from the quadrature; above 1e-4 rad the
/// edge sum's were within 5e-11).
pub(crate) const FACING_NT2: f64 = 1e-8;

/// The in-plane part `n_t` of the receiver normal, `‖n_t‖²` and the distance `D = |h_P|/‖n_t‖`
/// from x to the clip line ℓ, for [`near_plane_value`] (`n_t`, `nt2` its f64 estimates).
///
/// Why: `n_t = n − n_N N̂` is a difference of nearly equal vectors when the receiver faces the
/// plane nearly head-on, and the rounded `N̂` (an ulp, ~1e-16) tilts it by ~1e-16/‖n_t‖ rad. The
/// value is that sensitive to it: per ulp of `n` it moves by ~4e-10 relative at `‖n_t‖` = 2.3e-6
/// (the example of issue 18's grazing gap), which the f64 route turned into errors of 1.7e-9.
/// The clip points carry the same information exactly: they are the polygon's edges (exact, in the
/// plane) cut by the tangent plane in double-double, so ℓ's direction `ê` and x's distance from
/// it, `D = ‖r_a × r_b‖/L` (double-double cross product: `D ≪ ‖r_a‖` where the receiver is tilted
/// more), are accurate to a few ulps whatever `‖n_t‖`. Then `‖n_t‖ = |h_P|/D` (the exact height),
/// and `n_t` is along `N̂ × ê` (in the plane, perpendicular to ℓ = the direction of `n × N̂`; the
/// rounding of `N̂` now moves it by an ulp of its own size), oriented as the f64 estimate.
///
/// Above [`GRAZING_NT2`], or without a clip edge of nonzero length, the f64 estimates as they are
/// (and `D = |h_P|/‖n_t‖`).
#[inline]
fn grazing_tangent(
    verts: &[ClipVertex],
    n: DVec3,
    plane_n: DVec3,
    h_p: f64,
    n_t: DVec3,
    nt2: f64,
) -> (DVec3, f64, f64) {
    if nt2 < GRAZING_NT2 {
        let count = verts.len();
        for i in 0..count {
            let (a, b) = (&verts[i], &verts[next(i, count)]);
            if !(a.on_line && b.on_line) {
                continue;
            }
            let (ra, rb) = (
                dd::Dd3::from_parts(a.r, a.r_lo),
                dd::Dd3::from_parts(b.r, b.r_lo),
            );
            let e = rb.sub(&ra).to_dvec3();
            let len = e.length();
            if len == 0.0 {
                continue;
            }
            let big_d = ra.cross(&rb).to_dvec3().length() / len;
            let norm = h_p.abs() / big_d;
            let m = plane_n.cross(e) / len;
            let m = if m.dot(n_t) < 0.0 { -m } else { m };
            return (m * norm, norm * norm, big_d);
        }
        // Nothing clipped (the clip line passes beside the polygon): `n_t` from the polygon's own
        // normal in double-double, `N' = Σ r_i × r_{i+1}` (the vertices are exact pairs), as
        // `N' × (n × N') / ‖N'‖²` (`n` is exact): its relative error is then ~u whatever `‖n_t‖`.
        let exact = |v: &ClipVertex| dd::Dd3::from_parts(v.r, v.r_lo);
        let mut newell = dd::Dd3::new(DVec3::ZERO, DVec3::ZERO);
        for i in 0..count {
            newell = newell.add(&exact(&verts[i]).cross(&exact(&verts[next(i, count)])));
        }
        let tangent = newell.cross(&dd::Dd3::new(n, DVec3::ZERO).cross(&newell));
        let norm2 = newell.dot(&newell);
        let n_t = DVec3::new(
            tangent.x.div(norm2).to_f64(),
            tangent.y.div(norm2).to_f64(),
            tangent.z.div(norm2).to_f64(),
        );
        let nt2 = n_t.length_squared();
        return (n_t, nt2, h_p.abs() / nt2.sqrt());
    }
    (n_t, nt2, h_p.abs() / nt2.sqrt())
}

/// The frames of the loop's edges as the edge sum builds them ([`frame_of`]), pushed onto `out`
/// (filled in place: returning the small vector would copy it); `None` for the clip edges (when
/// `cut`), whose terms [`clip_edge_term`](crate::kernels::form_factor::edge::clip_edge_term) forms
/// from its own frame.
pub(crate) fn edge_frames(verts: &[ClipVertex], cut: bool, out: &mut Frames) {
    let count = verts.len();
    for i in 0..count {
        let clip_edge = cut && verts[i].on_line && verts[next(i, count)].on_line;
        out.push(if clip_edge { None } else { frame_of(verts, i) });
    }
}

/// The frame of the edge from vertex `i` of the loop to the next: a clip point's `u` is rounded
/// independently of its exact `r`, so the edge vector of an edge with a clip point is taken from
/// the exact ends, and the frame's cross product is recomputed in double-double when x is near the
/// edge's line. `None` for a zero-length edge.
fn frame_of(verts: &[ClipVertex], i: usize) -> Option<EdgeFrame> {
    let (a, b) = (&verts[i], &verts[next(i, verts.len())]);
    let ends = ExactEnds {
        a: [a.r, a.r_lo],
        b: [b.r, b.r_lo],
    };
    EdgeFrame::with_exact_ends(a.r, edge_vector(a, b), Some(&ends))
}

pub(crate) type Frames = SmallVec<[Option<EdgeFrame>; 10]>;

/// Whether the foot point of x (`h_p N̂` from x) lies inside the clipped loop, by the crossing
/// number of the loop projected along the dominant axis of `N̂` (bridges along the clip line cross
/// in pairs and leave the parity alone). Only used to choose between two accurate evaluations (see
/// [`evaluate`](crate::kernels::form_factor::robust::evaluate)), so a foot on or next to the
/// boundary may go either way.
#[inline]
pub(crate) fn foot_inside(verts: &[ClipVertex], plane_n: DVec3, h_p: f64) -> bool {
    // `dominant_projection`'s choice made once, each case with its own loop.
    let a = plane_n.abs();
    let foot = plane_n * h_p;
    if a.x >= a.y && a.x >= a.z {
        crossing_parity(verts, foot, |v| DVec2::new(v.y, v.z))
    } else if a.y >= a.z {
        crossing_parity(verts, foot, |v| DVec2::new(v.z, v.x))
    } else {
        crossing_parity(verts, foot, |v| DVec2::new(v.x, v.y))
    }
}

/// [`foot_inside`] for the projection `project`.
#[inline(always)]
fn crossing_parity(verts: &[ClipVertex], foot: DVec3, project: impl Fn(DVec3) -> DVec2) -> bool {
    let foot = project(foot);
    let count = verts.len();
    if count == 0 {
        return false;
    }
    // Each vertex projected once, carried to the next edge.
    let first = project(verts[0].r) - foot;
    let mut p = first;
    let mut inside = false;
    for i in 0..count {
        let q = if i + 1 == count {
            first
        } else {
            project(verts[i + 1].r) - foot
        };
        // The edge crosses the ray from the foot along +x: it straddles y = 0 at a positive x.
        let dy = q.y - p.y;
        if (p.y > 0.0) != (q.y > 0.0) && ((p.x * dy - p.y * (q.x - p.x)) > 0.0) == (dy > 0.0) {
            inside = !inside;
        }
        p = q;
    }
    inside
}

/// `atan(z)`, by its series where `|z|` is small (the arguments of the near-plane corrections are
/// O(h_P) or O(ε)): below 1e-4 three terms are exact to 1e-28 relative.
fn atan_small(z: f64) -> f64 {
    if z.abs() < 1e-4 {
        let z2 = z * z;
        z * (1.0 - z2 * (1.0 / 3.0 - 0.2 * z2))
    } else {
        z.atan()
    }
}

/// `β(D) − c β(cD)` with `β(t) = atan2(t L, t² + P)`: for an edge in the tangent plane at distance
/// `d = D` from x (`L` its length, `P = s_a s_b` the product of its ends' abscissae from the foot of
/// x, `c = |n_N|`, `nt2 = ‖n_t‖² = 1 − c²`), its term `β_c` less its share `c β(cD) = sign(n·w) n_N Δψ_c`
/// of the parallel part (see [`near_plane_value`]).
///
/// Outside the polygon (`P > 0`) both angles are O(D) and agree to `1 − c`, which is small when the
/// receiver faces the plane nearly head-on. With `u = DL/(D² + P)` and `v = cDL/(c²D² + P)` (the
/// tangents of the two angles), `β(D) − cβ(cD) = atan((u − v)/(1 + uv)) + (1 − c) atan(v)`, and
/// `u − v = DL (1 − c)(P − cD²)/((D² + P)(c²D² + P))`, with `1 − c = ‖n_t‖²/(1 + c)`: every part
/// carries its factor `1 − c` explicitly, so nothing cancels. Otherwise (`P ≤ 0`, the foot's
/// projection on ℓ inside the segment, which happens outside the polygon too: the foot beyond the
/// clip line) the angles are O(1) but still agree to `1 − c`; their difference is the angle between
/// the vectors `(D² + P, DL)` and `(c²D² + P, cDL)`, an `atan2` of their cross product (the same
/// numerator, factor `1 − c` explicit) and their dot product (positive, no cancellation).
/// Subtracting the angles as they are lost `~u β/(1 − c)` relative: 8.7e-6 of the value for a
/// receiver 1.9e-6 rad from head-on (`tests/form_factor_grazing.rs`). Returned with `β(cD)` itself,
/// which gives the edge's in-plane angle for the winding number.
fn tangent_excess(d: f64, len: f64, p: f64, c: f64, nt2: f64) -> (f64, f64) {
    let one_minus_c = nt2 / (1.0 + c);
    let (d2, cd2) = (d * d, c * c * d * d);
    if p <= 0.0 {
        // The angles are not small, but they still agree to `1 − c`: their difference is the
        // angle between (D² + P, DL) and (c²D² + P, cDL), whose cross product is `u − v`'s
        // numerator and whose dot product is positive (the two directions nearly agree).
        let beta_c = (c * d * len).atan2(cd2 + p);
        let cross = d * len * one_minus_c * (p - c * d2);
        let dot = (d2 + p) * (cd2 + p) + c * d2 * len * len;
        return (cross.atan2(dot) + one_minus_c * beta_c, beta_c);
    }
    let u = d * len / (d2 + p);
    let v = c * d * len / (cd2 + p);
    let u_minus_v = d * len * one_minus_c * (p - c * d2) / ((d2 + p) * (cd2 + p));
    // β(cD) = atan(v): its second argument c²D² + P is positive.
    let beta_c = atan_small(v);
    (
        atan_small(u_minus_v / (1.0 + u * v)) + one_minus_c * beta_c,
        beta_c,
    )
}

/// What [`near_plane_deficit`] returns for one edge.
struct Deficit {
    /// `G_e`.
    g: f64,
    /// `atan(s_b/H) − atan(s_a/H)`, the angle the edge subtends at x (`H A_1`).
    spread: f64,
    /// `H = √(d² + h_P²)`, the distance from x to the edge's line.
    big_h: f64,
}

/// `G_e = ∫ ε cos²ψ/(1 + ε cos²ψ) dψ` for an edge at in-plane distance `d > 0` from the foot point
/// of x, `h2 = h_P²`, abscissae `s_a < s_b` along its line (`ψ = atan(s/d)`, `ε = h_P²/d²`), given
/// `abs_dpsi = atan(s_b/d) − atan(s_a/d)` (the unsigned angle at the foot, which the caller has).
///
/// With `s = d tan ψ` the integrand is `d h²/((d² + s²)(H² + s²)) ds`, `H² = d² + h_P²`, which splits
/// into `d/(d² + s²) − d/(H² + s²)`: `G_e = [atan(s/d) − atan(s/H)] + (1 − d/H) [atan(s/H)]`, both
/// brackets taken between `s_a` and `s_b`. Written that way each part is a difference of angles
/// that agree to O(ε) and would lose everything to rounding; instead
/// `δ(s) = atan(s/d) − atan(s/H) = atan(s k/(d H + s²))` and `1 − d/H = k/H` with
/// `k = H − d = h²/(H + d)`, all without cancellation, and the second bracket is
/// `abs_dpsi − [δ]`. What remains is a difference of two O(ε) angles (at `s_b` and `s_a`), whose
/// rounding error is O(ε·u), far below the O(h_P) value it corrects.
fn near_plane_deficit(d: f64, h2: f64, sa: f64, sb: f64, abs_dpsi: f64) -> Deficit {
    let big_h = (d * d + h2).sqrt();
    let k = h2 / (big_h + d);
    let delta = |s: f64| atan_small(s * k / (d * big_h + s * s));
    let dd = delta(sb) - delta(sa);
    let spread = abs_dpsi - dd;
    Deficit {
        g: dd + k / big_h * spread,
        spread,
        big_h,
    }
}

#[cfg(test)]
mod tests;
