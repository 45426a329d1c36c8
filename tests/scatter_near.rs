//! Steep integrands (issue 19): a light close to a flat interface and eye segments grazing it, on
//! small and on 1000-unit triangles, against the first-principles flat integral
//! (`scatter_common::flat_reference`: 1-D Snell bisection per point, recursively bisected
//! Gauss-Legendre).

mod scatter_common;

use glam::DVec3;
use raddiff::scatter::{single_scatter, Medium, RefractiveMesh, ScatterOptions};
use scatter_common::{flat_reference, medium};

/// The plane z = 0 as one triangle around the origin with sides of about 3 `size`.
fn plane(size: f64) -> RefractiveMesh {
    RefractiveMesh::new(
        &[
            DVec3::new(-size, -size, 0.0),
            DVec3::new(2.0 * size, -size, 0.0),
            DVec3::new(-size, 2.0 * size, 0.0),
        ],
        &[DVec3::Z; 3],
        &[[0, 1, 2]],
    )
    .unwrap()
}

fn check(mesh: &RefractiveMesh, m: &Medium, light: DVec3, entry: DVec3, exit: DVec3, tol: f64) {
    let exact = flat_reference::radiance(m, light, entry, exit, 1e-12);
    let got = single_scatter(mesh, m, entry, exit, light, 1.0, &ScatterOptions::default())
        .unwrap()
        .radiance;
    assert!(
        (got - exact).abs() <= tol * exact && exact > 0.0,
        "light {light}, segment {entry} -> {exit}: {got} vs {exact} (error {:.3e})",
        got / exact - 1.0
    );
}

#[test]
fn lights_close_to_the_surface() {
    let m = medium();
    let (entry, exit) = (DVec3::new(-0.6, 0.2, -0.05), DVec3::new(0.7, -0.3, -0.4));
    for size in [1.0, 100.0] {
        let mesh = plane(size);
        for h in [1e-1, 1e-2, 1e-3, 1e-4, 1e-6] {
            check(&mesh, &m, DVec3::new(0.1, -0.05, h), entry, exit, 1e-6);
        }
    }
}

#[test]
fn points_close_to_large_triangles_contribute() {
    let m = medium();
    let mesh = plane(1000.0);
    let light = DVec3::new(0.1, -0.05, 0.5);
    for depth in [1e-1, 1e-3, 1e-5] {
        // A steep segment ending close to the surface, and a grazing one at that depth.
        check(
            &mesh,
            &m,
            light,
            DVec3::new(0.2, 0.1, -depth),
            DVec3::new(0.4, 0.3, -1.0),
            1e-6,
        );
        check(
            &mesh,
            &m,
            light,
            DVec3::new(-0.8, 0.1, -depth),
            DVec3::new(0.9, -0.2, -1.5 * depth),
            1e-6,
        );
    }
}
