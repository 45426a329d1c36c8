//! The triangle mesh a hemisphere gather implies: connectivity from the layout's grid (built once
//! per layout and reused), and per-gather vertex positions.
//!
//! Vertices are the M·N hit points plus synthesized ones that close the hemisphere:
//!
//! * a **horizon ring**: for every sample on the grid's outer boundary (polar ring M−1; the
//!   concentric square's perimeter), a vertex in the tangent plane at the sample's azimuth and hit
//!   distance, so that the mesh reaches the horizon and the all-miss hemisphere has form factor
//!   exactly 1;
//! * for the polar layout, a **pole** vertex along the normal (ring 0 does not reach θ = 0), at the
//!   harmonic mean of ring 0's distances (kept within their range, so that equal distances give
//!   exactly theirs), with ring 0's mean radiance.
//!
//! Triangles are listed counter-clockwise about the normal as seen from its tip (so each triangle's
//! edge terms `kernels::edge_form_factor` sum to its form factor). Every undirected edge is stored
//! once with the triangle on its left (which lists it as `a → b`) and the one on its right (which
//! lists it `b → a`), or [`NONE`] on the horizon, where the mesh ends.

use crate::error::{Error, Result};
use crate::gather::layout::LayoutKind;

/// No triangle (the right side of a horizon edge).
pub const NONE: u32 = u32::MAX;

/// Marks the synthesized pole vertex in [`Topology::vertex_source`] (the north pole, θ = 0).
pub const POLE: u32 = u32::MAX;

/// Marks the synthesized south pole vertex (θ = π) of a [`LayoutKind::Sphere`] mesh.
pub const SOUTH_POLE: u32 = u32::MAX - 1;

/// An undirected mesh edge, oriented as its left triangle lists it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Edge {
    /// Start vertex.
    pub a: u32,
    /// End vertex.
    pub b: u32,
    /// The triangle listing `a → b`.
    pub left: u32,
    /// The triangle listing `b → a`, or [`NONE`] on the horizon.
    pub right: u32,
}

/// Connectivity of the triangulated hemisphere of an M×N layout.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topology {
    /// The layout whose grid connectivity the mesh follows: `CosinePolar` (rings 0 = pole … M−1 =
    /// horizon, wrapping in k), `Concentric` (the square's centre is the pole, its boundary the
    /// horizon) or `Sphere` (rings from north to south, closed by a pole vertex at each end).
    pub connectivity: LayoutKind,
    /// Strata along the first axis.
    pub m: usize,
    /// Strata along the second axis.
    pub n: usize,
    /// For every vertex, the sample (index `j·N + k`) whose distance and radiance it takes, or
    /// [`POLE`]. Vertices `0..M·N` are the samples themselves.
    pub vertex_source: Vec<u32>,
    /// Whether a vertex lies on the horizon (in the tangent plane).
    pub on_horizon: Vec<bool>,
    /// Triangles, counter-clockwise about the normal.
    pub triangles: Vec<[u32; 3]>,
    /// Each undirected edge once.
    pub edges: Vec<Edge>,
    /// For every triangle, its three edges (indices into `edges`) in the triangle's order, with
    /// [`REVERSED`] set when the triangle lists the edge `b → a`.
    pub triangle_edges: Vec<[u32; 3]>,
}

/// Flag in [`Topology::triangle_edges`]: the triangle runs the edge backwards.
pub const REVERSED: u32 = 1 << 31;

