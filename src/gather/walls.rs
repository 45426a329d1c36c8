//! Exact wall integrals of the polar and sphere layouts, for the Ward-Heckbert gradient.
//!
//! Model: each stratum shows one piece of the scene with constant radiance. Translating x by δ
//! moves a scene point at distance r in direction ω by `dω = −(δ − (δ·ω)ω)/r` on the unit sphere,
//! so a wall between strata a and b drifts, and a gains `∫_wall w(ω) (δ·ν_a)/r dl` of weighted solid
//! angle (ν_a: the wall's unit normal pointing into a; w = cosθ for irradiance, 1 for fluence).
//! Ward and Heckbert let the wall move with the closer of the two hits. The gradient is then
//! `Σ_walls (L_a − L_b)/min(r_a, r_b) · W`, with `W = ∫_wall w ν_a dl` a vector depending on the
//! layout only. For θ/φ walls it has a closed form:
//!
//! * ring wall at `θ_j` between rings j−1 and j, column k (a = ring j, ν_a = e_θ):
//!   `W = w(θ_j) sinθ_j (cosθ_j (sinφ_{k+1} − sinφ_k), cosθ_j (cosφ_k − cosφ_{k+1}), −sinθ_j Δφ)`;
//! * azimuth wall at `φ_k` between columns k−1 and k, ring j (a = column k, ν_a = e_φ):
//!   `W = (−sinφ_k, cosφ_k, 0) ∫_{θ_j}^{θ_{j+1}} w(θ) dθ`.
//!
//! These are the exact integrals of Jarosz et al. 2008 eq. (12)-(13) (which approximate them with
//! centre values; the thesis' eq. 3.41-3.42 misprint the azimuthal wall's neighbour and sign: the wall between
//! (j, k) and (j, k−1) moves with the closer of those two, as in Jarosz et al. eq. 13) extended to all three
//! axes: the normal component follows from the same wall motion.

use std::f64::consts::TAU;

use std::cell::RefCell;
use std::rc::Rc;
use std::sync::{Arc, Mutex};

use glam::{DVec2, DVec3};
use smallvec::SmallVec;

use super::layout::{Layout, LayoutKind};

/// Per-ring and per-column wall data of a polar or sphere layout (local frame).
pub(crate) struct Walls {
    /// Per column k: `(cos φ_k, sin φ_k)` of its lower azimuth wall.
    pub(crate) phi_wall: Vec<(f64, f64)>,
    /// Per column k: `(sinφ_{k+1} − sinφ_k, cosφ_k − cosφ_{k+1})` = `∫ (cosφ, sinφ) dφ` over the column.
    pub(crate) column: Vec<(f64, f64)>,
    /// Per ring wall j (index j, used for j ≥ 1): `(w sinθ cosθ, −w sin²θ Δφ)` at `θ_j`.
    pub(crate) ring_wall: Vec<(f64, f64)>,
    /// Per ring j: `∫_{θ_j}^{θ_{j+1}} w(θ) dθ`.
    pub(crate) ring_span: Vec<f64>,
    /// Per ring j: `∫_{θ_j}^{θ_{j+1}} sin²θ dθ` (rotational gradient of the cosine-polar layout).
    pub(crate) ring_sin2: Vec<f64>,
}

