//! Bad input gives a clear error, never NaN.

use glam::DVec3;
use raddiff::scatter::{
    scene, single_scatter, single_scatter_brute_force, BruteForceOptions, Medium, ScatterOptions,
};
use raddiff::Error;

fn medium() -> Medium {
    Medium {
        eta: 1.5,
        sigma_t: 1.0,
        sigma_s: 0.5,
        g: 0.0,
    }
}

#[test]
fn bad_media_points_and_options_are_rejected() {
    let mesh = scene::bumpy_sphere(3, 0.05, 6.0).build().unwrap();
    let (entry, exit, light) = (
        DVec3::new(-0.5, 0.0, 0.0),
        DVec3::new(0.5, 0.1, 0.0),
        DVec3::new(0.0, 3.0, 0.0),
    );
    let o = ScatterOptions::default();
    let run =
        |m: Medium, e: DVec3, x: DVec3, l: DVec3, i: f64| single_scatter(&mesh, &m, e, x, l, i, &o);
    let expect = |r: raddiff::Result<raddiff::scatter::ScatterResult>, word: &str| match r {
        Err(Error::InvalidArgument(msg)) => assert!(msg.contains(word), "{msg}"),
        other => panic!("expected InvalidArgument containing {word:?}, got {other:?}"),
    };
    for eta in [1.0, 0.7, -2.0, f64::NAN, f64::INFINITY] {
        expect(
            run(Medium { eta, ..medium() }, entry, exit, light, 1.0),
            "eta",
        );
    }
    expect(
        run(
            Medium {
                sigma_s: 2.0,
                ..medium()
            },
            entry,
            exit,
            light,
            1.0,
        ),
        "sigma_s",
    );
    expect(
        run(
            Medium {
                sigma_t: -1.0,
                ..medium()
            },
            entry,
            exit,
            light,
            1.0,
        ),
        "sigma",
    );
    expect(
        run(Medium { g: 1.0, ..medium() }, entry, exit, light, 1.0),
        "g",
    );
    expect(run(medium(), DVec3::NAN, exit, light, 1.0), "entry");
    expect(
        run(
            medium(),
            entry,
            DVec3::new(0.0, f64::INFINITY, 0.0),
            light,
            1.0,
        ),
        "exit",
    );
    expect(
        run(medium(), entry, exit, DVec3::new(0.0, f64::NAN, 0.0), 1.0),
        "light",
    );
    expect(run(medium(), entry, exit, light, -1.0), "intensity");
    expect(run(medium(), entry, exit, light, f64::NAN), "intensity");
    expect(
        run(medium(), DVec3::new(5.0, 0.0, 0.0), exit, light, 1.0),
        "outside",
    );
    expect(
        run(medium(), entry, exit, DVec3::new(0.1, 0.2, 0.0), 1.0),
        "inside",
    );
    expect(
        single_scatter(
            &mesh,
            &medium(),
            entry,
            exit,
            light,
            1.0,
            &ScatterOptions {
                max_subintervals: 0,
                ..o
            },
        ),
        "max_subintervals",
    );
    for tolerance in [0.0, -1e-9, 1.0, f64::NAN] {
        expect(
            single_scatter(
                &mesh,
                &medium(),
                entry,
                exit,
                light,
                1.0,
                &ScatterOptions { tolerance, ..o },
            ),
            "tolerance",
        );
    }
    expect(
        single_scatter_brute_force(
            &mesh,
            &medium(),
            entry,
            exit,
            light,
            1.0,
            &BruteForceOptions {
                samples: 0,
                ..Default::default()
            },
        ),
        "samples",
    );
    // Degenerate but legal: zero-length segment, no scattering, no light.
    assert_eq!(
        run(medium(), entry, entry, light, 1.0).unwrap().radiance,
        0.0
    );
    assert_eq!(
        run(
            Medium {
                sigma_s: 0.0,
                ..medium()
            },
            entry,
            exit,
            light,
            1.0
        )
        .unwrap()
        .radiance,
        0.0
    );
    assert_eq!(
        run(medium(), entry, exit, light, 0.0).unwrap().radiance,
        0.0
    );
    assert!(run(medium(), entry, exit, light, 1.0).unwrap().radiance > 0.0);
}

#[test]
fn collinear_triangles_and_lights_on_vertices() {
    // Collinear points rounded to f32: a tiny non-zero cross product and a meaningless normal.
    let p = [0.1f32, 0.2, 0.3, 0.2, 0.4, 0.6, 0.3, 0.6, 0.9];
    let n = [0.0f32, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
    for idx in [[0u32, 1, 2], [0, 2, 1]] {
        match raddiff::scatter::RefractiveMesh::from_flat(&p, &n, &idx) {
            Err(Error::Degenerate(msg)) => assert!(msg.contains("zero area"), "{msg}"),
            other => panic!("expected a zero-area error, got {other:?}"),
        }
    }
    // A light exactly on a vertex of a closed mesh is on the surface, not inside it.
    let data = scene::bumpy_sphere(4, 0.05, 6.0);
    let mesh = data.build().unwrap();
    let (entry, exit) = (DVec3::new(-0.5, 0.0, 0.0), DVec3::new(0.5, 0.1, 0.0));
    for v in [0, 7, 100] {
        let light = data.positions[v];
        assert!(!mesh.contains(light));
        let r = single_scatter(
            &mesh,
            &medium(),
            entry,
            exit,
            light,
            1.0,
            &ScatterOptions::default(),
        )
        .unwrap();
        assert!(r.radiance.is_finite() && r.radiance >= 0.0);
        // Just inside it is rejected.
        let inside = light * (1.0 - 1e-6);
        assert!(mesh.contains(inside));
    }
}
