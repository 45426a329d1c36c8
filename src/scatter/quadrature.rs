//! Adaptive Gauss-Kronrod (7-15) quadrature with an error estimate, for one support piece.
//!
//! The 15-point Kronrod rule reuses the 7 Gauss-Legendre nodes; |K15 − G7| estimates the error of
//! K15 (pessimistically: K15 is exact to degree 22, G7 to degree 13). The interval with the largest
//! estimate is bisected until the summed estimate is within the tolerance. The Kronrod nodes avoid
//! the interval ends, so an integrable endpoint singularity is never evaluated; bisection resolves
//! steep but bounded integrands (a light close to the surface, grazing refraction).

use smallvec::SmallVec;

/// Kronrod nodes in (0, 1], descending; the odd entries (1, 3, 5) and 0 are the 7 Gauss nodes.
const NODES: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
/// Kronrod weights of [`NODES`].
const KRONROD: [f64; 8] = [
    0.022_935_322_010_529_225,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_18,
    0.140_653_259_715_525_92,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_83,
];
/// Gauss weights of the nodes 1, 3, 5 and 7 of [`NODES`].
const GAUSS: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// The 15 nodes of the rule on [a, b], ascending.
pub fn nodes(a: f64, b: f64) -> [f64; 15] {
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    let mut out = [0.0; 15];
    for k in 0..8 {
        out[k] = c - h * NODES[k];
        out[14 - k] = c + h * NODES[k];
    }
    out
}

/// (K15, |K15 − G7|) on [a, b] from the integrand's values at [`nodes`]`(a, b)`.
pub fn rule(a: f64, b: f64, values: &[f64; 15]) -> (f64, f64) {
    let h = 0.5 * (b - a);
    let (mut k, mut g) = (0.0, 0.0);
    for i in 0..8 {
        let pair = if i == 7 {
            values[7]
        } else {
            values[i] + values[14 - i]
        };
        k += KRONROD[i] * pair;
        if i % 2 == 1 {
            g += GAUSS[i / 2] * pair;
        }
    }
    (h * k, (h * (k - g)).abs())
}

/// Settings of the adaptive integration of one piece.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adaptive {
    /// Relative tolerance on the piece's integral.
    pub relative: f64,
    /// Absolute tolerance (units of the integral): pieces far smaller than the whole segment's
    /// result need no relative accuracy.
    pub absolute: f64,
    /// Maximum number of sub-intervals (each costs 15 evaluations).
    pub max_intervals: usize,
}

/// ∫ₐᵇ f by adaptive bisection; returns (estimate, error estimate, intervals used). `f` receives
/// the 15 nodes of one interval (ascending) and fills their values, so that the caller can seed each
/// evaluation from the previous one. Stops when the summed error estimate is at most
/// max(relative |estimate|, absolute), or at `max_intervals` (the error estimate then says so).
pub fn integrate(
    a: f64,
    b: f64,
    settings: &Adaptive,
    mut f: impl FnMut(&[f64; 15], &mut [f64; 15]),
) -> (f64, f64, usize) {
    let mut eval = |a: f64, b: f64| {
        let xs = nodes(a, b);
        let mut v = [0.0; 15];
        f(&xs, &mut v);
        let (i, e) = rule(a, b, &v);
        (a, b, i, e)
    };
    let mut parts: SmallVec<[(f64, f64, f64, f64); 16]> = smallvec::smallvec![eval(a, b)];
    loop {
        let total: f64 = parts.iter().map(|p| p.2).sum();
        let error: f64 = parts.iter().map(|p| p.3).sum();
        let allowed = (settings.relative * total.abs()).max(settings.absolute);
        if !(error > allowed) || parts.len() >= settings.max_intervals {
            return (total, error, parts.len());
        }
        let worst = (0..parts.len())
            .max_by(|&i, &j| parts[i].3.total_cmp(&parts[j].3))
            .unwrap_or(0);
        let (lo, hi, _, _) = parts[worst];
        let mid = 0.5 * (lo + hi);
        if !(mid > lo && mid < hi) {
            // The interval cannot be split further in double precision.
            return (total, error, parts.len());
        }
        parts[worst] = eval(lo, mid);
        parts.push(eval(mid, hi));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_are_exact_to_their_degree() {
        // K15 is exact for degree 22 (and G7 for 13): a wrong constant breaks one of these.
        for degree in 0..=22 {
            let f = |x: f64| x.powi(degree);
            let xs = nodes(-0.3, 1.7);
            let mut v = [0.0; 15];
            for (y, &x) in v.iter_mut().zip(&xs) {
                *y = f(x);
            }
            let exact =
                (1.7f64.powi(degree + 1) - (-0.3f64).powi(degree + 1)) / (degree + 1) as f64;
            let (k, e) = rule(-0.3, 1.7, &v);
            assert!(
                (k - exact).abs() < 1e-13 * exact.abs().max(1.0),
                "degree {degree}"
            );
            if degree <= 13 {
                assert!(e < 1e-12 * exact.abs().max(1.0), "degree {degree}: {e}");
            }
        }
    }

    #[test]
    fn bisection_resolves_a_near_singular_peak() {
        // ∫₀¹ h/(h² + (x − 0.3)²) dx with h = 1e-6: a peak of width 1e-6.
        let h = 1e-6;
        let exact = ((0.7f64) / h).atan() + (0.3f64 / h).atan();
        let s = Adaptive {
            relative: 1e-10,
            absolute: 0.0,
            max_intervals: 400,
        };
        let (got, err, n) = integrate(0.0, 1.0, &s, |xs, v| {
            for (y, &x) in v.iter_mut().zip(xs) {
                *y = h / (h * h + (x - 0.3) * (x - 0.3));
            }
        });
        assert!(
            (got - exact).abs() < 1e-9 * exact,
            "{got} vs {exact} ({err}, {n})"
        );
    }
}
