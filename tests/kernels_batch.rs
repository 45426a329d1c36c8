//! The batch kernels against the single-element calls they stand for: random meshes in every
//! regime the lanes' certificate must handle (generic, far field, near a triangle's plane, near
//! edges and vertices, slivers, triangles straddling the tangent plane), sums against the sums of
//! the single calls, closed-surface identities, the zero-area policy and the validation errors.

use raddiff::glam::DVec3;
use raddiff::{kernels, Deriv3, Error, Order};

/// A small deterministic generator (the tests must not depend on a platform RNG).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.range(-1., 1.),
                self.range(-1., 1.),
                self.range(-1., 1.),
            );
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

fn max_abs(m: raddiff::glam::DMat3) -> f64 {
    m.to_cols_array().iter().fold(0.0, |a, b| a.max(b.abs()))
}

/// The largest error of `d` against `r`, each part relative to its largest entry (the accuracy
/// tests' normalization).
fn rel_err(d: &Deriv3, r: &Deriv3) -> f64 {
    let v = (d.value - r.value).abs() / r.value.abs().max(1e-300);
    let g =
        (d.gradient - r.gradient).abs().max_element() / r.gradient.abs().max_element().max(1e-300);
    let h = max_abs(d.hessian - r.hessian) / max_abs(r.hessian).max(1e-300);
    v.max(g).max(h)
}

/// A random mesh of `count` triangles: vertices in a ball of radius `size` around the origin, a
/// fifth of the triangles slivers (a vertex 1e-6 of the size from the opposite edge).
fn random_mesh(rng: &mut Lcg, count: usize, size: f64) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    let mut ix = Vec::new();
    for t in 0..count {
        let a = rng.unit() * size * rng.next().cbrt();
        let b = rng.unit() * size * rng.next().cbrt();
        let c = if t % 5 == 0 {
            a + (b - a) * rng.range(0.1, 0.9) + rng.unit() * size * 1e-6
        } else {
            rng.unit() * size * rng.next().cbrt()
        };
        let base = v.len() as u32;
        v.extend([a, b, c]);
        ix.push([base, base + 1, base + 2]);
    }
    (v, ix)
}

/// Points around a mesh in the regimes of the certificate: generic, far, near a triangle's
/// plane (inside and outside it), near an edge, near a vertex.
fn probe_points(rng: &mut Lcg, v: &[DVec3], ix: &[[u32; 3]], size: f64) -> Vec<DVec3> {
    let mut pts = Vec::new();
    for _ in 0..4 {
        pts.push(rng.unit() * size * rng.range(1.5, 3.0));
        pts.push(rng.unit() * size * rng.range(1e3, 1e6));
    }
    for k in 0..6 {
        let t = ix[(k * 7) % ix.len()].map(|i| v[i as usize]);
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        let inside = (t[0] + t[1] + t[2]) / 3.0;
        let outside = t[0] + (t[0] - inside) * 0.7;
        let off = size * 10f64.powf(rng.range(-12.0, -6.0));
        pts.push(inside + n * off);
        pts.push(outside - n * off);
        pts.push(t[0] + (t[1] - t[0]) * 0.3 + rng.unit() * size * 1e-7);
        pts.push(t[2] + rng.unit() * size * 1e-6);
    }
    pts
}

const ORDERS: [Order; 3] = [Order::Value, Order::Gradient, Order::Hessian];

