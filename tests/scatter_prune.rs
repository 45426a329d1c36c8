//! The pruning tests are conservative: every refracted path the brute-force search finds passes the
//! sidedness, spindle and normal-cone tests of its triangle, with x inside the returned ranges, and
//! the spindle test of every hierarchy node above it.

mod scatter_common;

use raddiff::scatter::constraint::{Constraint, EyeSegment};
use raddiff::scatter::integrate::subdivision_seeds;
use raddiff::scatter::interval::solutions_at;
use raddiff::scatter::newton::{NewtonCounters, NewtonSettings};
use raddiff::scatter::prune::{normal_cone_test, sidedness_test, spindle_test};
use raddiff::scatter::scene;
use scatter_common::{chord, eye_rays, LIGHT};

#[test]
fn every_path_found_passes_every_pruning_test() {
    let mesh = scene::bumpy_sphere(6, 0.05, 6.0).build().unwrap();
    let eta = 1.5;
    let seeds = subdivision_seeds(3);
    let nodes = mesh.hierarchy().nodes();
    // Parent links, to check every node above a triangle.
    let mut leaf_of = vec![usize::MAX; mesh.triangle_count()];
    let mut parent = vec![usize::MAX; nodes.len()];
    for (i, n) in nodes.iter().enumerate() {
        if n.count > 0 {
            for &t in mesh.hierarchy().leaf_triangles(n) {
                leaf_of[t as usize] = i;
            }
        } else {
            parent[i + 1] = i;
            parent[n.start_or_right as usize] = i;
        }
    }
    let mut checked = 0;
    for (o, d) in eye_rays(10) {
        let Some((a, b)) = chord(&mesh, o, d) else {
            continue;
        };
        let eye = EyeSegment::new(a, b).unwrap();
        let full = (0.0, eye.length);
        for k in 0..60 {
            let x = eye.length * (k as f64 + 0.5) / 60.0;
            for (ti, tri) in mesh.triangles().iter().enumerate() {
                let c = Constraint {
                    tri,
                    eye: &eye,
                    light: LIGHT,
                    eta,
                };
                let found = solutions_at(
                    &c,
                    x,
                    &seeds,
                    false,
                    &NewtonSettings::default(),
                    &mut NewtonCounters::default(),
                );
                if found.is_empty() {
                    continue;
                }
                checked += 1;
                let r = sidedness_test(tri, &eye, full, LIGHT).expect("sidedness pruned a path");
                assert!(r.0 <= x && x <= r.1, "sidedness range {r:?} misses x = {x}");
                let sphere = mesh.triangle_sphere(ti);
                assert!(
                    spindle_test(sphere, &eye, full, LIGHT, eta),
                    "spindle pruned triangle {ti}"
                );
                let r = normal_cone_test(
                    sphere,
                    mesh.triangle_normal_cone(ti),
                    &eye,
                    full,
                    LIGHT,
                    eta,
                )
                .expect("normal cone pruned a path");
                assert!(
                    r.0 <= x && x <= r.1,
                    "normal-cone range {r:?} misses x = {x} (triangle {ti})"
                );
                let mut node = leaf_of[ti];
                while node != usize::MAX {
                    assert!(
                        spindle_test(&nodes[node].sphere, &eye, full, LIGHT, eta),
                        "node {node}"
                    );
                    node = parent[node];
                }
            }
        }
    }
    assert!(checked > 200, "only {checked} paths checked");
}
