//! Checks of the demo's ray casting (`examples/demo/`): the BVH against brute force, and no light
//! leaks: gather rays from what the camera sees in the closed room leave only through the window.

#![allow(dead_code)]

#[path = "../examples/demo/bvh.rs"]
mod bvh;
#[path = "../examples/demo/geometry.rs"]
mod geometry;
#[path = "../examples/demo/scene.rs"]
mod scene;

use glam::DVec3;

use crate::geometry::{Ray, Rng};
use crate::scene::{Scene, SceneKind};

fn random_direction(rng: &mut Rng) -> DVec3 {
    loop {
        let v = DVec3::new(
            2.0 * rng.next_f64() - 1.0,
            2.0 * rng.next_f64() - 1.0,
            2.0 * rng.next_f64() - 1.0,
        );
        let l = v.length();
        if l > 1e-3 && l <= 1.0 {
            return v / l;
        }
    }
}

#[test]
fn bvh_matches_brute_force() {
    for kind in SceneKind::ALL {
        let scene = Scene::build(kind);
        let mut rng = Rng::new(7);
        for _ in 0..4000 {
            let origin = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * scene.size;
            let ray = Ray {
                origin,
                direction: random_direction(&mut rng),
            };
            let mut best: Option<(f64, usize)> = None;
            for i in 0..scene.bvh.primitive_count() {
                if let Some((d, _, _)) = scene.bvh.primitive(i).intersect(&ray, 1e-9, f64::INFINITY)
                {
                    if best.is_none_or(|b| d < b.0) {
                        best = Some((d, i));
                    }
                }
            }
            let hit = scene.bvh.intersect(&ray, 1e-9, f64::INFINITY);
            match (best, hit) {
                (None, None) => {}
                (Some((d, _)), Some(h)) => assert!((d - h.distance).abs() <= 1e-12 * d.max(1.0)),
                other => panic!("{kind:?}: brute force and BVH disagree: {other:?}"),
            }
            assert_eq!(
                scene.bvh.occluded(&ray, 1e-9, f64::INFINITY),
                best.is_some(),
                "{kind:?}: occluded() disagrees"
            );
        }
    }
}

#[test]
fn room_gathers_leave_only_through_the_window() {
    let scene = Scene::build(SceneKind::Room);
    let (w, h) = (48, 48);
    let mut rng = Rng::new(3);
    let mut escaped = 0;
    for y in 0..h {
        for x in 0..w {
            let Some(sp) = scene.intersect(&scene.camera.ray(x, y, w, h)) else {
                continue;
            };
            for _ in 0..64 {
                let mut d = random_direction(&mut rng);
                if d.dot(sp.normal) < 0.0 {
                    d = -d;
                }
                let ray = Ray {
                    origin: sp.position,
                    direction: d,
                };
                if scene
                    .bvh
                    .intersect(&ray, scene.epsilon(), f64::INFINITY)
                    .is_some()
                {
                    continue;
                }
                // A miss must cross the wall x = 0 inside the window opening.
                escaped += 1;
                assert!(
                    d.x < 0.0,
                    "ray escaped away from the window wall: {sp:?} {d}"
                );
                let t = -sp.position.x / d.x;
                let p = sp.position + t * d;
                assert!(
                    (1.0..=2.2).contains(&p.y) && (1.3..=2.7).contains(&p.z),
                    "light leak: ray from {:?} left the room at {p}",
                    sp.position
                );
            }
        }
    }
    assert!(escaped > 0, "some rays must leave through the window");
}

/// The Cornell box is open at z = 1 only. Camera rays along the wall-floor seams land exactly on
/// both planes at 128 x 128 pixels; gathers from such points leaked through the floor before the
/// primary hits were pulled back from the surface.
#[test]
fn cornell_gathers_leave_only_through_the_open_front() {
    let scene = Scene::build(SceneKind::Cornell);
    let (w, h) = (128, 128);
    let mut rng = Rng::new(5);
    for y in h / 2..h {
        for x in 0..w {
            let Some(sp) = scene.intersect(&scene.camera.ray(x, y, w, h)) else {
                continue;
            };
            for _ in 0..24 {
                let mut d = random_direction(&mut rng);
                if d.dot(sp.normal) < 0.0 {
                    d = -d;
                }
                let ray = Ray {
                    origin: sp.position,
                    direction: d,
                };
                if scene
                    .bvh
                    .intersect(&ray, scene.epsilon(), f64::INFINITY)
                    .is_some()
                {
                    continue;
                }
                assert!(
                    d.z > 0.0,
                    "ray from {:?} escaped backwards along {d}",
                    sp.position
                );
                let p = sp.position + (1.0 - sp.position.z) / d.z * d;
                assert!(
                    (-1e-9..=1.0 + 1e-9).contains(&p.x) && (-1e-9..=1.0 + 1e-9).contains(&p.y),
                    "light leak at pixel ({x}, {y}): ray from {:?} left the box at {p}",
                    sp.position
                );
            }
        }
    }
}