#[test]
fn mesh_solid_angles_match_the_single_calls_in_every_regime() {
    let mut rng = Lcg(7);
    let mut worst = 0.0f64;
    let mut compared = 0;
    for &size in &[1e-3, 1.0, 1e4] {
        let (v, ix) = random_mesh(&mut rng, 60, size);
        let mesh = kernels::TriangleMesh::indexed(&v, &ix).unwrap();
        for x in probe_points(&mut rng, &v, &ix, size) {
            for order in ORDERS {
                let mut each = vec![Deriv3::default(); mesh.len()];
                let got_each = kernels::mesh_solid_angle_each(x, &mesh, order, &mut each);
                let got_sum = kernels::mesh_solid_angle(x, &mesh, order);
                let mut refs = Vec::new();
                let mut failed = None;
                for t in 0..mesh.len() {
                    let [a, b, c] = mesh.triangle(t);
                    match kernels::triangle_solid_angle(x, a, b, c, order) {
                        Ok(r) => refs.push(r),
                        Err(e) => {
                            failed = Some((t, e));
                            break;
                        }
                    }
                }
                if let Some((t, e)) = failed {
                    // The batch fails too, naming the same triangle with the same kind of error.
                    let err = got_each.unwrap_err();
                    assert!(err.to_string().contains(&format!("triangle {t}:")), "{err}");
                    assert_eq!(std::mem::discriminant(&err), std::mem::discriminant(&e));
                    assert!(got_sum.is_err());
                    continue;
                }
                got_each.unwrap();
                let sum = got_sum.unwrap();
                let (mut total, mut abs_v, mut abs_g, mut abs_h) =
                    (Deriv3::default(), 0.0, 0.0, 0.0);
                for (d, r) in each.iter().zip(&refs) {
                    let e = rel_err(d, r);
                    assert!(
                        e <= 1e-12,
                        "x={x} size={size} {order:?}: {e:e}\n{d:?}\n{r:?}"
                    );
                    worst = worst.max(e);
                    compared += 1;
                    total.value += r.value;
                    total.gradient += r.gradient;
                    total.hessian += r.hessian;
                    abs_v += r.value.abs();
                    abs_g += r.gradient.abs().max_element();
                    abs_h += max_abs(r.hessian);
                }
                // The sum against the sum of the single calls, relative to the sum of magnitudes.
                assert!((sum.value - total.value).abs() <= 1e-12 * abs_v);
                assert!((sum.gradient - total.gradient).abs().max_element() <= 1e-12 * abs_g);
                assert!(max_abs(sum.hessian - total.hessian) <= 1e-12 * abs_h.max(1e-300));
            }
        }
    }
    assert!(compared > 10_000, "{compared}");
    println!("mesh solid angles: {compared} triangles compared, worst relative error {worst:e}");
}

#[test]
fn mesh_form_factors_match_the_single_calls_with_clipping() {
    let mut rng = Lcg(11);
    let mut compared = 0;
    let (v, ix) = random_mesh(&mut rng, 40, 1.0);
    let mesh = kernels::TriangleMesh::indexed(&v, &ix).unwrap();
    for x in probe_points(&mut rng, &v, &ix, 1.0) {
        // Normals through the mesh: many triangles straddle the tangent plane.
        let n = rng.unit();
        for order in ORDERS {
            let mut each = vec![Deriv3::default(); mesh.len()];
            let Ok(()) = kernels::mesh_form_factor_each(x, n, &mesh, order, &mut each) else {
                continue;
            };
            let sum = kernels::mesh_form_factor(x, n, &mesh, order).unwrap();
            let mut total = Deriv3::default();
            for (t, d) in each.iter().enumerate() {
                let [a, b, c] = mesh.triangle(t);
                let r = kernels::triangle_form_factor(x, n, a, b, c, order).unwrap();
                assert!(rel_err(d, &r) <= 1e-12, "x={x} {order:?} triangle {t}");
                total.value += r.value;
                total.gradient += r.gradient;
                total.hessian += r.hessian;
                compared += 1;
            }
            assert!((sum.value - total.value).abs() <= 1e-14 * total.value.abs().max(1e-300));
            assert!(
                (sum.gradient - total.gradient).abs().max_element()
                    <= 1e-14 * total.gradient.abs().max_element()
            );
        }
    }
    assert!(compared > 1000, "{compared}");
}

