use super::super::solid_angle_lanes::tests::isas;
use super::super::{add, form_factor, form_factors, TriangleMesh, VertexData};
use super::*;
use crate::test_rng::Lcg;
use std::cell::Cell;

fn bits(d: &Deriv3) -> Vec<u64> {
    let mut v = vec![d.value.to_bits()];
    v.extend(d.gradient.to_array().map(f64::to_bits));
    v.extend(d.hessian.to_cols_array().map(f64::to_bits));
    v
}

/// Elements at every far-field rule's distance and nearer, some clipped by the receiver's
/// tangent plane, some slivers (thin and very thin), some seen from below their plane.
fn elements() -> Vec<(DVec3, DVec3, [DVec3; 3])> {
    let mut rng = Lcg(11);
    let mut elems = Vec::new();
    for k in 0..3000 {
        // Distance over size: near (edge sum), then each rule's range (3.6e4+, 1.5e3+, 280+,
        // 100+, 16+ radii; the radius is about half the size).
        let ratio = [2.0, 12.0, 20.0, 45.0, 80.0, 300.0, 1e3, 5e3, 2e5][k % 9];
        let size = [0.1, 1e-3, 30.0][(k / 9) % 3];
        let dir = DVec3::new(
            rng.next() - 0.5,
            rng.next() - 0.5,
            if k % 5 == 0 { -1.0 } else { 1.0 },
        );
        let c = dir.normalize() * (ratio * size);
        let mut y = [0, 1, 2].map(|_| c + rng.point(size));
        match k % 23 {
            // A sliver of aspect 1e-3 (thin: the replay declines) and 1e-7 (very thin).
            3 => y[2] = (y[0] + y[1]) * 0.5 + rng.point(size * 1e-3),
            4 => y[2] = (y[0] + y[1]) * 0.5 + rng.point(size * 1e-7),
            _ => {}
        }
        let x = rng.point(0.1 * size);
        // Mostly facing the triangle, sometimes tilted enough to clip it.
        let facing = if k % 7 == 0 { 0.0 } else { 1.0 };
        let n = (dir.normalize() * facing + rng.point(3.0)).normalize();
        elems.push((x, n, y));
    }
    elems
}

#[test]
fn lanes_are_the_single_call_bit_for_bit_on_every_isa() {
    let elems = elements();
    let mut per_rule = [0usize; RULES];
    for (x, n, y) in &elems {
        if let Some((rule, ..)) = classify(*x, *n, *y) {
            per_rule[rule_index(rule)] += 1;
        }
    }
    // Every rule's lanes are exercised, and many elements go to the single kernel.
    let taken: usize = per_rule.iter().sum();
    assert!(per_rule.iter().all(|&c| c >= 50), "{per_rule:?}");
    assert!(taken > 1000 && taken < 2700, "{taken}");
    for isa in isas() {
        for order in [Order::Gradient, Order::Hessian] {
            let single = |i: usize| {
                let (x, n, [a, b, c]) = elems[i];
                crate::kernels::triangle_form_factor(x, n, a, b, c, order)
            };
            let fell_back = Cell::new(0);
            let mut seen = 0;
            run_on(
                isa,
                elems.len(),
                |i| {
                    let (x, n, y) = elems[i];
                    (x, n, form_factor_lanes::lane_normal(n), y)
                },
                order,
                |i| {
                    fell_back.set(fell_back.get() + 1);
                    single(i)
                },
                |i, d| {
                    assert_eq!(i, seen);
                    seen += 1;
                    let reference = single(i).unwrap();
                    assert_eq!(bits(&d), bits(&reference), "{isa:?} {order:?} element {i}");
                },
            )
            .unwrap();
            assert_eq!(seen, elems.len());
            // Only the declined elements (and none of the taken ones) called the kernel.
            assert_eq!(fell_back.get(), elems.len() - taken, "{isa:?} {order:?}");
        }
    }
}

