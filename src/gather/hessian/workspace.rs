//! The evaluation of [`super::occlusion_derivatives`] on reusable buffers.
//!
//! A 4096-ray gather needs about 1 MB of per-vertex, per-triangle and per-edge scratch data; kept in
//! an [`OcclusionWorkspace`] (one per thread behind [`super::occlusion_derivatives`]) it is neither
//! allocated nor faulted in again for every gather, and the vertices are placed directly in the
//! scaled units the edge kernel reads.

use glam::{DMat3, DVec3};

use super::edges::EdgeSums;
use super::gather_mesh::{
    all_black, empty, farthest_vertices, finish, place, validate, HemisphereGather, MeshGeometry,
    OcclusionDerivatives, Scale,
};
use super::mesh::{Topology, NONE, POLE, REVERSED};
use crate::error::{Error, Result};
use crate::kernels::transmittance::separation;
use crate::Order;

/// Reusable scratch memory for [`super::occlusion_derivatives_with`]: keep one per thread and pass
/// it to every gather to avoid allocating 100 (surface) to 250 (medium) bytes per ray for each.
///
/// A workspace holds no results between calls, only capacity (it grows to the largest gather seen;
/// [`OcclusionWorkspace::new`] starts empty).
#[derive(Default)]
pub struct OcclusionWorkspace {
    /// Vertex distances from x (L), misses at the far distance.
    distance: Vec<f64>,
    /// Vertex positions relative to x, scaled (see [`Scale`]).
    points: Vec<DVec3>,
    /// Their squared lengths.
    squared: Vec<f64>,
    /// For every triangle, its farthest vertex.
    farthest: Vec<u32>,
    pole_radiance: Vec<f64>,
    /// Radiance per vertex and channel.
    vertex: Vec<f64>,
    /// Per triangle and channel: radiance (surface path) or `L_Δ T_Δ` and `T_Δ` (medium path),
    /// plus a zero row for the outside of the horizon.
    triangle: Vec<f64>,
    delta: Vec<f64>,
    /// Medium path: which vertices are the farthest of some triangle.
    lit: Vec<bool>,
    /// Medium path: the transmittance of every such vertex.
    transmittance: Vec<VertexTransmittance>,
    sums: Option<EdgeSums>,
}

impl std::fmt::Debug for OcclusionWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OcclusionWorkspace")
            .field("vertices", &self.points.capacity())
            .field("triangles", &self.farthest.capacity())
            .finish_non_exhaustive()
    }
}

/// Transmittance from x to a vertex with the coefficients of its derivatives:
/// `∇T = gradient`, `HT = radial_tangential u uᵀ − tangential 𝟙`.
#[derive(Debug, Clone, Copy, Default)]
struct VertexTransmittance {
    value: f64,
    gradient: DVec3,
    u: DVec3,
    radial_tangential: f64,
    tangential: f64,
}

impl OcclusionWorkspace {
    /// An empty workspace (buffers grow on first use).
    pub fn new() -> OcclusionWorkspace {
        OcclusionWorkspace::default()
    }

    /// Vertices the workspace currently has room for (its memory is 100 to 250 bytes per vertex).
    pub(super) fn vertex_capacity(&self) -> usize {
        self.points.capacity()
    }

    /// Validates and places a gather (vertices in scaled units).
    /// Returns the scale and the distance where misses were placed.
    pub(super) fn place_gather(
        &mut self,
        topo: &Topology,
        g: &HemisphereGather,
    ) -> Result<(Scale, f64)> {
        let (normal, far_distance) = validate(topo, g)?;
        let scale = Scale::of_far(far_distance);
        place(
            topo,
            g,
            normal,
            far_distance,
            (scale.f1, scale.f2),
            &mut self.distance,
            &mut self.points,
            &mut self.pole_radiance,
        )?;
        self.squared.clear();
        self.squared
            .extend(self.points.iter().map(|q| q.length_squared()));
        farthest_vertices(topo, &self.distance, &mut self.farthest);
        Ok((scale, far_distance))
    }

