//! The peer formulation for the occlusion-aware Hessian: every weighted edge of the mesh evaluated
//! in scalar code from the textbook closed forms of its line integrals, as Radiance's per-edge
//! Hessian does (`∫dt/ρ²` through `acos`, then `∫dt/ρ⁴`, `∫dt/ρ⁶` and their `t`, `t²` moments by
//! the standard recurrences), with no regimes, no rescaling and no batching. It is the baseline
//! the `hessian` bench times raddiff against, and a second derivation the tests compare with.
//!
//! With `r(t) = r_a + t e` (`e = r_b − r_a`, positions relative to x), `c = r_a × r_b`,
//! `Q(t) = |r(t)|²` and `I_k = ∫₀¹ dt/Q^k`, `J_k = ∫₀¹ t dt/Q^k`, `K_3 = ∫₀¹ t² dt/Q³`, the edge
//! term of `π F` is `½ I₁ (n·c)`, and since `∇(n·c) = n × e`, `∇I₁ = 2(r_a I₂ + e J₂)`:
//!
//! * gradient `½ (I₁ (n × e) + 2 (n·c)(r_a I₂ + e J₂))`,
//! * Hessian `½ (sym₂(n × e, ∇I₁) + (n·c)(−2 I₂ 𝟙 + 8 (I₃ r_a r_aᵀ + J₃ sym₂(r_a, e) + K₃ e eᵀ)))`,
//!
//! with `sym₂(u, v) = u vᵀ + v uᵀ`, `I₁ = γ/|c|` (γ the angle between `r_a` and `r_b`), and with
//! `Δ = |c|²`, `a = |e|²`, `b = e·r_a`, `Q₀ = |r_a|²`, `Q₁ = |r_b|²`:
//! `I₂ = (e·r_b/Q₁ − b/Q₀ + a I₁)/(2Δ)`, `J₂ = ((1/Q₀ − 1/Q₁)/2 − b I₂)/a`,
//! `I₃ = (e·r_b/Q₁² − b/Q₀² + 3a I₂)/(4Δ)`, `J₃ = ((1/Q₀² − 1/Q₁²)/4 − b I₃)/a`,
//! `K₃ = (I₂ − Q₀ I₃ − 2b J₃)/a`.

use glam::{DMat3, DVec3};
use raddiff::gather::hessian::mesh::{NONE, POLE};
use raddiff::gather::hessian::{HemisphereGather, MeshGeometry, Topology};

/// `π Σ L_Δ F_Δ` of one channel with its gradient and Hessian, as `occlusion_derivatives`
/// returns them (before the robustness term).
#[derive(Debug, Clone, Copy)]
pub struct PeerDerivatives {
    pub irradiance: f64,
    pub gradient: DVec3,
    pub hessian: DMat3,
}

fn sym2(u: DVec3, v: DVec3) -> DMat3 {
    DMat3::from_cols(u * v.x + v * u.x, u * v.y + v * u.y, u * v.z + v * u.z)
}

fn outer(u: DVec3, v: DVec3) -> DMat3 {
    DMat3::from_cols(u * v.x, u * v.y, u * v.z)
}

/// The radiance of `channel` at mesh vertex `v`.
fn vertex_radiance(
    topo: &Topology,
    mesh: &MeshGeometry,
    g: &HemisphereGather,
    v: u32,
    channel: usize,
) -> f64 {
    match topo.vertex_source[v as usize] {
        POLE => mesh.pole_radiance[channel],
        s => g.radiance[s as usize * g.channels + channel] as f64,
    }
}

/// Value, gradient and Hessian of the edge term `½ I₁ (n·c)` of `a → b`.
#[inline]
fn edge(n: DVec3, ra: DVec3, rb: DVec3) -> (f64, DVec3, DMat3) {
    let e = rb - ra;
    let c = ra.cross(rb);
    let delta = c.length_squared();
    let (q0, q1) = (ra.length_squared(), rb.length_squared());
    let (iq0, iq1) = (1.0 / q0, 1.0 / q1);
    let a = e.length_squared();
    let b = e.dot(ra);
    let eb = e.dot(rb);
    let cos = (ra.dot(rb) * (iq0 * iq1).sqrt()).clamp(-1.0, 1.0);
    let i1 = cos.acos() / delta.sqrt();
    let i2 = (eb * iq1 - b * iq0 + a * i1) * 0.5 / delta;
    let j2 = (0.5 * (iq0 - iq1) - b * i2) / a;
    let i3 = (eb * iq1 * iq1 - b * iq0 * iq0 + 3.0 * a * i2) * 0.25 / delta;
    let j3 = (0.25 * (iq0 * iq0 - iq1 * iq1) - b * i3) / a;
    let k3 = (i2 - q0 * i3 - 2.0 * b * j3) / a;
    let nc = n.dot(c);
    let nxe = n.cross(e);
    let grad_i1 = 2.0 * (ra * i2 + e * j2);
    let gradient = 0.5 * (i1 * nxe + nc * grad_i1);
    let second = DMat3::from_diagonal(DVec3::splat(-2.0 * i2))
        + 8.0 * (i3 * outer(ra, ra) + j3 * sym2(ra, e) + k3 * outer(e, e));
    let hessian = 0.5 * (sym2(nxe, grad_i1) + nc * second);
    (0.5 * i1 * nc, gradient, hessian)
}

/// The peer's `π Σ L_Δ F_Δ` with gradient and Hessian for `channel`: every edge whose two
/// triangles carry different radiance (the farthest vertex's), weighted by the difference.
pub fn per_edge_closed_forms(
    topo: &Topology,
    mesh: &MeshGeometry,
    g: &HemisphereGather,
    channel: usize,
) -> PeerDerivatives {
    let n = g.normal.normalize();
    let triangle_radiance: Vec<f64> = mesh
        .farthest
        .iter()
        .map(|&v| vertex_radiance(topo, mesh, g, v, channel))
        .collect();
    let mut out = PeerDerivatives {
        irradiance: 0.0,
        gradient: DVec3::ZERO,
        hessian: DMat3::ZERO,
    };
    for e in &topo.edges {
        let left = triangle_radiance[e.left as usize];
        let right = if e.right == NONE {
            0.0
        } else {
            triangle_radiance[e.right as usize]
        };
        let w = left - right;
        if w == 0.0 {
            continue;
        }
        let (v, gr, h) = edge(
            n,
            mesh.positions[e.a as usize],
            mesh.positions[e.b as usize],
        );
        out.irradiance += w * v;
        out.gradient += w * gr;
        out.hessian += w * h;
    }
    out
}
