//! Record radii from a Hessian: the ellipse (surface, flatland medium) or ellipsoid (medium) over
//! which a first-order extrapolation stays within an error tolerance.
//!
//! # What is bounded (the papers' radius formulas differ in how they bound the error integral)
//!
//! A record at x extrapolates to first order, `f(x + d) ≈ f(x) + ∇f·d`. Taking the second-order
//! Taylor expansion as the oracle, the error at offset `d` is `½ |dᵀ H d|` (thesis eq. 4.16, Marco
//! eq. 20). In the eigenbasis of the symmetric Hessian, `|dᵀ H d| ≤ Σ |λ_i| d_i²` (triangle
//! inequality; equality when H is definite). The quantity this module bounds is the **integrated**
//! error over the record's region D, an ellipse (2D) or ellipsoid (3D) whose axes are the
//! eigenvectors:
//!
//! ```text
//!   E(D) = ½ ∫_D |dᵀ H d| dd  ≤  B(D) = ½ Σ_i |λ_i| ∫_D d_i² dd
//!   2D, semi-axes a_i:  ∫ d_1² = π a_1³ a_2 / 4            ⇒ B = (π/8)  a_1 a_2     Σ |λ_i| a_i²
//!   3D, semi-axes a_i:  ∫ d_1² = 4π a_1³ a_2 a_3 / 15      ⇒ B = (2π/15) a_1 a_2 a_3 Σ |λ_i| a_i²
//! ```
//!
//! and the radii are chosen so that `B(D) = τ` exactly, with the tolerance `τ = error` in
//! [`ErrorMode::Absolute`] (units: value·L² in 2D, value·L³ in 3D) or `τ = error·|value|` in
//! [`ErrorMode::Relative`] (units L², L³: the thesis eq. 6.7 and Marco eq. 20 divide by the value).
//!
//! Shape: the ellipse of largest area (ellipsoid of largest volume) with `B = τ` has
//! `|λ_i| a_i²` equal on every axis (Lagrange multipliers; AM-GM), so `a_i ∝ |λ_i|^{-1/2}`. The
//! axis ratios are then clamped to `max_anisotropy` relative to the shortest axis, and one common
//! scale solves `B = τ` for the clamped shape, so the bound holds whatever the clamp did.
//!
//! Relation to the papers: for an isotropic Hessian in 2D this is exactly thesis eq. 4.19 / 6.9 and
//! Marco eq. 21, `R = (4τ/(π|λ|))^{1/4}`. The papers' anisotropic formulas (thesis eq. 4.22 / 6.9,
//! Marco eq. 21) take every axis from that isotropic formula; over the resulting ellipse `B` is
//! `τ (a_1/a_2 + a_2/a_1)/2`, above the tolerance whenever the radii differ. Marco eq. 22,
//! `R = (15τ/(4π|λ|))^{1/5}`, bounds `∫ |λ| d_1²` (one axis, no ½); for an isotropic Hessian `B` is
//! then 1.5 τ. Ours is `R = (5τ/(2π|λ|))^{1/5}` in that case. `tests/radii_*.rs` integrate the
//! error numerically over the returned regions and check both statements.
//!
//! Limits: where the Hessian vanishes (all eigenvalues zero, or the radius would exceed it) a
//! radius is [`MAX_RADIUS`]; tangent eigenvalues below the rounding level of the projection
//! (16 ε times the largest entry of the 3x3 Hessian) count as zero; a zero eigenvalue alone is
//! handled by the anisotropy clamp. A zero tolerance (relative mode at `value == 0`, or
//! `error == 0`) with a non-zero Hessian gives radii 0.
//!
//! Hostile input: for **any finite** Hessian (entries up to `±f64::MAX`, subnormal, zero,
//! indefinite, not symmetric) and any finite arguments that pass validation, every radius is
//! finite and in `[0, MAX_RADIUS]`, ascending, with orthonormal axes. The matrix is scaled by its
//! largest entry before it is projected and decomposed, and the radius is solved one factor at a
//! time (`τ^{1/p}`, `|λ|^{1/p}`, ...), so neither the matrix nor the tolerance nor the anisotropy
//! overflows or underflows on the way; a radius is 0 only when it is below the smallest positive
//! double or the curvature itself overflows (3x3 entries within a factor 3 of `f64::MAX`).
//! `tests/radii_hostile.rs` and `ffi-tests/radii_hostile.c` try such matrices.

