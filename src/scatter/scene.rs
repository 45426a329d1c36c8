//! A procedural test scene: the bumpy sphere of the report's figures (Walter et al. 2009 used a
//! 9680-triangle model; `bumpy_sphere(22, ..)` has exactly that many triangles).

use std::collections::HashMap;

use glam::DVec3;

use super::mesh::RefractiveMesh;
use crate::error::Result;

/// Vertex positions, vertex normals and triangles of a mesh.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Unit vertex normals (area-weighted averages of the adjacent face normals).
    pub normals: Vec<DVec3>,
    /// Vertex index triples, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl MeshData {
    /// Validates the data into a [`RefractiveMesh`].
    pub fn build(&self) -> Result<RefractiveMesh> {
        RefractiveMesh::new(&self.positions, &self.normals, &self.triangles)
    }
}

const PHI: f64 = 1.618_033_988_749_895;

fn icosahedron() -> (Vec<DVec3>, Vec<[usize; 3]>) {
    let v = [
        (-1.0, PHI, 0.0),
        (1.0, PHI, 0.0),
        (-1.0, -PHI, 0.0),
        (1.0, -PHI, 0.0),
        (0.0, -1.0, PHI),
        (0.0, 1.0, PHI),
        (0.0, -1.0, -PHI),
        (0.0, 1.0, -PHI),
        (PHI, 0.0, -1.0),
        (PHI, 0.0, 1.0),
        (-PHI, 0.0, -1.0),
        (-PHI, 0.0, 1.0),
    ];
    let v: Vec<DVec3> = v
        .iter()
        .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
        .collect();
    let f = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    (v, f)
}

/// A geodesic sphere of `20 frequency²` triangles with radius 1 + `amplitude` sin(k x) sin(k y)
/// sin(k z) (k = `bump_frequency`) around the origin, with area-weighted vertex normals.
///
/// `frequency` 22 gives 9680 triangles (the report's bumpy sphere), 71 about 100k.
pub fn bumpy_sphere(frequency: usize, amplitude: f64, bump_frequency: f64) -> MeshData {
    let n = frequency.max(1);
    let (ico, faces) = icosahedron();
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut dirs: Vec<DVec3> = Vec::new();
    let mut triangles = Vec::with_capacity(20 * n * n);
    let mut vertex = |p: DVec3| -> u32 {
        let d = p.normalize();
        let key = [
            (d.x * 1e9).round() as i64,
            (d.y * 1e9).round() as i64,
            (d.z * 1e9).round() as i64,
        ];
        *index.entry(key).or_insert_with(|| {
            dirs.push(d);
            (dirs.len() - 1) as u32
        })
    };
    for f in &faces {
        let (a, b, c) = (ico[f[0]], ico[f[1]], ico[f[2]]);
        // Orient outwards.
        let (b, c) = if (b - a).cross(c - a).dot(a + b + c) > 0.0 {
            (b, c)
        } else {
            (c, b)
        };
        let mut grid = vec![vec![0u32; n + 1]; n + 1];
        for (i, row) in grid.iter_mut().enumerate() {
            for (j, slot) in row.iter_mut().enumerate().take(n + 1 - i) {
                let p = a + (b - a) * (i as f64 / n as f64) + (c - a) * (j as f64 / n as f64);
                *slot = vertex(p);
            }
        }
        for i in 0..n {
            for j in 0..n - i {
                triangles.push([grid[i][j], grid[i + 1][j], grid[i][j + 1]]);
                if i + j + 1 < n {
                    triangles.push([grid[i + 1][j], grid[i + 1][j + 1], grid[i][j + 1]]);
                }
            }
        }
    }
    let k = bump_frequency;
    let positions: Vec<DVec3> = dirs
        .iter()
        .map(|d| *d * (1.0 + amplitude * (k * d.x).sin() * (k * d.y).sin() * (k * d.z).sin()))
        .collect();
    let mut normals = vec![DVec3::ZERO; positions.len()];
    for t in &triangles {
        let p = t.map(|i| positions[i as usize]);
        let area_normal = (p[1] - p[0]).cross(p[2] - p[0]);
        for &i in t {
            normals[i as usize] += area_normal;
        }
    }
    for nrm in &mut normals {
        *nrm = nrm.normalize();
    }
    MeshData {
        positions,
        normals,
        triangles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bumpy_sphere_is_closed_and_outward() {
        let m = bumpy_sphere(4, 0.05, 6.0);
        assert_eq!(m.triangles.len(), 320);
        // Euler characteristic of a closed sphere: V - E + F = 2, E = 3F/2.
        assert_eq!(m.positions.len() as i64 - 480 + 320, 2);
        let mut volume = 0.0;
        for t in &m.triangles {
            let p = t.map(|i| m.positions[i as usize]);
            volume += p[0].dot(p[1].cross(p[2])) / 6.0;
        }
        assert!(
            (volume - 4.0 / 3.0 * std::f64::consts::PI).abs() < 0.3,
            "{volume}"
        );
        assert!(m.build().is_ok());
        assert_eq!(bumpy_sphere(22, 0.05, 6.0).triangles.len(), 9680);
    }
}