    /// Takes an already placed mesh.
    pub(super) fn place_mesh(&mut self, mesh: &MeshGeometry) -> Scale {
        let scale = Scale::of(mesh);
        self.points.clear();
        self.points
            .extend(mesh.positions.iter().map(|&p| scale.point(p)));
        self.squared.clear();
        self.squared
            .extend(self.points.iter().map(|q| q.length_squared()));
        self.distance.clone_from(&mesh.distance);
        self.farthest.clone_from(&mesh.farthest);
        self.pole_radiance.clone_from(&mesh.pole_radiance);
        scale
    }

    /// The derivatives of the placed mesh (module docs of [`super`]).
    pub(super) fn derivatives(
        &mut self,
        topo: &Topology,
        g: &HemisphereGather,
        order: Order,
        scale: Scale,
        far_distance: f64,
    ) -> Result<OcclusionDerivatives> {
        if !order.gradient() {
            return Err(Error::InvalidArgument(
                "occlusion derivatives need order >= RADDIFF_ORDER_GRADIENT".into(),
            ));
        }
        let n = g.normal.normalize();
        let channels = g.channels;
        let out = empty(channels, all_black(g));
        self.vertex_radiance(topo, g);
        let mut sums = self
            .sums
            .take()
            .unwrap_or_else(|| EdgeSums::new(n, order, 1));
        let result = if g.sigma_t > 0.0 {
            self.medium(topo, g, order, scale, far_distance, &mut sums, out)
        } else {
            self.surface(topo, g, order, scale, &mut sums, out)
        };
        self.sums = Some(sums);
        result
    }

    /// Radiance of every vertex (samples, then horizon copies and the pole), channel-interleaved.
    fn vertex_radiance(&mut self, topo: &Topology, g: &HemisphereGather) {
        let ch = g.channels;
        self.vertex.clear();
        self.vertex.reserve(topo.vertex_count() * ch);
        self.vertex.extend(g.radiance.iter().map(|&l| l as f64));
        for v in g.radiance.len() / ch..topo.vertex_count() {
            let src = topo.vertex_source[v];
            if src == POLE {
                self.vertex.extend_from_slice(&self.pole_radiance[..ch]);
            } else {
                let s = src as usize * ch;
                self.vertex
                    .extend(g.radiance[s..s + ch].iter().map(|&l| l as f64));
            }
        }
    }

    fn surface(
        &mut self,
        topo: &Topology,
        g: &HemisphereGather,
        order: Order,
        scale: Scale,
        sums: &mut EdgeSums,
        mut out: OcclusionDerivatives,
    ) -> Result<OcclusionDerivatives> {
        let channels = g.channels;
        let n = g.normal.normalize();
        // Radiance of every triangle (its farthest vertex's), plus the zero row of the outside.
        let tri = &mut self.triangle;
        tri.clear();
        let tcount = topo.triangles.len();
        if channels == 1 {
            let vertex = &self.vertex;
            tri.extend(self.farthest.iter().map(|&f| vertex[f as usize]));
        } else {
            for &f in &self.farthest {
                let f = f as usize * channels;
                tri.extend_from_slice(&self.vertex[f..f + channels]);
            }
        }
        tri.resize((tcount + 1) * channels, 0.0);
        let outside = tcount;
        sums.reset(n, order, channels, 0);
        let (points, squared) = (&self.points, &self.squared);
        if channels == 1 {
            sums.add_edges_one_channel(&topo.edges, tri, points, squared)?;
        } else {
            let delta = &mut self.delta;
            delta.clear();
            delta.resize(channels, 0.0);
            for e in &topo.edges {
                let boundary = e.right == NONE;
                let right = if boundary { outside } else { e.right as usize };
                let (l, r) = (e.left as usize * channels, right * channels);
                let mut any = false;
                for (c, d) in delta.iter_mut().enumerate() {
                    *d = tri[l + c] - tri[r + c];
                    any |= *d != 0.0;
                }
                if any || boundary {
                    let (a, b) = (e.a as usize, e.b as usize);
                    sums.push(
                        points[a], points[b], squared[a], squared[b], delta, boundary,
                    )?;
                }
            }
        }
        let (acc, geometric) = sums.finish()?;
        out.geometric = geometric;
        finish(out, &acc, scale)
    }

