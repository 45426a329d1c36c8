//! Integration along the eye segment: the per-triangle interval method (report Fig. 5) over the
//! pruned hierarchy, and the brute-force sample-point reference (Walter et al. 2009).

use glam::{DVec2, DVec3};
use smallvec::SmallVec;

use super::constraint::{Constraint, EyeSegment};
use super::contribution::{path_contribution, DistanceFactor, Medium};
use super::fold::{
    fold_pairs, integrate_fold_pair, integrate_lone_fold, integrate_piece_along_arc,
};
use super::interval::{owned_solutions_at, seeds_at, triangle_support, Ownership, SupportInterval};
use super::mesh::RefractiveMesh;
use super::newton::NewtonSettings;
pub use super::options::ScatterOptions;
use super::prune::{normal_cone_test, sidedness_test, spindle_test};
use super::quadrature::{self, Adaptive};
use super::stats::ScatterStats;
use crate::error::{ensure_finite, ensure_finite3, Error, Result};

/// Radiance and what it cost.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ScatterResult {
    /// Single-scattered radiance arriving at the entry point along the eye segment, inside the
    /// medium (units of `intensity` per L²).
    pub radiance: f64,
    /// Counters.
    pub stats: ScatterStats,
}

/// Gauss-Legendre nodes and weights on [−1, 1] (Newton on the Legendre recurrence).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, 0.0);
            for k in 0..n {
                let p2 = p1;
                p1 = p0;
                p0 = ((2 * k + 1) as f64 * z * p1 - k as f64 * p2) / (k + 1) as f64;
            }
            dp = n as f64 * (z * p0 - p1) / (z * z - 1.0);
            let dz = p0 / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        nodes[i] = -z;
        nodes[n - 1 - i] = z;
        let w = 2.0 / ((1.0 - z * z) * dp * dp);
        weights[i] = w;
        weights[n - 1 - i] = w;
    }
    (nodes, weights)
}

pub(crate) fn validate(
    mesh: &RefractiveMesh,
    medium: &Medium,
    entry: DVec3,
    exit: DVec3,
    light: DVec3,
    intensity: f64,
) -> Result<()> {
    medium.validate()?;
    ensure_finite3(entry, "entry")?;
    ensure_finite3(exit, "exit")?;
    ensure_finite3(light, "light")?;
    ensure_finite(intensity, "intensity")?;
    if intensity < 0.0 {
        return Err(Error::InvalidArgument(format!(
            "intensity must be >= 0 (got {intensity})"
        )));
    }
    if !mesh.is_closed() {
        return Ok(());
    }
    let s = mesh.bounding_sphere();
    let slack = s.radius * (1.0 + 1e-6);
    for (p, name) in [(entry, "entry"), (exit, "exit")] {
        if (p - s.center).length() > slack {
            return Err(Error::InvalidArgument(format!(
                "{name} {p} lies outside the closed mesh's bounding sphere (centre {}, radius {}): \
                 the eye segment must be the part of the eye ray inside the mesh",
                s.center, s.radius
            )));
        }
    }
    if mesh.contains(light) {
        return Err(Error::InvalidArgument(format!(
            "the light {light} is inside the closed mesh: it must be outside the medium"
        )));
    }
    Ok(())
}

