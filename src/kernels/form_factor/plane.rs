//! A polygon's plane as the robust path validates it (area, planarity, simplicity), its thinness
//! tests, and the height of `x` over it recomputed from exact differences near the plane.

use glam::{DVec2, DVec3};
use smallvec::SmallVec;

use crate::error::{Error, Result};
use crate::kernels::form_factor::clip::next;
use crate::kernels::form_factor::scaled::Scaled;
use crate::kernels::numeric::dd;

/// Largest distance of a vertex from the polygon's plane, relative to its extent.
const PLANARITY_TOLERANCE: f64 = 1e-8;
/// `2·area / extent²` at or below which a polygon counts as having zero area.
const AREA_TOLERANCE: f64 = 1e-13;

/// The polygon's plane, checked for area, planarity and simplicity.
pub(crate) struct Plane {
    pub(crate) normal: DVec3,
    /// `‖Σ u_i × u_{i+1}‖` (twice the area).
    pub(crate) twice_area: f64,
    /// Largest distance from the first vertex.
    pub(crate) extent: f64,
}

impl Plane {
    pub(crate) fn new(u: &[DVec3]) -> Result<Self> {
        let count = u.len();
        // Newell's normal, relative to the first vertex (u[0] = 0).
        let mut nn = DVec3::ZERO;
        for i in 0..count {
            nn += u[i].cross(u[next(i, count)]);
        }
        let extent = u.iter().map(|v| v.length()).fold(0.0, f64::max);
        Self::validated(u, nn, extent, true)
    }

    /// [`Plane::new`] from the Newell sum `nn` and the `extent` the caller computed as `new` does
    /// (the same bits: the polygon sliver path has them already). `check_simplicity: false` skips
    /// the O(count²) simplicity test, for callers that have certified it otherwise (a fan from
    /// `u[0]` sorted by angle within a half-turn, `sliver::fan`). Inlined into `Plane::new`, its
    /// one caller on the hot path.
    #[inline(always)]
    pub(crate) fn validated(
        u: &[DVec3],
        nn: DVec3,
        extent: f64,
        check_simplicity: bool,
    ) -> Result<Self> {
        let count = u.len();
        let twice_area = nn.length();
        if twice_area <= AREA_TOLERANCE * extent * extent || twice_area.is_nan() {
            return Err(Error::Degenerate(format!(
                "polygon has (numerically) zero area (2*area = {twice_area:e}, extent {extent:e})"
            )));
        }
        let normal = nn / twice_area;
        // A triangle is planar by construction: for a thin one the test would measure only the
        // rounding of its normal (~u extent²/area), and refuse valid slivers below ~1e-9.
        if count > 3 {
            let off_plane = u.iter().map(|v| normal.dot(*v).abs()).fold(0.0, f64::max);
            // The rounded normal itself is tilted: each rounded cross product is off by at most
            // `2√3 ε ‖u_i‖‖u_{i+1}‖ ≤ 4ε extent²`, the sum adds `count·ε` per term, so by up to
            // `(4 + count)·count·ε·extent² / twice_area` radians, which moves a vertex up to that
            // times `extent` off the plane (`extent²/area ~ 1/thinness`: a quad 1e-10 wide,
            // ~5e-5 of its extent); the dot product adds a few ε. Twice that is allowed on top of
            // the tolerance, so that thin but planar polygons are not refused for the normal's
            // rounding; a polygon bent by less than that cannot be told from a planar one by this
            // normal and is accepted (the sum it then gets is the one for the rounded plane).
            let rounding = ((4 + count) * count) as f64 * f64::EPSILON * extent * extent
                / twice_area
                + 4.0 * f64::EPSILON;
            if off_plane > (PLANARITY_TOLERANCE + 2.0 * rounding) * extent {
                return Err(Error::InvalidArgument(format!(
                    "polygon is not planar: a vertex is {off_plane:e} from its plane \
                     (tolerance {PLANARITY_TOLERANCE:e} x extent {extent:e})"
                )));
            }
            if check_simplicity {
                check_simple(u, normal)?;
            }
        }
        Ok(Plane {
            normal,
            twice_area,
            extent,
        })
    }
}