impl Topology {
    /// The mesh of an `m`×`n` layout. Needs at least 6 azimuthal strata for the polar and sphere
    /// layouts and a 3×3 grid for the concentric one (`InvalidArgument` otherwise): with jitter,
    /// two neighbouring samples can be up to two strata apart in azimuth, and the horizon ring only
    /// winds once around x while every such gap stays well below π.
    pub fn new(connectivity: LayoutKind, m: usize, n: usize) -> Result<Topology> {
        let samples = m
            .checked_mul(n)
            .filter(|&s| s < (u32::MAX / 4) as usize)
            .ok_or_else(|| Error::InvalidArgument(format!("layout {m}x{n} is too large")))?;
        let mut vertex_source: Vec<u32> = (0..samples as u32).collect();
        let mut on_horizon = vec![false; samples];
        let mut triangles = Vec::with_capacity(2 * samples + 4 * (m + n));
        let id = |j: usize, k: usize| (j * n + k) as u32;
        // Quad a, b, c, d counter-clockwise, split along a-c.
        let quad = |t: &mut Vec<[u32; 3]>, a: u32, b: u32, c: u32, d: u32| {
            t.push([a, b, c]);
            t.push([a, c, d]);
        };
        match connectivity {
            LayoutKind::CosinePolar => {
                if m < 1 || n < 6 {
                    return Err(Error::InvalidArgument(format!(
                        "a polar layout needs m >= 1 and n >= 6 to be triangulated (got {m}x{n})"
                    )));
                }
                // Horizon vertices (ring "M") after the samples, then the pole.
                let horizon0 = samples as u32;
                for k in 0..n {
                    vertex_source.push(id(m - 1, k));
                    on_horizon.push(true);
                }
                let pole = vertex_source.len() as u32;
                vertex_source.push(POLE);
                on_horizon.push(false);
                let ring = |j: usize, k: usize| {
                    let k = k % n;
                    if j == m {
                        horizon0 + k as u32
                    } else {
                        id(j, k)
                    }
                };
                for k in 0..n {
                    triangles.push([pole, ring(0, k), ring(0, k + 1)]);
                }
                for j in 0..m {
                    for k in 0..n {
                        quad(
                            &mut triangles,
                            ring(j, k),
                            ring(j + 1, k),
                            ring(j + 1, k + 1),
                            ring(j, k + 1),
                        );
                    }
                }
            }
            LayoutKind::Sphere => {
                if m < 1 || n < 6 {
                    return Err(Error::InvalidArgument(format!(
                        "a sphere layout needs m >= 1 and n >= 6 to be triangulated (got {m}x{n})"
                    )));
                }
                let north = vertex_source.len() as u32;
                vertex_source.push(POLE);
                on_horizon.push(false);
                let south = vertex_source.len() as u32;
                vertex_source.push(SOUTH_POLE);
                on_horizon.push(false);
                let ring = |j: usize, k: usize| id(j, k % n);
                for k in 0..n {
                    triangles.push([north, ring(0, k), ring(0, k + 1)]);
                    triangles.push([south, ring(m - 1, k + 1), ring(m - 1, k)]);
                }
                for j in 0..m - 1 {
                    for k in 0..n {
                        quad(
                            &mut triangles,
                            ring(j, k),
                            ring(j + 1, k),
                            ring(j + 1, k + 1),
                            ring(j, k + 1),
                        );
                    }
                }
            }
            LayoutKind::Concentric => {
                if m < 3 || n < 3 {
                    return Err(Error::InvalidArgument(format!(
                        "a concentric layout needs m, n >= 3 to be triangulated (got {m}x{n})"
                    )));
                }
                // Grid axis j runs along the square's x, k along its y: (j, k) → (j+1, k) →
                // (j+1, k+1) → (j, k+1) is counter-clockwise.
                for j in 0..m - 1 {
                    for k in 0..n - 1 {
                        quad(
                            &mut triangles,
                            id(j, k),
                            id(j + 1, k),
                            id(j + 1, k + 1),
                            id(j, k + 1),
                        );
                    }
                }
                // The perimeter, counter-clockwise: bottom row, right column, top row, left column.
                let mut perimeter = Vec::with_capacity(2 * (m + n));
                perimeter.extend((0..m).map(|j| id(j, 0)));
                perimeter.extend((1..n).map(|k| id(m - 1, k)));
                perimeter.extend((0..m - 1).rev().map(|j| id(j, n - 1)));
                perimeter.extend((1..n - 1).rev().map(|k| id(0, k)));
                let horizon0 = vertex_source.len() as u32;
                for &p in &perimeter {
                    vertex_source.push(p);
                    on_horizon.push(true);
                }
                let count = perimeter.len();
                for i in 0..count {
                    let next = (i + 1) % count;
                    quad(
                        &mut triangles,
                        perimeter[i],
                        horizon0 + i as u32,
                        horizon0 + next as u32,
                        perimeter[next],
                    );
                }
            }
        }
        let (edges, triangle_edges) = match_edges(&triangles)?;
        Ok(Topology {
            connectivity,
            m,
            n,
            vertex_source,
            on_horizon,
            triangles,
            edges,
            triangle_edges,
        })
    }