/// Single-scattered radiance arriving at `entry` along the eye segment `entry → exit` inside the
/// mesh, from a point light of intensity `intensity` (power per sr) at `light` outside it, by the
/// per-triangle interval method (Holzschuch 2013) over the pruned bounding-sphere hierarchy.
///
/// The radiance is ∫₀^|exit−entry| exp(−σ_t x) Σ_paths σ_s φ I T exp(−σ_t d_V) / D dx (see
/// [`super::contribution`]): it is the radiance inside the medium at `entry` travelling towards the
/// eye, before refraction out of the surface. Occlusion of L → P and P → V by other parts of the
/// mesh is not tested (exact for convex meshes).
///
/// Errors: [`Error::InvalidArgument`] for a bad medium (η ≤ 1, σ_s outside [0, σ_t], |g| ≥ 1),
/// non-finite points, negative intensity; for a closed mesh also an entry/exit outside its bounding
/// sphere or a light inside it (parity of ray crossings). Open meshes (a single interface) accept
/// any points. The paths are integrated per unit intensity and scaled once at the end, so an
/// intensity up to `f64::MAX` is exact while the radiance itself fits a double;
/// [`Error::Degenerate`] when it does not (an intensity near `f64::MAX` focused by refraction).
/// `entry == exit` gives 0.
#[allow(clippy::too_many_arguments)]
pub fn single_scatter(
    mesh: &RefractiveMesh,
    medium: &Medium,
    entry: DVec3,
    exit: DVec3,
    light: DVec3,
    intensity: f64,
    options: &ScatterOptions,
) -> Result<ScatterResult> {
    validate(mesh, medium, entry, exit, light, intensity)?;
    if !(options.tolerance > 0.0 && options.tolerance < 1.0) {
        return Err(Error::InvalidArgument(format!(
            "tolerance must be in (0, 1) (got {})",
            options.tolerance
        )));
    }
    if options.max_subintervals == 0 {
        return Err(Error::InvalidArgument(
            "max_subintervals must be >= 1".into(),
        ));
    }
    let mut stats = ScatterStats {
        segments: 1,
        ..Default::default()
    };
    let Some(eye) = EyeSegment::new(entry, exit) else {
        return Ok(ScatterResult {
            radiance: 0.0,
            stats,
        });
    };
    if medium.sigma_s == 0.0 || intensity == 0.0 {
        return Ok(ScatterResult {
            radiance: 0.0,
            stats,
        });
    }
    let full = (0.0, eye.length);
    let h = mesh.hierarchy();
    let mut total = 0.0;
    let mut stack: SmallVec<[usize; 64]> = smallvec::smallvec![0];
    while let Some(ni) = stack.pop() {
        let node = &h.nodes()[ni];
        stats.nodes_visited += 1;
        if options.spindle_test && !spindle_test(&node.sphere, &eye, full, light, medium.eta) {
            stats.nodes_pruned_spindle += 1;
            continue;
        }
        if node.count == 0 {
            stack.push(node.start_or_right as usize);
            stack.push(ni + 1);
            continue;
        }
        for &ti in h.leaf_triangles(node) {
            // Per unit intensity, scaled once at the end: the radiance is linear in the intensity,
            // and a huge intensity would overflow in the paths' products before the sum does.
            total += triangle_contribution(
                mesh,
                ti as usize,
                &eye,
                light,
                1.0,
                medium,
                options,
                &mut stats,
            );
        }
    }
    let radiance = total * intensity;
    if !radiance.is_finite() {
        return Err(Error::Degenerate(format!(
            "the radiance overflows a double (intensity {intensity:e} times {total:e} per unit \
             intensity); scale the intensity down and the result up"
        )));
    }
    Ok(ScatterResult { radiance, stats })
}

/// The integral over the eye segment of triangle `ti`'s contribution, with pruning per `options`.
#[allow(clippy::too_many_arguments)]
pub fn triangle_contribution(
    mesh: &RefractiveMesh,
    ti: usize,
    eye: &EyeSegment,
    light: DVec3,
    intensity: f64,
    medium: &Medium,
    options: &ScatterOptions,
    stats: &mut ScatterStats,
) -> f64 {
    stats.triangles_visited += 1;
    let own = mesh.triangle_ownership(ti);
    let sphere = mesh.triangle_sphere(ti);
    let mut range = (0.0, eye.length);
    if options.sidedness_test {
        match sidedness_test(mesh.triangle(ti), eye, range, light) {
            Some(r) => range = r,
            None => {
                stats.triangles_pruned_sidedness += 1;
                return 0.0;
            }
        }
    }
    if options.spindle_test && !spindle_test(sphere, eye, range, light, medium.eta) {
        stats.triangles_pruned_spindle += 1;
        return 0.0;
    }
    if options.normal_cone_test {
        let cone = mesh.triangle_normal_cone(ti);
        match normal_cone_test(sphere, cone, eye, range, light, medium.eta) {
            Some(r) => range = r,
            None => {
                stats.triangles_pruned_normal_cone += 1;
                return 0.0;
            }
        }
    }
    let tri = mesh.triangle(ti);
    let c = Constraint {
        tri,
        eye,
        light,
        eta: medium.eta,
    };
    let support = triangle_support(
        &c,
        range,
        &options.newton,
        &mut stats.interior,
        &mut stats.edge,
    );
    if !support.consistent {
        stats.triangles_fallback += 1;
    }
    if support.intervals.is_empty() {
        stats.triangles_without_support += 1;
        return 0.0;
    }
    let mut sum = 0.0;
    let mut paths = 0;
    // The two branches meeting at a fold are integrated together along the curve (see `fold`).
    let mut done: SmallVec<[bool; 4]> = smallvec::smallvec![false; support.intervals.len()];
    for (i, j) in fold_pairs(&support.intervals, range) {
        let (p, q) = (&support.intervals[i], &support.intervals[j]);
        if let Some(v) = integrate_fold_pair(
            &c, p, q, range, own, intensity, medium, options, stats, &mut paths,
        ) {
            sum += v;
            done[i] = true;
            done[j] = true;
        }
    }
    // A fold without a partner: the other branch crossed one edge twice between two scan points.
    for (i, piece) in support.intervals.iter().enumerate() {
        if !done[i] && piece.folds[0] != piece.folds[1] {
            if let Some(v) = integrate_lone_fold(
                &c, piece, range, own, intensity, medium, options, stats, &mut paths,
            ) {
                sum += v;
                done[i] = true;
            }
        }
    }
    for (i, piece) in support.intervals.iter().enumerate() {
        if !done[i] && !support.consistent {
            if let Some(v) = integrate_piece_along_arc(
                &c, piece, range, own, intensity, medium, options, stats, &mut paths,
            ) {
                sum += v;
                done[i] = true;
            }
        }
    }
    for (piece, _) in support.intervals.iter().zip(&done).filter(|(_, &d)| !d) {
        sum += integrate_piece(
            &c, piece, own, intensity, medium, options, stats, &mut paths,
        );
    }
    if paths > 0 {
        stats.triangles_contributing += 1;
    }
    sum
}

