use super::*;

/// Every ISA this machine runs (the portable one always).
pub(crate) fn isas() -> Vec<Isa> {
    #[allow(unused_mut)]
    let mut v = vec![Isa::Portable];
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        v.push(Isa::Avx2);
    }
    #[cfg(all(target_arch = "x86_64", raddiff_avx512))]
    if std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512vl")
        && std::arch::is_x86_feature_detected!("avx512dq")
    {
        v.push(Isa::Avx512);
    }
    v
}

fn max_abs(m: glam::DMat3) -> f64 {
    m.to_cols_array().iter().fold(0.0, |a, b| a.max(b.abs()))
}

#[test]
fn lanes_match_the_kernel_on_every_isa() {
    // Generic lanes, and lanes whose certificate must fail (near the plane, near an edge, at a
    // vertex's scale extremes) and come from the kernel.
    let tri = [
        DVec3::new(0.1, 0.2, 1.0),
        DVec3::new(1.3, -0.1, 1.2),
        DVec3::new(0.4, 1.1, 0.9),
    ];
    let generic: Vec<DVec3> = (0..77)
        .map(|i| {
            let t = i as f64;
            DVec3::new(
                (t * 0.37).sin() * 2.0,
                (t * 0.61).cos() * 2.0,
                -1.0 - (t * 0.23).sin(),
            )
        })
        .collect();
    let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
    let normal = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
    let hard = [
        centroid + normal * 1e-9,
        (tri[0] + tri[1]) * 0.5 + normal * 1e-7,
        centroid * 1e200,
    ];
    let points: Vec<DVec3> = generic.iter().chain(hard.iter()).copied().collect();
    for isa in isas() {
        for order in [Order::Value, Order::Gradient, Order::Hessian] {
            // The certificate: generic lanes pass, hard ones fail.
            let mut lanes = Lanes::new();
            for (i, p) in points.iter().take(BATCH).enumerate() {
                lanes.set(i, *p, tri);
            }
            evaluate_on(isa, &mut lanes, order);
            assert!(lanes.ok.iter().all(|&ok| ok == 1), "{isa:?} {order:?}");
            for (i, p) in hard.iter().enumerate() {
                lanes.set(i, *p, tri);
            }
            evaluate_on(isa, &mut lanes, order);
            assert!(
                lanes.ok[..hard.len()].iter().all(|&ok| ok == 0),
                "{isa:?} {order:?}"
            );

            let mut seen = 0;
            run_on(
                isa,
                points.len(),
                |i| (points[i], tri),
                order,
                "point",
                |i, d| {
                    let [a, b, c] = tri;
                    let r =
                        crate::kernels::triangle_solid_angle(points[i], a, b, c, order).unwrap();
                    assert!(
                        (d.value - r.value).abs() <= 1e-13 * r.value.abs(),
                        "{isa:?} {i}"
                    );
                    let gs = r.gradient.abs().max_element();
                    let dg = (d.gradient - r.gradient).abs().max_element();
                    assert!(dg <= 1e-12 * gs, "{isa:?} {i}: {dg} vs {gs}");
                    let dh = max_abs(d.hessian - r.hessian);
                    assert!(dh <= 1e-12 * max_abs(r.hessian), "{isa:?} {i}: {dh}");
                    assert_eq!(i, seen);
                    seen += 1;
                },
            )
            .unwrap();
            assert_eq!(seen, points.len());
        }
    }
}

#[test]
fn portable_and_vector_paths_agree() {
    // What RADDIFF_SIMD=portable selects, against every vector copy, lane by lane (the FMA
    // contractions are the only difference).
    let mut state = 17u64;
    let mut next = || crate::test_rng::lcg(&mut state) - 0.5;
    let elems: Vec<(DVec3, [DVec3; 3])> = (0..200)
        .map(|_| {
            let x = DVec3::new(next(), next(), next()) * 4.0;
            let y = [0, 1, 2].map(|_| DVec3::new(next(), next(), next() + 2.0));
            (x, y)
        })
        .collect();
    let collect = |isa: Isa| {
        let mut v = Vec::new();
        run_on(
            isa,
            elems.len(),
            |i| elems[i],
            Order::Hessian,
            "e",
            |_, d| v.push(d),
        )
        .unwrap();
        v
    };
    let portable = collect(Isa::Portable);
    for isa in isas().into_iter().skip(1) {
        for (p, q) in portable.iter().zip(collect(isa)) {
            assert!((p.value - q.value).abs() <= 1e-14 * p.value.abs());
            let gs = p.gradient.abs().max_element();
            assert!((p.gradient - q.gradient).abs().max_element() <= 1e-13 * gs);
            assert!(max_abs(p.hessian - q.hessian) <= 1e-13 * max_abs(p.hessian));
        }
    }
}