impl Walls {
    /// Wall data for a [`LayoutKind::CosinePolar`] or [`LayoutKind::Sphere`] layout.
    pub(crate) fn new(layout: &Layout) -> Walls {
        debug_assert!(layout.kind != LayoutKind::Concentric);
        let (m, n) = (layout.m as usize, layout.n as usize);
        let d_phi = TAU / n as f64;
        let phi_wall: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let (s, c) = (d_phi * k as f64).sin_cos();
                (c, s)
            })
            .collect();
        let column = (0..n)
            .map(|k| {
                let (c0, s0) = phi_wall[k];
                let (c1, s1) = phi_wall[(k + 1) % n];
                (s1 - s0, c0 - c1)
            })
            .collect();
        // (sin θ_j, cos θ_j) at the ring boundaries j = 0..=M.
        let bound: Vec<(f64, f64)> = (0..=m)
            .map(|j| {
                let f = j as f64 / m as f64;
                match layout.kind {
                    LayoutKind::Sphere => {
                        let c = 1.0 - 2.0 * f;
                        (((1.0 - c) * (1.0 + c)).max(0.0).sqrt(), c)
                    }
                    _ => (f.sqrt(), (1.0 - f).max(0.0).sqrt()),
                }
            })
            .collect();
        let sphere = layout.kind == LayoutKind::Sphere;
        let weight = |c: f64| if sphere { 1.0 } else { c };
        let ring_wall = bound
            .iter()
            .map(|&(s, c)| (weight(c) * s * c, -weight(c) * s * s * d_phi))
            .collect();
        let theta = |(s, c): (f64, f64)| s.atan2(c);
        let ring_span = (0..m)
            .map(|j| {
                if sphere {
                    theta(bound[j + 1]) - theta(bound[j])
                } else {
                    bound[j + 1].0 - bound[j].0
                }
            })
            .collect();
        // ∫ sin²θ dθ = (θ − sinθ cosθ)/2
        let g = |b: (f64, f64)| 0.5 * (theta(b) - b.0 * b.1);
        let ring_sin2 = (0..m).map(|j| g(bound[j + 1]) - g(bound[j])).collect();
        Walls {
            phi_wall,
            column,
            ring_wall,
            ring_span,
            ring_sin2,
        }
    }
}

/// Everything about a layout's walls that the validation and the evaluation need and that depends
/// on (kind, M, N) only: computed once per thread and layout instead of per call (it costs M + N
/// transcendental calls, a few ns per sample of a 4096-ray gather).
pub(crate) struct LayoutTables {
    /// Wall data for the evaluation ([`Walls`]); `None` for the concentric layout.
    pub(crate) walls: Option<Walls>,
    /// `(cos φ_k, sin φ_k)`, k = 0..=N, for the direction check (see
    /// [`azimuth_bounds`]).
    pub(crate) azimuth_bounds: Vec<(f64, f64)>,
    /// The concentric layout's column walls on the square, k = 0..=N (see
    /// [`column_bounds`]).
    pub(crate) column_bounds: Vec<f64>,
}

/// `(kind, M, N)` and the tables of that layout.
type TablesEntry = (LayoutKind, u32, u32, Rc<LayoutTables>);

thread_local! {
    /// Recently used layouts' tables on this thread (a renderer gathers with one or two layouts).
    static LAYOUT_TABLES: RefCell<Vec<TablesEntry>> =
        const { RefCell::new(Vec::new()) };
}
const LAYOUT_TABLES_CACHE_SIZE: usize = 4;

impl LayoutTables {
    /// The tables of `layout` (the seed does not matter), from this thread's small cache.
    pub(crate) fn cached(layout: &Layout) -> Rc<LayoutTables> {
        let key = (layout.kind, layout.m, layout.n);
        LAYOUT_TABLES.with(|cache| {
            let mut cache = cache.borrow_mut();
            if let Some(hit) = cache.iter().find(|e| (e.0, e.1, e.2) == key) {
                return Rc::clone(&hit.3);
            }
            let tables = Rc::new(LayoutTables {
                walls: (layout.kind != LayoutKind::Concentric).then(|| Walls::new(layout)),
                azimuth_bounds: azimuth_bounds(layout),
                column_bounds: column_bounds(layout),
            });
            if cache.len() >= LAYOUT_TABLES_CACHE_SIZE {
                cache.remove(0);
            }
            cache.push((key.0, key.1, key.2, Rc::clone(&tables)));
            tables
        })
    }
}