#[allow(clippy::too_many_arguments)]
fn integrate_piece(
    c: &Constraint,
    piece: &SupportInterval,
    own: Ownership,
    intensity: f64,
    medium: &Medium,
    options: &ScatterOptions,
    stats: &mut ScatterStats,
    paths: &mut u64,
) -> f64 {
    let width = piece.x1 - piece.x0;
    // The piece is integrated over s in [0, 1]. A fold end gets the substitution
    // x = x_fold ± width s², which turns its 1/√ singularity into a smooth integrand.
    let fold_at_start = piece.folds[0] && !piece.folds[1];
    let fold_at_end = piece.folds[1] && !piece.folds[0];
    let map = |s: f64| -> (f64, f64) {
        if fold_at_end {
            let t = 1.0 - s;
            (piece.x1 - width * t * t, 2.0 * width * t)
        } else if fold_at_start {
            (piece.x0 + width * s * s, 2.0 * width * s)
        } else {
            (piece.x0 + width * s, width)
        }
    };
    // Continuation: each interval's nodes are solved from the regular end towards the fold, each
    // seeded by the previous solution.
    let mut previous: Option<DVec2> = if fold_at_start {
        piece.ends[1]
    } else {
        piece.ends[0]
    };
    let settings = Adaptive {
        relative: options.tolerance,
        absolute: 0.0,
        max_intervals: options.max_subintervals,
    };
    let all = piece.multiplicity > 1;
    let (sum, _, intervals) = quadrature::integrate(0.0, 1.0, &settings, |ss, values| {
        for i in 0..15 {
            let k = if fold_at_start { 14 - i } else { i };
            let s = ss[k];
            let (x, jac) = map(s);
            stats.samples += 1;
            let guess = if piece.folds == [false, false] {
                match piece.ends {
                    [Some(a), Some(b)] if piece.multiplicity == 1 => Some(a + s * (b - a)),
                    _ => previous,
                }
            } else {
                previous
            };
            let mut seeds: SmallVec<[DVec2; 8]> = SmallVec::new();
            seeds.extend(guess);
            seeds.extend(seeds_at(c, x));
            let found =
                owned_solutions_at(c, x, &seeds, all, own, &options.newton, &mut stats.interior);
            let found = if found.is_empty() && !all {
                // The first seed converged outside the triangle: try the others before giving up.
                owned_solutions_at(
                    c,
                    x,
                    &seeds_at(c, x),
                    true,
                    own,
                    &options.newton,
                    &mut stats.interior,
                )
            } else {
                found
            };
            let mut value = 0.0;
            for ab in &found {
                if let Some(p) = path_contribution(
                    c.tri,
                    *ab,
                    c.eye,
                    x,
                    c.light,
                    intensity,
                    medium,
                    options.distance_factor,
                ) {
                    value += jac * p.value;
                    stats.paths += 1;
                    *paths += 1;
                }
            }
            values[k] = value;
            previous = found.first().copied().or(previous);
        }
    });
    stats.subintervals += intervals as u64;
    sum
}

/// Settings of the brute-force reference [`single_scatter_brute_force`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BruteForceOptions {
    /// Sample points along the eye segment (midpoint rule).
    pub samples: usize,
    /// Seeds per triangle side: Newton starts from the centroids of the `seeds²` sub-triangles of a
    /// regular subdivision (1 = the centroid only).
    pub seeds: usize,
    /// Which D factor to use.
    pub distance_factor: DistanceFactor,
    /// Newton caps and tolerances.
    pub newton: NewtonSettings,
}

impl Default for BruteForceOptions {
    fn default() -> Self {
        BruteForceOptions {
            samples: 256,
            seeds: 2,
            distance_factor: DistanceFactor::Interpolated,
            newton: NewtonSettings::default(),
        }
    }
}