#[test]
fn many_points_against_one_triangle_match_the_single_calls() {
    let mut rng = Lcg(3);
    let tri = [
        DVec3::new(0.1, 0.2, 1.0),
        DVec3::new(1.3, -0.1, 1.2),
        DVec3::new(0.4, 1.1, 0.9),
    ];
    let ix = [[0u32, 1, 2]];
    let mut points = probe_points(&mut rng, &tri, &ix, 1.0);
    points.retain(|p| {
        kernels::triangle_solid_angle(*p, tri[0], tri[1], tri[2], Order::Hessian).is_ok()
    });
    let normals: Vec<DVec3> = points.iter().map(|_| rng.unit()).collect();
    for order in ORDERS {
        let mut out = vec![Deriv3::default(); points.len()];
        kernels::points_solid_angle(&points, tri[0], tri[1], tri[2], order, &mut out).unwrap();
        for (p, d) in points.iter().zip(&out) {
            let r = kernels::triangle_solid_angle(*p, tri[0], tri[1], tri[2], order).unwrap();
            assert!(rel_err(d, &r) <= 1e-12, "x={p} {order:?}");
        }
        let keep: Vec<usize> = (0..points.len())
            .filter(|&i| {
                kernels::triangle_form_factor(points[i], normals[i], tri[0], tri[1], tri[2], order)
                    .is_ok()
            })
            .collect();
        let (p, n): (Vec<DVec3>, Vec<DVec3>) =
            keep.iter().map(|&i| (points[i], normals[i])).unzip();
        let mut out = vec![Deriv3::default(); p.len()];
        kernels::points_form_factor(&p, &n, tri[0], tri[1], tri[2], order, &mut out).unwrap();
        for i in 0..p.len() {
            let r =
                kernels::triangle_form_factor(p[i], n[i], tri[0], tri[1], tri[2], order).unwrap();
            assert!(rel_err(&out[i], &r) <= 1e-12);
        }
    }
}

#[test]
fn f32_strided_and_soup_layouts_give_the_f64_results() {
    let mut rng = Lcg(5);
    let vf: Vec<[f32; 3]> = (0..30)
        .map(|_| (rng.unit() * 2.0).as_vec3().to_array())
        .collect();
    let vd: Vec<DVec3> = vf
        .iter()
        .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect();
    let ix: Vec<[u32; 3]> = (0..25)
        .map(|t| [t, (t * 7 + 1) % 30, (t * 13 + 2) % 30])
        .collect();
    let soup: Vec<[DVec3; 3]> = ix.iter().map(|t| t.map(|i| vd[i as usize])).collect();
    // float4 vertices with garbage in w, uint4 index rows.
    let padded: Vec<f32> = vf
        .iter()
        .flat_map(|p| [p[0], p[1], p[2], f32::NAN])
        .collect();
    let padded_ix: Vec<u32> = ix.iter().flat_map(|t| [t[0], t[1], t[2], 999]).collect();
    let meshes = [
        kernels::TriangleMesh::indexed_f32(&vf, &ix).unwrap(),
        kernels::TriangleMesh::indexed(&vd, &ix).unwrap(),
        kernels::TriangleMesh::soup(&soup).unwrap(),
        kernels::TriangleMesh::new(
            kernels::VertexData::F32(&padded),
            4,
            30,
            Some(&padded_ix),
            4,
            25,
        )
        .unwrap(),
    ];
    let x = DVec3::new(3.0, -2.5, 0.7);
    let n = DVec3::new(-0.6, 0.8, 0.0);
    let sa: Vec<Deriv3> = meshes
        .iter()
        .map(|m| kernels::mesh_solid_angle(x, m, Order::Hessian).unwrap())
        .collect();
    let ff: Vec<Deriv3> = meshes
        .iter()
        .map(|m| kernels::mesh_form_factor(x, n, m, Order::Hessian).unwrap())
        .collect();
    for k in 1..meshes.len() {
        assert_eq!(sa[k], sa[0]);
        assert_eq!(ff[k], ff[0]);
    }
    assert!(sa[0].value > 0.0 && ff[0].value > 0.0);
}

