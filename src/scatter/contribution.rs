//! The contribution I_e F A φ / D of one refracted light path L → P → V (report eq. 5-7).
//!
//! Units and meaning. A point light of intensity I (power per steradian) at L refracts into the
//! medium at P and reaches V. The irradiance at V on a plane perpendicular to the refracted ray is
//! `E = I T(θ_i) exp(−σ_t d_V) / D` with
//!
//! * `T(θ_i)` the unpolarized Fresnel transmittance from outside (index 1) into the medium (index η)
//!   at the incidence angle θ_i between ω_L and the shading normal n_s(P);
//! * `D = dA_V⊥ / dΩ_L` (L²): the cross-section at V of the refracted beam per unit solid angle
//!   leaving the light. Without refraction D = |LV|². Computed from ray differentials (Igehy 1999)
//!   of the refracted direction with respect to the surface point, including the variation of the
//!   interpolated normal (report eq. 7), or for a flat facet in closed form (eq. 6, corrected below).
//!
//! The single-scattered radiance at V towards the eye is σ_s φ(cos θ) E (per unit length along the
//! eye segment), φ the Henyey-Greenstein phase function of the angle between the propagation
//! direction ω_V (from P to V) and the direction to the eye, −u. Attenuated by exp(−σ_t x) back to
//! the entry point and integrated over x in [0, length], it gives the radiance arriving at the entry
//! point along the eye segment, inside the medium (power per area per steradian). The refraction out
//! of the medium towards the camera (Fresnel transmittance and the 1/η² radiance factor) is left to
//! the caller, who knows the camera side.
//!
//! The report's eq. 6 is the reverse quantity dA_L⊥/dΩ_V (traced from V to the light, eq. 7) and is
//! misprinted: with c_L = |ω_L·n|, c_V = |ω_V·n| the reverse factor is
//! `(d_V + η d_L)(c_L/c_V d_V + η c_V/c_L d_L)` (the report drops the η of the second d_L term). By
//! conservation of étendue (η² dA_V⊥ dΩ_V = dA_L⊥ dΩ_L) the forward factor used here is that divided
//! by η², which the tests check against a finite-difference trace in both directions. With
//! interpolated normals the two directions differ slightly (a normal field that is not the normal of
//! a surface makes the refraction map non-reciprocal): the forward D is used because it conserves the
//! light's power, E dA_V⊥ = I T dΩ_L.

use glam::{DVec2, DVec3};

use super::constraint::{d_normalize, EyeSegment, TriangleGeometry};

/// Which distance factor D to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DistanceFactor {
    /// Ray differentials through the interpolated normals (report eq. 7): accurate.
    #[default]
    Interpolated,
    /// The flat-interface closed form with the geometric normal (report eq. 6, corrected): what a
    /// renderer gets when it ignores the normal interpolation in D (report Fig. 9).
    Flat,
}

/// The homogeneous medium inside the mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Medium {
    /// Relative index of refraction (inside over outside), > 1.
    pub eta: f64,
    /// Extinction coefficient σ_t (1/L), ≥ 0.
    pub sigma_t: f64,
    /// Scattering coefficient σ_s (1/L), in [0, σ_t].
    pub sigma_s: f64,
    /// Henyey-Greenstein asymmetry g in (−1, 1); 0 is isotropic, > 0 forward scattering.
    pub g: f64,
}

impl Medium {
    /// Checks the domain of every field.
    pub fn validate(&self) -> crate::Result<()> {
        use crate::error::{ensure_finite, Error};
        ensure_finite(self.eta, "medium.eta")?;
        ensure_finite(self.sigma_t, "medium.sigma_t")?;
        ensure_finite(self.sigma_s, "medium.sigma_s")?;
        ensure_finite(self.g, "medium.g")?;
        if self.eta <= 1.0 {
            return Err(Error::InvalidArgument(format!(
                "medium.eta must be > 1 (got {}): the method assumes light refracts into a denser medium; \
                 for an index-matched medium (eta = 1) call straight_line_single_scatter",
                self.eta
            )));
        }
        if self.sigma_t < 0.0 || self.sigma_s < 0.0 || self.sigma_s > self.sigma_t {
            return Err(Error::InvalidArgument(format!(
                "need 0 <= sigma_s <= sigma_t (got sigma_s = {}, sigma_t = {})",
                self.sigma_s, self.sigma_t
            )));
        }
        if self.g <= -1.0 || self.g >= 1.0 {
            return Err(Error::InvalidArgument(format!(
                "medium.g must lie in (-1, 1) (got {})",
                self.g
            )));
        }
        Ok(())
    }
}

/// Unpolarized Fresnel transmittance from index 1 into index `eta` > 1 at incidence cosine `cos_i`
/// in [0, 1]. Entering a denser medium has no total internal reflection; T(1) = 4η/(1+η)².
pub fn fresnel_transmittance(cos_i: f64, eta: f64) -> f64 {
    let ci = cos_i.clamp(0.0, 1.0);
    let sin_t2 = (1.0 - ci * ci) / (eta * eta);
    let ct = (1.0 - sin_t2).max(0.0).sqrt();
    let rs = (ci - eta * ct) / (ci + eta * ct);
    let rp = (eta * ci - ct) / (eta * ci + ct);
    (1.0 - 0.5 * (rs * rs + rp * rp)).clamp(0.0, 1.0)
}

/// Henyey-Greenstein phase function (1/sr) at the cosine of the scattering angle; integrates to 1
/// over the sphere. |g| < 1.
pub fn henyey_greenstein(cos_theta: f64, g: f64) -> f64 {
    let denom = 1.0 + g * g - 2.0 * g * cos_theta.clamp(-1.0, 1.0);
    (1.0 - g * g) / (4.0 * std::f64::consts::PI * denom * denom.sqrt())
}

