//! Property tests of the record radii: invariance under rotation, the anisotropy clamp, ordering,
//! and the exact integrated-error bound for random Hessians.

use glam::{DMat3, DQuat, DVec3};
use proptest::prelude::*;
use raddiff::gather::radii::{
    ellipsoid_error_bound, surface_radii, tangent_hessian, volume_radii, ErrorMode,
};

fn symmetric(a: [f64; 6]) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(a[0], a[1], a[2]),
        DVec3::new(a[1], a[3], a[4]),
        DVec3::new(a[2], a[4], a[5]),
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn volume_radii_are_rotation_invariant_and_attain_the_bound(
        a in prop::array::uniform6(-10.0f64..10.0),
        axis in prop::array::uniform3(-1.0f64..1.0),
        angle in 0.0f64..6.0,
        aniso in 1.0f64..20.0,
    ) {
        let h = symmetric(a);
        let axis = DVec3::from(axis);
        prop_assume!(axis.length() > 0.1);
        let q = DQuat::from_axis_angle(axis.normalize(), angle);
        let r = DMat3::from_quat(q);
        let v = volume_radii(h, 1.0, 0.01, ErrorMode::Relative, aniso).unwrap();
        let w = volume_radii(r * h * r.transpose(), 1.0, 0.01, ErrorMode::Relative, aniso).unwrap();
        for i in 0..3 {
            prop_assert!((v.radii[i] - w.radii[i]).abs() <= 1e-9 * v.radii[i]);
        }
        prop_assert!(v.radii[0] <= v.radii[1] && v.radii[1] <= v.radii[2]);
        prop_assert!(v.radii[2] <= aniso * v.radii[0] * (1.0 + 1e-12));
        // The bound along the returned axes equals the tolerance (unless the radius was capped).
        let eig = v.axes.map(|ax| ax.dot(h * ax));
        let b = ellipsoid_error_bound(eig, v.radii);
        prop_assert!((b / 0.01 - 1.0).abs() < 1e-8, "bound {}", b);
    }

    #[test]
    fn surface_radii_follow_the_tangent_plane(
        a in prop::array::uniform6(-10.0f64..10.0),
        n in prop::array::uniform3(-1.0f64..1.0),
        extra in -50.0f64..50.0,
    ) {
        let n = DVec3::from(n);
        prop_assume!(n.length() > 0.1);
        let n = n.normalize();
        let h = symmetric(a);
        // Curvature along the normal does not change a surface record.
        let nn = DMat3::from_cols(n * n.x, n * n.y, n * n.z);
        let s = surface_radii(h, n, 1.0, 0.01, ErrorMode::Absolute, 2.0).unwrap();
        let t = surface_radii(h + nn * extra, n, 1.0, 0.01, ErrorMode::Absolute, 2.0).unwrap();
        for i in 0..2 {
            prop_assert!((s.radii[i] - t.radii[i]).abs() <= 1e-8 * s.radii[i]);
            prop_assert!(s.axes[i].dot(n).abs() < 1e-12);
        }
        // The axes diagonalize the tangent Hessian.
        let th = tangent_hessian(h, s.axes[0], s.axes[1]);
        prop_assert!(th.y_axis.x.abs() <= 1e-9 * (1.0 + th.x_axis.x.abs() + th.y_axis.y.abs()));
        prop_assert!(th.x_axis.x.abs() >= th.y_axis.y.abs() * (1.0 - 1e-9));
    }
}
