//! The vector form factor of a polygon: Arvo's irradiance Jacobian, an independent formulation
//! kept to cross-check the form factor's gradient.

use glam::{DMat3, DVec3};
use smallvec::SmallVec;

use crate::error::{ensure_finite3, Error, Result};
use crate::kernels::form_factor::edge::{outer_self, INV_2PI};

/// Arvo's irradiance Jacobian (Arvo 1994; Schwarzhaupt thesis §5.1, eq. 5.19) of the *vector form
/// factor* of an unoccluded, unclipped polygon:
///
/// ```text
/// Φ(x) = (1/2π) Σ_k Θ_k Γ_k,   Θ_k = angle(v_k − x, v_{k+1} − x),
/// Γ_k = unit((v_k − x) × (v_{k+1} − x)),    J = ∂Φ/∂x  (J_ij = ∂Φ_i/∂x_j).
/// ```
///
/// `n·Φ` is the signed, unclipped form factor of [`edge_form_factor`](super::edge_form_factor)'s
/// convention (positive when the vertices run clockwise as seen from `x`), so its gradient is
/// `Jᵀ n`. This is an independent formulation (unit vertex vectors, edge matrices
/// `E(a, b) = w wᵀ/(‖w‖² a·b) + (acos(a·b)/‖w‖)(𝟙 − w wᵀ/‖w‖²)` and skew matrices), kept to
/// cross-check the form-factor gradient.
///
/// Limits: Arvo's edge matrix divides by `a·b`, so an edge seen under exactly a right angle, `x` on
/// an edge's line, or `x` at a vertex gives [`Error::Degenerate`]. Units: per L.
pub fn vector_form_factor_jacobian(x: DVec3, vertices: &[DVec3]) -> Result<DMat3> {
    ensure_finite3(x, "x")?;
    if vertices.len() < 3 {
        return Err(Error::InvalidArgument(format!(
            "a polygon needs at least 3 vertices (got {})",
            vertices.len()
        )));
    }
    let skew = |p: DVec3| {
        DMat3::from_cols(
            DVec3::new(0.0, p.z, -p.y),
            DVec3::new(-p.z, 0.0, p.x),
            DVec3::new(p.y, -p.x, 0.0),
        )
    };
    let mut unit = SmallVec::<[(DVec3, DMat3); 8]>::new();
    for v in vertices {
        ensure_finite3(*v, "vertex")?;
        let d = *v - x;
        let len = d.length();
        if len == 0.0 {
            return Err(Error::Degenerate("x coincides with a vertex".into()));
        }
        let u = d / len;
        // ∂u/∂x = −(𝟙 − u uᵀ)/‖v − x‖
        unit.push((u, (outer_self(u) - DMat3::IDENTITY) * (1.0 / len)));
    }
    let count = unit.len();
    let mut jac = DMat3::ZERO;
    for k in 0..count {
        let (a, ja) = unit[k];
        let (b, jb) = unit[(k + 1) % count];
        let w = a.cross(b);
        let w2 = w.length_squared();
        let ab = a.dot(b);
        if w2 == 0.0 || ab == 0.0 {
            return Err(Error::Degenerate(
                "Arvo's edge matrix is singular (x on an edge's line, or a right angle)".into(),
            ));
        }
        let ww = outer_self(w) * (1.0 / w2);
        let edge =
            ww * (1.0 / ab) + (DMat3::IDENTITY - ww) * (ab.clamp(-1.0, 1.0).acos() / w2.sqrt());
        jac += edge * (skew(a) * jb - skew(b) * ja);
    }
    let jac = jac * INV_2PI;
    if jac.is_finite() {
        Ok(jac)
    } else {
        Err(Error::Degenerate("Arvo Jacobian overflows".into()))
    }
}
