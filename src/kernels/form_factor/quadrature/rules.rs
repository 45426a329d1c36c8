//! Gauss-Legendre rules, and the far-field rule chosen by distance over radius with its a-priori
//! error bound.

use std::sync::OnceLock;

use glam::DVec3;

/// Distance (from the vertex centroid) over radius above which the form factor is integrated by
/// quadrature instead of the edge sum. Chosen by measurement (see `tests/form_factor_accuracy.rs`): at
/// 16 the edge sum has lost ~16 ulps to cancellation and the 8x8 Gauss rule is at its rounding floor.
pub(crate) const FAR_FIELD_RATIO: f64 = 16.0;

/// The far-field rules: from this distance-over-radius ratio on, `n`x`n` Gauss-Legendre points per
/// fan triangle (largest ratio first). Above 16 the ratios come from the a-priori bound of
/// `far_field_error_bound` (unit tests): at each listed ratio (and beyond) that bound on the
/// relative error is at most 1e-14 for the value and the gradient and 1e-12 for the Hessian (a
/// factor 100 below the generic accuracy contract; the bound itself ignores that Gauss rules
/// converge faster than polynomial exactness alone implies, and overestimates the measured errors
/// by orders of magnitude). Between 16 and 31 radii the 8x8 rule is kept on measurement: there its
/// bound is above 1e-14 (see the unit test) but its measured error is at the rounding floor.
pub(crate) const FAR_FIELD_RULES: [(f64, usize); 5] = [
    (3.6e4, 3),
    (1.5e3, 4),
    (280.0, 5),
    (100.0, 6),
    (FAR_FIELD_RATIO, 8),
];

/// The second of [`fast_decisions`](crate::kernels::form_factor::replay::fast_decisions): the
/// far-field rule of the unclipped polygon, if any.
#[inline]
pub(crate) fn far_rule_of(r: &[DVec3]) -> Option<Rule> {
    let count = r.len() as f64;
    let centroid = r.iter().sum::<DVec3>() / count;
    let radius = r
        .iter()
        .map(|v| (*v - centroid).length_squared())
        .fold(0.0, f64::max)
        .sqrt();
    far_field_rule(centroid.length(), radius)
}

/// Gauss-Legendre nodes and weights on [0, 1] (Newton on the Legendre polynomial).
pub(crate) fn legendre_rule<const N: usize>() -> [(f64, f64); N] {
    let mut rule = [(0.0, 0.0); N];
    for (i, slot) in rule.iter_mut().enumerate() {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (N as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=N {
                let kf = k as f64;
                let p2 = ((2.0 * kf - 1.0) * z * p1 - (kf - 1.0) * p0) / kf;
                p0 = p1;
                p1 = p2;
            }
            dp = N as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-17 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - z * z) * dp * dp);
        *slot = (0.5 * (1.0 - z), 0.5 * w);
    }
    rule
}

/// The `N`-point Gauss-Legendre rule on [0, 1], computed once.
macro_rules! cached_rule {
    ($name:ident, $n:literal) => {
        pub(crate) fn $name() -> &'static [(f64, f64)] {
            static RULE: OnceLock<[(f64, f64); $n]> = OnceLock::new();
            RULE.get_or_init(legendre_rule::<$n>)
        }
    };
}
cached_rule!(gauss_legendre_2, 2);
cached_rule!(gauss_legendre_3, 3);
cached_rule!(gauss_legendre_4, 4);
cached_rule!(gauss_legendre_5, 5);
cached_rule!(gauss_legendre_6, 6);
cached_rule!(gauss_legendre_8, 8);

/// A far-field quadrature rule: Gauss-Legendre nodes and weights on [0, 1], used in both directions
/// of the Duffy-mapped fan triangle.
#[derive(Clone, Copy)]
pub(crate) struct Rule(pub(crate) &'static [(f64, f64)]);

impl Rule {
    /// The smallest distance-over-radius ratio at which [`far_field_rule`] returns this rule.
    pub(crate) fn min_ratio(self) -> f64 {
        FAR_FIELD_RULES
            .iter()
            .find(|(_, points)| *points == self.0.len())
            .map_or(FAR_FIELD_RATIO, |r| r.0)
    }
}

/// The rule for a (visible) polygon whose vertex centroid is `distance` from x and whose vertices
/// are within `radius` of that centroid: the cheapest of [`FAR_FIELD_RULES`] whose ratio
/// `distance / radius` reaches; `None` below [`FAR_FIELD_RATIO`] (the edge sum applies).
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // negated so that NaN fails every check
pub(crate) fn far_field_rule(distance: f64, radius: f64) -> Option<Rule> {
    if !(distance >= FAR_FIELD_RATIO * radius) {
        return None;
    }
    let points = FAR_FIELD_RULES
        .iter()
        .find(|(ratio, _)| distance >= ratio * radius)
        .map_or(8, |r| r.1);
    Some(Rule(match points {
        3 => gauss_legendre_3(),
        4 => gauss_legendre_4(),
        5 => gauss_legendre_5(),
        6 => gauss_legendre_6(),
        _ => gauss_legendre_8(),
    }))
}

pub(crate) fn gauss_legendre_16() -> &'static [(f64, f64); 16] {
    static RULE: OnceLock<[(f64, f64); 16]> = OnceLock::new();
    RULE.get_or_init(legendre_rule::<16>)
}

#[cfg(test)]
mod tests;