use glam::{DMat2, DMat3, DVec2, DVec3};
use nalgebra::{Matrix2, Matrix3};

use crate::error::{ensure_finite, ensure_finite3, Error, Result};

/// Largest radius returned (in the caller's length unit L): the radius of a record whose Hessian is
/// zero (or so small that the formula would exceed it) along that axis.
pub static MAX_RADIUS: f64 = 1e30;

/// Largest anisotropy the radii functions apply: a larger `max_anisotropy` acts as this one (the
/// axis-ratio product of the solve stays far from overflow).
const ANISOTROPY_CAP: f64 = 1e30;

/// Default weight κ of [`CurvatureFloor`]: 1% of the tangent curvature `4E/D²` of the
/// irradiance from a small source straight above the record at distance `D`.
pub const CURVATURE_FLOOR_WEIGHT: f64 = 0.04;

/// The robustness term of surface record radii: a curvature `κ·|value|/D²` added to the
/// magnitude of each tangent eigenvalue of the Hessian before the radii are solved for.
///
/// # Why a floor, and why this one
/// The thesis (sec. 6.3) makes radii robust by adding 1% of the irradiance to every triangle's
/// radiance. Its Hessian is that of a closed environment of uniform radiance, whose irradiance is
/// the constant πL wherever the receiver stands: its tangent projection is zero (to rounding), so
/// the term changes nothing, and a black gather (zero Hessian) gets the largest radius, the
/// opposite of what the term is for. A floor on the *magnitudes* does what it meant to do.
/// Irradiance `E` from a small source at distance `D` straight above a receiver has tangent
/// curvature `4E/D²` along every axis (`E ∝ D²/(D² + s²)²`); the floor is `κ` times `E/D²` with
/// `D` the gather's harmonic-mean hit distance (Ward's `R`), so where the estimated Hessian
/// vanishes the record's radius is `(4 ε D²/(πκ))^{1/4}` for a relative tolerance `ε` (the surface
/// bound of the module docs, isotropic), and where `|λ| ≫ κE/D²` the radii change by
/// `≈ κE/(4D²|λ|)` relative. In [`ErrorMode::Relative`] radii depend only on `|λ|/|value|`, so a
/// black gather (value and Hessian zero) takes the limit `κ/D²` and gets that split-sphere radius,
/// not the largest one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurvatureFloor {
    /// `D` (L, > 0): the gather's harmonic-mean hit distance (`GatherValues::harmonic_mean_distance`).
    pub distance: f64,
    /// `κ` (≥ 0, dimensionless); [`CURVATURE_FLOOR_WEIGHT`] by default; 0 turns the floor off.
    pub weight: f64,
}

impl CurvatureFloor {
    /// The floor for a gather whose harmonic-mean hit distance is `distance`, with the default
    /// weight [`CURVATURE_FLOOR_WEIGHT`].
    pub fn new(distance: f64) -> Self {
        CurvatureFloor {
            distance,
            weight: CURVATURE_FLOOR_WEIGHT,
        }
    }

    fn check(&self) -> Result<()> {
        if !(self.distance > 0.0 && self.distance.is_finite()) {
            return Err(Error::InvalidArgument(format!(
                "curvature floor distance must be positive and finite (got {})",
                self.distance
            )));
        }
        if !(self.weight >= 0.0 && self.weight.is_finite()) {
            return Err(Error::InvalidArgument(format!(
                "curvature floor weight must be >= 0 and finite (got {})",
                self.weight
            )));
        }
        Ok(())
    }
}

