//! Single scattering: `raddiff_refractive_mesh_new` and `raddiff_single_scatter`.
//!
//! Input: a mesh (a perturbed octahedron or tetrahedron, closed; an open perturbed quad; or raw
//! arrays with any indices), then up to four scattering queries: the medium (valid most of the
//! time), entry and exit points (on the mesh's triangles, near its centre, or raw), the light
//! (outside, or raw) and the intensity.
//! Properties: no panic; a refused mesh is NULL with a message; with `RADDIFF_OK` the radiance is
//! finite and non-negative; on failure it is untouched and a message is set.
use raddiff::ffi::*;

use super::check::{self, sentinel};
use super::decode::{add_scaled, Input};
use super::Outcome;

const OCTAHEDRON: ([[f32; 3]; 6], [[u32; 3]; 8]) = (
    [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ],
    [
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ],
);

const TETRAHEDRON: ([[f32; 3]; 4], [[u32; 3]; 4]) = (
    [
        [1.0, 1.0, 1.0],
        [1.0, -1.0, -1.0],
        [-1.0, 1.0, -1.0],
        [-1.0, -1.0, 1.0],
    ],
    [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]],
);

const QUAD: ([[f32; 3]; 4], [[u32; 3]; 2]) = (
    [
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ],
    [[0, 1, 2], [0, 2, 3]],
);

/// A mesh as the C arrays.
struct Mesh {
    positions: Vec<f32>,
    normals: Vec<f32>,
    indices: Vec<u32>,
}

impl Mesh {
    fn vertex(&self, i: u32) -> raddiff_vec3 {
        let p = &self.positions[3 * i as usize..3 * i as usize + 3];
        raddiff_vec3 {
            x: p[0] as f64,
            y: p[1] as f64,
            z: p[2] as f64,
        }
    }
}

/// Decodes a mesh and up to four queries, and runs them.
pub fn run(data: &[u8]) -> Outcome {
    let mut input = Input::new(data);
    let mesh = mesh(&mut input);
    // SAFETY: each array holds the stated number of elements.
    let handle = unsafe {
        raddiff_refractive_mesh_new(
            mesh.positions.as_ptr(),
            mesh.normals.as_ptr(),
            mesh.positions.len() / 3,
            mesh.indices.as_ptr(),
            mesh.indices.len() / 3,
        )
    };
    if !check::constructed("raddiff_refractive_mesh_new", handle) {
        return Outcome::Refused;
    }
    let mut any_ok = false;
    for _ in 0..4 {
        any_ok |= query(&mut input, handle, &mesh);
        if input.is_empty() {
            break;
        }
    }
    // SAFETY: a live mesh, freed once.
    unsafe { raddiff_refractive_mesh_free(handle) };
    if any_ok {
        Outcome::Ok
    } else {
        Outcome::Refused
    }
}

fn mesh(input: &mut Input) -> Mesh {
    let shape = input.below(8);
    let (vertices, triangles): (Vec<[f32; 3]>, Vec<[u32; 3]>) = match shape {
        0..=3 => (OCTAHEDRON.0.to_vec(), OCTAHEDRON.1.to_vec()),
        4 | 5 => (TETRAHEDRON.0.to_vec(), TETRAHEDRON.1.to_vec()),
        6 => (QUAD.0.to_vec(), QUAD.1.to_vec()),
        _ => return raw_mesh(input),
    };
    let scale = if input.byte() < 224 {
        0.1 + input.magnitude().min(100.0)
    } else {
        input.f64()
    };
    let centre = input.vec3();
    let jitter = 10f64.powi(-(input.below(8) as i32) - 1);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for v in &vertices {
        let raw = raddiff_vec3 {
            x: v[0] as f64,
            y: v[1] as f64,
            z: v[2] as f64,
        };
        let moved = add_scaled(raw, jitter * input.unit(), input.unit3());
        let placed = add_scaled(centre, scale, moved);
        positions.extend([placed.x, placed.y, placed.z].map(|c| c as f32));
        // Radial normals suit the convex solids; the quad's vertices get its plane's normal.
        let n = if shape == 6 {
            [0.0, 0.0, 1.0]
        } else {
            [v[0], v[1], v[2]]
        };
        normals.extend(n);
    }
    Mesh {
        positions,
        normals,
        indices: triangles.concat(),
    }
}

