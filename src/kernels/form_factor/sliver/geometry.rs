//! The exact geometry of a sliver's fan triangles: their normals and heights from the exact
//! differences, in double-double, and the visible part's plane from them.

use glam::DVec3;

use crate::kernels::form_factor::clip::ClipVertex;
use crate::kernels::numeric::dd::two_sum;

/// The sums over a loop's fan triangles of their [`sliver_geometry`] `(2·area·N̂, 2·area·N̂·r)`:
/// the loop's plane ([`FanGeometry::plane`]).
#[derive(Clone, Copy, Default)]
pub(crate) struct FanGeometry {
    normal: DVec3,
    volume: f64,
}

impl FanGeometry {
    #[inline(always)]
    pub(crate) fn add(&mut self, (normal, volume): (DVec3, f64)) {
        self.normal += normal;
        self.volume += volume;
    }

    /// The unit normal and `|h_P|` ([`visible_plane`]); `None` for zero area.
    #[inline(always)]
    pub(crate) fn plane(&self) -> Option<(DVec3, f64)> {
        let twice_area = self.normal.length();
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN declines
        if !(twice_area > 0.0) {
            return None;
        }
        Some((self.normal / twice_area, self.volume.abs() / twice_area))
    }
}

/// The unit normal of the loop `verts` (x origin of the `r`, the parts `r + r_lo` exact) and
/// `|h_P|`, the distance of x from its plane, from the fan triangles' exact geometry
/// ([`sliver_geometry`]); `None` for a loop of zero area. For the clip line's Hessian term of a
/// clipped sliver, `∝ |h_P| / ‖n_t‖`: the polygon's Newell normal, from rounded edge vectors, errs
/// by ~ε/aspect in direction, and so do `n_t` and the height taken with it. Inlined, so that the
/// clipped sliver's FMA build fuses its exact products
/// ([`sliver::clipped`](crate::kernels::form_factor::sliver::clipped)).
#[inline(always)]
pub(crate) fn visible_plane(verts: &[ClipVertex]) -> Option<(DVec3, f64)> {
    let mut geometry = FanGeometry::default();
    for k in 1..verts.len().checked_sub(1)? {
        // `N·r` is the same at every point of the plane: each piece's from its first vertex.
        geometry.add(sliver_geometry(&verts[0], &verts[k], &verts[k + 1]));
    }
    geometry.plane()
}

/// `(2·area·N̂, 2·area·N̂·r_a)` of the triangle `(a, b, c)` from the exact differences
/// (`r + r_lo`), each to a few ulps: a sliver's normal from rounded edge vectors would have lost
/// ~`log10(1/aspect)` digits. `N = (b − a) × (c − a)` with the edge vectors split into a leading
/// part and its remainder: the leading parts' products are exact (two-product) and the remainder
/// terms, ~ε of them, need only f64. Then `N·r_a` (the triple product `det(r_a, r_b, r_c)`) is a
/// compensated dot product, accurate to a few ulps while it cancels by less than ~1e15: x off the
/// plane by more than ~1e-15 of its distance (closer, `evaluate` takes x as in the plane).
#[inline(always)]
pub(crate) fn sliver_geometry(a: &ClipVertex, b: &ClipVertex, c: &ClipVertex) -> (DVec3, f64) {
    // q − a as a leading part and its remainder: two-sum per component on r, plus the r_lo.
    let edge = |q: &ClipVertex| {
        let (x, y) = (q.r, -a.r);
        let d = x + y;
        let yy = d - x;
        (d, ((x - (d - yy)) + (y - yy)) + (q.r_lo - a.r_lo))
    };
    let ((e1, l1), (e2, l2)) = (edge(b), edge(c));
    // One component of e1 × e2: e1[i]·e2[j] − e1[j]·e2[i], as leading part and remainder.
    let component = |i: usize, j: usize| {
        let (p, pe) = two_prod(e1[i], e2[j]);
        let (q, qe) = two_prod(e1[j], e2[i]);
        let (s, se) = two_sum(p, -q);
        let rest = (pe - qe) + ((e1[i] * l2[j] + l1[i] * e2[j]) - (e1[j] * l2[i] + l1[j] * e2[i]));
        two_sum(s, se + rest)
    };
    let (x, y, z) = (component(1, 2), component(2, 0), component(0, 1));
    let (hi, lo) = (DVec3::new(x.0, y.0, z.0), DVec3::new(x.1, y.1, z.1));
    // Σ N_k r_k with N = hi + lo, r_a = r + r_lo: the leading products summed exactly (two-sum
    // chain), the remainder products in f64.
    let (mut sum, mut err) = two_prod(hi.x, a.r.x);
    for k in 1..3 {
        let (p, pe) = two_prod(hi[k], a.r[k]);
        let (s, se) = two_sum(sum, p);
        sum = s;
        err += pe + se;
    }
    err += hi.dot(a.r_lo) + lo.dot(a.r);
    (hi + lo, sum + err)
}

/// `a·b = p + err` exactly (no overflow or underflow).
#[inline(always)]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}
