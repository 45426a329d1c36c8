//! Batch entry points: the solid angles and form factors a renderer asks for in bulk, one point
//! against the triangles of a mesh light or an occluder set ([`TriangleMesh`]), summed or per
//! triangle, and many points against one triangle.
//!
//! Every result is the one the single-element kernel gives
//! ([`triangle_solid_angle`](super::triangle_solid_angle),
//! [`triangle_form_factor`](super::triangle_form_factor)) for that element, to the kernels'
//! accuracy contract (1e-12 relative in generic configurations), with the same units, conventions
//! and limits, except that a triangle the form factor rejects as having zero area contributes 0
//! here (meshes commonly hold such triangles; a whole call should not fail on one). Sums are plain
//! sums of the per-element results: no occlusion between the triangles is accounted for.
//!
//! The solid angle is evaluated in SIMD lanes (AVX2 + FMA or AVX-512 when the CPU has them and
//! `RADDIFF_SIMD` allows it, portable code otherwise): the generic Van Oosterom-Strackee formula
//! with, per lane, a certificate that the lane is in the regime where the single kernel itself uses
//! that formula with margin (`|A|` large against its rounding bound, `A² + D²` not cancelling,
//! coordinates in range, every output finite). Lanes whose certificate fails (x near the plane, an
//! edge or a vertex, extreme scales) are evaluated by the single kernel. The form factor's value
//! ([`Order::Value`]) is evaluated in the same kind of lanes by the single kernel's far form of
//! Lambert's sum, replayed operation for operation without FMA, so that an accepted lane is the
//! single call's value bit for bit; lanes outside that form call the single kernel. The gradient and
//! Hessian orders replay, per element, the single kernel's decisions before its far-field Gauss
//! rule (where it integrates the triangle by quadrature: 16 radii away and beyond, unclipped, not a
//! sliver) and evaluate that rule in lanes, grouped by rule and with the same operations, so that
//! a taken element is again the single call's result bit for bit (value included: Lambert's value
//! from the value lanes where the single call takes it); the other elements call the single
//! kernel.
//!
//! Errors: invalid input gives [`Error::InvalidArgument`] before anything is computed; an element
//! whose single-element call fails (x on an edge, x in a triangle's plane with derivatives
//! requested, ...) fails the whole call with that error, its message prefixed with the element's
//! kind and index ("triangle 12: ..."). Per-element outputs are unspecified after an error.

mod element_error;
mod far_field_lanes;
mod form_factor_lanes;
mod mesh;
mod solid_angle_lanes;

use glam::DVec3;

pub use mesh::{TriangleMesh, VertexData};

use crate::error::{ensure_finite3, Error, Result};
use crate::{Deriv3, Order};
use element_error::label;

/// Sum over the triangles of `mesh` of the unsigned solid angle (steradians) each subtends at `x`
/// ([`triangle_solid_angle`](super::triangle_solid_angle)), with gradient (sr/L) and Hessian
/// (sr/L²) with respect to `x`, up to `order`.
///
/// Overlapping triangles are counted once each (this is not the solid angle of the union). Limits
/// are those of the single kernel per triangle: on a triangle's plane 2π inside it and 0 outside;
/// `x` on an edge or at a vertex of any triangle gives [`Error::Degenerate`]; zero-area triangles
/// contribute 0. An empty mesh gives 0.
///
/// ```
/// use raddiff::glam::DVec3;
/// use raddiff::{kernels, Order};
/// // The 8 octant faces of an octahedron around the origin cover the whole sphere.
/// let v = [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z];
/// let ix = [[0, 1, 2], [1, 3, 2], [3, 4, 2], [4, 0, 2], [1, 0, 5], [3, 1, 5], [4, 3, 5], [0, 4, 5]];
/// let mesh = kernels::TriangleMesh::indexed(&v, &ix)?;
/// let d = kernels::mesh_solid_angle(DVec3::new(0.1, -0.2, 0.05), &mesh, Order::Hessian)?;
/// assert!((d.value - 4.0 * std::f64::consts::PI).abs() < 1e-13);
/// assert!(d.gradient.length() < 1e-13); // constant inside a closed surface
/// # Ok::<(), raddiff::Error>(())
/// ```
pub fn mesh_solid_angle(x: DVec3, mesh: &TriangleMesh, order: Order) -> Result<Deriv3> {
    ensure_finite3(x, "x")?;
    let mut sum = Deriv3::constant(0.0);
    solid_angle_lanes::run(
        mesh.len(),
        |t| (x, mesh.triangle(t)),
        order,
        "triangle",
        |_, d| add(&mut sum, &d, order),
    )?;
    Ok(sum)
}

