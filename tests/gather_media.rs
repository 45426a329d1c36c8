//! Gradients through participating media (Jarosz, Zwicker, Jensen 2008) against finely integrated
//! references: an absorbing, an emissive and a scattering medium filling the space above the plane,
//! with an emitter and two occluders. Each case runs Ward-Heckbert alone (the renderer folds the
//! medium into the cell radiance) and with the media terms, and prints a table like Fig. 7.

#[path = "gather_support/mod.rs"]
mod support;

use glam::DVec3;
use support::*;

struct Row {
    m: u32,
    e_err: f64,
    g_wh: f64,
    g_media: f64,
}

fn run(name: &str, scene: &Scene, ms: &[u32]) -> Vec<Row> {
    let frame = plane_frame(0.05, -0.1);
    let x = frame.position;
    let e_ref = scene.irradiance(x, DVec3::Z);
    let g_ref = scene.irradiance_gradient(x, DVec3::Z);
    println!("{name}: E = {e_ref:.9}, grad E = {g_ref:.6}");
    println!(
        "  | M x N | irradiance | gradient, Ward-Heckbert only | gradient, with media terms |"
    );
    let mut rows = Vec::new();
    for &m in ms {
        let layout = polar(m, 0);
        let with = scene.gather(&layout, &frame, true);
        let without = scene.gather(&layout, &frame, false);
        let e_err = (with.irradiance[0] - e_ref).abs() / e_ref;
        // Both paths estimate the same irradiance.
        assert!((with.irradiance[0] - without.irradiance[0]).abs() < 1e-6 * e_ref);
        let g_wh = rel_err(without.gradient[0], g_ref).1;
        let g_media = rel_err(with.gradient[0], g_ref).1;
        println!(
            "  | {m} x {} | {e_err:.2e} | {g_wh:.2e} | {g_media:.2e} |",
            2 * m
        );
        rows.push(Row {
            m,
            e_err,
            g_wh,
            g_media,
        });
    }
    let ms: Vec<u32> = rows.iter().map(|r| r.m).collect();
    let rate_of = |f: &dyn Fn(&Row) -> f64| rate(&ms, &rows.iter().map(f).collect::<Vec<_>>());
    println!(
        "  rates: irradiance {:.2}, WH gradient {:.2}, media gradient {:.2}",
        rate_of(&|r| r.e_err),
        rate_of(&|r| r.g_wh),
        rate_of(&|r| r.g_media)
    );
    rows
}

fn occluded(sigma: f64, media: Media) -> Scene {
    let mut scene = Scene::new(vec![emitter(), occluder_a(), occluder_b()]);
    scene.env = 0.05;
    scene.sigma = sigma;
    scene.media = media;
    scene.steps = 160;
    scene.step = 0.05;
    scene
}

const MS: [u32; 4] = [8, 16, 32, 64];

fn check(rows: &[Row], final_error: f64) {
    let last = rows.last().unwrap();
    assert!(
        last.g_media < final_error,
        "media gradient error {:.3e}",
        last.g_media
    );
    assert!(last.g_media < rows[0].g_media / 3.0, "no convergence");
    // the irradiance error is edge aliasing, absolute in size: relative to a dim scene it is larger
    assert!(last.e_err < 2e-2);
}

#[test]
fn absorbing_medium() {
    let rows = run(
        "absorbing medium, sigma_t = 0.4",
        &occluded(0.4, Media::None),
        &MS,
    );
    check(&rows, 3e-2);
    // Ward-Heckbert alone misses the attenuation gradient: it does not converge to the truth.
    assert!(rows[3].g_wh > 5.0 * rows[3].g_media);
}

#[test]
fn emissive_medium() {
    let rows = run(
        "emissive medium, sigma_t = 0.5, Q = 0.3",
        &occluded(0.5, Media::Constant(0.3)),
        &MS,
    );
    check(&rows, 3e-2);
    assert!(rows[3].g_wh > 3.0 * rows[3].g_media);
}

#[test]
fn scattering_medium() {
    let rows = run(
        "scattering medium, sigma_t = 0.5, Q = 0.3 (1 + sin/2)",
        &occluded(0.5, Media::Field(0.3)),
        &MS,
    );
    check(&rows, 3e-2);
    assert!(rows[3].g_wh > 3.0 * rows[3].g_media);
}