/// How the error tolerance is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum ErrorMode {
    /// `error` bounds the integrated absolute error (thesis eq. 4.21-4.22).
    Absolute = 0,
    /// `error` bounds the integrated error divided by `|value|` (thesis eq. 6.7-6.9, Marco eq. 20-22).
    Relative = 1,
}

impl TryFrom<u32> for ErrorMode {
    type Error = Error;
    fn try_from(v: u32) -> Result<Self> {
        match v {
            0 => Ok(ErrorMode::Absolute),
            1 => Ok(ErrorMode::Relative),
            _ => Err(Error::InvalidArgument(format!(
                "error mode {v} is not RADDIFF_ERROR_ABSOLUTE (0) or RADDIFF_ERROR_RELATIVE (1)"
            ))),
        }
    }
}

/// An elliptical surface record: semi-axes `radii[0] <= radii[1]` along the unit tangent `axes`.
///
/// `axes[0]` is the direction of strongest curvature (largest |eigenvalue|); both axes are
/// perpendicular to the normal and to each other.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceRadii {
    /// Semi-axis lengths (L), ascending.
    pub radii: [f64; 2],
    /// Unit world-space directions of the semi-axes.
    pub axes: [DVec3; 2],
}

/// An ellipsoidal media record: semi-axes `radii[0] <= radii[1] <= radii[2]` along orthonormal `axes`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumeRadii {
    /// Semi-axis lengths (L), ascending.
    pub radii: [f64; 3],
    /// Unit directions of the semi-axes (a right- or left-handed orthonormal set).
    pub axes: [DVec3; 3],
}

/// An elliptical flatland record (Marco eq. 21): semi-axes `radii[0] <= radii[1]` along `axes`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EllipseRadii {
    /// Semi-axis lengths (L), ascending.
    pub radii: [f64; 2],
    /// Unit directions of the semi-axes.
    pub axes: [DVec2; 2],
}

/// The 2x2 Hessian on the plane spanned by the orthonormal `u1`, `u2` (thesis eq. 4.17):
/// `[[u1·H u1, u1·H u2], [u2·H u1, u2·H u2]]`, symmetrized.
pub fn tangent_hessian(hessian: DMat3, u1: DVec3, u2: DVec3) -> DMat2 {
    let a = hessian * u1;
    let b = hessian * u2;
    let off = 0.5 * (u1.dot(b) + u2.dot(a));
    DMat2::from_cols(DVec2::new(u1.dot(a), off), DVec2::new(off, u2.dot(b)))
}

/// An orthonormal tangent basis `(u1, u2)` of the unit `normal` with `u1 × u2 = normal`
/// (Duff et al. 2017, continuous except on the `normal.z = -1` branch cut).
pub fn tangent_basis(normal: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(normal.z);
    let a = -1.0 / (sign + normal.z);
    let b = normal.x * normal.y * a;
    (
        DVec3::new(
            1.0 + sign * normal.x * normal.x * a,
            sign * b,
            -sign * normal.x,
        ),
        DVec3::new(b, sign + normal.y * normal.y * a, -normal.y),
    )
}

/// Integrated error bound `B = ½ Σ |λ_i| ∫ d_i²` over the ellipse with semi-axes `radii[i]` along
/// the eigenvectors of eigenvalues `eigenvalues[i]` (module docs). Units: value·L².
pub fn ellipse_error_bound(eigenvalues: [f64; 2], radii: [f64; 2]) -> f64 {
    let s: f64 = eigenvalues
        .iter()
        .zip(radii)
        .map(|(l, a)| l.abs() * a * a)
        .sum();
    std::f64::consts::PI / 8.0 * radii[0] * radii[1] * s
}