fn raw_mesh(input: &mut Input) -> Mesh {
    let vertices = input.below(9) as usize;
    let triangles = input.below(9) as usize;
    let positions = (0..3 * vertices).map(|_| input.f32()).collect();
    let normals = (0..3 * vertices).map(|_| input.f32()).collect();
    let indices = (0..3 * triangles)
        .map(|_| input.below(vertices as u32 + 2))
        .collect();
    Mesh {
        positions,
        normals,
        indices,
    }
}

/// A point on triangle `t` of the mesh (barycentric from the input).
fn on_surface(input: &mut Input, mesh: &Mesh) -> raddiff_vec3 {
    let t = input.below((mesh.indices.len() / 3) as u32) as usize;
    let [a, b, c] = [0, 1, 2].map(|k| mesh.vertex(mesh.indices[3 * t + k]));
    let (mut u, mut v) = (input.unit(), input.unit());
    if u + v > 1.0 {
        (u, v) = (1.0 - u, 1.0 - v);
    }
    let ab = add_scaled(b, -1.0, a);
    let ac = add_scaled(c, -1.0, a);
    add_scaled(add_scaled(a, u, ab), v, ac)
}

fn centroid(mesh: &Mesh) -> raddiff_vec3 {
    let n = (mesh.positions.len() / 3) as f64;
    let sum = (0..mesh.positions.len() / 3).fold(raddiff_vec3::default(), |s, i| {
        add_scaled(s, 1.0, mesh.vertex(i as u32))
    });
    raddiff_vec3 {
        x: sum.x / n,
        y: sum.y / n,
        z: sum.z / n,
    }
}

fn point(input: &mut Input, mesh: &Mesh) -> raddiff_vec3 {
    match input.below(8) {
        0 => input.vec3(),
        1 => add_scaled(centroid(mesh), 0.1, input.unit3()),
        _ => on_surface(input, mesh),
    }
}

fn query(input: &mut Input, handle: *const raddiff_refractive_mesh, mesh: &Mesh) -> bool {
    let valid = input.byte() < 224;
    let medium = if valid {
        let sigma_t = input.magnitude().min(10.0);
        raddiff_medium {
            eta: 1.0 + 1e-3 + input.magnitude().min(3.0),
            sigma_t,
            sigma_s: sigma_t * input.unit(),
            g: (input.unit() * 2.0 - 1.0).clamp(-0.99, 0.99),
        }
    } else {
        raddiff_medium {
            eta: input.f64(),
            sigma_t: input.f64(),
            sigma_s: input.f64(),
            g: input.f64(),
        }
    };
    let entry = point(input, mesh);
    let exit = point(input, mesh);
    let light = if input.byte() < 224 {
        let reach = mesh
            .positions
            .iter()
            .fold(0.0f64, |r, p| r.max(p.abs() as f64));
        add_scaled(
            centroid(mesh),
            3.0 * reach + 1.0 + input.magnitude().min(1e3),
            input.unit3(),
        )
    } else {
        input.vec3()
    };
    let intensity = if valid {
        input.magnitude()
    } else {
        input.f64()
    };
    let mut radiance = sentinel();
    let name = "raddiff_single_scatter";
    // SAFETY: a live mesh, a valid medium and one writable double.
    let status = unsafe {
        raddiff_single_scatter(
            handle,
            &medium,
            entry,
            exit,
            light,
            intensity,
            &mut radiance,
        )
    };
    if !check::status(name, status) {
        check::untouched(name, "radiance", &[radiance]);
        return false;
    }
    assert!(
        radiance.is_finite() && radiance >= 0.0,
        "{name}: RADDIFF_OK with radiance {radiance}"
    );
    true
}