/// An octahedron around the origin (outward faces).
fn octahedron() -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let v = vec![
        DVec3::X,
        DVec3::Y,
        DVec3::Z,
        -DVec3::X,
        -DVec3::Y,
        -DVec3::Z,
    ];
    let ix = vec![
        [0, 1, 2],
        [1, 3, 2],
        [3, 4, 2],
        [4, 0, 2],
        [1, 0, 5],
        [3, 1, 5],
        [4, 3, 5],
        [0, 4, 5],
    ];
    (v, ix)
}

#[test]
fn closed_surfaces_cover_the_sphere_and_the_hemisphere() {
    let (v, ix) = octahedron();
    let mesh = kernels::TriangleMesh::indexed(&v, &ix).unwrap();
    let mut rng = Lcg(9);
    for _ in 0..20 {
        let x = rng.unit() * 0.4;
        let n = rng.unit();
        let sa = kernels::mesh_solid_angle(x, &mesh, Order::Hessian).unwrap();
        assert!((sa.value - 4.0 * std::f64::consts::PI).abs() < 1e-13);
        assert!(sa.gradient.abs().max_element() < 1e-12);
        assert!(max_abs(sa.hessian) < 1e-11);
        let ff = kernels::mesh_form_factor(x, n, &mesh, Order::Hessian).unwrap();
        assert!((ff.value - 1.0).abs() < 1e-12, "{}", ff.value);
        assert!(ff.gradient.abs().max_element() < 1e-11);
        assert!(max_abs(ff.hessian) < 1e-10);
    }
}

#[test]
fn zero_area_triangles_contribute_nothing_to_form_factors() {
    let (mut v, mut ix) = octahedron();
    // A collinear triangle, which the single form factor call rejects.
    v.push(DVec3::new(2.0, 0.0, 0.5));
    v.push(DVec3::new(3.0, 0.0, 0.5));
    v.push(DVec3::new(4.0, 0.0, 0.5));
    ix.push([6, 7, 8]);
    let x = DVec3::new(0.1, 0.2, -0.1);
    let n = DVec3::Z;
    let single = kernels::triangle_form_factor(x, n, v[6], v[7], v[8], Order::Value);
    assert!(matches!(single, Err(Error::Degenerate(_))));
    let mesh = kernels::TriangleMesh::indexed(&v, &ix).unwrap();
    let mut each = vec![Deriv3::constant(5.0); mesh.len()];
    kernels::mesh_form_factor_each(x, n, &mesh, Order::Hessian, &mut each).unwrap();
    assert_eq!(each[8], Deriv3::constant(0.0));
    let sum = kernels::mesh_form_factor(x, n, &mesh, Order::Value).unwrap();
    assert!((sum.value - 1.0).abs() < 1e-12);
    // The solid angle kernel returns 0 for it itself.
    let sa = kernels::triangle_solid_angle(x, v[6], v[7], v[8], Order::Hessian).unwrap();
    assert_eq!(sa, Deriv3::constant(0.0));
}