/// Integrated error bound `B = ½ Σ |λ_i| ∫ d_i²` over the ellipsoid with semi-axes `radii[i]` along
/// the eigenvectors of eigenvalues `eigenvalues[i]` (module docs). Units: value·L³.
pub fn ellipsoid_error_bound(eigenvalues: [f64; 3], radii: [f64; 3]) -> f64 {
    let s: f64 = eigenvalues
        .iter()
        .zip(radii)
        .map(|(l, a)| l.abs() * a * a)
        .sum();
    2.0 * std::f64::consts::PI / 15.0 * radii[0] * radii[1] * radii[2] * s
}

fn check_common(value: f64, error: f64, max_anisotropy: f64) -> Result<()> {
    ensure_finite(value, "value")?;
    ensure_finite(error, "error")?;
    ensure_finite(max_anisotropy, "max_anisotropy")?;
    if error < 0.0 {
        return Err(Error::InvalidArgument(format!(
            "error must be >= 0 (got {error})"
        )));
    }
    if max_anisotropy < 1.0 {
        return Err(Error::InvalidArgument(format!(
            "max_anisotropy must be >= 1 (got {max_anisotropy})"
        )));
    }
    Ok(())
}

fn tolerance(value: f64, error: f64, mode: ErrorMode) -> f64 {
    match mode {
        ErrorMode::Absolute => error,
        ErrorMode::Relative => error * value.abs(),
    }
}

/// Semi-axes for the eigenvalue magnitudes `mu` sorted descending (module docs), in the same order.
///
/// `mu` is given divided by a positive `scale` (so that its largest entry is about 1 and nothing
/// overflows); `tau` is the tolerance in unscaled units.
fn solve_radii<const D: usize>(
    mu: [f64; D],
    scale: f64,
    tau: f64,
    max_anisotropy: f64,
) -> [f64; D] {
    let top = mu[0];
    if top <= 0.0 || scale <= 0.0 {
        return [MAX_RADIUS; D];
    }
    // A cap near f64::MAX overflows the shape product below (found by fuzzing: caps near 1e280
    // gave radii [0, 1e30, 0]); axis ratios beyond 1e30 mean nothing anyway.
    let max_anisotropy = max_anisotropy.min(ANISOTROPY_CAP);
    if tau <= 0.0 {
        return [0.0; D];
    }
    // Shape: a_i ∝ |λ_i|^{-1/2} relative to the shortest axis, clamped to the anisotropy.
    let mut shape = [1.0; D];
    // `ratio·A² ≤ 1` without forming A² (it overflows for A above 1e154).
    let limit = max_anisotropy.recip().powi(2);
    for i in 1..D {
        let ratio = mu[i] / top;
        shape[i] = if ratio <= limit {
            max_anisotropy
        } else {
            // (not `ratio.recip().sqrt()`: the reciprocal of a subnormal ratio overflows)
            ratio.sqrt().recip()
        };
    }
    let (constant, power): (f64, f64) = if D == 2 {
        (std::f64::consts::PI / 8.0, 4.0)
    } else {
        (2.0 * std::f64::consts::PI / 15.0, 5.0)
    };
    let weighted: f64 = mu.iter().zip(shape).map(|(m, s)| m / top * s * s).sum();
    // B(R·shape) = constant · R^power · Π shape · (top·scale) · weighted = tau, solved one factor
    // at a time: their product may overflow or underflow (a Hessian entry of 1e300, a tolerance
    // of 1e-300, an anisotropy of 1e200) where R itself is representable.
    let root = |x: f64| x.powf(power.recip());
    let product_root: f64 = shape.iter().map(|&s| root(s)).product();
    let r = root(tau) / (root(top) * root(scale) * root(constant * weighted) * product_root);
    let mut out = [0.0; D];
    for i in 0..D {
        let a = r * shape[i];
        out[i] = if a.is_nan() {
            MAX_RADIUS
        } else {
            a.clamp(0.0, MAX_RADIUS)
        };
    }
    out
}

