//! The refraction constraint f(x, α, β) = the tangential part (with respect to n_s) of
//! η ω_V + ω_L, and its analytic 3x3 Jacobian (after Holzschuch 2013, sec. 3.2.3, eq. 8).
//!
//! * `x` is the distance (length unit L) from the eye segment's entry point to the scattering point
//!   V(x) = entry + x u.
//! * (α, β) are the barycentric coordinates of P = P0 + α (P1 − P0) + β (P2 − P0) in the triangle plane.
//! * ω_V = (V − P)/|V − P| points into the medium, ω_L = (L − P)/|L − P| towards the light (outside).
//! * n_s(α, β) = normalize((1 − α − β) n0 + α n1 + β n2) is the outward interpolated shading normal.
//!
//! f = 0 exactly when the tangential parts of ω_L and η ω_V cancel, which is Snell's law at P for
//! the normal n_s when the light is on the outer and V on the inner side of n_s (callers check the
//! sides: f also vanishes on the mirrored configurations). The report writes f = ĥ + n_s with
//! ĥ = normalize(η ω_V + ω_L); at a solution |η ω_V + ω_L| = η cos θ_t − cos θ_i → 0 as η → 1, so the
//! direction ĥ, its Jacobian (divided by that length) and a residual tolerance on it degrade like
//! 1/(η − 1) (η = 1 + 1e-9 lost every path). The tangential form divides by nothing that vanishes:
//! its Jacobian is O(1/|V − P| + 1/|L − P|) for every η, and at a solution it equals |h| times the
//! report's (so the λ, μ of the interval analysis are unchanged).

use glam::{DMat3, DVec2, DVec3};

/// A triangle of a refractive mesh with its unit vertex shading normals (outward).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangleGeometry {
    /// Vertex P0 (α = β = 0).
    pub p0: DVec3,
    /// P1 − P0 (the α direction).
    pub e1: DVec3,
    /// P2 − P0 (the β direction).
    pub e2: DVec3,
    /// Unit shading normals at P0, P1, P2, pointing out of the medium.
    pub normals: [DVec3; 3],
    /// Unit geometric normal normalize(e1 × e2); counter-clockwise winding seen from outside makes it
    /// point out of the medium.
    pub geometric_normal: DVec3,
}

impl TriangleGeometry {
    /// Builds the triangle from its vertices and (not necessarily unit) vertex normals. Returns `None`
    /// if the triangle has zero area or a normal is zero; no other validation.
    pub fn new(p: [DVec3; 3], n: [DVec3; 3]) -> Option<Self> {
        let e1 = p[1] - p[0];
        let e2 = p[2] - p[0];
        let ng = e1.cross(e2).try_normalize()?;
        let normals = [
            n[0].try_normalize()?,
            n[1].try_normalize()?,
            n[2].try_normalize()?,
        ];
        Some(TriangleGeometry {
            p0: p[0],
            e1,
            e2,
            normals,
            geometric_normal: ng,
        })
    }

    /// The point with barycentric coordinates (α, β).
    #[inline]
    pub fn point(&self, ab: DVec2) -> DVec3 {
        self.p0 + ab.x * self.e1 + ab.y * self.e2
    }

    /// The interpolated (not yet normalized) shading normal at (α, β).
    #[inline]
    pub fn raw_normal(&self, ab: DVec2) -> DVec3 {
        (1.0 - ab.x - ab.y) * self.normals[0] + ab.x * self.normals[1] + ab.y * self.normals[2]
    }

    /// The vertex positions.
    pub fn vertices(&self) -> [DVec3; 3] {
        [self.p0, self.p0 + self.e1, self.p0 + self.e2]
    }

    /// Whether all three shading normals are equal (a flat facet).
    pub fn is_flat(&self) -> bool {
        self.normals[0] == self.normals[1] && self.normals[1] == self.normals[2]
    }
}

/// The eye segment: V(x) = origin + x dir for x in [0, length].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EyeSegment {
    /// The entry point (x = 0), where the radiance is gathered.
    pub origin: DVec3,
    /// Unit direction from entry to exit.
    pub dir: DVec3,
    /// Distance from entry to exit (L).
    pub length: f64,
}

impl EyeSegment {
    /// The segment from `entry` to `exit`; `None` if they coincide.
    pub fn new(entry: DVec3, exit: DVec3) -> Option<Self> {
        let d = exit - entry;
        let length = d.length();
        if !(length > 0.0 && length.is_finite()) {
            return None;
        }
        Some(EyeSegment {
            origin: entry,
            dir: d / length,
            length,
        })
    }