#[test]
fn validation_errors_name_the_first_bad_element() {
    let (v, ix) = octahedron();
    let mesh = kernels::TriangleMesh::indexed(&v, &ix).unwrap();
    let x = DVec3::new(0.1, 0.2, 0.3);
    let msg = |r: raddiff::Result<()>| r.unwrap_err().to_string();

    let mut short = vec![Deriv3::default(); 7];
    let m = msg(kernels::mesh_solid_angle_each(
        x,
        &mesh,
        Order::Value,
        &mut short,
    ));
    assert!(
        m.contains("out holds 7 elements, expected one per triangle (8)"),
        "{m}"
    );
    let m =
        msg(kernels::mesh_form_factor(x, DVec3::new(0., 0., 2.), &mesh, Order::Value).map(|_| ()));
    assert!(m.contains("unit vector"), "{m}");
    let m = msg(
        kernels::mesh_solid_angle(DVec3::new(f64::NAN, 0., 0.), &mesh, Order::Value).map(|_| ()),
    );
    assert!(m.contains("x is not finite"), "{m}");

    let points = [x, DVec3::new(0.0, f64::INFINITY, 0.0)];
    let mut out = vec![Deriv3::default(); 2];
    let m = msg(kernels::points_solid_angle(
        &points,
        v[0],
        v[1],
        v[2],
        Order::Value,
        &mut out,
    ));
    assert!(m.contains("point 1 is not finite"), "{m}");
    let normals = [DVec3::Z, DVec3::new(0.0, 0.1, 0.0)];
    let points = [x, x * 2.0];
    let m = msg(kernels::points_form_factor(
        &points,
        &normals,
        v[0],
        v[1],
        v[2],
        Order::Value,
        &mut out,
    ));
    assert!(m.contains("normal 1:"), "{m}");
    // x at a vertex: the kernel's Degenerate, labelled with the triangle.
    let m = msg(kernels::mesh_solid_angle(v[4], &mesh, Order::Value).map(|_| ()));
    assert!(
        m.starts_with("degenerate configuration: triangle 2:"),
        "{m}"
    );
}

/// A mesh light as renderers hold it: `count` triangles of about `size` scattered over a slab at
/// distance 1..2 above the origin, in f32 with float4 rows (w garbage) and uint4 index rows.
fn light_f32(rng: &mut Lcg, count: usize, size: f64) -> (Vec<f32>, Vec<u32>) {
    let (mut v, mut ix) = (Vec::new(), Vec::new());
    for t in 0..count as u32 {
        let c = DVec3::new(
            rng.range(-0.5, 0.5),
            rng.range(-0.5, 0.5),
            rng.range(1.0, 2.0),
        );
        for _ in 0..3 {
            let p = c + rng.unit() * size * rng.next();
            v.extend([p.x as f32, p.y as f32, p.z as f32, f32::NAN]);
        }
        ix.extend([3 * t, 3 * t + 1, 3 * t + 2, 7]);
    }
    (v, ix)
}

#[test]
fn form_factor_values_in_lanes_are_the_single_calls_bit_for_bit() {
    // The value path runs in SIMD lanes (far form of Lambert's sum, certified per lane; the rest by
    // the single kernel). Accepted lanes replay the single kernel's operations in order without FMA,
    // so every value must equal the single call exactly, sums included (same order of addition):
    // near lights (size 0.3: Lambert's sum), far ones (size 1e-2 and 1e-4: the far form), receivers
    // with tilted normals (clipped triangles), f32 strided and f64 indexed layouts, and batch
    // lengths that are not multiples of the lane count.
    let mut rng = Lcg(21);
    let mut compared = 0;
    for (size, count) in [(0.3, 37), (0.1, 200), (1e-2, 65), (1e-4, 33)] {
        let (vf, ixf) = light_f32(&mut rng, count, size);
        let f32_mesh = kernels::TriangleMesh::new(
            kernels::VertexData::F32(&vf),
            4,
            3 * count,
            Some(&ixf),
            4,
            count,
        )
        .unwrap();
        let vd: Vec<DVec3> = vf
            .chunks(4)
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect();
        let ixd: Vec<[u32; 3]> = ixf.chunks(4).map(|t| [t[0], t[1], t[2]]).collect();
        let f64_mesh = kernels::TriangleMesh::indexed(&vd, &ixd).unwrap();
        for _ in 0..6 {
            let x = DVec3::new(
                rng.range(-0.3, 0.3),
                rng.range(-0.3, 0.3),
                rng.range(-0.2, 0.2),
            );
            let n = (DVec3::Z + rng.unit() * rng.range(0.0, 1.2)).normalize();
            for mesh in [&f32_mesh, &f64_mesh] {
                let mut each = vec![Deriv3::default(); mesh.len()];
                kernels::mesh_form_factor_each(x, n, mesh, Order::Value, &mut each).unwrap();
                let sum = kernels::mesh_form_factor(x, n, mesh, Order::Value).unwrap();
                let mut total = 0.0;
                for (t, d) in each.iter().enumerate() {
                    let [a, b, c] = mesh.triangle(t);
                    let r = kernels::triangle_form_factor(x, n, a, b, c, Order::Value).unwrap();
                    assert_eq!(
                        d.value.to_bits(),
                        r.value.to_bits(),
                        "x={x} n={n} triangle {t}"
                    );
                    assert_eq!(d.gradient, DVec3::ZERO);
                    total += r.value;
                    compared += 1;
                }
                assert_eq!(sum.value.to_bits(), total.to_bits(), "x={x} n={n}");
            }
            // Many receivers against one triangle of the light.
            let [a, b, c] = f64_mesh.triangle(0);
            let points: Vec<DVec3> = (0..45)
                .map(|_| x + rng.unit() * rng.range(0.0, 0.2))
                .collect();
            let normals: Vec<DVec3> = (0..45)
                .map(|_| (DVec3::Z + rng.unit() * rng.range(0.0, 1.2)).normalize())
                .collect();
            let mut out = vec![Deriv3::default(); points.len()];
            kernels::points_form_factor(&points, &normals, a, b, c, Order::Value, &mut out)
                .unwrap();
            for i in 0..points.len() {
                let r = kernels::triangle_form_factor(points[i], normals[i], a, b, c, Order::Value)
                    .unwrap();
                assert_eq!(out[i].value.to_bits(), r.value.to_bits(), "point {i}");
                compared += 1;
            }
        }
    }
    assert!(compared > 4000, "{compared}");
}

