use super::*;
use crate::cache::record::Frame;

fn head(seed: u64, isotropic: bool) -> Head {
    let u = |k: u64| {
        let mut z = seed.wrapping_mul(0x9e3779b97f4a7c15).wrapping_add(k);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let q = glam::DQuat::from_axis_angle(
        DVec3::new(u(0) - 0.5, u(1) - 0.5, u(2) - 0.5).normalize(),
        u(3) * 0.6,
    );
    let r = 0.5 + u(4) as f32;
    Head {
        position: [u(5) - 0.5, u(6) - 0.5, u(7) * 0.1],
        rotation: [q.x as f32, q.y as f32, q.z as f32, q.w as f32],
        radii: if isotropic {
            [r; 3]
        } else {
            [r, r * 0.6, r * 0.6]
        },
        ..Head::default()
    }
}

/// The four-lane weights equal the scalar ones bit for bit, for every kernel and domain,
/// including records that do not cover the query and anisotropic ones.
#[test]
fn vector_weights_equal_scalar_weights() {
    let heads: Vec<Head> = (0..64).map(|s| head(s, s % 5 != 3)).collect();
    let channels: Vec<Channel> = vec![Channel::default(); 64];
    let ids: Vec<usize> = (0..heads.len()).collect();
    let n = Frame::from_quaternion(heads[0].rotation).0[2];
    for domain in [Domain::Surface, Domain::Volume] {
        for interpolation in [
            Interpolation::Ward,
            Interpolation::WardClassic,
            Interpolation::WardTabellion,
            Interpolation::Tent,
            Interpolation::Cubic,
            Interpolation::Log,
        ] {
            let kernel = Kernel::new(interpolation, domain, 0.5).unwrap();
            for x in [
                DVec3::ZERO,
                DVec3::new(0.2, -0.1, 0.05),
                DVec3::new(0.9, 0.9, 0.0),
            ] {
                let mut fast = UsedRecords::new();
                weigh(
                    &kernel,
                    x,
                    n,
                    &ids,
                    |i| (&heads[i], &channels[i..i + 1]),
                    &mut fast,
                );
                let slow: Vec<(u64, u64, [u64; 3])> = heads
                    .iter()
                    .map(|h| (h, record_weight(&kernel, h, x, n)))
                    .filter(|(_, (w, _))| *w > 0.0)
                    .map(|(h, (w, nn))| {
                        (
                            h.position[0].to_bits(),
                            w.to_bits(),
                            nn.to_array().map(f64::to_bits),
                        )
                    })
                    .collect();
                let fast: Vec<(u64, u64, [u64; 3])> = fast
                    .iter()
                    .map(|u| {
                        (
                            u.order,
                            u.weight.to_bits(),
                            u.normal.to_array().map(f64::to_bits),
                        )
                    })
                    .collect();
                assert!(
                    !slow.is_empty(),
                    "{domain:?} {interpolation:?} {x}: nothing covered"
                );
                assert_eq!(fast, slow, "{domain:?} {interpolation:?} at {x}");
            }
        }
    }
}