fn max_abs(values: &[f64]) -> f64 {
    values.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// Entries of a matrix scaled to largest entry 1 below this magnitude are set to zero before the
/// eigen-solver runs: they move no eigenvalue by more than 3e-150 (far below rounding), and
/// subnormal operands made the iterative solver return NaN eigenvectors
/// (`tests/radii_hostile.rs`).
const FLUSH: f64 = 1e-150;

#[inline]
fn flush(v: f64) -> f64 {
    if v.abs() < FLUSH {
        0.0
    } else {
        v
    }
}

/// Eigen-decomposition of a symmetric 2x2 matrix, eigenvalues by descending magnitude, after scaling
/// by `scale` (returned) so that the largest entry is 1.
fn eigen2(m: DMat2) -> (f64, [f64; 2], [DVec2; 2]) {
    let scale = max_abs(&m.to_cols_array());
    if scale == 0.0 {
        return (0.0, [0.0; 2], [DVec2::X, DVec2::Y]);
    }
    // Division, not multiplication by the reciprocal: that of a subnormal scale overflows.
    let s = m / scale;
    let off = flush(0.5 * (s.x_axis.y + s.y_axis.x));
    let eig = Matrix2::new(flush(s.x_axis.x), off, off, flush(s.y_axis.y)).symmetric_eigen();
    if !(eig.eigenvalues.iter().all(|v| v.is_finite())
        && eig.eigenvectors.iter().all(|v| v.is_finite()))
    {
        return (scale, [s.x_axis.x, s.y_axis.y], [DVec2::X, DVec2::Y]);
    }
    let mut idx = [0usize, 1];
    idx.sort_by(|&a, &b| {
        eig.eigenvalues[b]
            .abs()
            .total_cmp(&eig.eigenvalues[a].abs())
    });
    let vals = idx.map(|i| eig.eigenvalues[i]);
    let first = eig.eigenvectors.column(idx[0]);
    let v0 = DVec2::new(first[0], first[1])
        .try_normalize()
        .unwrap_or(DVec2::X);
    // The second axis is the perpendicular of the first: exactly orthonormal, whatever the solver did.
    let v1 = v0.perp();
    (scale, vals, [v0, v1])
}

/// Eigen-decomposition of a symmetric 3x3 matrix, eigenvalues by descending magnitude, after scaling
/// by `scale` (returned) so that the largest entry is 1.
fn eigen3(m: DMat3) -> (f64, [f64; 3], [DVec3; 3]) {
    let scale = max_abs(&m.to_cols_array());
    if scale == 0.0 {
        return (0.0, [0.0; 3], [DVec3::X, DVec3::Y, DVec3::Z]);
    }
    let s = m / scale;
    let sym = |i: usize, j: usize| flush(0.5 * (s.col(j)[i] + s.col(i)[j]));
    let mat = Matrix3::from_fn(sym);
    let eig = mat.symmetric_eigen();
    if !(eig.eigenvalues.iter().all(|v| v.is_finite())
        && eig.eigenvectors.iter().all(|v| v.is_finite()))
    {
        // Never seen after the flush; a finite answer (the diagonal) rather than NaN radii.
        let d = [mat[(0, 0)], mat[(1, 1)], mat[(2, 2)]];
        let mut idx = [0usize, 1, 2];
        idx.sort_by(|&a, &b| d[b].abs().total_cmp(&d[a].abs()));
        let axis = [DVec3::X, DVec3::Y, DVec3::Z];
        return (scale, idx.map(|i| d[i]), idx.map(|i| axis[i]));
    }
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&a, &b| {
        eig.eigenvalues[b]
            .abs()
            .total_cmp(&eig.eigenvalues[a].abs())
    });
    let vals = idx.map(|i| eig.eigenvalues[i]);
    let col = |i: usize| {
        let c = eig.eigenvectors.column(idx[i]);
        DVec3::new(c[0], c[1], c[2])
    };
    // Re-orthonormalize (Gram-Schmidt, third = cross) so the axes are exactly orthonormal.
    // A solver's vectors can be (nearly) parallel for a (nearly) repeated eigenvalue: any
    // orthonormal completion is then an eigenbasis too.
    let v0 = col(0).try_normalize().unwrap_or(DVec3::X);
    let v1 = (col(1) - v0 * v0.dot(col(1)))
        .try_normalize()
        .filter(|v| v.dot(v0).abs() < 1e-6)
        .unwrap_or_else(|| v0.any_orthonormal_vector());
    let v2 = v0.cross(v1);
    (scale, vals, [v0, v1, v2])
}

