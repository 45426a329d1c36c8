//! `occlusion_derivatives` against the peer formulation (`hessian_common::peer`: the textbook
//! per-edge closed forms, as Radiance evaluates its Hessian): two derivations of the same mesh
//! sums must agree, on the thesis evaluation scene with structured and with noisy radiance, both
//! layouts, jittered and centred, three sizes, and with the environment black or grey.
//!
//! The bound on the Hessian is loose because the peer's closed forms lose digits where raddiff's
//! do not: on the skirt edges from a near hit to a miss at the far distance (~2.5e6 here), its
//! `I₃`, `J₃`, `K₃` recurrences cancel, and single edges come out up to ~5e-4 wrong relative to
//! `kernels::edge_form_factor` (measured), up to ~1e-4 of the summed Hessian (9e-5 at worst
//! over these cases); values and gradients agree to ~3e-13 and ~6e-12. A sign or formula error in
//! either derivation would be O(1).

mod hessian_common;

use glam::{DMat3, DVec3};
use hessian_common::peer::per_edge_closed_forms;
use hessian_common::{noisy_radiance, scene, SceneGather};
use raddiff::gather::hessian::{
    mesh_geometry, occlusion_derivatives, HemisphereGather, LayoutKind, Topology,
};
use raddiff::Order;

fn norm(m: &DMat3) -> f64 {
    m.to_cols_array().iter().map(|v| v * v).sum::<f64>().sqrt()
}

#[test]
fn batched_hessian_equals_the_per_edge_closed_forms() {
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    for kind in [LayoutKind::CosinePolar, LayoutKind::Concentric] {
        for (m, n) in [(16usize, 64usize), (32, 128), (64, 64)] {
            let (m, n) = if kind == LayoutKind::Concentric {
                (m.min(n), m.min(n))
            } else {
                (m, n)
            };
            for (seed, env) in [(0u64, 0.0f32), (7, 0.5)] {
                for x in [DVec3::new(-0.3, -0.2, 0.0), DVec3::new(0.35, 0.1, 0.0)] {
                    let sg = SceneGather::new(kind, m, n, seed, x, &scene::rects(), env);
                    let structured = sg.gather();
                    let radiance = noisy_radiance(&sg.radiance);
                    let mut shaken = sg.gather();
                    shaken.radiance = &radiance;
                    for g in [&structured, &shaken] {
                        let g: &HemisphereGather = g;
                        let topo = Topology::new(kind, m, n).unwrap();
                        let ours = occlusion_derivatives(&topo, g, Order::Hessian).unwrap();
                        let mesh = mesh_geometry(&topo, g).unwrap();
                        let peer = per_edge_closed_forms(&topo, &mesh, g, 0);
                        let e = ours.irradiance[0];
                        let dv = (peer.irradiance - e).abs() / e;
                        // the gradient and Hessian relative to their own size or, where they
                        // cancel, to the irradiance over the nearest hit distance (~0.25 here)
                        let gs = ours.gradient[0].length().max(e);
                        let dg = (peer.gradient - ours.gradient[0]).length() / gs;
                        let hs = norm(&ours.hessian[0]).max(e);
                        let dh = norm(&(peer.hessian - ours.hessian[0])) / hs;
                        let case = format!("{kind:?} {m}x{n} seed {seed} env {env} x {x}");
                        assert!(dv < 1e-12, "{case}: value {dv:e}");
                        assert!(dg < 1e-10, "{case}: gradient {dg:e}");
                        assert!(dh < 5e-4, "{case}: Hessian {dh:e}");
                        worst = (worst.0.max(dv), worst.1.max(dg), worst.2.max(dh));
                    }
                }
            }
        }
    }
    println!(
        "worst relative differences: value {:.1e}, gradient {:.1e}, Hessian {:.1e}",
        worst.0, worst.1, worst.2
    );
}