    /// Medium path. Each triangle carries `L_Δ T_Δ F_Δ` with `T_Δ` the transmittance to its
    /// farthest vertex, so by the product rule
    ///
    /// ```text
    ///   value  Σ_e f_e (W_left − W_right)                                    W_Δ = L_Δ T_Δ
    ///   ∇      Σ_e ∇f_e (W_left − W_right) + Σ_Δ L_Δ F_Δ ∇T_Δ
    ///   H      Σ_e Hf_e (W_left − W_right) + Σ_Δ L_Δ (∇T_Δ ∇F_Δᵀ + ∇F_Δ ∇T_Δᵀ + F_Δ HT_Δ)
    /// ```
    ///
    /// The edge sums are the surface path's with transmittance-weighted radiance (the batched edge
    /// kernel; the geometric terms are one more channel, of weight `T_Δ`); only each triangle's own
    /// form factor and gradient are summed per triangle, from the edges' kept values and gradients.
    /// Misses (and the pole, if it sits at the far distance) are attenuated to zero.
    #[allow(clippy::too_many_arguments)]
    fn medium(
        &mut self,
        topo: &Topology,
        g: &HemisphereGather,
        order: Order,
        scale: Scale,
        far_distance: f64,
        sums: &mut EdgeSums,
        mut out: OcclusionDerivatives,
    ) -> Result<OcclusionDerivatives> {
        let n = g.normal.normalize();
        // σ_t r is scale-free: σ_t in scaled units is σ_t / (f1 f2).
        let sigma = g.sigma_t / scale.f1 / scale.f2;
        let ch = g.channels;
        let rows = ch + 1;
        let vcount = topo.vertex_count();
        // The transmittance of every vertex that some triangle takes its radiance from (each is
        // the farthest of about two triangles); zero marks the others and the misses. Marked
        // first, then computed in vertex order (random access to the 72-byte entries was slower).
        let lit = &mut self.lit;
        lit.clear();
        lit.resize(vcount, false);
        for &far in &self.farthest {
            lit[far as usize] = true;
        }
        let tr = &mut self.transmittance;
        tr.clear();
        tr.resize(vcount, VertexTransmittance::default());
        for (v, t) in tr.iter_mut().enumerate() {
            if lit[v] && self.distance[v] < far_distance {
                *t = vertex_transmittance(self.points[v], sigma, order)?;
            }
        }
        // Per triangle `W_Δ` per channel and `T_Δ`, plus a zero row for the outside.
        let tcount = topo.triangles.len();
        let weight = &mut self.triangle;
        weight.clear();
        weight.resize((tcount + 1) * rows, 0.0);
        for (w, &far) in weight.chunks_exact_mut(rows).zip(&self.farthest) {
            let far = far as usize;
            let t = tr[far].value;
            for (w, &l) in w[..ch].iter_mut().zip(&self.vertex[far * ch..]) {
                *w = l * t;
            }
            w[ch] = t;
        }
        sums.reset(n, order, rows, topo.edges.len());
        if ch == 1 {
            sums.add_edges_medium_one_channel(&topo.edges, weight, &self.points, &self.squared)?;
        } else {
            let delta = &mut self.delta;
            delta.clear();
            delta.resize(rows, 0.0);
            for (index, e) in topo.edges.iter().enumerate() {
                let right = if e.right == NONE {
                    tcount
                } else {
                    e.right as usize
                };
                let (l, r) = (e.left as usize * rows, right * rows);
                // An edge between two dark triangles (T = 0) adds nothing, to the sums or to
                // either triangle.
                if weight[l + ch] == 0.0 && weight[r + ch] == 0.0 {
                    continue;
                }
                for (c, d) in delta.iter_mut().enumerate() {
                    *d = weight[l + c] - weight[r + c];
                }
                let (a, b) = (e.a as usize, e.b as usize);
                sums.push_kept(
                    self.points[a],
                    self.points[b],
                    self.squared[a],
                    self.squared[b],
                    delta,
                    false,
                    index as u32,
                )?;
            }
        }
        let (mut acc, _) = sums.finish()?;
        let terms = sums.terms();
        // Per row (channels, then the geometric terms): gradient (3) and the Hessian's unique
        // entries xx, xy, xz, yy, yz, zz of `L_Δ (F_Δ ∇T + ∇T ∇F_Δᵀ + ∇F_Δ ∇Tᵀ + F_Δ HT)`.
        let hessian = order.hessian();
        let mut extra = vec![[0.0f64; 9]; rows];
        for (codes, &far) in topo.triangle_edges.iter().zip(&self.farthest) {
            let far = far as usize;
            let tv = &tr[far];
            if tv.value == 0.0 {
                continue;
            }
            let mut f = [0.0f64; 4];
            for &code in codes {
                let e = &terms[(code & !REVERSED) as usize];
                let s = if code & REVERSED != 0 { -1.0 } else { 1.0 };
                for (f, e) in f.iter_mut().zip(e) {
                    *f += s * e;
                }
            }
            let [value, gx, gy, gz] = f;
            let (a, u) = (tv.gradient, tv.u);
            let mut p = [0.0f64; 9];
            p[0] = a.x * value;
            p[1] = a.y * value;
            p[2] = a.z * value;
            if hessian {
                let k = tv.radial_tangential * value;
                let d = tv.tangential * value;
                let h = |ai: f64, gi: f64, ui: f64, aj: f64, gj: f64, uj: f64| {
                    ai * gj + gi * aj + ui * (uj * k)
                };
                p[3] = h(a.x, gx, u.x, a.x, gx, u.x) - d;
                p[4] = h(a.x, gx, u.x, a.y, gy, u.y);
                p[5] = h(a.x, gx, u.x, a.z, gz, u.z);
                p[6] = h(a.y, gy, u.y, a.y, gy, u.y) - d;
                p[7] = h(a.y, gy, u.y, a.z, gz, u.z);
                p[8] = h(a.z, gz, u.z, a.z, gz, u.z) - d;
            }
            for (e, p) in extra[ch].iter_mut().zip(&p) {
                *e += p;
            }
            for (row, &l) in extra.iter_mut().zip(&self.vertex[far * ch..(far + 1) * ch]) {
                for (e, p) in row.iter_mut().zip(&p) {
                    *e += l * p;
                }
            }
        }
        let mut geometric = acc.pop().unwrap_or_default();
        for (d, e) in acc.iter_mut().chain([&mut geometric]).zip(&extra) {
            d.gradient += DVec3::new(e[0], e[1], e[2]);
            if hessian {
                d.hessian += DMat3::from_cols(
                    DVec3::new(e[3], e[4], e[5]),
                    DVec3::new(e[4], e[6], e[7]),
                    DVec3::new(e[5], e[7], e[8]),
                );
            }
        }
        out.geometric = geometric;
        finish(out, &acc, scale)
    }
}

