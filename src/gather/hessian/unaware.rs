//! Occlusion-unaware irradiance gradient and Hessian (thesis eq. 4.3-4.14, Jarosz et al. 2012):
//! Monte-Carlo estimates that differentiate the geometry term of every hit but hold visibility
//! fixed, and the geometric Hessian (eq. 4.23). Provided to compare against the occlusion-aware
//! derivatives of [`super::occlusion`]; they need the surface normal at every hit.
//!
//! With `d = y − x`, `a = n_x·d`, `b = n_y·d` (`cosθ_x = a/r`, `cosθ_y = −b/r`), the geometry term
//! `G = cosθ_x cosθ_y / r² = −a b / r⁴` has, with respect to x,
//!
//! ```text
//!   ∇G = (b n_x + a n_y)/r⁴ − 4ab d/r⁶
//!   HG = −(n_x n_yᵀ + n_y n_xᵀ)/r⁴ + 4 [b (n_x dᵀ + d n_xᵀ) + a (n_y dᵀ + d n_yᵀ)]/r⁶
//!        − 24ab d dᵀ/r⁸ + 4ab 𝟙/r⁶
//! ```
//!
//! (eq. 4.9 and 4.14 with the thesis' `y` being `d`). A cosine-weighted stratum has area density
//! `p_A = (cosθ_x/π)(cosθ_y/r²)`, so each hit contributes `L ∇G π r²/(MN cosθ_x cosθ_y)`.
//! Misses contribute to the irradiance only (their geometry terms vanish at infinity); hits seen from
//! behind (`cosθ_y ≤ 0`) contribute nothing to the derivatives.

use glam::{DMat3, DVec3};

use super::gather_mesh::HemisphereGather;
use crate::error::{ensure_finite3, Error, Result};
use crate::Order;

/// Occlusion-unaware derivatives of one gather, per channel.
#[derive(Debug, Clone, PartialEq)]
pub struct UnawareDerivatives {
    /// Monte-Carlo irradiance `π/(MN) Σ L`.
    pub irradiance: Vec<f64>,
    /// Gradient (eq. 4.3 with 4.9), per L.
    pub gradient: Vec<DVec3>,
    /// Radiometric Hessian (eq. 4.10 with 4.14), per L²; zero unless requested.
    pub hessian: Vec<DMat3>,
}

fn sym(u: DVec3, v: DVec3) -> DMat3 {
    DMat3::from_cols(u * v.x + v * u.x, u * v.y + v * u.y, u * v.z + v * u.z)
}

/// Gradient and Hessian of `G(x ↔ y)` with respect to x, for `d = y − x`, receiver normal `nx` and
/// hit normal `ny` (module docs).
pub fn geometry_term_derivatives(
    d: DVec3,
    nx: DVec3,
    ny: DVec3,
    order: Order,
) -> (f64, DVec3, DMat3) {
    let a = nx.dot(d);
    let b = ny.dot(d);
    let r2 = d.length_squared();
    let r4 = r2 * r2;
    let r6 = r4 * r2;
    let g = -a * b / r4;
    if !order.gradient() {
        return (g, DVec3::ZERO, DMat3::ZERO);
    }
    let grad = (nx * b + ny * a) / r4 - d * (4.0 * a * b / r6);
    if !order.hessian() {
        return (g, grad, DMat3::ZERO);
    }
    let dd = DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    let h = sym(nx, ny) * (-1.0 / r4) + (sym(nx, d) * b + sym(ny, d) * a) * (4.0 / r6)
        - dd * (24.0 * a * b / (r6 * r2))
        + DMat3::IDENTITY * (4.0 * a * b / r6);
    (g, grad, h)
}

/// Occlusion-unaware irradiance, gradient and radiometric Hessian of a cosine-weighted hemisphere
/// gather (either hemisphere layout), given the unit surface normal at every hit (`hit_normals`,
/// one per direction; ignored for misses). No participating medium (`sigma_t` must be 0).
pub fn unaware_derivatives(
    g: &HemisphereGather,
    hit_normals: &[DVec3],
    order: Order,
) -> Result<UnawareDerivatives> {
    let count = g.directions.len();
    if g.channels == 0
        || g.distance.len() != count
        || hit_normals.len() != count
        || g.radiance.len() != count * g.channels
        || count == 0
    {
        return Err(Error::InvalidArgument(
            "directions, distances, hit normals and radiance (x channels) must have matching sizes"
                .into(),
        ));
    }
    if g.sigma_t != 0.0 {
        return Err(Error::InvalidArgument(
            "the occlusion-unaware estimator is implemented without a medium (sigma_t = 0)".into(),
        ));
    }
    ensure_finite3(g.normal, "normal")?;
    let nx = g.normal.normalize();
    let mut out = UnawareDerivatives {
        irradiance: vec![0.0; g.channels],
        gradient: vec![DVec3::ZERO; g.channels],
        hessian: vec![DMat3::ZERO; g.channels],
    };
    let w = std::f64::consts::PI / count as f64;
    for (i, &ny) in hit_normals.iter().enumerate() {
        let ls = &g.radiance[i * g.channels..(i + 1) * g.channels];
        for (e, &l) in out.irradiance.iter_mut().zip(ls) {
            *e += w * l as f64;
        }
        let r = g.distance[i];
        if !order.gradient() || !r.is_finite() {
            continue;
        }
        let dir = g.directions[i];
        ensure_finite3(ny, "hit normal")?;
        let cx = nx.dot(dir);
        let cy = -ny.dot(dir);
        if cx <= 0.0 || cy <= 0.0 {
            continue;
        }
        let d = dir * r;
        let (_, grad, hess) = geometry_term_derivatives(d, nx, ny, order);
        let weight = w * r * r / (cx * cy);
        for (c, &l) in ls.iter().enumerate() {
            let lw = l as f64 * weight;
            out.gradient[c] += grad * lw;
            if order.hessian() {
                out.hessian[c] += hess * lw;
            }
        }
    }
    Ok(out)
}

/// The geometric Hessian (thesis eq. 4.23): the radiometric Hessian with every hit's radiance
/// replaced by `l_max`, the largest radiance in the scene. Single channel.
pub fn geometric_hessian(g: &HemisphereGather, hit_normals: &[DVec3], l_max: f64) -> Result<DMat3> {
    let ones = vec![1.0f32; g.directions.len()];
    let unit = HemisphereGather {
        radiance: &ones,
        channels: 1,
        ..*g
    };
    Ok(unaware_derivatives(&unit, hit_normals, Order::Hessian)?.hessian[0] * l_max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_term_derivatives_match_finite_differences() {
        let nx = DVec3::new(0.1, 0.2, 1.0).normalize();
        let ny = DVec3::new(-0.3, 0.1, -1.0).normalize();
        let y = DVec3::new(0.4, -0.3, 1.7);
        let g = |x: DVec3| geometry_term_derivatives(y - x, nx, ny, Order::Hessian);
        let (_, grad, hess) = g(DVec3::ZERO);
        let h = 1e-4;
        for i in 0..3 {
            let e = DVec3::AXES[i] * h;
            let (p, m) = (g(e), g(-e));
            let fd = (p.0 - m.0) / (2.0 * h);
            assert!(
                (fd - grad[i]).abs() < 1e-7 * grad.length(),
                "{fd} vs {}",
                grad[i]
            );
            let col = (p.1 - m.1) / (2.0 * h);
            assert!((col - hess.col(i)).abs().max_element() < 1e-6 * hess.col(i).length().max(1.0));
        }
    }
}