/// Centroids of the sub-triangles of a regular subdivision of the unit triangle into `k²` pieces.
pub fn subdivision_seeds(k: usize) -> Vec<DVec2> {
    let k = k.max(1);
    let h = 1.0 / k as f64;
    let mut out = Vec::with_capacity(k * k);
    for i in 0..k {
        for j in 0..k - i {
            let (a, b) = (i as f64 * h, j as f64 * h);
            out.push(DVec2::new(a + h / 3.0, b + h / 3.0));
            if i + j + 1 < k {
                out.push(DVec2::new(a + 2.0 * h / 3.0, b + 2.0 * h / 3.0));
            }
        }
    }
    out
}

/// The reference of Walter et al. 2009 without pruning: `samples` midpoint-rule points along the
/// eye segment, Newton from every seed on every triangle at each, distinct solutions summed. Seeds:
/// the previous sample's solutions on the triangle (continuation), the straight-line guess, then
/// the `seeds²` sub-triangle centroids.
/// Converges like O(1/samples) (each triangle's contribution jumps at its support's ends).
pub fn single_scatter_brute_force(
    mesh: &RefractiveMesh,
    medium: &Medium,
    entry: DVec3,
    exit: DVec3,
    light: DVec3,
    intensity: f64,
    options: &BruteForceOptions,
) -> Result<ScatterResult> {
    validate(mesh, medium, entry, exit, light, intensity)?;
    if options.samples == 0 {
        return Err(Error::InvalidArgument("samples must be >= 1".into()));
    }
    let mut stats = ScatterStats {
        segments: 1,
        ..Default::default()
    };
    let Some(eye) = EyeSegment::new(entry, exit) else {
        return Ok(ScatterResult {
            radiance: 0.0,
            stats,
        });
    };
    let seeds = subdivision_seeds(options.seeds);
    let dx = eye.length / options.samples as f64;
    let mut total = 0.0;
    for (ti, tri) in mesh.triangles().iter().enumerate() {
        let own = mesh.triangle_ownership(ti);
        stats.triangles_visited += 1;
        let c = Constraint {
            tri,
            eye: &eye,
            light,
            eta: medium.eta,
        };
        let mut contributed = false;
        let mut previous: SmallVec<[DVec2; 2]> = SmallVec::new();
        for k in 0..options.samples {
            let x = (k as f64 + 0.5) * dx;
            stats.samples += 1;
            // Continuation: the solutions at the previous sample come first, then the fixed seeds.
            let mut all_seeds: Vec<DVec2> = previous.to_vec();
            all_seeds.extend(seeds_at(&c, x));
            all_seeds.extend_from_slice(&seeds);
            previous = owned_solutions_at(
                &c,
                x,
                &all_seeds,
                true,
                own,
                &options.newton,
                &mut stats.interior,
            );
            for &ab in &previous {
                if let Some(p) = path_contribution(
                    tri,
                    ab,
                    &eye,
                    x,
                    light,
                    intensity,
                    medium,
                    options.distance_factor,
                ) {
                    total += p.value * dx;
                    stats.paths += 1;
                    contributed = true;
                }
            }
        }
        if contributed {
            stats.triangles_contributing += 1;
        }
    }
    Ok(ScatterResult {
        radiance: total,
        stats,
    })
}

/// The straight-line approximation (Jensen et al. 2001) the report compares against: light reaches
/// V along the straight line L → V, attenuated from where that line enters the mesh (the last
/// surface hit before V) and weighted by the Fresnel transmittance there; D = |LV|². Integrated with
/// `samples` midpoint points. Rays whose straight line does not cross the mesh contribute nothing.
#[allow(clippy::too_many_arguments)]
pub fn straight_line_single_scatter(
    mesh: &RefractiveMesh,
    medium: &Medium,
    entry: DVec3,
    exit: DVec3,
    light: DVec3,
    intensity: f64,
    samples: usize,
) -> Result<f64> {
    validate(mesh, medium, entry, exit, light, intensity)?;
    let Some(eye) = EyeSegment::new(entry, exit) else {
        return Ok(0.0);
    };
    let samples = samples.max(1);
    let dx = eye.length / samples as f64;
    let mut total = 0.0;
    for k in 0..samples {
        let x = (k as f64 + 0.5) * dx;
        let v = eye.at(x);
        let to_light = light - v;
        let dist = to_light.length();
        let Some(dir) = to_light.try_normalize() else {
            continue;
        };
        let Some(hit) = mesh.closest_hit(v, dir, 0.0, dist) else {
            continue;
        };
        let tri = mesh.triangle(hit.triangle as usize);
        let cos_i = dir.dot(tri.geometric_normal).abs();
        let t = super::contribution::fresnel_transmittance(cos_i, medium.eta);
        let phase = super::contribution::henyey_greenstein(dir.dot(eye.dir), medium.g);
        let att = (-medium.sigma_t * (x + hit.t)).exp();
        total += medium.sigma_s * phase * intensity * t * att / (dist * dist) * dx;
    }
    Ok(total)
}
