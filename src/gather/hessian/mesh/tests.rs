use super::*;

#[test]
fn half_edges_sort_as_a_comparison_sort_does() {
    for (kind, m, n) in [
        (LayoutKind::CosinePolar, 1, 6),
        (LayoutKind::CosinePolar, 7, 13),
        (LayoutKind::Concentric, 3, 3),
        (LayoutKind::Concentric, 9, 5),
        (LayoutKind::Sphere, 4, 6),
    ] {
        let topo = Topology::new(kind, m, n).unwrap();
        let mut half = Vec::new();
        for (t, tri) in topo.triangles.iter().enumerate() {
            for i in 0..3 {
                let (a, b) = (tri[i], tri[(i + 1) % 3]);
                half.push((a.min(b), a.max(b), (3 * t + i) as u32, a < b));
            }
        }
        let mut expected = half.clone();
        expected.sort_unstable();
        sort_half_edges(&mut half);
        assert_eq!(half, expected, "{kind:?} {m}x{n}");
    }
    let mut empty = Vec::new();
    sort_half_edges(&mut empty);
    assert!(empty.is_empty());
}

fn check(topo: &Topology, horizon_vertices: usize) {
    let v = topo.vertex_count();
    let t = topo.triangles.len();
    // A disc: V − E + F = 1 (F without the outer face).
    assert_eq!(v as i64 - topo.edges.len() as i64 + t as i64, 1);
    let boundary: Vec<&Edge> = topo.edges.iter().filter(|e| e.right == NONE).collect();
    assert_eq!(boundary.len(), horizon_vertices);
    for e in &boundary {
        assert!(topo.on_horizon[e.a as usize] && topo.on_horizon[e.b as usize]);
    }
    for e in &topo.edges {
        let has = |tri: u32, a: u32, b: u32| {
            let tr = topo.triangles[tri as usize];
            (0..3).any(|i| tr[i] == a && tr[(i + 1) % 3] == b)
        };
        assert!(has(e.left, e.a, e.b));
        if e.right != NONE {
            assert!(has(e.right, e.b, e.a));
        }
    }
    assert_eq!(
        topo.on_horizon.iter().filter(|h| **h).count(),
        horizon_vertices
    );
    for (t, tri) in topo.triangles.iter().enumerate() {
        for i in 0..3 {
            let code = topo.triangle_edges[t][i];
            let e = topo.edges[(code & !REVERSED) as usize];
            let (a, b) = if code & REVERSED != 0 {
                (e.b, e.a)
            } else {
                (e.a, e.b)
            };
            assert_eq!((a, b), (tri[i], tri[(i + 1) % 3]));
        }
    }
}

#[test]
fn polar_mesh_is_a_consistently_oriented_disc() {
    for (m, n) in [(1, 6), (2, 7), (8, 32), (3, 8)] {
        let topo = Topology::new(LayoutKind::CosinePolar, m, n).unwrap();
        assert_eq!(topo.vertex_count(), m * n + n + 1);
        assert_eq!(topo.triangles.len(), n + 2 * m * n);
        check(&topo, n);
    }
}

#[test]
fn concentric_mesh_is_a_consistently_oriented_disc() {
    for (m, n) in [(3, 3), (3, 5), (16, 16), (7, 4)] {
        let topo = Topology::new(LayoutKind::Concentric, m, n).unwrap();
        let perimeter = 2 * (m + n) - 4;
        assert_eq!(topo.vertex_count(), m * n + perimeter);
        check(&topo, perimeter);
    }
}

#[test]
fn sphere_mesh_is_a_closed_consistently_oriented_surface() {
    for (m, n) in [(1, 6), (4, 8), (16, 32)] {
        let topo = Topology::new(LayoutKind::Sphere, m, n).unwrap();
        let v = topo.vertex_count() as i64;
        let t = topo.triangles.len() as i64;
        assert_eq!(v - topo.edges.len() as i64 + t, 2);
        assert!(topo.edges.iter().all(|e| e.right != NONE));
    }
}

#[test]
fn too_small_layouts_are_rejected() {
    assert!(Topology::new(LayoutKind::CosinePolar, 4, 5).is_err());
    assert!(Topology::new(LayoutKind::Sphere, 4, 5).is_err());
    assert!(Topology::new(LayoutKind::Concentric, 2, 8).is_err());
    assert!(Topology::new(LayoutKind::CosinePolar, 0, 8).is_err());
    assert!(Topology::new(LayoutKind::Concentric, 1, 8).is_err());
}
