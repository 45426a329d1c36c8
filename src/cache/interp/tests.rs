use super::super::blend;
use super::*;

/// The dispatched blends (AVX and F16C where the CPU has them; from the lanes of a `Covering`
/// and gathered from `Used` entries) equal the portable one bit for bit, over random binary16
/// components (normal, subnormal, zero, ±1), value bits that read as NaN or infinite halves,
/// every group size (1-6 records: full and partial lane groups), gradient scales large
/// enough to saturate the offsets, and with and without the non-negative floor (then no
/// output is negative, though values and extrapolations are).
#[test]
fn vector_blend_equals_portable_blend() {
    let mut state = 0x1234_5678_9abc_def0u64;
    let mut next = || (crate::test_rng::step(&mut state) >> 33) as u32;
    let half = |r: u32| -> u16 {
        match r % 5 {
            0 => 0x3c00 | ((r >> 8) as u16 & 0x8000), // ±1
            1 => (r >> 4) as u16 & 0x83ff,            // subnormal
            2 => 0,
            _ => ((r >> 4) as u16 & 0x83ff) | (((r >> 16) % 15) as u16) << 10,
        }
    };
    let mut negative_seen = false;
    for round in 0..400 {
        let surface = round % 4 != 3;
        let records = 1 + round % 6;
        let huge = round % 7 == 0; // offsets past Q_MAX: saturated, still finite
        let heads: Vec<Head> = (0..records)
            .map(|k| Head {
                position: [k as f64 * 0.1, -0.05 * k as f64, 0.01],
                rotation: [0.0, 0.0, 0.0, 1.0],
                radii: [1.0; 3],
                gradient_scale: (next() % 1000) as f32 * if huge { 1e36 } else { 0.01 },
                rotation_scale: (next() % 1000) as f32 * if huge { 1e36 } else { 0.001 },
                open_fraction: 0,
            })
            .collect();
        let channels: Vec<Channel> = (0..records * 5)
            .map(|_| Channel {
                value: if round % 3 == 0 {
                    f32::from_bits(0x7c00_7e00 | next() & 0x0001_0001)
                } else {
                    (next() % 1000) as f32 * 0.01 - 2.0
                },
                gradient: [half(next()), half(next()), half(next())],
                rotation: [half(next()), half(next()), half(next())],
            })
            .collect();
        let used: Vec<Used> = heads
            .iter()
            .enumerate()
            .map(|(k, h)| Used {
                order: k as u64,
                weight: 0.5 + k as f64,
                normal: DVec3::new(0.1 * k as f64, 0.2, 1.0).normalize(),
                head: h,
                channels: &channels[k * 5..k * 5 + 5],
            })
            .collect();
        let x = DVec3::new(0.3, 0.2, 0.0);
        let n = DVec3::new(0.05, -0.1, 1.0).normalize();
        let covering = blend::Covering::from_used(&used, 5);
        let sum: f64 = used.iter().map(|u| u.weight).sum();
        assert_eq!(sum.to_bits(), covering.weight_sum().to_bits());
        let floor = if round % 2 == 0 {
            0.0
        } else {
            f64::NEG_INFINITY
        };
        let (mut lanes, mut gathered, mut portable) = ([0.0f32; 5], [0.0f32; 5], [0.0f32; 5]);
        blend::blend_linear(surface, &covering, x, n, floor, &mut lanes);
        blend::blend_linear_used(surface, &used, sum, x, n, floor, &mut gathered);
        blend::blend_portable(surface, &covering, x, n, floor, &mut portable);
        let bits = |v: [f32; 5]| v.map(f32::to_bits);
        assert_eq!(bits(lanes), bits(portable), "round {round}");
        assert_eq!(bits(gathered), bits(portable), "round {round}");
        assert!(lanes.iter().all(|v| v.is_finite()));
        if floor == 0.0 {
            assert!(lanes.iter().all(|&v| v >= 0.0), "round {round}: {lanes:?}");
        } else {
            negative_seen |= lanes.iter().any(|&v| v < 0.0);
        }
    }
    assert!(
        negative_seen,
        "the unclamped rounds must produce negative blends"
    );
}