/// Wall vectors `∫_wall w ν dl` (w = cosθ) of the concentric layout, whose walls are the images of
/// the grid lines of `[−1, 1]²` under the Shirley-Chiu map, lifted to the hemisphere.
///
/// For a wall traced as `ω(t)` with `t ∈ [0, 1]` along its grid line, `ν dl = ∓(ω × ω') dt` (the
/// sign picks the side). With `ω = (d, z)`, `z = sqrt(1 − |d|²)` and `z' = −(d·d')/z`, the integrand
/// `z (ω × ω')` is `(−(d_y (d·d') + z² d_y'), z² d_x' + d_x (d·d'), z (d × d'))`: bounded up to the
/// horizon. The map is smooth inside each of its four wedges and only continuous across the
/// diagonals `|a| = |b|`, so each wall is split there and integrated by 4-point Gauss-Legendre
/// per piece.
pub(crate) struct ConcentricWalls {
    /// Walls between `(j−1, k)` and `(j, k)`, index `(j−1)·N + k`, pointing into `(j, k)`, by
    /// component (x, y, z arrays), for contiguous per-row loops.
    pub(crate) first_by_axis: [Vec<f64>; 3],
    /// Walls between `(j, k−1)` and `(j, k)`, index `j·(N−1) + k − 1`, pointing into `(j, k)`, by
    /// component.
    pub(crate) second_by_axis: [Vec<f64>; 3],
}

/// The x, y and z components of `v` as three arrays.
fn by_axis(v: &[DVec3]) -> [Vec<f64>; 3] {
    [
        v.iter().map(|w| w.x).collect(),
        v.iter().map(|w| w.y).collect(),
        v.iter().map(|w| w.z).collect(),
    ]
}

/// Recently used concentric wall sets, keyed by (M, N): they depend on the grid only, and a
/// renderer gathers with the same layout again and again.
static CONCENTRIC_CACHE: Mutex<Vec<(u32, u32, Arc<ConcentricWalls>)>> = Mutex::new(Vec::new());
const CONCENTRIC_CACHE_SIZE: usize = 4;

impl ConcentricWalls {
    /// The wall set of an M×N concentric grid, from a small process-wide cache (computed on a miss).
    pub(crate) fn cached(layout: &Layout) -> Arc<ConcentricWalls> {
        let key = (layout.m, layout.n);
        let lock = || CONCENTRIC_CACHE.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(hit) = lock().iter().find(|e| (e.0, e.1) == key) {
            return Arc::clone(&hit.2);
        }
        let walls = Arc::new(ConcentricWalls::new(layout));
        let mut cache = lock();
        if cache.len() >= CONCENTRIC_CACHE_SIZE {
            cache.remove(0);
        }
        cache.push((key.0, key.1, Arc::clone(&walls)));
        walls
    }

    pub(crate) fn new(layout: &Layout) -> ConcentricWalls {
        let (m, n) = (layout.m as usize, layout.n as usize);
        let sa = |j: usize| 2.0 * j as f64 / m as f64 - 1.0;
        let sb = |k: usize| 2.0 * k as f64 / n as f64 - 1.0;
        let mut first_axis = Vec::with_capacity((m - 1) * n);
        for j in 1..m {
            for k in 0..n {
                // Travelling towards +b, the cell with the larger a lies on the right.
                let s0 = DVec2::new(sa(j), sb(k));
                let s1 = DVec2::new(sa(j), sb(k + 1));
                first_axis.push(-grid_line_integral(s0, s1));
            }
        }
        let mut second_axis = Vec::with_capacity(m * (n - 1));
        for j in 0..m {
            for k in 1..n {
                // Travelling towards +a, the cell with the larger b lies on the left.
                let s0 = DVec2::new(sa(j), sb(k));
                let s1 = DVec2::new(sa(j + 1), sb(k));
                second_axis.push(grid_line_integral(s0, s1));
            }
        }
        ConcentricWalls {
            first_by_axis: by_axis(&first_axis),
            second_by_axis: by_axis(&second_axis),
        }
    }
}

