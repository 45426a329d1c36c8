//! Clipping a polygon by the receiver's tangent plane: the clipped loop's vertices (kept
//! vertices and clip points, the latter on the edges' lines to ~u² from exact heights).

use glam::DVec3;
use smallvec::SmallVec;

use crate::kernels::numeric::dd;

/// A vertex of the clipped polygon.
#[derive(Clone, Copy)]
pub(crate) struct ClipVertex {
    /// Relative to the first input vertex (exact edge vectors).
    pub(crate) u: DVec3,
    /// Relative to x.
    pub(crate) r: DVec3,
    /// Rounding error of `r` (`r + r_lo` exact) for input vertices; zero for clip vertices.
    pub(crate) r_lo: DVec3,
    /// On the clip line (created by clipping, or an input vertex exactly on the tangent plane).
    pub(crate) on_line: bool,
}

/// The clipped loop: a triangle clips to at most 4 vertices, a polygon of `count` vertices to at
/// most `count` plus one per sign change of the heights.
pub(crate) type ClipLoop = SmallVec<[ClipVertex; 10]>;

/// Where [`clip`] puts the loop: a [`ClipLoop`], or a [`TriangleLoop`] for a triangle.
pub(crate) trait ClipOut {
    fn push(&mut self, v: ClipVertex);
}

impl ClipOut for ClipLoop {
    #[inline(always)]
    fn push(&mut self, v: ClipVertex) {
        SmallVec::push(self, v);
    }
}

/// A clipped triangle's loop (at most 4 vertices) in a plain array: the count is known, so the
/// small vector's capacity checks would be work thrown away on the sliver's direct entry.
pub(crate) struct TriangleLoop {
    verts: [ClipVertex; 4],
    pub(crate) len: usize,
}

impl TriangleLoop {
    pub(crate) fn new() -> Self {
        let zero = ClipVertex {
            u: DVec3::ZERO,
            r: DVec3::ZERO,
            r_lo: DVec3::ZERO,
            on_line: false,
        };
        TriangleLoop {
            verts: [zero; 4],
            len: 0,
        }
    }

    pub(crate) fn as_slice(&self) -> &[ClipVertex] {
        &self.verts[..self.len]
    }
}

impl ClipOut for TriangleLoop {
    /// Only for a triangle's clip (each vertex pushes itself and at most one clip point, and
    /// at most two of the three edges change sign).
    #[inline(always)]
    fn push(&mut self, v: ClipVertex) {
        self.verts[self.len] = v;
        self.len += 1;
    }
}

/// The index after `i` in a loop of `count` vertices (`(i + 1) % count` without the division).
#[inline]
pub(crate) fn next(i: usize, count: usize) -> usize {
    if i + 1 == count {
        0
    } else {
        i + 1
    }
}

/// Sutherland-Hodgman clip by the half-space `n·r ≥ 0`, onto `out` (empty; filled in place, as
/// returning the loop by value copies it). Returns whether any vertex was cut away. Inlined, so
/// that the clipped sliver's FMA build fuses its double-double products (`sliver::clipped`).
#[inline(always)]
pub(crate) fn clip<O: ClipOut>(
    u: &[DVec3],
    r: &[DVec3],
    r_lo: &[DVec3],
    n: DVec3,
    out: &mut O,
) -> bool {
    let count = u.len();
    let (u, r_lo) = (&u[..count], &r_lo[..count]);
    let r = &r[..count];
    let exact = |i: usize| dd::Dd3::from_parts_unpacked(r[i], r_lo[i]);
    // Heights over the tangent plane in double-double, so that the clip points (which land near
    // x whenever x is near the polygon's plane) are placed from exact data. A stack array for
    // the usual small polygons (a growable vector's pushes and indexing cost more than the
    // heights' arithmetic).
    const ZERO: dd::Dd = dd::Dd { hi: 0.0, lo: 0.0 };
    let mut inline = [ZERO; 8];
    let mut spilled = Vec::new();
    let d: &mut [dd::Dd] = if count <= inline.len() {
        &mut inline[..count]
    } else {
        spilled.resize(count, ZERO);
        &mut spilled
    };
    for (i, di) in d.iter_mut().enumerate() {
        *di = exact(i).dot_f64(n);
    }
    clip_by_heights(u, r, r_lo, exact, d, out)
}

/// [`clip`]'s loop from the heights `d_k = n·R_k` (double-double) and the exact differences
/// `exact(k) = R_k`: kept vertices and clip points pushed onto `out` in loop order; whether any
/// vertex was cut away. Shared with the near-plane routes (`near_plane::triangle`,
/// `near_plane::polygon`), which compute the heights on fixed arrays and must place the same
/// points.
#[inline(always)]
pub(crate) fn clip_by_heights<O: ClipOut>(
    u: &[DVec3],
    r: &[DVec3],
    r_lo: &[DVec3],
    exact: impl Fn(usize) -> dd::Dd3,
    d: &[dd::Dd],
    out: &mut O,
) -> bool {
    let count = d.len();
    let mut cut = false;
    for i in 0..count {
        let j = next(i, count);
        let (di, dj) = (d[i].hi, d[j].hi);
        if di >= 0.0 {
            out.push(ClipVertex {
                u: u[i],
                r: r[i],
                r_lo: r_lo[i],
                on_line: di == 0.0,
            });
        } else {
            cut = true;
        }
        if (di > 0.0 && dj < 0.0) || (di < 0.0 && dj > 0.0) {
            let t = d[i].div(d[i].add(d[j].neg()));
            let (ri, rj) = (exact(i), exact(j));
            let (rc, rc_lo) = ri.add(&rj.sub(&ri).scale(t)).split();
            out.push(ClipVertex {
                u: u[i] + t.hi * (u[j] - u[i]),
                r: rc,
                r_lo: rc_lo,
                on_line: true,
            });
        }
    }
    cut
}

/// A near-plane route's fixed array as a [`ClipOut`]; `len` counts the pushed vertices.
pub(crate) struct ArrayOut<'a> {
    pub(crate) verts: &'a mut [ClipVertex],
    pub(crate) len: usize,
}

impl ClipOut for ArrayOut<'_> {
    #[inline(always)]
    fn push(&mut self, v: ClipVertex) {
        self.verts[self.len] = v;
        self.len += 1;
    }
}

/// The edge vector from `a` to `b` (see
/// [`edge_frames`](crate::kernels::form_factor::near_plane::split::edge_frames)). Inlined: the
/// near-plane routes call it once per edge, and its common case is one subtraction.
#[inline(always)]
pub(crate) fn edge_vector(a: &ClipVertex, b: &ClipVertex) -> DVec3 {
    if a.on_line || b.on_line {
        let (ra, rb) = (
            dd::Dd3::from_parts(a.r, a.r_lo),
            dd::Dd3::from_parts(b.r, b.r_lo),
        );
        rb.sub(&ra).to_dvec3()
    } else {
        b.u - a.u
    }
}