    /// Number of vertices (samples and synthesized).
    pub fn vertex_count(&self) -> usize {
        self.vertex_source.len()
    }
}

/// Pairs the triangles' directed edges into undirected edges with left and right triangles.
/// `InvalidArgument` (an internal inconsistency) if an edge is used twice in the same direction or
/// by more than two triangles.
fn match_edges(triangles: &[[u32; 3]]) -> Result<(Vec<Edge>, Vec<[u32; 3]>)> {
    // (low, high, triangle·3 + slot, forward = listed low → high)
    let mut half: Vec<(u32, u32, u32, bool)> = Vec::with_capacity(3 * triangles.len());
    for (t, tri) in triangles.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (tri[i], tri[(i + 1) % 3]);
            half.push((a.min(b), a.max(b), (3 * t + i) as u32, a < b));
        }
    }
    let mut triangle_edges = vec![[0u32; 3]; triangles.len()];
    sort_half_edges(&mut half);
    let mut edges = Vec::with_capacity(half.len() / 2 + 8);
    let mut i = 0;
    while i < half.len() {
        let (lo, hi, t, fwd) = half[i];
        let twin = half.get(i + 1).filter(|h| h.0 == lo && h.1 == hi).copied();
        let inconsistent = || {
            Error::InvalidArgument(format!(
                "internal: mesh edge {lo}-{hi} is not shared by two oppositely oriented triangles"
            ))
        };
        let index = edges.len() as u32;
        let slot = |s: u32| (s / 3) as usize;
        match twin {
            Some((_, _, t2, fwd2)) => {
                if fwd == fwd2 || half.get(i + 2).is_some_and(|h| h.0 == lo && h.1 == hi) {
                    return Err(inconsistent());
                }
                let (left, right) = if fwd { (t, t2) } else { (t2, t) };
                triangle_edges[slot(left)][(left % 3) as usize] = index;
                triangle_edges[slot(right)][(right % 3) as usize] = index | REVERSED;
                edges.push(Edge {
                    a: lo,
                    b: hi,
                    left: left / 3,
                    right: right / 3,
                });
                i += 2;
            }
            None => {
                let (a, b) = if fwd { (lo, hi) } else { (hi, lo) };
                triangle_edges[slot(t)][(t % 3) as usize] = index;
                edges.push(Edge {
                    a,
                    b,
                    left: t / 3,
                    right: NONE,
                });
                i += 1;
            }
        }
    }
    Ok((edges, triangle_edges))
}

/// Sorts the half-edges `(low, high, slot, forward)` lexicographically, as `sort_unstable` would,
/// in linear time: vertex ids are dense and every vertex has a handful of edges, so the half-edges
/// are bucketed by `low` (a counting sort) and each small bucket is sorted on its own (the global
/// comparison sort took ~55% of building a 4096-sample topology).
fn sort_half_edges(half: &mut Vec<(u32, u32, u32, bool)>) {
    let Some(max_low) = half.iter().map(|h| h.0).max() else {
        return;
    };
    let mut start = vec![0usize; max_low as usize + 2];
    for h in half.iter() {
        start[h.0 as usize + 1] += 1;
    }
    for v in 1..start.len() {
        start[v] += start[v - 1];
    }
    let mut sorted = vec![(0u32, 0u32, 0u32, false); half.len()];
    let mut next = start.clone();
    for &h in half.iter() {
        let at = &mut next[h.0 as usize];
        sorted[*at] = h;
        *at += 1;
    }
    for bucket in start.windows(2) {
        sorted[bucket[0]..bucket[1]].sort_unstable();
    }
    *half = sorted;
}

#[cfg(test)]
mod tests;