/// The unsigned solid angle of each triangle of `mesh` seen from `x` into `out[t]` (as
/// [`mesh_solid_angle`], not summed). `out` must hold `mesh.len()` elements.
pub fn mesh_solid_angle_each(
    x: DVec3,
    mesh: &TriangleMesh,
    order: Order,
    out: &mut [Deriv3],
) -> Result<()> {
    ensure_finite3(x, "x")?;
    check_len(out.len(), mesh.len(), "out", "triangles")?;
    solid_angle_lanes::run(
        mesh.len(),
        |t| (x, mesh.triangle(t)),
        order,
        "triangle",
        |t, d| out[t] = d,
    )
}

/// The unsigned solid angle of the triangle `(a, b, c)` seen from each of `points`, into `out[i]`
/// (as [`triangle_solid_angle`](super::triangle_solid_angle) per point). `out` must hold
/// `points.len()` elements; every point and vertex must be finite.
pub fn points_solid_angle(
    points: &[DVec3],
    a: DVec3,
    b: DVec3,
    c: DVec3,
    order: Order,
    out: &mut [Deriv3],
) -> Result<()> {
    check_len(out.len(), points.len(), "out", "points")?;
    check_points(points, "point")?;
    ensure_finite3(a, "a")?;
    ensure_finite3(b, "b")?;
    ensure_finite3(c, "c")?;
    solid_angle_lanes::run(
        points.len(),
        |i| (points[i], [a, b, c]),
        order,
        "point",
        |i, d| out[i] = d,
    )
}

/// Sum over the triangles of `mesh` of the form factor from a differential area at `x` with unit
/// normal `n` to each triangle ([`triangle_form_factor`](super::triangle_form_factor): two-sided,
/// clipped to the half-space above the tangent plane), with gradient (per L) and Hessian (per L²)
/// with respect to `x` (`n` fixed).
///
/// The sum is the form factor of the mesh when no triangle hides another from `x` (a convex
/// emitter seen from outside, or an emitter with no self-occlusion). `n` must be unit length within
/// 1e-6. Triangles of (numerically) zero area contribute 0. Limits per triangle are the single
/// kernel's: `x` in the plane of a triangle gives 0 for the value and [`Error::Degenerate`] for
/// derivatives.
pub fn mesh_form_factor(x: DVec3, n: DVec3, mesh: &TriangleMesh, order: Order) -> Result<Deriv3> {
    ensure_finite3(x, "x")?;
    check_normal(n)?;
    let mut sum = Deriv3::constant(0.0);
    let ln = form_factor_lanes::lane_normal(n);
    form_factors(
        crate::simd::best_isa(),
        mesh.len(),
        |t| (x, n, ln, mesh.triangle(t)),
        order,
        "triangle",
        |_, d| add(&mut sum, &d, order),
    )?;
    Ok(sum)
}

/// The form factor to each triangle of `mesh` into `out[t]` (as [`mesh_form_factor`], not summed).
/// `out` must hold `mesh.len()` elements.
pub fn mesh_form_factor_each(
    x: DVec3,
    n: DVec3,
    mesh: &TriangleMesh,
    order: Order,
    out: &mut [Deriv3],
) -> Result<()> {
    ensure_finite3(x, "x")?;
    check_normal(n)?;
    check_len(out.len(), mesh.len(), "out", "triangles")?;
    let ln = form_factor_lanes::lane_normal(n);
    form_factors(
        crate::simd::best_isa(),
        mesh.len(),
        |t| (x, n, ln, mesh.triangle(t)),
        order,
        "triangle",
        |t, d| out[t] = d,
    )
}

