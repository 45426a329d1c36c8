//! Every layout kind refuses directions that are not in their own strata (issue 17): shifted,
//! cyclically shifted or swapped rows and columns, a direction from the far side, another frame,
//! with and without marched media; `InvalidArgument` names the first bad index, its row and column.
//! Valid gathers of many seeds and shapes pass, also rounded to `f32`.

use glam::DVec3;
use raddiff::gather::{
    evaluate, Frame, GatherInput, Layout, LayoutKind, MediaRadiance, ValidGather, Wanted,
};
use raddiff::Error;

const KINDS: [LayoutKind; 3] = [
    LayoutKind::CosinePolar,
    LayoutKind::Concentric,
    LayoutKind::Sphere,
];

fn frame() -> Frame {
    let n = DVec3::new(0.3, -0.4, 0.8).normalize();
    Frame::new(DVec3::new(1.0, 2.0, 3.0), n, n.any_orthonormal_vector()).unwrap()
}

struct Gather {
    dist: Vec<f64>,
    rad: Vec<f32>,
    media: Vec<f32>,
}

impl Gather {
    fn new(layout: &Layout) -> Gather {
        let cells = layout.len();
        Gather {
            dist: (0..cells).map(|i| 0.5 + (i % 7) as f64 * 0.3).collect(),
            rad: (0..cells).map(|i| 0.1 + (i % 5) as f32 * 0.2).collect(),
            media: (0..cells * 4)
                .map(|i| 0.05 + (i % 3) as f32 * 0.01)
                .collect(),
        }
    }

    fn input<'a>(&'a self, dirs: &'a [DVec3], media: bool) -> GatherInput<'a> {
        GatherInput {
            directions: dirs,
            distance: &self.dist,
            radiance: &self.rad,
            channels: 1,
            sigma_t: if media { 0.3 } else { 0.0 },
            media: media.then_some(MediaRadiance {
                radiance: &self.media,
                gradient: None,
                steps: 4,
                step: 0.25,
            }),
        }
    }
}

/// `dirs` must be refused for `layout` (with and without media), the message naming
/// `directions[first]`, its row and column.
fn expect_refused(layout: &Layout, frame: &Frame, dirs: &[DVec3], first: usize, what: &str) {
    let g = Gather::new(layout);
    let want = format!(
        "directions[{first}] (row j = {}, column k = {}",
        first / layout.n as usize,
        first % layout.n as usize
    );
    for media in [false, true] {
        match evaluate(layout, frame, &g.input(dirs, media), Wanted::ALL) {
            Err(Error::InvalidArgument(msg)) => {
                assert!(msg.contains(&want), "{layout:?} {what}: {msg}")
            }
            other => panic!("{layout:?} {what} (media {media}): {other:?}"),
        }
    }
    let check = layout
        .check_directions(frame, dirs)
        .unwrap_err()
        .to_string();
    assert!(check.contains(&want), "{check}");
}

/// The issue's malformed gathers, for every layout kind and a few seeds.
#[test]
fn malformed_gathers_are_refused_naming_the_first_bad_direction() {
    let f = frame();
    for kind in KINDS {
        for seed in [0, 1, 77, 123_456_789] {
            let layout = Layout::new(kind, 6, 10, seed).unwrap();
            let (m, n) = (6, 10);
            let good = layout.directions(&f).unwrap();

            let mut d = good.clone();
            d.copy_within(0..(m - 1) * n, n);
            expect_refused(&layout, &f, &d, n, "rows shifted by one");

            let d: Vec<DVec3> = (0..m * n).map(|i| good[(i + n) % (m * n)]).collect();
            expect_refused(&layout, &f, &d, 0, "rows cyclically shifted");

            let d: Vec<DVec3> = (0..m * n)
                .map(|i| good[(i / n) * n + (i % n + 1) % n])
                .collect();
            expect_refused(&layout, &f, &d, 0, "columns shifted by one");

            let mut d = good.clone();
            d.swap(2 * n + 3, 2 * n + 4);
            expect_refused(&layout, &f, &d, 2 * n + 3, "neighbours swapped in a row");

            let mut d = good.clone();
            d.swap(3 * n + 5, 4 * n + 5);
            expect_refused(&layout, &f, &d, 3 * n + 5, "neighbours swapped across rows");

            // far side: opposite azimuth at the same elevation (hemisphere), the antipode (sphere)
            let mut d = good.clone();
            let w = good[4 * n + 7];
            d[4 * n + 7] = if kind == LayoutKind::Sphere {
                -w
            } else {
                2.0 * w.dot(f.normal) * f.normal - w
            };
            expect_refused(&layout, &f, &d, 4 * n + 7, "far side");

            // another frame: the tangent turned by 90 degrees about the normal
            let turned = Frame::new(f.position, f.normal, f.bitangent()).unwrap();
            expect_refused(&layout, &turned, &good, 0, "turned frame");
        }
    }
}