#[test]
fn form_factor_lanes_match_the_single_call_on_very_thin_slivers() {
    // Very thin slivers (2·area below 1e-5 of the extent squared) have their own route in the
    // single kernel; a lane that accepts one must still return the single call's bits.
    let mut rng = Lcg(77);
    let mut compared = 0;
    for (size, apex) in [(1e-2, 1e-7), (1e-3, 1e-9), (0.2, 1e-8)] {
        let tris: Vec<[DVec3; 3]> = (0..40)
            .map(|_| {
                let a = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 1.0);
                let along = rng.unit().cross(DVec3::Z).normalize() * size;
                let across = along.cross(rng.unit()).normalize() * (apex * size);
                [a, a + along, a + 0.5 * along + across]
            })
            .collect();
        let verts: Vec<DVec3> = tris.iter().flatten().copied().collect();
        let idx: Vec<[u32; 3]> = (0..tris.len() as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect();
        let mesh = kernels::TriangleMesh::indexed(&verts, &idx).unwrap();
        for _ in 0..4 {
            let x = DVec3::new(
                rng.range(-0.3, 0.3),
                rng.range(-0.3, 0.3),
                rng.range(-0.2, 0.2),
            );
            let n = (DVec3::Z + rng.unit() * rng.range(0.0, 0.5)).normalize();
            let mut each = vec![Deriv3::default(); mesh.len()];
            kernels::mesh_form_factor_each(x, n, &mesh, Order::Value, &mut each).unwrap();
            for (t, d) in each.iter().enumerate() {
                let [a, b, c] = mesh.triangle(t);
                let single = kernels::triangle_form_factor(x, n, a, b, c, Order::Value);
                let hessian = kernels::triangle_form_factor(x, n, a, b, c, Order::Hessian);
                if let (Ok(r), Ok(h)) = (single, hessian) {
                    assert_eq!(d.value.to_bits(), r.value.to_bits(), "x={x} n={n} {t}");
                    assert_eq!(h.value.to_bits(), r.value.to_bits(), "order, x={x} {t}");
                    compared += 1;
                }
            }
        }
    }
    assert!(compared >= 400, "{compared}");
}