/// The plane of a triangle given relative to its first vertex (`u[0] = 0`), as [`Plane::new`]
/// computes it (a triangle is planar and simple); `None` for (numerically) zero area.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn triangle_plane(u: &[DVec3; 3]) -> Option<Plane> {
    // Newell's sum reduces to u_1 × u_2 (the other two terms are exactly zero).
    let nn = u[1].cross(u[2]);
    // sqrt is monotone and correctly rounded: the max of the roots is the root of the max.
    let extent = u[1].length_squared().max(u[2].length_squared()).sqrt();
    let twice_area = nn.length();
    if !(twice_area > AREA_TOLERANCE * extent * extent) {
        return None;
    }
    Some(Plane {
        normal: nn / twice_area,
        twice_area,
        extent,
    })
}

/// The first of [`fast_decisions`](crate::kernels::form_factor::replay::fast_decisions): the signed
/// height `h_P` of x over the plane as [`evaluate`](crate::kernels::form_factor::robust::evaluate)
/// takes it, `None` when x is in or near the plane. (A clipped sliver needs no more.)
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
#[inline]
pub(crate) fn plane_height(r: &[DVec3], plane: &Plane) -> Option<f64> {
    let nearest = r
        .iter()
        .min_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
        .copied()?;
    let h_p = plane.normal.dot(nearest);
    // One root each for r_max and the radius: the max of the roots is the root of the max, so the
    // decisions are those of `evaluate`.
    let r_max = r
        .iter()
        .map(|v| v.length_squared())
        .fold(0.0, f64::max)
        .sqrt();
    if !(h_p.abs() >= NEAR_PLANE_HEIGHT * r_max) {
        return None;
    }
    Some(h_p)
}

impl Plane {
    /// Whether [`evaluate`](crate::kernels::form_factor::robust::evaluate) takes the fan triangles'
    /// geometry from exact differences for this polygon even when x is not near its plane (a
    /// sliver: `2·area < 1e-2·extent²`).
    pub(crate) fn is_thin(&self) -> bool {
        self.twice_area < THIN_POLYGON * self.extent * self.extent
    }

    /// Whether the polygon is a sliver whose edge sum would cancel far beyond
    /// [`THIN_CANCELLATION_LIMIT`](crate::kernels::form_factor::tolerance::THIN_CANCELLATION_LIMIT)
    /// (it cancels by about the inverse of `2·area / extent²`).
    pub(crate) fn is_very_thin(&self) -> bool {
        self.twice_area < VERY_THIN_POLYGON * self.extent * self.extent
    }
}

fn orient2(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b - a).perp_dot(c - a)
}

fn on_segment(a: DVec2, b: DVec2, p: DVec2) -> bool {
    p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
}

/// Whether closed segments `[a, b]` and `[c, d]` share a point.
fn segments_touch(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let d1 = orient2(c, d, a);
    let d2 = orient2(c, d, b);
    let d3 = orient2(a, b, c);
    let d4 = orient2(a, b, d);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && on_segment(c, d, a))
        || (d2 == 0.0 && on_segment(c, d, b))
        || (d3 == 0.0 && on_segment(a, b, c))
        || (d4 == 0.0 && on_segment(a, b, d))
}

/// Projection onto the coordinate plane most nearly parallel to a plane of normal `normal` (drops
/// the coordinate of its largest component, keeping a right-handed pair): orientation tests in 2D
/// then agree with those in the plane, up to the sign of that component.
fn dominant_projection(normal: DVec3) -> impl Fn(DVec3) -> DVec2 {
    let a = normal.abs();
    move |v: DVec3| {
        if a.x >= a.y && a.x >= a.z {
            DVec2::new(v.y, v.z)
        } else if a.y >= a.z {
            DVec2::new(v.z, v.x)
        } else {
            DVec2::new(v.x, v.y)
        }
    }
}