/// The issue's gather: concentric rows cyclically shifted, so that consecutive perimeter samples
/// point in opposite azimuths. It used to evaluate to an occlusion gradient of 8e15 and a Hessian
/// entry of -4.8e31; it is refused before anything is evaluated.
#[test]
fn the_issues_concentric_gather_is_refused() {
    let f = Frame::new(DVec3::ZERO, DVec3::Z, DVec3::X).unwrap();
    let layout = Layout::new(LayoutKind::Concentric, 8, 8, 5).unwrap();
    let good = layout.directions(&f).unwrap();
    let d: Vec<DVec3> = (0..64).map(|i| good[(i + 8 * 7) % 64]).collect();
    let g = Gather::new(&layout);
    let err = ValidGather::new(&layout, &f, &g.input(&d, false)).unwrap_err();
    let msg = err.to_string();
    println!("{msg}");
    assert!(
        msg.contains("directions[0] (row j = 0, column k = 0 of the 8x8 Concentric layout) lies outside its stratum"),
        "{msg}"
    );
}

/// Directions of any seed lie in their strata: many seeds and shapes (1 x 1 to 64 x 128, odd and
/// uneven), also after rounding to `f32` (a renderer storing directions in single precision).
#[test]
fn valid_gathers_of_many_seeds_pass() {
    let f = frame();
    let shapes = [
        (1, 1),
        (1, 7),
        (5, 1),
        (2, 2),
        (3, 5),
        (7, 3),
        (16, 32),
        (64, 128),
    ];
    let mut tried = 0;
    for kind in KINDS {
        for (m, n) in shapes {
            let seeds = if m * n > 1000 { 20 } else { 400 };
            for s in 0..seeds {
                let seed = (s as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                let layout = Layout::new(kind, m, n, seed).unwrap();
                let d = layout.directions(&f).unwrap();
                layout.check_directions(&f, &d).unwrap();
                let single: Vec<DVec3> = d.iter().map(|w| w.as_vec3().as_dvec3()).collect();
                layout.check_directions(&f, &single).unwrap();
                tried += 1;
            }
        }
    }
    assert_eq!(tried, 3 * (7 * 400 + 20));
}

/// The tolerance is what the docs say: a direction pushed across its stratum's wall by 1e-7 in
/// the layout's coordinate passes, by 1e-5 it is refused (every kind, a wall in each direction).
#[test]
fn the_tolerance_is_a_thin_band_around_each_stratum() {
    let f = Frame::new(DVec3::ZERO, DVec3::Z, DVec3::X).unwrap();
    for kind in KINDS {
        let layout = Layout::new(kind, 4, 6, 0).unwrap();
        let good = layout.directions(&f).unwrap();
        // stratum (1, 2): grid points just outside its four walls
        for (da, db) in [(-1.0, 0.0), (1.0, 0.0), (0.0, -1.0), (0.0, 1.0)] {
            for (eps, ok) in [(1e-7, true), (1e-5, false)] {
                // grid coordinate offsets: the tolerance is in sin²θ, cosθ or square units, a
                // grid step is 1/M (polar), 2/M (sphere, concentric) of those
                let scale = |count: u32| match kind {
                    LayoutKind::CosinePolar => count as f64,
                    _ => count as f64 / 2.0,
                };
                let a = if da < 0.0 {
                    1.0 - eps * scale(4)
                } else if da > 0.0 {
                    2.0 + eps * scale(4)
                } else {
                    1.5
                };
                let b = if db < 0.0 {
                    2.0 - eps
                        * if kind == LayoutKind::Concentric {
                            3.0
                        } else {
                            6.0 / std::f64::consts::TAU
                        }
                } else if db > 0.0 {
                    3.0 + eps
                        * if kind == LayoutKind::Concentric {
                            3.0
                        } else {
                            6.0 / std::f64::consts::TAU
                        }
                } else {
                    2.5
                };
                let mut d = good.clone();
                d[layout.index(1, 2)] = f.to_world(layout.grid_to_local(a, b));
                let got = layout.check_directions(&f, &d);
                assert_eq!(got.is_ok(), ok, "{kind:?} ({da}, {db}) by {eps}: {got:?}");
            }
        }
    }
}
