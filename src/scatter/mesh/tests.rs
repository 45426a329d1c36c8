use super::*;

fn quad() -> (Vec<DVec3>, Vec<DVec3>, Vec<[u32; 3]>) {
    (
        vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ],
        vec![DVec3::Z; 4],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

#[test]
fn bad_meshes_are_rejected_with_a_reason() {
    let (p, n, t) = quad();
    assert!(RefractiveMesh::new(&p, &n, &t).is_ok());
    let err = |p: &[DVec3], n: &[DVec3], t: &[[u32; 3]]| {
        RefractiveMesh::new(p, n, t).unwrap_err().to_string()
    };
    assert!(err(&p, &n, &[]).contains("no triangles"));
    assert!(err(&p, &n, &[[0, 1, 7]]).contains("references vertex 7"));
    assert!(err(&p, &n, &[[0, 1, 1]]).contains("zero area"));
    assert!(err(&p, &n, &[[0, 2, 1]]).contains("faces away"));
    let mut n0 = n.clone();
    n0[2] = DVec3::ZERO;
    assert!(err(&p, &n0, &t).contains("is zero"));
    let mut pn = p.clone();
    pn[1].x = f64::NAN;
    assert!(err(&pn, &n, &t).contains("not finite"));
    assert!(err(&p, &n[..3], &t).contains("normals"));
    assert!(RefractiveMesh::from_flat(&[0.0; 8], &[0.0; 8], &[0, 1, 2])
        .unwrap_err()
        .to_string()
        .contains("3 floats"));
}

#[test]
fn hierarchy_contains_every_triangle_and_finds_the_closest_hit() {
    // A strip of 200 triangles at increasing heights.
    let mut p = Vec::new();
    let mut t = Vec::new();
    for k in 0..100u32 {
        let z = k as f64 * 0.1;
        let b = p.len() as u32;
        p.extend([
            DVec3::new(0.0, 0.0, z),
            DVec3::new(1.0, 0.0, z),
            DVec3::new(1.0, 1.0, z),
            DVec3::new(0.0, 1.0, z),
        ]);
        t.push([b, b + 1, b + 2]);
        t.push([b, b + 2, b + 3]);
    }
    let n = vec![DVec3::Z; p.len()];
    let mesh = RefractiveMesh::new(&p, &n, &t).unwrap();
    let mut seen = mesh.hierarchy().order().to_vec();
    seen.sort();
    assert_eq!(seen, (0..200).collect::<Vec<u32>>());
    for (ni, node) in mesh.hierarchy().nodes().iter().enumerate() {
        if node.count > 0 {
            for &ti in mesh.hierarchy().leaf_triangles(node) {
                for v in mesh.triangle(ti as usize).vertices() {
                    assert!(
                        (v - node.sphere.center).length() <= node.sphere.radius,
                        "{ni}"
                    );
                }
            }
        }
    }
    let hit = mesh
        .closest_hit(DVec3::new(0.3, 0.6, 5.55), DVec3::NEG_Z, 0.0, 100.0)
        .unwrap();
    assert!((hit.t - 0.05).abs() < 1e-12);
    assert!(mesh
        .closest_hit(DVec3::new(3.0, 0.6, 5.55), DVec3::NEG_Z, 0.0, 100.0)
        .is_none());
}
