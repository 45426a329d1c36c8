//! The references the occlusion-aware evaluation is tested and benchmarked against: every edge
//! through the general edge kernel ([`occlusion_derivatives_reference`], with the medium's
//! per-triangle product rule), and every triangle's three edges evaluated separately
//! ([`occlusion_derivatives_per_triangle`]). Compiled only with the `reference` feature, which the
//! crate's tests and benches turn on and users' builds leave off.

use glam::{DMat3, DVec3};

use super::gather_mesh::{
    all_black, edge_term, empty, finish, mesh_geometry, HemisphereGather, MeshGeometry,
    OcclusionDerivatives, Scale,
};
use super::mesh::{Topology, NONE, POLE, REVERSED};
use crate::error::{Error, Result};
use crate::kernels;
use crate::{Deriv3, Order};

/// [`occlusion_derivatives`](super::occlusion_derivatives) with every edge evaluated by the general edge kernel
/// (`kernels::edge_form_factor`'s closed form, one call per edge): the reference the
/// gather-specialised edge evaluation is tested and benchmarked against.
pub fn occlusion_derivatives_reference(
    topo: &Topology,
    g: &HemisphereGather,
    order: Order,
) -> Result<OcclusionDerivatives> {
    let mesh = mesh_geometry(topo, g)?;
    reference_on(topo, &mesh, g, order)
}

fn reference_on(
    topo: &Topology,
    mesh: &MeshGeometry,
    g: &HemisphereGather,
    order: Order,
) -> Result<OcclusionDerivatives> {
    if !order.gradient() {
        return Err(Error::InvalidArgument(
            "occlusion derivatives need order >= RADDIFF_ORDER_GRADIENT".into(),
        ));
    }
    let n = g.normal.normalize();
    let channels = g.channels;
    let mut out = empty(channels, all_black(g));
    if g.sigma_t > 0.0 {
        return with_medium_reference(topo, mesh, g, order, out);
    }
    let tri = triangle_radiance(topo, mesh, g);
    let outside = topo.triangles.len();
    let scale = Scale::of(mesh);
    let mut acc = vec![Deriv3::constant(0.0); channels];
    let mut delta = vec![0.0f64; channels];
    for e in &topo.edges {
        let boundary = e.right == NONE;
        let right = if boundary { outside } else { e.right as usize };
        let (l, r) = (e.left as usize * channels, right * channels);
        let mut any = false;
        for (c, d) in delta.iter_mut().enumerate() {
            *d = tri[l + c] - tri[r + c];
            any |= *d != 0.0;
        }
        if !any && !boundary {
            continue;
        }
        let f = edge_term(
            n,
            scale.point(mesh.positions[e.a as usize]),
            scale.point(mesh.positions[e.b as usize]),
            order,
        )?;
        if boundary {
            add_scaled(&mut out.geometric, &f, 1.0, order);
        }
        for (a, &d) in acc.iter_mut().zip(&delta) {
            if d != 0.0 {
                add_scaled(a, &f, d, order);
            }
        }
    }
    finish(out, &acc, scale)
}

/// The per-triangle form of [`occlusion_derivatives`](super::occlusion_derivatives): every triangle's three edge terms are
/// evaluated separately (each interior edge twice). Same result to rounding; the baseline the
/// shared-edge evaluation is benchmarked against.
pub fn occlusion_derivatives_per_triangle(
    topo: &Topology,
    g: &HemisphereGather,
    order: Order,
) -> Result<OcclusionDerivatives> {
    let mesh = mesh_geometry(topo, g)?;
    if !order.gradient() {
        return Err(Error::InvalidArgument(
            "occlusion derivatives need order >= RADDIFF_ORDER_GRADIENT".into(),
        ));
    }
    let n = g.normal.normalize();
    let scale = Scale::of(&mesh);
    let mut out = empty(g.channels, all_black(g));
    let mut acc = vec![Deriv3::constant(0.0); g.channels];
    for (t, tri) in topo.triangles.iter().enumerate() {
        let mut f = Deriv3::constant(0.0);
        for i in 0..3 {
            let a = scale.point(mesh.positions[tri[i] as usize]);
            let b = scale.point(mesh.positions[tri[(i + 1) % 3] as usize]);
            add_scaled(&mut f, &edge_term(n, a, b, order)?, 1.0, order);
        }
        add_scaled(&mut out.geometric, &f, 1.0, order);
        for (c, a) in acc.iter_mut().enumerate() {
            let l = vertex_radiance(topo, &mesh, g, mesh.farthest[t], c);
            add_scaled(a, &f, l, order);
        }
    }
    finish(out, &acc, scale)
}