/// The forward distance factor D = dA_V⊥/dΩ_L (L²) for a flat interface with unit normal `n`,
/// distances `d_l` = |PL|, `d_v` = |PV| and directions ω_L, ω_V (corrected report eq. 6 over η²).
pub fn distance_factor_flat(n: DVec3, wl: DVec3, wv: DVec3, d_l: f64, d_v: f64, eta: f64) -> f64 {
    let cl = wl.dot(n).abs();
    let cv = wv.dot(n).abs();
    (d_v + eta * d_l) * (cl / cv * d_v + eta * cv / cl * d_l) / (eta * eta)
}

/// The forward distance factor D = dA_V⊥/dΩ_L (L²) with interpolated normals, from the ray
/// differentials of the refracted ray with respect to the barycentric coordinates at P.
///
/// `None` if the refraction is undefined at P (light not on the outer side of n_s).
pub fn distance_factor_interpolated(
    tri: &TriangleGeometry,
    ab: DVec2,
    light: DVec3,
    d_v: f64,
    eta: f64,
) -> Option<f64> {
    let p = tri.point(ab);
    let l = p - light;
    let d_l = l.length();
    let m = tri.raw_normal(ab);
    let dm = m.length();
    if !(d_l > 0.0 && dm > 0.0) {
        return None;
    }
    let w = l / d_l; // propagation direction of the incident light
    let n = m / dm;
    let c = -w.dot(n);
    if !(c > 0.0) {
        return None;
    }
    let ct = (1.0 - (1.0 - c * c) / (eta * eta)).max(0.0).sqrt();
    if !(ct > 0.0) {
        return None;
    }
    let t = w / eta + (c / eta - ct) * n;
    let edges = [tri.e1, tri.e2];
    let dnormal = [
        tri.normals[1] - tri.normals[0],
        tri.normals[2] - tri.normals[0],
    ];
    let mut a = [DVec3::ZERO; 2];
    for q in 0..2 {
        let dw = d_normalize(w, d_l, edges[q]);
        let dn = d_normalize(n, dm, dnormal[q]);
        let dc = -(dw.dot(n) + w.dot(dn));
        let dct = c * dc / (eta * eta * ct);
        let dt = dw / eta + (dc / eta - dct) * n + (c / eta - ct) * dn;
        let spread = edges[q] + d_v * dt;
        a[q] = spread - t * t.dot(spread);
    }
    let area = a[0].cross(a[1]).length();
    let solid = edges[0].cross(edges[1]).dot(w).abs() / (d_l * d_l);
    if !(solid > 0.0) {
        return None;
    }
    Some(area / solid)
}

/// One refracted path and its contribution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathContribution {
    /// σ_s φ I T exp(−σ_t (x + d_V)) / D: radiance per unit length of the eye segment, carried to
    /// the entry point (power / (area · sr · L)).
    pub value: f64,
    /// The refraction point P.
    pub point: DVec3,
    /// Fresnel transmittance at P.
    pub fresnel: f64,
    /// The distance factor D (L²).
    pub distance_factor: f64,
    /// |PL| and |PV|.
    pub distances: DVec2,
}

/// The contribution of the path through (α, β) of `tri` to the point at `x` along `eye`, or `None`
/// when the path is not physical: the light must be on the outer side and V on the inner side of
/// both the geometric and the shading normal at P (Walter et al.'s sidedness agreement).
///
/// D is clamped below at 1e-12 (d_L + d_V)² so that the integrable caustic singularity (D → 0)
/// cannot produce an infinity; the clamp is reached only within ~1e-12 of a caustic.
#[allow(clippy::too_many_arguments)]
pub fn path_contribution(
    tri: &TriangleGeometry,
    ab: DVec2,
    eye: &EyeSegment,
    x: f64,
    light: DVec3,
    intensity: f64,
    medium: &Medium,
    distance_factor: DistanceFactor,
) -> Option<PathContribution> {
    let p = tri.point(ab);
    let v = eye.at(x);
    let (lv, vv) = (light - p, v - p);
    let (d_l, d_v) = (lv.length(), vv.length());
    if !(d_l > 0.0 && d_v > 0.0) {
        return None;
    }
    let (wl, wv) = (lv / d_l, vv / d_v);
    let ns = tri.raw_normal(ab).try_normalize()?;
    let ng = tri.geometric_normal;
    if !(wl.dot(ns) > 0.0 && wl.dot(ng) > 0.0 && wv.dot(ns) < 0.0 && wv.dot(ng) < 0.0) {
        return None;
    }
    let fresnel = fresnel_transmittance(wl.dot(ns), medium.eta);
    let d = match distance_factor {
        DistanceFactor::Interpolated => {
            distance_factor_interpolated(tri, ab, light, d_v, medium.eta)?
        }
        DistanceFactor::Flat => distance_factor_flat(ng, wl, wv, d_l, d_v, medium.eta),
    };
    let d = d.max(1e-12 * (d_l + d_v) * (d_l + d_v));
    let phase = henyey_greenstein(-wv.dot(eye.dir), medium.g);
    let attenuation = (-medium.sigma_t * (x + d_v)).exp();
    let value = medium.sigma_s * phase * intensity * fresnel * attenuation / d;
    value.is_finite().then_some(PathContribution {
        value,
        point: p,
        fresnel,
        distance_factor: d,
        distances: DVec2::new(d_l, d_v),
    })
}

#[cfg(test)]
mod tests;