/// Rejects polygons where two non-adjacent edges touch (projected on the dominant plane).
fn check_simple(u: &[DVec3], normal: DVec3) -> Result<()> {
    let project = dominant_projection(normal);
    // Up to 8 vertices in a fixed array: collecting into the small vector cost more than the tests
    // for a quad.
    let mut fixed = [DVec2::ZERO; 8];
    let many: SmallVec<[DVec2; 8]>;
    let p: &[DVec2] = if u.len() <= fixed.len() {
        for (q, v) in fixed.iter_mut().zip(u) {
            *q = project(*v);
        }
        &fixed[..u.len()]
    } else {
        many = u.iter().map(|v| project(*v)).collect();
        &many
    };
    let count = p.len();
    for i in 0..count {
        for j in i + 2..count {
            if i == 0 && j == count - 1 {
                continue;
            }
            if segments_touch(p[i], p[(i + 1) % count], p[j], p[(j + 1) % count]) {
                return Err(Error::InvalidArgument(format!(
                    "polygon is not simple: edges {i} and {j} intersect"
                )));
            }
        }
    }
    Ok(())
}

/// Below this `2·area / extent²` a polygon counts as thin (a sliver): its normal, computed from
/// rounded edge vectors, has lost more than ~2 digits.
const THIN_POLYGON: f64 = 1e-2;

/// Below this `2·area / extent²` a sliver's edge sum cancels by ~1e5, beyond
/// [`THIN_CANCELLATION_LIMIT`](crate::kernels::form_factor::tolerance::THIN_CANCELLATION_LIMIT):
/// [`evaluate`](crate::kernels::form_factor::robust::evaluate) tries the sliver rule without
/// computing the edge sum.
const VERY_THIN_POLYGON: f64 = 1e-5;

/// Whether the triangle is a sliver by [`VERY_THIN_POLYGON`] (from its rounded edge vectors,
/// accurate to ~1e-11 relative at that threshold; non-finite input gives `false`): its form factor
/// goes to [`evaluate`](crate::kernels::form_factor::robust::evaluate) directly, where the sliver
/// rule applies unless x is near it.
#[inline]
pub(crate) fn is_very_thin_triangle([a, b, c]: [DVec3; 3]) -> bool {
    let (ab, ac) = (b - a, c - a);
    let extent2 = ab.length_squared().max(ac.length_squared());
    ab.cross(ac).length() < VERY_THIN_POLYGON * extent2
}

/// Below this `|h_P| / max ‖r‖`, the height of x over the polygon's plane is recomputed by
/// [`exact_height`] (the rounded one has lost more than ~3 digits).
pub(crate) const NEAR_PLANE_HEIGHT: f64 = 1e-3;

/// The signed height of x over the polygon's plane (along the Newell normal), from the exact
/// differences `r_i = v_i − x`: `r_0 · Σ_i r_i × r_{i+1} / (2·area)` with the triple products
/// `det(r_0, r_i, r_{i+1})` summed in double-double.
pub(crate) fn exact_height(s: &Scaled, twice_area: f64) -> f64 {
    exact_height_of(&s.r, &s.r_lo, twice_area)
}

/// [`exact_height`] from the parts `hi + lo` of the differences `v_i − x` (inlined into the
/// callers, which may be compiled with FMA: see `near_plane::triangle`).
#[inline(always)]
pub(crate) fn exact_height_of(hi: &[DVec3], lo: &[DVec3], twice_area: f64) -> f64 {
    let lo = &lo[..hi.len()];
    let r = |i: usize| dd::Dd3::from_parts(hi[i], lo[i]);
    let r0 = r(0);
    let mut volume = dd::Dd::new(0.0, 0.0);
    let mut prev = r(1);
    for i in 2..hi.len() {
        let next = r(i);
        volume = volume.add(r0.dot(&prev.cross(&next)));
        prev = next;
    }
    volume.to_f64() / twice_area
}
