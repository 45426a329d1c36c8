//! Paths through shared edges and vertices are counted once (issue 19): a refraction point on the
//! diagonal of a two-triangle quad, at the centre of vertex fans of 3-8 triangles and at a 6-valent
//! vertex of an icosphere, for whole eye segments. References: the flat interface's first-principles
//! integral, or the same configuration with the light moved 1e-9 off the symmetry (which puts every
//! path strictly inside one triangle).

mod scatter_common;

use glam::DVec3;
use raddiff::scatter::constraint::refract_in;
use raddiff::scatter::{scene, single_scatter, Medium, RefractiveMesh, ScatterOptions};
use scatter_common::{flat_reference, medium};

fn run(mesh: &RefractiveMesh, m: &Medium, entry: DVec3, exit: DVec3, light: DVec3) -> f64 {
    single_scatter(mesh, m, entry, exit, light, 1.0, &ScatterOptions::default())
        .unwrap()
        .radiance
}

/// Outward normals of a dome: directions from a centre below the plane (symmetric under every
/// symmetry of the vertex layout that fixes the centre's vertical).
fn dome(p: &[DVec3], centre: DVec3) -> Vec<DVec3> {
    p.iter().map(|q| (*q - centre).normalize()).collect()
}

fn quad(curved: bool) -> RefractiveMesh {
    let p = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
    ];
    let n = if curved {
        dome(&p, DVec3::new(0.5, 0.5, -3.0))
    } else {
        vec![DVec3::Z; 4]
    };
    RefractiveMesh::new(&p, &n, &[[0, 1, 2], [0, 2, 3]]).unwrap()
}

/// `n` triangles around a centre vertex at the origin (index `centre_index` in the vertex list, so
/// that the tie-breaking by index is exercised both ways).
fn fan(n: usize, curved: bool, centre_index: usize) -> RefractiveMesh {
    let mut p: Vec<DVec3> = (0..n)
        .map(|k| {
            let a = 2.0 * std::f64::consts::PI * k as f64 / n as f64 + 0.1;
            DVec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    p.insert(centre_index, DVec3::ZERO);
    let rim = |k: usize| {
        let k = k % n;
        (if k >= centre_index { k + 1 } else { k }) as u32
    };
    let t: Vec<[u32; 3]> = (0..n)
        .map(|k| [centre_index as u32, rim(k), rim(k + 1)])
        .collect();
    let normals = if curved {
        dome(&p, DVec3::new(0.0, 0.0, -2.0))
    } else {
        vec![DVec3::Z; p.len()]
    };
    RefractiveMesh::new(&p, &normals, &t).unwrap()
}

fn close(got: f64, reference: f64, tol: f64, what: &str) {
    assert!(
        (got - reference).abs() <= tol * reference.abs() && reference > 0.0,
        "{what}: {got} vs {reference} (ratio {})",
        got / reference
    );
}

#[test]
fn quad_diagonal_is_counted_once() {
    let m = medium();
    let light = DVec3::new(0.3, 0.3, 2.0);
    let (entry, exit) = (DVec3::new(0.2, 0.2, -0.3), DVec3::new(0.8, 0.8, -0.6));
    let exact = flat_reference::radiance(&m, light, entry, exit, 1e-12);
    close(
        run(&quad(false), &m, entry, exit, light),
        exact,
        1e-9,
        "flat quad",
    );
    let off = DVec3::new(1e-9, -1e-9, 0.0);
    let curved = quad(true);
    let shifted = run(&curved, &m, entry, exit, light + off);
    close(
        run(&curved, &m, entry, exit, light),
        shifted,
        1e-9,
        "curved quad",
    );
    // The eye segment crossing the diagonal plane: paths cross the diagonal once.
    let (entry, exit) = (DVec3::new(0.1, 0.6, -0.3), DVec3::new(0.8, 0.3, -0.5));
    let exact = flat_reference::radiance(&m, light, entry, exit, 1e-12);
    close(
        run(&quad(false), &m, entry, exit, light),
        exact,
        1e-9,
        "crossing",
    );
}

#[test]
fn vertex_fans_are_counted_once() {
    let m = medium();
    for n in 3..=8 {
        for centre_index in [0, n] {
            // The light off the axis; the eye segment on the ray refracted at the centre vertex.
            let light = DVec3::new(0.3, 0.2, 2.0);
            let t = refract_in(DVec3::ZERO, light, DVec3::Z, m.eta).unwrap();
            let (entry, exit) = (0.05 * t, 1.2 * t);
            let flat = fan(n, false, centre_index);
            let exact = flat_reference::radiance(&m, light, entry, exit, 1e-12);
            close(
                run(&flat, &m, entry, exit, light),
                exact,
                1e-9,
                &format!("flat fan {n}"),
            );
            // Curved (the centre normal is still +z by symmetry): against a 1e-9 shift.
            let curved = fan(n, true, centre_index);
            let shifted = run(&curved, &m, entry, exit, light + DVec3::new(1e-9, 0.0, 0.0));
            close(
                run(&curved, &m, entry, exit, light),
                shifted,
                1e-9,
                &format!("curved fan {n}"),
            );
        }
    }
}

#[test]
fn icosphere_six_valent_vertex_is_counted_once() {
    let data = scene::bumpy_sphere(4, 0.0, 6.0);
    let mesh = data.build().unwrap();
    let mut valence = vec![0; data.positions.len()];
    for t in &data.triangles {
        for &i in t {
            valence[i as usize] += 1;
        }
    }
    let v = valence.iter().position(|&k| k == 6).unwrap();
    let (p, n) = (data.positions[v], data.normals[v]);
    let m = medium();
    // A light off the normal, and the eye segment along the ray it refracts into at the vertex.
    let side = n.any_orthonormal_vector();
    let light = p + 3.0 * n + 0.4 * side;
    let t = refract_in(p, light, n, m.eta).unwrap();
    let (entry, exit) = (p + 0.02 * t, p + 1.0 * t);
    let got = run(&mesh, &m, entry, exit, light);
    let shifted = run(&mesh, &m, entry, exit, light + 1e-9 * n.cross(side));
    close(got, shifted, 1e-9, "icosphere vertex");
}
