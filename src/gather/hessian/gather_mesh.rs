//! The gather as a mesh seen from x, shared by the occlusion-aware evaluations
//! ([`super::occlusion`], its workspace and its edge batches, [`super::media`]'s constants): the
//! gather's rays ([`HemisphereGather`]) checked against the layout's [`Topology`], its vertices
//! placed relative to x ([`MeshGeometry`], misses at [`FAR_DISTANCE_FACTOR`] times the largest hit
//! distance), the exact power-of-two rescaling that keeps the edge moments in range ([`Scale`]),
//! each triangle's farthest vertex, one edge term from its nearer end
//! ([`edge_term`]), and the assembly of the per-channel sums into [`OcclusionDerivatives`].
//!
//! It imports nothing else of the Hessian folder but the mesh's topology, so that the entry points,
//! the workspace and the edge batches, which all build on it, import it without a cycle.

use glam::{DMat3, DVec3};

use super::mesh::{Topology, POLE};
use crate::error::{ensure_finite, ensure_finite3, Error, Result};
use crate::gather::layout::LayoutKind;
use crate::kernels::form_factor::edge;
use crate::kernels::numeric::pow2::pow2_scale;
use crate::{Deriv3, Order};

/// Misses are placed at this multiple of the largest finite hit distance (2^20: the occlusion
/// terms of the distant environment converge like `1/FAR_DISTANCE_FACTOR`, about 1e-6 relative).
pub const FAR_DISTANCE_FACTOR: f64 = 1_048_576.0;

/// Fraction of the irradiance added to every triangle radiance by
/// [`OcclusionDerivatives::robust_hessian`] (thesis sec. 6.3).
pub const ROBUST_FRACTION: f64 = 0.01;

/// The rays of one hemisphere gather, as the renderer traced them.
#[derive(Debug, Clone, Copy)]
pub struct HemisphereGather<'a> {
    /// Unit surface normal at x (the layout's pole).
    pub normal: DVec3,
    /// Unit world directions, index `j·N + k` (from the layout).
    pub directions: &'a [DVec3],
    /// Hit distances (L), > 0, `f64::INFINITY` for a miss.
    pub distance: &'a [f64],
    /// Radiance leaving each hit towards x (environment radiance for a miss), before attenuation,
    /// `channels` values per direction.
    pub radiance: &'a [f32],
    /// Values per direction, ≥ 1.
    pub channels: usize,
    /// Homogeneous extinction (1/L) between x and the hits, ≥ 0.
    pub sigma_t: f64,
}

/// The mesh's unit-radiance terms: irradiance from unit radiance on every triangle (π times the
/// mesh's total form factor) with its gradient and Hessian: the occlusion-aware geometric Hessian
/// of the thesis' black-gather case.
pub type Geometric = Deriv3;

/// Occlusion-aware irradiance derivatives of one gather, per channel.
#[derive(Debug, Clone, PartialEq)]
pub struct OcclusionDerivatives {
    /// `π Σ L_Δ F_Δ` (eq. 6.1; F is the form factor, the cosine-weighted solid angle over π): the
    /// triangulated irradiance estimate, in the gather's units (π for unit radiance everywhere).
    pub irradiance: Vec<f64>,
    /// `π Σ L_Δ ∇F_Δ` (eq. 6.2), per L.
    pub gradient: Vec<DVec3>,
    /// `π Σ L_Δ H F_Δ` (eq. 6.3), per L², zero unless the Hessian was requested.
    pub hessian: Vec<DMat3>,
    /// The mesh with unit radiance on every triangle (transmittance included when in a medium).
    pub geometric: Geometric,
    /// Per channel, whether every ray returned exactly zero.
    pub all_black: Vec<bool>,
}

impl OcclusionDerivatives {
    /// The Hessian of channel `c` with the thesis' robustness (sec. 6.3): `H + 0.01 E H_geometric`
    /// (1% of the irradiance added to every triangle radiance), or `H_geometric` (unit radiance)
    /// when every ray of the channel returned black. Kept for comparison with the thesis: the
    /// added term's projection on the tangent plane is zero (module docs), so radii from this are
    /// those of the plain Hessian; use
    /// [`crate::gather::radii::surface_radii_floored`] for robust radii.
    pub fn robust_hessian(&self, c: usize) -> DMat3 {
        if self.all_black[c] {
            self.geometric.hessian
        } else {
            self.hessian[c] + self.geometric.hessian * (ROBUST_FRACTION * self.irradiance[c])
        }
    }
}

