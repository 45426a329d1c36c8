//! Flat interface: one large triangle with constant normals. The refraction point has a 1D Snell
//! solution and the flat-interface D has a closed form, derived here independently of the library
//! (beam widths in and across the plane of incidence); the library's Newton solve, D factors,
//! contribution and integral must match them to 1e-9.

use glam::{DVec2, DVec3};
use raddiff::scatter::constraint::{Constraint, EyeSegment};
use raddiff::scatter::contribution::{path_contribution, DistanceFactor};
use raddiff::scatter::newton::{
    solve_interior, straight_line_seed, NewtonCounters, NewtonSettings,
};
use raddiff::scatter::{self, Medium, RefractiveMesh, ScatterOptions};

const ETA: f64 = 1.5;
const LIGHT: DVec3 = DVec3::new(0.3, -0.2, 2.0);

fn medium() -> Medium {
    Medium {
        eta: ETA,
        sigma_t: 0.8,
        sigma_s: 0.6,
        g: 0.4,
    }
}

/// The plane z = 0 (outside is z > 0) as one triangle of side ~300.
fn plane() -> RefractiveMesh {
    RefractiveMesh::new(
        &[
            DVec3::new(-100.0, -100.0, 0.0),
            DVec3::new(200.0, -100.0, 0.0),
            DVec3::new(-100.0, 200.0, 0.0),
        ],
        &[DVec3::Z; 3],
        &[[0, 1, 2]],
    )
    .unwrap()
}

/// The refraction point for V below the plane: bisection of the (monotone) Snell residual along the
/// horizontal line from the light's foot to V's foot.
fn snell_point(v: DVec3) -> DVec3 {
    let (hl, hv) = (LIGHT.z, -v.z);
    let foot = DVec2::new(v.x - LIGHT.x, v.y - LIGHT.y);
    let r = foot.length();
    let residual = |p: f64| {
        p / (p * p + hl * hl).sqrt() - ETA * (r - p) / ((r - p) * (r - p) + hv * hv).sqrt()
    };
    let (mut lo, mut hi) = (0.0, r);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if residual(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let rho = 0.5 * (lo + hi);
    let dir = if r > 0.0 { foot / r } else { DVec2::ZERO };
    DVec3::new(LIGHT.x + rho * dir.x, LIGHT.y + rho * dir.y, 0.0)
}

/// Closed-form contribution per unit length at V (x along the eye segment).
fn reference_contribution(eye: &EyeSegment, x: f64) -> f64 {
    let m = medium();
    let v = eye.at(x);
    let p = snell_point(v);
    let (d_l, d_v) = ((LIGHT - p).length(), (v - p).length());
    let (cos_l, cos_v) = (LIGHT.z / d_l, -v.z / d_v);
    // Beam width across the plane of incidence per radian at the light: (η d_L + d_V)/η; in the
    // plane: d_L cos_V/cos_L + d_V cos_L/(η cos_V).
    let sagittal = (ETA * d_l + d_v) / ETA;
    let tangential = d_l * cos_v / cos_l + d_v * cos_l / (ETA * cos_v);
    let d = sagittal * tangential;
    // Fresnel, unpolarized.
    let rs = (cos_l - ETA * cos_v) / (cos_l + ETA * cos_v);
    let rp = (ETA * cos_l - cos_v) / (ETA * cos_l + cos_v);
    let t = 1.0 - 0.5 * (rs * rs + rp * rp);
    let wv = (v - p) / d_v;
    let mu = -wv.dot(eye.dir);
    let g = m.g;
    let phase =
        (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * mu).powf(1.5));
    m.sigma_s * phase * t * (-m.sigma_t * (x + d_v)).exp() / d
}

fn eye() -> EyeSegment {
    EyeSegment::new(DVec3::new(-0.5, 0.1, -0.2), DVec3::new(0.8, 0.3, -1.5)).unwrap()
}

#[test]
fn newton_point_and_contribution_match_the_1d_snell_solution() {
    let mesh = plane();
    let tri = mesh.triangle(0);
    let eye = eye();
    let c = Constraint {
        tri,
        eye: &eye,
        light: LIGHT,
        eta: ETA,
    };
    let mut k = NewtonCounters::default();
    for i in 0..=20 {
        let x = eye.length * i as f64 / 20.0;
        let ab = solve_interior(
            &c,
            x,
            straight_line_seed(&c, x).unwrap(),
            &NewtonSettings::default(),
            &mut k,
        )
        .unwrap_or_else(|| panic!("no solution at x = {x}: {k:?}"));
        let p = tri.point(ab);
        let p_ref = snell_point(eye.at(x));
        assert!((p - p_ref).length() < 1e-12, "x = {x}: {p} vs {p_ref}");
        let reference = reference_contribution(&eye, x);
        for df in [DistanceFactor::Interpolated, DistanceFactor::Flat] {
            let got = path_contribution(tri, ab, &eye, x, LIGHT, 1.0, &medium(), df)
                .unwrap()
                .value;
            assert!(
                (got - reference).abs() < 1e-9 * reference,
                "x = {x}, {df:?}: {got} vs {reference}"
            );
        }
    }
    assert_eq!(k.failures, 0);
    assert!(k.iterations <= 21 * 8, "{k:?}");
}