/// The form factor from a differential area at each of `points` (unit normal `normals[i]`) to the
/// triangle `(a, b, c)`, into `out[i]` (as [`triangle_form_factor`](super::triangle_form_factor)
/// per point). `normals` and `out` must hold `points.len()` elements. A zero-area triangle gives 0
/// everywhere.
pub fn points_form_factor(
    points: &[DVec3],
    normals: &[DVec3],
    a: DVec3,
    b: DVec3,
    c: DVec3,
    order: Order,
    out: &mut [Deriv3],
) -> Result<()> {
    check_len(normals.len(), points.len(), "normals", "points")?;
    check_len(out.len(), points.len(), "out", "points")?;
    check_points(points, "point")?;
    for (i, n) in normals.iter().enumerate() {
        check_normal(*n).map_err(|e| label(e, "normal", i))?;
    }
    ensure_finite3(a, "a")?;
    ensure_finite3(b, "b")?;
    ensure_finite3(c, "c")?;
    form_factors(
        crate::simd::best_isa(),
        points.len(),
        |i| {
            let n = normals[i];
            (points[i], n, form_factor_lanes::lane_normal(n), [a, b, c])
        },
        order,
        "point",
        |i, d| out[i] = d,
    )
}

/// The form factor of `count` elements, each the single call's, handed to `sink(i, result)` in
/// increasing `i`. Element `i` is `get(i)`: receiver, normal, the normal as the value lanes take it
/// ([`form_factor_lanes::lane_normal`], computed once per normal by the caller), triangle. The
/// value comes from the far form's lanes, the gradient and Hessian from the far-field rule's lanes,
/// the rest from the single call (whose error, labelled `what i`, stops the run).
fn form_factors(
    isa: crate::simd::Isa,
    count: usize,
    get: impl Fn(usize) -> (DVec3, DVec3, DVec3, [DVec3; 3]),
    order: Order,
    what: &str,
    sink: impl FnMut(usize, Deriv3),
) -> Result<()> {
    let fallback = |i: usize| {
        let (x, n, _, y) = get(i);
        form_factor(x, n, y, order, what, i)
    };
    if order == Order::Value {
        return form_factor_lanes::run_on(
            isa,
            count,
            |i| {
                let (x, _, ln, y) = get(i);
                (x, ln, y)
            },
            fallback,
            sink,
        );
    }
    far_field_lanes::run_on(isa, count, &get, order, fallback, sink)
}

/// Tolerance of [`zero_area`], above the polygon kernel's 1e-13 so that every triangle it rejects
/// for its area is caught.
const ZERO_AREA: f64 = 2e-13;

/// Whether the form factor kernel may have rejected `y` for its (numerically) zero area: twice the
/// area at most [`ZERO_AREA`] times the squared largest distance from the first vertex.
fn zero_area(y: [DVec3; 3]) -> bool {
    let (u, v) = (y[1] - y[0], y[2] - y[0]);
    let extent2 = u.length_squared().max(v.length_squared());
    u.cross(v).length_squared() <= ZERO_AREA * ZERO_AREA * extent2 * extent2
}

fn form_factor(
    x: DVec3,
    n: DVec3,
    y: [DVec3; 3],
    order: Order,
    what: &str,
    index: usize,
) -> Result<Deriv3> {
    match crate::kernels::form_factor::triangle_form_factor(x, n, y[0], y[1], y[2], order) {
        Ok(d) => Ok(d),
        Err(Error::Degenerate(_)) if zero_area(y) => Ok(Deriv3::constant(0.0)),
        Err(e) => Err(label(e, what, index)),
    }
}

#[inline]
/// `sum += d` for the parts `order` computes (the others are zero in every element and stay zero in
/// the sum: skipping them changes no bits, and a value batch is not slowed by twelve zero adds).
fn add(sum: &mut Deriv3, d: &Deriv3, order: Order) {
    sum.value += d.value;
    if order.gradient() {
        sum.gradient += d.gradient;
    }
    if order.hessian() {
        sum.hessian += d.hessian;
    }
}

fn check_len(actual: usize, expected: usize, what: &str, of: &str) -> Result<()> {
    if actual == expected {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!(
            "{what} holds {actual} elements, expected one per {} ({expected})",
            of.trim_end_matches('s')
        )))
    }
}

fn check_points(points: &[DVec3], what: &str) -> Result<()> {
    match points.iter().position(|p| !p.is_finite()) {
        None => Ok(()),
        Some(i) => Err(Error::InvalidArgument(format!(
            "{what} {i} is not finite ({})",
            points[i]
        ))),
    }
}

/// The single kernel's normal check (finite, unit length within 1e-6), done up front so that a
/// bad normal is reported even for an empty batch.
fn check_normal(n: DVec3) -> Result<()> {
    crate::kernels::form_factor::validate::unit_normal(n).map(|_| ())
}