/// `∫ z (ω × ω') dt` along the image of the axis-aligned segment `s0 → s1` of the square.
fn grid_line_integral(s0: DVec2, s1: DVec2) -> DVec3 {
    let delta = s1 - s0;
    // Split where the segment crosses a diagonal |a| = |b| (a kink of the concentric map).
    let mut cuts: SmallVec<[f64; 4]> = SmallVec::new();
    cuts.push(0.0);
    let (fixed, moving0, moving_len) = if delta.x == 0.0 {
        (s0.x, s0.y, delta.y)
    } else {
        (s0.y, s0.x, delta.x)
    };
    for target in [fixed.abs(), -fixed.abs()] {
        let t = (target - moving0) / moving_len;
        if t > 0.0 && t < 1.0 && !cuts.contains(&t) {
            cuts.push(t);
        }
    }
    cuts.push(1.0);
    cuts.sort_by(f64::total_cmp);
    const X: [f64; 2] = [0.339_981_043_584_856, 0.861_136_311_594_053];
    const W: [f64; 2] = [0.652_145_154_862_546, 0.347_854_845_137_454];
    let on_horizon = |t: f64| {
        let p = s0 + delta * t;
        p.x.abs().max(p.y.abs()) >= 1.0 - 1e-12
    };
    let mut sum = DVec3::ZERO;
    for piece in cuts.windows(2) {
        let (t0, t1) = (piece[0], piece[1]);
        // z ~ sqrt(distance to the horizon) at a horizon end: substitute t = end ∓ len·u² there,
        // which makes the integrand smooth again.
        let end = if on_horizon(t1) {
            Some((t1, -1.0))
        } else if on_horizon(t0) {
            Some((t0, 1.0))
        } else {
            None
        };
        for (x, w) in X.iter().zip(W) {
            for u in [0.5 - 0.5 * x, 0.5 + 0.5 * x] {
                let (t, jac) = match end {
                    Some((e, sign)) => {
                        let len = t1 - t0;
                        (e + sign * len * u * u, 2.0 * len * u)
                    }
                    None => (t0 + (t1 - t0) * u, t1 - t0),
                };
                sum += integrand(s0 + delta * t, delta) * (0.5 * w * jac);
            }
        }
    }
    sum
}

/// `z (ω × ω')` at square point `s` for the velocity `ds/dt = v`.
fn integrand(s: DVec2, v: DVec2) -> DVec3 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    let (a, b) = (s.x, s.y);
    // d and its derivatives ∂d/∂a, ∂d/∂b inside the wedge that contains s.
    let (d, da, db) = if a.abs() > b.abs() {
        let (sp, cp) = (FRAC_PI_4 * (b / a)).sin_cos();
        let radial = DVec2::new(cp, sp);
        let tangential = DVec2::new(-sp, cp);
        (
            radial * a,
            radial - tangential * (FRAC_PI_4 * b / a),
            tangential * FRAC_PI_4,
        )
    } else if b != 0.0 {
        let (sp, cp) = (FRAC_PI_2 - FRAC_PI_4 * (a / b)).sin_cos();
        let radial = DVec2::new(cp, sp);
        let tangential = DVec2::new(-sp, cp);
        (
            radial * b,
            -tangential * FRAC_PI_4,
            radial + tangential * (FRAC_PI_4 * a / b),
        )
    } else {
        // The centre: never a quadrature node (nodes are interior to each piece).
        return DVec3::ZERO;
    };
    let dd = da * v.x + db * v.y;
    let z2 = (1.0 - d.length_squared()).max(0.0);
    let dot = d.dot(dd);
    DVec3::new(
        -(d.y * dot + z2 * dd.y),
        z2 * dd.x + d.x * dot,
        z2.sqrt() * d.perp_dot(dd),
    )
}

/// `(cos φ_k, sin φ_k)` of the azimuth walls `φ_k = 2πk/N`, k = 0..=N (the last one is the
/// first), as the direction check uses them; empty for the concentric layout and N = 1.
pub(crate) fn azimuth_bounds(layout: &Layout) -> Vec<(f64, f64)> {
    let n = layout.n as usize;
    if layout.kind == LayoutKind::Concentric || n < 2 {
        return Vec::new();
    }
    (0..=n)
        .map(|k| {
            let (s, c) = (TAU * (k % n) as f64 / n as f64).sin_cos();
            (c, s)
        })
        .collect()
}

/// The concentric layout's column walls `b_k = 2k/N − 1`, k = 0..=N, on the square `[−1, 1]²`;
/// empty for the other layouts.
pub(crate) fn column_bounds(layout: &Layout) -> Vec<f64> {
    if layout.kind != LayoutKind::Concentric {
        return Vec::new();
    }
    let n = layout.n as f64;
    (0..=layout.n).map(|k| 2.0 * k as f64 / n - 1.0).collect()
}

#[cfg(test)]
pub(crate) mod tests;