    /// The point at distance `x` from the entry.
    #[inline]
    pub fn at(&self, x: f64) -> DVec3 {
        self.origin + x * self.dir
    }
}

/// The refraction constraint of one triangle for one eye segment and one point light.
#[derive(Debug, Clone, Copy)]
pub struct Constraint<'a> {
    /// The triangle.
    pub tri: &'a TriangleGeometry,
    /// The eye segment.
    pub eye: &'a EyeSegment,
    /// The point light position (outside the medium).
    pub light: DVec3,
    /// Relative index of refraction η > 1 (medium over outside).
    pub eta: f64,
}

/// f and its Jacobian at one parameter point.
#[derive(Debug, Clone, Copy)]
pub struct ConstraintValue {
    /// f(x, α, β) (dimensionless; |f| ≤ η + 1).
    pub f: DVec3,
    /// Columns ∂f/∂x (per L), ∂f/∂α, ∂f/∂β.
    pub jacobian: DMat3,
}

/// d(v/|v|)/dq for v̂ = v/|v| and dv/dq (report eq. 8).
#[inline]
pub(crate) fn d_normalize(vhat: DVec3, len: f64, dv: DVec3) -> DVec3 {
    (dv - vhat * vhat.dot(dv)) / len
}

impl Constraint<'_> {
    /// f and (if `with_jacobian`) its Jacobian at (x, α, β). `None` where f is undefined: P at V or at
    /// L or a vanishing interpolated normal.
    pub fn eval(&self, x: f64, ab: DVec2, with_jacobian: bool) -> Option<ConstraintValue> {
        let p = self.tri.point(ab);
        let v = self.eye.at(x) - p;
        let l = self.light - p;
        let (dv, dl) = (v.length(), l.length());
        let m = self.tri.raw_normal(ab);
        let dm = m.length();
        if !(dv > 0.0 && dl > 0.0 && dm > 0.0) {
            return None;
        }
        let wv = v / dv;
        let wl = l / dl;
        let ns = m / dm;
        let h = self.eta * wv + wl;
        let hn = h.dot(ns);
        // The tangential part of h: no division by |h|, which is ~(η − 1) at a solution.
        let f = h - hn * ns;
        if !with_jacobian {
            return Some(ConstraintValue {
                f,
                jacobian: DMat3::ZERO,
            });
        }
        let t = self.tri;
        // d/dx: only ω_V moves (dV/dx = u); d/dα, d/dβ: P moves by e1, e2, so v and l move by −e.
        let dwv_x = d_normalize(wv, dv, self.eye.dir);
        let dwv_a = d_normalize(wv, dv, -t.e1);
        let dwv_b = d_normalize(wv, dv, -t.e2);
        let dwl_a = d_normalize(wl, dl, -t.e1);
        let dwl_b = d_normalize(wl, dl, -t.e2);
        let dns_a = d_normalize(ns, dm, t.normals[1] - t.normals[0]);
        let dns_b = d_normalize(ns, dm, t.normals[2] - t.normals[0]);
        // d(h − (h·n) n) = dh − (dh·n + h·dn) n − (h·n) dn.
        let df = |dh: DVec3, dn: DVec3| dh - (dh.dot(ns) + h.dot(dn)) * ns - hn * dn;
        let df_x = df(self.eta * dwv_x, DVec3::ZERO);
        let df_a = df(self.eta * dwv_a + dwl_a, dns_a);
        let df_b = df(self.eta * dwv_b + dwl_b, dns_b);
        Some(ConstraintValue {
            f,
            jacobian: DMat3::from_cols(df_x, df_a, df_b),
        })
    }
}

/// The direction of the ray refracted into the medium at a surface point, for light arriving from a
/// point `light` outside, with outward unit normal `n` and relative index `eta` > 1.
///
/// Returns `None` when the light is not strictly on the outer side of `n`. Entering a denser medium
/// never meets total internal reflection, so no other case fails.
#[inline]
pub fn refract_in(point: DVec3, light: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let w = (point - light).try_normalize()?;
    let cos_i = -w.dot(n);
    if !(cos_i > 0.0) {
        return None;
    }
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(w / eta + (cos_i / eta - cos_t) * n)
}

#[cfg(test)]
mod tests;
