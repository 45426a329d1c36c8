use super::*;
use crate::gather::concentric_to_local;
use glam::DVec2;

/// The polynomial arctangent is within its documented error of the library's everywhere on
/// `[−1, 1]`, and exact at 0 and odd.
#[test]
fn polynomial_arctangent_is_within_its_bound() {
    let mut worst = 0.0f64;
    for i in -200_000..=200_000 {
        let t = i as f64 / 200_000.0;
        worst = worst.max((atan_unit(t) - t.atan()).abs());
        assert_eq!(atan_unit(-t), -atan_unit(t));
    }
    assert_eq!(atan_unit(0.0), 0.0);
    assert!(worst < 1.8e-9, "{worst}");
    assert!(worst > 1e-10, "the bound is tight ({worst})");
}

/// The inverse concentric map returns the square point the forward map started from, in all
/// four wedges, on the diagonals and axes, and at the pole.
#[test]
fn inverse_concentric_map_round_trips() {
    let mut worst = 0.0f64;
    for i in 0..=64 {
        for k in 0..=64 {
            let s = DVec2::new(i as f64 / 32.0 - 1.0, k as f64 / 32.0 - 1.0);
            let l = concentric_to_local(s);
            let (a, b) = local_to_square(l.x, l.y);
            worst = worst.max((a - s.x).abs()).max((b - s.y).abs());
        }
    }
    assert!(worst < 2.3e-9, "{worst}");
    assert_eq!(local_to_square(0.0, 0.0), (0.0, 0.0));
}

/// The AVX2 build of the scan gives the portable build's and the scalar locator's verdicts.
#[test]
fn avx2_scan_matches_the_portable_scan_and_the_locator() {
    let frame = Frame::new(DVec3::ZERO, DVec3::new(0.0, 0.6, 0.8), DVec3::X).unwrap();
    for kind in [
        LayoutKind::CosinePolar,
        LayoutKind::Sphere,
        LayoutKind::Concentric,
    ] {
        let layout = Layout::new(kind, 5, 9, 3).unwrap();
        let dirs = layout.directions(&frame).unwrap();
        assert!(directions_ok(&layout, &frame, &dirs));
        assert!(directions_ok_any(&layout, &frame, &dirs));
        for (i, scale) in [(0, 1.0 + 1e-5), (17, -1.0), (44, 1.0 + 1e-7)] {
            let mut d = dirs.clone();
            d[i] *= scale;
            let want = locate_bad_direction(&layout, &frame, &d).is_ok();
            assert_eq!(directions_ok(&layout, &frame, &d), want, "{kind:?} {i}");
            assert_eq!(directions_ok_any(&layout, &frame, &d), want, "{kind:?} {i}");
        }
        // Two neighbours swapped: refused by all three.
        let mut d = dirs.clone();
        d.swap(20, 21);
        assert!(!directions_ok(&layout, &frame, &d), "{kind:?}");
        assert!(!directions_ok_any(&layout, &frame, &d), "{kind:?}");
        assert!(
            locate_bad_direction(&layout, &frame, &d).is_err(),
            "{kind:?}"
        );
    }
}