/// A mesh light like the benchmark's (f32, 1024 triangles ~0.1 in size 1-2 above the
/// receiver), every third one flipped, stored with a vertex stride of 4 floats; the same in
/// f64, packed; and the same lifted far away.
#[test]
fn meshes_near_and_far_f32_strided_and_f64_sums_and_each_are_bit_for_bit() {
    let mut rng = Lcg(1);
    let count = 1024;
    let mut v32 = Vec::new();
    let mut ix = Vec::new();
    for t in 0..count as u32 {
        let c = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, 1.0 + rng.next());
        for _ in 0..3 {
            let p = c + rng.point(0.1);
            v32.extend([p.x as f32, p.y as f32, p.z as f32, f32::NAN]);
        }
        let o = if t % 3 == 0 { [0, 2, 1] } else { [0, 1, 2] };
        ix.extend(o.map(|k| 3 * t + k));
    }
    let strided =
        TriangleMesh::new(VertexData::F32(&v32), 4, 3 * count, Some(&ix), 3, count).unwrap();
    // Lifted by 5 to 2000 (rules of 6 down to 3 points).
    let far: Vec<f64> = v32
        .chunks(4)
        .enumerate()
        .flat_map(|(i, p)| {
            let lift = [0.0, 5.0, 20.0, 2e3][(i / 3) % 4];
            [p[0] as f64, p[1] as f64, p[2] as f64 + lift]
        })
        .collect();
    let near: Vec<f64> = v32
        .chunks(4)
        .flat_map(|p| [p[0] as f64, p[1] as f64, p[2] as f64])
        .collect();
    let packed_near =
        TriangleMesh::new(VertexData::F64(&near), 3, 3 * count, Some(&ix), 3, count).unwrap();
    let packed_far =
        TriangleMesh::new(VertexData::F64(&far), 3, 3 * count, Some(&ix), 3, count).unwrap();
    let x = DVec3::new(0.05, -0.03, 0.0);
    let n = DVec3::new(0.1, 0.0, 1.0).normalize();
    for mesh in [&strided, &packed_near, &packed_far] {
        let taken = (0..count)
            .filter(|&t| classify(x, n, mesh.triangle(t)).is_some())
            .count();
        assert!(taken > count / 2, "{taken}");
        for isa in isas() {
            for order in [Order::Gradient, Order::Hessian] {
                let single = |t: usize| form_factor(x, n, mesh.triangle(t), order, "t", t);
                let mut reference = Deriv3::constant(0.0);
                let mut sum = Deriv3::constant(0.0);
                form_factors(
                    isa,
                    count,
                    |t| (x, n, form_factor_lanes::lane_normal(n), mesh.triangle(t)),
                    order,
                    "t",
                    |t, d| {
                        let r = single(t).unwrap();
                        assert_eq!(bits(&d), bits(&r), "{isa:?} {order:?} {t}");
                        add(&mut reference, &r, order);
                        add(&mut sum, &d, order);
                    },
                )
                .unwrap();
                assert_eq!(bits(&sum), bits(&reference), "{isa:?} {order:?}");
            }
        }
    }
}

/// The benchmark's mesh light (`benches/kernels_batch.rs`, same generator): which path each
/// triangle's single call takes for its derivatives (the figures docs/kernels.md quotes).
#[test]
fn benchmark_mesh_paths() {
    let mut rng = Lcg(1);
    let x = DVec3::new(0.05, -0.03, 0.0);
    let mut per_rule = [0usize; RULES];
    let (mut thin, mut near) = (0, 0);
    for _ in 0..1024 {
        let (cx, cy, cz) = (rng.next() - 0.5, rng.next() - 0.5, 1.0 + rng.next());
        let y = [0, 1, 2].map(|_| {
            let d = [rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5];
            DVec3::new(
                (cx + 0.1 * d[0]) as f32 as f64,
                (cy + 0.1 * d[1]) as f32 as f64,
                (cz + 0.1 * d[2]) as f32 as f64,
            )
        });
        match classify(x, DVec3::Z, y) {
            Some((rule, ..)) => per_rule[rule_index(rule)] += 1,
            None if is_very_thin_triangle(y)
                || fast_setup(x, DVec3::Z, y, triangle_plane)
                    .is_some_and(|s| s.plane.is_thin()) =>
            {
                thin += 1
            }
            // Nearer than 16 radii (the edge sum).
            None => near += 1,
        }
    }
    println!("bench mesh: rules [3, 4, 5, 6, 8] points {per_rule:?}, slivers {thin}, near {near}");
    assert_eq!((per_rule, thin, near), ([0, 0, 0, 5, 1013], 0, 6));
}