/// Per-gather vertex data of the mesh (positions relative to x).
#[derive(Debug, Clone)]
pub struct MeshGeometry {
    /// Vertex positions relative to x (L).
    pub positions: Vec<DVec3>,
    /// Vertex distances from x, misses at the far distance.
    pub distance: Vec<f64>,
    /// The distance where misses were placed.
    pub far_distance: f64,
    /// Radiance of the synthesized pole vertex, per channel (empty without a pole).
    pub pole_radiance: Vec<f64>,
    /// For every triangle, its farthest vertex.
    pub farthest: Vec<u32>,
}

pub(super) fn check_gather(topo: &Topology, g: &HemisphereGather) -> Result<DVec3> {
    let count = topo.m * topo.n;
    if g.channels == 0 {
        return Err(Error::InvalidArgument("channels must be >= 1".into()));
    }
    if g.directions.len() != count || g.distance.len() != count {
        return Err(Error::InvalidArgument(format!(
            "directions ({}) and distances ({}) must hold m*n = {count} values",
            g.directions.len(),
            g.distance.len()
        )));
    }
    if Some(g.radiance.len()) != count.checked_mul(g.channels) {
        return Err(Error::InvalidArgument(format!(
            "radiance holds {} values, expected m*n*channels = {count}*{}",
            g.radiance.len(),
            g.channels
        )));
    }
    ensure_finite(g.sigma_t, "sigma_t")?;
    if g.sigma_t < 0.0 {
        return Err(Error::InvalidArgument(format!(
            "sigma_t must be >= 0 (got {})",
            g.sigma_t
        )));
    }
    ensure_finite3(g.normal, "normal")?;
    let len = g.normal.length();
    if (len - 1.0).abs() > 1e-6 {
        return Err(Error::InvalidArgument(format!(
            "normal must be a unit vector (length {len})"
        )));
    }
    // One branch-free pass (it vectorises); the failing index is searched only on failure.
    let bad_distance = |d: f64| d.is_nan() | (d <= 0.0);
    let bad_sample = |d: f64, w: &DVec3| {
        // A non-finite w gives an infinite or NaN deviation.
        let deviation = (w.length_squared() - 1.0).abs();
        bad_distance(d) | deviation.is_nan() | (deviation > 1e-6)
    };
    let any_bad = g
        .distance
        .iter()
        .zip(g.directions)
        .fold(false, |bad, (&d, w)| bad | bad_sample(d, w));
    if any_bad {
        for (i, (&d, w)) in g.distance.iter().zip(g.directions).enumerate() {
            if bad_distance(d) {
                return Err(Error::InvalidArgument(format!(
                    "distance[{i}] must be > 0 or +inf (got {d})"
                )));
            }
            if bad_sample(d, w) {
                return Err(Error::InvalidArgument(format!(
                    "directions[{i}] is not a unit vector ({w})"
                )));
            }
        }
    }
    if !g.radiance.iter().fold(true, |ok, v| ok & v.is_finite()) {
        let i = g.radiance.iter().position(|v| !v.is_finite()).unwrap_or(0);
        return Err(Error::InvalidArgument(format!(
            "radiance[{i}] is not finite ({})",
            g.radiance[i]
        )));
    }
    Ok(g.normal / len)
}

/// Places the mesh vertices of one gather (validating it against `topo`).
pub fn mesh_geometry(topo: &Topology, g: &HemisphereGather) -> Result<MeshGeometry> {
    let (normal, far_distance) = validate(topo, g)?;
    let mut mesh = MeshGeometry {
        positions: Vec::new(),
        distance: Vec::new(),
        far_distance,
        pole_radiance: Vec::new(),
        farthest: Vec::new(),
    };
    place(
        topo,
        g,
        normal,
        far_distance,
        (1.0, 1.0),
        &mut mesh.distance,
        &mut mesh.positions,
        &mut mesh.pole_radiance,
    )?;
    farthest_vertices(topo, &mesh.distance, &mut mesh.farthest);
    Ok(mesh)
}

