//! The settings of the single-scattering integral, below the integration and its fold handling,
//! which both read them.

use super::contribution::DistanceFactor;
use super::newton::NewtonSettings;

/// Settings of [`single_scatter`](super::integrate::single_scatter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScatterOptions {
    /// Relative tolerance of the adaptive Gauss-Kronrod (7-15) integral of each support piece, on
    /// the piece's own estimated error |K15 − G7| (pessimistic: the K15 result is usually far more
    /// accurate). In (0, 1); default 1e-10.
    pub tolerance: f64,
    /// Most sub-intervals (15 evaluations each) per support piece; ≥ 1, default 100. Bisection
    /// concentrates them where the integrand is steep (a light near the surface, grazing rays).
    pub max_subintervals: usize,
    /// Apply the sidedness test to triangles (also clips the x range to where V is below the plane).
    pub sidedness_test: bool,
    /// Apply the spindle test to hierarchy nodes and triangles.
    pub spindle_test: bool,
    /// Apply the shading-normal cone test to triangles (also narrows the x range searched).
    pub normal_cone_test: bool,
    /// Which D factor to use.
    pub distance_factor: DistanceFactor,
    /// Newton caps and tolerances.
    pub newton: NewtonSettings,
}

impl Default for ScatterOptions {
    fn default() -> Self {
        ScatterOptions {
            tolerance: 1e-10,
            max_subintervals: 100,
            sidedness_test: true,
            spindle_test: true,
            normal_cone_test: true,
            distance_factor: DistanceFactor::Interpolated,
            newton: NewtonSettings::default(),
        }
    }
}