/// Radii of an elliptical surface record from the 3x3 Hessian at a surface point (thesis ch. 4.2 and
/// 6.3, with the bound of the module docs).
///
/// * `hessian`: 3x3 translation Hessian of the cached quantity (value/L²); only its symmetric part
///   matters and it is projected onto the tangent plane of `normal` (thesis eq. 4.17).
/// * `normal`: unit surface normal (length within 1e-6 of 1).
/// * `value`: the record's value (used in [`ErrorMode::Relative`]).
/// * `error`: tolerance ≥ 0 on the integrated error over the record (module docs for units).
/// * `max_anisotropy`: largest `radii[1] / radii[0]`, ≥ 1 (the thesis uses 2).
///
/// Returns radii ascending and world-space tangent axes. Never Inf or NaN: see the module limits.
pub fn surface_radii(
    hessian: DMat3,
    normal: DVec3,
    value: f64,
    error: f64,
    mode: ErrorMode,
    max_anisotropy: f64,
) -> Result<SurfaceRadii> {
    let n = checked_surface_input(hessian, normal, value, error, max_anisotropy)?;
    surface_radii_with(hessian, n, value, error, mode, max_anisotropy, None)
}

/// Validates the arguments of the surface radii functions; returns the unit normal.
fn checked_surface_input(
    hessian: DMat3,
    normal: DVec3,
    value: f64,
    error: f64,
    max_anisotropy: f64,
) -> Result<DVec3> {
    if !hessian.is_finite() {
        return Err(Error::InvalidArgument("hessian is not finite".into()));
    }
    ensure_finite3(normal, "normal")?;
    check_common(value, error, max_anisotropy)?;
    let len = normal.length();
    if (len - 1.0).abs() > 1e-6 {
        return Err(Error::InvalidArgument(format!(
            "normal must be a unit vector (length {len})"
        )));
    }
    Ok(normal / len)
}

/// [`surface_radii`] with the robustness term [`CurvatureFloor`]: `κ·|value|/D²` is added to the
/// magnitude of each tangent eigenvalue (same axes). In [`ErrorMode::Relative`] with `value == 0`
/// and a zero tangent Hessian (a black gather) the radii are the limit of `value → 0`, those of
/// the relative curvature `κ/D²` alone; in [`ErrorMode::Absolute`] a zero value adds nothing.
/// Finite for any finite input; `InvalidArgument` for a non-positive or non-finite distance or a
/// negative or non-finite weight, and as [`surface_radii`].
pub fn surface_radii_floored(
    hessian: DMat3,
    normal: DVec3,
    value: f64,
    error: f64,
    mode: ErrorMode,
    max_anisotropy: f64,
    floor: CurvatureFloor,
) -> Result<SurfaceRadii> {
    floor.check()?;
    let n = checked_surface_input(hessian, normal, value, error, max_anisotropy)?;
    surface_radii_with(hessian, n, value, error, mode, max_anisotropy, Some(floor))
}