/// Validates a gather against `topo`: its unit normal and the distance where misses are placed.
pub(super) fn validate(topo: &Topology, g: &HemisphereGather) -> Result<(DVec3, f64)> {
    if topo.connectivity == LayoutKind::Sphere {
        return Err(Error::InvalidArgument(
            "a sphere layout is a media gather: use gather::hessian::media".into(),
        ));
    }
    let normal = check_gather(topo, g)?;
    let largest = g
        .distance
        .iter()
        .fold(0.0f64, |m, &d| if d.is_finite() { m.max(d) } else { m });
    let far_distance = FAR_DISTANCE_FACTOR * if largest > 0.0 { largest } else { 1.0 };
    if !far_distance.is_finite() {
        return Err(Error::InvalidArgument(format!(
            "hit distances up to {largest:e} leave no room for the environment"
        )));
    }
    Ok((normal, far_distance))
}

/// Vertex distances and positions relative to x times `factor.0 · factor.1` (powers of two,
/// applied one after the other as [`Scale::point`] does; 1 for [`MeshGeometry`]), and the pole's
/// radiance, into the given buffers (their capacity is reused).
#[allow(clippy::too_many_arguments)]
pub(super) fn place(
    topo: &Topology,
    g: &HemisphereGather,
    normal: DVec3,
    far_distance: f64,
    factor: (f64, f64),
    distance: &mut Vec<f64>,
    positions: &mut Vec<DVec3>,
    pole_radiance: &mut Vec<f64>,
) -> Result<()> {
    let sample_distance = |d: f64| if d.is_finite() { d } else { far_distance };
    let vcount = topo.vertex_count();
    let samples = g.distance.len();
    // Vertices 0..M·N are the samples themselves (`Topology`), placed in one vectorisable pass.
    distance.clear();
    distance.reserve(vcount);
    distance.extend(g.distance.iter().map(|&d| sample_distance(d)));
    positions.clear();
    positions.reserve(vcount);
    positions.extend(
        g.directions
            .iter()
            .zip(distance.iter())
            .map(|(&w, &d)| w * d * factor.0 * factor.1),
    );
    pole_radiance.clear();
    for v in samples..vcount {
        let src = topo.vertex_source[v];
        if src == POLE {
            // The pole was not sampled: harmonic mean of ring 0's distances, mean radiance.
            let n = topo.n;
            let ring = &distance[..n];
            let inv: f64 = ring.iter().map(|d| 1.0 / d).sum::<f64>() / n as f64;
            // Kept within the ring's range, where the mean lies: when ring 0's distances are all
            // equal (all misses, say) the pole is then exactly as far as they are, and which
            // vertex is the farthest of a pole triangle no longer depends on rounding (nor, so,
            // on the scene's unit).
            let (lo, hi) = ring.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &d| {
                (lo.min(d), hi.max(d))
            });
            let d = (1.0 / inv).max(lo).min(hi);
            positions.push(normal * d * factor.0 * factor.1);
            distance.push(d);
            pole_radiance.extend((0..g.channels).map(|c| {
                (0..n)
                    .map(|k| g.radiance[k * g.channels + c] as f64)
                    .sum::<f64>()
                    / n as f64
            }));
            continue;
        }
        let s = src as usize;
        let d = distance[s];
        let w = g.directions[s];
        let dir = if topo.on_horizon[v] {
            let flat = w - normal * w.dot(normal);
            let l = flat.length();
            if l.is_nan() || l <= 1e-12 {
                return Err(Error::Degenerate(format!(
                    "direction {s} on the layout's outer ring points along the normal"
                )));
            }
            flat / l
        } else {
            w
        };
        positions.push(dir * d * factor.0 * factor.1);
        distance.push(d);
    }
    Ok(())
}