/// The medium path of [`occlusion_derivatives_reference`]: per-triangle form factors from
/// once-computed general-kernel edge terms, times the transmittance to the triangle's farthest
/// vertex (product rule).
fn with_medium_reference(
    topo: &Topology,
    mesh: &MeshGeometry,
    g: &HemisphereGather,
    order: Order,
    mut out: OcclusionDerivatives,
) -> Result<OcclusionDerivatives> {
    let n = g.normal.normalize();
    let scale = Scale::of(mesh);
    // σ_t r is scale-free: σ_t in scaled units is σ_t / (f1 f2).
    let sigma = g.sigma_t / scale.f1 / scale.f2;
    let mut edge_terms = Vec::with_capacity(topo.edges.len());
    for e in &topo.edges {
        edge_terms.push(edge_term(
            n,
            scale.point(mesh.positions[e.a as usize]),
            scale.point(mesh.positions[e.b as usize]),
            order,
        )?);
    }
    let mut acc = vec![Deriv3::constant(0.0); g.channels];
    for (t, codes) in topo.triangle_edges.iter().enumerate() {
        let far = mesh.farthest[t];
        let src = topo.vertex_source[far as usize];
        // Misses (and the pole, if it sits at the far distance) are attenuated to zero.
        if mesh.distance[far as usize] >= mesh.far_distance {
            continue;
        }
        let mut f = Deriv3::constant(0.0);
        for &code in codes {
            let sign = if code & REVERSED != 0 { -1.0 } else { 1.0 };
            add_scaled(
                &mut f,
                &edge_terms[(code & !REVERSED) as usize],
                sign,
                order,
            );
        }
        let tr = kernels::transmittance(
            DVec3::ZERO,
            scale.point(mesh.positions[far as usize]),
            sigma,
            order,
        )?;
        let mut p = Deriv3::constant(f.value * tr.value);
        if order.gradient() {
            p.gradient = f.gradient * tr.value + tr.gradient * f.value;
        }
        if order.hessian() {
            let cross = DMat3::from_cols(
                tr.gradient * f.gradient.x + f.gradient * tr.gradient.x,
                tr.gradient * f.gradient.y + f.gradient * tr.gradient.y,
                tr.gradient * f.gradient.z + f.gradient * tr.gradient.z,
            );
            p.hessian = f.hessian * tr.value + cross + tr.hessian * f.value;
        }
        add_scaled(&mut out.geometric, &p, 1.0, order);
        for (c, a) in acc.iter_mut().enumerate() {
            let l = if src == POLE {
                mesh.pole_radiance[c]
            } else {
                g.radiance[src as usize * g.channels + c] as f64
            };
            if l != 0.0 {
                add_scaled(a, &p, l, order);
            }
        }
    }
    finish(out, &acc, scale)
}

/// Radiance of vertex `v` in channel `c` (sample, horizon copy or pole).
#[inline]
fn vertex_radiance(
    topo: &Topology,
    mesh: &MeshGeometry,
    g: &HemisphereGather,
    v: u32,
    c: usize,
) -> f64 {
    let src = topo.vertex_source[v as usize];
    if src == POLE {
        mesh.pole_radiance[c]
    } else {
        g.radiance[src as usize * g.channels + c] as f64
    }
}

fn add_scaled(acc: &mut Deriv3, d: &Deriv3, w: f64, order: Order) {
    acc.value += w * d.value;
    if order.gradient() {
        acc.gradient += d.gradient * w;
    }
    if order.hessian() {
        acc.hessian += d.hessian * w;
    }
}

/// Radiance of every triangle (its farthest vertex's), channel-interleaved, plus a zero row that
/// stands for the outside of the horizon.
fn triangle_radiance(topo: &Topology, mesh: &MeshGeometry, g: &HemisphereGather) -> Vec<f64> {
    let channels = g.channels;
    let samples = g.radiance.len();
    // Per-vertex radiance first (samples, then horizon copies and the pole), so the triangles'
    // lookups are plain indexing.
    let mut vertex: Vec<f64> = g.radiance.iter().map(|&l| l as f64).collect();
    vertex.reserve(topo.vertex_count() * channels - samples);
    for v in samples / channels..topo.vertex_count() {
        for c in 0..channels {
            vertex.push(vertex_radiance(topo, mesh, g, v as u32, c));
        }
    }
    let tcount = topo.triangles.len();
    let mut tri = Vec::with_capacity((tcount + 1) * channels);
    if channels == 1 {
        tri.extend(mesh.farthest.iter().map(|&f| vertex[f as usize]));
    } else {
        for &f in &mesh.farthest {
            let f = f as usize * channels;
            tri.extend_from_slice(&vertex[f..f + channels]);
        }
    }
    tri.resize((tcount + 1) * channels, 0.0);
    tri
}