/// Transmittance from x (the origin) to a vertex at scaled position `p`, with the expressions of
/// `kernels::transmittance` but without its validation (positions are validated and scaled), and
/// one division per vertex instead of four (the direction and `σT/r` from `1/r`, within an ulp of
/// the kernel's; medium gathers 2-3% faster).
#[inline]
fn vertex_transmittance(p: DVec3, sigma: f64, order: Order) -> Result<VertexTransmittance> {
    let m = p.abs().max_element();
    let (u, dist, inv) = if (1e-150..1e150).contains(&m) {
        let dist = p.length();
        let inv = 1.0 / dist;
        (p * -inv, dist, inv)
    } else {
        // Where the squared length would under- or overflow: the kernel's rescaled measurement.
        let (u, dist) = separation(DVec3::ZERO, p);
        (u, dist, 1.0 / dist)
    };
    if dist == 0.0 {
        return Err(Error::Degenerate(
            "transmittance gradient is undefined at x == y".into(),
        ));
    }
    let t = (-sigma * dist).exp();
    if t == 0.0 {
        return Ok(VertexTransmittance::default());
    }
    let mut out = VertexTransmittance {
        value: t,
        gradient: -sigma * t * u,
        u,
        ..VertexTransmittance::default()
    };
    if order.hessian() {
        let radial = sigma * sigma * t;
        out.tangential = sigma * t * inv;
        out.radial_tangential = radial + out.tangential;
    }
    Ok(out)
}