/// For every triangle, its farthest vertex (the first of equally far ones).
pub(super) fn farthest_vertices(topo: &Topology, distance: &[f64], farthest: &mut Vec<u32>) {
    farthest.clear();
    // Branch-free: the distances are noise to the branch predictor.
    farthest.extend(topo.triangles.iter().map(|t| {
        let (d0, d1, d2) = (
            distance[t[0] as usize],
            distance[t[1] as usize],
            distance[t[2] as usize],
        );
        let (best, db) = if d1 > d0 { (t[1], d1) } else { (t[0], d0) };
        if d2 > db {
            t[2]
        } else {
            best
        }
    }));
}

/// The edge term of `a → b` seen from the origin (x), unit normal `n`, positions already scaled
/// (see [`Scale`]) and validated.
///
/// The kernel's edge integral is measured from its first vertex, so it is called from the nearer
/// end and negated if that reverses the edge (the term is odd in the direction): for a
/// near-to-environment edge the other order loses about log10(far/near) digits in the foot point.
#[inline]
pub(super) fn edge_term(n: DVec3, a: DVec3, b: DVec3, order: Order) -> Result<Deriv3> {
    if a.length_squared() <= b.length_squared() {
        edge::edge_term(a, b - a, n, order)
    } else {
        let f = edge::edge_term(b, a - b, n, order)?;
        Ok(Deriv3 {
            value: -f.value,
            gradient: -f.gradient,
            hessian: -f.hessian,
        })
    }
}

/// Exact power-of-two rescaling of a gather's positions so that its largest hit distance is about
/// 1 (nothing overflows in the edge moments, whatever the scene's unit), and back.
#[derive(Debug, Clone, Copy)]
pub(super) struct Scale {
    pub(super) f1: f64,
    pub(super) f2: f64,
}

impl Scale {
    pub(super) fn of(mesh: &MeshGeometry) -> Scale {
        Scale::of_far(mesh.far_distance)
    }

    pub(super) fn of_far(far_distance: f64) -> Scale {
        let (f1, f2) = pow2_scale(far_distance / FAR_DISTANCE_FACTOR);
        Scale { f1, f2 }
    }

    #[inline]
    pub(super) fn point(&self, p: DVec3) -> DVec3 {
        p * self.f1 * self.f2
    }

    pub(super) fn back(&self, mut d: Deriv3) -> Deriv3 {
        d.gradient = d.gradient * self.f1 * self.f2;
        d.hessian = d.hessian * self.f1 * self.f1 * self.f2 * self.f2;
        d
    }
}

pub(super) fn all_black(g: &HemisphereGather) -> Vec<bool> {
    (0..g.channels)
        .map(|c| {
            g.radiance
                .iter()
                .skip(c)
                .step_by(g.channels)
                .all(|&v| v == 0.0)
        })
        .collect()
}

pub(super) fn empty(channels: usize, black: Vec<bool>) -> OcclusionDerivatives {
    OcclusionDerivatives {
        irradiance: vec![0.0; channels],
        gradient: vec![DVec3::ZERO; channels],
        hessian: vec![DMat3::ZERO; channels],
        geometric: Deriv3::constant(0.0),
        all_black: black,
    }
}

/// Irradiance is `π Σ L_Δ F_Δ` (F is the cosine-weighted solid angle over π); derivatives are
/// brought back from the scaled units.
pub(super) fn finish(
    mut out: OcclusionDerivatives,
    acc: &[Deriv3],
    scale: Scale,
) -> Result<OcclusionDerivatives> {
    use std::f64::consts::PI;
    for (c, a) in acc.iter().enumerate() {
        let a = scale.back(*a);
        out.irradiance[c] = PI * a.value;
        out.gradient[c] = a.gradient * PI;
        out.hessian[c] = a.hessian * PI;
    }
    let geo = scale.back(out.geometric);
    out.geometric = Deriv3 {
        value: geo.value * PI,
        gradient: geo.gradient * PI,
        hessian: geo.hessian * PI,
    };
    let finite = out.gradient.iter().all(|g| g.is_finite())
        && out.hessian.iter().all(|h| h.is_finite())
        && out.irradiance.iter().all(|e| e.is_finite())
        && out.geometric.is_finite();
    if !finite {
        return Err(Error::Degenerate(
            "occlusion derivatives overflow for this gather".into(),
        ));
    }
    Ok(out)
}