#[test]
fn integrated_radiance_matches_the_closed_form_integral() {
    let eye = eye();
    // Reference: composite 64-point Gauss-Legendre over 16 pieces of the closed form.
    let (nodes, weights) = scatter::integrate::gauss_legendre(64);
    let pieces = 16;
    let h = eye.length / pieces as f64;
    let mut reference = 0.0;
    for k in 0..pieces {
        let mid = (k as f64 + 0.5) * h;
        for (z, w) in nodes.iter().zip(&weights) {
            reference += 0.5 * h * w * reference_contribution(&eye, mid + 0.5 * h * z);
        }
    }
    let mesh = plane();
    let exit = eye.at(eye.length);
    for df in [DistanceFactor::Interpolated, DistanceFactor::Flat] {
        let opts = ScatterOptions {
            tolerance: 1e-12,
            distance_factor: df,
            ..Default::default()
        };
        let r =
            scatter::single_scatter(&mesh, &medium(), eye.origin, exit, LIGHT, 2.0, &opts).unwrap();
        let got = r.radiance / 2.0;
        assert!(
            (got - reference).abs() < 1e-9 * reference,
            "{df:?}: {got} vs {reference}"
        );
        assert_eq!(r.stats.triangles_contributing, 1);
        assert_eq!(r.stats.interior.failures, 0);
    }
    // The default 8 nodes are already within 1e-6 on this smooth integrand.
    let r = scatter::single_scatter(
        &mesh,
        &medium(),
        eye.origin,
        exit,
        LIGHT,
        1.0,
        &ScatterOptions::default(),
    )
    .unwrap();
    assert!((r.radiance - reference).abs() < 1e-6 * reference);
}

#[test]
fn support_ends_where_the_refraction_point_leaves_a_small_triangle() {
    // A small triangle: the refraction points of the segment cross it, so the support is a proper
    // sub-interval, found from the edge crossings; the integral must match the closed form there.
    let mesh = RefractiveMesh::new(
        &[
            DVec3::new(-0.2, -0.3, 0.0),
            DVec3::new(0.5, -0.2, 0.0),
            DVec3::new(0.0, 0.4, 0.0),
        ],
        &[DVec3::Z; 3],
        &[[0, 1, 2]],
    )
    .unwrap();
    let eye = EyeSegment::new(DVec3::new(-1.0, 0.0, -0.3), DVec3::new(1.2, 0.1, -0.6)).unwrap();
    let inside = |x: f64| {
        let p = snell_point(eye.at(x));
        let tri = mesh.triangle(0);
        let r = p - tri.p0;
        let (e1, e2) = (tri.e1, tri.e2);
        let det = e1.x * e2.y - e1.y * e2.x;
        let a = (r.x * e2.y - r.y * e2.x) / det;
        let b = (e1.x * r.y - e1.y * r.x) / det;
        a >= 0.0 && b >= 0.0 && a + b <= 1.0
    };
    // Locate the support by bisection on the closed form.
    let n = 4000;
    let xs: Vec<f64> = (0..=n).map(|k| eye.length * k as f64 / n as f64).collect();
    let first = xs.iter().position(|&x| inside(x)).unwrap();
    let last = xs.iter().rposition(|&x| inside(x)).unwrap();
    assert!(
        first > 0 && last < n,
        "support must be interior for this test"
    );
    let refine = |mut out: f64, mut inn: f64| {
        for _ in 0..100 {
            let m = 0.5 * (out + inn);
            if inside(m) {
                inn = m;
            } else {
                out = m;
            }
        }
        0.5 * (out + inn)
    };
    let (x0, x1) = (
        refine(xs[first - 1], xs[first]),
        refine(xs[last + 1], xs[last]),
    );
    let (nodes, weights) = scatter::integrate::gauss_legendre(64);
    let reference: f64 = nodes
        .iter()
        .zip(&weights)
        .map(|(z, w)| {
            0.5 * (x1 - x0)
                * w
                * reference_contribution(&eye, 0.5 * (x0 + x1) + 0.5 * (x1 - x0) * z)
        })
        .sum();
    let opts = ScatterOptions {
        tolerance: 1e-12,
        ..Default::default()
    };
    let r = scatter::single_scatter(
        &mesh,
        &medium(),
        eye.origin,
        eye.at(eye.length),
        LIGHT,
        1.0,
        &opts,
    )
    .unwrap();
    assert!(
        (r.radiance - reference).abs() < 1e-9 * reference,
        "{} vs {reference} (support [{x0}, {x1}])",
        r.radiance
    );
    assert!(r.stats.edge.solves >= 2);
}