/// The body of [`surface_radii`] for a validated unit normal `n`, with an optional floor.
fn surface_radii_with(
    hessian: DMat3,
    n: DVec3,
    value: f64,
    error: f64,
    mode: ErrorMode,
    max_anisotropy: f64,
    floor: Option<CurvatureFloor>,
) -> Result<SurfaceRadii> {
    let (u1, u2) = tangent_basis(n);
    // Scaled first so that the projection cannot overflow (entries up to f64::MAX): `pre` is the
    // largest entry's magnitude, the projected matrix's entries are then at most 3.
    let pre = max_abs(&hessian.to_cols_array());
    let unit = if pre > 0.0 { hessian / pre } else { hessian };
    let (tangent_scale, vals, vecs) = eigen2(tangent_hessian(unit, u1, u2));
    // The projection rounds at ~ε‖H‖: tangent curvature below that is noise, not information.
    let noise = 16.0 * f64::EPSILON;
    let mut mu = vals.map(|v| {
        if v.abs() * tangent_scale <= noise {
            0.0
        } else {
            v.abs()
        }
    });
    // May overflow to infinity for entries near f64::MAX; `solve_radii` then returns radii 0,
    // the limit of an unbounded curvature.
    let mut scale = tangent_scale * if pre > 0.0 { pre } else { 1.0 };
    let mut value = value;
    if let Some(f) = floor {
        let flat = mu.iter().all(|&m| m == 0.0);
        if mode == ErrorMode::Relative && value == 0.0 && flat {
            // radii depend on |λ|/|value| only: the black gather's limit is κ/D² at value 1
            value = 1.0;
        }
        let add = f.weight * value.abs() / (f.distance * f.distance);
        let add = if add.is_finite() { add } else { f64::MAX };
        // |λ|·scale + add for each axis, in units of the larger of the two so nothing overflows
        // (the order of the magnitudes is kept: the same term is added to each).
        let unit = if scale.is_finite() {
            scale.max(add)
        } else {
            f64::MAX
        };
        if unit > 0.0 {
            let ratio = if scale.is_finite() { scale / unit } else { 1.0 };
            mu = mu.map(|m| m * ratio + add / unit);
            scale = unit;
        }
    }
    let radii = solve_radii(mu, scale, tolerance(value, error, mode), max_anisotropy);
    let axes = vecs.map(|v| (u1 * v.x + u2 * v.y).normalize());
    Ok(SurfaceRadii { radii, axes })
}

/// Radii of an elliptical flatland media record from the 2x2 Hessian (Marco eq. 21, with the bound
/// of the module docs). Arguments as in [`surface_radii`] without the projection.
pub fn ellipse_radii(
    hessian: DMat2,
    value: f64,
    error: f64,
    mode: ErrorMode,
    max_anisotropy: f64,
) -> Result<EllipseRadii> {
    if !hessian.is_finite() {
        return Err(Error::InvalidArgument("hessian is not finite".into()));
    }
    check_common(value, error, max_anisotropy)?;
    let (scale, vals, axes) = eigen2(hessian);
    let mu = vals.map(|v| v.abs());
    let radii = solve_radii(mu, scale, tolerance(value, error, mode), max_anisotropy);
    Ok(EllipseRadii { radii, axes })
}

/// Radii of an ellipsoidal media record from the 3x3 Hessian (Marco eq. 22, with the bound of the
/// module docs; for an isotropic Hessian `R = (5τ/(2π|λ|))^{1/5}`).
///
/// * `max_anisotropy`: largest `radii[2] / radii[0]`, ≥ 1.
///
/// Other arguments as in [`surface_radii`]. Returns radii ascending along orthonormal axes, the
/// first along the eigenvector of largest |eigenvalue|.
pub fn volume_radii(
    hessian: DMat3,
    value: f64,
    error: f64,
    mode: ErrorMode,
    max_anisotropy: f64,
) -> Result<VolumeRadii> {
    if !hessian.is_finite() {
        return Err(Error::InvalidArgument("hessian is not finite".into()));
    }
    check_common(value, error, max_anisotropy)?;
    let (scale, vals, axes) = eigen3(hessian);
    let mu = vals.map(|v| v.abs());
    let radii = solve_radii(mu, scale, tolerance(value, error, mode), max_anisotropy);
    Ok(VolumeRadii { radii, axes })
}

#[cfg(test)]
mod tests;
